//! Searching the tunnel and the rails.

use super::*;
use firefleet_model::UnitKind;

/// A monorail unit "r" on a rail over the whole tunnel, at chainage `x`, and its
/// state there.
fn with_rail(x: f64) -> (Incident, UnitState) {
    let rail = Mobility::Rail {
        rail: std::sync::Arc::new(firefleet_model::scenario::Rail {
            id: "rail".into(),
            start_m: 0.0,
            end_m: 200.0,
            y_m: 0.0,
            height_m: 5.8,
            hose_points_m: (0..7).map(|k| 15.0 + 30.0 * f64::from(k)).collect(),
        }),
        speed_m_s: 10.0,
        coupling_s: 10.0,
        reach: firefleet_model::dock::Reach {
            hose_m: 15.0,
            working_m: 12.0,
            yaw_limit_rad: std::f64::consts::FRAC_PI_3,
            slack_m: 0.0,
        },
        detector_range_m: firefleet_model::profile::MONORAIL.detector_range_m,
    };
    let mut i = Incident::new(TUNNEL, [(u("r"), rail)], 5.0, Strategy::Optimal);
    i.on_alive(&u("r"), true, 0.0).unwrap();
    let mut st = state("r", x, None);
    st.kind = UnitKind::Monorail;
    st.pose = Pose2::new(x, 0.0, 0.0);
    (i, st)
}

fn search_goal(out: &[Output]) -> Option<f64> {
    kinds_for(out, "r").into_iter().find_map(|k| match k {
        TaskKind::Search { goal } => Some(goal.x),
        _ => None,
    })
}

#[test]
fn a_free_monorail_unit_searches_its_rail_end_to_end_and_back() {
    let (mut i, mut st) = with_rail(30.0);
    let out = i.state_at(echoing(&i, st.clone()), 0.0).unwrap();
    assert_eq!(search_goal(&out), Some(200.0), "the farther end first");
    st.pose.x = 120.0;
    i.state_at(echoing(&i, st.clone()), 10.0).unwrap();
    assert_eq!(search_goal(&i.tick(10.0)), None, "on its way: no new task");
    st.pose.x = 199.6;
    i.state_at(echoing(&i, st.clone()), 20.0).unwrap();
    assert_eq!(search_goal(&i.tick(20.0)), Some(0.0), "there: back again");
    // A fire it reaches takes it off the search; once out, the search resumes.
    let mut r = report("r", 150.0);
    r.observer = Pose2::new(150.0, 0.0, 0.0);
    let out = i.report_at(&r, 21.0).unwrap();
    let fire = tasks(&out)[0].clone();
    assert_eq!(fire.unit.as_str(), "r");
    assert_eq!(search_goal(&out), None);
    let TaskKind::Extinguish { fire: id, .. } = fire.kind else {
        unreachable!()
    };
    st.pose.x = 150.0;
    st.task = Some(TaskProgress {
        seq: fire.seq,
        fire: id,
        phase: TaskPhase::Extinguished,
        target: Point2::new(150.0, 1.0),
    });
    let out = i.state_at(echoing(&i, st), 40.0).unwrap();
    assert_eq!(search_goal(&out), Some(0.0));
}

#[test]
fn a_monorail_search_turns_short_of_a_keep_out_zone() {
    let (mut i, st) = with_rail(30.0);
    i.goals = Goals::new(&[zone("z1", 100.0, 150.0)], &[]);
    let (ack, _) = submit(&mut i, goal("g1", "z1", GoalKind::KeepOut, 0, None), 0.0);
    assert!(ack.accepted, "{ack:?}");
    let out = i.state_at(st, 0.5).unwrap();
    assert_eq!(
        search_goal(&out),
        Some(100.0 - Policy::DEFAULT.evacuate_margin_m)
    );
}

/// Ground units a and b in a tunnel nobody has looked at yet.
fn unsearched() -> Incident {
    let mut i = unheard();
    i.coverage = Coverage::new(TUNNEL.length_m);
    i
}

fn facing(unit: &str, x: f64, yaw: f64) -> UnitState {
    UnitState {
        pose: Pose2::new(x, -2.0, yaw),
        ..state(unit, x, None)
    }
}

