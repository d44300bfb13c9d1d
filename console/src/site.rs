//! The tunnel drawn to scale: the site file turned into polylines and polygons in the
//! site frame (metres), which the page only has to draw.
//!
//! A curved tunnel is sampled along its centreline (at most [`MAX_STATIONS`] stations, at
//! least one a metre for short tunnels), so the page needs no tunnel geometry of its own
//! and draws a bend the way the planners see it. The heat field is given on the same
//! stations ([`crate::picture`]), across the tunnel at [`LATERAL`] offsets.
//!
//! Not here: anything that moves (units, fires, goals are the picture's).

use firefleet_model::scenario::Scenario;
use firefleet_model::{Chainage, ZoneId};
use serde::Serialize;

/// The most stations a centreline is sampled at: 1 m for a tunnel up to 2 km.
pub const MAX_STATIONS: usize = 2000;

/// Fractions of the half-width at which the heat field is sampled across the tunnel.
pub const LATERAL: [f64; 5] = [-0.9, -0.45, 0.0, 0.45, 0.9];

/// A point of the site frame, `[x, y]` in metres.
pub type Xy = [f64; 2];

/// The site's geometry, as the page draws it.
#[derive(Debug, Clone, Serialize)]
pub struct SiteMap {
    pub site: String,
    pub scenario: String,
    pub length_m: f64,
    pub width_m: f64,
    /// Chainage of each station, m.
    pub stations_m: Vec<f64>,
    /// The centreline at each station.
    pub centre: Vec<Xy>,
    /// The left (+y side at the portal) and right walls at each station.
    pub left_wall: Vec<Xy>,
    pub right_wall: Vec<Xy>,
    /// Lateral offsets of the heat field's samples, m from the centreline.
    pub lateral_m: Vec<f64>,
    pub zones: Vec<ZoneMap>,
    pub obstacles: Vec<ObstacleMap>,
    pub rails: Vec<RailMap>,
    /// The units the site file lists: the page accounts for every one, heard or not.
    pub units: Vec<UnitSlot>,
    /// The portals' names, at chainage 0 and at the end.
    pub portals: [String; 2],
    /// The jet fans under the ceiling, in the order the SCADA reads their states.
    pub fans: Vec<FanMap>,
}

/// A jet fan on the map.
#[derive(Debug, Clone, Serialize)]
pub struct FanMap {
    pub name: String,
    pub chainage_m: f64,
    /// On the centreline at its chainage.
    pub at: Xy,
}

#[derive(Debug, Clone, Serialize)]
pub struct ZoneMap {
    pub id: ZoneId,
    pub start_m: f64,
    pub end_m: f64,
    /// The zone's floor: the left wall from start to end, then the right wall back.
    pub outline: Vec<Xy>,
    /// Where to write the zone's name.
    pub label: Xy,
}

#[derive(Debug, Clone, Serialize)]
pub struct ObstacleMap {
    pub name: String,
    pub corners: [Xy; 4],
}

#[derive(Debug, Clone, Serialize)]
pub struct RailMap {
    pub id: String,
    pub line: Vec<Xy>,
    pub height_m: f64,
    pub hose_points: Vec<Xy>,
}

#[derive(Debug, Clone, Serialize)]
pub struct UnitSlot {
    pub id: String,
    pub kind: firefleet_model::UnitKind,
    pub rail: Option<String>,
    /// Its tank, L; none for a unit on the tunnel's water main (a carriage).
    pub tank_l: Option<f64>,
}

