//! The simulator's side of the bus: its clock, sensor frames out, actuator commands in,
//! and the ground truth (postcard). A real robot's drivers stand where these are.
//!
//! Not here: the world that produces them (`firefleet-sim`).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use super::*;
use firefleet_model::geometry::{OrientedBox, Point2, Pose2};
use firefleet_model::ids::UnitId;
use firefleet_model::validate::{Invalid, Validate, each, finite, in_range, max_len};

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

/// Fewest valid depth pixels for a depth (a third of the window).
const MIN_VALID_DEPTH: usize = DEPTH_WINDOW * DEPTH_WINDOW / 3;

impl FlameDetection {
    /// The flame's depth, m: the median of the window's valid (non-zero, finite) pixels,
    /// robust to the dropouts and outliers a flame gives a depth camera; `None` with fewer
    /// than a third of them valid.
    pub fn depth_m(&self) -> Option<f64> {
        let mut valid = [0.0f32; DEPTH_WINDOW * DEPTH_WINDOW];
        let mut n = 0;
        for z in self
            .depth
            .iter()
            .copied()
            .filter(|z| z.is_finite() && *z > 0.0)
        {
            valid[n] = z;
            n += 1;
        }
        if n < MIN_VALID_DEPTH {
            return None;
        }
        let v = &mut valid[..n];
        v.sort_unstable_by(f32::total_cmp);
        Some(f64::from(if n % 2 == 1 {
            v[n / 2]
        } else {
            (v[n / 2 - 1] + v[n / 2]) / 2.0
        }))
    }
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

/// Largest thermal image a message may carry, pixels a side (640 x 512 is the largest
/// common uncooled radiometric core).
pub const MAX_THERMAL_SIDE: u16 = 640;

/// A radiometric thermal image and the depth image registered to it, as a robot's camera
/// drivers publish them (ROS 2: `sensor_msgs/Image` in `mono16` and `32FC1`).
///
/// Temperatures are in centikelvin, the TLinear output of common radiometric cores: a
/// pixel reads 0.01 K a count, so the scale ends at 655.35 K and hotter scenes (a flame's
/// core) saturate at `u16::MAX`, as the camera's high-gain mode does. Postcard carries
/// each buffer as one little-endian byte string (`pixels`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct ThermalImage {
    pub width: u16,
    pub height: u16,
    /// Row by row from the top left, centikelvin.
    #[serde(with = "super::pixels")]
    #[schemars(with = "Vec<u16>")]
    pub centikelvin: Vec<u16>,
    /// Depth along the optical axis, m, row by row; 0 where there is no value.
    #[serde(with = "super::pixels")]
    #[schemars(with = "Vec<f32>")]
    pub depth_m: Vec<f32>,
}

impl ThermalImage {
    /// Kelvin a count.
    pub const KELVIN_PER_COUNT: f64 = 0.01;

    /// Pixel `(u, v)`'s temperature, K.
    pub fn kelvin(&self, u: usize, v: usize) -> f64 {
        f64::from(self.centikelvin[v * usize::from(self.width) + u]) * Self::KELVIN_PER_COUNT
    }

    /// Pixel `(u, v)`'s depth, m, if the depth image has one.
    pub fn depth(&self, u: usize, v: usize) -> Option<f64> {
        let z = self.depth_m[v * usize::from(self.width) + u];
        (z.is_finite() && z > 0.0).then_some(f64::from(z))
    }
}

