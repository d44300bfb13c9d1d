//! Every message the fleet exchanges.
//!
//! Fleet messages (unit state, flame reports, tasks, fire tracks) and simulator messages
//! travel as postcard; commander-facing ones (zone goals and their acknowledgements, the
//! incident status) as JSON. [`Message::ENCODING`] says which, so a sender cannot pick the
//! wrong one.
//!
//! Times `t` are site time in seconds: simulator time in the simulator, system time on real
//! hardware (see [`crate::clock`]).

use std::collections::BTreeMap;
use std::fmt;

use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use crate::geometry::{Point2, Pose2};
use crate::ids::{FireId, UnitId, ZoneId};
use crate::validate::{Invalid, Validate, each, finite, in_range, max_len};

/// How a message type is put on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// One protocol-version byte, then postcard.
    Postcard,
    /// Plain UTF-8 JSON, for humans and any Zenoh client.
    Json,
}

/// A type that travels on the bus.
pub trait Message:
    Serialize + DeserializeOwned + Validate + JsonSchema + Send + Sync + 'static
{
    const ENCODING: Encoding;
    /// The schema name recordings and other tools know the type by.
    const NAME: &'static str;
}

macro_rules! message {
    ($enc:ident: $($t:ident),*) => { $(impl Message for $t {
        const ENCODING: Encoding = Encoding::$enc;
        const NAME: &'static str = concat!("firefleet.", stringify!($t));
    })* };
}
message!(Postcard: Decision, UnitState, FlameReport, Task, FireTrack, SimClock, UnitSensors, UnitCommand, RailSensors, RailCommand, SimTruth, BtTransitions);
message!(Json: ZoneGoal, GoalAck, IncidentStatus);

/// Longest list any fleet message may carry; bounds the work one message can cause.
pub const MAX_LIST: usize = 64;

/// Ground vehicle or ceiling-rail carriage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum UnitKind {
    Ground,
    Monorail,
}

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
        Ok(())
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
    /// Put out the fire believed to be at `target`.
    Extinguish { fire: FireId, target: Point2 },
}

/// `ff/<site>/unit/<id>/task`: a unit's current assignment. `seq` grows with every new
/// decision, so a unit can ignore a stale or repeated one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Task {
    pub unit: UnitId,
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
            TaskKind::Extinguish { fire, target } => {
                write!(f, "extinguish {fire} at ({:.1}, {:.1})", target.x, target.y)
            }
        }
    }
}

impl Validate for Task {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
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

/// Status of a behavior-tree node, for recordings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum NodeStatus {
    Idle,
    Running,
    Success,
    Failure,
    Skipped,
}

/// One status change of one node of a unit's behavior tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BtTransition {
    /// Node index in the tree (stable for one tree file).
    pub node: u32,
    /// `Type "name"` of the node.
    pub name: String,
    pub t: f64,
    pub from: NodeStatus,
    pub to: NodeStatus,
}

/// `ff/<site>/unit/<id>/bt`: the transitions of a unit's tree during one control step.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct BtTransitions {
    pub unit: UnitId,
    pub transitions: Vec<BtTransition>,
}

impl Validate for BtTransitions {
    fn validate(&self) -> Result<(), Invalid> {
        max_len("transitions", &self.transitions, 4096)?;
        self.transitions
            .iter()
            .enumerate()
            .try_for_each(|(i, t)| finite(&format!("transitions[{i}].t"), t.t))
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

/// One logged decision of the coordinator, with its reason in the text.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Decision {
    pub t: f64,
    pub text: String,
}

impl Validate for Decision {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        if self.text.len() > 1024 {
            Err(Invalid::new("text", "longer than 1024 bytes"))
        } else {
            Ok(())
        }
    }
}

/// What the coordinator knows of one unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct UnitStatus {
    pub unit: UnitId,
    pub alive: bool,
    pub state: Option<UnitState>,
    pub task: Option<Task>,
}

