// A ground unit in its most common state, shared by the `bt` bench and the allocation
// test (included with `include!`, so both measure the same thing).

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_model::UnitId;
use firefleet_model::scenario::Scenario;
use firefleet_model::profile::GROUND;
use firefleet_sim::World;


/// The shipped ground tree after 5 s of cruising with a coordinator present and no task.
pub fn cruising_unit() -> GroundController {
    let scenario = Arc::new(
        Scenario::straight(200.0)
            .name("cruise")
            .car("car", 60.0, -2.5)
            .fire("fire", 150.0, 1.0, 5000.0)
            .ignition(-60.0)
            .ground("u1", 5.0, -2.5)
            .build(),
    );
    let mut world = World::new(&scenario, 1);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario);
    ctl.office_changed(true);
    for _ in 0..100 {
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
    }
    ctl
}
