//! The coordinator's picture of the incident, and how it reacts to events.
//!
//! ```
//! use firefleet_coordinator::assign::Strategy;
//! use firefleet_coordinator::incident::{Decision, Incident, Output};
//! use firefleet_model::scenario::Scenario;
//! use firefleet_model::{Point2, Pose2, UnitId};
//! use firefleet_protocol::msg::{FlameObservation, FlameReport, TaskKind};
//! use firefleet_protocol::testing::ground_state;
//!
//! let site = Scenario::straight(200.0)
//!     .ground("ugv-1", 20.0, -2.0)
//!     .ground("ugv-2", 190.0, -2.0)
//!     .build();
//! let mut incident = Incident::from_scenario(&site, 5.0, Strategy::Optimal).unwrap();
//! let unit = |s: &str| UnitId::new(s).unwrap();
//! // Events in: the units appear and say where they are...
//! for (u, x) in [("ugv-1", 20.0), ("ugv-2", 190.0)] {
//!     incident.on_alive(&unit(u), true, 0.0).unwrap();
//!     incident.on_state(ground_state(u, x, -2.0), 0.0).unwrap();
//! }
//! // ...and ugv-1 sees a flame 30 m ahead of it.
//! let report = FlameReport {
//!     unit: unit("ugv-1"),
//!     t: 1.0,
//!     observer: Pose2::new(20.0, -2.0, 0.0),
//!     observations: vec![FlameObservation {
//!         position: Point2::new(50.0, 1.0),
//!         cov: [0.2, 0.0, 0.2],
//!         confidence: 0.9,
//!         hrr_kw: None,
//!     }],
//! };
//! // Decisions out: the nearest free unit is sent, and why is logged.
//! let out = incident.on_report(&report, 1.0).unwrap();
//! let first = out.iter().find_map(|o| match o {
//!     Output::Task(t) if matches!(t.kind, TaskKind::Extinguish { .. }) => Some(&t.unit),
//!     _ => None,
//! });
//! assert_eq!(first, Some(&unit("ugv-1")));
//! assert!(incident.decisions().any(|d| matches!(&d.decision, Decision::Assign { unit: u, .. } if *u == unit("ugv-1"))));
//! ```
//!
//! Every event (a unit's state, a flame report, a unit appearing or vanishing, time
//! passing) updates the picture and returns the messages to publish: new tasks and changed
//! fire tracks. Every decision is logged with its reason and kept in [`Incident::decisions`].
//!
//! Not here: the bus ([`crate::node`]), the cost model and solvers ([`crate::assign`]),
//! fusion ([`crate::fusion`]); the policy numbers are [`Policy`].

use std::collections::{BTreeMap, BTreeSet, HashMap, VecDeque};

use firefleet_model::profile::Profile;
use firefleet_model::scenario::{Scenario, Tunnel, UnitSpec};
use firefleet_model::validate::Invalid;
use firefleet_model::{FireId, Point2, UnitId};
use firefleet_protocol::msg::{
    Approach, FireState, FireTrack, IncidentStatus, Task, TaskKind, TaskPhase, UnitState,
    UnitStatus, epoch_after, task_seq_ceiling, task_seq_floor,
};

use crate::assign::{GroundBody, Mobility, Strategy};
use crate::coverage::Coverage;
use crate::fusion::Fusion;
use crate::goals::Goals;
use crate::invariants::churn::Churn;
use crate::roads::RoadMaps;
use firefleet_bus::suspension::Suspensions;

mod decision;
mod dispatch;
mod events;
pub mod freshness;
mod infra;
mod policy;
mod search;
mod staging;
mod trust;
mod zones;

pub use decision::{AttackSide, Decision, Logged, Loss};
pub use freshness::{AHEAD_S, BEHIND_S};
pub use infra::{MOVING_AIR_M_S, VENT_FRESH_S};
pub use policy::Policy;

/// How many decisions the incident remembers for status queries.
const DECISION_LOG: usize = 200;

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
/// A site file's unit the coordinator cannot plan for.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("unit {unit}: {reason}")]
pub struct UnitProfileError {
    pub unit: UnitId,
    pub reason: String,
}

