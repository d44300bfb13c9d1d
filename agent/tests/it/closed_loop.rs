//! The ground controller driving the simulated world directly (no bus): it must find,
//! reach and put out fires, around parked vehicles, with and without a coordinator's task.

use std::sync::Arc;

use firefleet_agent::controller::TaskRefused;
use firefleet_agent::ground::GroundController;
use firefleet_model::FireId;
use firefleet_model::UnitId;
use firefleet_model::geometry::{Point2, wrap_angle};
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::msg::{Approach, TaskKind, TaskPhase, TruthFireState, UnitMode};
use firefleet_sim::World;
use firefleet_sim::world::Perception;

/// What a closed-loop run did.
/// A 120 m tunnel: a parked car at 40 m, a 5 MW fire at 60 m, unit u1 at the portal.
fn site() -> Arc<Scenario> {
    Arc::new(
        Scenario::straight(120.0)
            .name("closed-loop")
            .car("car", 40.0, -2.5)
            .fire("fire", 60.0, -2.0, 5000.0)
            .ground("u1", 5.0, -2.5)
            .build(),
    )
}

struct Run {
    /// When the fire went out.
    out_at: Option<f64>,
    /// How often its knocked-down bed flared up again.
    rekindled: usize,
    /// Closest the unit came to the fire while it burned, m.
    closest_while_burning: f64,
    ctl: GroundController,
    world: World,
}

/// Step world and controller together until the fire is out (and 5 s more, for the
/// controller to notice) or the time limit; the unit sees boxes.
fn run(coordinator_task: Option<Point2>) -> Run {
    run_seeing(coordinator_task, Perception::Boxes)
}

fn run_seeing(coordinator_task: Option<Point2>, perception: Perception) -> Run {
    run_in(site(), coordinator_task, perception)
}

fn run_in(
    scenario: Arc<Scenario>,
    coordinator_task: Option<Point2>,
    perception: Perception,
) -> Run {
    let mut world = World::new(&scenario, 11);
    world.set_perception(perception);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario.clone());
    if let Some(target) = coordinator_task {
        ctl.office_changed(true);
        ctl.on_task(
            0,
            1,
            TaskKind::Extinguish {
                fire: FireId(1),
                target,
                from: Approach::Either,
            },
        )
        .unwrap();
    }
    let dt = 0.05;
    let mut closest_while_burning = f64::INFINITY;
    let mut rekindled = 0;
    while world.time() < scenario.time_limit_s {
        let before = world.truth().fires[0].state;
        world.step_unit(&id, dt, |s| ctl.step(s)).unwrap();
        let truth = world.truth();
        if before == TruthFireState::Smouldering && truth.fires[0].state == TruthFireState::Burning
        {
            rekindled += 1;
        }
        if truth.fires[0].state != TruthFireState::Out {
            closest_while_burning = closest_while_burning
                .min(truth.units[0].pose.position().dist(truth.fires[0].position));
            continue;
        }
        let out_at = Some(world.time());
        for _ in 0..100 {
            world.step_unit(&id, dt, |s| ctl.step(s)).unwrap();
        }
        return Run {
            out_at,
            rekindled,
            closest_while_burning,
            ctl,
            world,
        };
    }
    Run {
        out_at: None,
        rekindled,
        closest_while_burning,
        ctl,
        world,
    }
}

#[test]
fn alone_the_unit_cruises_finds_and_puts_out_the_fire() {
    let r = run(None);
    let t = r.out_at.expect("fire never went out");
    assert!(t < 120.0, "took {t} s");
    assert_eq!(
        r.world.truth().units[0].collisions,
        0,
        "touched the parked car or a wall"
    );
    assert!(
        r.closest_while_burning > 4.0,
        "came within {:.1} m of the burning fire",
        r.closest_while_burning
    );
}

