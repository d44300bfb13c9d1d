//! Cannon elevation that lands a drag-free jet on a target.
//!
//! For horizontal distance `d`, target height `dz` relative to the nozzle and jet speed
//! `v`, the elevations solve `dz = d tan(th) - g d^2 / (2 v^2 cos^2 th)`:
//! `tan(th) = (v^2 -+ sqrt(v^4 - g (g d^2 + 2 dz v^2))) / (g d)`. The low arc is preferred:
//! it is faster, less disturbed, and stays under the tunnel ceiling.

/// Gravity, m/s^2.
const G: f64 = 9.81;

/// Why no elevation lands the jet on the target.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum NoSolution {
    #[error("target beyond the jet's reach")]
    OutOfRange,
    #[error("target geometry is degenerate")]
    Degenerate,
}

/// Low-arc and high-arc elevations, radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elevations {
    pub low: f64,
    pub high: f64,
}

/// Elevations landing a jet of speed `v` on a point `d` m away horizontally and `dz` m above
/// the nozzle.
pub fn elevations(d: f64, dz: f64, v: f64) -> Result<Elevations, NoSolution> {
    if !(d.is_finite() && dz.is_finite() && v.is_finite()) || v <= 0.0 || d < 1e-6 {
        return Err(NoSolution::Degenerate);
    }
    let disc = v.powi(4) - G * (G * d * d + 2.0 * dz * v * v);
    if disc < 0.0 {
        return Err(NoSolution::OutOfRange);
    }
    let r = disc.sqrt();
    Ok(Elevations {
        low: ((v * v - r) / (G * d)).atan(),
        high: ((v * v + r) / (G * d)).atan(),
    })
}

/// Apex height above the nozzle of a jet at elevation `th`, m.
pub fn apex_height(th: f64, v: f64) -> f64 {
    (v * th.sin()).max(0.0).powi(2) / (2.0 * G)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Height of the jet after `d` m of horizontal travel at elevation `th`.
    fn height_at(d: f64, th: f64, v: f64) -> f64 {
        d * th.tan() - G * d * d / (2.0 * v * v * th.cos().powi(2))
    }

    proptest! {
        #[test]
        fn both_arcs_land_on_the_target(d in 0.5..30.0f64, dz in -2.0..1.0f64, v in 10.0..30.0f64) {
            match elevations(d, dz, v) {
                Ok(e) => {
                    prop_assert!(e.low <= e.high);
                    prop_assert!((height_at(d, e.low, v) - dz).abs() < 1e-6);
                    prop_assert!((height_at(d, e.high, v) - dz).abs() < 1e-5);
                }
                Err(NoSolution::OutOfRange) => prop_assert!(d > v * v / G * 0.5, "reachable target refused"),
                Err(e) => prop_assert!(false, "{e}"),
            }
        }
    }

    #[test]
    fn unreachable_and_degenerate_targets_are_explicit() {
        assert_eq!(elevations(100.0, 0.0, 20.0), Err(NoSolution::OutOfRange));
        assert_eq!(elevations(f64::NAN, 0.0, 20.0), Err(NoSolution::Degenerate));
        assert_eq!(elevations(5.0, 0.0, 0.0), Err(NoSolution::Degenerate));
    }
}
