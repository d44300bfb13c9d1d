//! Assignment churn: how often a fire's attackers change, read from the tasks the
//! coordinator sent.
//!
//! A change is a unit given a fire it was not on (an assignment, a backup joining, a
//! takeover) or taken off the fire it was on (a release, a stand-down). Re-sent tasks,
//! retargets on the same fire and a fire's own re-estimates are not changes, and nor are
//! the decisions of one instant that undo each other: a unit assigned and released in the
//! same step (the solve that runs as each unit of a starting fleet is heard chains several
//! at t = 0) never moved for them, so only its net change at that instant counts. (Counted
//! as the tasks come, a fire's count can stand one above its net for the rest of that
//! instant, while one unit's change is not yet undone by the next.) Over a busy
//! minute a fire sees its first attacker and a backup come, one handover (two changes)
//! and its attackers stood down when it is out: about six. A coordinator that thrashes
//! assigns and releases the same unit every second or two, dozens a minute (2304
//! releases over one 3 km incident before this check). The checker fails a recording in
//! which one fire's attackers change more than [`MAX_CHANGES_PER_WINDOW`] times within
//! any [`WINDOW_S`].
//!
//! The coordinator keeps the same count of the tasks it gives, and holds a fire's
//! attackers once they changed [`HOLD_AT`] times within the window: no unit joins or
//! leaves that fire by the coordinator's choice until the window has let the oldest
//! changes go (`crate::incident`'s dispatch). One count, so that what the coordinator
//! bounds is what the checker measures.
//!
//! Not here: why the coordinator changed its mind (its decision log says), or whether the
//! change was right.

use std::collections::{BTreeMap, VecDeque};

use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::{Task, TaskKind};

use crate::assign::MAX_ATTACKERS;

/// The window churn is counted over, s of site time.
pub const WINDOW_S: f64 = 60.0;
/// Most changes to one fire's attackers within any [`WINDOW_S`] before it counts as
/// thrash: the busy minute's six and a margin of two.
pub const MAX_CHANGES_PER_WINDOW: usize = 8;
/// Changes within [`WINDOW_S`] after which the coordinator holds a fire's attackers:
/// the busy minute's first attacker, a backup and one handover. What a held fire still
/// sees in that minute is forced, and fits under [`MAX_CHANGES_PER_WINDOW`]: its
/// attackers stood down when it is out (up to [`MAX_ATTACKERS`]) and one unit more (the
/// first attacker of a fire that reignited, or the replacement of one lost or broken
/// down). A track that merges into a held fire has its units released, not added
/// (`Incident::release_merged`). Against a fake track that follows its liar,
/// merges with every track it meets and draws each one's unit into a rename and a
/// release, the hold is what keeps the count down: fire f1 of one CI run of the
/// around-fakes flood changed ten times within a minute without it.
pub const HOLD_AT: usize = MAX_CHANGES_PER_WINDOW - MAX_ATTACKERS - 1;

/// Each fire's changes so far.
#[derive(Debug, Default)]
pub(crate) struct Churn {
    /// The fire each unit's latest task sends it to, if any.
    on: BTreeMap<UnitId, FireId>,
    /// Per fire, the times of its changes within the last window.
    recent: BTreeMap<FireId, VecDeque<f64>>,
    tally: ChurnTally,
    /// The instant of the latest change, and per unit changed then: its fire before that
    /// instant and the fires its net change counted.
    instant: f64,
    this_instant: BTreeMap<UnitId, (Option<FireId>, Vec<FireId>)>,
}

/// How much the fleet's assignments churned over a history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ChurnTally {
    /// Every change to any fire's attackers.
    pub changes: usize,
    /// The most changes to one fire within one [`WINDOW_S`], and that fire.
    pub worst: Option<(FireId, usize)>,
}

impl Churn {
    /// `task` was sent at `t`; the fire and its count within the window when this change
    /// took it past [`MAX_CHANGES_PER_WINDOW`] (or further past it).
    pub(crate) fn task(&mut self, task: &Task, t: f64) -> Vec<(FireId, usize)> {
        let now = match task.kind {
            TaskKind::Extinguish { fire, .. } => Some(fire),
            _ => None,
        };
        let before = self.on.get(&task.unit).copied();
        if before == now {
            return Vec::new();
        }
        match now {
            Some(f) => self.on.insert(task.unit.clone(), f),
            None => self.on.remove(&task.unit),
        };
        if t != self.instant {
            self.instant = t;
            self.this_instant.clear();
        }
        let (start, counted) = self
            .this_instant
            .remove(&task.unit)
            .unwrap_or((before, Vec::new()));
        for fire in counted {
            self.retract(fire, t);
        }
        let net: Vec<FireId> = if start == now {
            Vec::new()
        } else {
            start.into_iter().chain(now).collect()
        };
        self.this_instant
            .insert(task.unit.clone(), (start, net.clone()));
        net.into_iter()
            .filter_map(|fire| self.change(fire, t))
            .collect()
    }

