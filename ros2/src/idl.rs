//! The message definitions firefleet speaks, and their REP-2011 type hashes.
//!
//! rmw_zenoh puts a type's hash in every key expression (`RIHS01_<sha256>`), so a publisher
//! and a subscription whose definitions differ never meet. The hash is not a checksum of
//! the `.msg` text: `rosidl_generator_type_description` turns a definition into a
//! `type_description_interfaces/TypeDescription` (the type's fields, each with a numeric
//! field type, array capacity, string capacity and nested type name; then every type it
//! references, sorted by name), drops default values, writes that as JSON with `", "` and
//! `": "` separators in declaration order, and hashes the UTF-8 bytes with SHA-256. We do
//! the same from the definitions below, so a hash is derived, never pasted: the tests
//! compare it with the hashes rmw_zenoh's design document and the Python `rosbags`
//! package give.
//!
//! The definitions are the fields of the upstream `.msg` files (comments and constants
//! left out: neither enters the hash) of ROS 2 Jazzy's `common_interfaces` and
//! `vision_msgs` 4.1 (the `ros2` branch, Humble onwards), whose `Detection3D` ends in
//! `string id`, not ROS 1's `source_cloud`/`tracking_id`.
//!
//! Not here: encoding values of these types ([`crate::msg`], [`crate::cdr`]).

use std::collections::BTreeMap;
use std::fmt::Write as _;

use sha2::{Digest, Sha256};

/// Why a definition could not be turned into a type description.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum IdlError {
    #[error("no definition of {0} is known")]
    Unknown(String),
    #[error("{ty}, line {line}: {reason}")]
    Syntax {
        ty: String,
        line: usize,
        reason: String,
    },
}

/// `(type name, fields)` of every message firefleet publishes or takes, and everything
/// they reference.
const DEFINITIONS: &[(&str, &str)] = &[
    ("builtin_interfaces/msg/Time", "int32 sec\nuint32 nanosec"),
    (
        "builtin_interfaces/msg/Duration",
        "int32 sec\nuint32 nanosec",
    ),
    (
        "std_msgs/msg/Header",
        "builtin_interfaces/Time stamp\nstring frame_id",
    ),
    ("std_msgs/msg/Bool", "bool data"),
    ("std_msgs/msg/Float64", "float64 data"),
    ("std_msgs/msg/String", "string data"),
    (
        "std_msgs/msg/MultiArrayDimension",
        "string label\nuint32 size\nuint32 stride",
    ),
    (
        "std_msgs/msg/MultiArrayLayout",
        "MultiArrayDimension[] dim\nuint32 data_offset",
    ),
    (
        "std_msgs/msg/Float64MultiArray",
        "MultiArrayLayout layout\nfloat64[] data",
    ),
    ("geometry_msgs/msg/Point", "float64 x\nfloat64 y\nfloat64 z"),
    (
        "geometry_msgs/msg/Vector3",
        "float64 x\nfloat64 y\nfloat64 z",
    ),
    (
        "geometry_msgs/msg/Quaternion",
        "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    ),
    (
        "geometry_msgs/msg/Pose",
        "Point position\nQuaternion orientation",
    ),
    (
        "geometry_msgs/msg/PoseWithCovariance",
        "Pose pose\nfloat64[36] covariance",
    ),
    ("geometry_msgs/msg/Twist", "Vector3 linear\nVector3 angular"),
    (
        "geometry_msgs/msg/TwistStamped",
        "std_msgs/Header header\nTwist twist",
    ),
    (
        "geometry_msgs/msg/TwistWithCovariance",
        "Twist twist\nfloat64[36] covariance",
    ),
    (
        "nav_msgs/msg/Odometry",
        "std_msgs/Header header\nstring child_frame_id\n\
         geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist",
    ),
    (
        "sensor_msgs/msg/JointState",
        "std_msgs/Header header\nstring[] name\nfloat64[] position\nfloat64[] velocity\n\
         float64[] effort",
    ),
    (
        "sensor_msgs/msg/Temperature",
        "std_msgs/Header header\nfloat64 temperature\nfloat64 variance",
    ),
    (
        "trajectory_msgs/msg/JointTrajectoryPoint",
        "float64[] positions\nfloat64[] velocities\nfloat64[] accelerations\nfloat64[] effort\n\
         builtin_interfaces/Duration time_from_start",
    ),
    (
        "trajectory_msgs/msg/JointTrajectory",
        "std_msgs/Header header\nstring[] joint_names\nJointTrajectoryPoint[] points",
    ),
    (
        "sensor_msgs/msg/Image",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\n\
         uint8 is_bigendian\nuint32 step\nuint8[] data",
    ),
    (
        "sensor_msgs/msg/RegionOfInterest",
        "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify",
    ),
    (
        "sensor_msgs/msg/CameraInfo",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\n\
         float64[] d\nfloat64[9] k\nfloat64[9] r\nfloat64[12] p\nuint32 binning_x\n\
         uint32 binning_y\nRegionOfInterest roi",
    ),
    (
        "vision_msgs/msg/ObjectHypothesis",
        "string class_id\nfloat64 score",
    ),
    (
        "vision_msgs/msg/ObjectHypothesisWithPose",
        "ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose",
    ),
    (
        "vision_msgs/msg/BoundingBox3D",
        "geometry_msgs/Pose center\ngeometry_msgs/Vector3 size",
    ),
    (
        "vision_msgs/msg/Detection3D",
        "std_msgs/Header header\nObjectHypothesisWithPose[] results\nBoundingBox3D bbox\n\
         string id",
    ),
    (
        "vision_msgs/msg/Detection3DArray",
        "std_msgs/Header header\nDetection3D[] detections",
    ),
];

/// `type_description_interfaces/msg/FieldType` ids of the primitive types.
const PRIMITIVES: &[(&str, u8)] = &[
    ("int8", 2),
    ("uint8", 3),
    ("int16", 4),
    ("uint16", 5),
    ("int32", 6),
    ("uint32", 7),
    ("int64", 8),
    ("uint64", 9),
    ("float32", 10),
    ("float64", 11),
    ("char", 13),
    ("bool", 15),
    ("byte", 16),
    ("string", 17),
    ("wstring", 18),
];
const NESTED_TYPE: u8 = 1;
const BOUNDED_STRING: u8 = 21;
/// Offsets added to a field type for a fixed array, a bounded and an unbounded sequence.
const ARRAY: u8 = 48;
const BOUNDED_SEQUENCE: u8 = 96;
const UNBOUNDED_SEQUENCE: u8 = 144;

/// One field of a type description.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Field {
    pub name: String,
    pub type_id: u8,
    pub capacity: u64,
    pub string_capacity: u64,
    /// `pkg/msg/Type` for a nested type, empty otherwise.
    pub nested_type_name: String,
}

