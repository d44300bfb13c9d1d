//! `firefleet-lab robogat`: the ROBOGAT paper's case study, fuzzy against fixed
//! weights, with the time histories as CSV and as PNG plots of the paper's figures 5-8.
//!
//! Not here: the case study itself (`firefleet_agent::monorail::case_study`).

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;
use firefleet_agent::monorail::case_study::{CaseStudy, Outcome, Weighting};
use firefleet_agent::monorail::kinematics::{D, THETA1, THETA2, V0};
use serde::Serialize;

use super::plot::{self, Labels, Series};

use firefleet::args::write_json;

#[derive(Args, Debug)]
pub struct RobogatArgs {
    /// Also write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write the time histories (CSV) and plots (PNG) into this directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

#[derive(Serialize)]
struct Figures {
    time_to_reach_fire_s: Option<f64>,
    rail_travel_extinguishing_m: f64,
    joint_effort: f64,
    max_tracking_error_m: f64,
}

#[derive(Serialize)]
struct Results {
    fuzzy: Figures,
    fixed: Figures,
}

fn figures(o: &Outcome) -> Figures {
    Figures {
        time_to_reach_fire_s: o.time_to_reach_fire_s,
        rail_travel_extinguishing_m: o.rail_travel_extinguishing_m,
        joint_effort: o.joint_effort,
        max_tracking_error_m: o.max_tracking_error_m,
    }
}

/// Samples kept for CSV and plots: every 10 ms of the 1 kHz run.
const EVERY: usize = 10;

pub fn run(a: RobogatArgs) -> anyhow::Result<ExitCode> {
    let case = CaseStudy::default();
    let [fuzzy, fixed] = case.run(EVERY);
    let opt = |v: Option<f64>| v.map_or("never".to_owned(), |t| format!("{t:.2} s"));
    println!("ROBOGAT case study: fire at [20, 0, 6.3] m, 40 s at 1000 Hz, K = 600, kw = 200\n");
    println!("{:<44} {:>12} {:>12}   paper", "", "fuzzy", "fixed (b=1)");
    println!(
        "{:<44} {:>12} {:>12}   about 1 s",
        "jet reaches the fire along x",
        opt(fuzzy.time_to_reach_fire_s),
        opt(fixed.time_to_reach_fire_s)
    );
    println!(
        "{:<44} {:>10.1} m {:>10.1} m   fixed: vehicle keeps moving fast",
        "carriage travel while extinguishing",
        fuzzy.rail_travel_extinguishing_m,
        fixed.rail_travel_extinguishing_m
    );
    println!(
        "{:<44} {:>12.1} {:>12.1}   (not reported)",
        "joint effort (sum of (qdot/qdot_max)^2 dt)", fuzzy.joint_effort, fixed.joint_effort
    );
    println!(
        "{:<44} {:>10.3} m {:>10.3} m   (not reported)",
        "max tracking error |p_d - p|", fuzzy.max_tracking_error_m, fixed.max_tracking_error_m
    );
    if let Some(dir) = &a.out {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        for o in [&fuzzy, &fixed] {
            write_csv(dir, o)?;
        }
        write_plots(dir, &fuzzy, &fixed)?;
        println!("\ntime histories and plots in {}", dir.display());
    }
    if let Some(path) = &a.json {
        let r = Results {
            fuzzy: figures(&fuzzy),
            fixed: figures(&fixed),
        };
        write_json(Some(path), &r)?;
    }
    Ok(ExitCode::SUCCESS)
}

fn name(w: Weighting) -> &'static str {
    match w {
        Weighting::Fuzzy => "fuzzy",
        Weighting::Fixed => "fixed",
    }
}

fn write_csv(dir: &Path, o: &Outcome) -> anyhow::Result<()> {
    let mut text = String::from(
        "t_s,planned_x_m,planned_y_m,jet_x_m,jet_y_m,d_m,theta1_rad,theta2_rad,v0_m_s,beta_d,beta_m,beta_v,temperature_c,phase\n",
    );
    for s in &o.samples {
        writeln!(
            text,
            "{:.3},{:.5},{:.5},{:.5},{:.5},{:.5},{:.6},{:.6},{:.5},{:.4},{:.4},{:.4},{:.1},{:?}",
            s.t,
            s.planned.x,
            s.planned.y,
            s.jet.x,
            s.jet.y,
            s.q[D],
            s.q[THETA1],
            s.q[THETA2],
            s.q[V0],
            s.weights.beta_d,
            s.weights.beta_m,
            s.weights.beta_v,
            s.temperature_c,
            s.phase
        )?;
    }
    let path = dir.join(format!("robogat_{}.csv", name(o.weighting)));
    std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
}

fn series<'a>(
    o: &Outcome,
    name: &'a str,
    f: impl Fn(&firefleet_agent::monorail::case_study::Sample) -> f64,
) -> Series<'a> {
    Series {
        name,
        points: o.samples.iter().map(|s| (s.t, f(s))).collect(),
    }
}

fn joints(o: &Outcome) -> Vec<Series<'static>> {
    vec![
        series(o, "d [m]", |s| s.q[D]),
        series(o, "theta1 [rad]", |s| s.q[THETA1]),
        series(o, "theta2 [rad]", |s| s.q[THETA2]),
        series(o, "v0 [m/s]", |s| s.q[V0]),
    ]
}

/// The paper's figures 5-8: file, title, y axis.
const FIGURES: [(&str, &str, &str); 4] = [
    (
        "fig5_task_space.png",
        "Planned task-space trajectory of the jet (fuzzy)",
        "[m]",
    ),
    (
        "fig6_joints_fuzzy.png",
        "Joint positions, fuzzy weights",
        "[m, rad, rad, m/s]",
    ),
    ("fig7_fuzzy_outputs.png", "Fuzzy outputs", "weight"),
    (
        "fig8_joints_fixed.png",
        "Joint positions, fixed weights (beta = 1)",
        "[m, rad, rad, m/s]",
    ),
];

fn write_plots(dir: &Path, fuzzy: &Outcome, fixed: &Outcome) -> anyhow::Result<()> {
    let planned = vec![
        series(fuzzy, "x planned", |s| s.planned.x),
        series(fuzzy, "y planned", |s| s.planned.y),
    ];
    let weights = vec![
        series(fuzzy, "beta_d", |s| s.weights.beta_d),
        series(fuzzy, "beta_m", |s| s.weights.beta_m),
        series(fuzzy, "beta_v", |s| s.weights.beta_v),
    ];
    let lines = [planned, joints(fuzzy), weights, joints(fixed)];
    for ((file, title, y), lines) in FIGURES.into_iter().zip(lines) {
        let labels = Labels {
            title,
            x: "t [s]",
            y,
        };
        plot::line_chart(&dir.join(file), &labels, &lines)?;
    }
    Ok(())
}
