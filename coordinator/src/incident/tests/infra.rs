//! DTS alarms as fire reports, and the ventilation's side to attack from.

use super::*;
use firefleet_model::infra::{DtsAlarm, DtsReading, FanState, VentReading};
use firefleet_protocol::msg::{Approach, DtsZone, Vent};

/// A 300 m tunnel mapped in 10 m DTS zones, two ground units at each portal.
fn site() -> Incident {
    let mut s = Scenario::straight(300.0)
        .ground("west-1", 5.0, -2.5)
        .ground("west-2", 5.0, 2.5)
        .ground("east-1", 295.0, -2.5)
        .ground("east-2", 295.0, 2.5)
        .build();
    s.portals = Some(["west".into(), "east".into()]);
    s.scada = Some(toml::from_str("[dts]\nzone_length_m = 10.0\n").unwrap());
    let mut inc = Incident::from_scenario(&s, 5.0, Strategy::Optimal).unwrap();
    for (id, x) in [
        ("west-1", 5.0),
        ("west-2", 5.0),
        ("east-1", 295.0),
        ("east-2", 295.0),
    ] {
        inc.on_alive(&u(id), true, 0.0).unwrap();
        inc.state_at(ground_state(id, x, -2.5), 0.0).unwrap();
    }
    inc
}

/// Every zone at 20 C but those in `hot` (zone, degrees C), in alarm above 60 C.
fn measure(inc: &mut Incident, t: f64, hot: &[(u16, f64)]) {
    measure_rising(inc, t, hot, 0.0);
}

/// As [`measure`], the hot zones rising at `rise_c_min` (in alarm from 10 C/min).
fn measure_rising(inc: &mut Incident, t: f64, hot: &[(u16, f64)], rise_c_min: f64) {
    for z in readings(t, hot, rise_c_min) {
        inc.on_dts(&z, t).unwrap();
    }
}

/// The readings [`measure_rising`] takes, dated `t`.
fn readings(t: f64, hot: &[(u16, f64)], rise_c_min: f64) -> Vec<DtsZone> {
    (0..30u16)
        .map(|k| {
            let max_c = hot.iter().find(|(z, _)| *z == k).map_or(20.0, |(_, c)| *c);
            let rise_c_min = if max_c > 20.0 { rise_c_min } else { 0.0 };
            DtsZone {
                zone: k,
                start_m: f64::from(k) * 10.0,
                end_m: f64::from(k + 1) * 10.0,
                t,
                reading: DtsReading {
                    max_c,
                    rise_c_min,
                    alarm: DtsAlarm {
                        max: max_c >= 60.0,
                        rise: rise_c_min >= 10.0,
                        ..DtsAlarm::default()
                    },
                    fault: false,
                },
                stale: false,
            }
        })
        .collect()
}

fn air(inc: &mut Incident, t: f64, air_m_s: f64) {
    let v = Vent {
        t,
        reading: VentReading {
            air_m_s,
            fans: vec![FanState::Forward; 2],
        },
        stale: false,
    };
    inc.on_vent(&v, t).unwrap();
}

fn extinguish_tasks(out: &[Output]) -> Vec<(UnitId, Point2, Approach)> {
    out.iter()
        .filter_map(|o| match o {
            Output::Task(t) => match t.kind {
                TaskKind::Extinguish { target, from, .. } => Some((t.unit.clone(), target, from)),
                _ => None,
            },
            _ => None,
        })
        .collect()
}

/// `unit`, where it stands, reporting the flame of zone 15 at (152, -2) at t = 30 s.
fn sees_the_flame(inc: &Incident, unit: &UnitId) -> FlameReport {
    let at = inc.units[unit].state.as_ref().unwrap().pose.x;
    FlameReport {
        unit: unit.clone(),
        t: 30.0,
        observer: Pose2::new(at, -2.5, 0.0),
        observations: vec![FlameObservation {
            position: Point2::new(152.0, -2.0),
            cov: [0.2, 0.0, 0.2],
            confidence: 0.9,
            hrr_kw: None,
        }],
    }
}

