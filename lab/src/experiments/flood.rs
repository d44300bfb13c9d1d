//! `firefleet-lab flood`: a secure site under attack from one stolen certificate,
//! measured from outside.
//!
//! A `firefleet demo --secure` runs in a child process on a PKI made here, its site file
//! naming commander `chief` the incident commander and `rossi` a sector commander. Each
//! `--attack` is its own run, of the same seed:
//! - floods from a thief holding `unit:ugv-2`'s certificate, on ugv-2's own keys (what the
//!   access rules allow it), for the whole incident: valid states as fast as it can, random
//!   bytes, fake flame reports (64 random observations each, 94 a second), or 1 MB
//!   behaviour-tree messages;
//! - lies from the same thief at a unit's pace: three fake fires held in place, three fake
//!   fires moved every 12 s, "extinguished" on every fire ugv-2 is sent to, and reports of
//!   the site's real fires replayed 30 s late;
//! - fakes seen from where ugv-2 really is, 64 within 20 m of it in its camera's view in
//!   each report, 94 reports a second (the thief follows the unit and its camera through
//!   its simulated sensors);
//! - a stolen sector commander's certificate (`rossi`) putting keep-out at priority 255
//!   on every zone and 70 goals more, and the incident commander (`chief`) clearing them
//!   as soon as the stranded-fire alert shows in the status (its delay is printed);
//! - a stolen coordinator certificate, the standby's or the one in office's, telling every
//!   unit to stand by, and both commanders suspending it 5 s after the alarm;
//! - a stolen recorder certificate answering the standby's recall when the coordinator in
//!   office is killed (every fire out, fires that never were, keep-outs nobody sealed);
//! - a stolen SCADA bridge certificate raising the DTS alarm where no fire burns and
//!   calling the burning zones normal.
//!
//! The demo runs a standby coordinator (rank 1) in every run, as a site does.
//!
//! Optionally HTTPS clients hammer the console. A commander's session asks for the status
//! every 100 ms. Measured: whether every process lived and every fire went out and when,
//! the status probe's latency, how fast the logs (the demo's standard error) and the
//! recording grew, how many messages the thief got out, and the link drops Zenoh logged.
//! With `none` among the attacks, a table sets each run's all-out time beside it.
//!
//! Not here: the rules and bounds that hold against the attacks (`firefleet_bus::access`,
//! `limits`, the coordinator's trust in reports and goals), or attacks across identities
//! (`tests/it/secure.rs`).

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{ExitCode, Stdio};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::{Args, ValueEnum};
use firefleet_bus::access::Identity;
use firefleet_bus::pki::{self, Terms};
use firefleet_bus::{Ask, Bus, Connect, Mode, goal};
use firefleet_model::scenario::{CommanderSpec, Rank};
use firefleet_model::{CommanderId, FireId, Point2, Pose2, UnitId, UnitKind, ZoneId, builtin};
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{
    FireState, FireTrack, FlameObservation, FlameReport, GoalInForce, GoalKind, GoalsInForce,
    IncidentStatus, MAX_LIST, TaskPhase, TaskProgress, UnitState, ZoneGoal,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use firefleet::args::{Sensing, time_scale, write_json};
use firefleet::children::RoleCommand;

mod attacks;
use attacks::{
    Answer, Lie, Readings, Recall, answer_as_recorder, bar_every_zone, command_as_coordinator,
    flood_as_unit, report_as_scada,
};

/// What the thief sends on ugv-2's keys.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Attack {
    /// Nothing: the control run.
    None,
    /// Valid states of ugv-2, as fast as the link takes them.
    States,
    /// Random bytes on ugv-2's state key, as fast as the link takes them.
    Garbage,
    /// Fake flame reports, 64 random observations each, 94 a second.
    Reports,
    /// 1 MB messages on ugv-2's behaviour-tree key, as fast as the link takes them.
    BigBt,
    /// Three fake fires reported at confidence 0.95, each where it was, at a unit's pace.
    FakeFires,
    /// Three fake fires reported at confidence 0.95, moved every 12 s.
    MovingFakes,
    /// Fake flame reports seen from where ugv-2 really is and the way its camera looks (its
    /// simulated sensors tell the thief), 64 observations each within 20 m of it in that
    /// camera's field of view, 94 a second: they pass the observer, range and camera-cone
    /// checks, and move with the unit.
    AroundFakes,
    /// "Extinguished" on every fire ugv-2 is sent to, three times a task.
    FalseOut,
    /// Reports of the site's real fires as ugv-2 saw them 30 s before, replayed.
    Replay,
    /// States of ugv-2 (idle, where it is not) dated 4.5 s ahead of the site clock, inside
    /// the window, at a unit's pace: once, they made every real state "older than the
    /// sender's last" for as long as they came.
    AheadStates,
    /// A stolen sector commander's keep-out on every zone, and 70 goals more.
    Commander,
    /// A stolen incident commander's keep-out on every zone, and 70 goals more: nobody on
    /// the bus outranks it, so the sector commander and the operator at the coordinator's
    /// host suspend it 5 s of site time after the alert.
    Chief,
    /// The console's stolen key puts the incident commander's keep-out on every zone, and
    /// 70 goals more, sealed as the console seals for the commanders it logs in: the
    /// console hears its own key used elsewhere (its impostor alarm), and both commanders
    /// suspend it 5 s of site time after the stranded-fire alert. The demo runs a console.
    ConsoleKey,
    /// The standby coordinator's stolen key (`coordinator:1`) claims office (its lease)
    /// and tells every unit to stand by, numbered above what each holds, four times a
    /// second; both commanders suspend it 5 s of site time after the alarm.
    StandbyKey,
    /// The stolen key of the coordinator in office (`coordinator`) tells every unit to stand
    /// by, in its own term numbered above what each holds, four times a second: the units
    /// take it (it is the holder's key) until both commanders suspend the identity 5 s of
    /// site time after the alarm, and the standby takes office.
    CoordinatorKey,
    /// The recorder's stolen key answers every recall: each fire the coordinator published,
    /// called out as of the site clock; three fires that never were, "seen by" an honest
    /// unit; the incident commander's keep-out on every zone, unsealed. Needs
    /// `--kill-coordinator-at`: the standby that takes office asks.
    RecorderKey,
    /// The SCADA bridge's stolen key: a fire alarm in every DTS zone no fire burns in, and
    /// "all normal" in every zone one does, at the bridge's pace, dated by the site clock.
    /// Needs `--scada`.
    ScadaKey,
}

