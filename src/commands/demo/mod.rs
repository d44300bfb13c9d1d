//! `firefleet demo`: a whole fleet on loopback, each role its own process.
//!
//! The demo process is the Zenoh router (a free loopback port); the simulator, the
//! coordinator, one agent per unit and (with `--record`) a recorder are its children,
//! started from the same binary in client mode. Children are told to stop by closing their
//! standard input (`--die-with-parent`), which also ends them if the demo itself dies, so
//! none outlives it. The demo follows the simulator's ground truth, prints progress, and
//! exits 0 exactly when every fire is out before the scenario's time limit.
//!
//! With `--secure` the fleet runs as a site is deployed: a site PKI (`--pki DIR`, or one
//! made for the run), the access rules rendered for it, the router taking mutual TLS
//! only and enforcing the rules, every child on its identity's client configuration, and
//! the demo's goals put by a `commander:demo` client of its own.
//!
//! Not here: any role's logic; it starts the processes, watches the truth and reports.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::Identity;
use firefleet_bus::pki;
use firefleet_bus::render::{Layout, render_site};
use firefleet_bus::{Bus, Connect, Mode, free_loopback_port};
use firefleet_coordinator::goals::Goals;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use firefleet_model::{CommanderId, ZoneId};
use firefleet_protocol::msg::{
    GoalAck, GoalForm, GoalKind, SimTruth, TruthFireState, UnitState, ZoneGoal,
};
use serde::Serialize;
use tokio::process::Child;

use super::{PlatformKind, non_negative_f64, time_scale, write_json};
use firefleet::args::Sensing;
use firefleet::children::{RoleCommand, exited, stop_children};
use firefleet::net::shutdown_signal;

mod goals;
mod processes;
mod report;
mod roles;
mod site;

use goals::{demo_commander, parse_goal};
use processes::{COORDINATOR, Processes};
use report::{Outcome, ProcessInfo, Summary, UnitSummary, WallBudget, print_progress, verdict};
use roles::roles;
use site::SecureSite;

