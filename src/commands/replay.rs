//! `firefleet replay FILE.mcap`: the timeline of a recorded incident on standard output.
//!
//! Not here: reading the recording ([`firefleet_recorder::replay`]).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_recorder::replay::{ReplayError, timeline};

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The recording.
    file: PathBuf,
}

pub fn run(a: ReplayArgs) -> anyhow::Result<ExitCode> {
    let bytes = std::fs::read(&a.file).with_context(|| format!("reading {}", a.file.display()))?;
    match timeline(&bytes, &mut std::io::stdout().lock()) {
        // The reader went away (`| head`): not an error.
        Err(ReplayError::Io(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            Ok(ExitCode::SUCCESS)
        }
        other => other
            .map(|()| ExitCode::SUCCESS)
            .with_context(|| a.file.display().to_string()),
    }
}
