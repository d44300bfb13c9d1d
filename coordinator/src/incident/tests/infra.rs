//! DTS alarms as fire reports, and the ventilation's side to attack from.

use super::*;
use crate::incident::infra::DTS_DOUBT_S;
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
fn forward_dated_all_normal_readings_do_not_shut_out_the_bridge_and_betray_the_thief() {
    // A stolen SCADA key sends "all normal" dated 4.5 s ahead, again and again; every
    // real reading, dated by the clock, is still taken (`measure` unwraps).
    let mut inc = site();
    for k in 0..5 {
        let t = 10.0 + f64::from(k);
        for z in readings(t + 4.5, &[], 0.0) {
            inc.on_dts(&z, t).unwrap();
        }
        measure(&mut inc, t, &[(15, 300.0)]);
    }
    // And zone 15 read 20 C and 300 C at a rise of 0 within seconds: two voices.
    inc.tick(14.0);
    assert!(
        inc.decisions()
            .any(|d| matches!(d.decision, Decision::ScadaContradicted { zone: 15, .. })),
        "{:?}",
        inc.decisions().collect::<Vec<_>>()
    );
}

/// A thief on the bridge's key: a fire alarm in zone 20 (180 C, rising 30 K/min) and
/// "all normal" everywhere else, dated `t`.
fn thief(inc: &mut Incident, t: f64) {
    for z in readings(t, &[(20, 180.0)], 30.0) {
        inc.on_dts(&z, t).unwrap();
    }
}

#[test]
fn two_voices_on_the_bridge_s_key_are_an_impostor_and_nothing_on_it_is_believed_until_they_stop() {
    let mut inc = site();
    // The thief first, alone: its alarm sends a unit.
    thief(&mut inc, 1.0);
    let sent = extinguish_tasks(&inc.tick(1.0));
    assert_eq!(sent.len(), 1, "{sent:?}");
    let unit = sent[0].0.clone();
    // The bridge, reading the real detector a second later: zone 20 at 20 C, not rising.
    // No one detector gives both: the unit is called back, and an impostor alarm goes out.
    measure(&mut inc, 2.0, &[]);
    let out = inc.tick(2.0);
    assert!(extinguish_tasks(&out).is_empty(), "{out:?}");
    assert!(
        out.iter().any(|o| matches!(o, Output::Task(k)
            if k.unit == unit && k.kind == TaskKind::Standby)),
        "{out:?}"
    );
    let found = inc
        .decisions()
        .find(|d| matches!(d.decision, Decision::ScadaContradicted { zone: 20, .. }))
        .expect("two voices found")
        .to_msg();
    assert_eq!(found.impostor.as_deref(), Some("scada"), "{}", found.text);
    // While both speak, nothing on the key is believed: neither a real alarm (zone 15)
    // nor the ventilation.
    let mut out = Vec::new();
    for k in 3..8 {
        let t = f64::from(k);
        thief(&mut inc, t);
        measure(&mut inc, t + 0.5, &[(15, 300.0)]);
        air(&mut inc, t + 0.5, 2.0);
        out.extend(inc.tick(t + 0.5));
    }
    assert!(extinguish_tasks(&out).is_empty(), "{out:?}");
    assert_eq!(inc.approach(7.5), Approach::Either);
    // The thief stops. A minute after its last lie the bridge is believed again, and the
    // real alarm sends a unit, from upwind.
    for k in 8..70 {
        let t = f64::from(k);
        for (id, x) in [
            ("west-1", 5.0),
            ("west-2", 5.0),
            ("east-1", 295.0),
            ("east-2", 295.0),
        ] {
            inc.state_at(ground_state(id, x, -2.5), t).unwrap();
        }
        measure(&mut inc, t, &[(15, 300.0)]);
        air(&mut inc, t, 2.0);
        out.extend(inc.tick(t));
    }
    assert!(
        inc.decisions()
            .any(|d| d.decision == Decision::ScadaBelieved && d.t >= 7.0 + DTS_DOUBT_S)
    );
    let sent = extinguish_tasks(&out);
    assert!(
        sent.iter()
            .any(|(_, p, from)| (p.x - 155.0).abs() < 1e-9 && *from == Approach::Start),
        "{sent:?}"
    );
}

proptest::proptest! {
    /// However a real detector's zone heats and cools (each sweep 10 s, the rise since the
    /// last), and however often the bridge polls it, through the registers' rounding, its
    /// readings never contradict each other.
    #[test]
    fn an_honest_detector_never_contradicts_itself(
        start in 15.0..600.0f64,
        steps in proptest::collection::vec(-300.0..300.0f64, 1..25),
        poll_s in 0.3..12.0f64,
        phase in 0.0..1.0f64,
    ) {
        let mut inc = site();
        let map: firefleet_model::infra::ScadaMap =
            toml::from_str("[dts]\nzone_length_m = 10.0\n").unwrap();
        let period = map.dts.period_s;
        // Each sweep's maximum, within what the registers' rate of rise holds.
        let sweeps: Vec<f64> = std::iter::once(start)
            .chain(steps.iter().scan(start, |c, d| {
                *c = (*c + d).clamp(15.0, 1100.0);
                Some(*c)
            }))
            .collect();
        let end = period * sweeps.len() as f64;
        let mut t = phase * poll_s;
        while t < end {
            // The newest sweep by `t`, and its rise since the one before.
            let k = ((t / period).floor() as usize).min(sweeps.len() - 1);
            let rise = if k == 0 { 0.0 } else { (sweeps[k] - sweeps[k - 1]) / period * 60.0 };
            let exact = DtsReading {
                max_c: sweeps[k],
                rise_c_min: rise,
                alarm: map.alarm(sweeps[k], rise, 20.0),
                fault: false,
            };
            let reading = map.decode_zone(0, &map.encode_dts(&[exact])).unwrap();
            let z = DtsZone { zone: 0, start_m: 0.0, end_m: 10.0, t, reading, stale: false };
            inc.on_dts(&z, t).unwrap();
            inc.tick(t);
            t += poll_s;
        }
        let contradicted: Vec<_> = inc
            .decisions()
            .filter(|d| matches!(d.decision, Decision::ScadaContradicted { .. }))
            .collect();
        proptest::prop_assert!(contradicted.is_empty(), "{contradicted:?}");
    }
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
