//! Planar geometry in the site frame: x along the tunnel (chainage in a straight tunnel),
//! y lateral (left positive), z up from the road surface. SI units and radians.
//!
//! Not here: the tunnel's own coordinates (chainage and offset, [`crate::tunnel`]).

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::validate::{Invalid, Validate, in_range};

/// A point on the road plane, metres.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct Point2 {
    pub x: f64,
    pub y: f64,
}

impl Point2 {
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }
    pub fn dist(self, o: Point2) -> f64 {
        // Not hypot: its overflow care costs several times more, and site distances are
        // nowhere near overflow. This sits in the inner loops of planning and assignment.
        let (dx, dy) = (self.x - o.x, self.y - o.y);
        (dx * dx + dy * dy).sqrt()
    }
    /// Bearing from `self` towards `o`, radians in (-pi, pi].
    pub fn bearing_to(self, o: Point2) -> f64 {
        (o.y - self.y).atan2(o.x - self.x)
    }
    /// The point `d` metres from `self` in direction `heading`.
    pub fn offset(self, heading: f64, d: f64) -> Point2 {
        Point2::new(self.x + d * heading.cos(), self.y + d * heading.sin())
    }
}

/// Largest coordinate a site-frame position may have, m. Site frames are local to one
/// tunnel (the longest road tunnel is 24.5 km); a larger value is a lie or a bug, and
/// one that a distance or a grid index computed from it would turn into nonsense.
pub const MAX_COORD_M: f64 = 100_000.0;

/// Largest heading magnitude a pose may have, rad: senders wrap their headings, but an
/// odometry heading left unwrapped for fifteen turns still passes. Trigonometry on a
/// heading of 1e308 is finite and meaningless.
pub const MAX_YAW_RAD: f64 = 100.0;

impl Validate for Point2 {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("x", self.x, -MAX_COORD_M, MAX_COORD_M)?;
        in_range("y", self.y, -MAX_COORD_M, MAX_COORD_M)
    }
}

/// A planar pose: position and heading (yaw, radians, counter-clockwise from +x).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize, JsonSchema)]
pub struct Pose2 {
    pub x: f64,
    pub y: f64,
    pub yaw: f64,
}

impl Pose2 {
    pub const fn new(x: f64, y: f64, yaw: f64) -> Self {
        Self { x, y, yaw }
    }
    pub fn position(&self) -> Point2 {
        Point2::new(self.x, self.y)
    }
    /// Express a site-frame point in this pose's body frame (x forward, y left).
    pub fn to_body(&self, p: Point2) -> Point2 {
        let (s, c) = self.yaw.sin_cos();
        let (dx, dy) = (p.x - self.x, p.y - self.y);
        Point2::new(c * dx + s * dy, -s * dx + c * dy)
    }
    /// Express a body-frame point in the site frame.
    pub fn to_site(&self, p: Point2) -> Point2 {
        let (s, c) = self.yaw.sin_cos();
        Point2::new(self.x + c * p.x - s * p.y, self.y + s * p.x + c * p.y)
    }
}

impl Validate for Pose2 {
    fn validate(&self) -> Result<(), Invalid> {
        self.position().validate()?;
        in_range("yaw", self.yaw, -MAX_YAW_RAD, MAX_YAW_RAD)
    }
}

/// A rectangle on the road plane centred on a pose, long along its heading: a vehicle's
/// footprint, grown by a margin where one is wanted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    pub pose: Pose2,
    pub half_length: f64,
    pub half_width: f64,
}

impl OrientedBox {
    pub fn new(pose: Pose2, length_m: f64, width_m: f64) -> Self {
        Self {
            pose,
            half_length: length_m / 2.0,
            half_width: width_m / 2.0,
        }
    }

    /// This box with every side moved out by `by` metres.
    pub fn grown(self, by: f64) -> Self {
        Self {
            half_length: self.half_length + by,
            half_width: self.half_width + by,
            ..self
        }
    }

    pub fn contains(&self, p: Point2) -> bool {
        self.distance_to(p) == 0.0
    }

    /// How far `p` is from the box, m; 0 inside it.
    pub fn distance_to(&self, p: Point2) -> f64 {
        let b = self.pose.to_body(p);
        let dx = (b.x.abs() - self.half_length).max(0.0);
        let dy = (b.y.abs() - self.half_width).max(0.0);
        dx.hypot(dy)
    }

    pub fn corners(&self) -> [Point2; 4] {
        let (l, w) = (self.half_length, self.half_width);
        [(l, w), (-l, w), (-l, -w), (l, -w)].map(|(x, y)| self.pose.to_site(Point2::new(x, y)))
    }

