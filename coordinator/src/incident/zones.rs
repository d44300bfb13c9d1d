//! Commanders' zone goals as the incident applies them: goals taken or refused, and what
//! goals in force mean for units already at work (withdrawn from fires they may no longer
//! attack, sent out of zones they may not be in).
//!
//! Which goal governs where is [`crate::goals`]' business; this module only acts on it.

use std::collections::BTreeMap;

use firefleet_model::{Chainage, CommanderId, Point2, UnitId, UnitKind, ZoneId};
use firefleet_protocol::msg::{
    BarredSpace, FireState, GoalAck, GoalInForce, GoalKind, GoalPreview, GoalsInForce,
    INSIDE_PORTAL_M, MAX_LIST, Sealed, Stranded, TaskKind, Trapped, ZoneGoal,
};

use crate::assign::Mobility;
use crate::goals::{Active, Goals};

use super::{Decision, Incident, Output};
use firefleet_bus::suspension::commander_name;

impl Incident {
    /// A commander's goal arrived on zone `key_zone`'s key: the acknowledgement, and the
    /// decisions it leads to when accepted.
    pub fn on_goal(
        &mut self,
        key_zone: &ZoneId,
        by: &CommanderId,
        goal: ZoneGoal,
        t: f64,
        proof: Option<Sealed>,
    ) -> (GoalAck, Vec<Output>) {
        if self.is_suspended(&commander_name(by)) {
            return (suspended_ack(&goal, by), Vec::new());
        }
        let mut ack = match proof {
            Some(p) => self.goals.submit_sealed(key_zone, by, goal.clone(), t, p),
            None => self.goals.submit(key_zone, by, goal.clone(), t),
        };
        if ack.accepted
            && let (GoalKind::Contain, Some(line)) = (goal.goal, goal.before_m)
            && !self.fire_in_zone(&goal.id)
        {
            // A contain goal changes nothing until its zone burns: say so, or the
            // commander sees no effect and no reason.
            ack.reason = format!(
                "{}; no fire in zone {} yet: when one is confirmed there, reserves will hold the line at {line:.1} m",
                ack.reason, goal.zone
            );
        }
        self.log(
            t,
            Decision::Goal {
                goal,
                accepted: ack.accepted,
                reason: ack.reason.clone(),
            },
        );
        if ack.accepted {
            (ack, self.enforce(t))
        } else {
            (ack, Vec::new())
        }
    }

    /// Whether a fire burns (confirmed, not out) in the zone of the goal in force `goal`.
    fn fire_in_zone(&self, goal: &str) -> bool {
        let Some(g) = self.goals.active().iter().find(|a| a.goal.id == goal) else {
            return false;
        };
        self.fusion
            .fires()
            .iter()
            .filter(|f| f.active() && f.state != FireState::Tentative)
            .any(|f| g.covers(self.tunnel.chainage(f.position())))
    }

    /// Goals a previous coordinator had in force, as `coord/goals` kept them: taken back
    /// (with when they took effect and lapse) before anything is decided, so that a
    /// restart lifts no keep-out. Each is logged; one no longer valid here (lapsed, its zone
    /// gone from the site file) is refused with the reason.
    pub fn restore_goals(&mut self, kept: &GoalsInForce, t: f64) -> (Vec<Output>, Vec<GoalAck>) {
        let mut refused = Vec::new();
        // Clears first, then goals in the order they were sealed: a goal sealed before a
        // clear stays cleared, and a newer version replaces an older one, never the other
        // way round.
        self.restore_suspensions(&kept.suspensions, t);
        for c in &kept.cleared {
            self.goals.note_cleared(c.clone());
        }
        let mut goals: Vec<&GoalInForce> = kept.goals.iter().collect();
        goals.sort_by_key(|g| g.proof.as_ref().map_or(0, |p| p.seal.at_ms));
        for g in goals {
            let by = g.goal.issued_by.as_ref().map(commander_name);
            if by.is_some_and(|b| self.is_suspended(&b)) {
                refused.push(GoalAck {
                    id: g.goal.id.clone(),
                    zone: g.goal.zone.clone(),
                    issued_by: g.goal.issued_by.clone(),
                    accepted: false,
                    reason: "its issuer is suspended".into(),
                });
                continue;
            }
            let ack = self.goals.restore(g, t);
            if ack.accepted {
                self.log(
                    t,
                    Decision::GoalRecalled {
                        goal: g.goal.clone(),
                        since: g.since,
                    },
                );
            } else {
                refused.push(ack);
            }
        }
        (self.enforce(t), refused)
    }

