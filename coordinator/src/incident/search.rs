//! Search: where units' sensors have looked ([`crate::coverage`]), and free units sent to
//! look where nobody has for a while: ground units to the ends of unseen stretches,
//! monorail carriages from end to end of their rails.
//!
//! Not here: staging free units near fires ([`super::staging`]).

use std::collections::{BTreeMap, BTreeSet};

use firefleet_model::UnitKind;
use firefleet_model::geometry::wrap_angle;
use firefleet_model::{Chainage, Point2, Pose2, UnitId};
use firefleet_protocol::msg::TaskKind;

use crate::assign::Mobility;

use super::{Decision, Incident, Output};

impl Incident {
    /// The chainages a unit's sensors take in where it stands: a ground unit's camera
    /// looks ahead along the road (and its heat sensors feel the few metres behind it), a
    /// carriage's detector looks both ways along its rail.
    pub(super) fn sight(&self, mobility: &Mobility, pose: Pose2) -> (Chainage, Chainage) {
        let s = self.tunnel.chainage(pose.position());
        match mobility {
            Mobility::Rail {
                detector_range_m, ..
            } => (s - *detector_range_m, s + *detector_range_m),
            Mobility::Ground(g) => {
                let range = g.camera_range_m;
                if (pose.yaw - self.tunnel.heading_at(s)).cos() >= 0.0 {
                    (s - self.policy.sight_behind_m, s + range)
                } else {
                    (s - range, s + self.policy.sight_behind_m)
                }
            }
        }
    }

    /// Whether a flame at a point is one a unit at `pose` cannot miss
    /// ([`super::Policy::clear_view_m`]).
    ///
    /// [`super::Policy::clear_view_m`]: super::Policy::clear_view_m
    pub(super) fn clear_view(
        &self,
        mobility: &Mobility,
        pose: Pose2,
    ) -> impl Fn(Point2) -> bool + use<> {
        let range = self.policy.clear_view_m;
        let half_angle = match mobility {
            Mobility::Rail { .. } => std::f64::consts::PI,
            Mobility::Ground(g) => 0.75 * g.camera_hfov_rad / 2.0,
        };
        let at = pose.position();
        move |p| at.dist(p) <= range && wrap_angle(at.bearing_to(p) - pose.yaw).abs() <= half_angle
    }

