//! Liveness, fires going out, bad input, and a restarted coordinator.

use super::*;
use crate::incident::events::TARGET_MOVED_M;
use firefleet_protocol::msg::{Approach, EPOCH_RANKS, Task, epoch_after};

#[test]
fn a_lost_unit_s_fire_is_reassigned_at_once() {
    let mut i = incident();
    i.report_at(&report("a", 60.0), 1.0).unwrap();
    let out = i.on_alive(&u("b"), false, 2.0).unwrap();
    let t = tasks(&out);
    assert_eq!(t.len(), 1, "{out:?}");
    assert_eq!(t[0].unit.as_str(), "a");
}

#[test]
fn a_silent_unit_is_lost_after_its_lease() {
    let mut i = incident();
    i.report_at(&report("a", 60.0), 1.0).unwrap();
    i.state_at(state("a", 10.0, None), 5.5).unwrap();
    assert!(tasks(&i.tick(4.0)).is_empty());
    let out = i.tick(6.0);
    assert_eq!(tasks(&out)[0].unit.as_str(), "a");
}

#[test]
fn extinguished_fire_is_out_and_the_unit_stands_by() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let (fire, out) = b_puts_out_the_first_fire(&mut i, &out);
    assert!(
        out.iter()
            .any(|o| matches!(o, Output::Fire(f) if f.id == fire && f.state == FireState::Out))
    );
    assert_eq!(
        kinds_for(&out, "b"),
        [TaskKind::Standby],
        "b stands by, nothing left to stage for"
    );
}

#[test]
fn a_replayed_report_of_a_fire_since_out_is_refused_and_does_not_reignite_it() {
    let mut i = incident();
    i.state_at(state("a", 30.0, None), 0.5).unwrap();
    let recorded = FlameReport {
        t: 1.0,
        observer: Pose2::new(30.0, -2.0, 0.0),
        ..report("a", 60.0)
    };
    let out = i.on_report(&recorded, 1.0).unwrap();
    let (fire, _) = b_puts_out_the_first_fire(&mut i, &out);
    i.report_at(&report("a", 100.0), 25.0).unwrap();
    for now in [26.0, 40.0] {
        let e = i.on_report(&recorded, now).unwrap_err();
        assert_eq!(e.field, "t", "{e}");
    }
    let e = i
        .on_state(
            UnitState {
                t: 19.0,
                ..state("b", 55.0, None)
            },
            21.0,
        )
        .unwrap_err();
    assert!(e.reason.contains("older than the sender's last"), "{e}");
    let track = i
        .fire_tracks(40.0)
        .into_iter()
        .find(|f| f.id == fire)
        .unwrap();
    assert_eq!(track.state, FireState::Out, "no re-ignition from a replay");
}

#[test]
fn bad_input_is_refused_and_changes_nothing() {
    let mut i = incident();
    assert!(
        i.report_at(&report("zz", 60.0), 1.0)
            .unwrap_err()
            .reason
            .contains("unknown unit")
    );
    let e = i.report_at(&report("a", 260.0), 1.0).unwrap_err();
    assert_eq!(e.field, "observations[0].position");
    assert!(i.fire_tracks(1.0).is_empty());
    assert!(i.state_at(state("a", -30.0, None), 1.0).is_err());
}

#[test]
fn a_restarted_coordinator_adopts_running_tasks_and_numbers_new_ones_above_them() {
    let mut i = incident();
    // Unit a still works on task 70000 of the coordinator that died, on a fire at 60.
    let held = TaskProgress {
        seq: 70_000,
        fire: FireId(3),
        phase: TaskPhase::Travelling,
        target: Point2::new(60.0, 1.0),
    };
    // Heard before the first decision, as a starting coordinator does.
    i.heed(&state("a", 10.0, Some(held)), 1.0);
    let epoch = i.take_office(2, 1.0);
    let out = i.state_at(state("a", 10.0, Some(held)), 1.0).unwrap();
    // a keeps its attack, given again in this coordinator's term: the deposed one may
    // command it no more.
    let again = tasks(&out);
    assert_eq!(again.len(), 1, "{out:?}");
    assert_eq!(again[0].unit.as_str(), "a");
    assert!(matches!(again[0].kind, TaskKind::Extinguish { target, .. } if target == held.target));
    assert_eq!(again[0].epoch, epoch);
    assert!(again[0].seq >= epoch && epoch > 70_000, "{again:?}");
    assert_eq!(epoch % EPOCH_RANKS, 2);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Adopt { unit, seq: 70000, .. } if unit == "a"
    )));
    // The fire, reported again, is a's: nobody else is sent.
    let out = i.report_at(&report("b", 60.0), 2.0).unwrap();
    assert!(tasks(&out).is_empty(), "{out:?}");
    let fires = i.fire_tracks(2.0);
    assert_eq!(fires.len(), 1);
    assert_eq!(fires[0].assigned, [u("a")]);
    // A new fire gets a new task, numbered above the adopted one.
    let out = i.report_at(&report("b", 150.0), 3.0).unwrap();
    assert!(!all_tasks(&out).is_empty());
    assert!(all_tasks(&out).iter().all(|t| t.seq > 70_000), "{out:?}");
    // a finishes the adopted task: its fire is out.
    let done = TaskProgress {
        seq: again[0].seq,
        phase: TaskPhase::Extinguished,
        ..held
    };
    let out = i.state_at(state("a", 45.0, Some(done)), 4.0).unwrap();
    assert!(
        out.iter()
            .any(|o| matches!(o, Output::Fire(f) if f.state == FireState::Out)),
        "{out:?}"
    );
}

