//! `firefleet plan`: run the planners on standard inputs.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use clap::{Args, Subcommand};
use firefleet_agent::nav::movingai;
use serde::Serialize;

#[derive(Subcommand, Debug)]
pub enum PlanCommand {
    /// Solve a MovingAI grid benchmark (.map + .scen) and compare with its optimal lengths.
    Grid(GridArgs),
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
    }
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
    if let Some(path) = &a.json {
        std::fs::write(path, serde_json::to_string_pretty(&f)?)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(if f.solved == f.problems {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
