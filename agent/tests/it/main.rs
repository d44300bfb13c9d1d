//! The agent's integration tests, in one test binary: each file of `tests/it/` is a
//! module, sharing one link of the dependencies (the simulator's world among them). The
//! allocation test stays a binary of its own: it installs a counting global allocator.
//!
//! `cargo test -p firefleet-agent --test it closed_loop::` runs one module's tests.

mod aiming;
mod closed_loop;
mod keep_out;
mod monorail;
mod profiles;
mod ros2_thermal;
mod yielding;
