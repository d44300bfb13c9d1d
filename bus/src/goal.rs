//! Issuing and clearing a commander's zone goals: one way for every tool that does it
//! (`firefleet goal`, the console, the demo's and the nemesis's scripted commanders).
//!
//! A goal is put on `zone/<zone>/goal/<commander>`; the coordinator answers each one it
//! hears on `zone/<zone>/ack`. A delete on the goal key clears that commander's goals on
//! the zone, which a person's tool then sees gone from the goals in force. On a secure
//! site both are sealed with the tool's identity (a commander's own, or the console's for
//! its logins): the coordinator takes no goal or clear without a seal it can check.

use std::time::Duration;

use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{GoalAck, GoalPreview, GoalsInForce, Seal, ZoneGoal};

use crate::{Ask, Bus, BusError};

/// How long a person's tool waits for the coordinator's answer.
pub const ACK_TIMEOUT: Duration = Duration::from_secs(5);

/// How long a tool puts one seal again while it waits: well inside the half minute a
/// coordinator takes a seal as fresh.
const RESEAL: Duration = Duration::from_secs(10);

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
    /// The coordinator refused the question, saying why.
    #[error("{0}")]
    Refused(String),
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
    let acks = bus
        .subscribe::<GoalAck>(&bus.keys().zone_ack(&goal.zone))
        .await?;
    // Sealed once: every put again is the same message, not a newer one; sealed again
    // only before the seal grows too old for a coordinator to take as fresh.
    let mut sealed = (tokio::time::Instant::now(), Put::new(bus, goal, by));
    let deadline = tokio::time::Instant::now() + within;
    while tokio::time::Instant::now() < deadline {
        if sealed.0.elapsed() > RESEAL {
            sealed = (tokio::time::Instant::now(), Put::new(bus, goal, by));
        }
        sealed.1.send(bus).await?;
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

/// What `goal` under commander `by` would do if it were issued now, as the coordinator
/// works it out (`coord/preview`): nothing is put, nothing changes.
pub async fn preview(
    bus: &Bus,
    goal: &ZoneGoal,
    by: &CommanderId,
    within: Duration,
) -> Result<GoalPreview, GoalError> {
    let key = format!("{}?by={by}", bus.keys().expr(&Topic::CoordPreview));
    let answers = bus
        .ask_with(&key, Ask::within(within), Some(codec::encode(goal)))
        .await?;
    match answers.recv_or_refusal().await {
        Some(Ok(a)) => bus
            .decode::<GoalPreview>(&a, "goal preview")
            .ok_or(GoalError::Refused(
                "the coordinator's preview did not decode".into(),
            )),
        Some(Err(why)) => Err(GoalError::Refused(why)),
        None => Err(GoalError::NoAnswer(within)),
    }
}

/// Put `goal` under commander `by` once, sealed where the bus can seal, without waiting
/// for an answer: for scripted commanders that read the answers themselves.
pub async fn put(bus: &Bus, goal: &ZoneGoal, by: &CommanderId) -> Result<(), BusError> {
    Put::new(bus, goal, by).send(bus).await
}

/// A goal ready to put: its key, its bytes, and their seal.
struct Put {
    key: String,
    bytes: Vec<u8>,
    seal: Option<Seal>,
}

impl Put {
    fn new(bus: &Bus, goal: &ZoneGoal, by: &CommanderId) -> Self {
        let key = bus.keys().zone_goal(&goal.zone, by).as_str().to_owned();
        let bytes = codec::encode(goal);
        let seal = bus.seals().map(|s| s.sealer.seal(&key, Some(&bytes)));
        Self { key, bytes, seal }
    }

    async fn send(&self, bus: &Bus) -> Result<(), BusError> {
        match &self.seal {
            Some(seal) => bus.put_sealed(&self.key, self.bytes.clone(), seal).await,
            None => bus.put_raw(&self.key, self.bytes.clone()).await,
        }
    }
}

/// Clear commander `by`'s goals on `zone` and wait up to `within` until the goals in
/// force hold none of them, deleting again every second meanwhile. A delete is lost as a
/// put is (a tool's session that closes the moment it has sent, a link that drops it, a
/// coordinator taking over), and a person told "cleared" acts on it: under load in CI, a
/// `firefleet goal clear` said so while the coordinator kept the goal.
///
/// The goals in force are asked of everyone who holds them (`coord/goals`: the
/// coordinator, and recorders for one that is gone); the newest answer counts.
pub async fn clear(
    bus: &Bus,
    zone: &ZoneId,
    by: &CommanderId,
    within: Duration,
) -> Result<(), GoalError> {
    let now = tokio::time::Instant::now;
    let held = |g: &GoalsInForce| {
        g.goals
            .iter()
            .any(|g| &g.goal.zone == zone && g.goal.issued_by.as_ref() == Some(by))
    };
    let deadline = now() + within;
    let mut sealed = (now(), Delete::new(bus, zone, by));
    let mut answered = false;
    while now() < deadline {
        if sealed.0.elapsed() > RESEAL {
            sealed = (now(), Delete::new(bus, zone, by));
        }
        sealed.1.send(bus).await?;
        let resend = (now() + Duration::from_secs(1)).min(deadline);
        while now() < resend {
            let newest = in_force(bus, resend - now())
                .await?
                .into_iter()
                .max_by(|a, b| a.t.total_cmp(&b.t));
            if let Some(goals) = newest {
                if !held(&goals) {
                    return Ok(());
                }
                answered = true;
            }
            tokio::time::sleep_until((now() + Duration::from_millis(100)).min(resend)).await;
        }
    }
    Err(if answered {
        GoalError::Refused(format!(
            "{by}'s goals on zone {zone} are still in force after {:.0} s (the coordinator's log says why it kept them)",
            within.as_secs_f64()
        ))
    } else {
        GoalError::NoAnswer(within)
    })
}

/// Every answer to `coord/goals` within `within` but this process's own: the
/// coordinator's, and each recorder's copy for a coordinator that is gone (a recalling
/// coordinator's own queryable answers only once it runs, and would hold the question open
/// for the whole time). Answers that do not decode are counted and logged; the asker takes
/// the newest.
pub async fn in_force(bus: &Bus, within: Duration) -> Result<Vec<GoalsInForce>, BusError> {
    let ask = Ask {
        every_answer: true,
        remote_only: true,
        ..Ask::within(within)
    };
    let answers = bus.ask(bus.keys().coord_goals().as_str(), ask).await?;
    Ok(answers
        .all()
        .await
        .iter()
        .filter_map(|a| bus.decode::<GoalsInForce>(a, "goals in force"))
        .collect())
}

/// Delete commander `by`'s goals on `zone` once, sealed where the bus can seal, without
/// waiting to see them gone: for scripted commanders that read the goals in force
/// themselves.
pub async fn delete(bus: &Bus, zone: &ZoneId, by: &CommanderId) -> Result<(), BusError> {
    Delete::new(bus, zone, by).send(bus).await
}

/// A clear ready to send: the goal key, and its seal.
struct Delete {
    key: String,
    seal: Option<Seal>,
}

impl Delete {
    fn new(bus: &Bus, zone: &ZoneId, by: &CommanderId) -> Self {
        let key = bus.keys().zone_goal(zone, by).as_str().to_owned();
        let seal = bus.seals().map(|s| s.sealer.seal(&key, None));
        Self { key, seal }
    }

    async fn send(&self, bus: &Bus) -> Result<(), BusError> {
        bus.delete(&self.key, self.seal.as_ref()).await
    }
}

/// Why an ask to suspend could not be made.
#[derive(Debug, thiserror::Error)]
pub enum SuspendError {
    #[error(transparent)]
    Bus(#[from] BusError),
    #[error(
        "a suspension is sealed by whoever asks: this session has no identity (a site without a PKI has nothing to suspend)"
    )]
    Unsealed,
}

/// Ask, as this session's identity (a commander, or the coordinator's for its host's
/// operator), that identity `target` be suspended for `reason`: put sealed on
/// `trust/suspend/<target>/<this identity>`. Two commanders' asks, or the coordinator's
/// key's, suspend it.
pub async fn suspend(
    bus: &Bus,
    target: &crate::access::Identity,
    reason: &str,
) -> Result<(), SuspendError> {
    let seals = bus.seals().ok_or(SuspendError::Unsealed)?;
    let key = bus
        .keys()
        .suspend(&target.dir_name(), &seals.sealer.identity().dir_name());
    let bytes = codec::encode(&firefleet_protocol::msg::Suspension {
        reason: reason.to_owned(),
    });
    let seal = seals.sealer.seal(key.as_str(), Some(&bytes));
    Ok(bus.put_sealed(key.as_str(), bytes, &seal).await?)
}
