//! Ground units meeting in the simulated world, where bodies touch: two that meet head on
//! in one lane get past each other, so do two that start nose to nose closer than any
//! margin, and a unit finds its way past one parked in its lane, all without touching; a
//! unit that touched a car gets clear of it though its commands reach its body late.

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_model::UnitId;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Scenario;
use firefleet_sim::World;

/// Units on patrol in lockstep with the world until `done` holds of their x (or three
/// minutes pass); each unit's blocked steps.
fn patrol(scenario: Scenario, ids: &[&str], done: impl Fn(&[f64]) -> bool) -> (Vec<f64>, Vec<u32>) {
    let scenario = Arc::new(scenario);
    let mut world = World::new(&scenario, 5);
    let ids: Vec<UnitId> = ids.iter().map(|id| UnitId::new(*id).unwrap()).collect();
    let mut units: Vec<GroundController> = ids
        .iter()
        .map(|id| GroundController::new(id.clone(), *GROUND, scenario.clone()))
        .collect();
    for u in &mut units {
        u.office_changed(true);
    }
    let xs = |world: &World| {
        world
            .truth()
            .units
            .iter()
            .map(|u| u.pose.x)
            .collect::<Vec<_>>()
    };
    while world.time() < 180.0 && !done(&xs(&world)) {
        for (id, u) in ids.iter().zip(&mut units) {
            let sensors = world.sensors(id).unwrap();
            world.command(id, u.step(&sensors));
        }
        world.step(0.05);
    }
    let truth = world.truth();
    (
        xs(&world),
        truth.units.iter().map(|u| u.collisions).collect(),
    )
}

#[test]
fn two_units_meeting_head_on_in_one_lane_get_past_each_other_untouched() {
    // Both in the right-hand lane: u1 patrols east from the west portal, u2 west from the
    // east one, so they meet half way.
    let s = Scenario::straight(200.0)
        .ground("u1", 20.0, -2.5)
        .ground("u2", 180.0, -2.5)
        .build();
    let (x, blocked) = patrol(s, &["u1", "u2"], |x| x[0] > 150.0 && x[1] < 50.0);
    assert!(
        x[0] > 150.0 && x[1] < 50.0,
        "still short of each other's start: {x:?}"
    );
    assert_eq!(blocked, [0, 0], "the bodies touched");
}

#[test]
fn a_unit_goes_round_one_standing_in_its_lane() {
    // u2 has no controller: it stands where it starts, as a unit that lost its agent does.
    let s = Scenario::straight(200.0)
        .ground("u1", 20.0, -2.5)
        .ground("u2", 80.0, -2.5)
        .build();
    let (x, blocked) = patrol(s, &["u1"], |x| x[0] > 120.0);
    assert!(x[0] > 120.0, "u1 never got past: {x:?}");
    assert_eq!(blocked, [0, 0], "the bodies touched");
    assert_eq!(x[1], 80.0, "the standing unit was pushed");
}

#[test]
fn two_units_starting_nose_to_nose_get_past_each_other_untouched() {
    // 1 m between the bumpers: u1 patrols east, u2, facing it from the tunnel's east half,
    // west. Neither can steer round the other from there driving forwards.
    let gap = 1.0;
    let mut s = Scenario::straight(200.0)
        .ground("u1", 98.0, -2.5)
        .ground("u2", 98.0 + GROUND.length_m + gap, -2.5)
        .build();
    s.units[1].yaw_rad = std::f64::consts::PI;
    let (x, blocked) = patrol(s, &["u1", "u2"], |x| x[0] > 130.0 && x[1] < 70.0);
    assert!(x[0] > 130.0 && x[1] < 70.0, "still short: {x:?}");
    assert_eq!(blocked, [0, 0], "the bodies touched");
}

/// u1 on patrol east with a car in its lane 6 m ahead, driven straight at the car until
/// it touches it, and from then on by its controller, each command reaching the body
/// `lag` steps after the frame it answers (a loaded machine, or a lossy link's
/// retransmissions); its x once past the car (or after 90 s) and its blocked steps after
/// the first.
fn bump_then_drive_late(lag: usize) -> (f64, u32) {
    use firefleet_protocol::msg::UnitCommand;
    let scenario = Arc::new(
        Scenario::straight(200.0)
            .ground("u1", 20.0, -2.5)
            .car("car", 28.0, -2.5)
            .build(),
    );
    let mut world = World::new(&scenario, 5);
    let id = UnitId::new("u1").unwrap();
    let mut unit = GroundController::new(id.clone(), *GROUND, scenario.clone());
    unit.office_changed(true);
    let ram = UnitCommand {
        speed: 1.0,
        ..UnitCommand::halt(&Default::default())
    };
    let blocked = |world: &World| world.truth().units[0].collisions;
    let mut in_flight = std::collections::VecDeque::new();
    while world.time() < 90.0 && world.truth().units[0].pose.x < 40.0 {
        let cmd = unit.step(&world.sensors(&id).unwrap());
        if blocked(&world) == 0 {
            world.command(&id, ram);
        } else {
            in_flight.push_back(cmd);
            if in_flight.len() > lag {
                world.command(&id, in_flight.pop_front().unwrap());
            }
        }
        world.step(0.05);
    }
    assert!(blocked(&world) > 0, "never touched the car");
    (world.truth().units[0].pose.x, blocked(&world) - 1)
}

#[test]
fn a_unit_that_bumped_a_car_gets_clear_though_its_commands_reach_the_body_late() {
    // Each contact costs about `lag` blocked steps, the commands already on their way.
    // Taking those for refusals of the move that gets clear, a unit with 4 steps of lag
    // pushed against the car for 90 s (439 blocked steps).
    for lag in [1, 2, 4, 6, 10] {
        let (x, blocked) = bump_then_drive_late(lag);
        assert!(
            x >= 40.0,
            "lag {lag}: still behind the car after 90 s, at x {x:.1}"
        );
        assert!(
            blocked <= 2 * lag as u32 + 5,
            "lag {lag}: {blocked} blocked steps after the bump"
        );
    }
}
