//! The incident's memory.
//!
//! [`record`](mod@record) writes everything on a site's bus to an MCAP file (JSON messages with their
//! JSON Schemas, liveliness changes, a Foxglove [`scene`] and log), and answers a
//! restarted coordinator's query for the fire tracks it holds. [`reader`] takes the same
//! tracks back from a file, [`replay`] tells a recording's story on site time, all
//! reading the fleet's messages through `firefleet_protocol::payload`.
//! [`live`] serves the same channels over the Foxglove WebSocket protocol while the
//! incident happens.
//!
//! ```
//! use firefleet_recorder::parts::Recording;
//! use firefleet_recorder::replay::timeline;
//!
//! // A recording with nothing in it tells so, in one closing line.
//! let mut told = Vec::new();
//! timeline(&Recording::default(), &mut told).unwrap();
//! let told = String::from_utf8(told).unwrap();
//! assert!(told.starts_with("0 messages, 0 decisions"), "{told}");
//! ```
//!
//! Not here: deciding anything. The recorder never publishes but its answers to recall
//! queries, so a fleet runs the same with or without it.

pub mod budget;
pub mod live;
pub mod parts;
pub mod reader;
pub mod record;
pub mod replay;
pub mod scene;

pub use record::{RecordError, RecordSummary, record};
