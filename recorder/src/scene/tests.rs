use std::path::Path;

use base64::Engine;
use firefleet_protocol::msg::{GoalInForce, ZoneGoal};
use firefleet_protocol::testing::ground_state;

use super::*;

fn rail_tunnel() -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../model/scenarios/rail-tunnel.toml");
    Scenario::load(&path).unwrap()
}

fn unit(id: &str) -> UnitId {
    UnitId::new(id).unwrap()
}

fn burning(id: u32, x: f64, hrr_kw: Option<f64>, state: FireState) -> FireTrack {
    FireTrack {
        id: FireId(id),
        t: 1.0,
        position: Point2::new(x, 1.0),
        cov: [0.25, 0.0, 0.25],
        confidence: 0.9,
        state,
        assigned: vec![unit("ugv-1")],
        seen_by: vec![unit("ugv-1")],
        hrr_kw,
    }
}

fn drawn<'a>(u: &'a SceneUpdate, id: &str) -> &'a SceneEntity {
    u.entities
        .iter()
        .find(|e| e.id == id)
        .unwrap_or_else(|| panic!("no entity {id}"))
}

#[test]
fn units_are_drawn_where_they_say_they_are_the_monorail_under_its_rail() {
    let s = rail_tunnel();
    let mut fleet = Fleet::default();
    fleet.observe(&Payload::UnitState(ground_state("ugv-1", 30.0, -1.75)));
    let mut carriage = ground_state("rail-1", 60.0, 0.0);
    carriage.kind = UnitKind::Monorail;
    fleet.observe(&Payload::UnitState(carriage));
    let scene = fleet_scene(&s, &fleet, Time::from_nanos(0));

    let ugv = &drawn(&scene, "unit/ugv-1").cubes[0];
    assert_eq!((ugv.pose.position.x, ugv.pose.position.y), (30.0, -1.75));
    assert!(ugv.pose.position.z - ugv.size.z / 2.0 >= 0.0, "on the road");
    let rail = s.rails.iter().find(|r| r.id == "rail-1").unwrap();
    let carriage = &drawn(&scene, "unit/rail-1").cubes[0];
    assert_eq!(carriage.pose.position.x, 60.0);
    let top = carriage.pose.position.z + carriage.size.z / 2.0;
    assert!(
        top <= rail.height_m && top > rail.height_m - 0.5,
        "hangs under the rail: top {top}"
    );
    // Units the fleet has not heard from are not drawn: the scene is what it knows.
    assert!(!scene.entities.iter().any(|e| e.id == "unit/ugv-2"));
}

#[test]
fn a_unit_whose_token_vanished_stays_where_it_was_last_heard_marked_lost() {
    let s = rail_tunnel();
    let mut fleet = Fleet::default();
    fleet.observe(&Payload::UnitState(ground_state("ugv-1", 30.0, -1.75)));
    fleet.take_changes();
    fleet.token(unit("ugv-1"), false);
    assert_eq!(fleet.take_changes(), (true, false));
    let scene = fleet_scene(&s, &fleet, Time::from_nanos(0));
    let e = drawn(&scene, "unit/ugv-1");
    assert!(e.texts[0].text.ends_with("LOST"), "{}", e.texts[0].text);
    assert!(e.cubes[0].color.a < 1.0);
    // An older state arriving late does not move it back.
    let mut old = ground_state("ugv-1", 10.0, -1.75);
    old.t = -1.0;
    fleet.observe(&Payload::UnitState(old));
    assert_eq!(fleet.take_changes(), (false, false));
}

