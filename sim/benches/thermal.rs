//! One thermal frame of a 160x120 Lepton-class core (19 200 rays), the simulator's cost
//! per frame and unit under `--perception pixels`.
//!
//! `long_road` looks down the 3 km `long-road` site (its curved tunnel, every parked
//! vehicle a box, its four fires as flames) from its first ground unit's start; `short`
//! down a straight 300 m tunnel with one flame and one car, the lab's scene size.
//!
//! `sim_second` is a simulated second of the whole `long-road` world as the simulator's
//! loop runs it (20 steps, every unit's sensor frame after each), with boxes drawn from the
//! truth and with thermal pixels: the price of `--perception pixels`.

use std::hint::black_box;
use std::path::Path;

use criterion::{Criterion, criterion_group, criterion_main};
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Tunnel;
use firefleet_model::scenario::{Obstacle, Scenario};
use firefleet_model::{Point2, Pose2};
use firefleet_model::{UnitId, UnitKind};
use firefleet_sim::World;
use firefleet_sim::thermal::{Flame, HotBox, Scene, ThermalCore, render};
use firefleet_sim::world::Perception;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

const AMBIENT_K: f64 = 293.15;

fn frame(
    c: &mut Criterion,
    name: &str,
    tunnel: &Tunnel,
    boxes: &[HotBox],
    flames: &[Flame],
    eye: Pose2,
) {
    let ceiling = |_: f64, _: Point2| AMBIENT_K + 60.0;
    let scene = Scene {
        tunnel,
        boxes,
        flames,
        beds: &[],
        ambient_k: AMBIENT_K,
        outside_k: AMBIENT_K + 15.0,
        smoke_per_m: 0.05,
        ceiling_k: &ceiling,
    };
    let core = ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"));
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    c.bench_function(&format!("thermal_frame/{name}"), |b| {
        b.iter(|| black_box(render(&core, &eye, &scene, 12.0, &mut rng)))
    });
}

/// Every vehicle a box 40 K above ambient (warmed by the fires).
fn warm(obstacles: &[Obstacle]) -> Vec<HotBox> {
    obstacles
        .iter()
        .map(|o| HotBox {
            shape: o.clone(),
            surface_k: AMBIENT_K + 40.0,
        })
        .collect()
}

fn thermal(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/scenarios/long-road.toml");
    let site = Scenario::load(&path).expect("the shipped long-road scenario");
    let boxes = warm(&site.obstacles);
    let flames: Vec<Flame> = site
        .fires
        .iter()
        .map(|f| Flame {
            base: Point2::new(f.x_m, f.y_m),
            radius_m: f.radius_m,
            height_m: 2.5,
            sprayed: false,
        })
        .collect();
    let unit = site
        .units
        .iter()
        .find(|u| u.kind == UnitKind::Ground)
        .expect("long-road has ground units");
    frame(c, "long_road", &site.tunnel, &boxes, &flames, unit.pose());

    let short = Scenario::straight(300.0)
        .name("bench")
        .car("car", 80.0, -2.5)
        .build();
    let boxes = warm(&short.obstacles);
    let flame = [Flame {
        base: Point2::new(60.0, 1.0),
        radius_m: 0.6,
        height_m: 2.0,
        sprayed: false,
    }];
    frame(
        c,
        "short",
        &short.tunnel,
        &boxes,
        &flame,
        Pose2::new(50.0, 0.0, 0.0),
    );

    for (name, perception) in [("boxes", Perception::Boxes), ("pixels", Perception::Pixels)] {
        let mut world = World::new(&site, 1);
        world.set_perception(perception);
        let units: Vec<UnitId> = world.unit_ids().cloned().collect();
        let mut g = c.benchmark_group("sim_second");
        g.sample_size(10);
        g.bench_function(format!("long_road/{name}"), |b| {
            b.iter(|| {
                for _ in 0..20 {
                    world.step(0.05);
                    for id in &units {
                        black_box(world.sensors(id));
                    }
                }
            })
        });
        g.finish();
    }
}

criterion_group!(benches, thermal);
criterion_main!(benches);
