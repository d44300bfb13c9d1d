//! A monorail carriage as ROS 2 topics: what the carriage publishes, what the agent sends.
//!
//! Topics, relative to the carriage's namespace (`/mono_1/joint_states` and so on):
//!
//! | topic | type | direction | content |
//! |---|---|---|---|
//! | `joint_states` | sensor_msgs/JointState | robot -> agent | `carriage_joint` (prismatic: `d`, m from the rail's start), `monitor_yaw_joint` (`theta1`), `monitor_pitch_joint` (`theta2`), rad; velocities beside them |
//! | `nozzle/speed` | std_msgs/Float64 | robot -> agent | nozzle exit speed `v0`, m/s |
//! | `monitor/flow` | std_msgs/Float64 | robot -> agent | water through the monitor, L/s (its flow meter) |
//! | `water_connected` | std_msgs/Bool | robot -> agent | plugged into a hose point: water is available |
//! | `fire_detected` | std_msgs/Bool | robot -> agent | the fire detector's output (the ROBOGAT paper's `pi`) |
//! | `temperature` | sensor_msgs/Temperature | robot -> agent | gas temperature at the carriage, degrees C |
//! | `heat_flux` | std_msgs/Float64 | robot -> agent | radiant heat flux at the carriage, kW/m^2 |
//! | `hot_spots` | vision_msgs/Detection3DArray | robot -> agent | the thermal camera's fires on the road, in the site frame `map`, class `fire`; the pose's covariance is the position error |
//! | `monitor_controller/joint_trajectory` | trajectory_msgs/JointTrajectory | agent -> robot | one point: positions for `carriage_joint`, `monitor_yaw_joint`, `monitor_pitch_joint` |
//! | `nozzle/speed_command` | std_msgs/Float64 | agent -> robot | `v0` set-point, m/s |
//! | `monitor/valve` | std_msgs/Bool | agent -> robot | open the monitor's valve |
//!
//! Choices, and why:
//! - The set-points go to a ros2_control `joint_trajectory_controller`, not a forward
//!   command controller: the carriage and the monitor are position-controlled joints of
//!   very different speeds (metres along the rail, a fraction of a radian a second at the
//!   monitor), and a trajectory names its joints, so no order of an array can be got
//!   wrong. Each set-point is a single point whose `time_from_start` is the time the
//!   slowest joint needs at its profile's top rate ([`time_to_reach`]): the controller then
//!   moves no faster than the carriage the papers model, which moves each joint toward its
//!   set-point at its top rate. A newer trajectory replaces the old, as the controller does.
//! - `v0` is not a joint: the nozzle's exit speed is a pump or nozzle set-point, on a topic
//!   of its own.
//! - The carriage reports no valve state: water at the monitor is what its flow meter reads
//!   (`monitor/flow` above zero), which a valve opened away from a hose point does not give.
//! - Hot spots are placed by the carriage's thermal camera on the road (the ROBOGAT
//!   paper's camera gives the distance to the fire; the carriage knows where it is on its
//!   rail), so they are in the site frame, `z` 0 and a round one-sigma error `sigma` whose
//!   square is the covariance's x and y. A covariance of zeros (ROS's "unknown") is read
//!   as the profile's camera error at the edge of its range, so a carriage that gives no
//!   error still has its hot spots used, with the least weight they could deserve.
//!
//! Not here: the agent's `Platform` (`firefleet_agent::platform`) or the simulator's loop.

use firefleet_model::spec::MonorailSpec;
use firefleet_model::validate::Validate;
use firefleet_model::{Point2, UnitId};
use firefleet_protocol::msg::{HotSpot, RailCommand, RailJoints, RailSensors};

use crate::assemble::{self, Assemble, Latest, Parts};
use crate::ground::{FIRE_CLASS, frame};
use crate::msg::*;
use crate::node::{Node, NodeError, Publisher, Subscription};