    /// The goals in force as of `t`, with the fires they strand, for `coord/goals`.
    pub fn goals_in_force(&self, t: f64) -> GoalsInForce {
        GoalsInForce {
            stranded: self.stranded(),
            trapped: self.trapped(),
            suspensions: self.suspensions.proofs(),
            ..self.goals.in_force(t)
        }
    }

    /// Units inside a zone they may not be in with nowhere to go, as of the last
    /// enforcement of the goals; the first [`MAX_LIST`].
    pub fn trapped(&self) -> Vec<Trapped> {
        self.trapped.values().take(MAX_LIST).cloned().collect()
    }

    /// Burning fires the goals in force leave with no unit allowed to reach or attack them:
    /// for each, the goal in the way of the nearest unit (the goal barring attack where it
    /// burns, if one does). A fire no unit could reach anyway (no unit alive) is not a
    /// goal's doing and is not listed. The first [`MAX_LIST`] fires, oldest first.
    ///
    /// Every unit is asked as the units themselves judge a task ([`BarredSpace::refuses`]);
    /// where nothing is barred, nothing is asked.
    pub fn stranded(&self) -> Vec<Stranded> {
        self.stranded_under(&self.goals)
    }

    /// [`Incident::stranded`] under `goals` instead of the goals in force.
    fn stranded_under(&self, goals: &Goals) -> Vec<Stranded> {
        let barred = goals.barred_space(0.0);
        if barred.spans.is_empty() {
            return Vec::new();
        }
        let units: Vec<(UnitKind, Chainage)> = self
            .units
            .values()
            .filter(|v| v.alive)
            .filter_map(|v| {
                let st = v.state.as_ref()?;
                Some((v.mobility.kind(), self.tunnel.chainage(st.pose.position())))
            })
            .collect();
        if units.is_empty() {
            return Vec::new();
        }
        let mut out = Vec::new();
        for f in self.fusion.fires() {
            if !matches!(
                f.state,
                FireState::Confirmed | FireState::Assigned | FireState::Suppressing
            ) {
                continue;
            }
            let at = self.tunnel.chainage(f.position());
            let mut nearest: Option<(f64, &firefleet_protocol::msg::BarredSpan)> = None;
            let mut reachable = false;
            for &(kind, from) in &units {
                match barred.refuses(&self.tunnel, kind, from, at, true) {
                    None => {
                        reachable = true;
                        break;
                    }
                    Some((_, span)) => {
                        let d = (from.m() - at.m()).abs();
                        if nearest.is_none_or(|(best, _)| d < best) {
                            nearest = Some((d, span));
                        }
                    }
                }
            }
            let Some((_, span)) = nearest.filter(|_| !reachable) else {
                continue;
            };
            let issued_by = goals
                .active()
                .iter()
                .find(|a| a.goal.id == span.goal)
                .and_then(|a| a.goal.issued_by.clone());
            out.push(Stranded {
                fire: f.id,
                at: f.position(),
                goal: span.goal.clone(),
                zone: span.zone.clone(),
                issued_by,
                inside: span.covers(at),
            });
            if out.len() == MAX_LIST {
                break;
            }
        }
        out
    }

    /// Grows with every change to the goals in force (and so to what they bar).
    pub fn goals_revision(&self) -> u64 {
        self.goals.revision()
    }

    /// Every goal on `zone` withdrawn by a commander.
    pub fn clear_goals(
        &mut self,
        zone: &ZoneId,
        by: &CommanderId,
        t: f64,
        proof: Option<Sealed>,
    ) -> Vec<Output> {
        let cleared = match proof {
            Some(p) => self.goals.clear_sealed(zone, by, p),
            None => self.goals.clear(zone, by),
        };
        if cleared.is_empty()
            && let Some(a) = self.goals.active().iter().find(|a| &a.goal.zone == zone)
        {
            let d = Decision::ClearHeld {
                zone: zone.clone(),
                by: by.clone(),
                held: a.goal.id.clone(),
                issuer: a.goal.issuer().to_owned(),
                rank: a.rank,
            };
            self.log(t, d);
        }
        for g in cleared {
            self.log(
                t,
                Decision::GoalCleared {
                    zone: zone.clone(),
                    goal: g.id,
                    by: by.clone(),
                },
            );
        }
        self.enforce(t)
    }

