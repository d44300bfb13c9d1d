//! The bridge from a tunnel's SCADA to a firefleet site: the linear heat detector's (DTS)
//! zones and the ventilation, read as Modbus TCP input registers by the site file's map
//! (`firefleet_model::infra`) and published, typed and validated, for the coordinator,
//! the console and recorders.
//!
//! [`bridge`] is what the bridge knows, pure: a poll's registers in, the site's messages
//! out, readings it could not renew marked stale and never invented, failures counted by
//! kind. [`node`] is the process on the bus: the Modbus connection, the poll's period and
//! timeout, publishing.
//!
//! ```
//! use firefleet_scada::bridge::{Bridge, Cut, Failure};
//!
//! let site = firefleet_model::builtin::resolve("ventilated").unwrap();
//! let mut bridge = Bridge::new(&site, site.scada.clone().unwrap());
//! let server = "10.0.0.5:502".parse().unwrap();
//! let cut = Failure::Disconnected { server, cut: Cut::Refused };
//! assert!(bridge.poll(1.0, Err(cut))[0].drops_connection());
//! assert!(!bridge.link().up);
//! assert!(bridge.link().problem.contains("refuses the connection: is it running"));
//! assert_eq!(bridge.zones().count(), 0, "a zone never read is never published");
//! ```
//!
//! Not here: the register map and its decoding (`firefleet_model::infra`), what the
//! coordinator makes of the readings (`firefleet_coordinator::incident`), or the
//! simulator's Modbus server (`firefleet_sim::scada`).

pub mod bridge;
pub mod node;
