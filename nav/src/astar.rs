//! 8-connected A* on the occupancy grid, then string pulling into straight segments.
//!
//! Not here: kinematics (paths here turn on the spot; [`crate::hybrid_astar`] plans what a
//! car-like unit can drive) or cost maps ([`crate::grid_search`]).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use firefleet_model::Point2;

use super::grid::{Grid, NEIGHBOURS};

/// How far from its start a path may run through inflated (but not truly occupied)
/// space, m; about the inflation margin.
const ESCAPE_M: f64 = 1.0;

/// How much the search's estimate of the way left outweighs the way so far: a path at
/// most this factor longer than the shortest. The estimate (the octile distance) knows
/// nothing of the vehicles ahead, and in a long tunnel the shortest way's lane changes
/// add up: every cell near the start with a lane change of its own still looked better
/// than the whole way, and an exact search filled the tunnel's width end to end (656 000
/// cells for a 34 000-cell path, 161 ms, over 8.6 km). Weighted by 1 %, cells far from
/// the goal lose that tie: 37 000 cells, 10 ms, and the path 1 cm longer (`firefleet-lab
/// length`, which prints the plan times).
const ESTIMATE_WEIGHT: f64 = 1.01;

/// A path from `start` to `goal` through free cells, as corner points (first is `start`,
/// last is `goal`); `None` if the goal cannot be reached. The path is at most
/// [`ESTIMATE_WEIGHT`] times as long as the shortest through the grid.
pub fn plan(grid: &Grid, start: Point2, goal: Point2) -> Option<Vec<Point2>> {
    let (w, h) = grid.size();
    let s = grid.cell(start)?;
    let g = grid.cell(goal)?;
    if grid.blocked(g) {
        return None;
    }
    let idx = |(c, r): (usize, usize)| r * w + c;
    let estimate = |(c, r): (usize, usize)| {
        let (dx, dy) = (c.abs_diff(g.0) as f64, r.abs_diff(g.1) as f64);
        ESTIMATE_WEIGHT * (dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy))
    };
    // Per cell, the cost so far and the parent (its index + 1), both zero where nothing is
    // known yet: a zeroed allocation is pages the system zeroes when first touched, so a
    // plan pays for the stretch of tunnel it searches, not for the whole grid (a 250 m
    // plan in a 10 km tunnel spent most of its time filling two arrays of 1.6 million
    // cells).
    let mut cost = Costs(vec![0u64; w * h]);
    let mut parent = vec![0usize; w * h];
    let mut open = BinaryHeap::new();
    cost.set(idx(s), 0.0);
    // Keys are costs scaled to integers: exact ordering without a float wrapper. Among
    // entries of equal estimate the one farthest from the start comes first: in open road
    // every cell between the start's row and the goal's may lie on a shortest way (any
    // order of the straight and diagonal steps is as short), and the deepest leads on
    // where any other would widen the search. Each entry keeps the cost it was pushed
    // with, also to skip it once the cell is reached cheaper.
    let key = |f: f64| Reverse((f * 1024.0) as u64);
    let pushed = |g: f64| (g * 1024.0) as u64;
    open.push((key(estimate(s)), pushed(0.0), idx(s)));
    // The start may sit in inflated space (a robot that stopped close to a wall or a
    // vehicle): cells within ESCAPE_M of it are passable so that it can get out.
    let escape = (ESCAPE_M / grid.resolution()).ceil() as usize;
    let passable = |c: (usize, usize)| {
        !grid.blocked(c) || (c.0.abs_diff(s.0) <= escape && c.1.abs_diff(s.1) <= escape)
    };
    while let Some((_, g_key, i)) = open.pop() {
        let cur = (i % w, i / w);
        if cur == g {
            break;
        }
        // A stale entry: the cell was reached more cheaply since.
        if g_key > pushed(cost.get(i)) {
            continue;
        }
        for (dc, dr) in NEIGHBOURS {
            let (Some(c), Some(r)) = (cur.0.checked_add_signed(dc), cur.1.checked_add_signed(dr))
            else {
                continue;
            };
            if c >= w || r >= h || !passable((c, r)) {
                continue;
            }
            // No corner cutting past a blocked cell.
            if dc != 0 && dr != 0 && (!passable((cur.0, r)) || !passable((c, cur.1))) {
                continue;
            }
            let step = if dc != 0 && dr != 0 {
                std::f64::consts::SQRT_2
            } else {
                1.0
            };
            let n = r * w + c;
            let nc = cost.get(i) + step;
            if nc < cost.get(n) {
                cost.set(n, nc);
                parent[n] = i + 1;
                open.push((key(nc + estimate((c, r))), pushed(nc), n));
            }
        }
    }
    if !cost.get(idx(g)).is_finite() {
        return None;
    }
    let mut cells = vec![idx(g)];
    while let Some(&last) = cells.last() {
        if last == idx(s) {
            break;
        }
        cells.push(parent[last] - 1);
    }
    cells.reverse();
    let mut pts: Vec<Point2> = cells.iter().map(|&i| grid.center((i % w, i / w))).collect();
    pts[0] = start;
    *pts.last_mut().expect("non-empty") = goal;
    Some(string_pull(grid, &pts))
}