#[test]
fn an_alarm_peak_sends_a_unit_before_any_has_seen_the_fire_and_a_sighting_moves_it_there() {
    let mut inc = site();
    // Zones 14 to 16 in alarm, 15 the hottest: one fire, in zone 15.
    measure(
        &mut inc,
        1.0,
        &[(14, 70.0), (15, 180.0), (16, 90.0), (27, 40.0)],
    );
    let out = inc.tick(1.0);
    let sent = extinguish_tasks(&out);
    assert_eq!(sent.len(), 1, "{out:?}");
    let (unit, target, from) = sent[0].clone();
    assert!(
        (target.x - 155.0).abs() < 1e-9 && target.y.abs() < 1e-9,
        "{target:?}"
    );
    assert_eq!(from, Approach::Either, "still air: either side");
    assert!(
        inc.decisions()
            .any(|d| matches!(d.decision, Decision::DtsAlarm { from_m, .. } if from_m == 150.0))
    );
    // One source: provisional, no backup yet.
    let fire = inc.fire_tracks(1.0)[0].id;
    assert!(!inc.fusion.get(fire).unwrap().corroborated());
    // The unit sees the flame 3 m from the zone's middle: its task moves there, and the
    // detector's word and the unit's corroborate each other.
    let out = inc.report_at(&sees_the_flame(&inc, &unit), 30.0).unwrap();
    let moved = extinguish_tasks(&out);
    assert!(
        moved
            .iter()
            .any(|(u, p, _)| *u == unit && p.dist(Point2::new(152.0, -2.0)) < 1.0),
        "{out:?}"
    );
    assert!(inc.fusion.get(fire).unwrap().corroborated());
    assert_eq!(
        inc.fire_tracks(30.0).len(),
        1,
        "the sighting joined the DTS's fire"
    );
}

#[test]
fn a_stale_or_old_reading_raises_nothing_and_a_zone_off_the_map_is_refused() {
    let mut inc = site();
    let mut z = DtsZone {
        zone: 15,
        start_m: 150.0,
        end_m: 160.0,
        t: 1.0,
        reading: DtsReading {
            max_c: 200.0,
            rise_c_min: 0.0,
            alarm: DtsAlarm {
                max: true,
                ..DtsAlarm::default()
            },
            fault: false,
        },
        stale: true,
    };
    inc.on_dts(&z, 1.0).unwrap();
    assert!(extinguish_tasks(&inc.tick(1.0)).is_empty());
    // Fresh, but read long ago: no longer believed.
    z.stale = false;
    z.t = 2.0;
    inc.on_dts(&z, 9.0).unwrap();
    assert!(extinguish_tasks(&inc.tick(60.0)).is_empty());
    z.t = 60.0;
    z.start_m = 151.0;
    let e = inc.on_dts(&z, 60.0).unwrap_err();
    assert!(e.reason.contains("spans 150.0-160.0"), "{e}");
    z.start_m = 150.0;
    z.zone = 31;
    assert!(
        inc.on_dts(&z, 60.0)
            .unwrap_err()
            .reason
            .contains("30 zones")
    );
}

#[test]
fn forward_dated_all_normal_readings_do_not_shut_out_the_bridge_s_alarm() {
    // A stolen SCADA key sends "all normal" dated 4.5 s ahead, again and again; the real
    // bridge's alarm, dated by the clock, still gets through.
    let mut inc = site();
    for k in 0..5 {
        let t = 10.0 + f64::from(k);
        for z in readings(t + 4.5, &[], 0.0) {
            inc.on_dts(&z, t).unwrap();
        }
        measure(&mut inc, t, &[(15, 300.0)]);
    }
    // Every real reading was taken (`measure` unwraps), and the alarm's fire is tracked.
    let out = inc.tick(14.0);
    assert!(
        out.iter().any(|o| matches!(o, Output::Fire(f)
            if f.state == FireState::Confirmed && (f.position.x - 155.0).abs() < 1e-9)),
        "the real alarm was shut out: {out:?}"
    );
}

