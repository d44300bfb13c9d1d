//! Direct kinematics of the ROBOGAT monorail monitor and its Jacobians (paper, eq. 1-2).
//!
//! Frame (the paper's base frame): origin at the rail's start, at the height of the point
//! M where the monitor's axes meet; x along the rail, z pointing *down*, y completing a
//! right-handed frame, so y points to the *right* when looking along +x. The site frame
//! has z up and y left: a site point is `(x0 + x, y0 - y, h - z)` for a rail starting at
//! `(x0, y0)` with M at height `h` ([`super::RailFrame`] does that conversion).
//!
//! Joints `q = [d, theta1, theta2, v0]`: carriage position along the rail, monitor yaw
//! (eq. 1 puts the jet at `y = -r sin(theta1)`, so a positive yaw turns the jet to the
//! *left* of +x), monitor elevation (0 horizontal, negative down), and the nozzle's exit
//! speed. The jet is a drag-free parabola in the monitor's
//! vertical plane; `r(theta2, v0, z)` is its horizontal range on the plane `z` below M.
//!
//! Not here: choosing joint velocities (the CLIK, [`super::clik`]) or planning the jet's
//! path ([`super::planner`]).

use nalgebra::{Matrix2x4, Vector2, Vector4};

/// Standard gravity, m/s^2.
pub const G: f64 = 9.81;

/// Joint vector `[d, theta1, theta2, v0]` (m, rad, rad, m/s).
pub type Joints = Vector4<f64>;

/// Index of each joint in [`Joints`].
pub const D: usize = 0;
pub const THETA1: usize = 1;
pub const THETA2: usize = 2;
pub const V0: usize = 3;

/// The monitor's geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Monitor {
    /// Length of the monitor's second link (M to the nozzle), m; the paper's `l`.
    pub link_m: f64,
}

/// The jet's end point and its derivatives at one configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JetPoint {
    /// `[x, y]` of the point where the jet crosses the plane `z`.
    pub p: Vector2<f64>,
    /// `d p / d q` (2 x 4), the paper's `J_xy`.
    pub j_xy: Matrix2x4<f64>,
    /// `d p / d z`, the paper's `J_z`.
    pub j_z: Vector2<f64>,
}

impl Monitor {
    /// Horizontal range of the jet on the plane `z` below M, m (paper, eq. 1).
    ///
    /// With `s2 <= 0` (monitor level or pointing down) and `z >= l`, the square root's
    /// argument is positive, so the range is defined over the whole joint range.
    pub fn range(&self, theta2: f64, v0: f64, z: f64) -> f64 {
        let (s2, c2) = theta2.sin_cos();
        let l = self.link_m;
        l * c2 + v0 * v0 * c2 / G * (s2 + self.root(s2, v0, z))
    }

    fn root(&self, s2: f64, v0: f64, z: f64) -> f64 {
        (s2 * s2 + 2.0 * G * (z + self.link_m * s2) / (v0 * v0)).sqrt()
    }

    /// Where the jet crosses the plane `z` below M: `p_xy(q, z)` of eq. 1.
    pub fn position(&self, q: &Joints, z: f64) -> Vector2<f64> {
        let r = self.range(q[THETA2], q[V0], z);
        let (s1, c1) = q[THETA1].sin_cos();
        Vector2::new(q[D] + r * c1, -r * s1)
    }

    /// The jet point with the analytic Jacobians of eq. 2.
    pub fn jet(&self, q: &Joints, z: f64) -> JetPoint {
        let (s1, c1) = q[THETA1].sin_cos();
        let (s2, c2) = q[THETA2].sin_cos();
        let (v0, l) = (q[V0], self.link_m);
        let v2 = v0 * v0;
        let root = self.root(s2, v0, z);
        let a = v2 * c2 / G;
        let b = s2 + root;
        let r = l * c2 + a * b;
        // Partial derivatives of the range; `root` is never zero on the joint range.
        let droot_dth2 = c2 * (s2 + G * l / v2) / root;
        let dr_dth2 = -l * s2 - v2 * s2 / G * b + a * (c2 + droot_dth2);
        let droot_dv0 = -2.0 * G * (z + l * s2) / (v2 * v0 * root);
        let dr_dv0 = 2.0 * v0 * c2 / G * b + a * droot_dv0;
        let dr_dz = c2 / root;
        JetPoint {
            p: Vector2::new(q[D] + r * c1, -r * s1),
            j_xy: Matrix2x4::new(
                1.0,
                -r * s1,
                c1 * dr_dth2,
                c1 * dr_dv0,
                0.0,
                -r * c1,
                -s1 * dr_dth2,
                -s1 * dr_dv0,
            ),
            j_z: Vector2::new(c1 * dr_dz, -s1 * dr_dz),
        }
    }
}

