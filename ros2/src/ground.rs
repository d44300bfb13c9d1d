//! A ground unit's body as ROS 2 topics: what the robot publishes, what the agent sends.
//!
//! Topics, relative to the robot's namespace (`/ugv_1/odom` and so on):
//!
//! | topic | type | direction | content |
//! |---|---|---|---|
//! | `odom` | nav_msgs/Odometry | robot -> agent | localized pose in the site frame (`map`), forward speed |
//! | `joint_states` | sensor_msgs/JointState | robot -> agent | `steering_joint`, `cannon_pan_joint`, `cannon_tilt_joint` (rad) |
//! | `flame_detections` | vision_msgs/Detection3DArray | robot -> agent | flames in the camera's optical frame (x right, y down, z forward), class `fire` |
//! | `tank_level` | std_msgs/Float64 | robot -> agent | water left, litres |
//! | `heat_flux` | std_msgs/Float64 | robot -> agent | radiant heat flux at the body, kW/m^2 |
//! | `bumper` | std_msgs/Bool | robot -> agent | the body touched something since the last message |
//! | `thermal/image_raw`, `thermal/depth`, `thermal/camera_info` | sensor_msgs/Image, Image, CameraInfo | robot -> agent | a thermal core's frames, for a unit whose profile has a `thermal_camera` ([`crate::thermal`]); the agent finds flames in them itself |
//! | `cmd_vel` | geometry_msgs/TwistStamped | agent -> robot | `linear.x` m/s, `angular.z` rad/s |
//! | `cannon_controller/commands` | std_msgs/Float64MultiArray | agent -> robot | `[pan, tilt]` rad, a ros2_control forward command controller |
//! | `steering/command` | std_msgs/Float64 | agent -> robot | steering angle to turn the wheels to at a standstill, rad |
//! | `cannon/valve` | std_msgs/Bool | agent -> robot | open the monitor's valve |
//! | `firefleet_agent/flame_detections` | vision_msgs/Detection3DArray | agent -> robot | the flames the agent found in the thermal frames, in the thermal core's optical frame, class `fire` |
//!
//! Choices, and why:
//! - `cmd_vel` is `TwistStamped`: ros2_control's drive controllers take it from Jazzy on,
//!   and Nav2 sends it from Kilted on (`enable_stamped_cmd_vel`, false by default in Jazzy,
//!   where Nav2 still sends `Twist`); a Jazzy Nav2 stack is set to stamped to match.
//! - Our units steer like a bicycle: the agent's steering angle `delta` goes out as the yaw
//!   rate `v tan(delta) / L` a car-like controller turns back into an angle. Below
//!   [`MIN_STEER_SPEED`] the rate carries no angle, yet at a cusp the agent stops and turns
//!   its wheels to the next run's lock before it drives on (a Twist cannot say that: the
//!   first fleet run on ROS 2 stalled there, a unit waiting for wheels that never turned).
//!   So the angle also goes out on `steering/command`, which the body follows at a
//!   standstill only; while moving, `cmd_vel` alone steers.
//! - Detections are 3D (vision_msgs), the output of a detector plus depth localizer on the
//!   robot. The agent's tracker reads pixel boxes with depth, so the agent projects each 3D
//!   box through the camera model of its profile (an exact inverse of the localizer: the
//!   flame lands where the robot put it).
//! - Tank level and heat flux are plain `Float64` in stated units: `sensor_msgs` has no
//!   water tank or heat-flux message, and `BatteryState` would mean misreading its fields.
//! - No topic brings the other units a robot's range sensors track: on ROS 2 the agent
//!   neither yields to nor plans round other units, and the robot's own safety layer
//!   (Nav2's collision monitor, say) is what stops it short of one.
//!
//! Not here: the agent's `Platform` (`firefleet_agent::platform`, which builds on this crate) or the simulator's loop.

use firefleet_model::UnitId;
use firefleet_model::geometry::Pose2;
use firefleet_model::spec::{CameraSpec, GroundSpec};
use firefleet_model::validate::Validate;
use firefleet_protocol::msg::{
    CannonState, DEPTH_WINDOW, FlameDetection, ObjectClass, ThermalImage, UnitCommand, UnitSensors,
};

