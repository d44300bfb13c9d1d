//! Closed-loop inverse kinematics with a weighted, damped pseudo-inverse and a null-space
//! secondary task (ROBOGAT paper, eq. 5-8).
//!
//! One step integrates
//!
//! ```text
//! qdot = J#W v - J#W Jz zdot + (I - J#W Jxy) W^-1 qdot_a,    v = pdot_d + K (p_d - p)
//! J#W  = W^-1 Jxy^T (Jxy W^-1 Jxy^T + lambda^2 I)^-1
//! qdot_a = -alpha kw grad H(q)
//! ```
//!
//! with `W^-1 = diag(beta_d s_d^2, beta_m s_m^2, beta_m s_m^2, beta_v s_v^2)` and `H` the
//! dexterity objective `1/2 |q_m - q_dex|^2` over the monitor's joints and the nozzle speed.
//! Four choices the paper leaves open:
//!
//! - **Units.** The paper's `W^-1 = diag(beta)` weighs a metre of rail, a radian of monitor
//!   and a m/s of nozzle speed alike. At the case study's posture the jet moves about 19 m
//!   per radian of elevation and 1 m per metre of rail, so with `beta_m = 0.1` the monitor
//!   would still take most of an approach that the fuzzy system meant for the carriage.
//!   Each joint is therefore scaled by its top rate `s` (`v_dM`, `v_mM`, `v_mM`, `r_0M`):
//!   the pseudo-inverse minimises `sum qdot_i^2 / (beta_i s_i^2)`, each joint's speed as a
//!   share of what it can do, and `beta` keeps the paper's meaning (1 free, 0 frozen). The
//!   fixed-weights baseline is then `beta = 1` on these scaled joints.
//! - **Damping.** Near a singular configuration (the jet pointing straight down, or weights
//!   that freeze every joint that could move the jet along one axis) `Jxy W^-1 Jxy^T`
//!   loses rank. Its smallest eigenvalue `sigma^2` is watched and, below `epsilon^2`, a
//!   damping `lambda^2 = lambda_max^2 (1 - sigma^2 / epsilon^2)` is added (variable damped
//!   least squares, Chiaverini 1997): exact pseudo-inverse away from singularities, bounded
//!   joint speeds near them.
//! - **The secondary task is weighted too, without the scales.** Eq. 6 projects `qdot_a`
//!   unweighted; a joint that the fuzzy system freezes (`beta = 0`) would still move through
//!   the null space. We project `diag(beta) qdot_a` with `I - J#B Jxy`, where `J#B` is the
//!   pseudo-inverse weighted by `diag(beta)` alone (the paper's eq. 5 as printed). Any
//!   generalized inverse gives a null-space projector (`Jxy (I - J#B Jxy) = 0`), and this
//!   one keeps frozen joints frozen and lets the posture task move the monitor, not the
//!   carriage: the dexterous angles and nozzle speed fix the jet's range, so a projector
//!   that let the carriage make up for them would drag it along with every sweep of the
//!   jet, which is what the fuzzy weights are there to prevent. The scales stay out of the
//!   secondary task: `kw` is a rate, and `kw s^2 dt` would not be a stable step.
//! - **Joint limits.** A joint that would cross its limit in this step is frozen (its
//!   weight set to zero) and the step recomputed, up to once per joint; the result is then
//!   clamped. The task is thus carried by the joints that can still move, and no limit is
//!   ever exceeded.

use nalgebra::{Matrix2, Matrix2x4, Matrix4, Matrix4x2, Vector2};

use super::kinematics::{Joints, Limits, Monitor, THETA1, THETA2, V0};

/// The fuzzy system's outputs: how much each group of joints may move, each in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weights {
    /// The carriage along the rail.
    pub beta_d: f64,
    /// The monitor's two angles.
    pub beta_m: f64,
    /// The nozzle's exit speed (the valve).
    pub beta_v: f64,
}

impl Weights {
    /// Every joint fully free: the plain pseudo-inverse (the paper's "fixed weights").
    pub const FIXED: Weights = Weights {
        beta_d: 1.0,
        beta_m: 1.0,
        beta_v: 1.0,
    };

    /// `alpha` for the dexterity task: `(beta_m + beta_v) / 2` (paper, section III).
    pub fn alpha(&self) -> f64 {
        0.5 * (self.beta_m + self.beta_v)
    }

    fn diagonal(&self) -> Joints {
        Joints::new(self.beta_d, self.beta_m, self.beta_m, self.beta_v)
    }
}

