//! Physical specification of the ground and monorail units.
//!
//! The simulator moves bodies with these limits and the agent plans with them, the way a
//! real vehicle's datasheet serves both its firmware and its planners. A robot model's
//! values come from its profile ([`crate::profile`], where the shipped defaults
//! [`crate::profile::GROUND`] and [`crate::profile::MONORAIL`] are read). This module has the
//! types only, so profiles (data) depend on specs (shapes) and not the other way round. The field docs
//! below say why the shipped values are what they are: stated assumptions for a mid-size
//! tunnel firefighting robot (LUF 60 / Thermite class), not tuned to any experiment.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::geometry::{Point2, Pose2};

/// Ground vehicle or ceiling-rail carriage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum UnitKind {
    Ground,
    Monorail,
}

crate::names!(UnitKind, "a kind of unit" {
    Ground => "ground",
    Monorail => "monorail",
});

/// Limits and geometry of a ground unit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GroundSpec {
    /// Axle-to-axle distance of the bicycle model, m.
    pub wheelbase_m: f64,
    /// Body length and width (footprint rectangle centred on the pose), m.
    pub length_m: f64,
    pub width_m: f64,
    /// Top speed forward and reverse, m/s. Firefighting robots of this class drive at
    /// 3.6 to 8 km/h; we take 1.5 m/s (5.4 km/h).
    pub max_speed_m_s: f64,
    pub max_accel_m_s2: f64,
    /// Steering angle limit, rad, and how fast the steering moves, rad/s.
    pub max_steer_rad: f64,
    pub max_steer_rate_rad_s: f64,
    /// Water carried at the start, litres.
    pub tank_l: f64,
    /// Cannon flow with the valve open, L/s (600 L/min, a small robot monitor).
    pub cannon_flow_l_s: f64,
    /// The monitor's nozzle and the speed of its jet.
    pub nozzle: NozzleSpec,
    /// Nozzle height above the road, m.
    pub cannon_height_m: f64,
    /// Pan limit either side of straight ahead, rad; elevation range, rad.
    pub cannon_pan_limit_rad: f64,
    pub cannon_tilt_min_rad: f64,
    pub cannon_tilt_max_rad: f64,
    /// Slew rates of remote-controlled monitors, rad/s (about 30 and 20 deg/s).
    pub cannon_pan_rate_rad_s: f64,
    pub cannon_tilt_rate_rad_s: f64,
    /// The RGB-D camera the flame detector looks through.
    pub camera: CameraSpec,
    /// A radiometric thermal core registered to the depth camera, if the unit has one:
    /// the pixel flame detector looks through it. Its `depth_*` fields are the depth
    /// camera's as registered to it; `box_sigma_px` is the core's pixel noise on a region.
    #[serde(default)]
    pub thermal_camera: Option<CameraSpec>,
}

/// A monitor nozzle and its effective jet exit speed, the BT paper's equation 9:
/// `v_e = C_d sqrt(2 P / (rho (1 + f L / D) (1 + gamma r / D)))`, where `1 + f L / D` is the
/// friction loss in the monitor's piping and `1 + gamma r / D` an empirical correction for
/// air resistance and jet dispersion over a horizontal reach `r`.
///
/// Values: a 25 mm smooth bore at 6 bar (robot monitors run 4 to 10 bar), discharge
/// coefficient 0.97 (smooth-bore nozzles), Darcy friction 0.02 over 1.5 m of 25 mm piping
/// (turbulent flow in a smooth pipe). The paper gives no gamma; 0.001 makes the reach at 45
/// degrees about 26 m, the order of small robot monitors' published reach. Flow at 6 bar:
/// `C_d A v_e(0)` = 0.97 x 4.9 cm^2 x 22.7 m/s, about 11 L/s.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NozzleSpec {
    pub pressure_pa: f64,
    pub discharge_coeff: f64,
    pub friction_factor: f64,
    pub pipe_length_m: f64,
    pub diameter_m: f64,
    pub dispersion_gamma: f64,
}

