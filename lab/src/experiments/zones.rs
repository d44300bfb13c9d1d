//! `firefleet-lab zones`: commanders' keep-out and evacuate goals issued
//! mid-incident, and what the fleet makes of them.
//!
//! For each shipped scenario and each of its zones that leaves a fire outside it, the
//! optimal coordinator's run without a goal is the baseline; then a keep-out and an
//! evacuate goal on the zone are issued at each of several times. Measured: how many
//! units were inside when the goal came, how long until every one was out, the invariants
//! the run broke (`firefleet check`'s: it must be none), whether the fires outside the zone
//! were all put out, and the time that took against the baseline. A run goes on for
//! [`WATCH_S`] after its last event, so that a unit drifting back in would be seen.
//!
//! Not here: the enforcement itself (the units' navigation and the coordinator's goals).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use firefleet_coordinator::assign::Strategy;
use firefleet_model::builtin;
use firefleet_model::scenario::{Scenario, Zone};
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{GoalKind, TruthFireState, ZoneGoal};
use serde::Serialize;

use firefleet::args::write_json;
use firefleet_lab::fleet::{Command, SimFleet};

#[derive(Args, Debug)]
pub struct ZonesArgs {
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Only these shipped scenarios (default: all of them).
    #[arg(long)]
    scenario: Vec<String>,
    /// Site times at which the goal is issued, s.
    #[arg(long, value_delimiter = ',', default_values_t = [15.0, 40.0, 90.0])]
    at: Vec<f64>,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// The shipped scenarios the experiment runs.
const SCENARIOS: [&str; 5] = [
    "vehicle-collision",
    "self-ignition",
    "cargo-truck",
    "pileup",
    "rail-tunnel",
];
/// How long a run goes on after its last event (the goal, the last fire outside the zone
/// out, the last unit out), s.
const WATCH_S: f64 = 60.0;

#[derive(Serialize)]
struct ZoneRun {
    scenario: String,
    zone: ZoneId,
    goal: GoalKind,
    at_s: f64,
    /// Units inside the zone when the goal came.
    inside_at_goal: usize,
    /// From the goal until the last unit left the zone, s; `None` if one never did.
    all_out_after_s: Option<f64>,
    violations: usize,
    fires_outside: usize,
    fires_outside_out: usize,
    /// Until every fire outside the zone was out, s; `None` if one never was.
    outside_out_s: Option<f64>,
    /// The same in the run without the goal.
    baseline_outside_out_s: Option<f64>,
}

#[derive(Serialize)]
struct ZonesResults {
    seed: u64,
    runs: Vec<ZoneRun>,
}

/// What one run came to.
struct Watch {
    inside_at_goal: usize,
    last_inside: Option<f64>,
    violations: usize,
    outside_out: usize,
    outside_out_s: Option<f64>,
}

/// Run `scenario` with `goal` issued at `at` (none: the baseline), watching `zone`.
fn zone_run(
    scenario: &Scenario,
    zone: &Zone,
    goal: Option<(ZoneGoal, f64)>,
    seed: u64,
) -> anyhow::Result<Watch> {
    let mut fleet = SimFleet::new(scenario, Command::Coordinator(Strategy::Optimal), seed, &[])?;
    let t = &scenario.tunnel;
    let inside = |p| (zone.start_m..=zone.end_m).contains(&t.chainage(p));
    let outside_fires: Vec<usize> = (0..scenario.fires.len())
        .filter(|&i| !inside(scenario.fires[i].position()))
        .collect();
    let mut pending = goal;
    let at = pending.as_ref().map_or(0.0, |(_, at)| *at);
    let mut w = Watch {
        inside_at_goal: 0,
        last_inside: None,
        violations: 0,
        outside_out: 0,
        outside_out_s: None,
    };
    while fleet.time() < scenario.time_limit_s {
        if let Some((g, at)) = pending.take_if(|(_, at)| fleet.time() >= *at) {
            w.inside_at_goal = fleet
                .truth()
                .units
                .iter()
                .filter(|u| inside(u.pose.position()))
                .count();
            if w.inside_at_goal > 0 {
                w.last_inside = Some(at);
            }
            fleet.goal(&experimenter(), g)?;
        }
        fleet.step()?;
        let truth = fleet.truth();
        if fleet.time() >= at && truth.units.iter().any(|u| inside(u.pose.position())) {
            w.last_inside = Some(fleet.time());
        }
        w.outside_out = outside_fires
            .iter()
            .filter(|&&i| truth.fires[i].state == TruthFireState::Out)
            .count();
        if w.outside_out == outside_fires.len() && w.outside_out_s.is_none() {
            w.outside_out_s = Some(fleet.time());
        }
        let settled = w.outside_out_s.unwrap_or(f64::INFINITY);
        let last = settled.max(at).max(w.last_inside.unwrap_or(0.0));
        if pending.is_none() && fleet.time() > last + WATCH_S {
            break;
        }
    }
    w.violations = fleet.violations().len();
    for v in fleet.violations() {
        eprintln!("  violation: {v}");
    }
    Ok(w)
}

pub fn run(a: ZonesArgs) -> anyhow::Result<ExitCode> {
    if let Some(s) = a.scenario.iter().find(|s| !SCENARIOS.contains(&s.as_str())) {
        anyhow::bail!("--scenario {s}: not one of {}", SCENARIOS.join(", "));
    }
    anyhow::ensure!(
        a.at.iter().all(|t| t.is_finite() && *t >= 0.0),
        "--at: times must be seconds of site time, 0 or more"
    );
    println!(
        "zones experiment: seed {}, goals issued at {:?} s",
        a.seed, a.at
    );
    println!(
        "{:<18} {:<8} {:<9} {:>6} {:>7} {:>13} {:>10} {:>12} {:>16} {:>13}",
        "scenario",
        "zone",
        "goal",
        "at (s)",
        "inside",
        "all out (s)",
        "violations",
        "fires out",
        "outside out (s)",
        "baseline (s)"
    );
    let fmt = |t: Option<f64>| t.map_or("never".to_owned(), |t| format!("{t:.1}"));
    let mut runs = Vec::new();
    let mut violations = 0;
    for name in SCENARIOS {
        if !a.scenario.is_empty() && !a.scenario.iter().any(|s| s == name) {
            continue;
        }
        let scenario = builtin::resolve(name)?;
        for zone in &scenario.zones {
            let t = &scenario.tunnel;
            let burning_inside = |f: &&firefleet_model::scenario::FireSpec| {
                (zone.start_m..=zone.end_m).contains(&t.chainage(f.position()))
            };
            // A zone holding every fire leaves nothing to measure outside it.
            if scenario.fires.iter().all(|f| burning_inside(&f)) {
                continue;
            }
            let base = zone_run(&scenario, zone, None, a.seed)?;
            for kind in [GoalKind::KeepOut, GoalKind::Evacuate] {
                for &at in &a.at {
                    let goal = ZoneGoal {
                        id: format!("exp-{}", zone.id),
                        ..ZoneGoal::new(zone.id.clone(), kind, experimenter())
                    };
                    let w = zone_run(&scenario, zone, Some((goal, at)), a.seed)?;
                    let run = ZoneRun {
                        scenario: name.to_owned(),
                        zone: zone.id.clone(),
                        goal: kind,
                        at_s: at,
                        inside_at_goal: w.inside_at_goal,
                        all_out_after_s: match w.last_inside {
                            Some(last) if last >= scenario.time_limit_s - 0.1 => None,
                            Some(last) => Some(last - at),
                            None => Some(0.0),
                        },
                        violations: w.violations,
                        fires_outside: scenario.fires.iter().filter(|f| !burning_inside(f)).count(),
                        fires_outside_out: w.outside_out,
                        outside_out_s: w.outside_out_s,
                        baseline_outside_out_s: base.outside_out_s,
                    };
                    violations += run.violations;
                    println!(
                        "{:<18} {:<8} {:<9} {:>6.0} {:>7} {:>13} {:>10} {:>12} {:>16} {:>13}",
                        run.scenario,
                        run.zone.as_str(),
                        run.goal.as_str(),
                        run.at_s,
                        run.inside_at_goal,
                        fmt(run.all_out_after_s),
                        run.violations,
                        format!("{}/{}", run.fires_outside_out, run.fires_outside),
                        fmt(run.outside_out_s),
                        fmt(run.baseline_outside_out_s),
                    );
                    runs.push(run);
                }
            }
        }
    }
    write_json(a.json.as_deref(), &ZonesResults { seed: a.seed, runs })?;
    if violations > 0 {
        eprintln!("{violations} invariant violations");
        return Ok(ExitCode::FAILURE);
    }
    Ok(ExitCode::SUCCESS)
}

/// The commander the experiment issues its goals as.
fn experimenter() -> CommanderId {
    CommanderId::new("experiment").expect("a valid commander name")
}
