//! Physical specification of the ground unit.
//!
//! The simulator moves bodies with these limits and the agent plans with them, the way a
//! real vehicle's datasheet serves both its firmware and its planners. Values are stated
//! assumptions for a mid-size tunnel firefighting robot (LUF 60 / Thermite class), not
//! tuned to any experiment.

/// Limits and geometry of a ground unit.
#[derive(Debug, Clone, Copy, PartialEq)]
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
    /// Jet speed at the nozzle, m/s (about 2 bar at the nozzle through a smooth bore).
    pub cannon_muzzle_speed_m_s: f64,
    /// Nozzle height above the road, m.
    pub cannon_height_m: f64,
    /// Pan limit either side of straight ahead, rad; elevation range, rad.
    pub cannon_pan_limit_rad: f64,
    pub cannon_tilt_min_rad: f64,
    pub cannon_tilt_max_rad: f64,
    /// Slew rates of remote-controlled monitors, rad/s (about 30 and 20 deg/s).
    pub cannon_pan_rate_rad_s: f64,
    pub cannon_tilt_rate_rad_s: f64,
    /// Camera: height above the road, horizontal field of view (RealSense D435 colour,
    /// 69 deg), and the range to which a flame is detected reliably.
    pub camera_height_m: f64,
    pub camera_hfov_rad: f64,
    pub camera_range_m: f64,
    /// Detector noise: bearing (one sigma, rad) and depth `a + b r^2` (one sigma, m): stereo
    /// depth error grows with the square of range (Intel RealSense D400 depth RMS model).
    pub camera_bearing_sigma_rad: f64,
    pub camera_depth_sigma_a_m: f64,
    pub camera_depth_sigma_b_per_m: f64,
}

impl GroundSpec {
    /// Minimum turning radius of the bicycle model, m.
    pub fn min_turn_radius_m(&self) -> f64 {
        self.wheelbase_m / self.max_steer_rad.tan()
    }
    /// Depth noise (one sigma) of the camera at range `r`, m.
    pub fn depth_sigma_m(&self, r: f64) -> f64 {
        self.camera_depth_sigma_a_m + self.camera_depth_sigma_b_per_m * r * r
    }
    /// Radius of the circle that encloses the footprint, m.
    pub fn circumradius_m(&self) -> f64 {
        0.5 * self.length_m.hypot(self.width_m)
    }
}

/// The ground unit every scenario uses.
pub const GROUND: GroundSpec = GroundSpec {
    wheelbase_m: 1.0,
    length_m: 1.6,
    width_m: 1.0,
    max_speed_m_s: 1.5,
    max_accel_m_s2: 0.8,
    max_steer_rad: 0.5,
    max_steer_rate_rad_s: 1.0,
    tank_l: 1500.0,
    cannon_flow_l_s: 10.0,
    cannon_muzzle_speed_m_s: 20.0,
    cannon_height_m: 1.2,
    cannon_pan_limit_rad: 170.0 * std::f64::consts::PI / 180.0,
    cannon_tilt_min_rad: -15.0 * std::f64::consts::PI / 180.0,
    cannon_tilt_max_rad: 60.0 * std::f64::consts::PI / 180.0,
    cannon_pan_rate_rad_s: 0.52,
    cannon_tilt_rate_rad_s: 0.35,
    camera_height_m: 1.0,
    camera_hfov_rad: 69.0 * std::f64::consts::PI / 180.0,
    camera_range_m: 30.0,
    camera_bearing_sigma_rad: 0.01,
    camera_depth_sigma_a_m: 0.02,
    camera_depth_sigma_b_per_m: 0.002,
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ground_unit_turns_in_a_tunnel_lane() {
        // A 3.5 m lane must allow a U-turn in two lanes: radius well under 3.5 m.
        let r = GROUND.min_turn_radius_m();
        assert!(r > 1.0 && r < 3.5, "{r}");
    }
}
