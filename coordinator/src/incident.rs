//! The coordinator's picture of the incident, and how it reacts to events.
//!
//! Every event (a unit's state, a flame report, a unit appearing or vanishing, time
//! passing) updates the picture and returns the messages to publish: new tasks and changed
//! fire tracks. Every decision is logged with its reason and kept in [`Incident::decisions`].

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use firefleet_protocol::msg::{
    Decision, FireState, FireTrack, FlameReport, GoalAck, GoalKind, IncidentStatus, Task, TaskKind,
    TaskPhase, TaskProgress, UnitKind, UnitMode, UnitState, UnitStatus, ZoneGoal,
};
use firefleet_protocol::scenario::{Scenario, Tunnel};
use firefleet_protocol::spec::{GROUND, MONORAIL};
use firefleet_protocol::validate::{Invalid, Validate};
use firefleet_protocol::{FireId, Point2, Pose2, UnitId, ZoneId};

use crate::assign::{
    Candidate, Mobility, Need, Pick, Place, Roads, Site, Strategy, attackers_needed,
};
use crate::coverage::Coverage;
use crate::fusion::{Fire, Fused, Fusion};
use crate::goals::Goals;
use crate::roads::RoadMap;

/// How many decisions the incident remembers for status queries.
const DECISION_LOG: usize = 200;
/// Free units are staged this far short of the nearest active fire, m: beyond the 20 m at
/// which a cruising unit stops for a flame, and where the radiant flux of a 5 MW fire is
/// under 0.2 kW/m^2.
const STAGE_OFFSET_M: f64 = 25.0;
/// Ground units sent to one fire while units are free (more if its heat release needs
/// them, [`crate::assign::attackers_needed`]): alone, every unit that sees a fire attacks
/// it, and two cannons knock a fire down in less than half the time of one (Evans: tau ~
/// density^-1.85).
const UNITS_PER_FIRE: usize = 2;
/// Free units staged as reserves per active fire, nearest first.
const RESERVES_PER_FIRE: usize = 3;
/// A backup or a reserve is sent to a fire only from this near, s of travel: a unit
/// attacking alone has a minute to knock its fire down (the ground tree's timeout), so one
/// that arrives later comes to a fire that is out, or to a unit that has given up and is
/// replaced by the ordinary assignment. Farther units are worth more searching.
const HELP_WITHIN_S: f64 = 60.0;
/// After a unit fails a fire, it is not sent to that fire again for this long, s.
const RETRY_AFTER_S: f64 = 60.0;
/// A task adopted after a restart binds to a track this close to the unit's target, m.
const ADOPT_RADIUS_M: f64 = 5.0;
/// A monorail unit's search run has ended this close to its end, m.
const RAIL_RUN_DONE_M: f64 = 1.0;
/// The whole assignment, units on their way included, is solved again at least this often,
/// s: a unit on its way that a nearer one should relieve is relieved within the second.
/// A flame report re-solves only the fires nobody has taken (a whole solve takes about
/// 2 ms at 1000 units and 200 fires, too long to run on every report).
const SOLVE_ALL_EVERY_S: f64 = 1.0;
/// How far outside a zone units leaving it are sent, m.
const EVACUATE_MARGIN_M: f64 = 5.0;
/// A stretch nobody has looked at for this long is searched again, s: fire spreads to
/// nearby vehicles, and a fast-growing fire goes from nothing to 1 MW in 146 s.
const SEARCH_AGAIN_AFTER_S: f64 = 120.0;
/// A searching unit's goal is changed only when the new one lies this far from it, m: the
/// unseen stretch shrinks as units look, and every new goal makes the unit plan again.
const SEARCH_GOAL_SLACK_M: f64 = 10.0;
/// The first and last metres of the tunnel, which search leaves out, m.
const PORTAL_M: f64 = 10.0;
/// A ground unit takes in this much of the road behind it, m: its heat sensors feel a fire
/// it stands next to, whichever way its camera looks.
const SIGHT_BEHIND_M: f64 = 5.0;

/// How much of the assignment a solve takes up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scope {
    /// Fires nobody has taken, for units not on their way to a fire: what a flame report
    /// changes.
    NewFires,
    /// Every fire nobody sprays yet, for every unit not spraying.
    All,
}

/// What to publish after an event.
#[derive(Debug, Clone, PartialEq)]
pub enum Output {
    Task(Task),
    Fire(FireTrack),
}

/// What the coordinator knows of one unit.
#[derive(Debug, Clone)]
struct UnitView {
    mobility: Mobility,
    state: Option<UnitState>,
    alive: bool,
    last_heard: f64,
    task: Option<Task>,
    /// The task makes the unit a fire's second attacker: a new fire with nobody on it may
    /// take the unit while it is still on its way.
    backup: bool,
}

impl UnitView {
    fn new(mobility: Mobility) -> Self {
        Self {
            mobility,
            state: None,
            alive: false,
            last_heard: 0.0,
            task: None,
            backup: false,
        }
    }

    /// Not spraying: a unit spraying is never pulled off its fire; any other may be given
    /// a fire (one on its way keeps its own unless another unit is much nearer).
    fn available(&self) -> bool {
        !self
            .state
            .as_ref()
            .and_then(|s| s.task)
            .is_some_and(|p| p.phase == TaskPhase::Spraying)
    }

    fn working_on(&self) -> Option<FireId> {
        match self.task.as_ref()?.kind {
            TaskKind::Extinguish { fire, .. } => Some(fire),
            TaskKind::Standby | TaskKind::Cruise { .. } | TaskKind::Search { .. } => None,
        }
    }
}

/// The incident.
pub struct Incident {
    tunnel: Tunnel,
    units: BTreeMap<UnitId, UnitView>,
    fusion: Fusion,
    seq: u64,
    lease_s: f64,
    strategy: Strategy,
    /// (unit, fire) pairs that failed, and until when not to retry them.
    failed: BTreeMap<(UnitId, FireId), f64>,
    decisions: VecDeque<Decision>,
    /// Decisions not yet handed out for publication.
    unpublished: Vec<Decision>,
    goals: Goals,
    /// Ground units sent to one fire.
    units_per_fire: usize,
    /// Driving distances to fires; straight lines without (an incident built without a
    /// site file).
    roads: Option<RoadMap>,
    /// Where units have looked.
    coverage: Coverage,
    /// When the whole assignment was last solved.
    solved_all_at: f64,
}

impl Incident {
    /// An incident in `tunnel` with the units the site file declares. Reports from any
    /// other unit are refused. A unit silent for `lease_s` is treated as lost.
    pub fn new(
        tunnel: Tunnel,
        units: impl IntoIterator<Item = (UnitId, Mobility)>,
        lease_s: f64,
        strategy: Strategy,
    ) -> Self {
        Self {
            units: units
                .into_iter()
                .map(|(u, m)| (u, UnitView::new(m)))
                .collect(),
            fusion: Fusion::default(),
            seq: 0,
            lease_s,
            strategy,
            failed: BTreeMap::new(),
            decisions: VecDeque::new(),
            unpublished: Vec::new(),
            goals: Goals::default(),
            units_per_fire: UNITS_PER_FIRE,
            roads: None,
            coverage: Coverage::new(tunnel.length_m),
            solved_all_at: f64::NEG_INFINITY,
            tunnel,
        }
    }

    /// Send up to `n` ground units to each fire while units are free (default
    /// [`UNITS_PER_FIRE`]; at least 1), or more if its heat release needs them.
    pub fn set_units_per_fire(&mut self, n: usize) {
        self.units_per_fire = n.max(1);
    }

    /// The incident of a site file: its tunnel, and its units with their mobility (ground
    /// units at the ground unit's top speed, monorail units on their rails).
    pub fn from_scenario(scenario: &Scenario, lease_s: f64, strategy: Strategy) -> Self {
        let units = scenario.units.iter().map(|u| {
            let rail = u.rail.as_deref().and_then(|r| scenario.rail(r));
            let mobility = match (u.kind, rail) {
                (UnitKind::Monorail, Some(r)) => Mobility::Rail {
                    start_m: r.start_m,
                    end_m: r.end_m,
                    y_m: r.y_m,
                    speed_m_s: MONORAIL.carriage_speed_m_s,
                    reach_m: MONORAIL.working_reach_m,
                },
                _ => Mobility::Ground {
                    speed_m_s: GROUND.max_speed_m_s,
                },
            };
            (u.id.clone(), mobility)
        });
        let mut incident = Self::new(scenario.tunnel.clone(), units, lease_s, strategy);
        incident.goals = Goals::new(&scenario.zones);
        incident.roads = Some(RoadMap::from_scenario(scenario));
        incident
    }

    /// A commander's goal arrived on zone `key_zone`'s key: the acknowledgement, and the
    /// decisions it leads to when accepted.
    pub fn on_goal(&mut self, key_zone: &ZoneId, goal: ZoneGoal, t: f64) -> (GoalAck, Vec<Output>) {
        let text = format!(
            "goal '{}' ({:?}, priority {}) on zone {} from '{}'",
            goal.id, goal.goal, goal.priority, goal.zone, goal.issued_by
        );
        let ack = self.goals.submit(key_zone, goal, t);
        if ack.accepted {
            self.log(t, format!("{text}: {}", ack.reason));
            (ack, self.enforce(t))
        } else {
            self.log(t, format!("{text} rejected: {}", ack.reason));
            (ack, Vec::new())
        }
    }

