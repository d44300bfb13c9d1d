//! A behavior-tree engine faithful to BehaviorTree.CPP v4.
//!
//! Trees are built once (from XML, see the `xml` module, or in code) into a flat arena:
//! nodes in one vector, children as index ranges, every port bound at build time to a
//! literal or a blackboard slot. Ticking walks the arena with enum dispatch and allocates
//! nothing, which is what makes it fast enough to tick a whole robot's tree at kilohertz
//! rates on one core.
//!
//! What it is not: a scheduler. The engine has no threads and no clock of its own; the
//! caller ticks it and passes the time (`Timeout`, `Delay` and `Sleep` run on that clock,
//! so a tree in the simulator runs on simulated time). Leaves get the caller's context
//! (`&mut C`) on every tick; that is how they reach the robot.

pub mod blackboard;
pub mod factory;
pub mod node;
pub mod script;
pub mod status;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tree;
pub mod value;
pub mod xml;

pub use blackboard::{Blackboard, Slot};
pub use factory::{Builder, Category, NodeId, Registry, ScopeId};
pub use node::{Action, Io, Port, PortDir, PortSpec, StatefulAction};
pub use status::Status;
pub use tree::{Transition, Tree};
pub use value::{PortType, Value};