use crate::assemble::{self, Assemble, Latest, Parts};
use crate::msg::*;
use crate::node::{Node, NodeError, Publisher, Subscription};
use crate::thermal::{self, THERMAL_DEPTH, THERMAL_IMAGE, THERMAL_INFO};

pub const ODOM: &str = "odom";
pub const JOINT_STATES: &str = "joint_states";
pub const DETECTIONS: &str = "flame_detections";
pub const TANK: &str = "tank_level";
pub const HEAT_FLUX: &str = "heat_flux";
pub const BUMPER: &str = "bumper";
pub const CMD_VEL: &str = "cmd_vel";
pub const CANNON: &str = "cannon_controller/commands";
pub const VALVE: &str = "cannon/valve";
pub const STEERING: &str = "steering/command";
/// Where the agent publishes the flames its own detector found in the thermal frames, for
/// the robot's other tools: its node's private topic (`~/flame_detections`), so that it
/// never reads back its own findings as the robot's.
pub const FOUND: &str = "firefleet_agent/flame_detections";

pub const STEERING_JOINT: &str = "steering_joint";
pub const PAN_JOINT: &str = "cannon_pan_joint";
pub const TILT_JOINT: &str = "cannon_tilt_joint";
/// The class a flame detector labels flames with.
pub const FIRE_CLASS: &str = "fire";
/// Slowest speed at which a yaw rate still says a steering angle, m/s.
pub const MIN_STEER_SPEED: f64 = 0.05;

/// Frame `frame` of the robot in namespace `ns` (`/ugv_1`, `base_link` -> `ugv_1/base_link`).
pub(crate) fn frame(ns: &str, frame: &str) -> String {
    format!("{}/{frame}", ns.trim_start_matches('/'))
}

/// A flame detection as the robot's 3D localizer publishes it: the box's centre at the
/// detection's robust depth, its size from the box's pixels at that depth. `None` where
/// the depth camera had too little on the flame to place it.
pub fn detection_to_ros(
    d: &FlameDetection,
    cam: &CameraSpec,
    frame_id: &str,
) -> Option<Detection3D> {
    let z = d.depth_m()?;
    let (u, v) = ((d.bbox[0] + d.bbox[2]) / 2.0, (d.bbox[1] + d.bbox[3]) / 2.0);
    let [x, y, z] = cam.back_project(u, v, z);
    let center = Pose {
        position: Point { x, y, z },
        orientation: Quaternion::default(),
    };
    let size = Vector3 {
        x: (d.bbox[2] - d.bbox[0]) * z / cam.fx,
        y: (d.bbox[3] - d.bbox[1]) * z / cam.fy,
        z: (d.bbox[2] - d.bbox[0]) * z / cam.fx,
    };
    let var = cam.depth_sigma_m(z).powi(2);
    Some(Detection3D {
        header: Header {
            frame_id: frame_id.to_owned(),
            ..Header::default()
        },
        results: vec![ObjectHypothesisWithPose {
            hypothesis: ObjectHypothesis {
                class_id: FIRE_CLASS.to_owned(),
                score: d.confidence,
            },
            pose: PoseWithCovariance {
                pose: center,
                covariance: Covariance::diagonal([var, var, var, 0.0, 0.0, 0.0]),
            },
        }],
        bbox: BoundingBox3D { center, size },
        id: String::new(),
    })
}

/// A 3D detection back in the camera's pixels: the box the localizer's centre and size
/// project to, every depth pixel at the centre's depth. `None` for anything but a fire in
/// front of the camera.
pub fn detection_from_ros(d: &Detection3D, cam: &CameraSpec) -> Option<FlameDetection> {
    let score = d
        .results
        .iter()
        .filter(|r| r.hypothesis.class_id == FIRE_CLASS)
        .map(|r| r.hypothesis.score)
        .fold(None, |best: Option<f64>, s| {
            Some(best.map_or(s, |b| b.max(s)))
        })?;
    let p = d.bbox.center.position;
    let [u, v] = cam.project([p.x, p.y, p.z])?;
    let (hw, hh) = (
        d.bbox.size.x.abs() / 2.0 * cam.fx / p.z,
        d.bbox.size.y.abs() / 2.0 * cam.fy / p.z,
    );
    Some(FlameDetection {
        class: ObjectClass::Fire,
        confidence: score,
        bbox: [u - hw, v - hh, u + hw, v + hh],
        depth: [p.z as f32; DEPTH_WINDOW * DEPTH_WINDOW],
    })
}

