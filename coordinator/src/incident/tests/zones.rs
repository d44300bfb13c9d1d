//! Commanders' zone goals.

use super::*;
use firefleet_protocol::msg::{Refusal, RefusalReason};

#[test]
fn no_fire_in_a_keep_out_zone_is_attacked_and_no_unit_crosses_it() {
    let mut i = zoned();
    let (ack, _) = submit(&mut i, goal("g1", "z1", GoalKind::KeepOut, 0, None), 0.5);
    assert!(ack.accepted, "{ack:?}");
    assert!(tasks(&i.report_at(&report("a", 60.0), 1.0).unwrap()).is_empty());
    // Both units are on the near side: the fire beyond the zone gets nobody.
    assert!(tasks(&i.report_at(&report("a", 150.0), 2.0).unwrap()).is_empty());
    let out = i.clear_goals(
        &ZoneId::new("z1").unwrap(),
        &CommanderId::new("ic-1").unwrap(),
        3.0,
        None,
    );
    assert_eq!(tasks(&out).len(), 2, "cleared: both fires are attacked");
}

#[test]
fn fires_a_keep_out_cuts_off_are_stranded_naming_the_goal_and_its_issuer() {
    let mut i = zoned();
    i.report_at(&report("a", 60.0), 1.0).unwrap();
    i.report_at(&report("a", 150.0), 1.0).unwrap();
    assert!(i.stranded().is_empty(), "nothing barred");
    submit(&mut i, goal("g1", "z1", GoalKind::KeepOut, 0, None), 2.0);
    let stranded: Vec<(FireId, String, bool)> = i
        .stranded()
        .into_iter()
        .map(|s| {
            assert_eq!(s.issued_by, Some(CommanderId::new("ic-1").unwrap()));
            (s.fire, s.goal, s.inside)
        })
        .collect();
    // Fire 1 burns inside the zone; fire 2 beyond it, with both units on the near side.
    assert_eq!(
        stranded,
        [
            (FireId(1), "g1".into(), true),
            (FireId(2), "g1".into(), false)
        ]
    );
    assert_eq!(i.status(2.0).stranded.len(), 2);
    assert_eq!(
        i.goals_in_force(2.0).stranded.len(),
        2,
        "what consoles are told"
    );
    // A unit beyond the zone can reach fire 2: only fire 1 is stranded.
    i.state_at(state("b", 180.0, None), 3.0).unwrap();
    let left: Vec<FireId> = i.stranded().into_iter().map(|s| s.fire).collect();
    assert_eq!(left, [FireId(1)]);
}

#[test]
fn a_monitor_goal_withdraws_the_unit_and_leaves_the_fire_burning() {
    let mut i = zoned();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    assert_eq!(tasks(&out)[0].unit.as_str(), "b");
    let (ack, out) = submit(&mut i, goal("g1", "z1", GoalKind::Monitor, 0, None), 2.0);
    assert!(ack.accepted);
    let b = kinds_for(&out, "b");
    assert_eq!(b[0], TaskKind::Standby, "{out:?}");
    // Free again, b searches on past the fire left burning.
    assert!(
        b[1..].iter().all(|k| matches!(k, TaskKind::Search { .. })),
        "{out:?}"
    );
    assert!(tasks(&out).is_empty(), "nobody else is sent: {out:?}");
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Withdraw { unit, fire: F1, goal, .. } if unit == "b" && goal == "g1"
    )));
    assert!(tasks(&i.tick(3.0)).is_empty());
}

#[test]
fn evacuate_sends_units_out_of_the_zone_now() {
    let mut i = zoned();
    i.state_at(state("b", 55.0, None), 0.5).unwrap();
    let (_, out) = submit(&mut i, goal("g1", "z1", GoalKind::Evacuate, 0, None), 1.0);
    let b = kinds_for(&out, "b");
    assert_eq!(
        b,
        [TaskKind::Cruise {
            goal: Point2::new(45.0, -2.0)
        }],
        "{out:?}"
    );
    // The order stands: no repeat on the next tick.
    assert!(all_tasks(&i.tick(2.0)).is_empty());
}

#[test]
fn a_priority_zone_s_fire_is_served_first() {
    let mut i = zoned();
    i.on_alive(&u("b"), false, 0.5).unwrap();
    submit(&mut i, goal("g1", "z2", GoalKind::Extinguish, 2, None), 0.6);
    let mut r = report("a", 60.0);
    r.observations.push(FlameObservation {
        position: Point2::new(170.0, 1.0),
        cov: [0.2, 0.0, 0.2],
        confidence: 0.9,
        hrr_kw: None,
    });
    let out = i.report_at(&r, 1.0).unwrap();
    let t = tasks(&out);
    assert_eq!(t.len(), 1);
    assert!(
        matches!(t[0].kind, TaskKind::Extinguish { target, .. } if target.x > 150.0),
        "{t:?}"
    );
}

