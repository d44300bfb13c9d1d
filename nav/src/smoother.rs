//! Smoothing a Hybrid A* path (Dolgov, Thrun, Montemerlo, Diebel 2008, section IV).
//!
//! The search stitches arcs of the minimum turning radius and straights together, so its
//! paths swerve: full lock left, straight, full lock right, where a driver would ease
//! through a gentler curve. The smoother moves the path's points to lower
//! `w_smooth sum |x_{i+1} - 2 x_i + x_{i-1}|^2 + w_data sum |x_i - x_i^0|^2` by gradient
//! steps, Dolgov's smoothness term plus a pull back towards the search's own path.
//!
//! Dolgov's other two terms are hard checks here instead of penalties. The smoothing runs
//! on the search's vertices (one every `vertex_spacing_m`, as in the paper), the path is
//! drawn through them as a cubic Hermite spline sampled every grid cell, and every pose of
//! it must be free of obstacles (our footprint test is exact on the grid, so no Voronoi
//! field is needed) and no heading change may be sharper than the minimum turning radius
//! allows. Where a pose fails, the vertices about it go only half as far towards their
//! smoothed place, then a quarter, then not at all, where the search's own poses (free and
//! drivable) come back: the result is never worse than the search's path, and smoothing is
//! kept wherever it is safe.
//!
//! Cusps (where the path switches between forwards and reverse) and both ends are fixed,
//! each with a fixed ghost vertex beyond it along the search's heading, so the start pose,
//! the goal pose and the heading at every reversal stay exactly as planned. Pure: no I/O.

use firefleet_model::geometry::wrap_angle;
use firefleet_model::{Point2, Pose2};

/// How hard the smoother pulls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Smoothing {
    /// Distance between the vertices that are moved, m: the search's step, as in Dolgov's
    /// paper (smoothing every grid-cell sample would take hundreds of steps to move a
    /// metre-long swerve).
    pub vertex_spacing_m: f64,
    pub w_smooth: f64,
    pub w_data: f64,
    /// Gradient steps at most; it stops earlier once no vertex moves by `tolerance_m`.
    pub iterations: usize,
    pub tolerance_m: f64,
}

impl Default for Smoothing {
    /// `w_smooth` 0.1 is a stable step for the fourth-difference gradient (its largest
    /// eigenvalue is 16); `w_data` 0.02 lets a swerve spread over a few metres but keeps
    /// the path within decimetres of the search's.
    fn default() -> Self {
        Self {
            vertex_spacing_m: 0.5,
            w_smooth: 0.1,
            w_data: 0.02,
            iterations: 300,
            tolerance_m: 1e-4,
        }
    }
}

/// A smoothed path: poses about one `res` apart, and whether each is reached backwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Smoothed {
    pub poses: Vec<Pose2>,
    pub reverse: Vec<bool>,
}

/// The smoothing of `poses` (with `reverse[i]` telling whether pose `i` is reached
/// backwards), sampled every `res` metres or so; `None` if no smoothing of them is free
/// under `free` and drivable at `min_radius_m`.
pub fn smooth(
    poses: &[Pose2],
    reverse: &[bool],
    min_radius_m: f64,
    res: f64,
    free: impl Fn(&Pose2) -> bool,
    s: &Smoothing,
) -> Option<Smoothed> {
    debug_assert_eq!(poses.len(), reverse.len());
    let n = poses.len();
    // Runs between cusps (a cusp is a pose after which the direction changes), each as its
    // vertices: every `vertex_spacing_m` or so, and both of its ends.
    let mut runs: Vec<(&[Pose2], Vec<Pose2>, bool)> = Vec::new();
    let mut start = 0;
    for end in 1..n {
        if end + 1 == n || reverse[end + 1] != reverse[end] {
            let run = &poses[start..=end];
            let len: f64 = run
                .windows(2)
                .map(|w| w[0].position().dist(w[1].position()))
                .sum();
            // Evenly spread, so that no interval is much shorter than the others (the
            // fourth difference would read a short one as a kink).
            let m = ((len / s.vertex_spacing_m).round() as usize).clamp(1, run.len() - 1);
            let v: Vec<Pose2> = (0..=m).map(|k| run[k * (run.len() - 1) / m]).collect();
            runs.push((run, v, reverse[end]));
            start = end;
        }
    }
    let relaxed: Vec<Vec<Point2>> = runs.iter().map(|(_, v, _)| relax(v, s)).collect();
    // How far each vertex goes towards its relaxed place: all the way at first; where the
    // result cuts into an obstacle or bends too sharply, the vertices about it go half as
    // far, then a quarter, then stay where the search put them (an interval between two
    // such is the search's own poses again, which are free and drivable).
    let mut t: Vec<Vec<f64>> = runs.iter().map(|(_, v, _)| vec![1.0; v.len()]).collect();
    for _ in 0..BLEND_PASSES {
        let mut out = Smoothed {
            poses: vec![poses[0]],
            reverse: vec![false],
        };
        // Which run and interval each pose comes from, `None` for the search's own poses.
        let mut from: Vec<Option<(usize, usize)>> = vec![None];
        for (r, ((dense, v, back), x)) in runs.iter().zip(&relaxed).enumerate() {
            let blended: Vec<Point2> = v
                .iter()
                .zip(x)
                .zip(&t[r])
                .map(|((a, b), &t)| {
                    let a = a.position();
                    Point2::new(a.x + t * (b.x - a.x), a.y + t * (b.y - a.y))
                })
                .collect();
            densify(&blended, v, dense, *back, res, &mut out, (&mut from, r));
        }
        let mut failed: Vec<(usize, usize)> = (0..out.poses.len())
            .filter_map(|k| {
                let here = from[k]?;
                let sharp = k > 0 && !step_drivable(&out.poses[k - 1], &out.poses[k], min_radius_m);
                let sharp_next = k + 1 < out.poses.len()
                    && from[k + 1].is_none()
                    && !step_drivable(&out.poses[k], &out.poses[k + 1], min_radius_m);
                (sharp || sharp_next || !free(&out.poses[k])).then_some(here)
            })
            .collect();
        if failed.is_empty() {
            return Some(out);
        }
        failed.dedup();
        for (r, j) in failed {
            let last = t[r].len() - 1;
            for w in &mut t[r][j.saturating_sub(1)..=(j + 2).min(last)] {
                *w = if *w > 0.3 { *w / 2.0 } else { 0.0 };
            }
        }
    }
    None
}