#[test]
fn a_keep_out_zone_is_unmistakable_and_says_who_barred_it() {
    let s = rail_tunnel();
    let mut fleet = Fleet::default();
    let before = fleet_scene(&s, &fleet, Time::from_nanos(0));
    let goal = ZoneGoal {
        id: "g1".into(),
        zone: "deep".parse().unwrap(),
        goal: GoalKind::KeepOut,
        priority: 0,
        before_m: None,
        expires_s: None,
        issued_by: Some(firefleet_model::CommanderId::new("chief").unwrap()),
        rail_allowed: false,
    };
    fleet.observe(&Payload::Goals(GoalsInForce {
        t: 1.0,
        goals: vec![GoalInForce {
            goal,
            since: 1.0,
            until: None,
            proof: None,
        }],
        ..Default::default()
    }));
    assert_eq!(fleet.take_changes(), (true, false));
    let after = fleet_scene(&s, &fleet, Time::from_nanos(0));
    let deep = drawn(&after, "zone/deep");
    assert_eq!(deep.texts[0].text, "zone deep: keep-out (by chief)");
    let red = deep.cubes[0].color;
    assert!(red.r > 0.8 && red.g < 0.1 && red.a >= 0.5, "{red:?}");
    // Only keep-out is that red, and the zone without a goal is not.
    for kind in [
        None,
        Some(GoalKind::Extinguish),
        Some(GoalKind::Contain),
        Some(GoalKind::Monitor),
        Some(GoalKind::Evacuate),
    ] {
        let c = zone_color(kind);
        assert!(!(c.r > 0.8 && c.g < 0.1 && c.a >= 0.5), "{kind:?}");
    }
    assert_eq!(drawn(&before, "zone/deep").texts[0].text, "zone deep");
    assert_eq!(drawn(&after, "zone/portal").texts[0].text, "zone portal");
}

#[test]
fn fires_are_sized_by_their_heat_and_the_grid_is_hottest_at_a_burning_one() {
    let s = rail_tunnel();
    let mut fleet = Fleet::default();
    fleet.observe(&Payload::Fire(burning(
        1,
        50.0,
        Some(1000.0),
        FireState::Suppressing,
    )));
    fleet.observe(&Payload::Fire(burning(
        2,
        190.0,
        Some(3000.0),
        FireState::Confirmed,
    )));
    assert_eq!(fleet.take_changes(), (true, true));
    let scene = fleet_scene(&s, &fleet, Time::from_nanos(0));
    let (small, large) = (
        &drawn(&scene, "fire/f1").cylinders[0],
        &drawn(&scene, "fire/f2").cylinders[0],
    );
    assert!(large.size.z > small.size.z);
    assert!(
        drawn(&scene, "fire/f1").texts[0]
            .text
            .starts_with("f1 suppressing 1.0 MW <- ugv-1")
    );

    let grid = heat_grid(&s, &fleet, Time::from_nanos(0));
    let bytes = BASE64.decode(&grid.data).unwrap();
    let cells: Vec<f32> = bytes
        .chunks(4)
        .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
        .collect();
    let columns = grid.column_count as usize;
    assert_eq!(cells.len() % columns, 0);
    assert_eq!(grid.row_stride as usize, columns * 4);
    let (hottest, _) = cells
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .unwrap();
    let x = grid.pose.position.x + ((hottest % columns) as f64 + 0.5) * grid.cell_size.x;
    let y = grid.pose.position.y + ((hottest / columns) as f64 + 0.5) * grid.cell_size.y;
    // The model is flat within a metre of a source (and capped at 100 kW/m^2).
    assert!(
        Point2::new(x, y).dist(Point2::new(190.0, 1.0)) <= 1.0 + grid.cell_size.x,
        "hottest at ({x}, {y})"
    );

    // Out: no heat, drawn flat.
    fleet.observe(&Payload::Fire(FireTrack {
        t: 2.0,
        ..burning(2, 190.0, Some(30_000.0), FireState::Out)
    }));
    fleet.observe(&Payload::Fire(FireTrack {
        t: 2.0,
        ..burning(1, 50.0, Some(3000.0), FireState::Out)
    }));
    let grid = heat_grid(&s, &fleet, Time::from_nanos(0));
    assert!(BASE64.decode(&grid.data).unwrap().iter().all(|&b| b == 0));
    let scene = fleet_scene(&s, &fleet, Time::from_nanos(0));
    assert!(drawn(&scene, "fire/f2").cylinders[0].size.z < 0.1);
}