pub const JOINT_STATES: &str = "joint_states";
pub const NOZZLE_SPEED: &str = "nozzle/speed";
pub const FLOW: &str = "monitor/flow";
pub const WATER_CONNECTED: &str = "water_connected";
pub const FIRE_DETECTED: &str = "fire_detected";
pub const TEMPERATURE: &str = "temperature";
pub const HEAT_FLUX: &str = "heat_flux";
pub const HOT_SPOTS: &str = "hot_spots";
pub const TRAJECTORY: &str = "monitor_controller/joint_trajectory";
pub const NOZZLE_COMMAND: &str = "nozzle/speed_command";
pub const VALVE: &str = "monitor/valve";

pub const CARRIAGE_JOINT: &str = "carriage_joint";
pub const YAW_JOINT: &str = "monitor_yaw_joint";
pub const PITCH_JOINT: &str = "monitor_pitch_joint";

/// Shortest `time_from_start` a set-point is given, s: a point already reached is still a
/// move of one control period (the agent's 20 Hz), not an instant the controller would
/// have to meet at infinite speed.
pub const MIN_MOVE_S: f64 = 0.05;

/// Why a trajectory could not be followed; the carriage keeps its last set-points.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TrajectoryError {
    #[error("no points")]
    NoPoints,
    #[error("{names} joint names but {positions} positions in the last point")]
    Lengths { names: usize, positions: usize },
    #[error(
        "joint '{0}' is not one of the carriage's ({CARRIAGE_JOINT}, {YAW_JOINT}, {PITCH_JOINT})"
    )]
    UnknownJoint(String),
    #[error("joint '{0}': position is not a finite number")]
    NotFinite(String),
}

/// The set-points `t` leaves `joints` at: its last point's position for every joint it
/// names (a trajectory may name some joints only, as `joint_trajectory_controller` allows
/// with `allow_partial_joints_goal`), the rest as they were.
pub fn setpoints(
    t: &JointTrajectory,
    mut joints: RailJoints,
) -> Result<RailJoints, TrajectoryError> {
    let last = t.points.last().ok_or(TrajectoryError::NoPoints)?;
    if last.positions.len() != t.joint_names.len() {
        return Err(TrajectoryError::Lengths {
            names: t.joint_names.len(),
            positions: last.positions.len(),
        });
    }
    for (name, &p) in t.joint_names.iter().zip(&last.positions) {
        let slot = match name.as_str() {
            CARRIAGE_JOINT => &mut joints.d,
            YAW_JOINT => &mut joints.theta1,
            PITCH_JOINT => &mut joints.theta2,
            _ => return Err(TrajectoryError::UnknownJoint(name.clone())),
        };
        if !p.is_finite() {
            return Err(TrajectoryError::NotFinite(name.clone()));
        }
        *slot = p;
    }
    Ok(joints)
}

/// Time for every joint to go from `from` to `to` at `spec`'s top rates, at least
/// [`MIN_MOVE_S`].
pub fn time_to_reach(spec: &MonorailSpec, from: &RailJoints, to: &RailJoints) -> f64 {
    [
        (to.d - from.d).abs() / spec.carriage_speed_m_s,
        (to.theta1 - from.theta1).abs() / spec.monitor_rate_rad_s,
        (to.theta2 - from.theta2).abs() / spec.monitor_rate_rad_s,
    ]
    .into_iter()
    .fold(MIN_MOVE_S, f64::max)
}

/// A hot spot as the carriage publishes it: a fire on the road of the site frame.
pub fn hot_spot_to_ros(h: &HotSpot, header: &Header) -> Detection3D {
    let center = Pose {
        position: Point {
            x: h.position.x,
            y: h.position.y,
            z: 0.0,
        },
        orientation: Quaternion::default(),
    };
    let var = h.sigma_m * h.sigma_m;
    Detection3D {
        header: header.clone(),
        results: vec![ObjectHypothesisWithPose {
            hypothesis: ObjectHypothesis {
                class_id: FIRE_CLASS.to_owned(),
                score: 1.0,
            },
            pose: PoseWithCovariance {
                pose: center,
                covariance: Covariance::diagonal([var, var, 0.0, 0.0, 0.0, 0.0]),
            },
        }],
        bbox: BoundingBox3D {
            center,
            size: Vector3::default(),
        },
        id: String::new(),
    }
}

/// Largest and smallest one-sigma error a hot spot may carry, m (the frame's validation
/// refuses others): a variance a carriage rounds to zero still means some error, and one of
/// kilometres means none worth the name.
const SIGMA_RANGE_M: (f64, f64) = (1e-3, 100.0);