#[test]
fn a_restarted_coordinator_recalls_recorded_fires_under_their_ids() {
    // The coordinator that died tracked two fires: f4, which a is working on, and f9,
    // which nobody works on or sees any more. A third track is corrupt.
    let track = |id: u32, x: f64, state: FireState, assigned: &[&str]| FireTrack {
        id: FireId(id),
        t: 40.0,
        position: Point2::new(x, 1.0),
        cov: [0.3, 0.0, 0.3],
        confidence: 0.95,
        state,
        assigned: assigned.iter().map(|s| u(s)).collect(),
        seen_by: vec![u("a"), u("b")],
        hrr_kw: Some(5000.0),
    };
    // Restored before any unit is heard from, as a starting coordinator does.
    let mut i = unheard();
    i.set_units_per_fire(1);
    let (_, refused) = i.restore(
        &[
            track(4, 60.0, FireState::Assigned, &["a"]),
            track(9, 150.0, FireState::Confirmed, &[]),
            track(12, 500.0, FireState::Confirmed, &[]),
            FireTrack {
                t: 1e9,
                state: FireState::Out,
                ..track(13, 100.0, FireState::Out, &[])
            },
        ],
        41.0,
    );
    assert_eq!(refused.len(), 2);
    assert!(refused[0].field.starts_with("fire f12"), "{:?}", refused[0]);
    assert_eq!(refused[1].field, "fire f13.t", "{:?}", refused[1]);
    assert!(
        refused[1]
            .reason
            .contains("ahead of the site clock (41.0 s)")
    );
    let ids: Vec<FireId> = i.fire_tracks(41.0).iter().map(|f| f.id).collect();
    assert_eq!(ids, [FireId(4), FireId(9)]);
    assert_eq!(
        i.decisions()
            .filter(|d| matches!(d.decision, Decision::Recall { .. }))
            .count(),
        2
    );

    // a says it works on f4: adopted on that track. b is free and is sent to f9, the
    // fire only the recording remembered.
    let held = TaskProgress {
        seq: 40_100,
        fire: FireId(4),
        phase: TaskPhase::Spraying,
        target: Point2::new(60.3, 1.1),
    };
    i.on_alive(&u("a"), true, 42.0).unwrap();
    i.state_at(state("a", 55.0, Some(held)), 42.0).unwrap();
    i.on_alive(&u("b"), true, 42.0).unwrap();
    let out = i.state_at(state("b", 100.0, None), 42.0).unwrap();
    assert_eq!(
        kinds_for(&out, "b"),
        [TaskKind::Extinguish {
            fire: FireId(9),
            target: Point2::new(150.0, 1.0),
            from: Approach::Either,
        }]
    );
    let tracks = i.fire_tracks(42.0);
    assert_eq!(tracks[0].assigned, [u("a")]);
    assert_eq!(tracks[0].state, FireState::Suppressing);
    assert_eq!(tracks[1].assigned, [u("b")]);
}