#[test]
fn with_the_air_moving_units_attack_from_upwind_and_downwind_units_leave_the_smoke() {
    let mut inc = site();
    air(&mut inc, 1.0, 2.1);
    measure(&mut inc, 1.0, &[(15, 180.0)]);
    let out = inc.tick(1.0);
    let sent = extinguish_tasks(&out);
    assert_eq!(sent.len(), 1);
    // A west unit, from the west: the east units, as near, would cross the fire.
    assert!(sent[0].0.as_str().starts_with("west"), "{sent:?}");
    assert_eq!(sent[0].2, Approach::Start);
    let said = inc
        .decisions()
        .find(|d| matches!(d.decision, Decision::Assign { .. }))
        .unwrap()
        .decision
        .to_string();
    assert!(
        said.contains("from the west: air flows towards the east at 2.1 m/s"),
        "{said}"
    );
    // The east units, downwind, withdraw towards the east portal.
    let leaving: Vec<&UnitId> = out
        .iter()
        .filter_map(|o| match o {
            Output::Task(t) if matches!(t.kind, TaskKind::Cruise { goal } if goal.x > 280.0) => {
                Some(&t.unit)
            }
            _ => None,
        })
        .collect();
    assert_eq!(leaving.len(), 2, "{out:?}");
    assert!(leaving.iter().all(|u| u.as_str().starts_with("east")));
    // Reversed air: the east side is upwind.
    let mut inc = site();
    air(&mut inc, 1.0, -2.1);
    measure(&mut inc, 1.0, &[(15, 180.0)]);
    let sent = extinguish_tasks(&inc.tick(1.0));
    assert!(
        sent[0].0.as_str().starts_with("east") && sent[0].2 == Approach::End,
        "{sent:?}"
    );
    // Air too slow to choose a side by, or a stale reading: either side.
    let mut inc = site();
    air(&mut inc, 1.0, 0.3);
    measure(&mut inc, 1.0, &[(15, 180.0)]);
    assert_eq!(extinguish_tasks(&inc.tick(1.0))[0].2, Approach::Either);
}

/// The DTS's fire in zone 15, the unit sent to it, and that unit's task number.
fn sent_by_the_dts(inc: &mut Incident) -> (FireId, UnitId, u64) {
    measure(inc, 1.0, &[(15, 180.0)]);
    let out = inc.tick(1.0);
    let (unit, ..) = extinguish_tasks(&out)[0].clone();
    let seq = inc.units[&unit].task.as_ref().unwrap().seq;
    (inc.fire_tracks(1.0)[0].id, unit, seq)
}

fn claims_out(inc: &mut Incident, unit: &UnitId, fire: FireId, seq: u64, t: f64) -> Vec<Output> {
    let x = inc.units[unit].state.as_ref().unwrap().pose.x;
    let mut st = ground_state(unit.as_str(), x, -2.5);
    st.task = Some(TaskProgress {
        seq,
        fire,
        phase: TaskPhase::Extinguished,
        target: Point2::new(155.0, 0.0),
    });
    st.task_seq = Some(seq);
    st.epoch = inc.units[unit].task.as_ref().map(|k| k.epoch);
    inc.state_at(st, t).unwrap()
}

#[test]
fn a_unit_that_never_saw_the_dts_fire_cannot_call_it_out_and_another_is_sent() {
    let mut inc = site();
    let (fire, unit, seq) = sent_by_the_dts(&mut inc);
    // It reports the fire out without ever having reported a flame there (the flames were
    // behind a lorry): the fire stays open, the unit is freed, and someone else goes.
    let mut out = claims_out(&mut inc, &unit, fire, seq, 3.0);
    out.extend(inc.tick(3.5));
    assert!(inc.decisions().any(
        |d| matches!(&d.decision, Decision::OutUnseen { fire: f, by } if *f == fire && *by == unit)
    ));
    assert!(inc.fusion.get(fire).unwrap().active());
    let again = extinguish_tasks(&out);
    assert!(
        again.iter().any(|(u, ..)| *u != unit),
        "another unit is sent: {out:?}"
    );
}

