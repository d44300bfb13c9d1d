use super::*;
use firefleet_protocol::msg::{GoalKind, TaskKind, TaskProgress};
use firefleet_protocol::testing::ground_state;

use firefleet_model::{FireId, scenario::Zone};

fn site() -> Scenario {
    let mut s = Scenario::straight(300.0).ground("u1", 5.0, -2.5).build();
    s.zones = vec![Zone {
        id: z("deep"),
        start_m: Chainage::new(100.0),
        end_m: Chainage::new(200.0),
    }];
    s
}

fn z(id: &str) -> ZoneId {
    ZoneId::new(id).unwrap()
}

fn u() -> UnitId {
    UnitId::new("u1").unwrap()
}

fn state(x: f64, t: f64, task: Option<TaskProgress>) -> Event {
    state_of(&u(), x, t, task)
}

/// A ground unit's state at `x` along the tunnel, 2.5 m right of the axis.
pub(super) fn state_of(unit: &UnitId, x: f64, t: f64, task: Option<TaskProgress>) -> Event {
    Event::State(UnitState {
        t,
        task,
        ..ground_state(unit.as_str(), x, -2.5)
    })
}

fn goal(kind: GoalKind) -> Event {
    Event::Goal {
        key_zone: z("deep"),
        by: CommanderId::new("ic").unwrap(),
        goal: ZoneGoal {
            id: "g".into(),
            zone: z("deep"),
            goal: kind,
            priority: 0,
            before_m: None,
            expires_s: None,
            issued_by: Some(CommanderId::new("ic").unwrap()),
            rail_allowed: false,
        },
    }
}

/// Task `seq` sending u1 to cruise to `x`, 2.5 m right of the axis.
fn cruise(seq: u64, x: f64) -> Event {
    Event::Task(Task {
        unit: u(),
        epoch: 0,
        seq,
        t: 0.0,
        kind: TaskKind::Cruise {
            goal: Point2::new(x, -2.5),
        },
    })
}

/// Feeds `events` (each at its time) and returns the violations.
/// Coordinator task `seq` of `epoch` to [`u`]: stand by.
fn standby(epoch: u64, seq: u64) -> Event {
    Event::Task(Task {
        unit: u(),
        epoch,
        seq,
        t: 0.0,
        kind: TaskKind::Standby,
    })
}

fn check(events: Vec<(f64, Event)>) -> Vec<Violation> {
    let mut inv = Invariants::new(&site());
    for (t, e) in events {
        inv.observe(t, e);
    }
    inv.violations().to_vec()
}

#[test]
fn a_unit_that_leaves_within_its_grace_breaks_nothing() {
    // At 120 m when the goal comes: 20 m from the edge, so 10 + 2 * 20 / 1.5 = 36.7 s.
    let v = check(vec![
        (0.0, state(120.0, 0.0, None)),
        (1.0, goal(GoalKind::KeepOut)),
        (30.0, state(101.0, 30.0, None)),
        (36.0, state(95.0, 36.0, None)),
    ]);
    assert!(v.is_empty(), "{v:?}");
}