/// The goal of `unit`'s newest task, if it is a search.
fn searching_to(i: &Incident, unit: &str) -> Option<Point2> {
    match i.units[&u(unit)].task.as_ref()?.kind {
        TaskKind::Search { goal } => Some(goal),
        _ => None,
    }
}

#[test]
fn units_from_both_portals_search_the_unseen_middle_from_both_ends() {
    let mut i = unsearched();
    i.on_alive(&u("a"), true, 0.0).unwrap();
    i.on_alive(&u("b"), true, 0.0).unwrap();
    i.state_at(echoing(&i, facing("a", 5.0, 0.0)), 0.0).unwrap();
    i.state_at(echoing(&i, facing("b", 195.0, std::f64::consts::PI)), 0.0)
        .unwrap();
    // a sees 0-35 m, b 165-200 m: the unseen middle is 35-165, split at 100.
    assert_eq!(searching_to(&i, "a").map(|g| g.x), Some(100.0));
    assert_eq!(searching_to(&i, "b").map(|g| g.x), Some(100.0));
    assert!(decided(&i, |d| matches!(
        d,
        Decision::Search { unit, from, to, .. }
            if unit == "b" && from.m() == 35.0 && to.m() == 165.0
    )));
    // As they look, the middle shrinks evenly: the goals stand, no new tasks.
    for k in 1..=8 {
        let (t, d) = (5.0 * f64::from(k), 7.5 * f64::from(k));
        i.state_at(echoing(&i, facing("a", 5.0 + d, 0.0)), t)
            .unwrap();
        i.state_at(echoing(&i, facing("b", 195.0 - d, std::f64::consts::PI)), t)
            .unwrap();
        assert!(all_tasks(&i.solve(t)).is_empty(), "at {t} s");
    }
    // Once all is seen they are released to patrol.
    i.state_at(echoing(&i, facing("a", 72.5, 0.0)), 45.0)
        .unwrap();
    i.state_at(echoing(&i, facing("b", 127.5, std::f64::consts::PI)), 45.0)
        .unwrap();
    let out = i.solve(45.0);
    assert_eq!(kinds_for(&out, "a"), vec![TaskKind::Standby]);
    assert_eq!(kinds_for(&out, "b"), vec![TaskKind::Standby]);
}

#[test]
fn one_unit_searches_and_its_partner_takes_the_fire_it_finds() {
    let mut i = unsearched();
    for n in ["a", "b"] {
        i.on_alive(&u(n), true, 0.0).unwrap();
        i.state_at(echoing(&i, facing(n, 5.0, 0.0)), 0.0).unwrap();
    }
    let searcher = ["a", "b"]
        .into_iter()
        .find(|n| searching_to(&i, n).is_some())
        .expect("one of the pair searches");
    assert_eq!(searching_to(&i, searcher).map(|g| g.x), Some(190.0));
    let other = if searcher == "a" { "b" } else { "a" };
    assert_eq!(searching_to(&i, other), None, "one searcher per end");
    // The pair sees a fire at 60 m from 35 m: one attacks, the other searches on
    // beyond it rather than backing up a fire one unit can fight.
    i.state_at(echoing(&i, facing("a", 35.0, 0.0)), 20.0)
        .unwrap();
    i.state_at(echoing(&i, facing("b", 35.0, 0.0)), 20.0)
        .unwrap();
    let out = i.report_at(&report("a", 60.0), 20.0).unwrap();
    assert_eq!(tasks(&out).len(), 1, "{out:?}");
    let attacker = tasks(&out)[0].unit.as_str().to_owned();
    let other = if attacker == "a" { "b" } else { "a" };
    assert_eq!(searching_to(&i, other).map(|g| g.x), Some(190.0));
}

/// The zoned incident, unsearched, with `zone` kept out of from t = 0.
fn unsearched_keeping_out_of(zone: &str) -> Incident {
    let mut i = zoned();
    i.coverage = Coverage::new(TUNNEL.length_m);
    submit(&mut i, goal("g1", zone, GoalKind::KeepOut, 0, None), 0.0);
    i
}

