//! Invariants of an incident, checked over its history: what the fleet did against what
//! the commanders' zone goals asked. A Jepsen-style checker: events in (goals, clears,
//! unit states, tasks, each at its site time), violations out.
//!
//! Checked:
//! - **inside barred space**: a unit inside a keep-out or evacuate zone (one that bars
//!   its kind: `rail_allowed` lets carriages in) later than its grace period after the goal
//!   took effect. The grace is [`REACTION_S`] to hear the goal, plan and brake, plus, for a
//!   unit inside when the goal arrived, the time to drive out by the shortest way from
//!   where it stood, at its top speed, twice over (vehicles to go round, a turn to make).
//!   The shortest way stays in the tunnel: a zone that takes in a portal is left by its
//!   other end, since a unit's map ends at the portal. A unit with no way out at all (a
//!   carriage whose rail lies wholly in the zone) breaks nothing by staying: the
//!   coordinator tells the commander it is trapped.
//! - **sent into barred space**: a task whose destination lies in a zone barred to units
//!   when it was given.
//! - **attack where barred**: a unit spraying a fire in a zone whose goal forbids attack
//!   (monitor, keep-out, evacuate), later than [`REACTION_S`] after the goal.
//!
//! - **epoch went back**: a unit's state reports a task of an older epoch of one
//!   coordinator (rank) than an earlier state did: it obeyed that coordinator's earlier
//!   term (fencing failed). Going back to another rank's older term is the office
//!   changing hands (`firefleet_protocol::office`), not a violation.
//! - **two commanders in one epoch**: a task to a unit numbered below one already given
//!   to it in the same epoch. One coordinator's numbers to a unit only grow (it re-sends
//!   the latest), so two coordinators shared the epoch. Not counted in the term of a
//!   coordinator whose own log says someone else holds its key, from [`FINDING_S`] before
//!   that finding: a thief with the key of the coordinator in office commands in its term
//!   until it is suspended, and that is the attack, found and alarmed, not a fencing
//!   failure. Those tasks are counted apart ([`Invariants::stolen_key_tasks`]).
//! - **fire abandoned**, **fire forgotten across a takeover**: see [`continuity`].
//! - **assignment churn**: one fire's attackers changed more than
//!   [`churn::MAX_CHANGES_PER_WINDOW`] times within [`churn::WINDOW_S`]: see [`churn`].
//! - **unit pinned**: a unit's blocked steps (the simulator's refused moves) rose by more
//!   than [`pinned::MAX_BLOCKED_PER_WINDOW`] within [`pinned::WINDOW_S`]: see [`pinned`].
//!
//! Goals are applied with the coordinator's own rules ([`crate::goals::Goals`]: ids
//! replace, priorities, expiry), so a goal the coordinator refused binds nobody here
//! either. Pure: no I/O; reading a recording into events is the caller's business.
//!
//! Not here: why a violation happened. A violation names the unit, the goal and the time;
//! the recording around it tells the rest.

use std::collections::{BTreeMap, BTreeSet};

use firefleet_model::UnitKind;
use firefleet_model::profile::{GROUND, MONORAIL, Profile};
use firefleet_model::scenario::{Scenario, Tunnel};
use firefleet_model::{Chainage, CommanderId, FireId, Point2, UnitId, ZoneId};
use firefleet_protocol::msg::{
    GoalAck, INSIDE_PORTAL_M, SimTruth, Task, TaskPhase, TruthFireState, UnitState, ZoneGoal,
    epoch_rank, nearest_allowed,
};

use crate::goals::{Active, Goals};
use crate::incident::LEASE_S;
use firefleet_bus::access::Identity;
use firefleet_bus::suspension::commander_name;

pub mod churn;
mod continuity;
pub mod pinned;

use churn::{Churn, ChurnTally};
use continuity::Continuity;
pub use continuity::{RELIEF_S, TAKEOVER_S, Tally};
use pinned::{BlockedTally, Pinned};

