use super::*;
use firefleet_model::scenario::Scenario;
use firefleet_protocol::msg::{GoalKind, ZoneGoal};
use firefleet_protocol::testing::ground_state;

fn picture() -> Picture {
    let text = include_str!("../../../model/scenarios/rail-tunnel.toml");
    Picture::new(SiteMap::new(
        &Scenario::from_toml(text, "rail-tunnel.toml").unwrap(),
    ))
}

fn track(id: u32, t: f64, x: f64, state: FireState) -> FireTrack {
    FireTrack {
        id: FireId(id),
        t,
        position: Point2::new(x, 1.0),
        cov: [0.1, 0.0, 0.1],
        confidence: 0.9,
        state,
        assigned: vec![],
        seen_by: vec![],
        hrr_kw: Some(3000.0),
    }
}

fn unit(id: &str) -> UnitId {
    UnitId::new(id).unwrap()
}

#[test]
fn every_unit_of_the_site_is_accounted_for_before_it_is_heard() {
    let p = picture();
    let inc = p.incident();
    assert_eq!(inc.units.len(), inc.site.units.len());
    assert!(inc.units.iter().all(|u| u.state.is_none() && !u.alive));
}

#[test]
fn a_delta_carries_each_changed_unit_once_with_its_newest_state() {
    let mut p = picture();
    let id = p.site.units[0].id.clone();
    let mut s = ground_state(&id, 10.0, 0.0);
    s.t = 1.0;
    p.observe(100, Event::Message(Payload::UnitState(s.clone())));
    s.t = 2.0;
    s.pose.x = 12.0;
    p.observe(200, Event::Message(Payload::UnitState(s.clone())));
    // A late sample does not move the unit back.
    s.t = 1.5;
    s.pose.x = 11.0;
    p.observe(300, Event::Message(Payload::UnitState(s)));
    let d = p.delta(300).unwrap();
    assert_eq!(d.units.len(), 1);
    let u = &d.units[0];
    assert_eq!(u.state.as_ref().unwrap().pose.x, 12.0);
    assert_eq!(u.heard_ms, Some(300));
    assert_eq!(d.t, 2.0);
    assert!(p.delta(400).is_none(), "nothing changed since");
    assert_eq!(p.incident().seq, d.seq);
}

#[test]
fn a_repeated_decision_is_one_line_with_a_count_and_pages_get_lines_by_id() {
    let mut p = picture();
    let d = |t: f64, text: &str| {
        Event::Message(Payload::Decision(Decision {
            t,
            text: text.into(),
            impostor: None,
        }))
    };
    p.observe(0, d(1.0, "ugv-1 cannot obey goal 'v1'"));
    p.observe(0, d(1.1, "assign ugv-2 to f1"));
    let first = p.delta(0).unwrap();
    assert_eq!(first.decisions.len(), 2);
    for t in [1.2, 1.4, 1.6] {
        p.observe(0, d(t, "ugv-1 cannot obey goal 'v1'"));
    }
    // The repeats change the one line: its count and latest time, under its id.
    let next = p.delta(0).unwrap();
    assert_eq!(next.decisions.len(), 1);
    let line = &next.decisions[0];
    assert_eq!(
        (line.id, line.count, line.first_t, line.t),
        (first.decisions[0].id, 4, 1.0, 1.6)
    );
    let lines = p.incident().decisions;
    assert_eq!(lines.len(), 2, "{lines:?}");
}

#[test]
fn a_unit_s_moves_reach_pages_at_a_bounded_rate_and_what_it_does_at_once() {
    let mut p = picture();
    let id = p.site.units[0].id.clone();
    let mut s = ground_state(&id, 10.0, 0.0);
    let mut sent = 0;
    // Ten states a second for two seconds, moving: at most one a period reaches the page.
    for k in 0..20u64 {
        s.t = k as f64 / 10.0;
        s.pose.x = 10.0 + 0.1 * k as f64;
        p.observe(k * 100, Event::Message(Payload::UnitState(s.clone())));
        sent += p
            .delta(k * 100)
            .map_or(0, |d| d.units.len() + d.moves.len());
    }
    assert_eq!(sent as u64, 2000 / UNIT_PERIOD_MS, "moves only");
    // A change of mode goes at the next tick.
    s.mode = firefleet_protocol::msg::UnitMode::Fault;
    s.t = 2.0;
    p.observe(2_000, Event::Message(Payload::UnitState(s.clone())));
    let d = p.delta(2_050).unwrap();
    assert_eq!(d.units.len(), 1);
    // The move that waited is sent once its period is up, newest.
    s.mode = firefleet_protocol::msg::UnitMode::Fault;
    s.pose.x = 30.0;
    s.t = 2.1;
    p.observe(2_100, Event::Message(Payload::UnitState(s.clone())));
    assert!(p.delta(2_100).is_none());
    let d = p.delta(3_050).unwrap();
    assert!(d.units.is_empty(), "only a move: the page has the rest");
    assert_eq!((d.moves[0].x, d.moves[0].heard_ms), (30.0, 2_100));
    // Whole again once in a while, so a page never drifts from the picture.
    s.t = 12.5;
    p.observe(12_500, Event::Message(Payload::UnitState(s)));
    let d = p.delta(12_500).unwrap();
    assert_eq!((d.units.len(), d.moves.len()), (1, 0));
}

