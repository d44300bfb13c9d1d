//! Occupancy grid of the tunnel road: the road's bounding box in the site frame, cells
//! outside the tunnel (beyond its walls or ends) blocked like obstacles, so a curved
//! tunnel is just a grid with more blocked cells.
//!
//! A grid holds, for each cell, not just whether it is blocked but its clearance: how far
//! its centre is from the nearest blocked cell. In the same byte a cell would take anyway,
//! it lets a footprint well clear of everything be known free from one lookup
//! ([`Grid::clearance_m`]) and a sight line stride across open road
//! ([`Grid::segment_free`]): what the planners spend most of their time on.
//!
//! Not here: search over it ([`crate::astar`], [`crate::hybrid_astar`]) or costs beyond
//! free and blocked ([`crate::costmap`]).

use firefleet_model::Point2;
use firefleet_model::scenario::Scenario;

/// A cell index (column along x, row along y).
pub type Cell = (usize, usize);

/// The eight moves of an 8-connected grid, (column, row): straight ones first.
pub const NEIGHBOURS: [(isize, isize); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (1, -1),
    (-1, 1),
    (-1, -1),
];

/// An occupancy grid over the tunnel, origin at the road's lowest corner.
#[derive(Debug, Clone)]
pub struct Grid {
    res: f64,
    x0: f64,
    y0: f64,
    w: usize,
    h: usize,
    /// Per cell, row-major over the grid and a border of blocked cells round it (the
    /// cells beyond its edge, so that no step of the transform needs a bounds check): 0
    /// where blocked, else the octile distance to the nearest blocked cell in
    /// [`QUARTER`]s of a cell, at most 255 (64 cells: 16 m at 0.25 m, further than any
    /// question asked of it).
    clearance: Box<[u8]>,
}

/// The clearance's unit: a quarter of a cell, and a straight step of the transform.
const QUARTER: u8 = 4;
/// A diagonal step in quarter cells: 4 sqrt 2 = 5.66, rounded up so that a sum of steps
/// never falls below the octile distance.
const DIAGONAL: u8 = 6;
/// The most the stored clearance exceeds the Euclidean distance: the octile distance by up
/// to `sqrt(4 - 2 sqrt 2) = 1.0824` (at 22.5 deg), the rounded diagonal by 6/5.66.
const OVERSHOOT: f64 = 1.15;

impl Grid {
    /// Road cells blocked by walls and obstacle footprints grown by `inflate` metres.
    pub fn from_scenario(s: &Scenario, res: f64, inflate: f64) -> Self {
        let t = &s.tunnel;
        let (lo, hi) = t.bounds();
        let w = ((hi.x - lo.x) / res).ceil() as usize;
        let h = ((hi.y - lo.y) / res).ceil() as usize;
        Self::from_blocked(res, lo, w, h, |p| {
            !t.contains(p, inflate) || s.obstacles.iter().any(|o| o.footprint_contains(p, inflate))
        })
    }

    /// This grid with every cell whose centre `barred` holds blocked as well: a keep-out
    /// layer (as Nav2's keepout filter), so that no search over it enters that space.
    pub fn with_keepout(&self, barred: impl Fn(Point2) -> bool) -> Self {
        let blocked = |p: Point2| self.cell(p).is_none_or(|c| self.blocked(c)) || barred(p);
        Self::from_blocked(
            self.res,
            Point2::new(self.x0, self.y0),
            self.w,
            self.h,
            blocked,
        )
    }

