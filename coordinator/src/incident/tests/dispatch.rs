//! Assignment, backups and relief.

use super::*;

#[test]
fn a_fire_whose_heat_release_needs_two_cannons_gets_two_units() {
    for (hrr_kw, attackers) in [(Some(4_000.0), 1), (Some(20_000.0), 2), (None, 1)] {
        let mut i = incident();
        let mut r = report("a", 60.0);
        r.observations[0].hrr_kw = hrr_kw;
        let mut out = corroborated(&mut i, &r, &["b"], 1.0);
        out.extend(i.tick(1.2));
        assert_eq!(tasks(&out).len(), attackers, "{hrr_kw:?} kW");
        let fire = i.fusion.fires()[0].id;
        assert_eq!(i.track(fire, 1.2).hrr_kw, hrr_kw);
    }
}

#[test]
fn a_confirmed_fire_goes_to_the_nearest_free_unit() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let t = tasks(&out);
    assert_eq!(t.len(), 1);
    assert_eq!(t[0].unit.as_str(), "b");
    assert!(matches!(t[0].kind, TaskKind::Extinguish { .. }));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Assign { unit, fire: F1, backup: false, runner_up: Some((r, _)), .. }
            if unit == "b" && r == "a"
    )));
}

#[test]
fn the_nearer_unit_behind_a_truck_across_the_road_is_not_sent() {
    // a is 15 m from the fire but a jack-knifed truck closes the tunnel between them;
    // b is 40 m away on the open side.
    let scenario = Scenario::straight(200.0)
        .section(10.0, 6.0)
        .obstacle("truck", (52.0, 0.0), [3.0, 10.0, 3.0])
        .ground("a", 45.0, -2.0)
        .ground("b", 100.0, -2.0)
        .build();
    let mut i = Incident::from_scenario(&scenario, 5.0, Strategy::Optimal).unwrap();
    i.set_units_per_fire(1);
    for (n, x) in [("a", 45.0), ("b", 100.0)] {
        i.on_alive(&u(n), true, 0.0).unwrap();
        i.state_at(state(n, x, None), 0.0).unwrap();
    }
    let out = i.report_at(&report("b", 60.0), 1.0).unwrap();
    let sent: Vec<&str> = tasks(&out).iter().map(|t| t.unit.as_str()).collect();
    assert_eq!(sent, ["b"], "{out:?}");
}

#[test]
fn no_backup_or_reserve_is_sent_from_more_than_a_minute_away() {
    let mut i = incident_with_backups();
    // b drives to 150 m: 90 m from a fire at 60 m is a minute at 1.5 m/s, and more.
    i.state_at(state("b", 155.0, None), 0.5).unwrap();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    assert_eq!(tasks(&out).len(), 1, "{out:?}");
    assert_eq!(tasks(&out)[0].unit.as_str(), "a");
    assert!(kinds_for(&out, "b").is_empty(), "{out:?}");
}

#[test]
fn a_second_free_unit_backs_up_and_leaves_for_a_fire_nobody_attacks() {
    let mut i = incident_with_backups();
    let out = corroborated(&mut i, &report("a", 60.0), &["b"], 1.0);
    let t = tasks(&out);
    assert_eq!(t.len(), 2, "{out:?}");
    assert_eq!((t[0].unit.as_str(), t[1].unit.as_str()), ("b", "a"));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Assign { unit, fire: F1, backup: true, .. } if unit == "a"
    )));
    // A new fire, nobody on it: the backup (still on its way) takes it.
    let out = i.report_at(&report("b", 150.0), 2.0).unwrap();
    let t = tasks(&out);
    assert_eq!(t.len(), 1, "{out:?}");
    assert_eq!(t[0].unit.as_str(), "a");
    assert!(matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 100.0));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Leaves { unit, from: F1, was_backup: true, .. } if unit == "a"
    )));
}

/// Unit b at `x`, out of order.
fn broken(x: f64) -> UnitState {
    UnitState {
        mode: UnitMode::Fault,
        ..state("b", x, None)
    }
}

#[test]
fn a_unit_come_free_near_a_fire_takes_it_over_from_one_far_away() {
    let mut i = incident();
    i.state_at(broken(140.0), 0.5).unwrap();
    let out = i.report_at(&report("a", 150.0), 1.0).unwrap();
    assert_eq!(tasks(&out)[0].unit.as_str(), "a", "{out:?}");
    // b is repaired 10 m from the fire: a, 90 s away, is released.
    let out = i.state_at(state("b", 140.0, None), 2.0).unwrap();
    assert_eq!(tasks(&out).len(), 1, "{out:?}");
    assert_eq!(tasks(&out)[0].unit.as_str(), "b");
    assert_eq!(kinds_for(&out, "a"), vec![TaskKind::Standby]);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Relieved { unit, fire: F1, by, as_backup: false, .. } if unit == "a" && by == "b"
    )));
    assert!(all_tasks(&i.solve(3.0)).is_empty(), "settled");
}

