//! The heat-aware cost map of the Dijkstra+GA paper (`fire-path-planning-dijkstra-ga.txt`,
//! equations 1-8), and the genetic algorithm that tunes its weights.
//!
//! A 2.5-D grid holds each cell's obstacle height, surface roughness and temperature.
//! Height variation is the variance over the cell's 2 x 2 window (eq. 1-3); traversal time
//! is `alpha r / v_f + beta (1 + h_var) / v_h` (eq. 4, the paper's alpha = 1, beta = 4,
//! v_f = v_h = 1); a cell's cost is `w1 time + w2 temp` (eq. 6). The path is the cheapest
//! one on that cost (the paper's Dijkstra; [`CostGrid::astar`] returns the same optimum).
//! A path's fitness is `sum over its cells of (lambda1 temp + lambda2 time)` with
//! lambda1 = 1, lambda2 = 9 (eq. 8): what the robot really pays, whatever weights planned
//! it. The GA searches the weights that plan the fittest path.
//!
//! Choices the paper leaves open, ours: the window at the map's last row and column
//! repeats the edge cell; the first cell of a path is not counted in its fitness (the robot
//! is already there); the GA's operators are below ([`Ga`]). Pure and seeded.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use firefleet_model::Point2;
use firefleet_model::scenario::{Scenario, Tunnel};

use super::grid_search::{Cell, CostGrid};
use firefleet_model::heat::{HeatSource, radiant_flux_kw_m2};

/// A 2.5-D grid: per cell, obstacle height (m), roughness (dimensionless, 1 = smooth road)
/// and temperature (C); row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Terrain {
    pub width: usize,
    pub height: usize,
    pub h: Vec<f32>,
    pub r: Vec<f32>,
    pub temp: Vec<f32>,
}

/// The time model of eq. 4.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimeModel {
    pub alpha: f64,
    pub beta: f64,
    pub v_f: f64,
    pub v_h: f64,
}

impl TimeModel {
    /// The paper's values (eq. 5).
    pub const PAPER: TimeModel = TimeModel {
        alpha: 1.0,
        beta: 4.0,
        v_f: 1.0,
        v_h: 1.0,
    };
}

/// The fitness weights of eq. 8.
pub const LAMBDA_TEMP: f64 = 1.0;
pub const LAMBDA_TIME: f64 = 9.0;

/// What a path costs the robot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathScore {
    /// Eq. 8.
    pub fitness: f64,
    /// Sum of the traversal time of its cells.
    pub time: f64,
    /// Sum of the temperature of its cells: the heat dose, in C x cells.
    pub heat: f64,
}

impl Terrain {
    fn at(&self, c: usize, r: usize) -> usize {
        r.min(self.height - 1) * self.width + c.min(self.width - 1)
    }

    /// Local variance of the height over the 2 x 2 window at (c, r) (eq. 1-3).
    pub fn h_var(&self, c: usize, r: usize) -> f64 {
        let hs =
            [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(i, j)| f64::from(self.h[self.at(c + i, r + j)]));
        let mean = hs.iter().sum::<f64>() / 4.0;
        let mean_sq = hs.iter().map(|h| h * h).sum::<f64>() / 4.0;
        (mean_sq - mean * mean).max(0.0)
    }

    /// Traversal time of every cell (eq. 4).
    pub fn time(&self, m: &TimeModel) -> Vec<f64> {
        (0..self.height)
            .flat_map(|r| (0..self.width).map(move |c| (c, r)))
            .map(|(c, r)| {
                m.alpha * f64::from(self.r[self.at(c, r)]) / m.v_f
                    + m.beta * (1.0 + self.h_var(c, r)) / m.v_h
            })
            .collect()
    }

    /// The cost map `w1 time + w2 temp` (eq. 6).
    pub fn cost_map(&self, time: &[f64], w: [f64; 2]) -> CostGrid {
        let cost = time
            .iter()
            .zip(&self.temp)
            // An impassable cell stays so even at a zero time weight (0 x inf is NaN).
            .map(|(t, temp)| {
                if t.is_finite() {
                    (w[0] * t + w[1] * f64::from(*temp)) as f32
                } else {
                    f32::INFINITY
                }
            })
            .collect();
        CostGrid::new(self.width, self.height, cost).expect("non-negative weights and terms")
    }

