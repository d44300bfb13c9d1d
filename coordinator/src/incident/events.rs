//! How the incident takes events: a unit appearing, vanishing or stating where it is and
//! what it does, a flame report, recalled tracks, time passing. Each handler updates the
//! picture and re-solves as much of the assignment as the event can change.
//!
//! Not here: what the solve decides (dispatch, search, staging, zones).

use firefleet_model::geometry::wrap_angle;
use firefleet_model::validate::{Invalid, Validate};
use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::{
    FireState, FireTrack, FlameReport, Refusal, TaskKind, TaskPhase, TaskProgress, UnitState,
};

use crate::assign::{GroundBody, Mobility};
use crate::fusion::{Contradiction, Fused};

use super::{Decision, Incident, Loss, Output, Policy, Scope, able};

/// How far ahead of the site clock a recalled track may be dated, s: clock skew between the
/// hosts of the coordinator that published it and of this one.
pub const RECALL_AHEAD_S: f64 = 5.0;
/// How far a report's observer may stand from where the unit's state puts it, m: the
/// drift between two estimates of the unit's pose.
pub const OBSERVER_SLACK_M: f64 = 10.0;
/// How far a fire's estimate may move from the spot its attackers were sent to before
/// they are sent again, m: well over the estimate's jitter between reports (its standard
/// deviation is half a metre), under the 3 m within which a ground unit takes a flame it
/// sees for its fire's (`Unit::aim_point`). A track that moved further (two tracks of
/// one fire merged, a first estimate pulled by later reports) left its attackers going
/// to where it was: in the pile-up's around-fakes flood a track begun 12 m from the
/// burning van took the van's reports in and ended on the van; its nearest
/// attacker drove to the old spot, saw no flame there and reported it out, and the last
/// fire was out 28 s later than in the unattacked run (1.28x).
pub const TARGET_MOVED_M: f64 = 2.0;

impl Incident {
    /// A unit's liveliness token appeared or vanished.
    pub fn on_alive(&mut self, unit: &UnitId, alive: bool, t: f64) -> Result<Vec<Output>, Invalid> {
        let v = self.view(unit, "unit")?;
        let was = v.alive;
        v.alive = alive;
        if alive {
            v.last_heard = t;
            v.lost = None;
            if !was {
                self.log(t, Decision::Joined { unit: unit.clone() });
            }
            return Ok(self.solve(t));
        }
        if !was {
            return Ok(Vec::new());
        }
        Ok(self.lose(unit, t, Loss::TokenVanished))
    }

    pub(super) fn lose(&mut self, unit: &UnitId, t: f64, why: Loss) -> Vec<Output> {
        let Some(v) = self.view_mut(unit) else {
            return Vec::new();
        };
        v.alive = false;
        v.lost = Some((why, t));
        let fire = v.working_on();
        v.task = None;
        v.unechoed = None;
        let mut out = Vec::new();
        self.log(
            t,
            Decision::Lost {
                unit: unit.clone(),
                why,
                fire,
            },
        );
        if let Some(f) = fire {
            out.extend(self.release(f, t));
        }
        if why == Loss::Deaf {
            // Kept asking: the echo of this standby is what brings the unit back.
            out.push(self.standby(unit, t));
        }
        out.extend(self.solve(t));
        out
    }

    /// Put a fire back among those needing a unit, if it still burns.
    pub(super) fn release(&mut self, fire: FireId, t: f64) -> Option<Output> {
        let f = self.fusion.get_mut(fire)?;
        if !f.active() {
            return None;
        }
        f.state = FireState::Confirmed;
        Some(Output::Fire(self.track(fire, t)))
    }