/// The same with nothing but its thermal core: the unit finds the flame in the pixels,
/// places it, and puts it out (the vehicle beside it warms in the fire's radiation).
#[test]
fn alone_with_only_a_thermal_camera_the_unit_finds_and_puts_out_the_fire() {
    let r = run_seeing(None, Perception::Pixels);
    let t = r.out_at.expect("fire never went out");
    assert!(t < 120.0, "took {t} s");
    assert_eq!(r.rekindled, 0, "it cooled the fuel bed until it read cool");
    assert_eq!(r.world.truth().units[0].collisions, 0);
    assert!(
        r.closest_while_burning > 4.0,
        "came within {:.1} m of the burning fire",
        r.closest_while_burning
    );
}

/// A wide fire (a lorry's load, 5 m across) leaves a bed a fixed 3 s cooling pass leaves
/// hot: with the bed's reading turned off, this fire was still burning at the scenario's
/// time limit, flaring up behind the unit. Reading the bed in its thermal frames, the unit
/// cools it until it reads cool: out, and never flared up.
#[test]
fn a_wide_fires_bed_is_cooled_until_it_reads_cool_and_never_flares_up() {
    let mut scenario = site();
    Arc::make_mut(&mut scenario).fires[0].radius_m = 2.5;
    let r = run_in(scenario, None, Perception::Pixels);
    r.out_at.expect("fire never went out");
    assert_eq!(r.rekindled, 0);
}

/// The same wide fire with a tank that runs dry on the hot bed: the cooling pass ends
/// as the tank empties, not at its minute's limit with nothing left to spray (500 L: the
/// knock-down takes some 480 L, the pass with a full tank some 45 L more).
#[test]
fn a_cooling_pass_ends_when_the_tank_runs_dry() {
    use firefleet_model::profile::{GROUND, Profile};
    let small = firefleet_model::spec::GroundSpec {
        tank_l: 500.0,
        ..*GROUND
    };
    let scenario = Arc::new(
        Scenario::straight(120.0)
            .name("closed-loop-small-tank")
            .with_profile("small-tank", Profile::Ground(small))
            .fire("fire", 60.0, -2.0, 5000.0)
            .ground("u1", 5.0, -2.5)
            .profile("small-tank")
            .build(),
    );
    let mut scenario = scenario;
    Arc::make_mut(&mut scenario).fires[0].radius_m = 2.5;
    let mut world = World::new(&scenario, 11);
    world.set_perception(Perception::Pixels);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), small, scenario.clone());
    let cool_bed = (0..ctl.tree().len() as u32)
        .find(|&n| ctl.tree().type_name(n) == "CoolBed")
        .expect("the ground tree has a cooling pass");
    let running =
        |ctl: &GroundController| ctl.tree().status(cool_bed) == firefleet_bt::Status::Running;
    let mut dry_while_cooling = None;
    while world.time() < scenario.time_limit_s {
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
        let dry = world.truth().units[0].water_used_l >= small.tank_l - 1e-9;
        if dry && dry_while_cooling.is_none() {
            // The tank's size puts its last litre on the knocked-down bed.
            assert!(
                running(&ctl),
                "the tank ran dry at {:.1} s outside the cooling pass (fire {:?}): size it again",
                world.time(),
                world.truth().fires[0].state
            );
            dry_while_cooling = Some(world.time());
            continue;
        }
        if let Some(at) = dry_while_cooling {
            if !running(&ctl) {
                let took = world.time() - at;
                assert!(took <= 0.2, "the pass ran {took:.2} s on an empty tank");
                return;
            }
            assert!(
                world.time() - at < 5.0,
                "the pass still runs 5 s after the tank ran dry"
            );
        }
    }
    panic!(
        "the tank never ran dry: {} L used",
        world.truth().units[0].water_used_l
    );
}

#[test]
fn with_a_task_the_unit_reports_the_fire_extinguished() {
    let r = run(Some(Point2::new(60.3, -1.8)));
    assert!(r.out_at.is_some(), "fire never went out");
    assert_eq!(r.world.truth().units[0].collisions, 0);
    assert!(
        r.closest_while_burning > 4.0,
        "came within {:.1} m of the burning fire",
        r.closest_while_burning
    );
    let task = r.ctl.state().task.expect("task progress echoed");
    assert_eq!(
        (task.seq, task.fire, task.phase),
        (1, FireId(1), TaskPhase::Extinguished)
    );
}