/// Time to hear a goal and act on it, s: a state or task message comes at least once a
/// second, and a plan takes up to half a second.
pub const REACTION_S: f64 = 10.0;
/// The grace's allowance for the way out being longer than the straight line.
const DETOUR: f64 = 2.0;
/// How long a stolen key may be used before the coordinator finds it, s: the threat
/// model's bound on the alarm (issue #52). Two commanders in the term of a coordinator
/// found to have an impostor, from this long before the finding, are the thief's.
pub const FINDING_S: f64 = 2.0;

/// One thing that happened, at site time.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A commander's goal as sent on zone `key_zone`'s key by commander `by` (the checker
    /// decides, as the coordinator did, whether it was taken).
    Goal {
        key_zone: ZoneId,
        by: CommanderId,
        goal: ZoneGoal,
    },
    /// Commander `by` cleared its goals on `zone`.
    Clear {
        zone: ZoneId,
        by: CommanderId,
    },
    State(UnitState),
    Task(Task),
    /// Where fires burn (burning, not smouldering), by the simulator's ground truth.
    Burning(Vec<Point2>),
    /// The coordinator's answer to a goal, sent the moment it took (or refused) it.
    Ack(GoalAck),
    /// Identity `name` (`commander-rossi`, `console`) is suspended, as the goals in force
    /// first said, whose ids were then `in_force`: its goals lapsed, and so, if it is the
    /// console, did every goal it sealed for a commander, the goals the coordinator no
    /// longer held then ([`firefleet_bus::suspension`]). `asked_at`: when the last ask to
    /// suspend it was heard, at or before now.
    Suspended {
        name: String,
        in_force: Vec<String>,
        asked_at: f64,
    },
    /// Each unit's blocked steps so far, by the simulator's ground truth.
    Blocked(Vec<(UnitId, u32)>),
    /// The coordinator of `rank` says someone else holds its key: it heard tasks on its
    /// key that it never sent.
    KeyStolen {
        rank: u32,
    },
}

impl Event {
    /// Where `truth` has fires burning: the checker's event of the simulator's ground
    /// truth, in a recording or an in-process fleet alike.
    pub fn burning(truth: &SimTruth) -> Self {
        Self::Burning(
            truth
                .fires
                .iter()
                .filter(|f| f.state == TruthFireState::Burning)
                .map(|f| f.position)
                .collect(),
        )
    }

    /// Each unit's blocked steps in `truth`.
    pub fn blocked(truth: &SimTruth) -> Self {
        Self::Blocked(
            truth
                .units
                .iter()
                .map(|u| (u.id.clone(), u.collisions))
                .collect(),
        )
    }
}

/// A broken invariant.
#[derive(Debug, Clone, PartialEq)]
pub enum Violation {
    /// `unit` was inside barred zone `zone` at `t` (and, if `until` is later, through
    /// `until`), its grace for goal `goal` having run out at `deadline`.
    InsideBarred {
        unit: UnitId,
        zone: ZoneId,
        goal: String,
        t: f64,
        until: f64,
        deadline: f64,
        at: Chainage,
    },
    /// Task `seq` sent `unit` to `to`, inside zone `zone` barred by goal `goal`.
    SentIntoBarred {
        unit: UnitId,
        seq: u64,
        t: f64,
        to: Point2,
        zone: ZoneId,
        goal: String,
    },
    /// `unit` sprayed a fire at `target` inside zone `zone`, where goal `goal` forbids
    /// attack.
    AttackWhereBarred {
        unit: UnitId,
        t: f64,
        target: Point2,
        zone: ZoneId,
        goal: String,
    },
    /// `unit` reported a task of epoch `to` after one of the newer epoch `from` of the same
    /// coordinator.
    EpochWentBack {
        unit: UnitId,
        t: f64,
        from: u64,
        to: u64,
    },
    /// Task `seq` of `epoch` went to `unit` after task `after` of the same epoch.
    TwoCommanders {
        unit: UnitId,
        t: f64,
        epoch: u64,
        seq: u64,
        after: u64,
    },
    /// `unit`, sent to the fire at `fire`, was last heard at `heard`; by `due` no other
    /// unit was sent there, though one was free to go.
    FireAbandoned {
        unit: UnitId,
        heard: f64,
        due: f64,
        fire: Point2,
    },
    /// A coordinator took office in `epoch` at `t`; by `due` it had sent nobody to the
    /// fire at `fire`, which a unit of the old term was sent to.
    FireForgotten {
        epoch: u64,
        t: f64,
        due: f64,
        fire: Point2,
    },
    /// Fire `fire`'s attackers changed `changes` times within [`churn::WINDOW_S`] up to
    /// `t` (the most it reached).
    Churn {
        fire: FireId,
        t: f64,
        changes: usize,
    },
    /// `unit`'s blocked steps rose by `blocked` within [`pinned::WINDOW_S`] up to `t` (the
    /// most it reached).
    Pinned { unit: UnitId, t: f64, blocked: u32 },
}