    /// Fire tracks a previous coordinator published, as a recorder kept them: taken back
    /// under their ids before the units are heard from, so that a fire nobody is working on
    /// right now is not forgotten across a restart. A track that fails validation, lies
    /// outside the tunnel or is dated ahead of the site clock `t` (by more than
    /// [`RECALL_AHEAD_S`]: a forged track dated t = 1e9 would outrank every real one) is
    /// refused (returned with its reason) and the rest are still taken; one whose id is
    /// already known is skipped.
    pub fn restore(&mut self, tracks: &[FireTrack], t: f64) -> (Vec<Output>, Vec<Invalid>) {
        let mut refused = Vec::new();
        for track in tracks {
            let checked = track
                .validate()
                .and_then(|()| self.tunnel.check_inside("position", track.position))
                .and_then(|()| {
                    if track.t > t + RECALL_AHEAD_S {
                        Err(Invalid::new(
                            "t",
                            format!("{:.1} s is ahead of the site clock ({t:.1} s)", track.t),
                        ))
                    } else {
                        Ok(())
                    }
                })
                .map_err(|e| e.within(&format!("fire {}", track.id)));
            if let Err(e) = checked {
                refused.push(e);
                continue;
            }
            if self.fusion.restore(track) {
                self.log(
                    t,
                    Decision::Recall {
                        track: track.clone(),
                    },
                );
            }
        }
        (self.solve(t), refused)
    }

    /// A unit's state message.
    pub fn on_state(&mut self, st: UnitState, t: f64) -> Result<Vec<Output>, Invalid> {
        let unit = st.unit.clone();
        self.not_suspended(&format!("unit-{unit}"))?;
        self.tunnel.check_inside("pose", st.pose.position())?;
        self.view(&unit, "unit")?.newest_state.admit(st.t, t)?;
        let mobility = self.view(&unit, "unit")?.mobility.clone();
        let (from, to) = self.sight(&mobility, st.pose);
        self.coverage.look(from, to, t);
        let clear = self.clear_view(&mobility, st.pose);
        let deaf_after_s = self.policy.deaf_after_s;
        let v = self.view(&unit, "unit")?;
        v.last_heard = t;
        // Where the task the unit holds stands (epoch, number); a state of a robot that
        // reports only its progress echoes the task it works on.
        let echoed = st
            .task_seq
            .max(st.task.map(|p| p.seq))
            .map(|seq| (st.epoch.unwrap_or(0), seq));
        if let Some((order, _)) = v.unechoed
            && echoed >= Some(order)
        {
            v.unechoed = v
                .task
                .as_ref()
                .filter(|k| echoed < Some(k.order()))
                .map(|k| (k.order(), k.t));
        }
        // Lost for its silence and heard again, or lost as deaf and echoing the task it
        // was kept asked: back in play. A unit whose token vanished comes back with its
        // token.
        let back = match v.lost {
            Some((was @ Loss::Silent, at)) => Some((was, at)),
            Some((was @ Loss::Deaf, at)) if v.unechoed.is_none() => Some((was, at)),
            _ => None,
        };
        if back.is_some() {
            v.alive = true;
            v.lost = None;
        }
        if v.alive
            && v.unechoed
                .is_some_and(|(_, since)| t - since > deaf_after_s)
        {
            v.state = Some(st);
            return Ok(self.lose(&unit, t, Loss::Deaf));
        }
        // At most a second of view per state: a unit heard again after a gap does not
        // bring a long look it may not have had.
        let looked_s = (t - v.state_at).clamp(0.0, 1.0);
        v.state_at = t;
        // Whether it holds a task of this coordinator's as it is heard (what follows may
        // stand it by).
        let (tasked, holds) = (v.tasked, v.task.is_some());
        let progress = st.task;
        let refusal = st.refused.clone();
        let taken = st.task_seq.map(|seq| (st.epoch.unwrap_or(0), seq));
        // A state changes the decisions only when it brings a unit into play or takes one
        // out; a moving unit's position is picked up by the periodic re-solve. Re-solving
        // on every state would cost a solve per message: 10 000 a second for 1000 units.
        let mut relevant =
            back.is_some() || v.state.as_ref().is_none_or(|old| able(old) != able(&st));
        v.state = Some(st);
        if let Some(p) = progress {
            self.heed_seq(p.seq, t);
        }
        let mut out = Vec::new();
        let found = self.fusion.look(&unit, clear, looked_s, t);
        if !found.is_empty() {
            out.extend(self.contradicted(found, &unit, t));
            relevant = true;
        }
        if let Some((was, at)) = back {
            self.log(
                t,
                Decision::Rejoined {
                    unit: unit.clone(),
                    was,
                    after_s: t - at,
                },
            );
        }
        if !holds && !tasked {
            relevant |= self.take_over_task(&unit, progress, taken, t, &mut out);
        }
        if let Some(p) = progress {
            relevant |= self.on_progress(&unit, p, t, &mut out);
        }
        if let Some((epoch, seq)) = taken {
            self.supersede_forged(&unit, epoch, seq, t, &mut out);
        }
        if let Some(r) = refusal {
            relevant |= self.on_refusal(&unit, r, t, &mut out);
        }
        if relevant {
            out.extend(self.solve(t));
        }
        Ok(out)
    }