/// The coordinator's estimate of the fire is 3.5 m off (fused from units that saw it from
/// afar): the unit, seeing the flame itself on the way, plans again to the fire where it
/// is and puts it out.
#[test]
fn sent_to_a_misplaced_fire_the_unit_goes_where_its_own_camera_sees_it() {
    let r = run(Some(Point2::new(56.5, -2.5)));
    assert!(r.out_at.is_some(), "fire never went out");
    assert_eq!(r.world.truth().units[0].collisions, 0);
    let task = r.ctl.state().task.expect("task progress echoed");
    assert_eq!(task.phase, TaskPhase::Extinguished);
}

#[test]
fn a_cruise_task_stages_the_unit_and_a_new_goal_moves_it() {
    let scenario = site();
    let mut world = World::new(&scenario, 3);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario);
    ctl.office_changed(true);
    let drive = |ctl: &mut GroundController, world: &mut World, seconds: f64| {
        let end = world.time() + seconds;
        while world.time() < end {
            world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
        }
        world.truth().units[0].pose.position()
    };
    ctl.on_task(
        0,
        1,
        TaskKind::Cruise {
            goal: Point2::new(25.0, -2.5),
        },
    )
    .unwrap();
    let at = drive(&mut ctl, &mut world, 40.0);
    assert!(
        at.dist(Point2::new(25.0, -2.5)) < 1.0,
        "held at the staging point: {at:?}"
    );
    ctl.on_task(
        0,
        2,
        TaskKind::Cruise {
            goal: Point2::new(15.0, 2.5),
        },
    )
    .unwrap();
    let at = drive(&mut ctl, &mut world, 60.0);
    assert!(
        at.dist(Point2::new(15.0, 2.5)) < 1.0,
        "moved to the new goal: {at:?}"
    );
    assert_eq!(world.truth().units[0].collisions, 0);
}

#[test]
fn a_unit_sent_back_the_way_it_came_turns_round_and_touches_nothing() {
    // Facing the tunnel's end, a van parked 12 m ahead in its lane, sent back towards the
    // portal. (Pure pursuit alone drove such a unit on, away from its goal, into the van,
    // and it wedged itself against the wall: generated tunnel gen-51-1.)
    let scenario = Arc::new(
        Scenario::straight(120.0)
            .name("turn-round")
            .car("van", 62.0, -2.5)
            .ground("u1", 50.0, -2.5)
            .build(),
    );
    let mut world = World::new(&scenario, 7);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario.clone());
    ctl.office_changed(true);
    let goal = Point2::new(10.0, -2.5);
    ctl.on_task(0, 1, TaskKind::Cruise { goal }).unwrap();
    let mut furthest = 50.0_f64;
    while world.time() < 90.0 && world.truth().units[0].pose.position().dist(goal) > 1.0 {
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
        furthest = furthest.max(world.truth().units[0].pose.x);
    }
    let unit = &world.truth().units[0];
    assert!(
        unit.pose.position().dist(goal) <= 1.0,
        "not back at the portal after 90 s: {:?}",
        unit.pose
    );
    assert_eq!(unit.collisions, 0);
    assert!(
        furthest < 58.0,
        "drove on towards the van, to x = {furthest:.1}"
    );
}

#[test]
fn a_staged_unit_assigned_the_fire_puts_it_out() {
    let scenario = site();
    let mut world = World::new(&scenario, 5);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario.clone());
    ctl.office_changed(true);
    ctl.on_task(
        0,
        1,
        TaskKind::Cruise {
            goal: Point2::new(30.0, 2.5),
        },
    )
    .unwrap();
    let mut assigned = false;
    while world.time() < scenario.time_limit_s
        && world.truth().fires[0].state != TruthFireState::Out
    {
        if !assigned && world.time() > 30.0 {
            ctl.on_task(
                0,
                2,
                TaskKind::Extinguish {
                    fire: FireId(1),
                    target: Point2::new(60.0, -2.0),
                    from: Approach::Either,
                },
            )
            .unwrap();
            assigned = true;
        }
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
    }
    assert_eq!(
        world.truth().fires[0].state,
        TruthFireState::Out,
        "the staged unit never put the fire out"
    );
    assert_eq!(world.truth().units[0].collisions, 0);
}

