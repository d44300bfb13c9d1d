//! The ROS 2 messages firefleet speaks, as Rust values that encode to CDR field by field.
//!
//! Each struct lists its fields in the order of its definition in [`crate::idl`]: CDR has
//! no field names, so order is the format. Fixed arrays of more than 32 elements
//! (covariances) need their own (de)serializer, since serde stops at 32.
//!
//! Not here: what firefleet puts in them ([`crate::ground`]).

use serde::de::{Error as _, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// A ROS 2 message type: its `pkg/msg/Type` name, from which the DDS name in keys and the
/// type hash follow.
pub trait RosMessage: Serialize + for<'de> Deserialize<'de> + Send + 'static {
    const TYPE: &'static str;
}

/// The name DDS and rmw_zenoh use for `pkg/msg/Type`: `pkg::msg::dds_::Type_`.
pub fn dds_type_name(ty: &str) -> String {
    let mut parts = ty.split('/');
    let (pkg, kind, name) = (
        parts.next().unwrap_or_default(),
        parts.next().unwrap_or_default(),
        parts.next().unwrap_or_default(),
    );
    format!("{pkg}::{kind}::dds_::{name}_")
}

macro_rules! ros_message {
    ($ty:ident, $name:literal) => {
        impl RosMessage for $ty {
            const TYPE: &'static str = $name;
        }
    };
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Time {
    pub sec: i32,
    pub nanosec: u32,
}

impl Time {
    /// `t` seconds (non-negative; sim time or since the epoch).
    pub fn from_secs(t: f64) -> Self {
        let t = t.max(0.0);
        let sec = t.floor();
        // Rounding can carry the nanoseconds to a full second.
        let nanosec = (((t - sec) * 1e9).round() as u32).min(999_999_999);
        Self {
            sec: sec.min(f64::from(i32::MAX)) as i32,
            nanosec,
        }
    }
    pub fn secs(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

/// `builtin_interfaces/Duration`: a span of time, as `Time` splits it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Duration {
    pub sec: i32,
    pub nanosec: u32,
}

impl Duration {
    /// `t` seconds (non-negative).
    pub fn from_secs(t: f64) -> Self {
        let Time { sec, nanosec } = Time::from_secs(t);
        Self { sec, nanosec }
    }
    pub fn secs(&self) -> f64 {
        Time {
            sec: self.sec,
            nanosec: self.nanosec,
        }
        .secs()
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}

impl Header {
    pub fn new(t: f64, frame_id: impl Into<String>) -> Self {
        Self {
            stamp: Time::from_secs(t),
            frame_id: frame_id.into(),
        }
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Bool {
    pub data: bool,
}
ros_message!(Bool, "std_msgs/msg/Bool");

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64 {
    pub data: f64,
}
ros_message!(Float64, "std_msgs/msg/Float64");

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayDimension {
    pub label: String,
    pub size: u32,
    pub stride: u32,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MultiArrayLayout {
    pub dim: Vec<MultiArrayDimension>,
    pub data_offset: u32,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Float64MultiArray {
    pub layout: MultiArrayLayout,
    pub data: Vec<f64>,
}
ros_message!(Float64MultiArray, "std_msgs/msg/Float64MultiArray");

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Point {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

impl Default for Quaternion {
    fn default() -> Self {
        Self::from_yaw(0.0)
    }
}

impl Quaternion {
    /// A rotation by `yaw` about z.
    pub fn from_yaw(yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Self {
            x: 0.0,
            y: 0.0,
            z: s,
            w: c,
        }
    }
    /// The heading of this rotation: the yaw of its x axis projected on the ground plane.
    pub fn yaw(&self) -> f64 {
        let Self { x, y, z, w } = *self;
        (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z))
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub position: Point,
    pub orientation: Quaternion,
}

/// A row-major 6x6 covariance (x, y, z, rotation about x, y, z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Covariance(pub [f64; 36]);

impl Default for Covariance {
    fn default() -> Self {
        Self([0.0; 36])
    }
}

impl Covariance {
    /// Variances on the diagonal, nothing correlated.
    pub fn diagonal(d: [f64; 6]) -> Self {
        let mut c = [0.0; 36];
        for (i, v) in d.into_iter().enumerate() {
            c[i * 7] = v;
        }
        Self(c)
    }

    /// The variance of the `i`-th of x, y, z, roll, pitch, yaw (row-major diagonal).
    pub fn variance(&self, i: usize) -> f64 {
        self.0[i * 7]
    }
}

impl Serialize for Covariance {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        // A fixed array: CDR writes its elements with no length.
        let mut t = s.serialize_tuple(36)?;
        for v in &self.0 {
            t.serialize_element(v)?;
        }
        t.end()
    }
}

impl<'de> Deserialize<'de> for Covariance {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Covariance;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("36 float64")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Covariance, A::Error> {
                let mut c = [0.0; 36];
                for (i, slot) in c.iter_mut().enumerate() {
                    *slot = seq
                        .next_element()?
                        .ok_or_else(|| A::Error::invalid_length(i, &self))?;
                }
                Ok(Covariance(c))
            }
        }
        d.deserialize_tuple(36, V)
    }
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    pub pose: Pose,
    pub covariance: Covariance,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Twist {
    pub linear: Vector3,
    pub angular: Vector3,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistStamped {
    pub header: Header,
    pub twist: Twist,
}
ros_message!(TwistStamped, "geometry_msgs/msg/TwistStamped");

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct TwistWithCovariance {
    pub twist: Twist,
    pub covariance: Covariance,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Odometry {
    pub header: Header,
    pub child_frame_id: String,
    pub pose: PoseWithCovariance,
    pub twist: TwistWithCovariance,
}
ros_message!(Odometry, "nav_msgs/msg/Odometry");

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    pub header: Header,
    pub name: Vec<String>,
    pub position: Vec<f64>,
    pub velocity: Vec<f64>,
    pub effort: Vec<f64>,
}
ros_message!(JointState, "sensor_msgs/msg/JointState");

impl JointState {
    /// The position of joint `name`, if the message has one.
    pub fn position_of(&self, name: &str) -> Option<f64> {
        let i = self.name.iter().position(|n| n == name)?;
        self.position.get(i).copied()
    }

    /// The velocity of joint `name`, if the message has one.
    pub fn velocity_of(&self, name: &str) -> Option<f64> {
        let i = self.name.iter().position(|n| n == name)?;
        self.velocity.get(i).copied()
    }
}

/// `sensor_msgs/Temperature`: degrees Celsius, and the variance (0: unknown).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Temperature {
    pub header: Header,
    pub temperature: f64,
    pub variance: f64,
}
ros_message!(Temperature, "sensor_msgs/msg/Temperature");

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectoryPoint {
    pub positions: Vec<f64>,
    pub velocities: Vec<f64>,
    pub accelerations: Vec<f64>,
    pub effort: Vec<f64>,
    pub time_from_start: Duration,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointTrajectory {
    pub header: Header,
    pub joint_names: Vec<String>,
    pub points: Vec<JointTrajectoryPoint>,
}
ros_message!(JointTrajectory, "trajectory_msgs/msg/JointTrajectory");

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Image {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub encoding: String,
    pub is_bigendian: u8,
    /// Bytes a row.
    pub step: u32,
    #[serde(with = "crate::cdr::octets")]
    pub data: Vec<u8>,
}
ros_message!(Image, "sensor_msgs/msg/Image");

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionOfInterest {
    pub x_offset: u32,
    pub y_offset: u32,
    pub height: u32,
    pub width: u32,
    pub do_rectify: bool,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraInfo {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub distortion_model: String,
    pub d: Vec<f64>,
    /// Intrinsics, row-major: `[fx 0 cx; 0 fy cy; 0 0 1]`.
    pub k: [f64; 9],
    pub r: [f64; 9],
    pub p: [f64; 12],
    pub binning_x: u32,
    pub binning_y: u32,
    pub roi: RegionOfInterest,
}
ros_message!(CameraInfo, "sensor_msgs/msg/CameraInfo");

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectHypothesis {
    pub class_id: String,
    pub score: f64,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectHypothesisWithPose {
    pub hypothesis: ObjectHypothesis,
    pub pose: PoseWithCovariance,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct BoundingBox3D {
    pub center: Pose,
    pub size: Vector3,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Detection3D {
    pub header: Header,
    pub results: Vec<ObjectHypothesisWithPose>,
    pub bbox: BoundingBox3D,
    pub id: String,
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Detection3DArray {
    pub header: Header,
    pub detections: Vec<Detection3D>,
}
ros_message!(Detection3DArray, "vision_msgs/msg/Detection3DArray");

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dds_names() {
        assert_eq!(
            dds_type_name("std_msgs/msg/String"),
            "std_msgs::msg::dds_::String_"
        );
    }

    #[test]
    fn yaw_survives_a_quaternion() {
        for k in -31..=31 {
            let yaw = k as f64 * 0.1;
            assert!(
                (Quaternion::from_yaw(yaw).yaw() - yaw).abs() < 1e-12,
                "{yaw}"
            );
        }
    }

    #[test]
    fn time_splits_seconds() {
        let t = Time::from_secs(12.25);
        assert_eq!((t.sec, t.nanosec), (12, 250_000_000));
        assert_eq!(Time::from_secs(0.999_999_999_9).nanosec, 999_999_999);
        assert!((Time::from_secs(3.5).secs() - 3.5).abs() < 1e-9);
    }
}
