//! Occupancy grid of the tunnel road: the road's bounding box in the site frame, cells
//! outside the tunnel (beyond its walls or ends) blocked like obstacles, so a curved
//! tunnel is just a grid with more blocked cells.
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

/// A boolean occupancy grid over the tunnel, origin at the road's lowest corner.
#[derive(Debug, Clone)]
pub struct Grid {
    res: f64,
    x0: f64,
    y0: f64,
    w: usize,
    h: usize,
    occ: Vec<bool>,
}

impl Grid {
    /// Road cells blocked by walls and obstacle footprints grown by `inflate` metres.
    pub fn from_scenario(s: &Scenario, res: f64, inflate: f64) -> Self {
        let t = &s.tunnel;
        let (lo, hi) = t.bounds();
        let w = ((hi.x - lo.x) / res).ceil() as usize;
        let h = ((hi.y - lo.y) / res).ceil() as usize;
        let mut g = Self {
            res,
            x0: lo.x,
            y0: lo.y,
            w,
            h,
            occ: vec![false; w * h],
        };
        for r in 0..h {
            for c in 0..w {
                let p = g.center((c, r));
                let blocked = !t.contains(p, inflate)
                    || s.obstacles.iter().any(|o| o.footprint_contains(p, inflate));
                g.occ[r * w + c] = blocked;
            }
        }
        g
    }

    /// This grid with every cell whose centre `barred` holds blocked as well: a keep-out
    /// layer (as Nav2's keepout filter), so that no search over it enters that space.
    pub fn with_keepout(&self, barred: impl Fn(Point2) -> bool) -> Self {
        let mut g = self.clone();
        for r in 0..g.h {
            for c in 0..g.w {
                if !g.occ[r * g.w + c] && barred(g.center((c, r))) {
                    g.occ[r * g.w + c] = true;
                }
            }
        }
        g
    }

    pub fn resolution(&self) -> f64 {
        self.res
    }
    pub fn size(&self) -> (usize, usize) {
        (self.w, self.h)
    }

    pub fn cell(&self, p: Point2) -> Option<Cell> {
        let c = ((p.x - self.x0) / self.res).floor();
        let r = ((p.y - self.y0) / self.res).floor();
        (c >= 0.0 && r >= 0.0 && (c as usize) < self.w && (r as usize) < self.h)
            .then_some((c as usize, r as usize))
    }

    pub fn center(&self, (c, r): Cell) -> Point2 {
        Point2::new(
            self.x0 + (c as f64 + 0.5) * self.res,
            self.y0 + (r as f64 + 0.5) * self.res,
        )
    }

    pub fn blocked(&self, (c, r): Cell) -> bool {
        self.occ[r * self.w + c]
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
    pub fn segment_free(&self, a: Point2, b: Point2) -> bool {
        let Some(mut cur) = self.cell(a) else {
            return false;
        };
        if self.cell(b).is_none() {
            return false;
        }
        let (dx, dy) = (b.x - a.x, b.y - a.y);
        let step_x: isize = if dx > 0.0 { 1 } else { -1 };
        let step_y: isize = if dy > 0.0 { 1 } else { -1 };
        // Segment parameter (0 at a, 1 at b) at which the next x / y cell boundary is crossed.
        let first = |pos: f64, origin: f64, cell: usize, step: isize, d: f64| {
            if d == 0.0 {
                return f64::INFINITY;
            }
            let k = if step > 0 {
                cell as f64 + 1.0
            } else {
                cell as f64
            };
            (origin + k * self.res - pos) / d
        };
        let mut t_x = first(a.x, self.x0, cur.0, step_x, dx);
        let mut t_y = first(a.y, self.y0, cur.1, step_y, dy);
        let t_dx = if dx != 0.0 {
            self.res / dx.abs()
        } else {
            f64::INFINITY
        };
        let t_dy = if dy != 0.0 {
            self.res / dy.abs()
        } else {
            f64::INFINITY
        };
        loop {
            if self.blocked(cur) {
                return false;
            }
            // The segment ends inside this cell. Ending on the parameter rather than on b's
            // cell is robust to b lying exactly on a cell corner.
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
            if cur.0 >= self.w || cur.1 >= self.h {
                return false;
            }
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

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
}
