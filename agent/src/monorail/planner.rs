//! The fuzzy trajectory planner for the jet's end point (ROBOGAT paper, eq. 9).
//!
//! The speed the jet point may be asked for is a weighted mean of what the joints can do,
//! weighted by the fuzzy system's outputs (eq. 9):
//!
//! ```text
//! v_x = beta_d v_dM + beta_m v_mM + beta_v r_0M
//! v_y =               beta_m v_mM + beta_v r_0M
//! ```
//!
//! As printed, it adds a rail speed (m/s), a monitor rate (rad/s) and a rate of nozzle
//! speed (m/s^2). We make it consistent by turning each joint's top rate into the jet-point
//! speed it produces at the current posture, through the Jacobian's entries:
//! `v_a = sum_i beta_i qdot_max_i |J_a,i|` for `a` in {x, y}. For a rail along x, `J_y,d = 0`,
//! so `v_y` has no carriage term, as in eq. 9; with every `|J| = 1` this is eq. 9 itself.
//! As printed, eq. 9 asks for an 18 m/s jet sweep over a car fire (`0.9 x 20`), which the
//! monitor cannot follow (its yaw moves the jet at most 0.3 rad/s x 12 m = 3.6 m/s).
//!
//! Three phases:
//! 1. **Approach**: a straight line to the fire at the largest speed within `(v_x, v_y)`
//!    per axis. With the fire on the rail's line (as in the paper's case study) this is the
//!    rectilinear motion parallel to the rail the paper describes.
//! 2. **Sweep**, once the jet point is on the fire: `x = x_f + A_x sin(phi_x)`,
//!    `y = y_f + A_y sin(phi_y)` with `phi_dot = v / A`, so the peak speed on each axis is the
//!    eq. 9 speed and the sweep's frequencies change with the weights, as in the paper's
//!    figure 5. Different frequencies on the two axes draw a Lissajous figure that covers
//!    the burning area instead of one line across it.
//! 3. **Hold**, once the fire is out: the jet point stops where it is.

use nalgebra::{Matrix2x4, Vector2};

use super::clik::Weights;

/// The joint speed limits of eq. 9 and the sweep's size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlannerParams {
    /// Top carriage speed `v_dM`, m/s.
    pub v_dm: f64,
    /// Top monitor rate `v_mM`, rad/s.
    pub v_mm: f64,
    /// Top rate of change of the nozzle speed `r_0M`, m/s^2.
    pub r_0m: f64,
    /// Half-widths of the sweep along and across the rail, m.
    pub sweep: [f64; 2],
}

impl PlannerParams {
    /// The paper's case study: `v_dM = 10 m/s`, `v_mM = 0.3 rad/s`, `r_0M = 20 m/s^2`; a
    /// sweep of +-1.5 m along the rail and +-1 m across, the footprint of a burning car.
    pub const ROBOGAT: PlannerParams = PlannerParams {
        v_dm: 10.0,
        v_mm: 0.3,
        r_0m: 20.0,
        sweep: [1.5, 1.0],
    };

    /// The eq. 9 speed limits `(v_x, v_y)` for weights `w` at a posture whose task Jacobian
    /// is `j` (see the module doc).
    pub fn speed(&self, w: Weights, j: &Matrix2x4<f64>) -> Vector2<f64> {
        let rate = [
            w.beta_d * self.v_dm,
            w.beta_m * self.v_mm,
            w.beta_m * self.v_mm,
            w.beta_v * self.r_0m,
        ];
        Vector2::from_fn(|a, _| (0..4).map(|i| rate[i] * j[(a, i)].abs()).sum())
    }
}

/// Where the planner is in the attack.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    Approach,
    Sweep,
    Hold,
}

/// The planned jet point and its velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plan {
    pub p: Vector2<f64>,
    pub pdot: Vector2<f64>,
    pub phase: Phase,
}

/// The planner's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planner {
    params: PlannerParams,
    phase: Phase,
    p: Vector2<f64>,
    angle: [f64; 2],
}

