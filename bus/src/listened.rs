//! Whether anyone on another session subscribes to a key yet: what a publisher that sends
//! once (a test's robot, a one-shot tool) waits for before it sends, as
//! `ros2 topic pub --wait-matching-subscriptions` does.
//!
//! Zenoh sends a sample only along the routes its subscribers' declarations have made;
//! a sample put before a remote subscription's declaration reached this session is lost
//! on the way, not queued. A robot publishing at 10 Hz never notices; a sender of one
//! sample does.
//!
//! Not here: the fleet's own sessions, which publish periodically and never wait
//! ([`crate::Bus`]).

use std::time::Duration;

use zenoh::Session;
use zenoh::sample::Locality;

/// Wait up to `within` until a subscriber on another session (through any router)
/// takes `key` (a key expression; a wildcard waits for any key under it). `Ok(false)` if
/// none did in time.
pub async fn listened(session: &Session, key: &str, within: Duration) -> zenoh::Result<bool> {
    let publisher = session
        .declare_publisher(key.to_owned())
        .allowed_destination(Locality::Remote)
        .await?;
    // The listener first and the status after, so a declaration that arrives between the
    // two is not missed.
    let changes = publisher.matching_listener().await?;
    if publisher.matching_status().await?.matching() {
        return Ok(true);
    }
    let heard = async {
        while let Ok(status) = changes.recv_async().await {
            if status.matching() {
                return true;
            }
        }
        false
    };
    Ok(tokio::time::timeout(within, heard).await.unwrap_or(false))
}