impl SiteMap {
    pub fn new(scenario: &Scenario) -> Self {
        let tunnel = &scenario.tunnel;
        let length = tunnel.length_m;
        let n = (length.ceil() as usize).clamp(2, MAX_STATIONS);
        let stations_m: Vec<f64> = (0..=n).map(|i| length * i as f64 / n as f64).collect();
        let at = |s: f64, d: f64| {
            let p = tunnel.point_at(Chainage::new(s), d);
            [round_cm(p.x), round_cm(p.y)]
        };
        let half = tunnel.width_m / 2.0;
        let along = |from: f64, to: f64, d: f64| -> Vec<Xy> {
            let mut s: Vec<f64> = stations_m
                .iter()
                .copied()
                .filter(|&s| s > from && s < to)
                .collect();
            s.insert(0, from);
            s.push(to);
            s.into_iter().map(|s| at(s, d)).collect()
        };
        let zones = scenario
            .zones
            .iter()
            .map(|z| {
                let (a, b) = (z.start_m.m().max(0.0), z.end_m.m().min(length));
                let mut outline = along(a, b, half);
                outline.extend(along(a, b, -half).into_iter().rev());
                ZoneMap {
                    id: z.id.clone(),
                    start_m: a,
                    end_m: b,
                    outline,
                    label: at((a + b) / 2.0, 0.0),
                }
            })
            .collect();
        let rails = scenario
            .rails
            .iter()
            .map(|r| RailMap {
                id: r.id.clone(),
                line: along(r.start_m, r.end_m, r.y_m),
                height_m: r.height_m,
                hose_points: r.hose_points_m.iter().map(|&s| at(s, r.y_m)).collect(),
            })
            .collect();
        Self {
            site: scenario.site.to_string(),
            scenario: scenario.name.clone(),
            length_m: length,
            width_m: tunnel.width_m,
            centre: stations_m.iter().map(|&s| at(s, 0.0)).collect(),
            left_wall: stations_m.iter().map(|&s| at(s, half)).collect(),
            right_wall: stations_m.iter().map(|&s| at(s, -half)).collect(),
            lateral_m: LATERAL.iter().map(|f| f * half).collect(),
            stations_m,
            zones,
            obstacles: scenario
                .obstacles
                .iter()
                .map(|o| ObstacleMap {
                    name: o.name.clone(),
                    corners: o.corners().map(|p| [round_cm(p.x), round_cm(p.y)]),
                })
                .collect(),
            rails,
            portals: scenario.portal_names(),
            fans: scenario
                .ventilation
                .iter()
                .flat_map(|v| &v.fans)
                .map(|f| FanMap {
                    name: f.name.clone(),
                    chainage_m: f.chainage_m,
                    at: at(f.chainage_m.clamp(0.0, length), 0.0),
                })
                .collect(),
            units: scenario
                .units
                .iter()
                .map(|u| UnitSlot {
                    id: u.id.to_string(),
                    kind: u.kind,
                    rail: u.rail.clone(),
                    tank_l: match scenario.profile_of(u) {
                        Ok(firefleet_model::profile::Profile::Ground(g)) => Some(g.tank_l),
                        _ => None,
                    },
                })
                .collect(),
        }
    }

    /// The site-frame point `d` metres left of the centreline at station `i`.
    pub fn offset(&self, i: usize, d: f64) -> (f64, f64) {
        let (c, l) = (self.centre[i], self.left_wall[i]);
        let half = self.width_m / 2.0;
        (
            c[0] + (l[0] - c[0]) * d / half,
            c[1] + (l[1] - c[1]) * d / half,
        )
    }
}

/// Centimetres are plenty for a map and halve the JSON.
fn round_cm(v: f64) -> f64 {
    (v * 100.0).round() / 100.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::scenario::Scenario;
    use firefleet_model::tunnel::Segment;

    fn rail_tunnel() -> Scenario {
        let text = include_str!("../../model/scenarios/rail-tunnel.toml");
        Scenario::from_toml(text, "rail-tunnel.toml").unwrap()
    }

    /// 60 m straight, a 90 degree left bend of radius 40 m, 40 m straight.
    fn curved() -> Scenario {
        let mut s = rail_tunnel();
        let arc = 40.0 * std::f64::consts::FRAC_PI_2;
        s.tunnel.centerline = vec![
            Segment::Straight { length_m: 60.0 },
            Segment::Arc {
                radius_m: 40.0,
                angle_rad: std::f64::consts::FRAC_PI_2,
            },
            Segment::Straight { length_m: 40.0 },
        ];
        s.tunnel.length_m = 100.0 + arc;
        s
    }

    #[test]
    fn a_straight_tunnel_is_drawn_to_scale() {
        let s = rail_tunnel();
        let map = SiteMap::new(&s);
        assert_eq!(map.centre.first(), Some(&[0.0, 0.0]));
        let end = map.centre.last().unwrap();
        assert!((end[0] - s.tunnel.length_m).abs() < 0.01 && end[1].abs() < 0.01);
        let half = s.tunnel.width_m / 2.0;
        assert!(map.left_wall.iter().all(|p| (p[1] - half).abs() < 0.01));
        assert!(map.right_wall.iter().all(|p| (p[1] + half).abs() < 0.01));
        assert_eq!(map.units.len(), s.units.len());
        assert!(!map.rails.is_empty() && !map.zones.is_empty());
        for (z, spec) in map.zones.iter().zip(&s.zones) {
            let xs: Vec<f64> = z.outline.iter().map(|p| p[0]).collect();
            let lo = xs.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = xs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert!((lo - spec.start_m.m()).abs() < 0.01 && (hi - spec.end_m.m()).abs() < 0.01);
        }
    }

    #[test]
    fn a_curved_tunnel_keeps_its_width_round_the_bend() {
        let s = curved();
        let map = SiteMap::new(&s);
        for (l, r) in map.left_wall.iter().zip(&map.right_wall) {
            let w = ((l[0] - r[0]).powi(2) + (l[1] - r[1]).powi(2)).sqrt();
            assert!((w - s.tunnel.width_m).abs() < 0.05, "width {w}");
        }
        let end = map.centre.last().unwrap();
        let p = s.tunnel.point_at(Chainage::new(s.tunnel.length_m), 0.0);
        assert!((end[0] - p.x).abs() < 0.01 && (end[1] - p.y).abs() < 0.01);
        let (x, y) = map.offset(10, map.width_m / 2.0);
        assert!((x - map.left_wall[10][0]).abs() < 1e-9 && (y - map.left_wall[10][1]).abs() < 1e-9);
    }
}
