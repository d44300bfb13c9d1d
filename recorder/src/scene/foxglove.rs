//! The Foxglove messages the scene is written as: the fields of Foxglove's well-known
//! `foxglove.SceneUpdate`, `foxglove.Grid` and `foxglove.Log` that we use, with the topics
//! and schema names Foxglove knows them by. Serialised as JSON (Foxglove decodes JSON
//! messages by schema name); their JSON Schemas are derived from these types.

use firefleet_protocol::msg::{Decision, GoalAck};
use schemars::JsonSchema;
use serde::Serialize;

/// Schema name Foxglove recognises.
pub const SCHEMA_NAME: &str = "foxglove.SceneUpdate";
/// Schema name of Foxglove's grid message.
pub const GRID_SCHEMA_NAME: &str = "foxglove.Grid";
/// The site's fixed geometry.
pub const SITE_TOPIC: &str = "/scene/site";
/// Units, fires and zones as the fleet knows them.
pub const SCENE_TOPIC: &str = "/scene";
/// The heat field the fleet's fire tracks imply.
pub const HEAT_TOPIC: &str = "/heat";
/// The simulator's ground truth.
pub const TRUTH_TOPIC: &str = "/truth/scene";
/// The tunnel's own senses: DTS zones under the ceiling, the air and the fans.
pub const INFRA_TOPIC: &str = "/scene/tunnel";
/// Coordinator decisions and goal answers.
pub const LOG_TOPIC: &str = "/log";
/// The frame every entity is drawn in.
pub const FRAME: &str = "site";

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Time {
    pub sec: u32,
    pub nsec: u32,
}

impl Time {
    pub fn from_nanos(ns: u64) -> Self {
        Self {
            sec: (ns / 1_000_000_000) as u32,
            nsec: (ns % 1_000_000_000) as u32,
        }
    }
}

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Vector3 {
    pub x: f64,
    pub y: f64,
    pub z: f64,
}

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Quaternion {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub w: f64,
}

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Pose {
    pub position: Vector3,
    pub orientation: Quaternion,
}

impl Pose {
    pub(super) fn at(x: f64, y: f64, z: f64, yaw: f64) -> Self {
        let (s, c) = (yaw / 2.0).sin_cos();
        Self {
            position: Vector3 { x, y, z },
            orientation: Quaternion {
                x: 0.0,
                y: 0.0,
                z: s,
                w: c,
            },
        }
    }
}

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Color {
    pub r: f64,
    pub g: f64,
    pub b: f64,
    pub a: f64,
}

#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct CubePrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub color: Color,
}

#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct CylinderPrimitive {
    pub pose: Pose,
    pub size: Vector3,
    pub bottom_scale: f64,
    pub top_scale: f64,
    pub color: Color,
}

#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct TextPrimitive {
    pub pose: Pose,
    pub billboard: bool,
    pub font_size: f64,
    pub scale_invariant: bool,
    pub color: Color,
    pub text: String,
}

#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct SceneEntity {
    pub timestamp: Time,
    pub frame_id: String,
    pub id: String,
    /// Zero: the entity stays until replaced.
    pub lifetime: Time,
    pub frame_locked: bool,
    pub cubes: Vec<CubePrimitive>,
    pub cylinders: Vec<CylinderPrimitive>,
    pub texts: Vec<TextPrimitive>,
}

#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct SceneUpdate {
    pub deletions: Vec<serde_json::Value>,
    pub entities: Vec<SceneEntity>,
}

/// Schema name of Foxglove's log message.
pub const LOG_SCHEMA_NAME: &str = "foxglove.Log";

/// A `foxglove.Log` entry (level 2 is INFO).
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct Log {
    pub timestamp: Time,
    pub level: u8,
    pub message: String,
    pub name: String,
    pub file: String,
    pub line: u32,
}

impl Log {
    /// An INFO entry from `name` for a coordinator decision, stamped with site time.
    pub fn info(name: &str, d: &Decision, recorded: Time) -> Self {
        Self::new(2, name, format!("[t={:.1} s] {}", d.t, d.text), recorded)
    }

    /// The coordinator's answer to a zone goal: INFO if accepted, WARNING if not.
    pub fn ack(a: &GoalAck, recorded: Time) -> Self {
        let verdict = if a.accepted { "accepted" } else { "rejected" };
        Self::new(
            if a.accepted { 2 } else { 3 },
            "coordinator",
            format!("goal '{}' on zone {} {verdict}: {}", a.id, a.zone, a.reason),
            recorded,
        )
    }

    fn new(level: u8, name: &str, message: String, recorded: Time) -> Self {
        Self {
            timestamp: recorded,
            level,
            message,
            name: name.to_owned(),
            file: String::new(),
            line: 0,
        }
    }
}

#[derive(Debug, Clone, Copy, Serialize, JsonSchema)]
pub struct Vector2 {
    pub x: f64,
    pub y: f64,
}

/// One field of a grid cell (`foxglove.PackedElementField`).
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct PackedElementField {
    pub name: String,
    pub offset: u32,
    /// `foxglove.NumericType`: 7 is FLOAT32.
    #[serde(rename = "type")]
    pub numeric_type: u8,
}

pub(super) const FLOAT32: u8 = 7;

/// A raster over the site (`foxglove.Grid`): cell (column `j`, row `i`) has its corner at
/// `pose` + (`j`, `i`) * `cell_size`; rows follow the site's y axis.
#[derive(Debug, Clone, Serialize, JsonSchema)]
pub struct Grid {
    pub timestamp: Time,
    pub frame_id: String,
    pub pose: Pose,
    pub column_count: u32,
    pub cell_size: Vector2,
    pub row_stride: u32,
    pub cell_stride: u32,
    pub fields: Vec<PackedElementField>,
    /// The cells, little-endian, base64 as Foxglove's JSON encoding of bytes.
    pub data: String,
}
