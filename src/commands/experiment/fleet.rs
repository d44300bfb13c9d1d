//! `firefleet experiment fleet`: the shipped multi-fire scenarios under three strategies
//! side by side: every unit running its tree alone with no coordinator, greedy
//! nearest-free-unit assignment, and the coordinator's optimal assignment.
//!
//! A fourth row per scenario, `bound`, is not a strategy: the optimal coordinator told
//! where every fire is at t = 0, as if the tunnel's own fire detection had located them
//! all. The fleet still drives there and fights them, so its time to all-out is what no
//! coordination of these units can beat with their sensors alone: how much of the
//! uncoordinated fleet's time is finding fires rather than choosing who fights them.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::MonorailController;
use firefleet_coordinator::Incident;
use firefleet_coordinator::assign::Strategy;
use firefleet_coordinator::incident::Output;
use firefleet_protocol::FireId;
use firefleet_protocol::UnitId;
use firefleet_protocol::msg::{FireState, FireTrack, FlameReport, TaskKind, UnitKind, UnitState};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::{GROUND, MONORAIL};
use firefleet_sim::World;
use serde::Serialize;

use crate::commands::write_json;

#[derive(Args, Debug)]
pub struct FleetArgs {
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Runs per scenario and strategy (seeds seed, seed+1, ...).
    #[arg(long, default_value_t = 3)]
    trials: u32,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// The multi-fire scenarios the fleet experiment runs.
const FLEET_SCENARIOS: [&str; 3] = ["cargo-truck", "pileup", "rail-tunnel"];

/// One unit's control loop, whichever kind it is.
enum Fleet {
    Ground(GroundController),
    Rail(MonorailController),
}

impl Fleet {
    /// One control step on the unit's simulated body.
    fn step(&mut self, id: &UnitId, world: &mut World) -> anyhow::Result<()> {
        match self {
            Self::Ground(c) => {
                let sensors = world.sensors(id).context("unit exists")?;
                world.command(id, c.step(&sensors));
            }
            Self::Rail(c) => {
                let sensors = world.rail_sensors(id).context("unit exists")?;
                world.command_rail(id, c.step(&sensors));
            }
        }
        Ok(())
    }

    fn on_task(&mut self, seq: u64, kind: TaskKind) {
        match self {
            Self::Ground(c) => c.on_task(seq, kind),
            Self::Rail(c) => c.on_task(seq, kind),
        }
    }

    fn set_coordinator_present(&mut self, present: bool) {
        match self {
            Self::Ground(c) => c.set_coordinator_present(present),
            Self::Rail(c) => c.set_coordinator_present(present),
        }
    }

    fn state(&self) -> UnitState {
        match self {
            Self::Ground(c) => c.state(),
            Self::Rail(c) => c.state(),
        }
    }

