//! Robot profiles: a robot model's datasheet as a TOML file.
//!
//! A profile says what a ground unit's planners, controller and aim need of the body
//! (footprint, wheelbase, speeds, steering, cannon limits and rates, nozzle, tank, camera
//! intrinsics and mount, detector range) or what a monorail unit's CLIK and planner need of
//! its carriage and monitor. `kind = "ground"` or `"monorail"`, then the fields of
//! [`GroundSpec`] or [`MonorailSpec`] (units in the names, angles in radians).
//!
//! Profiles ship with firefleet (`model/profiles/*.toml`: `luf60`, the small unit every
//! shipped scenario uses; `heavy-ugv`; `robogat`, the paper's monorail unit), and a site
//! file may define its own under `[profiles.<name>]`; a unit names its profile with
//! `profile = "<name>"`. Every profile is validated like the site file: the error names the
//! file, the field and what is wrong with it.
//!
//! Not here: what the values mean physically ([`crate::spec`]).

use serde::{Deserialize, Serialize};

use std::sync::LazyLock;

use crate::spec::{CameraSpec, GroundSpec, MonorailSpec, NozzleSpec, UnitKind};
use crate::validate::{self, FileError, Invalid, Validate, in_range};

/// The profile of a ground unit that names none.
pub const DEFAULT_GROUND: &str = "luf60";
/// The profile of a monorail unit that names none.
pub const DEFAULT_MONORAIL: &str = "robogat";

/// The profiles firefleet ships, by name.
const SHIPPED: &[(&str, &str)] = &[
    ("luf60", include_str!("../profiles/luf60.toml")),
    ("heavy-ugv", include_str!("../profiles/heavy-ugv.toml")),
    ("robogat", include_str!("../profiles/robogat.toml")),
];

/// A robot model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
#[allow(
    clippy::large_enum_variant,
    reason = "a profile is read once a unit and copied as a value; 400 bytes cost nothing"
)]
pub enum Profile {
    Ground(GroundSpec),
    Monorail(MonorailSpec),
}

/// Why a profile was rejected.
pub type ProfileError = FileError;

impl Profile {
    /// Parse and validate profile text; `origin` (a file name) prefixes every error.
    pub fn from_toml(text: &str, origin: &str) -> Result<Self, ProfileError> {
        validate::from_toml(text, origin, Self::validate)
    }

    pub fn kind(&self) -> UnitKind {
        match self {
            Profile::Ground(_) => UnitKind::Ground,
            Profile::Monorail(_) => UnitKind::Monorail,
        }
    }
}

/// The shipped profile `name`.
pub fn shipped(name: &str) -> Option<Profile> {
    let (_, text) = SHIPPED.iter().find(|(n, _)| *n == name)?;
    // Tested to parse and validate; a broken shipped profile is a build defect.
    Some(Profile::from_toml(text, name).expect("shipped profiles are valid"))
}

/// The names of the shipped profiles.
pub fn shipped_names() -> impl Iterator<Item = &'static str> {
    SHIPPED.iter().map(|(n, _)| *n)
}

/// The ground unit every scenario uses unless a unit names another profile: the shipped
/// `luf60` profile.
pub static GROUND: LazyLock<GroundSpec> = LazyLock::new(|| match shipped(DEFAULT_GROUND) {
    Some(Profile::Ground(g)) => g,
    _ => unreachable!("the shipped ground profile is a valid ground profile (tested)"),
});

/// The paper's monorail unit (section IV), with our stated assumptions for its sensors and
/// hose coupling: the shipped `robogat` profile.
pub static MONORAIL: LazyLock<MonorailSpec> = LazyLock::new(|| match shipped(DEFAULT_MONORAIL) {
    Some(Profile::Monorail(m)) => m,
    _ => unreachable!("the shipped monorail profile is a valid monorail profile (tested)"),
});

impl Validate for Profile {
    fn validate(&self) -> Result<(), Invalid> {
        match self {
            Profile::Ground(g) => g.validate(),
            Profile::Monorail(m) => m.validate(),
        }
    }
}