/// Fire `id`'s track heard at `ms`, at `x` m, in `state`.
fn heard(p: &mut Picture, id: u32, ms: u64, x: f64, state: FireState) {
    p.observe(
        ms,
        Event::Message(Payload::Fire(track(id, ms as f64 / 1e3, x, state))),
    );
}

#[test]
fn fires_the_coordinator_no_longer_republishes_are_dropped() {
    let mut p = picture();
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 1.0, 50.0, FireState::Assigned))),
    );
    p.observe(
        0,
        Event::Message(Payload::Fire(track(2, 1.0, 90.0, FireState::Assigned))),
    );
    p.delta(0);
    // Only f2 is republished: f1 was merged, or its coordinator replaced.
    for ms in (1_000..=FIRE_ORPHAN_MS).step_by(1_000) {
        heard(&mut p, 2, ms, 90.0, FireState::Assigned);
    }
    let d = p.delta(FIRE_ORPHAN_MS).unwrap();
    assert_eq!(d.fires_gone, [FireId(1)]);
    assert_eq!(p.incident().fires.len(), 1);
}

#[test]
fn an_out_fire_resent_only_every_ten_seconds_is_kept_until_it_too_is_no_longer_resent() {
    let mut p = picture();
    let settled = keys::SETTLED_RESEND_MS;
    // Re-sent on time: heard at 0 and at `settled`, with f2 every second meanwhile.
    for ms in (0..=settled + FIRE_ORPHAN_MS).step_by(1_000) {
        heard(&mut p, 2, ms, 90.0, FireState::Assigned);
        if ms == 0 || ms == settled {
            heard(&mut p, 1, ms, 50.0, FireState::Out);
        }
        let d = p.delta(ms);
        assert!(d.is_none_or(|d| d.fires_gone.is_empty()), "at {ms} ms");
    }
    // Then no longer: gone once its re-send is the orphan margin late.
    let last = 2 * settled + FIRE_ORPHAN_MS;
    for ms in (settled + FIRE_ORPHAN_MS + 1_000..=last).step_by(1_000) {
        heard(&mut p, 2, ms, 90.0, FireState::Assigned);
    }
    let d = p.delta(last).unwrap();
    assert_eq!(d.fires_gone, [FireId(1)]);
}

#[test]
fn losing_the_site_is_not_losing_the_units() {
    let mut p = picture();
    let u = unit("ugv-1");
    p.observe(0, Event::Link(true));
    p.observe(0, Event::UnitAlive(u.clone(), true));
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.delta(0);
    // The tokens vanish a moment before the link is known to be down.
    p.observe(10, Event::UnitAlive(u.clone(), false));
    p.observe(10, Event::CoordinatorAlive(0, false));
    p.observe(500, Event::Link(false));
    let d = p.delta(10 + LOST_CONFIRM_MS).unwrap();
    assert_eq!(d.link, Some(false));
    assert!(d.alerts.is_empty(), "{:?}", d.alerts);
    assert!(d.units.iter().all(|v| !v.lost && !v.alive));
}

#[test]
fn a_console_started_mid_incident_fills_in_from_the_coordinator_s_status() {
    let mut p = picture();
    p.observe(
        0,
        Event::Message(Payload::Decision(Decision {
            t: 50.0,
            text: "heard live".into(),
            impostor: None,
        })),
    );
    let status = IncidentStatus {
        t: 50.0,
        units: Vec::new(),
        fires: vec![track(3, 40.0, 70.0, FireState::Out)],
        decisions: vec![
            Decision {
                t: 30.0,
                text: "assign ugv-1 to f3".into(),
                impostor: None,
            },
            Decision {
                t: 20.0,
                text: "fire f3 confirmed".into(),
                impostor: None,
            },
        ],
        goals: Vec::new(),
        stranded: Vec::new(),
        trapped: Vec::new(),
        rejected: Default::default(),
        suspended: Vec::new(),
    };
    p.observe(0, Event::Status(Box::new(status)));
    let inc = p.incident();
    assert_eq!(inc.coordinator, Some(true));
    assert_eq!(inc.fires.len(), 1);
    let texts: Vec<&str> = inc.decisions.iter().map(|l| l.text.as_str()).collect();
    assert_eq!(
        texts,
        ["fire f3 confirmed", "assign ugv-1 to f3", "heard live"]
    );
}