/// `ff/<site>/coord/status` (JSON, answered to queries): a snapshot of the incident.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct IncidentStatus {
    pub t: f64,
    pub units: Vec<UnitStatus>,
    pub fires: Vec<FireTrack>,
    /// Newest first.
    pub decisions: Vec<Decision>,
    /// Commanders' zone goals in force.
    #[serde(default)]
    pub goals: Vec<ZoneGoal>,
    /// Messages the coordinator dropped, by class (undecodable, version, invalid).
    pub rejected: BTreeMap<String, u64>,
}

impl Validate for IncidentStatus {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)
    }
}

/// A commander's instruction for a zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum GoalKind {
    Extinguish,
    /// Hold the fire front before `before_m` (chainage).
    Contain,
    Monitor,
    KeepOut,
    Evacuate,
}

/// `ff/<site>/zone/<zone>/goal` (JSON): an incident commander's zone goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ZoneGoal {
    /// Commander-chosen id, echoed in the acknowledgement.
    pub id: String,
    pub zone: ZoneId,
    pub goal: GoalKind,
    #[serde(default)]
    pub priority: u8,
    /// For `contain`: chainage the fire front must not pass, metres.
    #[serde(default)]
    pub before_m: Option<f64>,
    /// Seconds of site time after which the goal lapses.
    #[serde(default)]
    pub expires_s: Option<f64>,
    #[serde(default)]
    pub issued_by: String,
}

impl Validate for ZoneGoal {
    fn validate(&self) -> Result<(), Invalid> {
        if self.id.is_empty() || self.id.len() > 64 {
            return Err(Invalid::new("id", "must have 1 to 64 characters"));
        }
        if self.issued_by.len() > 64 {
            return Err(Invalid::new("issued_by", "longer than 64 characters"));
        }
        if let Some(b) = self.before_m {
            finite("before_m", b)?;
        }
        match (self.goal, self.before_m) {
            (GoalKind::Contain, None) => {
                return Err(Invalid::new("before_m", "required for a contain goal"));
            }
            (GoalKind::Contain, _) | (_, None) => {}
            (_, Some(_)) => {
                return Err(Invalid::new(
                    "before_m",
                    "only a contain goal takes before_m",
                ));
            }
        }
        if let Some(e) = self.expires_s {
            in_range("expires_s", e, 0.0, 1e9)?;
        }
        Ok(())
    }
}

/// `ff/<site>/zone/<zone>/ack` (JSON): the coordinator's answer to a zone goal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct GoalAck {
    pub id: String,
    pub zone: ZoneId,
    pub accepted: bool,
    pub reason: String,
}

impl Validate for GoalAck {
    fn validate(&self) -> Result<(), Invalid> {
        Ok(())
    }
}

/// `ff/<site>/sim/clock`: simulator time, the ROS `/clock` convention.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SimClock {
    pub t: f64,
    pub time_scale: f64,
}

impl Validate for SimClock {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("t", self.t, 0.0, 1e9)?;
        in_range("time_scale", self.time_scale, 0.0, 1e4)
    }
}

/// What a detector found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ObjectClass {
    Fire,
}

/// Side of the square depth window a detection carries, pixels.
pub const DEPTH_WINDOW: usize = 5;

/// A detection as a YOLO-style detector node publishes it, with the aligned depth image's
/// pixels around the box centre (what the localization node reads from the depth image).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct FlameDetection {
    pub class: ObjectClass,
    pub confidence: f64,
    /// Bounding box, pixels: `[u_min, v_min, u_max, v_max]`.
    pub bbox: [f64; 4],
    /// Depth, m, of the `DEPTH_WINDOW` x `DEPTH_WINDOW` pixels centred on the box centre,
    /// row by row; 0 where the depth camera has no value.
    pub depth: [f32; DEPTH_WINDOW * DEPTH_WINDOW],
}