/// How `u` of `scenario` moves, as its profile says (a carriage with the rail it names).
pub fn mobility_of(scenario: &Scenario, u: &UnitSpec) -> Result<Mobility, UnitProfileError> {
    let error = |reason: String| UnitProfileError {
        unit: u.id.clone(),
        reason,
    };
    Ok(
        match scenario.profile_of(u).map_err(|e| error(e.to_string()))? {
            Profile::Ground(g) => Mobility::Ground(GroundBody::of(&g)),
            Profile::Monorail(m) => {
                let name = u.rail.as_deref().unwrap_or_default();
                let r = scenario
                    .rail(name)
                    .ok_or_else(|| error(format!("no rail '{name}' for the carriage")))?;
                Mobility::Rail {
                    rail: std::sync::Arc::new(r.clone()),
                    speed_m_s: m.carriage_speed_m_s,
                    coupling_s: m.coupling_s,
                    reach: firefleet_model::dock::Reach::of(&m),
                    detector_range_m: m.detector_range_m,
                }
            }
        },
    )
}

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
    /// When its last state came: the view a state describes lasts until the next.
    state_at: f64,
    task: Option<Task>,
    /// The task makes the unit a fire's second attacker: a new fire with nobody on it may
    /// take the unit while it is still on its way.
    backup: bool,
    /// Why and when the unit was lost, while it is.
    lost: Option<(Loss, f64)>,
    /// The first task given that the unit's states have not echoed yet, and since when it
    /// waits: the clock of [`Policy::deaf_after_s`].
    unechoed: Option<((u64, u64), f64)>,
    /// This coordinator has given the unit a task: what the unit reports working on is
    /// then this coordinator's business, never a task to adopt.
    tasked: bool,
    /// The newest state and report taken from the unit: older ones are replays.
    newest_state: freshness::Newest,
    newest_report: freshness::Newest,
    /// The fire of its attack task, when it was first given that fire and where its state
    /// then put it: how soon it can have looked there ([`Incident::could_have_looked`]).
    sent_to: Option<(FireId, f64, firefleet_model::Point2)>,
}

