use super::*;

fn u(s: &str) -> UnitId {
    UnitId::new(s).unwrap()
}
fn obs(x: f64, y: f64, var: f64, c: f64) -> FlameObservation {
    FlameObservation {
        position: Point2::new(x, y),
        cov: [var, 0.0, var],
        confidence: c,
        hrr_kw: None,
    }
}

#[test]
fn the_same_flame_seen_by_three_units_is_one_fire() {
    let mut f = Fusion::default();
    assert!(matches!(
        f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.6), 0.0),
        Fused::New(_)
    ));
    assert!(matches!(
        f.observe(&u("b"), &obs(50.6, 1.3, 0.4, 0.6), 0.1),
        Fused::Confirmed(_)
    ));
    f.observe(&u("c"), &obs(49.7, 0.8, 0.2, 0.7), 0.2);
    assert_eq!(f.fires().len(), 1);
    let fire = &f.fires()[0];
    assert_eq!(fire.seen_by().count(), 3);
    assert!(fire.position().dist(Point2::new(50.0, 1.0)) < 0.4);
    assert!(fire.confidence > 0.9);
}

#[test]
fn overconfident_reports_of_one_fire_from_two_sides_are_one_fire() {
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(87.6, -2.5, 0.02, 0.9), 0.0);
    f.observe(&u("b"), &obs(86.4, -2.4, 0.02, 0.9), 0.5);
    assert_eq!(f.fires().len(), 1);
}

#[test]
fn two_tracks_of_one_fire_are_merged_into_the_older() {
    let mut f = Fusion::default();
    // Seen from far away by a, and by b with a biased first look: two tracks.
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 0.0);
    f.observe(&u("b"), &obs(54.0, 1.0, 0.3, 0.9), 0.1);
    assert_eq!(f.fires().len(), 2);
    assert!(
        f.merge_duplicates().is_empty(),
        "4 m apart: two fires so far"
    );
    // b's view converges on the same fire.
    f.get_mut(FireId(2)).unwrap().state = FireState::Assigned;
    f.observe(&u("b"), &obs(54.0, 1.0, 0.3, 0.9), 0.2);
    let fire2 = f.get_mut(FireId(2)).unwrap();
    fire2.per_unit.insert(
        u("b"),
        Sighting::new(
            Gaussian2 {
                mean: Point2::new(50.4, 1.0),
                cov: [0.3, 0.0, 0.3],
            },
            0.9,
            0.2,
        ),
    );
    fire2.refuse();
    let merges = f.merge_duplicates();
    assert_eq!(merges.len(), 1);
    assert_eq!(
        (merges[0].kept, merges[0].removed.id),
        (FireId(1), FireId(2))
    );
    assert_eq!(f.fires().len(), 1);
    let kept = f.get(FireId(2)).expect("the old id still finds the fire");
    assert_eq!(kept.id, FireId(1));
    assert_eq!(kept.state, FireState::Assigned, "the further-along state");
    assert_eq!(kept.seen_by().count(), 2);
}

#[test]
fn close_but_distinct_fires_stay_apart() {
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 2.5, 0.05, 0.9), 0.0);
    f.observe(&u("a"), &obs(50.0, -2.5, 0.05, 0.9), 0.0);
    assert_eq!(f.fires().len(), 2);
}

#[test]
fn repeated_reports_of_one_unit_do_not_inflate_confidence() {
    let mut f = Fusion::default();
    for k in 0..20 {
        f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.45), k as f64);
    }
    assert!((f.fires()[0].confidence - 0.45).abs() < 1e-9);
    assert_eq!(
        f.fires()[0].state,
        FireState::Tentative,
        "held, but no more confident than a false alarm"
    );
}

#[test]
fn one_unit_that_keeps_seeing_a_flame_confirms_it() {
    let mut f = Fusion::default();
    let mut confirmed_at = None;
    for k in 0..=12 {
        let t = 0.25 * f64::from(k);
        if f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.6), t) == Fused::Confirmed(FireId(1)) {
            confirmed_at = Some(t);
        }
    }
    assert_eq!(confirmed_at, Some(CONFIRM_HELD_S));
    assert!((f.fires()[0].confidence - 0.6).abs() < 1e-9, "not inflated");
}

