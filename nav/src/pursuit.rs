//! Pure pursuit path following for a bicycle-model vehicle, forwards and in reverse.
//!
//! Steer towards the point one look-ahead distance along the path: `delta = atan(2 L
//! sin(alpha) / l_d)` (Coulter, "Implementation of the Pure Pursuit Path Tracking
//! Algorithm", CMU-RI-TR-92-01). Speed drops near the goal and in tight turns.
//!
//! A [`Route`] is a path split at its cusps into runs driven in one direction. The
//! follower drives one run at a time and brakes to a stop at each run's end before the
//! next begins. In reverse the same law holds in the frame of the direction of travel:
//! the rear axle runs on a circle of curvature `-tan(delta) / L` when backing, so the
//! steering angle is the forward one with its sign turned. Backing is slower
//! ([`REVERSE_SPEED_M_S`]): the unit's camera looks forwards and sees nothing of where it
//! goes.
//!
//! Not here: the choice of path (the planners) or any obstacle check; the follower trusts
//! its path and the unit replans when it touches something.

use firefleet_model::geometry::{Point2, Pose2};
use firefleet_model::spec::GroundSpec;

/// Top speed when backing, m/s.
pub const REVERSE_SPEED_M_S: f64 = 0.6;

/// What the follower asks of the vehicle. `speed` is negative when backing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Follow {
    Drive { speed: f64, steer: f64 },
    Arrived,
}

/// Part of a route driven in one direction.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// At least two points, in the order they are driven.
    points: Vec<Point2>,
    reverse: bool,
}

impl Run {
    pub fn points(&self) -> &[Point2] {
        &self.points
    }
    pub fn reverse(&self) -> bool {
        self.reverse
    }
}

/// A path as the follower drives it: runs split at the cusps, each run ending where the
/// next begins. Never empty.
#[derive(Debug, Clone, PartialEq)]
pub struct Route {
    runs: Vec<Run>,
}

impl Route {
    /// A path driven forwards all the way (a lone point is a route already arrived).
    pub fn forward(points: Vec<Point2>) -> Self {
        assert!(!points.is_empty(), "a route has at least its start");
        Self {
            runs: vec![Run {
                points,
                reverse: false,
            }],
        }
    }

    /// A planner's poses, where `reverse[i]` says whether the motion into pose `i` backs
    /// (Hybrid A*'s convention). Every `step`-th pose of each run is kept, and always its
    /// ends: the cusps are where the vehicle must stop.
    pub fn from_poses(poses: &[Pose2], reverse: &[bool], step: usize) -> Self {
        assert!(!poses.is_empty(), "a route has at least its start");
        assert_eq!(poses.len(), reverse.len(), "one direction per pose");
        let step = step.max(1);
        let mut runs: Vec<Run> = Vec::new();
        let mut start = 0;
        while start + 1 < poses.len() {
            let dir = reverse[start + 1];
            let end = (start + 1..poses.len())
                .take_while(|&i| reverse[i] == dir)
                .last()
                .unwrap_or(start + 1);
            let mut points: Vec<Point2> = (start..end)
                .step_by(step)
                .map(|i| poses[i].position())
                .collect();
            points.push(poses[end].position());
            runs.push(Run {
                points,
                reverse: dir,
            });
            start = end;
        }
        if runs.is_empty() {
            return Self::forward(vec![poses[0].position()]);
        }
        Self { runs }
    }

    /// Extend the route forwards to `p`: the last run if it drives forwards, else a new run.
    pub fn push_forward(&mut self, p: Point2) {
        let last = self.runs.last_mut().expect("never empty");
        if !last.reverse {
            last.points.push(p);
            return;
        }
        let from = *last.points.last().expect("runs are never empty");
        self.runs.push(Run {
            points: vec![from, p],
            reverse: false,
        });
    }

    pub fn runs(&self) -> &[Run] {
        &self.runs
    }
}

/// Follows one route.
#[derive(Debug, Clone)]
pub struct PurePursuit {
    route: Route,
    /// Index of the run being driven.
    run: usize,
    /// Index of the segment of that run the vehicle is on.
    seg: usize,
    /// Waiting at a cusp for the wheels to turn to the new run's steering.
    at_cusp: bool,
}

