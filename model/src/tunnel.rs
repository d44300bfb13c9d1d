//! The tunnel's shape: a road of constant width along a centreline of straight and
//! circular-arc segments (the way tunnels are set out), and the two coordinate systems on
//! it.
//!
//! The site frame is planar Cartesian (x, y), the portal's centre at the origin and the
//! centreline leaving it along +x. Chainage `s` is the distance along the centreline from
//! the portal, the offset `d` the lateral distance from it (left positive). In a straight
//! tunnel, the default, the two coincide: `(s, d) = (x, y)`. Positions in messages and
//! scenario files are always in the site frame; chainages (zones, rails, staging lines)
//! are measured along the centreline.
//!
//! What this module does not do: clothoid transitions, gradients, or tunnels that come
//! back close to themselves (the projection takes the nearest piece of centreline, which
//! is only right while radii exceed the half-width, which validation enforces).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geometry::{Point2, Pose2, wrap_angle};
use crate::validate::{Invalid, in_range};

/// A straight or curved tunnel of constant cross-section.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tunnel {
    /// Length along the centreline, m; with a `centerline`, its segments must add up to it.
    pub length_m: f64,
    pub width_m: f64,
    pub height_m: f64,
    pub lanes: u8,
    /// The centreline from the portal, in order; empty for a straight tunnel along +x.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub centerline: Vec<Segment>,
}

/// One piece of centreline.
///
/// In a scenario file: `{ straight_m = 40.0 }` or
/// `{ arc_deg = 45.0, radius_m = 60.0, turn = "left" }`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawSegment", into = "RawSegment")]
pub enum Segment {
    Straight {
        length_m: f64,
    },
    /// A circular arc; `angle_rad` positive turns left.
    Arc {
        radius_m: f64,
        angle_rad: f64,
    },
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSegment {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    straight_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    arc_deg: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radius_m: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    turn: Option<Turn>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum Turn {
    Left,
    Right,
}

impl TryFrom<RawSegment> for Segment {
    type Error = String;
    fn try_from(r: RawSegment) -> Result<Self, String> {
        match (r.straight_m, r.arc_deg, r.radius_m, r.turn) {
            (Some(length_m), None, None, None) => Ok(Segment::Straight { length_m }),
            (None, Some(deg), Some(radius_m), Some(turn)) => Ok(Segment::Arc {
                radius_m,
                angle_rad: match turn {
                    Turn::Left => deg.to_radians(),
                    Turn::Right => -deg.to_radians(),
                },
            }),
            _ => Err("a centerline segment is either { straight_m } or \
                 { arc_deg, radius_m, turn = \"left\" | \"right\" }"
                .to_owned()),
        }
    }
}

impl From<Segment> for RawSegment {
    fn from(s: Segment) -> Self {
        match s {
            Segment::Straight { length_m } => RawSegment {
                straight_m: Some(length_m),
                arc_deg: None,
                radius_m: None,
                turn: None,
            },
            Segment::Arc {
                radius_m,
                angle_rad,
            } => RawSegment {
                straight_m: None,
                arc_deg: Some(angle_rad.abs().to_degrees()),
                radius_m: Some(radius_m),
                turn: Some(if angle_rad >= 0.0 {
                    Turn::Left
                } else {
                    Turn::Right
                }),
            },
        }
    }
}

impl Segment {
    pub fn length_m(&self) -> f64 {
        match *self {
            Segment::Straight { length_m } => length_m,
            Segment::Arc {
                radius_m,
                angle_rad,
            } => radius_m * angle_rad.abs(),
        }
    }

    /// Signed curvature, 1/m (positive turning left).
    fn curvature(&self) -> f64 {
        match *self {
            Segment::Straight { .. } => 0.0,
            Segment::Arc {
                radius_m,
                angle_rad,
            } => angle_rad.signum() / radius_m,
        }
    }

    /// The centreline pose `ds` metres into the segment that starts at `start`.
    fn advance(&self, start: Pose2, ds: f64) -> Pose2 {
        let k = self.curvature();
        if k == 0.0 {
            let p = start.position().offset(start.yaw, ds);
            return Pose2::new(p.x, p.y, start.yaw);
        }
        let yaw = start.yaw + k * ds;
        Pose2::new(
            start.x + (yaw.sin() - start.yaw.sin()) / k,
            start.y - (yaw.cos() - start.yaw.cos()) / k,
            yaw,
        )
    }

    /// The point of this segment (starting at `start`) nearest to `p`, as the distance
    /// along it, unclamped: negative before the start, beyond the length after the end.
    fn along(&self, start: Pose2, p: Point2) -> f64 {
        let k = self.curvature();
        if k == 0.0 {
            return start.to_body(p).x;
        }
        // Angle swept about the arc's centre from the start to p, measured in the turning
        // direction.
        let r = 1.0 / k;
        let centre = start.to_site(Point2::new(0.0, r));
        wrap_angle(centre.bearing_to(p) - centre.bearing_to(start.position())) * r
    }
}

/// Distance along the centreline from the portal, m: where zones, rails, staging lines
/// and hazards are. A type of its own because in a curved tunnel it is not the site
/// frame's x, and a bare `f64` let the two be mixed up (a zone looked up by x).
///
/// Differences of chainages are plain metres; a chainage plus or minus metres is a
/// chainage. On the wire and in site files it is a bare number (serde transparent).
#[derive(
    Debug, Clone, Copy, Default, PartialEq, PartialOrd, Serialize, Deserialize, JsonSchema,
)]
#[serde(transparent)]
pub struct Chainage(f64);

