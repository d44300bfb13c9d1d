//! Robot-to-robot and robot-to-coordinator traffic: unit states, flame reports, tasks,
//! fused fire tracks and the coordinator's decisions (postcard).
//!
//! Not here: the commander's JSON, the simulator's sensor and actuator messages.

use std::collections::BTreeMap;
use std::fmt;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::*;
use firefleet_model::UnitKind;
use firefleet_model::geometry::{Point2, Pose2};
use firefleet_model::heat::HeatSource;
use firefleet_model::ids::{FireId, UnitId};
use firefleet_model::validate::{Invalid, Validate, each, finite, in_range, max_len};

/// What a unit is doing, as it reports it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum UnitMode {
    /// Holding still with nothing to do.
    Idle,
    /// Patrolling the tunnel looking for fire.
    Cruising,
    /// Driving to a firing position.
    Navigating,
    /// Aiming and spraying.
    Extinguishing,
    /// Cannot act (no water, damaged, stuck).
    Fault,
}

firefleet_model::names!(UnitMode, "a unit mode" {
    Idle => "idle",
    Cruising => "cruising",
    Navigating => "navigating",
    Extinguishing => "extinguishing",
    Fault => "fault",
});

/// Where a unit is in carrying out its task.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum TaskPhase {
    Travelling,
    Spraying,
    /// The unit no longer sees the flame it was sent to.
    Extinguished,
    /// The unit gave up: no path, no firing solution, no water.
    Failed,
}

/// The task a unit is working on, echoed in its state so the coordinator can follow it,
/// and a restarted coordinator can adopt it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TaskProgress {
    pub seq: u64,
    pub fire: FireId,
    pub phase: TaskPhase,
    /// Where the unit believes the fire is.
    pub target: Point2,
}

/// `ff/<site>/unit/<id>/state`: a unit's self-report, a few times a second.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct UnitState {
    pub unit: UnitId,
    pub kind: UnitKind,
    pub t: f64,
    pub pose: Pose2,
    /// Forward speed, m/s (negative when reversing).
    pub speed: f64,
    pub mode: UnitMode,
    pub water_l: f64,
    /// 1 is intact, 0 destroyed.
    pub health: f64,
    /// Radiant heat flux at the unit, kW/m^2.
    pub heat_flux_kw_m2: f64,
    pub task: Option<TaskProgress>,
    /// True when the unit acts on its own because it has no coordinator.
    pub autonomous: bool,
    /// The number of the latest task the unit took, of any kind: a coordinator that sees
    /// one above its own for the unit knows somebody else tasked it, and one whose tasks a
    /// unit's states stop echoing for ten seconds counts the unit as deaf and gives its
    /// fire to another. Every platform must fill it in.
    pub task_seq: Option<u64>,
    /// The epoch of that task: the term of the coordinator the unit obeys. A coordinator
    /// of an older term sees it has been deposed; one taking office starts above it.
    pub epoch: Option<u64>,
    /// The unit's refusal of its latest task, because it would need barred space.
    pub refused: Option<Refusal>,
}

impl UnitState {
    /// A unit at `pose` at t = 0 with `water_l` in its tank, idle, intact, never tasked:
    /// a unit as it powers up (and a state to start a test or a load from).
    pub fn idle(unit: UnitId, kind: UnitKind, pose: Pose2, water_l: f64) -> Self {
        Self {
            unit,
            kind,
            t: 0.0,
            pose,
            speed: 0.0,
            mode: UnitMode::Idle,
            water_l,
            health: 1.0,
            heat_flux_kw_m2: 0.0,
            task: None,
            autonomous: false,
            refused: None,
            task_seq: None,
            epoch: None,
        }
    }
}

impl Validate for UnitState {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        self.pose.validate().map_err(|e| e.within("pose"))?;
        in_range("speed", self.speed, -20.0, 20.0)?;
        in_range("water_l", self.water_l, 0.0, 1e6)?;
        in_range("health", self.health, 0.0, 1.0)?;
        in_range("heat_flux_kw_m2", self.heat_flux_kw_m2, 0.0, 1e4)?;
        if let Some(p) = &self.task {
            p.target.validate().map_err(|e| e.within("task.target"))?;
        }
        match &self.refused {
            Some(r) => r.validate().map_err(|e| e.within("refused")),
            None => Ok(()),
        }
    }
}

