//! Shortest paths on a weighted 8-connected grid: Dijkstra from one cell to all, and A*
//! between two cells.
//!
//! Conventions (those of the MovingAI grid benchmarks): a move to one of the 8 neighbours
//! costs its length (1 straight, sqrt(2) diagonal) times the entered cell's cost (1 on an
//! unweighted map; a cost map's traversal cost on a weighted one); a diagonal move may not
//! cut a corner, so both cells it passes between must be passable. Impassable cells have
//! an infinite cost.
//!
//! Flat arrays, and for Dijkstra a bucket queue instead of a heap (Dial's algorithm): with
//! buckets as wide as the cheapest move, every cell in the lowest non-empty bucket already
//! has its final cost (no move is short enough to improve another cell of the same
//! bucket), so a bucket is emptied in any order and a push or pop is O(1). The buckets are
//! a ring of `max move / min move + 2`. A* keeps a binary heap keyed by the bits of
//! cost plus heuristic.

use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// A grid of cell costs; `f32::INFINITY` is impassable.
///
/// Stored with a one-cell impassable border, so that a neighbour is always at a fixed
/// offset and never out of bounds: the inner loop has no bounds or edge checks.
#[derive(Debug, Clone, PartialEq)]
pub struct CostGrid {
    width: usize,
    height: usize,
    /// (width + 2) x (height + 2), row-major, border impassable.
    cost: Vec<f32>,
}

/// A cell: (column, row).
pub type Cell = (usize, usize);

/// Non-negative floats order like their bit patterns.
fn key(d: f64) -> Reverse<u64> {
    Reverse(d.to_bits())
}

impl CostGrid {
    /// A grid from row-major costs; `None` if the sizes disagree or a cost is negative or
    /// NaN.
    pub fn new(width: usize, height: usize, cost: Vec<f32>) -> Option<Self> {
        // Cell indices travel as u32 in the bucket queue.
        if cost.len() != width * height
            || !cost.iter().all(|c| *c >= 0.0)
            || (width + 2) * (height + 2) > u32::MAX as usize
        {
            return None;
        }
        let wp = width + 2;
        let mut padded = vec![f32::INFINITY; wp * (height + 2)];
        for r in 0..height {
            padded[(r + 1) * wp + 1..(r + 1) * wp + 1 + width]
                .copy_from_slice(&cost[r * width..(r + 1) * width]);
        }
        Some(Self {
            width,
            height,
            cost: padded,
        })
    }

    /// A grid of unit cost where `passable`, impassable elsewhere.
    pub fn from_passable(width: usize, height: usize, passable: &[bool]) -> Option<Self> {
        Self::new(
            width,
            height,
            passable
                .iter()
                .map(|p| if *p { 1.0 } else { f32::INFINITY })
                .collect(),
        )
    }

    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    fn index(&self, (c, r): Cell) -> usize {
        (r + 1) * (self.width + 2) + c + 1
    }

    fn cell(&self, i: usize) -> Cell {
        let wp = self.width + 2;
        (i % wp - 1, i / wp - 1)
    }

    pub fn passable(&self, (c, r): Cell) -> bool {
        c < self.width && r < self.height && self.cost[self.index((c, r))].is_finite()
    }

    /// Call `f(neighbour index, cost)` for every move out of (inner) cell index `i`:
    /// straight moves, then diagonals between two passable straight neighbours (no corner
    /// cutting). Unrolled over fixed offsets: this is the inner loop of every search.
    #[inline]
    fn for_each_move(&self, i: usize, mut f: impl FnMut(usize, f64)) {
        let wp = (self.width + 2) as isize;
        let cost = &self.cost;
        let straight = [1, -1, wp, -wp].map(|o| {
            let j = i.wrapping_add_signed(o);
            (j, cost[j])
        });
        for (j, e) in straight {
            if e.is_finite() {
                f(j, f64::from(e));
            }
        }
        for (a, b) in [(0, 2), (0, 3), (1, 2), (1, 3)] {
            let ((ja, ea), (jb, eb)) = (straight[a], straight[b]);
            if ea.is_finite() && eb.is_finite() {
                let j = ja + jb - i;
                if cost[j].is_finite() {
                    f(j, std::f64::consts::SQRT_2 * f64::from(cost[j]));
                }
            }
        }
    }

