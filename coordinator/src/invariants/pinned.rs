//! Units pinned against a wall, a vehicle or another unit, read from the simulator's
//! count of each unit's blocked steps.
//!
//! A blocked step is one the simulator refused: the unit's footprint would have entered
//! something, so it stayed where it was and stopped. A unit that grazes a kerb while
//! turning has a few; one that drives into a vehicle again and again, or two units nose
//! to nose in one lane, have one a step for as long as it lasts (1763 for one unit in one
//! 3 km incident before this check; 0 on every shipped scenario). The checker fails a
//! recording in which a unit's blocked steps rise by more than [`MAX_BLOCKED_PER_WINDOW`]
//! within any [`WINDOW_S`]: at the simulator's 0.05 s step, five seconds of a minute spent
//! pushing against something.
//!
//! Not here: why it was pinned (its planner, its follower, another unit in the way), or
//! what the simulator counts as a collision (`firefleet-sim`).

use std::collections::{BTreeMap, VecDeque};

use firefleet_model::UnitId;

/// The window blocked steps are counted over, s of site time.
pub const WINDOW_S: f64 = 60.0;
/// Most blocked steps of one unit within any [`WINDOW_S`] before it counts as pinned.
pub const MAX_BLOCKED_PER_WINDOW: u32 = 100;

/// Each unit's recent counts.
#[derive(Debug, Default)]
pub(super) struct Pinned {
    /// Per unit, (site time, blocked steps so far) within the last window.
    counts: BTreeMap<UnitId, VecDeque<(f64, u32)>>,
    tally: BlockedTally,
}

/// How much the units were blocked over a history.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct BlockedTally {
    /// Blocked steps of all units.
    pub steps: u32,
    /// The most blocked steps of one unit within one [`WINDOW_S`], and that unit.
    pub worst: Option<(UnitId, u32)>,
}

impl Pinned {
    /// The simulator counted `blocked` steps for each unit by `t`; the units whose rise
    /// within the window is past [`MAX_BLOCKED_PER_WINDOW`], with that rise.
    pub(super) fn counts(&mut self, blocked: &[(UnitId, u32)], t: f64) -> Vec<(UnitId, u32)> {
        let mut pinned = Vec::new();
        for (unit, n) in blocked {
            let seen = self.counts.entry(unit.clone()).or_default();
            seen.push_back((t, *n));
            while seen.front().is_some_and(|&(s, _)| t - s > WINDOW_S) {
                seen.pop_front();
            }
            // A restarted simulator counts from 0 again: a fall is no rise.
            let rise = seen
                .front()
                .map_or(0, |&(_, first)| n.saturating_sub(first));
            if self.tally.worst.as_ref().is_none_or(|(_, w)| rise > *w) {
                self.tally.worst = Some((unit.clone(), rise));
            }
            if rise > MAX_BLOCKED_PER_WINDOW {
                pinned.push((unit.clone(), rise));
            }
        }
        self.tally.steps = self
            .counts
            .values()
            .filter_map(|c| c.back().map(|&(_, n)| n))
            .sum();
        pinned
    }

    pub(super) fn tally(&self) -> BlockedTally {
        self.tally.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(s: &str) -> UnitId {
        UnitId::new(s).unwrap()
    }

    #[test]
    fn a_unit_blocked_every_step_for_seconds_is_pinned_and_a_graze_is_not() {
        let mut p = Pinned::default();
        let mut flagged = Vec::new();
        // ugv-1 grazes a kerb twice a minute; ugv-2 is blocked every step from t = 10 s.
        for k in 0..=400u32 {
            let t = 0.05 * f64::from(k) * 5.0;
            let graze = k / 200 * 2;
            let pinned = if t >= 10.0 {
                ((t - 10.0) / 0.05) as u32
            } else {
                0
            };
            flagged.extend(p.counts(&[(u("ugv-1"), graze), (u("ugv-2"), pinned)], t));
        }
        assert!(flagged.iter().all(|(unit, _)| unit == &u("ugv-2")));
        assert!(!flagged.is_empty());
        assert!(
            p.tally()
                .worst
                .is_some_and(|(unit, n)| unit == u("ugv-2") && n > 1000)
        );
    }

    #[test]
    fn a_restarted_simulator_counting_from_zero_is_no_rise() {
        let mut p = Pinned::default();
        assert!(p.counts(&[(u("a"), 500)], 0.0).is_empty());
        assert!(p.counts(&[(u("a"), 0)], 1.0).is_empty());
        assert!(p.counts(&[(u("a"), 50)], 2.0).is_empty());
    }
}