    /// Every goal on `zone` withdrawn by a commander.
    pub fn clear_goals(&mut self, zone: &ZoneId, t: f64) -> Vec<Output> {
        for g in self.goals.clear(zone) {
            self.log(t, format!("goal '{}' on zone {zone} cleared", g.id));
        }
        self.enforce(t)
    }

    /// The goals in force.
    pub fn goals(&self) -> impl Iterator<Item = &ZoneGoal> {
        self.goals.active().iter().map(|a| &a.goal)
    }

    /// Apply the goals in force to the units: withdraw units from fires they may no longer
    /// attack, move units out of zones they may not be in, then re-solve.
    fn enforce(&mut self, t: f64) -> Vec<Output> {
        let mut out = Vec::new();
        let units: Vec<UnitId> = self.units.keys().cloned().collect();
        for u in units {
            let v = &self.units[&u];
            if !v.alive {
                continue;
            }
            if let Some(fire) = v.working_on()
                && let Some(f) = self.fusion.get(self.fusion.resolve(fire))
                && let Some(g) = self.goals.at(self.tunnel.chainage(f.position()))
                && g.bars_attack()
            {
                let text = format!(
                    "withdraw {u} from fire {fire}: goal '{}' ({:?}) on zone {}",
                    g.goal.id, g.goal.goal, g.goal.zone
                );
                self.log(t, text);
                if let Some(f) = self.fusion.get_mut(fire) {
                    f.state = FireState::Confirmed;
                }
                out.push(self.standby(&u, t));
            }
            let v = &self.units[&u];
            let (Some(st), Mobility::Ground { .. }) = (&v.state, v.mobility) else {
                continue;
            };
            let at = self.tunnel.station(st.pose.position());
            let Some(g) = self.goals.at(at.s).filter(|g| g.bars_entry()) else {
                continue;
            };
            let (id, zone) = (g.goal.id.clone(), g.goal.zone.clone());
            let Some(x) = self.goals.nearest_allowed(
                at.s,
                EVACUATE_MARGIN_M,
                1.0,
                self.tunnel.length_m - 1.0,
            ) else {
                self.log(
                    t,
                    format!("{u} cannot leave zone {zone}: no chainage outside it"),
                );
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
                format!("evacuate {u} from zone {zone} to chainage {x:.1}: goal '{id}'"),
            );
        }
        out.extend(self.solve(t));
        out
    }

    fn log(&mut self, t: f64, text: String) {
        tracing::info!(t, "{text}");
        if self.decisions.len() == DECISION_LOG {
            self.decisions.pop_front();
        }
        let d = Decision { t, text };
        self.unpublished.push(d.clone());
        self.decisions.push_back(d);
    }

    /// A task number higher than any before it, across coordinator restarts too: units
    /// ignore a task whose number is not higher than the last one they took, so a
    /// restarted coordinator counting from 0 would be ignored. Numbers are floored by site
    /// time (1000 per second) and by the highest number seen in any unit's state.
    fn next_seq(&mut self, t: f64) -> u64 {
        self.seq = (self.seq + 1).max((t.max(0.0) * 1000.0) as u64);
        self.seq
    }

    /// Decisions made since the last call, for the bus (and so the recording).
    pub fn take_decisions(&mut self) -> Vec<Decision> {
        std::mem::take(&mut self.unpublished)
    }

    fn view(&mut self, unit: &UnitId, field: &str) -> Result<&mut UnitView, Invalid> {
        self.units
            .get_mut(unit)
            .ok_or_else(|| Invalid::new(field, format!("unknown unit '{unit}'")))
    }

    /// A unit's liveliness token appeared or vanished.
    pub fn on_alive(&mut self, unit: &UnitId, alive: bool, t: f64) -> Result<Vec<Output>, Invalid> {
        let v = self.view(unit, "unit")?;
        let was = v.alive;
        v.alive = alive;
        if alive {
            v.last_heard = t;
            if !was {
                self.log(t, format!("unit {unit} joined"));
            }
            return Ok(self.solve(t));
        }
        if !was {
            return Ok(Vec::new());
        }
        Ok(self.lose(unit, t, "its liveliness token vanished"))
    }

    fn lose(&mut self, unit: &UnitId, t: f64, why: &str) -> Vec<Output> {
        let v = self.units.get_mut(unit).expect("known unit");
        v.alive = false;
        let fire = v.working_on();
        v.task = None;
        let mut out = Vec::new();
        match fire {
            Some(f) => {
                self.log(
                    t,
                    format!("unit {unit} lost ({why}); fire {f} needs a new unit"),
                );
                out.extend(self.release(f, t));
            }
            None => self.log(t, format!("unit {unit} lost ({why})")),
        }
        out.extend(self.solve(t));
        out
    }

    /// Put a fire back among those needing a unit, if it still burns.
    fn release(&mut self, fire: FireId, t: f64) -> Option<Output> {
        let f = self.fusion.get_mut(fire)?;
        if !f.active() {
            return None;
        }
        f.state = FireState::Confirmed;
        Some(Output::Fire(self.track(fire, t)))
    }

    /// Fire tracks a previous coordinator published, as a recorder kept them: taken back
    /// under their ids before the units are heard from, so that a fire nobody is working on
    /// right now is not forgotten across a restart. A track that fails validation or lies
    /// outside the tunnel is refused (returned with its reason) and the rest are still
    /// taken; one whose id is already known is skipped.
    pub fn restore(&mut self, tracks: &[FireTrack], t: f64) -> (Vec<Output>, Vec<Invalid>) {
        let mut refused = Vec::new();
        for track in tracks {
            let checked = track
                .validate()
                .and_then(|()| self.tunnel.check_inside("position", track.position))
                .map_err(|e| e.within(&format!("fire {}", track.id)));
            if let Err(e) = checked {
                refused.push(e);
                continue;
            }
            if self.fusion.restore(track) {
                let seen_by: Vec<&str> = track.seen_by.iter().map(|u| u.as_str()).collect();
                self.log(
                    t,
                    format!(
                        "recall fire {} at ({:.1}, {:.1}), {:?} at t = {:.1} s, seen by [{}]: tracked before this coordinator started",
                        track.id,
                        track.position.x,
                        track.position.y,
                        track.state,
                        track.t,
                        seen_by.join(", ")
                    ),
                );
            }
        }
        (self.solve(t), refused)
    }

    /// A unit's state message.
    pub fn on_state(&mut self, st: UnitState, t: f64) -> Result<Vec<Output>, Invalid> {
        let unit = st.unit.clone();
        self.tunnel.check_inside("pose", st.pose.position())?;
        let mobility = self.view(&unit, "unit")?.mobility;
        let (from, to) = self.sight(mobility, st.pose);
        self.coverage.look(from, to, t);
        let v = self.view(&unit, "unit")?;
        v.last_heard = t;
        let current = v.task.clone();
        let progress = st.task;
        // A state changes the decisions only when it brings a unit into play or takes one
        // out; a moving unit's position is picked up by the periodic re-solve. Re-solving
        // on every state would cost a solve per message: 10 000 a second for 1000 units.
        let able = |s: &UnitState| s.mode != UnitMode::Fault && s.water_l > 0.0;
        let mut relevant = v.state.as_ref().is_none_or(|old| able(old) != able(&st));
        v.state = Some(st);
        if let Some(p) = progress {
            self.seq = self.seq.max(p.seq);
        }
        let mut out = Vec::new();
        if current.is_none()
            && let Some(p) = progress
            && matches!(p.phase, TaskPhase::Travelling | TaskPhase::Spraying)
        {
            out.extend(self.adopt(&unit, p, t));
            relevant = true;
        }
        let current = self.units[&unit].task.clone();
        if let (Some(task), Some(p)) = (current, progress)
            && task.seq == p.seq
            && let TaskKind::Extinguish { fire, .. } = task.kind
        {
            // The task may name a track since merged into another.
            let fire = self.fusion.resolve(fire);
            match p.phase {
                TaskPhase::Extinguished => {
                    relevant = true;
                    if let Some(f) = self.fusion.get_mut(fire) {
                        f.state = FireState::Out;
                        f.out_at = Some(t);
                    }
                    self.log(t, format!("fire {fire} out, reported by {unit}"));
                    out.push(Output::Fire(self.track(fire, t)));
                    // Everyone on that fire is free again (after a merge, more than one).
                    let mut free = self.assigned_to(fire);
                    if !free.contains(&unit) {
                        free.push(unit.clone());
                    }
                    for u in free {
                        out.push(self.standby(&u, t));
                    }
                }
                TaskPhase::Failed => {
                    relevant = true;
                    self.failed.insert((unit.clone(), fire), t + RETRY_AFTER_S);
                    self.log(t, format!("unit {unit} gave up fire {fire}"));
                    out.extend(self.release(fire, t));
                    out.push(self.standby(&unit, t));
                }
                TaskPhase::Spraying => {
                    if let Some(f) = self.fusion.get_mut(fire)
                        && f.state == FireState::Assigned
                    {
                        f.state = FireState::Suppressing;
                        out.push(Output::Fire(self.track(fire, t)));
                    }
                }
                TaskPhase::Travelling => {}
            }
        }
        if relevant {
            out.extend(self.solve(t));
        }
        Ok(out)
    }