const HALF_PI: f64 = std::f64::consts::FRAC_PI_2;

impl Validate for GroundSpec {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("wheelbase_m", self.wheelbase_m, 0.2, 10.0)?;
        in_range("length_m", self.length_m, self.wheelbase_m, 20.0).map_err(|e| {
            Invalid::new(
                e.field,
                format!("{} (and at least the wheelbase)", e.reason),
            )
        })?;
        in_range("width_m", self.width_m, 0.3, 5.0)?;
        in_range("max_speed_m_s", self.max_speed_m_s, 0.05, 30.0)?;
        in_range("max_accel_m_s2", self.max_accel_m_s2, 0.05, 20.0)?;
        // Past ~70 degrees a bicycle model's turning radius is no longer physical.
        in_range("max_steer_rad", self.max_steer_rad, 0.05, 1.2)?;
        in_range(
            "max_steer_rate_rad_s",
            self.max_steer_rate_rad_s,
            0.05,
            10.0,
        )?;
        in_range("tank_l", self.tank_l, 0.0, 1e5)?;
        in_range("cannon_flow_l_s", self.cannon_flow_l_s, 0.1, 1000.0)?;
        in_range("cannon_height_m", self.cannon_height_m, 0.1, 10.0)?;
        in_range(
            "cannon_pan_limit_rad",
            self.cannon_pan_limit_rad,
            0.0,
            std::f64::consts::PI,
        )?;
        in_range(
            "cannon_tilt_min_rad",
            self.cannon_tilt_min_rad,
            -HALF_PI,
            HALF_PI,
        )?;
        in_range(
            "cannon_tilt_max_rad",
            self.cannon_tilt_max_rad,
            self.cannon_tilt_min_rad,
            HALF_PI,
        )
        .map_err(|e| {
            Invalid::new(
                e.field,
                format!("{} (and above cannon_tilt_min_rad)", e.reason),
            )
        })?;
        in_range(
            "cannon_pan_rate_rad_s",
            self.cannon_pan_rate_rad_s,
            0.01,
            10.0,
        )?;
        in_range(
            "cannon_tilt_rate_rad_s",
            self.cannon_tilt_rate_rad_s,
            0.01,
            10.0,
        )?;
        self.nozzle.validate().map_err(|e| e.within("nozzle"))?;
        self.camera.validate().map_err(|e| e.within("camera"))?;
        match &self.thermal_camera {
            Some(c) => c.validate().map_err(|e| e.within("thermal_camera")),
            None => Ok(()),
        }
    }
}

impl Validate for NozzleSpec {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("pressure_pa", self.pressure_pa, 1e4, 1e7)?;
        in_range("discharge_coeff", self.discharge_coeff, 0.1, 1.0)?;
        in_range("friction_factor", self.friction_factor, 0.0, 1.0)?;
        in_range("pipe_length_m", self.pipe_length_m, 0.0, 100.0)?;
        in_range("diameter_m", self.diameter_m, 0.002, 0.5)?;
        in_range("dispersion_gamma", self.dispersion_gamma, 0.0, 1.0)
    }
}

impl Validate for CameraSpec {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("width_px", self.width_px, 16.0, 1e5)?;
        in_range("height_px", self.height_px, 16.0, 1e5)?;
        in_range("fx", self.fx, 1.0, 1e6)?;
        in_range("fy", self.fy, 1.0, 1e6)?;
        in_range("cx", self.cx, 0.0, self.width_px)?;
        in_range("cy", self.cy, 0.0, self.height_px)?;
        in_range("mount_forward_m", self.mount_forward_m, -10.0, 10.0)?;
        in_range("mount_height_m", self.mount_height_m, 0.05, 10.0)?;
        in_range("range_m", self.range_m, 1.0, 500.0)?;
        in_range("depth_sigma_a_m", self.depth_sigma_a_m, 0.0, 10.0)?;
        in_range("depth_sigma_b_per_m", self.depth_sigma_b_per_m, 0.0, 1.0)?;
        in_range("depth_dropout", self.depth_dropout, 0.0, 0.9)?;
        in_range("box_sigma_px", self.box_sigma_px, 0.0, 100.0)
    }
}

