//! The command line's way onto the bus: Zenoh arguments, opening a site's bus, shutting
//! down on a signal, and asking the coordinator for its status.
//!
//! Not here: what any role does once it is on the bus (`commands`).

use std::path::PathBuf;
use std::time::Duration;

use anyhow::Context;
use clap::{Args, ValueEnum};
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
    /// Endpoint to connect to, e.g. tcp/127.0.0.1:7447 (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub connect: Vec<String>,
    /// Endpoint to listen on (repeatable).
    #[arg(long, value_name = "ENDPOINT")]
    pub listen: Vec<String>,
    /// Mutual TLS as the identity in DIR (ca.pem, cert.pem, key.pem, as `firefleet pki init`
    /// writes them); every endpoint must then be tls/HOST:PORT.
    #[arg(long, value_name = "DIR")]
    pub tls_dir: Option<PathBuf>,
    /// Exit when standard input closes (used by `demo` so no child outlives it).
    #[arg(long, hide = true)]
    pub die_with_parent: bool,
}

impl ZenohArgs {
    pub fn connect(&self) -> Connect {
        Connect {
            config_file: self.zenoh_config.clone(),
            mode: self.mode.map(Mode::from),
            connect: self.connect.clone(),
            listen: self.listen.clone(),
            tls: self.tls_dir.clone(),
        }
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
    Bus::open(&zenoh.connect(), scenario.site.clone())
        .await
        .context("joining the Zenoh network")
}

/// The wait before attempt `n + 1` to join (`n` failed so far): half a second, doubling,
/// at most [`JOIN_RETRY_MAX`].
fn join_backoff(failed: u32) -> Duration {
    (Duration::from_millis(500) * 2u32.saturating_pow(failed.saturating_sub(1))).min(JOIN_RETRY_MAX)
}

/// The longest wait between two attempts to join: a robot powered up before the site's
/// router is up should be on the bus within seconds of it.
const JOIN_RETRY_MAX: Duration = Duration::from_secs(8);

/// Join the Zenoh network for a role that runs until stopped (agent, coordinator,
/// recorder, simulator): a client whose router does not answer yet (a robot powered up
/// before the site's network) waits and tries again, saying so each time, until it joins
/// or is stopped; a peer that reaches none of its `--connect` endpoints says so loudly
/// (Zenoh opens a peer anyway and keeps trying in the background). A configuration that
/// can never work (a bad endpoint, a missing certificate) fails at once.
pub async fn join(zenoh: &ZenohArgs, scenario: &Scenario) -> anyhow::Result<Bus> {
    let connect = zenoh.connect();
    let config = connect.to_config().context("joining the Zenoh network")?;
    let mut failed = 0u32;
    let bus = loop {
        match Bus::open(&connect, scenario.site.clone()).await {
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
                    _ = shutdown_signal(zenoh.die_with_parent) => {
                        anyhow::bail!("stopped before joining the Zenoh network");
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
        tokio::time::sleep(Duration::from_millis(500)).await;
        if !bus.connected().await {
            tracing::error!(
                "reached none of {:?}: running alone until one answers (Zenoh keeps trying)",
                zenoh.connect
            );
        }
    }
    Ok(bus)
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
