//! Commanders' barred space enforced by a ground unit itself, against the simulated world:
//! inside, it leaves by the shortest way and stays out; a task that needs barred space is
//! refused with its reason; alone, it does not attack a fire there. (The monorail
//! carriage's part is in `monorail.rs`.)

use std::sync::Arc;

use firefleet_agent::ground::GroundController;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Scenario;
use firefleet_model::{Chainage, FireId, Point2, UnitId, ZoneId};
use firefleet_protocol::msg::{Approach, Bar, BarredSpace, BarredSpan, RefusalReason, TaskKind};
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
    let ctl = GroundController::new(id.clone(), *GROUND, scenario);
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
    ctl.office_changed(true);
    // Patrolling east, it is well inside 50-150 m after 40 s.
    drive(&mut ctl, &mut world, &id, 40.0);
    let x0 = ctl.state().pose.x;
    assert!((60.0..100.0).contains(&x0), "at {x0}");
    ctl.on_barred(barred(world.time(), 50.0, 150.0, false))
        .unwrap();
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
    ctl.office_changed(true);
    drive(&mut ctl, &mut world, &id, 0.1);
    ctl.on_barred(barred(0.0, 50.0, 150.0, false)).unwrap();
    ctl.on_task(
        0,
        1,
        TaskKind::Cruise {
            goal: Point2::new(180.0, -2.5),
        },
    )
    .unwrap();
    let r = ctl.state().refused.expect("refused");
    assert_eq!(
        (r.seq, r.reason, r.goal.as_str()),
        (1, RefusalReason::WayBarred, "ko")
    );
    drive(&mut ctl, &mut world, &id, 60.0);
    assert!(ctl.state().pose.x < 50.0, "crossed into barred space");
    // The next task, on this side, is taken and the refusal forgotten.
    ctl.on_task(
        0,
        2,
        TaskKind::Cruise {
            goal: Point2::new(30.0, -2.5),
        },
    )
    .unwrap();
    assert_eq!(ctl.state().refused, None);
    ctl.on_task(
        0,
        3,
        TaskKind::Extinguish {
            fire: FireId(1),
            target: Point2::new(100.0, 0.0),
            from: Approach::Either,
        },
    )
    .unwrap();
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
    ctl.on_barred(barred(0.0, 80.0, 120.0, false)).unwrap();
    let mut farthest: f64 = 0.0;
    for _ in 0..240 {
        drive(&mut ctl, &mut world, &id, 0.5);
        farthest = farthest.max(ctl.state().pose.x);
    }
    let fire = &world.truth().fires[0];
    assert_eq!(fire.water_received_l, 0.0, "{fire:?}");
    assert!(farthest < 80.0, "went to {farthest}");
}

#[test]
fn a_barred_space_dated_ahead_of_the_clock_is_refused_and_one_heard_before_the_first_frame_waits() {
    let s = Scenario::straight(200.0).ground("u1", 20.0, -2.5).build();
    let (mut ctl, mut world, id) = ground(s);
    // Before the first frame (a recorder's answer to the start-up question): kept, judged
    // when the clock is known.
    ctl.on_barred(barred(0.5, 50.0, 150.0, false)).unwrap();
    drive(&mut ctl, &mut world, &id, 1.0);
    ctl.on_task(
        0,
        1,
        TaskKind::Cruise {
            goal: Point2::new(180.0, -2.5),
        },
    )
    .unwrap();
    assert!(
        ctl.state().refused.is_some(),
        "the early barred space binds"
    );
    // Dated a day ahead: refused, and it does not shut out the real lifting of the zone.
    let e = ctl
        .on_barred(barred(86_400.0, 0.0, 200.0, false))
        .unwrap_err();
    assert!(e.to_string().contains("ahead of the site clock"), "{e}");
    ctl.on_barred(BarredSpace {
        t: 2.0,
        spans: Vec::new(),
    })
    .unwrap();
    ctl.on_task(
        0,
        2,
        TaskKind::Cruise {
            goal: Point2::new(180.0, -2.5),
        },
    )
    .unwrap();
    assert_eq!(ctl.state().refused, None);
}

/// Issue #35's idle units: a keep-out that catches a unit on its way, lifted a moment
/// later, left it idle for good (its cruise was stopped under the tree, which kept waiting
/// for an arrival that could never come).
#[test]
fn a_unit_whose_cruise_a_keep_out_interrupted_cruises_on_once_it_is_lifted() {
    let s = Scenario::straight(200.0).ground("u1", 20.0, -2.5).build();
    let (mut ctl, mut world, id) = ground(s);
    ctl.office_changed(true);
    drive(&mut ctl, &mut world, &id, 0.1);
    let goal = Point2::new(180.0, -2.5);
    ctl.on_task(0, 1, TaskKind::Search { goal }).unwrap();
    drive(&mut ctl, &mut world, &id, 25.0);
    let x0 = ctl.state().pose.x;
    assert!((50.0..150.0).contains(&x0), "on its way at {x0}");
    ctl.on_barred(barred(world.time(), 0.0, 200.0, false))
        .unwrap();
    drive(&mut ctl, &mut world, &id, 1.0);
    ctl.on_barred(BarredSpace {
        t: world.time(),
        spans: Vec::new(),
    })
    .unwrap();
    drive(&mut ctl, &mut world, &id, 120.0);
    let x = ctl.state().pose.x;
    assert!(
        x > 170.0,
        "still short of its goal at {x} two minutes after the keep-out was lifted"
    );
}