#[test]
fn after_a_unit_looked_in_vain_from_upwind_the_next_looks_from_downwind() {
    let mut inc = site();
    air(&mut inc, 1.0, 2.1);
    let (fire, unit, seq) = sent_by_the_dts(&mut inc);
    assert!(unit.as_str().starts_with("west"), "{unit}");
    // Nothing seen from the west (the flames come out of the lorry's east end): the next
    // unit attacks from the east, downwind, and an east unit, already there, is the one.
    let mut out = claims_out(&mut inc, &unit, fire, seq, 3.0);
    out.extend(inc.tick(3.5));
    let again = extinguish_tasks(&out);
    assert_eq!(again.len(), 1, "{out:?}");
    assert!(again[0].0.as_str().starts_with("east"), "{again:?}");
    assert_eq!(again[0].2, Approach::End);
    let said = inc
        .decisions()
        .filter(|d| matches!(d.decision, Decision::Assign { .. }))
        .last()
        .unwrap()
        .decision
        .to_string();
    assert!(
        said.contains("from the east, downwind (looked for from upwind in vain)"),
        "{said}"
    );
}

#[test]
fn a_dts_fire_two_units_looked_for_in_vain_draws_no_more_until_one_sees_it() {
    let mut inc = site();
    let (fire, west, seq) = sent_by_the_dts(&mut inc);
    let out = claims_out(&mut inc, &west, fire, seq, 3.0);
    let mut out = [out, inc.tick(3.5)].concat();
    let (east, ..) = extinguish_tasks(&out)[0].clone();
    // Nothing from the other side either (or a stolen bridge key raised the alarm where
    // nothing burns): the alarm stays open, and no third unit is sent.
    let seq = inc.units[&east].task.as_ref().unwrap().seq;
    out = claims_out(&mut inc, &east, fire, seq, 5.0);
    out.extend(inc.tick(5.5));
    assert!(extinguish_tasks(&out).is_empty(), "{out:?}");
    assert!(inc.fusion.get(fire).unwrap().active());
    assert!(inc.decisions().any(|d| matches!(
        d.decision,
        Decision::AlarmUnverified { fire: f, looks: 2 } if f == fire
    )));
    // A unit that sees the flame there: it is a fire again, and one of the units that have
    // not looked in vain goes.
    for (id, x) in [("west-2", 5.0), ("east-2", 295.0)] {
        inc.state_at(ground_state(id, x, 2.5), 5.8).unwrap();
    }
    let out = inc.report_at(&sees_the_flame(&inc, &west), 6.0).unwrap();
    let out = [out, inc.tick(6.5)].concat();
    let sent = extinguish_tasks(&out);
    assert!(
        sent.iter().any(|(u, ..)| u.as_str().ends_with("-2")),
        "{out:?}"
    );
}

#[test]
fn a_zone_heating_up_again_after_its_fire_was_called_out_reopens_it() {
    let mut inc = site();
    let (fire, unit, seq) = sent_by_the_dts(&mut inc);
    // The unit saw the flame, and then saw it gone: out.
    inc.report_at(&sees_the_flame(&inc, &unit), 30.0).unwrap();
    let seq = inc.units[&unit].task.as_ref().map_or(seq, |k| k.seq);
    claims_out(&mut inc, &unit, fire, seq, 40.0);
    assert_eq!(inc.fusion.get(fire).unwrap().state, FireState::Out);
    // The zone still hot but cooling: still out. Rising 30 s after: it burns.
    measure_rising(&mut inc, 50.0, &[(15, 150.0)], -40.0);
    inc.tick(50.0);
    assert_eq!(inc.fusion.get(fire).unwrap().state, FireState::Out);
    measure_rising(&mut inc, 70.0, &[(15, 170.0)], 25.0);
    inc.tick(70.0);
    assert!(inc.fusion.get(fire).unwrap().active());
    assert!(
        inc.decisions()
            .any(|d| matches!(&d.decision, Decision::ReheatedZone { fire: f, .. } if *f == fire))
    );
}