/// The look-ahead distance is the distance driven in [`LOOKAHEAD_S`] at the current speed,
/// within these bounds, m. Short when slow, so that the short tight arcs of a manoeuvre
/// are not cut (a 1.8 m look-ahead cuts a 0.7 m arc at the 2 m turning radius by a third
/// of a metre); long when fast, so that the steering stays calm (Nav2's regulated pure
/// pursuit makes the same choice).
const LOOKAHEAD_S: f64 = 1.5;
const LOOKAHEAD_MIN_M: f64 = 0.8;
const LOOKAHEAD_MAX_M: f64 = 1.8;

/// How far the wheels may be from the commanded angle when the vehicle sets off from a
/// cusp, rad.
const CUSP_STEER_TOLERANCE_RAD: f64 = 0.1;

impl PurePursuit {
    pub fn new(route: Route) -> Self {
        Self {
            route,
            run: 0,
            seg: 0,
            at_cusp: false,
        }
    }

    /// Steering and speed for the vehicle at `pose`, driving at `speed_now` (m/s) with its
    /// wheels at `steer_now`.
    pub fn follow(
        &mut self,
        pose: &Pose2,
        speed_now: f64,
        steer_now: f64,
        spec: &GroundSpec,
    ) -> Follow {
        let p = pose.position();
        self.advance(p);
        // A cusp is passed once the vehicle's projection reaches the run's end: it has
        // braked for it, and the next run starts from there.
        while self.run + 1 < self.route.runs.len() && self.remaining_from(p) < 0.05 {
            self.run += 1;
            self.seg = 0;
            self.at_cusp = true;
            self.advance(p);
        }
        let remaining = self.remaining_from(p);
        let last_run = self.run + 1 == self.route.runs.len();
        // Arrived once past the end, not merely near it: the last run is where the heading
        // the route ends on is made, and a planner's route can end on a manoeuvre shorter
        // than any distance tolerance would be.
        if last_run && remaining < 0.05 {
            return Follow::Arrived;
        }
        let reverse = self.route.runs[self.run].reverse;
        let lookahead = (speed_now.abs() * LOOKAHEAD_S).clamp(LOOKAHEAD_MIN_M, LOOKAHEAD_MAX_M);
        let target = self.lookahead_point(p, lookahead);
        // The target in the frame of the direction of travel.
        let local = pose.to_body(target);
        let (ahead, left) = if reverse {
            (-local.x, -local.y)
        } else {
            (local.x, local.y)
        };
        let ld = ahead.hypot(left).max(0.1);
        // A target behind is turned towards at the law's hardest, as one abeam would be:
        // the sine of an angle near 180 degrees is next to nothing, and the vehicle drove
        // on, away from it.
        let alpha = left
            .atan2(ahead)
            .clamp(-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2);
        let curvature_steer = (2.0 * spec.wheelbase_m * alpha.sin() / ld).atan();
        let steer = if reverse {
            -curvature_steer
        } else {
            curvature_steer
        }
        .clamp(-spec.max_steer_rad, spec.max_steer_rad);
        // Braking distance at max deceleration, with margin, to the goal or the cusp;
        // slower when steering hard or when the target is behind.
        let top = if reverse {
            REVERSE_SPEED_M_S.min(spec.max_speed_m_s)
        } else {
            spec.max_speed_m_s
        };
        let v_stop = (2.0 * spec.max_accel_m_s2 * 0.5 * remaining).sqrt();
        let v_turn = top * (1.0 - 0.6 * steer.abs() / spec.max_steer_rad);
        let v_behind = if ahead < 0.0 { 0.4 } else { top };
        let speed = v_stop.min(v_turn).min(v_behind).clamp(0.2, top);
        // Turn the wheels at the standstill a cusp is: from full lock one way to the other
        // takes a second, and setting off meanwhile leaves the path by tens of centimetres.
        if self.at_cusp {
            if (steer - steer_now).abs() > CUSP_STEER_TOLERANCE_RAD {
                return Follow::Drive { speed: 0.0, steer };
            }
            self.at_cusp = false;
        }
        Follow::Drive {
            speed: if reverse { -speed } else { speed },
            steer,
        }
    }

