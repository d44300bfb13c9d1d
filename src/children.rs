//! The child processes a command starts (the demo's fleet, the lab's harnesses, the end to
//! end tests): where the `firefleet` binary is, one typed way to say which role to start
//! and how it joins the bus ([`RoleCommand`]), how each child is started so none outlives
//! its parent, and how they are stopped so the recorder keeps what the others say until
//! they exit.

use std::ffi::OsString;
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

/// How a role joins the site's bus.
#[derive(Debug, Clone)]
enum Join {
    /// As its own arguments say (a router, or a command that takes no bus).
    AsGiven,
    /// A client of the router at this endpoint.
    ClientOf(String),
    /// As this Zenoh configuration file says (a secure site's rendered one).
    Config(PathBuf),
}

/// One role of the `firefleet` binary: `firefleet ROLE ARGS... --scenario SITE` joined to
/// the bus as told, optionally ending when its parent does.
///
/// ```
/// use firefleet::children::RoleCommand;
///
/// let agent = RoleCommand::new("agent")
///     .args(["--unit", "ugv-1"])
///     .scenario("vehicle-collision")
///     .client_of("tcp/127.0.0.1:7447")
///     .die_with_parent();
/// let args: Vec<String> = agent.to_args().into_iter().map(|a| a.into_string().unwrap()).collect();
/// assert_eq!(
///     args.join(" "),
///     "agent --unit ugv-1 --scenario vehicle-collision --die-with-parent \
///      --mode client --connect tcp/127.0.0.1:7447"
/// );
/// ```
#[derive(Debug, Clone)]
pub struct RoleCommand {
    args: Vec<OsString>,
    scenario: Option<OsString>,
    join: Join,
    die_with_parent: bool,
}

impl RoleCommand {
    /// `firefleet ROLE` (`agent`, `coordinator`, `sim`, `record`, `console`, `scada`,
    /// `router`, `demo`, ...).
    pub fn new(role: &str) -> Self {
        Self {
            args: vec![role.into()],
            scenario: None,
            join: Join::AsGiven,
            die_with_parent: false,
        }
    }

    /// One more argument of the role's own.
    pub fn arg(mut self, arg: impl Into<OsString>) -> Self {
        self.args.push(arg.into());
        self
    }

    /// More arguments of the role's own.
    pub fn args<I: IntoIterator<Item = S>, S: Into<OsString>>(mut self, args: I) -> Self {
        self.args.extend(args.into_iter().map(Into::into));
        self
    }

    /// The site file (or built-in scenario) the role reads.
    pub fn scenario(mut self, scenario: impl Into<OsString>) -> Self {
        self.scenario = Some(scenario.into());
        self
    }

    /// Join as a client of the router at `endpoint`.
    pub fn client_of(mut self, endpoint: &str) -> Self {
        self.join = Join::ClientOf(endpoint.to_owned());
        self
    }

    /// Join as the Zenoh configuration file at `path` says.
    pub fn zenoh_config(mut self, path: impl Into<PathBuf>) -> Self {
        self.join = Join::Config(path.into());
        self
    }

    /// End when this process's end of the child's stdin closes (a child of [`as_child`]).
    pub fn die_with_parent(mut self) -> Self {
        self.die_with_parent = true;
        self
    }

    /// The arguments after the binary's name.
    pub fn to_args(&self) -> Vec<OsString> {
        let mut args = self.args.clone();
        if let Some(s) = &self.scenario {
            args.extend(["--scenario".into(), s.clone()]);
        }
        if self.die_with_parent {
            args.push("--die-with-parent".into());
        }
        match &self.join {
            Join::AsGiven => {}
            Join::ClientOf(endpoint) => {
                args.extend(["--mode", "client", "--connect"].map(OsString::from));
                args.push(endpoint.into());
            }
            Join::Config(path) => {
                args.extend(["--zenoh-config".into(), path.into()]);
            }
        }
        args
    }

    /// The role as a child of this process ([`as_child`], logging at `log` unless
    /// `RUST_LOG` says otherwise), run by the [`firefleet_binary`]: ready to spawn, or to
    /// take more arguments first.
    pub fn child(&self, log: &str) -> anyhow::Result<Command> {
        let mut cmd = Command::new(firefleet_binary()?);
        cmd.args(self.to_args());
        as_child(&mut cmd, log);
        Ok(cmd)
    }
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