/// One flame a unit has placed in the site frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FlameObservation {
    pub position: Point2,
    /// Position covariance, m^2: [xx, xy, yy].
    pub cov: [f64; 3],
    /// Detector confidence in [0, 1].
    pub confidence: f64,
    /// Heat release the unit estimates from the flame's size, kW; `None` from a sensor
    /// that cannot size a flame.
    pub hrr_kw: Option<f64>,
}

/// The largest heat release anyone reports, kW: a fully involved fuel tanker is about
/// 300 MW.
pub const MAX_HRR_KW: f64 = 500_000.0;

impl Validate for FlameObservation {
    fn validate(&self) -> Result<(), Invalid> {
        self.position.validate().map_err(|e| e.within("position"))?;
        let [xx, xy, yy] = self.cov;
        for (name, v) in [("cov[0]", xx), ("cov[1]", xy), ("cov[2]", yy)] {
            finite(name, v)?;
        }
        if xx <= 0.0 || yy <= 0.0 || xx * yy - xy * xy <= 0.0 {
            return Err(Invalid::new("cov", "not positive definite"));
        }
        in_range("confidence", self.confidence, 0.0, 1.0)?;
        match self.hrr_kw {
            Some(q) => in_range("hrr_kw", q, 0.0, MAX_HRR_KW),
            None => Ok(()),
        }
    }
}

/// `ff/<site>/unit/<id>/report`: flames a unit currently sees, in the site frame.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FlameReport {
    pub unit: UnitId,
    pub t: f64,
    /// Where the unit saw the flames from: its position, and the heading its camera looks
    /// along (the body's, turned by the cannon's pan if the camera rides on the cannon; a
    /// carriage's detector sees all round, and its heading says nothing).
    pub observer: Pose2,
    pub observations: Vec<FlameObservation>,
}

impl Validate for FlameReport {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        self.observer.validate().map_err(|e| e.within("observer"))?;
        max_len("observations", &self.observations, MAX_LIST)?;
        each("observations", &self.observations)
    }
}

/// What the coordinator asks of a unit.
// Externally tagged: postcard cannot decode internally tagged enums.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum TaskKind {
    /// Nothing assigned: the unit cruises or holds on its own.
    Standby,
    /// Drive to `goal` and hold there, looking for fire (staged as a reserve).
    Cruise { goal: Point2 },
    /// Drive to `goal` looking for new fires, past the fires the coordinator already knows
    /// (left burning by a commander's goal): do not stop for them.
    Search { goal: Point2 },
    /// Put out the fire believed to be at `target`, firing from the side `from`.
    Extinguish {
        fire: FireId,
        target: Point2,
        from: Approach,
    },
}

/// Which side of a fire, along the tunnel, a unit takes its firing position on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum Approach {
    /// Whichever side the unit reaches first: the air is still, or nobody knows.
    #[default]
    Either,
    /// The side towards chainage 0 (the first portal): upwind while the air flows towards
    /// the tunnel's end.
    Start,
    /// The side towards the tunnel's end.
    End,
}

impl Approach {
    /// The other side; `Either` stays itself.
    pub fn opposite(self) -> Self {
        match self {
            Approach::Start => Approach::End,
            Approach::End => Approach::Start,
            Approach::Either => Approach::Either,
        }
    }

    /// The upwind side in air moving at `air_m_s` along the tunnel (positive towards its
    /// end); `Either` in air slower than `still_m_s`.
    pub fn upwind(air_m_s: f64, still_m_s: f64) -> Self {
        if air_m_s >= still_m_s {
            Approach::Start
        } else if air_m_s <= -still_m_s {
            Approach::End
        } else {
            Approach::Either
        }
    }
}

/// Task numbers grow at least this fast with site time, per second: a restarted
/// coordinator numbering from its clock starts above every task it gave before.
pub const TASK_SEQ_PER_S: u64 = 1000;
/// A task numbered more than this many seconds' worth ahead of the receiver's site clock is
/// refused: units take only numbers above the last, so one forged task numbered near
/// `u64::MAX` would otherwise make a unit deaf to its coordinator for good. Two minutes
/// cover clock skew between hosts and a coordinator's burst of thousands of tasks.
pub const TASK_SEQ_LEAD_S: u64 = 120;

/// The lowest task number a coordinator may give at site time `t`.
pub fn task_seq_floor(t: f64) -> u64 {
    (t.max(0.0) * TASK_SEQ_PER_S as f64) as u64
}

/// The highest task number anyone takes at site time `t`.
pub fn task_seq_ceiling(t: f64) -> u64 {
    task_seq_floor(t).saturating_add(TASK_SEQ_LEAD_S * TASK_SEQ_PER_S)
}

