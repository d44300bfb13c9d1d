//! The firefleet bus: the one edge between firefleet processes and Zenoh.
//!
//! A [`Bus`] is a Zenoh session bound to one site: it puts typed, validated messages on
//! their keys and hands back typed inboxes, counting and dropping what does not decode.
//! [`Connect`] says how a role joins the network (mode, endpoints, a config file, the
//! site's TLS identity); besides put and subscribe, a bus declares and watches liveliness
//! tokens, asks and answers questions, reads samples undecoded and deletes
//! (`exchange`). [`goal`] issues and clears commanders' goals. [`access`] derives the
//! router's access rules from the same key table the messages travel on, so what a
//! certificate may touch is derived, not written; [`pki`] makes the site's certificates
//! and [`render`] the configurations that carry them and the rules.
//!
//! Not here: the messages and keys themselves (`firefleet-protocol`), or what any role does
//! with them (the role crates). Besides `firefleet-ros2`, this is the only crate that
//! names Zenoh.

pub mod access;
mod bus;
mod exchange;
pub mod goal;
pub mod pki;
pub mod render;

pub use bus::{Bus, BusError, Connect, Inbox, Mode, RejectCounts, free_loopback_port, tls_link};
pub use exchange::{Answers, Ask, Question, Questions, Raw, RawInbox, Token, Tokens};