#[test]
fn a_trapped_unit_raises_one_alert_while_it_lasts() {
    let mut p = picture();
    let x = firefleet_protocol::msg::Trapped {
        unit: unit("ugv-1"),
        goal: "v1".into(),
        zone: firefleet_model::ZoneId::new("portal").unwrap(),
        issued_by: Some(firefleet_model::CommanderId::new("rossi").unwrap()),
    };
    let told = |t, trapped| {
        Event::Message(Payload::Goals(GoalsInForce {
            t,
            trapped,
            ..Default::default()
        }))
    };
    for t in [1.0, 1.1, 1.2] {
        p.observe(0, told(t, vec![x.clone()]));
    }
    let alerts = p.incident().alerts;
    assert_eq!(alerts.len(), 1);
    assert!(
        matches!(&alerts[0].kind, AlertKind::UnitTrapped { unit, goal, .. } if unit == "ugv-1" && goal == "v1")
    );
    assert_eq!(alerts[0].priority, 1);
    assert!(alerts[0].text.contains("rossi"), "{}", alerts[0].text);
    assert!(alerts[0].active && alerts[0].count == 1);
    // Freed: it returns to normal by itself, and stays open until acknowledged.
    p.observe(0, told(2.0, vec![]));
    let a = &p.incident().alerts[0];
    assert!(
        !a.active && a.returned_t == Some(2.0) && !a.closed(),
        "{a:?}"
    );
    // Trapped again before anyone acknowledged: the same alarm, active again, counted.
    p.observe(0, told(3.0, vec![x.clone()]));
    let a = p.incident().alerts[0].clone();
    assert_eq!((a.active, a.count, a.t, a.last_t), (true, 2, 1.0, 3.0));
    assert_eq!(p.incident().alerts.len(), 1, "one cause, one alarm");
    // Acknowledged while active; freed: closed. Trapped once more: a new alarm.
    assert!(p.acknowledge(a.id, "rossi"));
    p.observe(0, told(4.0, vec![]));
    assert!(p.incident().alerts[0].closed());
    p.observe(0, told(5.0, vec![x]));
    let alerts = p.incident().alerts;
    assert_eq!(alerts.len(), 2, "after it closed: raised anew");
    assert!(alerts[1].active && alerts[1].acked_by.is_none());
}

#[test]
fn a_standby_gone_is_an_alarm_until_one_follows_again_and_says_how_many_are_left() {
    let mut p = picture();
    p.observe(0, Event::Link(true));
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.observe(0, Event::StandbyAlive(1, true));
    p.observe(0, Event::StandbyAlive(2, true));
    p.observe(0, Event::StandbyAlive(1, false));
    // Not at once (it may be failing over between routers), but after the grace.
    assert!(p.delta(0).is_none_or(|d| d.alerts.is_empty()));
    let d = p.delta(LOST_CONFIRM_MS).unwrap();
    assert!(
        matches!(&d.alerts[..], [a] if a.kind == AlertKind::StandbyGone { rank: 1, left: 1 } && a.priority == 2),
        "{:?}",
        d.alerts
    );
    p.observe(LOST_CONFIRM_MS, Event::StandbyAlive(2, false));
    let d = p.delta(2 * LOST_CONFIRM_MS).unwrap();
    assert!(
        d.alerts[0].text.contains("no standby is left"),
        "{:?}",
        d.alerts
    );
    // The coordinator gone with no standby: the alarm does not promise one.
    p.observe(2 * LOST_CONFIRM_MS, Event::CoordinatorAlive(0, false));
    let d = p.delta(3 * LOST_CONFIRM_MS).unwrap();
    let lost = d
        .alerts
        .iter()
        .find(|a| a.kind == AlertKind::CoordinatorLost)
        .unwrap();
    assert!(lost.text.contains("no standby follows"), "{}", lost.text);
    // A standby back, the coordinator back: both return to normal.
    p.observe(3 * LOST_CONFIRM_MS, Event::StandbyAlive(1, true));
    p.observe(3 * LOST_CONFIRM_MS, Event::CoordinatorAlive(0, true));
    let open: Vec<_> = p
        .incident()
        .alerts
        .into_iter()
        .filter(|a| a.active)
        .collect();
    assert_eq!(
        open.iter().map(|a| &a.kind).collect::<Vec<_>>(),
        [&AlertKind::StandbyGone { rank: 2, left: 0 }],
        "{open:?}"
    );
}