/// Density of water, kg/m^3.
const WATER_DENSITY: f64 = 1000.0;

impl NozzleSpec {
    /// Effective exit speed for a jet reaching `reach_m` horizontally, m/s (equation 9).
    pub fn exit_speed_m_s(&self, reach_m: f64) -> f64 {
        let friction = 1.0 + self.friction_factor * self.pipe_length_m / self.diameter_m;
        let dispersion = 1.0 + self.dispersion_gamma * reach_m.max(0.0) / self.diameter_m;
        self.discharge_coeff
            * (2.0 * self.pressure_pa / (WATER_DENSITY * friction * dispersion)).sqrt()
    }
}

/// A forward-looking pinhole RGB-D camera on the body, optical axis horizontal.
///
/// Frames: the camera frame has x right, y down, z forward along the optical axis (the
/// OpenCV / RealSense convention); the body frame has x forward, y left, z up. Depth is
/// z-depth (along the optical axis), as depth cameras report it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    pub width_px: f64,
    pub height_px: f64,
    /// Focal lengths and principal point, pixels.
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
    /// The camera sits on the cannon and pans with it (as on many robot monitors), so it
    /// sees what the cannon aims at; otherwise it looks along the body.
    pub pans_with_cannon: bool,
    /// Optical centre ahead of the pan axis (the pose origin), and above the road, m.
    pub mount_forward_m: f64,
    pub mount_height_m: f64,
    /// Range to which the detector finds flames, m.
    pub range_m: f64,
    /// Depth noise `a + b z^2` (one sigma, m): stereo depth error grows with the square of
    /// depth (Intel RealSense D400 RMS error model; a long-baseline pair is assumed so that
    /// depth is usable to 30 m).
    pub depth_sigma_a_m: f64,
    pub depth_sigma_b_per_m: f64,
    /// Fraction of depth pixels with no value on a flame (bright, textureless, flickering:
    /// stereo matching fails on a part of it).
    pub depth_dropout: f64,
    /// Jitter of a detector's box edges, pixels (one sigma).
    pub box_sigma_px: f64,
}

impl CameraSpec {
    /// The pose the camera looks from: the body's, turned by the cannon's pan if the camera
    /// rides on the cannon. Camera and body frames above are relative to this pose.
    pub fn looking_from(&self, body: &Pose2, cannon_pan: f64) -> Pose2 {
        if self.pans_with_cannon {
            Pose2::new(body.x, body.y, body.yaw + cannon_pan)
        } else {
            *body
        }
    }

    /// Whether the camera, looking from `look` ([`Self::looking_from`]), faces the site
    /// point `p`: `p` at the camera's own height lands inside the image's width, in front
    /// of the lens and within [`Self::range_m`]. Whether the camera is turned to where a
    /// flame is, not whether it would see one there: smoke, walls and vehicles are the
    /// world's, and a flame stands higher than the camera or lower as it will.
    pub fn faces(&self, look: &Pose2, p: Point2) -> bool {
        let b = look.to_body(p);
        let c = self.body_to_camera([b.x, b.y, self.mount_height_m]);
        let depth_ok = c[2].hypot(c[0]) <= self.range_m;
        depth_ok
            && self
                .project(c)
                .is_some_and(|[u, _]| (0.0..self.width_px).contains(&u))
    }

    /// Depth noise (one sigma) at depth `z`, m.
    pub fn depth_sigma_m(&self, z: f64) -> f64 {
        self.depth_sigma_a_m + self.depth_sigma_b_per_m * z * z
    }

    /// Horizontal field of view, rad.
    pub fn hfov_rad(&self) -> f64 {
        2.0 * (self.width_px / 2.0 / self.fx).atan()
    }

    /// Camera-frame coordinates of a body-frame point `[forward, left, up]`.
    pub fn body_to_camera(&self, b: [f64; 3]) -> [f64; 3] {
        [
            -b[1],
            self.mount_height_m - b[2],
            b[0] - self.mount_forward_m,
        ]
    }

