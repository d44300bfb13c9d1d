//! Typed, validated messages on a Zenoh session.
//!
//! A [`Bus`] is a Zenoh session bound to one site. Publishing encodes a [`Message`] in its
//! wire encoding; an [`Inbox`] decodes and validates what arrives and drops whatever fails,
//! with a logged reason and a count in [`RejectCounts`], so one bad peer cannot crash or
//! confuse a process.
//!
//! Not here: how a session is configured and checked before it opens
//! ([`crate::connect`]).

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::marker::PhantomData;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use zenoh::handlers::FifoChannelHandler;
use zenoh::pubsub::{Publisher, Subscriber};
use zenoh::sample::{Sample, SampleKind};
use zenoh::{Session, Wait};

use firefleet_model::ids::SiteId;
use firefleet_protocol::codec::{self, CodecError};
use firefleet_protocol::keys::{self, Key, Keys, Subscribable, Topic};
use firefleet_protocol::msg::Message;

use crate::connect::{Connect, tls_files};
use crate::pki::PkiError;
use crate::refusals::Refusals;
use crate::seal::Seals;

/// What failed on the bus, by what a caller can do about it: a configuration to fix, an
/// identity to replace, a network Zenoh refused, or a bus that is gone.
#[derive(Debug, thiserror::Error)]
pub enum BusError {
    /// The session's configuration cannot be used: a configuration file, an endpoint, a
    /// link's settings (what, and why).
    #[error("{0}")]
    Config(String),
    /// The TLS identity the session would present can never link.
    #[error("TLS identity: {0}")]
    Identity(#[from] PkiError),
    /// Zenoh refused an operation (opening a session, declaring, putting, querying).
    #[error("zenoh: {0}")]
    Zenoh(String),
    /// Asked to stop before the session joined the network.
    #[error("stopped before joining the Zenoh network")]
    Stopped,
    /// The bus closed under a reader.
    #[error("the bus closed")]
    Closed,
}

impl BusError {
    pub(crate) fn from_zenoh(e: impl std::fmt::Display) -> Self {
        Self::Zenoh(e.to_string())
    }
}

impl From<zenoh::Error> for BusError {
    fn from(e: zenoh::Error) -> Self {
        Self::from_zenoh(e)
    }
}

/// Messages this session put and took (valid ones; what was refused is counted in
/// [`RejectCounts`]): for a role's `/metrics`.
#[derive(Debug, Default)]
pub struct Traffic {
    sent: AtomicU64,
    received: AtomicU64,
}

impl Traffic {
    pub fn sent(&self) -> u64 {
        self.sent.load(Ordering::Relaxed)
    }
    pub fn received(&self) -> u64 {
        self.received.load(Ordering::Relaxed)
    }
}

/// Counts of messages dropped on receipt, by failure class, and their log: counted
/// summaries per sender and class ([`crate::refusals`]), never a line per message.
#[derive(Debug, Default)]
pub struct RejectCounts {
    undecodable: AtomicU64,
    version: AtomicU64,
    invalid: AtomicU64,
    /// A goal or clear whose seal is missing, does not hold, is stale or is a replay.
    seal: AtomicU64,
    /// Taken off the bus but dropped: the reader was behind ([`crate::RawInbox`]).
    overflow: AtomicU64,
    log: Mutex<Refusals>,
    /// The keys last heard in another protocol version: which version, and when.
    versions: Mutex<HashMap<String, (u8, std::time::Instant)>>,
}

impl RejectCounts {
    /// Count and log a message from `from` (the key it came on, or what sent it) that
    /// did not decode.
    pub fn refuse(&self, from: &str, e: &CodecError) {
        self.count(e);
        if let CodecError::Version { got } = e {
            self.versions
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner)
                .insert(from.to_owned(), (*got, std::time::Instant::now()));
        }
        self.log(from, e.class(), e);
    }
    /// The keys heard in another protocol version within `recent`, and the version each
    /// spoke last: a unit of another release (a rolling upgrade half done) is shown as
    /// such, not as lost. A key heard in this version again drops out once `recent` passes.
    pub fn other_versions(&self, recent: Duration) -> Vec<(String, u8)> {
        let mut versions = self
            .versions
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        versions.retain(|_, (_, at)| at.elapsed() <= recent);
        let mut out: Vec<(String, u8)> =
            versions.iter().map(|(k, (v, _))| (k.clone(), *v)).collect();
        out.sort();
        out
    }
    /// Count and log a message from `from` that decoded but its receiver refused.
    pub fn refuse_invalid(&self, from: &str, reason: &dyn std::fmt::Display) {
        self.count_invalid();
        self.log(from, "invalid", reason);
    }
    /// Count and log a message from `from` whose seal was refused (missing, not holding,
    /// stale, a replay).
    pub fn refuse_seal(&self, from: &str, reason: &dyn std::fmt::Display) {
        self.count_seal();
        self.log(from, "seal", reason);
    }
    /// Count and log a message from `from` dropped because its reader was behind.
    pub fn refuse_overflow(&self, from: &str) {
        self.count_overflow();
        self.log(from, "overflow", &"the reader was behind");
    }
    fn log(&self, from: &str, class: &'static str, reason: &dyn std::fmt::Display) {
        let line = self
            .log
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .note(from, class, reason, std::time::Instant::now());
        if let Some(line) = line {
            tracing::warn!("{line}");
        }
    }
    /// Count a message that did not decode, by why.
    pub fn count(&self, e: &CodecError) {
        let c = match e.class() {
            "version" => &self.version,
            "invalid" => &self.invalid,
            _ => &self.undecodable,
        };
        c.fetch_add(1, Ordering::Relaxed);
    }
    /// Count a message that decoded but was refused by its receiver (unknown unit, outside
    /// the tunnel, ...).
    pub fn count_invalid(&self) {
        self.invalid.fetch_add(1, Ordering::Relaxed);
    }
    /// Count a message whose seal was refused, logged by the caller.
    pub fn count_seal(&self) {
        self.seal.fetch_add(1, Ordering::Relaxed);
    }
    /// Count a message dropped because its reader was behind.
    pub fn count_overflow(&self) {
        self.overflow.fetch_add(1, Ordering::Relaxed);
    }
    /// Messages dropped because their reader was behind.
    pub fn overflow(&self) -> u64 {
        self.overflow.load(Ordering::Relaxed)
    }
    pub fn total(&self) -> u64 {
        self.snapshot().iter().map(|(_, n)| n).sum()
    }
    /// `(class, count)` pairs, for status reports.
    pub fn snapshot(&self) -> [(&'static str, u64); 5] {
        [
            ("undecodable", self.undecodable.load(Ordering::Relaxed)),
            ("version", self.version.load(Ordering::Relaxed)),
            ("invalid", self.invalid.load(Ordering::Relaxed)),
            ("seal", self.seal.load(Ordering::Relaxed)),
            ("overflow", self.overflow.load(Ordering::Relaxed)),
        ]
    }
}

/// A Zenoh session serving one site.
#[derive(Clone)]
pub struct Bus {
    session: Session,
    keys: Keys,
    rejects: Arc<RejectCounts>,
    traffic: Arc<Traffic>,
    /// A declared publisher per key put on: a put on an undeclared key makes Zenoh match
    /// the key against every resource it knows, each time (with a thousand units, about
    /// half of a coordinator's CPU); a declared one keeps its route. Keys are few
    /// (a unit's topics, a fire's track, a zone's ack), so the map stays small.
    publishers: Arc<Mutex<HashMap<String, Publisher<'static>>>>,
    /// With a TLS identity: its key to seal with and its CA to check seals.
    seals: Option<Arc<Seals>>,
    /// The session routes (Zenoh's router mode): it has an admin space of its own.
    routes: bool,
}

impl Bus {
    pub async fn open(connect: &Connect, site: SiteId) -> Result<Self, BusError> {
        let config = connect.to_config()?;
        let seals = match tls_files(&config) {
            Some(files) => Some(Arc::new(Seals::load(&files)?)),
            None => None,
        };
        let routes = crate::connect::routes(&config);
        let session = zenoh::open(config).await.map_err(BusError::from_zenoh)?;
        Ok(Self {
            session,
            keys: Keys::new(site),
            rejects: Arc::default(),
            traffic: Arc::default(),
            publishers: Arc::default(),
            seals,
            routes,
        })
    }