#[test]
fn a_standby_taking_office_is_said_at_once_with_who_and_when_and_a_router_failover_is_not() {
    use firefleet_protocol::msg::{Task, TaskKind};
    let task = |epoch| {
        Event::Message(Payload::Task(Task {
            unit: unit("ugv-1"),
            epoch,
            seq: 1,
            t: 15.0,
            kind: TaskKind::Standby,
        }))
    };
    let took = |p: &mut Picture, now| {
        p.delta(now)
            .map(|d| d.alerts)
            .unwrap_or_default()
            .into_iter()
            .find(|a| a.active && matches!(a.kind, AlertKind::StandbyGone { rank: 0, .. }))
    };
    let started = || {
        let mut p = picture();
        p.observe(0, Event::Link(true));
        p.observe(0, Event::CoordinatorAlive(0, true));
        p.observe(0, Event::StandbyAlive(0, true));
        p.observe(0, Event::StandbyAlive(1, true));
        p.observe(100, task(10));
        // The site's clock, from what the coordinator publishes.
        p.observe(
            100,
            Event::Message(Payload::Fire(track(1, 15.0, 100.0, FireState::Confirmed))),
        );
        assert!(took(&mut p, 100).is_none());
        p
    };
    // The coordinator killed: rank 0 drops its standby token, takes the coordinator's and
    // tasks in a new term a fraction of a second later. Said then, not after the grace.
    let mut p = started();
    p.observe(1000, Event::CoordinatorAlive(0, false));
    p.observe(1001, Event::StandbyAlive(0, false));
    p.observe(1002, Event::CoordinatorAlive(0, true));
    assert!(
        took(&mut p, 1002).is_none(),
        "no term yet: it may be a failover"
    );
    p.observe(1150, task(20));
    let a = took(&mut p, 1150).expect("said when the new term's first task is heard");
    assert!(
        a.text.contains("rank 0 took office at t=15.0 s in term 20")
            && a.text.ends_with("1 standby left"),
        "{}",
        a.text
    );
    assert_eq!(a.priority, 2);
    // The other order: the term heard before the token's going.
    let mut p = started();
    p.observe(1000, Event::CoordinatorAlive(0, false));
    p.observe(1001, Event::CoordinatorAlive(0, true));
    p.observe(1100, task(20));
    p.observe(1200, Event::StandbyAlive(0, false));
    assert!(took(&mut p, 1200).is_some_and(|a| a.text.contains("took office")));
    // A router's death: both tokens go and come back in any order, the term stays; no
    // alarm then or after the grace.
    let mut p = started();
    p.observe(1000, Event::CoordinatorAlive(0, false));
    p.observe(1000, Event::StandbyAlive(0, false));
    p.observe(1500, Event::CoordinatorAlive(0, true));
    p.observe(1600, task(10));
    p.observe(1900, Event::StandbyAlive(0, true));
    assert!(took(&mut p, 1900 + LOST_CONFIRM_MS).is_none());
    assert_eq!(p.incident().standbys, 2);
}

#[test]
fn a_vanished_token_is_a_lost_unit_and_an_alert_until_acknowledged() {
    let mut p = picture();
    let u = unit("ugv-9");
    p.observe(0, Event::UnitAlive(u.clone(), false));
    assert!(p.incident().alerts.is_empty(), "never alive: not lost");
    p.observe(0, Event::UnitAlive(u.clone(), true));
    p.observe(0, Event::UnitAlive(u.clone(), false));
    // Not yet: the console's own link might be what went.
    let d = p.delta(0).unwrap();
    assert!(d.alerts.is_empty() && d.units.iter().all(|v| !v.lost));
    let d = p.delta(LOST_CONFIRM_MS).unwrap();
    assert!(d.units.iter().any(|v| v.id == u && v.lost));
    assert_eq!(d.alerts.len(), 1);
    let id = d.alerts[0].id;
    assert!(matches!(&d.alerts[0].kind, AlertKind::UnitLost { unit } if *unit == u));
    assert!(p.acknowledge(id, "rossi"));
    assert!(p.acknowledge(id, "bianchi"));
    let d = p.delta(0).unwrap();
    assert_eq!(d.alerts[0].acked_by.as_deref(), Some("rossi"));
    assert!(!p.acknowledge(99, "rossi"));
    p.observe(0, Event::UnitAlive(u.clone(), true));
    let d = p.delta(0).unwrap();
    assert!(d.units.iter().any(|v| v.id == u && !v.lost));
    assert!(d.alerts[0].closed(), "back, and acknowledged: closed");
}

