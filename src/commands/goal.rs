//! `firefleet goal`: issue, list and clear incident commanders' zone goals.
//!
//! A goal is JSON on `ff/<site>/zone/<zone>/goal/<commander>`; the coordinator answers
//! every goal on `ff/<site>/zone/<zone>/ack`, and a delete on the goal key clears that
//! commander's goals on the zone. This command is one client of that API
//! (`firefleet_bus::goal`); any Zenoh client can do the same (docs/zone-goals.md).
//!
//! Not here: how the coordinator applies goals (`firefleet_coordinator::goals`).

use std::process::ExitCode;

use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet_bus::access::Identity;
use firefleet_bus::goal;
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{GoalForm, GoalKind};

use super::ScenarioArg;
use firefleet::net::{ZenohArgs, open, query_status};

#[derive(Subcommand, Debug)]
pub enum GoalCommand {
    /// Issue a goal for a zone and wait for the coordinator's answer (exit 1 if rejected).
    Set(SetArgs),
    /// List the goals in force.
    List(Common),
    /// Clear a commander's goals on a zone, and wait until the coordinator holds none of
    /// them (deleting again each second, up to 5 s).
    Clear(ClearArgs),
}

#[derive(Args, Debug)]
pub struct Common {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
}

#[derive(Args, Debug)]
pub struct SetArgs {
    #[command(flatten)]
    common: Common,
    #[arg(long)]
    zone: ZoneId,
    /// extinguish, contain, monitor, keep-out or evacuate.
    #[arg(long)]
    goal: GoalKind,
    /// The goal's id (default: the commander, the zone and the goal, e.g. `rossi-z3-keep-out`).
    #[arg(long)]
    id: Option<String>,
    #[arg(long, default_value_t = 0)]
    priority: u8,
    /// For contain: the chainage the fire front must not pass, m.
    #[arg(long)]
    before_m: Option<f64>,
    /// Seconds of site time after which the goal lapses.
    #[arg(long)]
    expires_s: Option<f64>,
    /// For keep-out and evacuate: monorail carriages may still run through the zone.
    #[arg(long)]
    rail_allowed: bool,
    #[command(flatten)]
    by: Issuer,
}

/// Who issues: the goal's key names the commander, and on a site with access rules the
/// router lets a commander put only under the name in its certificate.
#[derive(Args, Debug)]
pub struct Issuer {
    /// The commander's name (default: the NAME of a `commander:NAME` certificate, else
    /// `firefleet-cli`).
    #[arg(long = "issued-by", value_name = "NAME")]
    name: Option<CommanderId>,
}

#[derive(Args, Debug)]
pub struct ClearArgs {
    #[command(flatten)]
    common: Common,
    #[arg(long)]
    zone: ZoneId,
    #[command(flatten)]
    by: Issuer,
}

pub async fn run(cmd: GoalCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        GoalCommand::Set(a) => set(a).await,
        GoalCommand::List(a) => {
            let scenario = a.scenario.load()?;
            let bus = open(&a.zenoh, &scenario).await?;
            let (status, _) = query_status(&bus).await?;
            if status.goals.is_empty() {
                println!("  (none)");
            }
            for g in &status.goals {
                println!("  {g}");
            }
            bus.close().await;
            Ok(ExitCode::SUCCESS)
        }
        GoalCommand::Clear(a) => {
            let scenario = a.common.scenario.load()?;
            let by = issuer(&a.common.zenoh, a.by.name)?;
            let bus = open(&a.common.zenoh, &scenario).await?;
            goal::clear(&bus, &a.zone, &by, goal::ACK_TIMEOUT)
                .await
                .with_context(|| format!("clearing {by}'s goals on zone {}", a.zone))?;
            println!("cleared {by}'s goals on zone {}", a.zone);
            bus.close().await;
            Ok(ExitCode::SUCCESS)
        }
    }
}

async fn set(a: SetArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.common.scenario.load()?;
    let form = GoalForm {
        id: a.id,
        priority: a.priority,
        before_m: a.before_m,
        expires_s: a.expires_s,
        rail_allowed: a.rail_allowed,
        ..GoalForm::new(a.zone, a.goal)
    };
    let by = issuer(&a.common.zenoh, a.by.name)?;
    let goal = form
        .issued_by(by.clone())
        .map_err(|e| anyhow::anyhow!("the goal is not valid: {e}"))?;
    let bus = open(&a.common.zenoh, &scenario).await?;
    let ack = goal::issue(&bus, &goal, &by, goal::ACK_TIMEOUT).await;
    bus.close().await;
    let ack = ack?;
    if ack.accepted {
        println!("goal '{}' on zone {}: {}", ack.id, ack.zone, ack.reason);
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "goal '{}' on zone {} rejected: {}",
            ack.id, ack.zone, ack.reason
        );
        Ok(ExitCode::FAILURE)
    }
}

/// The commander a goal or a clear is issued as: the one `asked` for (`--issued-by`), else
/// the certificate's commander, else `firefleet-cli`. Refused, before anything is sent,
/// where the site's router would drop it without a word: on a site with access rules a
/// commander's certificate puts and clears goals only under its own name, the console's
/// under any, and no other identity's at all.
fn issuer(zenoh: &ZenohArgs, asked: Option<CommanderId>) -> anyhow::Result<CommanderId> {
    let identity = zenoh.connect(None).identity()?;
    let by = match (asked, &identity) {
        (Some(by), _) => by,
        (None, Some(Identity::Commander(name))) => name.clone(),
        (None, _) => CommanderId::new("firefleet-cli").expect("a valid name"),
    };
    match identity {
        None | Some(Identity::Console) => Ok(by),
        Some(Identity::Commander(name)) if name == by => Ok(by),
        Some(Identity::Commander(name)) => anyhow::bail!(
            "this certificate is commander:{name}: the site's router takes goals from it only \
             as --issued-by {name} (under '{by}' it would drop the goal, unanswered)"
        ),
        Some(other) => anyhow::bail!(
            "this certificate is {other}, which may not put goals: the site's router would \
             drop the goal, unanswered (a commander's certificate or the console's may)"
        ),
    }
}