    /// A unit this coordinator has never tasked, heard working on a task: one of an earlier
    /// coordinator of this site (before a restart) is adopted; one of an older term it
    /// merely holds stands it by. Whether that changes the decisions.
    ///
    /// What a unit it tasked reports of an older task is not adopted (a unit heard again
    /// after its lease lapsed may still be on a fire since given to another). A unit that
    /// holds any other task of an older term stands by in this one: until it takes a task
    /// of this term, the coordinator of that one (deposed, perhaps only cut off) could
    /// still command it.
    fn take_over_task(
        &mut self,
        unit: &UnitId,
        progress: Option<TaskProgress>,
        taken: Option<(u64, u64)>,
        t: f64,
        out: &mut Vec<Output>,
    ) -> bool {
        match progress {
            Some(p) if matches!(p.phase, TaskPhase::Travelling | TaskPhase::Spraying) => {
                out.extend(self.adopt(unit, p, t));
                true
            }
            _ if taken.is_some_and(|(epoch, _)| epoch < self.epoch) => {
                out.push(self.standby(unit, t));
                true
            }
            _ => false,
        }
    }

    /// What a unit says of the task it holds from this coordinator: a fire it says is out,
    /// a task it gave up, spraying begun. Whether that changes the decisions.
    fn on_progress(
        &mut self,
        unit: &UnitId,
        p: TaskProgress,
        t: f64,
        out: &mut Vec<Output>,
    ) -> bool {
        let Some(task) = self.units.get(unit).and_then(|v| v.task.clone()) else {
            return false;
        };
        let TaskKind::Extinguish { fire, .. } = task.kind else {
            return false;
        };
        if task.seq != p.seq {
            return false;
        }
        // The task may name a track since merged into another.
        let fire = self.fusion.resolve(fire);
        match p.phase {
            TaskPhase::Extinguished => {
                self.on_out_claim(unit, fire, t, out);
                true
            }
            TaskPhase::Failed => {
                self.failed
                    .insert((unit.clone(), fire), t + self.policy.retry_after_s);
                self.log(
                    t,
                    Decision::GaveUp {
                        unit: unit.clone(),
                        fire,
                    },
                );
                out.extend(self.release(fire, t));
                out.push(self.standby(unit, t));
                true
            }
            TaskPhase::Spraying => {
                if let Some(f) = self.fusion.get_mut(fire)
                    && f.state == FireState::Assigned
                {
                    f.state = FireState::Suppressing;
                    out.push(Output::Fire(self.track(fire, t)));
                }
                false
            }
            TaskPhase::Travelling => false,
        }
    }