/// Rounds of backing off towards the search's path (three take a vertex all the way back;
/// the rest let the backing off spread to neighbours).
const BLEND_PASSES: usize = 8;

/// The vertices of one run after gradient steps, its ends fixed. Each end also holds a
/// fixed ghost vertex one spacing beyond it along the search's heading there, so that the
/// smoothness term keeps the run's start and end headings.
fn relax(v: &[Pose2], s: &Smoothing) -> Vec<Point2> {
    let n = v.len();
    let original: Vec<Point2> = v.iter().map(|p| p.position()).collect();
    if n < 3 {
        return original;
    }
    let first = v[0].position().dist(v[1].position());
    let last = v[n - 2].position().dist(v[n - 1].position());
    // Ghosts sit in the direction of travel, which for a run driven backwards is the
    // heading's opposite: the chord to the neighbour says which way that is.
    let ghost = |end: Pose2, next: Point2, d: f64| {
        let (c, sn) = (end.yaw.cos(), end.yaw.sin());
        let ahead = (next.x - end.x) * c + (next.y - end.y) * sn >= 0.0;
        let d = if ahead { -d } else { d };
        Point2::new(end.x + d * c, end.y + d * sn)
    };
    let mut x = Vec::with_capacity(n + 2);
    x.push(ghost(v[0], original[1], first));
    x.extend_from_slice(&original);
    x.push(ghost(v[n - 1], original[n - 2], last));
    let lap = |a: Point2, b: Point2, c: Point2| (a.x - 2.0 * b.x + c.x, a.y - 2.0 * b.y + c.y);
    // Only vertices near one that moved last sweep are visited: on a long path most of it
    // is straight road the smoother never touches.
    let mut busy = vec![true; n + 2];
    for _ in 0..s.iterations {
        let mut next = vec![false; n + 2];
        let mut any = false;
        // x[0] and x[n + 1] are the ghosts, x[1] and x[n] the run's ends.
        for i in (2..n).filter(|&i| busy[i]) {
            // Gradient of the smoothness term at i: the second difference's second difference.
            let (l0, l1, l2) = (
                lap(x[i - 2], x[i - 1], x[i]),
                lap(x[i - 1], x[i], x[i + 1]),
                lap(x[i], x[i + 1], x[i + 2]),
            );
            let o = original[i - 1];
            let step = Point2::new(
                -s.w_smooth * (l0.0 - 2.0 * l1.0 + l2.0) + s.w_data * (o.x - x[i].x),
                -s.w_smooth * (l0.1 - 2.0 * l1.1 + l2.1) + s.w_data * (o.y - x[i].y),
            );
            if step.x.hypot(step.y) >= s.tolerance_m {
                x[i] = Point2::new(x[i].x + step.x, x[i].y + step.y);
                next[i - 2..=i + 2].fill(true);
                any = true;
            }
        }
        if !any {
            break;
        }
        busy = next;
    }
    x[1..=n].to_vec()
}