impl Attack {
    /// Whether the thief holds a unit's certificate (else a commander's or a
    /// coordinator's).
    fn by_unit(self) -> bool {
        !matches!(
            self,
            Attack::Commander
                | Attack::Chief
                | Attack::ConsoleKey
                | Attack::StandbyKey
                | Attack::CoordinatorKey
                | Attack::RecorderKey
                | Attack::ScadaKey
        )
    }

    /// The rank of the coordinator whose key the thief holds, if it holds one.
    fn coordinator_rank(self) -> Option<u32> {
        match self {
            Attack::StandbyKey => Some(1),
            Attack::CoordinatorKey => Some(0),
            _ => None,
        }
    }

    /// Whether the honest side answers by suspending the stolen identity (so its time to
    /// the alarm and the people's seconds are allowed on top of the unattacked run).
    fn suspended(self) -> bool {
        matches!(
            self,
            Attack::Chief | Attack::ConsoleKey | Attack::StandbyKey | Attack::CoordinatorKey
        )
    }
}

#[derive(Args, Debug)]
pub struct FloodArgs {
    /// The site (a built-in scenario or a file); it must have a unit ugv-2.
    #[arg(long, default_value = "pileup")]
    scenario: String,
    #[arg(long, default_value_t = 4.0, value_parser = time_scale, allow_negative_numbers = true)]
    time_scale: f64,
    /// The attacks, one run each (comma-separated); with `none` among them, a table sets
    /// each run's all-out time beside the unattacked one's.
    #[arg(long, value_enum, value_delimiter = ',', default_value = "states")]
    attack: Vec<Attack>,
    /// HTTPS clients asking the console for the incident without pause, each request
    /// bounded to 2 s (curl; 0: no console).
    #[arg(long, default_value_t = 0)]
    https_clients: usize,
    /// The run's seed: the site's and the thief's.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Keep each run's site file, recording and log in DIR/<attack>/ (for `firefleet
    /// check`); by default they go with a temporary directory.
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Fail unless every attacked run put every fire out within this many times the
    /// unattacked run's all-out time (needs `none` among the attacks).
    #[arg(long, value_name = "X")]
    max_slowdown: Option<f64>,
    /// Kill the coordinator in office at this site time in every run, the unattacked one
    /// too: the standby takes office and recalls what recorders answer (what
    /// `recorder-key` lies to, which needs it).
    #[arg(long, value_name = "SECONDS")]
    kill_coordinator_at: Option<f64>,
    /// Run the tunnel's SCADA in every run (`demo --scada`: the DTS and the ventilation
    /// over Modbus, bridged to the bus), which `scada-key` lies in the name of.
    #[arg(long)]
    scada: bool,
    /// What ground units find flames in (`demo --perception`): the attacks are on what
    /// the coordinator believes, which checks every report alike whatever the unit saw
    /// its flames in.
    #[arg(long, value_enum, default_value_t = Sensing::Pixels)]
    perception: Sensing,
}

