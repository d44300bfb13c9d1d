//! A Foxglove 3D scene of the tunnel, built from what the fleet knows.
//!
//! Four layers, each its own topic so a viewer can switch them on and off:
//! - [`SITE_TOPIC`]: road, walls, rails and parked vehicles from the site file, drawn once;
//! - [`SCENE_TOPIC`]: units from their own state reports, fires from the coordinator's
//!   tracks, zones coloured by the commanders' goals in force ([`Fleet`], [`fleet_scene`]).
//!   With real robots this is all there is, so it never reads the simulator;
//! - [`HEAT_TOPIC`]: a `foxglove.Grid` of the radiant flux the fleet's fire tracks imply
//!   (the planners' model, [`heat_grid`]);
//! - [`INFRA_TOPIC`]: the tunnel's own senses from the SCADA bridge: each DTS zone a band
//!   under the ceiling coloured by its temperature (red in alarm, grey when stale), the
//!   air's direction and the fans ([`infra_scene`]). Foxglove's Plot panel plots the
//!   recorded zones themselves (`ff/<site>/infra/dts/<zone>`, `.reading.max_c`);
//! - [`TRUTH_TOPIC`]: the simulator's ground truth, for demos and experiments only.
//!
//! The messages are Foxglove's well-known `foxglove.SceneUpdate`, `foxglove.Grid` and
//! `foxglove.Log`, as JSON ([`foxglove`]).
//!
//! Not here: writing the file ([`crate::record`](mod@crate::record)) or serving it live
//! ([`crate::live`]).

use std::collections::BTreeMap;

use base64::Engine;
use base64::engine::general_purpose::STANDARD as BASE64;

use firefleet_model::UnitKind;
use firefleet_model::heat::{HeatSource, radiant_flux_kw_m2};
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::{Scenario, Tunnel};
use firefleet_model::{Chainage, FireId, Point2, UnitId};
use firefleet_protocol::msg::{
    DtsZone, FireState, FireTrack, GoalKind, GoalsInForce, SimTruth, TruthFireState, UnitMode,
    UnitState, Vent,
};

use firefleet_protocol::payload::Payload;

mod foxglove;
pub use foxglove::*;

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
        color: WHITE,
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

/// Road, walls, rails and parked vehicles: drawn once.
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

