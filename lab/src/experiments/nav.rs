//! `firefleet-lab nav`: the BT paper's navigation trials (section 4.2, Fig. 10-11).
//!
//! The paper's set-up: a two-lane tunnel with one curve; two vehicles placed at random
//! for each trial, one on the curve and one in front of the flame; the robot runs its tree
//! towards the flame and stops in front of it. It reports the time to arrive and the final
//! angular deviation from facing the flame over 30 trials.
//!
//! Ours: the shipped ground tree and unit (flame tracker, firing-position choice,
//! Hybrid A* with the visibility term, pure pursuit) on the simulated body,
//! stepped in-process with the world. The unit is given the fire as a coordinator's task
//! at t = 0, as the paper starts its timer with the flame already localised. Arrival is
//! when the unit stops navigating and starts aiming. Each trial runs twice, with the
//! visibility term on and off, on the same vehicles and seed, so the difference is the
//! term's alone; "in view" is ground truth from the simulator: the flame in the camera's
//! image, within range, hidden by neither the inner wall nor a vehicle.
//!
//! Our tunnel's dimensions are ours (the paper gives none): 9 m wide, a 25 m straight, a
//! 60 degree left curve of 45 m radius, a 35 m straight; the robot starts 5 m in, in the
//! right lane, and the flame burns 15 m past the curve. Times cannot match the paper's
//! (its robot, distance and speed differ); the angular deviation can be compared.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet_agent::ground::GroundController;
use firefleet_model::UnitKind;
use firefleet_model::geometry::wrap_angle;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::{FireSpec, Growth, Obstacle, Scenario, Segment, Tunnel, UnitSpec};
use firefleet_model::{Chainage, FireId, SiteId, UnitId};
use firefleet_protocol::msg::{Approach, TaskKind, UnitMode};
use firefleet_sim::World;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::mean_std;

use firefleet::args::write_json;

#[derive(Args, Debug)]
pub struct NavArgs {
    #[arg(long, default_value_t = 1)]
    seed: u64,
    #[arg(long, default_value_t = 30)]
    trials: u32,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

const STRAIGHT_IN_M: f64 = 25.0;
const CURVE_RADIUS_M: f64 = 45.0;
const CURVE_DEG: f64 = 60.0;
const STRAIGHT_OUT_M: f64 = 35.0;
const START_S_M: f64 = 5.0;
/// The flame's chainage past the end of the curve, and its offset, m.
const FLAME_PAST_CURVE_M: f64 = 15.0;
const FLAME_D_M: f64 = -1.5;
/// A trial that has not arrived by then has failed, s.
const TRIAL_LIMIT_S: f64 = 150.0;
const DT_S: f64 = 0.05;

/// The paper's figures: time mean and std (s), mean absolute angle and its std (deg).
const PAPER: (f64, f64, f64, f64) = (20.22, 0.08, 4.27, 6.21);

fn tunnel() -> Tunnel {
    let centerline = vec![
        Segment::Straight {
            length_m: STRAIGHT_IN_M,
        },
        Segment::Arc {
            radius_m: CURVE_RADIUS_M,
            angle_rad: CURVE_DEG.to_radians(),
        },
        Segment::Straight {
            length_m: STRAIGHT_OUT_M,
        },
    ];
    let length_m = centerline.iter().map(Segment::length_m).sum();
    Tunnel {
        centerline,
        ..Tunnel::straight(length_m, 9.0, 6.3, 2)
    }
}

fn curve_end_m() -> f64 {
    STRAIGHT_IN_M + CURVE_RADIUS_M * CURVE_DEG.to_radians()
}

/// A parked car at chainage `s` in lane `lane`, a little off the lane's centre and askew.
fn car(name: &str, t: &Tunnel, s: f64, lane: u8, rng: &mut ChaCha8Rng) -> Obstacle {
    let s = Chainage::new(s);
    let d = t.lane_center_y(lane) + rng.random_range(-0.4..0.4);
    let p = t.point_at(s, d);
    Obstacle {
        name: name.into(),
        x_m: p.x,
        y_m: p.y,
        length_m: 4.5,
        width_m: 1.8,
        height_m: 1.5,
        yaw_rad: wrap_angle(t.heading_at(s) + rng.random_range(-0.15..0.15)),
    }
}

/// Trial `k`'s site: the vehicles drawn from `seed`.
fn scenario(seed: u64) -> anyhow::Result<Scenario> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let t = tunnel();
    let flame_s = curve_end_m() + FLAME_PAST_CURVE_M;
    let flame = t.point_at(Chainage::new(flame_s), FLAME_D_M);
    let start = t.point_at(Chainage::new(START_S_M), t.lane_center_y(0));
    let on_curve = rng.random_range(STRAIGHT_IN_M + 3.0..curve_end_m() - 3.0);
    let lane_curve = rng.random_range(0..2u8);
    let in_front = flame_s - rng.random_range(6.5..10.0);
    let lane_front = rng.random_range(0..2u8);
    let obstacles = vec![
        car("on-curve", &t, on_curve, lane_curve, &mut rng),
        car("before-flame", &t, in_front, lane_front, &mut rng),
    ];
    let s = Scenario {
        seed,
        obstacles,
        fires: vec![FireSpec {
            name: "flame".into(),
            x_m: flame.x,
            y_m: flame.y,
            // A small fire that burns through the trial without spreading: navigation is
            // what is measured.
            growth: Growth::Medium,
            peak_kw: 400.0,
            ignition_s: -120.0,
            radius_m: 0.5,
        }],
        units: vec![UnitSpec {
            id: UnitId::new("ugv")?,
            kind: UnitKind::Ground,
            x_m: start.x,
            y_m: start.y,
            yaw_rad: 0.0,
            rail: None,
            profile: None,
        }],
        ..Scenario::empty("nav-experiment", SiteId::new("nav")?, t, TRIAL_LIMIT_S)
    };
    s.validate()
        .map_err(|e| anyhow::anyhow!("generated scenario (seed {seed}): {e}"))?;
    Ok(s)
}

