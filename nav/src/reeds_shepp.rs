//! Reeds-Shepp paths: the shortest paths of a car that turns no tighter than a radius and
//! may reverse (Reeds & Shepp, "Optimal paths for a car that goes both forwards and
//! backwards", 1990).
//!
//! The candidate words of the families CSC, CCC, CCCC, CCSC and CCSCC (44 of them) come
//! from eight base formulas of the paper (its equations 8.1 to 8.11) through its two
//! symmetries: *time-flip* (drive the word backwards: negate x, phi and
//! every segment) and *reflect* (mirror left and right: negate y and phi, swap L and R),
//! and for the CCC and CCSC families the *backwards* reading of the word. The tests drive
//! every candidate from the start and check it ends at the goal, and compare the shortest
//! lengths with an independent implementation (the `reeds_shepp` crate): equal within
//! 1e-6 on every pose pair tried.
//!
//! Lengths are in units of the turning radius inside, metres outside.
//!
//! Not here: obstacles; a Reeds-Shepp path knows only the turning radius, and its users
//! check it against the grid.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use firefleet_model::Pose2;

/// How one segment turns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Turn {
    Left,
    Right,
    Straight,
}

/// One segment: a turn and a signed length, metres (negative: reversing).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    pub turn: Turn,
    pub length: f64,
}

/// A Reeds-Shepp path: up to five segments.
#[derive(Debug, Clone, PartialEq)]
pub struct Path {
    pub segments: Vec<Segment>,
}

impl Path {
    /// Total length driven, forwards and backwards, metres.
    pub fn length(&self) -> f64 {
        self.segments.iter().map(|s| s.length.abs()).sum()
    }

    /// Whether the path reverses anywhere.
    pub fn reverses(&self) -> bool {
        self.segments.iter().any(|s| s.length < 0.0)
    }

    /// Poses along the path from `start` every `step` metres of travel (and the end), for
    /// turning radius `radius`.
    pub fn sample(&self, start: Pose2, radius: f64, step: f64) -> Vec<Pose2> {
        let mut out = vec![start];
        let mut p = start;
        for s in &self.segments {
            let n = (s.length.abs() / step).ceil().max(1.0) as usize;
            for k in 1..=n {
                out.push(advance(p, s.turn, s.length * k as f64 / n as f64, radius));
            }
            p = advance(p, s.turn, s.length, radius);
        }
        out
    }
}

/// Drive `length` metres (signed) of one segment from `p`.
pub fn advance(p: Pose2, turn: Turn, length: f64, radius: f64) -> Pose2 {
    let (s, c) = p.yaw.sin_cos();
    match turn {
        Turn::Straight => Pose2::new(p.x + length * c, p.y + length * s, p.yaw),
        Turn::Left | Turn::Right => {
            let k = if turn == Turn::Left { 1.0 } else { -1.0 };
            let dyaw = k * length / radius;
            let yaw = p.yaw + dyaw;
            Pose2::new(
                p.x + k * radius * (yaw.sin() - s),
                p.y - k * radius * (yaw.cos() - c),
                firefleet_model::geometry::wrap_angle(yaw),
            )
        }
    }
}

/// Below this a length counts as zero (the paper's formulas meet at boundaries).
const EPS: f64 = 1e-10;

fn m2pi(a: f64) -> f64 {
    let v = a.rem_euclid(TAU);
    if v > PI { v - TAU } else { v }
}

fn polar(x: f64, y: f64) -> (f64, f64) {
    (x.hypot(y), y.atan2(x))
}

fn tau_omega(u: f64, v: f64, xi: f64, eta: f64, phi: f64) -> (f64, f64) {
    let delta = m2pi(u - v);
    let a = u.sin() - delta.sin();
    let b = u.cos() - delta.cos() - 1.0;
    let t1 = (eta * a - xi * b).atan2(xi * a + eta * b);
    let t2 = 2.0 * (delta.cos() - v.cos() - u.cos()) + 3.0;
    let tau = if t2 < 0.0 { m2pi(t1 + PI) } else { m2pi(t1) };
    (tau, m2pi(tau - u + v - phi))
}