#[derive(Args, Debug)]
pub struct DemoArgs {
    /// A built-in scenario name (see `firefleet scenarios`) or a scenario file.
    #[arg(long, default_value = "vehicle-collision")]
    scenario: String,
    /// Seed of the simulator (default: the scenario's).
    #[arg(long)]
    seed: Option<u64>,
    /// Simulated seconds per wall-clock second.
    #[arg(long, default_value_t = 4.0, value_parser = time_scale, allow_negative_numbers = true)]
    time_scale: f64,
    /// The loopback port the demo's router listens on, for `firefleet status`, `goal` and
    /// other clients to `--connect` to (default: a free one, printed at the start).
    #[arg(long)]
    port: Option<u16>,
    /// Record all fleet traffic to this MCAP file.
    #[arg(long, value_name = "FILE.mcap")]
    record: Option<PathBuf>,
    /// Write a JSON summary of the run to this file.
    #[arg(long, value_name = "FILE")]
    summary_json: Option<PathBuf>,
    /// Issue a commander's zone goal once the fleet is up, `ZONE:GOAL[:PRIORITY]` (e.g.
    /// `deep:keep-out`, `portal:extinguish:2`, `portal:contain@40` to hold the fire
    /// front before chainage 40 m, or `deep:keep-out+rail` to let monorail carriages
    /// through); repeatable.
    #[arg(long, value_name = "ZONE:GOAL[@CHAINAGE][:PRIORITY]")]
    goal: Vec<String>,
    /// Issue the goals this many seconds of site time into the incident instead of at its
    /// start (mid-incident, with units already at work).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = non_negative_f64, allow_negative_numbers = true)]
    goals_at: f64,
    /// Run the fleet over mutual TLS through a router enforcing the site's access rules.
    #[arg(long)]
    secure: bool,
    /// With --secure: the site PKI to use (`firefleet pki init --commander demo`; default:
    /// one made for this run).
    #[arg(long, value_name = "DIR", requires = "secure")]
    pki: Option<PathBuf>,
    /// Run a standby coordinator beside the one in charge (`coordinator --standby`).
    #[arg(long)]
    standby: bool,
    /// Serve the incident commander's console here too (`firefleet console --http ADDR`),
    /// e.g. 127.0.0.1:8080.
    #[arg(long, value_name = "ADDR:PORT")]
    console: Option<std::net::SocketAddr>,
    /// Serve the recording live over the Foxglove WebSocket protocol here (the recorder's
    /// `--foxglove`; with or without --record): open `ws://ADDR` in Foxglove.
    #[arg(long, value_name = "ADDR:PORT")]
    foxglove: Option<std::net::SocketAddr>,
    /// With --console: the commanders who may log in (`firefleet console add-user`).
    #[arg(long, value_name = "FILE", requires = "console")]
    console_users: Option<PathBuf>,
    /// Keep the fleet up this many seconds after the incident ends (to look at it on the
    /// console, or steer the units still patrolling).
    #[arg(long, value_name = "SECONDS", default_value_t = 0.0, value_parser = non_negative_f64, allow_negative_numbers = true)]
    linger: f64,
    /// The bodies the agents drive: the simulator's units over the site's `sim/` keys, or
    /// ROS 2 robots, ground units and carriages alike (the simulator serving each on
    /// rmw_zenoh topics in its unit's namespace, each agent on `--platform ros2`). Not with --secure: the site's access
    /// rules cover the fleet's keys; a robot's ROS 2 topics stay on the robot's own router.
    #[arg(long, value_enum, default_value_t = PlatformKind::Sim, conflicts_with = "secure")]
    platform: PlatformKind,
    /// What ground units find flames in (the simulator's `--perception`): their thermal
    /// cores' frames, or boxes drawn from the truth.
    #[arg(long, value_enum, default_value_t = Sensing::Pixels)]
    perception: Sensing,
    /// Run the tunnel's SCADA too: the simulator serves its DTS zones and ventilation over
    /// Modbus TCP on a free loopback port, and `firefleet scada` bridges them to the bus
    /// for the coordinator (the scenario's file must map `[scada]`).
    #[arg(long)]
    scada: bool,
    /// With --scada: stop the simulator's Modbus server at this site time, as a cut link
    /// to the tunnel's SCADA (the bridge marks its readings stale; nothing else changes).
    #[arg(long, value_name = "SECONDS", requires = "scada", value_parser = non_negative_f64, allow_negative_numbers = true)]
    cut_scada_at: Option<f64>,
    /// Kill the coordinator in charge at this site time: the standby takes over.
    #[arg(long, value_name = "SECONDS", requires = "standby", value_parser = non_negative_f64, allow_negative_numbers = true)]
    kill_coordinator_at: Option<f64>,
    /// Kill the coordinator at this site time and start a new one at once, which remembers
    /// nothing but what a recorder kept (with --record) and what the units say.
    #[arg(long, value_name = "SECONDS", conflicts_with = "standby", value_parser = non_negative_f64, allow_negative_numbers = true)]
    restart_coordinator_at: Option<f64>,
    /// Serve each unit's behavior tree to Groot2 on loopback: the first unit of the
    /// scenario on PORT, the next on PORT + 1, and so on (the agent's `--groot2`).
    #[arg(long, value_name = "PORT")]
    groot2: Option<u16>,
    /// Record each unit's behavior tree in DIR/UNIT.btlog (the agent's `--btlog`), which
    /// Groot2 replays.
    #[arg(long, value_name = "DIR")]
    btlog_dir: Option<PathBuf>,
}

