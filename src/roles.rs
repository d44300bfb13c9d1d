//! Running one role per process, and how every role is told to stop.

use std::path::Path;
use std::process::ExitCode;
use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use firefleet_agent::ground::GroundController;
use firefleet_agent::monorail::MonorailController;
use firefleet_agent::{AgentOptions, SimPlatform};
use firefleet_coordinator::CoordinatorOptions;
use firefleet_protocol::SiteId;
use firefleet_protocol::bus::Bus;
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{FireTrack, IncidentStatus, UnitKind, ZoneGoal};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::{GROUND, MONORAIL};
use firefleet_sim::SimOptions;
use tokio::io::AsyncReadExt;

use crate::{AgentArgs, CoordinatorArgs, RecordArgs, SimArgs, StatusArgs, ZenohArgs, scenarios};

/// Completes on Ctrl-C, SIGTERM, or (with `--die-with-parent`) when stdin closes.
pub async fn shutdown_signal(die_with_parent: bool) {
    let stdin_closed = async {
        if die_with_parent {
            let mut buf = [0u8; 64];
            let mut stdin = tokio::io::stdin();
            while matches!(stdin.read(&mut buf).await, Ok(n) if n > 0) {}
        } else {
            std::future::pending::<()>().await;
        }
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        _ = tokio::signal::ctrl_c() => {}
        _ = term => {}
        _ = stdin_closed => {}
    }
}

pub async fn open(zenoh: &ZenohArgs, scenario: &Scenario) -> anyhow::Result<Bus> {
    Bus::open(&zenoh.connect(), scenario.site.clone())
        .await
        .context("joining the Zenoh network")
}

pub async fn sim(a: SimArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = open(&a.zenoh, &scenario).await?;
    let opts = SimOptions {
        seed: a.seed.unwrap_or(scenario.seed),
        time_scale: a.time_scale,
        wait_for_fleet: a.wait_for_fleet.map(Duration::from_secs_f64),
        wait_for_coordinator: a.wait_for_coordinator,
        ..SimOptions::default()
    };
    let truth = firefleet_sim::run(
        &bus,
        &scenario,
        &opts,
        shutdown_signal(a.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(
        t = truth.t,
        fires_out = truth.fires_out(),
        fires = truth.fires.len(),
        "simulation stopped"
    );
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

pub async fn coordinator(a: CoordinatorArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = open(&a.zenoh, &scenario).await?;
    let resume = match &a.resume {
        Some(path) => recorded_fires(path, &scenario.site)?,
        None => Vec::new(),
    };
    let opts = CoordinatorOptions {
        lease_s: a.lease_s,
        sim_clock: a.sim_clock,
        strategy: a.assignment,
        resume,
    };
    firefleet_coordinator::run(
        &bus,
        &scenario,
        &opts,
        shutdown_signal(a.zenoh.die_with_parent),
    )
    .await?;
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// The latest fire tracks of `site` recorded in `path`, for `coordinator --resume`.
fn recorded_fires(path: &Path, site: &SiteId) -> anyhow::Result<Vec<FireTrack>> {
    let bytes = std::fs::read(path).with_context(|| format!("--resume {}", path.display()))?;
    let r = firefleet_coordinator::record::fire_tracks_in(&bytes, site)
        .with_context(|| format!("--resume {}", path.display()))?;
    if let Some(why) = &r.cut_short {
        tracing::warn!(file = %path.display(), "the recording ends early ({why}); using what comes before");
    }
    for why in &r.refused {
        tracing::warn!(file = %path.display(), "recorded fire track refused: {why}");
    }
    tracing::info!(file = %path.display(), fires = r.tracks.len(), "fire tracks read from the recording");
    Ok(r.tracks)
}

pub async fn agent(a: AgentArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    if scenario.unit(&a.unit).is_none() {
        anyhow::bail!(
            "--unit {}: the scenario '{}' has no such unit",
            a.unit,
            scenario.name
        );
    }
    let spec = scenario.unit(&a.unit).expect("checked above");
    let bus = open(&a.zenoh, &scenario).await?;
    let opts = AgentOptions {
        unit: a.unit.clone(),
        report_period_s: 0.25,
        print_tree: a.print_tree,
    };
    let shared = Arc::new(scenario.clone());
    let shutdown = shutdown_signal(a.zenoh.die_with_parent);
    match spec.kind {
        UnitKind::Ground => {
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::ground::default_tree(),
            };
            let ctl =
                GroundController::with_tree(a.unit.clone(), GROUND, shared, &doc, 1.0 / a.tick_hz)?;
            let platform = SimPlatform::ground(&bus, &a.unit).await?;
            firefleet_agent::run(&bus, platform, ctl, &opts, shutdown).await?;
        }
        UnitKind::Monorail => {
            let doc = match &a.tree {
                Some(path) => firefleet_bt::xml::load_file(path)?,
                None => firefleet_agent::monorail::default_tree(),
            };
            let ctl = MonorailController::with_tree(a.unit.clone(), MONORAIL, shared, &doc)?
                .context("the unit's rail is not in the scenario")?;
            let platform = SimPlatform::monorail(&bus, &a.unit).await?;
            firefleet_agent::run(&bus, platform, ctl, &opts, shutdown).await?;
        }
    }
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

pub async fn record(a: RecordArgs) -> anyhow::Result<ExitCode> {
    let scenario = scenarios::resolve(&a.scenario.scenario)?;
    let bus = open(&a.zenoh, &scenario).await?;
    let summary = firefleet_coordinator::record::record(
        &bus,
        &scenario,
        &a.out,
        shutdown_signal(a.zenoh.die_with_parent),
    )
    .await?;
    tracing::info!(messages = summary.messages, channels = summary.channels, skipped = summary.skipped, out = %a.out.display(), "recording finished");
    bus.close().await;
    Ok(ExitCode::SUCCESS)
}

/// The coordinator's snapshot of the incident, decoded and as sent.
pub async fn query_status(bus: &Bus) -> anyhow::Result<(IncidentStatus, Vec<u8>)> {
    let key = bus.keys().expr(&Topic::CoordStatus);
    let replies = bus
        .session()
        .get(&key)
        .timeout(Duration::from_secs(3))
        .await
        .map_err(|e| anyhow::anyhow!("querying {key}: {e}"))?;
    let reply = replies
        .recv_async()
        .await
        .map_err(|_| anyhow::anyhow!("no coordinator answered on {key}"))?;
    let sample = reply
        .result()
        .map_err(|e| anyhow::anyhow!("the coordinator answered with an error: {e:?}"))?;
    let bytes = sample.payload().to_bytes().to_vec();
    let status = codec::decode(&bytes).context("the coordinator's status")?;
    Ok((status, bytes))
}

pub async fn status(a: StatusArgs) -> anyhow::Result<ExitCode> {
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
        println!(
            "  {:10} {:6} {:13} water {:6.0} L  task {task}",
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