    /// Cost of the cheapest path from `source` to every cell (infinite where unreachable),
    /// row-major.
    pub fn dijkstra_all(&self, source: Cell) -> Vec<f64> {
        let mut dist = vec![f64::INFINITY; self.cost.len()];
        let finite = self.cost.iter().copied().filter(|c| c.is_finite());
        let (lo, hi) = finite.fold((f32::INFINITY, 0.0f32), |(lo, hi), c| {
            (lo.min(c), hi.max(c))
        });
        if self.passable(source) && lo > 0.0 {
            let delta = f64::from(lo);
            let ring = (std::f64::consts::SQRT_2 * f64::from(hi) / delta).ceil() as usize + 2;
            let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); ring];
            let slot = |d: f64| (d / delta) as usize;
            let s = self.index(source);
            dist[s] = 0.0;
            buckets[0].push(s as u32);
            let (mut current, mut queued) = (0usize, 1usize);
            while queued > 0 {
                let b = current % ring;
                // Cells pushed into this bucket while it is emptied (a float rounding at
                // its upper edge) are taken too.
                while let Some(i) = buckets[b].pop() {
                    queued -= 1;
                    let i = i as usize;
                    let d = dist[i];
                    if slot(d) != current {
                        continue; // stale: improved into an earlier bucket since
                    }
                    self.for_each_move(i, |j, step| {
                        let nd = d + step;
                        if nd < dist[j] {
                            dist[j] = nd;
                            buckets[slot(nd) % ring].push(j as u32);
                            queued += 1;
                        }
                    });
                }
                current += 1;
            }
        } else if self.passable(source) {
            // Free cells (cost 0) make the buckets zero-wide: a heap instead.
            let s = self.index(source);
            let mut open = BinaryHeap::new();
            dist[s] = 0.0;
            open.push((key(0.0), s));
            while let Some((Reverse(bits), i)) = open.pop() {
                let d = f64::from_bits(bits);
                if d > dist[i] {
                    continue;
                }
                self.for_each_move(i, |j, c| {
                    if d + c < dist[j] {
                        dist[j] = d + c;
                        open.push((key(d + c), j));
                    }
                });
            }
        }
        let wp = self.width + 2;
        let mut out = Vec::with_capacity(self.width * self.height);
        for r in 0..self.height {
            out.extend_from_slice(&dist[(r + 1) * wp + 1..(r + 1) * wp + 1 + self.width]);
        }
        out
    }

    /// The cheapest path from `start` to `goal` and its cost; `None` if there is none. The
    /// heuristic is the octile distance times the cheapest cell cost, so it never
    /// overestimates and the path is optimal.
    pub fn astar(&self, start: Cell, goal: Cell) -> Option<(f64, Vec<Cell>)> {
        if !self.passable(start) || !self.passable(goal) {
            return None;
        }
        let min_cost = f64::from(
            self.cost
                .iter()
                .copied()
                .filter(|c| c.is_finite())
                .fold(f32::INFINITY, f32::min),
        );
        let h = |i: usize| {
            let (c, r) = self.cell(i);
            let (dx, dy) = (c.abs_diff(goal.0) as f64, r.abs_diff(goal.1) as f64);
            min_cost * (dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy))
        };
        let (s, g) = (self.index(start), self.index(goal));
        let mut dist = vec![f64::INFINITY; self.cost.len()];
        let mut parent = vec![usize::MAX; self.cost.len()];
        let mut open = BinaryHeap::new();
        dist[s] = 0.0;
        open.push((key(h(s)), s));
        while let Some((Reverse(bits), i)) = open.pop() {
            if i == g {
                break;
            }
            if f64::from_bits(bits) > dist[i] + h(i) + 1e-9 {
                continue;
            }
            let di = dist[i];
            self.for_each_move(i, |j, c| {
                let nd = di + c;
                if nd < dist[j] {
                    dist[j] = nd;
                    parent[j] = i;
                    open.push((key(nd + h(j)), j));
                }
            });
        }
        if !dist[g].is_finite() {
            return None;
        }
        let mut path = vec![goal];
        let mut i = g;
        while i != s {
            i = parent[i];
            path.push(self.cell(i));
        }
        path.reverse();
        Some((dist[g], path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn octile(a: Cell, b: Cell) -> f64 {
        let (dx, dy) = (a.0.abs_diff(b.0) as f64, a.1.abs_diff(b.1) as f64);
        dx.max(dy) + (std::f64::consts::SQRT_2 - 1.0) * dx.min(dy)
    }

    #[test]
    fn on_an_open_grid_the_cost_is_the_octile_distance() {
        let g = CostGrid::from_passable(20, 10, &[true; 200]).unwrap();
        let d = g.dijkstra_all((3, 4));
        for (i, di) in d.iter().enumerate() {
            assert!((di - octile((3, 4), (i % 20, i / 20))).abs() < 1e-9);
        }
        let (len, path) = g.astar((0, 0), (19, 9)).unwrap();
        assert!((len - octile((0, 0), (19, 9))).abs() < 1e-9);
        assert_eq!(path.first(), Some(&(0, 0)));
        assert_eq!(path.last(), Some(&(19, 9)));
    }

    #[test]
    fn diagonals_do_not_cut_corners() {
        // . #
        // . .   from (0,0) to (1,1): the diagonal passes the wall's corner; 2 straight moves.
        let g = CostGrid::from_passable(2, 2, &[true, false, true, true]).unwrap();
        assert_eq!(g.astar((0, 0), (1, 1)).unwrap().0, 2.0);
        assert_eq!(g.dijkstra_all((0, 0))[3], 2.0);
    }

    #[test]
    fn walls_are_gone_round_and_enclosed_cells_are_unreachable() {
        let mut cells = vec![true; 25];
        for r in 0..4 {
            cells[r * 5 + 2] = false; // a wall in column 2, open at the bottom row
        }
        let g = CostGrid::from_passable(5, 5, &cells).unwrap();
        let (len, path) = g.astar((0, 0), (4, 0)).unwrap();
        assert!(path.iter().all(|c| g.passable(*c)));
        assert!(path.contains(&(2, 4)), "round the wall's foot: {path:?}");
        // A diagonal to (1,1), straight down to (1,4) (no cutting the wall's corner), through
        // the gap to (3,4), straight up to (3,1), a diagonal to (4,0): 2 diagonals, 8
        // straight moves.
        assert!(
            (len - (8.0 + 2.0 * std::f64::consts::SQRT_2)).abs() < 1e-9,
            "{len}"
        );
        let mut boxed = vec![true; 9];
        for i in [1, 3, 5, 7] {
            boxed[i] = false;
        }
        let g = CostGrid::from_passable(3, 3, &boxed).unwrap();
        assert!(g.astar((1, 1), (0, 0)).is_none());
        assert!(g.dijkstra_all((1, 1))[0].is_infinite());
    }

    #[test]
    fn zero_cost_cells_are_searched_with_a_heap_and_agree_with_astar() {
        let mut cost = vec![1.0f32; 16];
        cost[5] = 0.0;
        let g = CostGrid::new(4, 4, cost).unwrap();
        let d = g.dijkstra_all((0, 0));
        for (i, di) in d.iter().enumerate() {
            let (len, _) = g.astar((0, 0), (i % 4, i / 4)).unwrap();
            assert!((di - len).abs() < 1e-9, "{i}: {di} vs {len}");
        }
    }

    #[test]
    fn costly_cells_are_avoided() {
        // A 3-row corridor whose middle row is ten times dearer.
        let mut cost = vec![1.0f32; 30];
        for c in 1..9 {
            cost[10 + c] = 10.0;
        }
        let g = CostGrid::new(10, 3, cost).unwrap();
        let (_, path) = g.astar((0, 1), (9, 1)).unwrap();
        assert!(
            path[1..path.len() - 1].iter().all(|(_, r)| *r != 1),
            "{path:?}"
        );
    }

    fn grid() -> impl Strategy<Value = CostGrid> {
        (3usize..16, 3usize..16).prop_flat_map(|(w, h)| {
            proptest::collection::vec(
                prop_oneof![4 => 1.0f32..5.0, 1 => Just(f32::INFINITY)],
                w * h,
            )
            .prop_map(move |cost| CostGrid::new(w, h, cost).unwrap())
        })
    }

    proptest! {
        #[test]
        fn astar_agrees_with_dijkstra_and_its_paths_are_legal(g in grid(), a in any::<(usize, usize)>(), b in any::<(usize, usize)>()) {
            let (w, h) = g.size();
            let (s, t) = ((a.0 % w, a.1 % h), (b.0 % w, b.1 % h));
            let d = g.dijkstra_all(s);
            match g.astar(s, t) {
                Some((len, path)) => {
                    prop_assert!((len - d[t.1 * w + t.0]).abs() < 1e-6);
                    // Every step is to a passable neighbour, without cutting a corner, and
                    // the steps' costs add up to the length.
                    let mut sum = 0.0;
                    for win in path.windows(2) {
                        let (p, q) = (win[0], win[1]);
                        let j = g.index(q);
                        let mut step = None;
                        g.for_each_move(g.index(p), |k, c| if k == j { step = Some((k, c)) });
                        prop_assert!(step.is_some(), "illegal step {:?} -> {:?}", p, q);
                        sum += step.unwrap().1;
                    }
                    prop_assert!((sum - len).abs() < 1e-6);
                }
                None => prop_assert!(!g.passable(s) || !g.passable(t) || d[t.1 * w + t.0].is_infinite()),
            }
        }
    }
}