#[test]
fn a_task_the_coordinator_never_gave_is_superseded_and_forged_numbers_are_not_heeded() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let ours = tasks(&out)[0].clone();
    assert_eq!(ours.unit.as_str(), "b");
    // b took a task numbered above ours: somebody else's.
    let mut st = state("b", 40.0, None);
    st.task_seq = Some(ours.seq + 50);
    let out = i.state_at(st, 2.0).unwrap();
    let again = all_tasks(&out)
        .into_iter()
        .find(|t| t.unit.as_str() == "b")
        .expect("b's task given again");
    assert_eq!(again.kind, ours.kind);
    assert!(again.seq > ours.seq + 50, "{again:?}");
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Superseded { unit, foreign, .. } if unit == "b" && *foreign == ours.seq + 50
    )));
    // A number far ahead of the clock (a forged state) moves nothing, and numbering goes on.
    let mut st = state("a", 10.0, None);
    st.task_seq = Some(u64::MAX);
    st.task = Some(TaskProgress {
        seq: u64::MAX,
        fire: FireId(9),
        phase: TaskPhase::Travelling,
        target: Point2::new(10.0, 1.0),
    });
    i.state_at(st, 3.0).unwrap();
    let out = i.report_at(&report("a", 150.0), 4.0).unwrap();
    assert!(all_tasks(&out).iter().all(|t| t.seq < 1_000_000), "{out:?}");
}

#[test]
fn a_unit_heard_again_after_its_lease_is_back_in_play_and_its_old_task_not_adopted() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let first = tasks(&out)[0].clone();
    assert_eq!(first.unit.as_str(), "b");
    let TaskKind::Extinguish { fire, target, .. } = first.kind else {
        unreachable!()
    };
    // b falls silent past its lease (its token stays): lost, its fire goes to a.
    i.state_at(state("a", 10.0, None), 5.5).unwrap();
    let out = i.tick(6.5);
    assert_eq!(tasks(&out)[0].unit.as_str(), "a");
    // b is heard again, still reporting its old task: back in play, the old task not
    // taken over (a has the fire), no new fire made of it.
    let old = TaskProgress {
        seq: first.seq,
        fire,
        phase: TaskPhase::Travelling,
        target,
    };
    let out = i.state_at(state("b", 40.0, Some(old)), 7.0).unwrap();
    assert!(decided(
        &i,
        |d| matches!(d, Decision::Rejoined { unit, .. } if unit == "b")
    ));
    assert!(
        !decided(&i, |d| matches!(d, Decision::Adopt { .. })),
        "{out:?}"
    );
    assert_eq!(i.fire_tracks(7.0).len(), 1);
    assert!(
        i.status(7.0)
            .units
            .iter()
            .any(|u| u.unit.as_str() == "b" && u.alive),
        "b is usable again"
    );
    // It is given work again: a new fire nearer b than a goes to b.
    let out = i.report_at(&report("b", 45.0), 8.0).unwrap();
    assert!(
        tasks(&out).iter().any(|t| t.unit.as_str() == "b"),
        "{out:?}"
    );
}

#[test]
fn a_unit_whose_states_stop_echoing_its_task_is_lost_as_deaf_and_its_fire_reassigned() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let first = tasks(&out)[0].clone();
    assert_eq!(first.unit.as_str(), "b");
    // a hears its coordinator; b's states go on, still on the task before (none).
    let deaf_after = Policy::DEFAULT.deaf_after_s;
    let mut t = 1.0;
    while t <= 1.0 + deaf_after {
        i.state_at(echoing(&i, state("a", 10.0, None)), t).unwrap();
        i.state_at(state("b", 40.0, None), t).unwrap();
        assert!(
            !decided(&i, |d| matches!(d, Decision::Lost { .. })),
            "not before {deaf_after} s: at {t} s"
        );
        t += 0.5;
    }
    let out = i.state_at(state("b", 40.0, None), t).unwrap();
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Lost { unit, why: Loss::Deaf, fire: Some(_) } if unit == "b"
    )));
    assert_eq!(tasks(&out)[0].unit.as_str(), "a", "the fire goes to a");
    // b is kept asked: a standby, re-sent with every task.
    let ask = i.units[&u("b")].task.clone().expect("b is kept asked");
    assert_eq!(ask.kind, TaskKind::Standby);
    assert!(i.tasks().any(|k| k == &ask));
    assert!(
        i.status(t).units.iter().any(|s| s.unit.as_str() == "b"
            && !s.alive
            && s.lost.as_deref() == Some("its states have stopped echoing its task")),
        "named in status"
    );
    // Deaf states keep it out; the echo of what it was asked brings it back.
    i.state_at(state("b", 40.0, None), t + 5.0).unwrap();
    assert!(!i.units[&u("b")].alive);
    i.state_at(echoing(&i, state("b", 40.0, None)), t + 6.0)
        .unwrap();
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Rejoined { unit, was: Loss::Deaf, .. } if unit == "b"
    )));
    assert!(i.units[&u("b")].alive);
}

