//! Hybrid A* (Dolgov, Thrun, Montemerlo, Diebel 2008) with the BT paper's visibility
//! reward (section 3.3.1, eq. 1-6).
//!
//! The search runs over continuous poses, deduplicated in cells of `xy_bin_m` and
//! `heading_bins` headings. A node expands by six motion primitives: an arc of `step_m`
//! turning fully left, straight or fully right (the minimum turning radius), forwards or
//! backwards. The cost of a primitive is `w_dist ds + w_steer |steer| ds` (times
//! `w_reverse` backwards) plus `w_switch` when the direction changes: the paper's
//! `w1 ds + w2 |delta| + w3 I_rev`. The heuristic is `max(obstacle-aware 2-D distance,
//! Reeds-Shepp distance)`; the 2-D part is a Dijkstra from the goal over a coarse grid
//! (passable where any fine cell is, so it never overestimates), the Reeds-Shepp part is
//! computed near the goal only, where it dominates. Near the goal each node also tries the
//! analytic expansion: the Reeds-Shepp path to the goal, taken if collision-free.
//!
//! Visibility: `h' = h + lambda (1 - I_LOS)`, with `I_LOS = 1` when the segment from the
//! pose to the flame crosses no occupied cell of the sight grid (a supercover traversal,
//! which misses no cell the segment touches, where Bresenham would let a sight line slip
//! through a corner). The paper writes `h + lambda I_LOS` and describes a reward for keeping
//! the flame in view; as printed that would penalise visibility, so the term charges
//! losing sight instead.
//!
//! Heat: given the fires' positions and heat releases ([`HeatSource`], [`firefleet_model::heat`]), each primitive
//! also costs `w_heat q ds`, `q` the radiant flux at its end (point source radiating 30 %
//! of the heat release, capped at 100 kW/m^2): the path keeps its distance from fires
//! where that is cheap, which is the heat-exposure term of the Dijkstra+GA paper's cost
//! map (eq. 6) on continuous poses. The heuristic ignores it and stays admissible. The
//! analytic Reeds-Shepp tail (within `analytic_within_m` of the goal) is taken without
//! its heat cost; the goal is a firing position at a standoff chosen for its flux anyway.
//!
//! Smoothing: the path found is handed to [`smoother`] (Dolgov's smoothing with the
//! obstacle and curvature terms as hard checks); its result replaces the search's path only
//! if every pose of it is free and drivable, which is checked with this planner's own
//! footprint test.
//!
//! Collisions: the footprint rectangle's outline, sampled at the grid's resolution, on
//! the occupancy grid of walls and vehicles (not inflated: the footprint is the robot).
//! A pose whose cell is clear of every blocked cell by more than the outline's reach
//! ([`Grid::clearance_m`]) is free without looking at the outline: in a tunnel most poses
//! are, and the answer is the same as the outline's (the bound below proves it).
//! Pure: no I/O, no clock.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use firefleet_model::geometry::wrap_angle;
use firefleet_model::heat::{HeatSource, radiant_flux_kw_m2};
use firefleet_model::{Point2, Pose2};
use rustc_hash::FxHashMap;

use super::grid::Grid;
use super::grid_search::CostGrid;
use super::reeds_shepp::{self, Turn};
use super::smoother::{self, Smoothing};

/// The robot's footprint: a rectangle centred on the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    pub length_m: f64,
    pub width_m: f64,
}

/// How the planner searches.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub min_radius_m: f64,
    pub step_m: f64,
    pub xy_bin_m: f64,
    pub heading_bins: usize,
    pub w_dist: f64,
    pub w_steer: f64,
    pub w_reverse: f64,
    pub w_switch: f64,
    pub goal_xy_tol_m: f64,
    pub goal_yaw_tol_rad: f64,
    /// The visibility term's weight, m (0: off).
    pub lambda_m: f64,
    /// The heat term's weight, m of path per kW/m^2 of radiant flux per m driven.
    pub w_heat: f64,
    /// Try the analytic Reeds-Shepp expansion within this distance of the goal, m.
    pub analytic_within_m: f64,
    /// Whether paths may reverse (a follower that only drives forwards needs `false`:
    /// no backward primitives, and only analytic expansions without a reversal).
    pub allow_reverse: bool,
    pub max_expansions: usize,
    /// Smooth the path the search finds ([`smoother`]); `None` keeps it as searched.
    pub smoothing: Option<Smoothing>,
}

