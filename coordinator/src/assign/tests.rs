//! The parent module's tests.

use firefleet_model::profile::GROUND;

use super::*;

fn cand(id: &str, x: f64) -> Candidate {
    Candidate {
        unit: UnitId::new(id).unwrap(),
        at: Place::straight(x, 0.0),
        mobility: Mobility::Ground(GroundBody {
            speed_m_s: 1.0,
            ..GroundBody::of(&GROUND)
        }),
        water_l: 1500.0,
        heading_for: None,
        not_for: Vec::new(),
    }
}

/// How many cannons of `flow_l_s` a fire of `hrr_kw` is given, one at a time while it
/// wants another, with one unit per fire otherwise.
fn attackers(hrr_kw: Option<f64>, flow_l_s: f64) -> usize {
    let mut on = Vec::new();
    while wants_another(hrr_kw, &on, 1) {
        on.push(flow_l_s);
    }
    on.len()
}

#[test]
fn a_fire_wants_units_per_fire_or_the_water_it_needs_whichever_is_more() {
    assert!(wants_another(None, &[10.0], 2), "two per fire: one more");
    assert!(!wants_another(None, &[10.0, 10.0], 2));
    // 20 MW needs about 19 L/s: two small cannons, or one heavy one.
    assert_eq!(attackers(Some(20_000.0), 10.0), 2);
    assert_eq!(attackers(Some(20_000.0), 30.0), 1);
    assert!(
        wants_another(Some(20_000.0), &[30.0], 2),
        "units_per_fire still counts"
    );
    assert!(
        !wants_another(Some(1e6), &[10.0; 3], 1),
        "never more than three"
    );
}

#[test]
fn bigger_fires_need_more_cannons() {
    let n = |q| attackers(q, 10.0);
    assert_eq!(n(None), 1, "unknown size: one");
    assert_eq!(n(Some(5.0)), 1);
    // 5 MW (a car): 8.3 m^2 at 0.50 mm/s, 4.2 L/s.
    assert_eq!(n(Some(5_000.0)), 1);
    // 20 MW (a van or small truck): 33 m^2 at 0.56 mm/s, 19 L/s.
    assert_eq!(n(Some(20_000.0)), 2);
    assert_eq!(n(Some(30_000.0)), 3);
    assert_eq!(n(Some(300_000.0)), MAX_ATTACKERS);
    let mut last = 0;
    for q in (1..200).map(|k| f64::from(k) * 1000.0) {
        assert!(n(Some(q)) >= last, "monotonic in the heat release");
        last = n(Some(q));
    }
}

#[test]
fn nearest_free_unit_gets_each_fire() {
    let units = [cand("a", 0.0), cand("b", 40.0), cand("c", 100.0)];
    let needs = [
        Need {
            fire: FireId(1),
            at: Place::straight(50.0, 0.0),
            priority: 0,
            from: Approach::Either,
        },
        Need {
            fire: FireId(2),
            at: Place::straight(5.0, 0.0),
            priority: 0,
            from: Approach::Either,
        },
    ];
    let picks = greedy(&units, &needs, &Site::default());
    assert_eq!(picks.len(), 2);
    let of = |f: u32| picks.iter().find(|p| p.fire == FireId(f)).unwrap();
    assert_eq!(of(1).unit.as_str(), "b");
    assert_eq!(of(2).unit.as_str(), "a");
    assert_eq!(
        of(1).runner_up.as_ref().unwrap().1,
        50.0,
        "a and c are both 50 s away"
    );
}

#[test]
fn more_fires_than_units_leaves_the_farthest_unattended() {
    let picks = greedy(
        &[cand("a", 0.0)],
        &[
            Need {
                fire: FireId(1),
                at: Place::straight(90.0, 0.0),
                priority: 0,
                from: Approach::Either,
            },
            Need {
                fire: FireId(2),
                at: Place::straight(10.0, 0.0),
                priority: 0,
                from: Approach::Either,
            },
        ],
        &Site::default(),
    );
    assert_eq!(picks.len(), 1);
    assert_eq!(picks[0].fire, FireId(2));
}

fn at(id: &str, x: f64, y: f64) -> Candidate {
    Candidate {
        unit: UnitId::new(id).unwrap(),
        at: Place::straight(x, y),
        mobility: Mobility::Ground(GroundBody {
            speed_m_s: 1.0,
            ..GroundBody::of(&GROUND)
        }),
        water_l: 1500.0,
        heading_for: None,
        not_for: Vec::new(),
    }
}