    /// This session's seals: none on a plain link (a site without a PKI trusts whoever
    /// is on its bus, and nothing is sealed).
    pub fn seals(&self) -> Option<&Seals> {
        self.seals.as_deref()
    }

    /// Join the network for a role that runs until stopped (agent, coordinator, recorder,
    /// simulator): a client whose router does not answer yet (a robot powered up before
    /// the site's network) waits and tries again, saying so each time, until it joins or
    /// `stop` completes; a peer that reaches none of its endpoints says so loudly (Zenoh
    /// opens a peer anyway and keeps trying in the background). A configuration that can
    /// never work (a bad endpoint, a missing certificate) fails at once.
    pub async fn join(
        connect: &Connect,
        site: SiteId,
        stop: impl std::future::Future<Output = ()>,
    ) -> Result<Self, BusError> {
        let config = connect.to_config()?;
        tokio::pin!(stop);
        let mut failed = 0u32;
        let bus = loop {
            match Self::open(connect, site.clone()).await {
                Ok(bus) => break bus,
                Err(e) => {
                    failed += 1;
                    let wait = join_backoff(failed);
                    tracing::warn!(
                        "cannot join the Zenoh network ({e}); attempt {failed}, trying again in {:.1} s",
                        wait.as_secs_f64()
                    );
                    tokio::select! {
                        _ = tokio::time::sleep(wait) => {}
                        _ = &mut stop => {
                            return Err(BusError::Stopped);
                        }
                    }
                }
            }
        };
        if failed > 0 {
            tracing::info!("joined the Zenoh network after {failed} failed attempts");
        }
        let json = |key: &str| -> serde_json::Value {
            config
                .get_json(key)
                .ok()
                .and_then(|j| serde_json::from_str(&j).ok())
                .unwrap_or_default()
        };
        let peer = json("mode").as_str().is_none_or(|m| m == "peer");
        // A list, or one list per mode.
        let endpoints = match json("connect/endpoints") {
            serde_json::Value::Array(list) => !list.is_empty(),
            serde_json::Value::Object(per_mode) => per_mode
                .get("peer")
                .and_then(|l| l.as_array())
                .is_some_and(|l| !l.is_empty()),
            _ => false,
        };
        if peer && endpoints {
            // A peer's links come up in the background: give them a moment.
            tokio::time::sleep(std::time::Duration::from_millis(500)).await;
            if !bus.connected().await {
                tracing::error!(
                    "reached none of {:?}: running alone until one answers (Zenoh keeps trying)",
                    connect.connect
                );
            }
        }
        Ok(bus)
    }