#[test]
fn units_heard_before_the_site_clock_jumped_are_not_lost_for_the_time_nobody_watched() {
    // A coordinator that took office before the site clock reached it heard a's and b's
    // tokens at its own t = 0; then the clock arrives, at 14 s of site time.
    let lost = |i: &Incident| {
        i.decisions()
            .filter(|d| matches!(d.decision, Decision::Lost { .. }))
            .count()
    };
    let heard = || {
        let mut i = unheard();
        for n in ["a", "b"] {
            i.on_alive(&u(n), true, 0.0).unwrap();
        }
        i
    };
    let mut without = heard();
    without.lapse(14.1);
    assert_eq!(lost(&without), 2, "both lost at once by the unwatched jump");
    let mut i = heard();
    i.clock_jumped(0.0, 14.0);
    i.lapse(14.1);
    assert_eq!(lost(&i), 0, "nobody is lost for the time nobody watched");
    // a speaks after the jump, b never does: b is lost one lease after it, a is not.
    i.state_at(state("a", 10.0, None), 14.5).unwrap();
    i.lapse(14.0 + 5.0 - 0.1);
    assert_eq!(lost(&i), 0);
    i.lapse(14.0 + 5.0 + 0.1);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Lost { unit, why: Loss::Silent, .. } if unit == "b"
    )));
    assert_eq!(lost(&i), 1, "only b");
}

#[test]
fn a_unit_echoing_an_older_task_while_new_ones_keep_coming_is_not_deaf() {
    // Re-tasked every 2 s, each echoed 1 s late: always one behind, never deaf.
    let mut i = incident();
    let mut t = 0.0;
    let mut echo = None;
    while t < 40.0 {
        i.state_at(echoing(&i, state("a", 10.0, None)), t).unwrap();
        let mut st = state("b", 40.0, None);
        st.task_seq = echo;
        i.state_at(st, t + 1.0).unwrap();
        let out = i.give(&u("b"), TaskKind::Standby, t + 1.0);
        let Output::Task(k) = out else { unreachable!() };
        echo = Some(k.seq);
        t += 2.0;
    }
    assert!(i.units[&u("b")].alive);
    assert!(!decided(&i, |d| matches!(d, Decision::Lost { .. })));
}

fn contradictions(i: &Incident) -> usize {
    i.decisions()
        .filter(|d| matches!(d.decision, Decision::Contradicted { .. }))
        .count()
}

/// From `t0`, every half second, a claims a fire at `claim` while b stands at `b_at`
/// looking up the tunnel at the spot, echoing its task, until b has contradicted the claim;
/// returns the time.
fn b_looks_at_a_s_claim(i: &mut Incident, claim: f64, b_at: f64, t0: f64) -> f64 {
    let before = contradictions(i);
    let mut t = t0;
    while contradictions(i) == before {
        t += 0.5;
        assert!(t < t0 + 30.0, "never contradicted");
        i.report_at(&report("a", claim), t).unwrap();
        i.state_at(echoing(i, state("b", b_at, None)), t).unwrap();
    }
    t
}

#[test]
fn a_unit_whose_fire_another_looks_at_and_never_sees_is_doubted_and_its_claims_disbelieved() {
    let mut i = incident();
    // a claims a fire at 100 m that is not there; b is sent, looks from 8 m short of it
    // for ten seconds and sees nothing. Nothing a has claimed was ever corroborated: one
    // look is enough.
    let out = i.report_at(&report("a", 100.0), 1.0).unwrap();
    assert_eq!(tasks(&out)[0].unit.as_str(), "b");
    let t = b_looks_at_a_s_claim(&mut i, 100.0, 92.0, 1.0);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Contradicted { fire: FireId(1), witness, by } if witness == "a" && by == "b"
    )));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Doubted { unit, record } if unit == "a" && record.contradicted == 1
    )));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Disbelieved { fire: FireId(1) }
    )));
    assert_eq!(
        i.units[&u("b")].task.as_ref().map(|k| k.kind),
        Some(TaskKind::Standby)
    );
    assert_eq!(i.fusion.get(FireId(1)).unwrap().state, FireState::Tentative);
    let status = i.status(t);
    let a = status
        .units
        .iter()
        .find(|s| s.unit.as_str() == "a")
        .unwrap();
    assert!(
        a.report_weight < 0.5,
        "named in status: {}",
        a.report_weight
    );
    // a's word alone no longer confirms a fire, however long it claims one; b's does.
    let confirmed = |i: &Incident| {
        i.decisions()
            .filter(|d| matches!(d.decision, Decision::Confirmed { .. }))
            .count()
    };
    let before = confirmed(&i);
    for k in 1..=20 {
        let out = i
            .report_at(&report("a", 30.0), t + 0.25 * f64::from(k))
            .unwrap();
        assert!(tasks(&out).is_empty(), "{out:?}");
    }
    assert_eq!(confirmed(&i), before);
    let out = i.report_at(&report("b", 30.0), t + 6.0).unwrap();
    assert_eq!(confirmed(&i), before + 1);
    assert_eq!(tasks(&out).len(), 1, "{out:?}");
}