#[test]
fn under_contain_reserves_hold_the_line() {
    let mut i = zoned();
    submit(
        &mut i,
        goal("g1", "z2", GoalKind::Contain, 0, Some(110.0)),
        0.5,
    );
    let out = corroborated(&mut i, &report("a", 150.0), &["b"], 1.0);
    let a = kinds_for(&out, "a");
    assert_eq!(
        a,
        [TaskKind::Cruise {
            goal: Point2::new(110.0, -2.5)
        }],
        "{out:?}"
    );
}

#[test]
fn a_contain_goal_on_a_zone_without_fire_says_what_it_will_do() {
    let mut i = zoned();
    let (ack, _) = submit(
        &mut i,
        goal("g1", "z2", GoalKind::Contain, 0, Some(110.0)),
        0.5,
    );
    assert!(ack.accepted, "{ack:?}");
    assert!(
        ack.reason.contains("no fire in zone z2 yet") && ack.reason.contains("110.0 m"),
        "{ack:?}"
    );
    i.report_at(&report("a", 150.0), 1.0).unwrap();
    let (ack, _) = submit(
        &mut i,
        goal("g1", "z2", GoalKind::Contain, 0, Some(120.0)),
        2.0,
    );
    assert!(!ack.reason.contains("no fire"), "{ack:?}");
}

#[test]
fn a_rejected_goal_changes_nothing() {
    let mut i = zoned();
    let (ack, out) = submit(&mut i, goal("g1", "z9", GoalKind::KeepOut, 0, None), 0.5);
    assert!(!ack.accepted && ack.reason.contains("unknown zone 'z9'"));
    assert!(out.is_empty());
    assert_eq!(i.goals().count(), 0);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Goal { accepted: false, reason, .. } if reason.starts_with("unknown zone 'z9'")
    )));
    assert_eq!(
        tasks(&i.report_at(&report("a", 60.0), 1.0).unwrap()).len(),
        1
    );
}

#[test]
fn a_unit_s_refusal_is_logged_and_its_task_withdrawn() {
    let mut i = zoned();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let task = tasks(&out)[0].clone();
    assert_eq!(task.unit.as_str(), "b");
    let TaskKind::Extinguish { fire, .. } = task.kind else {
        unreachable!()
    };
    // b holds a barred space the coordinator does not (its goal came by another way).
    let mut st = state("b", 40.0, None);
    st.refused = Some(Refusal {
        seq: task.seq,
        reason: RefusalReason::DestinationBarred,
        goal: "ko".into(),
        zone: ZoneId::new("z1").unwrap(),
    });
    let out = i.state_at(st.clone(), 2.0).unwrap();
    assert_eq!(kinds_for(&out, "b")[0], TaskKind::Standby, "{out:?}");
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Refused { unit, refusal } if unit == "b" && refusal.seq == task.seq
    )));
    let said = format!(
        "b refused task {}: its destination is in zone z1, barred by goal 'ko'",
        task.seq
    );
    let text: Vec<String> = i.take_decisions().iter().map(|d| d.to_msg().text).collect();
    assert!(text.contains(&said), "{text:?}");
    // The fire goes to a; b is not sent to it again, and its refusal is not logged twice.
    assert!(
        tasks(&out).iter().all(|t| t.unit.as_str() != "b"),
        "{out:?}"
    );
    let again = i.state_at(st, 3.0).unwrap();
    assert!(
        !kinds_for(&again, "b")
            .iter()
            .any(|k| matches!(k, TaskKind::Extinguish { fire: f, .. } if *f == fire)),
        "{again:?}"
    );
    assert!(
        !i.take_decisions()
            .iter()
            .any(|d| matches!(d.decision, Decision::Refused { .. }))
    );
}

#[test]
fn a_refusal_for_a_goal_since_lifted_is_late_news_and_the_fire_is_given_again_at_once() {
    let mut i = zoned();
    submit(&mut i, goal("ko", "z1", GoalKind::KeepOut, 0, None), 0.5);
    assert!(tasks(&i.report_at(&report("a", 60.0), 1.0).unwrap()).is_empty());
    let out = i.clear_goals(
        &ZoneId::new("z1").unwrap(),
        &CommanderId::new("ic-1").unwrap(),
        2.0,
        None,
    );
    let task = tasks(&out)[0].clone();
    // The unit has not heard of the lift yet and refuses.
    let mut st = echoing(&i, state(task.unit.as_str(), 40.0, None));
    st.refused = Some(Refusal {
        seq: task.seq,
        reason: RefusalReason::DestinationBarred,
        goal: "ko".into(),
        zone: ZoneId::new("z1").unwrap(),
    });
    let mut out = i.state_at(st, 2.5).unwrap();
    out.extend(i.tick(2.7));
    assert!(
        out.iter().any(|o| matches!(o, Output::Task(t) if t.unit == task.unit && matches!(t.kind, TaskKind::Extinguish { .. }))),
        "sent again, not held back a minute: {out:?}"
    );
}