#[test]
fn a_unit_on_its_way_keeps_its_fire_against_a_marginal_gain_and_stays_as_backup_otherwise() {
    let mut i = incident_with_backups();
    i.state_at(broken(100.0), 0.5).unwrap();
    i.state_at(state("a", 40.0, None), 0.5).unwrap();
    corroborated(&mut i, &report("a", 80.0), &["b"], 1.0);
    // b 10 s nearer (15 m against 40 m): not worth a change; b backs a up.
    i.state_at(state("b", 95.0, None), 2.0).unwrap();
    assert!(!i.units[&u("a")].backup);
    assert!(i.units[&u("b")].backup);
    // b next to the fire, 25 s sooner: b takes it over without a new task, and a
    // (27 s away) stays on as its backup.
    i.state_at(state("b", 82.0, None), 4.0).unwrap();
    let out = i.tick(4.0);
    assert!(all_tasks(&out).is_empty(), "{out:?}");
    assert!(i.units[&u("a")].backup && !i.units[&u("b")].backup);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::BackupTakesOver { unit, fire: F1 } if unit == "b"
    )));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Relieved { unit, fire: F1, as_backup: true, .. } if unit == "a"
    )));
}

#[test]
fn a_spraying_backup_stays_on_its_fire_and_the_unit_still_on_its_way_takes_a_new_one() {
    let mut i = incident_with_backups();
    let out = corroborated(&mut i, &report("a", 60.0), &["b"], 1.0);
    let backup = tasks(&out)[1].clone();
    let TaskKind::Extinguish { fire, target, .. } = backup.kind else {
        panic!()
    };
    let spraying = TaskProgress {
        seq: backup.seq,
        fire,
        phase: TaskPhase::Spraying,
        target,
    };
    i.state_at(state("a", 50.0, Some(spraying)), 1.5).unwrap();
    let out = i.report_at(&report("b", 150.0), 2.0).unwrap();
    assert!(kinds_for(&out, "a").is_empty(), "{out:?}");
    let t = tasks(&out);
    assert_eq!(t.len(), 1, "{out:?}");
    assert_eq!(t[0].unit.as_str(), "b");
    assert!(matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 100.0));
}

/// Each unit is dispatched as its own profile says: `heavy-ugv` (2.5 m wide, 30 L/s) and
/// `luf60` (1.0 m, 10 L/s) in one site.
mod profiles {
    use super::*;
    use crate::assign::{Place, Road};

    /// A heavy unit at `heavy_x` and a light one at `light_x` on the near lane, both heard
    /// at t = 0, in the tunnel `b` builds, searched; one unit per fire unless its heat
    /// release needs more water.
    fn site(b: firefleet_model::testing::ScenarioBuilder, heavy_x: f64, light_x: f64) -> Incident {
        let scenario = b
            .ground("heavy", heavy_x, -2.0)
            .profile("heavy-ugv")
            .ground("light", light_x, -2.0)
            .build();
        let mut i = Incident::from_scenario(&scenario, 5.0, Strategy::Optimal).unwrap();
        i.set_units_per_fire(1);
        // Searched already: these tests are about fires.
        let end = i.tunnel.end();
        i.coverage.look(Chainage::ZERO, end, 0.0);
        for (n, x) in [("heavy", heavy_x), ("light", light_x)] {
            i.on_alive(&u(n), true, 0.0).unwrap();
            i.state_at(state(n, x, None), 0.0).unwrap();
        }
        i
    }

    #[test]
    fn a_gap_the_light_unit_threads_is_no_road_for_the_heavy_one() {
        // A truck leaves 2 m at the right-hand wall: wide enough for 1 m, not for 2.5 m.
        let b = Scenario::straight(200.0).section(10.0, 6.0).obstacle(
            "truck",
            (52.0, 1.0),
            [3.0, 8.0, 3.0],
        );
        // The heavy unit is nearer the fire (14 m against 24 m), with the gap between.
        let mut i = site(b, 48.0, 38.0);
        let out = i.report_at(&report("light", 62.0), 1.0).unwrap();
        let sent: Vec<&str> = tasks(&out).iter().map(|t| t.unit.as_str()).collect();
        assert_eq!(sent, ["light"], "{out:?}");
        // The same roads, asked for each body.
        let fire = i.fusion.fires()[0].id;
        let at = Place::straight(40.0, -4.0);
        assert!(matches!(i.roads.road(fire, &at, 1.0), Road::Metres(_)));
        assert_eq!(i.roads.road(fire, &at, 2.5), Road::Blocked);
    }

