//! `firefleet-lab fleet`: the shipped multi-fire scenarios under four strategies
//! side by side: every unit running its tree alone with no coordinator, greedy
//! nearest-free-unit assignment, the coordinator's optimal assignment, and the optimal
//! coordinator with the tunnel's SCADA feed (`feed`: DTS alarms as fire reports, the
//! ventilation's air for the side to attack from; what `firefleet scada` delivers).
//!
//! A further row per scenario, `bound`, is not a strategy: the optimal coordinator told
//! exactly where every fire is at t = 0. The fleet still drives there and fights them, so
//! its time to all-out is what no coordination of these units can beat: how much of the
//! uncoordinated fleet's time is finding fires rather than choosing who fights them. The
//! feed comes close to it but for the DTS's zone (a fire is somewhere in 10 m until a
//! unit sees it) and its first measurement.
//!
//! On a ventilated scenario one more row, `feed, downwind`, tells the fed coordinator the
//! air flows the other way: it then sends units in from downwind, through the smoke, and
//! the heat dose column shows what the upwind side spares them.
//!
//! `--generated N` runs a family of N real-size tunnels instead ([`firefleet_lab::tunnels`],
//! 1-10 km), by default the autonomous and optimal rows only, one trial each, and prints
//! the median gain of each row over the autonomous fleet, and of the drive floor.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_coordinator::assign::{Mobility, Strategy};
use firefleet_coordinator::incident::mobility_of;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use firefleet_model::{FireId, Point2};
use firefleet_protocol::msg::{FireState, FireTrack};
use firefleet_sim::world::Perception;
use serde::Serialize;

use firefleet::args::{Sensing, write_json};
use firefleet_lab::fleet::{self as sim_fleet, Air, SimFleet};
use firefleet_lab::tunnels;

#[derive(Args, Debug)]
pub struct FleetArgs {
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Runs per scenario and strategy (seeds seed, seed+1, ...); 3, or 1 with
    /// `--generated`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    trials: Option<u32>,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Run these scenarios (shipped names or site files) instead of the default set.
    #[arg(long = "scenario", value_name = "NAME")]
    scenarios: Vec<String>,
    /// Run only the rows whose label starts with one of these (autonomous, greedy,
    /// optimal, feed, bound); every row by default, autonomous and optimal with
    /// `--generated`.
    #[arg(long = "row", value_name = "LABEL")]
    rows: Vec<String>,
    /// Run a generated family of this many real-size tunnels (1-10 km) instead.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u16).range(1..=1000))]
    generated: Option<u16>,
    /// The generated family's seed.
    #[arg(long, default_value_t = 51, requires = "generated")]
    family: u64,
    /// Write the generated tunnels' site files to this directory (each runs as a real
    /// fleet with `firefleet demo --scenario FILE`).
    #[arg(long, value_name = "DIR", requires = "generated")]
    sites: Option<PathBuf>,
    /// What ground units find flames in: boxes drawn from the truth (the papers'
    /// detector's stand-in, and this experiment's default: the comparisons and the papers'
    /// reproductions were measured with it) or their thermal cores' pixels (the
    /// simulator's default, `firefleet sim`).
    #[arg(long, value_enum, default_value_t = Sensing::Boxes)]
    perception: Sensing,
}

/// The scenarios the fleet experiment runs.
const FLEET_SCENARIOS: [&str; 4] = ["cargo-truck", "pileup", "rail-tunnel", "ventilated"];

#[derive(Serialize)]
struct FleetRun {
    strategy: &'static str,
    scenario: String,
    trials: u32,
    /// Mean over trials; a trial that did not finish counts at the time limit.
    time_all_out_s: f64,
    unfinished: u32,
    heat_dose: f64,
    /// The heat dose of the units that sprayed: the attackers'.
    attack_heat_dose: f64,
    water_l: f64,
    fires_never_attacked: f64,
    /// Incident invariants broken, over all trials (`firefleet check`'s).
    violations: usize,
}

#[derive(Serialize)]
struct FleetResults {
    seed: u64,
    strategies: Vec<FleetRun>,
    /// The `bound` rows: the optimal coordinator told every fire at t = 0.
    bounds: Vec<FleetRun>,
    /// Per ground-only scenario, the drive floor ([`drive_floor_s`]).
    floors: Vec<(String, f64)>,
}

/// Preferred firing distances reach out to this, m (the ground units' farthest standoff).
const FARTHEST_STANDOFF_M: f64 = 10.0;

