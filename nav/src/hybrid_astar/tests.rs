//! The parent module's tests.

use super::*;
use firefleet_model::scenario::Scenario;

const R: f64 = 1.83; // the ground unit's turning radius (1 m wheelbase, 0.5 rad)

fn tunnel(extra: &str) -> Scenario {
    let text = format!(
        "name = \"t\"\ntime_limit_s = 100\n[tunnel]\nlength_m = 60.0\nwidth_m = 7.0\nheight_m = 6.0\nlanes = 2\n{extra}"
    );
    Scenario::from_toml(&text, "t.toml").unwrap()
}

const CAR: &str = "[[obstacles]]\nname = \"car\"\nx_m = 25.0\ny_m = -1.5\nlength_m = 4.5\nwidth_m = 1.8\nheight_m = 1.5\n";
const FOOT: Footprint = Footprint {
    length_m: 1.6,
    width_m: 1.0,
};

fn check(planner: &HybridAStar<'_>, plan: &Plan, start: Pose2, goal: Pose2) {
    assert_eq!(plan.poses[0], start);
    let end = *plan.poses.last().unwrap();
    assert!(end.position().dist(goal.position()) < 0.3, "{end:?}");
    for (k, w) in plan.poses.windows(2).enumerate() {
        assert!(planner.pose_free(&w[1]), "pose {k} collides: {:?}", w[1]);
        // Kinematically feasible: the heading turns no more than an arc of the minimum
        // radius turns over this chord (chord = 2 R sin(dyaw / 2)).
        let ds = w[0].position().dist(w[1].position());
        let dyaw = wrap_angle(w[1].yaw - w[0].yaw).abs();
        let most = 2.0 * (ds / (2.0 * R)).min(1.0).asin();
        assert!(dyaw <= most + 1e-6, "pose {k}: {dyaw} rad over {ds} m");
    }
}

#[test]
fn drives_around_a_parked_car_without_touching_it() {
    let s = tunnel(CAR);
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let planner = HybridAStar::new(&grid, FOOT, Params::for_radius(R));
    let (start, goal) = (Pose2::new(5.0, -1.5, 0.0), Pose2::new(45.0, -1.5, 0.0));
    let plan = planner.plan(start, goal, None).unwrap();
    check(&planner, &plan, start, goal);
    // The car fills y in [-2.4, -0.6]: passing it takes the robot's centre above -0.1.
    let mut passing = plan.poses.iter().filter(|p| (22.75..27.25).contains(&p.x));
    assert!(passing.all(|p| p.y > -0.1), "it goes round the car");
    assert!(plan.length_m < 45.0, "{}", plan.length_m);
}

/// Several goals: a blocked one is left out, and of the others the search takes the
/// one cheapest to reach, by the path it would take to that one alone.
#[test]
fn to_any_of_several_goals_it_reaches_the_cheapest() {
    let s = tunnel(CAR);
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let mut params = Params::for_radius(R);
    params.allow_reverse = false;
    let planner = HybridAStar::new(&grid, FOOT, params);
    let start = Pose2::new(5.0, -1.5, 0.0);
    let inside_the_car = Pose2::new(25.0, -1.5, 0.0);
    let far = Pose2::new(45.0, 1.5, 0.0);
    let near = Pose2::new(35.0, 1.5, 0.0);
    let goals = [inside_the_car, far, near];
    let plan = planner.plan_any(start, &goals, None).unwrap();
    assert_eq!(plan.goal, 2, "the nearer free goal");
    check(&planner, &plan, start, near);
    let alone = planner.plan(start, near, None).unwrap();
    assert!(
        (plan.length_m - alone.length_m).abs() < 1e-6,
        "the same path as to it alone"
    );
    assert_eq!(
        planner
            .plan_any(start, &[inside_the_car], None)
            .unwrap_err(),
        PlanError::GoalBlocked
    );
}

#[test]
fn the_smoothed_path_round_a_car_bends_less_and_is_no_longer() {
    let s = tunnel(CAR);
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let (start, goal) = (Pose2::new(5.0, -1.5, 0.0), Pose2::new(45.0, -1.5, 0.0));
    let mut raw_params = Params::for_radius(R);
    raw_params.smoothing = None;
    let raw = HybridAStar::new(&grid, FOOT, raw_params)
        .plan(start, goal, None)
        .unwrap();
    let planner = HybridAStar::new(&grid, FOOT, Params::for_radius(R));
    let plan = planner.plan(start, goal, None).unwrap();
    assert!(plan.smoothed && !raw.smoothed);
    check(&planner, &plan, start, goal);
    // Bending energy: the squared heading change per metre, summed over the path.
    let bending = |p: &Plan| -> f64 {
        p.poses
            .windows(2)
            .map(|w| {
                let ds = w[0].position().dist(w[1].position()).max(1e-9);
                wrap_angle(w[1].yaw - w[0].yaw).powi(2) / ds
            })
            .sum()
    };
    assert!(
        bending(&plan) < 0.7 * bending(&raw),
        "bending {:.3} smoothed, {:.3} as searched",
        bending(&plan),
        bending(&raw)
    );
    assert!(
        plan.length_m <= raw.length_m + 1e-9,
        "{} vs {}",
        plan.length_m,
        raw.length_m
    );
}