/// Gains and set-up of the CLIK loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClikParams {
    /// Task-space error gain `K = diag(k, k)`, 1/s.
    pub k: f64,
    /// Secondary-task gain `kw`, 1/s.
    pub kw: f64,
    /// Integration step, s.
    pub dt: f64,
    /// The dexterous posture `[theta1, theta2, v0]` the secondary task pulls toward.
    pub dexterous: [f64; 3],
    /// Each joint's scale `s`: its top rate (m/s, rad/s, rad/s, m/s^2).
    pub scale: [f64; 4],
    /// Smallest eigenvalue scale below which damping starts, and the largest damping.
    pub epsilon: f64,
    pub lambda_max: f64,
}

impl ClikParams {
    /// The paper's values: `K = diag(600, 600)`, `kw = 200`, 1000 Hz, dexterous posture
    /// `theta1 = 0`, `theta2 = -pi/12`, `v0 = 14.6 m/s`, the joints' top rates of its case
    /// study (`v_dM = 10 m/s`, `v_mM = 0.3 rad/s`, `r_0M = 20 m/s^2`).
    pub const ROBOGAT: ClikParams = ClikParams {
        k: 600.0,
        kw: 200.0,
        dt: 1e-3,
        dexterous: [0.0, -std::f64::consts::PI / 12.0, 14.6],
        scale: [10.0, 0.3, 0.3, 20.0],
        epsilon: 0.05,
        lambda_max: 0.05,
    };
}

/// What one step did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Step {
    /// Joint velocities applied, per second.
    pub qdot: Joints,
    /// `|p_d - p|` before the step, m.
    pub error_m: f64,
    /// Damping used, `lambda^2`.
    pub damping: f64,
}

/// The CLIK solver for one monitor.
#[derive(Debug, Clone, Copy)]
pub struct Clik {
    pub monitor: Monitor,
    pub limits: Limits,
    pub params: ClikParams,
}

/// The desired task-space motion for one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Desired jet point `[x, y]` and its velocity.
    pub p: Vector2<f64>,
    pub pdot: Vector2<f64>,
    /// Depth of the target plane below M, and its rate.
    pub z: f64,
    pub zdot: f64,
}

impl Clik {
    /// Advance `q` by one step toward `target`.
    pub fn step(&self, q: &mut Joints, target: &Target, weights: Weights) -> Step {
        let jet = self.monitor.jet(q, target.z);
        let error = target.p - jet.p;
        let v = target.pdot + self.params.k * error;
        let alpha = weights.alpha();
        let [t1, t2, v0] = self.params.dexterous;
        let grad = Joints::new(0.0, q[THETA1] - t1, q[THETA2] - t2, q[V0] - v0);
        let qdot_a = -alpha * self.params.kw * grad;

        let mut beta = weights.diagonal();
        let mut out = self.rates(&jet, &beta, v, target.zdot, &qdot_a);
        for _ in 0..4 {
            let next = *q + out.0 * self.params.dt;
            let Some(i) = (0..4).find(|&i| {
                beta[i] > 0.0
                    && ((next[i] > self.limits.hi[i] && out.0[i] > 0.0)
                        || (next[i] < self.limits.lo[i] && out.0[i] < 0.0))
            }) else {
                break;
            };
            beta[i] = 0.0;
            out = self.rates(&jet, &beta, v, target.zdot, &qdot_a);
        }
        *q = self.limits.clamp(&(*q + out.0 * self.params.dt));
        Step {
            qdot: out.0,
            error_m: error.norm(),
            damping: out.1,
        }
    }

    /// Joint rates for weights `beta`, and the damping used.
    fn rates(
        &self,
        jet: &super::kinematics::JetPoint,
        beta: &Joints,
        v: Vector2<f64>,
        zdot: f64,
        qdot_a: &Joints,
    ) -> (Joints, f64) {
        let s = self.params.scale;
        let scaled = beta.component_mul(&Joints::from_fn(|i, _| s[i] * s[i]));
        let (pinv, damping) = self.pinv(&jet.j_xy, &scaled);
        let (pinv_null, _) = self.pinv(&jet.j_xy, beta);
        let null = Matrix4::identity() - pinv_null * jet.j_xy;
        let qdot = pinv * (v - jet.j_z * zdot) + null * beta.component_mul(qdot_a);
        (qdot, damping)
    }

