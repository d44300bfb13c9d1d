//! Flight of a water jet from a cannon nozzle to where it lands.
//!
//! Drag-free ballistics (stated assumption: air drag on a solid-bore jet shortens its reach
//! by tens of percent at long range; the units fire from under 15 m, where it matters
//! little). The jet is stopped by the tunnel ceiling, the walls and parked vehicles; only
//! water that reaches the road can land on a fire.

use firefleet_protocol::Point2;
use firefleet_protocol::scenario::{Obstacle, Tunnel};

use crate::camera::{P3, line_blocked};
use crate::physics::G;

/// Where a jet ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Landing {
    /// On the road at `at`, after `travel_m` metres of horizontal travel.
    Road { at: Point2, travel_m: f64 },
    /// Against the ceiling, a wall or a vehicle.
    Blocked,
}

/// Trace a jet leaving `nozzle` at heading `azimuth` (site frame), elevation `elevation`,
/// speed `v` m/s.
pub fn trace(
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
    nozzle: P3,
    azimuth: f64,
    elevation: f64,
    v: f64,
) -> Landing {
    let (vz, vh) = (v * elevation.sin(), v * elevation.cos());
    let h = nozzle[2];
    if h + vz.max(0.0).powi(2) / (2.0 * G) >= tunnel.height_m {
        return Landing::Blocked;
    }
    let t_land = (vz + (vz * vz + 2.0 * G * h).sqrt()) / G;
    let travel = vh * t_land;
    let (s, c) = azimuth.sin_cos();
    let at = |t: f64| -> P3 {
        [
            nozzle[0] + c * vh * t,
            nozzle[1] + s * vh * t,
            h + vz * t - 0.5 * G * t * t,
        ]
    };
    // Chords every 0.25 m of travel follow the arc closely enough for vehicle-sized boxes.
    let steps = ((travel / 0.25).ceil() as usize).clamp(4, 400);
    let mut prev = nozzle;
    for i in 1..=steps {
        let p = at(t_land * i as f64 / steps as f64);
        if p[1].abs() > tunnel.width_m / 2.0 || line_blocked(obstacles, prev, p) {
            return Landing::Blocked;
        }
        prev = p;
    }
    Landing::Road {
        at: Point2::new(prev[0], prev[1]),
        travel_m: travel,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TUNNEL: Tunnel = Tunnel {
        length_m: 200.0,
        width_m: 10.0,
        height_m: 6.0,
        lanes: 2,
    };

    #[test]
    fn level_ground_range_matches_closed_form() {
        // From ground level, range = v^2 sin(2 theta) / g.
        let v = 15.0;
        let th = 0.4f64;
        match trace(&TUNNEL, &[], [0.0, 0.0, 0.0], 0.0, th, v) {
            Landing::Road { at, travel_m } => {
                let expect = v * v * (2.0 * th).sin() / G;
                assert!(
                    (travel_m - expect).abs() < 1e-6
                        && (at.x - expect).abs() < 1e-6
                        && at.y.abs() < 1e-9
                );
            }
            Landing::Blocked => panic!("blocked"),
        }
    }

    #[test]
    fn ceiling_walls_and_vehicles_stop_the_jet() {
        assert_eq!(
            trace(&TUNNEL, &[], [0.0, 0.0, 1.0], 0.0, 1.2, 20.0),
            Landing::Blocked,
            "ceiling"
        );
        assert_eq!(
            trace(&TUNNEL, &[], [0.0, 0.0, 1.0], 1.5, 0.3, 20.0),
            Landing::Blocked,
            "wall"
        );
        let car = Obstacle {
            name: "c".into(),
            x_m: 5.0,
            y_m: 0.0,
            length_m: 4.0,
            width_m: 2.0,
            height_m: 1.5,
            yaw_rad: 0.0,
        };
        assert_eq!(
            trace(&TUNNEL, &[car], [0.0, 0.0, 1.0], 0.0, 0.0, 10.0),
            Landing::Blocked,
            "vehicle"
        );
    }
}
