//! Dispatch: fires as needs, units as candidates, the strategy's picks turned into tasks
//! (first attackers, backups), and units relieved when another gets there much sooner.
//!
//! The cost model and the solvers are [`crate::assign`]'s; this module feeds them the
//! incident's picture and acts on what they pick.
//!
//! A fire whose attackers changed [`HOLD_AT`](crate::invariants::churn::HOLD_AT) times
//! within the churn window is held: while it is, a solve leaves its attackers out of the
//! candidates and the fire out of the needs (unless no unit able to work attacks it),
//! and no backup joins it. So no swap, relief or backup of the coordinator's choosing
//! changes it; what must still happen does (a unit lost or broken down replaced, the
//! fire out, a goal that withdraws units). The price: a unit that would do more
//! elsewhere stays for up to [`crate::invariants::churn::WINDOW_S`], and a fire nobody
//! attacks can wait that long for a unit of a held fire.

use std::collections::BTreeSet;

use firefleet_model::UnitKind;
use firefleet_model::{FireId, Point2, UnitId};
use firefleet_protocol::msg::{FireState, TaskKind, TaskPhase};

use crate::assign::{Candidate, Mobility, Need, Pick, Place, Roads, Site, wants_another};
use crate::fusion::Fire;

use super::{AttackSide, Decision, Incident, Output, Scope, able};

impl Incident {
    /// Fire `f` as a need for a unit, with its zone's priority; `None` if a goal bars
    /// attacking it.
    pub(super) fn need(&self, f: &Fire, t: f64) -> Option<Need> {
        let at = Place::in_tunnel(&self.tunnel, f.position());
        let goal = self.goals.at(at.chainage);
        (!goal.is_some_and(|g| g.bars_attack())).then(|| Need {
            fire: f.id,
            at,
            priority: goal.map_or(0, |g| g.goal.priority),
            from: self.attack_side(f.id, t),
        })
    }

