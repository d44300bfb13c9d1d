//! Planar geometry in the site frame: x along the tunnel (chainage in a straight tunnel),
//! y lateral (left positive), z up from the road surface. SI units and radians.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::validate::{Invalid, Validate, finite};

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
        (self.x - o.x).hypot(self.y - o.y)
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

impl Validate for Point2 {
    fn validate(&self) -> Result<(), Invalid> {
        finite("x", self.x)?;
        finite("y", self.y)
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
        finite("x", self.x)?;
        finite("y", self.y)?;
        finite("yaw", self.yaw)
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
    fn body_frame_points_forward() {
        let pose = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        let b = pose.to_body(Point2::new(1.0, 3.0));
        assert!((b.x - 2.0).abs() < 1e-12 && b.y.abs() < 1e-12);
    }
}