    /// `unit`, sent to `fire`, says it is out: a fact once no other unit still sees it or
    /// sprays it, and everyone on it is free; a claim disputed otherwise, which frees only
    /// the claimant (a unit lying, or whose detector lost the flame in steam, frees itself,
    /// not the units still at work).
    fn on_out_claim(&mut self, unit: &UnitId, fire: FireId, t: f64, out: &mut Vec<Output>) {
        // Sent to a fire one other unit alone claims, it saw nothing there.
        if self.could_have_looked(unit, fire, t)
            && let Some(c) = self.fusion.found_nothing(fire, unit, t)
        {
            out.extend(self.contradicted(vec![c], unit, t));
        }
        let against = self.still_burning_for(fire, unit, t);
        let unseen = self.fusion.get(fire).is_some_and(|f| f.dts_only());
        if !against.is_empty() || unseen {
            self.log(
                t,
                if unseen {
                    // Sent by the DTS to a fire it never found (behind a lorry, say): its
                    // detector seeing no flame there says nothing of the fire.
                    Decision::OutUnseen {
                        fire,
                        by: unit.clone(),
                    }
                } else {
                    Decision::OutDisputed {
                        fire,
                        by: unit.clone(),
                        against,
                    }
                },
            );
            // Not sent straight back to a fire it says is out.
            self.failed
                .insert((unit.clone(), fire), t + self.policy.retry_after_s);
            let alone = self.assigned_to(fire).iter().all(|u| u == unit);
            out.push(self.standby(unit, t));
            if unseen {
                self.looked_in_vain(fire, unit, t);
            }
            if unseen && alone {
                // Nobody is on it now: it is anyone's to take again.
                out.extend(self.release(fire, t));
            }
            return;
        }
        if let Some(f) = self.fusion.get_mut(fire) {
            f.state = FireState::Out;
            f.out_at = Some(t);
        }
        self.log(
            t,
            Decision::FireOut {
                fire,
                by: unit.clone(),
            },
        );
        out.push(Output::Fire(self.track(fire, t)));
        // Everyone on that fire is free again (after a merge, more than one).
        let mut free = self.assigned_to(fire);
        if !free.contains(unit) {
            free.push(unit.clone());
        }
        for u in free {
            out.push(self.standby(&u, t));
        }
    }

    /// Whether `unit` can have looked at `fire` by `t`: from where its state put it when it
    /// was given the fire, at its top speed, it can have come within its sensors' range. An
    /// "out" sooner is no look and says nothing against the fire's claimant: a stolen key's
    /// forged "out" came a tenth of a second after the task, and counted against the honest
    /// unit that reported the fire made its sightings count for nothing, so that every
    /// forged "out" after it was taken and every sighting reignited the fire (assignment
    /// thrash, 12 attacker changes in 60 s on one fire in CI).
    fn could_have_looked(&self, unit: &UnitId, fire: FireId, t: f64) -> bool {
        let (Some(v), Some(f)) = (self.units.get(unit), self.fusion.get(fire)) else {
            return false;
        };
        let Some((_, given, from)) = v.sent_to.filter(|s| self.fusion.resolve(s.0) == fire) else {
            return true;
        };
        let far = (from.dist(f.position()) - v.mobility.sensor_range_m()).max(0.0);
        t - given >= far / v.mobility.top_speed_m_s()
    }

    /// The unit took task `seq` of term `epoch`: above the one this coordinator gave it in
    /// its own term, it is a task this coordinator never gave (forged), and the unit gets
    /// its task again, numbered above, so that it hears this coordinator again. A task of
    /// another term is another coordinator's, given while it held office: the unit takes
    /// this one's next task once this one holds office in its eyes (the first after the
    /// office changed hands is taken whatever its term), and this one sends every task
    /// again each second.
    fn supersede_forged(
        &mut self,
        unit: &UnitId,
        epoch: u64,
        seq: u64,
        t: f64,
        out: &mut Vec<Output>,
    ) {
        if let Some(task) = self.units.get(unit).and_then(|v| v.task.clone())
            && epoch == task.epoch
            && seq > task.seq
            && self.heed_seq(seq, t)
        {
            self.log(
                t,
                Decision::Superseded {
                    unit: unit.clone(),
                    foreign: seq,
                    ours: task.seq,
                },
            );
            out.push(self.give(unit, task.kind, t));
        }
    }

