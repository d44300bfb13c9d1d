//! Staging free units short of fires.

use super::*;

#[test]
fn free_units_are_staged_short_of_the_fire_and_released_when_it_is_out() {
    let mut i = incident();
    let out = corroborated(&mut i, &report("a", 60.0), &["b"], 1.0);
    assert_eq!(
        kinds_for(&out, "a"),
        [TaskKind::Cruise {
            goal: Point2::new(35.0, -2.5)
        }],
        "25 m short, in a's lane"
    );
    assert!(
        all_tasks(&i.tick(2.0)).is_empty(),
        "no churn while nothing changes"
    );
    let (_, out) = b_puts_out_the_first_fire(&mut i, &out);
    assert_eq!(kinds_for(&out, "a"), [TaskKind::Standby]);
}

/// Zones are chainage ranges: in a bend the site frame's x is not the chainage. A monitor
/// goal over the far end leaves its fire burning there; staging once looked the zone up by
/// the fire's x (100 m, outside the zone) and held reserves 25 m short of a fire nobody may
/// attack.
#[test]
fn in_a_bend_staging_finds_a_fire_s_zone_by_its_chainage() {
    use firefleet_model::scenario::Segment;
    use firefleet_protocol::msg::FlameObservation;
    let tunnel = Tunnel {
        centerline: vec![
            Segment::Straight { length_m: 60.0 },
            Segment::Arc {
                radius_m: 40.0,
                angle_rad: std::f64::consts::FRAC_PI_2,
            },
            Segment::Straight {
                length_m: 140.0 - 20.0 * std::f64::consts::PI,
            },
        ],
        ..Tunnel::straight(200.0, 10.0, 6.0, 2)
    };
    let at = |s: f64, d: f64| tunnel.point_at(Chainage::new(s), d);
    let fire = at(150.0, 1.0);
    assert!(
        (fire.x - 99.0).abs() < 1e-6,
        "x is not the chainage: {fire:?}"
    );
    let ground = Mobility::Ground(GroundBody::of(&GROUND));
    let mut i = Incident::new(
        tunnel.clone(),
        [(u("a"), ground.clone()), (u("b"), ground)],
        5.0,
        Strategy::Optimal,
    );
    i.coverage.look(Chainage::ZERO, tunnel.end(), 0.0);
    i.goals = Goals::new(&[zone("end", 140.0, 180.0)], &[]);
    let (ack, _) = submit(&mut i, goal("g1", "end", GoalKind::Monitor, 0, None), 0.0);
    assert!(ack.accepted, "{ack:?}");
    for (n, s) in [("a", 90.0), ("b", 20.0)] {
        let mut st = state(n, 0.0, None);
        let p = at(s, -2.5);
        st.pose = Pose2::new(p.x, p.y, tunnel.heading_at(Chainage::new(s)));
        i.on_alive(&u(n), true, 0.0).unwrap();
        i.state_at(st, 0.0).unwrap();
    }
    let observer = at(130.0, -2.5);
    let r = FlameReport {
        unit: u("a"),
        t: 1.0,
        observer: Pose2::new(
            observer.x,
            observer.y,
            tunnel.heading_at(Chainage::new(130.0)),
        ),
        observations: vec![FlameObservation {
            position: fire,
            cov: [0.2, 0.0, 0.2],
            confidence: 0.9,
            hrr_kw: None,
        }],
    };
    let mut out = i.report_at(&r, 1.0).unwrap();
    out.extend(i.tick(3.5));
    for unit in ["a", "b"] {
        let kinds = kinds_for(&out, unit);
        assert!(
            !kinds
                .iter()
                .any(|k| matches!(k, TaskKind::Cruise { .. } | TaskKind::Extinguish { .. })),
            "{unit} is neither staged for nor sent to a fire under a monitor goal: {kinds:?}"
        );
    }
    assert!(
        kinds_for(&out, "a")
            .iter()
            .any(|k| matches!(k, TaskKind::Search { .. })),
        "a searches on past the fire left burning"
    );
}