impl std::fmt::Display for Violation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Violation::InsideBarred {
                unit,
                zone,
                goal,
                t,
                until,
                deadline,
                at,
            } => write!(
                f,
                "t={t:.1} s: {unit} inside zone {zone} (goal '{goal}') at chainage {at:.1} until t={until:.1} s; barred to it from t={deadline:.1} s"
            ),
            Violation::SentIntoBarred {
                unit,
                seq,
                t,
                to,
                zone,
                goal,
            } => write!(
                f,
                "t={t:.1} s: task {seq} sent {unit} to ({:.1}, {:.1}) in zone {zone}, barred by goal '{goal}'",
                to.x, to.y
            ),
            Violation::AttackWhereBarred {
                unit,
                t,
                target,
                zone,
                goal,
            } => write!(
                f,
                "t={t:.1} s: {unit} sprayed a fire at ({:.1}, {:.1}) in zone {zone}, where goal '{goal}' forbids attack",
                target.x, target.y
            ),
            Violation::EpochWentBack { unit, t, from, to } => write!(
                f,
                "t={t:.1} s: {unit} took a task of epoch {to} after one of epoch {from} of the same coordinator: it obeyed that coordinator's earlier term"
            ),
            Violation::TwoCommanders {
                unit,
                t,
                epoch,
                seq,
                after,
            } => write!(
                f,
                "t={t:.1} s: task {seq} of epoch {epoch} went to {unit} after task {after} of that epoch: two coordinators commanded in one epoch"
            ),
            Violation::FireAbandoned {
                unit,
                heard,
                due,
                fire,
            } => write!(
                f,
                "t={heard:.1} s: {unit} fell silent on its way to the fire at ({:.1}, {:.1}); at t={due:.1} s nobody else was sent there, though a unit was free",
                fire.x, fire.y
            ),
            Violation::FireForgotten {
                epoch,
                t,
                due,
                fire,
            } => write!(
                f,
                "t={t:.1} s: epoch {epoch} took office; at t={due:.1} s it had sent nobody to the fire at ({:.1}, {:.1}) that the old term was attacking",
                fire.x, fire.y
            ),
            Violation::Pinned { unit, t, blocked } => write!(
                f,
                "t={t:.1} s: {unit} was blocked {blocked} steps within {:.0} s (at most {} allowed): pinned against a wall, a vehicle or a unit",
                pinned::WINDOW_S,
                pinned::MAX_BLOCKED_PER_WINDOW
            ),
            Violation::Churn { fire, t, changes } => write!(
                f,
                "t={t:.1} s: fire {fire}'s attackers changed {changes} times within {:.0} s (at most {} allowed): assignment thrash",
                churn::WINDOW_S,
                churn::MAX_CHANGES_PER_WINDOW
            ),
        }
    }
}