/// Units and fires as the simulator sees them now: the truth layer, beside the fleet's.
pub fn truth_scene(s: &Scenario, truth: &SimTruth, ts: Time) -> SceneUpdate {
    let mut entities = Vec::new();
    for u in &truth.units {
        let mut e = entity(format!("truth/unit/{}", u.id), ts);
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
        let mut e = entity(format!("truth/fire/{}", f.name), ts);
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

/// What the fleet knows, as a listener on the bus hears it: each unit's newest state and
/// whether its token is alive, each fire's newest track, the goals in force. Newest by the
/// sender's site time, so that a sample arriving late does not roll a unit back.
#[derive(Debug, Default)]
pub struct Fleet {
    units: BTreeMap<UnitId, UnitState>,
    /// Units whose liveliness token vanished: their last state stays, drawn as lost.
    gone: BTreeMap<UnitId, bool>,
    fires: BTreeMap<FireId, FireTrack>,
    goals: GoalsInForce,
    changed: bool,
    fires_changed: bool,
    /// The SCADA bridge's newest reading of each DTS zone, and of the ventilation.
    dts: BTreeMap<u16, DtsZone>,
    vent: Option<Vent>,
    infra_changed: bool,
}

impl Fleet {
    /// Take in a message; only unit states, fire tracks and goals in force matter here.
    pub fn observe(&mut self, p: &Payload) {
        match p {
            Payload::UnitState(s) if self.units.get(&s.unit).is_none_or(|o| o.t <= s.t) => {
                self.units.insert(s.unit.clone(), s.clone());
                self.changed = true;
            }
            Payload::Fire(f) if self.fires.get(&f.id).is_none_or(|o| o.t <= f.t) => {
                self.fires.insert(f.id, f.clone());
                self.changed = true;
                self.fires_changed = true;
            }
            Payload::Goals(g) if self.goals.t <= g.t => {
                self.changed |= self.goals.goals != g.goals;
                self.goals = g.clone();
            }
            Payload::Dts(z) if self.dts.get(&z.zone).is_none_or(|o| o.t <= z.t) => {
                self.infra_changed |= self.dts.insert(z.zone, *z).as_ref() != Some(z);
            }
            Payload::Vent(v) if self.vent.as_ref().is_none_or(|o| o.t <= v.t) => {
                self.infra_changed |= self.vent.as_ref() != Some(v);
                self.vent = Some(v.clone());
            }
            _ => {}
        }
    }

    /// A unit's liveliness token appeared or vanished.
    pub fn token(&mut self, unit: UnitId, alive: bool) {
        if self.gone.insert(unit, !alive) != Some(!alive) {
            self.changed = true;
        }
    }

    /// Whether the tunnel's senses changed since the last call (never, on a site without a
    /// SCADA bridge).
    pub fn take_infra_change(&mut self) -> bool {
        std::mem::take(&mut self.infra_changed)
    }

    /// Whether the SCADA bridge was ever heard.
    pub fn has_infra(&self) -> bool {
        !self.dts.is_empty() || self.vent.is_some()
    }

    /// Whether anything drawn changed since the last call, and whether the heat did.
    pub fn take_changes(&mut self) -> (bool, bool) {
        let changes = (self.changed, self.fires_changed);
        self.changed = false;
        self.fires_changed = false;
        changes
    }
}

const WHITE: Color = Color {
    r: 1.0,
    g: 1.0,
    b: 1.0,
    a: 1.0,
};

const fn rgba(r: f64, g: f64, b: f64, a: f64) -> Color {
    Color { r, g, b, a }
}

/// A zone's colour by the goal in force on it: keep-out is the one a commander must never
/// mistake, so it is the only opaque red.
fn zone_color(goal: Option<GoalKind>) -> Color {
    match goal {
        None => rgba(0.2, 0.5, 1.0, 0.12),
        Some(GoalKind::Extinguish) => rgba(1.0, 0.55, 0.0, 0.25),
        Some(GoalKind::Contain) => rgba(1.0, 0.85, 0.0, 0.3),
        Some(GoalKind::Monitor) => rgba(0.0, 0.8, 0.8, 0.25),
        Some(GoalKind::Evacuate) => rgba(0.6, 0.2, 0.9, 0.35),
        Some(GoalKind::KeepOut) => rgba(0.9, 0.0, 0.0, 0.6),
    }
}

fn fire_color(state: FireState) -> Color {
    match state {
        FireState::Tentative => rgba(1.0, 0.85, 0.0, 0.6),
        FireState::Confirmed | FireState::Assigned => rgba(1.0, 0.35, 0.0, 0.85),
        FireState::Suppressing => rgba(0.95, 0.45, 0.6, 0.85),
        FireState::Out => rgba(0.2, 0.2, 0.2, 0.8),
        FireState::Lost => rgba(0.5, 0.3, 0.6, 0.6),
    }
}

/// Units, fires and zones as the fleet knows them: the whole layer, each entity replacing
/// its previous self by id.
pub fn fleet_scene(s: &Scenario, fleet: &Fleet, ts: Time) -> SceneUpdate {
    let t = &s.tunnel;
    let mut entities = Vec::new();
    for z in &s.zones {
        // Of several goals on one zone the coordinator obeys the highest priority, then
        // the newest; the drawing says the same.
        let goal = fleet
            .goals
            .goals
            .iter()
            .filter(|g| g.goal.zone == z.id)
            .max_by(|a, b| {
                (a.goal.priority, a.since)
                    .partial_cmp(&(b.goal.priority, b.since))
                    .unwrap_or(std::cmp::Ordering::Equal)
            });
        let mut e = entity(format!("zone/{}", z.id), ts);
        e.cubes.extend(band(
            t,
            (z.start_m, z.end_m),
            (0.0, t.width_m),
            (0.01, 0.02),
            zone_color(goal.map(|g| g.goal.goal)),
        ));
        let text = match goal {
            Some(g) => format!("zone {}: {} (by {})", z.id, g.goal.goal, g.goal.issuer()),
            None => format!("zone {}", z.id),
        };
        let at = t.point_at(z.start_m.midpoint(z.end_m), t.width_m / 2.0);
        e.texts.push(label(at.x, at.y, 0.5, text));
        entities.push(e);
    }
    for u in fleet.units.values() {
        entities.push(unit_entity(
            s,
            u,
            fleet.gone.get(&u.unit) == Some(&true),
            ts,
        ));
    }
    for f in fleet.fires.values() {
        let mut e = entity(format!("fire/{}", f.id), ts);
        // Height grows with the log of the heat release: a 5 MW car and a 100 MW lorry
        // both read at a glance (1.9 m and 4.2 m) without the lorry hiding the tunnel.
        let h = match (f.state, f.hrr_kw) {
            (FireState::Out, _) => 0.05,
            (_, Some(q)) => 0.5 + 0.8 * (1.0 + q / 1000.0).ln(),
            (_, None) => 1.0,
        };
        // Two standard deviations of the track's position, at least half a metre.
        let r = 2.0 * f.cov[0].max(f.cov[2]).max(0.0).sqrt();
        let d = 2.0 * r.max(0.5);
        e.cylinders.push(CylinderPrimitive {
            pose: Pose::at(f.position.x, f.position.y, h / 2.0, 0.0),
            size: Vector3 { x: d, y: d, z: h },
            bottom_scale: 1.0,
            top_scale: if f.state == FireState::Out { 1.0 } else { 0.3 },
            color: fire_color(f.state),
        });
        let mut text = format!("{} {}", f.id, f.state);
        if let Some(q) = f.hrr_kw {
            text.push_str(&format!(" {:.1} MW", q / 1000.0));
        }
        if !f.assigned.is_empty() {
            let units: Vec<String> = f.assigned.iter().map(ToString::to_string).collect();
            text.push_str(&format!(" <- {}", units.join(", ")));
        }
        e.texts
            .push(label(f.position.x, f.position.y, h + 0.5, text));
        entities.push(e);
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// The tunnel's own senses: each DTS zone a band under the ceiling, from blue (ambient) to
/// yellow (60 C) and red at 300 C, red and labelled in alarm, grey while stale; the air
/// and each fan's state labelled at mid-tunnel.
pub fn infra_scene(s: &Scenario, fleet: &Fleet, ts: Time) -> SceneUpdate {
    let t = &s.tunnel;
    let mut entities = Vec::new();
    for z in fleet.dts.values() {
        let r = &z.reading;
        let color = if z.stale || r.fault {
            rgba(0.5, 0.5, 0.5, 0.5)
        } else if r.alarm.any() {
            rgba(1.0, 0.1, 0.0, 0.9)
        } else {
            let a = ((r.max_c - 20.0) / 280.0).clamp(0.0, 1.0);
            rgba(a.sqrt(), 0.8 * (1.0 - a), 1.0 - a, 0.6)
        };
        let mut e = entity(format!("dts/{}", z.zone), ts);
        let span = (Chainage::new(z.start_m), Chainage::new(z.end_m));
        e.cubes
            .extend(band(t, span, (0.0, 0.6), (t.height_m - 0.2, 0.15), color));
        if r.alarm.any() || z.stale {
            let at = t.point_at(span.0.midpoint(span.1), 0.0);
            let stale = if z.stale { " (stale)" } else { "" };
            e.texts.push(label(
                at.x,
                at.y,
                t.height_m + 0.3,
                format!(
                    "DTS {:.0}-{:.0} m: {:.0} C{stale}",
                    z.start_m, z.end_m, r.max_c
                ),
            ));
        }
        entities.push(e);
    }
    if let Some(v) = &fleet.vent {
        let [start, end] = s.portal_names();
        let air = if v.reading.air_m_s.abs() < 0.05 {
            "air still".to_owned()
        } else {
            let to = if v.reading.air_m_s > 0.0 { end } else { start };
            format!("air towards {to} at {:.1} m/s", v.reading.air_m_s.abs())
        };
        let stale = if v.stale { " (stale)" } else { "" };
        let mut e = entity("vent".into(), ts);
        let at = t.point_at(Chainage::new(t.length_m / 2.0), -t.width_m / 2.0);
        e.texts
            .push(label(at.x, at.y, t.height_m, format!("{air}{stale}")));
        let fans = s
            .ventilation
            .as_ref()
            .map(|v| v.fans.as_slice())
            .unwrap_or_default();
        for (f, state) in fans.iter().zip(&v.reading.fans) {
            let at = t.point_at(Chainage::new(f.chainage_m), 0.0);
            e.cylinders.push(CylinderPrimitive {
                pose: Pose::at(
                    at.x,
                    at.y,
                    t.height_m - 0.6,
                    t.heading_at(Chainage::new(f.chainage_m)),
                ),
                size: Vector3 {
                    x: 1.0,
                    y: 1.0,
                    z: 0.8,
                },
                bottom_scale: 1.0,
                top_scale: 1.0,
                color: rgba(0.7, 0.7, 0.8, 0.8),
            });
            e.texts.push(label(
                at.x,
                at.y,
                t.height_m - 1.2,
                format!("{} {state:?}", f.name),
            ));
        }
        entities.push(e);
    }
    SceneUpdate {
        deletions: Vec::new(),
        entities,
    }
}

/// A unit where it says it is: a ground vehicle on the road, a monorail carriage hanging
/// under its rail (the rail the site file gives it, else the nearest).
fn unit_entity(s: &Scenario, u: &UnitState, gone: bool, ts: Time) -> SceneEntity {
    let mut e = entity(format!("unit/{}", u.unit), ts);
    let color = if gone {
        rgba(0.5, 0.5, 0.5, 0.4)
    } else {
        match u.mode {
            UnitMode::Fault => rgba(0.9, 0.1, 0.1, 1.0),
            UnitMode::Extinguishing => rgba(0.1, 0.8, 1.0, 1.0),
            _ => rgba(0.1, 0.4, 0.9, 1.0),
        }
    };
    let p = u.pose;
    let (z, size) = match u.kind {
        UnitKind::Ground => (
            0.5,
            Vector3 {
                x: GROUND.length_m,
                y: GROUND.width_m,
                z: 1.0,
            },
        ),
        UnitKind::Monorail => {
            let named = s
                .units
                .iter()
                .find(|spec| spec.id == u.unit)
                .and_then(|spec| spec.rail.as_deref())
                .and_then(|id| s.rails.iter().find(|r| r.id == id));
            let rail = named.or_else(|| {
                s.rails
                    .iter()
                    .min_by(|a, b| (a.y_m - p.y).abs().total_cmp(&(b.y_m - p.y).abs()))
            });
            let height = rail.map_or(s.tunnel.height_m, |r| r.height_m);
            (
                height - 0.4,
                Vector3 {
                    x: 1.2,
                    y: 0.6,
                    z: 0.6,
                },
            )
        }
    };
    e.cubes.push(CubePrimitive {
        pose: Pose::at(p.x, p.y, z, p.yaw),
        size,
        color,
    });
    let mut text = format!("{} {}", u.unit, u.mode);
    if let Some(task) = &u.task {
        text.push_str(&format!(" on {}", task.fire));
    }
    text.push_str(&format!(" {:.0} L", u.water_l));
    if gone {
        text.push_str(" LOST");
    }
    e.texts.push(label(p.x, p.y, z + 1.1, text));
    e
}

/// At most this many cells in the heat grid: a 2 km tunnel at 1 m, a curved one coarser.
const MAX_HEAT_CELLS: f64 = 40_000.0;

/// The radiant flux, kW/m^2, that the fleet's fire tracks imply over the site (the
/// planners' model, [`radiant_flux_kw_m2`]): square cells of at least 0.5 m over the
/// tunnel's bounding box; cells outside the tunnel are 0.
pub fn heat_grid(s: &Scenario, fleet: &Fleet, ts: Time) -> Grid {
    let sources: Vec<HeatSource> = fleet
        .fires
        .values()
        .filter_map(FireTrack::heat_source)
        .collect();
    let t = &s.tunnel;
    let (lo, hi) = t.bounds();
    let (w, h) = ((hi.x - lo.x).max(0.5), (hi.y - lo.y).max(0.5));
    let cell = (w * h / MAX_HEAT_CELLS).sqrt().max(0.5);
    let (columns, rows) = ((w / cell).ceil() as u32, (h / cell).ceil() as u32);
    let mut bytes = Vec::with_capacity((columns * rows * 4) as usize);
    for i in 0..rows {
        for j in 0..columns {
            let p = Point2::new(
                lo.x + (j as f64 + 0.5) * cell,
                lo.y + (i as f64 + 0.5) * cell,
            );
            let q = if sources.is_empty() || !t.contains(p, 0.0) {
                0.0
            } else {
                radiant_flux_kw_m2(&sources, p)
            };
            bytes.extend_from_slice(&(q as f32).to_le_bytes());
        }
    }
    Grid {
        timestamp: ts,
        frame_id: FRAME.into(),
        pose: Pose::at(lo.x, lo.y, 0.05, 0.0),
        column_count: columns,
        cell_size: Vector2 { x: cell, y: cell },
        row_stride: columns * 4,
        cell_stride: 4,
        fields: vec![PackedElementField {
            name: "flux_kw_m2".into(),
            offset: 0,
            numeric_type: FLOAT32,
        }],
        data: BASE64.encode(bytes),
    }
}

#[cfg(test)]
mod tests;