/// Append to `out` the run through vertices `x` (the search's vertices `v`, moved), each
/// pose tagged in `from` with the run and interval it belongs to (`None` for the search's
/// own poses, copied), sampled
/// every `res` or so, as a cubic Hermite spline: through every vertex, with the search's
/// heading at every vertex that did not move and the neighbours' chord (Catmull-Rom) at
/// those that did, and tangent lengths that make it a circular arc wherever the two end
/// headings allow one. Between two vertices that did not move, or with no neighbour that
/// moved, the search's own poses are kept: an arc at full lock stays exactly that arc.
/// Headings are the spline's own tangent (turned round backwards).
fn densify(
    x: &[Point2],
    v: &[Pose2],
    dense: &[Pose2],
    back: bool,
    res: f64,
    out: &mut Smoothed,
    (from, run): (&mut Vec<Option<(usize, usize)>>, usize),
) {
    let n = x.len();
    let flip = if back { std::f64::consts::PI } else { 0.0 };
    let still = |i: usize| x[i].dist(v[i].position()) < 1e-9;
    let yaw = |i: usize| {
        if still(i) {
            v[i].yaw + flip
        } else {
            x[i - 1].bearing_to(x[i + 1])
        }
    };
    let mut k0 = 0;
    for j in 0..n - 1 {
        let k1 = k0
            + 1
            + dense[k0 + 1..]
                .iter()
                .position(|p| *p == v[j + 1])
                .expect("a vertex is one of the poses");
        if still(j) && still(j + 1) {
            for p in &dense[k0 + 1..=k1] {
                out.poses.push(*p);
                out.reverse.push(back);
                from.push(None);
            }
            k0 = k1;
            continue;
        }
        k0 = k1;
        let (a, b) = (x[j], x[j + 1]);
        let (ya, yb) = (yaw(j), yaw(j + 1));
        // A cubic matches a circular arc turning by theta best with tangents of chord /
        // cos^2(theta / 4) (the usual 4/3 tan(theta / 4) Bezier handles).
        let len = a.dist(b) / (wrap_angle(yb - ya) / 4.0).cos().powi(2);
        let (ma, mb) = (
            (ya.cos() * len, ya.sin() * len),
            (yb.cos() * len, yb.sin() * len),
        );
        let k = (a.dist(b) / res).ceil().max(1.0) as usize;
        for step in 1..=k {
            let u = step as f64 / k as f64;
            let (u2, u3) = (u * u, u * u * u);
            let h = [
                2.0 * u3 - 3.0 * u2 + 1.0,
                u3 - 2.0 * u2 + u,
                -2.0 * u3 + 3.0 * u2,
                u3 - u2,
            ];
            let d = [
                6.0 * u2 - 6.0 * u,
                3.0 * u2 - 4.0 * u + 1.0,
                -6.0 * u2 + 6.0 * u,
                3.0 * u2 - 2.0 * u,
            ];
            let at = |w: &[f64; 4], pa: f64, ta: f64, pb: f64, tb: f64| {
                w[0] * pa + w[1] * ta + w[2] * pb + w[3] * tb
            };
            let (px, py) = (at(&h, a.x, ma.0, b.x, mb.0), at(&h, a.y, ma.1, b.y, mb.1));
            let (dx, dy) = (at(&d, a.x, ma.0, b.x, mb.0), at(&d, a.y, ma.1, b.y, mb.1));
            let pose = if step == k {
                // The vertex itself, with its heading (the goal's, at the end).
                Pose2::new(b.x, b.y, wrap_angle(yb - flip))
            } else {
                Pose2::new(px, py, wrap_angle(dy.atan2(dx) + flip))
            };
            out.poses.push(pose);
            out.reverse.push(back);
            from.push(Some((run, j)));
        }
    }
}