    /// What the goals in force bar, as units are told at site time `t`.
    pub fn barred_space(&self, t: f64) -> BarredSpace {
        self.goals.barred_space(t)
    }

    /// The goals in force.
    pub fn goals(&self) -> impl Iterator<Item = &ZoneGoal> {
        self.goals.active().iter().map(|a| &a.goal)
    }

    /// The goal governing where `p` is.
    pub(super) fn goal_at(&self, p: Point2) -> Option<&Active> {
        self.goals.at(self.tunnel.chainage(p))
    }

    /// Whether a goal bars attacking a fire at `p`.
    pub(super) fn attack_barred_at(&self, p: Point2) -> bool {
        self.goal_at(p).is_some_and(|g| g.bars_attack())
    }

    /// Where a ground unit at chainage `s` must go under `goals`: nothing if no goal bars
    /// it there, else the goal that does and the chainage to leave to (none: trapped).
    fn way_out<'g>(&self, goals: &'g Goals, s: Chainage) -> Option<(&'g Active, Option<Chainage>)> {
        let g = goals.at(s).filter(|g| g.bars_entry())?;
        let to = goals.nearest_allowed(
            s,
            self.policy.evacuate_margin_m,
            Chainage::new(INSIDE_PORTAL_M),
            self.tunnel.end() - INSIDE_PORTAL_M,
        );
        Some((g, to))
    }

    /// The ground units `goals` would trap where they are now.
    fn trapped_under(&self, goals: &Goals) -> Vec<Trapped> {
        self.units
            .iter()
            .filter(|(_, v)| v.alive && matches!(v.mobility, Mobility::Ground(_)))
            .filter_map(|(u, v)| {
                let at = self.tunnel.chainage(v.state.as_ref()?.pose.position());
                match self.way_out(goals, at)? {
                    (g, None) => Some(trapped_by(u, g)),
                    (_, Some(_)) => None,
                }
            })
            .take(MAX_LIST)
            .collect()
    }

    /// What goal `goal`, from commander `by` on zone `key_zone`'s key, would do if it were
    /// taken at `t`: the answer it would get, the fires the goals would then strand and the
    /// units they would trap. Nothing changes (the goals are copied).
    pub fn preview(
        &self,
        key_zone: &ZoneId,
        by: &CommanderId,
        goal: ZoneGoal,
        t: f64,
    ) -> GoalPreview {
        if self.is_suspended(&commander_name(by)) {
            return GoalPreview {
                ack: suspended_ack(&goal, by),
                stranded: Vec::new(),
                trapped: Vec::new(),
                t,
            };
        }
        let mut goals = self.goals.clone();
        let ack = goals.submit(key_zone, by, goal, t);
        let (stranded, trapped) = if ack.accepted {
            (self.stranded_under(&goals), self.trapped_under(&goals))
        } else {
            (Vec::new(), Vec::new())
        };
        GoalPreview {
            ack,
            stranded,
            trapped,
            t,
        }
    }

    /// Apply the goals in force to the units, then re-solve: what a change of the goals
    /// calls for.
    pub(super) fn enforce(&mut self, t: f64) -> Vec<Output> {
        let mut out = self.hold_to_goals(t);
        out.extend(self.solve(t));
        out
    }

    /// Apply the goals in force to the units: withdraw units from fires they may no longer
    /// attack, move units out of zones they may not be in. Whether that changed anything
    /// (a task, or who is trapped) is for the caller's solve: the periodic tick re-solves
    /// everything only then (a whole solve takes about 10 ms at 1000 units and 200 fires,
    /// and a flame report arriving during one waits for it).
    pub(super) fn hold_to_goals(&mut self, t: f64) -> Vec<Output> {
        let mut out = Vec::new();
        let mut trapped = BTreeMap::new();
        let units: Vec<UnitId> = self.units.keys().cloned().collect();
        for u in units {
            let v = &self.units[&u];
            if !v.alive {
                continue;
            }
            if let Some(fire) = v.working_on()
                && let Some(f) = self.fusion.get(self.fusion.resolve(fire))
                && let Some(g) = self.goal_at(f.position())
                && g.bars_attack()
            {
                let d = Decision::Withdraw {
                    unit: u.clone(),
                    fire,
                    goal: g.goal.id.clone(),
                    kind: g.goal.goal,
                    zone: g.goal.zone.clone(),
                };
                self.log(t, d);
                if let Some(f) = self.fusion.get_mut(fire) {
                    f.state = FireState::Confirmed;
                }
                out.push(self.standby(&u, t));
            }
            let v = &self.units[&u];
            let (Some(st), Mobility::Ground(_)) = (&v.state, &v.mobility) else {
                continue;
            };
            let at = self.tunnel.station(st.pose.position());
            let Some((g, way)) = self.way_out(&self.goals, at.s) else {
                continue;
            };
            let (id, zone) = (g.goal.id.clone(), g.goal.zone.clone());
            let Some(x) = way else {
                let held = trapped_by(&u, g);
                // Said once while it lasts: every enforcement finds it again.
                if self.trapped.get(&u) != Some(&held) {
                    self.log(
                        t,
                        Decision::Trapped {
                            unit: u.clone(),
                            zone: held.zone.clone(),
                            goal: held.goal.clone(),
                        },
                    );
                }
                // It holds where it is: a way out given before another goal closed it
                // (an evacuate's destination now barred too) is taken back, not re-sent.
                let bound_into_barred = match self.units[&u].task.as_ref().map(|t| t.kind) {
                    Some(TaskKind::Cruise { goal } | TaskKind::Search { goal }) => {
                        self.goal_at(goal).is_some_and(|g| g.bars_entry())
                    }
                    _ => false,
                };
                if bound_into_barred {
                    out.push(self.standby(&u, t));
                }
                trapped.insert(u, held);
                continue;
            };
            let goal = self.tunnel.point_at(x, at.d);
            if matches!(v.task.as_ref().map(|t| t.kind), Some(TaskKind::Cruise { goal: g }) if g.dist(goal) < 1.0)
            {
                continue;
            }
            out.push(self.give(&u, TaskKind::Cruise { goal }, t));
            self.log(
                t,
                Decision::Evacuate {
                    unit: u,
                    zone,
                    to: x,
                    goal: id,
                },
            );
        }
        self.trapped = trapped;
        out
    }
}