    /// The unit refused the task it holds from this coordinator for barred space. Whether
    /// that changes the decisions.
    ///
    /// The unit holds a barred space the coordinator did not (one of them is late, or the
    /// two disagree): the unit's word stands. Standby replaces the task, so the refusal is
    /// logged once. A refusal for a goal no longer in force is the unit's late news (the
    /// lifted bar reaches it within a second): the fire may be given again at once, not
    /// after a minute.
    fn on_refusal(&mut self, unit: &UnitId, r: Refusal, t: f64, out: &mut Vec<Output>) -> bool {
        let Some(task) = self.units.get(unit).and_then(|v| v.task.clone()) else {
            return false;
        };
        if task.seq != r.seq {
            return false;
        }
        let lifted = self.goals.lifted(&r.goal);
        if let TaskKind::Extinguish { fire, .. } = task.kind {
            let fire = self.fusion.resolve(fire);
            if !lifted {
                self.failed
                    .insert((unit.clone(), fire), t + self.policy.retry_after_s);
            }
            out.extend(self.release(fire, t));
        }
        self.log(
            t,
            Decision::Refused {
                unit: unit.clone(),
                refusal: r,
            },
        );
        out.push(self.standby(unit, t));
        true
    }

    /// The units other than `claimant` that still see fire `fire` burning
    /// ([`crate::fusion::Fire::seen_now_by`]) or spray it.
    fn still_burning_for(&self, fire: FireId, claimant: &UnitId, t: f64) -> Vec<UnitId> {
        let seeing = self
            .fusion
            .get(fire)
            .map(|f| f.seen_now_by(t))
            .unwrap_or_default();
        let mut against: Vec<UnitId> = self
            .assigned_to(fire)
            .into_iter()
            .filter(|u| {
                self.units[u]
                    .state
                    .as_ref()
                    .is_some_and(|s| s.task.is_some_and(|p| p.phase == TaskPhase::Spraying))
            })
            .chain(seeing)
            .filter(|u| u != claimant)
            .collect();
        against.sort();
        against.dedup();
        against
    }

    /// Claims `by` contradicted: logged, their witnesses doubted if it came to that, and
    /// the fires only doubted units claim taken back from the units sent to them.
    fn contradicted(&mut self, found: Vec<Contradiction>, by: &UnitId, t: f64) -> Vec<Output> {
        for c in found {
            self.log(
                t,
                Decision::Contradicted {
                    fire: c.fire,
                    witness: c.witness.clone(),
                    by: by.clone(),
                },
            );
            if c.doubted_now {
                let record = self.fusion.witnesses().record(&c.witness);
                self.log(
                    t,
                    Decision::Doubted {
                        unit: c.witness,
                        record,
                    },
                );
            }
        }
        let mut out = Vec::new();
        for fire in self.fusion.demote_doubted() {
            self.log(t, Decision::Disbelieved { fire });
            for u in self.assigned_to(fire) {
                out.push(self.standby(&u, t));
            }
            out.push(Output::Fire(self.track(fire, t)));
        }
        out
    }

