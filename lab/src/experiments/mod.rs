//! The lab's experiments, one module each: the papers' experiments reproduced in the
//! simulator, the fleet's strategies compared, goals mid-incident, and the harnesses that
//! run the real processes under load (`scale`), attack (`flood`) and network faults
//! (`nemesis`).
//!
//! The papers' experiments and the fleet's comparisons run in-process
//! ([`firefleet_lab::fleet`], or a unit's controller stepped alone), so a seed gives the
//! same run every time. `scale`, `flood` and `nemesis` start the `firefleet` binary's
//! roles as processes on a real bus instead.
//!
//! Not here: the fleet loop they share (`firefleet_lab::fleet`).

use std::process::ExitCode;

use clap::Subcommand;

pub mod cannon;
mod costmap_ga;
mod fleet;
mod flood;
pub mod length;
mod nav;
mod nemesis;
mod plot;
mod robogat;
mod scale;
mod thermal;
mod zones;

#[derive(Subcommand, Debug)]
pub enum Experiment {
    /// The BT paper's water-cannon experiment: 1 to 5 flames 6 m away at 0, 30 and 60 deg.
    Cannon(cannon::CannonArgs),
    /// The shipped multi-fire scenarios with no coordinator, greedy and optimal assignment.
    Fleet(fleet::FleetArgs),
    /// What a tunnel's length costs: a unit's and the coordinator's memory, plan times.
    Length(length::LengthArgs),
    /// The ROBOGAT paper's monorail case study: fuzzy against fixed weights.
    Robogat(robogat::RobogatArgs),
    /// A real coordinator process under a large simulated fleet over loopback Zenoh.
    Scale(scale::ScaleArgs),
    /// The pixel flame detector's precision, recall and localisation error by scene class.
    Thermal(thermal::ThermalArgs),
    /// A secure demo site under a flood from one stolen unit certificate, measured.
    Flood(flood::FloodArgs),
    /// The Dijkstra+GA paper's heat-aware cost map: no heat, w1 = w2 = 1, GA-tuned.
    CostmapGa(costmap_ga::CostmapGaArgs),
    /// The BT paper's navigation trials in a curved tunnel, visibility term on and off.
    Nav(nav::NavArgs),
    /// Keep-out and evacuate goals issued mid-incident on the shipped scenarios.
    Zones(zones::ZonesArgs),
    /// The fleet across Linux network namespaces under partitions, loss, kills and
    /// pauses, one fault a run, checked over its recordings (needs root).
    Nemesis(nemesis::NemesisArgs),
    /// The nemesis's delaying TCP proxy, run in the router's namespace.
    #[command(hide = true)]
    DelayProxy(nemesis::proxy::ProxyArgs),
}

pub async fn run(experiment: Experiment) -> anyhow::Result<ExitCode> {
    match experiment {
        Experiment::Cannon(a) => cannon::run(a),
        Experiment::Fleet(a) => fleet::run(a),
        Experiment::Length(a) => length::run(a),
        Experiment::Robogat(a) => robogat::run(a),
        Experiment::Scale(a) => scale::run(a).await,
        Experiment::Flood(a) => flood::run(a).await,
        Experiment::Thermal(a) => thermal::run(a),
        Experiment::CostmapGa(a) => costmap_ga::run(a),
        Experiment::Nav(a) => nav::run(a),
        Experiment::Zones(a) => zones::run(a),
        Experiment::Nemesis(a) => nemesis::run(a).await,
        Experiment::DelayProxy(a) => nemesis::proxy::run(a).await,
    }
}

/// The mean and the sample standard deviation of `v` (NaN for none; 0 spread for one).
pub fn mean_std(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let m = v.iter().sum::<f64>() / v.len() as f64;
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64
    } else {
        0.0
    };
    (m, var.sqrt())
}