/// Forward speed and steering angle from a stamped twist, for a bicycle of `spec`; the
/// angle is `held` when the speed says none.
pub fn drive_from_twist(t: &Twist, spec: &GroundSpec, held: f64) -> (f64, f64) {
    let v = t.linear.x;
    let steer = if v.abs() < MIN_STEER_SPEED {
        held
    } else {
        (t.angular.z * spec.wheelbase_m / v)
            .atan()
            .clamp(-spec.max_steer_rad, spec.max_steer_rad)
    };
    (v, steer)
}

/// The robot's side: publishes a unit's sensor frames on its topics, keeps the newest
/// set-point of each command topic. The simulator runs one per ground unit.
pub struct Body {
    unit: UnitId,
    spec: GroundSpec,
    ns: String,
    odom: Publisher<Odometry>,
    joints: Publisher<JointState>,
    detections: Publisher<Detection3DArray>,
    tank: Publisher<Float64>,
    heat: Publisher<Float64>,
    bumper: Publisher<Bool>,
    thermal: Publisher<Image>,
    thermal_depth: Publisher<Image>,
    thermal_info: Publisher<CameraInfo>,
    commands: Latest<Received>,
    _subscriptions: [Subscription; 4],
}

/// Set-points received since the body last took them.
#[derive(Debug, Default)]
struct Received {
    drive: Option<Twist>,
    cannon: Option<[f64; 2]>,
    valve: Option<bool>,
    /// The newest standstill steering angle (kept: it applies whenever the body stops).
    standstill_steer: Option<f64>,
}

impl Body {
    pub async fn new(node: &Node, unit: UnitId, spec: GroundSpec) -> Result<Self, NodeError> {
        let commands = Latest::new();
        let subscriptions = [
            node.subscribe(
                CMD_VEL,
                commands.to(|r: &mut Received, m: TwistStamped| r.drive = Some(m.twist)),
            )
            .await?,
            node.subscribe(
                CANNON,
                commands.to(|r: &mut Received, m: Float64MultiArray| {
                    if let [pan, tilt] = m.data[..] {
                        r.cannon = Some([pan, tilt]);
                    } else {
                        tracing::warn!(len = m.data.len(), "{CANNON}: expected [pan, tilt]");
                    }
                }),
            )
            .await?,
            node.subscribe(
                VALVE,
                commands.to(|r: &mut Received, m: Bool| r.valve = Some(m.data)),
            )
            .await?,
            node.subscribe(
                STEERING,
                commands.to(|r: &mut Received, m: Float64| r.standstill_steer = Some(m.data)),
            )
            .await?,
        ];
        Ok(Self {
            unit,
            spec,
            ns: node.namespace().to_string(),
            odom: node.publisher(ODOM).await?,
            joints: node.publisher(JOINT_STATES).await?,
            detections: node.publisher(DETECTIONS).await?,
            tank: node.publisher(TANK).await?,
            heat: node.publisher(HEAT_FLUX).await?,
            bumper: node.publisher(BUMPER).await?,
            thermal: node.publisher(THERMAL_IMAGE).await?,
            thermal_depth: node.publisher(THERMAL_DEPTH).await?,
            thermal_info: node.publisher(THERMAL_INFO).await?,
            commands,
            _subscriptions: subscriptions,
        })
    }

