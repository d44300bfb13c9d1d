//! `firefleet experiment flood`: a secure site under attack from one stolen unit
//! certificate, measured from outside.
//!
//! A `firefleet demo --secure` runs in a child process on a PKI made here; a thief holding
//! `unit:ugv-2`'s certificate sends on ugv-2's own keys (what the access rules allow it)
//! for the whole incident: valid states as fast as it can, random bytes, fake flame reports
//! (64 random observations each, 94 a second), or 1 MB behaviour-tree messages; optionally
//! HTTPS clients hammer the console. A commander's session asks for the status every
//! 100 ms. Measured: whether every process lived and every fire went out, the status
//! probe's latency, how fast the logs (the demo's standard error) and the recording grew,
//! how many messages the thief got out, and the link drops Zenoh logged.
//!
//! Not here: the rules and bounds that hold against the flood (`firefleet_bus::access`,
//! `limits`), or attacks across identities (`tests/secure.rs`).

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
use firefleet_bus::{Ask, Bus, Connect, Mode};
use firefleet_model::{CommanderId, Pose2, UnitId, UnitKind, builtin};
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{FlameObservation, FlameReport, MAX_LIST, UnitState};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use crate::commands::{time_scale, write_json};

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
}

#[derive(Args, Debug)]
pub struct FloodArgs {
    /// The site (a built-in scenario or a file); it must have a unit ugv-2.
    #[arg(long, default_value = "pileup")]
    scenario: String,
    #[arg(long, default_value_t = 4.0, value_parser = time_scale)]
    time_scale: f64,
    #[arg(long, value_enum, default_value_t = Attack::States)]
    attack: Attack,
    /// HTTPS clients asking the console for the incident without pause, each request
    /// bounded to 2 s (curl; 0: no console).
    #[arg(long, default_value_t = 0)]
    https_clients: usize,
    /// The thief's seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the figures as JSON.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
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
    let scenario = builtin::resolve(&a.scenario)?;
    let ugv2 = UnitId::new("ugv-2")?;
    anyhow::ensure!(
        scenario.unit(&ugv2).is_some(),
        "--scenario {}: no unit ugv-2 to steal",
        a.scenario
    );
    let dir = tempfile::tempdir()?;
    let pki_dir = dir.path().join("pki");
    let commander = CommanderId::new("demo")?;
    pki::make_site(
        &scenario,
        std::slice::from_ref(&commander),
        &Terms::default(),
        &pki_dir,
    )?;
    let (recording, summary, log) = (
        dir.path().join("run.mcap"),
        dir.path().join("summary.json"),
        dir.path().join("stderr.log"),
    );
    let console = (a.https_clients > 0)
        .then(|| firefleet_bus::free_loopback_port().map(|p| format!("127.0.0.1:{p}")))
        .transpose()?;
    let mut demo = std::process::Command::new(std::env::current_exe()?);
    demo.args(["demo", "--secure", "--scenario", &a.scenario])
        .args(["--time-scale", &a.time_scale.to_string()])
        .arg("--pki")
        .arg(&pki_dir)
        .arg("--record")
        .arg(&recording)
        .arg("--summary-json")
        .arg(&summary)
        .stdout(Stdio::piped())
        .stderr(std::fs::File::create(&log)?);
    if let Some(c) = &console {
        demo.args(["--console", c]);
    }
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
    let thief = join(&as_who(&Identity::Unit(ugv2.clone())), &scenario.site).await?;
    let probe = join(&as_who(&Identity::Commander(commander)), &scenario.site).await?;
    let flood = tokio::spawn(attack(
        thief,
        ugv2,
        a.attack,
        a.seed,
        stop.clone(),
        sent.clone(),
    ));
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
    let f = Figures {
        attack: a.attack,
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
        fires_out: summary["fires_out"].as_u64().unwrap_or(0),
        fires_total: summary["fires_total"].as_u64().unwrap_or(0),
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
        "attack {:?}, {} HTTPS clients: demo status {:?} ({}){}, fires out {}/{}, wall {:.1} s",
        f.attack,
        f.https_clients,
        f.demo_status,
        f.outcome,
        if f.aborted { ", a process ABORTED" } else { "" },
        f.fires_out,
        f.fires_total,
        f.wall_s
    );
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
    write_json(a.json.as_deref(), &f)?;
    let ok = !f.aborted && f.demo_status == Some(0) && f.fires_out == f.fires_total;
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
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

/// Send `attack` on `unit`'s keys until `stop`, counting in `sent`.
async fn attack(
    thief: Bus,
    unit: UnitId,
    attack: Attack,
    seed: u64,
    stop: Arc<AtomicBool>,
    sent: Arc<AtomicU64>,
) {
    let keys = thief.keys().clone();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut state = UnitState::idle(
        unit.clone(),
        UnitKind::Ground,
        Pose2::new(60.0, -2.0, 0.0),
        1000.0,
    );
    let big = vec![0xA5u8; 1 << 20];
    while !stop.load(Ordering::Relaxed) {
        let (key, bytes) = match attack {
            Attack::None => {
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
            Attack::States => {
                state.t += 0.001;
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    codec::encode(&state),
                )
            }
            Attack::Garbage => {
                let n = rng.random_range(1..256);
                (
                    keys.unit_state(&unit).as_str().to_owned(),
                    (0..n).map(|_| rng.random()).collect(),
                )
            }
            Attack::Reports => {
                tokio::time::sleep(Duration::from_micros(1_000_000 / 94)).await;
                let report = FlameReport {
                    unit: unit.clone(),
                    t: state.t,
                    observer: Pose2::new(60.0, -2.0, 0.0),
                    observations: (0..MAX_LIST)
                        .map(|_| FlameObservation {
                            position: firefleet_model::Point2::new(
                                rng.random_range(0.0..300.0),
                                rng.random_range(-4.0..4.0),
                            ),
                            cov: [0.3, 0.0, 0.3],
                            confidence: 0.95,
                            hrr_kw: Some(5000.0),
                        })
                        .collect(),
                };
                (
                    keys.unit_report(&unit).as_str().to_owned(),
                    codec::encode(&report),
                )
            }
            Attack::BigBt => (keys.unit_bt(&unit).as_str().to_owned(), big.clone()),
        };
        if thief.put_raw(&key, bytes).await.is_ok() {
            sent.fetch_add(1, Ordering::Relaxed);
        }
        // The link's own pace, but never a task that starves the runtime.
        if sent.load(Ordering::Relaxed).is_multiple_of(256) {
            tokio::task::yield_now().await;
        }
    }
    thief.close().await;
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