    /// The gap between two boxes, m; 0 where they overlap. Between two convex polygons
    /// apart the nearest points are a corner of one and a side of the other.
    pub fn gap_to(&self, o: &OrientedBox) -> f64 {
        if self.overlaps(o) {
            return 0.0;
        }
        let to_o = self.corners().map(|c| o.distance_to(c));
        let to_self = o.corners().map(|c| self.distance_to(c));
        to_o.into_iter()
            .chain(to_self)
            .fold(f64::INFINITY, f64::min)
    }

    /// Whether the two boxes share any point: by the separating axis theorem, two convex
    /// shapes are apart exactly when their projections are apart on some axis, and for
    /// rectangles the four edge normals are the only axes to try.
    pub fn overlaps(&self, o: &OrientedBox) -> bool {
        let reach = |b: &OrientedBox| b.half_length.hypot(b.half_width);
        if self.pose.position().dist(o.pose.position()) > reach(self) + reach(o) {
            return false;
        }
        let (d, axes) = (
            (o.pose.x - self.pose.x, o.pose.y - self.pose.y),
            [
                self.pose.yaw,
                self.pose.yaw + std::f64::consts::FRAC_PI_2,
                o.pose.yaw,
                o.pose.yaw + std::f64::consts::FRAC_PI_2,
            ],
        );
        // Half the box's extent along the unit axis at angle `a`.
        let radius = |b: &OrientedBox, a: f64| {
            let rel = b.pose.yaw - a;
            b.half_length * rel.cos().abs() + b.half_width * rel.sin().abs()
        };
        axes.into_iter().all(|a| {
            let centres = (d.0 * a.cos() + d.1 * a.sin()).abs();
            centres <= radius(self, a) + radius(o, a)
        })
    }
}

/// A position estimate: mean and covariance `[xx, xy, yy]`, m and m^2.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, JsonSchema)]
pub struct Gaussian2 {
    pub mean: Point2,
    pub cov: [f64; 3],
}

impl Gaussian2 {
    /// An estimate at `mean` whose one-sigma error is `along` in direction `heading` and
    /// `across` perpendicular to it (e.g. depth error along a camera's axis, pixel error
    /// across it).
    pub fn oriented(mean: Point2, heading: f64, along: f64, across: f64) -> Self {
        let (s, c) = heading.sin_cos();
        let (va, vc) = (along * along, across * across);
        Self {
            mean,
            cov: [
                va * c * c + vc * s * s,
                (va - vc) * s * c,
                va * s * s + vc * c * c,
            ],
        }
    }

    fn det(&self) -> f64 {
        self.cov[0] * self.cov[2] - self.cov[1] * self.cov[1]
    }

    /// Squared Mahalanobis distance of `p` from this estimate.
    pub fn mahalanobis2(&self, p: Point2) -> f64 {
        let [a, b, d] = self.cov;
        let (dx, dy) = (p.x - self.mean.x, p.y - self.mean.y);
        (d * dx * dx - 2.0 * b * dx * dy + a * dy * dy) / self.det()
    }

    /// Squared Mahalanobis distance between two independent estimates (of the difference
    /// of their means, under the sum of their covariances): the association gate.
    pub fn gate2(&self, o: &Gaussian2) -> f64 {
        let sum = Gaussian2 {
            mean: self.mean,
            cov: [
                self.cov[0] + o.cov[0],
                self.cov[1] + o.cov[1],
                self.cov[2] + o.cov[2],
            ],
        };
        sum.mahalanobis2(o.mean)
    }

    /// Product of two independent estimates of the same static point (information form).
    pub fn fuse(&self, o: &Gaussian2) -> Gaussian2 {
        let inv = |g: &Gaussian2| {
            let d = g.det();
            [g.cov[2] / d, -g.cov[1] / d, g.cov[0] / d]
        };
        let (i1, i2) = (inv(self), inv(o));
        let info = [i1[0] + i2[0], i1[1] + i2[1], i1[2] + i2[2]];
        let det = info[0] * info[2] - info[1] * info[1];
        let cov = [info[2] / det, -info[1] / det, info[0] / det];
        // Information-weighted means.
        let wx = |i: &[f64; 3], m: Point2| (i[0] * m.x + i[1] * m.y, i[1] * m.x + i[2] * m.y);
        let (a, b) = (wx(&i1, self.mean), wx(&i2, o.mean));
        let (ix, iy) = (a.0 + b.0, a.1 + b.1);
        Gaussian2 {
            mean: Point2::new(cov[0] * ix + cov[1] * iy, cov[1] * ix + cov[2] * iy),
            cov,
        }
    }

    /// Grow the covariance by `q` m^2 on each axis (uncertainty added by time passing).
    pub fn inflate(&mut self, q: f64) {
        self.cov[0] += q;
        self.cov[2] += q;
    }
}

/// Wrap an angle to (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let t = std::f64::consts::TAU;
    let w = a.rem_euclid(t);
    if w > std::f64::consts::PI { w - t } else { w }
}