impl Validate for FlameDetection {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("confidence", self.confidence, 0.0, 1.0)?;
        for (i, v) in self.bbox.iter().enumerate() {
            in_range(&format!("bbox[{i}]"), *v, -1e4, 1e4)?;
        }
        if self.bbox[0] > self.bbox[2] || self.bbox[1] > self.bbox[3] {
            return Err(Invalid::new("bbox", "min corner beyond max corner"));
        }
        for (i, z) in self.depth.iter().enumerate() {
            in_range(&format!("depth[{i}]"), f64::from(*z), 0.0, 1e3)?;
        }
        Ok(())
    }
}

/// State of a unit's water cannon.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct CannonState {
    /// Pan relative to the body, radians.
    pub pan: f64,
    /// Elevation above horizontal, radians.
    pub tilt: f64,
    pub valve_open: bool,
    /// Current flow, litres per second.
    pub flow_l_s: f64,
}

/// `ff/<site>/sim/unit/<id>/sensors`: what a unit's hardware drivers would publish.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct UnitSensors {
    pub unit: UnitId,
    pub t: f64,
    pub pose: Pose2,
    pub speed: f64,
    pub steer: f64,
    pub heat_flux_kw_m2: f64,
    pub water_l: f64,
    pub cannon: CannonState,
    pub detections: Vec<FlameDetection>,
    /// The body touched an obstacle or a wall in the last step.
    pub collided: bool,
}

impl Validate for UnitSensors {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        self.pose.validate().map_err(|e| e.within("pose"))?;
        finite("speed", self.speed)?;
        finite("steer", self.steer)?;
        in_range("heat_flux_kw_m2", self.heat_flux_kw_m2, 0.0, 1e4)?;
        in_range("water_l", self.water_l, 0.0, 1e6)?;
        finite("cannon.pan", self.cannon.pan)?;
        finite("cannon.tilt", self.cannon.tilt)?;
        max_len("detections", &self.detections, MAX_LIST)?;
        each("detections", &self.detections)
    }
}

/// `ff/<site>/sim/unit/<id>/cmd`: set-points for a unit's drivers. The platform applies
/// its own limits (acceleration, steering rate, slew rates); these are targets.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct UnitCommand {
    pub speed: f64,
    pub steer: f64,
    pub pan: f64,
    pub tilt: f64,
    pub valve_open: bool,
}

impl UnitCommand {
    /// Stand still with the valve shut, cannon where it is.
    pub fn halt(cannon: &CannonState) -> Self {
        Self {
            speed: 0.0,
            steer: 0.0,
            pan: cannon.pan,
            tilt: cannon.tilt,
            valve_open: false,
        }
    }
}

impl Validate for UnitCommand {
    fn validate(&self) -> Result<(), Invalid> {
        finite("speed", self.speed)?;
        finite("steer", self.steer)?;
        finite("pan", self.pan)?;
        finite("tilt", self.tilt)
    }
}

/// A monorail unit's joints: carriage position along its rail and the monitor's state, in
/// the ROBOGAT paper's terms (see `firefleet_agent::rail::kinematics` for the frame).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct RailJoints {
    /// Carriage position from the rail's start, m.
    pub d: f64,
    /// Monitor yaw, rad (positive turns the jet to the left of the rail's direction).
    pub theta1: f64,
    /// Monitor elevation, rad (0 level, negative down).
    pub theta2: f64,
    /// Nozzle exit speed, m/s.
    pub v0: f64,
}

impl RailJoints {
    fn check(&self, field: &str) -> Result<(), Invalid> {
        for (name, v) in [
            ("d", self.d),
            ("theta1", self.theta1),
            ("theta2", self.theta2),
            ("v0", self.v0),
        ] {
            finite(&format!("{field}.{name}"), v)?;
        }
        Ok(())
    }
}

