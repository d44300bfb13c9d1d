//! The child processes a command starts (the demo's fleet, the lab's harnesses): where the
//! `firefleet` binary is, how each child is started so none outlives its parent, and how
//! they are stopped so the recorder keeps what the others say until they exit.

use std::path::PathBuf;
use std::process::Stdio;
use std::time::Duration;

use tokio::process::{Child, Command};

/// The `firefleet` binary whose roles a command starts: `FIREFLEET_BIN` if set, else the
/// `firefleet` beside the running executable (itself, or the lab's `firefleet-lab`, which
/// cargo builds into the same directory and a package installs beside it).
pub fn firefleet_binary() -> anyhow::Result<PathBuf> {
    if let Some(bin) = std::env::var_os("FIREFLEET_BIN") {
        return Ok(bin.into());
    }
    let exe = std::env::current_exe()
        .map_err(|e| anyhow::anyhow!("locating the running executable: {e}"))?;
    let bin = exe.with_file_name(format!("firefleet{}", std::env::consts::EXE_SUFFIX));
    anyhow::ensure!(
        bin.is_file(),
        "no firefleet binary beside {} (build it with `cargo build`, or name one with FIREFLEET_BIN)",
        exe.display()
    );
    Ok(bin)
}

/// The role of the first child that has exited, if any.
pub fn exited(children: &mut [(String, Child)]) -> Option<String> {
    children
        .iter_mut()
        .find_map(|(role, c)| matches!(c.try_wait(), Ok(Some(_))).then(|| role.clone()))
}

/// Make `cmd` a child of this process: stdin a pipe from here (its `--die-with-parent`
/// watches it), stdout quiet, stderr shared, killed if dropped; logging at `log` unless
/// `RUST_LOG` says otherwise.
pub fn as_child(cmd: &mut Command, log: &str) {
    cmd.stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::inherit())
        .kill_on_drop(true);
    if std::env::var_os("RUST_LOG").is_none() {
        cmd.env("RUST_LOG", log);
    }
}

/// Stop `children` (stdin closed, then killed if they linger), the recorder last and with
/// time to merge its parts, so that it keeps what the others say until they exit.
pub async fn stop_children(children: Vec<(String, Child)>) {
    let (recorder, others): (Vec<_>, Vec<_>) = children
        .into_iter()
        .partition(|(role, _)| role == "recorder");
    stop(others, Duration::from_secs(5)).await;
    // The recorder merges its parts into one file as it stops: a minute of a long
    // recording's compression, at most (and were it killed, the parts would stay).
    stop(recorder, Duration::from_secs(120)).await;
}

/// Close the children's stdin (their signal to stop), wait up to `grace`, kill stragglers.
async fn stop(mut children: Vec<(String, Child)>, grace: Duration) {
    for (_, c) in &mut children {
        drop(c.stdin.take());
    }
    for (role, c) in &mut children {
        if tokio::time::timeout(grace, c.wait()).await.is_err() {
            tracing::warn!(role, "did not stop in {grace:?}; killing it");
            let _ = c.kill().await;
        }
    }
}