/// Box limits on the joints.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    pub lo: Joints,
    pub hi: Joints,
}

impl Limits {
    /// The ROBOGAT monitor's limits (paper, section IV) on a rail of `length_m`.
    pub fn robogat(length_m: f64) -> Self {
        use std::f64::consts::{FRAC_PI_2, FRAC_PI_3};
        Self {
            lo: Joints::new(0.0, -FRAC_PI_3, -FRAC_PI_2, 2.6),
            hi: Joints::new(length_m, FRAC_PI_3, 0.0, 26.6),
        }
    }

    pub fn contains(&self, q: &Joints) -> bool {
        (0..4).all(|i| (self.lo[i]..=self.hi[i]).contains(&q[i]))
    }

    pub fn clamp(&self, q: &Joints) -> Joints {
        Joints::from_fn(|i, _| q[i].clamp(self.lo[i], self.hi[i]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const M: Monitor = Monitor { link_m: 0.8 };

    fn joints() -> impl Strategy<Value = (Joints, f64)> {
        let lim = Limits::robogat(100.0);
        (
            lim.lo[0]..lim.hi[0],
            lim.lo[1]..lim.hi[1],
            lim.lo[2]..lim.hi[2],
            lim.lo[3]..lim.hi[3],
            1.0f64..12.0,
        )
            .prop_map(|(d, t1, t2, v, z)| (Joints::new(d, t1, t2, v), z))
    }

    #[test]
    fn range_matches_the_projectile_it_comes_from() {
        // Fly the particle of the paper's appendix (eq. 12-13) and find where it crosses z.
        for (th2, v0, z) in [(-0.26, 14.6, 6.3), (0.0, 26.6, 6.3), (-1.2, 3.0, 2.0)] {
            let (s2, c2) = f64::sin_cos(th2);
            let l = M.link_m;
            let mut t = 0.0;
            // 2y = l s2 + v0 s2 t - g t^2 / 2 reaches -z.
            while l * s2 + v0 * s2 * t - 0.5 * G * t * t > -z {
                t += 1e-6;
            }
            let x = l * c2 + v0 * c2 * t;
            assert!((x - M.range(th2, v0, z)).abs() < 1e-4, "{x}");
        }
    }

    #[test]
    fn straight_down_lands_under_the_nozzle() {
        let r = M.range(-std::f64::consts::FRAC_PI_2, 10.0, 6.3);
        assert!(r.abs() < 1e-9, "{r}");
    }

    proptest! {
        #[test]
        fn jacobians_agree_with_central_differences((q, z) in joints()) {
            let jet = M.jet(&q, z);
            prop_assert!((jet.p - M.position(&q, z)).norm() < 1e-12);
            let h = 1e-6;
            for i in 0..4 {
                let mut dq = Joints::zeros();
                dq[i] = h;
                let fd = (M.position(&(q + dq), z) - M.position(&(q - dq), z)) / (2.0 * h);
                let col = jet.j_xy.column(i);
                prop_assert!((fd - col).norm() < 1e-5 * (1.0 + col.norm()), "column {}: {} vs {}", i, fd, col);
            }
            let fd = (M.position(&q, z + h) - M.position(&q, z - h)) / (2.0 * h);
            prop_assert!((fd - jet.j_z).norm() < 1e-5 * (1.0 + fd.norm()));
        }

        #[test]
        fn the_jet_lands_ahead_of_the_monitor_and_within_its_plane((q, z) in joints()) {
            let p = M.position(&q, z);
            let r = M.range(q[THETA2], q[V0], z);
            prop_assert!(r >= -1e-9);
            prop_assert!(((p.x - q[D]).hypot(p.y) - r).abs() < 1e-9);
        }
    }
}