#[test]
fn a_unit_whose_fires_others_have_seen_survives_one_flame_nobody_else_sees() {
    let mut i = incident();
    // a and b both see the fire at 60 m: a's word has been borne out once.
    corroborated(&mut i, &report("a", 60.0), &["b"], 1.0);
    let task = i.units[&u("b")].task.clone().unwrap();
    let done = TaskProgress {
        seq: task.seq,
        fire: FireId(1),
        phase: TaskPhase::Extinguished,
        target: Point2::new(60.0, 1.0),
    };
    i.state_at(echoing(&i, state("b", 55.0, Some(done))), 3.0)
        .unwrap();
    // a then claims a flame at 160 m that b, sent there, never sees (hidden behind a
    // parked car, say): contradicted, not doubted, and its next claim is still believed.
    let t = b_looks_at_a_s_claim(&mut i, 160.0, 152.0, 3.0);
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Contradicted { witness, by, .. } if witness == "a" && by == "b"
    )));
    assert!(
        !decided(&i, |d| matches!(d, Decision::Doubted { .. })),
        "one hidden flame does not make a liar of a unit others have borne out"
    );
    assert!(!i.fusion.witnesses().doubted(&u("a")));
    let mut confirmed = false;
    for k in 1..=12 {
        let out = i
            .report_at(&report("a", 30.0), t + 0.25 * f64::from(k))
            .unwrap();
        confirmed |= out.iter().any(
            |o| matches!(o, Output::Fire(f) if f.position.x == 30.0 && f.state != FireState::Tentative),
        );
    }
    assert!(
        confirmed,
        "a flame it keeps seeing is still confirmed on its word"
    );
}

#[test]
fn a_unit_that_took_a_newer_term_s_task_is_not_fought_over() {
    let mut i = incident();
    let epoch = i.take_office(0, 1.0);
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let ours = tasks(&out)[0].clone();
    assert_eq!(ours.epoch, epoch);
    // The unit now obeys a coordinator that took office above this one: this one does not
    // task it again (the unit would refuse), as it does a unit that took a forged task.
    let newer = epoch_after(ours.seq + 10, 1);
    let mut st = state(ours.unit.as_str(), 40.0, None);
    st.task_seq = Some(newer);
    st.epoch = Some(newer);
    let out = i.state_at(st, 2.0).unwrap();
    assert!(
        all_tasks(&out).iter().all(|t| t.unit != ours.unit),
        "{out:?}"
    );
    assert!(!decided(&i, |d| matches!(d, Decision::Superseded { .. })));
}

#[test]
fn a_claim_on_office_is_logged_and_one_on_its_own_key_names_the_stolen_identity() {
    let mut i = incident();
    i.take_office(0, 1.0);
    i.claimed(1, false, 2.0);
    i.claimed(0, true, 3.0);
    i.stand_down(1, 0, 4.0);
    let logged: Vec<_> = i.take_decisions().iter().map(|d| d.to_msg()).collect();
    let rival = logged
        .iter()
        .find(|d| d.text.contains("claims office"))
        .unwrap();
    assert!(
        rival.text.starts_with("coordinator:1 claims office"),
        "{}",
        rival.text
    );
    assert_eq!(rival.impostor, None);
    let stolen = logged
        .iter()
        .find(|d| d.text.starts_with("someone else"))
        .unwrap();
    assert_eq!(stolen.impostor.as_deref(), Some("coordinator"));
    assert!(
        logged
            .iter()
            .any(|d| d.text.starts_with("stepped down: coordinator holds office"))
    );
}

#[test]
fn a_unit_holding_an_older_term_s_task_is_brought_into_this_one_at_first_hearing() {
    let mut i = incident();
    let epoch = i.take_office(1, 30.0);
    // b stands by under the coordinator this one replaced (epoch 16, task 2000).
    let mut st = state("b", 40.0, None);
    st.task_seq = Some(2_000);
    st.epoch = Some(16);
    let out = i.state_at(st.clone(), 30.5).unwrap();
    let given = all_tasks(&out);
    assert_eq!(given.len(), 1, "{out:?}");
    assert_eq!(
        (given[0].unit.as_str(), given[0].epoch, &given[0].kind),
        ("b", epoch, &TaskKind::Standby)
    );
    // Once is enough: the next state (still echoing the old task) brings nothing new.
    let out = i.state_at(st, 30.7).unwrap();
    assert!(all_tasks(&out).is_empty(), "{out:?}");
}

