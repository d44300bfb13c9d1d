//! One full assignment re-solve: `cargo bench -p firefleet-coordinator --bench assignment`.
//!
//! Target (issue #7): at most 20 ms for 1000 units and 200 fires. Every fire burns, so a
//! ground unit's cost counts the fires it would drive past, as in the coordinator.
//! Baseline in the same run: `kuhn_munkres_min` of the pathfinding crate on the same
//! instance (integer costs in milliseconds, as it requires).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_coordinator::assign::{self, Candidate, GroundBody, Mobility, Need, Place, Site};
use firefleet_model::profile::GROUND;
use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::Approach;
use pathfinding::matrix::Matrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Units and fires scattered along a 2 km tunnel.
fn instance(units: usize, fires: usize) -> (Vec<Candidate>, Vec<Need>) {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut p = || Place::straight(rng.random_range(0.0..2000.0), rng.random_range(-4.5..4.5));
    let u = (0..units)
        .map(|i| Candidate {
            unit: UnitId::new(format!("u{i}")).unwrap(),
            at: p(),
            mobility: Mobility::Ground(GroundBody::of(&GROUND)),
            water_l: 1500.0,
            heading_for: None,
            not_for: Vec::new(),
        })
        .collect();
    let f = (0..fires)
        .map(|i| Need {
            fire: FireId(i as u32),
            at: p(),
            priority: 0,
            from: Approach::Either,
        })
        .collect();
    (u, f)
}

fn bench(c: &mut Criterion) {
    let (units, needs) = instance(1000, 200);
    let hazards: Vec<Place> = needs.iter().map(|n| n.at).collect();
    let site = Site {
        hazards: &hazards,
        ..Site::default()
    };
    let mut g = c.benchmark_group("assignment");
    g.sample_size(20);
    g.bench_function("1000_units_200_fires", |b| {
        b.iter(|| black_box(assign::optimal(&units, &needs, &site)))
    });
    let ms: Vec<i64> = needs
        .iter()
        .flat_map(|n| {
            units.iter().map(move |u| {
                let t = u
                    .mobility
                    .travel_s(u.at.position, n.at.position)
                    .unwrap_or(1e6);
                (t * 1000.0) as i64
            })
        })
        .collect();
    let costs: Vec<f64> = ms.iter().map(|&c| c as f64).collect();
    g.bench_function("hungarian_only_1000_units_200_fires", |b| {
        b.iter(|| black_box(assign::hungarian(&costs, needs.len(), units.len())))
    });
    let matrix = Matrix::from_vec(needs.len(), units.len(), ms).unwrap();
    g.bench_function("pathfinding_kuhn_munkres_1000_units_200_fires", |b| {
        b.iter(|| black_box(pathfinding::kuhn_munkres::kuhn_munkres_min(&matrix)))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