// The base formulas, for a goal (x, y, phi) with unit radius; each gives segment lengths.

/// 8.1: L+ S+ L+.
fn lp_sp_lp(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (u, t) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    let v = m2pi(phi - t);
    (t >= -EPS && v >= -EPS).then_some([t, u, v])
}

/// 8.2: L+ S+ R+.
fn lp_sp_rp(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (u1, t1) = polar(x + phi.sin(), y - 1.0 - phi.cos());
    let u1 = u1 * u1;
    if u1 < 4.0 {
        return None;
    }
    let u = (u1 - 4.0).sqrt();
    let t = m2pi(t1 + 2.0f64.atan2(u));
    let v = m2pi(t - phi);
    (t >= -EPS && v >= -EPS).then_some([t, u, v])
}

/// 8.3: L+ R- L.
fn lp_rm_l(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (u1, theta) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    if u1 > 4.0 {
        return None;
    }
    let u = -2.0 * (0.25 * u1).asin();
    let t = m2pi(theta + 0.5 * u + PI);
    let v = m2pi(phi - t + u);
    (t >= -EPS && u <= EPS).then_some([t, u, v])
}

/// 8.7: L+ R+ L- R-.
fn lp_rup_lum_rm(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let rho = 0.25 * (2.0 + xi.hypot(eta));
    if rho > 1.0 {
        return None;
    }
    let u = rho.acos();
    let (t, v) = tau_omega(u, -u, xi, eta, phi);
    (t >= -EPS && v <= EPS).then_some([t, u, v])
}

/// 8.8: L+ R- L- R+.
fn lp_rum_lum_rp(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let rho = (20.0 - xi * xi - eta * eta) / 16.0;
    if !(0.0..=1.0).contains(&rho) {
        return None;
    }
    let u = -rho.acos();
    if u < -FRAC_PI_2 {
        return None;
    }
    let (t, v) = tau_omega(u, u, xi, eta, phi);
    (t >= -EPS && v >= -EPS).then_some([t, u, v])
}

/// 8.9: L+ R-(pi/2) S- L-.
fn lp_rm_sm_lm(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (rho, theta) = polar(x - phi.sin(), y - 1.0 + phi.cos());
    if rho < 2.0 {
        return None;
    }
    let r = (rho * rho - 4.0).sqrt();
    let u = 2.0 - r;
    let t = m2pi(theta + r.atan2(-2.0));
    let v = m2pi(phi - FRAC_PI_2 - t);
    (t >= -EPS && u <= EPS && v <= EPS).then_some([t, u, v])
}

/// 8.10: L+ R-(pi/2) S- R-.
fn lp_rm_sm_rm(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let (rho, theta) = polar(-eta, xi);
    if rho < 2.0 {
        return None;
    }
    let (t, u) = (theta, 2.0 - rho);
    let v = m2pi(t + FRAC_PI_2 - phi);
    (t >= -EPS && u <= EPS && v <= EPS).then_some([t, u, v])
}

/// 8.11: L+ R-(pi/2) S- L-(pi/2) R+.
fn lp_rm_s_lm_rp(x: f64, y: f64, phi: f64) -> Option<[f64; 3]> {
    let (xi, eta) = (x + phi.sin(), y - 1.0 - phi.cos());
    let (rho, _) = polar(xi, eta);
    if rho < 2.0 {
        return None;
    }
    let u = 4.0 - (rho * rho - 4.0).sqrt();
    if u > EPS {
        return None;
    }
    let t = m2pi(((4.0 - u) * xi - 2.0 * eta).atan2(-2.0 * xi + (u - 4.0) * eta));
    let v = m2pi(t - phi);
    (t >= -EPS && v >= -EPS).then_some([t, u, v])
}

use Turn::{Left as L, Right as R, Straight as S};