/// The checker: feed it events in order, then take the violations.
pub struct Invariants {
    tunnel: Tunnel,
    goals: Goals,
    t: f64,
    /// When each goal took effect, by id.
    since: BTreeMap<String, f64>,
    /// Each unit's last state.
    units: BTreeMap<UnitId, UnitState>,
    /// For each (unit, goal id): when the unit must be out, site time.
    deadlines: BTreeMap<(UnitId, String), f64>,
    /// The open inside-barred violation of each (unit, goal id), to extend while it lasts.
    open: BTreeMap<(UnitId, String), usize>,
    /// The newest epoch each unit's states reported, by the rank of its coordinator.
    epochs: BTreeMap<(UnitId, u32), u64>,
    /// The highest task number given to each unit in each epoch.
    issued: BTreeMap<(UnitId, u64), u64>,
    /// When each coordinator whose key someone else holds first said so, by rank.
    stolen: BTreeMap<u32, f64>,
    /// Tasks below one already given in their epoch, in the term of a stolen key
    /// ([`FINDING_S`]): (unit, epoch, number).
    stolen_key_tasks: BTreeSet<(UnitId, u64, u64)>,
    continuity: Continuity,
    churn: Churn,
    pinned: Pinned,
    violations: Vec<Violation>,
    /// Each declared unit's top speed, m/s, from its own profile: the time it is given to
    /// leave a zone.
    speeds: BTreeMap<UnitId, f64>,
    /// The goals the coordinator acknowledged as taken, by id, once the history holds
    /// acknowledgements at all (a recording does; an in-process run may not).
    acked: Option<BTreeSet<String>>,
}

impl Invariants {
    /// A checker of an incident at `scenario`'s site whose coordinator counts a unit
    /// silent for [`LEASE_S`] as lost.
    pub fn new(scenario: &Scenario) -> Self {
        Self::with_lease(scenario, LEASE_S)
    }

    /// [`Invariants::new`], for a coordinator whose lease is `lease_s`.
    pub fn with_lease(scenario: &Scenario, lease_s: f64) -> Self {
        Self {
            tunnel: scenario.tunnel.clone(),
            speeds: scenario
                .units
                .iter()
                .filter_map(|u| {
                    let speed = match scenario.profile_of(u).ok()? {
                        Profile::Ground(g) => g.max_speed_m_s,
                        Profile::Monorail(m) => m.carriage_speed_m_s,
                    };
                    Some((u.id.clone(), speed))
                })
                .collect(),
            goals: Goals::new(&scenario.zones, &scenario.commanders),
            t: 0.0,
            since: BTreeMap::new(),
            units: BTreeMap::new(),
            deadlines: BTreeMap::new(),
            open: BTreeMap::new(),
            epochs: BTreeMap::new(),
            issued: BTreeMap::new(),
            stolen: BTreeMap::new(),
            stolen_key_tasks: BTreeSet::new(),
            continuity: Continuity::new(lease_s),
            churn: Churn::default(),
            pinned: Pinned::default(),
            violations: Vec::new(),
            acked: None,
        }
    }