impl Planner {
    /// A planner whose jet point starts at `start` (where the jet is now).
    pub fn new(params: PlannerParams, start: Vector2<f64>) -> Self {
        Self {
            params,
            phase: Phase::Approach,
            p: start,
            angle: [0.0; 2],
        }
    }

    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Advance by `dt` toward or about `fire`, with weights `w` at a posture whose task
    /// Jacobian is `j`; `out` once the fire is out.
    pub fn step(
        &mut self,
        dt: f64,
        w: Weights,
        j: &Matrix2x4<f64>,
        fire: Vector2<f64>,
        out: bool,
    ) -> Plan {
        let v = self.params.speed(w, j);
        if out {
            self.phase = Phase::Hold;
        }
        let pdot = match self.phase {
            Phase::Hold => Vector2::zeros(),
            Phase::Approach => {
                let to = fire - self.p;
                let dist = to.norm();
                if dist < 1e-9 {
                    self.start_sweep();
                    Vector2::zeros()
                } else {
                    let u = to / dist;
                    // Largest speed along `u` within the per-axis limits.
                    let s = [(u.x, v.x), (u.y, v.y)]
                        .iter()
                        .filter(|(c, _)| c.abs() > 1e-12)
                        .map(|(c, lim)| lim / c.abs())
                        .fold(f64::INFINITY, f64::min);
                    let step = (s * dt).min(dist);
                    self.p += u * step;
                    if step >= dist {
                        self.start_sweep();
                    }
                    u * (step / dt)
                }
            }
            Phase::Sweep => {
                let [ax, ay] = self.params.sweep;
                self.angle[0] += v.x / ax * dt;
                self.angle[1] += v.y / ay * dt;
                let (sx, cx) = self.angle[0].sin_cos();
                let (sy, cy) = self.angle[1].sin_cos();
                self.p = fire + Vector2::new(ax * sx, ay * sy);
                Vector2::new(v.x * cx, v.y * cy)
            }
        };
        Plan {
            p: self.p,
            pdot,
            phase: self.phase,
        }
    }

    fn start_sweep(&mut self) {
        self.phase = Phase::Sweep;
        self.angle = [0.0; 2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HALF: Weights = Weights {
        beta_d: 0.5,
        beta_m: 0.5,
        beta_v: 0.5,
    };

    /// A Jacobian whose every entry is 1 (0 for the carriage across the rail): eq. 9 as
    /// printed.
    fn unit_jacobian() -> Matrix2x4<f64> {
        Matrix2x4::new(1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0)
    }

    #[test]
    fn equation_9() {
        let v = PlannerParams::ROBOGAT.speed(HALF, &unit_jacobian());
        // The monitor's two angles both count.
        assert!((v.x - (5.0 + 0.3 + 10.0)).abs() < 1e-12);
        assert!((v.y - (0.3 + 10.0)).abs() < 1e-12);
    }

    #[test]
    fn approaches_in_a_straight_line_then_sweeps_about_the_fire_then_holds() {
        let mut p = Planner::new(PlannerParams::ROBOGAT, Vector2::new(9.0, 0.0));
        let fire = Vector2::new(20.0, 0.0);
        let w = Weights {
            beta_d: 1.0,
            beta_m: 0.1,
            beta_v: 0.1,
        };
        let mut t: f64 = 0.0;
        while p.phase() == Phase::Approach {
            let plan = p.step(1e-3, w, &unit_jacobian(), fire, false);
            assert_eq!(plan.p.y, 0.0, "parallel to the rail");
            assert!(plan.pdot.x <= PlannerParams::ROBOGAT.speed(w, &unit_jacobian()).x + 1e-9);
            t += 1e-3;
        }
        // 11 m at 10 + 0.06 + 2 m/s.
        assert!((t - 11.0 / 12.06).abs() < 2e-3, "{t}");
        let mut last = p.step(1e-3, HALF, &unit_jacobian(), fire, false);
        for _ in 0..10_000 {
            let plan = p.step(1e-3, HALF, &unit_jacobian(), fire, false);
            let d = plan.p - fire;
            assert!(d.x.abs() <= 1.5 + 1e-9 && d.y.abs() <= 1.0 + 1e-9);
            // The stated velocity is the derivative of the stated position.
            let fd = (plan.p - last.p) / 1e-3;
            assert!((fd - plan.pdot).norm() < 0.2, "{fd} {}", plan.pdot);
            last = plan;
        }
        let held = p.step(1e-3, HALF, &unit_jacobian(), fire, true);
        assert_eq!(held.phase, Phase::Hold);
        assert_eq!(held.pdot, Vector2::zeros());
        assert_eq!(p.step(1e-3, HALF, &unit_jacobian(), fire, true).p, held.p);
    }

    #[test]
    fn approach_off_the_rail_line_respects_both_axis_limits() {
        let mut p = Planner::new(PlannerParams::ROBOGAT, Vector2::new(0.0, 0.0));
        let w = Weights {
            beta_d: 1.0,
            beta_m: 0.0,
            beta_v: 0.05,
        };
        let v = PlannerParams::ROBOGAT.speed(w, &unit_jacobian());
        let plan = p.step(1e-3, w, &unit_jacobian(), Vector2::new(10.0, 10.0), false);
        assert!(plan.pdot.x <= v.x + 1e-9 && plan.pdot.y <= v.y + 1e-9);
        assert!((plan.pdot.x - plan.pdot.y).abs() < 1e-9, "straight line");
    }
}