/// A unit sent to a fire behind it in a bore too narrow to turn round in one sweep (a
/// U-turn takes 3.7 m of turning circle plus the body and the planner's clearance, 5.3 m)
/// must back and fill: its route has cusps, the follower drives them, and it still ends
/// facing the flame without touching a wall.
#[test]
fn facing_away_in_a_narrow_bore_the_unit_turns_round_by_backing() {
    let scenario = Arc::new(
        Scenario::from_toml(
            r#"
            name = "narrow-bore"
            time_limit_s = 120
            [tunnel]
            length_m = 60.0
            width_m = 5.0
            height_m = 6.3
            lanes = 1
            [[fires]]
            name = "fire"
            x_m = 12.0
            y_m = 0.0
            growth = "medium"
            peak_kw = 400.0
            ignition_s = -120.0
            [[units]]
            id = "u1"
            kind = "ground"
            x_m = 30.0
            y_m = 0.0
            yaw_rad = 0.0
        "#,
            "narrow-bore.toml",
        )
        .unwrap(),
    );
    let mut world = World::new(&scenario, 3);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario.clone());
    ctl.office_changed(true);
    let flame = scenario.fires[0].position();
    ctl.on_task(
        0,
        1,
        TaskKind::Extinguish {
            fire: FireId(1),
            target: flame,
            from: Approach::Either,
        },
    )
    .unwrap();
    let mut backed_m = 0.0;
    while world.time() < 90.0 {
        let s = world.sensors(&id).unwrap();
        let cmd = ctl.step(&s);
        let state = ctl.state();
        if state.mode == UnitMode::Extinguishing {
            let off = wrap_angle(state.pose.yaw - state.pose.position().bearing_to(flame));
            assert!(off.abs() < 5f64.to_radians(), "{off} rad off the flame");
            assert!(backed_m > 1.0, "turned round backing only {backed_m} m");
            assert_eq!(world.truth().units[0].collisions, 0, "touched a wall");
            return;
        }
        if s.speed < 0.0 {
            backed_m += -s.speed * 0.05;
        }
        world.command(&id, cmd);
        world.step(0.05);
    }
    panic!("never reached a firing position: {:?}", ctl.state());
}

#[test]
fn a_task_numbered_ahead_of_the_clock_is_refused_and_the_coordinator_still_heard() {
    let scenario = site();
    let mut world = World::new(&scenario, 11);
    let id = UnitId::new("u1").unwrap();
    let mut ctl = GroundController::new(id.clone(), *GROUND, scenario);
    ctl.office_changed(true);
    for _ in 0..20 {
        world.step_unit(&id, 0.05, |s| ctl.step(s)).unwrap();
    }
    // One forged task numbered near u64::MAX would leave it deaf to every later real one.
    let forged = TaskKind::Cruise {
        goal: Point2::new(5.0, -2.5),
    };
    let e = ctl.on_task(0, u64::MAX, forged).unwrap_err();
    let TaskRefused::Ahead { ceiling, .. } = e else {
        panic!("{e}")
    };
    assert!((120_000..=121_000).contains(&ceiling), "{e}");
    assert!(e.to_string().contains("ahead of the site clock"), "{e}");
    assert_eq!(ctl.state().task_seq, None);
    let real = TaskKind::Cruise {
        goal: Point2::new(25.0, -2.5),
    };
    ctl.on_task(0, 1_001, real).unwrap();
    assert_eq!(ctl.state().task_seq, Some(1_001));

    // A coordinator taking office outranks the first at once, whatever its numbers; the
    // deposed one then commands the unit no more, however high it numbers.
    let new_term = TaskKind::Cruise {
        goal: Point2::new(30.0, -2.5),
    };
    ctl.on_task(1_009, 1_009, new_term).unwrap();
    assert_eq!(ctl.state().epoch, Some(1_009));
    let e = ctl.on_task(0, 1_500, real).unwrap_err();
    assert_eq!(
        e,
        TaskRefused::Fenced {
            seq: 1_500,
            epoch: 0,
            obeyed: 1_009
        }
    );
    assert_eq!(ctl.state().task_seq, Some(1_009));
}