    /// Where the vehicle at `p` will be over the next `within_m` of the run it drives: a
    /// pose every `step_m`, facing as the vehicle will (backwards on a reverse run). For a
    /// check against what moved since the route was planned: the follower itself trusts
    /// its path.
    pub fn ahead(&self, p: Point2, within_m: f64, step_m: f64) -> Vec<Pose2> {
        let path = self.points();
        let reverse = self.route.runs[self.run].reverse;
        let n = path.len();
        if n < 2 {
            return Vec::new();
        }
        let seg = self.seg.min(n - 2);
        let mut from = lerp(
            path[seg],
            path[seg + 1],
            closest_t(path[seg], path[seg + 1], p),
        );
        let mut poses = Vec::new();
        // Distance along the path from `from` to the next pose wanted, and how far the
        // path has been walked.
        let (mut next, mut walked) = (step_m, 0.0);
        for &to in &path[seg + 1..] {
            let d = from.dist(to);
            let yaw = from.bearing_to(to) + if reverse { std::f64::consts::PI } else { 0.0 };
            while next <= d && walked + next <= within_m {
                let at = lerp(from, to, next / d);
                poses.push(Pose2::new(at.x, at.y, yaw));
                next += step_m;
            }
            walked += d;
            next -= d;
            from = to;
        }
        poses
    }

    fn points(&self) -> &[Point2] {
        &self.route.runs[self.run].points
    }

    /// Move on along the run past the segments whose end `p` has passed.
    fn advance(&mut self, p: Point2) {
        let path = &self.route.runs[self.run].points;
        while self.seg + 2 < path.len() && closest_t(path[self.seg], path[self.seg + 1], p) >= 1.0 {
            self.seg += 1;
        }
    }

    /// The point `lookahead` metres on along the run from the projection of `p`.
    fn lookahead_point(&self, p: Point2, lookahead: f64) -> Point2 {
        let path = self.points();
        let (a, b) = (path[self.seg], path[(self.seg + 1).min(path.len() - 1)]);
        let t = closest_t(a, b, p);
        let mut left = lookahead;
        let mut from = lerp(a, b, t);
        for i in self.seg..path.len() - 1 {
            let to = path[i + 1];
            let d = from.dist(to);
            if d >= left {
                return lerp(from, to, left / d);
            }
            left -= d;
            from = to;
        }
        // Past the end, aim along the last segment's extension: steering at the end point
        // itself would swing the vehicle round to face it and spoil the heading it arrives
        // with (at the goal, or at a cusp where the next run needs it).
        let n = path.len();
        let Some(&end) = path.last() else {
            return p;
        };
        if n < 2 {
            return end;
        }
        let a = path[n - 2];
        let d = a.dist(end);
        if d < 1e-9 {
            return end;
        }
        lerp(
            end,
            Point2::new(2.0 * end.x - a.x, 2.0 * end.y - a.y),
            left / d,
        )
    }

