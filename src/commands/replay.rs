//! `firefleet replay FILE.mcap`: the timeline of a recorded incident on standard output.
//!
//! Not here: reading the recording ([`firefleet_recorder::replay`]).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_recorder::parts::Recording;
use firefleet_recorder::replay::{ReplayError, timeline};

#[derive(Args, Debug)]
pub struct ReplayArgs {
    /// The recording: its MCAP file, or the parts a recorder killed before it could merge
    /// them left (`FILE.mcap.parts/`; naming `FILE.mcap` finds them too).
    file: PathBuf,
}

pub fn run(a: ReplayArgs) -> anyhow::Result<ExitCode> {
    let recording = Recording::load(&a.file)?;
    match timeline(&recording, &mut std::io::stdout().lock()) {
        // The reader went away (`| head`): not an error.
        Err(ReplayError::Io(e)) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            Ok(ExitCode::SUCCESS)
        }
        other => other
            .map(|()| ExitCode::SUCCESS)
            .with_context(|| a.file.display().to_string()),
    }
}