#[test]
fn a_unit_still_inside_after_its_grace_is_reported_once_with_how_long() {
    let v = check(vec![
        (0.0, state(120.0, 0.0, None)),
        (1.0, goal(GoalKind::Evacuate)),
        (40.0, state(110.0, 40.0, None)),
        (50.0, state(105.0, 50.0, None)),
        (60.0, state(95.0, 60.0, None)),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    let Violation::InsideBarred {
        t, until, deadline, ..
    } = &v[0]
    else {
        panic!("{v:?}")
    };
    assert_eq!((*t, *until), (40.0, 50.0));
    assert!((deadline - (1.0 + 10.0 + 2.0 * 20.0 / 1.5)).abs() < 1e-9);
}

#[test]
fn entering_after_the_time_to_hear_the_goal_is_a_violation_and_a_clear_ends_it() {
    let v = check(vec![
        (0.0, state(90.0, 0.0, None)),
        (1.0, goal(GoalKind::KeepOut)),
        // Braking at the edge as the goal is heard: not yet a violation.
        (5.0, state(100.5, 5.0, None)),
        (6.0, state(98.0, 6.0, None)),
        (15.0, state(101.0, 15.0, None)),
        (
            16.0,
            Event::Clear {
                zone: z("deep"),
                by: CommanderId::new("ic").unwrap(),
            },
        ),
        (17.0, state(110.0, 17.0, None)),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(matches!(
        v[0],
        Violation::InsideBarred {
            t: 15.0,
            until: 15.0,
            deadline: 11.0,
            ..
        }
    ));
}

#[test]
fn a_zone_at_the_portal_is_left_by_its_far_end_and_a_trapped_unit_breaks_nothing() {
    let mut s = site();
    s.zones[0].start_m = Chainage::ZERO;
    let mut inv = Invariants::new(&s);
    // At 20 m in a zone from the portal to 200 m: 180 m to its far end, 10 + 2 * 180 /
    // 1.5 = 250 s.
    inv.observe(0.0, state(20.0, 0.0, None));
    inv.observe(1.0, goal(GoalKind::Evacuate));
    inv.observe(200.0, state(150.0, 200.0, None));
    assert!(inv.violations().is_empty(), "{:?}", inv.violations());
    inv.observe(252.0, state(199.0, 252.0, None));
    assert_eq!(inv.violations().len(), 1);

    s.zones[0].end_m = Chainage::new(300.0);
    let mut inv = Invariants::new(&s);
    inv.observe(0.0, state(20.0, 0.0, None));
    inv.observe(1.0, goal(GoalKind::Evacuate));
    inv.observe(900.0, state(20.0, 900.0, None));
    assert!(inv.violations().is_empty(), "{:?}", inv.violations());
}

/// A task the coordinator sent before it took a goal, recorded after the goal (the goal
/// reached the recorder first): no violation where the history holds the coordinator's
/// acknowledgements; the same task sent again once the goal was acknowledged is one.
#[test]
fn a_task_is_judged_by_the_goals_its_coordinator_had_acknowledged() {
    let task = |seq| cruise(seq, 150.0);
    let ack = |id: &str, accepted| {
        Event::Ack(GoalAck {
            id: id.into(),
            zone: z("deep"),
            issued_by: Some(CommanderId::new("ic").unwrap()),
            accepted,
            reason: String::new(),
        })
    };
    let v = check(vec![
        (0.5, ack("earlier", false)),
        (1.0, goal(GoalKind::KeepOut)),
        (1.0, task(7)),
        (1.1, ack("g", true)),
        (2.0, task(8)),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(matches!(v[0], Violation::SentIntoBarred { seq: 8, .. }));
}

#[test]
fn a_suspended_commander_s_goals_bar_nothing_after_the_suspension() {
    let v = check(vec![
        (1.0, goal(GoalKind::KeepOut)),
        (
            2.0,
            Event::Suspended {
                name: "commander-ic".into(),
                in_force: Vec::new(),
                asked_at: 2.0,
            },
        ),
        (3.0, cruise(7, 150.0)),
        // A goal heard after it bars again (the coordinator's refusal of it is in the
        // acknowledgements, where a recording holds them), and another identity's
        // suspension changes nothing.
        (4.0, goal(GoalKind::KeepOut)),
        (
            5.0,
            Event::Suspended {
                name: "unit-ugv-9".into(),
                in_force: Vec::new(),
                asked_at: 5.0,
            },
        ),
        (6.0, cruise(8, 150.0)),
    ]);
    assert!(
        matches!(&v[..], [Violation::SentIntoBarred { seq: 8, .. }]),
        "{v:?}"
    );
}

#[test]
fn a_task_sent_after_the_ask_but_before_the_goals_in_force_said_so_is_no_violation() {
    // The ask came at 2.0; the goals in force that carry it were heard only at 4.0 (the
    // one sent at once was lost). The task of 3.0 went out once the goal had lapsed; the
    // one of 1.5, before the ask, still broke it.
    let v = check(vec![
        (1.0, goal(GoalKind::KeepOut)),
        (1.5, cruise(6, 150.0)),
        (3.0, cruise(7, 150.0)),
        (
            4.0,
            Event::Suspended {
                name: "commander-ic".into(),
                in_force: Vec::new(),
                asked_at: 2.0,
            },
        ),
    ]);
    assert!(
        matches!(&v[..], [Violation::SentIntoBarred { seq: 6, .. }]),
        "{v:?}"
    );
}

#[test]
fn a_suspended_console_s_goals_bar_nothing_and_the_goals_still_in_force_still_bar() {
    let console = |in_force: &[&str]| Event::Suspended {
        name: "console".into(),
        in_force: in_force.iter().map(|s| (*s).to_owned()).collect(),
        asked_at: 2.0,
    };
    // Goal "g", issued in ic's name: the console sealed it, the coordinator dropped it.
    let v = check(vec![
        (1.0, goal(GoalKind::KeepOut)),
        (2.0, console(&[])),
        (3.0, cruise(7, 150.0)),
    ]);
    assert!(v.is_empty(), "{v:?}");
    // ic sealed it itself: still in force, still barring.
    let v = check(vec![
        (1.0, goal(GoalKind::KeepOut)),
        (2.0, console(&["g"])),
        (3.0, cruise(7, 150.0)),
    ]);
    assert!(
        matches!(&v[..], [Violation::SentIntoBarred { seq: 7, .. }]),
        "{v:?}"
    );
}

#[test]
fn tasks_into_barred_space_and_attacks_in_a_monitor_zone_are_reported() {
    let task = cruise;
    let v = check(vec![
        (1.0, goal(GoalKind::KeepOut)),
        (2.0, task(7, 150.0)),
        (3.0, task(7, 150.0)),
        (4.0, task(8, 95.0)),
    ]);
    assert_eq!(v.len(), 1, "re-sent tasks count once: {v:?}");
    assert!(matches!(v[0], Violation::SentIntoBarred { seq: 7, .. }));

    let spraying = |t| {
        let p = TaskProgress {
            seq: 1,
            fire: FireId(1),
            phase: TaskPhase::Spraying,
            target: Point2::new(150.0, 0.0),
        };
        (t, state(140.0, t, Some(p)))
    };
    let v = check(vec![
        (0.0, goal(GoalKind::Monitor)),
        spraying(5.0),
        spraying(11.0),
        spraying(12.0),
    ]);
    assert_eq!(v.len(), 1, "{v:?}");
    assert!(matches!(v[0], Violation::AttackWhereBarred { t: 11.0, .. }));
}

#[test]
fn a_refused_goal_binds_nobody() {
    let mut g = goal(GoalKind::KeepOut);
    if let Event::Goal { key_zone, .. } = &mut g {
        *key_zone = z("other");
    }
    let v = check(vec![(1.0, g), (2.0, state(150.0, 2.0, None))]);
    assert!(v.is_empty(), "{v:?}");
}

#[test]
fn a_unit_going_back_an_epoch_and_two_commanders_in_one_epoch_are_violations() {
    let mut inv = Invariants::new(&site());
    let with_epoch = |epoch, t| match state(10.0, t, None) {
        Event::State(st) => Event::State(UnitState {
            epoch: Some(epoch),
            task_seq: Some(epoch),
            ..st
        }),
        other => other,
    };
    // One coordinator re-sending, then a newer one: nothing wrong.
    for (t, e) in [
        (1.0, standby(16, 16)),
        (2.0, standby(16, 16)),
        (3.0, standby(16, 20)),
    ] {
        inv.observe(t, e);
    }
    inv.observe(3.5, with_epoch(16, 3.5));
    // The same coordinator restarted in a newer term (rank 0 again), and a unit that
    // then took the standby's term and the coordinator's older one back (the office
    // changed hands twice): nothing wrong either.
    inv.observe(4.0, standby(32, 32));
    inv.observe(4.5, with_epoch(32, 4.5));
    inv.observe(4.6, with_epoch(49, 4.6));
    inv.observe(4.7, with_epoch(32, 4.7));
    assert!(inv.violations().is_empty(), "{:?}", inv.violations());
    // A second coordinator in epoch 16 (its numbers below the first's), and the unit
    // obeying rank 0's earlier term again: each reported once.
    for t in [5.0, 6.0] {
        inv.observe(t, standby(16, 18));
        inv.observe(t, with_epoch(16, t));
    }
    assert_eq!(
        inv.violations(),
        [
            Violation::TwoCommanders {
                unit: u(),
                t: 5.0,
                epoch: 16,
                seq: 18,
                after: 20
            },
            Violation::EpochWentBack {
                unit: u(),
                t: 5.0,
                from: 32,
                to: 16
            }
        ]
    );
}

#[test]
fn two_commanders_in_the_term_of_a_key_its_coordinator_found_stolen_are_the_thief_s() {
    // Rank 0's term 16: the thief numbers above the holder, the holder re-sends its own.
    let fight = |inv: &mut Invariants, from: f64| {
        inv.observe(from, standby(16, 20));
        inv.observe(from + 0.5, standby(16, 120));
        inv.observe(from + 1.0, standby(16, 21));
        inv.observe(from + 1.5, standby(16, 21));
    };
    // Found within the fight (before or after the violation is seen): set aside, and
    // each task counted once (the fight goes on: the holder's 20 and 21 under the
    // thief's 120).
    for found_first in [true, false] {
        let mut inv = Invariants::new(&site());
        if found_first {
            inv.observe(0.5, Event::KeyStolen { rank: 0 });
        }
        fight(&mut inv, 1.0);
        inv.observe(2.5, Event::KeyStolen { rank: 0 });
        fight(&mut inv, 3.0);
        assert!(inv.violations().is_empty(), "{:?}", inv.violations());
        assert_eq!(inv.stolen_key_tasks(), 2);
    }
    // Another rank's key found stolen, or this one's found long after: still two
    // commanders.
    for (rank, found_at) in [(1, 2.0), (0, 1.0 + 2.0 * FINDING_S + 1.0)] {
        let mut inv = Invariants::new(&site());
        fight(&mut inv, 1.0);
        inv.observe(found_at, Event::KeyStolen { rank });
        assert_eq!(inv.violations().len(), 1, "{:?}", inv.violations());
        assert_eq!(inv.stolen_key_tasks(), 0);
    }
}
