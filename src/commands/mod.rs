//! The `firefleet` subcommands, one module each, each owning its arguments, and the
//! argument types they share.
//!
//! Not here: the bus plumbing they share ([`firefleet::net`]).

use clap::{Args, ValueEnum};
pub use firefleet::args::{non_negative_f64, positive_f64, time_scale, write_json};

pub mod agent;
pub mod bt;
pub mod check;
pub mod console;
pub mod coordinator;
pub mod demo;
pub mod deploy;
pub mod doctor;
pub mod goal;
pub mod pki;
pub mod plan;
pub mod record;
pub mod replay;
pub mod scada;
pub mod scenarios;
pub mod schema;
pub mod sim;
pub mod status;
pub mod suspend;

/// The scenario (site file) every role reads. Required: a role started on a site without
/// it would have run, silently, on the `vehicle-collision` demo's map and units. (An
/// `Option` that clap requires, so that a command's subcommand may do without it:
/// `console add-user`.)
#[derive(Args, Clone, Debug)]
pub struct ScenarioArg {
    /// The site file, or a built-in scenario's name (see `firefleet scenarios`).
    #[arg(long, value_name = "FILE|NAME", required = true)]
    pub scenario: Option<String>,
}

impl ScenarioArg {
    /// The site file, loaded and validated.
    pub fn load(&self) -> anyhow::Result<firefleet_model::scenario::Scenario> {
        let name = self
            .scenario
            .as_deref()
            .ok_or_else(|| anyhow::anyhow!("--scenario FILE|NAME is required"))?;
        Ok(firefleet_model::builtin::resolve(name)?)
    }
}

/// What every role that runs until stopped takes: its site file, how it joins the bus,
/// and where it serves its health and figures.
#[derive(Args, Debug)]
pub struct RoleArgs {
    #[command(flatten)]
    pub scenario: ScenarioArg,
    #[command(flatten)]
    pub zenoh: firefleet::net::ZenohArgs,
    #[command(flatten)]
    pub metrics: crate::metrics::MetricsArg,
}

/// Which body an agent drives.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlatformKind {
    /// The simulator's unit, over the site's `sim/` keys.
    Sim,
    /// A ROS 2 robot over rmw_zenoh, a ground unit or a carriage: `firefleet sim --ros2`,
    /// or a real one.
    Ros2,
}

impl PlatformKind {
    /// Whether an agent may drive this body on `scenario`'s site: a real tunnel has no
    /// simulator, and an agent on the simulator's platform there would drive nothing (its
    /// unit shown lost while it logs nothing wrong). The reason, if not.
    pub fn fits(self, scenario: &firefleet_model::scenario::Scenario) -> Result<(), String> {
        match (self, scenario.simulated) {
            (PlatformKind::Sim, Some(false)) => Err(format!(
                "--platform sim on site '{}', which its site file says is real (simulated = false): a robot's agent runs --platform ros2",
                scenario.site
            )),
            _ => Ok(()),
        }
    }
}

/// Whether the coordinator keeps the simulator's clock: told so (`--sim-clock`) or on a
/// site whose site file says it is simulated. A real site has no simulator clock to keep
/// (tasks numbered by it would never be due), so asking for one there is refused.
pub fn sim_clock(
    scenario: &firefleet_model::scenario::Scenario,
    told: bool,
) -> Result<bool, String> {
    match (told, scenario.simulated) {
        (true, Some(false)) => Err(format!(
            "--sim-clock on site '{}', which its site file says is real (simulated = false): a real site runs on the system clock",
            scenario.site
        )),
        (told, simulated) => Ok(told || simulated == Some(true)),
    }
}
