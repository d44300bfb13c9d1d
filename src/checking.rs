//! A recording through the incident's invariants: what `firefleet check` prints and the
//! nemesis judges its runs by; and the simulator's burning fires as the invariants' event,
//! which the in-process experiments feed them too.
//!
//! Not here: the invariants themselves (`firefleet_coordinator::invariants`) or reading MCAP
//! records (`firefleet_recorder::parts`, `firefleet_protocol::payload`); this feeds one to
//! the other.

use firefleet_coordinator::invariants::{Event, Invariants, Tally, Violation};
use firefleet_model::scenario::Scenario;
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{SimTruth, TruthFireState};
use firefleet_protocol::payload::{GoalClear, Payload};
use firefleet_recorder::parts::Recording;

/// What the checker found in a recording.
pub struct Checked {
    pub violations: Vec<Violation>,
    /// How many of its messages are of the site.
    pub messages: usize,
    pub continuity: Tally,
}

/// The invariants over `recording` of `scenario`'s site, whose coordinator counted units
/// silent for `lease_s` lost.
pub fn check(recording: &Recording, scenario: &Scenario, lease_s: f64) -> anyhow::Result<Checked> {
    let mut inv = Invariants::with_lease(scenario, lease_s);
    let (mut t, mut messages) = (0.0, 0usize);
    for m in recording.messages() {
        let m = match m {
            Ok(m) => m,
            Err(e) if messages == 0 => anyhow::bail!("not an MCAP recording: {e}"),
            Err(e) => {
                eprintln!("a file of the recording is cut short: {e}");
                continue;
            }
        };
        let Ok((site, topic)) = keys::parse(&m.channel.topic) else {
            continue;
        };
        if site != scenario.site {
            continue;
        }
        messages += 1;
        let event = match (&topic, Payload::from_json(&topic, &m.data)) {
            // A clear is told apart by its schema: a goal's JSON would parse as one too.
            (Topic::ZoneGoal(zone, by), _)
                if m.channel.schema.as_ref().map(|s| s.name.as_str()) == Some(GoalClear::NAME) =>
            {
                Some(Event::Clear {
                    zone: zone.clone(),
                    by: by.clone(),
                })
            }
            (_, Ok(Payload::SimClock(c))) => {
                t = c.t;
                None
            }
            (_, Ok(Payload::UnitState(s))) => {
                t = s.t;
                Some(Event::State(s))
            }
            (_, Ok(Payload::Task(task))) => {
                t = task.t;
                Some(Event::Task(task))
            }
            (_, Ok(Payload::SimTruth(truth))) => {
                t = truth.t;
                Some(burning(&truth))
            }
            (Topic::ZoneGoal(zone, by), Ok(Payload::Goal(goal))) => Some(Event::Goal {
                key_zone: zone.clone(),
                by: by.clone(),
                goal,
            }),
            _ => None,
        };
        if let Some(e) = event {
            inv.observe(t, e);
        }
    }
    Ok(Checked {
        violations: inv.violations().to_vec(),
        messages,
        continuity: inv.continuity(),
    })
}

/// Where `truth` has fires burning, for the checker.
pub fn burning(truth: &SimTruth) -> Event {
    Event::Burning(
        truth
            .fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
            .map(|f| f.position)
            .collect(),
    )
}