#[test]
fn a_dim_flame_held_by_a_unit_its_heat_reaches_is_confirmed_and_only_then() {
    // Downstream of a fire, smoke dims the flame to 0.2 where its heat reaches the unit.
    let run = |heat_kw_m2: f64| {
        let mut f = Fusion::default();
        f.feel(&u("a"), heat_kw_m2);
        (0..=12).map(|k| 0.25 * f64::from(k)).find(|&t| {
            f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.2), t) == Fused::Confirmed(FireId(1))
        })
    };
    assert_eq!(run(2.5), Some(CONFIRM_HELD_S), "held 2 s while heated");
    assert_eq!(
        run(0.3),
        None,
        "a dim flame where nothing heats the unit stays tentative"
    );

    // The heat that counts is the unit's latest reading: cooled, it confirms nothing.
    let mut f = Fusion::default();
    f.feel(&u("a"), 4.0);
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.2), 0.0);
    f.feel(&u("a"), 0.2);
    for k in 1..=12 {
        f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.2), 0.25 * f64::from(k));
    }
    assert_eq!(f.fires()[0].state, FireState::Tentative);
}

#[test]
fn sightings_with_gaps_do_not_add_up_to_a_held_one() {
    let mut f = Fusion::default();
    for t in [0.0, 1.5, 5.0, 6.5, 10.0, 11.5] {
        f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.6), t);
    }
    assert_eq!(f.fires()[0].state, FireState::Tentative);
}

#[test]
fn a_restored_track_keeps_its_id_estimate_and_confidence_and_takes_new_reports() {
    let mut old = Fusion::default();
    old.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.7), 0.0);
    old.observe(&u("b"), &obs(50.5, 1.2, 0.5, 0.6), 0.5);
    old.fires[0].sizes.insert(u("a"), 4000.0);
    old.fires[0].state = FireState::Suppressing;
    let track = old.fires()[0].to_track(9.0, vec![u("a")]);

    let mut new = Fusion::default();
    assert!(new.restore(&track));
    assert!(
        !new.restore(&track),
        "an id already known is not taken twice"
    );
    let fire = new.get(track.id).unwrap();
    assert_eq!(
        fire.state,
        FireState::Confirmed,
        "the assignment is not restored"
    );
    assert!(fire.position().dist(track.position) < 1e-9);
    for (got, want) in fire.estimate.cov.iter().zip(track.cov) {
        assert!(
            (got - want).abs() < 1e-9,
            "{:?} vs {:?}",
            fire.estimate.cov,
            track.cov
        );
    }
    assert!((fire.confidence - track.confidence).abs() < 1e-9);
    assert_eq!(fire.hrr_kw(), Some(4000.0));
    assert_eq!(fire.last_seen, 9.0);

    // A unit's next report of it lands on the restored track, and a new fire is
    // numbered above every restored one.
    assert_eq!(
        new.observe(&u("b"), &obs(50.3, 1.1, 0.3, 0.9), 10.0),
        Fused::Updated(track.id)
    );
    assert_eq!(new.fires().len(), 1);
    let Fused::Confirmed(id) = new.observe(&u("a"), &obs(150.0, 1.0, 0.3, 0.9), 11.0) else {
        panic!()
    };
    assert!(id > track.id);
}

/// Make `unit` doubted: two of its lone claims contradicted.
fn doubt(f: &mut Fusion, unit: &UnitId) {
    f.witnesses.contradict(unit);
    f.witnesses.contradict(unit);
    assert!(f.witnesses.doubted(unit));
}

#[test]
fn a_doubted_unit_alone_neither_confirms_nor_reignites_but_adds_to_a_credible_witness() {
    let mut f = Fusion::default();
    doubt(&mut f, &u("liar"));
    for k in 0..=20 {
        let fused = f.observe(&u("liar"), &obs(50.0, 1.0, 0.3, 0.99), 0.25 * f64::from(k));
        assert!(
            matches!(fused, Fused::New(_) | Fused::Updated(_)),
            "{fused:?}"
        );
    }
    let fire = f.fires()[0].clone();
    assert_eq!(fire.state, FireState::Tentative, "held 5 s at 0.99, alone");
    assert!(fire.confidence < 0.34, "{}", fire.confidence);
    // An honest unit's sightings there confirm it, and credit both.
    assert_eq!(
        f.observe(&u("b"), &obs(50.2, 1.0, 0.3, 0.6), 6.0),
        Fused::Updated(fire.id),
        "0.6 alone is not enough"
    );
    assert_eq!(
        f.observe(&u("b"), &obs(50.2, 1.0, 0.3, 0.9), 6.1),
        Fused::Confirmed(FireId(1))
    );
    assert_eq!(f.witnesses.record(&u("b")).corroborated, 1);
    assert_eq!(f.witnesses.record(&u("liar")).corroborated, 1);
    f.observe(&u("b"), &obs(50.2, 1.0, 0.3, 0.9), 6.2);
    assert_eq!(f.witnesses.record(&u("b")).corroborated, 1, "once per fire");
    // Put out, then claimed again by the doubted unit alone: not reignited.
    let id = f.fires()[0].id;
    let fire = f.get_mut(id).unwrap();
    fire.state = FireState::Out;
    fire.out_at = Some(7.0);
    assert_eq!(
        f.observe(&u("liar"), &obs(50.0, 1.0, 0.3, 0.99), 20.0),
        Fused::Updated(id)
    );
}