impl Chainage {
    pub const ZERO: Chainage = Chainage(0.0);

    pub const fn new(m: f64) -> Self {
        Self(m)
    }

    /// Metres from the portal.
    pub const fn m(self) -> f64 {
        self.0
    }

    pub fn min(self, other: Chainage) -> Chainage {
        Chainage(self.0.min(other.0))
    }

    pub fn max(self, other: Chainage) -> Chainage {
        Chainage(self.0.max(other.0))
    }

    pub fn clamp(self, lo: Chainage, hi: Chainage) -> Chainage {
        Chainage(self.0.clamp(lo.0, hi.0))
    }

    /// Half-way between `self` and `other`.
    pub fn midpoint(self, other: Chainage) -> Chainage {
        Chainage((self.0 + other.0) / 2.0)
    }

    pub fn total_cmp(&self, other: &Chainage) -> std::cmp::Ordering {
        self.0.total_cmp(&other.0)
    }
}

impl std::ops::Add<f64> for Chainage {
    type Output = Chainage;
    fn add(self, m: f64) -> Chainage {
        Chainage(self.0 + m)
    }
}

impl std::ops::Sub<f64> for Chainage {
    type Output = Chainage;
    fn sub(self, m: f64) -> Chainage {
        Chainage(self.0 - m)
    }
}

impl std::ops::Sub for Chainage {
    type Output = f64;
    fn sub(self, other: Chainage) -> f64 {
        self.0 - other.0
    }
}

impl std::fmt::Display for Chainage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&self.0, f)
    }
}

/// A position along the tunnel: chainage and lateral offset (left positive, m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Station {
    pub s: Chainage,
    pub d: f64,
}

impl Tunnel {
    /// A straight tunnel.
    pub const fn straight(length_m: f64, width_m: f64, height_m: f64, lanes: u8) -> Self {
        Self {
            length_m,
            width_m,
            height_m,
            lanes,
            centerline: Vec::new(),
        }
    }

    pub fn is_straight(&self) -> bool {
        self.centerline
            .iter()
            .all(|s| matches!(s, Segment::Straight { .. }))
    }