    /// Body-frame coordinates `[forward, left, up]` of a camera-frame point.
    pub fn camera_to_body(&self, c: [f64; 3]) -> [f64; 3] {
        [
            c[2] + self.mount_forward_m,
            -c[0],
            self.mount_height_m - c[1],
        ]
    }

    /// Pixel of a camera-frame point in front of the camera.
    pub fn project(&self, c: [f64; 3]) -> Option<[f64; 2]> {
        (c[2] > 0.05).then(|| {
            [
                self.cx + self.fx * c[0] / c[2],
                self.cy + self.fy * c[1] / c[2],
            ]
        })
    }

    /// The camera-frame point at pixel `(u, v)` and depth `z`: the BT paper's equation 7,
    /// with its typo fixed (the paper writes `y = (v - c_x) z / f_x`; y uses `c_y` and `f_y`).
    pub fn back_project(&self, u: f64, v: f64, z: f64) -> [f64; 3] {
        [(u - self.cx) * z / self.fx, (v - self.cy) * z / self.fy, z]
    }
}

impl GroundSpec {
    /// Minimum turning radius of the bicycle model, m.
    pub fn min_turn_radius_m(&self) -> f64 {
        self.wheelbase_m / self.max_steer_rad.tan()
    }
    /// Radius of the circle that encloses the footprint, m.
    pub fn circumradius_m(&self) -> f64 {
        0.5 * self.length_m.hypot(self.width_m)
    }
}

/// Limits and geometry of a monorail unit: the ROBOGAT carriage and monitor.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MonorailSpec {
    /// Length of the monitor's second link, m (the paper's `l`).
    pub link_m: f64,
    /// Joint limits: monitor yaw either side, elevation range, nozzle speed range.
    pub theta1_limit_rad: f64,
    pub theta2_min_rad: f64,
    pub theta2_max_rad: f64,
    pub v0_min_m_s: f64,
    pub v0_max_m_s: f64,
    /// Top carriage speed (`v_dM`), monitor rate (`v_mM`) and rate of change of the nozzle
    /// speed (`r_0M`).
    pub carriage_speed_m_s: f64,
    pub monitor_rate_rad_s: f64,
    pub nozzle_rate_m_s2: f64,
    /// Monitor flow with the valve open, L/s (the paper's 8e-3 m^3/s).
    pub flow_l_s: f64,
    /// How far the telescopic tubes let the carriage move from the hose point it is
    /// plugged into, m. Hose points stand about 30 m apart, so +-15 m covers the rail.
    pub hose_reach_m: f64,
    /// Range of the fire detector and the thermal camera, m.
    pub detector_range_m: f64,
    /// Thermal-camera position error `a + b * range` (one sigma), m: a 640-pixel
    /// long-wave camera with a 60 degree field of view resolves 1.6 mrad per pixel, so a
    /// few pixels of blob-centroid error at 30 m is about 0.3 m.
    pub hot_spot_sigma_a_m: f64,
    pub hot_spot_sigma_b: f64,
    /// Horizontal distance from the carriage within which the monitor works a fire
    /// without straining, m: a level jet at 18 m/s (two thirds of full speed) from a pivot
    /// 4 to 6 m above the road lands 17 to 20 m away (checked in
    /// `firefleet_agent::monorail`). The coordinator sends a monorail unit only to fires
    /// this close to its rail.
    pub working_reach_m: f64,
    /// Time to plug into a hose point and have water at the monitor, s. The ROBOGAT
    /// carriage "is automatically connected to a fire hose" at its place of intervention;
    /// the paper gives no time. Ours: stop, engage the coupling, open the hydrant valve and
    /// fill the telescopic tubes, 10 s (a chosen figure; a site measures its own).
    #[serde(default = "default_coupling_s")]
    pub coupling_s: f64,
}

fn default_coupling_s() -> f64 {
    10.0
}

