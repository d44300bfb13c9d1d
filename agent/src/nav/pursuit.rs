//! Pure pursuit path following for a bicycle-model vehicle.
//!
//! Steer towards the point one look-ahead distance along the path: `delta = atan(2 L
//! sin(alpha) / l_d)` (Coulter, "Implementation of the Pure Pursuit Path Tracking
//! Algorithm", CMU-RI-TR-92-01). Speed drops near the goal and in tight turns.

use firefleet_protocol::geometry::{Point2, Pose2};
use firefleet_protocol::spec::GroundSpec;

/// What the follower asks of the vehicle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Follow {
    Drive { speed: f64, steer: f64 },
    Arrived,
}

/// Follows one path.
#[derive(Debug, Clone)]
pub struct PurePursuit {
    path: Vec<Point2>,
    /// Index of the segment the vehicle is on.
    seg: usize,
    lookahead_m: f64,
    goal_tolerance_m: f64,
}

impl PurePursuit {
    pub fn new(path: Vec<Point2>) -> Self {
        Self {
            path,
            seg: 0,
            lookahead_m: 1.8,
            goal_tolerance_m: 0.5,
        }
    }

    pub fn path(&self) -> &[Point2] {
        &self.path
    }

    pub fn goal(&self) -> Point2 {
        *self.path.last().expect("a path has at least its start")
    }

    /// Steering and speed for the vehicle at `pose`.
    pub fn follow(&mut self, pose: &Pose2, spec: &GroundSpec) -> Follow {
        let p = pose.position();
        let remaining = self.remaining_from(p);
        if p.dist(self.goal()) < self.goal_tolerance_m || remaining < 0.05 {
            return Follow::Arrived;
        }
        let target = self.lookahead_point(p);
        let local = pose.to_body(target);
        let ld = local.x.hypot(local.y).max(0.1);
        let alpha = local.y.atan2(local.x);
        let steer = (2.0 * spec.wheelbase_m * alpha.sin() / ld)
            .atan()
            .clamp(-spec.max_steer_rad, spec.max_steer_rad);
        // Braking distance at max deceleration, with margin; slower when steering hard or
        // when the target is behind.
        let v_goal = (2.0 * spec.max_accel_m_s2 * 0.5 * remaining).sqrt();
        let v_turn = spec.max_speed_m_s * (1.0 - 0.6 * steer.abs() / spec.max_steer_rad);
        let v_behind = if local.x < 0.0 {
            0.4
        } else {
            spec.max_speed_m_s
        };
        let speed = v_goal
            .min(v_turn)
            .min(v_behind)
            .clamp(0.2, spec.max_speed_m_s);
        Follow::Drive { speed, steer }
    }

    /// Advance along the path to the segment nearest `p`, then walk forward `lookahead_m`.
    fn lookahead_point(&mut self, p: Point2) -> Point2 {
        while self.seg + 2 < self.path.len()
            && closest_t(self.path[self.seg], self.path[self.seg + 1], p) >= 1.0
        {
            self.seg += 1;
        }
        let (a, b) = (
            self.path[self.seg],
            self.path[(self.seg + 1).min(self.path.len() - 1)],
        );
        let t = closest_t(a, b, p);
        let mut left = self.lookahead_m;
        let mut from = lerp(a, b, t);
        for i in self.seg..self.path.len() - 1 {
            let to = self.path[i + 1];
            let d = from.dist(to);
            if d >= left {
                return lerp(from, to, left / d);
            }
            left -= d;
            from = to;
        }
        // Past the end, aim along the last segment's extension: steering at the goal point
        // itself would swing the vehicle round to face it and spoil the arrival heading.
        let n = self.path.len();
        if n < 2 {
            return self.goal();
        }
        let (a, b) = (self.path[n - 2], self.path[n - 1]);
        let d = a.dist(b);
        if d < 1e-9 {
            return b;
        }
        lerp(b, Point2::new(2.0 * b.x - a.x, 2.0 * b.y - a.y), left / d)
    }

    fn remaining_from(&self, p: Point2) -> f64 {
        let n = self.path.len();
        if n < 2 {
            return p.dist(self.goal());
        }
        let (a, b) = (self.path[self.seg], self.path[self.seg + 1]);
        let c = lerp(a, b, closest_t(a, b, p));
        c.dist(b)
            + self.path[self.seg + 1..]
                .windows(2)
                .map(|w| w[0].dist(w[1]))
                .sum::<f64>()
    }
}

fn closest_t(a: Point2, b: Point2, p: Point2) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let l2 = dx * dx + dy * dy;
    if l2 < 1e-12 {
        1.0
    } else {
        (((p.x - a.x) * dx + (p.y - a.y) * dy) / l2).clamp(0.0, 1.0)
    }
}

fn lerp(a: Point2, b: Point2, t: f64) -> Point2 {
    Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::geometry::wrap_angle;
    use firefleet_protocol::spec::GROUND;

    /// Integrate the bicycle model under the follower; returns the final pose and steps.
    fn drive(path: Vec<Point2>, mut pose: Pose2) -> (Pose2, usize, f64) {
        let mut pp = PurePursuit::new(path.clone());
        let dt = 0.05;
        let mut max_dev = 0.0f64;
        for k in 0..4000 {
            match pp.follow(&pose, &GROUND) {
                Follow::Arrived => return (pose, k, max_dev),
                Follow::Drive { speed, steer } => {
                    pose.yaw = wrap_angle(pose.yaw + speed / GROUND.wheelbase_m * steer.tan() * dt);
                    pose.x += speed * pose.yaw.cos() * dt;
                    pose.y += speed * pose.yaw.sin() * dt;
                    let dev = path
                        .windows(2)
                        .map(|w| {
                            lerp(w[0], w[1], closest_t(w[0], w[1], pose.position()))
                                .dist(pose.position())
                        })
                        .fold(f64::INFINITY, f64::min);
                    max_dev = max_dev.max(dev);
                }
            }
        }
        panic!("never arrived: {pose:?}");
    }

    #[test]
    fn follows_a_dogleg_and_stops_at_the_goal() {
        let path = vec![
            Point2::new(0.0, 0.0),
            Point2::new(10.0, 0.0),
            Point2::new(14.0, 3.0),
            Point2::new(25.0, 3.0),
        ];
        let (end, _, max_dev) = drive(path, Pose2::new(0.0, 0.0, 0.0));
        assert!(end.position().dist(Point2::new(25.0, 3.0)) < 0.6, "{end:?}");
        assert!(
            end.yaw.abs() < 0.2,
            "arrives along the last segment: {end:?}"
        );
        assert!(max_dev < 0.8, "stays near the path: {max_dev}");
    }
}