    #[test]
    fn one_heavy_cannon_does_the_work_of_two_light_ones() {
        // 20 MW needs two 10 L/s cannons (the first test above) but one 30 L/s cannon.
        for (heavy_x, light_x, sent) in [(55.0, 50.0, 1), (20.0, 50.0, 2)] {
            let mut i = site(Scenario::straight(200.0), heavy_x, light_x);
            let mut r = report("light", 62.0);
            r.observations[0].hrr_kw = Some(20_000.0);
            let mut out = corroborated(&mut i, &r, &["heavy"], 1.0);
            out.extend(i.tick(1.2));
            let units: Vec<&str> = tasks(&out).iter().map(|t| t.unit.as_str()).collect();
            assert_eq!(units.len(), sent, "heavy at {heavy_x}: {units:?}");
        }
    }
}

#[test]
fn a_fire_one_unit_alone_reports_gets_no_backup_until_that_unit_sprays_it() {
    let mut i = incident_with_backups();
    let out = i.report_at(&report("b", 60.0), 1.0).unwrap();
    let t = tasks(&out);
    assert_eq!(t.len(), 1, "provisional: one unit, no backup: {out:?}");
    assert_eq!(t[0].unit.as_str(), "b");
    let TaskKind::Extinguish { fire, target, .. } = t[0].kind else {
        panic!()
    };
    let spraying = TaskProgress {
        seq: t[0].seq,
        fire,
        phase: TaskPhase::Spraying,
        target,
    };
    // b got there and still sees it: one backup may come and see for itself.
    let mut out = i
        .state_at(echoing(&i, state("b", 52.0, Some(spraying))), 8.0)
        .unwrap();
    out.extend(i.state_at(state("a", 10.0, None), 8.0).unwrap());
    out.extend(i.tick(8.2));
    let backups: Vec<&str> = tasks(&out).iter().map(|t| t.unit.as_str()).collect();
    assert_eq!(backups, ["a"], "{out:?}");
}

#[test]
fn a_dim_flame_in_the_smoke_is_sent_a_unit_when_its_heat_reaches_the_reporter() {
    // a, downstream of the fire, sees its flame at 0.2 through the smoke, four reports a
    // second for 2 s; only its heat gauge tells the coordinator it is a fire.
    for (heat_kw_m2, sent) in [(3.0, true), (0.2, false)] {
        let mut i = incident();
        let mut r = report("a", 60.0);
        r.observations[0].confidence = 0.2;
        let mut out = Vec::new();
        for k in 0..=8 {
            let t = 0.25 * f64::from(k);
            let hot = UnitState {
                heat_flux_kw_m2: heat_kw_m2,
                ..state("a", 45.0, None)
            };
            i.state_at(hot, t).unwrap();
            out.extend(i.report_at(&r, t).unwrap());
        }
        out.extend(i.tick(2.2));
        let extinguish = tasks(&out)
            .iter()
            .any(|t| matches!(t.kind, TaskKind::Extinguish { .. }));
        assert_eq!(extinguish, sent, "{heat_kw_m2} kW/m2: {out:?}");
    }
}

/// Fire F1 held at t = 3 with a on it: two handovers, each to the unit that came free
/// much nearer (a, then b, then a again), are five changes to its attackers.
fn held_with_a() -> Incident {
    let mut i = incident();
    i.state_at(broken(140.0), 0.5).unwrap();
    i.report_at(&report("a", 150.0), 1.0).unwrap();
    i.state_at(state("b", 140.0, None), 2.0).unwrap();
    let (a, b) = (near(&i, "a", 148.0), near(&i, "b", 100.0));
    i.state_at(b, 3.0).unwrap();
    i.state_at(a, 3.0).unwrap();
    let out = i.tick(3.0);
    assert_eq!(tasks(&out)[0].unit.as_str(), "a", "{out:?}");
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Held {
            fire: F1,
            changes: 5
        }
    )));
    i
}

/// `unit` at `x`, on its way with nothing to report, hearing its tasks.
fn near(i: &Incident, unit: &str, x: f64) -> UnitState {
    echoing(i, state(unit, x, None))
}

