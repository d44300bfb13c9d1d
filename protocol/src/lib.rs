//! The contract between firefleet processes: what travels between them and how.
//!
//! Message types by direction ([`msg`]), the key expressions they travel on with the one
//! table of which message goes on which key ([`keys`]), and how they are encoded and
//! validated on the way in ([`codec`]); and [`payload`], the one typed decoder a recorder,
//! a console or a checker reads any message of the fleet through, by its key. Robot-to-robot traffic is postcard behind a one-byte
//! protocol version; commander-facing messages (zone goals, the incident status) are JSON
//! so any Zenoh client can speak them.
//!
//! ```
//! use firefleet_model::{SiteId, UnitId};
//! use firefleet_protocol::keys::{self, Keys, Topic};
//!
//! let keys = Keys::new(SiteId::new("tunnel-a").unwrap());
//! let ugv = UnitId::new("ugv-1").unwrap();
//! let state = keys.unit_state(&ugv);
//! assert_eq!(state.as_str(), "ff/tunnel-a/unit/ugv-1/state");
//! // Keys parse back into the topic they were built from: the two cannot drift apart.
//! let (site, topic) = keys::parse(state.as_str()).unwrap();
//! assert_eq!((site.as_str(), topic), ("tunnel-a", Topic::UnitState(ugv)));
//! ```
//!
//! Not here: what a site is (ids, geometry, tunnel, site file, profiles: `firefleet-model`)
//! or how bytes reach the network (`firefleet-bus`). This crate does no I/O and has no
//! Zenoh, so a reader of recordings or a console can decode messages without a transport.

pub mod codec;
pub mod keys;
pub mod msg;
pub mod office;
pub mod payload;
#[cfg(any(test, feature = "testing"))]
pub mod testing;

pub use codec::{CodecError, PROTOCOL_VERSION};
