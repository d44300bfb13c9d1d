//! Typed, validated messages on a Zenoh session.
//!
//! A [`Bus`] is a Zenoh session bound to one site. Publishing encodes a [`Message`] in its
//! wire encoding; an [`Inbox`] decodes and validates what arrives and drops whatever fails,
//! with a logged reason and a count in [`RejectCounts`], so one bad peer cannot crash or
//! confuse a process.
//!
//! [`Connect`] turns the usual command-line choices (a zenoh JSON5 config file, or
//! `--mode/--connect/--listen`) into a Zenoh configuration. Multicast scouting is off unless
//! a config file turns it on: fleets find each other through configured endpoints, so two
//! fleets on one machine (parallel CI jobs) never cross-talk.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::marker::PhantomData;
use std::path::PathBuf;
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

use crate::access::Role;
use crate::pki::{self, Expect, PkiError};
use crate::refusals::Refusals;

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
    fn from_zenoh(e: impl std::fmt::Display) -> Self {
        Self::Zenoh(e.to_string())
    }
}

impl From<zenoh::Error> for BusError {
    fn from(e: zenoh::Error) -> Self {
        Self::from_zenoh(e)
    }
}

/// A Zenoh session's role.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Peer,
    Client,
    Router,
}

impl Mode {
    fn as_str(self) -> &'static str {
        match self {
            Mode::Peer => "peer",
            Mode::Client => "client",
            Mode::Router => "router",
        }
    }
}

/// How to join the Zenoh network.
#[derive(Debug, Clone, Default)]
pub struct Connect {
    /// A zenoh configuration file (JSON5); the other fields then override it.
    pub config_file: Option<PathBuf>,
    /// Default: the config file's, else peer.
    pub mode: Option<Mode>,
    /// Endpoints to connect to, e.g. `tcp/127.0.0.1:7447`.
    pub connect: Vec<String>,
    /// Endpoints to listen on.
    pub listen: Vec<String>,
    /// Mutual TLS with this identity: a directory holding the site CA (`ca.pem`) and the
    /// identity's certificate and key (`cert.pem`, `key.pem`), as `firefleet pki` writes
    /// them. Every link is then QUIC with mutual TLS, and any other endpoint is refused.
    pub tls: Option<PathBuf>,
    /// Who this process must be: with a TLS identity (from `tls` or the config file),
    /// files of another identity, or ones that can never link (expired, another site's,
    /// a key not its certificate's), are refused before anything is tried.
    pub expect: Option<Expect>,
}

impl Connect {
    /// Build the Zenoh configuration.
    pub fn to_config(&self) -> Result<zenoh::Config, BusError> {
        let config = self.build()?;
        self.check_identity(&config)?;
        Ok(config)
    }

    /// What the configuration says of this process's links, before its identity is
    /// checked: for `firefleet doctor`, which names every problem rather than the first.
    pub fn links(&self) -> Result<Links, BusError> {
        let config = self.build()?;
        let endpoints = |field: &str| -> Vec<String> {
            config
                .get_json(field)
                .ok()
                .and_then(|s| serde_json::from_str::<Vec<String>>(&s).ok())
                .unwrap_or_default()
        };
        Ok(Links {
            router: config.get_json("mode").is_ok_and(|m| m.contains("router")),
            tls: tls_files(&config),
            connect: endpoints("connect/endpoints"),
            listen: endpoints("listen/endpoints"),
        })
    }

    fn build(&self) -> Result<zenoh::Config, BusError> {
        let mut config = match &self.config_file {
            Some(path) => zenoh::Config::from_file(path)
                .map_err(|e| BusError::Config(format!("config file {}: {e}", path.display())))?,
            None => {
                let mut c = zenoh::Config::default();
                c.insert_json5("scouting/multicast/enabled", "false")
                    .map_err(BusError::from_zenoh)?;
                c
            }
        };
        if let Some(mode) = self.mode {
            config
                .insert_json5("mode", &json_string(mode.as_str()))
                .map_err(BusError::from_zenoh)?;
        }
        let list = |v: &[String]| {
            format!(
                "[{}]",
                v.iter()
                    .map(|s| json_string(s))
                    .collect::<Vec<_>>()
                    .join(",")
            )
        };
        if let Some(e) = self
            .connect
            .iter()
            .chain(&self.listen)
            .find(|e| e.starts_with("tls/"))
        {
            return Err(BusError::Config(format!(
                "endpoint '{e}': secure links are quic/HOST:PORT (Zenoh's TLS link can \
                 corrupt its stream under load, eclipse-zenoh/zenoh#2557)"
            )));
        }
        if let Some(dir) = &self.tls {
            for e in self.connect.iter().chain(&self.listen) {
                if !e.starts_with("quic/") {
                    return Err(BusError::Config(format!(
                        "endpoint '{e}' is not QUIC: with a TLS identity ({}) every link is quic/...",
                        dir.display()
                    )));
                }
            }
            let serde_json::Value::Object(fields) = mtls_link(dir) else {
                unreachable!("mtls_link is an object")
            };
            for (field, value) in fields {
                config
                    .insert_json5(&format!("transport/link/tls/{field}"), &value.to_string())
                    .map_err(|e| BusError::Config(format!("TLS {field}: {e}")))?;
            }
        }
        let connect: Vec<String> = self.connect.iter().map(|e| one_stream(e)).collect();
        let listen: Vec<String> = self.listen.iter().map(|e| one_stream(e)).collect();
        if !connect.is_empty() {
            config
                .insert_json5("connect/endpoints", &list(&connect))
                .map_err(|e| BusError::Config(format!("--connect: {e}")))?;
        }
        if !listen.is_empty() {
            config
                .insert_json5("listen/endpoints", &list(&listen))
                .map_err(|e| BusError::Config(format!("--listen: {e}")))?;
        }
        Ok(config)
    }