/// One run's figures.
#[derive(Debug, Serialize)]
struct Figures {
    attack: Attack,
    https_clients: usize,
    /// The demo's exit status, and whether a process of it died of a signal.
    demo_status: Option<i32>,
    /// The demo's own word on how the run ended.
    outcome: String,
    aborted: bool,
    fires_out: u64,
    fires_total: u64,
    /// Site time when the last fire went out, s (none if not every fire did).
    all_out_s: Option<f64>,
    /// From the stolen commander's keep-outs being accepted to the stranded-fire alert in
    /// the status, or from a stolen coordinator key's first claim to the coordinator's
    /// finding in its log (what consoles raise their alarm from), site s.
    alert_delay_s: Option<f64>,
    wall_s: f64,
    sent: u64,
    sent_per_s: f64,
    probe_p50_ms: f64,
    probe_p99_ms: f64,
    probe_max_ms: f64,
    probes: usize,
    probes_unanswered: usize,
    log_bytes_per_min: f64,
    recording_bytes_per_s: f64,
    link_drops: usize,
}

pub async fn run(a: FloodArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(
        a.kill_coordinator_at.is_some() || !a.attack.contains(&Attack::RecorderKey),
        "--attack recorder-key lies to a recall: it needs --kill-coordinator-at, for the standby to recall"
    );
    anyhow::ensure!(
        a.scada || !a.attack.contains(&Attack::ScadaKey),
        "--attack scada-key lies in the SCADA bridge's name: it needs --scada"
    );
    let mut all = Vec::new();
    for &attack in &a.attack {
        all.push(run_one(&a, attack).await?);
    }
    if let Some(control) = all.iter().find(|f| f.attack == Attack::None) {
        println!();
        println!("attack          all out (site s)   x unattacked   alert (site s)");
        for f in &all {
            let cell = |v: Option<f64>| v.map_or("-".to_owned(), |v| format!("{v:.1}"));
            let ratio = f.all_out_s.zip(control.all_out_s).map(|(x, c)| x / c);
            println!(
                "{:15} {:>16}   {:>12}   {:>14}",
                format!("{:?}", f.attack),
                cell(f.all_out_s),
                ratio.map_or("-".to_owned(), |r| format!("{r:.2}")),
                cell(f.alert_delay_s),
            );
        }
    }
    write_json(a.json.as_deref(), &all)?;
    let mut ok = all
        .iter()
        .all(|f| !f.aborted && f.demo_status == Some(0) && f.fires_out == f.fires_total);
    if let Some(max) = a.max_slowdown {
        let control = all
            .iter()
            .find(|f| f.attack == Attack::None)
            .and_then(|f| f.all_out_s)
            .context("--max-slowdown needs an unattacked run (--attack none,...) that put every fire out")?;
        for f in &all {
            // A suspension is a person's answer: the time to the alert and the seconds
            // people take to act are allowed on top.
            let answer_s = if f.attack.suspended() {
                f.alert_delay_s.unwrap_or(0.0) + SUSPEND_AFTER_S
            } else {
                0.0
            };
            let slow = f
                .all_out_s
                .map_or(f64::INFINITY, |t| (t - answer_s) / control);
            if slow > max {
                println!(
                    "FAILED: {:?} put every fire out {slow:.2} times as late as the unattacked run (at most {max}, less {answer_s:.1} s of the people's answer)",
                    f.attack
                );
                ok = false;
            }
        }
    }
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The incident commander and the sector commander whose certificate is stolen.
const CHIEF: &str = "chief";
/// How long after the alert the honest side suspends a stolen incident commander's key,
/// site s: the five seconds for people to see the alarm and act.
const SUSPEND_AFTER_S: f64 = 5.0;
const SECTOR: &str = "rossi";

/// One run under `attack`.
async fn run_one(a: &FloodArgs, attack: Attack) -> anyhow::Result<Figures> {
    let mut scenario = builtin::resolve(&a.scenario)?;
    let ugv2 = UnitId::new("ugv-2")?;
    anyhow::ensure!(
        scenario.unit(&ugv2).is_some(),
        "--scenario {}: no unit ugv-2 to steal",
        a.scenario
    );
    let (chief, sector) = (CommanderId::new(CHIEF)?, CommanderId::new(SECTOR)?);
    for (id, rank) in [(&chief, Rank::Incident), (&sector, Rank::Sector)] {
        scenario.commanders.retain(|c| &c.id != id);
        scenario.commanders.push(CommanderSpec {
            id: id.clone(),
            rank,
        });
    }
    let tmp = tempfile::tempdir()?;
    let dir = match &a.out {
        Some(out) => {
            let d = out.join(
                attack
                    .to_possible_value()
                    .map_or("run".into(), |v| v.get_name().to_owned()),
            );
            std::fs::create_dir_all(&d)?;
            // A run of its own: no PKI or recording of an earlier one.
            for old in ["pki", "run.mcap", "run.mcap.parts"] {
                let p = d.join(old);
                let _ = std::fs::remove_dir_all(&p).or_else(|_| std::fs::remove_file(&p));
            }
            d
        }
        None => tmp.path().to_owned(),
    };
    // The site file every process of the run reads: the scenario with its commanders.
    let site_file = dir.join("site.toml");
    std::fs::write(&site_file, scenario.to_toml())?;
    let pki_dir = dir.join("pki");
    let commander = CommanderId::new("demo")?;
    pki::make_site(
        &scenario,
        &[commander.clone(), chief.clone(), sector.clone()],
        &Terms::default(),
        &pki_dir,
    )?;
    let (recording, summary, log) = (
        dir.join("run.mcap"),
        dir.join("summary.json"),
        dir.join("stderr.log"),
    );
    let console = (a.https_clients > 0 || attack == Attack::ConsoleKey)
        .then(|| firefleet_bus::free_loopback_port().map(|p| format!("127.0.0.1:{p}")))
        .transpose()?;
    // A site runs a standby coordinator: it is what takes office from a suspended one.
    let mut role = RoleCommand::new("demo")
        .arg("--secure")
        .arg("--standby")
        .args(["--seed".into(), a.seed.to_string()])
        .args(["--time-scale".into(), a.time_scale.to_string()])
        .arg("--pki")
        .arg(&pki_dir)
        .arg("--record")
        .arg(&recording)
        .arg("--summary-json")
        .arg(&summary)
        .scenario(&site_file);
    if let Some(c) = &console {
        role = role.args(["--console", c]);
    }
    if a.scada {
        role = role.arg("--scada");
    }
    if a.perception == Sensing::Boxes {
        role = role.args(["--perception", "boxes"]);
    }
    if let Some(at) = a.kill_coordinator_at {
        role = role.args(["--kill-coordinator-at".into(), at.to_string()]);
    }
    // Its output is read line by line (the router's endpoint, the outcome): not a quiet
    // child as `RoleCommand::child` makes.
    let mut demo = std::process::Command::new(firefleet::children::firefleet_binary()?);
    demo.args(role.to_args())
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log)?);
    let started = Instant::now();
    let mut demo = demo.spawn().context("starting the demo")?;
    let mut lines = BufReader::new(demo.stdout.take().context("the demo's output")?).lines();
    // The line that names the router's endpoint ("... processes on quic/...").
    let endpoint = loop {
        let line = lines
            .next()
            .context("the demo ended before it named its endpoint")??;
        if let Some(e) = line.split_whitespace().find(|w| w.starts_with("quic/")) {
            break e.trim_end_matches(',').to_owned();
        }
    };
    // The rest of its output is read so it never blocks on a full pipe.
    std::thread::spawn(move || lines.for_each(drop));

    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let as_who = |who: &Identity| Connect {
        mode: Some(Mode::Client),
        connect: vec![endpoint.clone()],
        tls: Some(pki_dir.join(who.dir_name())),
        ..Connect::default()
    };
    let probe = join(&as_who(&Identity::Commander(commander)), &scenario.site).await?;
    let alert_delay = Arc::new(std::sync::Mutex::new(None));
    let flood = if let Some(rank) = attack.coordinator_rank() {
        let thief = join(&as_who(&Identity::Coordinator(rank)), &scenario.site).await?;
        let mut honest = Vec::new();
        for c in [&chief, &sector] {
            honest.push(join(&as_who(&Identity::Commander(c.clone())), &scenario.site).await?);
        }
        let units = scenario.units.iter().map(|u| u.id.clone()).collect();
        tokio::spawn(command_as_coordinator(
            (thief, rank),
            units,
            honest,
            SUSPEND_AFTER_S,
            (stop.clone(), sent.clone()),
            alert_delay.clone(),
        ))
    } else if attack == Attack::RecorderKey {
        let thief = join(&as_who(&Identity::Recorder), &scenario.site).await?;
        let lie = Recall {
            chief: chief.clone(),
            zones: scenario.zones.iter().map(|z| z.id.clone()).collect(),
            witness: UnitId::new("ugv-1")?,
            fires: scenario
                .fires
                .iter()
                .map(|f| Point2::new(f.x_m, f.y_m))
                .collect(),
            seed: a.seed,
        };
        tokio::spawn(answer_as_recorder(thief, lie, stop.clone(), sent.clone()))
    } else if attack == Attack::ScadaKey {
        let thief = join(&as_who(&Identity::Scada), &scenario.site).await?;
        let clock = join(&as_who(&Identity::Commander(chief.clone())), &scenario.site).await?;
        let lie = Readings {
            map: scenario.scada.clone().context("the site maps no SCADA")?,
            length_m: scenario.tunnel.length_m,
            fires: scenario
                .fires
                .iter()
                .map(|f| scenario.tunnel.chainage(Point2::new(f.x_m, f.y_m)).m())
                .collect(),
        };
        tokio::spawn(report_as_scada(
            (thief, clock),
            lie,
            a.time_scale,
            (stop.clone(), sent.clone()),
            alert_delay.clone(),
        ))
    } else if attack.by_unit() {
        let thief = join(&as_who(&Identity::Unit(ugv2.clone())), &scenario.site).await?;
        let camera = scenario
            .ground_spec(&ugv2)
            .context("ugv-2 is not a ground unit")?
            .camera;
        let lie = Lie {
            unit: ugv2,
            fires: scenario
                .fires
                .iter()
                .map(|f| Point2::new(f.x_m, f.y_m))
                .collect(),
            time_scale: a.time_scale,
            tunnel: scenario.tunnel.clone(),
            camera,
        };
        tokio::spawn(flood_as_unit(
            thief,
            lie,
            attack,
            a.seed,
            stop.clone(),
            sent.clone(),
        ))
    } else {
        // The stolen key, whose name its goals are issued in, and the honest commander who
        // answers it.
        let (thief_id, stolen, honest, answer) = match attack {
            Attack::Chief => {
                let operator = join(&as_who(&Identity::COORDINATOR), &scenario.site).await?;
                let answer = Answer::Suspend {
                    operator,
                    target: Identity::Commander(chief.clone()),
                    after: SUSPEND_AFTER_S,
                };
                (Identity::Commander(chief.clone()), chief, sector, answer)
            }
            Attack::ConsoleKey => {
                // The real incident commander is the second to ask.
                let operator =
                    join(&as_who(&Identity::Commander(chief.clone())), &scenario.site).await?;
                let answer = Answer::Suspend {
                    operator,
                    target: Identity::Console,
                    after: SUSPEND_AFTER_S,
                };
                (Identity::Console, chief, sector, answer)
            }
            _ => (
                Identity::Commander(sector.clone()),
                sector,
                chief,
                Answer::Clear,
            ),
        };
        let thief = join(&as_who(&thief_id), &scenario.site).await?;
        let honest = (
            join(
                &as_who(&Identity::Commander(honest.clone())),
                &scenario.site,
            )
            .await?,
            honest,
        );
        let zones: Vec<ZoneId> = scenario.zones.iter().map(|z| z.id.clone()).collect();
        tokio::spawn(bar_every_zone(
            (thief, stolen),
            honest,
            answer,
            zones,
            stop.clone(),
            sent.clone(),
            alert_delay.clone(),
        ))
    };
    let curls: Vec<std::process::Child> = match &console {
        Some(c) => (0..a.https_clients)
            .map(|_| {
                std::process::Command::new("sh")
                    .arg("-c")
                    .arg(format!(
                        "while :; do curl -sk --max-time 2 -o /dev/null https://{c}/api/incident; done"
                    ))
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .context("starting curl (is it installed?)")
            })
            .collect::<anyhow::Result<_>>()?,
        None => Vec::new(),
    };
    let probing = tokio::spawn(probe_status(probe, stop.clone()));
    let status = tokio::task::spawn_blocking(move || demo.wait()).await??;
    let wall_s = started.elapsed().as_secs_f64();
    stop.store(true, Ordering::Relaxed);
    for mut c in curls {
        let _ = c.kill();
        let _ = c.wait();
    }
    let _ = flood.await;
    let latencies = probing.await?;

    let summary: serde_json::Value = std::fs::read(&summary)
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default();
    let log_text = std::fs::read_to_string(&log).unwrap_or_default();
    let recorded = recording_bytes(&recording);
    let answered: Vec<f64> = latencies.iter().flatten().copied().collect();
    let fires_out = summary["fires_out"].as_u64().unwrap_or(0);
    let fires_total = summary["fires_total"].as_u64().unwrap_or(0);
    let f = Figures {
        attack,
        https_clients: a.https_clients,
        demo_status: status.code(),
        outcome: summary["outcome"]
            .as_str()
            .unwrap_or("no summary")
            .to_owned(),
        // A child that died ends the demo with these words.
        aborted: aborted(&status, &log_text)
            || summary["outcome"]
                .as_str()
                .is_some_and(|o| o.contains("exited unexpectedly")),
        fires_out,
        fires_total,
        all_out_s: summary["sim_time_s"]
            .as_f64()
            .filter(|_| fires_total > 0 && fires_out == fires_total),
        alert_delay_s: *alert_delay.lock().expect("not poisoned"),
        wall_s,
        sent: sent.load(Ordering::Relaxed),
        sent_per_s: sent.load(Ordering::Relaxed) as f64 / wall_s,
        probe_p50_ms: percentile(&answered, 0.5),
        probe_p99_ms: percentile(&answered, 0.99),
        probe_max_ms: answered.iter().copied().fold(0.0, f64::max),
        probes: latencies.len(),
        probes_unanswered: latencies.iter().filter(|l| l.is_none()).count(),
        log_bytes_per_min: log_text.len() as f64 / (wall_s / 60.0),
        recording_bytes_per_s: recorded as f64 / wall_s,
        link_drops: log_text
            .lines()
            .filter(|l| l.contains("zenoh") && (l.contains("WARN") || l.contains("ERROR")))
            .count(),
    };
    println!(
        "attack {:?}, {} HTTPS clients: demo status {:?} ({}){}, fires out {}/{} (all out at {}), wall {:.1} s",
        f.attack,
        f.https_clients,
        f.demo_status,
        f.outcome,
        if f.aborted { ", a process ABORTED" } else { "" },
        f.fires_out,
        f.fires_total,
        f.all_out_s.map_or("-".to_owned(), |t| format!("{t:.1} s")),
        f.wall_s
    );
    if let Some(d) = f.alert_delay_s {
        let (alert, after) = if attack.coordinator_rank().is_some() {
            (
                "the coordinator's finding (the consoles' alarm) in its log",
                "the stolen key's first claim",
            )
        } else if attack == Attack::ScadaKey {
            (
                "the coordinator's finding (the consoles' alarm) in its log",
                "the stolen key's first reading",
            )
        } else {
            (
                "stranded-fire alert in the status",
                "the keep-outs were accepted",
            )
        };
        println!("  {alert} {d:.1} site s after {after}");
    }
    println!(
        "  thief sent {} ({:.0}/s); status probe every 100 ms: p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms, {} of {} unanswered",
        f.sent,
        f.sent_per_s,
        f.probe_p50_ms,
        f.probe_p99_ms,
        f.probe_max_ms,
        f.probes_unanswered,
        f.probes
    );
    println!(
        "  logs {:.0} B/min, recording {:.0} B/s, Zenoh warnings or errors {}",
        f.log_bytes_per_min, f.recording_bytes_per_s, f.link_drops
    );
    for l in log_text
        .lines()
        .filter(|l| l.contains("zenoh") && (l.contains("WARN") || l.contains("ERROR")))
        .take(5)
    {
        println!("    {l}");
    }
    Ok(f)
}