/// Whether driving from `a` to `b` turns the heading no more than an arc of
/// `min_radius_m` does over their distance (a chord `d` of a circle of radius `R` turns the
/// heading by `2 asin(d / 2R)`).
pub fn step_drivable(a: &Pose2, b: &Pose2, min_radius_m: f64) -> bool {
    let ds = a.position().dist(b.position());
    let most = 2.0 * (ds / (2.0 * min_radius_m)).min(1.0).asin();
    wrap_angle(b.yaw - a.yaw).abs() <= most + 1e-6
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reeds_shepp::{Turn, advance};

    const R: f64 = 2.0;

    /// A lane change the way the search builds it: full lock left, straight, full lock
    /// right, sampled every 0.1 m.
    fn swerve() -> Vec<Pose2> {
        let mut poses = vec![Pose2::new(0.0, 0.0, 0.0)];
        for (turn, len) in [
            (Turn::Straight, 2.0),
            (Turn::Left, 1.0),
            (Turn::Straight, 1.0),
            (Turn::Right, 1.0),
            (Turn::Straight, 2.0),
        ] {
            let from = *poses.last().unwrap();
            let k = (len / 0.1_f64).round() as usize;
            poses.extend((1..=k).map(|j| advance(from, turn, len * j as f64 / k as f64, R)));
        }
        poses
    }

    fn bending(poses: &[Pose2]) -> f64 {
        poses
            .windows(2)
            .map(|w| wrap_angle(w[1].yaw - w[0].yaw).powi(2))
            .sum()
    }

    fn length(poses: &[Pose2]) -> f64 {
        poses
            .windows(2)
            .map(|w| w[0].position().dist(w[1].position()))
            .sum()
    }

    #[test]
    fn a_swerve_becomes_gentler_shorter_and_stays_drivable() {
        let raw = swerve();
        let reverse = vec![false; raw.len()];
        let smooth = smooth(&raw, &reverse, R, 0.1, |_| true, &Smoothing::default()).unwrap();
        assert!(drivable(&smooth.poses, R, |_| true));
        assert_eq!(smooth.poses.first(), raw.first());
        assert_eq!(
            smooth.poses.last(),
            raw.last(),
            "the goal pose is kept exactly"
        );
        assert!(
            bending(&smooth.poses) < 0.5 * bending(&raw),
            "bending {:.4} from {:.4}",
            bending(&smooth.poses),
            bending(&raw)
        );
        assert!(length(&smooth.poses) < length(&raw));
    }

    #[test]
    fn a_corner_it_may_not_cut_is_cut_less_or_not_at_all() {
        let raw = swerve();
        let reverse = vec![false; raw.len()];
        let free = |_: &Pose2| true;
        let relaxed = smooth(&raw, &reverse, R, 0.1, free, &Smoothing::default()).unwrap();
        // Smoothing eases into the first (left) turn early, above the search's path; an
        // obstacle there forbids that.
        let cut = |q: &Pose2| q.y - raw_y(&raw, q.x);
        let most = relaxed.poses.iter().map(cut).fold(0.0, f64::max);
        assert!(
            most > 0.05,
            "the free smoothing cuts the corner by {most:.3} m"
        );
        let wall = |q: &Pose2| cut(q) < 0.5 * most;
        let held = smooth(&raw, &reverse, R, 0.1, wall, &Smoothing::default()).unwrap();
        assert!(held.poses.iter().all(wall));
        assert!(drivable(&held.poses, R, wall));
    }

    /// The raw path's y at x (nearest sample).
    fn raw_y(raw: &[Pose2], x: f64) -> f64 {
        raw.iter()
            .min_by(|a, b| (a.x - x).abs().total_cmp(&(b.x - x).abs()))
            .unwrap()
            .y
    }

    #[test]
    fn cusps_stay_where_the_search_put_them() {
        // Forwards 3 m turning left, then backwards 3 m turning right.
        let mut poses = vec![Pose2::new(0.0, 0.0, 0.0)];
        let mut reverse = vec![false];
        for (turn, len) in [(Turn::Left, 3.0), (Turn::Right, -3.0)] {
            let from = *poses.last().unwrap();
            poses.extend((1..=30).map(|j| advance(from, turn, len * j as f64 / 30.0, R)));
            reverse.extend(std::iter::repeat_n(len < 0.0, 30));
        }
        let smooth = smooth(&poses, &reverse, R, 0.1, |_| true, &Smoothing::default()).unwrap();
        let cusp = smooth.reverse.iter().position(|r| *r).unwrap() - 1;
        assert_eq!(smooth.poses[cusp], poses[30], "the cusp");
        assert_eq!(smooth.poses.last(), poses.last());
        assert!(smooth.reverse[cusp + 1..].iter().all(|r| *r));
    }

    #[test]
    fn where_nothing_may_move_the_search_path_comes_back() {
        let raw = swerve();
        let reverse = vec![false; raw.len()];
        let pinned = |q: &Pose2| raw.iter().any(|p| p.position().dist(q.position()) < 1e-9);
        let same = smooth(&raw, &reverse, R, 0.1, pinned, &Smoothing::default()).unwrap();
        assert_eq!(same.poses, raw);
    }

    fn drivable(poses: &[Pose2], min_radius_m: f64, free: impl Fn(&Pose2) -> bool) -> bool {
        poses.iter().all(free)
            && poses
                .windows(2)
                .all(|w| step_drivable(&w[0], &w[1], min_radius_m))
    }
}