#[test]
fn a_preview_says_what_the_goal_then_does_and_changes_nothing() {
    let mut i = incident();
    let end = TUNNEL.end().m();
    i.goals = Goals::new(&[zone("w", 0.0, 100.0), zone("e", 100.0, end)], &[]);
    i.state_at(state("b", 55.0, None), 0.5).unwrap();
    submit(&mut i, goal("k1", "e", GoalKind::KeepOut, 0, None), 1.0);
    let (zone_w, evacuate) = goal("v1", "w", GoalKind::Evacuate, 0, None);
    let by = CommanderId::new("ic-1").unwrap();
    let before = i.goals_revision();
    let preview = i.preview(&zone_w, &by, evacuate.clone(), 1.2);
    assert!(preview.ack.accepted, "{preview:?}");
    assert_eq!(i.goals_revision(), before, "a preview changes no goal");
    assert!(i.trapped().is_empty());
    // Taken for real, it traps what the preview said.
    i.on_goal(&zone_w, &by, evacuate, 1.2, None);
    i.tick(1.4);
    assert_eq!(preview.trapped, i.trapped());
    assert_eq!(preview.trapped.len(), 2, "{preview:?}");
    // A goal that would be refused is previewed as refused, with nothing it would do.
    let (_, bad) = goal("x", "w", GoalKind::Monitor, 0, None);
    let refused = i.preview(&ZoneId::new("e").unwrap(), &by, bad, 2.0);
    assert!(
        !refused.ack.accepted && refused.trapped.is_empty(),
        "{refused:?}"
    );
}

#[test]
fn a_unit_no_goal_leaves_a_way_out_is_trapped_said_once_and_freed_when_cleared() {
    let mut i = incident();
    let end = TUNNEL.end().m();
    i.goals = Goals::new(&[zone("w", 0.0, 100.0), zone("e", 100.0, end)], &[]);
    i.state_at(state("b", 55.0, None), 0.5).unwrap();
    submit(&mut i, goal("k1", "e", GoalKind::KeepOut, 0, None), 1.0);
    submit(&mut i, goal("v1", "w", GoalKind::Evacuate, 0, None), 1.2);
    for t in [1.4, 1.6, 1.8, 2.0] {
        i.state_at(state("b", 55.0, None), t).unwrap();
        i.tick(t);
    }
    let trapped = i.trapped();
    assert_eq!(trapped.len(), 2, "a at 10 m and b at 55 m: {trapped:?}");
    assert!(
        trapped
            .iter()
            .all(|x| x.goal == "v1" && x.zone.as_str() == "w" && x.issued_by.is_some())
    );
    assert_eq!(i.goals_in_force(2.0).trapped, trapped);
    let said = i
        .decisions()
        .filter(|d| matches!(&d.decision, Decision::Trapped { unit, .. } if unit == "b"))
        .count();
    assert_eq!(
        said, 1,
        "said once while it lasts, not at every enforcement"
    );
    // The evacuate cleared: nothing traps them.
    i.clear_goals(
        &ZoneId::new("w").unwrap(),
        &CommanderId::new("ic-1").unwrap(),
        3.0,
        None,
    );
    assert!(i.trapped().is_empty());
}

/// A keep-out that closes the way out an evacuate just gave (the CI attack's stolen
/// incident commander set one on each zone 0.1 s apart): the trapped unit holds where it
/// is, and its task into the newly barred zone is taken back rather than re-sent.
#[test]
fn a_way_out_closed_by_the_next_goal_is_taken_back() {
    let mut i = incident();
    let end = TUNNEL.end().m();
    i.goals = Goals::new(&[zone("w", 0.0, 100.0), zone("e", 100.0, end)], &[]);
    i.state_at(state("b", 55.0, None), 0.5).unwrap();
    let (_, out) = submit(&mut i, goal("k1", "w", GoalKind::KeepOut, 0, None), 1.0);
    let [TaskKind::Cruise { goal: way_out }] = kinds_for(&out, "b")[..] else {
        panic!("b is sent out of w: {out:?}")
    };
    assert!(TUNNEL.chainage(way_out).m() > 100.0, "into e: {way_out:?}");
    let (_, out) = submit(&mut i, goal("k2", "e", GoalKind::KeepOut, 0, None), 1.1);
    assert_eq!(kinds_for(&out, "b"), [TaskKind::Standby], "{out:?}");
    assert!(i.trapped().iter().any(|x| x.unit.as_str() == "b"));
    // Said once: the next enforcement leaves the standing order be.
    assert!(kinds_for(&i.tick(1.5), "b").is_empty());
}