#[test]
fn an_out_claim_while_another_attacker_still_sees_the_fire_frees_only_the_claimant() {
    let mut i = incident_with_backups();
    let out = corroborated(&mut i, &report("a", 60.0), &["b"], 1.0);
    let on_fire: Vec<Task> = tasks(&out).into_iter().cloned().collect();
    assert_eq!(on_fire.len(), 2, "both units attack: {out:?}");
    let progress = |task: &Task, phase| {
        let TaskKind::Extinguish { fire, target, .. } = task.kind else {
            unreachable!()
        };
        TaskProgress {
            seq: task.seq,
            fire,
            phase,
            target,
        }
    };
    let (a_task, b_task) = if on_fire[0].unit == u("a") {
        (&on_fire[0], &on_fire[1])
    } else {
        (&on_fire[1], &on_fire[0])
    };
    let fire = FireId(1);
    // a sprays and still sees the flame; b, beside it, says it is out.
    i.state_at(
        state("a", 50.0, Some(progress(a_task, TaskPhase::Spraying))),
        10.0,
    )
    .unwrap();
    i.report_at(&report("a", 60.0), 10.0).unwrap();
    let out = i
        .state_at(
            state("b", 52.0, Some(progress(b_task, TaskPhase::Extinguished))),
            10.2,
        )
        .unwrap();
    let b_next = kinds_for(&out, "b");
    assert_eq!(b_next[0], TaskKind::Standby, "{out:?}");
    assert!(
        !b_next
            .iter()
            .any(|k| matches!(k, TaskKind::Extinguish { .. })),
        "not sent back to a fire it says is out: {out:?}"
    );
    assert!(
        kinds_for(&out, "a").is_empty(),
        "a keeps its attack: {out:?}"
    );
    assert!(decided(&i, |d| matches!(
        d,
        Decision::OutDisputed { by, against, .. } if by == "b" && against == &[u("a")]
    )));
    let burning = i
        .fire_tracks(10.2)
        .into_iter()
        .find(|f| f.id == fire)
        .unwrap();
    assert_ne!(burning.state, FireState::Out);
    // a, which attacks it, sees it go out: now it is.
    let out = i
        .state_at(
            state("a", 50.0, Some(progress(a_task, TaskPhase::Extinguished))),
            14.0,
        )
        .unwrap();
    assert!(
        out.iter()
            .any(|o| matches!(o, Output::Fire(f) if f.id == fire && f.state == FireState::Out)),
        "{out:?}"
    );
}

#[test]
fn a_unit_sent_to_a_lone_claim_that_finds_nothing_there_contradicts_it_at_once() {
    let mut i = incident();
    let out = i.report_at(&report("a", 100.0), 1.0).unwrap();
    let task = tasks(&out)[0].clone();
    assert_eq!(task.unit.as_str(), "b");
    // b gets there, sees no flame (it reports none), and says so: the fire is out.
    let done = TaskProgress {
        seq: task.seq,
        fire: FireId(1),
        phase: TaskPhase::Extinguished,
        target: Point2::new(100.0, 1.0),
    };
    i.state_at(echoing(&i, state("b", 92.0, Some(done))), 30.0)
        .unwrap();
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Contradicted { fire: FireId(1), witness, by } if witness == "a" && by == "b"
    )));
    assert!(
        i.fusion.witnesses().doubted(&u("a")),
        "nothing a said was borne out: one look"
    );
    // a's next fake is not believed.
    for k in 1..=12 {
        let out = i
            .report_at(&report("a", 150.0), 30.0 + 0.25 * f64::from(k))
            .unwrap();
        assert!(tasks(&out).is_empty(), "{out:?}");
    }
}

#[test]
fn a_report_seen_from_where_the_unit_is_not_is_refused() {
    let mut i = incident();
    // a stands at 10 m (its state); a report "from" 85 m, 75 m off, is not a's.
    let forged = FlameReport {
        t: 1.0,
        observer: Pose2::new(85.0, -2.0, 0.0),
        ..report("a", 100.0)
    };
    let e = i.on_report(&forged, 1.0).unwrap_err();
    assert_eq!(e.field, "observer", "{e}");
    assert!(e.reason.contains("75 m from where the unit's state"), "{e}");
    assert!(i.fire_tracks(1.0).is_empty());
    // From where a is, a flame beyond its camera is not a's to report either.
    let far = FlameReport {
        observer: Pose2::new(14.0, -2.0, 0.0),
        ..forged
    };
    let e = i.on_report(&far, 1.0).unwrap_err();
    assert_eq!(e.field, "observations[0].position", "{e}");
    assert!(e.reason.contains("beyond the unit's sensors"), "{e}");
    // From where a is, or where it can have driven since its state, of a flame in its
    // camera's range, the report stands.
    let honest = FlameReport {
        observer: Pose2::new(14.0, -2.0, 0.0),
        ..report("a", 40.0)
    };
    assert!(i.on_report(&honest, 1.0).is_ok());
    assert_eq!(i.fire_tracks(1.0).len(), 1);
}