/// Costs so far, infinite until set, stored so that infinity is all zero bits (the bits of
/// the cost XOR those of infinity: exact both ways).
struct Costs(Vec<u64>);

impl Costs {
    fn get(&self, i: usize) -> f64 {
        f64::from_bits(self.0[i] ^ f64::INFINITY.to_bits())
    }
    fn set(&mut self, i: usize, cost: f64) {
        self.0[i] = cost.to_bits() ^ f64::INFINITY.to_bits();
    }
}

/// Longest straight segment string pulling makes, m: each sight line it tests is traced
/// cell by cell where the road is narrow, so a cap bounds the cost of one test. A corner
/// every 250 m on a straight line costs the follower nothing, and it leaves every path
/// in a 300 m tunnel as it was.
const MAX_SEGMENT_M: f64 = 250.0;

/// Keep only the corners needed for straight, free segments of at most [`MAX_SEGMENT_M`]:
/// from each corner, the farthest point of the grid path it sees, found by doubling the
/// reach while the point at it is seen and then halving back between the last point seen
/// and the first not. That is a few sight lines a corner; testing every point in turn
/// until one was hidden made string pulling most of a plan's time (3 of 4 ms over 250 m,
/// a thousand sight lines of up to 250 m each). Where a point hides behind an obstacle and
/// a farther one is seen again, the search may take the farther one: every segment is
/// still tested free, and the path only shorter. A start inside inflated space sees no
/// free segment, so the path keeps its first grid step out of it.
fn string_pull(grid: &Grid, pts: &[Point2]) -> Vec<Point2> {
    let last = pts.len() - 1;
    let mut out = vec![pts[0]];
    let mut anchor = 0;
    while anchor < last {
        let sees = |k: usize| {
            pts[anchor].dist(pts[k]) <= MAX_SEGMENT_M && grid.segment_free(pts[anchor], pts[k])
        };
        // The next point is a grid step away: the path's own, seen or not.
        let mut seen = anchor + 1;
        let mut reach = 1;
        while seen + reach <= last && sees(seen + reach) {
            seen += reach;
            reach *= 2;
        }
        let mut hidden = (seen + reach).min(last + 1);
        while hidden - seen > 1 {
            let mid = seen + (hidden - seen) / 2;
            if sees(mid) {
                seen = mid;
            } else {
                hidden = mid;
            }
        }
        out.push(pts[seen]);
        anchor = seen;
    }
    out
}

