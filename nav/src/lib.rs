//! Ground navigation: maps of the tunnel, planners and a path follower.
//!
//! [`hybrid_astar`] plans kinematically feasible paths to firing positions (Dolgov's
//! Hybrid A* with the BT paper's visibility reward and a radiant-heat term), using
//! [`reeds_shepp`] for its heuristic and analytic expansion, and [`smoother`] to ease the
//! swerves its motion primitives leave. [`astar`] is the 8-connected grid planner on the
//! inflated occupancy [`grid`], string-pulled into straight segments: units cruise on it,
//! and fall back on it when no Hybrid A* path to a firing spot is found within budget.
//! [`grid_search`] is the general weighted-grid search (Dijkstra to all cells, A* between
//! two) under the heat-aware cost map ([`costmap`]) and the MovingAI benchmarks
//! ([`movingai`]). [`pursuit`] follows any of these paths, forwards and backing through
//! the cusps of a Hybrid A* route.
//!
//! ```
//! use firefleet_nav::grid_search::CostGrid;
//!
//! // A 5 x 3 corridor with a wall across it but for the top row.
//! let passable: Vec<bool> = (0..15).map(|i| i % 5 != 2 || i / 5 == 0).collect();
//! let grid = CostGrid::from_passable(5, 3, &passable).unwrap();
//! let (cost, path) = grid.astar((0, 2), (4, 2)).unwrap();
//! assert_eq!(path.first(), Some(&(0, 2)));
//! assert_eq!(path.last(), Some(&(4, 2)));
//! assert!(path.iter().all(|&cell| grid.passable(cell)));
//! assert!(cost > 4.0, "round the wall, not through it: {cost}");
//! ```
//!
//! No I/O, no Zenoh, no clock: every function takes a map and poses and returns a path or
//! a command, so the robot (`firefleet-agent`) and the coordinator's road map share the
//! same code. What to plan for (firing spots, tasks) is the agent's business, not this
//! crate's.

pub mod astar;
pub mod costmap;
pub mod grid;
pub mod grid_search;
pub mod hybrid_astar;
pub mod movingai;
pub mod pursuit;
pub mod reeds_shepp;
pub mod smoother;

pub use astar::plan;
pub use grid::Grid;
pub use pursuit::{Follow, PurePursuit, Route};