/// The fields of `ty` (`pkg/msg/Type`) from its definition.
pub fn fields(ty: &str) -> Result<Vec<Field>, IdlError> {
    let text = DEFINITIONS
        .iter()
        .find(|(name, _)| *name == ty)
        .map(|(_, text)| *text)
        .ok_or_else(|| IdlError::Unknown(ty.to_owned()))?;
    let package = ty.split('/').next().unwrap_or_default();
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.split('#').next().unwrap_or_default().trim();
        if line.is_empty() {
            continue;
        }
        let syntax = |reason: &str| IdlError::Syntax {
            ty: ty.to_owned(),
            line: i + 1,
            reason: reason.to_owned(),
        };
        let mut words = line.split_whitespace();
        let (Some(type_spec), Some(name)) = (words.next(), words.next()) else {
            return Err(syntax("expected '<type> <name> [default]'"));
        };
        if name.contains('=') {
            continue; // a constant: not part of the type description's fields
        }
        out.push(parse_field(type_spec, name, package).map_err(|r| syntax(&r))?);
    }
    Ok(out)
}

fn parse_field(type_spec: &str, name: &str, package: &str) -> Result<Field, String> {
    let (base, array) = match type_spec.split_once('[') {
        Some((base, rest)) => {
            let inner = rest
                .strip_suffix(']')
                .ok_or_else(|| format!("'{type_spec}': unclosed '['"))?;
            (base, Some(inner))
        }
        None => (type_spec, None),
    };
    let number = |s: &str| {
        s.parse::<u64>()
            .map_err(|_| format!("'{type_spec}': '{s}' is not a size"))
    };
    let (base, string_capacity) = match base.split_once("<=") {
        Some((b, n)) => (b, number(n)?),
        None => (base, 0),
    };
    let (mut type_id, nested_type_name) = match PRIMITIVES
        .iter()
        .find(|(p, _)| *p == base)
        .map(|(_, id)| *id)
    {
        Some(17) if string_capacity > 0 => (BOUNDED_STRING, String::new()),
        Some(id) => (id, String::new()),
        None => {
            let qualified = match base.split_once('/') {
                Some((pkg, ty)) => format!("{pkg}/msg/{ty}"),
                None => format!("{package}/msg/{base}"),
            };
            (NESTED_TYPE, qualified)
        }
    };
    let capacity = match array {
        None => 0,
        Some("") => {
            type_id += UNBOUNDED_SEQUENCE;
            0
        }
        Some(inner) => match inner.strip_prefix("<=") {
            Some(n) => {
                type_id += BOUNDED_SEQUENCE;
                number(n)?
            }
            None => {
                type_id += ARRAY;
                number(inner)?
            }
        },
    };
    Ok(Field {
        name: name.to_owned(),
        type_id,
        capacity,
        string_capacity,
        nested_type_name,
    })
}