    /// A unit works on a task this coordinator did not give (it gave it before a restart):
    /// take the task over rather than send the unit elsewhere. Its fire is the track the
    /// task names if that was recalled and is still burning, else the track within
    /// [`super::Policy::adopt_radius_m`] of where the unit believes it is, or a new track there.
    ///
    /// The task is given again in this coordinator's term: until a unit has taken a task
    /// of the new term, the coordinator that gave the old one (deposed, perhaps only cut
    /// off) could still command it. The unit takes up the attack again under the new
    /// number, a pause of a second or two at a takeover.
    pub(super) fn adopt(&mut self, unit: &UnitId, p: TaskProgress, t: f64) -> Vec<Output> {
        let named = self
            .fusion
            .get(p.fire)
            .filter(|f| f.active() && f.position().dist(p.target) <= self.policy.adopt_radius_m)
            .map(|f| f.id);
        let fire = match named.or_else(|| {
            self.fusion
                .nearest_active(p.target, self.policy.adopt_radius_m)
        }) {
            Some(id) => id,
            None => self.fusion.adopt(unit, p.target, t),
        };
        if let Some(f) = self.fusion.get_mut(fire)
            && matches!(f.state, FireState::Tentative | FireState::Confirmed)
        {
            f.state = if p.phase == TaskPhase::Spraying {
                FireState::Suppressing
            } else {
                FireState::Assigned
            };
        }
        self.log(
            t,
            Decision::Adopt {
                unit: unit.clone(),
                seq: p.seq,
                fire,
                target: p.target,
            },
        );
        let kind = TaskKind::Extinguish {
            fire,
            target: p.target,
            from: self.attack_side(fire, t),
        };
        vec![Output::Fire(self.track(fire, t)), self.give(unit, kind, t)]
    }

    /// A unit's flame report.
    ///
    /// Besides its shape and freshness, a report must be seen from where the unit's own
    /// latest state puts it (within [`OBSERVER_SLACK_M`] plus what it can have driven
    /// since), of flames within its sensors' range of there (plus
    /// [`super::Policy::report_reach_slack_m`]) and, for a ground unit, within its
    /// camera's view ([`in_camera_view`]). A stolen certificate can speak on the
    /// unit's key, but it is not the unit:
    /// the rules let it hear the unit's tasks, not its states, and on a real site nothing
    /// else tells it where the unit is; a report from anywhere else is refused. (On a
    /// simulated site the unit's simulated sensors would.)
    pub fn on_report(&mut self, r: &FlameReport, t: f64) -> Result<Vec<Output>, Invalid> {
        self.not_suspended(&format!("unit-{}", r.unit))?;
        for (i, o) in r.observations.iter().enumerate() {
            self.tunnel
                .check_inside(&format!("observations[{i}].position"), o.position)?;
        }
        let policy = self.policy;
        let v = self.view(&r.unit, "unit")?;
        let observer = r.observer.position();
        let Some(st) = &v.state else {
            // Reports repeat four times a second: one before the unit's first state is no
            // loss, and a thief's would be unchecked.
            return Err(Invalid::new(
                "unit",
                "no state from this unit yet: where it saw this from cannot be checked",
            ));
        };
        let moved = v.mobility.top_speed_m_s() * (r.t - st.t).abs();
        let off = st.pose.position().dist(observer);
        if off > OBSERVER_SLACK_M + moved {
            return Err(Invalid::new(
                "observer",
                format!(
                    "({:.1}, {:.1}) is {off:.0} m from where the unit's state of t = {:.1} s puts it ({:.1}, {:.1})",
                    observer.x, observer.y, st.t, st.pose.x, st.pose.y
                ),
            ));
        }
        let reach = v.mobility.sensor_range_m() + policy.report_reach_slack_m;
        for (i, o) in r.observations.iter().enumerate() {
            let d = o.position.dist(observer);
            if d > reach {
                return Err(Invalid::new(
                    format!("observations[{i}].position"),
                    format!("{d:.0} m from the observer, beyond the unit's sensors ({reach:.0} m)"),
                ));
            }
        }
        if let Mobility::Ground(g) = &v.mobility {
            in_camera_view(&policy, g, r, st)?;
        }
        let heat_flux_kw_m2 = st.heat_flux_kw_m2;
        let v = self.view(&r.unit, "unit")?;
        v.newest_report.admit(r.t, t)?;
        v.last_heard = t;
        self.fusion.feel(&r.unit, heat_flux_kw_m2);
        let mut out = Vec::new();
        // Whether the work to assign changed: a fire confirmed, found again or located, or
        // a new witness of one (a second unit's word brings a backup). A unit that goes on
        // watching its fire (most reports: several a second) or a track still tentative
        // leaves the rest to the tick's solve within 0.2 s: a solve costs milliseconds at
        // a thousand units, and the report of a new fire would wait behind every other's.
        let mut new_work = false;
        for o in &r.observations {
            match self.fusion.observe(&r.unit, o, t) {
                Fused::New(_) => {}
                Fused::Updated(id) => {
                    new_work |= self
                        .fusion
                        .get(id)
                        .is_some_and(|f| f.began_seeing(&r.unit, t));
                    if self.may_need_aim(id, TARGET_MOVED_M) {
                        out.extend(self.aim_again(id, TARGET_MOVED_M, t));
                    }
                }
                Fused::Refused => self.lone_refused += 1,
                Fused::Confirmed(id) => {
                    new_work = true;
                    self.log(
                        t,
                        Decision::Confirmed {
                            fire: id,
                            at: o.position,
                        },
                    );
                    out.push(Output::Fire(self.track(id, t)));
                }
                Fused::Reignited(id) => {
                    new_work = true;
                    self.log(t, Decision::Reignited { fire: id });
                    out.push(Output::Fire(self.track(id, t)));
                }
                Fused::Located(id) => {
                    new_work = true;
                    out.extend(self.retarget(id, t));
                }
            }
        }
        for m in self.fusion.merge_duplicates() {
            new_work = true;
            self.log(
                t,
                Decision::Merged {
                    removed: m.removed.id,
                    kept: m.kept,
                },
            );
            let mut gone = m.removed.to_track(t, Vec::new());
            gone.state = FireState::Lost;
            out.push(Output::Fire(gone));
            out.push(Output::Fire(self.track(m.kept, t)));
            self.aims.remove(&m.removed.id);
            out.extend(self.release_merged(m.kept, t));
            out.extend(self.aim_again(m.kept, TARGET_MOVED_M, t));
        }
        if new_work {
            out.extend(self.solve_within(Scope::NewFires, t));
        }
        Ok(out)
    }