impl Validate for ThermalImage {
    fn validate(&self) -> Result<(), Invalid> {
        in_range(
            "width",
            f64::from(self.width),
            1.0,
            f64::from(MAX_THERMAL_SIDE),
        )?;
        in_range(
            "height",
            f64::from(self.height),
            1.0,
            f64::from(MAX_THERMAL_SIDE),
        )?;
        let n = usize::from(self.width) * usize::from(self.height);
        for (field, len) in [
            ("centikelvin", self.centikelvin.len()),
            ("depth_m", self.depth_m.len()),
        ] {
            if len != n {
                return Err(Invalid::new(
                    field,
                    format!("{len} pixels for a {}x{} image", self.width, self.height),
                ));
            }
        }
        match self
            .depth_m
            .iter()
            .position(|z| !z.is_finite() || *z < 0.0 || *z > 1e3)
        {
            Some(i) => Err(Invalid::new(
                format!("depth_m[{i}]"),
                format!("{} is not a depth in 0..1000 m", self.depth_m[i]),
            )),
            None => Ok(()),
        }
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

/// A robot's sensor frame, as an agent that fell behind its body treats it: frames queue
/// up, and the agent acts on the newest, passing over the ones in between unless a frame
/// carries what the agent cannot do without.
pub trait SensorFrame {
    /// Whether an agent that has a newer frame may pass this one over.
    fn may_pass_over(&self) -> bool;
}

impl SensorFrame for UnitSensors {
    /// Not when it carries a thermal image: the core delivers fewer frames than the body
    /// (8.7 Hz against 20), and the flame detector tells a flame from hot metal by its
    /// flicker over consecutive images, so a skipped image is one the detector lacks (an
    /// agent running behind at time scale 8 once passed over most of them, and took
    /// minutes to see a fire). Box detections come with every frame: the newest suffice.
    fn may_pass_over(&self) -> bool {
        self.thermal.is_none()
    }
}

impl SensorFrame for RailSensors {
    /// Always: every frame carries the carriage's whole state.
    fn may_pass_over(&self) -> bool {
        true
    }
}

/// A body a unit's range sensor tracks near it: another ground unit, as a lidar's
/// obstacle tracker reports one (an oriented box with its speed). The unit yields to it
/// and plans round it; walls and parked vehicles are on the unit's map already.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct NearbyBody {
    /// The box's centre and heading.
    pub pose: Pose2,
    pub length_m: f64,
    pub width_m: f64,
    /// Along its heading, m/s; negative when it backs.
    pub speed: f64,
}

impl NearbyBody {
    pub fn footprint(&self) -> OrientedBox {
        OrientedBox::new(self.pose, self.length_m, self.width_m)
    }
}

impl Validate for NearbyBody {
    fn validate(&self) -> Result<(), Invalid> {
        self.pose.validate().map_err(|e| e.within("pose"))?;
        // Sizes a road vehicle can have: a zero or a kilometre box would stop every unit
        // that believed it, or none.
        in_range("length_m", self.length_m, 0.1, 30.0)?;
        in_range("width_m", self.width_m, 0.1, 5.0)?;
        in_range("speed", self.speed, -50.0, 50.0)
    }
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
    /// A frame of the thermal core, when one is due (the core delivers fewer frames than
    /// the sensors do); the unit finds flames in it itself.
    #[serde(default)]
    pub thermal: Option<ThermalImage>,
    /// Other units the range sensor tracks within [`NEARBY_RANGE_M`].
    #[serde(default)]
    pub nearby: Vec<NearbyBody>,
}

/// How far a unit's range sensor tracks other bodies, m: past the stopping distance at
/// top speed and the few metres a unit looks ahead for another in its way, with room to
/// plan round one it meets.
pub const NEARBY_RANGE_M: f64 = 20.0;

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
        each("detections", &self.detections)?;
        max_len("nearby", &self.nearby, MAX_LIST)?;
        each("nearby", &self.nearby)?;
        match &self.thermal {
            Some(image) => image.validate().map_err(|e| e.within("thermal")),
            None => Ok(()),
        }
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
/// the ROBOGAT paper's terms (see `firefleet_agent::monorail::kinematics` for the frame).
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

#[cfg(test)]
mod tests {

    #[test]
    fn a_thermal_image_whose_buffers_do_not_match_its_size_or_whose_depth_is_no_depth_is_refused() {
        let good = ThermalImage {
            width: 4,
            height: 2,
            centikelvin: vec![29_315; 8],
            depth_m: vec![0.0, 1.5, 3.0, 0.0, 2.0, 2.0, 2.0, 2.0],
        };
        good.validate().unwrap();
        assert!((good.kelvin(1, 0) - 293.15).abs() < 1e-9);
        assert_eq!((good.depth(0, 0), good.depth(1, 0)), (None, Some(1.5)));
        let short = ThermalImage {
            centikelvin: vec![0; 7],
            ..good.clone()
        };
        let e = short.validate().unwrap_err();
        assert_eq!(e.field, "centikelvin");
        assert!(e.reason.contains("7 pixels for a 4x2 image"), "{e}");
        let mut nan = good.clone();
        nan.depth_m[5] = f32::NAN;
        assert_eq!(nan.validate().unwrap_err().field, "depth_m[5]");
        let huge = ThermalImage { width: 641, ..good };
        assert_eq!(huge.validate().unwrap_err().field, "width");
    }

    use super::*;

    #[test]
    fn depth_ignores_dropouts_and_outliers() {
        let at = |depth| FlameDetection {
            class: ObjectClass::Fire,
            confidence: 0.9,
            bbox: [0.0, 0.0, 1.0, 1.0],
            depth,
        };
        let mut w = [0.0f32; 25];
        for (i, z) in w.iter_mut().enumerate().take(12) {
            *z = 8.0 + 0.01 * i as f32;
        }
        w[12] = 80.0;
        let z = at(w).depth_m().unwrap();
        assert!((z - 8.065).abs() < 0.01, "{z}");
        assert_eq!(at([0.0; 25]).depth_m(), None);
        let mut sparse = [0.0f32; 25];
        sparse[..7].fill(5.0);
        assert_eq!(at(sparse).depth_m(), None, "fewer than a third valid");
    }
}
