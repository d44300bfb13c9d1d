use super::*;

#[test]
fn a_unit_patrols_to_the_far_end_from_where_it_starts_in_its_lane() {
    let t = Tunnel::straight(300.0, 10.0, 6.3, 2);
    let (right, left) = (t.lane_center_y(0), t.lane_center_y(1));
    assert_eq!(
        patrol_goal(&t, Point2::new(5.0, right)),
        t.point_at(Chainage::new(290.0), right)
    );
    assert_eq!(
        patrol_goal(&t, Point2::new(295.0, left + 0.4)),
        t.point_at(Chainage::new(10.0), left),
        "in from the east portal, it patrols west"
    );
}

#[test]
fn a_fire_is_watched_once_the_cameras_have_faced_it_throughout_a_flames_memory() {
    use firefleet_model::profile::GROUND;
    let scenario = Arc::new(Scenario::straight(100.0).ground("u", 10.0, -2.5).build());
    let mut u = Unit::new(UnitId::new("u").unwrap(), *GROUND, scenario);
    // Straight ahead of the unit, 8 m off: in view with the cannon (and its cameras) at
    // the centre, out of it with the cannon swung a radian aside.
    let at = u.pose();
    let fire = Point2::new(at.x + 8.0 * at.yaw.cos(), at.y + 8.0 * at.yaw.sin());
    // A frame at `t` with the cannon at `pan`; whether the fire is watched then.
    let frame = |u: &mut Unit, t: f64, pan: f64| {
        u.frame.t = t;
        u.frame.cannon.pan = pan;
        u.remember_look();
        u.has_watched(fire)
    };
    let ts = |from: f64, to: f64| {
        (0..)
            .map(move |k| from + 0.05 * f64::from(k))
            .take_while(move |t| *t < to + 1e-9)
    };
    for t in ts(0.0, 1.9) {
        assert!(!frame(&mut u, t, 0.0), "faced for only {t:.2} s");
    }
    assert!(frame(&mut u, 2.1, 0.0), "faced for 2.1 s");
    assert!(!frame(&mut u, 2.15, 1.0), "swung off");
    for t in ts(2.2, 4.1) {
        assert!(!frame(&mut u, t, 0.0), "swung off {:.2} s ago", t - 2.15);
    }
    assert!(frame(&mut u, 4.3, 0.0), "faced again for 2.1 s");
    assert!(!frame(&mut u, 5.5, 0.0), "no frame for 1.2 s: no watch");
}

/// A ground unit's controller at 10 m in a straight 100 m tunnel that stands still, as
/// its world: each step feeds it the same frame, 0.05 s on.
struct Standing {
    ctl: crate::ground::GroundController,
    frame: UnitSensors,
}

impl Standing {
    fn new() -> Self {
        Self::in_tunnel(100.0, Pose2::new(10.0, -2.5, 0.0))
    }

    /// In a straight 300 m tunnel, at `pose`.
    fn new_at(pose: Pose2) -> Self {
        Self::in_tunnel(300.0, pose)
    }

    fn in_tunnel(length_m: f64, pose: Pose2) -> Self {
        use firefleet_model::profile::GROUND;
        let scenario = Arc::new(
            Scenario::straight(length_m)
                .ground("u", pose.x, pose.y)
                .build(),
        );
        let id = UnitId::new("u").unwrap();
        let mut frame = Unit::new(id.clone(), *GROUND, scenario.clone()).frame;
        frame.pose = pose;
        let ctl = crate::ground::GroundController::new(id, *GROUND, scenario);
        Self { ctl, frame }
    }

    fn step(&mut self) {
        self.frame.t += 0.05;
        self.ctl.step(&self.frame);
    }

    /// The navigation under way for `purpose`, to break.
    fn nav(&mut self, purpose: NavPurpose) -> Option<&mut Navigation> {
        self.ctl
            .unit_mut()
            .nav
            .as_mut()
            .filter(|n| n.purpose == purpose)
    }
}

#[test]
fn a_unit_whose_way_to_its_fire_fails_plans_again_then_gives_the_fire_up() {
    use firefleet_model::FireId;
    use firefleet_protocol::msg::TaskPhase;
    let mut u = Standing::new();
    u.ctl.office_changed(true);
    u.step();
    let fire = TaskKind::Extinguish {
        fire: FireId(1),
        target: Point2::new(60.0, -2.0),
        from: Approach::Either,
    };
    u.ctl.on_task(1, 1, fire).unwrap();
    let phase = |u: &Standing| u.ctl.state().task.map(|t| t.phase);
    let mut failed = 0;
    for _ in 0..400 {
        u.step();
        // Each navigation to the fire fails, as one does when no path is left after the
        // unit got clear of what it touched.
        if let Some(n) = u.nav(NavPurpose::Fire).filter(|n| !n.failed) {
            n.failed = true;
            failed += 1;
        }
        if phase(&u) == Some(TaskPhase::Failed) {
            break;
        }
    }
    assert_eq!(
        phase(&u),
        Some(TaskPhase::Failed),
        "the fire never given up"
    );
    assert_eq!(failed, 5, "planned again until the tree's retries ran out");
    assert_eq!(
        u.ctl.unit().nav_purpose(),
        None,
        "still navigating to the fire"
    );
}

#[test]
fn a_cruise_whose_navigation_failed_starts_again() {
    let mut u = Standing::new();
    u.step();
    u.nav(NavPurpose::Cruise).expect("the unit patrols").failed = true;
    for _ in 0..3 {
        u.step();
    }
    assert!(
        u.nav(NavPurpose::Cruise).is_some_and(|n| !n.failed),
        "no new cruise"
    );
}