    /// Units silent beyond their lease by `t` are lost, and their fires given to others.
    /// Cheap when nobody is (a pass over the units): the node runs it more often than
    /// [`Incident::tick`], because a fire waits for its new unit from the moment its old
    /// one's lease ran out, and at four times real time a 200 ms tick is 0.8 s of it.
    pub fn lapse(&mut self, t: f64) -> Vec<Output> {
        let silent: Vec<UnitId> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && t - v.last_heard > self.lease_s)
            .map(|(u, _)| u.clone())
            .collect();
        let mut out = Vec::new();
        for u in silent {
            out.extend(self.lose(&u, t, Loss::Silent));
        }
        out
    }

    /// The site clock went from `from` to `to` with none of the time between watched: the
    /// coordinator took office before the site clock reached it (it waits 3 s, then starts
    /// at 0) or was cut off from it. What it heard before was dated by its own clock, so
    /// every unit's last word and every task it awaits an echo of move on by the jump:
    /// silence counts only the time the coordinator watched. Otherwise the first lapse after
    /// the jump counts every unit lost at once, as a deploy guide's coordinator restarted by
    /// a power cut once did (ugv-1, ugv-2 and ugv-3 lost at 14.1 s, heard again a moment
    /// later). A unit that really fell silent meanwhile is lost one lease after `to`.
    ///
    /// Not moved: fires' sightings and goals' ends, which came dated in site time.
    pub fn clock_jumped(&mut self, from: f64, to: f64) {
        let jump = to - from;
        if !jump.is_finite() || jump <= 0.0 {
            return;
        }
        for v in self.units.values_mut() {
            if v.last_heard <= from {
                v.last_heard += jump;
            }
            if let Some((_, since)) = &mut v.unechoed
                && *since <= from
            {
                *since += jump;
            }
        }
    }

    /// Time passed: expire silent units and unseen fires, enforce goals, re-solve.
    pub fn tick(&mut self, t: f64) -> Vec<Output> {
        let mut out = self.lapse(t);
        let barred = self.goals.barred_space(0.0);
        let tunnel = &self.tunnel;
        let left_burning = |p| barred.attack_at(tunnel.chainage(p)).is_some();
        for id in self.fusion.expire(t, left_burning) {
            self.log(t, Decision::FireLost { fire: id });
            out.push(Output::Fire(self.track(id, t)));
        }
        self.failed.retain(|_, until| *until > t);
        if self.goals.revision() != self.failed_under {
            self.failed.clear();
            self.failed_under = self.goals.revision();
        }
        for g in self.goals.expire(t) {
            self.log(
                t,
                Decision::GoalExpired {
                    zone: g.zone,
                    goal: g.id,
                },
            );
        }
        let trapped = self.trapped.clone();
        let mut held = self.hold_to_goals(t);
        held.extend(self.scada_doubt(t));
        let units_moved = !held.is_empty() || self.trapped != trapped;
        out.extend(held);
        out.extend(self.dts_alarms(t));
        // Units move and look between events: searches end, searchers change, and a unit
        // on its way may now have a nearer relief.
        let scope = if units_moved || t - self.solved_all_at >= self.policy.solve_all_every_s {
            Scope::All
        } else {
            Scope::NewFires
        };
        out.extend(self.solve_within(scope, t));
        out
    }

    /// Re-decide: assign free units to fires that need one; send free ground units to
    /// search where nobody has looked; back up fires with the units still free; stage the
    /// rest.
    ///
    /// Search comes before backups: a second cannon shortens a knock-down by seconds,
    /// while a fire nobody has seen burns on until somebody drives past it.
    pub(super) fn solve(&mut self, t: f64) -> Vec<Output> {
        self.solve_within(Scope::All, t)
    }

    /// [`Incident::solve`], assigning within `scope`.
    pub(super) fn solve_within(&mut self, scope: Scope, t: f64) -> Vec<Output> {
        if scope == Scope::All {
            self.solved_all_at = t;
        }
        let mut out = self.assign(scope, t);
        let (sent, searching) = self.search(t);
        out.extend(sent);
        out.extend(self.back_up(&searching, t));
        out.extend(self.stage(&searching, t));
        out.extend(self.patrol_rails(t));
        out.extend(self.recall_from_barred(t));
        out
    }
}