    /// The identity this session would present on the site, checked as
    /// [`Connect::to_config`] checks it; none without a TLS identity (a plain link).
    pub fn identity(&self) -> Result<Option<crate::access::Identity>, BusError> {
        let config = self.to_config()?;
        let Some(files) = tls_files(&config) else {
            return Ok(None);
        };
        Ok(Some(pki::check(&files, None)?))
    }

    /// Refuse, with the file and the reason, a TLS identity that can never link: what
    /// `config` will present (the listening certificate for a router, else the
    /// connecting one).
    fn check_identity(&self, config: &zenoh::Config) -> Result<(), BusError> {
        let router = config.get_json("mode").is_ok_and(|m| m.contains("router"));
        let Some(files) = tls_files(config) else {
            return if quic_endpoints(config) {
                Err(BusError::Config(
                    "a QUIC link needs a TLS identity: --tls-dir, or a configuration from firefleet deploy render".into(),
                ))
            } else {
                Ok(())
            };
        };
        // A process that routes serves the others' links: whatever role it runs, it holds a
        // router's certificate (the scale experiment's coordinator is its own router).
        let expect = if router {
            Some(Expect::Role(Role::Router))
        } else {
            self.expect.clone()
        };
        pki::check(&files, expect.as_ref())?;
        Ok(())
    }
}

/// A process's links as its configuration says ([`Connect::links`]).
#[derive(Debug, Clone)]
pub struct Links {
    /// It runs as a router.
    pub router: bool,
    /// The identity it presents (the listening one for a router), if complete.
    pub tls: Option<pki::TlsFiles>,
    pub connect: Vec<String>,
    pub listen: Vec<String>,
}

/// The TLS files `config` presents: the listening certificate for a router, else the
/// connecting one; none if it names no complete identity.
fn tls_files(config: &zenoh::Config) -> Option<pki::TlsFiles> {
    let get = |field: &str| -> Option<PathBuf> {
        config
            .get_json(&format!("transport/link/tls/{field}"))
            .ok()
            .and_then(|s| serde_json::from_str::<Option<String>>(&s).ok().flatten())
            .map(PathBuf::from)
    };
    let router = config.get_json("mode").is_ok_and(|m| m.contains("router"));
    let (cert, key) = if router {
        ("listen_certificate", "listen_private_key")
    } else {
        ("connect_certificate", "connect_private_key")
    };
    Some(pki::TlsFiles {
        ca: get("root_ca_certificate")?,
        cert: get(cert)?,
        key: get(key)?,
    })
}

fn quic_endpoints(config: &zenoh::Config) -> bool {
    ["connect/endpoints", "listen/endpoints"]
        .iter()
        .filter_map(|f| config.get_json(f).ok())
        .any(|s| s.contains("quic/"))
}

/// Zenoh's `transport/link/tls` section (which its QUIC link reads) for mutual TLS as the
/// identity whose PKI directory (`ca.pem`, `cert.pem`, `key.pem`, as `firefleet pki` writes
/// them) is `dir`: the same certificate to listen and to connect, peers verified against
/// the site CA both ways, a router also by the name it is reached at, and a link closed
/// when a certificate on it expires.
pub fn mtls_link(dir: &std::path::Path) -> serde_json::Value {
    let file = |name: &str| dir.join(name).display().to_string();
    serde_json::json!({
        "root_ca_certificate": file("ca.pem"),
        "listen_certificate": file("cert.pem"),
        "listen_private_key": file("key.pem"),
        "connect_certificate": file("cert.pem"),
        "connect_private_key": file("key.pem"),
        "enable_mtls": true,
        "verify_name_on_connect": true,
        "close_link_on_expiration": true,
    })
}

/// `endpoint` as our QUIC links use it: one stream for every priority
/// (`multistream=0`) unless the endpoint says otherwise. With a stream per priority, which
/// Zenoh 1.10 opens by default, QUIC delivers the streams in no order among each other:
/// a key's declaration could arrive after the first data sent on it, which the router
/// then drops ("Received Data for unknown expr_id", "Unknown subscriber" in its log,
/// seen in 2 of 7 secure demos and in none of 6 on one stream). Other endpoints are
/// returned as they are.
pub fn one_stream(endpoint: &str) -> String {
    if !endpoint.starts_with("quic/") || endpoint.contains("multistream=") {
        return endpoint.to_owned();
    }
    // Metadata follows `?`, entries separated by `;`; configuration follows `#`.
    let (address, config) = match endpoint.split_once('#') {
        Some((a, c)) => (a, format!("#{c}")),
        None => (endpoint, String::new()),
    };
    let sep = if address.contains('?') { ';' } else { '?' };
    format!("{address}{sep}multistream=0{config}")
}