/// Length of a polyline, m.
pub fn length(path: &[Point2]) -> f64 {
    path.windows(2).map(|w| w[0].dist(w[1])).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::tests::{grid, point, scenario};
    use proptest::prelude::*;

    /// The oracle: the shortest 8-connected way through the cells `plan` may pass, in
    /// cells, by Dijkstra's algorithm with nothing but a sorted list.
    fn shortest_cells(g: &Grid, s: (usize, usize), goal: (usize, usize)) -> Option<f64> {
        let (w, h) = g.size();
        let escape = (ESCAPE_M / g.resolution()).ceil() as usize;
        let passable = |c: (usize, usize)| {
            !g.blocked(c) || (c.0.abs_diff(s.0) <= escape && c.1.abs_diff(s.1) <= escape)
        };
        let mut dist = vec![f64::INFINITY; w * h];
        let mut done = vec![false; w * h];
        dist[s.1 * w + s.0] = 0.0;
        loop {
            let i = (0..w * h)
                .filter(|&i| !done[i] && dist[i].is_finite())
                .min_by(|&a, &b| dist[a].total_cmp(&dist[b]))?;
            let cur = (i % w, i / w);
            if cur == goal {
                return Some(dist[i]);
            }
            done[i] = true;
            for (dc, dr) in NEIGHBOURS {
                let (c, r) = (cur.0 as isize + dc, cur.1 as isize + dr);
                if c < 0 || r < 0 || c as usize >= w || r as usize >= h {
                    continue;
                }
                let (c, r) = (c as usize, r as usize);
                let diagonal = dc != 0 && dr != 0;
                if !passable((c, r))
                    || (diagonal && (!passable((cur.0, r)) || !passable((c, cur.1))))
                {
                    continue;
                }
                let step = if diagonal {
                    std::f64::consts::SQRT_2
                } else {
                    1.0
                };
                let n = r * w + c;
                dist[n] = dist[n].min(dist[i] + step);
            }
        }
    }

    proptest! {
        #[test]
        fn a_path_is_free_segment_by_segment_and_within_the_weight_of_the_shortest(
            g in grid(),
            from in (0.0f64..1.0, 0.0f64..1.0),
            to in (0.0f64..1.0, 0.0f64..1.0),
        ) {
            // From and to cells' centres: a point on a cell's edge touches the next cell.
            let (sa, sb) = (g.cell(point(&g, from)).unwrap(), g.cell(point(&g, to)).unwrap());
            let (a, b) = (g.center(sa), g.center(sb));
            let shortest = shortest_cells(&g, sa, sb).filter(|_| !g.blocked(sb));
            let p = plan(&g, a, b);
            prop_assert_eq!(p.is_some(), shortest.is_some(), "found a way where there is none, or none where there is one");
            let (Some(p), Some(shortest)) = (p, shortest) else { return Ok(()) };
            prop_assert_eq!(p[0], a);
            prop_assert_eq!(*p.last().unwrap(), b);
            // Blocked cells near the start are the way out of inflated space: a grid step
            // from one of them is the one segment that may cross one.
            let escape = (ESCAPE_M / g.resolution()).ceil() as usize;
            let near_start = |q: Point2| {
                let c = g.cell(q).unwrap();
                c.0.abs_diff(sa.0) <= escape && c.1.abs_diff(sa.1) <= escape
            };
            for s in p.windows(2) {
                prop_assert!(s[0].dist(s[1]) <= MAX_SEGMENT_M);
                prop_assert!(
                    g.segment_free(s[0], s[1]) || near_start(s[0]) && s[0].dist(s[1]) < 1.5 * g.resolution(),
                    "segment {:?} crosses a blocked cell", s
                );
            }
            let most = ESTIMATE_WEIGHT * shortest * g.resolution();
            prop_assert!(length(&p) <= most + 1e-9, "{} m against at most {} m", length(&p), most);
        }
    }

    #[test]
    fn path_goes_around_the_car_and_stays_free() {
        let g = Grid::from_scenario(&scenario(), 0.25, 1.0);
        let (a, b) = (Point2::new(5.0, 0.0), Point2::new(35.0, 0.0));
        let p = plan(&g, a, b).unwrap();
        assert_eq!(p[0], a);
        assert_eq!(*p.last().unwrap(), b);
        assert!(p.len() >= 3, "must bend around the car: {p:?}");
        for w in p.windows(2) {
            assert!(
                g.segment_free(w[0], w[1]),
                "segment {w:?} crosses an obstacle"
            );
        }
        let l = length(&p);
        assert!(l > 30.0 && l < 34.0, "{l}");
    }

    #[test]
    fn unreachable_goals_give_none() {
        let g = Grid::from_scenario(&scenario(), 0.25, 1.0);
        assert!(
            plan(&g, Point2::new(5.0, 0.0), Point2::new(20.0, 0.0)).is_none(),
            "goal inside the car"
        );
        assert!(
            plan(&g, Point2::new(5.0, 0.0), Point2::new(80.0, 0.0)).is_none(),
            "goal outside the map"
        );
    }
}