fn total(p: &[Pick]) -> f64 {
    p.iter().map(|p| p.cost_s).sum()
}

#[test]
fn optimal_beats_greedy_where_greedy_is_myopic() {
    // b is nearest to the fire at 9, but sending a there and b to 20 costs less overall.
    let units = [at("a", 0.0, 0.0), at("b", 10.0, 0.0)];
    let needs = [
        Need {
            fire: FireId(1),
            at: Place::straight(9.0, 0.0),
            priority: 0,
            from: Approach::Either,
        },
        Need {
            fire: FireId(2),
            at: Place::straight(20.0, 0.0),
            priority: 0,
            from: Approach::Either,
        },
    ];
    assert_eq!(total(&greedy(&units, &needs, &Site::default())), 21.0);
    let best = optimal(&units, &needs, &Site::default());
    assert_eq!(total(&best), 19.0);
    assert_eq!(
        best.iter()
            .find(|p| p.fire == FireId(1))
            .unwrap()
            .unit
            .as_str(),
        "a"
    );
}

#[test]
fn a_unit_on_its_way_is_replaced_only_by_one_keep_s_sooner() {
    let fire = Need {
        fire: FireId(1),
        at: Place::straight(100.0, 0.0),
        priority: 0,
        from: Approach::Either,
    };
    let on_its_way = Candidate {
        heading_for: Some(FireId(1)),
        ..at("a", 40.0, 0.0)
    };
    for strategy in [Strategy::Greedy, Strategy::Optimal] {
        let solve = |b: f64| {
            let units = [on_its_way.clone(), at("b", b, 0.0)];
            strategy.solve(&units, std::slice::from_ref(&fire), &Site::default())[0]
                .unit
                .to_string()
        };
        // a is 60 s away; b 50 s: not worth the change.
        assert_eq!(solve(50.0), "a", "{strategy:?}");
        // b 30 s away: 30 s sooner.
        assert_eq!(solve(70.0), "b", "{strategy:?}");
    }
}

/// Least total cost over every injective pairing, by enumeration.
fn brute_force(costs: &[f64], rows: usize, cols: usize) -> f64 {
    fn go(r: usize, rows: usize, cols: usize, costs: &[f64], used: &mut Vec<bool>) -> f64 {
        if r == rows {
            return 0.0;
        }
        let mut best = f64::INFINITY;
        for c in 0..cols {
            if !used[c] {
                used[c] = true;
                best = best.min(costs[r * cols + c] + go(r + 1, rows, cols, costs, used));
                used[c] = false;
            }
        }
        best
    }
    if rows <= cols {
        go(0, rows, cols, costs, &mut vec![false; cols])
    } else {
        let t: Vec<f64> = (0..cols)
            .flat_map(|c| (0..rows).map(move |r| costs[r * cols + c]))
            .collect();
        go(0, cols, rows, &t, &mut vec![false; rows])
    }
}

proptest::proptest! {
    #[test]
    fn hazards_between_are_counted_as_by_looking_at_each(
        at in proptest::collection::vec(0.0..100.0f64, 0..20),
        a in 0.0..100.0f64,
        len in 0.0..100.0f64,
    ) {
        let places: Vec<Place> = at.iter().map(|&x| Place::straight(x, 0.0)).collect();
        let site = Site { hazards: &places, ..Site::default() };
        let b = a + len;
        let naive = at.iter().filter(|&&c| c > a && c < b).count();
        let h = Hazards::new(&site);
        let (a, b) = (Chainage::new(a), Chainage::new(b));
        proptest::prop_assert_eq!(Hazards::between(h.rank(a), h.rank(b)), naive);
        proptest::prop_assert_eq!(Hazards::between(h.rank(b), h.rank(a)), naive);
    }

    #[test]
    fn hungarian_matches_brute_force(rows in 1usize..5, cols in 1usize..6, seed in proptest::collection::vec(0.0..100.0f64, 30)) {
        let costs: Vec<f64> = (0..rows * cols).map(|k| seed[k % seed.len()] + (k as f64 * 7.3) % 11.0).collect();
        let a = hungarian(&costs, rows, cols);
        let chosen: Vec<usize> = a.iter().flatten().copied().collect();
        proptest::prop_assert_eq!(chosen.len(), rows.min(cols));
        let mut distinct = chosen.clone();
        distinct.sort_unstable();
        distinct.dedup();
        proptest::prop_assert_eq!(distinct.len(), chosen.len(), "a column used twice");
        let cost: f64 = a.iter().enumerate().filter_map(|(r, c)| c.map(|c| costs[r * cols + c])).sum();
        proptest::prop_assert!((cost - brute_force(&costs, rows, cols)).abs() < 1e-9);
    }
}