    /// Take back a change to `fire` counted at `t`, the current instant.
    fn retract(&mut self, fire: FireId, t: f64) {
        if let Some(times) = self.recent.get_mut(&fire)
            && let Some(k) = times.iter().rposition(|&s| s == t)
        {
            times.remove(k);
            self.tally.changes -= 1;
        }
    }

    fn change(&mut self, fire: FireId, t: f64) -> Option<(FireId, usize)> {
        self.tally.changes += 1;
        let times = self.recent.entry(fire).or_default();
        times.push_back(t);
        while times.front().is_some_and(|&s| t - s > WINDOW_S) {
            times.pop_front();
        }
        let n = times.len();
        if self.tally.worst.is_none_or(|(_, w)| n > w) {
            self.tally.worst = Some((fire, n));
        }
        (n > MAX_CHANGES_PER_WINDOW).then_some((fire, n))
    }

    pub(super) fn tally(&self) -> ChurnTally {
        self.tally.clone()
    }

    /// The fires whose attackers changed at least [`HOLD_AT`] times within the
    /// [`WINDOW_S`] up to `t`, with how many times.
    pub(crate) fn held(&self, t: f64) -> impl Iterator<Item = (FireId, usize)> + '_ {
        self.recent
            .iter()
            .filter(|(_, times)| times.len() >= HOLD_AT)
            .map(move |(fire, times)| {
                let n = times.iter().filter(|&&s| t - s <= WINDOW_S).count();
                (*fire, n)
            })
            .filter(|&(_, n)| n >= HOLD_AT)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::Point2;
    use firefleet_protocol::msg::Approach;

    fn task(unit: &str, seq: u64, fire: Option<u32>) -> Task {
        Task {
            unit: UnitId::new(unit).unwrap(),
            epoch: 1,
            seq,
            t: 0.0,
            kind: match fire {
                Some(f) => TaskKind::Extinguish {
                    fire: FireId(f),
                    target: Point2::new(10.0, 0.0),
                    from: Approach::Either,
                },
                None => TaskKind::Standby,
            },
        }
    }

    #[test]
    fn resent_tasks_are_no_change_and_a_handover_is_two() {
        let mut c = Churn::default();
        assert!(c.task(&task("a", 1, Some(1)), 0.0).is_empty());
        assert!(c.task(&task("a", 1, Some(1)), 1.0).is_empty(), "re-sent");
        assert!(c.task(&task("b", 1, Some(1)), 2.0).is_empty());
        assert!(c.task(&task("a", 2, None), 2.0).is_empty());
        assert_eq!(
            c.tally(),
            ChurnTally {
                changes: 3,
                worst: Some((FireId(1), 3))
            }
        );
    }

    #[test]
    fn decisions_that_undo_each_other_within_an_instant_are_no_change() {
        let mut c = Churn::default();
        // At one instant: a, then b, then c given fire 1, each relieving the one before
        // (the solve as each unit of a starting fleet is heard).
        c.task(&task("a", 1, Some(1)), 0.0);
        c.task(&task("b", 1, Some(1)), 0.0);
        c.task(&task("a", 2, None), 0.0);
        c.task(&task("c", 1, Some(1)), 0.0);
        c.task(&task("b", 2, None), 0.0);
        assert_eq!(c.tally().changes, 1, "only c came");
        // Later, c handed over to a: two changes.
        c.task(&task("a", 3, Some(1)), 5.0);
        c.task(&task("c", 2, None), 5.0);
        assert_eq!(c.tally().changes, 3);
    }

    #[test]
    fn a_unit_assigned_and_released_every_few_seconds_is_thrash() {
        let mut c = Churn::default();
        let mut flagged = Vec::new();
        for k in 0..10u32 {
            let t = 3.0 * f64::from(k);
            flagged.extend(c.task(&task("rail-1", 2 * u64::from(k), Some(1)), t));
            flagged.extend(c.task(&task("rail-1", 2 * u64::from(k) + 1, None), t + 0.3));
        }
        assert_eq!(
            flagged.first(),
            Some(&(FireId(1), MAX_CHANGES_PER_WINDOW + 1))
        );
        assert_eq!(c.tally().worst, Some((FireId(1), 20)));
    }

    #[test]
    fn changes_spread_over_the_incident_are_not() {
        let mut c = Churn::default();
        for k in 0..30u32 {
            let t = 20.0 * f64::from(k);
            let fire = Some(1 + k % 2);
            assert!(c.task(&task("a", u64::from(k), fire), t).is_empty());
        }
        assert!(
            c.tally()
                .worst
                .is_some_and(|(_, n)| n <= MAX_CHANGES_PER_WINDOW)
        );
    }
}