#[cfg(test)]
mod tests {
    #[test]
    fn boxes_overlap_exactly_when_no_axis_separates_them() {
        use super::{OrientedBox, Pose2};
        let car = OrientedBox::new(Pose2::new(0.0, 0.0, 0.0), 4.0, 2.0);
        let at = |x, y, yaw| OrientedBox::new(Pose2::new(x, y, yaw), 4.0, 2.0);
        assert!(
            car.overlaps(&at(3.9, 0.0, 0.0)),
            "end to end, 0.1 m overlap"
        );
        assert!(!car.overlaps(&at(4.1, 0.0, 0.0)), "end to end, 0.1 m apart");
        assert!(!car.overlaps(&at(0.0, 2.1, 0.0)), "side by side");
        // Turned 45 degrees beside the car: its corner reaches 1 + 2.12 m from its centre
        // across, within the circles' test but clear of the car on the car's own axis.
        let turned = at(0.0, 3.2, std::f64::consts::FRAC_PI_4);
        assert!(!car.overlaps(&turned));
        assert!(car.overlaps(&at(0.0, 3.0, std::f64::consts::FRAC_PI_4)));
        assert!(
            car.grown(0.2).overlaps(&at(4.1, 0.0, 0.0)),
            "grown by a margin"
        );
        assert!(car.contains(super::Point2::new(1.9, -0.9)));
        assert!((car.distance_to(super::Point2::new(5.0, 5.0)) - 3.0f64.hypot(4.0)).abs() < 1e-12);
        assert!(
            (car.gap_to(&at(4.5, 0.0, 0.0)) - 0.5).abs() < 1e-12,
            "end to end"
        );
        assert!((car.gap_to(&turned) - (3.2 - 1.0 - 2.0f64.sqrt() * 1.5)).abs() < 1e-9);
        assert_eq!(car.gap_to(&at(3.9, 0.0, 0.0)), 0.0);
        assert!(!car.contains(super::Point2::new(2.1, 0.0)));
    }

    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn body_and_site_frames_are_inverse(x in -100.0..100.0f64, y in -10.0..10.0f64, yaw in -4.0..4.0f64,
                                            px in -50.0..50.0f64, py in -50.0..50.0f64) {
            let pose = Pose2::new(x, y, yaw);
            let p = Point2::new(px, py);
            let back = pose.to_site(pose.to_body(p));
            prop_assert!((back.x - p.x).abs() < 1e-9 && (back.y - p.y).abs() < 1e-9);
            prop_assert!((pose.to_body(p).x.hypot(pose.to_body(p).y) - pose.position().dist(p)).abs() < 1e-9);
        }

        #[test]
        fn wrapped_angles_stay_in_range_and_keep_direction(a in -50.0..50.0f64) {
            let w = wrap_angle(a);
            prop_assert!(w > -std::f64::consts::PI - 1e-12 && w <= std::f64::consts::PI + 1e-12);
            prop_assert!((w.sin() - a.sin()).abs() < 1e-9 && (w.cos() - a.cos()).abs() < 1e-9);
        }
    }

    #[test]
    fn fusing_two_estimates_shrinks_and_weights_them() {
        let a = Gaussian2 {
            mean: Point2::new(0.0, 0.0),
            cov: [1.0, 0.0, 1.0],
        };
        let b = Gaussian2 {
            mean: Point2::new(2.0, 0.0),
            cov: [1.0, 0.0, 1.0],
        };
        let f = a.fuse(&b);
        assert!((f.mean.x - 1.0).abs() < 1e-12 && (f.cov[0] - 0.5).abs() < 1e-12);
        let sharp = Gaussian2 {
            mean: Point2::new(2.0, 0.0),
            cov: [0.01, 0.0, 0.01],
        };
        assert!((a.fuse(&sharp).mean.x - 2.0).abs() < 0.05);
        assert!((a.mahalanobis2(Point2::new(3.0, 4.0)) - 25.0).abs() < 1e-12);
        // Two unit-variance estimates 2 m apart: the difference has variance 2.
        assert!((a.gate2(&b) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn oriented_covariance_is_elongated_along_its_heading() {
        let g = Gaussian2::oriented(Point2::new(10.0, 0.0), 0.0, 0.5, 0.1);
        assert!(
            (g.cov[0] - 0.25).abs() < 1e-12
                && (g.cov[2] - 0.01).abs() < 1e-12
                && g.cov[1].abs() < 1e-12
        );
        let r = Gaussian2::oriented(Point2::new(0.0, 0.0), std::f64::consts::FRAC_PI_2, 0.5, 0.1);
        assert!((r.cov[0] - 0.01).abs() < 1e-12 && (r.cov[2] - 0.25).abs() < 1e-12);
    }

    #[test]
    fn body_frame_points_forward() {
        let pose = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        let b = pose.to_body(Point2::new(1.0, 3.0));
        assert!((b.x - 2.0).abs() < 1e-12 && b.y.abs() < 1e-12);
    }
}
