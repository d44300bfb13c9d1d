//! `firefleet record`: everything on a site's bus to an MCAP file.
//!
//! Not here: the recorder (`firefleet_recorder`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

use super::{ScenarioArg, scenarios};
use crate::net::{ZenohArgs, join, shutdown_signal};

#[derive(Args, Debug)]
pub struct RecordArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The MCAP file to write.
    #[arg(long, value_name = "FILE.mcap")]
    out: PathBuf,
}

pub async fn run(a: RecordArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = join(&a.zenoh, &scenario).await?;
    let summary = firefleet_recorder::record(
        &bus,
        &scenario,
        &a.out,
        shutdown_signal(a.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(messages = summary.messages, channels = summary.channels, skipped = summary.skipped, out = %a.out.display(), "recording finished");
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}