    /// Each segment with its start pose and chainage.
    fn pieces(&self) -> impl Iterator<Item = (Segment, Pose2, f64)> + '_ {
        let mut pose = Pose2::new(0.0, 0.0, 0.0);
        let mut s0 = 0.0;
        self.centerline.iter().map(move |seg| {
            let here = (*seg, pose, s0);
            pose = seg.advance(pose, seg.length_m());
            s0 += seg.length_m();
            here
        })
    }

    /// The tunnel's far end.
    pub fn end(&self) -> Chainage {
        Chainage(self.length_m)
    }

    /// The centreline pose at chainage `s` (extended straight beyond either end).
    pub fn centre_pose(&self, s: Chainage) -> Pose2 {
        let s = s.m();
        let (mut end, mut end_s) = (Pose2::new(0.0, 0.0, 0.0), 0.0);
        if s > 0.0 {
            for (seg, start, s0) in self.pieces() {
                let len = seg.length_m();
                if s < s0 + len {
                    return seg.advance(start, s - s0);
                }
                end = seg.advance(start, len);
                end_s = s0 + len;
            }
        }
        let p = end.position().offset(end.yaw, s - end_s);
        Pose2::new(p.x, p.y, end.yaw)
    }

    /// The site-frame point at chainage `s`, offset `d`.
    pub fn point_at(&self, s: Chainage, d: f64) -> Point2 {
        self.centre_pose(s).to_site(Point2::new(0.0, d))
    }

    /// The tunnel's direction (+s) at chainage `s`, radians.
    pub fn heading_at(&self, s: Chainage) -> f64 {
        self.centre_pose(s).yaw
    }

    /// Chainage and offset of a site-frame point: its nearest point on the centreline
    /// (extended straight beyond the two ends).
    pub fn station(&self, p: Point2) -> Station {
        if self.centerline.is_empty() {
            return Station {
                s: Chainage(p.x),
                d: p.y,
            };
        }
        let n = self.centerline.len();
        let (mut best, mut best_dist) = (
            Station {
                s: Chainage::ZERO,
                d: 0.0,
            },
            f64::INFINITY,
        );
        for (i, (seg, start, s0)) in self.pieces().enumerate() {
            let len = seg.length_m();
            let lo = if i == 0 { f64::NEG_INFINITY } else { 0.0 };
            let hi = if i + 1 == n { f64::INFINITY } else { len };
            let t = seg.along(start, p).clamp(lo, hi);
            // Past either end of an arc the projection continues on the end's tangent.
            let on = if t < 0.0 {
                let q = start.position().offset(start.yaw, t);
                Pose2::new(q.x, q.y, start.yaw)
            } else if t > len {
                let end = seg.advance(start, len);
                let q = end.position().offset(end.yaw, t - len);
                Pose2::new(q.x, q.y, end.yaw)
            } else {
                seg.advance(start, t)
            };
            let dist = on.position().dist(p);
            if dist < best_dist {
                best_dist = dist;
                best = Station {
                    s: Chainage(s0 + t),
                    d: on.to_body(p).y,
                };
            }
        }
        best
    }

    /// Chainage of a site-frame point.
    pub fn chainage(&self, p: Point2) -> Chainage {
        self.station(p).s
    }

    /// Whether `p` is inside the tunnel with at least `margin` metres to every wall and
    /// to either end.
    pub fn contains(&self, p: Point2, margin: f64) -> bool {
        let Station { s, d } = self.station(p);
        let s = s.m();
        s >= margin && s <= self.length_m - margin && d.abs() <= self.width_m / 2.0 - margin
    }

    /// Whether the straight segment `a`-`b` stays inside the tunnel: in a curve the
    /// inner wall hides what lies round the bend.
    pub fn segment_inside(&self, a: Point2, b: Point2) -> bool {
        if self.is_straight() {
            // A rectangle is convex: the ends decide.
            return self.contains(a, 0.0) && self.contains(b, 0.0);
        }
        let n = (a.dist(b) / 0.2).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let t = k as f64 / n as f64;
            self.contains(
                Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)),
                0.0,
            )
        })
    }

    /// Like [`Tunnel::contains`] with no margin, as a validation result naming `field`.
    pub fn check_inside(&self, field: &str, p: Point2) -> Result<(), Invalid> {
        if self.contains(p, 0.0) {
            return Ok(());
        }
        let Station { s, d } = self.station(p);
        Err(Invalid::new(
            field,
            format!(
                "({:.2}, {:.2}) is outside the tunnel (chainage {s:.2} of [0, {}], offset \
                 {d:.2}, |offset| <= {})",
                p.x,
                p.y,
                self.length_m,
                self.width_m / 2.0
            ),
        ))
    }

    /// Lateral offset of the centre of lane `i` (0 is the rightmost lane, driving in +s).
    pub fn lane_center_y(&self, i: u8) -> f64 {
        let lane_w = self.width_m / f64::from(self.lanes);
        -self.width_m / 2.0 + lane_w * (f64::from(i) + 0.5)
    }

    /// The centre of the lane nearest lateral offset `d`.
    pub fn lane_nearest(&self, d: f64) -> f64 {
        (0..self.lanes)
            .map(|i| self.lane_center_y(i))
            .min_by(|a, b| (a - d).abs().total_cmp(&(b - d).abs()))
            .unwrap_or(0.0)
    }

    /// The site-frame bounding box of the road, `(min, max)`.
    pub fn bounds(&self) -> (Point2, Point2) {
        let hw = self.width_m / 2.0;
        if self.is_straight() {
            return (Point2::new(0.0, -hw), Point2::new(self.length_m, hw));
        }
        let n = (self.length_m / 0.5).ceil() as usize;
        let mut lo = Point2::new(f64::INFINITY, f64::INFINITY);
        let mut hi = Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
        for k in 0..=n {
            let s = self.length_m * k as f64 / n as f64;
            for d in [-hw, hw] {
                let p = self.point_at(Chainage(s), d);
                lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
                hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
            }
        }
        // Sampling every half metre cuts corners of arcs by far less than this.
        (
            Point2::new(lo.x - 0.1, lo.y - 0.1),
            Point2::new(hi.x + 0.1, hi.y + 0.1),
        )
    }

    /// Checks of the cross-section and the centreline.
    pub fn validate(&self) -> Result<(), Invalid> {
        in_range("tunnel.length_m", self.length_m, 10.0, 100_000.0)?;
        in_range("tunnel.width_m", self.width_m, 2.0, 50.0)?;
        in_range("tunnel.height_m", self.height_m, 2.0, 30.0)?;
        if !(1..=8).contains(&self.lanes) {
            return Err(Invalid::new(
                "tunnel.lanes",
                format!("{} is outside [1, 8]", self.lanes),
            ));
        }
        if self.centerline.is_empty() {
            return Ok(());
        }
        for (i, seg) in self.centerline.iter().enumerate() {
            let f = |n: &str| format!("tunnel.centerline[{i}].{n}");
            match *seg {
                Segment::Straight { length_m } => {
                    in_range(&f("straight_m"), length_m, 0.1, 100_000.0)?;
                }
                Segment::Arc {
                    radius_m,
                    angle_rad,
                } => {
                    // The inner wall must stay a curve, and a wider margin keeps the
                    // nearest-point projection unique across the road.
                    in_range(&f("radius_m"), radius_m, self.width_m, 100_000.0)?;
                    in_range(&f("arc_deg"), angle_rad.abs().to_degrees(), 0.1, 180.0)?;
                }
            }
        }
        let sum: f64 = self.centerline.iter().map(Segment::length_m).sum();
        if (sum - self.length_m).abs() > 0.01 {
            return Err(Invalid::new(
                "tunnel.length_m",
                format!(
                    "is {} but the centerline adds up to {sum:.3}",
                    self.length_m
                ),
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn curved() -> Tunnel {
        Tunnel {
            centerline: vec![
                Segment::Straight { length_m: 30.0 },
                Segment::Arc {
                    radius_m: 40.0,
                    angle_rad: std::f64::consts::FRAC_PI_2,
                },
                Segment::Straight { length_m: 20.0 },
            ],
            ..Tunnel::straight(30.0 + 20.0 * std::f64::consts::PI + 20.0, 8.0, 6.0, 2)
        }
    }

    #[test]
    fn a_quarter_turn_left_ends_where_geometry_says() {
        let t = curved();
        let end = t.centre_pose(Chainage(30.0 + 20.0 * std::f64::consts::PI));
        assert!((end.x - 70.0).abs() < 1e-9 && (end.y - 40.0).abs() < 1e-9);
        assert!((end.yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let far = t.point_at(t.end(), -2.0);
        assert!((far.x - 72.0).abs() < 1e-9 && (far.y - 60.0).abs() < 1e-9);
        assert!(t.validate().is_ok());
    }

    #[test]
    fn the_inner_wall_hides_what_is_round_the_bend() {
        let t = curved();
        let before = t.point_at(Chainage(20.0), 0.0);
        let after = t.point_at(Chainage(100.0), 0.0);
        assert!(t.contains(before, 0.0) && t.contains(after, 0.0));
        assert!(!t.segment_inside(before, after));
        assert!(t.segment_inside(before, t.point_at(Chainage(35.0), 3.0)));
    }

    #[test]
    fn the_centreline_must_add_up_and_curves_must_be_gentle() {
        let mut t = curved();
        t.length_m += 1.0;
        assert!(t.validate().unwrap_err().to_string().contains("adds up to"));
        t = curved();
        t.centerline[1] = Segment::Arc {
            radius_m: 3.0,
            angle_rad: 0.1,
        };
        assert!(
            t.validate()
                .unwrap_err()
                .to_string()
                .contains("centerline[1].radius_m")
        );
    }

    #[test]
    fn a_straight_tunnel_is_its_own_frame() {
        let t = Tunnel::straight(100.0, 10.0, 6.0, 2);
        let st = t.station(Point2::new(12.5, -3.0));
        assert_eq!((st.s, st.d), (Chainage(12.5), -3.0));
        assert!(!t.contains(Point2::new(50.0, 5.1), 0.0));
    }

    proptest! {
        #[test]
        fn station_inverts_point_at(s in 0.0..131.0f64, d in -3.9..3.9f64) {
            let t = curved();
            let st = t.station(t.point_at(Chainage(s), d));
            prop_assert!((st.s.m() - s).abs() < 1e-6, "s {} -> {}", s, st.s);
            prop_assert!((st.d - d).abs() < 1e-6, "d {} -> {}", d, st.d);
        }
    }
}
