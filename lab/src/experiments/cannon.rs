//! The BT paper's water-cannon experiment (section 4.3): one ground unit 6 m from an
//! ignition point with 1 to 5 flames, at 0, 30 and 60 degrees, its tree alone.
//!
//! Not here: the tree (`firefleet_agent::ground::cannon_experiment_tree`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;

use anyhow::Context;
use clap::Args;
use firefleet::args::write_json;
use firefleet_agent::ground::{GroundController, cannon_experiment_tree};
use firefleet_model::UnitKind;
use firefleet_model::geometry::Point2;
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::{FireSpec, Growth, Scenario, Tunnel, UnitSpec};
use firefleet_model::{SiteId, UnitId};
use firefleet_protocol::msg::TruthFireState;
use firefleet_sim::World;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::mean_std;

#[derive(Args, Debug)]
pub struct CannonArgs {
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trials per angle.
    #[arg(long, default_value_t = 10)]
    trials: u32,
    /// Also write the results as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

/// The paper's figures: angle, mean and standard deviation of the time per flame, s.
const PAPER: [(f64, f64, f64); 3] = [
    (0.0, 1.7710, 0.1975),
    (30.0, 2.5599, 0.6582),
    (60.0, 3.8651, 1.1983),
];
/// Distance from the unit to the ignition point, m (as in the paper).
const IGNITION_DISTANCE_M: f64 = 6.0;
/// Flames are scattered within this radius of the ignition point, at least this far apart.
const SCATTER_RADIUS_M: f64 = 1.0;
const MIN_SEPARATION_M: f64 = 0.6;
/// A trial ends unfinished after this much simulated time, s.
const TRIAL_LIMIT_S: f64 = 120.0;

#[derive(Serialize)]
struct AngleResult {
    angle_deg: f64,
    trials: u32,
    flames: usize,
    mean_s_per_flame: f64,
    std_s_per_flame: f64,
    completion_rate: f64,
    paper_mean_s_per_flame: f64,
    paper_std_s_per_flame: f64,
}

#[derive(Serialize)]
struct CannonResults {
    seed: u64,
    angles: Vec<AngleResult>,
}

/// One trial: flames out, flames total, and the time per flame if all went out.
fn trial(angle_deg: f64, seed: u64) -> anyhow::Result<(usize, usize, Option<f64>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = rng.random_range(1..=5);
    let robot = Point2::new(30.0, -3.0);
    let ignition = robot.offset(angle_deg.to_radians(), IGNITION_DISTANCE_M);
    let mut spots: Vec<Point2> = Vec::new();
    while spots.len() < n {
        let (r, a) = (
            SCATTER_RADIUS_M * rng.random::<f64>().sqrt(),
            rng.random_range(0.0..std::f64::consts::TAU),
        );
        let p = ignition.offset(a, r);
        if spots.iter().all(|q| q.dist(p) >= MIN_SEPARATION_M) {
            spots.push(p);
        }
    }
    let unit = UnitId::new("ugv")?;
    let scenario = Scenario {
        seed,
        fires: spots
            .iter()
            .enumerate()
            .map(|(i, p)| FireSpec {
                name: format!("flame-{i}"),
                x_m: p.x,
                y_m: p.y,
                // Small pool flames of about 170 kW (1.3 m tall), burning when the trial starts.
                growth: Growth::Medium,
                peak_kw: 400.0,
                ignition_s: -120.0,
                radius_m: 0.25,
            })
            .collect(),
        units: vec![UnitSpec {
            id: unit.clone(),
            kind: UnitKind::Ground,
            x_m: robot.x,
            y_m: robot.y,
            yaw_rad: 0.0,
            rail: None,
            profile: None,
        }],
        ..Scenario::empty(
            "cannon-experiment",
            SiteId::new("cannon")?,
            Tunnel::straight(80.0, 10.0, 6.3, 2),
            TRIAL_LIMIT_S,
        )
    };
    scenario
        .validate()
        .map_err(|e| anyhow::anyhow!("generated scenario: {e}"))?;
    let mut world = World::new(&scenario, seed);
    let mut ctl = GroundController::with_tree(
        unit.clone(),
        *GROUND,
        Arc::new(scenario.clone()),
        &cannon_experiment_tree(),
        0.0,
    )?;
    while world.time() < TRIAL_LIMIT_S {
        world
            .step_unit(&unit, 0.05, |s| ctl.step(s))
            .context("the unit exists")?;
        if world.truth().all_out() {
            return Ok((n, n, Some(world.time() / n as f64)));
        }
    }
    let out = world
        .truth()
        .fires
        .iter()
        .filter(|f| f.state == TruthFireState::Out)
        .count();
    Ok((out, n, None))
}

pub fn run(a: CannonArgs) -> anyhow::Result<ExitCode> {
    let mut angles = Vec::new();
    println!(
        "water-cannon experiment (BT paper, section 4.3): unit 6 m from the ignition point, 1-5 flames, seed {}",
        a.seed
    );
    println!(
        "{:>6} {:>7} {:>7} {:>22} {:>11}   {:>22}",
        "angle", "trials", "flames", "time per flame (s)", "completion", "paper (s)"
    );
    for (angle, paper_mean, paper_std) in PAPER {
        let (mut times, mut out, mut total) = (Vec::new(), 0, 0);
        for k in 0..a.trials {
            let (o, n, t) = trial(angle, a.seed.wrapping_mul(1000).wrapping_add(u64::from(k)))?;
            out += o;
            total += n;
            times.extend(t);
        }
        let (mean, std) = mean_std(&times);
        let completion = out as f64 / total as f64;
        println!(
            "{angle:>5.0}° {:>7} {total:>7} {:>14.2} ± {std:<5.2} {:>10.0}%   {paper_mean:>13.4} ± {paper_std:.4}",
            a.trials,
            mean,
            100.0 * completion
        );
        angles.push(AngleResult {
            angle_deg: angle,
            trials: a.trials,
            flames: total,
            mean_s_per_flame: mean,
            std_s_per_flame: std,
            completion_rate: completion,
            paper_mean_s_per_flame: paper_mean,
            paper_std_s_per_flame: paper_std,
        });
    }
    if let Some(path) = &a.json {
        write_json(
            Some(path),
            &CannonResults {
                seed: a.seed,
                angles,
            },
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