impl Incident {
    /// The last word before a solve's tasks go out: no unit keeps a task whose
    /// destination the goals in force bar to it, read as units and the incident's checker
    /// read it ([`BarredSpace::entry_at`], a zone's edges inside it). Every planner keeps
    /// out of barred space on its own, so a task caught here is a bug in one of them:
    /// counted as an inconsistency, and the unit stands by rather than be sent in (a
    /// task is re-sent every second; a standing order into barred space would be sent
    /// until the bug's planner moved it).
    pub(super) fn recall_from_barred(&mut self, t: f64) -> Vec<Output> {
        let barred = self.goals.barred_space(t);
        let caught: Vec<(UnitId, TaskKind, String)> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive)
            .filter_map(|(u, v)| {
                let kind = v.task.as_ref()?.kind;
                let to = self.tunnel.chainage(kind.destination()?);
                let span = barred.entry_at(v.mobility.kind(), to)?;
                Some((u.clone(), kind, span.goal.clone()))
            })
            .collect();
        caught
            .into_iter()
            .map(|(u, kind, goal)| {
                self.inconsistencies += 1;
                tracing::error!(unit = %u, task = %kind, goal, "a task into barred space was caught before it went out; the unit stands by");
                self.standby(&u, t)
            })
            .collect()
    }
}

/// Unit `u` trapped by goal `g`.
fn trapped_by(u: &UnitId, g: &Active) -> Trapped {
    Trapped {
        unit: u.clone(),
        goal: g.goal.id.clone(),
        zone: g.goal.zone.clone(),
        issued_by: g.goal.issued_by.clone(),
    }
}

/// The answer to goal `goal` of commander `by`, who is suspended.
fn suspended_ack(goal: &ZoneGoal, by: &CommanderId) -> GoalAck {
    GoalAck {
        id: goal.id.clone(),
        zone: goal.zone.clone(),
        issued_by: Some(by.clone()),
        accepted: false,
        reason: format!("commander '{by}' is suspended: its goals are not taken"),
    }
}