impl Params {
    /// Defaults for a robot turning at `min_radius_m`: 72 heading bins, primitives of
    /// 0.5 m in 0.25 m cells, reversing twice as dear as driving forwards.
    pub fn for_radius(min_radius_m: f64) -> Self {
        Self {
            min_radius_m,
            step_m: 0.5,
            xy_bin_m: 0.25,
            heading_bins: 72,
            w_dist: 1.0,
            w_steer: 0.2,
            w_reverse: 2.0,
            w_switch: 2.0,
            goal_xy_tol_m: 0.25,
            goal_yaw_tol_rad: 5f64.to_radians(),
            lambda_m: 0.0,
            w_heat: 0.25,
            analytic_within_m: 12.0,
            allow_reverse: true,
            max_expansions: 200_000,
            smoothing: Some(Smoothing::default()),
        }
    }
}

/// Why no path was found.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlanError {
    #[error("the start pose collides")]
    StartBlocked,
    #[error("the goal pose collides")]
    GoalBlocked,
    #[error("no path after {0} expansions")]
    NoPath(usize),
}

/// A planned path: poses every grid cell or so, and whether each is driven backwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Which of the goals the path reaches (0 for [`HybridAStar::plan`]).
    pub goal: usize,
    pub poses: Vec<Pose2>,
    pub reverse: Vec<bool>,
    pub length_m: f64,
    pub expansions: usize,
    /// Whether the smoother's path replaced the search's.
    pub smoothed: bool,
}

#[derive(Debug, Clone, Copy)]
struct Node {
    pose: Pose2,
    g: f64,
    parent: usize,
    steer: i8,
    reverse: bool,
}

/// `v.floor()` for the bins of the search: `floor` is a library call on the x86-64
/// baseline, three per node.
fn floor(v: f64) -> i64 {
    let t = v as i64;
    if (t as f64) > v { t - 1 } else { t }
}

/// Poses of one primitive, every `res` along it.
fn arc(from: Pose2, turn: Turn, length: f64, radius: f64, res: f64) -> impl Iterator<Item = Pose2> {
    let n = (length.abs() / res).ceil().max(1.0) as usize;
    (1..=n).map(move |k| reeds_shepp::advance(from, turn, length * k as f64 / n as f64, radius))
}

/// The planner for one map.
pub struct HybridAStar<'a> {
    grid: &'a Grid,
    footprint: Footprint,
    outline: Vec<(f64, f64)>,
    /// A pose is free if its cell's clearance exceeds this, m: an outline point lies within
    /// the outline's radius of the pose, the pose within half a cell's diagonal of its
    /// cell's centre and the point within as much of its own cell's centre, so no outline
    /// point's cell is nearer the pose's cell than `radius + diagonal`.
    clear_beyond_m: f64,
    params: Params,
    heat: Vec<HeatSource>,
}

impl<'a> HybridAStar<'a> {
    pub fn new(grid: &'a Grid, footprint: Footprint, params: Params) -> Self {
        // The outline of the footprint in the body frame, one point per grid cell.
        let (hl, hw) = (footprint.length_m / 2.0, footprint.width_m / 2.0);
        let res = grid.resolution();
        let mut outline = Vec::new();
        let n_l = (footprint.length_m / res).ceil() as usize;
        let n_w = (footprint.width_m / res).ceil() as usize;
        for k in 0..=n_l {
            let x = -hl + footprint.length_m * k as f64 / n_l as f64;
            outline.push((x, hw));
            outline.push((x, -hw));
        }
        for k in 1..n_w {
            let y = -hw + footprint.width_m * k as f64 / n_w as f64;
            outline.push((hl, y));
            outline.push((-hl, y));
        }
        let radius = outline.iter().map(|&(x, y)| x.hypot(y)).fold(0.0, f64::max);
        Self {
            grid,
            footprint,
            clear_beyond_m: radius + res * std::f64::consts::SQRT_2,
            outline,
            params,
            heat: Vec::new(),
        }
    }

