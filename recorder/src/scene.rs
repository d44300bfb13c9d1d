//! A Foxglove 3D scene of the tunnel, built from the site file and the simulator's truth.
//!
//! The types mirror the fields of Foxglove's well-known `foxglove.SceneUpdate` and
//! `foxglove.Log` messages that we use, serialised as JSON (Foxglove decodes JSON messages by schema name). Their JSON
//! Schemas are derived from these types.
//!
//! Not here: writing the file ([`crate::record`](mod@crate::record)).

use firefleet_protocol::Chainage;
use firefleet_protocol::msg::{Decision, GoalAck, SimTruth, TruthFireState};
use firefleet_protocol::scenario::{Scenario, Tunnel};
use schemars::JsonSchema;
use serde::Serialize;

/// Schema name Foxglove recognises.
pub const SCHEMA_NAME: &str = "foxglove.SceneUpdate";
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
    fn at(x: f64, y: f64, z: f64, yaw: f64) -> Self {
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

fn entity(id: String, ts: Time) -> SceneEntity {
    SceneEntity {
        timestamp: ts,
        frame_id: FRAME.into(),
        id,
        lifetime: Time { sec: 0, nsec: 0 },
        frame_locked: false,
        cubes: Vec::new(),
        cylinders: Vec::new(),
        texts: Vec::new(),
    }
}

fn label(x: f64, y: f64, z: f64, text: String) -> TextPrimitive {
    TextPrimitive {
        pose: Pose::at(x, y, z, 0.0),
        billboard: true,
        font_size: 14.0,
        scale_invariant: true,
        color: Color {
            r: 1.0,
            g: 1.0,
            b: 1.0,
            a: 1.0,
        },
        text,
    }
}

/// Boxes along the tunnel from chainage `s.0` to `s.1`, centred `d.0` off the centreline
/// and `d.1` wide, centred `z.0` above the road and `z.1` tall: one box in a straight
/// tunnel, pieces of at most 2 m round a curve.
fn band(
    t: &Tunnel,
    s: (Chainage, Chainage),
    d: (f64, f64),
    z: (f64, f64),
    color: Color,
) -> impl Iterator<Item = CubePrimitive> + '_ {
    let n = if t.is_straight() {
        1
    } else {
        ((s.1 - s.0) / 2.0).ceil().max(1.0) as usize
    };
    let piece = (s.1 - s.0) / n as f64;
    (0..n).map(move |k| {
        let mid = s.0 + (k as f64 + 0.5) * piece;
        let at = t.point_at(mid, d.0);
        CubePrimitive {
            pose: Pose::at(at.x, at.y, z.0, t.heading_at(mid)),
            size: Vector3 {
                x: piece,
                y: d.1,
                z: z.1,
            },
            color,
        }
    })
}

/// Road, walls and parked vehicles: drawn once.
pub fn static_scene(s: &Scenario, ts: Time) -> SceneUpdate {
    let t = &s.tunnel;
    let mut tunnel = entity("tunnel".into(), ts);
    let grey = |a| Color {
        r: 0.5,
        g: 0.5,
        b: 0.55,
        a,
    };
    tunnel.cubes.extend(band(
        t,
        (Chainage::ZERO, t.end()),
        (0.0, t.width_m),
        (-0.05, 0.1),
        grey(1.0),
    ));
    for side in [-1.0, 1.0] {
        tunnel.cubes.extend(band(
            t,
            (Chainage::ZERO, t.end()),
            (side * (t.width_m / 2.0 + 0.1), 0.2),
            (t.height_m / 2.0, t.height_m),
            grey(0.25),
        ));
    }
    let mut entities = vec![tunnel];
    for o in &s.obstacles {
        let mut e = entity(format!("obstacle/{}", o.name), ts);
        e.cubes.push(CubePrimitive {
            pose: Pose::at(o.x_m, o.y_m, o.height_m / 2.0, o.yaw_rad),
            size: Vector3 {
                x: o.length_m,
                y: o.width_m,
                z: o.height_m,
            },
            color: Color {
                r: 0.3,
                g: 0.35,
                b: 0.4,
                a: 1.0,
            },
        });
        entities.push(e);
    }
    for z in &s.zones {
        let mut e = entity(format!("zone/{}", z.id), ts);
        let mid = z.start_m.midpoint(z.end_m);
        e.cubes.extend(band(
            t,
            (z.start_m, z.end_m),
            (0.0, t.width_m),
            (0.01, 0.02),
            Color {
                r: 0.2,
                g: 0.5,
                b: 1.0,
                a: 0.15,
            },
        ));
        let at = t.point_at(mid, t.width_m / 2.0);
        e.texts
            .push(label(at.x, at.y, 0.5, format!("zone {}", z.id)));
        entities.push(e);
    }
    for r in &s.rails {
        let mut e = entity(format!("rail/{}", r.id), ts);
        e.cubes.push(CubePrimitive {
            pose: Pose::at((r.start_m + r.end_m) / 2.0, r.y_m, r.height_m + 0.1, 0.0),
            size: Vector3 {
                x: r.end_m - r.start_m,
                y: 0.15,
                z: 0.15,
            },
            color: grey(1.0),
        });
        entities.push(e);
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// Units and fires as the simulator sees them now.
pub fn truth_scene(s: &Scenario, truth: &SimTruth, ts: Time) -> SceneUpdate {
    let mut entities = Vec::new();
    for u in &truth.units {
        let mut e = entity(format!("unit/{}", u.id), ts);
        e.cubes.push(CubePrimitive {
            pose: Pose::at(u.pose.x, u.pose.y, 0.5, u.pose.yaw),
            size: Vector3 {
                x: 1.6,
                y: 1.0,
                z: 1.0,
            },
            color: Color {
                r: 0.1,
                g: 0.4,
                b: 0.9,
                a: 1.0,
            },
        });
        e.texts
            .push(label(u.pose.x, u.pose.y, 1.6, u.id.to_string()));
        entities.push(e);
    }
    for (f, spec) in truth.fires.iter().zip(&s.fires) {
        let mut e = entity(format!("fire/{}", f.name), ts);
        let burning = f.state == TruthFireState::Burning;
        let h = if burning {
            0.5 + 3.0 * (f.hrr_kw / spec.peak_kw).min(1.0)
        } else {
            0.05
        };
        let color = if burning {
            Color {
                r: 1.0,
                g: 0.35,
                b: 0.0,
                a: 0.8,
            }
        } else {
            Color {
                r: 0.2,
                g: 0.2,
                b: 0.2,
                a: 0.8,
            }
        };
        e.cylinders.push(CylinderPrimitive {
            pose: Pose::at(f.position.x, f.position.y, h / 2.0, 0.0),
            size: Vector3 {
                x: 2.0 * spec.radius_m,
                y: 2.0 * spec.radius_m,
                z: h,
            },
            bottom_scale: 1.0,
            top_scale: if burning { 0.3 } else { 1.0 },
            color,
        });
        e.texts.push(label(
            f.position.x,
            f.position.y,
            h + 0.5,
            format!("{} {:.0} kW", f.name, f.hrr_kw),
        ));
        entities.push(e);
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}