#[test]
fn a_lone_claim_another_unit_looks_at_for_long_without_seeing_it_is_contradicted_once() {
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 0.0);
    f.observe(&u("a"), &obs(150.0, 1.0, 0.3, 0.9), 0.0);
    let near_50 = |p: Point2| p.dist(Point2::new(45.0, 1.0)) < 12.0;
    let mut t = 0.0;
    let mut found = Vec::new();
    while found.is_empty() {
        t += 0.5;
        f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), t);
        f.observe(&u("a"), &obs(150.0, 1.0, 0.3, 0.9), t);
        assert!(f.look(&u("a"), near_50, 0.5, t).is_empty(), "not by itself");
        found = f.look(&u("b"), near_50, 0.5, t);
        assert!(t < 20.0);
    }
    assert_eq!(t, CONTRADICT_AFTER_S);
    assert_eq!(
        found,
        vec![Contradiction {
            fire: FireId(1),
            witness: u("a"),
            doubted_now: true
        }],
        "the fire out of view is not contradicted; nothing a claimed was borne out, so one look makes it doubted"
    );
    assert_eq!(f.witnesses.record(&u("a")).contradicted, 1);
    assert!(f.look(&u("b"), near_50, 60.0, t).is_empty(), "counted once");

    // A tentative claim nobody keeps up (a passing false alarm), or one two units share,
    // is not contradicted; a confirmed one is, though its claimant drove on.
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.4), 0.0);
    assert!(f.look(&u("b"), near_50, 30.0, 10.0).is_empty(), "lapsed");
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 0.0);
    assert_eq!(
        f.look(&u("b"), near_50, 30.0, 10.0).len(),
        1,
        "confirmed, then left"
    );
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 11.0);
    f.observe(&u("c"), &obs(50.0, 1.0, 0.3, 0.9), 11.0);
    assert!(f.look(&u("b"), near_50, 30.0, 11.0).is_empty(), "shared");
}

#[test]
fn a_contradicted_fire_only_doubted_units_claim_goes_back_to_tentative() {
    let mut f = Fusion::default();
    let Fused::Confirmed(id) = f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 0.0) else {
        panic!()
    };
    f.get_mut(id).unwrap().state = FireState::Assigned;
    let here = |p: Point2| p.x > 40.0 && p.x < 60.0;
    // a's word was borne out once before: one contradiction does not make it doubted.
    f.witnesses.corroborate(&u("a"));
    assert_eq!(f.look(&u("b"), here, 10.0, 1.0).len(), 1);
    assert!(f.demote_doubted().is_empty());
    f.witnesses.contradict(&u("a"));
    assert_eq!(f.demote_doubted(), vec![id]);
    let fire = f.get(id).unwrap();
    assert_eq!(fire.state, FireState::Tentative);
    assert!(fire.confidence < 0.45, "re-weighted: {}", fire.confidence);
}

#[test]
fn unworked_unseen_tracks_are_lost_and_out_fires_can_reignite() {
    let mut f = Fusion::default();
    f.observe(&u("a"), &obs(50.0, 1.0, 0.3, 0.9), 0.0);
    assert!(f.expire(30.0, |_| false).is_empty());
    assert!(
        f.expire(61.0, |_| true).is_empty(),
        "a fire a goal leaves burning is kept"
    );
    assert_eq!(f.expire(61.0, |_| false).len(), 1);

    let mut f = Fusion::default();
    let Fused::Confirmed(id) = f.observe(&u("a"), &obs(20.0, 1.0, 0.3, 0.9), 0.0) else {
        panic!()
    };
    let fire = f.get_mut(id).unwrap();
    fire.state = FireState::Out;
    fire.out_at = Some(10.0);
    assert_eq!(
        f.observe(&u("a"), &obs(20.0, 1.0, 0.3, 0.9), 12.0),
        Fused::Updated(id),
        "stale report"
    );
    assert_eq!(
        f.observe(&u("a"), &obs(20.0, 1.0, 0.3, 0.9), 20.0),
        Fused::Reignited(id)
    );
}