/// The last word before a solve's tasks go out: a task into barred space that a planner
/// left standing (put there by hand here, as a bug would) is taken back and counted.
#[test]
fn a_task_left_standing_into_barred_space_is_taken_back_and_counted() {
    let mut i = zoned();
    submit(&mut i, goal("k", "z1", GoalKind::KeepOut, 0, None), 0.5);
    let inside = TUNNEL.point_at(Chainage::new(75.0), 0.0);
    let kind = TaskKind::Cruise { goal: inside };
    let task = match i.give(&u("b"), kind, 1.0) {
        Output::Task(task) => task,
        other => panic!("{other:?}"),
    };
    assert_eq!(task.kind, kind);
    let out = i.recall_from_barred(1.0);
    assert_eq!(kinds_for(&out, "b"), [TaskKind::Standby], "{out:?}");
    assert_eq!(i.inconsistencies(), 1);
    assert!(i.recall_from_barred(1.5).is_empty(), "taken back once");
}

#[test]
fn a_clear_says_who_cleared_and_one_that_lifts_nothing_says_whose_goal_holds() {
    let mut i = zoned();
    i.goals = Goals::new(
        &[zone("z1", 50.0, 100.0)],
        &[firefleet_model::scenario::CommanderSpec {
            id: CommanderId::new("ic-1").unwrap(),
            rank: firefleet_model::scenario::Rank::Incident,
        }],
    );
    submit(&mut i, goal("k1", "z1", GoalKind::KeepOut, 0, None), 1.0);
    let z1 = ZoneId::new("z1").unwrap();
    i.clear_goals(&z1, &CommanderId::new("rossi").unwrap(), 2.0, None);
    let held = i
        .decisions()
        .map(|d| d.decision.to_string())
        .find(|d| d.contains("lifted nothing"))
        .expect("a clear that lifted nothing said nothing");
    assert!(
        held.contains("goal 'k1' of incident commander 'ic-1' holds"),
        "{held}"
    );
    i.clear_goals(&z1, &CommanderId::new("ic-1").unwrap(), 3.0, None);
    assert!(
        i.decisions()
            .any(|d| d.decision.to_string() == "goal 'k1' on zone z1 cleared by ic-1")
    );
}

#[test]
fn a_suspended_unit_is_heard_no_more_and_the_suspension_is_told_with_the_goals() {
    use firefleet_protocol::msg::{Seal, Sealed};
    let mut i = incident();
    let ask = |by: &str| Sealed {
        key: format!("ff/s/trust/suspend/unit-b/{by}"),
        payload: Some(r#"{"reason": ""}"#.into()),
        seal: Seal {
            cert: String::new(),
            at_ms: 1,
            sig: String::new(),
        },
    };
    let before = i.goals_revision();
    let (now, _) = i.suspend("unit-b", "commander-rossi", ask("commander-rossi"), 1.0);
    assert!(!now, "one commander alone");
    assert!(i.state_at(state("b", 55.0, None), 1.5).is_ok());
    let (now, _) = i.suspend("unit-b", "coordinator", ask("coordinator"), 2.0);
    assert!(now);
    assert!(i.goals_revision() > before, "told and journaled");
    assert_eq!(i.goals_in_force(2.0).suspensions.len(), 2);
    let e = i.state_at(state("b", 56.0, None), 2.5).unwrap_err();
    assert!(e.to_string().contains("unit-b is suspended"), "{e}");
    assert_eq!(i.status(2.5).suspended, ["unit-b"]);
}

#[test]
fn a_suspended_commander_s_goals_lapse_and_are_refused_and_previewed_as_refused() {
    use firefleet_protocol::msg::{Seal, Sealed};
    let mut i = zoned();
    submit(&mut i, goal("k1", "z1", GoalKind::KeepOut, 0, None), 1.0);
    let ask = Sealed {
        key: "ff/s/trust/suspend/commander-ic-1/coordinator".into(),
        payload: Some(r#"{"reason": ""}"#.into()),
        seal: Seal {
            cert: String::new(),
            at_ms: 1,
            sig: String::new(),
        },
    };
    let (now, _) = i.suspend("commander-ic-1", "coordinator", ask, 2.0);
    assert!(now);
    assert_eq!(i.goals().count(), 0, "its goals lapse at once");
    let (zone, g) = goal("k2", "z2", GoalKind::Monitor, 0, None);
    let by = CommanderId::new("ic-1").unwrap();
    let preview = i.preview(&zone, &by, g.clone(), 3.0);
    assert!(!preview.ack.accepted && preview.ack.reason.contains("suspended"));
    let (ack, _) = i.on_goal(&zone, &by, g, 3.0, None);
    assert!(!ack.accepted && ack.reason.contains("suspended"), "{ack:?}");
}