    pub fn keys(&self) -> &Keys {
        &self.keys
    }
    /// Whether the session routes (Zenoh's router mode).
    pub(crate) fn routes(&self) -> bool {
        self.routes
    }

    /// The session, for this crate's own edges ([`crate::exchange`]).
    pub(crate) fn zenoh(&self) -> &Session {
        &self.session
    }

    /// The Zenoh session itself: for the other Zenoh edge (`firefleet-ros2` speaks
    /// rmw_zenoh's keys and types on it, not the site's) and for tests that play an
    /// attacker, who does what no role does. Roles use the typed methods.
    pub fn zenoh_session(&self) -> &Session {
        &self.session
    }
    pub fn rejects(&self) -> &Arc<RejectCounts> {
        &self.rejects
    }
    /// Messages put and taken by this session.
    pub fn traffic(&self) -> &Arc<Traffic> {
        &self.traffic
    }

    /// Publish `m` on `key`.
    pub async fn put<M: Message>(&self, key: &Key<M>, m: &M) -> Result<(), BusError> {
        self.publish(key.as_str(), codec::encode(m), None)
    }

    /// Publish `m` on `key` with this process's seal in the attachment on a secure site
    /// (as [`Bus::put`] on an open one): for a message that others pass on and whose
    /// reader must be able to tell who put it, as recorders answer a coordinator's recall
    /// with the fire tracks the one before it published.
    pub async fn put_sealed_by_me<M: Message>(&self, key: &Key<M>, m: &M) -> Result<(), BusError> {
        let bytes = codec::encode(m);
        let seal = self.seal_of(key.as_str(), &bytes);
        self.publish(key.as_str(), bytes, seal)
    }

    /// This process's seal of `bytes` on `key`, as an attachment; none on an open site.
    pub(crate) fn seal_of(&self, key: &str, bytes: &[u8]) -> Option<Vec<u8>> {
        self.seals()
            .map(|s| s.sealer.seal(key, Some(bytes)).to_attachment())
    }

    /// Put `bytes` (and an `attachment`) on `key` through its declared publisher, counted.
    /// Zenoh's blocking calls, so that the map is not locked across an await: a put with
    /// the default congestion control (drop) never waits.
    fn publish(
        &self,
        key: &str,
        bytes: Vec<u8>,
        attachment: Option<Vec<u8>>,
    ) -> Result<(), BusError> {
        let mut publishers = self.publishers.lock().expect("not poisoned");
        self.publisher(&mut publishers, key)?
            .put(bytes)
            .attachment(attachment)
            .wait()
            .map_err(BusError::from_zenoh)?;
        self.traffic.sent.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// Declare the publisher of `key` now rather than at its first put: for a key whose
    /// first message is one somebody waits for (a unit's first flame report, the first
    /// task to a unit). Declaring is not free: a router matches the new key against every
    /// resource it holds (about 0.4 ms with a thousand units' keys), on the path of that
    /// first message if it is declared then.
    pub async fn declare<M: Message>(&self, key: &Key<M>) -> Result<(), BusError> {
        let mut publishers = self.publishers.lock().expect("not poisoned");
        self.publisher(&mut publishers, key.as_str()).map(|_| ())
    }

    /// `key`'s publisher, declared if it is not yet.
    fn publisher<'a>(
        &self,
        publishers: &'a mut HashMap<String, Publisher<'static>>,
        key: &str,
    ) -> Result<&'a Publisher<'static>, BusError> {
        Ok(match publishers.entry(key.to_owned()) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => e.insert(
                self.session
                    .declare_publisher(key.to_owned())
                    .wait()
                    .map_err(BusError::from_zenoh)?,
            ),
        })
    }

