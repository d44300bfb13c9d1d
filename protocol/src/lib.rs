//! The contract between firefleet processes.
//!
//! Everything two processes must agree on lives here and nowhere else: identifiers,
//! message types, the key expressions they travel on, how they are encoded, what makes a
//! message valid, the scenario (site) file format, and how time is read.
//!
//! What this crate does not do: decide anything. It has no fleet logic; the simulator,
//! the agents and the coordinator are built on top of it. The only I/O it owns is the thin
//! [`bus`] wrapper that puts typed, validated messages on a Zenoh session.
//!
//! Encoding: robot-to-robot traffic is postcard behind a one-byte protocol version
//! ([`codec`]); commander-facing messages (zone goals, the incident status) are JSON so any
//! Zenoh client can speak them.

pub mod access;
pub mod bus;
pub mod clock;
pub mod codec;
pub mod geometry;
pub mod ids;
pub mod keys;
pub mod msg;
pub mod profile;
pub mod scenario;
pub mod spec;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tunnel;
pub mod validate;

pub use codec::{CodecError, PROTOCOL_VERSION};
pub use geometry::{Gaussian2, Point2, Pose2};
pub use ids::{CommanderId, FireId, SiteId, UnitId, ZoneId};
pub use tunnel::Chainage;
pub use validate::{Invalid, Validate};
