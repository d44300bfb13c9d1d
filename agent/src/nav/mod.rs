//! Ground navigation: a map of the tunnel, a grid planner and a path follower.
//!
//! This is the first planner: 8-connected A* on an occupancy grid inflated by the robot's
//! footprint, string-pulled into straight segments and followed by pure pursuit. It keeps
//! clear of parked vehicles and the walls. It is not yet kinematically aware (that is the
//! Hybrid A* planner's job) and does not weigh heat. [`grid_search`] is the general
//! weighted-grid search (Dijkstra to all cells, A* between two) that the heat-aware cost
//! map ([`costmap`]) and the MovingAI benchmarks ([`movingai`]) use; [`reeds_shepp`] gives
//! the shortest paths of a car that may reverse, which [`hybrid_astar`] uses for its
//! heuristic and its analytic expansion. The ground unit does not use Hybrid A* yet.

pub mod astar;
pub mod costmap;
pub mod grid;
pub mod grid_search;
pub mod hybrid_astar;
pub mod movingai;
pub mod pursuit;
pub mod reeds_shepp;

pub use astar::plan;
pub use grid::Grid;
pub use pursuit::{Follow, PurePursuit};