/// A hot spot back from a detection: a fire's position and the larger of its x and y
/// errors, clamped to [`SIGMA_RANGE_M`]. `unknown_sigma_m` where the covariance says
/// nothing (all zeros is ROS's "unknown"). `None` for anything but a fire, or a position
/// that is not a number.
pub fn hot_spot_from_ros(d: &Detection3D, unknown_sigma_m: f64) -> Option<HotSpot> {
    let r = d
        .results
        .iter()
        .find(|r| r.hypothesis.class_id == FIRE_CLASS)?;
    let p = r.pose.pose.position;
    if !(p.x.is_finite() && p.y.is_finite()) {
        return None;
    }
    let c = &r.pose.covariance;
    let var = c.variance(0).max(c.variance(1));
    let sigma_m = if var.is_finite() && var > 0.0 {
        var.sqrt().clamp(SIGMA_RANGE_M.0, SIGMA_RANGE_M.1)
    } else {
        unknown_sigma_m
    };
    Some(HotSpot {
        position: Point2::new(p.x, p.y),
        sigma_m,
    })
}

/// The carriage's side: publishes its sensor frames on its topics, keeps the newest
/// set-point of each command topic. The simulator runs one per monorail unit.
pub struct Body {
    unit: UnitId,
    ns: String,
    joints: Publisher<JointState>,
    nozzle_speed: Publisher<Float64>,
    flow: Publisher<Float64>,
    water: Publisher<Bool>,
    fire: Publisher<Bool>,
    temperature: Publisher<Temperature>,
    heat: Publisher<Float64>,
    hot_spots: Publisher<Detection3DArray>,
    /// The previous frame's time and joints, for the joints' velocities.
    last: Option<(f64, RailJoints)>,
    commands: Latest<Received>,
    _subscriptions: [Subscription; 3],
}

/// Set-points received since the body last took them.
#[derive(Debug, Default)]
struct Received {
    trajectory: Option<JointTrajectory>,
    v0: Option<f64>,
    valve: Option<bool>,
}

impl Body {
    pub async fn new(node: &Node, unit: UnitId) -> Result<Self, NodeError> {
        let commands = Latest::new();
        let subscriptions = [
            node.subscribe(
                TRAJECTORY,
                commands.to(|r: &mut Received, m: JointTrajectory| r.trajectory = Some(m)),
            )
            .await?,
            node.subscribe(
                NOZZLE_COMMAND,
                commands.to(|r: &mut Received, m: Float64| r.v0 = Some(m.data)),
            )
            .await?,
            node.subscribe(
                VALVE,
                commands.to(|r: &mut Received, m: Bool| r.valve = Some(m.data)),
            )
            .await?,
        ];
        Ok(Self {
            unit,
            ns: node.namespace().to_string(),
            joints: node.publisher(JOINT_STATES).await?,
            nozzle_speed: node.publisher(NOZZLE_SPEED).await?,
            flow: node.publisher(FLOW).await?,
            water: node.publisher(WATER_CONNECTED).await?,
            fire: node.publisher(FIRE_DETECTED).await?,
            temperature: node.publisher(TEMPERATURE).await?,
            heat: node.publisher(HEAT_FLUX).await?,
            hot_spots: node.publisher(HOT_SPOTS).await?,
            last: None,
            commands,
            _subscriptions: subscriptions,
        })
    }

