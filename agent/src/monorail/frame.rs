//! The rail's frame: where a rail's base frame sits in the site. The ROBOGAT paper's
//! frame (z down, y right) lives inside the monorail's kinematics, CLIK and planner;
//! [`RailFrame`] converts to and from the site frame (z up, y left).
//!
//! Not here: the kinematics themselves ([`super::kinematics`]).

use firefleet_model::Point2;
use nalgebra::Vector2;

/// Where a rail's base frame sits in the site: the rail runs along +x from `(x0, y0)`, with
/// the monitor's pivot M at `height_m` above the road.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RailFrame {
    pub x0: f64,
    pub y0: f64,
    pub height_m: f64,
}

impl RailFrame {
    /// A road point of the site in the rail's frame (`[x, y]` on the plane `z = height_m`).
    pub fn from_site(&self, p: Point2) -> Vector2<f64> {
        Vector2::new(p.x - self.x0, self.y0 - p.y)
    }

    /// A point of the rail's frame on the road, in the site frame.
    pub fn to_site(&self, p: Vector2<f64>) -> Point2 {
        Point2::new(self.x0 + p.x, self.y0 - p.y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_round_trip_and_y_flips() {
        let f = RailFrame {
            x0: 30.0,
            y0: 1.0,
            height_m: 6.0,
        };
        let site = Point2::new(45.0, 3.0);
        let r = f.from_site(site);
        assert_eq!(
            r,
            Vector2::new(15.0, -2.0),
            "2 m left of the rail is y = -2"
        );
        assert_eq!(f.to_site(r), site);
    }
}
