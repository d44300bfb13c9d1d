//! What the demo reports: its progress, how it ended, and the summary it writes as JSON.
//!
//! Not here: running the fleet (the parent module).

use super::*;

#[derive(Serialize)]
pub(super) struct ProcessInfo {
    pub(super) role: String,
    pub(super) pid: Option<u32>,
}

#[derive(Serialize)]
pub(super) struct UnitSummary {
    pub(super) id: String,
    pub(super) heat_dose_kj_m2: f64,
    pub(super) water_used_l: f64,
    pub(super) collisions: u32,
}

#[derive(Serialize)]
pub(super) struct Summary {
    pub(super) scenario: String,
    pub(super) seed: u64,
    pub(super) success: bool,
    pub(super) outcome: String,
    pub(super) fires_total: usize,
    pub(super) fires_out: usize,
    pub(super) sim_time_s: f64,
    pub(super) wall_time_s: f64,
    pub(super) time_scale: f64,
    pub(super) processes: Vec<ProcessInfo>,
    pub(super) units: Vec<UnitSummary>,
    pub(super) recording: Option<PathBuf>,
    /// The router's endpoint.
    pub(super) router: String,
    /// With --secure: the site PKI and the rendered configurations (made for the run and
    /// removed at its end, but for a PKI given with --pki).
    pub(super) pki: Option<PathBuf>,
    pub(super) configs: Option<PathBuf>,
}

/// How the run ended.
pub(super) enum Outcome {
    AllOut,
    TimeLimit,
    ChildDied(String),
    Interrupted,
    WallTimeout,
}

/// Whether the run succeeded, and how it ended in words: every fire out, or the time limit
/// reached with the fires left burning only where the goal governing their place (by rank,
/// then priority, as the coordinator decides) bars attack.
pub(super) fn verdict(
    outcome: &Outcome,
    truth: &SimTruth,
    in_force: &mut Goals,
    scenario: &Scenario,
    wall: f64,
) -> (bool, String) {
    in_force.expire(truth.t);
    let spared: Vec<&str> = truth
        .fires
        .iter()
        .filter(|f| f.state != TruthFireState::Out)
        .filter_map(|f| {
            in_force
                .at(scenario.tunnel.chainage(f.position))
                .filter(|g| g.bars_attack())
                .map(|g| g.goal.zone.as_str())
        })
        .collect();
    let mut zones = spared.clone();
    zones.sort_unstable();
    zones.dedup();
    let all_but_spared = matches!(outcome, Outcome::TimeLimit)
        && !spared.is_empty()
        && truth.fires_out() + spared.len() == truth.fires.len();
    let success = matches!(outcome, Outcome::AllOut) || all_but_spared;
    let outcome_text = match outcome {
        Outcome::AllOut => format!(
            "all {} fires out at t = {:.1} s",
            truth.fires.len(),
            truth.t
        ),
        Outcome::TimeLimit if all_but_spared => format!(
            "time limit {:.0} s reached with {} of {} fires out; the rest burn where a commander's goal bars attack (zone {})",
            truth.time_limit_s,
            truth.fires_out(),
            truth.fires.len(),
            zones.join(", ")
        ),
        Outcome::TimeLimit => format!(
            "time limit {:.0} s reached with {} of {} fires out",
            truth.time_limit_s,
            truth.fires_out(),
            truth.fires.len()
        ),
        Outcome::ChildDied(role) => format!("the {role} process exited unexpectedly"),
        Outcome::Interrupted => "interrupted".to_owned(),
        Outcome::WallTimeout => format!("no result after {wall:.0} s of wall time"),
    };
    (success, outcome_text)
}

pub(super) fn print_progress(truth: &SimTruth, modes: &BTreeMap<String, String>) {
    let burning = truth
        .fires
        .iter()
        .filter(|f| f.state == TruthFireState::Burning)
        .count();
    let units: Vec<String> = modes.iter().map(|(u, m)| format!("{u} {m}")).collect();
    println!(
        "t={:6.1} s  fires burning {burning}, out {}/{}  | {}",
        truth.t,
        truth.fires_out(),
        truth.fires.len(),
        units.join(", ")
    );
}
