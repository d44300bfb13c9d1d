//! What runs on a robot.
//!
//! The pure parts know nothing of Zenoh: they take sensor frames and tasks and return
//! actuator set-points, so they are tested and benchmarked without a network.
//! [`ground`] is the ground unit (its services, perception, flame tracker, ballistic aim,
//! behavior-tree leaves and tree), [`monorail`] the monorail unit (the ROBOGAT kinematics,
//! fuzzy system, CLIK and planner, its leaves and tree); [`mission`] is the coordinator
//! link both share and [`controller`] what both are to the node. Navigation (grids,
//! planners, the path follower) is its own crate, `firefleet-nav`, which the coordinator
//! shares for its road map. The edges are [`platform`], the interface a robot's hardware
//! drivers implement (implemented here for the simulator and a ROS 2 robot), [`node`],
//! which connects a controller to its platform and to the coordinator, and [`rehome`],
//! a unit's move to a nearer router.
//!
//! ```
//! use std::sync::Arc;
//!
//! use firefleet_agent::ground::GroundController;
//! use firefleet_model::{UnitId, builtin};
//! use firefleet_sim::World;
//!
//! let site = Arc::new(builtin::resolve("vehicle-collision").unwrap());
//! let id = UnitId::new("ugv-1").unwrap();
//! let mut ctl = GroundController::new(id.clone(), site.ground_spec(&id).unwrap(), site.clone());
//! let mut world = World::new(&site, 1);
//! let start = ctl.state().pose.position();
//! // With no coordinator the unit runs its tree alone: it cruises into the tunnel.
//! while world.time() < 10.0 {
//!     world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
//! }
//! assert!(ctl.state().pose.position().dist(start) > 2.0);
//! ```
//!
//! Not here: the coordinator's side of the fleet (`firefleet-coordinator`) or the simulator
//! (`firefleet-sim`).

pub mod btlog;
pub mod controller;
pub mod groot2;
pub mod ground;
pub mod mission;
pub mod monorail;
pub mod node;
pub mod platform;
pub mod rehome;

pub use controller::{Controller, Services};
pub use node::{AgentOptions, DriveError, Ended, drive, run};
pub use platform::{Platform, PlatformError, Ros2Platform, SimPlatform};
