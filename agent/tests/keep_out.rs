//! Commanders' barred space enforced by the units themselves, against the simulated world:
//! a ground unit inside leaves by the shortest way and stays out, a task that needs barred
//! space is refused with its reason, a unit alone does not attack a fire in it, and a
//! monorail carriage keeps out of it unless the goal lets rail units through (and even
//! then attacks nothing there).

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::{MonorailController, default_tree};
use firefleet_protocol::msg::{Bar, BarredSpace, BarredSpan, RefusalReason, TaskKind};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::{GROUND, MONORAIL};
use firefleet_protocol::{Chainage, FireId, Point2, UnitId, ZoneId};
use firefleet_sim::World;

/// Chainages `start`-`end` barred to every unit (to ground units only if `rail_allowed`).
fn barred(t: f64, start: f64, end: f64, rail_allowed: bool) -> BarredSpace {
    BarredSpace {
        t,
        spans: vec![BarredSpan {
            goal: "ko".into(),
            zone: ZoneId::new("z").unwrap(),
            start: Chainage::new(start),
            end: Chainage::new(end),
            bar: Bar::Entry,
            rail_allowed,
        }],
    }
}

/// A ground unit `u1` starting at 20 m in a 200 m tunnel, and its world.
fn ground(scenario: Scenario) -> (GroundController, World, UnitId) {
    let scenario = Arc::new(scenario);
    let id = UnitId::new("u1").unwrap();
    let world = World::new(&scenario, 3);
    let ctl = GroundController::new(id.clone(), GROUND, scenario);
    (ctl, world, id)
}

fn drive(ctl: &mut GroundController, world: &mut World, id: &UnitId, seconds: f64) {
    let until = world.time() + seconds;
    while world.time() < until {
        world.step_unit(id, 0.05, |s| ctl.step(s)).unwrap();
    }
}

#[test]
fn a_unit_inside_a_new_keep_out_leaves_by_the_shortest_way_and_stays_out() {
    let s = Scenario::straight(200.0).ground("u1", 20.0, -2.5).build();
    let (mut ctl, mut world, id) = ground(s);
    ctl.set_coordinator_present(true);
    // Patrolling east, it is well inside 50-150 m after 40 s.
    drive(&mut ctl, &mut world, &id, 40.0);
    let x0 = ctl.state().pose.x;
    assert!((60.0..100.0).contains(&x0), "at {x0}");
    ctl.on_barred(barred(world.time(), 50.0, 150.0, false));
    // The way out is west, back past 50 m: at most (x0 - 45) at 1.5 m/s, twice over.
    let deadline = 2.0 * (x0 - 45.0) / GROUND.max_speed_m_s;
    let mut out_after = None;
    let start = world.time();
    while world.time() < start + deadline + 120.0 {
        drive(&mut ctl, &mut world, &id, 0.5);
        let x = ctl.state().pose.x;
        if out_after.is_none() && x < 50.0 - GROUND.circumradius_m() {
            out_after = Some(world.time() - start);
        }
        if out_after.is_some() {
            assert!(x < 50.0, "back inside at {x}, t = {}", world.time());
        }
    }
    let out_after = out_after.expect("never left");
    assert!(
        out_after <= deadline,
        "out after {out_after:.1} s (deadline {deadline:.1} s)"
    );
    // It holds at the edge, not somewhere else: its patrol stops short of the zone.
    let x = ctl.state().pose.x;
    assert!((38.0..50.0).contains(&x), "holds at {x}");
}

#[test]
fn a_task_that_needs_barred_space_is_refused_with_the_reason() {
    let s = Scenario::straight(200.0).ground("u1", 20.0, -2.5).build();
    let (mut ctl, mut world, id) = ground(s);
    ctl.set_coordinator_present(true);
    ctl.on_barred(barred(0.0, 50.0, 150.0, false));
    ctl.on_task(
        1,
        TaskKind::Cruise {
            goal: Point2::new(180.0, -2.5),
        },
    );
    let r = ctl.state().refused.expect("refused");
    assert_eq!(
        (r.seq, r.reason, r.goal.as_str()),
        (1, RefusalReason::WayBarred, "ko")
    );
    drive(&mut ctl, &mut world, &id, 60.0);
    assert!(ctl.state().pose.x < 50.0, "crossed into barred space");
    // The next task, on this side, is taken and the refusal forgotten.
    ctl.on_task(
        2,
        TaskKind::Cruise {
            goal: Point2::new(30.0, -2.5),
        },
    );
    assert_eq!(ctl.state().refused, None);
    ctl.on_task(
        3,
        TaskKind::Extinguish {
            fire: FireId(1),
            target: Point2::new(100.0, 0.0),
        },
    );
    let r = ctl.state().refused.expect("refused");
    assert_eq!((r.seq, r.reason), (3, RefusalReason::DestinationBarred));
}

