//! The end-to-end tests of the `firefleet` binary and its processes, in one test binary:
//! each file of `tests/it/` is a module, sharing the harness in `support` and one link of
//! the dependencies (eight binaries took a minute more to build, and ran one after the
//! other where one runs its tests two at a time).
//!
//! `cargo test --test it fleet::` runs one module's tests.

mod cli;
mod console;
mod doctor;
mod fleet;
mod fuzz;
mod groot2;
mod readme;
mod recording;
mod routers;
mod scada;
mod secure;
mod support;
mod units;
