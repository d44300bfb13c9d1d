//! The agent's firing solutions, flown by the simulator's jet: they land on the target
//! across the working range, and targets out of reach or behind the ceiling get an
//! explicit "no firing solution".

use firefleet_agent::ground::aim::{self, NoSolution};
use firefleet_model::Point2;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Tunnel;
use firefleet_sim::jet::{self, Landing};
use proptest::prelude::*;

const TUNNEL: Tunnel = Tunnel {
    length_m: 200.0,
    width_m: 10.0,
    height_m: 6.3,
    lanes: 2,
    centerline: Vec::new(),
};

/// Solve within the cannon's limits and under a ceiling `ceiling_m` high, then fly the jet.
fn shoot_under(ceiling_m: f64, d: f64, bearing: f64) -> Result<Landing, NoSolution> {
    let (h, spec) = (GROUND.cannon_height_m, *GROUND);
    let shot = aim::solve(&spec.nozzle, d, -h, |th, v| {
        (spec.cannon_tilt_min_rad..=spec.cannon_tilt_max_rad).contains(&th)
            && h + (v * th.sin()).max(0.0).powi(2) / (2.0 * 9.81) < ceiling_m - 0.3
    })?;
    let tunnel = Tunnel {
        height_m: ceiling_m,
        ..TUNNEL
    };
    Ok(jet::trace(
        &tunnel,
        &[],
        [100.0, 0.0, h],
        bearing,
        shot.elevation,
        &spec.nozzle,
    ))
}

fn shoot(d: f64, bearing: f64) -> Result<Landing, NoSolution> {
    shoot_under(TUNNEL.height_m, d, bearing)
}

proptest! {
    #[test]
    fn solved_shots_land_on_the_target(d in 4.0..20.0f64, bearing in -0.2..0.2f64) {
        match shoot(d, bearing) {
            Ok(Landing::Road { at, .. }) => {
                let target = Point2::new(100.0, 0.0).offset(bearing, d);
                prop_assert!(at.dist(target) < 0.05, "missed by {:.3} m at {d:.1} m", at.dist(target));
            }
            Ok(Landing::Blocked | Landing::Vehicle { .. }) => {
                prop_assert!(false, "a solved shot was blocked")
            }
            Err(e) => prop_assert!(d > 15.0, "no solution at {d:.1} m: {e}"),
        }
    }
}

#[test]
fn out_of_reach_and_too_close_targets_are_refused_explicitly() {
    assert_eq!(shoot(40.0, 0.0), Err(NoSolution::OutOfRange));
    // 2 m away the jet would have to point 30 deg down; the cannon stops at -15.
    assert_eq!(shoot(2.0, 0.0), Err(NoSolution::Blocked));
    // 20 m away the low arc peaks 2.5 m above the road: under a 2.6 m ceiling (with its
    // 0.3 m margin) it is blocked, and the high arc is steeper than the cannon's 60 deg.
    assert!(matches!(
        shoot_under(6.3, 20.0, 0.0),
        Ok(Landing::Road { .. })
    ));
    assert_eq!(shoot_under(2.6, 20.0, 0.0), Err(NoSolution::Blocked));
}