/// How many coordinators can stand ready for one site: an epoch's remainder modulo this
/// is the rank of the coordinator that took office in it ([`epoch_after`]), so two never
/// share an epoch.
pub const EPOCH_RANKS: u64 = 16;

/// The epoch a coordinator of `rank` takes office in: the first number above `above`
/// whose remainder modulo [`EPOCH_RANKS`] is the rank.
///
/// An epoch is a task number, the first of the coordinator's term: one fencing mechanism
/// with the task numbers, not two. Taken above everything the coordinator heard (the site
/// clock's floor, every task number and epoch the units report), a new term outranks every
/// term before it; and a deposed coordinator that comes back keeps its old epoch however
/// high its task numbers climb, so a unit that has taken a task of the new term refuses
/// it (units order tasks by epoch, then number).
pub fn epoch_after(above: u64, rank: u32) -> u64 {
    let rank = u64::from(rank) % EPOCH_RANKS;
    let base = above.saturating_add(1);
    let up = (rank + EPOCH_RANKS - base % EPOCH_RANKS) % EPOCH_RANKS;
    base.saturating_add(up)
}

/// The rank of the coordinator that took office in `epoch` ([`epoch_after`]).
pub fn epoch_rank(epoch: u64) -> u32 {
    // Below EPOCH_RANKS (16), so it fits.
    (epoch % EPOCH_RANKS) as u32
}

/// `ff/<site>/unit/<id>/task`: a unit's current assignment. A unit takes a task only if
/// it outranks the last one it took: a newer epoch, or the same epoch and a higher
/// number (`seq` grows with every decision), so it ignores stale and repeated tasks and
/// every task of a deposed coordinator; see [`task_seq_ceiling`] for the ones it refuses.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Task {
    pub unit: UnitId,
    /// The term of the coordinator that gave it ([`epoch_after`]); never above `seq`.
    pub epoch: u64,
    pub seq: u64,
    pub t: f64,
    pub kind: TaskKind,
}

impl fmt::Display for TaskKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TaskKind::Standby => f.write_str("standby"),
            TaskKind::Cruise { goal } => write!(f, "cruise to ({:.1}, {:.1})", goal.x, goal.y),
            TaskKind::Search { goal } => write!(f, "search to ({:.1}, {:.1})", goal.x, goal.y),
            TaskKind::Extinguish { fire, target, from } => {
                write!(f, "extinguish {fire} at ({:.1}, {:.1})", target.x, target.y)?;
                match from {
                    Approach::Either => Ok(()),
                    Approach::Start => f.write_str(" from the start side"),
                    Approach::End => f.write_str(" from the end side"),
                }
            }
        }
    }
}

impl TaskKind {
    /// Where the task sends the unit: its goal, or the fire it attacks; `None` for
    /// standby. The one reading of a task that barred space is checked against, by the
    /// coordinator before it sends and by the recorded incident's checker after.
    pub fn destination(&self) -> Option<Point2> {
        match *self {
            TaskKind::Standby => None,
            TaskKind::Cruise { goal } | TaskKind::Search { goal } => Some(goal),
            TaskKind::Extinguish { target, .. } => Some(target),
        }
    }
}

impl Task {
    /// Where the task stands in a unit's order of tasks: epoch first, then number.
    pub fn order(&self) -> (u64, u64) {
        (self.epoch, self.seq)
    }

    /// The rank of the coordinator whose term the task is of ([`epoch_after`]): the key it
    /// goes on, `unit/<id>/task/<rank>`.
    pub fn rank(&self) -> u32 {
        epoch_rank(self.epoch)
    }
}

impl Validate for Task {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        if self.epoch > self.seq {
            return Err(Invalid::new(
                "epoch",
                format!("{} is above the task's number {}", self.epoch, self.seq),
            ));
        }
        match self.kind {
            TaskKind::Standby => Ok(()),
            TaskKind::Cruise { goal } | TaskKind::Search { goal } => {
                goal.validate().map_err(|e| e.within("kind.goal"))
            }
            TaskKind::Extinguish { target, .. } => {
                target.validate().map_err(|e| e.within("kind.target"))
            }
        }
    }
}

/// Lifecycle of a fused fire track.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum FireState {
    /// Seen, not yet confirmed.
    Tentative,
    Confirmed,
    Assigned,
    Suppressing,
    Out,
    /// Not seen for too long while nobody was working on it.
    Lost,
}

