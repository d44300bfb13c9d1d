//! Robot profiles drive the planners: the same site, the same task, two robot models. The
//! small unit threads a gap between two wrecks that the heavy one cannot pass, and the
//! heavy one knows it (it never tries to force its way through).

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_model::scenario::Scenario;
use firefleet_model::{FireId, UnitId};
use firefleet_protocol::msg::{Approach, TaskKind};
use firefleet_sim::World;

/// A wall of wrecks across the bore at x = 50 with a 2.45 m gap on the centreline: wide enough for the small unit (1.0 m wide, 1.9 m across its footprint's diagonal), not for the heavy one (2.5 m wide).
const WALL_X: f64 = 50.0;
const GAP_M: f64 = 2.45;

/// How far along the bore the unit of `profile` gets in 120 s when sent to a fire beyond
/// the gap, and how often it touched something.
fn furthest(profile: &str) -> (f64, u32) {
    let side = (10.0 - GAP_M) / 2.0;
    let scenario = Arc::new(
        Scenario::straight(120.0)
            .name("gap")
            .obstacle("wreck-left", (WALL_X, 5.0 - side / 2.0), [2.0, side, 3.0])
            .obstacle("wreck-right", (WALL_X, -5.0 + side / 2.0), [2.0, side, 3.0])
            .fire("fire", 100.0, 0.0, 2000.0)
            .ground("u1", 10.0, 0.0)
            .profile(profile)
            .build(),
    );
    scenario.validate().unwrap();
    let id = UnitId::new("u1").unwrap();
    let spec = scenario.ground_spec(&id).unwrap();
    let mut world = World::new(&scenario, 5);
    let mut ctl = GroundController::new(id.clone(), spec, scenario.clone());
    ctl.office_changed(true);
    let target = scenario.fires[0].position();
    // Refused or accepted, the unit is the one to judge whether it can get there.
    let _ = ctl.on_task(
        0,
        1,
        TaskKind::Extinguish {
            fire: FireId(1),
            target,
            from: Approach::Either,
        },
    );
    let mut furthest: f64 = 0.0;
    while world.time() < 120.0 {
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
        furthest = furthest.max(world.truth().units[0].pose.x);
    }
    (furthest, world.truth().units[0].collisions)
}

#[test]
fn a_heavy_robot_does_not_pass_a_gap_the_small_one_threads() {
    let (small, small_hits) = furthest("luf60");
    assert!(small > WALL_X + 10.0, "the small unit got to x = {small}");
    assert_eq!(small_hits, 0);
    let (heavy, heavy_hits) = furthest("heavy-ugv");
    assert!(heavy < WALL_X - 1.0, "the heavy unit got to x = {heavy}");
    assert_eq!(heavy_hits, 0, "the heavy unit tried to force the gap");
}