impl Validate for MonorailSpec {
    fn validate(&self) -> Result<(), Invalid> {
        in_range("link_m", self.link_m, 0.05, 5.0)?;
        in_range(
            "theta1_limit_rad",
            self.theta1_limit_rad,
            0.0,
            std::f64::consts::PI,
        )?;
        in_range(
            "theta2_min_rad",
            self.theta2_min_rad,
            -std::f64::consts::PI,
            0.0,
        )?;
        in_range(
            "theta2_max_rad",
            self.theta2_max_rad,
            self.theta2_min_rad,
            HALF_PI,
        )?;
        in_range("v0_min_m_s", self.v0_min_m_s, 0.0, 100.0)?;
        in_range("v0_max_m_s", self.v0_max_m_s, self.v0_min_m_s, 100.0)?;
        in_range("carriage_speed_m_s", self.carriage_speed_m_s, 0.05, 50.0)?;
        in_range("monitor_rate_rad_s", self.monitor_rate_rad_s, 0.01, 10.0)?;
        in_range("nozzle_rate_m_s2", self.nozzle_rate_m_s2, 0.1, 1000.0)?;
        in_range("flow_l_s", self.flow_l_s, 0.1, 1000.0)?;
        in_range("hose_reach_m", self.hose_reach_m, 0.0, 1000.0)?;
        in_range("detector_range_m", self.detector_range_m, 1.0, 500.0)?;
        in_range("hot_spot_sigma_a_m", self.hot_spot_sigma_a_m, 0.0, 10.0)?;
        in_range("hot_spot_sigma_b", self.hot_spot_sigma_b, 0.0, 1.0)?;
        in_range("working_reach_m", self.working_reach_m, 0.5, 200.0)?;
        in_range("coupling_s", self.coupling_s, 0.0, 600.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_profiles_parse_validate_and_are_of_their_kind() {
        for name in shipped_names() {
            let p = shipped(name).unwrap();
            let expected = if name == DEFAULT_MONORAIL {
                UnitKind::Monorail
            } else {
                UnitKind::Ground
            };
            assert_eq!(p.kind(), expected, "{name}");
        }
        let (Some(Profile::Ground(small)), Some(Profile::Ground(heavy))) =
            (shipped(DEFAULT_GROUND), shipped("heavy-ugv"))
        else {
            panic!("ground profiles")
        };
        assert!(heavy.circumradius_m() > small.circumradius_m());
    }

    #[test]
    fn bad_profiles_name_the_file_field_and_reason() {
        let text = include_str!("../profiles/luf60.toml");
        let err = |t: &str| Profile::from_toml(t, "x.toml").unwrap_err().to_string();
        let e = err(&text.replace("width_m = 1.0", "width_m = -1.0"));
        assert!(e.starts_with("x.toml: width_m:"), "{e}");
        let e = err(&text.replace("fx = 465.6", "fx = 0.0"));
        assert!(e.starts_with("x.toml: camera.fx:"), "{e}");
        let e = err(&text.replace(
            "cannon_tilt_max_rad = 1.0471975511965976",
            "cannon_tilt_max_rad = -0.5",
        ));
        assert!(
            e.contains("cannon_tilt_max_rad") && e.contains("above cannon_tilt_min_rad"),
            "{e}"
        );
        let e = err(&text.replace("tank_l", "tank_litres"));
        assert!(e.contains("tank_litres"), "unknown fields are refused: {e}");
        let e = err(&text.replace("kind = \"ground\"", "kind = \"hovercraft\""));
        assert!(e.contains("hovercraft"), "{e}");
        let e = err(&text.replace("max_speed_m_s = 1.5", "max_speed_m_s = nan"));
        assert!(e.contains("max_speed_m_s"), "{e}");
    }
}