    /// Eq. 8 along `path` (its first cell excluded).
    pub fn score(&self, time: &[f64], path: &[Cell]) -> PathScore {
        let (mut t, mut heat) = (0.0, 0.0);
        for &(c, r) in path.iter().skip(1) {
            let i = self.at(c, r);
            t += time[i];
            heat += f64::from(self.temp[i]);
        }
        PathScore {
            fitness: LAMBDA_TEMP * heat + LAMBDA_TIME * t,
            time: t,
            heat,
        }
    }

    /// The path planned with weights `w` from `start` to `goal`, and its score.
    pub fn plan(
        &self,
        time: &[f64],
        w: [f64; 2],
        start: Cell,
        goal: Cell,
    ) -> Option<(Vec<Cell>, PathScore)> {
        let (_, path) = self.cost_map(time, w).astar(start, goal)?;
        let score = self.score(time, &path);
        Some((path, score))
    }

    /// A generated fire scene of `n x n` cells: smooth roughness, a few low walls and
    /// blocks of cars (heights), and a fire whose temperature falls off with distance from
    /// a point on the straight line between the corners, so that the shortest route runs
    /// through the heat. Seeded.
    pub fn generated(n: usize, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let cells = n * n;
        let mut h = vec![0.0f32; cells];
        let mut r = vec![1.0f32; cells];
        for _ in 0..(n / 6).max(1) {
            // Blocks 2-4 cells across, 0.3-1.5 m high: parked vehicles and debris.
            let (bw, bh) = (rng.random_range(2..5), rng.random_range(2..5));
            let (c0, r0) = (rng.random_range(0..n - bw), rng.random_range(0..n - bh));
            let height = rng.random_range(0.3..1.5);
            for rr in r0..r0 + bh {
                for cc in c0..c0 + bw {
                    h[rr * n + cc] = height;
                }
            }
        }
        // Roughness: a smooth field from a few random bumps, 1 to about 3.
        let bumps: Vec<(f64, f64, f64)> = (0..6)
            .map(|_| {
                (
                    rng.random_range(0.0..n as f64),
                    rng.random_range(0.0..n as f64),
                    rng.random_range(0.5..2.0),
                )
            })
            .collect();
        let sigma = n as f64 / 6.0;
        for rr in 0..n {
            for cc in 0..n {
                let extra: f64 = bumps
                    .iter()
                    .map(|(x, y, a)| {
                        a * (-((cc as f64 - x).powi(2) + (rr as f64 - y).powi(2))
                            / (2.0 * sigma * sigma))
                            .exp()
                    })
                    .sum();
                r[rr * n + cc] = (1.0 + extra) as f32;
            }
        }
        // The fire: 20 C ambient, up to 400 C at its centre, half-width n/8.
        let along = rng.random_range(0.35..0.65);
        let (fx, fy) = (along * n as f64, along * n as f64);
        let spread = n as f64 / 8.0;
        let temp = (0..cells)
            .map(|i| {
                let (cc, rr) = ((i % n) as f64, (i / n) as f64);
                let d2 = (cc - fx).powi(2) + (rr - fy).powi(2);
                (20.0 + 380.0 * (-d2 / (2.0 * spread * spread)).exp()) as f32
            })
            .collect();
        Self {
            width: n,
            height: n,
            h,
            r,
            temp,
        }
    }
}