#[test]
fn a_ground_units_report_keeps_to_its_cameras_view() {
    let mut i = incident();
    // a stands at 10 m heading down the tunnel (its state). Its camera looking back up the
    // tunnel has no flame at 40 m in view: 64 fakes all round a unit were 64 flames in range.
    let back = FlameReport {
        t: 1.0,
        observer: Pose2::new(14.0, -2.0, std::f64::consts::PI),
        ..report("a", 40.0)
    };
    let e = i.on_report(&back, 1.0).unwrap_err();
    assert_eq!(e.field, "observations[0].position", "{e}");
    assert!(e.reason.contains("outside its field of view"), "{e}");
    assert!(i.fire_tracks(1.0).is_empty());
    // Its camera rides on the cannon, which pans 170 deg either side: looking up the tunnel
    // from the same place, it has the flame in view; or a flame beside it, 2 m off, at
    // any bearing (the estimate's spread near the camera).
    let ahead = FlameReport {
        observer: Pose2::new(14.0, -2.0, 0.0),
        ..back.clone()
    };
    assert!(i.on_report(&ahead, 1.0).is_ok());
    let beside = FlameReport {
        t: 1.25,
        observations: vec![FlameObservation {
            position: Point2::new(14.0, 0.0),
            ..back.observations[0]
        }],
        ..back.clone()
    };
    assert!(i.on_report(&beside, 1.25).is_ok());
    // A camera fixed to the body looks where the body heads: b's cannot look back a second
    // after its state said it headed down the tunnel.
    if let Some(v) = i.units.get_mut(&u("b")) {
        v.mobility = Mobility::Ground(GroundBody {
            camera_look_rad: 0.0,
            ..GroundBody::of(&GROUND)
        });
    }
    let turned = FlameReport {
        unit: u("b"),
        t: 1.0,
        observer: Pose2::new(40.0, -2.0, std::f64::consts::PI),
        ..report("b", 20.0)
    };
    let e = i.on_report(&turned, 1.0).unwrap_err();
    assert_eq!(e.field, "observer.yaw", "{e}");
}

#[test]
fn a_coordinator_after_another_numbers_its_fires_where_that_one_could_not_have() {
    // The first coordinator of a site numbers from 1.
    let mut first = incident();
    first.take_office(0, 0.5);
    first.report_at(&report("a", 60.0), 1.0).unwrap();
    assert_eq!(first.fire_tracks(1.0)[0].id, FireId(1));
    // One restarted at 130 s with nothing recording, whose units held tasks: its first
    // fire is not f1 (a console or recording would take it for the first one's f1), nor
    // any number the first could have given in its 130 s at ten a second.
    let mut next = incident();
    let mut st = state("a", 10.0, None);
    st.task_seq = Some(2_000);
    st.epoch = Some(16);
    next.heed(&st, 130.0);
    next.take_office(1, 130.0);
    next.report_at(&report("b", 150.0), 131.0).unwrap();
    let ids: Vec<FireId> = next.fire_tracks(131.0).iter().map(|f| f.id).collect();
    assert_eq!(ids, [FireId(1301)]);
    assert_eq!(fire_id_floor(130.0), 1300);
    // On a real site's Unix clock the ids wrap around u32 rather than overflow.
    assert!(fire_id_floor(1.8e9) < u32::MAX);
}

