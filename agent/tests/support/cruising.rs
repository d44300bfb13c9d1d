// A ground unit in its most common state, shared by the `bt` bench and the allocation
// test (included with `include!`, so both measure the same thing).

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_protocol::UnitId;
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::GROUND;
use firefleet_sim::World;

const CRUISE_SCENARIO: &str = r#"
    name = "cruise"
    time_limit_s = 300
    [tunnel]
    length_m = 200.0
    width_m = 10.0
    height_m = 6.3
    lanes = 2
    [[obstacles]]
    name = "car"
    x_m = 60.0
    y_m = -2.5
    length_m = 4.5
    width_m = 1.8
    height_m = 1.5
    [[fires]]
    name = "fire"
    x_m = 150.0
    y_m = 1.0
    growth = "fast"
    peak_kw = 5000.0
    ignition_s = -60.0
    [[units]]
    id = "u1"
    kind = "ground"
    x_m = 5.0
    y_m = -2.5
"#;

/// The shipped ground tree after 5 s of cruising with a coordinator present and no task.
pub fn cruising_unit() -> GroundController {
    let scenario = Arc::new(Scenario::from_toml(CRUISE_SCENARIO, "cruise.toml").unwrap());
    let mut world = World::new(&scenario, 1);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), GROUND, scenario);
    ctl.set_coordinator_present(true);
    for _ in 0..100 {
        let cmd = ctl.step(&world.sensors(&id).unwrap());
        world.command(&id, cmd);
        world.step(0.05);
    }
    ctl
}
