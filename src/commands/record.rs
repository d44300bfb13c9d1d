//! `firefleet record`: everything on a site's bus to an MCAP file.
//!
//! Not here: the recorder (`firefleet_recorder`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use firefleet_recorder::parts::PART_EVERY;

use super::{ScenarioArg, positive_f64, scenarios};
use crate::net::{ZenohArgs, join, shutdown_signal};

#[derive(Args, Debug)]
pub struct RecordArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The MCAP file to write. Until the recorder stops it is written as parts in
    /// `FILE.mcap.parts/`, each a finished MCAP file, so that a recorder killed outright
    /// leaves all but the last few seconds readable by any MCAP reader.
    #[arg(long, value_name = "FILE.mcap")]
    out: PathBuf,
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
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = join(&a.zenoh, &scenario).await?;
    let summary = firefleet_recorder::record(
        &bus,
        &scenario,
        &a.out,
        Duration::from_secs_f64(a.part_seconds),
        shutdown_signal(a.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(messages = summary.messages, channels = summary.channels, skipped = summary.skipped, out = %a.out.display(), "recording finished");
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