#[test]
fn a_fire_burning_after_it_was_out_raises_an_alert() {
    let mut p = picture();
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 1.0, 50.0, FireState::Suppressing))),
    );
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 2.0, 50.0, FireState::Out))),
    );
    assert!(p.incident().alerts.is_empty());
    // The same track again, and a new track at the same place.
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 3.0, 50.0, FireState::Confirmed))),
    );
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 4.0, 50.0, FireState::Out))),
    );
    p.observe(
        0,
        Event::Message(Payload::Fire(track(2, 5.0, 53.0, FireState::Confirmed))),
    );
    // A new fire elsewhere is no re-ignition.
    p.observe(
        0,
        Event::Message(Payload::Fire(track(3, 5.0, 120.0, FireState::Confirmed))),
    );
    let alerts = p.incident().alerts;
    let fires: Vec<FireId> = alerts
        .iter()
        .filter_map(|a| match a.kind {
            AlertKind::FireReignited { fire } => Some(fire),
            _ => None,
        })
        .collect();
    assert_eq!(fires, [FireId(1), FireId(2)]);
}

#[test]
fn a_rejected_goal_and_a_lost_coordinator_are_alerts() {
    let mut p = picture();
    let ack = |accepted| GoalAck {
        id: "g".into(),
        zone: firefleet_model::ZoneId::new("z1").unwrap(),
        issued_by: Some(firefleet_model::CommanderId::new("bianchi").unwrap()),
        accepted,
        reason: "because".into(),
    };
    p.observe(0, Event::Message(Payload::Ack(ack(true))));
    p.observe(0, Event::Message(Payload::Ack(ack(false))));
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.observe(0, Event::CoordinatorAlive(0, false));
    let mut d = p.delta(0).unwrap();
    d.alerts.extend(p.delta(LOST_CONFIRM_MS).unwrap().alerts);
    assert_eq!(d.acks.len(), 2);
    assert_eq!(d.coordinator, Some(false));
    assert!(
        matches!(&d.alerts[0].kind, AlertKind::GoalRejected { issued_by, .. } if issued_by.as_deref() == Some("bianchi"))
    );
    assert_eq!(
        d.alerts[0].text,
        "bianchi's goal 'g' on zone z1 rejected: because"
    );
    assert!(matches!(d.alerts[1].kind, AlertKind::CoordinatorLost));
}

#[test]
fn goals_change_only_when_the_goals_in_force_do() {
    let mut p = picture();
    let goal = GoalInForce {
        goal: ZoneGoal {
            id: "g".into(),
            zone: firefleet_model::ZoneId::new("z1").unwrap(),
            goal: GoalKind::KeepOut,
            priority: 0,
            before_m: None,
            expires_s: None,
            issued_by: Some(firefleet_model::CommanderId::new("ic").unwrap()),
            rail_allowed: false,
        },
        since: 1.0,
        until: None,
        proof: None,
    };
    let g = |t| GoalsInForce {
        t,
        goals: vec![goal.clone()],
        ..Default::default()
    };
    p.observe(0, Event::Message(Payload::Goals(g(1.0))));
    assert_eq!(p.delta(0).unwrap().goals.unwrap().len(), 1);
    p.observe(0, Event::Message(Payload::Goals(g(2.0))));
    assert!(p.delta(0).is_none(), "the same goals a second later");
}

#[test]
fn the_heat_field_is_hottest_at_a_burning_fire_and_gone_once_it_is_out() {
    let mut p = picture();
    p.observe(
        0,
        Event::Message(Payload::Fire(track(1, 1.0, 50.0, FireState::Suppressing))),
    );
    let heat = p.delta(0).unwrap().heat.unwrap();
    let site = p.site().clone();
    let (hot, _) = heat
        .kw_m2
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .unwrap();
    let s = site.stations_m[hot / heat.columns];
    assert!((s - 50.0).abs() <= 1.5, "hottest at chainage {s}");
    p.observe(
        10,
        Event::Message(Payload::Fire(track(1, 2.0, 50.0, FireState::Out))),
    );
    let d = p.delta(10).unwrap();
    assert!(d.heat.is_none(), "at most once a second");
    p.observe(
        1500,
        Event::Message(Payload::Fire(track(1, 3.0, 50.0, FireState::Out))),
    );
    let heat = p.delta(1500).unwrap().heat.unwrap();
    assert!(heat.kw_m2.iter().all(|&q| q == 0.0));
}

