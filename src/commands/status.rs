//! `firefleet status`: the incident as the coordinator sees it, for people or as JSON;
//! with `--watch`, the site's live picture for an operator's terminal.
//!
//! Beside the coordinator's snapshot, what no one process knows: whether a coordinator is
//! in office and which standbys could take over (their liveliness tokens), and, watching,
//! the SCADA link as its bridge last told it.
//!
//! Not here: the snapshot itself (the coordinator answers `coord/status`).

use std::io::IsTerminal as _;
use std::process::ExitCode;
use std::time::Duration;

use clap::Args;
use firefleet_bus::Bus;
use firefleet_bus::access::Identity;
use firefleet_protocol::codec::PROTOCOL_VERSION;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{IncidentStatus, ScadaLink};
use firefleet_protocol::office::Leases;

use super::{ScenarioArg, positive_f64};
use firefleet::net::{ZenohArgs, open, query_status};

#[derive(Args, Debug)]
pub struct StatusArgs {
    #[command(flatten)]
    scenario: ScenarioArg,
    #[command(flatten)]
    zenoh: ZenohArgs,
    /// Print the raw JSON snapshot (watching: one line a round).
    #[arg(long)]
    json: bool,
    /// Ask again every SECONDS (default 2) and show the picture afresh, until interrupted;
    /// a round with no coordinator answering says so and the watch goes on.
    #[arg(long, value_name = "SECONDS", num_args = 0..=1, default_missing_value = "2", value_parser = positive_f64)]
    watch: Option<f64>,
}

pub async fn run(a: StatusArgs) -> anyhow::Result<ExitCode> {
    let scenario = a.scenario.load()?;
    let bus = open(&a.zenoh, &scenario).await?;
    let Some(every) = a.watch else {
        let (status, bytes) = query_status(&bus).await?;
        if a.json {
            println!("{}", String::from_utf8_lossy(&bytes));
        } else {
            print_status(&status);
            print_office(&bus).await;
        }
        bus.close().await;
        return Ok(ExitCode::SUCCESS);
    };
    let links = bus.subscribe::<ScadaLink>(&bus.keys().infra_link()).await?;
    let mut link: Option<ScadaLink> = None;
    let clear = std::io::stdout().is_terminal() && !a.json;
    let mut tick = tokio::time::interval(Duration::from_secs_f64(every));
    loop {
        tokio::select! {
            _ = tick.tick() => {}
            _ = tokio::signal::ctrl_c() => break,
        }
        while let Some((_, l)) = links.try_recv() {
            link = Some(l);
        }
        watch_round(&bus, &scenario, a.json, clear, link.as_ref()).await;
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// One round of `--watch`: the snapshot (or that nobody answered), who is in office, and
/// the SCADA link.
async fn watch_round(
    bus: &Bus,
    scenario: &firefleet_model::scenario::Scenario,
    json: bool,
    clear: bool,
    link: Option<&ScadaLink>,
) {
    let status = query_status(bus).await;
    if json {
        match status {
            Ok((_, bytes)) => println!("{}", String::from_utf8_lossy(&bytes)),
            Err(e) => println!("{}", serde_json::json!({ "error": format!("{e:#}") })),
        }
        return;
    }
    if clear {
        print!("\x1b[2J\x1b[H");
    }
    println!(
        "firefleet status --watch: site '{}', {}",
        scenario.site,
        humantime_now()
    );
    match status {
        Ok((s, _)) => print_status(&s),
        Err(e) => println!("NO COORDINATOR ANSWERS: {e:#}"),
    }
    print_office(bus).await;
    match (link, &scenario.scada) {
        (_, None) => {}
        (None, Some(_)) => println!("SCADA link: nothing heard from its bridge"),
        (Some(l), Some(_)) if l.up => println!(
            "SCADA link: up at t = {:.1} s ({} polls, {} failed)",
            l.t,
            l.polls,
            l.timeouts + l.disconnects + l.exceptions
        ),
        (Some(l), Some(_)) => println!(
            "SCADA link: DOWN at t = {:.1} s, last good poll {}: {}",
            l.t,
            l.last_ok
                .map_or("never".to_owned(), |t| format!("t = {t:.1} s")),
            l.problem
        ),
    }
}

/// The wall-clock time of a round, UTC, to the second.
fn humantime_now() -> String {
    let now = time::OffsetDateTime::now_utc();
    format!(
        "{:04}-{:02}-{:02} {:02}:{:02}:{:02} UTC",
        now.year(),
        u8::from(now.month()),
        now.day(),
        now.hour(),
        now.minute(),
        now.second()
    )
}

/// Who holds office (and who else claims it) and which standbys could take over, from
/// their liveliness tokens: a site whose standby is gone has no spare, and says so.
async fn print_office(bus: &Bus) {
    let keys = bus.keys();
    let mut leases = Leases::default();
    for t in bus
        .tokens_alive(&keys.every_coord_alive())
        .await
        .unwrap_or_default()
    {
        if let Topic::CoordAlive(rank) = t {
            leases.set(rank, true);
        }
    }
    let mut standbys: Vec<u32> = bus
        .tokens_alive(&keys.every_standby_alive())
        .await
        .unwrap_or_default()
        .into_iter()
        .filter_map(|t| match t {
            Topic::CoordStandbyAlive(rank) => Some(rank),
            _ => None,
        })
        .collect();
    standbys.sort_unstable();
    let standing_by = match standbys.as_slice() {
        [] => "NO STANDBY: nobody could take over".to_owned(),
        ranks => format!(
            "standing by: {}",
            ranks
                .iter()
                .map(|r| format!("rank {r}"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    };
    let holder = leases.holder().map_or_else(
        || "NO COORDINATOR IN OFFICE".to_owned(),
        |h| format!("{} in office", Identity::Coordinator(h)),
    );
    let rivals: Vec<String> = leases
        .rivals()
        .map(|r| {
            format!(
                "; RIVAL: {} claims office too (units refuse its tasks)",
                Identity::Coordinator(r)
            )
        })
        .collect();
    println!("office: {holder}{}; {standing_by}", rivals.concat());
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
    for who in &s.suspended {
        println!("SUSPENDED {who}: nothing of it is taken (revoke it: firefleet pki revoke)");
    }
    if s.rejected.values().any(|n| *n > 0) {
        println!("rejected messages: {:?}", s.rejected);
    }
    println!("recent decisions:");
    for d in &s.decisions {
        println!("  t={:7.1}  {}", d.t, d.text);
    }
}
