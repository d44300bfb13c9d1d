//! What the fleet reckons a fire radiates: the heat term every planner, map and console
//! shares.
//!
//! A fire is a point source radiating a fixed fraction of its heat release: the flux at
//! distance `r` is `chi_r Q / (4 pi r^2)` with `chi_r = 0.3` (the radiative fraction of
//! vehicle and pool fires lies between 0.2 and 0.4), no closer than 1 m (inside the flame
//! the point-source model diverges) and capped at 100 kW/m^2 (about the flux inside a large
//! flame). It is the heat-exposure term of the Dijkstra+GA paper's cost map (eq. 6) and what
//! Hybrid A* charges a path for; the console and the recorder draw the same field so a
//! commander sees what the planners avoid.
//!
//! Not here: the simulator's own physics (its flames radiate by their own model) or how a
//! fire track becomes a source (that is the track's, in `firefleet-protocol`).

use crate::geometry::Point2;

/// A fire as a heat source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeatSource {
    pub at: Point2,
    pub hrr_kw: f64,
}

/// Radiant flux from `sources` at `p`, kW/m^2: point sources radiating 30 % of their heat
/// release, no closer than 1 m, capped at 100 kW/m^2.
///
/// Inline: Hybrid A* calls it for every primitive it expands, from another crate.
#[inline]
pub fn radiant_flux_kw_m2(sources: &[HeatSource], p: Point2) -> f64 {
    sources
        .iter()
        .map(|s| {
            let r = s.at.dist(p).max(1.0);
            0.3 * s.hrr_kw / (4.0 * std::f64::consts::PI * r * r)
        })
        .sum::<f64>()
        .min(100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flux_falls_with_the_square_of_distance_and_is_capped() {
        let fire = [HeatSource {
            at: Point2::new(0.0, 0.0),
            hrr_kw: 5000.0,
        }];
        let q2 = radiant_flux_kw_m2(&fire, Point2::new(2.0, 0.0));
        let q4 = radiant_flux_kw_m2(&fire, Point2::new(4.0, 0.0));
        assert!((q2 / q4 - 4.0).abs() < 1e-9);
        let big = [HeatSource {
            at: Point2::new(0.0, 0.0),
            hrr_kw: 1e6,
        }];
        assert_eq!(radiant_flux_kw_m2(&big, Point2::new(0.5, 0.0)), 100.0);
    }
}