#[test]
fn a_fire_a_goal_strands_raises_one_alert_naming_the_goal_and_its_issuer() {
    use firefleet_protocol::msg::Stranded;
    let mut p = picture();
    let stranded = Stranded {
        fire: FireId(3),
        at: Point2::new(120.0, 1.0),
        goal: "east-keep-out".into(),
        zone: firefleet_model::ZoneId::new("east").unwrap(),
        issued_by: Some(firefleet_model::CommanderId::new("rossi").unwrap()),
        inside: true,
    };
    let told = |t, stranded: Vec<Stranded>| {
        Event::Message(Payload::Goals(GoalsInForce {
            t,
            stranded,
            ..Default::default()
        }))
    };
    p.observe(0, told(1.0, vec![stranded.clone()]));
    p.observe(0, told(2.0, vec![stranded.clone()]));
    let alerts = p.delta(0).unwrap().alerts;
    assert_eq!(alerts.len(), 1, "raised once while it lasts: {alerts:?}");
    assert!(
        alerts[0].text.contains("fire f3")
            && alerts[0].text.contains("east-keep-out")
            && alerts[0].text.contains("rossi"),
        "{}",
        alerts[0].text
    );
    // Lifted: returned to normal at once. Stranded again before anyone acknowledged: the
    // same alarm, active again.
    p.observe(0, told(3.0, Vec::new()));
    let a = p.delta(0).unwrap().alerts[0].clone();
    assert_eq!((a.active, a.returned_t), (false, Some(3.0)));
    p.observe(0, told(4.0, vec![stranded]));
    let alerts = p.incident().alerts;
    assert_eq!(alerts.len(), 1);
    assert!(alerts[0].active && alerts[0].count == 2);
}

#[test]
fn a_silent_scada_bridge_raises_one_alert_and_the_layer_goes_stale() {
    use firefleet_model::infra::{DtsAlarm, DtsReading};
    use firefleet_protocol::msg::{DtsZone, ScadaLink};
    let mut p = picture();
    assert!(
        p.delta(0).is_none_or(|d| d.infra.is_none()),
        "no bridge, no layer"
    );
    let zone = DtsZone {
        zone: 3,
        start_m: 30.0,
        end_m: 40.0,
        t: 1.0,
        reading: DtsReading {
            max_c: 80.0,
            rise_c_min: 0.0,
            alarm: DtsAlarm {
                max: true,
                ..DtsAlarm::default()
            },
            fault: false,
        },
        stale: false,
    };
    let link = ScadaLink {
        t: 1.0,
        up: true,
        last_ok: Some(1.0),
        polls: 1,
        timeouts: 0,
        disconnects: 0,
        exceptions: 0,
        out_of_range: 0,
        problem: String::new(),
    };
    p.observe(1000, Event::Message(Payload::Dts(zone)));
    p.observe(1000, Event::Message(Payload::ScadaLink(link)));
    let live = p.delta(1000).unwrap().infra.unwrap();
    assert_eq!(live.link_up, Some(true));
    assert!(live.zones[0].alarm && !live.zones[0].stale);
    // Nothing from the bridge for longer than it takes to miss it: stale, and one alert.
    let gone = p.delta(1000 + crate::infra::SILENT_MS).unwrap();
    let layer = gone.infra.unwrap();
    assert_eq!(layer.link_up, Some(false));
    assert!(layer.zones[0].stale && layer.zones[0].max_c == 80.0);
    assert_eq!(gone.alerts.len(), 1);
    assert!(matches!(gone.alerts[0].kind, AlertKind::ScadaLost { .. }));
    assert_eq!(
        gone.alerts[0].priority, 2,
        "the DTS finds what no camera has seen"
    );
    assert!(
        gone.alerts[0]
            .text
            .starts_with("the tunnel's DTS and ventilation are no longer read"),
        "{}",
        gone.alerts[0].text
    );
    assert!(
        p.delta(3000 + crate::infra::SILENT_MS)
            .is_none_or(|d| d.alerts.is_empty() && d.infra.is_none()),
        "said once"
    );
}

