//! Placing a detected flame in the site frame.
//!
//! The localization node of the BT paper (section 3.3.2): the box centre `(u, v)` and the
//! depth there give the flame's position in the camera frame by equation 7 (with the
//! paper's typo fixed: y uses c_y and f_y), then the camera's mount and the unit's pose
//! take it to the site frame. Depth is taken robustly ([`FlameDetection::depth_m`]): the
//! median of the valid pixels of the window around the box centre, with too few valid
//! pixels meaning no position.
//!
//! Not here: tracking flames over time ([`crate::ground::tracker`]) or any image processing before
//! the detector's boxes.

use firefleet_model::geometry::{Gaussian2, Point2, Pose2};
use firefleet_model::spec::CameraSpec;
use firefleet_protocol::msg::FlameDetection;

/// A detection placed in the site frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Located {
    /// Position on the road plane with its uncertainty.
    pub estimate: Gaussian2,
    /// Height of the box centre above the road, m.
    pub height_m: f64,
    /// Half the box's width at the flame's depth, m.
    pub radius_m: f64,
}

impl Located {
    /// The heat release a flame of this size gives off, kW: Heskestad's flame-height
    /// correlation `L = 0.235 Q^0.4 - 1.02 D` (SFPE Handbook) solved for `Q`, with the
    /// flame `L` twice the box centre's height (the box spans the flame from the road up)
    /// and `D` the box's width. Coarse (a flickering flame's height varies by tens of per
    /// cent, and the heat release goes with its 5/2 power), but enough to tell a burning
    /// tyre from a burning truck, which is what deciding how many units a fire needs asks.
    /// A box whose centre noise puts at or below the road gives 0, never NaN.
    pub fn heat_release_kw(&self) -> f64 {
        let (l, d) = (2.0 * self.height_m, 2.0 * self.radius_m);
        let q = ((l + 1.02 * d).max(0.0) / 0.235).powf(2.5);
        if q.is_finite() { q } else { 0.0 }
    }
}

/// Place detection `d` seen by a camera `cam` on a unit at `pose`.
pub fn locate(d: &FlameDetection, cam: &CameraSpec, pose: &Pose2) -> Option<Located> {
    let z = d.depth_m()?;
    let (u, v) = ((d.bbox[0] + d.bbox[2]) / 2.0, (d.bbox[1] + d.bbox[3]) / 2.0);
    let [forward, left, up] = cam.camera_to_body(cam.back_project(u, v, z));
    let mean = pose.to_site(Point2::new(forward, left));
    // Depth error lies along the optical axis (the unit's heading); the box centre's pixel
    // error, scaled by depth, across it. The median of n pixels is about sqrt(pi / 2n)
    // sigma; we keep the single-pixel sigma, since neighbouring depth pixels correlate.
    let along = cam.depth_sigma_m(z);
    let across = z * cam.box_sigma_px / cam.fx;
    Some(Located {
        estimate: Gaussian2::oriented(mean, pose.yaw, along, across),
        height_m: up,
        radius_m: (d.bbox[2] - d.bbox[0]) / 2.0 * z / cam.fx,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;
    use firefleet_protocol::msg::ObjectClass;
    use proptest::prelude::*;

    #[test]
    fn heat_release_inverts_heskestads_flame_height() {
        // 5 MW over a 2 m pool: L = 0.235 * 5000^0.4 - 1.02 * 2 = 5.05 m.
        let l = 0.235 * 5000f64.powf(0.4) - 2.04;
        let seen = Located {
            estimate: Gaussian2 {
                mean: Point2::new(0.0, 0.0),
                cov: [0.1, 0.0, 0.1],
            },
            height_m: l / 2.0,
            radius_m: 1.0,
        };
        assert!((seen.heat_release_kw() - 5000.0).abs() < 1e-6);
        let below = Located {
            height_m: -1.5,
            ..seen
        };
        assert_eq!(below.heat_release_kw(), 0.0, "noise below the road: no NaN");
    }

    /// An ideal detection of a flame centred at body point `b`.
    fn detection(cam: &CameraSpec, b: [f64; 3], depth: f32) -> FlameDetection {
        let c = cam.body_to_camera(b);
        let [u, v] = cam.project(c).unwrap();
        FlameDetection {
            class: ObjectClass::Fire,
            confidence: 0.9,
            bbox: [u - 20.0, v - 30.0, u + 20.0, v + 30.0],
            depth: [depth; 25],
        }
    }

    proptest! {
        #[test]
        fn pixels_and_depth_go_back_to_the_flame(
            x in -50.0..50.0f64, y in -4.0..4.0f64, yaw in -3.0..3.0f64,
            fwd in 2.0..25.0f64, side in -0.6..0.6f64, up in 0.2..3.0f64,
        ) {
            let cam = GROUND.camera;
            let pose = Pose2::new(x, y, yaw);
            let b = [fwd, side * (fwd - cam.mount_forward_m), up];
            let z = cam.body_to_camera(b)[2];
            let l = locate(&detection(&cam, b, z as f32), &cam, &pose).unwrap();
            let truth = pose.to_site(Point2::new(b[0], b[1]));
            prop_assert!(l.estimate.mean.dist(truth) < 1e-3 * fwd, "{:?} vs {truth:?}", l.estimate.mean);
            prop_assert!((l.height_m - up).abs() < 1e-3);
            // The test box is 40 px wide.
            prop_assert!((l.radius_m - 20.0 * z / cam.fx).abs() < 1e-6);
        }
    }

    #[test]
    fn uncertainty_is_depth_along_the_axis_and_pixels_across_it() {
        let cam = GROUND.camera;
        let l = locate(
            &detection(&cam, [20.6, 0.0, 1.0], 20.0),
            &cam,
            &Pose2::default(),
        )
        .unwrap();
        let [xx, xy, yy] = l.estimate.cov;
        assert!((xx.sqrt() - cam.depth_sigma_m(20.0)).abs() < 1e-9 && xy.abs() < 1e-12);
        assert!((yy.sqrt() - 20.0 * cam.box_sigma_px / cam.fx).abs() < 1e-9);
    }
}