    /// The same planner, charging for the radiant heat of `sources` on the way.
    pub fn with_heat(mut self, sources: Vec<HeatSource>) -> Self {
        self.heat = sources;
        self
    }

    pub fn footprint(&self) -> Footprint {
        self.footprint
    }

    /// Whether the footprint at `p` touches no occupied cell.
    pub fn pose_free(&self, p: &Pose2) -> bool {
        let Some(cell) = self.grid.cell(p.position()) else {
            return false;
        };
        self.grid.clearance_m(cell) > self.clear_beyond_m || self.outline_free(p)
    }

    /// Whether every point of the footprint's outline at `p` lies on a free cell.
    fn outline_free(&self, p: &Pose2) -> bool {
        let (s, c) = p.yaw.sin_cos();
        self.outline.iter().all(|&(bx, by)| {
            self.grid
                .free(Point2::new(p.x + c * bx - s * by, p.y + s * bx + c * by))
        })
    }

    /// Dijkstra from the goals over a coarse grid: the obstacle-aware 2-D distance to the
    /// nearest goal, and the coarse cell size. The coarse grid is made once for all goals.
    fn distance_field(&self, goals: &[Point2]) -> (Vec<f64>, usize) {
        let (w, h) = self.grid.size();
        let k = ((0.5 / self.grid.resolution()).round() as usize).max(1);
        let (cw, ch) = (w.div_ceil(k), h.div_ceil(k));
        let passable: Vec<bool> = (0..cw * ch)
            .map(|i| {
                let (cc, cr) = (i % cw, i / cw);
                (cr * k..((cr + 1) * k).min(h))
                    .any(|r| (cc * k..((cc + 1) * k).min(w)).any(|c| !self.grid.blocked((c, r))))
            })
            .collect();
        let coarse = CostGrid::from_passable(cw, ch, &passable).expect("sizes match");
        let mut dist = vec![f64::INFINITY; cw * ch];
        for goal in goals {
            let g = self
                .grid
                .cell(*goal)
                .map_or((0, 0), |(c, r)| (c / k, r / k));
            for (d, o) in dist.iter_mut().zip(coarse.dijkstra_all(g)) {
                *d = d.min(o);
            }
        }
        (dist, k)
    }

    /// Plan from `start` to `goal`, keeping `flame` in view if given and `lambda_m > 0`.
    pub fn plan(
        &self,
        start: Pose2,
        goal: Pose2,
        flame: Option<Point2>,
    ) -> Result<Plan, PlanError> {
        self.plan_any(start, &[goal], flame)
    }