#[test]
fn an_impostor_is_a_p1_alarm_that_nothing_but_a_commander_ends() {
    let mut p = picture();
    let heard = |key: &str| Event::Impostor {
        identity: "console".into(),
        key: key.into(),
    };
    p.observe(0, heard("ff/s/zone/a/goal/rossi"));
    p.observe(0, heard("ff/s/zone/b/goal/bianchi"));
    let alerts = p.incident().alerts;
    assert_eq!(alerts.len(), 1, "one alarm per identity: {alerts:?}");
    let a = &alerts[0];
    assert!(a.active && a.priority == 1 && a.count == 2, "{a:?}");
    assert!(a.text.contains("ff/s/zone/b/goal/bianchi"), "{}", a.text);
    assert!(p.acknowledge(a.id, "rossi"));
    assert!(
        p.incident().alerts[0].active,
        "acknowledged, still in force"
    );
}

#[test]
fn a_rival_lease_is_a_p1_alarm_while_it_lasts_and_the_holder_is_the_lowest_rank() {
    let mut p = picture();
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.observe(10, Event::CoordinatorAlive(1, true));
    let rival = |p: &Picture| {
        p.incident()
            .alerts
            .into_iter()
            .find(|a| a.kind == AlertKind::RivalCoordinator { rank: 1 })
    };
    let a = rival(&p).expect("a rival's lease alarms");
    assert!(a.active && a.priority == 1, "{a:?}");
    assert!(
        a.text
            .starts_with("coordinator:1 claims office while coordinator holds it"),
        "{}",
        a.text
    );
    // The holder's lease lapses: the rank 1 coordinator holds office now, no rival is
    // left, and no coordinator is lost.
    p.observe(20, Event::CoordinatorAlive(0, false));
    assert!(!rival(&p).unwrap().active, "returned to normal");
    assert!(
        p.incident()
            .alerts
            .iter()
            .all(|a| a.kind != AlertKind::CoordinatorLost),
        "office changed hands: nobody is lost"
    );
}

#[test]
fn tasks_on_the_coordinator_s_own_key_it_never_sent_are_an_impostor_alarm() {
    let mut p = picture();
    p.observe(
        0,
        Event::Message(Payload::Decision(Decision {
            t: 3.0,
            text: "someone else holds the key of coordinator:1: ...".into(),
            impostor: Some("coordinator:1".into()),
        })),
    );
    let a = &p.incident().alerts[0];
    assert_eq!(
        a.kind,
        AlertKind::Impostor {
            identity: "coordinator:1".into()
        }
    );
    assert!(a.active && a.priority == 1, "{a:?}");
}

#[test]
fn tasks_of_two_terms_at_once_are_two_coordinators_until_one_alone_is_heard() {
    use firefleet_protocol::msg::{Task, TaskKind};
    let mut p = picture();
    let task = |epoch, seq| {
        Event::Message(Payload::Task(Task {
            unit: unit("ugv-1"),
            epoch,
            seq,
            t: 1.0,
            kind: TaskKind::Standby,
        }))
    };
    // One coordinator re-sending, then a new one's term right after it stopped (a
    // restart), then a standby's long after: no alarm.
    p.observe(0, task(10, 1));
    p.observe(1000, task(10, 1));
    p.observe(1500, task(15, 1));
    p.observe(1500 + CLAIM_WINDOW_MS, task(20, 2));
    assert!(p.incident().alerts.is_empty(), "{:?}", p.incident().alerts);
    // Another term while term 20 still commands (heard after the new one began): both
    // claim office.
    let thief = u64::MAX / 2;
    p.observe(1600 + CLAIM_WINDOW_MS, task(thief, 1));
    assert!(
        p.incident().alerts.is_empty(),
        "one term after another is no alarm yet"
    );
    p.observe(1700 + CLAIM_WINDOW_MS, task(20, 3));
    let a = p.incident().alerts[0].clone();
    assert!(
        a.active
            && a.priority == 1
            && matches!(&a.kind, AlertKind::TwoCoordinators { epochs } if epochs.len() == 2),
        "{a:?}"
    );
    // Term 20 heard no more: one term commands, back to normal.
    p.observe(2000 + 2 * CLAIM_WINDOW_MS, task(u64::MAX / 2, 2));
    assert!(!p.incident().alerts[0].active);
}

