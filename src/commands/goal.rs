//! `firefleet goal`: issue, list and clear incident commanders' zone goals.
//!
//! A goal is JSON on `ff/<site>/zone/<zone>/goal/<commander>`; the coordinator answers
//! every goal on `ff/<site>/zone/<zone>/ack`, and a delete on the goal key clears that
//! commander's goals on the zone. This command
//! is one client of that API; any Zenoh client can do the same (see the README).
//!
//! Not here: how the coordinator applies goals (`firefleet_coordinator::goals`).

use std::process::ExitCode;
use std::time::Duration;

use clap::{Args, Subcommand};
use firefleet_protocol::bus::Bus;
use firefleet_protocol::msg::{GoalAck, GoalKind, ZoneGoal};
use firefleet_protocol::validate::Validate;
use firefleet_protocol::{CommanderId, ZoneId};

use super::status::print_goals;
use super::{ScenarioArg, scenarios};
use crate::net::{ZenohArgs, open, query_status};

#[derive(Subcommand, Debug)]
pub enum GoalCommand {
    /// Issue a goal for a zone and wait for the coordinator's answer (exit 1 if rejected).
    Set(SetArgs),
    /// List the goals in force.
    List(Common),
    /// Clear a commander's goals on a zone.
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
    #[arg(long, value_parser = parse_kind)]
    goal: GoalKind,
    /// The goal's id (default: the zone and the goal, e.g. `z3-keep-out`).
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
    /// The commander's name (with --tls-dir: the NAME of its `commander:NAME` certificate).
    #[arg(
        long = "issued-by",
        value_name = "NAME",
        default_value = "firefleet-cli"
    )]
    name: CommanderId,
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

fn parse_kind(s: &str) -> Result<GoalKind, String> {
    serde_json::from_value(serde_json::Value::String(s.to_owned())).map_err(|_| {
        format!("'{s}' is not a goal (extinguish, contain, monitor, keep-out, evacuate)")
    })
}

/// How long to wait for the coordinator's answer.
pub const ACK_TIMEOUT: Duration = Duration::from_secs(5);

/// Put `goal` under commander `by` and wait up to `within` for the coordinator's answer,
/// putting it again every second meanwhile: a goal is idempotent (the same id amends),
/// and a coordinator that was taking over or a link that dropped the first put still
/// hears it.
pub async fn issue(
    bus: &Bus,
    goal: &ZoneGoal,
    by: &CommanderId,
    within: Duration,
) -> anyhow::Result<GoalAck> {
    let keys = bus.keys();
    let acks = bus.subscribe::<GoalAck>(&keys.zone_ack(&goal.zone)).await?;
    let deadline = tokio::time::Instant::now() + within;
    while tokio::time::Instant::now() < deadline {
        bus.put(&keys.zone_goal(&goal.zone, by), goal).await?;
        let resend = (tokio::time::Instant::now() + Duration::from_secs(1)).min(deadline);
        loop {
            match tokio::time::timeout_at(resend, acks.recv()).await {
                Ok(Some((_, ack))) if ack.id == goal.id => return Ok(ack),
                Ok(Some(_)) => {}
                Ok(None) => anyhow::bail!("the bus closed before the coordinator answered"),
                Err(_) => break,
            }
        }
    }
    anyhow::bail!(
        "no answer from a coordinator within {:.0} s",
        within.as_secs_f64()
    )
}

pub async fn run(cmd: GoalCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        GoalCommand::Set(a) => set(a).await,
        GoalCommand::List(a) => {
            let scenario = scenarios::resolve(&a.scenario.scenario)?;
            let bus = open(&a.zenoh, &scenario).await?;
            let (status, _) = query_status(&bus).await?;
            print_goals(&status.goals);
            bus.close().await;
            Ok(ExitCode::SUCCESS)
        }
        GoalCommand::Clear(a) => {
            let scenario = scenarios::resolve(&a.common.scenario.scenario)?;
            let bus = open(&a.common.zenoh, &scenario).await?;
            let key = bus.keys().zone_goal(&a.zone, &a.by.name);
            bus.session()
                .delete(key.as_str())
                .await
                .map_err(|e| anyhow::anyhow!("clearing {}: {e}", key.as_str()))?;
            println!("cleared {}'s goals on zone {}", a.by.name, a.zone);
            bus.close().await;
            Ok(ExitCode::SUCCESS)
        }
    }
}

async fn set(a: SetArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.common.scenario.scenario)?;
    let kind = serde_json::to_value(a.goal)?
        .as_str()
        .unwrap_or_default()
        .to_owned();
    let goal = ZoneGoal {
        id: a.id.unwrap_or_else(|| format!("{}-{kind}", a.zone)),
        zone: a.zone.clone(),
        goal: a.goal,
        priority: a.priority,
        before_m: a.before_m,
        expires_s: a.expires_s,
        issued_by: a.by.name.to_string(),
        rail_allowed: a.rail_allowed,
    };
    goal.validate()
        .map_err(|e| anyhow::anyhow!("the goal is not valid: {e}"))?;
    let bus = open(&a.common.zenoh, &scenario).await?;
    let ack = issue(&bus, &goal, &a.by.name, ACK_TIMEOUT).await;
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