/// A carriage at `x` on a rail from 0 to 100 m with hose points at `hose_points_m`
/// (tubes of 15 m, 10 s to plug in).
fn carriage(id: &str, x: f64, hose_points_m: &[f64]) -> Candidate {
    Candidate {
        unit: UnitId::new(id).unwrap(),
        at: Place::straight(x, 0.0),
        mobility: Mobility::Rail {
            rail: std::sync::Arc::new(firefleet_model::scenario::Rail {
                id: "rail".into(),
                start_m: 0.0,
                end_m: 100.0,
                y_m: 0.0,
                height_m: 5.8,
                hose_points_m: hose_points_m.to_vec(),
            }),
            speed_m_s: 10.0,
            coupling_s: 10.0,
            reach: firefleet_model::dock::Reach {
                hose_m: 15.0,
                working_m: 15.0,
                yaw_limit_rad: std::f64::consts::FRAC_PI_3,
                slack_m: 0.0,
            },
            detector_range_m: 30.0,
        },
        water_l: 1e5,
        heading_for: None,
        not_for: Vec::new(),
    }
}

/// A carriage on a rail with hose points 30 m apart (the ROBOGAT set-up: the whole rail is
/// within a tube's reach of one).
fn rail(id: &str, x: f64) -> Candidate {
    carriage(id, x, &[15.0, 45.0, 75.0])
}

#[test]
fn a_carriage_runs_to_the_dock_that_serves_the_fire_and_plugs_in() {
    let m = rail("r", 10.0).mobility;
    let from = Point2::new(10.0, 0.0);
    // Plugged in at 15 m (0-30 m); the fire 9 m aside at 50 m is served from the hose
    // point at 45 m (30-60 m): 20 m of rail, then 10 s to plug in.
    let t = m.travel_s(from, Point2::new(50.0, 9.0)).unwrap();
    assert!((t - 12.0).abs() < 1e-9, "{t}");
    assert_eq!(
        m.travel_s(from, Point2::new(20.0, 0.0)),
        Some(0.0),
        "served from where it is plugged in"
    );
    assert_eq!(
        m.travel_s(from, Point2::new(50.0, 16.0)),
        None,
        "too far aside"
    );
    assert_eq!(
        m.travel_s(from, Point2::new(130.0, 0.0)),
        None,
        "past the rail's end"
    );
    assert!(
        m.travel_s(from, Point2::new(100.0, 0.0)).is_some(),
        "reached from the last dock"
    );
}

#[test]
fn a_carriage_already_sent_keeps_a_fire_on_the_edge_of_its_reach() {
    // 2.5 m aside at 61 m: in front of the monitor only from 59.56 m (2.5 / tan 60 deg
    // short of it), and the dock at 75 m starts at 60 m. Not a fresh carriage's; the one
    // already sent keeps it as the estimate wavers by tenths of a metre.
    let m = carriage("r", 70.0, &[15.0, 75.0]).mobility;
    let (from, fire) = (Point2::new(70.0, 0.0), Point2::new(61.0, 2.5));
    assert_eq!(m.travel_s(from, fire), None);
    assert_eq!(m.travel_keeping_s(from, fire, true), Some(0.0));
    assert_eq!(
        m.travel_keeping_s(from, Point2::new(57.0, 2.5), true),
        None,
        "a metre and more beyond is beyond"
    );
}

#[test]
fn a_fire_between_hydrants_far_apart_is_no_carriages() {
    let m = carriage("r", 0.0, &[0.0, 90.0]).mobility;
    let from = Point2::new(0.0, 0.0);
    assert_eq!(m.travel_s(from, Point2::new(45.0, 0.0)), None);
    assert_eq!(m.travel_s(from, Point2::new(20.0, 0.0)), Some(0.0));
}

#[test]
fn a_fire_out_of_a_rails_reach_goes_to_a_ground_unit_or_to_nobody() {
    let needs = [Need {
        fire: FireId(1),
        at: Place::straight(150.0, 0.0),
        priority: 0,
        from: Approach::Either,
    }];
    for solve in [greedy, optimal] {
        assert!(solve(&[rail("r", 90.0)], &needs, &Site::default()).is_empty());
        let picks = solve(&[rail("r", 90.0), cand("g", 0.0)], &needs, &Site::default());
        assert_eq!(picks.len(), 1);
        assert_eq!(picks[0].unit.as_str(), "g");
        assert!(
            picks[0].runner_up.is_none(),
            "the rail unit is no runner-up"
        );
    }
}