#[test]
fn a_suspended_identity_is_an_alarm_while_the_goals_in_force_say_so() {
    let mut p = picture();
    let ask = |by: &str| firefleet_protocol::msg::Sealed {
        key: format!("ff/tunnel-a/trust/suspend/commander-rossi/{by}"),
        payload: Some(r#"{"reason": ""}"#.into()),
        seal: firefleet_protocol::msg::Seal {
            cert: String::new(),
            at_ms: 1,
            sig: String::new(),
        },
    };
    for t in [1.0, 2.0] {
        p.observe(
            0,
            Event::Message(Payload::Goals(GoalsInForce {
                t,
                suspensions: vec![ask("coordinator")],
                ..Default::default()
            })),
        );
    }
    let alerts = p.incident().alerts;
    assert_eq!(alerts.len(), 1, "{alerts:?}");
    assert!(
        matches!(&alerts[0].kind, AlertKind::Suspended { identity } if identity == "commander-rossi")
            && alerts[0].active
    );
}

#[test]
fn a_new_term_while_the_coordinator_never_left_is_usurped_and_a_takeover_is_not() {
    use firefleet_protocol::msg::{Task, TaskKind};
    let task = |epoch| {
        Event::Message(Payload::Task(Task {
            unit: unit("ugv-1"),
            epoch,
            seq: 1,
            t: 1.0,
            kind: TaskKind::Standby,
        }))
    };
    let usurped = |p: &Picture| {
        p.incident()
            .alerts
            .iter()
            .any(|a| matches!(a.kind, AlertKind::Usurped { .. }))
    };
    let mut p = picture();
    p.observe(0, Event::Link(true));
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.observe(100, task(10));
    // The coordinator dies; a standby takes office after the lease, token first.
    p.observe(1000, Event::CoordinatorAlive(0, false));
    p.observe(4000, Event::CoordinatorAlive(0, true));
    p.observe(4100, task(20));
    assert!(!usurped(&p), "a takeover is no usurpation");
    // A term newer still, while that one's token never left: taken.
    p.observe(4100 + TAKEOVER_QUIET_MS, task(30));
    assert!(usurped(&p));
    // An older term heard again is no new one.
    let mut q = picture();
    q.observe(0, Event::CoordinatorAlive(0, true));
    q.observe(10_000, task(20));
    q.observe(10_100, task(10));
    assert!(!usurped(&q));
}

/// A standby that holds its token but stops hearing the coordinator (its goals fall
/// behind) or stops saying what it follows is an alarm until it follows again; one that
/// follows never is, at any time scale.
#[test]
fn a_standby_that_holds_its_token_but_does_not_follow_is_an_alarm_until_it_follows_again() {
    use firefleet_protocol::msg::StandbyHealth;
    let not_following = |p: &Picture| {
        p.incident()
            .alerts
            .into_iter()
            .filter(|a| a.active && a.kind == AlertKind::StandbyNotFollowing { rank: 1 })
            .map(|a| a.text)
            .collect::<Vec<_>>()
    };
    let mut p = picture();
    p.observe(0, Event::Link(true));
    p.observe(0, Event::CoordinatorAlive(0, true));
    p.observe(0, Event::StandbyAlive(1, true));
    // Goals every wall second, eight site seconds apart (x8); the standby hears each at
    // once and says so a second later. It follows.
    let goals = |t: f64| {
        Event::Message(Payload::Goals(GoalsInForce {
            t,
            ..Default::default()
        }))
    };
    let said = |goals_t: Option<f64>| {
        Event::Message(Payload::StandbyHealth(StandbyHealth {
            rank: 1,
            goals_t,
            tracks: 0,
        }))
    };
    for s in 0..10u64 {
        p.observe(s * 1000, goals(8.0 * s as f64));
        p.observe(s * 1000 + 900, said(Some(8.0 * s as f64)));
        p.delta(s * 1000 + 950);
    }
    assert!(not_following(&p).is_empty());
    // Cut off from the coordinator: it goes on saying the goals of t = 72 s.
    for s in 10..14u64 {
        p.observe(s * 1000, goals(8.0 * s as f64));
        p.observe(s * 1000 + 900, said(Some(72.0)));
        p.delta(s * 1000 + 950);
    }
    let text = not_following(&p);
    assert!(
        matches!(&text[..], [t] if t.contains("follows the goals in force of t=72.0 s")),
        "{text:?}"
    );
    assert_eq!(
        p.incident()
            .alerts
            .iter()
            .filter(|a| a.kind == AlertKind::StandbyNotFollowing { rank: 1 })
            .count(),
        1,
        "raised once while it lasts"
    );
    // Following again: back to normal.
    p.observe(14_000, goals(112.0));
    p.observe(14_900, said(Some(112.0)));
    p.delta(14_950);
    assert!(not_following(&p).is_empty());
    // Silent (hung): an alarm after 3 s; its token gone: the silence is moot.
    p.delta(18_000);
    assert!(not_following(&p)[0].contains("has said nothing"));
    p.observe(18_100, Event::StandbyAlive(1, false));
    assert!(not_following(&p).is_empty());
}
