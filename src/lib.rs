//! What the `firefleet` binary and the lab's `firefleet-lab` share: how a binary starts and
//! ends (`cli`), argument parsers (`args`), the way onto the bus (`net`), the child
//! processes a command starts (`children`) and a recording judged by the incident's
//! invariants (`checking`).
//!
//! Not here: any command (the binaries' modules) or any role's work (the library crates).

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a CLI prints what a person reads"
)]

pub mod args;
pub mod checking;
pub mod children;
pub mod cli;
pub mod net;
