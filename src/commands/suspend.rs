//! `firefleet suspend`: ask, as this host's identity, that a site identity be suspended in
//! band (issue #52): two commanders asking, or the operator at a coordinator's host with
//! its own files (not for a coordinator identity), suspend it within a second;
//! `firefleet status` then lists it. Revocation (`firefleet pki revoke`) is the lasting cut.
//!
//! Not here: who may suspend whom (`firefleet_bus::suspension`) or what a suspension does
//! (the coordinator's incident, `firefleet_bus::office`).

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::goal;

use super::ScenarioArg;
use firefleet::net::{ZenohArgs, open};
use firefleet_bus::{Ask, Bus};
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::GoalsInForce;

#[derive(Args, Debug)]
pub struct SuspendArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// The identity to suspend: commander:NAME, console, unit:ID, scada, coordinator or
    /// coordinator:RANK (a coordinator only by two commanders).
    #[arg(long, value_name = "IDENTITY")]
    identity: Identity,
    /// Why, for the record (at most 256 characters).
    #[arg(long, default_value = "")]
    reason: String,
}

/// How long to wait for the coordinator's status to show the suspension.
const SHOWN_WITHIN: Duration = Duration::from_secs(5);

pub async fn run(a: SuspendArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.scenario.load()?;
    let bus = open(&a.zenoh, &scenario).await?;
    goal::suspend(&bus, &a.identity, &a.reason)
        .await
        .with_context(|| format!("asking that {} be suspended", a.identity))?;
    let name = a.identity.dir_name();
    // Shown once enough have asked; else say what is missing.
    let deadline = tokio::time::Instant::now() + SHOWN_WITHIN;
    let shown = loop {
        if suspended(&bus, &name).await {
            break true;
        }
        if tokio::time::Instant::now() >= deadline {
            break false;
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    bus.close().await;
    if shown {
        println!(
            "{} is suspended: the coordinator takes nothing of it",
            a.identity
        );
    } else {
        println!(
            "asked that {} be suspended; a second commander's ask (or the operator's at the coordinator's host) suspends it",
            a.identity
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// Whether the coordinator keeps `name` suspended: the goals in force carry the asks of
/// every identity suspended, and of none other (every role that may ask may read them).
async fn suspended(bus: &Bus, name: &str) -> bool {
    let Ok(answers) = bus
        .ask(
            bus.keys().coord_goals().as_str(),
            Ask::within(Duration::from_secs(1)),
        )
        .await
    else {
        return false;
    };
    let Some(answer) = answers.recv().await else {
        return false;
    };
    bus.decode::<GoalsInForce>(&answer, "goals in force")
        .is_some_and(|g| {
            g.suspensions
                .iter()
                .any(|p| matches!(keys::parse(&p.key), Ok((_, Topic::Suspend(t, _))) if t == name))
        })
}