    /// Plan from `start` to whichever of `goals` is cheapest to reach; [`Plan::goal`] says
    /// which. One search to all of them costs less than one per goal (nodes on the way
    /// to several are expanded once) and takes the budget where it is needed: a goal
    /// that cannot be reached does not use it up before the others are tried. Blocked
    /// goals are left out; `GoalBlocked` if all are.
    pub fn plan_any(
        &self,
        start: Pose2,
        goals: &[Pose2],
        flame: Option<Point2>,
    ) -> Result<Plan, PlanError> {
        let p = &self.params;
        if !self.pose_free(&start) {
            return Err(PlanError::StartBlocked);
        }
        let goals: Vec<(usize, Pose2)> = goals
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, g)| self.pose_free(g))
            .collect();
        if goals.is_empty() {
            return Err(PlanError::GoalBlocked);
        }
        let res = self.grid.resolution();
        let positions: Vec<Point2> = goals.iter().map(|(_, g)| g.position()).collect();
        let (dist, k) = self.distance_field(&positions);
        let (w, _) = self.grid.size();
        let cw = w.div_ceil(k);
        let coarse_m = res * k as f64;
        let h2d = |q: &Pose2| {
            self.grid
                .cell(q.position())
                .map_or(f64::INFINITY, |(c, r)| {
                    // Cells of the coarse grid are up to a diagonal apart from the pose.
                    (dist[(r / k) * cw + c / k] * coarse_m - coarse_m * std::f64::consts::SQRT_2)
                        .max(0.0)
                })
        };
        // I_LOS per grid cell, traced once from the cell's centre (the paper's Bresenham
        // runs cell to cell too) and kept: a cell is reached at many headings, and a trace
        // to a flame 100 m off crosses a thousand cells. 0: not traced, 1: in view, 2: not.
        let (gw, gh) = self.grid.size();
        let traced: Vec<std::cell::Cell<u8>> = if flame.is_some() && p.lambda_m > 0.0 {
            vec![std::cell::Cell::new(0); gw * gh]
        } else {
            Vec::new()
        };
        let visible = |q: &Pose2| {
            let Some(f) = flame else { return true };
            let Some((c, r)) = self.grid.cell(q.position()) else {
                return false;
            };
            let k = &traced[r * gw + c];
            if k.get() == 0 {
                let seen = self.grid.segment_free(self.grid.center((c, r)), f);
                k.set(if seen { 1 } else { 2 });
            }
            k.get() == 1
        };
        // The least Reeds-Shepp distance to a goal, which goal, and whether it is close
        // enough for an analytic expansion. Beyond `analytic_within_m` the straight line
        // stands in for it (a lower bound too, and cheap); a goal's Reeds-Shepp distance
        // is only worked out while its straight line is shorter than the best so far.
        let nearest = |q: &Pose2| {
            let line = |j: usize| q.position().dist(goals[j].1.position());
            let closest = (0..goals.len())
                .min_by(|&a, &b| line(a).total_cmp(&line(b)))
                .expect("at least one goal");
            let mut best = (f64::INFINITY, closest, false);
            for j in std::iter::once(closest).chain((0..goals.len()).filter(|&j| j != closest)) {
                let l = line(j);
                if l >= best.0 {
                    continue;
                }
                best = if l < p.analytic_within_m {
                    let rs = reeds_shepp::distance(*q, goals[j].1, p.min_radius_m);
                    if rs < best.0 { (rs, j, true) } else { best }
                } else {
                    (l, j, false)
                };
            }
            best
        };
        let h = |q: &Pose2| {
            let mut v = h2d(q).max(nearest(q).0);
            if p.lambda_m > 0.0 && !visible(q) {
                v += p.lambda_m;
            }
            p.w_dist * v
        };
        let bin = |q: &Pose2| {
            let t = (wrap_angle(q.yaw) + std::f64::consts::PI) / std::f64::consts::TAU;
            (
                floor(q.x / p.xy_bin_m),
                floor(q.y / p.xy_bin_m),
                ((t * p.heading_bins as f64) as usize).min(p.heading_bins - 1),
            )
        };
        let mut nodes = vec![Node {
            pose: start,
            g: 0.0,
            parent: usize::MAX,
            steer: 0,
            reverse: false,
        }];
        let mut best: FxHashMap<(i64, i64, usize), f64> = FxHashMap::default();
        best.insert(bin(&start), 0.0);
        let mut open = BinaryHeap::new();
        open.push((Reverse(h(&start).to_bits()), 0usize));
        let mut expansions = 0;
        while let Some((_, i)) = open.pop() {
            let n = nodes[i];
            if best.get(&bin(&n.pose)).is_some_and(|g| *g < n.g) {
                continue;
            }
            expansions += 1;
            if expansions > p.max_expansions {
                return Err(PlanError::NoPath(expansions));
            }
            if let Some(&(j, _)) = goals.iter().find(|(_, g)| {
                n.pose.position().dist(g.position()) <= p.goal_xy_tol_m
                    && wrap_angle(n.pose.yaw - g.yaw).abs() <= p.goal_yaw_tol_rad
            }) {
                return Ok(self.finish(&nodes, i, j, None, expansions));
            }
            let (_, j, near) = nearest(&n.pose);
            if near {
                let rs = reeds_shepp::shortest(n.pose, goals[j].1, p.min_radius_m);
                let samples = rs.sample(n.pose, p.min_radius_m, res);
                if (p.allow_reverse || !rs.reverses()) && samples.iter().all(|q| self.pose_free(q))
                {
                    return Ok(self.finish(&nodes, i, goals[j].0, Some(rs), expansions));
                }
            }
            for reverse in [false, true] {
                if reverse && !p.allow_reverse {
                    continue;
                }
                for steer in [-1i8, 0, 1] {
                    let turn = match steer {
                        -1 => Turn::Right,
                        0 => Turn::Straight,
                        _ => Turn::Left,
                    };
                    let len = if reverse { -p.step_m } else { p.step_m };
                    let mut end = n.pose;
                    let mut free = true;
                    for q in arc(n.pose, turn, len, p.min_radius_m, res) {
                        if !self.pose_free(&q) {
                            free = false;
                            break;
                        }
                        end = q;
                    }
                    if !free {
                        continue;
                    }
                    let mut cost = p.step_m * (p.w_dist + p.w_steer * f64::from(steer.abs()));
                    if !self.heat.is_empty() {
                        cost +=
                            p.w_heat * p.step_m * radiant_flux_kw_m2(&self.heat, end.position());
                    }
                    if reverse {
                        cost *= p.w_reverse;
                    }
                    if i != 0 && reverse != n.reverse {
                        cost += p.w_switch;
                    }
                    let g = n.g + cost;
                    let key = bin(&end);
                    if best.get(&key).is_some_and(|b| *b <= g) {
                        continue;
                    }
                    best.insert(key, g);
                    nodes.push(Node {
                        pose: end,
                        g,
                        parent: i,
                        steer,
                        reverse,
                    });
                    open.push((Reverse((g + h(&end)).to_bits()), nodes.len() - 1));
                }
            }
        }
        Err(PlanError::NoPath(expansions))
    }

    /// The path to node `i`, then the analytic tail if any, sampled every grid cell; it
    /// reaches goal `goal`.
    fn finish(
        &self,
        nodes: &[Node],
        mut i: usize,
        goal: usize,
        tail: Option<reeds_shepp::Path>,
        expansions: usize,
    ) -> Plan {
        let res = self.grid.resolution();
        let r = self.params.min_radius_m;
        let mut chain = Vec::new();
        while i != usize::MAX {
            chain.push(nodes[i]);
            i = nodes[i].parent;
        }
        chain.reverse();
        let mut poses = vec![chain[0].pose];
        let mut reverse = vec![false];
        for w in chain.windows(2) {
            let (a, b) = (w[0], w[1]);
            let turn = match b.steer {
                -1 => Turn::Right,
                0 => Turn::Straight,
                _ => Turn::Left,
            };
            let len = if b.reverse {
                -self.params.step_m
            } else {
                self.params.step_m
            };
            for q in arc(a.pose, turn, len, r, res) {
                poses.push(q);
                reverse.push(b.reverse);
            }
        }
        if let Some(rs) = tail {
            let mut at = *poses.last().expect("the start is there");
            for s in &rs.segments {
                for q in arc(at, s.turn, s.length, r, res) {
                    poses.push(q);
                    reverse.push(s.length < 0.0);
                }
                at = reeds_shepp::advance(at, s.turn, s.length, r);
            }
        }
        let smoothed = self
            .params
            .smoothing
            .and_then(|s| smoother::smooth(&poses, &reverse, r, res, |q| self.pose_free(q), &s));
        let (poses, reverse, smoothed) = match smoothed {
            Some(s) => (s.poses, s.reverse, true),
            None => (poses, reverse, false),
        };
        let length_m = poses
            .windows(2)
            .map(|w| w[0].position().dist(w[1].position()))
            .sum();
        Plan {
            goal,
            poses,
            reverse,
            length_m,
            expansions,
            smoothed,
        }
    }
}

#[cfg(test)]
mod tests;
