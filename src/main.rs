//! `firefleet`: one binary for every role of a tunnel firefighting fleet.
//!
//! `firefleet demo` starts a whole fleet on loopback (simulator, coordinator, one agent per
//! unit, optionally a recorder) as child processes and reports the incident. The other
//! subcommands run one role each and join a Zenoh network given on the command line, so
//! the same binary deploys onto several machines.
//!
//! Each subcommand lives in `commands/` and only parses, calls and prints; beside them is
//! `metrics` (a role's health and Prometheus figures over HTTP). What the binary shares
//! with the lab is this package's library: `firefleet::net` (joining the bus, signals, the
//! status query), `firefleet::children` (the processes a command starts),
//! `firefleet::checking` (a recording through the invariants), `firefleet::args` and
//! `firefleet::cli`.
//!
//! Not here: any role's work (the library crates).

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a CLI prints what a person reads"
)]

mod commands;
mod metrics;

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
    /// Ask that a site identity whose key is stolen be suspended in band (two commanders,
    /// or the operator with the coordinator's identity).
    Suspend(commands::suspend::SuspendArgs),
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

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    // Tree tools and checks print tables; per-event logs are noise there.
    let quiet = matches!(
        cli.command,
        Command::Bt(_)
            | Command::Replay(_)
            | Command::Check(_)
            | Command::Schema(_)
            | Command::Plan(_)
            | Command::Doctor(_)
    );
    firefleet::cli::run(quiet, async move {
        match cli.command {
            Command::Demo(a) => commands::demo::run(a).await,
            Command::Sim(a) => commands::sim::run(a).await,
            Command::Scada(a) => commands::scada::run(a).await,
            Command::Coordinator(a) => commands::coordinator::run(a).await,
            Command::Agent(a) => commands::agent::run(a).await,
            Command::Record(a) => commands::record::run(a).await,
            Command::Status(a) => commands::status::run(a).await,
            Command::Goal(c) => commands::goal::run(c).await,
            Command::Suspend(a) => commands::suspend::run(a).await,
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
        }
    })
}
