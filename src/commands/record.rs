//! `firefleet record`: everything on a site's bus to an MCAP file, and live to Foxglove.
//!
//! Not here: the recorder (`firefleet_recorder`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Expect;
use firefleet_recorder::live::Live;
use firefleet_recorder::parts::PART_EVERY;

use super::{RoleArgs, positive_f64};
use firefleet::net::{join, shutdown_signal};

#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("output").required(true).multiple(true).args(["out", "foxglove"])))]
pub struct RecordArgs {
    #[command(flatten)]
    role: RoleArgs,
    /// The MCAP file to write. Until the recorder stops it is written as parts in
    /// `FILE.mcap.parts/`, each a finished MCAP file, so that a recorder killed outright
    /// leaves all but the last few seconds readable by any MCAP reader.
    #[arg(long, value_name = "FILE.mcap")]
    out: Option<PathBuf>,
    /// Serve the same channels live over the Foxglove WebSocket protocol here: open
    /// `ws://ADDR` in Foxglove. Loopback unless the site's network is trusted: the
    /// protocol has no authentication.
    #[arg(long, value_name = "ADDR:PORT")]
    foxglove: Option<std::net::SocketAddr>,
    /// Seconds between two parts: what a recorder killed outright loses, at most.
    #[arg(long, default_value_t = PART_EVERY.as_secs_f64(), value_parser = part_seconds)]
    part_seconds: f64,
}

/// A part's length: positive, and a day at most (a part is the unit of loss).
fn part_seconds(s: &str) -> Result<f64, String> {
    match positive_f64(s)? {
        v if v <= 86_400.0 => Ok(v),
        v => Err(format!("{v} s is more than a day")),
    }
}

pub async fn run(a: RecordArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.role.scenario.load()?;
    let live = match a.foxglove {
        Some(addr) => {
            let listener = tokio::net::TcpListener::bind(addr)
                .await
                .with_context(|| format!("--foxglove {addr}: cannot listen there"))?;
            let live = Live::new();
            // Serves until the process ends with the recording.
            tokio::spawn(live.clone().serve(listener, std::future::pending()));
            println!("Foxglove live: ws://{addr}");
            Some(live)
        }
        None => None,
    };
    let bus = join(
        &a.role.zenoh,
        &scenario,
        Expect::Identity(Identity::Recorder),
    )
    .await?;
    a.role.metrics.serve(&bus, false, None).await?;
    let summary = firefleet_recorder::record(
        &bus,
        &scenario,
        a.out.as_deref(),
        live,
        Duration::from_secs_f64(a.part_seconds),
        shutdown_signal(a.role.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(messages = summary.messages, channels = summary.channels, skipped = summary.skipped, dropped = summary.dropped, over_budget = summary.over_budget, out = ?a.out, "recording finished");
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