impl Terrain {
    /// The cost-map layers of a site at `res` metres per cell: heights from the parked
    /// vehicles, smooth road (roughness 1), and as the heat layer the radiant heat flux
    /// (kW/m^2) of the scenario's fires at their peak, from a point source radiating 30 %
    /// of the heat release (the simulator's model), capped at 100 kW/m^2. The paper's
    /// layer is a temperature; any heat-exposure field serves eq. 6 and 8 the same way.
    /// The grid covers the road's bounding box; cells outside the tunnel (round a curve)
    /// get infinite roughness, which makes them impassable.
    pub fn from_scenario(s: &Scenario, res: f64) -> Self {
        let t = &s.tunnel;
        let (lo, hi) = t.bounds();
        let (w, h) = (
            ((hi.x - lo.x) / res).ceil() as usize,
            ((hi.y - lo.y) / res).ceil() as usize,
        );
        let centre = |i: usize| {
            Point2::new(
                lo.x + ((i % w) as f64 + 0.5) * res,
                lo.y + ((i / w) as f64 + 0.5) * res,
            )
        };
        let heights = (0..w * h)
            .map(|i| {
                let p = centre(i);
                s.obstacles
                    .iter()
                    .filter(|o| o.footprint_contains(p, 0.0))
                    .map(|o| o.height_m as f32)
                    .fold(0.0, f32::max)
            })
            .collect();
        let fires: Vec<HeatSource> = s
            .fires
            .iter()
            .map(|f| HeatSource {
                at: f.position(),
                hrr_kw: f.peak_kw,
            })
            .collect();
        let heat = (0..w * h)
            .map(|i| radiant_flux_kw_m2(&fires, centre(i)) as f32)
            .collect();
        Self {
            width: w,
            height: h,
            h: heights,
            r: (0..w * h)
                .map(|i| {
                    if t.contains(centre(i), 0.0) {
                        1.0
                    } else {
                        f32::INFINITY
                    }
                })
                .collect(),
            temp: heat,
        }
    }

    /// The cell of site point `p` at `res` metres per cell, for a terrain made by
    /// [`Terrain::from_scenario`] of tunnel `t`.
    pub fn cell_of(&self, p: Point2, res: f64, t: &Tunnel) -> Cell {
        let lo = t.bounds().0;
        (
            (((p.x - lo.x) / res).max(0.0) as usize).min(self.width - 1),
            (((p.y - lo.y) / res).max(0.0) as usize).min(self.height - 1),
        )
    }
}

/// A real-coded genetic algorithm over the weights `(w1, w2)` in `[0, w_max]^2`:
/// tournament selection of two, blend crossover (BLX-0.5), Gaussian mutation, the best
/// `elite` kept unchanged. The first individuals are the paper's cases 1 and 2, so the
/// result is never worse than either.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ga {
    pub population: usize,
    pub generations: usize,
    pub elite: usize,
    pub mutation_sigma: f64,
    pub w_max: f64,
}

impl Default for Ga {
    fn default() -> Self {
        Self {
            population: 24,
            generations: 30,
            elite: 2,
            mutation_sigma: 0.05,
            w_max: 1.0,
        }
    }
}

/// The GA's result.
#[derive(Debug, Clone, PartialEq)]
pub struct Tuned {
    pub weights: [f64; 2],
    pub score: PathScore,
    /// Best fitness after each generation.
    pub history: Vec<f64>,
}

impl Ga {
    /// Tune the weights for the trip `start` to `goal` on `terrain`; `None` if no path.
    pub fn tune(
        &self,
        terrain: &Terrain,
        time: &[f64],
        start: Cell,
        goal: Cell,
        seed: u64,
    ) -> Option<Tuned> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let fit = |w: [f64; 2]| terrain.plan(time, w, start, goal).map(|(_, s)| s);
        let mut pop: Vec<[f64; 2]> = vec![[1.0, 0.0], [1.0, 1.0]];
        while pop.len() < self.population {
            pop.push([
                rng.random_range(0.0..self.w_max),
                rng.random_range(0.0..self.w_max),
            ]);
        }
        let mut scored: Vec<([f64; 2], PathScore)> = pop
            .into_iter()
            .map(|w| Some((w, fit(w)?)))
            .collect::<Option<_>>()?;
        let mut history = Vec::with_capacity(self.generations);
        for _ in 0..self.generations {
            scored.sort_by(|a, b| a.1.fitness.total_cmp(&b.1.fitness));
            history.push(scored[0].1.fitness);
            let mut next: Vec<([f64; 2], PathScore)> = scored[..self.elite].to_vec();
            while next.len() < self.population {
                let mut pick = || {
                    let (a, b) = (
                        rng.random_range(0..scored.len()),
                        rng.random_range(0..scored.len()),
                    );
                    if scored[a].1.fitness <= scored[b].1.fitness {
                        scored[a].0
                    } else {
                        scored[b].0
                    }
                };
                let (p, q) = (pick(), pick());
                let child: [f64; 2] = std::array::from_fn(|k| {
                    let (lo, hi) = (p[k].min(q[k]), p[k].max(q[k]));
                    let span = hi - lo;
                    let x = rng.random_range((lo - 0.5 * span)..=(hi + 0.5 * span));
                    let noise: f64 = rng.sample(rand_distr::StandardNormal);
                    (x + self.mutation_sigma * self.w_max * noise).clamp(0.0, self.w_max)
                });
                // A child with both weights zero plans on no cost at all: re-draw it.
                if child == [0.0, 0.0] {
                    continue;
                }
                next.push((child, fit(child)?));
            }
            scored = next;
        }
        scored.sort_by(|a, b| a.1.fitness.total_cmp(&b.1.fitness));
        history.push(scored[0].1.fitness);
        Some(Tuned {
            weights: scored[0].0,
            score: scored[0].1,
            history,
        })
    }
}

