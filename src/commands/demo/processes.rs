//! The demo's processes: each role started under its label, watched, and killed or
//! restarted when the demo's script says.
//!
//! Not here: which roles a demo starts ([`super::roles`]).

use super::*;

/// The label of the coordinator in charge's process.
pub(super) const COORDINATOR: &str = "coordinator";
/// The label of the standby coordinator's process.
const STANDBY: &str = "coordinator:standby";

/// The fleet's running processes, each under its label, and how each was started (to
/// start it again).
pub(super) struct Processes {
    running: Vec<(String, Child)>,
    launched: Vec<(String, RoleCommand)>,
}

impl Processes {
    /// Start every role, told the site file `scenario` and how to join: its Zenoh file on
    /// a secure `site`, a client of `endpoint` otherwise.
    pub(super) fn launch(
        roles: Vec<(Identity, RoleCommand)>,
        scenario: &str,
        site: Option<&SecureSite>,
        endpoint: &str,
    ) -> anyhow::Result<Self> {
        let launched: Vec<(String, RoleCommand)> = roles
            .into_iter()
            .map(|(who, role)| {
                let label = match &who {
                    Identity::Unit(u) => format!("agent:{u}"),
                    Identity::Coordinator(rank) if *rank > 0 => STANDBY.into(),
                    other => other.to_string(),
                };
                let role = role.scenario(scenario).die_with_parent();
                let role = match site {
                    Some(s) => {
                        role.zenoh_config(s.configs.join(format!("{}.json5", who.dir_name())))
                    }
                    None => role.client_of(endpoint),
                };
                (label, role)
            })
            .collect();
        let running = launched
            .iter()
            .map(|(label, role)| start(label, role))
            .collect::<anyhow::Result<_>>()?;
        Ok(Self { running, launched })
    }

    pub(super) fn len(&self) -> usize {
        self.running.len()
    }

    /// Kill the process labelled `label`: whether one ran.
    pub(super) async fn kill(&mut self, label: &str) -> anyhow::Result<bool> {
        let Some(k) = self.running.iter().position(|(l, _)| l == label) else {
            return Ok(false);
        };
        let (_, mut c) = self.running.remove(k);
        c.kill().await?;
        Ok(true)
    }

    /// Kill the process labelled `label` and start it again as it was first started:
    /// whether one ran.
    pub(super) async fn restart(&mut self, label: &str) -> anyhow::Result<bool> {
        let Some((_, role)) = self.launched.iter().find(|(l, _)| l == label) else {
            return Ok(false);
        };
        let role = role.clone();
        if !self.kill(label).await? {
            return Ok(false);
        }
        self.running.push(start(label, &role)?);
        Ok(true)
    }

    /// The label of a process that has exited, if one has. The coordinator in charge
    /// exiting while its standby runs is a failover, not the demo's end (as on a site, where
    /// an operator may kill it to see the standby take office): said, and no longer
    /// watched; the standby, then in charge, is.
    pub(super) fn exited(&mut self) -> Option<String> {
        let role = exited(&mut self.running)?;
        let standing_by = self.running.iter().any(|(l, _)| l == STANDBY);
        if role != COORDINATOR || !standing_by {
            return Some(role);
        }
        self.running.retain(|(l, _)| l != COORDINATOR);
        println!("the coordinator in charge exited; the standby takes over");
        None
    }

    /// Stop every process; what ran, for the summary.
    pub(super) async fn stop(self) -> Vec<ProcessInfo> {
        let ran = self
            .running
            .iter()
            .map(|(role, c)| ProcessInfo {
                role: role.clone(),
                pid: c.id(),
            })
            .collect();
        stop_children(self.running).await;
        ran
    }
}

fn start(label: &str, role: &RoleCommand) -> anyhow::Result<(String, Child)> {
    let child = role
        .child("warn,zenoh=error")?
        .spawn()
        .with_context(|| format!("starting the {label} process"))?;
    Ok((label.to_owned(), child))
}
