//! A behavior-tree engine faithful to BehaviorTree.CPP v4.
//!
//! ```
//! use firefleet_bt::node::Io;
//! use firefleet_bt::{Leaf, Port, Registry, Status, xml};
//!
//! /// What the leaves act on: here, how much water is left.
//! struct Robot {
//!     water_l: f64,
//! }
//!
//! const LITRES: Port<f64> = Port::input("litres", "water one spray takes");
//!
//! let mut leaves = Registry::<Robot>::new();
//! leaves.register("HasWater", vec![], Leaf::condition(|| {
//!     |_: &mut Io<'_>, r: &mut Robot| {
//!         if r.water_l > 0.0 { Status::Success } else { Status::Failure }
//!     }
//! }));
//! leaves.register("Spray", vec![LITRES.spec()], Leaf::action(|| {
//!     |io: &mut Io<'_>, r: &mut Robot| {
//!         r.water_l -= io.get(&LITRES).unwrap_or(0.0);
//!         Status::Success
//!     }
//! }));
//! let doc = xml::parse_str(
//!     r#"<root BTCPP_format="4"><BehaviorTree ID="Main">
//!          <Sequence><HasWater/><Spray litres="40"/></Sequence>
//!        </BehaviorTree></root>"#,
//!     "example.xml",
//! )
//! .unwrap();
//! let mut tree = xml::build(&doc, &leaves).unwrap();
//! let mut robot = Robot { water_l: 50.0 };
//! // The caller ticks and passes the time; the tree has no clock of its own.
//! assert_eq!(tree.tick(0.0, &mut robot), Status::Success);
//! assert_eq!(tree.tick(0.1, &mut robot), Status::Success);
//! assert_eq!(tree.tick(0.2, &mut robot), Status::Failure, "the tank ran dry");
//! ```
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
pub mod error;
pub mod factory;
pub mod groot2;
pub mod node;
pub mod script;
pub mod status;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tree;
pub mod value;
pub mod xml;

pub use blackboard::{Blackboard, Slot};
pub use error::{BlackboardError, BuildError, LiteralError, ScriptError};
pub use factory::{Builder, Category, Leaf, NodeId, Registry, ScopeId};
pub use node::{Action, Io, Port, PortDir, PortSpec, StatefulAction};
pub use status::Status;
pub use tree::{Transition, Tree};
pub use value::{PortType, Value};