#[test]
fn a_fire_whose_attackers_keep_changing_is_held_until_the_window_lets_them_go() {
    let mut i = held_with_a();
    // b comes free next to the fire and a drives away: no handover while held.
    let mut t = 4.0;
    while t < 62.0 {
        let (a, b) = (near(&i, "a", 100.0), near(&i, "b", 149.0));
        let mut out = i.state_at(a, t).unwrap();
        out.extend(i.state_at(b, t).unwrap());
        out.extend(i.report_at(&report("b", 150.0), t).unwrap());
        out.extend(i.tick(t));
        assert!(tasks(&out).is_empty(), "t = {t}: {out:?}");
        assert!(kinds_for(&out, "a").is_empty(), "t = {t}: {out:?}");
        assert_eq!(i.assigned_to(F1), [u("a")]);
        t += 1.0;
    }
    // A minute after the changes began, they are out of the window: b takes over.
    let mut handed = false;
    while t < 70.0 && !handed {
        let (a, b) = (near(&i, "a", 100.0), near(&i, "b", 149.0));
        i.state_at(a, t).unwrap();
        i.state_at(b, t).unwrap();
        i.tick(t);
        handed = i.assigned_to(F1) == [u("b")];
        t += 1.0;
    }
    assert!(handed, "{:?}", i.decisions().last());
    assert!(i.decisions().any(|d| d.t >= 62.0
        && matches!(
            &d.decision,
            Decision::Relieved { unit, fire: F1, by, .. } if unit == "a" && by == "b"
        )));
}

#[test]
fn a_held_fire_whose_attacker_breaks_down_is_still_given_another() {
    let mut i = held_with_a();
    i.state_at(near(&i, "b", 120.0), 4.0).unwrap();
    let a = UnitState {
        mode: UnitMode::Fault,
        ..near(&i, "a", 148.0)
    };
    let mut out = i.state_at(a, 5.0).unwrap();
    out.extend(i.tick(5.0));
    assert_eq!(kinds_for(&out, "b").len(), 1, "{out:?}");
    assert_eq!(tasks(&out)[0].unit.as_str(), "b", "{out:?}");
    assert_eq!(i.assigned_to(F1), [u("b")]);
}

/// b reports a flame 6 m past fire F1 (a attacks it, from `a_x`), is sent to it, and its
/// estimate converges on F1's: the two tracks merge. The time after.
fn b_sent_to_a_duplicate_of_f1(i: &mut Incident, t: f64, a_x: f64) -> f64 {
    let mut t = t;
    for x in [156.0, 155.0, 154.0, 153.0, 152.0] {
        i.state_at(near(i, "a", a_x), t).unwrap();
        i.state_at(near(i, "b", 140.0), t).unwrap();
        let out = i.report_at(&report("b", x), t).unwrap();
        if x == 156.0 {
            assert!(matches!(
                kinds_for(&out, "b")[..],
                [TaskKind::Extinguish { fire, .. }] if fire != F1
            ));
        }
        t += 0.5;
    }
    assert!(decided(i, |d| matches!(
        d,
        Decision::Merged { kept: F1, .. }
    )));
    t
}

#[test]
fn a_track_merged_into_a_fire_with_an_attacker_has_its_unit_released_not_added() {
    let mut i = incident();
    i.state_at(broken(20.0), 0.5).unwrap();
    i.report_at(&report("a", 150.0), 1.0).unwrap();
    i.state_at(near(&i, "a", 148.0), 2.0).unwrap();
    i.state_at(near(&i, "b", 20.0), 2.0).unwrap();
    assert_eq!(i.assigned_to(F1), [u("a")]);
    b_sent_to_a_duplicate_of_f1(&mut i, 4.0, 148.0);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::MergedAway { unit, kept: F1, .. } if unit == "b"
    )));
    assert_eq!(i.assigned_to(F1), [u("a")]);
    assert_eq!(i.units[&u("b")].working_on(), None);
}

#[test]
fn a_track_merged_into_a_held_fire_has_its_unit_released_not_added() {
    let mut i = held_with_a();
    let t = b_sent_to_a_duplicate_of_f1(&mut i, 4.0, 148.0);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::MergedAway { unit, kept: F1, .. } if unit == "b"
    )));
    assert_eq!(i.assigned_to(F1), [u("a")]);
    assert_eq!(
        i.churn.held(t).collect::<Vec<_>>(),
        [(F1, 5)],
        "b left only its own track"
    );
}

#[test]
fn a_track_merged_into_a_held_fire_keeps_its_unit_when_the_incumbent_is_far() {
    let mut i = held_with_a();
    // a, held to F1, has driven off to 60 m; b is 10 m from it when the tracks merge.
    let t = b_sent_to_a_duplicate_of_f1(&mut i, 4.0, 60.0);
    assert!(!decided(&i, |d| matches!(d, Decision::MergedAway { .. })));
    let b = i.units[&u("b")].working_on().map(|f| i.fusion.resolve(f));
    assert_eq!(b, Some(F1), "b stays on the fire it is 10 m from");
    // Its task still names the track it was sent to, 2 m from F1's spot: no change yet.
    assert_eq!(i.churn.held(t).collect::<Vec<_>>(), [(F1, 5)]);
}