    fn report(&mut self) -> Option<FlameReport> {
        match self {
            Self::Ground(c) => c.report(),
            Self::Rail(c) => c.report(),
        }
    }
}

#[derive(Serialize)]
struct FleetRun {
    strategy: &'static str,
    scenario: String,
    trials: u32,
    /// Mean over trials; a trial that did not finish counts at the time limit.
    time_all_out_s: f64,
    unfinished: u32,
    heat_dose: f64,
    water_l: f64,
    fires_never_attacked: f64,
}

#[derive(Serialize)]
struct FleetResults {
    seed: u64,
    strategies: Vec<FleetRun>,
    /// The `bound` rows: the optimal coordinator told every fire at t = 0.
    bounds: Vec<FleetRun>,
}

/// Who decides what the units do in a run.
#[derive(Debug, Clone, Copy)]
enum Command {
    /// No coordinator: every unit runs its tree alone.
    Alone,
    /// A coordinator with this strategy, which learns of fires from the units' reports.
    Coordinator(Strategy),
    /// The optimal coordinator, told every fire at t = 0: the bound.
    Told,
}

/// The rows of the table: label, command.
const ROWS: [(&str, Command); 4] = [
    ("autonomous", Command::Alone),
    ("greedy", Command::Coordinator(Strategy::Greedy)),
    ("optimal", Command::Coordinator(Strategy::Optimal)),
    ("bound", Command::Told),
];

/// Every fire of `scenario` as a confirmed track, as a coordinator would recall it.
fn known_fires(scenario: &Scenario) -> Vec<FireTrack> {
    (1..)
        .zip(&scenario.fires)
        .map(|(id, f)| FireTrack {
            id: FireId(id),
            t: 0.0,
            position: f.position(),
            cov: [0.25, 0.0, 0.25],
            confidence: 1.0,
            state: FireState::Confirmed,
            assigned: Vec::new(),
            seen_by: Vec::new(),
            hrr_kw: None,
        })
        .collect()
}

/// One run of `scenario` with the units' trees under `command` (the coordinator's
/// incident logic, when there is one, stepped together with them in-process: the same
/// code as the processes of a demo, without the bus): time all out (or `None`), heat dose
/// (kJ/m^2, summed over units), water used (L), fires that got no water.
fn fleet_run(
    scenario: &Scenario,
    command: Command,
    seed: u64,
) -> anyhow::Result<(Option<f64>, f64, f64, usize)> {
    let shared = Arc::new(scenario.clone());
    let mut world = World::new(scenario, seed);
    let monorail = firefleet_agent::monorail::default_tree();
    let mut units: Vec<(UnitId, Fleet)> = scenario
        .units
        .iter()
        .map(|u| {
            let ctl = match u.kind {
                UnitKind::Ground => {
                    Fleet::Ground(GroundController::new(u.id.clone(), GROUND, shared.clone()))
                }
                UnitKind::Monorail => Fleet::Rail(
                    MonorailController::with_tree(
                        u.id.clone(),
                        MONORAIL,
                        shared.clone(),
                        &monorail,
                    )?
                    .with_context(|| format!("monorail unit {} has no rail", u.id))?,
                ),
            };
            Ok((u.id.clone(), ctl))
        })
        .collect::<anyhow::Result<_>>()?;
    let mut incident = match command {
        Command::Alone => None,
        Command::Coordinator(s) => Some(Incident::from_scenario(scenario, 5.0, s)),
        Command::Told => {
            let mut inc = Incident::from_scenario(scenario, 5.0, Strategy::Optimal);
            let (_, refused) = inc.restore(&known_fires(scenario), 0.0);
            anyhow::ensure!(refused.is_empty(), "fires refused: {refused:?}");
            Some(inc)
        }
    };
    let deliver = |outputs: Vec<Output>, units: &mut [(UnitId, Fleet)]| {
        for o in outputs {
            if let Output::Task(task) = o
                && let Some((_, ctl)) = units.iter_mut().find(|(id, _)| *id == task.unit)
            {
                ctl.on_task(task.seq, task.kind);
            }
        }
    };
    if let Some(inc) = &mut incident {
        for (id, ctl) in &mut units {
            ctl.set_coordinator_present(true);
            inc.on_alive(id, true, 0.0).map_err(anyhow::Error::msg)?;
        }
    }
    let (dt, report_every) = (0.05, 5);
    let mut step = 0u64;
    while world.time() < scenario.time_limit_s {
        for (id, ctl) in &mut units {
            ctl.step(id, &mut world)?;
        }
        if let Some(inc) = &mut incident
            && step.is_multiple_of(report_every)
        {
            let t = world.time();
            let mut outputs = inc.tick(t);
            for (_, ctl) in &mut units {
                outputs.extend(inc.on_state(ctl.state(), t).unwrap_or_default());
                if let Some(r) = ctl.report() {
                    outputs.extend(inc.on_report(&r, t).unwrap_or_default());
                }
            }
            deliver(outputs, &mut units);
        }
        world.step(dt);
        step += 1;
        if world.truth().all_out() {
            break;
        }
    }
    let truth = world.truth();
    let done = truth.all_out().then_some(truth.t);
    let dose = truth.units.iter().map(|u| u.heat_dose_kj_m2).sum();
    let water = truth.units.iter().map(|u| u.water_used_l).sum();
    let never = truth
        .fires
        .iter()
        .filter(|f| f.water_received_l == 0.0)
        .count();
    Ok((done, dose, water, never))
}

pub fn run(a: FleetArgs) -> anyhow::Result<ExitCode> {
    let (mut runs, mut bounds) = (Vec::new(), Vec::new());
    println!(
        "fleet experiment: {} trials per scenario and strategy, seed {}",
        a.trials, a.seed
    );
    println!(
        "{:<12} {:<11} {:>16} {:>10} {:>14} {:>9} {:>14}",
        "scenario",
        "strategy",
        "all out (s)",
        "unfinished",
        "heat (kJ/m2)",
        "water (L)",
        "never attacked"
    );
    for name in FLEET_SCENARIOS {
        let scenario = crate::commands::scenarios::resolve(name)?;
        for (label, command) in ROWS {
            let (mut time, mut unfinished, mut dose, mut water, mut never) =
                (0.0, 0, 0.0, 0.0, 0.0);
            for k in 0..a.trials {
                let (done, d, w, n) = fleet_run(&scenario, command, a.seed + u64::from(k))?;
                time += done.unwrap_or(scenario.time_limit_s);
                unfinished += u32::from(done.is_none());
                dose += d;
                water += w;
                never += n as f64;
            }
            let n = f64::from(a.trials);
            let run = FleetRun {
                strategy: label,
                scenario: name.to_owned(),
                trials: a.trials,
                time_all_out_s: time / n,
                unfinished,
                heat_dose: dose / n,
                water_l: water / n,
                fires_never_attacked: never / n,
            };
            println!(
                "{:<12} {:<11} {:>16.1} {:>10} {:>14.1} {:>9.0} {:>14.1}",
                run.scenario,
                run.strategy,
                run.time_all_out_s,
                run.unfinished,
                run.heat_dose,
                run.water_l,
                run.fires_never_attacked
            );
            match command {
                Command::Told => bounds.push(run),
                _ => runs.push(run),
            }
        }
    }
    if let Some(path) = &a.json {
        write_json(
            Some(path),
            &FleetResults {
                seed: a.seed,
                strategies: runs,
                bounds,
            },
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
