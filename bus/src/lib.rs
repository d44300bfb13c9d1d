//! The firefleet bus: the one edge between firefleet processes and Zenoh.
//!
//! ```
//! use firefleet_bus::{Bus, Connect, Mode};
//! use firefleet_model::SiteId;
//! use firefleet_protocol::keys::Topic;
//! use firefleet_protocol::msg::SimClock;
//!
//! # #[tokio::main(flavor = "multi_thread", worker_threads = 1)]
//! # async fn main() -> Result<(), firefleet_bus::BusError> {
//! // A peer on its own: it hears its own puts, as every process on a site hears the others'.
//! let connect = Connect { mode: Some(Mode::Peer), ..Connect::default() };
//! let bus = Bus::open(&connect, SiteId::new("tunnel-a").unwrap()).await?;
//! let keys = bus.keys().clone();
//!
//! // Typed: a message goes on its key, validated, and comes back decoded.
//! let clock = bus.subscribe(&keys.sim_clock()).await?;
//! bus.put(&keys.sim_clock(), &SimClock { t: 1.5, time_scale: 4.0 }).await?;
//! let (topic, tick) = clock.recv().await.expect("the bus is open");
//! assert_eq!((topic, tick.t), (Topic::SimClock, 1.5));
//!
//! // A liveliness token says a process is there for as long as it holds it.
//! let coordinators = bus.watch_tokens(&keys.every_coord_alive()).await?;
//! let alive = bus.token(&Topic::CoordAlive(0)).await?;
//! assert_eq!(coordinators.recv().await, Some((Topic::CoordAlive(0), true)));
//! drop(alive);
//! assert_eq!(coordinators.recv().await, Some((Topic::CoordAlive(0), false)));
//! bus.close().await;
//! # Ok(())
//! # }
//! ```
//!
//! A [`Bus`] is a Zenoh session bound to one site: it puts typed, validated messages on
//! their keys and hands back typed inboxes, counting and dropping what does not decode.
//! [`Connect`] says how a role joins the network (mode, endpoints, a config file, the
//! site's TLS identity); besides put and subscribe, a bus declares and watches liveliness
//! tokens, asks and answers questions, reads samples undecoded and deletes
//! (`exchange`). [`goal`] issues and clears commanders' goals. [`access`] derives the
//! router's access rules from the same key table the messages travel on, so what a
//! certificate may touch is derived, not written; [`limits`] bounds how fast and how large
//! a unit may send on its own keys; [`pki`] makes the site's role-bound certificates and
//! checks an identity's files before a link is tried; [`render`] writes the configurations
//! that carry them, the rules and the bounds; [`probe`] opens a link's handshake on its own
//! to see which certificate a router presents and [`hello`] asks whether the routers'
//! rules admit this identity at all (`firefleet doctor`).
//!
//! Not here: the messages and keys themselves (`firefleet-protocol`), or what any role does
//! with them (the role crates). Besides `firefleet-ros2`, this is the only crate that
//! names Zenoh.

pub mod access;
mod bus;
mod connect;
mod exchange;
pub mod goal;
pub mod hello;
pub mod limits;
mod listened;
pub mod office;
pub mod pki;
pub mod probe;
pub mod refusals;
pub mod render;
pub mod seal;
pub mod suspension;

pub use bus::{Bus, BusError, Inbox, RejectCounts, Traffic};
pub use connect::{
    Connect, Links, Mode, free_loopback_port, free_loopback_ports, mtls_link, one_stream,
};
pub use exchange::{
    Answers, Ask, DeclaredKeys, Linked, Question, Questions, Raw, RawInbox, Token, Tokens,
};
pub use listened::listened;