    /// Free ground units search the stretches nobody has looked at for
    /// [`super::Policy::search_again_after_s`] (less barred zones): each end of each unseen stretch gets
    /// the nearest free unit on its side, nearest pairs first. Searched from both ends, a
    /// stretch is split at its middle; from one, the unit drives through to its far end.
    /// A unit already searching keeps its goal unless the new one is
    /// [`super::Policy::search_goal_slack_m`] away. Returns the tasks and the units searching.
    pub(super) fn search(&mut self, t: f64) -> (Vec<Output>, BTreeSet<UnitId>) {
        // Not the portals' mouths: units come in through them, and the incident's command
        // post sees them from outside.
        let mouth = self.policy.portal_m.min(self.tunnel.length_m / 2.0);
        let (lo, hi) = (Chainage::ZERO + mouth, self.tunnel.end() - mouth);
        let mut gaps: Vec<(Chainage, Chainage)> = self
            .coverage
            .gaps(t - self.policy.search_again_after_s)
            .into_iter()
            .map(|(a, b)| (a.max(lo), b.min(hi)))
            .filter(|(a, b)| b > a)
            .collect();
        let barred = self.goals.barred(UnitKind::Ground);
        for &(bs, be) in &barred {
            let (lo, hi) = (
                bs - self.policy.evacuate_margin_m,
                be + self.policy.evacuate_margin_m,
            );
            gaps = gaps
                .into_iter()
                .flat_map(|(a, b)| [(a, b.min(lo)), (a.max(hi), b)])
                .filter(|(a, b)| b > a)
                .collect();
        }
        let free = self.free_ground_units(&BTreeSet::new());
        let searching_now = |u: &UnitId| {
            matches!(
                self.units[u].task.as_ref().map(|t| t.kind),
                Some(TaskKind::Search { .. })
            )
        };
        // (cost, unit, gap, from the west): the distance to the stretch's near end, less
        // the slack for a unit already searching, so that two units side by side do not
        // trade places at every solve.
        let mut pairs: Vec<(f64, usize, usize, bool)> = Vec::new();
        for (k, c) in free.iter().enumerate() {
            let s = c.at.chainage;
            for (g, &(a, b)) in gaps.iter().enumerate() {
                let west = s < a.midpoint(b);
                // No way to a stretch through a barred zone.
                let end = if west { a } else { b };
                let (lo, hi) = (s.min(end), s.max(end));
                if barred.iter().any(|&(bs, be)| lo < be && hi > bs) {
                    continue;
                }
                let d = if west { a - s } else { s - b }.max(0.0);
                let bonus = if searching_now(&c.unit) {
                    self.policy.search_goal_slack_m
                } else {
                    0.0
                };
                pairs.push((d - bonus, k, g, west));
            }
        }
        pairs.sort_by(|x, y| x.0.total_cmp(&y.0));
        let mut taken_units = vec![false; free.len()];
        let mut ends: BTreeMap<(usize, bool), usize> = BTreeMap::new();
        for (_, k, g, west) in pairs {
            if !taken_units[k] && !ends.contains_key(&(g, west)) {
                taken_units[k] = true;
                ends.insert((g, west), k);
            }
        }
        let mut out = Vec::new();
        let mut searching = BTreeSet::new();
        for (&(g, west), &k) in &ends {
            let (a, b) = gaps[g];
            let both = ends.contains_key(&(g, !west));
            let x = match (both, west) {
                (true, _) => a.midpoint(b),
                (false, true) => b,
                (false, false) => a,
            };
            let Some(x) =
                self.goals
                    .nearest_allowed(x.clamp(lo, hi), self.policy.evacuate_margin_m, lo, hi)
            else {
                continue;
            };
            let c = &free[k];
            let lane = self
                .tunnel
                .lane_nearest(self.tunnel.station(c.at.position).d);
            let goal = self.tunnel.point_at(x, lane);
            searching.insert(c.unit.clone());
            let current = self.units[&c.unit].task.as_ref().map(|t| t.kind);
            // The slack keeps a goal, never one a goal has barred since: a keep-out's
            // edge can fall within it of the new goal (a search to a zone's boundary).
            if matches!(current, Some(TaskKind::Search { goal: now })
                if now.dist(goal) < self.policy.search_goal_slack_m
                    && self.goal_at(now).is_none_or(|g| !g.bars_entry()))
            {
                continue;
            }
            out.push(self.give(&c.unit, TaskKind::Search { goal }, t));
            self.log(
                t,
                Decision::Search {
                    unit: c.unit.clone(),
                    from: a,
                    to: b,
                    goal,
                },
            );
        }
        (out, searching)
    }

    /// Free monorail units search their rail from end to end and back: at 10 m/s, with a
    /// thermal camera that sees 40 m, a carriage finds in half a minute what a ground
    /// unit finds in three (the portals are where ground units come in, and they drive at
    /// 1.5 m/s). Alone, a monorail unit waits where it is (the ROBOGAT tree); a
    /// coordinator puts it to use. The run keeps out of barred zones: it turns at the
    /// first one either side.
    pub(super) fn patrol_rails(&mut self, t: f64) -> Vec<Output> {
        let barred = self.goals.barred_space(t);
        let runs: Vec<(UnitId, Point2)> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && v.working_on().is_none())
            .filter_map(|(u, v)| {
                let Mobility::Rail { rail, .. } = &v.mobility else {
                    return None;
                };
                let (start_m, end_m, y_m) = (rail.start_m, rail.end_m, rail.y_m);
                let rail = UnitKind::Monorail;
                let x = self.tunnel.chainage(v.state.as_ref()?.pose.position());
                // A carriage inside barred space leaves it on its own first.
                if barred.entry_at(rail, x).is_some() {
                    return None;
                }
                let margin = self.policy.evacuate_margin_m;
                let lo = barred.reach(rail, x, Chainage::new(start_m), margin);
                let hi = barred.reach(rail, x, Chainage::new(end_m), margin);
                if hi - lo < 2.0 * self.policy.rail_run_done_m {
                    return None;
                }
                let searching = match v.task.as_ref().map(|t| t.kind) {
                    Some(TaskKind::Search { goal }) => {
                        let goal = self.tunnel.chainage(goal);
                        (lo..=hi).contains(&goal) && (goal - x).abs() > self.policy.rail_run_done_m
                    }
                    _ => false,
                };
                // The farther end: from one end, the other.
                let end = if x - lo > hi - x { lo } else { hi };
                (!searching).then(|| (u.clone(), self.tunnel.point_at(end, y_m)))
            })
            .collect();
        let mut out = Vec::new();
        for (unit, goal) in runs {
            out.push(self.give(&unit, TaskKind::Search { goal }, t));
            self.log(t, Decision::SearchRail { unit, to: goal });
        }
        out
    }
}