    /// Publish frame `s`. The joint states go last: the agent takes a frame when they
    /// arrive.
    pub fn publish(&mut self, s: &RailSensors) -> Result<(), NodeError> {
        let j = s.joints;
        self.nozzle_speed.put(&Float64 { data: j.v0 })?;
        self.flow.put(&Float64 { data: s.flow_l_s })?;
        self.water.put(&Bool {
            data: s.water_connected,
        })?;
        self.fire.put(&Bool {
            data: s.fire_detected,
        })?;
        self.temperature.put(&Temperature {
            header: Header::new(s.t, frame(&self.ns, "monitor_link")),
            temperature: s.temperature_c,
            variance: 0.0,
        })?;
        self.heat.put(&Float64 {
            data: s.heat_flux_kw_m2,
        })?;
        let map = Header::new(s.t, "map");
        self.hot_spots.put(&Detection3DArray {
            header: map.clone(),
            detections: s
                .hot_spots
                .iter()
                .map(|h| hot_spot_to_ros(h, &map))
                .collect(),
        })?;
        // The monitor's rates by difference; the carriage's speed as its drive measures it.
        let (yaw_rate, pitch_rate) = match self.last {
            Some((t0, j0)) if s.t > t0 => (
                (j.theta1 - j0.theta1) / (s.t - t0),
                (j.theta2 - j0.theta2) / (s.t - t0),
            ),
            _ => (0.0, 0.0),
        };
        self.last = Some((s.t, j));
        self.joints.put(&JointState {
            header: Header::new(s.t, frame(&self.ns, "base_link")),
            name: [CARRIAGE_JOINT, YAW_JOINT, PITCH_JOINT]
                .map(String::from)
                .to_vec(),
            position: vec![j.d, j.theta1, j.theta2],
            velocity: vec![s.speed, yaw_rate, pitch_rate],
            effort: vec![],
        })
    }

    /// The set-points to apply, if any arrived since the last call, on top of `last`.
    pub fn take_command(&self, last: &RailCommand) -> Option<RailCommand> {
        let mut r = self.commands.lock();
        if r.trajectory.is_none() && r.v0.is_none() && r.valve.is_none() {
            return None;
        }
        let mut cmd = *last;
        if let Some(t) = r.trajectory.take() {
            match setpoints(&t, cmd.joints) {
                Ok(joints) => cmd.joints = joints,
                Err(e) => tracing::warn!(unit = %self.unit, "dropped a {TRAJECTORY}: {e}"),
            }
        }
        if let Some(v0) = r.v0.take() {
            cmd.joints.v0 = v0;
        }
        if let Some(open) = r.valve.take() {
            cmd.valve_open = open;
        }
        match cmd.validate() {
            Ok(()) => Some(cmd),
            Err(e) => {
                tracing::warn!(unit = %self.unit, "dropped ROS 2 set-points: {e}");
                None
            }
        }
    }
}

/// What arrives on a carriage's topics, in arrival order.
#[derive(Debug)]
enum Incoming {
    Joints(JointState),
    NozzleSpeed(f64),
    Flow(f64),
    Water(bool),
    Fire(bool),
    Temperature(f64),
    Heat(f64),
    HotSpots(Detection3DArray),
}

/// The agent's side: a carriage's topics assembled into sensor frames, set-points sent
/// out.
pub struct Robot {
    parts: Parts<Incoming>,
    heard: Heard,
    spec: MonorailSpec,
    /// The newest frame's time and joints: set-points are stamped with the one and timed
    /// from the other.
    last: Option<(f64, RailJoints)>,
    trajectory: Publisher<JointTrajectory>,
    nozzle_cmd: Publisher<Float64>,
    valve_cmd: Publisher<Bool>,
    _subscriptions: Vec<Subscription>,
}

/// What the carriage has said since the last frame, and what it said last.
struct Heard {
    unit: UnitId,
    v0: Option<f64>,
    temperature_c: Option<f64>,
    water_connected: Option<bool>,
    flow_l_s: f64,
    fire_detected: bool,
    heat: f64,
    hot_spots: Vec<HotSpot>,
    /// A hot spot's error where the carriage gives none: the profile's camera at the
    /// edge of its range.
    unknown_sigma_m: f64,
}