/// The paper's three cases on one terrain and trip: (case, weights, score).
pub fn three_cases(
    terrain: &Terrain,
    start: Cell,
    goal: Cell,
    ga: &Ga,
    seed: u64,
) -> Option<[(u8, [f64; 2], PathScore); 3]> {
    let time = terrain.time(&TimeModel::PAPER);
    let (_, s1) = terrain.plan(&time, [1.0, 0.0], start, goal)?;
    let (_, s2) = terrain.plan(&time, [1.0, 1.0], start, goal)?;
    let tuned = ga.tune(terrain, &time, start, goal, seed)?;
    Some([
        (1, [1.0, 0.0], s1),
        (2, [1.0, 1.0], s2),
        (3, tuned.weights, tuned.score),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(n: usize) -> Terrain {
        Terrain {
            width: n,
            height: n,
            h: vec![0.0; n * n],
            r: vec![1.0; n * n],
            temp: vec![20.0; n * n],
        }
    }

    #[test]
    fn local_variance_is_that_of_the_2x2_window() {
        let mut t = flat(3);
        t.h[0] = 2.0; // window at (0,0): 2, 0, 0, 0 -> mean 0.5, mean of squares 1
        assert!((t.h_var(0, 0) - 0.75).abs() < 1e-12);
        assert_eq!(t.h_var(1, 1), 0.0);
        // Time on flat smooth ground: 1 + 4 (eq. 5).
        let smooth = flat(3).time(&TimeModel::PAPER);
        assert!(smooth.iter().all(|v| (v - 5.0).abs() < 1e-12));
    }

    #[test]
    fn heat_pushes_the_path_aside_and_the_ga_balances_time_and_heat() {
        let t = Terrain::generated(40, 3);
        let (s, g) = ((0, 0), (39, 39));
        let [c1, c2, c3] = three_cases(&t, s, g, &Ga::default(), 1).unwrap();
        assert!(c2.2.heat < c1.2.heat, "case 2 avoids heat: {c1:?} {c2:?}");
        assert!(
            c1.2.time <= c2.2.time,
            "case 1 is the quickest: {c1:?} {c2:?}"
        );
        assert!(
            c3.2.fitness <= c1.2.fitness.min(c2.2.fitness),
            "{c1:?} {c2:?} {c3:?}"
        );
    }

    #[test]
    fn the_ga_is_deterministic_and_never_worsens() {
        let t = Terrain::generated(24, 5);
        let time = t.time(&TimeModel::PAPER);
        let ga = Ga {
            population: 10,
            generations: 8,
            ..Ga::default()
        };
        let a = ga.tune(&t, &time, (0, 0), (23, 23), 9).unwrap();
        assert_eq!(a, ga.tune(&t, &time, (0, 0), (23, 23), 9).unwrap());
        assert!(
            a.history.windows(2).all(|w| w[1] <= w[0] + 1e-9),
            "{:?}",
            a.history
        );
    }
}
