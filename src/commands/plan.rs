//! `firefleet plan`: run the planners on standard inputs.
//!
//! Not here: the planners (`firefleet-nav`).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet_model::builtin;
use firefleet_nav::costmap::{Ga, Terrain, TimeModel};
use firefleet_nav::movingai;
use serde::Serialize;

use crate::commands::write_json;

#[derive(Subcommand, Debug)]
pub enum PlanCommand {
    /// Solve a MovingAI grid benchmark (.map + .scen) and compare with its optimal lengths.
    Grid(GridArgs),
    /// Tune the heat-aware cost map's weights (w1 time, w2 heat) with the genetic
    /// algorithm, for a trip through a scenario: from its first unit to the tunnel's far
    /// end in that unit's lane, past the fires.
    TuneCostmap(TuneArgs),
}

#[derive(Args, Debug)]
pub struct TuneArgs {
    /// A built-in scenario name or a scenario file.
    #[arg(long, default_value = "vehicle-collision")]
    scenario: String,
    /// Cell size, m.
    #[arg(long, default_value_t = 0.5)]
    res_m: f64,
    #[arg(long, default_value_t = 1)]
    seed: u64,
}

#[derive(Args, Debug)]
pub struct GridArgs {
    #[arg(long, value_name = "FILE.map")]
    map: PathBuf,
    #[arg(long, value_name = "FILE.scen")]
    scen: PathBuf,
    /// Also write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct GridFigures {
    problems: usize,
    solved: usize,
    mean_rel_error: f64,
    mean_ms: f64,
}

pub fn run(cmd: PlanCommand) -> anyhow::Result<ExitCode> {
    match cmd {
        PlanCommand::Grid(a) => grid(a),
        PlanCommand::TuneCostmap(a) => tune(a),
    }
}

fn tune(a: TuneArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        (0.1..=5.0).contains(&a.res_m),
        "--res-m {}: must be within [0.1, 5] m",
        a.res_m
    );
    let s = builtin::resolve(&a.scenario)?;
    let unit = s.units.first().context("the scenario has no unit")?;
    let terrain = Terrain::from_scenario(&s, a.res_m);
    let t = &s.tunnel;
    let start = terrain.cell_of(unit.pose().position(), a.res_m, t);
    let end = t.point_at(t.end() - 1.0, t.station(unit.pose().position()).d);
    let goal = terrain.cell_of(end, a.res_m, t);
    let time = terrain.time(&TimeModel::PAPER);
    let tuned = Ga::default()
        .tune(&terrain, &time, start, goal, a.seed)
        .context("no path from the unit to the tunnel's far end")?;
    let (w, sc) = (tuned.weights, tuned.score);
    println!(
        "{}: {} from ({:.1}, {:.1}) to ({:.1}, {:.1}), {} x {} cells of {} m",
        s.name, unit.id, unit.x_m, unit.y_m, end.x, end.y, terrain.width, terrain.height, a.res_m
    );
    println!("weights     w1 (time) {:.4}, w2 (heat) {:.4}", w[0], w[1]);
    println!(
        "fitness     {:.1}  (path time {:.1}, heat {:.1})",
        sc.fitness, sc.time, sc.heat
    );
    println!(
        "best by generation: {}",
        tuned
            .history
            .iter()
            .map(|f| format!("{f:.0}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    Ok(ExitCode::SUCCESS)
}

fn grid(a: GridArgs) -> anyhow::Result<ExitCode> {
    let read = |p: &PathBuf| {
        std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))
    };
    let map = movingai::parse_map(&read(&a.map)?).with_context(|| a.map.display().to_string())?;
    let problems = movingai::parse_scen(&read(&a.scen)?, map.size())
        .with_context(|| a.scen.display().to_string())?;
    let (mut solved, mut rel_error, mut total_ms) = (0, 0.0, 0.0);
    for p in &problems {
        let t0 = Instant::now();
        let found = map.astar(p.start, p.goal);
        total_ms += t0.elapsed().as_secs_f64() * 1e3;
        if let Some((len, _)) = found {
            solved += 1;
            if p.optimal > 0.0 {
                rel_error += (len - p.optimal).abs() / p.optimal;
            }
        }
    }
    let f = GridFigures {
        problems: problems.len(),
        solved,
        mean_rel_error: if solved > 0 {
            rel_error / solved as f64
        } else {
            f64::NAN
        },
        mean_ms: if problems.is_empty() {
            f64::NAN
        } else {
            total_ms / problems.len() as f64
        },
    };
    let (w, h) = map.size();
    println!("{} ({w} x {h}), {}", a.map.display(), a.scen.display());
    println!("problems        {}", f.problems);
    println!("solved          {}", f.solved);
    println!(
        "mean rel. error {:.2e}  (against the benchmark's optimal lengths)",
        f.mean_rel_error
    );
    println!("mean time       {:.3} ms per problem", f.mean_ms);
    write_json(a.json.as_deref(), &f)?;
    Ok(if f.solved == f.problems {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