/// A floor under every strategy's time to all-out, s: the fire whose nearest unit is
/// farthest, reached at that unit's top speed, a ground unit in a straight line to within
/// [`FARTHEST_STANDOFF_M`], a carriage along its rail to the dock that serves the fire and
/// coupled there (it cannot spray before), with no time to start, turn, aim or spray. No
/// coordination, feed or sensor beats it; the units' speed does.
fn drive_floor_s(scenario: &Scenario) -> anyhow::Result<f64> {
    let units = scenario
        .units
        .iter()
        .map(|u| Ok((Point2::new(u.x_m, u.y_m), mobility_of(scenario, u)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let reach = |at: Point2, m: &Mobility, fire: Point2| match m {
        Mobility::Ground(g) => Some((at.dist(fire) - FARTHEST_STANDOFF_M).max(0.0) / g.speed_m_s),
        Mobility::Rail { .. } => m.travel_s(at, fire),
    };
    scenario
        .fires
        .iter()
        .map(|f| {
            units
                .iter()
                .filter_map(|(at, m)| reach(*at, m, f.position()))
                .fold(f64::INFINITY, f64::min)
        })
        .reduce(f64::max)
        .context("no fires")
}

/// Who decides what the units do in a run.
#[derive(Debug, Clone, Copy)]
enum Command {
    /// No coordinator: every unit runs its tree alone.
    Alone,
    /// A coordinator with this strategy, which learns of fires from the units' reports.
    Coordinator(Strategy),
    /// The optimal coordinator with the SCADA feed, told the air as measured or reversed.
    Fed(Air),
    /// The optimal coordinator, told every fire at t = 0: the bound.
    Told,
}

/// The rows of the table: label, command. The reversed air only where the air moves.
const ROWS: [(&str, Command); 6] = [
    ("autonomous", Command::Alone),
    ("greedy", Command::Coordinator(Strategy::Greedy)),
    ("optimal", Command::Coordinator(Strategy::Optimal)),
    ("feed", Command::Fed(Air::AsMeasured)),
    ("feed, downwind", Command::Fed(Air::Reversed)),
    ("bound", Command::Told),
];

/// Every fire of `scenario` as a confirmed track, as a coordinator would recall it.
pub(super) fn known_fires(scenario: &Scenario) -> Vec<FireTrack> {
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
/// (kJ/m^2, summed over units), water used (L), fires that got no water, invariants broken.
fn fleet_run(
    scenario: &Scenario,
    command: Command,
    seed: u64,
    perception: Perception,
) -> anyhow::Result<Outcome> {
    let (how, known) = match command {
        Command::Alone => (sim_fleet::Command::Alone, Vec::new()),
        Command::Coordinator(s) => (sim_fleet::Command::Coordinator(s), Vec::new()),
        Command::Fed(air) => (sim_fleet::Command::Fed(Strategy::Optimal, air), Vec::new()),
        Command::Told => (
            sim_fleet::Command::Coordinator(Strategy::Optimal),
            known_fires(scenario),
        ),
    };
    let mut fleet = SimFleet::new(scenario, how, seed, &known)?;
    fleet.set_perception(perception);
    while fleet.time() < scenario.time_limit_s {
        fleet.step()?;
        if fleet.truth().all_out() {
            break;
        }
    }
    // The count goes in the table; what broke, where and when goes here, or nobody can
    // tell which run to look at.
    for v in fleet.violations() {
        eprintln!("{} seed {seed}: {v}", scenario.name);
    }
    let truth = fleet.truth();
    Ok(Outcome {
        done: truth.all_out().then_some(truth.t),
        dose: truth.units.iter().map(|u| u.heat_dose_kj_m2).sum(),
        attack_dose: truth
            .units
            .iter()
            .filter(|u| u.water_used_l > 0.0)
            .map(|u| u.heat_dose_kj_m2)
            .sum(),
        water: truth.units.iter().map(|u| u.water_used_l).sum(),
        never: truth
            .fires
            .iter()
            .filter(|f| f.water_received_l == 0.0)
            .count(),
        violations: fleet.violations().len(),
    })
}

/// What one run came to.
struct Outcome {
    done: Option<f64>,
    dose: f64,
    attack_dose: f64,
    water: f64,
    never: usize,
    violations: usize,
}

/// The scenarios to run: a generated family (its site files written where asked), those
/// named, or the default set.
fn scenarios(a: &FleetArgs) -> anyhow::Result<Vec<Scenario>> {
    if let Some(n) = a.generated {
        let family = tunnels::family(a.family, usize::from(n))?;
        if let Some(dir) = &a.sites {
            std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
            for (k, s) in family.iter().enumerate() {
                let path = dir.join(format!("{}.toml", s.name));
                std::fs::write(&path, tunnels::site_file(a.family, k, usize::from(n)))
                    .with_context(|| format!("writing {}", path.display()))?;
            }
        }
        return Ok(family);
    }
    let names: Vec<&str> = match a.scenarios.is_empty() {
        true => FLEET_SCENARIOS.to_vec(),
        false => a.scenarios.iter().map(String::as_str).collect(),
    };
    Ok(names
        .into_iter()
        .map(builtin::resolve)
        .collect::<Result<_, _>>()?)
}

/// The median of `xs` (the mean of the middle two of an even count); `None` if empty.
fn median(mut xs: Vec<f64>) -> Option<f64> {
    xs.sort_by(f64::total_cmp);
    let n = xs.len();
    (n > 0).then(|| (xs[(n - 1) / 2] + xs[n / 2]) / 2.0)
}

pub fn run(a: FleetArgs) -> anyhow::Result<ExitCode> {
    let (mut runs, mut bounds, mut floors) = (Vec::new(), Vec::new(), Vec::new());
    let trials = a
        .trials
        .unwrap_or(if a.generated.is_some() { 1 } else { 3 });
    let rows: Vec<&str> = match (a.generated, a.rows.is_empty()) {
        (Some(_), true) => vec!["autonomous", "optimal"],
        _ => a.rows.iter().map(String::as_str).collect(),
    };
    println!(
        "fleet experiment: {trials} trials per scenario and strategy, seed {}",
        a.seed
    );
    println!(
        "{:<12} {:<15} {:>12} {:>10} {:>14} {:>14} {:>9} {:>14} {:>10}",
        "scenario",
        "strategy",
        "all out (s)",
        "unfinished",
        "heat (kJ/m2)",
        "attackers'",
        "water (L)",
        "never attacked",
        "violations"
    );
    // Per row label, the gain over the autonomous fleet on each scenario, %.
    let mut gains: Vec<(&str, Vec<f64>)> = Vec::new();
    let mut gain = |label: &'static str, autonomous: f64, t: f64| {
        let g = 100.0 * (autonomous - t) / autonomous;
        match gains.iter_mut().find(|(l, _)| *l == label) {
            Some((_, v)) => v.push(g),
            None => gains.push((label, vec![g])),
        }
        format!("  {g:+.1} %")
    };
    for scenario in scenarios(&a)? {
        let name = scenario.name.as_str();
        if a.generated.is_some() {
            println!(
                "{name}: {:.2} km, {} fires, {} units ({} carriages), air {:.1} m/s",
                scenario.tunnel.length_m / 1000.0,
                scenario.fires.len(),
                scenario.units.len(),
                scenario.rails.len(),
                scenario.air_m_s()
            );
        }
        let mut autonomous = None;
        for (label, command) in ROWS {
            if matches!(command, Command::Fed(Air::Reversed)) && scenario.air_m_s() == 0.0 {
                continue;
            }
            if !rows.is_empty() && !rows.iter().any(|r| label.starts_with(r)) {
                continue;
            }
            let (mut time, mut unfinished, mut dose, mut water, mut never, mut violations) =
                (0.0, 0, 0.0, 0.0, 0.0, 0);
            let mut attack_dose = 0.0;
            for k in 0..trials {
                let o = fleet_run(
                    &scenario,
                    command,
                    a.seed + u64::from(k),
                    a.perception.into(),
                )?;
                time += o.done.unwrap_or(scenario.time_limit_s);
                unfinished += u32::from(o.done.is_none());
                dose += o.dose;
                attack_dose += o.attack_dose;
                water += o.water;
                never += o.never as f64;
                violations += o.violations;
            }
            let n = f64::from(trials);
            let run = FleetRun {
                strategy: label,
                scenario: name.to_owned(),
                trials,
                time_all_out_s: time / n,
                unfinished,
                heat_dose: dose / n,
                attack_heat_dose: attack_dose / n,
                water_l: water / n,
                fires_never_attacked: never / n,
                violations,
            };
            let faster = match (command, autonomous) {
                (Command::Alone, _) => {
                    autonomous = Some(run.time_all_out_s);
                    String::new()
                }
                (_, Some(a)) => gain(label, a, run.time_all_out_s),
                (_, None) => String::new(),
            };
            println!(
                "{:<12} {:<15} {:>12.1} {:>10} {:>14.1} {:>14.1} {:>9.0} {:>14.1} {:>10}{faster}",
                run.scenario,
                run.strategy,
                run.time_all_out_s,
                run.unfinished,
                run.heat_dose,
                run.attack_heat_dose,
                run.water_l,
                run.fires_never_attacked,
                run.violations
            );
            match command {
                Command::Told => bounds.push(run),
                _ => runs.push(run),
            }
        }
        if let Some(a) = autonomous {
            let floor = drive_floor_s(&scenario)?;
            println!(
                "{name:<12} {:<15} {floor:>12.1}{:>60}{}",
                "drive floor",
                "(top speed, straight line, no spraying)",
                gain("drive floor", a, floor)
            );
            floors.push((name.to_owned(), floor));
        }
    }
    if !gains.is_empty() {
        println!("median gain over the autonomous fleet:");
        for (label, g) in &gains {
            let m = median(g.clone()).unwrap_or(f64::NAN);
            println!("  {label:<15} {m:+.1} % over {} scenarios", g.len());
        }
    }
    let unfinished: u32 = runs
        .iter()
        .filter(|r| r.strategy != "autonomous")
        .map(|r| r.unfinished)
        .sum();
    let broken: usize = runs.iter().chain(&bounds).map(|r| r.violations).sum();
    write_json(
        a.json.as_deref(),
        &FleetResults {
            seed: a.seed,
            strategies: runs,
            bounds,
            floors,
        },
    )?;
    let mut ok = true;
    if broken > 0 {
        eprintln!("{broken} invariant violations");
        ok = false;
    }
    if unfinished > 0 {
        eprintln!("{unfinished} coordinated runs left fires burning at the time limit");
        ok = false;
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
