//! `firefleet-lab costmap-ga`: the Dijkstra+GA paper's three cases on a generated
//! 2.5-D fire map: no heat in the cost (case 1), heat with w1 = w2 = 1 (case 2), and
//! GA-tuned weights (case 3).
//!
//! Not here: the cost map and the GA themselves (`firefleet_nav::costmap`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_nav::costmap::{Ga, Terrain, three_cases};
use serde::Serialize;

use firefleet::args::write_json;

#[derive(Args, Debug)]
pub struct CostmapGaArgs {
    /// Seed of the generated map and of the GA.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The map is SIZE x SIZE cells; the trip runs corner to corner.
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u16).range(8..=400))]
    size: u16,
    /// Also write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct Case {
    case: u8,
    w1: f64,
    w2: f64,
    fitness: f64,
    path_time: f64,
    heat_dose: f64,
}

#[derive(Serialize)]
struct Results {
    seed: u64,
    size: u16,
    cases: Vec<Case>,
}

/// The paper's Table 1, on its own map.
const PAPER: [f64; 3] = [2306.33, 2281.98, 2042.69];

pub fn run(a: CostmapGaArgs) -> anyhow::Result<ExitCode> {
    let n = usize::from(a.size);
    let terrain = Terrain::generated(n, a.seed);
    let cases = three_cases(&terrain, (0, 0), (n - 1, n - 1), &Ga::default(), a.seed)
        .context("no path across the generated map")?;
    println!(
        "cost map + GA (Dijkstra+GA paper, eq. 1-8): generated {n} x {n} fire map, seed {}, corner to corner",
        a.seed
    );
    println!(
        "{:<5} {:>14} {:>10} {:>10} {:>11}   paper fitness",
        "case", "w1, w2", "fitness", "path time", "heat dose"
    );
    for (k, (case, w, s)) in cases.iter().enumerate() {
        println!(
            "{case:<5} {:>14} {:>10.1} {:>10.1} {:>11.0}   {:.2}",
            format!("{:.3}, {:.3}", w[0], w[1]),
            s.fitness,
            s.time,
            s.heat,
            PAPER[k]
        );
    }
    let [c1, c2, c3] = &cases;
    println!(
        "ordering: case 3 {} case 2 {} case 1 (paper: 2042.69 < 2281.98 < 2306.33); GA gain over case 2: {:.1} % (paper {:.1} %)",
        if c3.2.fitness <= c2.2.fitness {
            "<="
        } else {
            ">"
        },
        if c2.2.fitness <= c1.2.fitness {
            "<="
        } else {
            ">"
        },
        100.0 * (1.0 - c3.2.fitness / c2.2.fitness),
        100.0 * (1.0 - PAPER[2] / PAPER[1])
    );
    if let Some(path) = &a.json {
        let r = Results {
            seed: a.seed,
            size: a.size,
            cases: cases
                .iter()
                .map(|(case, w, s)| Case {
                    case: *case,
                    w1: w[0],
                    w2: w[1],
                    fitness: s.fitness,
                    path_time: s.time,
                    heat_dose: s.heat,
                })
                .collect(),
        };
        write_json(Some(path), &r)?;
    }
    Ok(ExitCode::SUCCESS)
}
