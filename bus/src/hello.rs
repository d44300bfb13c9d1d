//! A router's hello: whether the site's routers admit an identity at all.
//!
//! Zenoh's access rules deny in silence. A certificate of the site's CA whose name the
//! rules leave nothing (a revoked name, or one issued after the router's rules were
//! rendered) still links over mutual TLS, and then every put, subscription and question
//! of it vanishes at the router: its process looks linked and hears nothing, which is
//! also what a site without a coordinator looks like. So each router answers
//! `router/hello` with its name, and every identity with a part on the site may ask it
//! ([`crate::access`]): an answer means the router's rules admit the asker, silence on a
//! link that is up means they give it nothing.
//!
//! Not here: the handshake itself ([`crate::probe`]), or what to tell the operator
//! (`firefleet doctor`).

use std::time::Duration;

use firefleet_protocol::keys::Topic;

use crate::{Ask, Bus, BusError};

/// Answer `router/hello` with `name` for as long as `bus` is open, from a task of its own.
pub async fn answer(bus: &Bus, name: String) -> Result<(), BusError> {
    let key = bus.keys().expr(&Topic::RouterHello);
    let questions = bus.serve(&key).await?;
    tokio::spawn(async move {
        while let Some(q) = questions.recv().await {
            if let Err(e) = q.answer(&key, name.clone().into_bytes()).await {
                tracing::debug!("a hello went unanswered: {e}");
            }
        }
    });
    Ok(())
}

/// The name of a router that admits this process's identity, if one answers within
/// `within`; `None` if none does (no rules for it, or no router with a hello).
pub async fn admitted_by(bus: &Bus, within: Duration) -> Result<Option<String>, BusError> {
    let key = bus.keys().expr(&Topic::RouterHello);
    let answers = bus.ask(&key, Ask::within(within)).await?;
    Ok(answers
        .recv()
        .await
        .map(|a| String::from_utf8_lossy(&a.bytes).into_owned()))
}