/// The JSON `rosidl` hashes for `ty`: its description, then every type it references,
/// each once, sorted by name.
pub fn hashable_json(ty: &str) -> Result<String, IdlError> {
    let own = fields(ty)?;
    let mut referenced = BTreeMap::new();
    let mut pending: Vec<String> = nested(&own);
    while let Some(name) = pending.pop() {
        if referenced.contains_key(&name) {
            continue;
        }
        let f = fields(&name)?;
        pending.extend(nested(&f));
        referenced.insert(name, f);
    }
    let mut json = String::from("{\"type_description\": ");
    describe(&mut json, ty, &own);
    json.push_str(", \"referenced_type_descriptions\": [");
    for (i, (name, f)) in referenced.iter().enumerate() {
        if i > 0 {
            json.push_str(", ");
        }
        describe(&mut json, name, f);
    }
    json.push_str("]}");
    Ok(json)
}

fn nested(fields: &[Field]) -> Vec<String> {
    fields
        .iter()
        .filter(|f| !f.nested_type_name.is_empty())
        .map(|f| f.nested_type_name.clone())
        .collect()
}

fn describe(json: &mut String, ty: &str, fields: &[Field]) {
    // Names are `[A-Za-z0-9_/]`: nothing in them needs escaping.
    let _ = write!(json, "{{\"type_name\": \"{ty}\", \"fields\": [");
    for (i, f) in fields.iter().enumerate() {
        if i > 0 {
            json.push_str(", ");
        }
        let _ = write!(
            json,
            "{{\"name\": \"{}\", \"type\": {{\"type_id\": {}, \"capacity\": {}, \
             \"string_capacity\": {}, \"nested_type_name\": \"{}\"}}}}",
            f.name, f.type_id, f.capacity, f.string_capacity, f.nested_type_name
        );
    }
    json.push_str("]}");
}

/// The REP-2011 hash of `ty`, as rmw_zenoh writes it in keys: `RIHS01_<64 hex digits>`.
pub fn type_hash(ty: &str) -> Result<String, IdlError> {
    let digest = Sha256::digest(hashable_json(ty)?.as_bytes());
    let mut out = String::from("RIHS01_");
    for b in digest {
        let _ = write!(out, "{b:02x}");
    }
    Ok(out)
}

/// Every type with a definition here.
pub fn known_types() -> impl Iterator<Item = &'static str> {
    DEFINITIONS.iter().map(|(name, _)| *name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hashes_match_the_ones_rmw_zenoh_documents() {
        // docs/design.md of ros2/rmw_zenoh: the `chatter` topic's key.
        assert_eq!(
            type_hash("std_msgs/msg/String").unwrap(),
            "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
        );
    }

    #[test]
    fn nested_and_array_fields_are_described() {
        let f = fields("geometry_msgs/msg/PoseWithCovariance").unwrap();
        assert_eq!(f[0].type_id, NESTED_TYPE);
        assert_eq!(f[0].nested_type_name, "geometry_msgs/msg/Pose");
        assert_eq!((f[1].type_id, f[1].capacity), (11 + ARRAY, 36));
        let j = fields("sensor_msgs/msg/JointState").unwrap();
        assert_eq!(j[1].type_id, 17 + UNBOUNDED_SEQUENCE);
        assert_eq!(j[0].nested_type_name, "std_msgs/msg/Header");
        let q = fields("geometry_msgs/msg/Quaternion").unwrap();
        assert_eq!(q.len(), 4, "default values are not fields");
        let b = parse_field("string<=8[<=3]", "names", "p").unwrap();
        assert_eq!(
            (b.type_id, b.capacity, b.string_capacity),
            (BOUNDED_STRING + BOUNDED_SEQUENCE, 3, 8)
        );
    }

    #[test]
    fn referenced_types_are_listed_once_and_sorted() {
        let json = hashable_json("nav_msgs/msg/Odometry").unwrap();
        let names: Vec<&str> = json
            .match_indices("\"type_name\": \"")
            .map(|(i, m)| {
                let rest = &json[i + m.len()..];
                &rest[..rest.find('"').unwrap()]
            })
            .collect();
        assert_eq!(names[0], "nav_msgs/msg/Odometry");
        let refs = &names[1..];
        assert!(refs.windows(2).all(|w| w[0] < w[1]), "{refs:?}");
        assert_eq!(refs.len(), 9, "{refs:?}");
    }

    #[test]
    fn every_definition_parses() {
        for ty in known_types() {
            type_hash(ty).unwrap_or_else(|e| panic!("{ty}: {e}"));
        }
        assert!(matches!(
            type_hash("std_msgs/msg/Nope"),
            Err(IdlError::Unknown(_))
        ));
    }
}