    /// Subscribe to `key` (one key or a pattern), decoding `M`.
    pub async fn subscribe<M: Message>(
        &self,
        key: &impl Subscribable<M>,
    ) -> Result<Inbox<M>, BusError> {
        self.subscribe_with_capacity(key, DEFAULT_INBOX).await
    }

    /// Like [`Bus::subscribe`], with room for `capacity` messages. When an inbox is full,
    /// Zenoh's receiving task waits for room, and every other subscription of the session
    /// waits with it: a high-rate stream (every unit's state) gets room for a burst.
    pub async fn subscribe_with_capacity<M: Message>(
        &self,
        key: &impl Subscribable<M>,
        capacity: usize,
    ) -> Result<Inbox<M>, BusError> {
        let sub = self
            .session
            .declare_subscriber(key.key_expr().to_owned())
            .with(zenoh::handlers::FifoChannel::new(capacity))
            .await
            .map_err(BusError::from_zenoh)?;
        Ok(Inbox {
            sub,
            rejects: self.rejects.clone(),
            traffic: self.traffic.clone(),
            _m: PhantomData,
        })
    }

    /// Close the session, waiting [`CLOSE_WAIT`] at most: a router's QUIC links whose
    /// clients have left can hold Zenoh's close for its whole ten-second timeout and an
    /// ERROR line (eclipse-zenoh/zenoh#1267), on the way out of a process that no longer
    /// needs them.
    pub async fn close(self) {
        match tokio::time::timeout(CLOSE_WAIT, self.session.close()).await {
            Ok(Ok(())) => {}
            Ok(Err(e)) => tracing::debug!("closing zenoh session: {e}"),
            Err(_) => {
                tracing::debug!("closing zenoh session: gave up after {CLOSE_WAIT:?}");
                // Dropped, the session would close itself again, blocking the whole ten
                // seconds (Zenoh's timeout on a close is not public in 1.10): it is left
                // to the process's exit instead.
                std::mem::forget(self);
            }
        }
    }
}

/// How long [`Bus::close`] waits for Zenoh to close the session.
const CLOSE_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// The wait before attempt `n + 1` to join (`n` failed so far): half a second, doubling,
/// at most [`JOIN_RETRY_MAX`].
fn join_backoff(failed: u32) -> std::time::Duration {
    (std::time::Duration::from_millis(500) * 2u32.saturating_pow(failed.saturating_sub(1)))
        .min(JOIN_RETRY_MAX)
}

/// The longest wait between two attempts to join: a robot powered up before the site's
/// router is up should be on the bus within seconds of it.
const JOIN_RETRY_MAX: std::time::Duration = std::time::Duration::from_secs(8);

/// Zenoh's default inbox size.
const DEFAULT_INBOX: usize = 256;

/// Validated messages of one type arriving on a subscription.
pub struct Inbox<M> {
    sub: Subscriber<FifoChannelHandler<Sample>>,
    rejects: Arc<RejectCounts>,
    traffic: Arc<Traffic>,
    _m: PhantomData<fn() -> M>,
}

impl<M: Message> Inbox<M> {
    /// The next valid message and the topic it came on; `None` once the session is closed.
    pub async fn recv(&self) -> Option<(Topic, M)> {
        loop {
            let sample = self.sub.recv_async().await.ok()?;
            if let Some(m) = self.accept(&sample) {
                return Some(m);
            }
        }
    }

    /// A message already waiting, without blocking.
    pub fn try_recv(&self) -> Option<(Topic, M)> {
        while let Ok(Some(sample)) = self.sub.try_recv() {
            if let Some(m) = self.accept(&sample) {
                return Some(m);
            }
        }
        None
    }

    fn accept(&self, sample: &Sample) -> Option<(Topic, M)> {
        if sample.kind() == SampleKind::Delete {
            return None;
        }
        let key = sample.key_expr().as_str();
        let topic = match keys::parse(key) {
            Ok((_, topic)) => topic,
            Err(e) => {
                self.rejects.refuse_invalid(key, &e);
                return None;
            }
        };
        match codec::decode::<M>(&sample.payload().to_bytes()) {
            Ok(m) => {
                self.traffic.received.fetch_add(1, Ordering::Relaxed);
                Some((topic, m))
            }
            Err(e) => {
                self.rejects.refuse(key, &e);
                None
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn joining_backs_off_to_a_ceiling() {
        let waits: Vec<u64> = (1..=6)
            .map(|n| join_backoff(n).as_millis() as u64)
            .collect();
        assert_eq!(waits, [500, 1000, 2000, 4000, 8000, 8000]);
    }
}
