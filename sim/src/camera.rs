//! Line of sight in the tunnel and the simulated flame detector.
//!
//! The detector stands in for a YOLO-style detector on an RGB-D camera: it reports each
//! visible flame as a bearing, a depth and a confidence, misses some, and is blind beyond
//! its range, outside its field of view and behind parked vehicles.

use firefleet_protocol::geometry::Pose2;
use firefleet_protocol::msg::FlameDetection;
use firefleet_protocol::scenario::Obstacle;
use firefleet_protocol::spec::GroundSpec;
use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::physics;

/// A point in the site frame with height, m.
pub type P3 = [f64; 3];

/// Whether the segment `a`-`b` passes through the obstacle's box (slab test in the box
/// frame).
pub fn segment_hits(o: &Obstacle, a: P3, b: P3) -> bool {
    let pose = o.pose();
    let la = pose.to_body(firefleet_protocol::Point2::new(a[0], a[1]));
    let lb = pose.to_body(firefleet_protocol::Point2::new(b[0], b[1]));
    let start = [la.x, la.y, a[2]];
    let dir = [lb.x - la.x, lb.y - la.y, b[2] - a[2]];
    let lo = [-o.length_m / 2.0, -o.width_m / 2.0, 0.0];
    let hi = [o.length_m / 2.0, o.width_m / 2.0, o.height_m];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for k in 0..3 {
        if dir[k].abs() < 1e-12 {
            if start[k] < lo[k] || start[k] > hi[k] {
                return false;
            }
        } else {
            let (mut ta, mut tb) = ((lo[k] - start[k]) / dir[k], (hi[k] - start[k]) / dir[k]);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
            if t0 > t1 {
                return false;
            }
        }
    }
    true
}

/// Whether any obstacle blocks the straight line between `a` and `b`.
pub fn line_blocked(obstacles: &[Obstacle], a: P3, b: P3) -> bool {
    obstacles.iter().any(|o| segment_hits(o, a, b))
}

/// One flame as the detector could see it.
#[derive(Debug, Clone, Copy)]
pub struct FlameTarget {
    /// Middle of the flame, site frame.
    pub centre: P3,
}

/// Detect flames from a unit at `pose`; `rng` draws misses and noise.
pub fn detect(
    spec: &GroundSpec,
    pose: &Pose2,
    flames: &[FlameTarget],
    obstacles: &[Obstacle],
    rng: &mut impl Rng,
) -> Vec<FlameDetection> {
    let cam = [pose.x, pose.y, spec.camera_height_m];
    let bearing_noise = Normal::new(0.0, spec.camera_bearing_sigma_rad).expect("positive sigma");
    let mut out = Vec::new();
    for f in flames {
        let body = pose.to_body(firefleet_protocol::Point2::new(f.centre[0], f.centre[1]));
        let bearing = body.y.atan2(body.x);
        let range = (body.x.powi(2) + body.y.powi(2) + (f.centre[2] - cam[2]).powi(2)).sqrt();
        if bearing.abs() > spec.camera_hfov_rad / 2.0
            || range > spec.camera_range_m
            || line_blocked(obstacles, cam, f.centre)
        {
            continue;
        }
        // Draw every random number whether or not the flame is missed, so that one miss
        // does not shift the noise of every later detection.
        let missed = rng.random::<f64>() < physics::DETECT_MISS_PROB;
        let db = bearing_noise.sample(rng);
        let dr = Normal::new(0.0, spec.depth_sigma_m(range))
            .expect("positive sigma")
            .sample(rng);
        let dc: f64 = rng.random_range(-0.05..0.05);
        if missed {
            continue;
        }
        out.push(FlameDetection {
            bearing: (bearing + db).clamp(-std::f64::consts::PI, std::f64::consts::PI),
            range: (range + dr).max(0.1),
            confidence: (0.95 - 0.3 * range / spec.camera_range_m + dc).clamp(0.05, 0.99),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::spec::GROUND;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn car(x: f64, y: f64) -> Obstacle {
        Obstacle {
            name: "car".into(),
            x_m: x,
            y_m: y,
            length_m: 4.0,
            width_m: 2.0,
            height_m: 1.5,
            yaw_rad: 0.0,
        }
    }

    #[test]
    fn segment_box_intersection() {
        let c = car(10.0, 0.0);
        assert!(segment_hits(&c, [0.0, 0.0, 1.0], [20.0, 0.0, 1.0]));
        assert!(
            !segment_hits(&c, [0.0, 0.0, 2.0], [20.0, 0.0, 2.0]),
            "passes over the roof"
        );
        assert!(
            !segment_hits(&c, [0.0, 3.0, 1.0], [20.0, 3.0, 1.0]),
            "passes beside"
        );
        assert!(
            !segment_hits(&c, [0.0, 0.0, 1.0], [5.0, 0.0, 1.0]),
            "stops short"
        );
    }

    #[test]
    fn detector_sees_only_what_is_in_view_and_unoccluded() {
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let flame = FlameTarget {
            centre: [15.0, 0.0, 0.8],
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let seen = (0..200)
            .filter(|_| !detect(&GROUND, &pose, &[flame], &[], &mut rng).is_empty())
            .count();
        assert!(
            seen > 170 && seen < 200,
            "misses at the documented rate: {seen}"
        );
        assert!(
            detect(&GROUND, &pose, &[flame], &[car(8.0, 0.0)], &mut rng).is_empty(),
            "occluded"
        );
        let behind = Pose2::new(0.0, 0.0, std::f64::consts::PI);
        assert!(
            detect(&GROUND, &behind, &[flame], &[], &mut rng).is_empty(),
            "outside the field of view"
        );
        let far = FlameTarget {
            centre: [45.0, 0.0, 0.8],
        };
        assert!(
            detect(&GROUND, &pose, &[far], &[], &mut rng).is_empty(),
            "beyond range"
        );
    }

    #[test]
    fn detections_are_close_to_truth() {
        let pose = Pose2::new(2.0, 1.0, 0.3);
        let flame = FlameTarget {
            centre: [12.0, 3.0, 0.8],
        };
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let d = (0..20)
            .find_map(|_| detect(&GROUND, &pose, &[flame], &[], &mut rng).pop())
            .unwrap();
        let truth_bearing = (2.0f64).atan2(10.0) - 0.3;
        assert!((d.bearing - truth_bearing).abs() < 0.05);
        assert!((d.range - (104.0f64 + 0.04).sqrt()).abs() < 1.0);
    }
}
