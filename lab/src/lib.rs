//! The lab's library: [`fleet::SimFleet`], a whole fleet stepped deterministically in one
//! process (world, unit controllers, the coordinator's incident core), which the lab's
//! experiments and any crate's tests can drive.
//!
//! ```
//! use firefleet_coordinator::assign::Strategy;
//! use firefleet_lab::fleet::{Command, SimFleet};
//!
//! let scenario = firefleet_model::builtin::resolve("vehicle-collision").unwrap();
//! let mut fleet = SimFleet::new(&scenario, Command::Coordinator(Strategy::Optimal), 1, &[]).unwrap();
//! while fleet.time() < 5.0 {
//!     fleet.step().unwrap();
//! }
//! assert!(fleet.violations().is_empty());
//! ```
//!
//! It lives here rather than in `firefleet-sim` (where the design first placed it): a whole
//! fleet needs the agent's controllers and the coordinator's incident, and the agent
//! already builds on the simulator, so the simulator cannot build on the agent. A crate's
//! tests that want it take this crate as a dev-dependency.
//!
//! Not here: the experiments (the `firefleet-lab` binary) or the fleet's processes (the
//! `firefleet` binary's roles).

pub mod fleet;
pub mod tunnels;