    /// A unit works on a task this coordinator did not give (it gave it before a restart):
    /// take the task over rather than send the unit elsewhere. Its fire is the track the
    /// task names if that was recalled and is still burning, else the track within
    /// [`ADOPT_RADIUS_M`] of where the unit believes it is, or a new track there.
    fn adopt(&mut self, unit: &UnitId, p: TaskProgress, t: f64) -> Vec<Output> {
        let named = self
            .fusion
            .get(p.fire)
            .filter(|f| f.active() && f.position().dist(p.target) <= ADOPT_RADIUS_M)
            .map(|f| f.id);
        let fire = match named.or_else(|| self.fusion.nearest_active(p.target, ADOPT_RADIUS_M)) {
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
        let task = Task {
            unit: unit.clone(),
            seq: p.seq,
            t,
            kind: TaskKind::Extinguish {
                fire,
                target: p.target,
            },
        };
        self.units.get_mut(unit).expect("known unit").task = Some(task);
        self.log(
            t,
            format!(
                "adopt {unit}'s task {} on fire {fire} at ({:.1}, {:.1}): given before this coordinator started",
                p.seq, p.target.x, p.target.y
            ),
        );
        vec![Output::Fire(self.track(fire, t))]
    }

    fn standby(&mut self, unit: &UnitId, t: f64) -> Output {
        self.give(unit, TaskKind::Standby, t)
    }

    /// Give `unit` a new task of `kind`, numbered above every task before it.
    fn give(&mut self, unit: &UnitId, kind: TaskKind, t: f64) -> Output {
        let seq = self.next_seq(t);
        let task = Task {
            unit: unit.clone(),
            seq,
            t,
            kind,
        };
        self.units.get_mut(unit).expect("known unit").task = Some(task.clone());
        Output::Task(task)
    }

    /// A unit's flame report.
    pub fn on_report(&mut self, r: &FlameReport, t: f64) -> Result<Vec<Output>, Invalid> {
        self.view(&r.unit, "unit")?.last_heard = t;
        for (i, o) in r.observations.iter().enumerate() {
            self.tunnel
                .check_inside(&format!("observations[{i}].position"), o.position)?;
        }
        let mut out = Vec::new();
        for o in &r.observations {
            match self.fusion.observe(&r.unit, o, t) {
                Fused::New(_) | Fused::Updated(_) => {}
                Fused::Confirmed(id) => {
                    self.log(
                        t,
                        format!(
                            "fire {id} confirmed at ({:.1}, {:.1})",
                            o.position.x, o.position.y
                        ),
                    );
                    out.push(Output::Fire(self.track(id, t)));
                }
                Fused::Reignited(id) => {
                    self.log(t, format!("fire {id} reignited"));
                    out.push(Output::Fire(self.track(id, t)));
                }
            }
        }
        for m in self.fusion.merge_duplicates() {
            self.log(
                t,
                format!(
                    "fire {} is fire {} seen again: merged",
                    m.removed.id, m.kept
                ),
            );
            let mut gone = m.removed.to_track(t, Vec::new());
            gone.state = FireState::Lost;
            out.push(Output::Fire(gone));
            out.push(Output::Fire(self.track(m.kept, t)));
        }
        out.extend(self.solve_within(Scope::NewFires, t));
        Ok(out)
    }

    /// Time passed: expire silent units and unseen fires, enforce goals, re-solve.
    pub fn tick(&mut self, t: f64) -> Vec<Output> {
        let silent: Vec<UnitId> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && t - v.last_heard > self.lease_s)
            .map(|(u, _)| u.clone())
            .collect();
        let mut out = Vec::new();
        for u in silent {
            out.extend(self.lose(&u, t, "silent beyond its lease"));
        }
        for id in self.fusion.expire(t) {
            self.log(
                t,
                format!("fire {id} lost: unseen for a minute and unattended"),
            );
            out.push(Output::Fire(self.track(id, t)));
        }
        self.failed.retain(|_, until| *until > t);
        for g in self.goals.expire(t) {
            self.log(t, format!("goal '{}' on zone {} expired", g.id, g.zone));
        }
        out.extend(self.enforce(t));
        // Units move and look between events: searches end, searchers change, and a unit
        // on its way may now have a nearer relief.
        let scope = if t - self.solved_all_at >= SOLVE_ALL_EVERY_S {
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
    fn solve(&mut self, t: f64) -> Vec<Output> {
        self.solve_within(Scope::All, t)
    }

    /// [`Incident::solve`], assigning within `scope`.
    fn solve_within(&mut self, scope: Scope, t: f64) -> Vec<Output> {
        if scope == Scope::All {
            self.solved_all_at = t;
        }
        let mut out = self.assign(scope, t);
        let (sent, searching) = self.search(t);
        out.extend(sent);
        out.extend(self.back_up(&searching, t));
        out.extend(self.stage(&searching, t));
        out.extend(self.patrol_rails(t));
        out
    }

    /// The chainages a unit's sensors take in where it stands: a ground unit's camera
    /// looks ahead along the road (and its heat sensors feel the few metres behind it), a
    /// carriage's detector looks both ways along its rail.
    fn sight(&self, mobility: Mobility, pose: Pose2) -> (f64, f64) {
        let s = self.tunnel.chainage(pose.position());
        match mobility {
            Mobility::Rail { .. } => (s - MONORAIL.detector_range_m, s + MONORAIL.detector_range_m),
            Mobility::Ground { .. } => {
                let range = GROUND.camera.range_m;
                if (pose.yaw - self.tunnel.heading_at(s)).cos() >= 0.0 {
                    (s - SIGHT_BEHIND_M, s + range)
                } else {
                    (s - range, s + SIGHT_BEHIND_M)
                }
            }
        }
    }

    /// Free ground units search the stretches nobody has looked at for
    /// [`SEARCH_AGAIN_AFTER_S`] (less barred zones): each end of each unseen stretch gets
    /// the nearest free unit on its side, nearest pairs first. Searched from both ends, a
    /// stretch is split at its middle; from one, the unit drives through to its far end.
    /// A unit already searching keeps its goal unless the new one is
    /// [`SEARCH_GOAL_SLACK_M`] away. Returns the tasks and the units searching.
    fn search(&mut self, t: f64) -> (Vec<Output>, BTreeSet<UnitId>) {
        // Not the portals' mouths: units come in through them, and the incident's command
        // post sees them from outside.
        let lo = PORTAL_M.min(self.tunnel.length_m / 2.0);
        let hi = self.tunnel.length_m - lo;
        let mut gaps: Vec<(f64, f64)> = self
            .coverage
            .gaps(t - SEARCH_AGAIN_AFTER_S)
            .into_iter()
            .map(|(a, b)| (a.max(lo), b.min(hi)))
            .filter(|(a, b)| b > a)
            .collect();
        let barred = self.goals.barred();
        for &(bs, be) in &barred {
            let (lo, hi) = (bs - EVACUATE_MARGIN_M, be + EVACUATE_MARGIN_M);
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
            let s = c.at.chainage_m;
            for (g, &(a, b)) in gaps.iter().enumerate() {
                let west = s < (a + b) / 2.0;
                // No way to a stretch through a barred zone.
                let end = if west { a } else { b };
                let (lo, hi) = (s.min(end), s.max(end));
                if barred.iter().any(|&(bs, be)| lo < be && hi > bs) {
                    continue;
                }
                let d = if west { a - s } else { s - b }.max(0.0);
                let bonus = if searching_now(&c.unit) {
                    SEARCH_GOAL_SLACK_M
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
                (true, _) => (a + b) / 2.0,
                (false, true) => b,
                (false, false) => a,
            };
            let Some(x) = self
                .goals
                .nearest_allowed(x.clamp(lo, hi), EVACUATE_MARGIN_M, lo, hi)
            else {
                continue;
            };
            let c = &free[k];
            let lane = self.lane_nearest(self.tunnel.station(c.at.position).d);
            let goal = self.tunnel.point_at(x, lane);
            searching.insert(c.unit.clone());
            let current = self.units[&c.unit].task.as_ref().map(|t| t.kind);
            if matches!(current, Some(TaskKind::Search { goal: now }) if now.dist(goal) < SEARCH_GOAL_SLACK_M)
            {
                continue;
            }
            out.push(self.give(&c.unit, TaskKind::Search { goal }, t));
            self.log(
                t,
                format!(
                    "send {} searching the unseen stretch {a:.0}-{b:.0} m, to ({:.1}, {:.1})",
                    c.unit, goal.x, goal.y
                ),
            );
        }
        (out, searching)
    }

    /// The centre of the lane nearest lateral offset `d`.
    fn lane_nearest(&self, d: f64) -> f64 {
        (0..self.tunnel.lanes)
            .map(|i| self.tunnel.lane_center_y(i))
            .min_by(|a, b| (a - d).abs().total_cmp(&(b - d).abs()))
            .unwrap_or(0.0)
    }

    /// Free monorail units search their rail from end to end and back: at 10 m/s, with a
    /// thermal camera that sees 40 m, a carriage finds in half a minute what a ground
    /// unit finds in three (the portals are where ground units come in, and they drive at
    /// 1.5 m/s). Alone, a monorail unit waits where it is (the ROBOGAT tree); a
    /// coordinator puts it to use. The run keeps out of barred zones: it turns at the
    /// first one either side.
    fn patrol_rails(&mut self, t: f64) -> Vec<Output> {
        let barred = self.goals.barred();
        let runs: Vec<(UnitId, Point2)> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && v.working_on().is_none())
            .filter_map(|(u, v)| {
                let Mobility::Rail {
                    start_m,
                    end_m,
                    y_m,
                    ..
                } = v.mobility
                else {
                    return None;
                };
                let x = v.state.as_ref()?.pose.x;
                let lo = barred
                    .iter()
                    .map(|&(_, e)| e + EVACUATE_MARGIN_M)
                    .filter(|&c| c <= x)
                    .fold(start_m, f64::max);
                let hi = barred
                    .iter()
                    .map(|&(s, _)| s - EVACUATE_MARGIN_M)
                    .filter(|&c| c >= x)
                    .fold(end_m, f64::min);
                if !(lo..=hi).contains(&x) || hi - lo < 2.0 * RAIL_RUN_DONE_M {
                    return None;
                }
                let searching = match v.task.as_ref().map(|t| t.kind) {
                    Some(TaskKind::Search { goal }) => {
                        (lo..=hi).contains(&goal.x) && (goal.x - x).abs() > RAIL_RUN_DONE_M
                    }
                    _ => false,
                };
                // The farther end: from one end, the other.
                let end = if x - lo > hi - x { lo } else { hi };
                (!searching).then(|| (u.clone(), Point2::new(end, y_m)))
            })
            .collect();
        let mut out = Vec::new();
        for (unit, goal) in runs {
            out.push(self.give(&unit, TaskKind::Search { goal }, t));
            self.log(
                t,
                format!("send {unit} searching along its rail to {:.0} m", goal.x),
            );
        }
        out
    }

    /// Free units (but the `searching`) wait [`STAGE_OFFSET_M`] short of the nearest
    /// active fire, on their own side and in their lane, at most [`RESERVES_PER_FIRE`] per
    /// fire; the others patrol on their own.
    fn stage(&mut self, searching: &BTreeSet<UnitId>, t: f64) -> Vec<Output> {
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
            .filter(|f| {
                !self
                    .goals
                    .at(f.position().x)
                    .is_some_and(|g| g.bars_attack())
            })
            .map(|f| (f.id, f.position()))
            .collect();
        // Fires left burning by a goal hold no reserves; free units search on past them.
        let left_burning = self.fusion.fires().iter().filter(burning).any(|f| {
            self.goals
                .at(f.position().x)
                .is_some_and(|g| g.bars_attack())
        });
        let free: Vec<(UnitId, Point2, Option<TaskKind>, Mobility)> = self
            .units
            .iter()
            .filter(|(u, v)| v.alive && v.working_on().is_none() && !searching.contains(*u))
            // Monorail units wait where they are: their carriages reach a fire in seconds.
            .filter(|(_, v)| matches!(v.mobility, Mobility::Ground { .. }))
            .filter_map(|(u, v)| {
                Some((
                    u.clone(),
                    v.state.as_ref()?.pose.position(),
                    v.task.as_ref().map(|t| t.kind),
                    v.mobility,
                ))
            })
            // Units leaving a barred zone keep their way out.
            .filter(|(_, at, ..)| {
                !self
                    .goals
                    .at(self.tunnel.chainage(*at))
                    .is_some_and(|g| g.bars_entry())
            })
            .collect();
        let mut out = Vec::new();
        // Each free unit's nearest active fire; each fire keeps its nearest
        // RESERVES_PER_FIRE within HELP_WITHIN_S (any distance to hold a contain line),
        // the others patrol (a thousand units must not converge on the first fire
        // reported).
        let holds_a_line = |f: Point2| {
            self.goals
                .at(self.tunnel.chainage(f))
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
                                .is_some_and(|s| s <= HELP_WITHIN_S)
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
                if *n < RESERVES_PER_FIRE {
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
                let side = if at.s <= f { -1.0 } else { 1.0 };
                // Under a contain goal, reserves hold the line the front must not pass.
                let s = match self.goals.at(f).map(|g| (g.goal.goal, g.goal.before_m)) {
                    Some((GoalKind::Contain, Some(line))) => line,
                    _ => f + side * STAGE_OFFSET_M,
                };
                let s = self
                    .goals
                    .nearest_allowed(s, EVACUATE_MARGIN_M, 5.0, self.tunnel.length_m - 5.0)
                    .unwrap_or(at.s)
                    .clamp(5.0, self.tunnel.length_m - 5.0);
                (fire, self.tunnel.point_at(s, self.lane_nearest(at.d)))
            });
            match (goal, current) {
                (Some((_, g)), Some(TaskKind::Cruise { goal })) if goal.dist(g) < 3.0 => {}
                (Some((fire, g)), _) => {
                    out.push(self.give(&unit, TaskKind::Cruise { goal: g }, t));
                    self.log(
                        t,
                        format!(
                            "stage {unit} at ({:.1}, {:.1}), in reserve for fire {fire}",
                            g.x, g.y
                        ),
                    );
                }
                (None, current) if left_burning => {
                    // Search the rest of the tunnel, away from where the unit came in.
                    let end = if at.s < self.tunnel.length_m / 2.0 {
                        self.tunnel.length_m - PORTAL_M
                    } else {
                        PORTAL_M
                    };
                    let Some(x) = self.goals.nearest_allowed(
                        end,
                        EVACUATE_MARGIN_M,
                        5.0,
                        self.tunnel.length_m - 5.0,
                    ) else {
                        continue;
                    };
                    let g = self.tunnel.point_at(x, at.d);
                    if matches!(current, Some(TaskKind::Search { goal }) if goal.dist(g) < 3.0) {
                        continue;
                    }
                    out.push(self.give(&unit, TaskKind::Search { goal: g }, t));
                    self.log(
                        t,
                        format!("send {unit} on to search past the fires left burning, to ({:.1}, {:.1})", g.x, g.y),
                    );
                }
                (None, Some(TaskKind::Cruise { .. } | TaskKind::Search { .. })) => {
                    self.log(t, format!("release {unit} to patrol: no active fire"));
                    out.push(self.standby(&unit, t));
                }
                (None, _) => {}
            }
        }
        out
    }

    /// Fire `f` as a need for a unit, with its zone's priority; `None` if a goal bars
    /// attacking it.
    fn need(&self, f: &Fire) -> Option<Need> {
        let at = Place::in_tunnel(&self.tunnel, f.position());
        let goal = self.goals.at(at.chainage_m);
        (!goal.is_some_and(|g| g.bars_attack())).then(|| Need {
            fire: f.id,
            at,
            priority: goal.map_or(0, |g| g.goal.priority),
        })
    }

    /// Assign units to the fires that need one: fires nobody has taken, and fires whose
    /// units are all still on their way, solved again so that a unit come free near a
    /// fire takes it over from one still far away ([`KEEP_S`] keeps changes to real
    /// gains). A unit that loses its fire so stays on as its backup if it is within
    /// [`HELP_WITHIN_S`] of it and the fire wants another attacker, and is released
    /// otherwise.
    fn assign(&mut self, scope: Scope, t: f64) -> Vec<Output> {
        let open = |s: FireState| match scope {
            Scope::All => matches!(s, FireState::Confirmed | FireState::Assigned),
            Scope::NewFires => s == FireState::Confirmed,
        };
        let needs: Vec<Need> = self
            .fusion
            .fires()
            .iter()
            .filter(|f| open(f.state))
            .filter_map(|f| self.need(f))
            .collect();
        // The first attackers on their way to those fires, before the solve.
        let on_their_way: Vec<(UnitId, FireId)> = self
            .units
            .iter()
            .filter(|(_, v)| v.alive && !v.backup)
            .filter_map(|(u, v)| Some((u.clone(), self.fusion.resolve(v.working_on()?))))
            .filter(|(_, f)| needs.iter().any(|n| n.fire == *f))
            .collect();
        let mut candidates = self.candidates();
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
            let v = &self.units[&unit];
            if taker.unit == unit || v.working_on().map(|f| self.fusion.resolve(f)) != Some(fire) {
                continue;
            }
            let from = v.state.as_ref().map(|s| s.pose.position());
            let to = self.fusion.get(fire).map(|f| f.position());
            let away = from
                .zip(to)
                .and_then(|(a, b)| v.mobility.travel_s(a, b))
                .unwrap_or(f64::INFINITY);
            let taken = format!(
                "{} gets there in {:.1} s, {unit} in about {away:.1} s",
                taker.unit, taker.cost_s
            );
            let wanted = self.units_per_fire.max(attackers_needed(
                self.fusion.get(fire).and_then(|f| f.hrr_kw()),
                GROUND.cannon_flow_l_s,
            ));
            if away <= HELP_WITHIN_S && self.assigned_to(fire).len() <= wanted {
                self.units.get_mut(&unit).expect("known unit").backup = true;
                self.log(
                    t,
                    format!("{unit} stays on fire {fire} as a backup: {taken}"),
                );
            } else {
                self.log(t, format!("release {unit} from fire {fire}: {taken}"));
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

    /// Ground units not working on a fire, less those in `busy`.
    fn free_ground_units(&self, busy: &BTreeSet<UnitId>) -> Vec<Candidate> {
        let mut candidates = self.candidates();
        candidates.retain(|c| {
            matches!(c.mobility, Mobility::Ground { .. })
                && self.units[&c.unit].working_on().is_none()
                && !busy.contains(&c.unit)
        });
        candidates
    }

    /// Units that may be sent to a fire: alive, able, with water, outside barred zones.
    fn candidates(&self) -> Vec<Candidate> {
        let barred = self.goals.barred();
        self.units
            .iter()
            .filter(|(_, v)| v.alive && v.available())
            .filter_map(|(u, v)| {
                let st = v.state.as_ref()?;
                (st.mode != UnitMode::Fault && st.water_l > 0.0).then(|| Candidate {
                    unit: u.clone(),
                    at: Place::in_tunnel(&self.tunnel, st.pose.position()),
                    mobility: v.mobility,
                    water_l: st.water_l,
                    // Backups are extra hands: only a fire's first attacker is kept on it.
                    heading_for: v
                        .working_on()
                        .filter(|_| !v.backup)
                        .map(|f| self.fusion.resolve(f)),
                })
            })
            .filter(|c| {
                !barred
                    .iter()
                    .any(|&(s, e)| (s..=e).contains(&c.at.chainage_m))
            })
            .collect()
    }

    /// Second wave: ground units still free (and not in `busy`) join fires that have
    /// fewer attackers than `units_per_fire` or than their heat release needs, nearest
    /// first, one more per fire and solve.
    fn back_up(&mut self, busy: &BTreeSet<UnitId>, t: f64) -> Vec<Output> {
        let backups: Vec<Need> = self
            .fusion
            .fires()
            .iter()
            .filter(|f| matches!(f.state, FireState::Assigned | FireState::Suppressing))
            .filter(|f| {
                let needed = attackers_needed(f.hrr_kw(), GROUND.cannon_flow_l_s);
                self.assigned_to(f.id).len() < self.units_per_fire.max(needed)
            })
            .filter_map(|f| self.need(f))
            .collect();
        let candidates = self.free_ground_units(busy);
        let mut out = Vec::new();
        for p in self.picks(&candidates, &backups) {
            if p.cost_s <= HELP_WITHIN_S {
                out.extend(self.dispatch(&p, t, true));
            }
        }
        out
    }

    /// `needs` paired with `candidates` by the strategy, on this site.
    fn picks(&mut self, candidates: &[Candidate], needs: &[Need]) -> Vec<Pick> {
        if candidates.is_empty() || needs.is_empty() {
            return Vec::new();
        }
        let barred = self.goals.barred();
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
        let mut roads = self.roads.take();
        if let Some(r) = &mut roads {
            r.track(&burning);
        }
        let site = Site {
            barred: &barred,
            hazards: &hazards,
            roads: roads.as_ref().map(|r| r as &dyn Roads),
        };
        let picks = self.strategy.solve(candidates, needs, &site);
        self.roads = roads;
        picks
    }

    /// Give `p.unit` the task of putting out `p.fire` (as its second attacker if `backup`),
    /// logging the decision.
    fn dispatch(&mut self, p: &Pick, t: f64, backup: bool) -> Vec<Output> {
        let verb = if backup { "send backup" } else { "assign" };
        if self.failed.contains_key(&(p.unit.clone(), p.fire)) {
            return Vec::new();
        }
        let view = self.units.get_mut(&p.unit).expect("candidate is known");
        if view.working_on().map(|f| self.fusion.resolve(f)) == Some(p.fire) {
            // Already on its way there: no new task. A backup chosen as the first
            // attacker becomes it.
            if view.backup && !backup {
                view.backup = false;
                self.log(t, format!("backup {} takes fire {} over", p.unit, p.fire));
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
        if let Some(old) = self.units[&p.unit].working_on() {
            let why = if self.units[&p.unit].backup {
                ", where it was a backup".to_owned()
            } else {
                format!(" for fire {}, where it does more", p.fire)
            };
            self.log(t, format!("{} leaves fire {old}{why}", p.unit));
        }
        let task = self.give(
            &p.unit,
            TaskKind::Extinguish {
                fire: p.fire,
                target,
            },
            t,
        );
        self.units
            .get_mut(&p.unit)
            .expect("candidate is known")
            .backup = backup;
        let runner_up = match &p.runner_up {
            Some((u, c)) => format!("runner-up {u} at {c:.1} s"),
            None => "no other free unit".to_owned(),
        };
        self.log(
            t,
            format!(
                "{verb} {} to fire {}: cost {:.1} s; {runner_up}",
                p.unit, p.fire, p.cost_s
            ),
        );
        vec![task, Output::Fire(self.track(p.fire, t))]
    }

    fn assigned_to(&self, fire: FireId) -> Vec<UnitId> {
        self.units
            .iter()
            .filter(|(_, v)| {
                v.alive && v.working_on().map(|f| self.fusion.resolve(f)) == Some(fire)
            })
            .map(|(u, _)| u.clone())
            .collect()
    }

    fn track(&self, fire: FireId, t: f64) -> FireTrack {
        self.fusion
            .get(fire)
            .expect("track exists")
            .to_track(t, self.assigned_to(fire))
    }

    /// Every current task, for periodic re-publication (late joiners, lost messages).
    pub fn tasks(&self) -> impl Iterator<Item = &Task> {
        self.units
            .values()
            .filter(|v| v.alive)
            .filter_map(|v| v.task.as_ref())
    }

    /// Every fire track.
    pub fn fire_tracks(&self, t: f64) -> Vec<FireTrack> {
        self.fusion
            .fires()
            .iter()
            .map(|f| f.to_track(t, self.assigned_to(f.id)))
            .collect()
    }

    pub fn decisions(&self) -> impl Iterator<Item = &Decision> {
        self.decisions.iter()
    }

    /// A snapshot of the incident, for `firefleet status` and any Zenoh client. The
    /// caller fills in `rejected`, which it counts.
    pub fn status(&self, t: f64) -> IncidentStatus {
        IncidentStatus {
            t,
            units: self
                .units
                .iter()
                .map(|(u, v)| UnitStatus {
                    unit: u.clone(),
                    alive: v.alive,
                    state: v.state.clone(),
                    task: v.task.clone(),
                })
                .collect(),
            fires: self.fire_tracks(t),
            decisions: self.decisions.iter().rev().take(20).cloned().collect(),
            goals: self.goals().cloned().collect(),
            rejected: Default::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::geometry::{Point2, Pose2};
    use firefleet_protocol::msg::FlameObservation;

    const TUNNEL: Tunnel = Tunnel {
        length_m: 200.0,
        width_m: 10.0,
        height_m: 6.0,
        lanes: 2,
        centerline: Vec::new(),
    };

    fn u(s: &str) -> UnitId {
        UnitId::new(s).unwrap()
    }

    fn state(unit: &str, x: f64, task: Option<TaskProgress>) -> UnitState {
        UnitState {
            unit: u(unit),
            kind: UnitKind::Ground,
            t: 0.0,
            pose: Pose2::new(x, -2.0, 0.0),
            speed: 0.0,
            mode: UnitMode::Idle,
            water_l: 1000.0,
            health: 1.0,
            heat_flux_kw_m2: 0.0,
            task,
            autonomous: false,
        }
    }

    fn report(unit: &str, x: f64) -> FlameReport {
        FlameReport {
            unit: u(unit),
            t: 0.0,
            observer: Pose2::new(x - 15.0, -2.0, 0.0),
            observations: vec![FlameObservation {
                position: Point2::new(x, 1.0),
                cov: [0.2, 0.0, 0.2],
                confidence: 0.9,
                hrr_kw: None,
            }],
        }
    }

    /// Extinguish tasks only.
    fn tasks(out: &[Output]) -> Vec<&Task> {
        all_tasks(out)
            .into_iter()
            .filter(|t| matches!(t.kind, TaskKind::Extinguish { .. }))
            .collect()
    }

    /// The kinds of the tasks in `out` for `unit`, in order.
    fn kinds_for(out: &[Output], unit: &str) -> Vec<TaskKind> {
        all_tasks(out)
            .iter()
            .filter(|t| t.unit.as_str() == unit)
            .map(|t| t.kind)
            .collect()
    }

    fn all_tasks(out: &[Output]) -> Vec<&Task> {
        out.iter()
            .filter_map(|o| {
                if let Output::Task(t) = o {
                    Some(t)
                } else {
                    None
                }
            })
            .collect()
    }

    /// Unit b, given the first fire task in `out`, reports that fire extinguished.
    fn b_puts_out_the_first_fire(i: &mut Incident, out: &[Output]) -> (FireId, Vec<Output>) {
        let task = tasks(out)[0].clone();
        let TaskKind::Extinguish { fire, .. } = task.kind else {
            panic!("not a fire task: {task:?}")
        };
        let done = TaskProgress {
            seq: task.seq,
            fire,
            phase: TaskPhase::Extinguished,
            target: Point2::new(60.0, 1.0),
        };
        (
            fire,
            i.on_state(state("b", 55.0, Some(done)), 20.0).unwrap(),
        )
    }

    /// Two ground units, one per fire (the backup wave has tests of its own).
    fn incident() -> Incident {
        let mut i = incident_with_backups();
        i.set_units_per_fire(1);
        i
    }

    /// Ground units a and b, neither heard from yet, in a tunnel searched at t = 0 (these
    /// tests are about fires; searching has tests of its own).
    fn unheard() -> Incident {
        let ground = Mobility::Ground { speed_m_s: 1.5 };
        let mut i = Incident::new(
            TUNNEL,
            [(u("a"), ground), (u("b"), ground)],
            5.0,
            Strategy::Optimal,
        );
        i.coverage.look(0.0, TUNNEL.length_m, 0.0);
        i
    }

    fn incident_with_backups() -> Incident {
        let mut i = unheard();
        for (n, x) in [("a", 10.0), ("b", 40.0)] {
            i.on_alive(&u(n), true, 0.0).unwrap();
            i.on_state(state(n, x, None), 0.0).unwrap();
        }
        i
    }

    #[test]
    fn a_fire_whose_heat_release_needs_two_cannons_gets_two_units() {
        for (hrr_kw, attackers) in [(Some(4_000.0), 1), (Some(20_000.0), 2), (None, 1)] {
            let mut i = incident();
            let mut r = report("a", 60.0);
            r.observations[0].hrr_kw = hrr_kw;
            let mut out = i.on_report(&r, 1.0).unwrap();
            out.extend(i.tick(1.2));
            assert_eq!(tasks(&out).len(), attackers, "{hrr_kw:?} kW");
            let fire = i.fusion.fires()[0].id;
            assert_eq!(i.track(fire, 1.2).hrr_kw, hrr_kw);
        }
    }

    #[test]
    fn a_confirmed_fire_goes_to_the_nearest_free_unit() {
        let mut i = incident();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        let t = tasks(&out);
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].unit.as_str(), "b");
        assert!(matches!(t[0].kind, TaskKind::Extinguish { .. }));
        assert!(
            i.decisions().any(
                |d| d.text.starts_with("assign b to fire f1") && d.text.contains("runner-up a")
            )
        );
    }

    #[test]
    fn a_lost_unit_s_fire_is_reassigned_at_once() {
        let mut i = incident();
        i.on_report(&report("a", 60.0), 1.0).unwrap();
        let out = i.on_alive(&u("b"), false, 2.0).unwrap();
        let t = tasks(&out);
        assert_eq!(t.len(), 1, "{out:?}");
        assert_eq!(t[0].unit.as_str(), "a");
    }

    #[test]
    fn a_silent_unit_is_lost_after_its_lease() {
        let mut i = incident();
        i.on_report(&report("a", 60.0), 1.0).unwrap();
        i.on_state(state("a", 10.0, None), 5.5).unwrap();
        assert!(tasks(&i.tick(4.0)).is_empty());
        let out = i.tick(6.0);
        assert_eq!(tasks(&out)[0].unit.as_str(), "a");
    }

    #[test]
    fn extinguished_fire_is_out_and_the_unit_stands_by() {
        let mut i = incident();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        let (fire, out) = b_puts_out_the_first_fire(&mut i, &out);
        assert!(
            out.iter()
                .any(|o| matches!(o, Output::Fire(f) if f.id == fire && f.state == FireState::Out))
        );
        assert_eq!(
            kinds_for(&out, "b"),
            [TaskKind::Standby],
            "b stands by, nothing left to stage for"
        );
    }

    #[test]
    fn free_units_are_staged_short_of_the_fire_and_released_when_it_is_out() {
        let mut i = incident();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        assert_eq!(
            kinds_for(&out, "a"),
            [TaskKind::Cruise {
                goal: Point2::new(35.0, -2.5)
            }],
            "25 m short, in a's lane"
        );
        assert!(
            all_tasks(&i.tick(2.0)).is_empty(),
            "no churn while nothing changes"
        );
        let (_, out) = b_puts_out_the_first_fire(&mut i, &out);
        assert_eq!(kinds_for(&out, "a"), [TaskKind::Standby]);
    }

    #[test]
    fn a_restarted_coordinator_adopts_running_tasks_and_numbers_new_ones_above_them() {
        let mut i = incident();
        // Unit a still works on task 70000 of the coordinator that died, on a fire at 60.
        let held = TaskProgress {
            seq: 70_000,
            fire: FireId(3),
            phase: TaskPhase::Travelling,
            target: Point2::new(60.0, 1.0),
        };
        let out = i.on_state(state("a", 10.0, Some(held)), 1.0).unwrap();
        assert!(
            all_tasks(&out).iter().all(|t| t.unit.as_str() != "a"),
            "a keeps its task: {out:?}"
        );
        assert!(
            i.decisions()
                .any(|d| d.text.starts_with("adopt a's task 70000"))
        );
        // The fire, reported again, is a's: nobody else is sent.
        let out = i.on_report(&report("b", 60.0), 2.0).unwrap();
        assert!(tasks(&out).is_empty(), "{out:?}");
        let fires = i.fire_tracks(2.0);
        assert_eq!(fires.len(), 1);
        assert_eq!(fires[0].assigned, [u("a")]);
        // A new fire gets a new task, numbered above the adopted one.
        let out = i.on_report(&report("b", 150.0), 3.0).unwrap();
        assert!(!all_tasks(&out).is_empty());
        assert!(all_tasks(&out).iter().all(|t| t.seq > 70_000), "{out:?}");
        // a finishes the adopted task: its fire is out.
        let done = TaskProgress {
            phase: TaskPhase::Extinguished,
            ..held
        };
        let out = i.on_state(state("a", 45.0, Some(done)), 4.0).unwrap();
        assert!(
            out.iter()
                .any(|o| matches!(o, Output::Fire(f) if f.state == FireState::Out)),
            "{out:?}"
        );
    }

    #[test]
    fn a_restarted_coordinator_recalls_recorded_fires_under_their_ids() {
        // The coordinator that died tracked two fires: f4, which a is working on, and f9,
        // which nobody works on or sees any more. A third track is corrupt.
        let track = |id: u32, x: f64, state: FireState, assigned: &[&str]| FireTrack {
            id: FireId(id),
            t: 40.0,
            position: Point2::new(x, 1.0),
            cov: [0.3, 0.0, 0.3],
            confidence: 0.95,
            state,
            assigned: assigned.iter().map(|s| u(s)).collect(),
            seen_by: vec![u("a"), u("b")],
            hrr_kw: Some(5000.0),
        };
        // Restored before any unit is heard from, as a starting coordinator does.
        let mut i = unheard();
        i.set_units_per_fire(1);
        let (_, refused) = i.restore(
            &[
                track(4, 60.0, FireState::Assigned, &["a"]),
                track(9, 150.0, FireState::Confirmed, &[]),
                track(12, 500.0, FireState::Confirmed, &[]),
            ],
            41.0,
        );
        assert_eq!(refused.len(), 1);
        assert!(refused[0].field.starts_with("fire f12"), "{:?}", refused[0]);
        let ids: Vec<FireId> = i.fire_tracks(41.0).iter().map(|f| f.id).collect();
        assert_eq!(ids, [FireId(4), FireId(9)]);
        assert_eq!(
            i.decisions()
                .filter(|d| d.text.starts_with("recall fire"))
                .count(),
            2
        );

        // a says it works on f4: adopted on that track. b is free and is sent to f9, the
        // fire only the recording remembered.
        let held = TaskProgress {
            seq: 40_100,
            fire: FireId(4),
            phase: TaskPhase::Spraying,
            target: Point2::new(60.3, 1.1),
        };
        i.on_alive(&u("a"), true, 42.0).unwrap();
        i.on_state(state("a", 55.0, Some(held)), 42.0).unwrap();
        i.on_alive(&u("b"), true, 42.0).unwrap();
        let out = i.on_state(state("b", 100.0, None), 42.0).unwrap();
        assert_eq!(
            kinds_for(&out, "b"),
            [TaskKind::Extinguish {
                fire: FireId(9),
                target: Point2::new(150.0, 1.0),
            }]
        );
        let tracks = i.fire_tracks(42.0);
        assert_eq!(tracks[0].assigned, [u("a")]);
        assert_eq!(tracks[0].state, FireState::Suppressing);
        assert_eq!(tracks[1].assigned, [u("b")]);
    }

    #[test]
    fn the_nearer_unit_behind_a_truck_across_the_road_is_not_sent() {
        // a is 15 m from the fire but a jack-knifed truck closes the tunnel between them;
        // b is 40 m away on the open side.
        let text = "name = \"t\"\ntime_limit_s = 100\n[tunnel]\nlength_m = 200.0\nwidth_m = 10.0\nheight_m = 6.0\nlanes = 2\n\
            [[obstacles]]\nname = \"truck\"\nx_m = 52.0\ny_m = 0.0\nlength_m = 3.0\nwidth_m = 10.0\nheight_m = 3.0\n\
            [[units]]\nid = \"a\"\nkind = \"ground\"\nx_m = 45.0\ny_m = -2.0\n\
            [[units]]\nid = \"b\"\nkind = \"ground\"\nx_m = 100.0\ny_m = -2.0\n";
        let scenario = Scenario::from_toml(text, "t.toml").unwrap();
        let mut i = Incident::from_scenario(&scenario, 5.0, Strategy::Optimal);
        i.set_units_per_fire(1);
        for (n, x) in [("a", 45.0), ("b", 100.0)] {
            i.on_alive(&u(n), true, 0.0).unwrap();
            i.on_state(state(n, x, None), 0.0).unwrap();
        }
        let out = i.on_report(&report("b", 60.0), 1.0).unwrap();
        let sent: Vec<&str> = tasks(&out).iter().map(|t| t.unit.as_str()).collect();
        assert_eq!(sent, ["b"], "{out:?}");
    }

    #[test]
    fn bad_input_is_refused_and_changes_nothing() {
        let mut i = incident();
        assert!(
            i.on_report(&report("zz", 60.0), 1.0)
                .unwrap_err()
                .reason
                .contains("unknown unit")
        );
        let e = i.on_report(&report("a", 260.0), 1.0).unwrap_err();
        assert_eq!(e.field, "observations[0].position");
        assert!(i.fire_tracks(1.0).is_empty());
        assert!(i.on_state(state("a", -30.0, None), 1.0).is_err());
    }

    /// A monorail unit "r" on a rail over the whole tunnel, at chainage `x`, and its
    /// state there.
    fn with_rail(x: f64) -> (Incident, UnitState) {
        let rail = Mobility::Rail {
            start_m: 0.0,
            end_m: 200.0,
            y_m: 0.0,
            speed_m_s: 10.0,
            reach_m: 12.0,
        };
        let mut i = Incident::new(TUNNEL, [(u("r"), rail)], 5.0, Strategy::Optimal);
        i.on_alive(&u("r"), true, 0.0).unwrap();
        let mut st = state("r", x, None);
        st.kind = UnitKind::Monorail;
        st.pose = Pose2::new(x, 0.0, 0.0);
        (i, st)
    }

    fn search_goal(out: &[Output]) -> Option<f64> {
        kinds_for(out, "r").into_iter().find_map(|k| match k {
            TaskKind::Search { goal } => Some(goal.x),
            _ => None,
        })
    }

    #[test]
    fn a_free_monorail_unit_searches_its_rail_end_to_end_and_back() {
        let (mut i, mut st) = with_rail(30.0);
        let out = i.on_state(st.clone(), 0.0).unwrap();
        assert_eq!(search_goal(&out), Some(200.0), "the farther end first");
        st.pose.x = 120.0;
        i.on_state(st.clone(), 10.0).unwrap();
        assert_eq!(search_goal(&i.tick(10.0)), None, "on its way: no new task");
        st.pose.x = 199.6;
        i.on_state(st.clone(), 20.0).unwrap();
        assert_eq!(search_goal(&i.tick(20.0)), Some(0.0), "there: back again");
        // A fire it reaches takes it off the search; once out, the search resumes.
        let mut r = report("r", 150.0);
        r.observer = Pose2::new(150.0, 0.0, 0.0);
        let out = i.on_report(&r, 21.0).unwrap();
        let fire = tasks(&out)[0].clone();
        assert_eq!(fire.unit.as_str(), "r");
        assert_eq!(search_goal(&out), None);
        let TaskKind::Extinguish { fire: id, .. } = fire.kind else {
            unreachable!()
        };
        st.pose.x = 150.0;
        st.task = Some(TaskProgress {
            seq: fire.seq,
            fire: id,
            phase: TaskPhase::Extinguished,
            target: Point2::new(150.0, 1.0),
        });
        let out = i.on_state(st, 40.0).unwrap();
        assert_eq!(search_goal(&out), Some(0.0));
    }

    #[test]
    fn a_monorail_search_turns_short_of_a_keep_out_zone() {
        let (mut i, st) = with_rail(30.0);
        i.goals = Goals::new(&[firefleet_protocol::scenario::Zone {
            id: ZoneId::new("z1").unwrap(),
            start_m: 100.0,
            end_m: 150.0,
        }]);
        let (ack, _) = submit(&mut i, goal("g1", "z1", GoalKind::KeepOut, 0, None), 0.0);
        assert!(ack.accepted, "{ack:?}");
        let out = i.on_state(st, 0.5).unwrap();
        assert_eq!(search_goal(&out), Some(100.0 - EVACUATE_MARGIN_M));
    }

    fn zoned() -> Incident {
        let mut i = incident();
        let z = |id: &str, a: f64, b: f64| firefleet_protocol::scenario::Zone {
            id: ZoneId::new(id).unwrap(),
            start_m: a,
            end_m: b,
        };
        i.goals = Goals::new(&[z("z1", 50.0, 100.0), z("z2", 100.0, 200.0)]);
        i
    }

    fn goal(
        id: &str,
        zone: &str,
        kind: GoalKind,
        priority: u8,
        before_m: Option<f64>,
    ) -> (ZoneId, ZoneGoal) {
        let zone = ZoneId::new(zone).unwrap();
        let g = ZoneGoal {
            id: id.into(),
            zone: zone.clone(),
            goal: kind,
            priority,
            before_m,
            expires_s: None,
            issued_by: "ic-1".into(),
        };
        (zone, g)
    }

    fn submit(i: &mut Incident, (zone, g): (ZoneId, ZoneGoal), t: f64) -> (GoalAck, Vec<Output>) {
        i.on_goal(&zone, g, t)
    }

    #[test]
    fn no_fire_in_a_keep_out_zone_is_attacked_and_no_unit_crosses_it() {
        let mut i = zoned();
        let (ack, _) = submit(&mut i, goal("g1", "z1", GoalKind::KeepOut, 0, None), 0.5);
        assert!(ack.accepted, "{ack:?}");
        assert!(tasks(&i.on_report(&report("a", 60.0), 1.0).unwrap()).is_empty());
        // Both units are on the near side: the fire beyond the zone gets nobody.
        assert!(tasks(&i.on_report(&report("a", 150.0), 2.0).unwrap()).is_empty());
        let out = i.clear_goals(&ZoneId::new("z1").unwrap(), 3.0);
        assert_eq!(tasks(&out).len(), 2, "cleared: both fires are attacked");
    }

    #[test]
    fn a_monitor_goal_withdraws_the_unit_and_leaves_the_fire_burning() {
        let mut i = zoned();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        assert_eq!(tasks(&out)[0].unit.as_str(), "b");
        let (ack, out) = submit(&mut i, goal("g1", "z1", GoalKind::Monitor, 0, None), 2.0);
        assert!(ack.accepted);
        let b = kinds_for(&out, "b");
        assert_eq!(b[0], TaskKind::Standby, "{out:?}");
        // Free again, b searches on past the fire left burning.
        assert!(
            b[1..].iter().all(|k| matches!(k, TaskKind::Search { .. })),
            "{out:?}"
        );
        assert!(tasks(&out).is_empty(), "nobody else is sent: {out:?}");
        assert!(
            i.decisions()
                .any(|d| d.text.starts_with("withdraw b from fire f1: goal 'g1'"))
        );
        assert!(tasks(&i.tick(3.0)).is_empty());
    }

    #[test]
    fn evacuate_sends_units_out_of_the_zone_now() {
        let mut i = zoned();
        i.on_state(state("b", 55.0, None), 0.5).unwrap();
        let (_, out) = submit(&mut i, goal("g1", "z1", GoalKind::Evacuate, 0, None), 1.0);
        let b = kinds_for(&out, "b");
        assert_eq!(
            b,
            [TaskKind::Cruise {
                goal: Point2::new(45.0, -2.0)
            }],
            "{out:?}"
        );
        // The order stands: no repeat on the next tick.
        assert!(all_tasks(&i.tick(2.0)).is_empty());
    }

    #[test]
    fn a_priority_zone_s_fire_is_served_first() {
        let mut i = zoned();
        i.on_alive(&u("b"), false, 0.5).unwrap();
        submit(&mut i, goal("g1", "z2", GoalKind::Extinguish, 2, None), 0.6);
        let mut r = report("a", 60.0);
        r.observations.push(FlameObservation {
            position: Point2::new(170.0, 1.0),
            cov: [0.2, 0.0, 0.2],
            confidence: 0.9,
            hrr_kw: None,
        });
        let out = i.on_report(&r, 1.0).unwrap();
        let t = tasks(&out);
        assert_eq!(t.len(), 1);
        assert!(
            matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 150.0),
            "{t:?}"
        );
    }

    #[test]
    fn under_contain_reserves_hold_the_line() {
        let mut i = zoned();
        submit(
            &mut i,
            goal("g1", "z2", GoalKind::Contain, 0, Some(110.0)),
            0.5,
        );
        let out = i.on_report(&report("a", 150.0), 1.0).unwrap();
        let a = kinds_for(&out, "a");
        assert_eq!(
            a,
            [TaskKind::Cruise {
                goal: Point2::new(110.0, -2.5)
            }],
            "{out:?}"
        );
    }

    #[test]
    fn a_rejected_goal_changes_nothing() {
        let mut i = zoned();
        let (ack, out) = submit(&mut i, goal("g1", "z9", GoalKind::KeepOut, 0, None), 0.5);
        assert!(!ack.accepted && ack.reason.contains("unknown zone 'z9'"));
        assert!(out.is_empty());
        assert_eq!(i.goals().count(), 0);
        assert!(
            i.decisions()
                .any(|d| d.text.contains("rejected: unknown zone 'z9'"))
        );
        assert_eq!(
            tasks(&i.on_report(&report("a", 60.0), 1.0).unwrap()).len(),
            1
        );
    }

    /// Ground units a and b in a tunnel nobody has looked at yet.
    fn unsearched() -> Incident {
        let mut i = unheard();
        i.coverage = Coverage::new(TUNNEL.length_m);
        i
    }

    fn facing(unit: &str, x: f64, yaw: f64) -> UnitState {
        UnitState {
            pose: Pose2::new(x, -2.0, yaw),
            ..state(unit, x, None)
        }
    }

    /// The goal of `unit`'s newest task, if it is a search.
    fn searching_to(i: &Incident, unit: &str) -> Option<Point2> {
        match i.units[&u(unit)].task.as_ref()?.kind {
            TaskKind::Search { goal } => Some(goal),
            _ => None,
        }
    }

    #[test]
    fn units_from_both_portals_search_the_unseen_middle_from_both_ends() {
        let mut i = unsearched();
        i.on_alive(&u("a"), true, 0.0).unwrap();
        i.on_alive(&u("b"), true, 0.0).unwrap();
        i.on_state(facing("a", 5.0, 0.0), 0.0).unwrap();
        i.on_state(facing("b", 195.0, std::f64::consts::PI), 0.0)
            .unwrap();
        // a sees 0-35 m, b 165-200 m: the unseen middle is 35-165, split at 100.
        assert_eq!(searching_to(&i, "a").map(|g| g.x), Some(100.0));
        assert_eq!(searching_to(&i, "b").map(|g| g.x), Some(100.0));
        assert!(i.decisions().any(|d| {
            d.text
                .starts_with("send b searching the unseen stretch 35-165 m")
        }));
        // As they look, the middle shrinks evenly: the goals stand, no new tasks.
        for k in 1..=8 {
            let (t, d) = (5.0 * f64::from(k), 7.5 * f64::from(k));
            i.on_state(facing("a", 5.0 + d, 0.0), t).unwrap();
            i.on_state(facing("b", 195.0 - d, std::f64::consts::PI), t)
                .unwrap();
            assert!(all_tasks(&i.solve(t)).is_empty(), "at {t} s");
        }
        // Once all is seen they are released to patrol.
        i.on_state(facing("a", 72.5, 0.0), 45.0).unwrap();
        i.on_state(facing("b", 127.5, std::f64::consts::PI), 45.0)
            .unwrap();
        let out = i.solve(45.0);
        assert_eq!(kinds_for(&out, "a"), vec![TaskKind::Standby]);
        assert_eq!(kinds_for(&out, "b"), vec![TaskKind::Standby]);
    }

    #[test]
    fn one_unit_searches_and_its_partner_takes_the_fire_it_finds() {
        let mut i = unsearched();
        for n in ["a", "b"] {
            i.on_alive(&u(n), true, 0.0).unwrap();
            i.on_state(facing(n, 5.0, 0.0), 0.0).unwrap();
        }
        let searcher = ["a", "b"]
            .into_iter()
            .find(|n| searching_to(&i, n).is_some())
            .expect("one of the pair searches");
        assert_eq!(searching_to(&i, searcher).map(|g| g.x), Some(190.0));
        let other = if searcher == "a" { "b" } else { "a" };
        assert_eq!(searching_to(&i, other), None, "one searcher per end");
        // The pair sees a fire at 60 m from 35 m: one attacks, the other searches on
        // beyond it rather than backing up a fire one unit can fight.
        i.on_state(facing("a", 35.0, 0.0), 20.0).unwrap();
        i.on_state(facing("b", 35.0, 0.0), 20.0).unwrap();
        let out = i.on_report(&report("a", 60.0), 20.0).unwrap();
        assert_eq!(tasks(&out).len(), 1, "{out:?}");
        let attacker = tasks(&out)[0].unit.as_str().to_owned();
        let other = if attacker == "a" { "b" } else { "a" };
        assert_eq!(searching_to(&i, other).map(|g| g.x), Some(190.0));
    }

    /// The zoned incident, unsearched, with `zone` kept out of from t = 0.
    fn unsearched_keeping_out_of(zone: &str) -> Incident {
        let mut i = zoned();
        i.coverage = Coverage::new(TUNNEL.length_m);
        submit(&mut i, goal("g1", zone, GoalKind::KeepOut, 0, None), 0.0);
        i
    }

    #[test]
    fn search_stops_short_of_a_keep_out_zone() {
        let mut i = unsearched_keeping_out_of("z2");
        i.on_state(facing("a", 10.0, 0.0), 1.0).unwrap();
        let g = searching_to(&i, "a").expect("a searches");
        assert_eq!(g.x, 100.0 - EVACUATE_MARGIN_M);
    }

    #[test]
    fn nobody_searches_a_stretch_beyond_a_keep_out_zone() {
        let mut i = unsearched_keeping_out_of("z1");
        i.on_state(facing("a", 10.0, 0.0), 1.0).unwrap();
        i.on_state(facing("b", 40.0, 0.0), 1.0).unwrap();
        i.solve(1.0);
        // Up to 70 m is seen (b looks 30 m ahead); 105-190 lies beyond the zone.
        assert_eq!(searching_to(&i, "a"), None);
        assert_eq!(searching_to(&i, "b"), None);
    }

    #[test]
    fn a_stretch_not_seen_for_two_minutes_is_searched_again() {
        let mut i = incident();
        assert_eq!(searching_to(&i, "a"), None);
        i.on_state(facing("a", 10.0, 0.0), SEARCH_AGAIN_AFTER_S - 1.0)
            .unwrap();
        assert!(all_tasks(&i.solve(SEARCH_AGAIN_AFTER_S - 1.0)).is_empty());
        i.on_state(facing("a", 10.0, 0.0), SEARCH_AGAIN_AFTER_S + 1.0)
            .unwrap();
        i.on_state(facing("b", 40.0, 0.0), SEARCH_AGAIN_AFTER_S + 1.0)
            .unwrap();
        i.solve(SEARCH_AGAIN_AFTER_S + 1.0);
        assert_eq!(searching_to(&i, "b").map(|g| g.x), Some(190.0));
    }

    #[test]
    fn no_backup_or_reserve_is_sent_from_more_than_a_minute_away() {
        let mut i = incident_with_backups();
        // b drives to 150 m: 90 m from a fire at 60 m is a minute at 1.5 m/s, and more.
        i.on_state(state("b", 155.0, None), 0.5).unwrap();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        assert_eq!(tasks(&out).len(), 1, "{out:?}");
        assert_eq!(tasks(&out)[0].unit.as_str(), "a");
        assert!(kinds_for(&out, "b").is_empty(), "{out:?}");
    }

    #[test]
    fn a_second_free_unit_backs_up_and_leaves_for_a_fire_nobody_attacks() {
        let mut i = incident_with_backups();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        let t = tasks(&out);
        assert_eq!(t.len(), 2, "{out:?}");
        assert_eq!((t[0].unit.as_str(), t[1].unit.as_str()), ("b", "a"));
        assert!(
            i.decisions()
                .any(|d| d.text.starts_with("send backup a to fire f1"))
        );
        // A new fire, nobody on it: the backup (still on its way) takes it.
        let out = i.on_report(&report("b", 150.0), 2.0).unwrap();
        let t = tasks(&out);
        assert_eq!(t.len(), 1, "{out:?}");
        assert_eq!(t[0].unit.as_str(), "a");
        assert!(matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 100.0));
        assert!(
            i.decisions()
                .any(|d| d.text == "a leaves fire f1, where it was a backup")
        );
    }

    /// Unit b at `x`, out of order.
    fn broken(x: f64) -> UnitState {
        UnitState {
            mode: UnitMode::Fault,
            ..state("b", x, None)
        }
    }

    #[test]
    fn a_unit_come_free_near_a_fire_takes_it_over_from_one_far_away() {
        let mut i = incident();
        i.on_state(broken(140.0), 0.5).unwrap();
        let out = i.on_report(&report("a", 150.0), 1.0).unwrap();
        assert_eq!(tasks(&out)[0].unit.as_str(), "a", "{out:?}");
        // b is repaired 10 m from the fire: a, 90 s away, is released.
        let out = i.on_state(state("b", 140.0, None), 2.0).unwrap();
        assert_eq!(tasks(&out).len(), 1, "{out:?}");
        assert_eq!(tasks(&out)[0].unit.as_str(), "b");
        assert_eq!(kinds_for(&out, "a"), vec![TaskKind::Standby]);
        assert!(i.decisions().any(|d| {
            d.text
                .starts_with("release a from fire f1: b gets there in")
        }));
        assert!(all_tasks(&i.solve(3.0)).is_empty(), "settled");
    }

    #[test]
    fn a_unit_on_its_way_keeps_its_fire_against_a_marginal_gain_and_stays_as_backup_otherwise() {
        let mut i = incident_with_backups();
        i.on_state(broken(100.0), 0.5).unwrap();
        i.on_state(state("a", 40.0, None), 0.5).unwrap();
        i.on_report(&report("a", 80.0), 1.0).unwrap();
        // b 10 s nearer (15 m against 40 m): not worth a change; b backs a up.
        i.on_state(state("b", 95.0, None), 2.0).unwrap();
        assert!(!i.units[&u("a")].backup);
        assert!(i.units[&u("b")].backup);
        // b next to the fire, 25 s sooner: b takes it over without a new task, and a
        // (27 s away) stays on as its backup.
        i.on_state(state("b", 82.0, None), 4.0).unwrap();
        let out = i.tick(4.0);
        assert!(all_tasks(&out).is_empty(), "{out:?}");
        assert!(i.units[&u("a")].backup && !i.units[&u("b")].backup);
        assert!(
            i.decisions()
                .any(|d| d.text == "backup b takes fire f1 over")
        );
        assert!(
            i.decisions()
                .any(|d| d.text.starts_with("a stays on fire f1 as a backup"))
        );
    }

    #[test]
    fn a_spraying_backup_stays_on_its_fire_and_the_unit_still_on_its_way_takes_a_new_one() {
        let mut i = incident_with_backups();
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        let backup = tasks(&out)[1].clone();
        let TaskKind::Extinguish { fire, target } = backup.kind else {
            panic!()
        };
        let spraying = TaskProgress {
            seq: backup.seq,
            fire,
            phase: TaskPhase::Spraying,
            target,
        };
        i.on_state(state("a", 50.0, Some(spraying)), 1.5).unwrap();
        let out = i.on_report(&report("b", 150.0), 2.0).unwrap();
        assert!(kinds_for(&out, "a").is_empty(), "{out:?}");
        let t = tasks(&out);
        assert_eq!(t.len(), 1, "{out:?}");
        assert_eq!(t[0].unit.as_str(), "b");
        assert!(matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 100.0));
    }

    #[test]
    fn past_a_fire_left_burning_free_units_search_on() {
        let mut i = zoned();
        submit(&mut i, goal("g1", "z1", GoalKind::Monitor, 0, None), 0.5);
        let out = i.on_report(&report("a", 60.0), 1.0).unwrap();
        let kinds: Vec<TaskKind> = all_tasks(&out).iter().map(|t| t.kind).collect();
        assert_eq!(kinds.len(), 2, "{out:?}");
        assert!(
            kinds
                .iter()
                .all(|k| matches!(k, TaskKind::Search { goal } if goal.x == 190.0)),
            "both units search on to the far end: {kinds:?}"
        );
        assert!(all_tasks(&i.tick(2.0)).is_empty(), "the order stands");
    }
}