/// Whether a ground unit's report keeps to its camera: the heading it looks from is
/// one its camera can have (the body's heading in its latest state, turned as far as it
/// can turn since, plus the camera's pan), and every flame lies in that camera's field
/// of view ([`Policy::report_cone_slack_rad`]). A carriage's detector sees all
/// round.
fn in_camera_view(
    p: &Policy,
    g: &GroundBody,
    r: &FlameReport,
    st: &UnitState,
) -> Result<(), Invalid> {
    let look = g.camera_look_rad + g.turn_rate_rad_s * (r.t - st.t).abs() + p.report_cone_slack_rad;
    let off = wrap_angle(r.observer.yaw - st.pose.yaw).abs();
    if look < std::f64::consts::PI && off > look {
        return Err(Invalid::new(
            "observer.yaw",
            format!(
                "{:.0} deg off the heading of the unit's state of t = {:.1} s; its camera looks at most {:.0} deg off",
                off.to_degrees(),
                st.t,
                look.to_degrees()
            ),
        ));
    }
    for (i, o) in r.observations.iter().enumerate() {
        if !g.in_view(
            r.observer,
            o.position,
            p.report_cone_slack_rad,
            p.report_cone_slack_m,
        ) {
            let at = r.observer.position();
            return Err(Invalid::new(
                format!("observations[{i}].position"),
                format!(
                    "{:.0} deg off the heading the camera looks from, outside its field of view ({:.0} deg either side)",
                    wrap_angle(at.bearing_to(o.position) - r.observer.yaw)
                        .abs()
                        .to_degrees(),
                    g.camera_hfov_rad.to_degrees() / 2.0
                ),
            ));
        }
    }
    Ok(())
}