/// A unit on patrol with another unit in its lane 3 m ahead, which moves as `speed_at`
/// says (its speed at each time); how many ways round the first has planned after 30 s.
fn ways_round_past(speed_at: impl Fn(f64) -> f64) -> u32 {
    use firefleet_model::profile::GROUND;
    use firefleet_protocol::msg::NearbyBody;
    let mut u = Standing::new();
    u.step();
    assert!(u.nav(NavPurpose::Cruise).is_some(), "the unit patrols");
    let pose = u.frame.pose;
    let mut ahead = Pose2::new(pose.x + 3.0, pose.y, pose.yaw);
    for _ in 0..600 {
        let speed = speed_at(u.frame.t);
        ahead = Pose2::new(ahead.x + 0.05 * speed, ahead.y, ahead.yaw);
        u.frame.nearby = vec![NearbyBody {
            pose: ahead,
            length_m: GROUND.length_m,
            width_m: GROUND.width_m,
            speed,
        }];
        u.step();
    }
    u.nav(NavPurpose::Cruise)
        .expect("still on patrol")
        .yielding
        .detours
}

#[test]
fn a_unit_ahead_that_moves_without_getting_anywhere_is_gone_round_one_on_its_way_is_followed() {
    // Back and forth at 0.3 m/s, turning each second: ±0.15 m about one spot, as a unit
    // caught at a zone's edge between its task and the way out (the evacuate demo).
    let dithering = ways_round_past(|t| {
        if (t as u64).is_multiple_of(2) {
            0.3
        } else {
            -0.3
        }
    });
    assert!(dithering >= 1, "held for 30 s by one going nowhere");
    // On its way at 0.3 m/s, slower than the patrol: the unit waits behind it.
    assert_eq!(ways_round_past(|_| 0.3), 0, "went round one making its way");
}

/// A unit sent to a fire 20 m on, jammed behind and beside another that stands idle in
/// its way, driven by its own commands (a kinematic bicycle, the wheels where they are
/// told); where it is after `seconds`, and the least gap it left between the two bodies.
/// The pile-up flood's ugv-3 and ugv-4: 1.6 m apart along the road and 1 m across, ugv-3
/// facing past ugv-4's flank.
fn jammed_behind_one_standing(seconds: f64) -> (Pose2, f64) {
    use firefleet_model::FireId;
    use firefleet_model::geometry::OrientedBox;
    use firefleet_model::profile::GROUND;
    use firefleet_protocol::msg::NearbyBody;
    let mut u = Standing::new_at(Pose2::new(180.1, 0.0, 2.73));
    u.ctl.office_changed(true);
    let fire = TaskKind::Extinguish {
        fire: FireId(1),
        target: Point2::new(160.0, -2.0),
        from: Approach::Either,
    };
    u.ctl.on_task(1, 1, fire).unwrap();
    let idle = NearbyBody {
        pose: Pose2::new(178.5, -1.0, 3.13),
        length_m: GROUND.length_m,
        width_m: GROUND.width_m,
        speed: 0.0,
    };
    let dt = 0.05;
    let mut least_gap = f64::INFINITY;
    while u.frame.t < seconds {
        u.frame.nearby = vec![idle];
        u.frame.t += dt;
        let cmd = u.ctl.step(&u.frame);
        let p = &mut u.frame.pose;
        let yaw = p.yaw + cmd.speed / GROUND.wheelbase_m * cmd.steer.tan() * dt;
        *p = Pose2::new(
            p.x + cmd.speed * p.yaw.cos() * dt,
            p.y + cmd.speed * p.yaw.sin() * dt,
            yaw,
        );
        (u.frame.speed, u.frame.steer) = (cmd.speed, cmd.steer);
        let me = OrientedBox::new(*p, GROUND.length_m, GROUND.width_m);
        least_gap = least_gap.min(me.gap_to(&idle.footprint()));
    }
    (u.frame.pose, least_gap)
}

#[test]
fn a_unit_jammed_behind_one_standing_in_its_way_goes_round_it_and_on() {
    let (at, least_gap) = jammed_behind_one_standing(30.0);
    assert!(
        at.x < 174.0,
        "still behind the unit standing at 178.5 m after 30 s: {at:?}"
    );
    assert!(
        least_gap > 0.05,
        "touched it on the way round: gap {least_gap:.2} m"
    );
}

#[test]
fn a_fire_placed_inside_a_locomotive_is_aimed_at_where_its_firing_position_was_chosen_for() {
    use firefleet_model::profile::GROUND;
    // The long rail tunnel's locomotive, 20 x 2.9 x 4 m on the track, and a unit coming
    // from the east along the free side; the fire where a DTS zone puts it, on the axis,
    // inside the body.
    let scenario = Arc::new(
        Scenario::straight(200.0)
            .section(9.0, 6.5)
            .obstacle("loco", (100.0, -1.3), [20.0, 2.9, 4.0])
            .ground("u", 130.0, 2.0)
            .build(),
    );
    let mut u = Unit::new(UnitId::new("u").unwrap(), *GROUND, scenario.clone());
    let fire = Point2::new(108.5, 0.0);
    let spot = u
        .firing_position(fire)
        .expect("a firing position beside the body");
    let aim = scenario.fightable_at(fire);
    u.frame.pose = Pose2::new(spot.x, spot.y, spot.bearing_to(aim));
    assert_eq!(
        u.aim_point(fire),
        aim,
        "no flame seen: the fire's spot, off the body"
    );
    assert!(
        u.aim_at(fire).is_none(),
        "a jet into the body from {spot:?} would clear it: the test shows nothing"
    );
    assert!(
        u.aim_at(u.aim_point(fire)).is_some(),
        "no shot from the firing position at {aim:?}"
    );
}
