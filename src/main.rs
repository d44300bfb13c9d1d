//! `firefleet`: one binary for every role of a tunnel firefighting fleet.
//!
//! `firefleet demo` starts a whole fleet on loopback (simulator, coordinator, one agent per
//! unit, optionally a recorder) as child processes and reports the incident. The other
//! subcommands run one role each and join a Zenoh network given on the command line, so
//! the same binary deploys onto several machines.

mod bt_cli;
mod demo;
mod experiment;
mod goal;
mod plan;
mod plot;
mod replay;
mod roles;
mod scenarios;

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand};
use firefleet_protocol::UnitId;
use firefleet_protocol::bus::Connect;

#[derive(Parser)]
#[command(
    name = "firefleet",
    version,
    about = "Coordinate firefighting robots in road and rail tunnels"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a whole fleet (simulator, coordinator, agents) on loopback and report the incident.
    Demo(demo::DemoArgs),
    /// Run the tunnel fire simulator.
    Sim(SimArgs),
    /// Run the coordinator.
    Coordinator(CoordinatorArgs),
    /// Run the agent of one unit.
    Agent(AgentArgs),
    /// Record all traffic of a site to an MCAP file.
    Record(RecordArgs),
    /// Print the incident as the coordinator sees it.
    Status(StatusArgs),
    /// Issue, list or clear incident commanders' zone goals.
    #[command(subcommand)]
    Goal(goal::GoalCommand),
    /// Run the planners on standard inputs (MovingAI grid benchmarks).
    #[command(subcommand)]
    Plan(plan::PlanCommand),
    /// Print the timeline of a recorded incident.
    Replay(replay::ReplayArgs),
    /// Validate, show or dry-run behavior-tree XML files.
    #[command(subcommand)]
    Bt(bt_cli::BtCommand),
    /// Reproduce an experiment of the papers in the simulator.
    #[command(subcommand)]
    Experiment(experiment::ExperimentCommand),
    /// List the built-in scenarios.
    Scenarios,
}

/// How a role joins the Zenoh network.
#[derive(Args, Clone, Debug, Default)]
pub struct ZenohArgs {
    /// A Zenoh configuration file (JSON5, zenoh's own format).
    #[arg(long, value_name = "FILE")]
    zenoh_config: Option<PathBuf>,
    /// Zenoh mode: peer, client or router.
    #[arg(long)]
    mode: Option<String>,
    /// Endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    connect: Vec<String>,
    /// Endpoint to listen on (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    listen: Vec<String>,
    /// Exit when standard input closes (used by `demo` so no child outlives it).
    #[arg(long, hide = true)]
    die_with_parent: bool,
}

impl ZenohArgs {
    fn connect(&self) -> Connect {
        Connect {
            config_file: self.zenoh_config.clone(),
            mode: self.mode.clone(),
            connect: self.connect.clone(),
            listen: self.listen.clone(),
        }
    }
}

/// The scenario (site file) every role reads.
#[derive(Args, Clone, Debug)]
pub struct ScenarioArg {
    /// A built-in scenario name (see `firefleet scenarios`) or a scenario file.
    #[arg(long, default_value = "vehicle-collision")]
    scenario: String,
}

#[derive(Args, Debug)]
pub struct SimArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// Seed of the simulator's random draws (default: the scenario's).
    #[arg(long)]
    seed: Option<u64>,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 1.0, value_parser = positive_f64)]
    time_scale: f64,
    /// Wait up to this many seconds for every unit to be alive before starting the clock.
    #[arg(long, value_name = "SECONDS", value_parser = positive_f64)]
    wait_for_fleet: Option<f64>,
    /// With --wait-for-fleet, wait for a coordinator too.
    #[arg(long)]
    wait_for_coordinator: bool,
}

#[derive(Args, Debug)]
pub struct CoordinatorArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// A unit silent this long is treated as lost, seconds of site time.
    #[arg(long, default_value_t = 5.0, value_parser = positive_f64)]
    lease_s: f64,
    /// Follow the simulator's clock (ff/<site>/sim/clock) instead of the system clock.
    #[arg(long)]
    sim_clock: bool,
    /// How units are paired with fires: optimal (least total travel time) or greedy
    /// (nearest free unit first).
    #[arg(long, default_value = "optimal")]
    assignment: firefleet_coordinator::assign::Strategy,
    /// Take back the fire tracks recorded in this MCAP file (a recording of this site by
    /// `firefleet record` or `demo --record`), for a restart with no recorder left
    /// running; a file cut short by a crash is read up to where it ends.
    #[arg(long, value_name = "FILE.mcap")]
    resume: Option<PathBuf>,
}

#[derive(Args, Debug)]
pub struct AgentArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The unit this agent drives (an id from the scenario's [[units]]).
    #[arg(long)]
    unit: UnitId,
    /// Behavior tree (BehaviorTree.CPP v4 XML) to run instead of the shipped one.
    #[arg(long, value_name = "FILE.xml")]
    tree: Option<PathBuf>,
    /// How often the tree is ticked, per second of site time.
    #[arg(long, default_value_t = 20.0, value_parser = positive_f64)]
    tick_hz: f64,
    /// Print the tree with live statuses to stderr about once a second of site time.
    #[arg(long)]
    print_tree: bool,
}

#[derive(Args, Debug)]
pub struct RecordArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The MCAP file to write.
    #[arg(long, value_name = "FILE.mcap")]
    out: PathBuf,
}

#[derive(Args, Debug)]
pub struct StatusArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// Print the raw JSON snapshot.
    #[arg(long)]
    json: bool,
}

fn positive_f64(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        Ok(v) => Err(format!("{v} is not a positive number")),
        Err(e) => Err(e.to_string()),
    }
}

/// Log to stderr; `RUST_LOG` overrides `default`.
fn init_logging(default: &str) {
    let filter =
        tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default.into());
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // Experiments and tree tools print tables; per-event logs are noise there.
    let quiet = matches!(
        cli.command,
        Command::Experiment(_) | Command::Bt(_) | Command::Replay(_) | Command::Plan(_)
    );
    init_logging(if quiet { "warn" } else { "info,zenoh=warn" });
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("tokio runtime");
    let result = runtime.block_on(async move {
        match cli.command {
            Command::Demo(a) => demo::run(a).await,
            Command::Sim(a) => roles::sim(a).await,
            Command::Coordinator(a) => roles::coordinator(a).await,
            Command::Agent(a) => roles::agent(a).await,
            Command::Record(a) => roles::record(a).await,
            Command::Status(a) => roles::status(a).await,
            Command::Goal(c) => goal::run(c).await,
            Command::Plan(c) => plan::run(c),
            Command::Scenarios => scenarios::list(),
            Command::Bt(c) => bt_cli::run(c),
            Command::Replay(a) => replay::run(a),
            Command::Experiment(c) => experiment::run(c).await,
        }
    });
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::from(2)
        }
    }
}