/// A port on 127.0.0.1 that nothing uses right now over TCP or UDP, for a loopback
/// fleet's router on `tcp/` or `quic/` (the OS hands out a free one; another process could
/// take it before we bind it, which on a test machine does not happen in practice).
pub fn free_loopback_port() -> std::io::Result<u16> {
    for _ in 0..64 {
        let tcp = std::net::TcpListener::bind("127.0.0.1:0")?;
        let port = tcp.local_addr()?.port();
        if std::net::UdpSocket::bind(("127.0.0.1", port)).is_ok() {
            return Ok(port);
        }
    }
    Err(std::io::Error::other("no port free for both TCP and UDP"))
}

fn json_string(s: &str) -> String {
    serde_json::Value::String(s.to_owned()).to_string()
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
    pub fn snapshot(&self) -> [(&'static str, u64); 4] {
        [
            ("undecodable", self.undecodable.load(Ordering::Relaxed)),
            ("version", self.version.load(Ordering::Relaxed)),
            ("invalid", self.invalid.load(Ordering::Relaxed)),
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
}

impl Bus {
    pub async fn open(connect: &Connect, site: SiteId) -> Result<Self, BusError> {
        let session = zenoh::open(connect.to_config()?)
            .await
            .map_err(BusError::from_zenoh)?;
        Ok(Self {
            session,
            keys: Keys::new(site),
            rejects: Arc::default(),
            traffic: Arc::default(),
            publishers: Arc::default(),
        })
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
        let key = key.as_str();
        let bytes = codec::encode(m);
        // Zenoh's blocking calls, so that the map is not locked across an await: a put
        // with the default congestion control (drop) never waits, and declaring a
        // publisher is a local table update.
        let mut publishers = self.publishers.lock().expect("not poisoned");
        let publisher = match publishers.entry(key.to_owned()) {
            Entry::Occupied(e) => e.into_mut(),
            Entry::Vacant(e) => e.insert(
                self.session
                    .declare_publisher(key.to_owned())
                    .wait()
                    .map_err(BusError::from_zenoh)?,
            ),
        };
        publisher.put(bytes).wait().map_err(BusError::from_zenoh)?;
        self.traffic.sent.fetch_add(1, Ordering::Relaxed);
        Ok(())
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

    #[test]
    fn quic_endpoints_get_one_stream() {
        assert_eq!(one_stream("quic/h:1"), "quic/h:1?multistream=0");
        assert_eq!(one_stream("quic/h:1?a=b"), "quic/h:1?a=b;multistream=0");
        assert_eq!(one_stream("quic/h:1#x=1"), "quic/h:1?multistream=0#x=1");
        assert_eq!(
            one_stream("quic/h:1?multistream=1"),
            "quic/h:1?multistream=1"
        );
        assert_eq!(one_stream("tcp/h:1"), "tcp/h:1");
        // Zenoh reads what it makes.
        let c = Connect {
            mode: Some(Mode::Client),
            connect: vec![one_stream("quic/127.0.0.1:7447#x=1")],
            ..Connect::default()
        };
        let config = c.to_config().unwrap_err();
        assert!(
            config.to_string().contains("needs a TLS identity"),
            "{config}"
        );
    }

    #[test]
    fn connect_options_become_zenoh_config() {
        let c = Connect {
            mode: Some(Mode::Client),
            connect: vec!["tcp/127.0.0.1:7447".into()],
            ..Default::default()
        };
        let cfg = c.to_config().unwrap();
        assert_eq!(cfg.get_json("mode").unwrap(), "\"client\"");
        assert!(
            cfg.get_json("connect/endpoints")
                .unwrap()
                .contains("127.0.0.1:7447")
        );
        assert_eq!(cfg.get_json("scouting/multicast/enabled").unwrap(), "false");
    }

    #[test]
    fn shipped_deploy_configs_load() {
        for name in ["router.json5", "unit.json5"] {
            let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../deploy")
                .join(name);
            let c = Connect {
                config_file: Some(path.clone()),
                ..Default::default()
            };
            let cfg = c
                .to_config()
                .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert_eq!(
                cfg.get_json("scouting/multicast/enabled").unwrap(),
                "false",
                "{name}"
            );
        }
    }

    #[test]
    fn bad_connect_options_are_named() {
        let bad = [
            (
                Connect {
                    connect: vec!["nonsense".into()],
                    ..Default::default()
                },
                "--connect",
            ),
            (
                Connect {
                    config_file: Some("/nonexistent.json5".into()),
                    ..Default::default()
                },
                "/nonexistent.json5",
            ),
        ];
        for (c, named) in bad {
            let e = c.to_config().unwrap_err().to_string();
            assert!(e.contains(named), "{e}");
        }
    }
}
