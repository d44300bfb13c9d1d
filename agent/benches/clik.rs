//! The monorail's inverse kinematics: one 1 kHz step (fuzzy inference, planner, CLIK) and
//! the whole 40 s case study of the ROBOGAT paper.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_agent::monorail::case_study::CaseStudy;
use firefleet_agent::monorail::clik::{Clik, ClikParams, Target};
use firefleet_agent::monorail::fis::{Fis, Inputs};
use firefleet_agent::monorail::kinematics::{Joints, Limits, Monitor};
use firefleet_agent::monorail::planner::{Planner, PlannerParams};
use nalgebra::Vector2;

fn clik(c: &mut Criterion) {
    let mut g = c.benchmark_group("clik");
    let solver = Clik {
        monitor: Monitor { link_m: 0.8 },
        limits: Limits::robogat(100.0),
        params: ClikParams::ROBOGAT,
    };
    let mut fis = Fis::new();
    let fire = Vector2::new(20.0, 0.0);
    let mut q = Joints::new(8.0, 0.0, -0.26, 14.6);
    let mut planner = Planner::new(PlannerParams::ROBOGAT, solver.monitor.position(&q, 6.3));
    g.bench_function("step", |b| {
        b.iter(|| {
            let w = fis.weights(Inputs {
                fire: true,
                temperature_c: black_box(480.0),
                distance_m: 20.0 - q[0],
            });
            let j = solver.monitor.jet(&q, 6.3).j_xy;
            let plan = planner.step(1e-3, w, &j, fire, false);
            let target = Target {
                p: plan.p,
                pdot: plan.pdot,
                z: 6.3,
                zdot: 0.0,
            };
            black_box(solver.step(&mut q, &target, w))
        })
    });
    let case = CaseStudy::default();
    g.sample_size(20);
    g.bench_function("robogat_40s", |b| {
        b.iter(|| black_box(case.run_fuzzy(usize::MAX)))
    });
    g.finish();
}

criterion_group!(benches, clik);
criterion_main!(benches);