impl Robot {
    pub async fn new(node: &Node, unit: UnitId, spec: MonorailSpec) -> Result<Self, NodeError> {
        let (feed, parts) = assemble::parts();
        let subscriptions = vec![
            node.subscribe(
                NOZZLE_SPEED,
                feed.to(|m: Float64| Incoming::NozzleSpeed(m.data)),
            )
            .await?,
            node.subscribe(FLOW, feed.to(|m: Float64| Incoming::Flow(m.data)))
                .await?,
            node.subscribe(WATER_CONNECTED, feed.to(|m: Bool| Incoming::Water(m.data)))
                .await?,
            node.subscribe(FIRE_DETECTED, feed.to(|m: Bool| Incoming::Fire(m.data)))
                .await?,
            node.subscribe(
                TEMPERATURE,
                feed.to(|m: Temperature| Incoming::Temperature(m.temperature)),
            )
            .await?,
            node.subscribe(HEAT_FLUX, feed.to(|m: Float64| Incoming::Heat(m.data)))
                .await?,
            node.subscribe(HOT_SPOTS, feed.to(Incoming::HotSpots))
                .await?,
            node.subscribe(JOINT_STATES, feed.to(Incoming::Joints))
                .await?,
        ];
        Ok(Self {
            parts,
            heard: Heard {
                unit,
                v0: None,
                temperature_c: None,
                water_connected: None,
                flow_l_s: 0.0,
                fire_detected: false,
                heat: 0.0,
                hot_spots: Vec::new(),
                unknown_sigma_m: spec.hot_spot_sigma_a_m
                    + spec.hot_spot_sigma_b * spec.detector_range_m,
            },
            spec,
            last: None,
            trajectory: node.publisher(TRAJECTORY).await?,
            nozzle_cmd: node.publisher(NOZZLE_COMMAND).await?,
            valve_cmd: node.publisher(VALVE).await?,
            _subscriptions: subscriptions,
        })
    }

    /// The next sensor frame: taken when joint states arrive, once the carriage has
    /// reported its nozzle speed, temperature and hose connection; `None` when the
    /// session is gone.
    pub async fn sense(&mut self) -> Option<RailSensors> {
        let frame = self.parts.next_frame(&mut self.heard).await?;
        self.last = Some((frame.t, frame.joints));
        Some(frame)
    }

    /// Send set-points, stamped with the newest frame's time.
    pub fn actuate(&mut self, cmd: &RailCommand) -> Result<(), NodeError> {
        let (t, from) = self.last.unwrap_or((0.0, cmd.joints));
        let to = cmd.joints;
        self.trajectory.put(&JointTrajectory {
            header: Header::new(t, ""),
            joint_names: [CARRIAGE_JOINT, YAW_JOINT, PITCH_JOINT]
                .map(String::from)
                .to_vec(),
            points: vec![JointTrajectoryPoint {
                positions: vec![to.d, to.theta1, to.theta2],
                time_from_start: Duration::from_secs(time_to_reach(&self.spec, &from, &to)),
                ..JointTrajectoryPoint::default()
            }],
        })?;
        self.nozzle_cmd.put(&Float64 { data: to.v0 })?;
        self.valve_cmd.put(&Bool {
            data: cmd.valve_open,
        })
    }
}

impl Assemble for Heard {
    type Part = Incoming;
    type Frame = RailSensors;

    fn unit(&self) -> &UnitId {
        &self.unit
    }