    /// Publish frame `s`. Odometry goes last: the agent takes a frame when it arrives.
    pub fn publish(&self, s: &UnitSensors) -> Result<(), NodeError> {
        let header = |f: &str| Header::new(s.t, frame(&self.ns, f));
        self.joints.put(&JointState {
            header: header("base_link"),
            name: [STEERING_JOINT, PAN_JOINT, TILT_JOINT]
                .map(String::from)
                .to_vec(),
            position: vec![s.steer, s.cannon.pan, s.cannon.tilt],
            velocity: vec![],
            effort: vec![],
        })?;
        let optical = frame(&self.ns, "camera_optical_frame");
        self.detections.put(&Detection3DArray {
            header: header("camera_optical_frame"),
            detections: s
                .detections
                .iter()
                .filter_map(|d| detection_to_ros(d, &self.spec.camera, &optical))
                .map(|mut d| {
                    d.header.stamp = Time::from_secs(s.t);
                    d
                })
                .collect(),
        })?;
        self.tank.put(&Float64 { data: s.water_l })?;
        self.heat.put(&Float64 {
            data: s.heat_flux_kw_m2,
        })?;
        self.bumper.put(&Bool { data: s.collided })?;
        if let (Some(img), Some(optics)) = (&s.thermal, &self.spec.thermal_camera) {
            let optical = frame(&self.ns, "thermal_optical_frame");
            let (image, depth, info) = thermal::to_ros(img, s.t, &optical, optics);
            self.thermal_info.put(&info)?;
            self.thermal_depth.put(&depth)?;
            self.thermal.put(&image)?;
        }
        self.odom.put(&Odometry {
            header: Header::new(s.t, "map"),
            child_frame_id: frame(&self.ns, "base_link"),
            pose: PoseWithCovariance {
                pose: Pose {
                    position: Point {
                        x: s.pose.x,
                        y: s.pose.y,
                        z: 0.0,
                    },
                    orientation: Quaternion::from_yaw(s.pose.yaw),
                },
                covariance: Covariance::default(),
            },
            twist: TwistWithCovariance {
                twist: Twist {
                    linear: Vector3 {
                        x: s.speed,
                        ..Vector3::default()
                    },
                    ..Twist::default()
                },
                covariance: Covariance::default(),
            },
        })
    }