pub async fn run(a: DemoArgs) -> anyhow::Result<ExitCode> {
    let scenario = builtin::resolve(&a.scenario)?;
    let goals = a
        .goal
        .iter()
        .map(|g| parse_goal(g, &scenario))
        .collect::<anyhow::Result<Vec<_>>>()?;
    let seed = a.seed.unwrap_or(scenario.seed);
    let port = match a.port {
        Some(port) => port,
        None => free_loopback_port().context("finding a free loopback port")?,
    };
    let commander = demo_commander();
    let site = a
        .secure
        .then(|| SecureSite::make(&scenario, a.pki.clone(), port, &commander, a.time_scale))
        .transpose()?;
    let endpoint = match &site {
        Some(_) => format!("quic/127.0.0.1:{port}"),
        None => format!("tcp/127.0.0.1:{port}"),
    };
    let router = match &site {
        Some(s) => Connect {
            config_file: Some(s.configs.join("router.json5")),
            ..Connect::default()
        },
        None => Connect {
            mode: Some(Mode::Router),
            listen: vec![endpoint.clone()],
            ..Connect::default()
        },
    };
    let bus = Bus::open(&router, scenario.site.clone())
        .await
        .context("starting the demo's Zenoh router")?;
    let keys = bus.keys().clone();
    // Goals come from a commander: on a secure site, a client holding its certificate.
    let commander_bus = match &site {
        Some(s) => Some(
            Bus::open(
                &s.client(&Identity::Commander(commander.clone())),
                scenario.site.clone(),
            )
            .await
            .context("joining as commander:demo")?,
        ),
        None => None,
    };
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await?;
    let states = bus.subscribe::<UnitState>(&keys.every_unit_state()).await?;
    let acks = bus.subscribe::<GoalAck>(&keys.every_zone_ack()).await?;
    let mut goals_to_issue = Some(goals.clone());
    // The goals the coordinator accepted, as it holds them: fires where one bars attack may
    // be left burning.
    let mut in_force = Goals::new(&scenario.zones, &scenario.commanders);
    let mut site_t = 0.0;

    let mut processes = Processes::launch(
        roles(&a, &scenario, seed, site.as_ref())?,
        &a.scenario,
        site.as_ref(),
        &endpoint,
    )?;
    println!(
        "firefleet demo: scenario '{}' (seed {seed}), {} fires, {} units, {} processes on {endpoint}, time x{}",
        scenario.name,
        scenario.fires.len(),
        scenario.units.len(),
        processes.len(),
        a.time_scale
    );
    if site.is_none() {
        println!(
            "follow it from another terminal: firefleet status --scenario {} --mode client --connect {endpoint}",
            a.scenario
        );
    }

    let started = Instant::now();
    let budget = WallBudget::new(scenario.time_limit_s, a.time_scale);
    let mut site_clock_moved = started;
    let mut last_truth: Option<SimTruth> = None;
    let mut modes: BTreeMap<String, String> = BTreeMap::new();
    let mut next_print = 0.0;
    let mut last_out = 0;
    let mut watchdog = tokio::time::interval(Duration::from_millis(250));
    let shutdown = shutdown_signal(false);
    tokio::pin!(shutdown);
    let mut kill_at = a.kill_coordinator_at;
    let mut restart_at = a.restart_coordinator_at;
    let outcome = loop {
        tokio::select! {
            _ = &mut shutdown => break Outcome::Interrupted,
            Some((_, st)) = states.recv() => {
                modes.insert(st.unit.to_string(), st.mode.as_str().to_owned());
            }
            Some((_, ack)) = acks.recv() => {
                if ack.accepted && let Some(g) = goals.iter().find(|g| g.id == ack.id && g.zone == ack.zone) {
                    in_force.submit(&g.zone, &commander, g.clone(), site_t);
                }
                let verdict = if ack.accepted { "" } else { "rejected: " };
                println!("goal '{}' on zone {}: {verdict}{}", ack.id, ack.zone, ack.reason);
            }
            Some((_, truth)) = truths.recv() => {
                if truth.t > site_t {
                    site_clock_moved = Instant::now();
                }
                site_t = truth.t;
                // The simulator starts once the coordinator is up: time to issue the goals.
                if kill_at.take_if(|at| truth.t >= *at).is_some() && processes.kill(COORDINATOR).await? {
                    println!("t={:.1} s: killed the coordinator in charge; the standby takes over", truth.t);
                }
                if restart_at.take_if(|at| truth.t >= *at).is_some() && processes.restart(COORDINATOR).await? {
                    println!("t={:.1} s: killed the coordinator and started a new one", truth.t);
                }
                let due = goals_to_issue.take_if(|_| truth.t >= a.goals_at);
                for g in due.unwrap_or_default() {
                    println!("t={:.1} s: issuing goal '{}': {:?} on zone {} (priority {})", truth.t, g.id, g.goal, g.zone, g.priority);
                    firefleet_bus::goal::put(commander_bus.as_ref().unwrap_or(&bus), &g, &commander).await?;
                }
                let out = truth.fires_out();
                if truth.t >= next_print || out != last_out {
                    next_print = truth.t + 10.0;
                    last_out = out;
                    print_progress(&truth, &modes);
                }
                let done = if truth.all_out() { Some(Outcome::AllOut) } else if truth.t >= truth.time_limit_s { Some(Outcome::TimeLimit) } else { None };
                last_truth = Some(truth);
                if let Some(o) = done { break o; }
            }
            _ = watchdog.tick() => {
                if let Some(why) = budget.spent(started.elapsed(), site_clock_moved.elapsed(), site_t) {
                    break Outcome::WallTimeout(why);
                }
                if let Some(role) = processes.exited() {
                    break Outcome::ChildDied(role);
                }
            }
        }
    };
    let wall = started.elapsed().as_secs_f64();
    if a.linger > 0.0 && matches!(outcome, Outcome::AllOut | Outcome::TimeLimit) {
        println!(
            "the fleet stays up {:.0} s more (--linger); Ctrl-C ends it",
            a.linger
        );
        // This process is the router: its inboxes must keep draining, or a full one stalls
        // every session routed through it.
        let until = tokio::time::sleep(Duration::from_secs_f64(a.linger));
        tokio::pin!(until);
        loop {
            tokio::select! {
                _ = &mut until => break,
                _ = &mut shutdown => break,
                Some(_) = states.recv() => {}
                Some(_) = truths.recv() => {}
                Some(_) = acks.recv() => {}
            }
        }
    }
    let processes = processes.stop().await;
    // The commander's client first: closed after its router, it would wait out Zenoh's
    // ten-second close for a link whose other end is gone.
    if let Some(c) = commander_bus {
        c.close().await;
    }
    bus.close().await;

    let truth = last_truth.unwrap_or(SimTruth {
        t: 0.0,
        time_limit_s: scenario.time_limit_s,
        fires: Vec::new(),
        units: Vec::new(),
    });
    let (success, outcome_text) = verdict(&outcome, &truth, &mut in_force, &scenario);
    println!("{outcome_text} (wall {wall:.1} s)");
    for u in &truth.units {
        println!(
            "  {:8} heat dose {:7.1} kJ/m2  water {:6.1} L  collisions {}",
            u.id, u.heat_dose_kj_m2, u.water_used_l, u.collisions
        );
    }
    let summary = Summary {
        scenario: scenario.name.clone(),
        seed,
        success,
        outcome: outcome_text,
        fires_total: scenario.fires.len(),
        fires_out: truth.fires_out(),
        sim_time_s: truth.t,
        wall_time_s: wall,
        time_scale: a.time_scale,
        processes,
        units: truth
            .units
            .iter()
            .map(|u| UnitSummary {
                id: u.id.to_string(),
                heat_dose_kj_m2: u.heat_dose_kj_m2,
                water_used_l: u.water_used_l,
                collisions: u.collisions,
            })
            .collect(),
        recording: a.record.clone(),
        router: endpoint,
        pki: site.as_ref().map(|s| s.pki.clone()),
        configs: site.as_ref().map(|s| s.configs.clone()),
    };
    write_json(a.summary_json.as_deref(), &summary)?;
    Ok(match outcome {
        _ if success => ExitCode::SUCCESS,
        Outcome::Interrupted => ExitCode::from(130),
        _ => ExitCode::FAILURE,
    })
}
