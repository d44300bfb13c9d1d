//! Staging: free ground units that neither attack nor search wait short of the nearest
//! active fire (or hold a contain line), or search on past fires a goal leaves burning, or
//! are released to patrol.
//!
//! Not here: which unit attacks which fire ([`super::dispatch`]).

use std::collections::{BTreeMap, BTreeSet};

use firefleet_model::{Chainage, FireId, Point2, UnitId};
use firefleet_protocol::msg::{FireState, GoalKind, TaskKind};

use crate::assign::Mobility;

use super::{Decision, Incident, Output};

impl Incident {
    /// Free units (but the `searching`) wait [`super::Policy::stage_offset_m`] short of the nearest
    /// active fire, on their own side and in their lane, at most [`super::Policy::reserves_per_fire`] per
    /// fire; the others patrol on their own.
    pub(super) fn stage(&mut self, searching: &BTreeSet<UnitId>, t: f64) -> Vec<Output> {
        let burning = |f: &&crate::fusion::Fire| {
            matches!(
                f.state,
                FireState::Confirmed | FireState::Assigned | FireState::Suppressing
            )
        };
        let active: Vec<(FireId, Point2)> = self
            .fusion
            .fires()
            .iter()
            .filter(burning)
            // Reserves wait for fires two sources have seen: one unit's word alone
            // (perhaps a liar's) does not draw the fleet.
            .filter(|f| f.corroborated())
            .filter(|f| !self.attack_barred_at(f.position()))
            .map(|f| (f.id, f.position()))
            .collect();
        // Fires left burning by a goal hold no reserves; free units search on past them.
        let left_burning = self
            .fusion
            .fires()
            .iter()
            .filter(burning)
            .any(|f| self.attack_barred_at(f.position()));
        let free: Vec<(UnitId, Point2, Option<TaskKind>, Mobility)> = self
            .units
            .iter()
            .filter(|(u, v)| v.alive && v.working_on().is_none() && !searching.contains(*u))
            // Monorail units wait where they are: their carriages reach a fire in seconds.
            .filter(|(_, v)| matches!(v.mobility, Mobility::Ground(_)))
            .filter_map(|(u, v)| {
                Some((
                    u.clone(),
                    v.state.as_ref()?.pose.position(),
                    v.task.as_ref().map(|t| t.kind),
                    v.mobility.clone(),
                ))
            })
            // Units leaving a barred zone keep their way out.
            .filter(|(_, at, ..)| !self.goal_at(*at).is_some_and(|g| g.bars_entry()))
            .collect();
        // Reserves wait upwind while the air moves: downstream is the fire's smoke.
        let upwind = match self.approach(t) {
            firefleet_protocol::msg::Approach::Start => Some(-1.0),
            firefleet_protocol::msg::Approach::End => Some(1.0),
            firefleet_protocol::msg::Approach::Either => None,
        };
        // Units wait and search at least this far inside the portals, m.
        const INSIDE_M: f64 = 5.0;
        let (lo, hi) = (Chainage::ZERO + INSIDE_M, self.tunnel.end() - INSIDE_M);
        let mut out = Vec::new();
        // With the air moving, a free unit downwind of a burning fire and within its hot
        // gas ([`super::Policy::hot_smoke_heights`]) withdraws out of it, downstream (to
        // the portal at most), and is nobody's reserve (it would have to drive through the
        // fire to wait upwind). The others wait upwind.
        let mut free = free;
        if let Some(side) = upwind {
            let reach = self.policy.hot_smoke_heights * self.tunnel.height_m;
            let fires: Vec<(FireId, Chainage)> = self
                .fusion
                .fires()
                .iter()
                .filter(burning)
                .map(|f| (f.id, self.tunnel.chainage(f.position())))
                .collect();
            let mut leaving = Vec::new();
            free.retain(|(unit, at, current, _)| {
                let s = self.tunnel.chainage(*at);
                // The fires upwind of the unit whose hot gas reaches it; it leaves the
                // reach of the one furthest downstream.
                let Some(&(fire, edge)) = fires
                    .iter()
                    .filter(|(_, f)| (s - *f) * side < 0.0 && (s - *f).abs() < reach)
                    .max_by(|a, b| ((a.1 - b.1) * -side).total_cmp(&0.0))
                else {
                    return true;
                };
                let out_of_reach = (edge - side * reach).clamp(lo, hi);
                let to = self
                    .goals
                    .nearest_allowed(out_of_reach, self.policy.evacuate_margin_m, lo, hi)
                    .unwrap_or(s);
                let goal = self
                    .tunnel
                    .point_at(to, self.tunnel.lane_nearest(self.tunnel.station(*at).d));
                if !matches!(current, Some(TaskKind::Cruise { goal: g }) if g.dist(goal) < 3.0) {
                    leaving.push((unit.clone(), fire, goal));
                }
                false
            });
            for (unit, fire, goal) in leaving {
                out.push(self.give(&unit, TaskKind::Cruise { goal }, t));
                self.log(
                    t,
                    Decision::LeaveSmoke {
                        unit,
                        fire,
                        to: goal,
                    },
                );
            }
        }
        // Each free unit's nearest active fire; each fire keeps its nearest
        // `reserves_per_fire` within `help_within_s` (any distance to hold a contain
        // line), the others patrol (a thousand units must not converge on the first fire
        // reported).
        let holds_a_line = |f: Point2| {
            self.goal_at(f)
                .is_some_and(|g| g.goal.goal == GoalKind::Contain)
        };
        let nearest: Vec<Option<&(FireId, Point2)>> = free
            .iter()
            .map(|(_, at, _, mobility)| {
                active
                    .iter()
                    .min_by(|a, b| a.1.dist(*at).total_cmp(&b.1.dist(*at)))
                    .filter(|(_, f)| {
                        holds_a_line(*f)
                            || mobility
                                .travel_s(*at, *f)
                                .is_some_and(|s| s <= self.policy.help_within_s)
                    })
            })
            .collect();
        let mut order: Vec<usize> = (0..free.len()).collect();
        order.sort_by(|&i, &j| {
            let d = |k: usize| nearest[k].map_or(f64::INFINITY, |f| f.1.dist(free[k].1));
            d(i).total_cmp(&d(j))
        });
        let mut kept: BTreeMap<FireId, usize> = BTreeMap::new();
        let mut reserve = vec![false; free.len()];
        for i in order {
            if let Some((fire, _)) = nearest[i] {
                let n = kept.entry(*fire).or_default();
                if *n < self.policy.reserves_per_fire {
                    *n += 1;
                    reserve[i] = true;
                }
            }
        }
        for (k, (unit, at, current, _)) in free.into_iter().enumerate() {
            let nearest = nearest[k].filter(|_| reserve[k]);
            let at = self.tunnel.station(at);
            let goal = nearest.map(|&(fire, f)| {
                let f = self.tunnel.chainage(f);
                let side = upwind.unwrap_or(if at.s <= f { -1.0 } else { 1.0 });
                // Under a contain goal, reserves hold the line the front must not pass.
                let s = match self.goals.at(f).map(|g| (g.goal.goal, g.goal.before_m)) {
                    Some((GoalKind::Contain, Some(line))) => Chainage::new(line),
                    _ => f + side * self.policy.stage_offset_m,
                };
                let s = self
                    .goals
                    .nearest_allowed(s, self.policy.evacuate_margin_m, lo, hi)
                    .unwrap_or(at.s)
                    .clamp(lo, hi);
                (
                    fire,
                    self.tunnel.point_at(s, self.tunnel.lane_nearest(at.d)),
                )
            });
            match (goal, current) {
                (Some((_, g)), Some(TaskKind::Cruise { goal })) if goal.dist(g) < 3.0 => {}
                (Some((fire, g)), _) => {
                    out.push(self.give(&unit, TaskKind::Cruise { goal: g }, t));
                    self.log(t, Decision::Stage { unit, at: g, fire });
                }
                (None, current) if left_burning => {
                    // Search the rest of the tunnel, away from where the unit came in.
                    let end = if at.s.m() < self.tunnel.length_m / 2.0 {
                        self.tunnel.end() - self.policy.portal_m
                    } else {
                        Chainage::ZERO + self.policy.portal_m
                    };
                    let Some(x) =
                        self.goals
                            .nearest_allowed(end, self.policy.evacuate_margin_m, lo, hi)
                    else {
                        continue;
                    };
                    let g = self.tunnel.point_at(x, at.d);
                    if matches!(current, Some(TaskKind::Search { goal }) if goal.dist(g) < 3.0) {
                        continue;
                    }
                    out.push(self.give(&unit, TaskKind::Search { goal: g }, t));
                    self.log(t, Decision::SearchOn { unit, goal: g });
                }
                (None, Some(TaskKind::Cruise { .. } | TaskKind::Search { .. })) => {
                    out.push(self.standby(&unit, t));
                    self.log(t, Decision::ReleaseToPatrol { unit });
                }
                (None, _) => {}
            }
        }
        out
    }
}