firefleet_model::names!(FireState, "a fire state" {
    Tentative => "tentative",
    Confirmed => "confirmed",
    Assigned => "assigned",
    Suppressing => "suppressing",
    Out => "out",
    Lost => "lost",
});

/// `ff/<site>/fire/<fire_id>`: a fused fire track.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FireTrack {
    pub id: FireId,
    pub t: f64,
    pub position: Point2,
    pub cov: [f64; 3],
    pub confidence: f64,
    pub state: FireState,
    pub assigned: Vec<UnitId>,
    /// Units whose reports made this track, for "seen by n units".
    pub seen_by: Vec<UnitId>,
    /// Estimated heat release, kW, when some unit could size the flame.
    pub hrr_kw: Option<f64>,
}

impl FireTrack {
    /// What the fleet knows of this fire as a heat source: a track not yet out whose flame
    /// some unit sized. A track nobody sized radiates nothing here rather than a guess.
    pub fn heat_source(&self) -> Option<HeatSource> {
        match (self.state, self.hrr_kw) {
            (FireState::Out, _) | (_, None) => None,
            (_, Some(hrr_kw)) => Some(HeatSource {
                at: self.position,
                hrr_kw,
            }),
        }
    }
}

impl Validate for FireTrack {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        self.position.validate().map_err(|e| e.within("position"))?;
        in_range("confidence", self.confidence, 0.0, 1.0)?;
        if let Some(q) = self.hrr_kw {
            in_range("hrr_kw", q, 0.0, MAX_HRR_KW)?;
        }
        max_len("assigned", &self.assigned, MAX_LIST)?;
        max_len("seen_by", &self.seen_by, MAX_LIST)
    }
}

/// The newest of each fire's tracks (by site time; the later one of a tie): what a
/// restarted coordinator recalls when recorders (or a recording) give it several.
pub fn latest_per_fire(tracks: impl IntoIterator<Item = FireTrack>) -> Vec<FireTrack> {
    let mut latest: BTreeMap<FireId, FireTrack> = BTreeMap::new();
    for f in tracks {
        if latest.get(&f.id).is_none_or(|old| old.t <= f.t) {
            latest.insert(f.id, f);
        }
    }
    latest.into_values().collect()
}

/// What a standby coordinator follows, each second while it stands by: the site time of
/// the newest goals in force it heard from the coordinator in office (none yet) and how
/// many fire tracks it keeps. A standby that stops following (cut off from the coordinator,
/// hung) would take office knowing neither; the console compares this with what the
/// coordinator publishes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct StandbyHealth {
    pub rank: u32,
    pub goals_t: Option<f64>,
    pub tracks: u32,
}

impl Validate for StandbyHealth {
    fn validate(&self) -> Result<(), Invalid> {
        if let Some(t) = self.goals_t {
            finite("goals_t", t)?;
        }
        Ok(())
    }
}

/// One logged decision of the coordinator, with its reason in the text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Decision {
    pub t: f64,
    pub text: String,
    /// The identity whose key someone else holds, when this decision is that finding (the
    /// coordinator heard tasks on its own key that it never sent): consoles raise their
    /// alarm from it, not from the text.
    #[serde(default)]
    pub impostor: Option<String>,
}

impl Validate for Decision {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        if self.text.len() > 1024 {
            return Err(Invalid::new("text", "longer than 1024 bytes"));
        }
        if let Some(who) = &self.impostor {
            crate::keys::identity_name(&who.replace(':', "-"))
                .map_err(|e| Invalid::new("impostor", e))?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// An epoch is above what it was taken above, at most one round of ranks above
        /// it, and names its rank: two ranks never share one.
        #[test]
        fn an_epoch_is_the_next_number_of_its_rank(above in 0u64..u64::MAX - 64, rank in 0u32..16) {
            let e = epoch_after(above, rank);
            prop_assert!(e > above && e <= above + EPOCH_RANKS);
            prop_assert_eq!(e % EPOCH_RANKS, u64::from(rank));
        }
    }

    #[test]
    fn a_task_ranks_by_epoch_before_number() {
        let task = |epoch, seq| Task {
            unit: UnitId::new("ugv-1").unwrap(),
            epoch,
            seq,
            t: 0.0,
            kind: TaskKind::Standby,
        };
        assert!(task(32, 33).order() > task(16, 90_000).order());
        assert!(task(16, 17).validate().is_ok());
        assert!(task(17, 16).validate().is_err());
    }
}
