//! Monorail units: a carriage on a ceiling rail carrying a fire monitor (the ROBOGAT
//! paper, `robogat-monorail-fuzzy-redundancy.txt`).
//!
//! - [`kinematics`]: where the jet lands for given joints, and the Jacobians (eq. 1-2).
//! - [`clik`]: the weighted, damped pseudo-inverse CLIK with the null-space dexterity task
//!   (eq. 5-8), joint limits enforced.
//! - [`fis`]: the fuzzy system that sets the weights from fire, temperature and distance,
//!   built on the general engine in [`crate::fuzzy`].
//! - [`planner`]: the jet point's approach, sweep and hold (eq. 9).
//! - [`case_study`]: the paper's simulation case study, for the experiment and the bench.
//!
//! All pure: no I/O, no clock. The paper's frame (z down, y right) lives inside these
//! modules; [`RailFrame`] converts to and from the site frame (z up, y left).

pub mod case_study;
pub mod clik;
pub mod fis;
pub mod kinematics;
pub mod planner;

use firefleet_protocol::Point2;
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
