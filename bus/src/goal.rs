//! Issuing and clearing a commander's zone goals: one way for every tool that does it
//! (`firefleet goal`, the console, the demo's and the nemesis's scripted commanders).
//!
//! A goal is put on `zone/<zone>/goal/<commander>`; the coordinator answers each one it
//! hears on `zone/<zone>/ack`. A delete on the goal key clears that commander's goals on
//! the zone.

use std::time::Duration;

use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{GoalAck, ZoneGoal};

use crate::{Bus, BusError};

/// How long a person's tool waits for the coordinator's answer.
pub const ACK_TIMEOUT: Duration = Duration::from_secs(5);

/// Why a goal got no answer.
#[derive(Debug, thiserror::Error)]
pub enum GoalError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error("the bus closed before the coordinator answered")]
    Closed,
    #[error(
        "no answer from a coordinator within {:.0} s (is one running, and may this identity put goals on the zone?)",
        .0.as_secs_f64()
    )]
    NoAnswer(Duration),
}

/// Put `goal` under commander `by` and wait up to `within` for the coordinator's answer,
/// putting it again every second meanwhile: a goal is idempotent (the same id amends),
/// and a coordinator that was taking over or a link that dropped the first put still
/// hears it.
pub async fn issue(
    bus: &Bus,
    goal: &ZoneGoal,
    by: &CommanderId,
    within: Duration,
) -> Result<GoalAck, GoalError> {
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
                Ok(None) => return Err(GoalError::Closed),
                Err(_) => break,
            }
        }
    }
    Err(GoalError::NoAnswer(within))
}

/// Clear commander `by`'s goals on `zone`.
pub async fn clear(bus: &Bus, zone: &ZoneId, by: &CommanderId) -> Result<(), BusError> {
    bus.delete(bus.keys().zone_goal(zone, by).as_str()).await
}