    /// Take `event`, which happened at site time `t` (times never go back: an earlier
    /// `t` counts as the latest seen).
    pub fn observe(&mut self, t: f64, event: Event) {
        self.t = self.t.max(t);
        let t = self.t;
        for g in self.goals.expire(t) {
            self.forget(&g.id);
        }
        self.continuity.heard_anything(t);
        match event {
            Event::Goal { key_zone, by, goal } => {
                let id = goal.id.clone();
                if self.goals.submit(&key_zone, &by, goal, t).accepted {
                    self.forget(&id);
                    self.since.insert(id.clone(), t);
                    self.grant_grace(&id, t);
                }
            }
            Event::Clear { zone, by } => {
                for g in self.goals.clear(&zone, &by) {
                    self.forget(&g.id);
                }
            }
            Event::State(st) => {
                self.continuity.state(&st, t);
                self.check_state(st, t);
            }
            Event::Task(task) => {
                self.continuity.task(&task, t);
                self.check_task(&task, t);
                for (fire, changes) in self.churn.task(&task, t) {
                    self.raise(Violation::Churn { fire, t, changes });
                }
            }
            Event::Burning(fires) => self.continuity.burning(fires),
            Event::Blocked(counts) => {
                for (unit, blocked) in self.pinned.counts(&counts, t) {
                    self.raise(Violation::Pinned { unit, t, blocked });
                }
            }
            Event::Suspended {
                name,
                in_force,
                asked_at,
            } => {
                // The console seals goals in commanders' names: which were its own, only
                // the coordinator's record of the goals it still holds tells.
                let seals_for_others = name == Identity::Console.dir_name();
                let lapsed = self.goals.lapse(|a| {
                    a.goal.issued_by.as_ref().map(commander_name) == Some(name.clone())
                        || (seals_for_others && !in_force.contains(&a.goal.id))
                });
                for g in &lapsed {
                    self.forget(&g.id);
                }
                // The coordinator let those goals lapse as the ask came, and told it with
                // the goals in force, which the recording may hold only at their next
                // once-a-second send (a put on a busy link is dropped, not queued): what
                // they barred after the ask was no longer barred.
                let lapsed: BTreeSet<&str> = lapsed.iter().map(|g| g.id.as_str()).collect();
                self.violations.retain(|v| match v {
                    Violation::SentIntoBarred { goal, t, .. }
                    | Violation::AttackWhereBarred { goal, t, .. }
                    | Violation::InsideBarred { goal, t, .. } => {
                        !(lapsed.contains(goal.as_str()) && *t >= asked_at)
                    }
                    _ => true,
                });
            }
            Event::KeyStolen { rank } => {
                let found = *self.stolen.entry(rank).or_insert(t);
                let (theirs, ours): (Vec<_>, Vec<_>) = std::mem::take(&mut self.violations)
                    .into_iter()
                    .partition(|v| match v {
                        Violation::TwoCommanders { t, epoch, .. } => {
                            epoch_rank(*epoch) == rank && *t >= found - FINDING_S
                        }
                        _ => false,
                    });
                self.violations = ours;
                for v in theirs {
                    if let Violation::TwoCommanders {
                        unit, epoch, seq, ..
                    } = v
                    {
                        self.stolen_key_tasks.insert((unit, epoch, seq));
                    }
                }
            }
            Event::Ack(ack) => {
                let acked = self.acked.get_or_insert_default();
                if ack.accepted {
                    acked.insert(ack.id);
                }
            }
        }
        let goals = &self.goals;
        let tunnel = &self.tunnel;
        self.continuity.settle(
            t,
            |p| {
                goals
                    .at(tunnel.chainage(p))
                    .is_some_and(Active::bars_attack)
            },
            &mut self.violations,
        );
    }

    /// The violations found so far.
    pub fn violations(&self) -> &[Violation] {
        &self.violations
    }

    /// How many tasks were numbered below one already given in their epoch, in the term
    /// of a coordinator whose key someone else held ([`FINDING_S`]): the thief's fight
    /// with the holder, not judged as two commanders.
    pub fn stolen_key_tasks(&self) -> usize {
        self.stolen_key_tasks.len()
    }

    /// How the fires owed a unit (lost units', takeovers') were settled so far.
    pub fn continuity(&self) -> Tally {
        self.continuity.tally()
    }

    /// How much the assignments churned so far.
    pub fn churn(&self) -> ChurnTally {
        self.churn.tally()
    }

    /// How much the units were blocked so far.
    pub fn blocked(&self) -> BlockedTally {
        self.pinned.tally()
    }

