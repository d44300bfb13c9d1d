//! Flight of a water jet from a cannon nozzle to where it lands.
//!
//! Drag-free ballistics at the effective exit speed of the BT paper's equation 9, whose
//! `1 + gamma r / D` term stands for air resistance and dispersion over the jet's reach `r`
//! ([`NozzleSpec`]). The reach depends on that speed and the speed on the reach, so the jet
//! flies at the fixed point of the two. The jet is stopped by the tunnel ceiling, the walls
//! and parked vehicles; only water that reaches the road can land on a fire.

use firefleet_model::Point2;
use firefleet_model::scenario::{Obstacle, Tunnel};
use firefleet_model::spec::NozzleSpec;

use crate::camera::{P3, segment_hits};
use crate::physics::G;

/// Where a jet ends.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Landing {
    /// On the road at `at`, after `travel_m` metres of horizontal travel.
    Road { at: Point2, travel_m: f64 },
    /// Against parked vehicle `index` (of the scenario's obstacles): it wets the vehicle.
    Vehicle { index: usize },
    /// Against the ceiling or a wall.
    Blocked,
}

/// Horizontal reach on the road of a drag-free jet leaving height `h` at elevation `th` and
/// speed `v`.
fn reach(h: f64, th: f64, v: f64) -> f64 {
    let (vz, vh) = (v * th.sin(), v * th.cos());
    vh * (vz + (vz * vz + 2.0 * G * h).sqrt()) / G
}

/// The speed a jet from height `h` at elevation `th` flies with: the fixed point of
/// `r = reach(v_e(r))`. The map contracts (its slope is about -0.5 for the units' nozzle),
/// so the damped iteration converges in a few dozen steps.
pub fn flight_speed(spec: &NozzleSpec, h: f64, th: f64) -> f64 {
    let mut r = reach(h, th, spec.exit_speed_m_s(0.0));
    for _ in 0..200 {
        let next = reach(h, th, spec.exit_speed_m_s(r));
        if (next - r).abs() < 1e-9 {
            break;
        }
        r = 0.5 * (r + next);
    }
    spec.exit_speed_m_s(r)
}

/// Trace a jet leaving `nozzle` at heading `azimuth` (site frame) and elevation `elevation`.
pub fn trace(
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
    nozzle: P3,
    azimuth: f64,
    elevation: f64,
    spec: &NozzleSpec,
) -> Landing {
    let v = flight_speed(spec, nozzle[2], elevation);
    trace_at_speed(tunnel, obstacles, nozzle, azimuth, elevation, v)
}

/// Trace a jet that leaves the nozzle at speed `v`: a monitor whose nozzle sets the exit
/// speed directly (the monorail's variable-area nozzle).
pub fn trace_at_speed(
    tunnel: &Tunnel,
    obstacles: &[Obstacle],
    nozzle: P3,
    azimuth: f64,
    elevation: f64,
    v: f64,
) -> Landing {
    let h = nozzle[2];
    let (vz, vh) = (v * elevation.sin(), v * elevation.cos());
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
        if !tunnel.contains(Point2::new(p[0], p[1]), 0.0) {
            return Landing::Blocked;
        }
        if let Some(index) = obstacles.iter().position(|o| segment_hits(o, prev, p)) {
            return Landing::Vehicle { index };
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
    use firefleet_model::profile::GROUND;

    const TUNNEL: Tunnel = Tunnel::straight(200.0, 10.0, 6.0, 2);

    /// A nozzle whose jet is a plain drag-free jet at `v` m/s (no reach correction).
    fn plain(v: f64) -> NozzleSpec {
        let n = GROUND.nozzle;
        let friction = 1.0 + n.friction_factor * n.pipe_length_m / n.diameter_m;
        let pressure_pa = (v / n.discharge_coeff).powi(2) * 1000.0 * friction / 2.0;
        NozzleSpec {
            pressure_pa,
            dispersion_gamma: 0.0,
            ..n
        }
    }

    #[test]
    fn level_ground_range_matches_closed_form() {
        // From ground level, range = v^2 sin(2 theta) / g.
        let (v, th) = (15.0, 0.4f64);
        let Landing::Road { at, travel_m } =
            trace(&TUNNEL, &[], [0.0, 0.0, 0.0], 0.0, th, &plain(v))
        else {
            panic!("blocked")
        };
        let expect = v * v * (2.0 * th).sin() / G;
        assert!(
            (travel_m - expect).abs() < 1e-6 && (at.x - expect).abs() < 1e-6 && at.y.abs() < 1e-9
        );
    }

    #[test]
    fn the_jet_flies_at_the_equation_9_speed_of_its_own_reach() {
        let n = GROUND.nozzle;
        for th in [0.1, 0.3, 0.6] {
            let v = flight_speed(&n, 1.2, th);
            let Landing::Road { travel_m, .. } = trace(&TUNNEL, &[], [0.0, 0.0, 1.2], 0.0, th, &n)
            else {
                panic!("blocked")
            };
            assert!(
                (v - n.exit_speed_m_s(travel_m)).abs() < 1e-6,
                "th {th}: {v} vs v_e({travel_m})"
            );
            assert!(v < n.exit_speed_m_s(0.0));
        }
    }

    #[test]
    fn ceiling_walls_and_vehicles_stop_the_jet() {
        let n = GROUND.nozzle;
        assert_eq!(
            trace(&TUNNEL, &[], [0.0, 0.0, 1.0], 0.0, 1.2, &n),
            Landing::Blocked,
            "ceiling"
        );
        assert_eq!(
            trace(&TUNNEL, &[], [0.0, 0.0, 1.0], 1.5, 0.3, &n),
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
            trace(&TUNNEL, &[car], [0.0, 0.0, 1.0], 0.0, 0.0, &n),
            Landing::Vehicle { index: 0 },
            "vehicle"
        );
    }
}
