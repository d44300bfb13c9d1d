//! The firefleet world as data: what every process agrees a site *is*, with no transport.
//!
//! Identifiers, the site frame and its geometry, the tunnel and its chainage, the site
//! (scenario) file format and its validation, robot profiles and the specs they carry,
//! how time is read, when two places are one fire, where a carriage sprays from, the tunnel's ventilation and SCADA map,
//! the radiant heat model the planners and the console share, and the file a role keeps
//! its state in across restarts.
//!
//! ```
//! use firefleet_model::{Point2, builtin};
//!
//! let site = builtin::resolve("vehicle-collision").unwrap();
//! assert_eq!(site.site.as_str(), "tunnel-a");
//! // Zones are chainages along the tunnel; in a straight tunnel x is the chainage.
//! let far = site.zones.iter().find(|z| z.id.as_str() == "far").unwrap();
//! let s = site.tunnel.chainage(Point2::new(150.0, 1.0));
//! assert!((far.start_m..=far.end_m).contains(&s));
//! ```
//!
//! Not here: messages, keys and encodings (`firefleet-protocol`), or anything that talks
//! to a network (`firefleet-bus`). This crate has no Zenoh and no tokio, so the pure
//! algorithms (`firefleet-nav`, the coordinator's incident core) build on it alone.

pub mod builtin;
pub mod clock;
pub mod dock;
pub mod fire;
pub mod geometry;
pub mod heat;
pub mod ids;
pub mod infra;
mod names;
pub mod profile;
pub mod scenario;
pub mod spec;
pub mod state_file;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
pub mod tunnel;
pub mod validate;

pub use geometry::{Gaussian2, Point2, Pose2};
pub use ids::{CommanderId, FireId, RouterId, SiteId, UnitId, ZoneId};
pub use spec::UnitKind;
pub use tunnel::Chainage;
pub use validate::{Invalid, Validate};