    /// The damped weighted pseudo-inverse `W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1` for
    /// `W^-1 = diag(w)`, and the damping `lambda^2` used.
    fn pinv(&self, j: &Matrix2x4<f64>, w: &Joints) -> (Matrix4x2<f64>, f64) {
        let jw = j * Matrix4::from_diagonal(w);
        let a: Matrix2<f64> = jw * j.transpose();
        let sigma2 = smallest_eigenvalue(&a);
        let eps2 = self.params.epsilon * self.params.epsilon;
        let damping = if sigma2 < eps2 {
            self.params.lambda_max.powi(2) * (1.0 - sigma2.max(0.0) / eps2)
        } else {
            0.0
        };
        let inv = (a + Matrix2::identity() * damping)
            .try_inverse()
            .unwrap_or_else(Matrix2::zeros);
        (jw.transpose() * inv, damping)
    }
}

/// Smallest eigenvalue of a symmetric 2 x 2 matrix.
fn smallest_eigenvalue(a: &Matrix2<f64>) -> f64 {
    let (p, q, r) = (a[(0, 0)], a[(0, 1)], a[(1, 1)]);
    let mean = 0.5 * (p + r);
    mean - (0.25 * (p - r) * (p - r) + q * q).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clik() -> Clik {
        Clik {
            monitor: Monitor { link_m: 0.8 },
            limits: Limits::robogat(100.0),
            params: ClikParams::ROBOGAT,
        }
    }

    fn hold(p: Vector2<f64>) -> Target {
        Target {
            p,
            pdot: Vector2::zeros(),
            z: 6.3,
            zdot: 0.0,
        }
    }

    #[test]
    fn converges_to_a_reachable_point() {
        let c = clik();
        let mut q = Joints::new(0.0, 0.0, -0.26, 14.6);
        let goal = Vector2::new(20.0, 1.5);
        for _ in 0..2000 {
            c.step(&mut q, &hold(goal), Weights::FIXED);
        }
        assert!((c.monitor.position(&q, 6.3) - goal).norm() < 1e-6);
        assert!(c.limits.contains(&q));
    }

    #[test]
    fn the_secondary_task_reaches_the_dexterous_posture_while_the_jet_holds() {
        // A jet point that the dexterous posture reaches with the carriage at d = 12 m.
        let c = clik();
        let [t1, t2, v0] = ClikParams::ROBOGAT.dexterous;
        let goal = c.monitor.position(&Joints::new(12.0, t1, t2, v0), 6.3);
        let mut q = Joints::new(10.0, 0.3, -0.6, 20.0);
        for _ in 0..20_000 {
            c.step(&mut q, &hold(goal), Weights::FIXED);
        }
        assert!((c.monitor.position(&q, 6.3) - goal).norm() < 1e-6);
        let expected = Joints::new(12.0, t1, t2, v0);
        assert!((q - expected).amax() < 1e-3, "{q}");
    }

    #[test]
    fn a_frozen_joint_does_not_move() {
        let c = clik();
        let mut q = Joints::new(5.0, 0.0, -0.26, 14.6);
        let w = Weights {
            beta_d: 0.0,
            beta_m: 1.0,
            beta_v: 1.0,
        };
        let goal = c.monitor.position(&q, 6.3) + Vector2::new(2.0, 1.0);
        for _ in 0..2000 {
            c.step(&mut q, &hold(goal), w);
        }
        assert_eq!(q[super::super::kinematics::D], 5.0);
        assert!((c.monitor.position(&q, 6.3) - goal).norm() < 1e-6);
    }

    #[test]
    fn limits_are_never_exceeded_even_for_unreachable_targets() {
        let c = clik();
        let mut q = Joints::new(1.0, 0.0, -0.26, 14.6);
        for goal in [
            Vector2::new(-30.0, 0.0),
            Vector2::new(200.0, 40.0),
            Vector2::new(5.0, -60.0),
        ] {
            for _ in 0..3000 {
                let s = c.step(&mut q, &hold(goal), Weights::FIXED);
                assert!(c.limits.contains(&q), "{q}");
                assert!(s.qdot.iter().all(|v| v.is_finite()));
            }
        }
    }

    #[test]
    fn damping_keeps_rates_bounded_at_a_singular_posture() {
        // Jet straight down with the carriage and the valve frozen: the monitor's yaw
        // moves nothing, the task Jacobian's rank drops.
        let c = clik();
        let mut q = Joints::new(10.0, 0.0, -std::f64::consts::FRAC_PI_2, 5.0);
        let w = Weights {
            beta_d: 0.0,
            beta_m: 1.0,
            beta_v: 0.0,
        };
        let s = c.step(&mut q, &hold(Vector2::new(10.0, 3.0)), w);
        assert!(s.damping > 0.0);
        assert!(
            s.qdot.iter().all(|v| v.is_finite() && v.abs() < 1e5),
            "{}",
            s.qdot
        );
    }
}
