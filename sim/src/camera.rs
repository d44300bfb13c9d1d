//! Line of sight in the tunnel and the simulated flame detector.
//!
//! The detector stands in for a YOLO-style detector on an RGB-D camera: each visible flame
//! becomes a bounding box in the image (pinhole projection of the flame's width and
//! height) with a class, a confidence and the aligned depth image's pixels around the box
//! centre. It misses flames, reports false alarms, and sees nothing beyond its range,
//! outside the image, or behind parked vehicles. A real detector replaces this stream and
//! the agent cannot tell the difference.

use firefleet_model::Point2;
use firefleet_model::geometry::Pose2;
use firefleet_model::scenario::{Obstacle, Tunnel};
use firefleet_model::spec::CameraSpec;
use firefleet_protocol::msg::{DEPTH_WINDOW, FlameDetection, ObjectClass};
use rand::Rng;
use rand_distr::{Distribution, Normal};

use crate::physics;

/// A point in the site frame with height, m.
pub type P3 = [f64; 3];

/// Whether the segment `a`-`b` passes through the obstacle's box (slab test in the box
/// frame).
pub fn segment_hits(o: &Obstacle, a: P3, b: P3) -> bool {
    let pose = o.pose();
    let la = pose.to_body(Point2::new(a[0], a[1]));
    let lb = pose.to_body(Point2::new(b[0], b[1]));
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

/// Whether a wall or an obstacle blocks the straight line between `a` and `b`. The walls
/// of a straight tunnel never do (the road is convex); round a bend the inner wall does.
pub fn line_blocked(tunnel: &Tunnel, obstacles: &[Obstacle], a: P3, b: P3) -> bool {
    let plan = |p: P3| Point2::new(p[0], p[1]);
    (!tunnel.is_straight() && !tunnel.segment_inside(plan(a), plan(b)))
        || obstacles.iter().any(|o| segment_hits(o, a, b))
}

/// One flame as the camera could see it.
#[derive(Debug, Clone, Copy)]
pub struct FlameTarget {
    /// Middle of the flame, site frame.
    pub centre: P3,
    pub radius_m: f64,
    pub height_m: f64,
}

fn depth_window(
    z: f64,
    cam: &CameraSpec,
    rng: &mut impl Rng,
) -> [f32; DEPTH_WINDOW * DEPTH_WINDOW] {
    let noise = Normal::new(0.0, cam.depth_sigma_m(z)).expect("positive sigma");
    std::array::from_fn(|_| {
        let drop = rng.random::<f64>() < cam.depth_dropout;
        let v = (z + noise.sample(rng)).max(0.1);
        if drop { 0.0 } else { v as f32 }
    })
}

/// A flame in the image: its centre in the camera frame, its range and its box.
struct Imaged {
    c: P3,
    range: f64,
    corners: [f64; 4],
}

/// Where flame `f` appears to a camera at `pose`, if it is in the image, within range and
/// in plain sight.
fn image(
    cam: &CameraSpec,
    pose: &Pose2,
    f: &FlameTarget,
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
) -> Option<Imaged> {
    let b = pose.to_body(Point2::new(f.centre[0], f.centre[1]));
    let c = cam.body_to_camera([b.x, b.y, f.centre[2]]);
    let range = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
    let [u0, v0] = cam.project([c[0] - f.radius_m, c[1] - f.height_m / 2.0, c[2]])?;
    let [u1, v1] = cam.project([c[0] + f.radius_m, c[1] + f.height_m / 2.0, c[2]])?;
    let (uc, vc) = ((u0 + u1) / 2.0, (v0 + v1) / 2.0);
    let in_image = (0.0..cam.width_px).contains(&uc) && (0.0..cam.height_px).contains(&vc);
    let optical_centre = pose.to_site(Point2::new(cam.mount_forward_m, 0.0));
    let eye = [optical_centre.x, optical_centre.y, cam.mount_height_m];
    (in_image && range <= cam.range_m && !line_blocked(tunnel, obstacles, eye, f.centre)).then_some(
        Imaged {
            c,
            range,
            corners: [u0, v0, u1, v1],
        },
    )
}

/// Whether a camera at `pose` has flame `f` in view: in the image, within range, not
/// hidden by a wall or a vehicle. What the detector would see if it never missed.
pub fn in_view(
    cam: &CameraSpec,
    pose: &Pose2,
    f: &FlameTarget,
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
) -> bool {
    image(cam, pose, f, tunnel, obstacles).is_some()
}

/// Detect flames from a unit at `pose` through smoke of extinction `smoke_per_m` (at least
/// [`physics::SMOKE_EXTINCTION_PER_M`]); `rng` draws misses, false alarms and noise.
pub fn detect(
    cam: &CameraSpec,
    pose: &Pose2,
    flames: &[FlameTarget],
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
    smoke_per_m: f64,
    rng: &mut impl Rng,
) -> Vec<FlameDetection> {
    let edge = Normal::new(0.0, cam.box_sigma_px).expect("positive sigma");
    let mut out = Vec::new();
    for f in flames {
        let Some(Imaged {
            c,
            range,
            corners: [u0, v0, u1, v1],
        }) = image(cam, pose, f, tunnel, obstacles)
        else {
            continue;
        };
        // Draw every random number whether or not the flame is missed, so that one miss
        // does not shift the noise of every later detection.
        let missed = rng.random::<f64>() < physics::DETECT_MISS_PROB;
        let jitter: [f64; 4] = std::array::from_fn(|_| edge.sample(rng));
        let depth = depth_window(c[2], cam, rng);
        let dc: f64 = rng.random_range(-0.05..0.05);
        if missed {
            continue;
        }
        let clip = |v: f64, max: f64| v.clamp(0.0, max);
        // Jitter can cross the edges of a box a few pixels wide (a small, distant flame):
        // keep each pair ordered, as a detector's boxes are.
        let (ua, ub) = (
            clip(u0 + jitter[0], cam.width_px),
            clip(u1 + jitter[2], cam.width_px),
        );
        let (va, vb) = (
            clip(v0 + jitter[1], cam.height_px),
            clip(v1 + jitter[3], cam.height_px),
        );
        let confidence = ((0.95 - 0.3 * range / cam.range_m) * (-smoke_per_m * range).exp() + dc)
            .clamp(0.05, 0.99);
        out.push(FlameDetection {
            class: ObjectClass::Fire,
            confidence,
            bbox: [ua.min(ub), va.min(vb), ua.max(ub), va.max(vb)],
            depth,
        });
    }
    if rng.random::<f64>() < physics::FALSE_ALARM_PROB {
        let (u, v) = (
            rng.random_range(0.0..cam.width_px),
            rng.random_range(cam.cy..cam.height_px),
        );
        let (w, h) = (rng.random_range(8.0..40.0), rng.random_range(8.0..40.0));
        let z = rng.random_range(3.0..cam.range_m);
        out.push(FlameDetection {
            class: ObjectClass::Fire,
            confidence: rng.random_range(0.3..0.6),
            bbox: [
                (u - w / 2.0).max(0.0),
                (v - h / 2.0).max(0.0),
                (u + w / 2.0).min(cam.width_px),
                (v + h / 2.0).min(cam.height_px),
            ],
            depth: depth_window(z, cam, rng),
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// A straight road wide enough that its walls never matter.
    fn open_road() -> Tunnel {
        Tunnel::straight(1000.0, 50.0, 10.0, 2)
    }

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

    fn flame(x: f64, y: f64) -> FlameTarget {
        FlameTarget {
            centre: [x, y, 0.8],
            radius_m: 0.8,
            height_m: 1.6,
        }
    }

    /// Detections of true flames only (false alarms have confidence below 0.6).
    fn seen(
        pose: &Pose2,
        f: FlameTarget,
        obstacles: &[Obstacle],
        rng: &mut ChaCha8Rng,
    ) -> Vec<FlameDetection> {
        let road = open_road();
        detect(
            &GROUND.camera,
            pose,
            &[f],
            &road,
            obstacles,
            physics::SMOKE_EXTINCTION_PER_M,
            rng,
        )
        .into_iter()
        .filter(|d| d.confidence > 0.6)
        .collect()
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
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let hits = (0..400)
            .filter(|_| !seen(&pose, flame(15.0, 0.0), &[], &mut rng).is_empty())
            .count();
        assert!(
            hits > 360 && hits < 400,
            "misses at the documented rate: {hits}"
        );
        assert!(
            seen(&pose, flame(15.0, 0.0), &[car(8.0, 0.0)], &mut rng).is_empty(),
            "occluded"
        );
        assert!(
            seen(
                &Pose2::new(0.0, 0.0, std::f64::consts::PI),
                flame(15.0, 0.0),
                &[],
                &mut rng
            )
            .is_empty(),
            "behind"
        );
        assert!(
            seen(&pose, flame(10.0, 9.0), &[], &mut rng).is_empty(),
            "outside the image (42 deg off axis)"
        );
        assert!(
            seen(&pose, flame(45.0, 0.0), &[], &mut rng).is_empty(),
            "beyond range"
        );
    }

    #[test]
    fn boxes_are_where_the_pinhole_model_puts_the_flame() {
        let cam = GROUND.camera;
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let d = (0..20)
            .find_map(|_| seen(&pose, flame(10.6, 1.0), &[], &mut rng).pop())
            .unwrap();
        // Flame centre 10 m ahead of the camera, 1 m to the left, 0.2 m below it.
        let (uc, vc) = ((d.bbox[0] + d.bbox[2]) / 2.0, (d.bbox[1] + d.bbox[3]) / 2.0);
        assert!((uc - (cam.cx - cam.fx * 1.0 / 10.0)).abs() < 6.0, "{uc}");
        assert!((vc - (cam.cy + cam.fy * 0.2 / 10.0)).abs() < 6.0, "{vc}");
        assert!(
            ((d.bbox[2] - d.bbox[0]) - cam.fx * 1.6 / 10.0).abs() < 8.0,
            "box width is the flame's"
        );
        let valid: Vec<f32> = d.depth.iter().copied().filter(|z| *z > 0.0).collect();
        assert!(valid.len() >= 15);
        assert!(
            valid.iter().all(|z| (f64::from(*z) - 10.0).abs() < 1.5),
            "{valid:?}"
        );
    }

    #[test]
    fn every_detection_is_a_valid_message() {
        use firefleet_model::Validate;
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        // Small flames far away (boxes a few pixels high) and close ones.
        let flames = [
            FlameTarget {
                centre: [29.0, 0.0, 0.1],
                radius_m: 0.1,
                height_m: 0.2,
            },
            FlameTarget {
                centre: [4.0, 1.0, 1.0],
                radius_m: 1.0,
                height_m: 2.0,
            },
        ];
        for _ in 0..5000 {
            for d in detect(
                &GROUND.camera,
                &Pose2::default(),
                &flames,
                &open_road(),
                &[],
                physics::SMOKE_EXTINCTION_PER_M,
                &mut rng,
            ) {
                d.validate().unwrap();
            }
        }
    }

    #[test]
    fn false_alarms_appear_at_their_documented_rate() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let frames = 20_000;
        let alarms: usize = (0..frames)
            .map(|_| {
                detect(
                    &GROUND.camera,
                    &Pose2::default(),
                    &[],
                    &open_road(),
                    &[],
                    physics::SMOKE_EXTINCTION_PER_M,
                    &mut rng,
                )
                .len()
            })
            .sum();
        let rate = alarms as f64 / frames as f64;
        assert!((rate - physics::FALSE_ALARM_PROB).abs() < 0.004, "{rate}");
    }
}