/// b, far from the fire a alone claims, is sent there and says it is out a tenth of a
/// second later (a stolen key's forged "out"): no look, so nothing against a. Said once it
/// can have come within its camera's range, it is a look that found nothing.
#[test]
fn an_out_sooner_than_the_unit_can_have_looked_says_nothing_against_the_claimant() {
    for (after, counted) in [(0.1, false), (120.0, true)] {
        let mut i = incident();
        // a saw the flame from 40 m; b stands 35 m from it, beyond its camera's 30 m.
        i.state_at(state("a", 60.0, None), 0.5).unwrap();
        i.state_at(state("b", 135.0, None), 0.5).unwrap();
        let claim = FlameReport {
            observer: Pose2::new(60.0, -2.0, 0.0),
            ..report("a", 100.0)
        };
        let out = i.report_at(&claim, 1.0).unwrap();
        // b is the one sent: a, its claimant, is not sent to verify itself here.
        let Some(task) = all_tasks(&out)
            .into_iter()
            .find(|k| k.unit.as_str() == "b" && matches!(k.kind, TaskKind::Extinguish { .. }))
            .cloned()
        else {
            panic!("b was not sent: {out:?}")
        };
        let TaskKind::Extinguish { fire, target, .. } = task.kind else {
            unreachable!()
        };
        let done = TaskProgress {
            seq: task.seq,
            fire,
            phase: TaskPhase::Extinguished,
            target,
        };
        i.state_at(echoing(&i, state("b", 135.0, Some(done))), 1.0 + after)
            .unwrap();
        assert_eq!(contradictions(&i) == 1, counted, "out after {after} s");
    }
}

#[test]
fn a_fire_whose_estimate_moves_is_given_again_to_its_attacker_at_its_spot_now() {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let first = tasks(&out)[0].clone();
    let TaskKind::Extinguish { fire, target, .. } = first.kind else {
        panic!("not a fire task: {first:?}")
    };
    let attacker = first.unit.as_str().to_owned();
    // Reports a metre further on each time pull the estimate along.
    let mut again = Vec::new();
    for (k, x) in [61.0, 62.0, 63.0, 64.0, 65.0, 66.0].into_iter().enumerate() {
        let out = i.report_at(&report("a", x), 2.0 + k as f64 * 0.2).unwrap();
        let at = i.fusion.get(fire).unwrap().position();
        let sent: Vec<_> = tasks(&out)
            .into_iter()
            .filter(|t| t.unit.as_str() == attacker)
            .collect();
        let last_target = again.last().copied().unwrap_or(target);
        if at.dist(last_target) > TARGET_MOVED_M {
            assert_eq!(
                sent.len(),
                1,
                "estimate at {at:?}, task still at {last_target:?}: {out:?}"
            );
            let TaskKind::Extinguish {
                fire: f,
                target: to,
                ..
            } = sent[0].kind
            else {
                panic!("not a fire task: {:?}", sent[0])
            };
            assert_eq!(f, fire);
            assert!(to.dist(at) < 1e-9, "sent to {to:?}, the fire at {at:?}");
            again.push(to);
        } else {
            assert!(
                sent.is_empty(),
                "sent again for a move within {TARGET_MOVED_M} m: {sent:?}"
            );
        }
    }
    assert!(
        !again.is_empty(),
        "the estimate never moved {TARGET_MOVED_M} m"
    );
}

#[test]
fn an_attacker_that_sees_its_fire_where_it_was_sent_is_not_sent_again_when_others_pull_the_estimate()
 {
    let mut i = incident();
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let first = tasks(&out)[0].clone();
    let TaskKind::Extinguish { fire, target, .. } = first.kind else {
        panic!("not a fire task: {first:?}")
    };
    assert_eq!(first.unit.as_str(), "b", "the nearest attacks");
    // b sees the flame where it was sent, from afar (a loose estimate); a's tight reports,
    // a metre further on each time, pull the fused estimate along.
    let b_sees = |x: f64| {
        let mut r = report("b", x);
        r.observations[0].cov = [2.0, 0.0, 2.0];
        r
    };
    let sent_to_b = |out: &[Output]| kinds_for(out, "b");
    let mut t = 2.0;
    for x in [61.0, 62.0, 63.0, 64.0, 65.0] {
        let mut out = i.report_at(&b_sees(target.x), t).unwrap();
        out.extend(i.report_at(&report("a", x), t + 0.1).unwrap());
        assert_eq!(sent_to_b(&out), [], "b sees its fire at its spot");
        t += 0.2;
    }
    let at = i.fusion.get(fire).unwrap().position();
    assert!(
        at.dist(target) > TARGET_MOVED_M,
        "the estimate moved only to {at:?}"
    );
    // b looks away: the next pull sends it to the fire as the others see it.
    let out = i.report_at(&report("a", 65.5), t + 1.5).unwrap();
    let again = sent_to_b(&out);
    let [
        TaskKind::Extinguish {
            fire: f,
            target: to,
            ..
        },
    ] = again[..]
    else {
        panic!("b not sent again once it no longer sees the fire: {out:?}")
    };
    assert_eq!(f, fire);
    assert!(to.dist(target) > TARGET_MOVED_M, "sent to {to:?}");
}