/// What one run did.
struct Trial {
    /// Time to arrive, s; `None` if it never did.
    time_s: Option<f64>,
    /// Signed deviation of the heading from the bearing to the flame on arrival, deg.
    angle_deg: f64,
    /// Share of the drive with the flame in view.
    in_view: f64,
    collisions: u32,
}

fn trial(s: &Scenario, seed: u64, lambda_m: Option<f64>) -> anyhow::Result<Trial> {
    let id = s.units[0].id.clone();
    let flame = s.fires[0].position();
    let mut world = World::new(s, seed);
    let mut ctl = GroundController::new(id.clone(), *GROUND, Arc::new(s.clone()));
    if let Some(l) = lambda_m {
        ctl.set_visibility_weight(l);
    }
    ctl.office_changed(true);
    ctl.on_task(
        0,
        1,
        TaskKind::Extinguish {
            fire: FireId(1),
            target: flame,
            from: Approach::Either,
        },
    )?;
    let (mut frames, mut seen) = (0u32, 0u32);
    while world.time() < TRIAL_LIMIT_S {
        let sensors = world.sensors(&id).context("the unit exists")?;
        let cmd = ctl.step(&sensors);
        let state = ctl.state();
        if state.mode == UnitMode::Extinguishing {
            let truth = world.truth();
            let pose = state.pose;
            return Ok(Trial {
                time_s: Some(state.t),
                angle_deg: wrap_angle(pose.yaw - pose.position().bearing_to(flame)).to_degrees(),
                in_view: f64::from(seen) / f64::from(frames.max(1)),
                collisions: truth.units[0].collisions,
            });
        }
        frames += 1;
        seen += u32::from(world.flame_in_view(&id, 0).unwrap_or(false));
        world.command(&id, cmd);
        world.step(DT_S);
    }
    Ok(Trial {
        time_s: None,
        angle_deg: f64::NAN,
        in_view: f64::from(seen) / f64::from(frames.max(1)),
        collisions: world.truth().units[0].collisions,
    })
}

#[derive(Serialize)]
struct Figures {
    trials: u32,
    arrived: u32,
    mean_time_s: f64,
    std_time_s: f64,
    mean_abs_angle_deg: f64,
    /// Standard deviation of the signed deviation (the paper's spread).
    std_angle_deg: f64,
    flame_in_view_fraction: f64,
    collisions: u32,
}

#[derive(Serialize)]
struct NavResults {
    seed: u64,
    #[serde(flatten)]
    visibility: Figures,
    no_visibility: Figures,
    paper: PaperFigures,
}

