//! `firefleet status`: the incident as the coordinator sees it, for people or as JSON.
//!
//! Not here: the snapshot itself (the coordinator answers `coord/status`).

use std::process::ExitCode;

use clap::Args;
use firefleet_protocol::codec::PROTOCOL_VERSION;
use firefleet_protocol::msg::IncidentStatus;

use super::ScenarioArg;
use firefleet::net::{ZenohArgs, open, query_status};

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
    let scenario = a.scenario.load()?;
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

fn print_status(s: &IncidentStatus) {
    println!("site time {:.1} s", s.t);
    println!("fires:");
    for f in &s.fires {
        let assigned: Vec<String> = f.assigned.iter().map(ToString::to_string).collect();
        println!(
            "  {:5} {:11} at ({:6.1}, {:5.1})  confidence {:.2}  assigned [{}]",
            f.id.to_string(),
            f.state.as_str(),
            f.position.x,
            f.position.y,
            f.confidence,
            assigned.join(", ")
        );
    }
    println!("units:");
    for u in &s.units {
        let mode = u.state.as_ref().map(|st| st.mode.as_str());
        let task = u
            .task
            .as_ref()
            .map_or("-".to_owned(), |t| t.kind.to_string());
        // A unit of another release is not lost: its messages are refused until the site
        // and the unit speak one version (deploy/UPGRADE.md).
        let why = match (u.protocol, &u.lost) {
            (Some(v), _) => format!(
                "  (OTHER PROTOCOL: speaks version {v}, the coordinator {PROTOCOL_VERSION}: its messages are refused until it is upgraded)"
            ),
            (None, Some(w)) => format!("  ({w})"),
            (None, None) => String::new(),
        };
        let presence = match (u.protocol, u.alive) {
            (Some(_), _) => "other",
            (None, true) => "alive",
            (None, false) => "lost",
        };
        // A unit whose reports no longer confirm a fire alone is named as such.
        let doubted = if u.report_weight < 0.5 {
            format!("  DOUBTED: reports weighed {:.2}", u.report_weight)
        } else {
            String::new()
        };
        println!(
            "  {:10} {:6} {:13} water {:6.0} L  task {task}{why}{doubted}",
            u.unit.as_str(),
            presence,
            mode.unwrap_or("-"),
            u.state.as_ref().map_or(0.0, |st| st.water_l),
        );
    }
    println!("goals:");
    if s.goals.is_empty() {
        println!("  (none)");
    }
    for g in &s.goals {
        println!("  {g}");
    }
    for x in &s.stranded {
        println!("ALERT {x}");
    }
    for x in &s.trapped {
        println!("ALERT {x}");
    }
    if s.rejected.values().any(|n| *n > 0) {
        println!("rejected messages: {:?}", s.rejected);
    }
    println!("recent decisions:");
    for d in &s.decisions {
        println!("  t={:7.1}  {}", d.t, d.text);
    }
}
