//! The parent module's tests.

use super::*;
use firefleet_model::Validate;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Growth;
use firefleet_model::testing::ScenarioBuilder;

/// A 100 m tunnel with a car, a 3 MW fire just short of it, and unit u1.
fn site() -> ScenarioBuilder {
    Scenario::straight(100.0)
        .name("w")
        .section(10.0, 6.0)
        .time_limit(200.0)
        .obstacle("car", (20.0, -2.5), [4.0, 1.8, 1.5])
        .fire("f", 15.0, 0.0, 3000.0)
        .ignition(-100.0)
        .ground("u1", 5.0, -2.5)
}

fn world() -> World {
    World::new(&site().build(), 1)
}

fn u1() -> UnitId {
    UnitId::new("u1").unwrap()
}

/// Unit u1 stands still and sprays at `pan`, `tilt`.
fn spray(w: &mut World, pan: f64, tilt: f64) {
    w.command(
        &u1(),
        UnitCommand {
            speed: 0.0,
            steer: 0.0,
            pan,
            tilt,
            valve_open: true,
        },
    );
}

#[test]
fn fire_grows_as_t_squared_to_its_peak() {
    let mut w = world();
    // Burning for 100 s at the fast rate: 0.0469 * 100^2 = 469 kW.
    assert!((w.truth().fires[0].hrr_kw - 469.0).abs() < 1.0);
    // 253 s after ignition it would pass 3000 kW; it stays capped there.
    for _ in 0..4000 {
        w.step(0.05);
    }
    assert_eq!(w.truth().fires[0].hrr_kw, 3000.0);
}

/// Knock the fire down, then either keep the water on for `soak_s` or walk away.
fn knock_down_then(soak_s: f64) -> World {
    let mut w = world();
    let d = 10.0f64.hypot(2.5);
    let v = GROUND.nozzle.exit_speed_m_s(d);
    let (g, h) = (physics::G, 1.2);
    let tilt = ((v * v - (v.powi(4) - g * (g * d * d - 2.0 * h * v * v)).sqrt()) / (g * d)).atan();
    let mut cmd = UnitCommand {
        speed: 0.0,
        steer: 0.0,
        pan: (2.5f64).atan2(10.0),
        tilt,
        valve_open: true,
    };
    w.command(&u1(), cmd);
    while w.truth().fires[0].state == TruthFireState::Burning {
        w.step(0.05);
    }
    assert_eq!(w.truth().fires[0].state, TruthFireState::Smouldering);
    for _ in 0..(soak_s / 0.05) as usize {
        w.step(0.05);
    }
    cmd.valve_open = false;
    w.command(&u1(), cmd);
    for _ in 0..300 {
        w.step(0.05);
    }
    w
}

#[test]
fn a_knocked_down_fire_reignites_unless_it_is_cooled() {
    assert_eq!(
        knock_down_then(0.0).truth().fires[0].state,
        TruthFireState::Burning,
        "abandoned at knock-down"
    );
    // 5 L/m^2 over the 3.14 m^2 bed at about 10 L/s: under 2 s of cooling.
    assert_eq!(
        knock_down_then(3.0).truth().fires[0].state,
        TruthFireState::Out
    );
}

#[test]
fn driving_into_a_vehicle_stops_the_unit_until_it_is_told_to_drive_again() {
    let mut w = world();
    let ahead = UnitCommand {
        speed: 1.5,
        steer: 0.0,
        pan: 0.0,
        tilt: 0.0,
        valve_open: false,
    };
    w.command(&u1(), ahead);
    for _ in 0..400 {
        w.step(0.05);
    }
    let t = w.truth();
    assert_eq!(
        t.units[0].collisions, 1,
        "the bumper stop holds the body: one refused step, not one a step"
    );
    assert!(
        t.units[0].pose.x < 20.0 - 2.0 - 0.8 + 0.1,
        "stopped before the car: {}",
        t.units[0].pose.x
    );
    w.command(&u1(), ahead);
    for _ in 0..10 {
        w.step(0.05);
    }
    assert_eq!(
        w.truth().units[0].collisions,
        2,
        "a new set-point drives again"
    );
}