    /// A `w` x `h` grid of `res` cells from `origin`, each blocked where `blocked` holds at
    /// its centre, with its clearance: the octile distance to the nearest blocked cell by
    /// the two-pass chamfer transform (Rosenfeld and Pfaltz), exact for the 8-connected
    /// metric, which is never below the Euclidean one.
    fn from_blocked(
        res: f64,
        origin: Point2,
        w: usize,
        h: usize,
        blocked: impl Fn(Point2) -> bool,
    ) -> Self {
        let mut g = Self {
            res,
            x0: origin.x,
            y0: origin.y,
            w,
            h,
            clearance: vec![0; (w + 2) * (h + 2)].into_boxed_slice(),
        };
        for r in 0..h {
            for c in 0..w {
                if !blocked(g.center((c, r))) {
                    let i = g.index((c, r));
                    g.clearance[i] = u8::MAX;
                }
            }
        }
        let stride = w + 2;
        let dist = &mut g.clearance;
        // Offsets of the neighbours before a cell in raster order, and their steps.
        let before = [
            (1, QUARTER),
            (stride + 1, DIAGONAL),
            (stride, QUARTER),
            (stride - 1, DIAGONAL),
        ];
        for r in 1..=h {
            for i in r * stride + 1..r * stride + 1 + w {
                for (back, step) in before {
                    dist[i] = dist[i].min(dist[i - back].saturating_add(step));
                }
            }
        }
        for r in (1..=h).rev() {
            for i in (r * stride + 1..r * stride + 1 + w).rev() {
                for (ahead, step) in before {
                    dist[i] = dist[i].min(dist[i + ahead].saturating_add(step));
                }
            }
        }
        g
    }

    /// Where a cell's clearance is kept.
    fn index(&self, (c, r): Cell) -> usize {
        (r + 1) * (self.w + 2) + c + 1
    }

    pub fn resolution(&self) -> f64 {
        self.res
    }
    pub fn size(&self) -> (usize, usize) {
        (self.w, self.h)
    }

    pub fn cell(&self, p: Point2) -> Option<Cell> {
        let c = (p.x - self.x0) / self.res;
        let r = (p.y - self.y0) / self.res;
        // Truncation is the floor of a number not below 0 (`floor` itself is a library
        // call on the x86-64 baseline, and this is the planners' innermost step); NaN fails
        // the comparison.
        if !(c >= 0.0 && r >= 0.0) {
            return None;
        }
        let (c, r) = (c as usize, r as usize);
        (c < self.w && r < self.h).then_some((c, r))
    }

    pub fn center(&self, (c, r): Cell) -> Point2 {
        Point2::new(
            self.x0 + (c as f64 + 0.5) * self.res,
            self.y0 + (r as f64 + 0.5) * self.res,
        )
    }

    pub fn blocked(&self, cell: Cell) -> bool {
        self.clearance[self.index(cell)] == 0
    }

    /// A lower bound on the distance from the centre of `cell` to the centre of the
    /// nearest blocked cell, m (within 15 % of it, up to 55 cells); the cells beyond the
    /// grid's edge count as blocked. 0 on a blocked cell.
    pub fn clearance_m(&self, cell: Cell) -> f64 {
        f64::from(self.clearance[self.index(cell)]) * (self.res / (f64::from(QUARTER) * OVERSHOOT))
    }

    /// Whether `p` lies on a free cell.
    pub fn free(&self, p: Point2) -> bool {
        self.cell(p).is_some_and(|c| !self.blocked(c))
    }

    /// The free cell centre nearest `p` within `within_m` of it (`p` itself if its cell is
    /// free), if any.
    pub fn nearest_free(&self, p: Point2, within_m: f64) -> Option<Point2> {
        if self.free(p) {
            return Some(p);
        }
        let reach = (within_m / self.res).ceil() as isize;
        let c0 = ((p.x - self.x0) / self.res).floor() as isize;
        let r0 = ((p.y - self.y0) / self.res).floor() as isize;
        let cells = (-reach..=reach).flat_map(|dr| (-reach..=reach).map(move |dc| (dc, dr)));
        cells
            .filter_map(|(dc, dr)| {
                let (c, r) = (
                    usize::try_from(c0 + dc).ok()?,
                    usize::try_from(r0 + dr).ok()?,
                );
                (c < self.w && r < self.h && !self.blocked((c, r))).then(|| self.center((c, r)))
            })
            .filter(|q| q.dist(p) <= within_m)
            .min_by(|a, b| a.dist(p).total_cmp(&b.dist(p)))
    }