    /// A windowed count past its bound: one violation per fire (churn) or unit (pinned),
    /// the first time it is passed, raised to the most it reaches after.
    fn raise(&mut self, new: Violation) {
        for open in &mut self.violations {
            match (open, &new) {
                (
                    Violation::Churn { fire, changes, .. },
                    Violation::Churn {
                        fire: f,
                        changes: c,
                        ..
                    },
                ) if fire == f => {
                    *changes = (*changes).max(*c);
                    return;
                }
                (
                    Violation::Pinned { unit, blocked, .. },
                    Violation::Pinned {
                        unit: u,
                        blocked: b,
                        ..
                    },
                ) if unit == u => {
                    *blocked = (*blocked).max(*b);
                    return;
                }
                _ => {}
            }
        }
        self.violations.push(new);
    }

    fn forget(&mut self, goal: &str) {
        self.since.remove(goal);
        self.deadlines.retain(|(_, g), _| g != goal);
        self.open.retain(|(_, g), _| g != goal);
    }

    /// Every unit inside goal `id`'s zone when it took effect gets until its deadline.
    fn grant_grace(&mut self, id: &str, t: f64) {
        let Some(active) = self.goals.active().iter().find(|a| a.goal.id == id) else {
            return;
        };
        if !active.bars_entry() {
            return;
        }
        let barred = self.goals.barred_space(t);
        for (unit, st) in &self.units {
            let s = self.tunnel.chainage(st.pose.position());
            if barred.entry_at(st.kind, s).is_none_or(|b| b.goal != id) {
                continue;
            }
            let (lo, hi) = (
                Chainage::new(INSIDE_PORTAL_M),
                self.tunnel.end() - INSIDE_PORTAL_M,
            );
            let Some(out) = nearest_allowed(&barred.ranges(st.kind), s, 0.0, lo, hi) else {
                self.deadlines
                    .insert((unit.clone(), id.to_owned()), f64::INFINITY);
                continue;
            };
            // The unit's own top speed; one the site file does not declare is judged as
            // its kind's shipped profile.
            let speed = self.speeds.get(unit).copied().unwrap_or(match st.kind {
                UnitKind::Ground => GROUND.max_speed_m_s,
                UnitKind::Monorail => MONORAIL.carriage_speed_m_s,
            });
            let deadline = t + REACTION_S + DETOUR * (out - s).abs() / speed;
            self.deadlines
                .insert((unit.clone(), id.to_owned()), deadline);
        }
    }

    /// The goal governing `p`, if one is in force there.
    fn goal_at(&self, p: Point2) -> Option<&Active> {
        self.goals.at(self.tunnel.chainage(p))
    }