#[test]
fn units_driving_into_each_other_stop_touching_and_see_each_other_coming() {
    let site = Scenario::straight(100.0)
        .name("w")
        .section(10.0, 6.0)
        .ground("u1", 30.0, 0.0)
        .ground("u2", 40.0, 0.0)
        .ground("u3", 70.0, 0.0)
        .build();
    let mut w = World::new(&site, 1);
    let drive = |speed| UnitCommand {
        speed,
        steer: 0.0,
        pan: 0.0,
        tilt: 0.0,
        valve_open: false,
    };
    let (u1, u2) = (UnitId::new("u1").unwrap(), UnitId::new("u2").unwrap());
    let seen = w.sensors(&u1).unwrap().nearby;
    assert_eq!(seen.len(), 1, "u2 within range, u3 beyond it: {seen:?}");
    assert_eq!(seen[0].pose.x, 40.0);
    w.command(&u1, drive(1.5));
    w.command(&u2, drive(-0.6));
    for _ in 0..400 {
        w.step(0.05);
        let t = w.truth();
        let gap = t.units[1].pose.x - t.units[0].pose.x;
        assert!(gap >= GROUND.length_m, "the bodies overlap: {gap} m apart");
    }
    let t = w.truth();
    assert!(t.units[0].collisions > 0 && t.units[1].collisions > 0);
    assert!(
        t.units[1].pose.x - t.units[0].pose.x < GROUND.length_m + 0.1,
        "touching"
    );
    assert_eq!(t.units[2].collisions, 0);
}

#[test]
fn water_on_the_fire_puts_it_out_and_water_beside_it_does_not() {
    let aim = |w: &mut World, pan: f64| {
        // Unit at x=5 faces +x; the fire is 10 m ahead and 2.5 m left. Low-arc elevation
        // for that shot from 1.2 m at the nozzle's equation-9 speed for its reach.
        let d = 10.0f64.hypot(2.5);
        let v = GROUND.nozzle.exit_speed_m_s(d);
        let (g, h) = (physics::G, 1.2);
        let tilt =
            ((v * v - (v.powi(4) - g * (g * d * d - 2.0 * h * v * v)).sqrt()) / (g * d)).atan();
        spray(w, pan, tilt);
    };
    let mut off = world();
    aim(&mut off, 0.6);
    let mut on = world();
    aim(&mut on, (2.5f64).atan2(10.0));
    for _ in 0..400 {
        off.step(0.05);
        on.step(0.05);
    }
    assert_eq!(on.truth().fires[0].state, TruthFireState::Out);
    assert_eq!(off.truth().fires[0].state, TruthFireState::Burning);
    assert!(on.truth().units[0].water_used_l > 0.0);
}