/// Every candidate word for the goal (x, y, phi) at unit radius.
fn candidates(x: f64, y: f64, phi: f64) -> Vec<Vec<Segment>> {
    let mut out = Vec::new();
    let mut add = |turns: &[Turn], lengths: &[f64]| {
        out.push(
            turns
                .iter()
                .zip(lengths)
                .map(|(&turn, &length)| Segment { turn, length })
                .collect(),
        );
    };
    let swap = |turns: &[Turn]| -> Vec<Turn> {
        turns
            .iter()
            .map(|t| match t {
                L => R,
                R => L,
                S => S,
            })
            .collect()
    };
    // The four symmetric readings of a base formula: as is, time-flipped, reflected, both.
    let mut four = |f: fn(f64, f64, f64) -> Option<[f64; 3]>,
                    x: f64,
                    y: f64,
                    phi: f64,
                    turns: &[Turn],
                    lengths: &dyn Fn([f64; 3]) -> Vec<f64>| {
        let reflected = swap(turns);
        for (sx, sy, sphi, flip, word) in [
            (1.0, 1.0, 1.0, 1.0, turns.to_vec()),
            (-1.0, 1.0, -1.0, -1.0, turns.to_vec()),
            (1.0, -1.0, -1.0, 1.0, reflected.clone()),
            (-1.0, -1.0, 1.0, -1.0, reflected),
        ] {
            if let Some(p) = f(sx * x, sy * y, sphi * phi) {
                let l: Vec<f64> = lengths(p).iter().map(|v| flip * v).collect();
                add(&word, &l);
            }
        }
    };
    // CSC.
    four(lp_sp_lp, x, y, phi, &[L, S, L], &|[t, u, v]| vec![t, u, v]);
    four(lp_sp_rp, x, y, phi, &[L, S, R], &|[t, u, v]| vec![t, u, v]);
    // CCC, forwards and read backwards.
    four(lp_rm_l, x, y, phi, &[L, R, L], &|[t, u, v]| vec![t, u, v]);
    let (s, c) = phi.sin_cos();
    let (xb, yb) = (x * c + y * s, x * s - y * c);
    four(lp_rm_l, xb, yb, phi, &[L, R, L], &|[t, u, v]| vec![v, u, t]);
    // CCCC.
    four(lp_rup_lum_rm, x, y, phi, &[L, R, L, R], &|[t, u, v]| {
        vec![t, u, -u, v]
    });
    four(lp_rum_lum_rp, x, y, phi, &[L, R, L, R], &|[t, u, v]| {
        vec![t, u, u, v]
    });
    // CCSC, forwards and read backwards.
    four(lp_rm_sm_lm, x, y, phi, &[L, R, S, L], &|[t, u, v]| {
        vec![t, -FRAC_PI_2, u, v]
    });
    four(lp_rm_sm_rm, x, y, phi, &[L, R, S, R], &|[t, u, v]| {
        vec![t, -FRAC_PI_2, u, v]
    });
    four(lp_rm_sm_lm, xb, yb, phi, &[L, S, R, L], &|[t, u, v]| {
        vec![v, u, -FRAC_PI_2, t]
    });
    four(lp_rm_sm_rm, xb, yb, phi, &[R, S, R, L], &|[t, u, v]| {
        vec![v, u, -FRAC_PI_2, t]
    });
    // CCSCC.
    four(lp_rm_s_lm_rp, x, y, phi, &[L, R, S, L, R], &|[t, u, v]| {
        vec![t, -FRAC_PI_2, u, -FRAC_PI_2, v]
    });
    out
}

