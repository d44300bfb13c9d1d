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

/// A path from `start` to `goal` through free cells, as corner points (first is `start`,
/// last is `goal`); `None` if the goal cannot be reached.
pub fn plan(grid: &Grid, start: Point2, goal: Point2) -> Option<Vec<Point2>> {
    let (w, h) = grid.size();
    let s = grid.cell(start)?;
    let g = grid.cell(goal)?;
    if grid.blocked(g) {
        return None;
    }
    let idx = |(c, r): (usize, usize)| r * w + c;
    let octile = |(c, r): (usize, usize)| {
        let (dx, dy) = (c.abs_diff(g.0) as f64, r.abs_diff(g.1) as f64);
        dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy)
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
    // Keys are costs scaled to integers: exact ordering without a float wrapper; each
    // entry keeps the cost it was pushed with, to skip it once the cell is reached cheaper.
    let key = |f: f64| Reverse((f * 1024.0) as u64);
    let pushed = |g: f64| (g * 1024.0) as u64;
    open.push((key(octile(s)), idx(s), pushed(0.0)));
    // The start may sit in inflated space (a robot that stopped close to a wall or a
    // vehicle): cells within ESCAPE_M of it are passable so that it can get out.
    let escape = (ESCAPE_M / grid.resolution()).ceil() as usize;
    let passable = |c: (usize, usize)| {
        !grid.blocked(c) || (c.0.abs_diff(s.0) <= escape && c.1.abs_diff(s.1) <= escape)
    };
    while let Some((_, i, g_key)) = open.pop() {
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
                open.push((key(nc + octile((c, r))), n, pushed(nc)));
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

/// Longest straight segment string pulling makes, m. Each step of the pulling traces the
/// segment from its anchor, so an uncapped segment costs the square of its length in
/// cells: a kilometre of straight tunnel at 0.25 m cells is sixteen million cell visits
/// a plan (what made plans along a 3 km tunnel take seconds; capped, a tenth of that). A
/// corner every 250 m on a straight line costs the follower nothing, and it leaves every
/// path in a 300 m tunnel as it was.
const MAX_SEGMENT_M: f64 = 250.0;

/// Keep only the corners needed for straight, free segments of at most [`MAX_SEGMENT_M`]. A
/// start inside inflated space sees no free segment, so the path keeps its first grid step
/// out of it.
fn string_pull(grid: &Grid, pts: &[Point2]) -> Vec<Point2> {
    let mut out = vec![pts[0]];
    let mut anchor = 0;
    let mut i = 1;
    while i < pts.len() {
        if i + 1 < pts.len()
            && pts[anchor].dist(pts[i + 1]) <= MAX_SEGMENT_M
            && grid.segment_free(pts[anchor], pts[i + 1])
        {
            i += 1;
            continue;
        }
        out.push(pts[i]);
        anchor = i;
        i += 1;
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
    use crate::grid::tests::scenario;

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
