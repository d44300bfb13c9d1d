//! What runs on a robot.
//!
//! The pure parts ([`perception`], [`aim`], [`tracker`], [`unit`](mod@unit), [`leaves`], [`ground`],
//! [`monorail`], [`rail`], [`fuzzy`]) know nothing of Zenoh: they take sensor frames and
//! tasks and return actuator set-points, so they are tested and benchmarked without a
//! network. Navigation (grids, planners, the path follower) is its own crate,
//! `firefleet-nav`, which the coordinator shares for its road map. The edges are
//! [`platform`], the interface a robot's hardware drivers implement (implemented here for
//! the simulator), and [`node`], which connects a controller to its platform and to the
//! coordinator.
//!
//! Not here: the coordinator's side of the fleet (`firefleet-coordinator`) or the simulator
//! (`firefleet-sim`).

pub mod aim;
pub mod controller;
pub mod fuzzy;
pub mod ground;
pub mod leaves;
pub mod mission;
pub mod monorail;
pub mod node;
pub mod perception;
pub mod platform;
pub mod rail;
pub mod tracker;
pub mod unit;

pub use controller::{Controller, Services};
pub use node::{AgentOptions, run};
pub use platform::{Platform, SimPlatform};