#[test]
fn a_fast_rail_unit_beats_a_slow_ground_unit_within_its_reach() {
    let needs = [Need {
        fire: FireId(1),
        at: Place::straight(60.0, 2.0),
        priority: 0,
        from: Approach::Either,
    }];
    // The carriage: 30 m of rail and 10 s to plug in, 13 s; the ground unit 20 s.
    let picks = optimal(&[rail("r", 0.0), cand("g", 30.0)], &needs, &Site::default());
    assert_eq!(picks[0].unit.as_str(), "r");
}

#[test]
fn a_higher_priority_fire_is_served_first_when_units_are_short() {
    let mut needs = [
        Need {
            fire: FireId(1),
            at: Place::straight(10.0, 0.0),
            priority: 0,
            from: Approach::Either,
        },
        Need {
            fire: FireId(2),
            at: Place::straight(90.0, 0.0),
            priority: 2,
            from: Approach::Either,
        },
    ];
    for solve in [greedy, optimal] {
        let picks = solve(&[cand("a", 0.0)], &needs, &Site::default());
        assert_eq!(picks[0].fire, FireId(2));
        assert_eq!(
            picks[0].cost_s, 90.0,
            "the log shows travel, not the priority"
        );
    }
    needs[1].priority = 0;
    assert_eq!(
        optimal(&[cand("a", 0.0)], &needs, &Site::default())[0].fire,
        FireId(1)
    );
}

#[test]
fn no_unit_travels_through_a_barred_range() {
    let needs = [Need {
        fire: FireId(1),
        at: Place::straight(90.0, 0.0),
        priority: 0,
        from: Approach::Either,
    }];
    let units = [cand("near", 50.0), cand("far", 150.0)];
    for solve in [greedy, optimal] {
        let site = Site {
            barred: &[(Chainage::new(60.0), Chainage::new(80.0))],
            ..Site::default()
        };
        let picks = solve(&units, &needs, &site);
        assert_eq!(picks.len(), 1);
        assert_eq!(picks[0].unit.as_str(), "far");
        assert!(solve(&units[..1], &needs, &site).is_empty());
    }
}

#[test]
fn units_avoid_driving_past_other_fires_and_running_dry() {
    let needs = [Need {
        fire: FireId(1),
        at: Place::straight(50.0, 0.0),
        priority: 0,
        from: Approach::Either,
    }];
    // Equally far, but the way from the left passes a burning car at 40.
    let units = [cand("left", 20.0), cand("right", 80.0)];
    let hazards = [Place::straight(40.0, 1.0), Place::straight(50.5, 0.0)];
    let site = Site {
        hazards: &hazards,
        ..Site::default()
    };
    let picks = optimal(&units, &needs, &site);
    assert_eq!(picks[0].unit.as_str(), "right");
    assert_eq!(picks[0].cost_s, 30.0, "the target itself is no hazard");
    assert_eq!(picks[0].runner_up.as_ref().unwrap().1, 30.0 + HAZARD_S);
    let mut dry = units.clone();
    dry[1].water_l = 100.0;
    assert_eq!(
        optimal(&dry, &needs, &Site::default())[0].unit.as_str(),
        "left"
    );
}

#[test]
fn a_unit_not_to_be_sent_to_a_fire_is_passed_over_for_the_next() {
    let fire = Need {
        fire: FireId(1),
        at: Place::straight(100.0, 0.0),
        priority: 0,
        from: Approach::Either,
    };
    // a is nearest, but gave this fire up a moment ago.
    let gave_up = Candidate {
        not_for: vec![FireId(1)],
        ..at("a", 90.0, 0.0)
    };
    for strategy in [Strategy::Greedy, Strategy::Optimal] {
        let units = [gave_up.clone(), at("b", 40.0, 0.0)];
        let picks = strategy.solve(&units, std::slice::from_ref(&fire), &Site::default());
        assert_eq!(picks.len(), 1, "{strategy:?}");
        assert_eq!(picks[0].unit.as_str(), "b", "{strategy:?}");
        // Alone, it is not sent at all.
        let picks = strategy.solve(
            std::slice::from_ref(&gave_up),
            std::slice::from_ref(&fire),
            &Site::default(),
        );
        assert!(picks.is_empty(), "{strategy:?}: {picks:?}");
    }
}