    /// Whether the segment `a`-`b` crosses only free cells. Uses a supercover traversal
    /// (every cell the segment touches, Amanatides-Woo), not Bresenham: Bresenham skips
    /// cells the segment clips at a corner, which would let a path graze an obstacle.
    ///
    /// The traversal strides through open space by the grid's clearance
    /// ([`Grid::clearance_m`]): every cell the segment touches within `clearance - cell
    /// diagonal` of where it leaves a cell is free (a point of the segment is within half a
    /// diagonal of its cell's centre), so it jumps there. The answer is the cell-by-cell
    /// traversal's, from tens of cells looked at across a tunnel's open road instead of
    /// one per cell.
    pub fn segment_free(&self, a: Point2, b: Point2) -> bool {
        let (Some(mut cur), Some(_)) = (self.cell(a), self.cell(b)) else {
            return false;
        };
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let step_x: isize = if dx > 0.0 { 1 } else { -1 };
        let step_y: isize = if dy > 0.0 { 1 } else { -1 };
        // The segment parameter (0 at a, 1 at b) at which it crosses a column's (row's)
        // boundary on its way out of the cell or into it, worked out from the cell's index
        // rather than accumulated step by step, so that a stride can land in any cell; in
        // metres from `a`, as the cell-by-cell traversal does (in cells from the grid's
        // origin, a point an ulp off a boundary loses the ulp).
        let crossing = |origin: f64, pos: f64, d: f64, cell: usize, out: bool| {
            if d == 0.0 {
                return if out {
                    f64::INFINITY
                } else {
                    f64::NEG_INFINITY
                };
            }
            let k = cell as f64 + if out == (d > 0.0) { 1.0 } else { 0.0 };
            (origin + k * self.res - pos) / d
        };
        let cross_x = |c: usize, out: bool| crossing(self.x0, a.x, dx, c, out);
        let cross_y = |r: usize, out: bool| crossing(self.y0, a.y, dy, r, out);
        let per_m = 1.0 / dx.hypot(dy);
        loop {
            if self.blocked(cur) {
                return false;
            }
            let (t_x, t_y) = (cross_x(cur.0, true), cross_y(cur.1, true));
            let t_out = t_x.min(t_y);
            // The segment ends inside this cell. Ending on the parameter rather than on b's
            // cell is robust to b lying exactly on a cell corner.
            if t_out > 1.0 {
                return true;
            }
            // The point where the segment leaves the cell is within half a diagonal of its
            // centre; a stride shorter by a whole diagonal (and a hair, for rounding)
            // touches no cell as near a blocked one as the clearance.
            let stride = self.clearance_m(cur) - self.res * (std::f64::consts::SQRT_2 + 1e-6);
            if stride > 2.0 * self.res {
                let t = t_out + stride * per_m;
                if t >= 1.0 {
                    return true;
                }
                // Only into a cell the segment runs through at `t`: one a rounding error
                // beside a segment along a cell boundary would be walked instead of its
                // own, and one whose exit lies behind would be strode from again and
                // again, for ever.
                if let Some((c, r)) = self.cell(Point2::new(a.x + t * dx, a.y + t * dy))
                    && cross_x(c, false).max(cross_y(r, false)) <= t
                    && cross_x(c, true).min(cross_y(r, true)) >= t
                {
                    cur = (c, r);
                    continue;
                }
            }
            if t_x < t_y {
                cur.0 = cur.0.wrapping_add_signed(step_x);
            } else {
                cur.1 = cur.1.wrapping_add_signed(step_y);
            }
            if cur.0 >= self.w || cur.1 >= self.h {
                return false;
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use proptest::prelude::*;

    pub(crate) fn scenario() -> Scenario {
        Scenario::straight(50.0)
            .section(10.0, 6.0)
            .time_limit(10.0)
            .obstacle("car", (20.0, 0.0), [4.0, 2.0, 1.5])
            .build()
    }

    #[test]
    fn walls_and_obstacles_are_blocked_with_inflation() {
        let g = Grid::from_scenario(&scenario(), 0.25, 1.0);
        assert!(g.free(Point2::new(5.0, 0.0)));
        assert!(!g.free(Point2::new(20.0, 0.0)));
        assert!(!g.free(Point2::new(20.0, 1.8)), "inflated");
        assert!(g.free(Point2::new(20.0, 2.6)));
        assert!(!g.free(Point2::new(5.0, 4.5)), "wall margin");
        assert!(!g.free(Point2::new(-1.0, 0.0)));
    }

    #[test]
    fn the_nearest_free_point_to_one_inside_a_car_is_beside_it() {
        let g = Grid::from_scenario(&scenario(), 0.25, 1.0);
        let p = g.nearest_free(Point2::new(20.0, 0.5), 5.0).unwrap();
        assert!(g.free(p));
        // The car is 2 m wide: inflated, it reaches y = 2.0; the nearest free cell
        // centre lies just beyond.
        assert!(
            (p.y - 2.125).abs() < 1e-9 && (p.x - 20.0).abs() < 0.2,
            "{p:?}"
        );
        assert_eq!(
            g.nearest_free(Point2::new(5.0, 0.0), 5.0),
            Some(Point2::new(5.0, 0.0))
        );
        assert_eq!(g.nearest_free(Point2::new(20.0, 0.5), 1.0), None);
    }

    #[test]
    fn segments_through_obstacles_are_not_free() {
        let g = Grid::from_scenario(&scenario(), 0.25, 0.0);
        assert!(!g.segment_free(Point2::new(5.0, 0.0), Point2::new(35.0, 0.0)));
        assert!(g.segment_free(Point2::new(5.0, 3.0), Point2::new(35.0, 3.0)));
        assert!(g.segment_free(Point2::new(35.0, 3.0), Point2::new(5.0, 2.5)));
        // A diagonal that clips the car's corner.
        assert!(!g.segment_free(Point2::new(17.0, 2.0), Point2::new(19.0, 0.0)));
    }

    /// Grids of scattered blocked cells, off the origin, with open space to stride in.
    fn grid() -> impl Strategy<Value = Grid> {
        (5usize..60, 5usize..40).prop_flat_map(|(w, h)| {
            proptest::collection::vec(prop::bool::weighted(0.03), w * h).prop_map(move |occ| {
                let (res, origin) = (0.25, Point2::new(-3.0, 1.5));
                let cell = |p: Point2| {
                    let (c, r) = ((p.x - origin.x) / res, (p.y - origin.y) / res);
                    c as usize + w * r as usize
                };
                Grid::from_blocked(res, origin, w, h, |p| occ[cell(p)])
            })
        })
    }

    /// A point on or a little beyond the grid, from fractions of its extent.
    fn point(g: &Grid, (fx, fy): (f64, f64)) -> Point2 {
        Point2::new(
            g.x0 + fx * g.w as f64 * g.res,
            g.y0 + fy * g.h as f64 * g.res,
        )
    }

    /// The oracle: Amanatides-Woo one cell at a time, boundaries accumulated.
    fn cell_by_cell(g: &Grid, a: Point2, b: Point2) -> bool {
        let (Some(mut cur), Some(_)) = (g.cell(a), g.cell(b)) else {
            return false;
        };
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let (step_x, step_y): (isize, isize) =
            (if dx > 0.0 { 1 } else { -1 }, if dy > 0.0 { 1 } else { -1 });
        let first = |pos: f64, origin: f64, cell: usize, step: isize, d: f64| {
            let k = cell as f64 + if step > 0 { 1.0 } else { 0.0 };
            if d == 0.0 {
                f64::INFINITY
            } else {
                (origin + k * g.res - pos) / d
            }
        };
        let mut t_x = first(a.x, g.x0, cur.0, step_x, dx);
        let mut t_y = first(a.y, g.y0, cur.1, step_y, dy);
        let (t_dx, t_dy) = (g.res / dx.abs(), g.res / dy.abs());
        loop {
            if g.blocked(cur) {
                return false;
            }
            if t_x.min(t_y) > 1.0 {
                return true;
            }
            if t_x < t_y {
                t_x += t_dx;
                cur.0 = cur.0.wrapping_add_signed(step_x);
            } else {
                t_y += t_dy;
                cur.1 = cur.1.wrapping_add_signed(step_y);
            }
            if cur.0 >= g.w || cur.1 >= g.h {
                return false;
            }
        }
    }

    /// A segment along a row boundary, a rounding error off it: its strides land in the
    /// row beside the one it runs through, whose exit lies behind (this hung a fleet).
    #[test]
    fn a_segment_along_a_cell_boundary_ends() {
        let g = Grid::from_blocked(0.25, Point2::new(-3.0, 1.5), 200, 20, |_| false);
        // Row 10 begins at y = 4; the floats next to it, and it.
        let boundary = 4.0f64;
        for y in [
            f64::from_bits(boundary.to_bits() - 1),
            boundary,
            f64::from_bits(boundary.to_bits() + 1),
        ] {
            for (a, b) in [
                (Point2::new(-2.0, boundary), Point2::new(45.0, y)),
                (Point2::new(-2.0, y), Point2::new(45.0, boundary)),
            ] {
                assert!(g.segment_free(a, b), "{a:?} {b:?}");
                assert!(g.segment_free(b, a), "{b:?} {a:?}");
            }
        }
    }

    proptest! {
        #[test]
        fn clearance_is_at_most_the_distance_to_the_nearest_blocked_cell_and_within_fifteen_percent_of_it(g in grid()) {
            let (w, h) = g.size();
            for r in 0..h {
                for c in 0..w {
                    let here = g.center((c, r));
                    // The cells beyond the edge count as blocked.
                    let edge = [c + 1, w - c, r + 1, h - r].into_iter().min().unwrap() as f64 * g.res;
                    let nearest = (0..w * h)
                        .map(|i| (i % w, i / w))
                        .filter(|&cell| g.blocked(cell))
                        .map(|cell| g.center(cell).dist(here))
                        .fold(edge, f64::min);
                    let clear = g.clearance_m((c, r));
                    // What the byte holds at most: 255 quarter cells.
                    let most = 255.0 / f64::from(QUARTER) * g.res;
                    prop_assert!(clear <= nearest + 1e-9, "({c}, {r}): {clear} > {nearest}");
                    prop_assert!(clear >= nearest.min(most) / OVERSHOOT - 1e-9, "({c}, {r}): {clear} << {nearest}");
                }
            }
        }

        #[test]
        fn a_segment_along_a_cell_boundary_is_judged_as_one_cell_at_a_time(
            g in grid(),
            (row, col) in (0usize..40, 0usize..60),
            ulps in (-2i64..=2, -2i64..=2),
            (from, to) in (-0.1f64..1.1, -0.1f64..1.1),
            along_x in any::<bool>(),
        ) {
            // A boundary of the grid's cells, and the floats a few steps from it.
            let near = |v: f64, k: i64| f64::from_bits(v.to_bits().wrapping_add_signed(k));
            let (a, b) = if along_x {
                let y = g.y0 + (row % g.h) as f64 * g.res;
                let (a, b) = (point(&g, (from, 0.0)), point(&g, (to, 0.0)));
                (Point2::new(a.x, near(y, ulps.0)), Point2::new(b.x, near(y, ulps.1)))
            } else {
                let x = g.x0 + (col % g.w) as f64 * g.res;
                let (a, b) = (point(&g, (0.0, from)), point(&g, (0.0, to)));
                (Point2::new(near(x, ulps.0), a.y), Point2::new(near(x, ulps.1), b.y))
            };
            prop_assert_eq!(g.segment_free(a, b), cell_by_cell(&g, a, b));
        }

        #[test]
        fn a_segment_is_judged_the_same_striding_through_open_space(
            g in grid(),
            a in (-0.1f64..1.1, -0.1f64..1.1),
            b in (-0.1f64..1.1, -0.1f64..1.1),
        ) {
            let (a, b) = (point(&g, a), point(&g, b));
            prop_assert_eq!(g.segment_free(a, b), cell_by_cell(&g, a, b));
            prop_assert_eq!(g.segment_free(b, a), cell_by_cell(&g, b, a));
        }
    }
}
