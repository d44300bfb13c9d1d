//! `firefleet-lab`: the experiments, attack and load harnesses, the nemesis and the plots
//! that measure firefleet. Built and run by CI; not in the Debian package or on a robot.
//!
//! Each experiment prints a table and can write its results as JSON (`--json`). The
//! harnesses that run real processes (`scale`, `flood`, `nemesis`) start the `firefleet`
//! binary found beside this one (or named by `FIREFLEET_BIN`).
//!
//! Not here: the deterministic fleet loop the experiments share (the library's
//! [`firefleet_lab::fleet`]), or any role's work.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "the lab prints the tables a person reads"
)]

mod experiments;

// Counts the bytes live for the length experiment's memory figures; a relaxed atomic add
// per allocation, nothing the other experiments' figures notice.
#[global_allocator]
static ALLOCATOR: experiments::length::Counting = experiments::length::Counting;

use clap::Parser;

#[derive(Parser)]
#[command(
    name = "firefleet-lab",
    version,
    about = "Measure firefleet: the papers' experiments, load, attacks and network faults"
)]
struct Lab {
    #[command(subcommand)]
    experiment: experiments::Experiment,
}

fn main() -> std::process::ExitCode {
    let lab = Lab::parse();
    // Experiments print tables; per-event logs are noise there.
    firefleet::cli::run(true, experiments::run(lab.experiment))
}
