//! `firefleet status`: the incident as the coordinator sees it, for people or as JSON.
//!
//! Not here: the snapshot itself (the coordinator answers `coord/status`).

use std::process::ExitCode;

use clap::Args;
use firefleet_protocol::msg::{IncidentStatus, ZoneGoal};

use super::{ScenarioArg, scenarios};
use crate::net::{ZenohArgs, open, query_status};

#[derive(Args, Debug)]
pub struct StatusArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// Print the raw JSON snapshot.
    #[arg(long)]
    json: bool,
}

pub async fn run(a: StatusArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = open(&a.zenoh, &scenario).await?;
    let (status, bytes) = query_status(&bus).await?;
    if a.json {
        println!("{}", String::from_utf8_lossy(&bytes));
    } else {
        print_status(&status);
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// The goals in force, one a line.
pub fn print_goals(goals: &[ZoneGoal]) {
    if goals.is_empty() {
        println!("  (none)");
    }
    for g in goals {
        let kind = serde_json::to_value(g.goal)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default();
        let before = g
            .before_m
            .map_or(String::new(), |b| format!(" before {b:.1} m"));
        let expires = g
            .expires_s
            .map_or(String::new(), |e| format!(", expires after {e:.0} s"));
        println!(
            "  {:12} zone {:8} {kind}{before}  priority {}  by '{}'{expires}",
            g.id,
            g.zone.as_str(),
            g.priority,
            g.issued_by
        );
    }
}

fn print_status(s: &IncidentStatus) {
    println!("site time {:.1} s", s.t);
    println!("fires:");
    for f in &s.fires {
        let assigned: Vec<String> = f.assigned.iter().map(ToString::to_string).collect();
        let state = serde_json::to_value(f.state)
            .ok()
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap_or_default();
        println!(
            "  {:5} {:11} at ({:6.1}, {:5.1})  confidence {:.2}  assigned [{}]",
            f.id.to_string(),
            state,
            f.position.x,
            f.position.y,
            f.confidence,
            assigned.join(", ")
        );
    }
    println!("units:");
    for u in &s.units {
        let mode = u
            .state
            .as_ref()
            .and_then(|st| serde_json::to_value(st.mode).ok())
            .and_then(|v| v.as_str().map(str::to_owned));
        let task = u
            .task
            .as_ref()
            .map_or("-".to_owned(), |t| t.kind.to_string());
        let why = u
            .lost
            .as_ref()
            .map_or(String::new(), |w| format!("  ({w})"));
        println!(
            "  {:10} {:6} {:13} water {:6.0} L  task {task}{why}",
            u.unit.as_str(),
            if u.alive { "alive" } else { "lost" },
            mode.as_deref().unwrap_or("-"),
            u.state.as_ref().map_or(0.0, |st| st.water_l),
        );
    }
    println!("goals:");
    print_goals(&s.goals);
    if s.rejected.values().any(|n| *n > 0) {
        println!("rejected messages: {:?}", s.rejected);
    }
    println!("recent decisions:");
    for d in &s.decisions {
        println!("  t={:7.1}  {}", d.t, d.text);
    }
}