/// A hot spot a monorail unit's thermal camera has placed on the road.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct HotSpot {
    pub position: Point2,
    /// One-sigma position error, m.
    pub sigma_m: f64,
}

/// `ff/<site>/sim/rail/<id>/sensors`: what a monorail unit's drivers publish: its joints,
/// the ROBOGAT paper's three sensors (fire detector, temperature, and a thermal camera that
/// gives the distance to the fire) and whether it is plugged into a hose point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RailSensors {
    pub unit: UnitId,
    pub t: f64,
    pub joints: RailJoints,
    /// Carriage speed along the rail, m/s.
    pub speed: f64,
    pub valve_open: bool,
    pub flow_l_s: f64,
    /// Within reach of a hose point: water is available.
    pub water_connected: bool,
    /// The fire detector's output (the paper's `pi`).
    pub fire_detected: bool,
    /// Gas temperature at the carriage, degrees C.
    pub temperature_c: f64,
    /// Radiant heat flux at the carriage, kW/m^2.
    pub heat_flux_kw_m2: f64,
    pub hot_spots: Vec<HotSpot>,
}

impl Validate for RailSensors {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        self.joints.check("joints")?;
        finite("speed", self.speed)?;
        in_range("flow_l_s", self.flow_l_s, 0.0, 1e3)?;
        in_range("temperature_c", self.temperature_c, -50.0, 2000.0)?;
        in_range("heat_flux_kw_m2", self.heat_flux_kw_m2, 0.0, 1e4)?;
        max_len("hot_spots", &self.hot_spots, MAX_LIST)?;
        for (i, h) in self.hot_spots.iter().enumerate() {
            h.position
                .validate()
                .map_err(|e| e.within(&format!("hot_spots[{i}].position")))?;
            in_range(&format!("hot_spots[{i}].sigma_m"), h.sigma_m, 1e-3, 100.0)?;
        }
        Ok(())
    }
}

/// `ff/<site>/sim/rail/<id>/cmd`: joint set-points for a monorail unit; the carriage and
/// the monitor move toward them at their own top rates and stop at their limits.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct RailCommand {
    pub joints: RailJoints,
    pub valve_open: bool,
}

impl Validate for RailCommand {
    fn validate(&self) -> Result<(), Invalid> {
        self.joints.check("joints")
    }
}

/// Whether a simulated fire still burns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum TruthFireState {
    /// Not ignited yet.
    Dormant,
    Burning,
    /// Flames knocked down, fuel bed still hot: re-ignites if left without water.
    Smouldering,
    Out,
}

/// Ground truth about one simulated fire.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TruthFire {
    pub name: String,
    pub position: Point2,
    pub hrr_kw: f64,
    pub state: TruthFireState,
    pub water_received_l: f64,
}

/// Ground truth about one simulated unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct TruthUnit {
    pub id: UnitId,
    pub pose: Pose2,
    /// Radiant heat dose taken so far, kJ/m^2.
    pub heat_dose_kj_m2: f64,
    pub water_used_l: f64,
    pub collisions: u32,
}

/// `ff/<site>/sim/truth`: the simulator's ground truth, for progress displays, tests and
/// recordings. Units never read it: they know only what their sensors say.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct SimTruth {
    pub t: f64,
    pub time_limit_s: f64,
    pub fires: Vec<TruthFire>,
    pub units: Vec<TruthUnit>,
}

impl SimTruth {
    pub fn fires_out(&self) -> usize {
        self.fires
            .iter()
            .filter(|f| f.state == TruthFireState::Out)
            .count()
    }
    pub fn all_out(&self) -> bool {
        self.fires.iter().all(|f| f.state == TruthFireState::Out)
    }
}

impl Validate for SimTruth {
    fn validate(&self) -> Result<(), Invalid> {
        finite("t", self.t)?;
        finite("time_limit_s", self.time_limit_s)?;
        max_len("fires", &self.fires, 4096)?;
        max_len("units", &self.units, 4096)
    }
}