#[derive(Serialize)]
struct PaperFigures {
    mean_time_s: f64,
    std_time_s: f64,
    mean_abs_angle_deg: f64,
    std_angle_deg: f64,
}

fn figures(runs: &[Trial]) -> Figures {
    let arrived: Vec<&Trial> = runs.iter().filter(|r| r.time_s.is_some()).collect();
    let times: Vec<f64> = arrived.iter().filter_map(|r| r.time_s).collect();
    let angles: Vec<f64> = arrived.iter().map(|r| r.angle_deg).collect();
    let abs: Vec<f64> = angles.iter().map(|a| a.abs()).collect();
    let (mean_time_s, std_time_s) = mean_std(&times);
    Figures {
        trials: runs.len() as u32,
        arrived: arrived.len() as u32,
        mean_time_s,
        std_time_s,
        mean_abs_angle_deg: mean_std(&abs).0,
        std_angle_deg: mean_std(&angles).1,
        flame_in_view_fraction: runs.iter().map(|r| r.in_view).sum::<f64>()
            / runs.len().max(1) as f64,
        collisions: runs.iter().map(|r| r.collisions).sum(),
    }
}

pub fn run(a: NavArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        (1..=1000).contains(&a.trials),
        "--trials {}: must be within [1, 1000]",
        a.trials
    );
    let (mut on, mut off) = (Vec::new(), Vec::new());
    for k in 0..a.trials {
        let seed = a.seed.wrapping_mul(1000).wrapping_add(u64::from(k));
        let s = scenario(seed)?;
        on.push(trial(&s, seed, None)?);
        off.push(trial(&s, seed, Some(0.0))?);
    }
    let (vis, novis) = (figures(&on), figures(&off));
    let t = tunnel();
    println!(
        "navigation experiment (BT paper, section 4.2): {} trials, seed {}; two-lane tunnel {:.1} m long with a {CURVE_DEG:.0} deg curve, \
         a car on the curve and one before the flame, robot {:.1} m from the flame along the road",
        a.trials,
        a.seed,
        t.length_m,
        curve_end_m() + FLAME_PAST_CURVE_M - START_S_M
    );
    println!(
        "{:<16} {:>8} {:>17} {:>11} {:>10} {:>14} {:>10}",
        "", "arrived", "time (s)", "|angle| deg", "angle std", "flame in view", "collisions"
    );
    for (name, f) in [("visibility on", &vis), ("visibility off", &novis)] {
        println!(
            "{name:<16} {:>5}/{:<2} {:>9.2} ± {:<5.2} {:>11.2} {:>10.2} {:>13.0}% {:>10}",
            f.arrived,
            f.trials,
            f.mean_time_s,
            f.std_time_s,
            f.mean_abs_angle_deg,
            f.std_angle_deg,
            100.0 * f.flame_in_view_fraction,
            f.collisions
        );
    }
    println!(
        "{:<16} {:>5}/{:<2} {:>9.2} ± {:<5.2} {:>11.2} {:>10.2} {:>14} {:>10}",
        "paper", 30, 30, PAPER.0, PAPER.1, PAPER.2, PAPER.3, "-", "-"
    );
    if let Some(path) = &a.json {
        let results = NavResults {
            seed: a.seed,
            visibility: vis,
            no_visibility: novis,
            paper: PaperFigures {
                mean_time_s: PAPER.0,
                std_time_s: PAPER.1,
                mean_abs_angle_deg: PAPER.2,
                std_angle_deg: PAPER.3,
            },
        };
        write_json(Some(path), &results)?;
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_unit_drives_round_the_bend_past_the_cars_and_stops_facing_the_flame() {
        let s = scenario(1000).unwrap();
        let r = trial(&s, 1000, None).unwrap();
        let t = r.time_s.expect("arrived");
        // 82 m along the road to the flame, the firing spot 4.5 m or more short of it, at
        // up to 1.5 m/s: 51 s at least, a little less on the inside of the curve.
        assert!((48.0..70.0).contains(&t), "{t} s");
        assert!(r.angle_deg.abs() < 5.0, "{} deg off the flame", r.angle_deg);
        assert_eq!(r.collisions, 0);
        assert!(r.in_view > 0.1 && r.in_view < 0.9, "{}", r.in_view);
    }
}