    /// Assign units to the fires that need one: fires nobody has taken, and fires whose
    /// units are all still on their way, solved again so that a unit come free near a
    /// fire takes it over from one still far away ([`crate::assign::KEEP_S`] keeps changes to real
    /// gains). A unit that loses its fire so stays on as its backup if it is within
    /// [`super::Policy::help_within_s`] of it and the fire wants another attacker, and is released
    /// otherwise.
    pub(super) fn assign(&mut self, scope: Scope, t: f64) -> Vec<Output> {
        let open = |s: FireState| match scope {
            Scope::All => matches!(s, FireState::Confirmed | FireState::Assigned),
            Scope::NewFires => s == FireState::Confirmed,
        };
        let mut candidates = self.candidates();
        let kept = self.kept(&candidates, t);
        candidates.retain(|c| {
            self.units
                .get(&c.unit)
                .and_then(|v| self.works_on(v))
                .is_none_or(|f| !kept.contains(&f))
        });
        let needs: Vec<Need> = self
            .fusion
            .fires()
            .iter()
            .filter(|f| open(f.state) && !self.unverified_alarm(f))
            .filter(|f| !kept.contains(&f.id))
            .filter_map(|f| self.need(f, t))
            .collect();
        // The first attackers on their way to those fires, before the solve.
        let on_their_way: Vec<(UnitId, FireId)> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && !v.backup)
            .filter_map(|(u, v)| Some((u.clone(), self.fusion.resolve(v.working_on()?))))
            .filter(|(_, f)| needs.iter().any(|n| n.fire == *f))
            .collect();
        if scope == Scope::NewFires {
            // A unit on its way to a fire nobody sprays yet stays out: its fire is not in
            // this solve, so nothing would hold the unit to it.
            candidates.retain(|c| {
                c.heading_for
                    .and_then(|f| self.fusion.get(f))
                    .is_none_or(|f| f.state != FireState::Assigned)
            });
        }
        let picks = self.picks(&candidates, &needs);
        let mut out = Vec::new();
        for p in &picks {
            out.extend(self.dispatch(p, t, false));
        }
        for (unit, fire) in on_their_way {
            let Some(taker) = picks.iter().find(|p| p.fire == fire) else {
                continue;
            };
            let Some(v) = self.units.get(&unit) else {
                continue;
            };
            if taker.unit == unit || v.working_on().map(|f| self.fusion.resolve(f)) != Some(fire) {
                continue;
            }
            let (away, as_backup) = self.as_backup(&unit, fire);
            self.log(
                t,
                Decision::Relieved {
                    unit: unit.clone(),
                    fire,
                    by: taker.unit.clone(),
                    by_s: taker.cost_s,
                    own_s: away,
                    as_backup,
                },
            );
            if as_backup {
                if let Some(v) = self.units.get_mut(&unit) {
                    v.backup = true;
                }
            } else {
                out.push(self.standby(&unit, t));
            }
        }
        // A fire whose unit went to a more urgent one waits for the next.
        for n in &needs {
            if self.assigned_to(n.fire).is_empty()
                && let Some(f) = self.fusion.get_mut(n.fire)
                && f.state == FireState::Assigned
            {
                f.state = FireState::Confirmed;
                out.push(Output::Fire(self.track(n.fire, t)));
            }
        }
        out
    }

    /// `unit`'s travel time to `fire`, and whether it stays on as its backup if another
    /// takes it: within [`super::Policy::help_within_s`] of a corroborated fire that,
    /// without this unit, would want one more cannon.
    fn as_backup(&self, unit: &UnitId, fire: FireId) -> (f64, bool) {
        let Some(v) = self.units.get(unit) else {
            return (f64::INFINITY, false);
        };
        let from = v.state.as_ref().map(|s| s.pose.position());
        let to = self.fusion.get(fire).map(|f| f.position());
        let away = from
            .zip(to)
            .and_then(|(a, b)| v.mobility.travel_s(a, b))
            .unwrap_or(f64::INFINITY);
        let stays = away <= self.policy.help_within_s
            && self.fusion.get(fire).is_some_and(Fire::corroborated)
            && wants_another(
                self.fusion.get(fire).and_then(|f| f.hrr_kw()),
                &self.attack_flows(fire, Some(unit)),
                self.policy.units_per_fire,
            );
        (away, stays)
    }

    /// Whether a provisional fire's one reporter is spraying it alone: it drove there and
    /// still sees it, which a detector's false alarm does not survive. One backup may then
    /// join, and see it for itself (a liar's fake costs that unit a trip and the liar its
    /// credit: [`crate::fusion::Fusion::found_nothing`]).
    fn sprayed_by_its_lone_reporter(&self, f: &Fire) -> bool {
        let mut seen = f.seen_by();
        let (Some(reporter), None) = (seen.next(), seen.next()) else {
            return false;
        };
        self.assigned_to(f.id) == [reporter.clone()]
            && self.units.get(reporter).is_some_and(|v| {
                v.state.as_ref().and_then(|s| s.task).is_some_and(|p| {
                    p.phase == TaskPhase::Spraying && self.fusion.resolve(p.fire) == f.id
                })
            })
    }

    /// The cannon flows of the ground units on `fire` (but `except`), L/s: each its own
    /// profile's.
    fn attack_flows(&self, fire: FireId, except: Option<&UnitId>) -> Vec<f64> {
        self.flows(&self.assigned_to(fire), except)
    }

    /// The cannon flows of the ground units of `units` (but `except`), L/s.
    fn flows(&self, units: &[UnitId], except: Option<&UnitId>) -> Vec<f64> {
        units
            .iter()
            .filter(|u| Some(*u) != except)
            .filter_map(|u| self.units.get(u)?.mobility.cannon_flow_l_s())
            .collect()
    }

    /// Ground units not working on a fire, less those in `busy`.
    pub(super) fn free_ground_units(&self, busy: &BTreeSet<UnitId>) -> Vec<Candidate> {
        let mut candidates = self.candidates();
        candidates.retain(|c| {
            matches!(c.mobility, Mobility::Ground(_))
                && self
                    .units
                    .get(&c.unit)
                    .is_some_and(|v| v.working_on().is_none())
                && !busy.contains(&c.unit)
        });
        candidates
    }

    /// Units that may be sent to a fire: alive, able, with water, outside barred zones.
    pub(super) fn candidates(&self) -> Vec<Candidate> {
        let barred = self.goals.barred_space(0.0);
        self.units
            .iter()
            .filter(|(_, v)| v.alive && v.available())
            .filter_map(|(u, v)| {
                let st = v.state.as_ref()?;
                able(st).then(|| Candidate {
                    unit: u.clone(),
                    at: Place::in_tunnel(&self.tunnel, st.pose.position()),
                    mobility: v.mobility.clone(),
                    water_l: st.water_l,
                    // Backups are extra hands: only a fire's first attacker is kept on it.
                    heading_for: v
                        .working_on()
                        .filter(|_| !v.backup)
                        .map(|f| self.fusion.resolve(f)),
                    not_for: self
                        .failed
                        .keys()
                        .filter(|(unit, _)| unit == u)
                        .map(|(_, f)| *f)
                        .collect(),
                })
            })
            .filter(|c| barred.entry_at(c.mobility.kind(), c.at.chainage).is_none())
            .collect()
    }

    /// Second wave: ground units still free (and not in `busy`) join corroborated fires
    /// ([`Fire::corroborated`]) that have fewer attackers than `units_per_fire` or than their heat release needs, nearest
    /// first, one more per fire and solve.
    pub(super) fn back_up(&mut self, busy: &BTreeSet<UnitId>, t: f64) -> Vec<Output> {
        let working = self.assignments();
        let held = self.held(t);
        let backups: Vec<Need> = self
            .fusion
            .fires()
            .iter()
            .filter(|f| matches!(f.state, FireState::Assigned | FireState::Suppressing))
            .filter(|f| !held.contains(&f.id))
            // A provisional fire has its one unit until another source sees it, or one
            // backup once that unit sprays it: the backup is then its verifier.
            .filter(|f| f.corroborated() || self.sprayed_by_its_lone_reporter(f))
            .filter(|f| {
                wants_another(
                    f.hrr_kw(),
                    &self.flows(working.get(&f.id).map_or(&[], Vec::as_slice), None),
                    self.policy.units_per_fire,
                )
            })
            .filter_map(|f| self.need(f, t))
            .collect();
        let candidates = self.free_ground_units(busy);
        let mut out = Vec::new();
        for p in self.picks(&candidates, &backups) {
            if p.cost_s <= self.policy.help_within_s {
                out.extend(self.dispatch(&p, t, true));
            }
        }
        out
    }

    /// Of the fires held at `t`, those a unit among `candidates` (able to work) attacks:
    /// they keep their attackers and take no other. A held fire whose attackers all
    /// broke down or ran dry is not kept: its need for one is not a choice.
    fn kept(&mut self, candidates: &[Candidate], t: f64) -> BTreeSet<FireId> {
        let held = self.held(t);
        if held.is_empty() {
            return held;
        }
        candidates
            .iter()
            .filter_map(|c| self.works_on(self.units.get(&c.unit)?))
            .filter(|f| held.contains(f))
            .collect()
    }

    /// At a merge into `kept`, if an attacker of `kept`'s own (its task names `kept`)
    /// can work: each unit whose task still names a track merged into it (and that is
    /// not spraying) is released at once, unless it gets there sooner than every one of
    /// those attackers, or it would stay on as a backup ([`Incident::as_backup`]) and
    /// `kept` is not held. A unit kept on is renamed onto `kept` by its next task, one
    /// change to `kept` even when held: a held fire that released its nearest unit
    /// waited for the others (in one around-fakes flood the van waited 38 s for its
    /// attacker while the unit 2 s from it was sent to search; in another the unit
    /// spraying the van, drawn to a second track of it, was stood down when the two
    /// merged, and the van flared up again). Renamed onto `kept` and released there a
    /// second later, as before, each other unit was two changes to `kept`'s attackers;
    /// released now, it leaves only the track it was sent to. Against a fake track that
    /// follows its liar and swallows every track it meets, that was most of a minute's
    /// churn, and a hold that kept the swallowed tracks' units on the fake kept them from
    /// searching.
    pub(super) fn release_merged(&mut self, kept: FireId, t: f64) -> Vec<Output> {
        let named = |v: &super::UnitView| v.working_on().filter(|_| v.alive);
        let own: Vec<UnitId> = self
            .units
            .iter()
            .filter(|(_, v)| v.state.as_ref().is_some_and(able) && named(v) == Some(kept))
            .map(|(u, _)| u.clone())
            .collect();
        if own.is_empty() {
            return Vec::new();
        }
        let first_s = own
            .iter()
            .map(|u| self.as_backup(u, kept).0)
            .fold(f64::INFINITY, f64::min);
        let held = self.held(t).contains(&kept);
        let merged: Vec<(UnitId, FireId)> = self
            .units
            .iter()
            .filter(|(_, v)| v.available())
            .filter_map(|(u, v)| Some((u.clone(), named(v)?)))
            .filter(|&(_, f)| f != kept && self.fusion.resolve(f) == kept)
            .collect();
        let mut out = Vec::new();
        for (unit, from) in merged {
            let (away, backup) = self.as_backup(&unit, kept);
            if away < first_s || (backup && !held) {
                continue;
            }
            self.log(
                t,
                Decision::MergedAway {
                    unit: unit.clone(),
                    from,
                    kept,
                },
            );
            out.push(self.standby(&unit, t));
        }
        out
    }

    /// The fires held at `t` (the module's doc); a fire newly held is logged.
    fn held(&mut self, t: f64) -> BTreeSet<FireId> {
        let now: Vec<(FireId, usize)> = self
            .churn
            .held(t)
            .filter(|&(fire, _)| {
                self.fusion
                    .get(fire)
                    .is_some_and(|f| f.id == fire && f.active())
            })
            .collect();
        for &(fire, changes) in &now {
            if !self.held.contains(&fire) {
                self.log(t, Decision::Held { fire, changes });
            }
        }
        self.held = now.into_iter().map(|(fire, _)| fire).collect();
        self.held.clone()
    }

    /// `needs` paired with `candidates` by the strategy, on this site.
    pub(super) fn picks(&mut self, candidates: &[Candidate], needs: &[Need]) -> Vec<Pick> {
        if candidates.is_empty() || needs.is_empty() {
            return Vec::new();
        }
        let (barred, barred_rail) = (
            self.goals.barred(UnitKind::Ground),
            self.goals.barred(UnitKind::Monorail),
        );
        let burning: Vec<(FireId, Point2)> = self
            .fusion
            .fires()
            .iter()
            .filter(|f| f.active() && f.state != FireState::Tentative)
            .map(|f| (f.id, f.position()))
            .collect();
        let hazards: Vec<Place> = burning
            .iter()
            .map(|(_, p)| Place::in_tunnel(&self.tunnel, *p))
            .collect();
        // Out of `self` while decisions are dispatched below; put back at the end.
        let mut roads = std::mem::take(&mut self.roads);
        roads.track(&burning);
        let site = Site {
            barred: &barred,
            barred_rail: &barred_rail,
            hazards: &hazards,
            roads: Some(&roads as &dyn Roads),
        };
        let picks = self.strategy.solve(candidates, needs, &site);
        self.roads = roads;
        picks
    }

    /// Give `p.unit` the task of putting out `p.fire` (as its second attacker if `backup`),
    /// logging the decision.
    pub(super) fn dispatch(&mut self, p: &Pick, t: f64, backup: bool) -> Vec<Output> {
        if self.failed.contains_key(&(p.unit.clone(), p.fire)) {
            return Vec::new();
        }
        let resolved = self
            .units
            .get(&p.unit)
            .and_then(|v| v.working_on())
            .map(|f| self.fusion.resolve(f));
        let Some(view) = self.view_mut(&p.unit) else {
            return Vec::new();
        };
        if resolved == Some(p.fire) {
            // Already on its way there: no new task. A backup chosen as the first
            // attacker becomes it.
            if view.backup && !backup {
                view.backup = false;
                self.log(
                    t,
                    Decision::BackupTakesOver {
                        unit: p.unit.clone(),
                        fire: p.fire,
                    },
                );
            }
            return Vec::new();
        }
        let Some(fire) = self.fusion.get_mut(p.fire) else {
            return Vec::new();
        };
        if fire.state == FireState::Confirmed {
            fire.state = FireState::Assigned;
        }
        let target = fire.position();
        let from = self.attack_side(p.fire, t);
        if let Some((old, was_backup)) = self
            .units
            .get(&p.unit)
            .and_then(|v| Some((v.working_on()?, v.backup)))
        {
            self.log(
                t,
                Decision::Leaves {
                    unit: p.unit.clone(),
                    from: old,
                    to: p.fire,
                    was_backup,
                },
            );
        }
        let task = self.give(
            &p.unit,
            TaskKind::Extinguish {
                fire: p.fire,
                target,
                from,
            },
            t,
        );
        if let Some(v) = self.view_mut(&p.unit) {
            v.backup = backup;
        }
        self.log(
            t,
            Decision::Assign {
                unit: p.unit.clone(),
                fire: p.fire,
                backup,
                cost_s: p.cost_s,
                runner_up: p.runner_up.clone(),
                side: self
                    .air_m_s(t)
                    .and_then(|air| AttackSide::new(from, air, &self.portals)),
            },
        );
        vec![task, Output::Fire(self.track(p.fire, t))]
    }
}