    /// The set-points to apply, if any arrived since the last call, on top of `last`.
    pub fn take_command(&self, last: &UnitCommand) -> Option<UnitCommand> {
        let mut r = self.commands.lock();
        if r.drive.is_none() && r.cannon.is_none() && r.valve.is_none() {
            return None;
        }
        let mut cmd = *last;
        if let Some(t) = r.drive.take() {
            let standstill = r.standstill_steer.unwrap_or(last.steer);
            (cmd.speed, cmd.steer) = drive_from_twist(&t, &self.spec, standstill);
        }
        if let Some([pan, tilt]) = r.cannon.take() {
            (cmd.pan, cmd.tilt) = (pan, tilt);
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

/// What arrives on a robot's topics, in arrival order.
#[derive(Debug)]
enum Incoming {
    Odom(Box<Odometry>),
    Joints(JointState),
    Detections(Detection3DArray),
    Tank(f64),
    Heat(f64),
    Bumper(bool),
    Thermal(Image),
    ThermalDepth(Image),
    ThermalInfo(Box<CameraInfo>),
}

/// Which of a robot's flame streams the agent takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FlameSource {
    /// The robot's own detector's (`flame_detections`) only.
    Detections,
    /// The thermal core's frames only: the agent finds the flames itself.
    Thermal,
    /// Whatever the robot sends: detections, thermal frames or both.
    #[default]
    Both,
}

impl FlameSource {
    fn detections(self) -> bool {
        self != Self::Thermal
    }
    fn thermal(self) -> bool {
        self != Self::Detections
    }
}

/// The agent's side: a robot's topics assembled into sensor frames, set-points sent out.
pub struct Robot {
    parts: Parts<Incoming>,
    heard: Heard,
    last_t: f64,
    /// Where the agent's own findings go, when it takes thermal frames.
    found: Option<Publisher<Detection3DArray>>,
    ns: String,
    cmd_vel: Publisher<TwistStamped>,
    steering_cmd: Publisher<Float64>,
    cannon_cmd: Publisher<Float64MultiArray>,
    valve_cmd: Publisher<Bool>,
    _subscriptions: Vec<Subscription>,
}

/// What the robot has said since the last frame, and what it said last.
struct Heard {
    unit: UnitId,
    spec: GroundSpec,
    steer: Option<f64>,
    cannon: Option<(f64, f64)>,
    water_l: Option<f64>,
    heat: f64,
    bumped: bool,
    /// The newest array since the last frame. An array is the detector's whole finding in
    /// one image, so a newer one replaces an older (a robot whose detector runs faster
    /// than its odometry would otherwise count one flame once an image); a bump, an event,
    /// is kept until a frame takes it.
    detections: Vec<FlameDetection>,
    /// A thermal image and a depth image waiting for their partner, the newest camera
    /// info, and the frame they made.
    thermal_image: Option<Image>,
    thermal_depth: Option<Image>,
    thermal_info: Option<CameraInfo>,
    thermal: Option<ThermalImage>,
    /// The valve as the agent last set it (the robot reports no valve state of its own).
    valve: bool,
}

impl Robot {
    /// The robot on `node`'s namespace, its flames taken from `flames`.
    pub async fn new(
        node: &Node,
        unit: UnitId,
        spec: GroundSpec,
        flames: FlameSource,
    ) -> Result<Self, NodeError> {
        let (feed, parts) = assemble::parts();
        let mut subscriptions = vec![
            node.subscribe(JOINT_STATES, feed.to(Incoming::Joints))
                .await?,
            node.subscribe(TANK, feed.to(|m: Float64| Incoming::Tank(m.data)))
                .await?,
            node.subscribe(HEAT_FLUX, feed.to(|m: Float64| Incoming::Heat(m.data)))
                .await?,
            node.subscribe(BUMPER, feed.to(|m: Bool| Incoming::Bumper(m.data)))
                .await?,
        ];
        if flames.detections() {
            subscriptions.push(
                node.subscribe(DETECTIONS, feed.to(Incoming::Detections))
                    .await?,
            );
        }
        let mut found = None;
        if flames.thermal() {
            subscriptions.extend([
                node.subscribe(THERMAL_IMAGE, feed.to(Incoming::Thermal))
                    .await?,
                node.subscribe(THERMAL_DEPTH, feed.to(Incoming::ThermalDepth))
                    .await?,
                node.subscribe(
                    THERMAL_INFO,
                    feed.to(|m| Incoming::ThermalInfo(Box::new(m))),
                )
                .await?,
            ]);
            found = Some(node.publisher(FOUND).await?);
        }
        // Last: a frame is taken when odometry arrives.
        subscriptions.push(
            node.subscribe(ODOM, feed.to(|m| Incoming::Odom(Box::new(m))))
                .await?,
        );
        Ok(Self {
            found,
            ns: node.namespace().to_string(),
            parts,
            heard: Heard::new(unit, spec),
            last_t: 0.0,
            cmd_vel: node.publisher(CMD_VEL).await?,
            steering_cmd: node.publisher(STEERING).await?,
            cannon_cmd: node.publisher(CANNON).await?,
            valve_cmd: node.publisher(VALVE).await?,
            _subscriptions: subscriptions,
        })
    }

    /// The next sensor frame: taken when odometry arrives, once the robot has reported its
    /// joints and tank; `None` when the session is gone.
    pub async fn sense(&mut self) -> Option<UnitSensors> {
        let frame = self.parts.next_frame(&mut self.heard).await?;
        self.last_t = frame.t;
        Some(frame)
    }

    /// Publish the flames the agent found in the thermal frame of time `t` (in the
    /// thermal core's pixels, placed by depth) on [`FOUND`], for the robot's other tools;
    /// nothing when the agent takes no thermal frames or the profile has no thermal core.
    pub fn publish_found(&self, t: f64, found: &[FlameDetection]) -> Result<(), NodeError> {
        let (Some(publisher), Some(optics)) = (&self.found, &self.heard.spec.thermal_camera) else {
            return Ok(());
        };
        let optical = frame(&self.ns, "thermal_optical_frame");
        let header = Header::new(t, optical.clone());
        publisher.put(&Detection3DArray {
            detections: found
                .iter()
                .filter_map(|d| detection_to_ros(d, optics, &optical))
                .map(|mut d| {
                    d.header = header.clone();
                    d
                })
                .collect(),
            header,
        })
    }

    /// Send set-points, stamped with the newest frame's time.
    pub fn actuate(&mut self, cmd: &UnitCommand) -> Result<(), NodeError> {
        let header = Header::new(self.last_t, "");
        // Before the twist: the body reads the standstill angle when the twist arrives.
        self.steering_cmd.put(&Float64 { data: cmd.steer })?;
        self.cmd_vel.put(&TwistStamped {
            header,
            twist: Twist {
                linear: Vector3 {
                    x: cmd.speed,
                    ..Vector3::default()
                },
                angular: Vector3 {
                    z: cmd.speed * cmd.steer.tan() / self.heard.spec.wheelbase_m,
                    ..Vector3::default()
                },
            },
        })?;
        self.cannon_cmd.put(&Float64MultiArray {
            layout: MultiArrayLayout {
                dim: vec![MultiArrayDimension {
                    label: "pan_tilt".into(),
                    size: 2,
                    stride: 2,
                }],
                data_offset: 0,
            },
            data: vec![cmd.pan, cmd.tilt],
        })?;
        self.heard.valve = cmd.valve_open;
        self.valve_cmd.put(&Bool {
            data: cmd.valve_open,
        })
    }
}

impl Heard {
    /// Nothing heard yet.
    fn new(unit: UnitId, spec: GroundSpec) -> Self {
        Self {
            unit,
            spec,
            steer: None,
            cannon: None,
            water_l: None,
            heat: 0.0,
            bumped: false,
            detections: Vec::new(),
            thermal_image: None,
            thermal_depth: None,
            thermal_info: None,
            thermal: None,
            valve: false,
        }
    }

    /// A thermal frame from the waiting image and depth, once both have the same stamp;
    /// one the profile cannot take is refused with the reason.
    fn pair_thermal(&mut self) {
        let (Some(image), Some(depth)) = (&self.thermal_image, &self.thermal_depth) else {
            return;
        };
        if image.header.stamp != depth.header.stamp {
            return;
        }
        let Some(optics) = &self.spec.thermal_camera else {
            tracing::warn!(unit = %self.unit, "a thermal frame, but the unit's profile has no thermal_camera");
            return;
        };
        match thermal::from_ros(image, depth, self.thermal_info.as_ref(), optics) {
            Ok(frame) => self.thermal = Some(frame),
            Err(e) => tracing::warn!(unit = %self.unit, "dropped a thermal frame: {e}"),
        }
        (self.thermal_image, self.thermal_depth) = (None, None);
    }
}

impl Assemble for Heard {
    type Part = Incoming;
    type Frame = UnitSensors;

    fn unit(&self) -> &UnitId {
        &self.unit
    }

    fn take(&mut self, m: Incoming) -> Option<UnitSensors> {
        match m {
            Incoming::Joints(j) => {
                if let Some(s) = j.position_of(STEERING_JOINT) {
                    self.steer = Some(s);
                }
                if let (Some(p), Some(t)) = (j.position_of(PAN_JOINT), j.position_of(TILT_JOINT)) {
                    self.cannon = Some((p, t));
                }
            }
            Incoming::Detections(a) => {
                self.detections = a
                    .detections
                    .iter()
                    .filter_map(|d| detection_from_ros(d, &self.spec.camera))
                    .collect();
            }
            Incoming::Thermal(i) => {
                self.thermal_image = Some(i);
                self.pair_thermal();
            }
            Incoming::ThermalDepth(d) => {
                self.thermal_depth = Some(d);
                self.pair_thermal();
            }
            Incoming::ThermalInfo(i) => self.thermal_info = Some(*i),
            Incoming::Tank(l) => self.water_l = Some(l),
            Incoming::Heat(q) => self.heat = q,
            Incoming::Bumper(b) => self.bumped |= b,
            Incoming::Odom(o) => {
                let (Some(steer), Some((pan, tilt)), Some(water_l)) =
                    (self.steer, self.cannon, self.water_l)
                else {
                    return None;
                };
                let p = o.pose.pose;
                return Some(UnitSensors {
                    unit: self.unit.clone(),
                    t: o.header.stamp.secs(),
                    pose: Pose2::new(p.position.x, p.position.y, p.orientation.yaw()),
                    speed: o.twist.twist.linear.x,
                    steer,
                    heat_flux_kw_m2: self.heat,
                    water_l,
                    cannon: CannonState {
                        pan,
                        tilt,
                        valve_open: self.valve,
                        flow_l_s: if self.valve {
                            self.spec.cannon_flow_l_s
                        } else {
                            0.0
                        },
                    },
                    detections: std::mem::take(&mut self.detections),
                    collided: std::mem::take(&mut self.bumped),
                    thermal: self.thermal.take(),
                    // No topic carries the robot's tracked bodies yet (see the module doc).
                    nearby: Vec::new(),
                });
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;

    #[test]
    fn a_detection_goes_through_ros_and_back_to_the_same_flame() {
        let cam = GROUND.camera;
        let c = cam.body_to_camera([12.0, -1.5, 1.1]);
        let [u, v] = cam.project(c).unwrap();
        let mut depth = [c[2] as f32; DEPTH_WINDOW * DEPTH_WINDOW];
        depth[3] = 0.0;
        let d = FlameDetection {
            class: ObjectClass::Fire,
            confidence: 0.8,
            bbox: [u - 25.0, v - 40.0, u + 25.0, v + 40.0],
            depth,
        };
        let ros = detection_to_ros(&d, &cam, "ugv_1/camera_optical_frame").unwrap();
        let back = detection_from_ros(&ros, &cam).unwrap();
        assert_eq!(back.confidence, 0.8);
        for k in 0..4 {
            assert!(
                (back.bbox[k] - d.bbox[k]).abs() < 1e-6,
                "{:?} {:?}",
                back.bbox,
                d.bbox
            );
        }
        assert!((back.depth_m().unwrap() - c[2]).abs() < 1e-5);
        let mut other = ros.clone();
        other.results[0].hypothesis.class_id = "person".into();
        assert!(detection_from_ros(&other, &cam).is_none(), "only fires");
        let mut behind = ros;
        behind.bbox.center.position.z = -3.0;
        assert!(detection_from_ros(&behind, &cam).is_none());
    }

    #[test]
    fn a_frame_takes_the_newest_detection_array_and_every_bump_since_the_last() {
        let cam = GROUND.camera;
        let flame_at = |x: f64| {
            let c = cam.body_to_camera([x, 0.0, 1.0]);
            let [u, v] = cam.project(c).unwrap();
            let d = FlameDetection {
                class: ObjectClass::Fire,
                confidence: 0.8,
                bbox: [u - 20.0, v - 30.0, u + 20.0, v + 30.0],
                depth: [c[2] as f32; DEPTH_WINDOW * DEPTH_WINDOW],
            };
            detection_to_ros(&d, &cam, "ugv_1/camera_optical_frame").unwrap()
        };
        let mut heard = Heard::new(UnitId::new("ugv-1").unwrap(), *GROUND);
        let joints = JointState {
            name: [STEERING_JOINT, PAN_JOINT, TILT_JOINT]
                .map(String::from)
                .into(),
            position: vec![0.0; 3],
            ..JointState::default()
        };
        let before_odom = [
            Incoming::Joints(joints),
            Incoming::Tank(900.0),
            Incoming::Bumper(true),
            Incoming::Detections(Detection3DArray {
                detections: vec![flame_at(8.0), flame_at(12.0)],
                ..Detection3DArray::default()
            }),
            Incoming::Bumper(false),
            Incoming::Detections(Detection3DArray {
                detections: vec![flame_at(7.5)],
                ..Detection3DArray::default()
            }),
        ];
        for part in before_odom {
            assert!(heard.take(part).is_none(), "no frame before odometry");
        }
        let frame = heard.take(Incoming::Odom(Box::default())).unwrap();
        let [d] = &frame.detections[..] else {
            panic!("the newest array alone: {:?}", frame.detections)
        };
        let ahead = cam.body_to_camera([7.5, 0.0, 1.0])[2];
        assert!((d.depth_m().unwrap() - ahead).abs() < 1e-5);
        assert!(frame.collided, "the bump between frames is kept");
        let next = heard.take(Incoming::Odom(Box::default())).unwrap();
        assert!(
            next.detections.is_empty() && !next.collided,
            "each taken once"
        );
    }

    #[test]
    fn steering_survives_the_yaw_rate() {
        let spec = *GROUND;
        for steer in [-0.5, -0.2, 0.0, 0.3, 0.5] {
            for v in [-0.4, 0.5, 1.5] {
                let t = Twist {
                    linear: Vector3 {
                        x: v,
                        ..Vector3::default()
                    },
                    angular: Vector3 {
                        z: v * f64::tan(steer) / spec.wheelbase_m,
                        ..Vector3::default()
                    },
                };
                let (v2, s2) = drive_from_twist(&t, &spec, 9.0);
                assert_eq!(v2, v);
                assert!((s2 - steer).abs() < 1e-12, "{v} {steer} -> {s2}");
            }
        }
        let (_, held) = drive_from_twist(&Twist::default(), &spec, 0.25);
        assert_eq!(held, 0.25, "standing still: the steering holds");
    }
}
