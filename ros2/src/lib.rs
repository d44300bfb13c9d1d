//! firefleet's robots as ROS 2 robots, over rmw_zenoh's conventions and with no bridge.
//!
//! rmw_zenoh (ROS 2's Zenoh middleware) makes every topic a Zenoh key, every node and
//! endpoint a liveliness token and every message a CDR byte string. A firefleet agent that
//! speaks those conventions drives a ROS 2 robot directly, and shows up in `ros2 node
//! list` and `ros2 topic list` on it; the simulator speaks them too, so a fleet runs end to
//! end with nothing firefleet-specific between agent and body.
//!
//! - [`idl`]: the message definitions and their REP-2011 type hashes, computed;
//! - [`msg`] and [`cdr`]: the messages as Rust values, and their wire form;
//! - [`graph`]: key expressions, liveliness tokens, attachments;
//! - [`node`]: a node with typed publishers and subscriptions on a Zenoh session;
//! - [`ground`]: a ground unit's topics, from the robot's side ([`ground::Body`]) and
//!   the agent's ([`ground::Robot`]);
//! - [`monorail`]: a monorail carriage's, the same way ([`monorail::Body`],
//!   [`monorail::Robot`]).
//!
//! ```
//! use firefleet_model::UnitId;
//! use firefleet_ros2::graph::Namespace;
//!
//! // Unit `ugv-1` is the robot in namespace `/ugv_1` (ROS names have no `-`).
//! let ns = Namespace::of_unit(&UnitId::new("ugv-1").unwrap());
//! assert_eq!(ns.to_string(), "/ugv_1");
//! ```
//!
//! Not here: services, actions, parameters, TF, QoS beyond rclcpp's default.

mod assemble;
pub mod cdr;
pub mod graph;
pub mod ground;
pub mod idl;
pub mod monorail;
pub mod msg;
pub mod node;
pub mod thermal;