/// The shortest Reeds-Shepp path from `from` to `to` for turning radius `radius` (metres).
pub fn shortest(from: Pose2, to: Pose2, radius: f64) -> Path {
    let (dx, dy) = ((to.x - from.x) / radius, (to.y - from.y) / radius);
    let (s, c) = from.yaw.sin_cos();
    let (x, y) = (c * dx + s * dy, -s * dx + c * dy);
    let phi = m2pi(to.yaw - from.yaw);
    let best = candidates(x, y, phi)
        .into_iter()
        .min_by(|a, b| {
            let len = |w: &Vec<Segment>| w.iter().map(|s| s.length.abs()).sum::<f64>();
            len(a).total_cmp(&len(b))
        })
        .unwrap_or_default();
    Path {
        segments: best
            .into_iter()
            .filter(|s| s.length.abs() > EPS)
            .map(|s| Segment {
                turn: s.turn,
                length: s.length * radius,
            })
            .collect(),
    }
}

/// The length of the shortest Reeds-Shepp path, metres.
pub fn distance(from: Pose2, to: Pose2, radius: f64) -> f64 {
    shortest(from, to, radius).length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn end_of(path: &Path, from: Pose2, radius: f64) -> Pose2 {
        path.segments
            .iter()
            .fold(from, |p, s| advance(p, s.turn, s.length, radius))
    }

    fn close(a: Pose2, b: Pose2) -> bool {
        (a.x - b.x).abs() < 1e-6 && (a.y - b.y).abs() < 1e-6 && m2pi(a.yaw - b.yaw).abs() < 1e-6
    }

    #[test]
    fn every_candidate_word_drives_to_the_goal() {
        let mut count = 0;
        for (x, y, phi) in [
            (3.0, 2.0, 0.5),
            (-2.0, 1.0, 2.5),
            (0.5, -0.5, -2.0),
            (6.0, -4.0, 3.0),
            (-1.0, -3.0, 1.0),
            (0.2, 0.1, 3.1),
        ] {
            let goal = Pose2::new(x, y, phi);
            for w in candidates(x, y, phi) {
                let p = Path { segments: w };
                assert!(
                    close(end_of(&p, Pose2::default(), 1.0), goal),
                    "{p:?} to {goal:?}"
                );
                count += 1;
            }
        }
        assert!(count > 30, "{count} candidates");
    }

    #[test]
    fn straight_ahead_is_a_straight_line_and_a_turn_in_place_reverses() {
        let d = distance(Pose2::new(0.0, 0.0, 0.0), Pose2::new(10.0, 0.0, 0.0), 2.0);
        assert!((d - 10.0).abs() < 1e-9);
        let p = shortest(Pose2::new(0.0, 0.0, 0.0), Pose2::new(0.0, 0.0, PI), 1.0);
        assert!(
            p.reverses(),
            "turning round on the spot needs a reversal: {p:?}"
        );
    }

    fn pose() -> impl Strategy<Value = Pose2> {
        (-15.0f64..15.0, -15.0f64..15.0, -PI..PI).prop_map(|(x, y, t)| Pose2::new(x, y, t))
    }

    proptest! {
        #[test]
        fn the_shortest_path_reaches_the_goal_is_symmetric_and_beats_euclid(a in pose(), b in pose(), r in 0.5f64..4.0) {
            let p = shortest(a, b, r);
            prop_assert!(close(end_of(&p, a, r), b), "{:?}", p);
            let d = p.length();
            prop_assert!(d + 1e-9 >= a.position().dist(b.position()));
            prop_assert!((d - distance(b, a, r)).abs() < 1e-6, "{} vs {}", d, distance(b, a, r));
        }

        #[test]
        fn lengths_agree_with_an_independent_implementation(a in pose(), b in pose()) {
            let to = |p: Pose2| reeds_shepp_lib::Pose { x: p.x, y: p.y, theta_degree: p.yaw.to_degrees() };
            let theirs = reeds_shepp_lib::get_optimal_path(to(a), to(b)).map(|p| reeds_shepp_lib::path_length(&p));
            let ours = distance(a, b, 1.0);
            prop_assert!(theirs.is_some());
            prop_assert!((ours - theirs.unwrap()).abs() < 1e-6, "ours {} theirs {:?}", ours, theirs);
        }
    }
}