    /// Path length left in the current run from the projection of `p`.
    fn remaining_from(&self, p: Point2) -> f64 {
        let path = self.points();
        let n = path.len();
        // A lone point is a route that starts where it ends.
        if n < 2 {
            return 0.0;
        }
        let seg = self.seg.min(n - 2);
        let (a, b) = (path[seg], path[seg + 1]);
        let c = lerp(a, b, closest_t(a, b, p));
        c.dist(b)
            + path[seg + 1..]
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
    use crate::reeds_shepp;
    use firefleet_model::geometry::wrap_angle;
    use firefleet_model::profile::GROUND;

    /// How a drive under the follower went.
    struct Drive {
        end: Pose2,
        /// Largest distance from the route's polyline.
        max_dev: f64,
        /// Times the vehicle's direction of travel changed.
        reversals: usize,
        /// Largest speed the vehicle had when its direction changed, m/s.
        speed_at_reversal: f64,
    }

    /// Integrate the bicycle model with the simulator's limits (acceleration, steering rate)
    /// under the follower until it reports arrival.
    fn drive(route: Route, mut pose: Pose2) -> Drive {
        let dt = 0.05;
        let polyline: Vec<(Point2, Point2)> = route
            .runs()
            .iter()
            .flat_map(|r| r.points().windows(2).map(|w| (w[0], w[1])))
            .collect();
        let mut pp = PurePursuit::new(route);
        let (mut v, mut delta) = (0.0f64, 0.0f64);
        let mut d = Drive {
            end: pose,
            max_dev: 0.0,
            reversals: 0,
            speed_at_reversal: 0.0,
        };
        let mut moving = 0.0f64;
        for _ in 0..4000 {
            let Follow::Drive { speed, steer } = pp.follow(&pose, v, delta, &GROUND) else {
                d.end = pose;
                return d;
            };
            let a = GROUND.max_accel_m_s2 * dt;
            v += (speed - v).clamp(-a, a);
            let r = GROUND.max_steer_rate_rad_s * dt;
            delta += (steer - delta).clamp(-r, r);
            if v.abs() > 1e-9 {
                if moving != 0.0 && v.signum() != moving {
                    d.reversals += 1;
                    d.speed_at_reversal = d.speed_at_reversal.max(v.abs());
                }
                moving = v.signum();
            }
            pose.yaw = wrap_angle(pose.yaw + v / GROUND.wheelbase_m * delta.tan() * dt);
            pose.x += v * pose.yaw.cos() * dt;
            pose.y += v * pose.yaw.sin() * dt;
            let dev = polyline
                .iter()
                .map(|&(a, b)| lerp(a, b, closest_t(a, b, pose.position())).dist(pose.position()))
                .fold(f64::INFINITY, f64::min);

            d.max_dev = d.max_dev.max(dev);
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
        let d = drive(Route::forward(path), Pose2::new(0.0, 0.0, 0.0));
        assert!(
            d.end.position().dist(Point2::new(25.0, 3.0)) < 0.6,
            "{:?}",
            d.end
        );
        assert!(
            d.end.yaw.abs() < 0.2,
            "arrives along the last segment: {:?}",
            d.end
        );
        assert!(d.max_dev < 0.8, "stays near the path: {}", d.max_dev);
        assert_eq!(d.reversals, 0);
    }

    #[test]
    fn backs_along_a_reverse_run_facing_the_way_it_came() {
        let start = Pose2::new(0.0, 0.0, 0.0);
        // Back 12 m while moving over a lane: an S in reverse.
        let to = Pose2::new(-12.0, 2.0, 0.0);
        let rs = reeds_shepp::shortest(start, to, 1.5 * GROUND.min_turn_radius_m());
        assert!(rs.segments.iter().all(|s| s.length <= 0.0), "{rs:?}");
        let poses = rs.sample(start, 1.5 * GROUND.min_turn_radius_m(), 0.1);
        let reverse: Vec<bool> = (0..poses.len()).map(|i| i > 0).collect();
        let route = Route::from_poses(&poses, &reverse, 3);
        assert_eq!(route.runs().len(), 1);
        let d = drive(route, start);
        assert!(d.end.position().dist(to.position()) < 0.6, "{:?}", d.end);
        assert!(wrap_angle(d.end.yaw).abs() < 0.2, "{:?}", d.end);
        assert!(d.max_dev < 0.3, "stays near the path: {}", d.max_dev);
        assert_eq!(d.reversals, 0, "backs all the way");
    }

    /// Turning round in the road at the vehicle's tightest radius, then a straight run-in,
    /// as the unit's firing routes end.
    #[test]
    fn turns_round_to_a_path_that_sets_off_behind_it() {
        // Facing +x, the path runs to -x, straight behind: the sine of the angle to the
        // look-ahead point is next to nothing, and the follower drove on, away from it.
        let path = vec![Point2::new(0.0, 0.0), Point2::new(-30.0, -0.5)];
        let d = drive(Route::forward(path), Pose2::new(0.0, 0.0, 0.0));
        assert!(
            d.end.position().dist(Point2::new(-30.0, -0.5)) < 0.6,
            "{:?}",
            d.end
        );
        assert!(
            d.max_dev < 2.0 * GROUND.min_turn_radius_m() + 1.0,
            "a turn at full lock, not a drive away: {}",
            d.max_dev
        );
    }

    #[test]
    fn the_poses_ahead_follow_the_run_from_the_vehicles_projection() {
        let route = Route::forward(vec![
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
            Point2::new(2.0, 5.0),
        ]);
        let f = PurePursuit::new(route);
        let ahead = f.ahead(Point2::new(1.0, 0.3), 2.5, 0.5);
        let at: Vec<(f64, f64)> = ahead.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(
            at,
            [(1.5, 0.0), (2.0, 0.0), (2.0, 0.5), (2.0, 1.0), (2.0, 1.5)]
        );
        assert!(
            (ahead[4].yaw - std::f64::consts::FRAC_PI_2).abs() < 1e-12,
            "round the corner"
        );
        // Backing, the body faces against the way it goes.
        let back = PurePursuit::new(Route::from_poses(
            &[Pose2::new(0.0, 0.0, 0.0), Pose2::new(-3.0, 0.0, 0.0)],
            &[true, true],
            1,
        ));
        let behind = back.ahead(Point2::new(0.0, 0.0), 1.0, 1.0);
        assert_eq!(behind.len(), 1);
        assert!((behind[0].x + 1.0).abs() < 1e-12 && behind[0].yaw.cos() > 0.99);
    }

    #[test]
    fn drives_a_path_with_cusps_stopping_at_each() {
        let radius = GROUND.min_turn_radius_m();
        let start = Pose2::new(0.0, 0.0, 0.0);
        let turned = Pose2::new(1.0, 2.5, std::f64::consts::PI);
        let rs = reeds_shepp::shortest(start, turned, radius);
        let poses = rs.sample(start, radius, 0.1);
        let mut reverse = vec![false];
        for s in &rs.segments {
            let n = (s.length.abs() / 0.1).ceil().max(1.0) as usize;
            reverse.extend(std::iter::repeat_n(s.length < 0.0, n));
        }
        let mut route = Route::from_poses(&poses, &reverse, 2);
        let cusps = route.runs().len() - 1;
        assert!(cusps >= 1, "the turn needs backing: {rs:?}");
        let goal = Point2::new(-1.5, 2.5);
        route.push_forward(goal);
        let d = drive(route, start);
        assert!(d.end.position().dist(goal) < 0.6, "{:?}", d.end);
        assert!(
            wrap_angle(d.end.yaw - turned.yaw).abs() < 0.2,
            "ends turned round: {:?}",
            d.end
        );
        assert!(d.max_dev < 0.3, "stays near the path: {}", d.max_dev);
        assert_eq!(d.reversals, cusps, "changes direction at the cusps only");
        assert!(
            d.speed_at_reversal < 0.1,
            "at a standstill when it does: {}",
            d.speed_at_reversal
        );
    }

    #[test]
    fn a_route_splits_at_cusps_and_keeps_their_poses() {
        let poses: Vec<Pose2> = (0..10)
            .map(|i| Pose2::new(f64::from(i), 0.0, 0.0))
            .collect();
        let reverse = [
            false, false, false, false, true, true, true, false, false, false,
        ];
        let route = Route::from_poses(&poses, &reverse, 2);
        let runs: Vec<(bool, Vec<f64>)> = route
            .runs()
            .iter()
            .map(|r| (r.reverse(), r.points().iter().map(|p| p.x).collect()))
            .collect();
        assert_eq!(
            runs,
            vec![
                (false, vec![0.0, 2.0, 3.0]),
                (true, vec![3.0, 5.0, 6.0]),
                (false, vec![6.0, 8.0, 9.0]),
            ]
        );
        let mut route = route;
        route.push_forward(Point2::new(10.0, 0.0));
        assert_eq!(route.runs().len(), 3);
        assert_eq!(
            route.runs()[2].points().last(),
            Some(&Point2::new(10.0, 0.0))
        );
    }
}
