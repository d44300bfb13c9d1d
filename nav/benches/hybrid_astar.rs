//! Hybrid A* in a 200 m x 10 m tunnel at 0.1 m (200 000 cells), 72 heading bins, two
//! parked vehicles between the start and the flame, the visibility term on.
//!
//! `turn_around` is a ground unit's harder everyday call, on its own grid (0.25 m cells,
//! walls and vehicles grown 0.3 m): a firing position behind it, facing the other way,
//! past the parked car, which takes some 20 000 expansions instead of 300.
//!
//! A grid works its clearance out when it is made (a unit keeps its grid until a keep-out
//! changes it); `grid_keepout` times making one, a keep-out layer that bars nothing.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "a bench prints its figures"
)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Scenario;
use firefleet_model::{Point2, Pose2};
use firefleet_nav::Grid;
use firefleet_nav::hybrid_astar::{Footprint, HybridAStar, Params};

fn hybrid_astar(c: &mut Criterion) {
    let site = Scenario::straight(200.0)
        .name("bench")
        .car("car", 80.0, -2.5)
        .obstacle("van", (140.0, 2.5), [5.5, 2.0, 2.4])
        .build();
    let grid = Grid::from_scenario(&site, 0.1, 0.0);
    let mut params = Params::for_radius(GROUND.min_turn_radius_m());
    params.lambda_m = 5.0;
    let footprint = Footprint {
        length_m: GROUND.length_m,
        width_m: GROUND.width_m,
    };
    let planner = HybridAStar::new(&grid, footprint, params);
    let (start, goal, flame) = (
        Pose2::new(5.0, -2.5, 0.0),
        Pose2::new(172.0, 2.5, 0.0),
        Point2::new(180.0, 2.5),
    );
    let plan = planner.plan(start, goal, Some(flame)).expect("a path");
    eprintln!(
        "tunnel_200m: {} expansions, {:.1} m, {} poses, smoothed {}",
        plan.expansions,
        plan.length_m,
        plan.poses.len(),
        plan.smoothed
    );
    let mut g = c.benchmark_group("hybrid_astar");
    g.sample_size(20);
    g.bench_function("tunnel_200m", |b| {
        b.iter(|| black_box(planner.plan(start, goal, Some(flame))))
    });
    // The same search without the smoother, for the smoother's share of the time.
    let search_only = HybridAStar::new(
        &grid,
        footprint,
        Params {
            smoothing: None,
            ..params
        },
    );
    g.bench_function("tunnel_200m_unsmoothed", |b| {
        b.iter(|| black_box(search_only.plan(start, goal, Some(flame))))
    });
    g.bench_function("grid_keepout", |b| {
        b.iter(|| black_box(grid.with_keepout(|_| false)))
    });
    let unit_grid = Grid::from_scenario(&site, 0.25, 0.3);
    let unit = HybridAStar::new(
        &unit_grid,
        footprint,
        Params {
            max_expansions: 100_000,
            ..params
        },
    );
    let (behind, facing_back) = (
        Pose2::new(60.0, 2.5, 0.0),
        Pose2::new(90.0, -2.5, std::f64::consts::PI),
    );
    let plan = unit.plan(behind, facing_back, Some(flame)).expect("a path");
    eprintln!(
        "turn_around: {} expansions, {:.1} m",
        plan.expansions, plan.length_m
    );
    g.sample_size(10);
    g.bench_function("turn_around", |b| {
        b.iter(|| black_box(unit.plan(behind, facing_back, Some(flame))))
    });
    g.finish();
}

criterion_group!(benches, hybrid_astar);
criterion_main!(benches);