#[test]
fn one_unit_alone_holds_and_starts_a_bounded_number_of_tracks() {
    let mut f = Fusion::default();
    let liar = |i: i32| obs(10.0 + 3.0 * f64::from(i), 1.0, 0.3, 0.6);
    // A liar's report: fires three metres apart everywhere, each seen only by it. A burst
    // of four starts, then one every five seconds, never more than eight held.
    let started = |f: &mut Fusion, t: f64, from: i32| {
        (from..from + 100)
            .filter(|&i| matches!(f.observe(&u("liar"), &liar(i), t), Fused::New(_)))
            .count()
    };
    assert_eq!(started(&mut f, 1.0, 0), LONE_STARTS_BURST as usize);
    assert_eq!(started(&mut f, 1.0 + LONE_START_EVERY_S, 0), 1);
    assert_eq!(started(&mut f, 1000.0, 0), MAX_LONE_TRACKS - 5);
    assert_eq!(f.fires().len(), MAX_LONE_TRACKS);
    // Another unit's fires are its own business, and the liar still updates what it holds.
    assert!(matches!(
        f.observe(&u("b"), &obs(280.0, 1.0, 0.3, 0.6), 1000.0),
        Fused::New(_)
    ));
    assert!(matches!(
        f.observe(&u("liar"), &liar(0), 1000.5),
        Fused::Updated(_)
    ));
}

#[test]
fn each_lone_fire_nothing_bore_out_slows_the_units_next_lone_start() {
    // A liar's fakes, each confirmed at once on its word: one lost unseen, one merged into
    // another of its own, one contradicted (another unit looked).
    let mut f = Fusion::default();
    let fake = |x: f64| obs(x, 1.0, 0.3, 0.95);
    let confirmed = |f: &mut Fusion, x: f64, t: f64| {
        let got = f.observe(&u("liar"), &fake(x), t);
        assert!(matches!(got, Fused::Confirmed(_)), "{got:?}");
    };
    confirmed(&mut f, 100.0, 0.0);
    assert_eq!(f.expire(61.0, |_| false).len(), 1);
    confirmed(&mut f, 150.0, 61.0);
    confirmed(&mut f, 153.0, 61.0);
    f.get_mut(FireId(3)).unwrap().estimate.mean = Point2::new(150.2, 1.0);
    assert_eq!(f.merge_duplicates().len(), 1);
    confirmed(&mut f, 50.0, 61.0);
    assert_eq!(f.look(&u("b"), |p| p.x < 60.0, 10.0, 62.0).len(), 1);
    let record = f.witnesses().record(&u("liar"));
    assert_eq!(
        (record.contradicted, record.lone_unborne),
        (1, 2),
        "{record:?}"
    );
    // Three unborne: one start every 40 s, where it had one every 5 s.
    let (_, every_s) = witness::lone_starts(3, LONE_STARTS_BURST, LONE_START_EVERY_S);
    assert_eq!(every_s, 8.0 * LONE_START_EVERY_S);
    let new_at = |f: &mut Fusion, t: f64| {
        !matches!(f.observe(&u("liar"), &fake(200.0 + t), t), Fused::Refused)
    };
    let t0 = 62.0 + every_s;
    assert!(new_at(&mut f, t0));
    assert!(!new_at(&mut f, t0 + every_s / 2.0), "half its wait");
    assert!(new_at(&mut f, t0 + every_s));
    // An honest unit is not slowed by the liar's record.
    assert!(matches!(
        f.observe(&u("b"), &obs(280.0, 1.0, 0.3, 0.95), t0),
        Fused::Confirmed(_)
    ));
}

#[test]
fn a_fire_whose_lone_claim_was_found_out_does_not_reignite_on_its_claimants_word() {
    let mut f = Fusion::default();
    let Fused::Confirmed(id) = f.observe(&u("liar"), &obs(50.0, 1.0, 0.3, 0.95), 0.0) else {
        panic!()
    };
    assert_eq!(
        f.found_nothing(id, &u("b"), 5.0).map(|c| c.witness),
        Some(u("liar"))
    );
    let fire = f.get_mut(id).unwrap();
    fire.state = FireState::Out;
    fire.out_at = Some(5.0);
    assert_eq!(
        f.observe(&u("liar"), &obs(50.0, 1.0, 0.3, 0.95), 20.0),
        Fused::Updated(id)
    );
    assert_eq!(
        f.observe(&u("c"), &obs(50.0, 1.0, 0.3, 0.95), 21.0),
        Fused::Reignited(id),
        "another unit's flames there are news"
    );
}
