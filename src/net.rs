//! The command line's way onto the bus: Zenoh arguments, opening a site's bus, shutting
//! down on a signal, and asking the coordinator for its status.
//!
//! Not here: what any role does once it is on the bus (`commands`).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, ValueEnum};
use firefleet_bus::pki::Expect;
use firefleet_bus::{Ask, Bus, Connect, Mode};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::IncidentStatus;
use tokio::io::AsyncReadExt;

/// Zenoh's roles for a session.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ZenohMode {
    Peer,
    Client,
    Router,
}

impl From<ZenohMode> for Mode {
    fn from(m: ZenohMode) -> Mode {
        match m {
            ZenohMode::Peer => Mode::Peer,
            ZenohMode::Client => Mode::Client,
            ZenohMode::Router => Mode::Router,
        }
    }
}

/// How a role joins the Zenoh network.
#[derive(Args, Clone, Debug, Default)]
pub struct ZenohArgs {
    /// A Zenoh configuration file (JSON5, zenoh's own format).
    #[arg(long, value_name = "FILE")]
    pub zenoh_config: Option<PathBuf>,
    /// Zenoh mode (default: peer, or the config file's).
    #[arg(long, value_enum)]
    pub mode: Option<ZenohMode>,
    /// Endpoint to connect to, e.g. tcp/127.0.0.1:7447, or quic/HOST:7447 with --tls-dir
    /// (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Endpoint to listen on (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Mutual TLS as the identity in DIR (ca.pem, cert.pem, key.pem, as `firefleet pki init`
    /// writes them); every endpoint must then be quic/HOST:PORT.
    #[arg(long, value_name = "DIR")]
    pub tls_dir: Option<PathBuf>,
    /// Exit when standard input closes (used by `demo` so no child outlives it).
    #[arg(long, hide = true)]
    pub die_with_parent: bool,
}

impl ZenohArgs {
    /// How to join as a process that must be `expect` when it has a TLS identity (`None`:
    /// any identity of the site).
    ///
    /// Under systemd with `LoadCredential=` of `ca.pem`, `cert.pem` and `key.pem`, the
    /// identity is the credentials directory's unless `--tls-dir` says otherwise: the key
    /// stays 0600 and root's on disk, and the service's dynamic user reads the copy systemd
    /// hands it (it could not read the file itself).
    pub fn connect(&self, expect: Option<Expect>) -> Connect {
        Connect {
            config_file: self.zenoh_config.clone(),
            mode: self.mode.map(Mode::from),
            connect: self.connect.clone(),
            listen: self.listen.clone(),
            tls: self.tls_dir.clone().or_else(credentials),
            expect,
        }
    }
}

/// systemd's credentials directory for this service, if it holds a TLS identity.
fn credentials() -> Option<PathBuf> {
    let dir = PathBuf::from(std::env::var_os("CREDENTIALS_DIRECTORY")?);
    ["ca.pem", "cert.pem", "key.pem"]
        .iter()
        .all(|f| dir.join(f).is_file())
        .then_some(dir)
}

/// Tell systemd (a `Type=notify` service) that the role has joined its site, and feed its
/// watchdog for as long as the runtime runs; nothing when not under systemd. The watchdog
/// is fed from a task of its own: a runtime that stalls starves it and systemd restarts the
/// service.
pub fn ready() {
    if let Err(e) = sd_notify::notify(false, &[sd_notify::NotifyState::Ready]) {
        tracing::warn!("could not tell systemd the service is ready: {e}");
    }
    let mut usec = 0;
    if sd_notify::watchdog_enabled(false, &mut usec) {
        let every = Duration::from_micros(usec / 2);
        tokio::spawn(async move {
            loop {
                tokio::time::sleep(every).await;
                let _ = sd_notify::notify(false, &[sd_notify::NotifyState::Watchdog]);
            }
        });
    }
}

/// Completes on Ctrl-C, SIGTERM, or (with `--die-with-parent`) when stdin closes.
pub async fn shutdown_signal(die_with_parent: bool) {
    let stdin_closed = async {
        if die_with_parent {
            let mut buf = [0u8; 64];
            let mut stdin = tokio::io::stdin();
            while matches!(stdin.read(&mut buf).await, Ok(n) if n > 0) {}
        } else {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term => {}
        _ = stdin_closed => {}
    }
}

/// Join the Zenoh network as `zenoh` says, for `scenario`'s site, once: for commands a
/// person waits on (`status`, `goal`), which should fail at once and say why.
pub async fn open(zenoh: &ZenohArgs, scenario: &Scenario) -> anyhow::Result<Bus> {
    Bus::open(&zenoh.connect(None), scenario.site.clone())
        .await
        .context("joining the Zenoh network")
}

/// Join the Zenoh network for a role that runs until stopped (agent, coordinator,
/// recorder, simulator, console), trying again while the network is not there yet
/// ([`Bus::join`]), until joined or stopped by a signal; then [`ready`]. With a TLS identity it must be
/// `who`: files that can never link end the process at once, naming the file and why.
pub async fn join(zenoh: &ZenohArgs, scenario: &Scenario, who: Expect) -> anyhow::Result<Bus> {
    let bus = Bus::join(
        &zenoh.connect(Some(who)),
        scenario.site.clone(),
        shutdown_signal(zenoh.die_with_parent),
    )
    .await
    .context("joining the Zenoh network")?;
    ready();
    watch(&bus, scenario);
    Ok(bus)
}

/// Log `bus`'s link changes (`watch_link`) for as long as it is open.
pub fn watch(bus: &Bus, scenario: &Scenario) {
    tokio::spawn(watch_link(bus.clone(), scenario.clone()));
}

/// Say in the log whenever the router (or peer) this process is linked through changes: a
/// unit that shows lost, or one that failed over to the next router, says so in its own log
/// at the default level, with when.
/// Routers are named as in the site file (a Zenoh id only for one it does not list).
async fn watch_link(bus: Bus, scenario: Scenario) {
    let mut was: Vec<String> = Vec::new();
    while !bus.zenoh_session().is_closed() {
        let info = bus.zenoh_session().info();
        let mut now: Vec<String> = info
            .routers_zid()
            .await
            .map(|z| firefleet_bus::render::router_name(&scenario, &z.to_string()))
            .collect();
        now.extend(info.peers_zid().await.map(|z| z.to_string()));
        now.sort();
        if now != was && !bus.zenoh_session().is_closed() {
            if now.is_empty() {
                tracing::warn!("link to the site lost: trying its routers again");
            } else {
                tracing::info!(through = now.join(","), "linked to the site");
            }
            was = now;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// The coordinator's snapshot of the incident, decoded and as sent.
pub async fn query_status(bus: &Bus) -> anyhow::Result<(IncidentStatus, Vec<u8>)> {
    let key = bus.keys().expr(&Topic::CoordStatus);
    let answers = bus
        .ask(&key, Ask::within(Duration::from_secs(3)))
        .await
        .with_context(|| format!("querying {key}"))?;
    let answer = answers
        .recv()
        .await
        .ok_or_else(|| anyhow::anyhow!("no coordinator answered on {key}"))?;
    let status = codec::decode(&answer.bytes).context("the coordinator's status")?;
    Ok((status, answer.bytes))
}