    fn check_state(&mut self, st: UnitState, t: f64) {
        let unit = st.unit.clone();
        if let Some(epoch) = st.epoch {
            let newest = self
                .epochs
                .entry((unit.clone(), epoch_rank(epoch)))
                .or_insert(epoch);
            let from = *newest;
            *newest = from.max(epoch);
            // Once per epoch gone back to: states come ten times a second.
            if epoch < from
                && !self.violations.iter().any(|w| {
                    matches!(w, Violation::EpochWentBack { unit: u, to, .. } if *u == unit && *to == epoch)
                })
            {
                self.violations.push(Violation::EpochWentBack {
                    unit: unit.clone(),
                    t,
                    from,
                    to: epoch,
                });
            }
        }
        let p = st.pose.position();
        let barred = self.goals.barred_space(t);
        if let Some(b) = barred.entry_at(st.kind, self.tunnel.chainage(p)) {
            let (id, zone) = (b.goal.clone(), b.zone.clone());
            let key = (unit.clone(), id.clone());
            // A unit that was outside when the goal came has the time to hear it and
            // brake.
            let deadline = self
                .deadlines
                .get(&key)
                .copied()
                .or(self.since.get(&id).map(|since| since + REACTION_S))
                .unwrap_or(t);
            if t > deadline {
                match self.open.get(&key) {
                    Some(&k) => {
                        if let Violation::InsideBarred { until, .. } = &mut self.violations[k] {
                            *until = t;
                        }
                    }
                    None => {
                        self.open.insert(key, self.violations.len());
                        self.violations.push(Violation::InsideBarred {
                            unit: unit.clone(),
                            zone,
                            goal: id,
                            t,
                            until: t,
                            deadline,
                            at: self.tunnel.chainage(p),
                        });
                    }
                }
            }
        } else {
            // Out (or the goal lapsed): a later time inside is a new violation.
            self.open.retain(|(u, _), _| u != &unit);
        }
        if let Some(progress) = st.task
            && progress.phase == TaskPhase::Spraying
            && let Some(g) = self.goal_at(progress.target).filter(|g| g.bars_attack())
            && self
                .since
                .get(&g.goal.id)
                .is_some_and(|since| t > since + REACTION_S)
        {
            let v = Violation::AttackWhereBarred {
                unit: unit.clone(),
                t,
                target: progress.target,
                zone: g.goal.zone.clone(),
                goal: g.goal.id.clone(),
            };
            // One report per unit and goal: a unit spraying sends a state ten times a
            // second.
            let reported = self.violations.iter().any(|w| {
                matches!(w, Violation::AttackWhereBarred { unit: u, goal, .. }
                    if *u == unit && *goal == g.goal.id)
            });
            if !reported {
                self.violations.push(v);
            }
        }
        self.units.insert(unit, st);
    }

    fn check_task(&mut self, task: &Task, t: f64) {
        let last = self
            .issued
            .entry((task.unit.clone(), task.epoch))
            .or_insert(task.seq);
        let after = *last;
        *last = after.max(task.seq);
        let thief_s = self
            .stolen
            .get(&task.rank())
            .is_some_and(|found| t >= found - FINDING_S);
        if task.seq < after && thief_s {
            self.stolen_key_tasks
                .insert((task.unit.clone(), task.epoch, task.seq));
        // Once per task: tasks are re-sent every second.
        } else if task.seq < after
            && !self.violations.iter().any(|w| {
                matches!(w, Violation::TwoCommanders { unit, epoch, seq, .. }
                    if *unit == task.unit && *epoch == task.epoch && *seq == task.seq)
            })
        {
            self.violations.push(Violation::TwoCommanders {
                unit: task.unit.clone(),
                t,
                epoch: task.epoch,
                seq: task.seq,
                after,
            });
        }
        let Some(to) = task.kind.destination() else {
            return;
        };
        let kind = self
            .units
            .get(&task.unit)
            .map_or(UnitKind::Ground, |st| st.kind);
        let barred = self.goals.barred_space(t);
        // A task is judged against the goals its coordinator had taken when it sent it: a
        // goal reaches the recorder and the coordinator by different ways, and a task the
        // coordinator sent before it heard the goal can be recorded after the goal. The
        // coordinator acknowledges a goal as it takes it, before any task that follows from
        // it, so where the history holds acknowledgements a goal not yet acknowledged bars
        // no task.
        let taken = |goal: &str| self.acked.as_ref().is_none_or(|a| a.contains(goal));
        if let Some(b) = barred
            .entry_at(kind, self.tunnel.chainage(to))
            .filter(|b| taken(&b.goal))
        {
            let v = Violation::SentIntoBarred {
                unit: task.unit.clone(),
                seq: task.seq,
                t,
                to,
                zone: b.zone.clone(),
                goal: b.goal.clone(),
            };
            // Tasks are re-sent every second; the first sending is the violation.
            if !self.violations.iter().any(|w| {
                matches!(w, Violation::SentIntoBarred { unit, seq, .. }
                    if *unit == task.unit && *seq == task.seq)
            }) {
                self.violations.push(v);
            }
        }
    }
}

#[cfg(test)]
mod tests;