/// A session as `connect` says, once the site's router takes it.
async fn join(connect: &Connect, site: &firefleet_model::SiteId) -> anyhow::Result<Bus> {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        match Bus::open(connect, site.clone()).await {
            Ok(bus) => return Ok(bus),
            Err(e) if Instant::now() > deadline => return Err(e.into()),
            Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
        }
    }
}

/// Ask for the status every 100 ms until `stop`: each question's latency, ms (`None`: no
/// answer within a second), from the first answer to the last.
async fn probe_status(bus: Bus, stop: Arc<AtomicBool>) -> Vec<Option<f64>> {
    let key = bus.keys().expr(&Topic::CoordStatus);
    let mut out = Vec::new();
    let mut every = tokio::time::interval(Duration::from_millis(100));
    while !stop.load(Ordering::Relaxed) {
        every.tick().await;
        let asked = Instant::now();
        let answer = match bus.ask(&key, Ask::within(Duration::from_secs(1))).await {
            Ok(answers) => answers.recv().await,
            Err(_) => None,
        };
        out.push(answer.map(|_| asked.elapsed().as_secs_f64() * 1e3));
    }
    bus.close().await;
    // The incident runs from the coordinator's first answer to its last: questions before
    // it started or after it stopped are not the site's to answer.
    let first = out.iter().position(Option::is_some).unwrap_or(out.len());
    let last = out
        .iter()
        .rposition(Option::is_some)
        .map_or(first, |l| l + 1);
    out[first..last].to_vec()
}

fn percentile(v: &[f64], q: f64) -> f64 {
    if v.is_empty() {
        return f64::NAN;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[((s.len() - 1) as f64 * q).round() as usize]
}

/// The bytes of the recording at `path`, or of its parts if it was not merged.
fn recording_bytes(path: &Path) -> u64 {
    let file = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
    let parts = path.with_extension("mcap.parts");
    let parts: u64 = std::fs::read_dir(parts)
        .map(|d| {
            d.flatten()
                .filter_map(|e| e.metadata().ok())
                .map(|m| m.len())
                .sum()
        })
        .unwrap_or(0);
    file + parts
}

/// Whether the demo or one of its processes died of a signal or an abort.
fn aborted(status: &std::process::ExitStatus, log: &str) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::process::ExitStatusExt;
        if status.signal().is_some() {
            return true;
        }
    }
    // Rust's abort on a failed allocation, and a panic, in any process of the demo.
    ["memory allocation of", "panicked at"]
        .iter()
        .any(|s| log.contains(s))
}