#[test]
fn search_stops_short_of_a_keep_out_zone() {
    let mut i = unsearched_keeping_out_of("z2");
    i.state_at(facing("a", 10.0, 0.0), 1.0).unwrap();
    let g = searching_to(&i, "a").expect("a searches");
    assert_eq!(g.x, 100.0 - Policy::DEFAULT.evacuate_margin_m);
}

#[test]
fn nobody_searches_a_stretch_beyond_a_keep_out_zone() {
    let mut i = unsearched_keeping_out_of("z1");
    i.state_at(facing("a", 10.0, 0.0), 1.0).unwrap();
    i.state_at(facing("b", 40.0, 0.0), 1.0).unwrap();
    i.solve(1.0);
    // Up to 70 m is seen (b looks 30 m ahead); 105-190 lies beyond the zone.
    assert_eq!(searching_to(&i, "a"), None);
    assert_eq!(searching_to(&i, "b"), None);
}

#[test]
fn a_stretch_not_seen_for_two_minutes_is_searched_again() {
    let mut i = incident();
    assert_eq!(searching_to(&i, "a"), None);
    i.state_at(
        facing("a", 10.0, 0.0),
        Policy::DEFAULT.search_again_after_s - 1.0,
    )
    .unwrap();
    assert!(all_tasks(&i.solve(Policy::DEFAULT.search_again_after_s - 1.0)).is_empty());
    i.state_at(
        facing("a", 10.0, 0.0),
        Policy::DEFAULT.search_again_after_s + 1.0,
    )
    .unwrap();
    i.state_at(
        facing("b", 40.0, 0.0),
        Policy::DEFAULT.search_again_after_s + 1.0,
    )
    .unwrap();
    i.solve(Policy::DEFAULT.search_again_after_s + 1.0);
    assert_eq!(searching_to(&i, "b").map(|g| g.x), Some(190.0));
}

#[test]
fn past_a_fire_left_burning_free_units_search_on() {
    let mut i = zoned();
    submit(&mut i, goal("g1", "z1", GoalKind::Monitor, 0, None), 0.5);
    let out = i.report_at(&report("a", 60.0), 1.0).unwrap();
    let kinds: Vec<TaskKind> = all_tasks(&out).iter().map(|t| t.kind).collect();
    assert_eq!(kinds.len(), 2, "{out:?}");
    assert!(
        kinds
            .iter()
            .all(|k| matches!(k, TaskKind::Search { goal } if goal.x == 190.0)),
        "both units search on to the far end: {kinds:?}"
    );
    assert!(all_tasks(&i.tick(2.0)).is_empty(), "the order stands");
}

/// A keep-out on the zone a search ends at the edge of (CI's stolen incident commander
/// barred zone west while a unit searched to its boundary, 150.0, from the east): the
/// search goal moves out, though the new one lies within the slack that keeps a goal.
#[test]
fn a_search_goal_a_keep_out_bars_is_never_kept() {
    let mut i = unsearched();
    i.goals = Goals::new(&[zone("w", 0.0, 100.0), zone("e", 100.0, 200.0)], &[]);
    i.on_alive(&u("a"), true, 0.0).unwrap();
    i.on_alive(&u("b"), true, 0.0).unwrap();
    i.state_at(echoing(&i, facing("a", 5.0, 0.0)), 0.0).unwrap();
    i.state_at(echoing(&i, facing("b", 195.0, std::f64::consts::PI)), 0.0)
        .unwrap();
    assert_eq!(
        searching_to(&i, "b").map(|g| g.x),
        Some(100.0),
        "the boundary"
    );
    submit(&mut i, goal("k", "w", GoalKind::KeepOut, 0, None), 1.0);
    let barred = i.barred_space(1.0);
    for n in ["a", "b"] {
        let task = i.units[&u(n)].task.as_ref().map(|t| t.kind);
        let to = task.and_then(|k| k.destination());
        assert!(
            to.is_none_or(|p| barred
                .entry_at(UnitKind::Ground, TUNNEL.chainage(p))
                .is_none()),
            "{n}: {task:?}"
        );
    }
    assert!(all_tasks(&i.tick(1.5)).is_empty(), "the new orders stand");
    assert_eq!(
        i.inconsistencies(),
        0,
        "the search moved it, not the last word"
    );
}
