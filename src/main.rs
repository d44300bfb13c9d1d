//! `firefleet`: one binary for every role of a tunnel firefighting fleet.
//!
//! `firefleet demo` starts a whole fleet on loopback (simulator, coordinator, one agent per
//! unit, optionally a recorder) as child processes and reports the incident. The other
//! subcommands run one role each and join a Zenoh network given on the command line, so
//! the same binary deploys onto several machines.
//!
//! Each subcommand lives in `commands/` and only parses, calls and prints; what several
//! share is beside them: `net` (joining the bus, signals, the status query), `children`
//! (the processes a command starts), `checking` (a recording through the invariants),
//! `metrics` (a role's health and Prometheus figures over HTTP), `rehome` (a unit's move
//! to a nearer router).
//! Not here: any role's work (the library crates).

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a CLI prints what a person reads"
)]

mod checking;
mod children;
mod commands;
mod metrics;
mod net;
mod rehome;

use clap::{Parser, Subcommand};

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
    Demo(commands::demo::DemoArgs),
    /// Run the tunnel fire simulator.
    Sim(commands::sim::SimArgs),
    /// Bridge the tunnel's SCADA (DTS zones, ventilation) from Modbus TCP to the site's bus.
    Scada(commands::scada::ScadaArgs),
    /// Run the coordinator.
    Coordinator(commands::coordinator::CoordinatorArgs),
    /// Run the agent of one unit.
    Agent(commands::agent::AgentArgs),
    /// Record all traffic of a site to an MCAP file.
    Record(commands::record::RecordArgs),
    /// Print the incident as the coordinator sees it.
    Status(commands::status::StatusArgs),
    /// The incident commander's web console (a live map, goals, alerts), or add a login.
    Console(commands::console::ConsoleArgs),
    /// Issue, list or clear incident commanders' zone goals.
    #[command(subcommand)]
    Goal(commands::goal::GoalCommand),
    /// Run the planners on standard inputs (MovingAI grid benchmarks).
    #[command(subcommand)]
    Plan(commands::plan::PlanCommand),
    /// Check a recorded incident against the commanders' zone goals (exit 1 on a violation).
    Check(commands::check::CheckArgs),
    /// Print the timeline of a recorded incident.
    Replay(commands::replay::ReplayArgs),
    /// The JSON Schema of every message, for tools in other languages.
    Schema(commands::schema::SchemaArgs),
    /// Validate, show or dry-run behavior-tree XML files.
    #[command(subcommand)]
    Bt(commands::bt::BtCommand),
    /// Reproduce an experiment of the papers in the simulator.
    #[command(subcommand)]
    Experiment(commands::experiment::ExperimentCommand),
    /// List the built-in scenarios.
    Scenarios,
    /// Make a site's certificates for mutual TLS.
    #[command(subcommand)]
    Pki(commands::pki::PkiCommand),
    /// Render a site's Zenoh configurations with access rules.
    #[command(subcommand)]
    Deploy(commands::deploy::DeployCommand),
    /// Run a site's Zenoh router (mutual TLS and access rules, unless --plain).
    Router(commands::deploy::RouterArgs),
    /// Check one host's role before (or beside) its service: every problem one line with
    /// its fix (exit 1 if any).
    Doctor(commands::doctor::DoctorArgs),
}

/// Log to stderr; `RUST_LOG` overrides `default`. Colour only on a terminal: a journal or a
/// log file would keep the escape codes.
fn init_logging(default: &str) {
    use std::io::IsTerminal as _;
    let filter =
        tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| default.into());
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
}

fn main() -> std::process::ExitCode {
    end_quietly_on_a_closed_pipe();
    let cli = Cli::parse();
    // Experiments and tree tools print tables; per-event logs are noise there.
    let quiet = matches!(
        cli.command,
        Command::Experiment(_)
            | Command::Bt(_)
            | Command::Replay(_)
            | Command::Check(_)
            | Command::Schema(_)
            | Command::Plan(_)
            | Command::Doctor(_)
    );
    init_logging(if quiet { "warn" } else { "info,zenoh=warn" });
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("tokio runtime");
    let result = runtime.block_on(async move {
        match cli.command {
            Command::Demo(a) => commands::demo::run(a).await,
            Command::Sim(a) => commands::sim::run(a).await,
            Command::Scada(a) => commands::scada::run(a).await,
            Command::Coordinator(a) => commands::coordinator::run(a).await,
            Command::Agent(a) => commands::agent::run(a).await,
            Command::Record(a) => commands::record::run(a).await,
            Command::Status(a) => commands::status::run(a).await,
            Command::Goal(c) => commands::goal::run(c).await,
            Command::Console(a) => commands::console::run(a).await,
            Command::Plan(c) => commands::plan::run(c),
            Command::Scenarios => commands::scenarios::list(),
            Command::Pki(c) => commands::pki::run(c),
            Command::Deploy(c) => commands::deploy::run(c),
            Command::Router(a) => commands::deploy::router(a).await,
            Command::Doctor(a) => commands::doctor::run(a).await,
            Command::Bt(c) => commands::bt::run(c),
            Command::Replay(a) => commands::replay::run(a),
            Command::Check(a) => commands::check::run(a),
            Command::Schema(a) => commands::schema::run(a),
            Command::Experiment(c) => commands::experiment::run(c).await,
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

/// A reader that stops reading (`firefleet status | head`) ends this process quietly with
/// the status a shell gives a program a closed pipe stopped (141), instead of a panic on
/// the next `println!`. Not by restoring SIGPIPE's default: then a TLS link whose peer went
/// away (rustls writes with `writev`, which cannot ask for no signal) would kill a role
/// mid-incident; with SIGPIPE ignored, as Rust starts programs, a socket write fails with
/// an error its owner handles, and only printing to a closed stdout ends the process.
fn end_quietly_on_a_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info.payload();
        let message = payload
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| payload.downcast_ref::<&str>().copied())
            .unwrap_or_default();
        if message.starts_with("failed printing to stdout") && message.contains("Broken pipe") {
            std::process::exit(CLOSED_PIPE);
        }
        default(info);
    }));
}

/// The exit status of a program stopped by a closed pipe, as shells report it (128 +
/// SIGPIPE).
const CLOSED_PIPE: i32 = 141;
