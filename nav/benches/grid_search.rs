//! Dijkstra from one cell to all cells of a 1000 x 1000 8-connected grid: ours, and the
//! same search through `pathfinding::directed::dijkstra::dijkstra_all` as the baseline.
//!
//! The grid has 10 % of its cells blocked at random (seeded), so that the search is not a
//! plain octile fill. `pathfinding` needs integer costs: moves cost 1000 straight and 1414
//! diagonal there, the same problem to three digits.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_nav::grid::NEIGHBOURS;
use firefleet_nav::grid_search::CostGrid;

const N: usize = 1000;

fn passable() -> Vec<bool> {
    // A small xorshift: the bench must not depend on rand's stream staying the same.
    let mut s = 0x9E37_79B9_7F4A_7C15_u64;
    (0..N * N)
        .map(|i| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            i == 0 || !s.is_multiple_of(10)
        })
        .collect()
}

fn grid_search(c: &mut Criterion) {
    let open = passable();
    let grid = CostGrid::from_passable(N, N, &open).expect("sizes match");
    let mut g = c.benchmark_group("grid_search");
    g.sample_size(10);
    g.bench_function("dijkstra_1000x1000", |b| {
        b.iter(|| black_box(grid.dijkstra_all((0, 0))))
    });
    let free = |x: isize, y: isize| {
        x >= 0
            && y >= 0
            && (x as usize) < N
            && (y as usize) < N
            && open[y as usize * N + x as usize]
    };
    let successors = |&(x, y): &(isize, isize)| {
        let mut out = Vec::with_capacity(8);
        for (dx, dy) in NEIGHBOURS {
            let (nx, ny) = (x + dx, y + dy);
            if !free(nx, ny) {
                continue;
            }
            if dx != 0 && dy != 0 {
                if !free(nx, y) || !free(x, ny) {
                    continue;
                }
                out.push(((nx, ny), 1414u32));
            } else {
                out.push(((nx, ny), 1000u32));
            }
        }
        out
    };
    g.bench_function("pathfinding_dijkstra_1000x1000", |b| {
        b.iter(|| {
            black_box(pathfinding::directed::dijkstra::dijkstra_all(
                &(0isize, 0isize),
                successors,
            ))
        })
    });
    g.finish();
}

criterion_group!(benches, grid_search);
criterion_main!(benches);
