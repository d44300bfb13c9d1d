//! When two places are one fire: the rule the incident's checker (matching an old
//! coordinator's fires to a new one's) and the console (a track near one put out is that
//! fire burning again) share.
//!
//! Not here: how a fire is tracked or fused (`firefleet-coordinator`'s fusion, whose gates
//! weigh each sighting's covariance), or a fire's physics (`firefleet-sim`).

use crate::geometry::Point2;

/// Two fire positions this close are one fire, m: fused estimates of one flame differ by a
/// metre or two, and separate fires in one tunnel stand further apart than this (the
/// shipped scenarios' closest pair, two flames of the cargo truck, are 6.5 m apart).
pub const SAME_FIRE_M: f64 = 6.0;

/// Whether fires at `a` and `b` are one fire.
///
/// ```
/// use firefleet_model::{Point2, fire::same_fire};
/// assert!(same_fire(Point2::new(100.0, 0.0), Point2::new(104.0, 1.0)));
/// assert!(!same_fire(Point2::new(100.0, 0.0), Point2::new(110.0, 0.0)));
/// ```
pub fn same_fire(a: Point2, b: Point2) -> bool {
    a.dist(b) <= SAME_FIRE_M
}