#[test]
fn same_seed_same_world() {
    let run = |seed| {
        let mut w = World::new(&site().build(), seed);
        w.command(
            &u1(),
            UnitCommand {
                speed: 1.0,
                steer: 0.1,
                pan: 0.0,
                tilt: 0.0,
                valve_open: false,
            },
        );
        (0..100)
            .map(|_| {
                w.step(0.05);
                w.sensors(&u1()).unwrap()
            })
            .collect::<Vec<_>>()
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}

#[test]
fn a_monorail_monitor_puts_out_a_fire_under_its_rail() {
    let site = site()
        .rail("r", 0.0, 100.0, &[20.0])
        .rail_height(5.5)
        .monorail("m", "r", 5.0)
        .build();
    let mut w = World::new(&site, 1);
    let m = UnitId::new("m").unwrap();
    let s = w.rail_sensors(&m).unwrap();
    assert!(s.fire_detected && s.water_connected);
    assert!((s.hot_spots[0].position.x - 15.0).abs() < 1.0);
    assert!(s.temperature_c > physics::AMBIENT_C);
    // The nozzle speed whose jet lands nearest the fire 10 m ahead, monitor at -15 deg.
    let c = w.carriages[0].clone();
    let (nozzle, azimuth, elevation) = c.nozzle();
    let v0 = (26..=266)
        .map(|k| k as f64 / 10.0)
        .min_by_key(|v| {
            match jet::trace_at_speed(&w.tunnel, &w.obstacles, nozzle, azimuth, elevation, *v) {
                Landing::Road { at, .. } => (at.dist(Point2::new(15.0, 0.0)) * 1e3) as i64,
                Landing::Blocked | Landing::Vehicle { .. } => i64::MAX,
            }
        })
        .unwrap();
    let mut joints = c.joints;
    joints.v0 = v0;
    w.command_rail(
        &m,
        RailCommand {
            joints,
            valve_open: true,
        },
    );
    for _ in 0..600 {
        w.step(0.05);
    }
    assert_eq!(w.truth().fires[0].state, TruthFireState::Out);
    let carriage = w.truth().units.into_iter().find(|u| u.id == m).unwrap();
    assert!(carriage.water_used_l > 0.0);
}

/// A 5 MW car fire in one lane, a car in the next lane 0.7 m away, and unit u1.
fn car_beside_a_fire() -> Scenario {
    Scenario::straight(100.0)
        .name("spread")
        .section(10.0, 6.0)
        .time_limit(900.0)
        .car("burning", 50.0, -1.25)
        .car("exposed", 50.0, 1.25)
        .fire("car", 50.0, -1.25, 5000.0)
        .growth(Growth::Ultrafast)
        .ignition(-300.0)
        .ground("u1", 30.0, 3.0)
        .build()
}

/// [`car_beside_a_fire`] after 400 s; `hose` puts a jet on the exposed car while the unit's
/// water lasts.
fn neighbours(hose: bool) -> World {
    let mut w = World::new(&car_beside_a_fire(), 1);
    if hose {
        // A jet into the exposed car's rear, 18 m away: the lowest elevation that hits it.
        let pan = (1.25f64 - 3.0).atan2(18.0);
        let nozzle = [30.0, 3.0, GROUND.cannon_height_m];
        let tilt = (0..60)
            .map(|k| k as f64 * 0.01)
            .find(|th| {
                jet::trace(&w.tunnel, &w.obstacles, nozzle, pan, *th, &GROUND.nozzle)
                    == Landing::Vehicle { index: 1 }
            })
            .expect("some elevation hits the exposed car");
        spray(&mut w, pan, tilt);
    }
    // 400 s: the unit's tank (150 s of water) is empty well before the end.
    for _ in 0..(400.0 / 0.05) as usize {
        w.step(0.05);
    }
    w
}

#[test]
fn fire_spreads_to_an_exposed_vehicle_and_water_on_it_holds_it_back() {
    let spread = neighbours(false).truth();
    assert_eq!(spread.fires.len(), 2, "{:?}", spread.fires);
    assert_eq!(spread.fires[1].name, "exposed-spread");
    assert_ne!(spread.fires[1].state, TruthFireState::Dormant);
    // It burns on the side facing the first car, off the exposed car's body, where a camera
    // in the gap between the two can see it.
    let w = neighbours(false);
    let at = spread.fires[1].position;
    assert!(!w.obstacles[1].footprint_contains(at, 0.0), "{at:?}");
    assert!(
        at.y < w.obstacles[1].y_m && at.y > w.obstacles[0].y_m,
        "{at:?}"
    );
    let eye = [at.x + 6.0, at.y, 1.0];
    assert!(!camera::line_blocked(
        &w.tunnel,
        &w.obstacles,
        eye,
        [at.x, at.y, 0.5]
    ));
    let cooled = neighbours(true).truth();
    assert_eq!(cooled.fires.len(), 1, "{:?}", cooled.fires);
}

#[test]
fn heat_flux_rises_near_the_fire() {
    let mut w = world();
    w.step(0.05);
    let far = w.sensors(&u1()).unwrap().heat_flux_kw_m2;
    assert!(far > 0.0 && far < 1.0, "{far}");
}

/// Two units 15 m either side of a 3 MW fire (at 470 kW, growing), facing it, with the air moving east at
/// `air_m_s`: (the west unit's, the east unit's) mean detection confidence over 200 frames,
/// and the heat flux each takes.
fn either_side(air_m_s: f64) -> ((f64, f64), (f64, f64)) {
    let mut s = Scenario::straight(100.0)
        .fire("f", 50.0, 0.0, 3000.0)
        .ignition(-100.0)
        .ground("west", 35.0, 0.0)
        .ground("east", 65.0, 0.0)
        .build();
    s.units[1].yaw_rad = std::f64::consts::PI;
    s.ventilation = Some(firefleet_model::infra::Ventilation {
        air_m_s,
        fans: Vec::new(),
    });
    let mut w = World::new(&s, 1);
    w.step(0.05);
    let mut seen = |id: &str| {
        let id = UnitId::new(id).unwrap();
        let c: Vec<f64> = (0..200)
            .flat_map(|_| w.sensors(&id).unwrap().detections)
            .map(|d| d.confidence)
            .collect();
        let flux = w.sensors(&id).unwrap().heat_flux_kw_m2;
        (c.iter().sum::<f64>() / c.len().max(1) as f64, flux)
    };
    (seen("west"), seen("east"))
}

#[test]
fn moving_air_carries_heat_and_smoke_downstream_only() {
    let ((west_c, west_q), (east_c, east_q)) = either_side(0.0);
    assert!(
        (west_c - east_c).abs() < 0.05,
        "still air: {west_c} {east_c}"
    );
    assert!(
        (west_q - east_q).abs() < 1e-9,
        "still air: {west_q} {east_q}"
    );
    let ((up_c, up_q), (down_c, down_q)) = either_side(2.0);
    // Upstream as in still air; downstream dimmer (exp(-0.05 x 15) = 0.47) and hotter.
    assert!((up_c - west_c).abs() < 0.05 && (up_q - west_q).abs() < 1e-9);
    assert!(down_c < 0.6 * up_c, "downstream {down_c}, upstream {up_c}");
    assert!(
        down_q > 5.0 * up_q,
        "downstream {down_q} kW/m2, upstream {up_q}"
    );
}

/// A world carried on from a snapshot (through its bytes, as a restarted simulator reads
/// it) is the world that would have run on: the same fires, spread ones included, units,
/// heat and sensor noise, step for step.
#[test]
fn a_world_resumed_from_its_snapshot_runs_on_as_it_would_have() {
    // Commands are not kept (a unit's computer sends them again): each world gets its own.
    let drive = UnitCommand {
        speed: 0.5,
        steer: 0.05,
        pan: 0.2,
        tilt: 0.1,
        valve_open: false,
    };
    let mut w = neighbours(false);
    w.command(&u1(), drive);
    let bytes = postcard::to_stdvec(&w.snapshot()).unwrap();
    let mut resumed = World::new(&car_beside_a_fire(), 99);
    resumed
        .resume(postcard::from_bytes(&bytes).unwrap())
        .unwrap();
    assert_eq!(resumed.time(), w.time());
    assert_eq!(resumed.truth(), w.truth(), "the spread fire is back too");
    resumed.command(&u1(), drive);
    for _ in 0..100 {
        w.step(0.05);
        resumed.step(0.05);
        assert_eq!(resumed.sensors(&u1()), w.sensors(&u1()));
    }
    assert_eq!(resumed.truth(), w.truth());
}

#[test]
fn a_snapshot_of_another_world_or_of_a_rehearsal_that_is_over_is_not_taken_back() {
    let mut w = world();
    for _ in 0..40 {
        w.step(0.05);
    }
    let snap = w.snapshot();
    let other = site().fire("g", 60.0, 0.0, 2000.0).build();
    let mut fresh = World::new(&other, 1);
    let e = fresh.resume(snap.clone()).unwrap_err();
    assert!(e.to_string().contains("fire 1: 'g' against 'none'"), "{e}");
    assert_eq!(fresh.time(), 0.0, "left as it was");
    let moved = site().obstacle("van", (70.0, 2.5), [5.0, 2.0, 2.2]).build();
    assert!(matches!(
        World::new(&moved, 1).resume(snap.clone()),
        Err(Mismatch::Obstacles { now: 2, then: 1 })
    ));
    let short = site().time_limit(1.0).build();
    assert!(matches!(
        World::new(&short, 1).resume(snap),
        Err(Mismatch::Over { .. })
    ));
}

/// A unit the site file added since the snapshot starts where the file says; the others
/// are where they stood.
#[test]
fn a_unit_added_to_the_site_file_starts_where_the_file_says() {
    let mut w = world();
    w.command(
        &u1(),
        UnitCommand {
            speed: 1.0,
            steer: 0.0,
            pan: 0.0,
            tilt: 0.0,
            valve_open: false,
        },
    );
    for _ in 0..40 {
        w.step(0.05);
    }
    let added = site().ground("u2", 8.0, 2.5).build();
    let mut resumed = World::new(&added, 1);
    resumed.resume(w.snapshot()).unwrap();
    let truth = resumed.truth();
    let at = |id: &str| truth.units.iter().find(|u| u.id == *id).unwrap().pose;
    assert_eq!(at("u1"), w.truth().units[0].pose);
    assert_eq!((at("u2").x, at("u2").y), (8.0, 2.5));
}

#[test]
fn with_pixels_a_unit_gets_thermal_frames_at_the_cores_rate_showing_the_fire_and_no_boxes() {
    let mut w = world();
    w.set_perception(Perception::Pixels);
    let (mut frames, mut boxes) = (Vec::new(), 0);
    for _ in 0..100 {
        let s = w.sensors(&u1()).unwrap();
        boxes += s.detections.len();
        if let Some(image) = s.thermal {
            image.validate().unwrap();
            frames.push(image);
        }
        w.step(0.05);
    }
    assert_eq!(boxes, 0);
    // 5 s at 8.7 Hz: a frame at every first step past each period.
    assert!((40..=44).contains(&frames.len()), "{} frames", frames.len());
    let saturated = frames[0]
        .centikelvin
        .iter()
        .filter(|k| **k == u16::MAX)
        .count();
    assert!(
        saturated > 20,
        "the 3 MW fire 10 m ahead: {saturated} saturated pixels"
    );
}