#[test]
fn alone_a_unit_does_not_attack_a_fire_in_barred_space() {
    let s = Scenario::straight(200.0)
        .fire("car", 100.0, 1.0, 3000.0)
        .ground("u1", 20.0, -2.5)
        .build();
    let (mut ctl, mut world, id) = ground(s);
    ctl.on_barred(barred(0.0, 80.0, 120.0, false));
    let mut farthest: f64 = 0.0;
    for _ in 0..240 {
        drive(&mut ctl, &mut world, &id, 0.5);
        farthest = farthest.max(ctl.state().pose.x);
    }
    let fire = &world.truth().fires[0];
    assert_eq!(fire.water_received_l, 0.0, "{fire:?}");
    assert!(farthest < 80.0, "went to {farthest}");
}

fn carriage(scenario: &Arc<Scenario>) -> MonorailController {
    MonorailController::with_tree(
        UnitId::new("m").unwrap(),
        MONORAIL,
        scenario.clone(),
        &default_tree(),
    )
    .unwrap()
    .unwrap()
}

/// Step a monorail controller and its world for `seconds`; the carriage's chainages.
fn ride(ctl: &mut MonorailController, world: &mut World, seconds: f64) -> Vec<f64> {
    let id = UnitId::new("m").unwrap();
    let until = world.time() + seconds;
    let mut at = Vec::new();
    while world.time() < until {
        let cmd = ctl.step(&world.rail_sensors(&id).unwrap());
        world.command_rail(&id, cmd);
        world.step(0.05);
        at.push(ctl.state().pose.x);
    }
    at
}

#[test]
fn a_carriage_keeps_out_of_barred_space_unless_rail_units_are_let_through() {
    let scenario = Arc::new(
        Scenario::straight(200.0)
            .fire("car", 100.0, 1.0, 3000.0)
            .ignition(-60.0)
            .rail("r", 0.0, 200.0, &[15.0, 45.0, 75.0, 105.0, 135.0, 165.0])
            .monorail("m", "r", 120.0)
            .build(),
    );
    let attack = TaskKind::Extinguish {
        fire: FireId(1),
        target: Point2::new(100.0, 1.0),
    };
    // Inside 50-150 m when the goal comes: it runs out by the nearest end (155 m), and
    // refuses the fire inside.
    let mut world = World::new(&scenario, 5);
    let mut ctl = carriage(&scenario);
    ctl.set_coordinator_present(true);
    ride(&mut ctl, &mut world, 1.0);
    ctl.on_barred(barred(world.time(), 50.0, 150.0, false));
    ctl.on_task(1, attack);
    assert_eq!(
        ctl.state().refused.map(|r| r.reason),
        Some(RefusalReason::DestinationBarred)
    );
    let at = ride(&mut ctl, &mut world, 60.0);
    let settled = &at[at.len() / 2..];
    assert!(settled.iter().all(|&x| x > 150.0), "{:?}", &settled[..5]);
    assert_eq!(world.truth().fires[0].water_received_l, 0.0);

    // Let through, it runs across the zone (a search to the far end), but still does not
    // attack there: the goal lets carriages pass, not spray where firefighters go in.
    let mut world = World::new(&scenario, 5);
    let mut ctl = carriage(&scenario);
    ctl.set_coordinator_present(true);
    ctl.on_barred(barred(0.0, 50.0, 150.0, true));
    ctl.on_task(
        1,
        TaskKind::Search {
            goal: Point2::new(10.0, 0.0),
        },
    );
    assert_eq!(ctl.state().refused, None);
    let at = ride(&mut ctl, &mut world, 30.0);
    assert!(at.iter().any(|&x| x < 20.0), "ran to {:?}", at.last());
    ctl.on_task(2, attack);
    assert_eq!(
        ctl.state().refused.map(|r| r.reason),
        Some(RefusalReason::DestinationBarred)
    );
}
