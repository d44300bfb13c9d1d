//! The ROBOGAT fuzzy inference system: fire, temperature and distance in; how much the
//! carriage, the monitor and the valve may move out (paper, section III).
//!
//! The paper gives the variables and the four rules but not the membership functions
//! ("not reported here for brevity"); ours are designed for a rail under the ceiling of a
//! road tunnel and written down here:
//!
//! - **temperature** near the carriage, 0 to 600 C: `low` fully below 150 C, gone at 350 C;
//!   `high` the complement. 150 C is a tenable limit for the carriage's drives and cables
//!   in the hot layer; 350 C is where the paper's robot must be protecting itself (it is
//!   built for 1000 C with self-cooling).
//! - **distance** from the carriage to the fire along the rail, 0 to 40 m: `low` fully
//!   within 8 m, gone at 14 m; `average` a triangle 8-13-18 m; `high` from 12 m, full at
//!   18 m. The jet's comfortable reach at the dexterous posture is about 12 m below a 6.3 m
//!   ceiling, so 8 to 18 m is the band in which the monitor can do the work from where the
//!   carriage is.
//! - **outputs** on [0, 1]: the extreme sets are narrow shoulders (`standing`/`closed`
//!   full below 0.1, gone at 0.3; `moving`/`open` mirrored) and the middle ones a triangle
//!   0.2-0.5-0.8, so that "about 0" and "about 1", as the paper describes its phases, are
//!   what the centroid gives when one rule dominates (0.09 and 0.91).
//!
//! The paper's rule 2 says "distance is medium": the variable's set is named `average`
//! where it is declared, so the rule uses that name. After defuzzification `beta_v` is
//! multiplied by the fire detector's output `pi`, freezing the valve when there is no fire.

use super::clik::Weights;
use crate::monorail::fuzzy::{Mamdani, Scratch, Set, Variable};

/// The paper's four rules, verbatim but for `medium` (see the module doc).
pub const RULES: [&str; 4] = [
    "if distance is high and temperature is low then vehicle is moving, monitor is standing, valve is closed",
    "if distance is average and temperature is low then monitor is average, valve is half-open",
    "if distance is low and temperature is low then vehicle is standing",
    "if temperature is high then vehicle is standing, monitor is moving, valve is open",
];

/// The ROBOGAT weights system, ready to evaluate without allocating.
#[derive(Debug, Clone)]
pub struct Fis {
    system: Mamdani,
    scratch: Scratch,
}

/// The crisp inputs of the system.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inputs {
    /// The fire detector's output: is there fire in the tunnel.
    pub fire: bool,
    /// Temperature near the carriage, degrees C.
    pub temperature_c: f64,
    /// Distance from the carriage to the fire along the rail, m.
    pub distance_m: f64,
}

impl Default for Fis {
    fn default() -> Self {
        Self::new()
    }
}

impl Fis {
    pub fn new() -> Self {
        let (low, mid, high) = (
            Set::left_shoulder(0.1, 0.3),
            Set::Triangle {
                a: 0.2,
                b: 0.5,
                c: 0.8,
            },
            Set::right_shoulder(0.7, 0.9),
        );
        let inputs = vec![
            Variable::new(
                "temperature",
                (0.0, 600.0),
                &[
                    ("low", Set::left_shoulder(150.0, 350.0)),
                    ("high", Set::right_shoulder(150.0, 350.0)),
                ],
            ),
            Variable::new(
                "distance",
                (0.0, 40.0),
                &[
                    ("low", Set::left_shoulder(8.0, 14.0)),
                    (
                        "average",
                        Set::Triangle {
                            a: 8.0,
                            b: 13.0,
                            c: 18.0,
                        },
                    ),
                    ("high", Set::right_shoulder(12.0, 18.0)),
                ],
            ),
        ];
        let outputs = vec![
            Variable::new(
                "vehicle",
                (0.0, 1.0),
                &[("standing", low), ("moving", high)],
            ),
            Variable::new(
                "monitor",
                (0.0, 1.0),
                &[("standing", low), ("average", mid), ("moving", high)],
            ),
            Variable::new(
                "valve",
                (0.0, 1.0),
                &[("closed", low), ("half-open", mid), ("open", high)],
            ),
        ];
        let system = Mamdani::new(inputs, outputs, &RULES).expect("the ROBOGAT system is valid");
        let scratch = system.scratch();
        Self { system, scratch }
    }

    /// The weights for these readings.
    pub fn weights(&mut self, x: Inputs) -> Weights {
        let mut out = [0.0; 3];
        self.system.infer(
            &[x.temperature_c, x.distance_m],
            &mut self.scratch,
            &mut out,
        );
        let pi = if x.fire { 1.0 } else { 0.0 };
        Weights {
            beta_d: out[0],
            beta_m: out[1],
            beta_v: out[2] * pi,
        }
    }

    /// The underlying system, for display.
    pub fn system(&self) -> &Mamdani {
        &self.system
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn w(temperature_c: f64, distance_m: f64) -> Weights {
        Fis::new().weights(Inputs {
            fire: true,
            temperature_c,
            distance_m,
        })
    }

    #[test]
    fn far_and_cool_the_carriage_moves_and_the_monitor_stands() {
        let x = w(30.0, 30.0);
        assert!(x.beta_d > 0.85, "{x:?}");
        assert!(x.beta_m < 0.15 && x.beta_v < 0.15, "{x:?}");
    }

    #[test]
    fn hot_the_carriage_stands_and_the_monitor_and_valve_move() {
        let x = w(480.0, 12.0);
        assert!(x.beta_d < 0.15, "{x:?}");
        assert!(x.beta_m > 0.85 && x.beta_v > 0.85, "{x:?}");
    }

    #[test]
    fn at_a_working_distance_the_monitor_is_half_free() {
        let x = w(30.0, 13.0);
        assert!(
            (x.beta_m - 0.5).abs() < 0.05 && (x.beta_v - 0.5).abs() < 0.05,
            "{x:?}"
        );
    }

    #[test]
    fn no_fire_freezes_the_valve_only() {
        let mut f = Fis::new();
        let x = f.weights(Inputs {
            fire: false,
            temperature_c: 480.0,
            distance_m: 12.0,
        });
        assert_eq!(x.beta_v, 0.0);
        assert!(x.beta_m > 0.85);
    }

    #[test]
    fn weights_stay_in_the_unit_interval() {
        let mut f = Fis::new();
        for t in (0..=70).map(|k| k as f64 * 10.0) {
            for d in (0..=50).map(|k| k as f64) {
                let x = f.weights(Inputs {
                    fire: true,
                    temperature_c: t,
                    distance_m: d,
                });
                for b in [x.beta_d, x.beta_m, x.beta_v] {
                    assert!((0.0..=1.0).contains(&b), "{t} {d} {x:?}");
                }
            }
        }
    }
}