/// What a monorail unit reports as its water, L: it draws from the tunnel's main, which a
/// unit cannot run dry, so it reports a volume no incident uses up.
pub const MAINS_WATER_L: f64 = 100_000.0;

#[cfg(test)]
mod tests {
    use crate::profile::GROUND;

    use super::UnitKind;

    #[test]
    fn unit_kinds_are_named_as_on_the_wire() {
        for k in UnitKind::ALL {
            assert_eq!(serde_json::to_value(k).unwrap(), k.as_str());
            assert_eq!(k.as_str().parse::<UnitKind>(), Ok(*k));
        }
        let e = "tracked".parse::<UnitKind>().unwrap_err();
        assert_eq!(e, "'tracked' is not a kind of unit (ground, monorail)");
    }

    #[test]
    fn a_camera_faces_what_lies_within_its_field_and_range_as_it_pans() {
        use crate::geometry::{Point2, Pose2};
        let cam = GROUND.camera;
        let body = Pose2::new(0.0, 0.0, 0.0);
        let half = cam.hfov_rad() / 2.0;
        let at = |bearing: f64, r: f64| Point2::new(r * bearing.cos(), r * bearing.sin());
        let ahead = cam.looking_from(&body, 0.0);
        assert!(cam.faces(&ahead, at(0.0, 8.0)));
        assert!(cam.faces(&ahead, at(half - 0.05, 8.0)));
        assert!(!cam.faces(&ahead, at(half + 0.05, 8.0)), "beside the field");
        assert!(!cam.faces(&ahead, at(std::f64::consts::PI, 8.0)), "behind");
        assert!(
            !cam.faces(&ahead, at(0.0, cam.range_m + 1.0)),
            "out of range"
        );
        // The cannon panned away: a camera on it looks elsewhere.
        let panned = cam.looking_from(&body, 2.0 * half);
        assert_eq!(cam.faces(&panned, at(0.0, 8.0)), !cam.pans_with_cannon);
    }

    #[test]
    fn camera_projection_and_equation_7_are_inverse() {
        let cam = GROUND.camera;
        assert!((cam.hfov_rad().to_degrees() - 69.0).abs() < 0.05);
        for b in [[10.0, 2.0, 0.3], [5.0, -1.0, 2.5], [25.0, 0.0, 1.0]] {
            let c = cam.body_to_camera(b);
            let [u, v] = cam.project(c).unwrap();
            let back = cam.camera_to_body(cam.back_project(u, v, c[2]));
            for k in 0..3 {
                assert!((back[k] - b[k]).abs() < 1e-9, "{b:?} -> {back:?}");
            }
        }
        assert!(
            cam.project(cam.body_to_camera([-3.0, 0.0, 1.0])).is_none(),
            "behind the camera"
        );
    }

    #[test]
    fn equation_9_exit_speed() {
        let n = GROUND.nozzle;
        // 0.97 sqrt(2 x 6e5 / (1000 x 2.2)) = 22.65 m/s with no reach correction.
        assert!(
            (n.exit_speed_m_s(0.0) - 22.65).abs() < 0.01,
            "{}",
            n.exit_speed_m_s(0.0)
        );
        assert!(
            n.exit_speed_m_s(10.0) < n.exit_speed_m_s(5.0),
            "dispersion slows longer jets"
        );
        // Reach at 45 degrees from the road: R = v_e(R)^2 / g has its root near 26 m.
        let reach = (0..200)
            .map(|k| k as f64 * 0.25)
            .find(|r| *r >= n.exit_speed_m_s(*r).powi(2) / 9.81)
            .unwrap();
        assert!((24.0..28.0).contains(&reach), "{reach}");
    }

    #[test]
    fn ground_unit_turns_in_a_tunnel_lane() {
        // A 3.5 m lane must allow a U-turn in two lanes: radius well under 3.5 m.
        let r = GROUND.min_turn_radius_m();
        assert!(r > 1.0 && r < 3.5, "{r}");
    }
}