impl UnitView {
    fn new(mobility: Mobility) -> Self {
        Self {
            mobility,
            state: None,
            alive: false,
            last_heard: 0.0,
            state_at: 0.0,
            task: None,
            backup: false,
            lost: None,
            unechoed: None,
            tasked: false,
            newest_state: freshness::Newest::default(),
            newest_report: freshness::Newest::default(),
            sent_to: None,
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

/// Whether a unit in state `st` can work a fire: not faulted, and with water.
fn able(st: &UnitState) -> bool {
    st.mode != firefleet_protocol::msg::UnitMode::Fault && st.water_l > 0.0
}

/// How long a unit may stay silent before it counts as lost, s of site time, unless the
/// operator says otherwise: states come ten times a second, so five seconds is fifty lost
/// in a row, and a fire waits no longer than that for its relief.
pub const LEASE_S: f64 = 5.0;

/// Fire ids a successor coordinator leaves room for, per second of site time.
pub const FIRE_IDS_PER_S: f64 = 10.0;

/// The first fire id a coordinator that took office after another may give at site time
/// `t`: ten per second of site time, so an id meets one its predecessor gave only if that
/// one numbered more than ten tracks a second for its whole term. On a real site the
/// clock is Unix time and the ids wrap around `u32`: they read as nine or ten digits there
/// once a coordinator was replaced, which is the price of never naming two fires alike.
pub fn fire_id_floor(t: f64) -> u32 {
    ((t.max(0.0) * FIRE_IDS_PER_S) as u64 % u64::from(u32::MAX)) as u32
}

/// The incident.
pub struct Incident {
    tunnel: Tunnel,
    units: BTreeMap<UnitId, UnitView>,
    fusion: Fusion,
    seq: u64,
    /// This coordinator's term ([`Incident::take_office`]); 0 until it takes office.
    epoch: u64,
    lease_s: f64,
    strategy: Strategy,
    /// (unit, fire) pairs that failed, and until when not to retry them; and the goals'
    /// revision they failed under: a unit that refused a fire for barred space, or gave up
    /// on a way a goal closed, may go again once the goals change (a keep-out lifted a
    /// minute early would otherwise still hold the fleet back).
    failed: BTreeMap<(UnitId, FireId), f64>,
    failed_under: u64,
    decisions: VecDeque<Logged>,
    /// Decisions not yet handed out for publication.
    unpublished: Vec<Logged>,
    goals: Goals,
    policy: Policy,
    /// Driving distances to fires; straight lines without (an incident built without a
    /// site file).
    roads: RoadMaps,
    /// Where units have looked.
    coverage: Coverage,
    /// When the whole assignment was last solved.
    solved_all_at: f64,
    /// Changes skipped for want of a unit's view ([`Incident::view_mut`]).
    inconsistencies: u64,
    /// Flame observations refused for starting a track past a unit's
    /// [`crate::fusion::MAX_LONE_TRACKS`].
    lone_refused: u64,
    /// Identities suspended in band ([`firefleet_bus::suspension`]).
    suspensions: Suspensions,
    /// Units a goal holds in a zone with nowhere to go, as of the last enforcement: the
    /// decision is logged once when a unit becomes trapped, not at every enforcement.
    trapped: BTreeMap<UnitId, firefleet_protocol::msg::Trapped>,
    /// The tunnel's DTS and ventilation, as the SCADA bridge reports them.
    infra: infra::Infra,
    /// The portals' names, at chainage 0 and at the end, for the decisions' words.
    portals: [String; 2],
    /// Fires the DTS alone placed that units sent there looked for and did not find: the
    /// side the last looked from (the next looks from the other: [`Incident::attack_side`])
    /// and how many looked ([`Policy::dts_unseen_looks`]).
    unseen: BTreeMap<FireId, (Approach, u32)>,
    /// Per fire, a bound on the spots its attackers were sent to ([`Aim`]): what lets a
    /// report that moves the fire's estimate skip asking who attacks it.
    aims: BTreeMap<FireId, Aim>,
    /// How often each fire's attackers changed, counted from the tasks given as the
    /// checker counts them from the tasks sent; and the fires held for it as of the last
    /// dispatch ([`crate::invariants::churn::HOLD_AT`]), so a hold is logged once. Not
    /// journaled: a coordinator that restarts (or takes office) counts from then.
    churn: Churn,
    held: BTreeSet<FireId>,
}

/// Every unit sent to a fire (by its id) was sent to a spot within `within_m` of `at`:
/// widened by each task given for the fire, made exact by each
/// [`Incident::aim_again`]. By the triangle inequality, no attacker's spot is farther
/// than `within_m` plus the estimate's distance from `at` from the estimate.
#[derive(Debug, Clone, Copy)]
pub(super) struct Aim {
    at: Point2,
    within_m: f64,
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
            epoch: 0,
            lease_s,
            strategy,
            failed: BTreeMap::new(),
            failed_under: 0,
            decisions: VecDeque::new(),
            unpublished: Vec::new(),
            goals: Goals::default(),
            policy: Policy::DEFAULT,
            roads: RoadMaps::default(),
            coverage: Coverage::new(tunnel.length_m),
            trapped: BTreeMap::new(),
            unseen: BTreeMap::new(),
            aims: BTreeMap::new(),
            churn: Churn::default(),
            held: BTreeSet::new(),
            solved_all_at: f64::NEG_INFINITY,
            inconsistencies: 0,
            lone_refused: 0,
            suspensions: Suspensions::default(),
            infra: infra::Infra::new(None, tunnel.length_m),
            portals: ["portal A".into(), "portal B".into()],
            tunnel,
        }
    }

    /// Send up to `n` ground units to each fire while units are free (default
    /// [`Policy::units_per_fire`]; at least 1), or more if its heat release needs them.
    pub fn set_units_per_fire(&mut self, n: usize) {
        self.policy.units_per_fire = n.max(1);
    }

    /// The incident of a site file: its tunnel, and its units each with its own profile
    /// (speed, body width, cannon flow, camera; a carriage's rail, speed, reach and
    /// detector), and the road map for each body width among its ground units. A unit
    /// whose profile is unknown or of the wrong kind, or a carriage without its rail, is
    /// an error: a fallback would send a heavy robot down roads only a light one fits.
    pub fn from_scenario(
        scenario: &Scenario,
        lease_s: f64,
        strategy: Strategy,
    ) -> Result<Self, UnitProfileError> {
        let units = scenario
            .units
            .iter()
            .map(|u| Ok((u.id.clone(), mobility_of(scenario, u)?)))
            .collect::<Result<Vec<_>, UnitProfileError>>()?;
        let widths = units.iter().filter_map(|(_, m)| match m {
            Mobility::Ground(g) => Some(g.width_m),
            Mobility::Rail { .. } => None,
        });
        let roads = RoadMaps::from_scenario(scenario, widths);
        let mut incident = Self::new(scenario.tunnel.clone(), units, lease_s, strategy);
        incident.goals = Goals::new(&scenario.zones, &scenario.commanders);
        incident.roads = roads;
        incident.infra = infra::Infra::new(scenario.scada.clone(), scenario.tunnel.length_m);
        incident.portals = scenario.portal_names();
        Ok(incident)
    }

    fn log(&mut self, t: f64, decision: Decision) {
        // Site time to the hundredth, as a reader takes it (not 55.89999999999896).
        tracing::info!(t = %format_args!("{t:.2}"), "{decision}");
        if self.decisions.len() == DECISION_LOG {
            self.decisions.pop_front();
        }
        let d = Logged { t, decision };
        self.unpublished.push(d.clone());
        self.decisions.push_back(d);
    }

    /// A task number higher than any before it, across coordinator restarts too: units
    /// ignore a task whose number is not higher than the last one they took, so a
    /// restarted coordinator counting from 0 would be ignored. Numbers are floored by site
    /// time ([`task_seq_floor`]) and by the highest number seen in any unit's state that
    /// is not ahead of the clock ([`Incident::heed_seq`]).
    fn next_seq(&mut self, t: f64) -> u64 {
        self.seq = self.seq.saturating_add(1).max(task_seq_floor(t));
        self.seq
    }

    /// Number tasks above `seq`, a number seen in a unit's state at site time `t`, unless
    /// it is ahead of the clock ([`task_seq_ceiling`]): a forged state numbered near
    /// `u64::MAX` must not push this coordinator's numbers where every unit refuses them.
    /// Whether it was heeded.
    fn heed_seq(&mut self, seq: u64, t: f64) -> bool {
        let ok = seq <= task_seq_ceiling(t);
        if ok {
            self.seq = self.seq.max(seq);
        }
        ok
    }

    /// Before the first decision: number every task above what `st` says its unit holds
    /// (unless the number is ahead of the clock, [`task_seq_ceiling`]).
    pub fn heed(&mut self, st: &UnitState, t: f64) {
        for seq in [st.task_seq, st.task.map(|p| p.seq), st.epoch]
            .into_iter()
            .flatten()
        {
            self.heed_seq(seq, t);
        }
    }

    /// Begin this coordinator's term as the coordinator of `rank` at site time `t`, after
    /// heeding the units ([`Incident::heed`]) and before the first decision: its epoch is
    /// above every task number and epoch heard and the clock's floor ([`epoch_after`]),
    /// and its tasks are numbered from it. The epoch.
    ///
    /// When a unit held a task, some coordinator ran before this one and numbered fires
    /// this one may not know (restarted with nothing recording, or the other side of a
    /// split): its own fires are then numbered from [`fire_id_floor`], so no id names two
    /// fires on the bus, in recordings or on a console.
    pub fn take_office(&mut self, rank: u32, t: f64) -> u64 {
        if self.seq > 0 {
            self.fusion.number_above(fire_id_floor(t));
        }
        self.epoch = epoch_after(self.seq.max(task_seq_floor(t)), rank);
        self.seq = self.epoch - 1;
        self.log(
            t,
            Decision::TookOffice {
                epoch: self.epoch,
                rank,
            },
        );
        self.epoch
    }

    /// The coordinator of rank `holder` holds office ([`firefleet_protocol::office`]):
    /// this one, of `rank`, stands down at `t`.
    pub fn stand_down(&mut self, rank: u32, holder: u32, t: f64) {
        self.log(t, Decision::SteppedDown { rank, holder });
    }

    /// At `t`, the coordinator of `rank` claimed office while this one held it (its lease
    /// appeared, or its tasks were heard), or, if `rank` is this one's own, someone sent
    /// tasks on this one's key.
    pub fn claimed(&mut self, rank: u32, own: bool, t: f64) {
        let d = if own {
            Decision::Impostor { rank }
        } else {
            Decision::Rival { rank }
        };
        self.log(t, d);
    }

    /// Decisions made since the last call, for the bus (and so the recording).
    pub fn take_decisions(&mut self) -> Vec<Logged> {
        std::mem::take(&mut self.unpublished)
    }

    fn view(&mut self, unit: &UnitId, field: &str) -> Result<&mut UnitView, Invalid> {
        self.units
            .get_mut(unit)
            .ok_or_else(|| Invalid::new(field, unknown_unit(unit.as_str())))
    }

    fn standby(&mut self, unit: &UnitId, t: f64) -> Output {
        self.give(unit, TaskKind::Standby, t)
    }

    /// Give `unit` a new task of `kind`, numbered above every task before it.
    fn give(&mut self, unit: &UnitId, kind: TaskKind, t: f64) -> Output {
        let seq = self.next_seq(t);
        let task = Task {
            unit: unit.clone(),
            epoch: self.epoch,
            seq,
            t,
            kind,
        };
        self.churn.task(&task, t);
        if let TaskKind::Extinguish { fire, target, .. } = kind {
            self.aims
                .entry(fire)
                .and_modify(|a| a.within_m = a.within_m.max(a.at.dist(target)))
                .or_insert(Aim {
                    at: target,
                    within_m: 0.0,
                });
        }
        if let Some(v) = self.view_mut(unit) {
            v.unechoed.get_or_insert((task.order(), t));
            v.task = Some(task.clone());
            v.tasked = true;
            v.sent_to = match (kind, v.sent_to, &v.state) {
                (TaskKind::Extinguish { fire, .. }, Some(sent), _) if sent.0 == fire => Some(sent),
                (TaskKind::Extinguish { fire, .. }, _, Some(s)) => {
                    Some((fire, t, s.pose.position()))
                }
                _ => None,
            };
        }
        Output::Task(task)
    }

    /// A unit's view, for a change: `None`, logged and counted, for a unit the site file
    /// does not declare. Every path here starts from a declared unit, so a miss is a bug
    /// in the incident, never the input; the coordinator keeps running past it.
    fn view_mut(&mut self, unit: &UnitId) -> Option<&mut UnitView> {
        if !self.units.contains_key(unit) {
            self.inconsistencies += 1;
            tracing::error!(%unit, "no view of this unit; the change is skipped");
            return None;
        }
        self.units.get_mut(unit)
    }

    /// How many changes were skipped for want of a unit's view ([`Incident::view_mut`]):
    /// zero unless the incident has a bug.
    pub fn inconsistencies(&self) -> u64 {
        self.inconsistencies
    }

    /// How many flame observations were refused for starting a track past a unit's
    /// [`crate::fusion::MAX_LONE_TRACKS`].
    pub fn lone_refused(&self) -> u64 {
        self.lone_refused
    }

    /// The fire `v`'s unit works on as the incident knows it now (a merged track's id
    /// leads to the one it joined), if the unit is alive: the one rule of who works a
    /// fire, for [`Incident::assigned_to`] and [`Incident::assignments`].
    fn works_on(&self, v: &UnitView) -> Option<FireId> {
        v.working_on()
            .filter(|_| v.alive)
            .map(|f| self.fusion.resolve(f))
    }

    fn assigned_to(&self, fire: FireId) -> Vec<UnitId> {
        self.units
            .iter()
            .filter(|(_, v)| self.works_on(v) == Some(fire))
            .map(|(u, _)| u.clone())
            .collect()
    }

    /// [`Incident::assigned_to`] of every fire at once, from one pass over the units: for
    /// what asks it of every fire (with a thousand units and hundreds of fires, asking fire
    /// by fire is hundreds of thousands of steps on the loop a report waits for).
    fn assignments(&self) -> HashMap<FireId, Vec<UnitId>> {
        let mut assigned: HashMap<FireId, Vec<UnitId>> = HashMap::new();
        for (u, v) in &self.units {
            if let Some(f) = self.works_on(v) {
                assigned.entry(f).or_default().push(u.clone());
            }
        }
        assigned
    }

    fn track(&self, fire: FireId, t: f64) -> FireTrack {
        self.fusion
            .get(fire)
            .expect("track exists")
            .to_track(t, self.assigned_to(fire))
    }

    /// Whether `unit` is on this incident's roster (its site file's units).
    pub fn knows(&self, unit: &str) -> bool {
        UnitId::new(unit).is_ok_and(|u| self.units.contains_key(&u))
    }

    /// Every current task, for periodic re-publication (late joiners, lost messages): a
    /// deaf unit's too, whose echo of it brings the unit back.
    pub fn tasks(&self) -> impl Iterator<Item = &Task> {
        self.units
            .values()
            .filter(|v| v.alive || matches!(v.lost, Some((Loss::Deaf, _))))
            .filter_map(|v| v.task.as_ref())
    }

    /// Every fire track.
    pub fn fire_tracks(&self, t: f64) -> Vec<FireTrack> {
        self.fire_tracks_picked(t, |_, _| true)
    }

    /// The tracks of the fires `pick` takes, given each fire's id and whether it is
    /// settled (out or lost: only an event changes it, and that event sends its track):
    /// the once-a-second re-send builds only its slice's. Who works each fire comes from
    /// [`Incident::assignments`]: asked fire by fire, the thousands of fires a long
    /// incident keeps and a thousand units were two million steps a slice.
    pub fn fire_tracks_picked(
        &self,
        t: f64,
        pick: impl Fn(FireId, bool) -> bool,
    ) -> Vec<FireTrack> {
        let mut assigned = self.assignments();
        self.fusion
            .fires()
            .iter()
            .filter(|f| pick(f.id, matches!(f.state, FireState::Out | FireState::Lost)))
            .map(|f| f.to_track(t, assigned.remove(&f.id).unwrap_or_default()))
            .collect()
    }

    /// How many tracks are not out: a count, with no track built.
    pub fn not_out(&self) -> usize {
        self.fusion
            .fires()
            .iter()
            .filter(|f| f.state != FireState::Out)
            .count()
    }

    pub fn decisions(&self) -> impl Iterator<Item = &Logged> {
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
                    lost: v.lost.map(|(why, _)| why.to_string()),
                    report_weight: self.fusion.witnesses().weight(u),
                    protocol: None,
                })
                .collect(),
            fires: self.fire_tracks(t),
            decisions: self
                .decisions
                .iter()
                .rev()
                .take(20)
                .map(Logged::to_msg)
                .collect(),
            goals: self.goals().cloned().collect(),
            stranded: self.stranded(),
            trapped: self.trapped(),
            rejected: Default::default(),
            suspended: self.suspensions.names(),
        }
    }
}

/// Why a unit the incident does not know is refused, and what to do: its states, its
/// reports, and its own question whether the coordinator knows it (the agent's readiness)
/// all say this.
pub fn unknown_unit(unit: &str) -> String {
    format!(
        "unknown unit '{unit}': not in this coordinator's site file (a robot added since: give the coordinator and its standby the new site file and restart them, deploy/README.md)"
    )
}

#[cfg(test)]
mod tests;