    fn take(&mut self, m: Incoming) -> Option<RailSensors> {
        match m {
            Incoming::NozzleSpeed(v) => self.v0 = Some(v),
            Incoming::Flow(q) => self.flow_l_s = q,
            Incoming::Water(w) => self.water_connected = Some(w),
            Incoming::Fire(f) => self.fire_detected = f,
            Incoming::Temperature(c) => self.temperature_c = Some(c),
            Incoming::Heat(q) => self.heat = q,
            Incoming::HotSpots(a) => {
                let unknown = self.unknown_sigma_m;
                let before = self.hot_spots.len();
                self.hot_spots.extend(
                    a.detections
                        .iter()
                        .filter_map(|d| hot_spot_from_ros(d, unknown)),
                );
                let dropped = a.detections.len() - (self.hot_spots.len() - before);
                if dropped > 0 {
                    tracing::debug!(unit = %self.unit, dropped, "{HOT_SPOTS}: detections that are no fire, or nowhere");
                }
            }
            Incoming::Joints(j) => {
                let (Some(d), Some(theta1), Some(theta2)) = (
                    j.position_of(CARRIAGE_JOINT),
                    j.position_of(YAW_JOINT),
                    j.position_of(PITCH_JOINT),
                ) else {
                    tracing::warn!(unit = %self.unit, "{JOINT_STATES} without the carriage's three joints: {:?}", j.name);
                    return None;
                };
                let (Some(v0), Some(temperature_c), Some(water_connected)) =
                    (self.v0, self.temperature_c, self.water_connected)
                else {
                    return None;
                };
                return Some(RailSensors {
                    unit: self.unit.clone(),
                    t: j.header.stamp.secs(),
                    joints: RailJoints {
                        d,
                        theta1,
                        theta2,
                        v0,
                    },
                    speed: j.velocity_of(CARRIAGE_JOINT).unwrap_or(0.0),
                    valve_open: self.flow_l_s > 0.0,
                    flow_l_s: self.flow_l_s,
                    water_connected,
                    fire_detected: self.fire_detected,
                    temperature_c,
                    heat_flux_kw_m2: self.heat,
                    hot_spots: std::mem::take(&mut self.hot_spots),
                });
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::MONORAIL;

    fn trajectory(names: &[&str], positions: &[f64]) -> JointTrajectory {
        JointTrajectory {
            joint_names: names.iter().map(|n| n.to_string()).collect(),
            points: vec![JointTrajectoryPoint {
                positions: positions.to_vec(),
                ..JointTrajectoryPoint::default()
            }],
            ..JointTrajectory::default()
        }
    }

    const HOME: RailJoints = RailJoints {
        d: 10.0,
        theta1: 0.0,
        theta2: -0.2,
        v0: 12.0,
    };

    #[test]
    fn a_trajectory_sets_the_joints_it_names_in_any_order() {
        let t = trajectory(&[PITCH_JOINT, CARRIAGE_JOINT], &[-0.5, 42.0]);
        let j = setpoints(&t, HOME).unwrap();
        assert_eq!((j.d, j.theta1, j.theta2, j.v0), (42.0, 0.0, -0.5, 12.0));
    }

    #[test]
    fn a_trajectory_the_carriage_cannot_follow_names_why() {
        let cases = [
            (
                trajectory(&[CARRIAGE_JOINT, YAW_JOINT], &[1.0]),
                TrajectoryError::Lengths {
                    names: 2,
                    positions: 1,
                },
            ),
            (
                trajectory(&["wrist_joint"], &[1.0]),
                TrajectoryError::UnknownJoint("wrist_joint".into()),
            ),
            (
                trajectory(&[YAW_JOINT], &[f64::NAN]),
                TrajectoryError::NotFinite(YAW_JOINT.into()),
            ),
            (JointTrajectory::default(), TrajectoryError::NoPoints),
        ];
        for (t, why) in cases {
            assert_eq!(setpoints(&t, HOME), Err(why));
        }
    }

    #[test]
    fn a_move_takes_the_slowest_joints_time() {
        let spec = *MONORAIL;
        let far = RailJoints { d: 30.0, ..HOME };
        assert!((time_to_reach(&spec, &HOME, &far) - 20.0 / spec.carriage_speed_m_s).abs() < 1e-12);
        let turn = RailJoints {
            theta1: 1.0,
            ..HOME
        };
        assert!((time_to_reach(&spec, &HOME, &turn) - 1.0 / spec.monitor_rate_rad_s).abs() < 1e-12);
        assert_eq!(time_to_reach(&spec, &HOME, &HOME), MIN_MOVE_S);
    }

    #[test]
    fn a_hot_spot_goes_through_ros_and_back() {
        let h = HotSpot {
            position: Point2::new(120.5, -1.25),
            sigma_m: 0.4,
        };
        let d = hot_spot_to_ros(&h, &Header::new(3.0, "map"));
        let back = hot_spot_from_ros(&d, 9.0).unwrap();
        assert_eq!(back.position, h.position);
        assert!((back.sigma_m - h.sigma_m).abs() < 1e-12);
        let mut person = d.clone();
        person.results[0].hypothesis.class_id = "person".into();
        assert!(hot_spot_from_ros(&person, 9.0).is_none(), "only fires");
        let mut unknown = d.clone();
        unknown.results[0].pose.covariance = Covariance::default();
        assert_eq!(
            hot_spot_from_ros(&unknown, 9.0).unwrap().sigma_m,
            9.0,
            "all zeros: unknown"
        );
        let mut nowhere = d;
        nowhere.results[0].pose.pose.position.x = f64::NAN;
        assert!(hot_spot_from_ros(&nowhere, 9.0).is_none());
    }
}
