//! A simulated monorail unit: a carriage on a ceiling rail with a fire monitor.
//!
//! The carriage and the monitor move toward their set-points at their top rates (the
//! ROBOGAT paper's `v_dM`, `v_mM`, `r_0M`) and stop at their limits; the nozzle sets the
//! jet's exit speed directly. Water flows when the valve is open and the carriage is within
//! its telescopic tubes' reach of a hose point. The jet itself is traced by [`crate::jet`],
//! the same ballistics and suppression model as ground cannons.
//!
//! Not here: the monitor's control (the agent's CLIK) or water suppression
//! ([`crate::world`]).

use firefleet_model::UnitId;
use firefleet_model::geometry::Pose2;
use firefleet_model::scenario::Rail;
use firefleet_model::spec::MonorailSpec;
use firefleet_protocol::msg::{RailCommand, RailJoints};

use crate::camera::P3;

/// A carriage and its monitor.
#[derive(Debug, Clone)]
pub struct Carriage {
    pub id: UnitId,
    pub spec: MonorailSpec,
    pub rail: Rail,
    pub joints: RailJoints,
    pub cmd: RailCommand,
    /// Carriage speed over the last step, m/s.
    pub speed: f64,
    pub valve_open: bool,
    pub heat_flux: f64,
    pub heat_dose: f64,
    pub water_used: f64,
}

fn toward(from: f64, to: f64, rate: f64, dt: f64) -> f64 {
    from + (to - from).clamp(-rate * dt, rate * dt)
}

impl Carriage {
    /// A carriage at site chainage `x` on `rail`, monitor level and ahead, valve shut.
    pub fn new(id: UnitId, spec: MonorailSpec, rail: Rail, x: f64) -> Self {
        let joints = RailJoints {
            d: x - rail.start_m,
            theta1: 0.0,
            theta2: -std::f64::consts::PI / 12.0,
            v0: 10.0,
        };
        Self {
            id,
            spec,
            rail,
            joints,
            cmd: RailCommand {
                joints,
                valve_open: false,
            },
            speed: 0.0,
            valve_open: false,
            heat_flux: 0.0,
            heat_dose: 0.0,
            water_used: 0.0,
        }
    }

    /// Hold where it is with the valve shut (its controller went silent).
    pub fn halt(&mut self) {
        self.cmd = RailCommand {
            joints: self.joints,
            valve_open: false,
        };
    }

    /// Move the joints toward the set-points for `dt` seconds.
    pub fn step(&mut self, dt: f64) {
        let (s, c, j) = (&self.spec, self.cmd.joints, &mut self.joints);
        let d = toward(
            j.d,
            c.d.clamp(0.0, self.rail.length_m()),
            s.carriage_speed_m_s,
            dt,
        );
        self.speed = (d - j.d) / dt;
        j.d = d;
        let lim = s.theta1_limit_rad;
        j.theta1 = toward(
            j.theta1,
            c.theta1.clamp(-lim, lim),
            s.monitor_rate_rad_s,
            dt,
        );
        j.theta2 = toward(
            j.theta2,
            c.theta2.clamp(s.theta2_min_rad, s.theta2_max_rad),
            s.monitor_rate_rad_s,
            dt,
        );
        j.v0 = toward(
            j.v0,
            c.v0.clamp(s.v0_min_m_s, s.v0_max_m_s),
            s.nozzle_rate_m_s2,
            dt,
        );
        self.valve_open = self.cmd.valve_open && self.connected();
    }

    /// The carriage's chainage, m.
    pub fn x(&self) -> f64 {
        self.rail.start_m + self.joints.d
    }

    /// Plugged into a hose point.
    pub fn connected(&self) -> bool {
        self.rail
            .dock_at(self.x(), self.spec.hose_reach_m)
            .is_some()
    }

    /// The monitor's pivot M in the site frame.
    pub fn pivot(&self) -> P3 {
        [self.x(), self.rail.y_m, self.rail.height_m]
    }

    /// The carriage as a pose (facing along the rail).
    pub fn pose(&self) -> Pose2 {
        Pose2::new(self.x(), self.rail.y_m, 0.0)
    }

    /// Where the jet leaves the nozzle, its site heading and its elevation. The paper's
    /// eq. 1 puts the jet at `y = -r sin(theta1)` in a frame whose y points right, so a
    /// positive yaw turns the jet left: the site heading is `theta1`.
    pub fn nozzle(&self) -> (P3, f64, f64) {
        let j = &self.joints;
        let azimuth = j.theta1;
        let (s2, c2) = j.theta2.sin_cos();
        let m = self.pivot();
        let l = self.spec.link_m;
        (
            [
                m[0] + l * c2 * azimuth.cos(),
                m[1] + l * c2 * azimuth.sin(),
                m[2] + l * s2,
            ],
            azimuth,
            j.theta2,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::MONORAIL;

    fn carriage() -> Carriage {
        let rail = Rail {
            id: "r".into(),
            start_m: 10.0,
            end_m: 110.0,
            y_m: 1.0,
            height_m: 5.5,
            hose_points_m: vec![20.0, 50.0],
        };
        Carriage::new(UnitId::new("m").unwrap(), *MONORAIL, rail, 20.0)
    }

    #[test]
    fn joints_move_at_their_rates_and_stop_at_their_limits() {
        let mut c = carriage();
        c.cmd.joints = RailJoints {
            d: 500.0,
            theta1: 3.0,
            theta2: 1.0,
            v0: 100.0,
        };
        c.step(0.1);
        assert!((c.joints.d - 11.0).abs() < 1e-12, "10 m/s for 0.1 s");
        assert!((c.joints.theta1 - 0.03).abs() < 1e-12);
        for _ in 0..1000 {
            c.step(0.1);
        }
        assert_eq!(c.joints.d, 100.0, "the rail's end");
        assert_eq!(c.joints.theta1, MONORAIL.theta1_limit_rad);
        assert_eq!(c.joints.theta2, 0.0);
        assert_eq!(c.joints.v0, MONORAIL.v0_max_m_s);
    }

    #[test]
    fn water_flows_only_near_a_hose_point() {
        let mut c = carriage();
        c.cmd.valve_open = true;
        c.step(0.1);
        assert!(c.valve_open);
        c.cmd.joints.d = 80.0;
        for _ in 0..100 {
            c.step(0.1);
        }
        assert!(
            !c.connected() && !c.valve_open,
            "90 m is 40 m from the nearest hose point"
        );
    }

    #[test]
    fn positive_yaw_points_the_jet_to_the_left() {
        let mut c = carriage();
        c.joints.theta1 = 0.5;
        let (n, azimuth, _) = c.nozzle();
        assert!(azimuth > 0.0 && n[1] > c.rail.y_m);
    }
}
