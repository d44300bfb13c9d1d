//! The incident commander's console: what a commander at the portal looks at and steers
//! the incident from.
//!
//! [`picture`] is the incident as the fleet knows it (unit states, fire tracks, goals,
//! decisions, alerts), built from the bus's messages with no I/O, so what the page shows
//! is testable message by message, with [`infra`] its layer of the tunnel's own DTS and
//! ventilation; [`site`] is the tunnel drawn to scale from the site
//! file; [`auth`] the commanders' logins and [`throttle`] what failing one costs; [`http`]
//! the web page, its API and the stream of
//! changes, over a [`http::Console`] that [`node`] feeds from the bus and that sends goals
//! back through it; [`tls`] serves them over HTTPS.
//!
//! ```
//! use firefleet_console::picture::{Event, Picture};
//! use firefleet_console::site::SiteMap;
//! use firefleet_model::{UnitId, builtin};
//!
//! let site = builtin::resolve("vehicle-collision").unwrap();
//! let mut picture = Picture::new(SiteMap::new(&site));
//! picture.observe(0, Event::CoordinatorAlive(0, true));
//! picture.observe(0, Event::UnitAlive(UnitId::new("ugv-1").unwrap(), true));
//! let incident = picture.incident();
//! assert_eq!(incident.coordinator, Some(true));
//! assert!(incident.units.iter().any(|u| u.id.as_str() == "ugv-1" && u.alive));
//! ```
//!
//! The picture is built from what the fleet says, never from the simulator's truth: with
//! real robots there is no truth to read, and a commander must see what the coordinator
//! decides on.
//!
//! Only [`node`] touches the bus (the same split as the coordinator's `Incident` and
//! `node`): the picture and the HTTP API are tested without one.

pub mod alarm_file;
pub mod audit;
pub mod auth;
pub mod history;
pub mod http;
pub mod infra;
pub mod line_log;
pub mod node;
pub mod picture;
pub mod report;
pub mod site;
pub mod throttle;
pub mod tls;