#[test]
fn reaches_a_goal_behind_it_facing_the_other_way() {
    let s = tunnel("");
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let planner = HybridAStar::new(&grid, FOOT, Params::for_radius(R));
    let (start, goal) = (
        Pose2::new(30.0, -1.5, 0.0),
        Pose2::new(24.0, 1.5, std::f64::consts::PI),
    );
    let plan = planner.plan(start, goal, None).unwrap();
    check(&planner, &plan, start, goal);
    let end = plan.poses.last().unwrap();
    assert!(wrap_angle(end.yaw - goal.yaw).abs() < 0.1, "{end:?}");
}

#[test]
fn refuses_blocked_poses_and_unreachable_goals() {
    let wall = "[[obstacles]]\nname = \"wall\"\nx_m = 30.0\ny_m = 0.0\nlength_m = 1.0\nwidth_m = 7.0\nheight_m = 3.0\n";
    let s = tunnel(wall);
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let mut params = Params::for_radius(R);
    params.max_expansions = 20_000;
    let planner = HybridAStar::new(&grid, FOOT, params);
    let start = Pose2::new(5.0, 0.0, 0.0);
    assert_eq!(
        planner.plan(start, Pose2::new(30.0, 0.0, 0.0), None),
        Err(PlanError::GoalBlocked)
    );
    assert!(matches!(
        planner.plan(start, Pose2::new(50.0, 0.0, 0.0), None),
        Err(PlanError::NoPath(_))
    ));
}

#[test]
fn the_heat_term_keeps_the_path_away_from_a_fire_beside_it() {
    // A 5 MW fire at the edge of the lane the robot drives along.
    let s = tunnel("");
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let fire = [HeatSource {
        at: Point2::new(25.0, -3.2),
        hrr_kw: 5000.0,
    }];
    let (start, goal) = (Pose2::new(5.0, -2.0, 0.0), Pose2::new(45.0, -2.0, 0.0));
    let mut p = Params::for_radius(R);
    p.analytic_within_m = 3.0;
    let dose = |plan: &Plan| -> f64 {
        plan.poses
            .windows(2)
            .map(|w| {
                radiant_flux_kw_m2(&fire, w[1].position()) * w[0].position().dist(w[1].position())
            })
            .sum()
    };
    let blind = HybridAStar::new(&grid, FOOT, p);
    let plain = blind.plan(start, goal, None).unwrap();
    let wary = HybridAStar::new(&grid, FOOT, p).with_heat(fire.to_vec());
    let plan = wary.plan(start, goal, None).unwrap();
    check(&wary, &plan, start, goal);
    assert!(
        dose(&plan) < 0.7 * dose(&plain),
        "heat dose {:.1} with the term, {:.1} without",
        dose(&plan),
        dose(&plain)
    );
    let closest = plan
        .poses
        .iter()
        .map(|q| q.position().dist(fire[0].at))
        .fold(f64::INFINITY, f64::min);
    assert!(closest > 3.0, "passes {closest:.1} m from the fire");
}

#[test]
fn the_visibility_term_keeps_the_flame_in_view_longer() {
    // A van between the start and the flame: without the term the path hugs it.
    let van = "[[obstacles]]\nname = \"van\"\nx_m = 25.0\ny_m = 1.7\nlength_m = 5.5\nwidth_m = 2.0\nheight_m = 2.4\n";
    let s = tunnel(van);
    let grid = Grid::from_scenario(&s, 0.1, 0.0);
    let flame = Point2::new(40.0, 2.0);
    let (start, goal) = (Pose2::new(5.0, 1.5, 0.0), Pose2::new(35.0, 1.5, 0.0));
    let in_view = |lambda: f64| {
        let mut p = Params::for_radius(R);
        p.lambda_m = lambda;
        let planner = HybridAStar::new(&grid, FOOT, p);
        let plan = planner.plan(start, goal, Some(flame)).unwrap();
        check(&planner, &plan, start, goal);
        let seen = plan
            .poses
            .iter()
            .filter(|q| grid.segment_free(q.position(), flame))
            .count();
        seen as f64 / plan.poses.len() as f64
    };
    let (without, with) = (in_view(0.0), in_view(10.0));
    assert!(
        with > without,
        "in view {with:.2} with the term, {without:.2} without"
    );
}

/// The clearance's shortcut says free exactly where the outline does, on poses all over a
/// tunnel with a car in it, at the planner's resolutions.
#[test]
fn a_pose_clear_by_the_clearance_is_free_by_its_outline() {
    let s = tunnel(CAR);
    for res in [0.1, 0.25] {
        let grid = Grid::from_scenario(&s, res, 0.0);
        let planner = HybridAStar::new(&grid, FOOT, Params::for_radius(R));
        let (mut free, mut shortcut) = (0, 0);
        for i in 0..60 {
            for j in 0..36 {
                for k in 0..8 {
                    let p = Pose2::new(i as f64, -3.6 + 0.2 * j as f64, k as f64 * 0.8);
                    let by_outline =
                        planner.grid.cell(p.position()).is_some() && planner.outline_free(&p);
                    assert_eq!(planner.pose_free(&p), by_outline, "{p:?} at {res} m");
                    free += usize::from(by_outline);
                    shortcut += usize::from(
                        grid.cell(p.position())
                            .is_some_and(|c| grid.clearance_m(c) > planner.clear_beyond_m),
                    );
                }
            }
        }
        // Most free poses of a tunnel's open road take the shortcut.
        assert!(shortcut * 2 > free, "{shortcut} of {free} at {res} m");
    }
}
