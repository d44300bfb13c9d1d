//! `firefleet-lab scale`: a real coordinator process under the load of a large fleet.
//!
//! The coordinator is a separate `firefleet coordinator` process on a generated site with
//! `--units` ground units; it is also the Zenoh router the fleet connects to, so that its
//! CPU share includes the routing a coordinator machine would do.
//! Light-weight simulated units (one Zenoh session in this process) hold a liveliness token
//! each and publish their state at 10 Hz; after a warm-up, a flame report for each of
//! `--fires` fires is sent, one every `--report-interval-ms`, by the unit nearest the fire.
//! Measured: for each report, the time until the coordinator's Extinguish task for that
//! fire arrives (the whole path: the report over Zenoh, fusion, the assignment over every
//! unit, the task back over Zenoh), and the coordinator process's CPU time over the run.
//! The units sway about their posts (2 m either way) and do not act: this measures the
//! coordinator, not the fleet, and a console that must tell pages of every move.
//!
//! `--rounds` repeats it: once every fire of a round has its task, each unit sent to one
//! says it is out, the coordinator is asked until it holds every fire out, and the next
//! round's fires start 10 m along from the last's. A p99 wants samples: one round of 200
//! fires makes the p99 its second largest one, ten make it the twentieth of 2000.
//! Each fire is seen by the two units nearest it (the second report follows the timed one
//! at once), as a fire in a fleet's midst is: a fire one unit alone claims would be
//! contradicted by every neighbour that looks at it ten seconds and reports nothing
//! (`fusion::witness`), and those loads are the attack harness's, not this one's.
//!
//! `--secure` runs the same load a second time over QUIC with mutual TLS, the coordinator's
//! router (holding the router's certificate) enforcing the site's access rules and rate and
//! size bounds (`firefleet_bus::access`, every unit's own rules; the load
//! generator, which speaks for every unit, holds the union of theirs), and prints the
//! two side by side: the cost of the secure site, measured in one run.
//!
//! `--console` runs it once more with the commanders' console attached (a `firefleet
//! console` process on the plain link, one page following its stream), and adds the
//! console's own CPU share and the bytes a second its page is sent: the console's cost,
//! against the budget of issue #35 (10 % of a core, 300 kB/s a page at 1000 units).

use std::collections::BTreeMap;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;
use firefleet_bus::access::{self, Grant, Identity, Op};
use firefleet_bus::{Bus, Connect, Mode, free_loopback_port, limits, mtls_link};
use firefleet_model::UnitKind;
use firefleet_model::builtin;
use firefleet_model::scenario::Scenario;
use firefleet_model::{Point2, Pose2, SiteId, UnitId};
use firefleet_protocol::keys::{Keys, Topic};
use firefleet_protocol::msg::{
    FireState, FlameObservation, FlameReport, Task, TaskKind, TaskPhase, TaskProgress, UnitState,
};
use serde::Serialize;

use firefleet::args::write_json;
use firefleet::children::RoleCommand;

#[derive(Args, Debug)]
pub struct ScaleArgs {
    #[arg(long, default_value_t = 1000)]
    units: usize,
    #[arg(long, default_value_t = 200)]
    fires: usize,
    /// Times the fires are reported, put out, and reported again 10 m along.
    #[arg(long, default_value_t = 10)]
    rounds: usize,
    /// Time between two fires' reports, ms.
    #[arg(long, default_value_t = 50)]
    report_interval_ms: u64,
    /// Run the load a second time over mutual TLS and access rules, and compare.
    #[arg(long)]
    secure: bool,
    /// Run the load once more with a console and one page following it, and compare.
    #[arg(long)]
    console: bool,
    /// Also write the figures as JSON (a list: one entry per link).
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
}

#[derive(Serialize)]
struct Figures {
    /// `tcp`, `quic+mtls+acl`, or `tcp+console`.
    link: &'static str,
    units: usize,
    fires: usize,
    /// Reports sent: fires times the rounds run.
    reports: usize,
    state_msgs_per_s: f64,
    tasks_received: usize,
    report_to_task_p50_ms: f64,
    report_to_task_p99_ms: f64,
    report_to_task_max_ms: f64,
    /// The coordinator's own part of the p99 (from taking a report off the bus to handing
    /// its task to Zenoh), as its `/metrics` histogram bounds it: the upper edge of the
    /// bucket holding the 99th percentile.
    inside_p99_at_most_ms: f64,
    coordinator_cpu_share: f64,
    /// The console process's CPU share, with a console attached.
    console_cpu_share: Option<f64>,
    /// What the console's stream sent its one page, bytes per second.
    page_bytes_per_s: Option<f64>,
    wall_s: f64,
}

/// Units stand 10 m apart; fires 50 m apart, so that fusion keeps them apart.
const UNIT_SPACING_M: f64 = 10.0;
/// How far each simulated unit drives either side of its post, m, and how fast it turns
/// back, rad/s (so at most 1 m/s).
const SWAY_M: f64 = 2.0;
const SWAY_RAD_S: f64 = 0.5;
const FIRE_SPACING_M: f64 = 50.0;
/// Rounds whose fires stand apart before one stands where an earlier one did: a round's
/// fires start 10 m (a unit's post) along from the last's, and the fifth is back at the first's
/// places, long after those went out.
const OFFSETS: usize = 5;
const WARM_UP: Duration = Duration::from_secs(3);
/// How long to wait for the last answers after the last report.
const DRAIN: Duration = Duration::from_secs(3);
/// How long after a round's last report its units say the fires are out: a claim while
/// another unit's report is fresher than this would be disputed
/// (`firefleet_coordinator::fusion::STILL_SEEN_S`, 1 s).
const OUT_AFTER: Duration = Duration::from_millis(1500);
/// How long the coordinator may take to hold a round's fires out.
const OUT_WITHIN: Duration = Duration::from_secs(10);

fn site_file(units: usize, fires: usize) -> String {
    let length = (units as f64 * UNIT_SPACING_M).max(fire_at(OFFSETS - 1, fires).x) + 100.0;
    let mut toml = format!(
        "name = \"scale\"\nsite = \"scale\"\ntime_limit_s = 3600\n[tunnel]\nlength_m = {length}\nwidth_m = 10.0\nheight_m = 6.3\nlanes = 2\n"
    );
    for i in 0..units {
        toml.push_str(&format!(
            "[[units]]\nid = \"u{i:05}\"\nkind = \"ground\"\nx_m = {}\ny_m = -1.75\n",
            50.0 + i as f64 * UNIT_SPACING_M
        ));
    }
    toml
}

/// Fire `k` of round `round`: 1 m along from a unit's post, so that two units are the nearest,
/// one clearly first (1 m and 9 m, each swaying 2 m).
fn fire_at(round: usize, k: usize) -> Point2 {
    Point2::new(
        51.0 + k as f64 * FIRE_SPACING_M + (round % OFFSETS) as f64 * UNIT_SPACING_M,
        1.0,
    )
}

/// Which of round `round`'s fires a task for `target` is for, if any.
fn fire_of(round: usize, target: Point2, fires: usize) -> Option<usize> {
    let k = ((target.x - fire_at(round, 0).x) / FIRE_SPACING_M).round();
    // A late task for a fire of the round before stands 10 m off every fire of this one.
    (k >= 0.0
        && (k as usize) < fires
        && (target.x - fire_at(round, k as usize).x).abs() < UNIT_SPACING_M / 2.0)
        .then_some(k as usize)
}

/// User plus system CPU time of process `pid` so far, s (Linux `/proc`).
fn cpu_time_s(pid: u32) -> anyhow::Result<f64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .context("reading the coordinator's CPU time (Linux /proc)")?;
    // Fields after the command name, which is in parentheses and may contain spaces.
    let rest = stat.rsplit_once(')').context("/proc stat format")?.1;
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f[11].parse::<f64>()? + f[12].parse::<f64>()?;
    // The kernel's USER_HZ is 100 on every Linux architecture we run on.
    Ok(ticks / 100.0)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let k = ((p / 100.0) * (sorted.len() - 1) as f64).round() as usize;
    sorted[k]
}

/// How the load reaches the coordinator.
struct Link {
    name: &'static str,
    endpoint: String,
    /// The coordinator's Zenoh arguments: it is the router.
    coordinator: Vec<std::ffi::OsString>,
    client: Connect,
    /// Whether a console and a page follow the fleet.
    console: bool,
}

impl Link {
    fn plain() -> anyhow::Result<Self> {
        let endpoint = format!("tcp/127.0.0.1:{}", free_loopback_port()?);
        Ok(Self {
            name: "tcp",
            coordinator: ["--mode", "router", "--listen", &endpoint]
                .map(Into::into)
                .into(),
            client: Connect {
                mode: Some(Mode::Client),
                connect: vec![endpoint.clone()],
                ..Connect::default()
            },
            endpoint,
            console: false,
        })
    }

    /// The plain link with a console attached.
    fn with_console() -> anyhow::Result<Self> {
        Ok(Self {
            name: "tcp+console",
            console: true,
            ..Self::plain()?
        })
    }

    /// QUIC with mutual TLS and a PKI made in `dir` for `scenario`'s site, its access rules and bounds;
    /// the load generator holds the simulator's certificate, granted what every unit may
    /// do and what it reads itself (tasks, the status).
    fn secure(dir: &std::path::Path, scenario: &Scenario) -> anyhow::Result<Self> {
        let endpoint = format!("quic/127.0.0.1:{}", free_loopback_port()?);
        let pki = dir.join("pki");
        let terms = firefleet_bus::pki::Terms::default();
        let identities = firefleet_bus::pki::make_site(scenario, &[], &terms, &pki)?;
        let keys = Keys::new(scenario.site.clone());
        let mut granted = Vec::new();
        let mut load = vec![
            Grant {
                op: Op::Subscribe,
                key_expr: keys.every_unit_task().as_str().to_owned(),
            },
            Grant {
                op: Op::Query,
                key_expr: keys.every_coord(),
            },
        ];
        for who in identities {
            let g = access::grants(scenario, &who, false)?;
            if let Identity::Unit(u) = &who {
                load.extend(g.iter().map(|g| any_unit(g, u)));
            }
            granted.push((who, g));
        }
        load.sort_by(|a, b| (a.op, &a.key_expr).cmp(&(b.op, &b.key_expr)));
        load.dedup();
        granted.push((Identity::Sim, load));
        let units: Vec<UnitId> = scenario.units.iter().map(|u| u.id.clone()).collect();
        let (downsampling, low_pass) = limits::zenoh_limits(&keys, &units, 1.0);
        let config = serde_json::json!({
            "mode": "router",
            "listen": { "endpoints": [endpoint] },
            "scouting": { "multicast": { "enabled": false } },
            "transport": { "link": { "tls": mtls_link(&pki.join(Identity::ROUTER.dir_name())) } },
            "access_control": access::zenoh_acl_of(&keys, &granted),
            "downsampling": downsampling,
            "low_pass_filter": low_pass,
        });
        let path = dir.join("router.json5");
        std::fs::write(&path, serde_json::to_vec(&config)?)?;
        Ok(Self {
            name: "quic+mtls+acl",
            coordinator: vec!["--zenoh-config".into(), path.into()],
            client: Connect {
                mode: Some(Mode::Client),
                connect: vec![endpoint.clone()],
                tls: Some(pki.join(Identity::Sim.dir_name())),
                ..Connect::default()
            },
            endpoint,
            console: false,
        })
    }
}

/// Unit `unit`'s `grant` made every unit's: the key chunk that names the unit a `*`.
///
/// The load speaks for a thousand units on one identity. Granted each unit's rules one by
/// one, that identity had some 15 000 key expressions, and the router walked them all
/// for every task it let through to the load: 15 % of the coordinator's CPU (which is
/// the router here), 40 µs a task, in no site's path. On a site each unit's identity has
/// its own dozen rules; one dozen with the unit's name a wildcard costs the same.
fn any_unit(grant: &Grant, unit: &UnitId) -> Grant {
    let key_expr = grant
        .key_expr
        .split('/')
        .map(|chunk| if chunk == unit.as_str() { "*" } else { chunk })
        .collect::<Vec<_>>()
        .join("/");
    Grant {
        op: grant.op,
        key_expr,
    }
}

pub async fn run(a: ScaleArgs) -> anyhow::Result<ExitCode> {
    anyhow::ensure!(a.units >= 1 && a.units <= 20_000, "--units: 1 to 20000");
    anyhow::ensure!(a.fires >= 1 && a.fires <= a.units, "--fires: 1 to --units");
    anyhow::ensure!(a.rounds >= 1 && a.rounds <= 1000, "--rounds: 1 to 1000");
    let dir = tempfile::tempdir()?;
    let site = dir.path().join("scale.toml");
    std::fs::File::create(&site)?.write_all(site_file(a.units, a.fires).as_bytes())?;
    let mut links = vec![Link::plain()?];
    if a.secure {
        let scenario = builtin::resolve(&site.display().to_string())?;
        links.push(Link::secure(dir.path(), &scenario)?);
    }
    if a.console {
        links.push(Link::with_console()?);
    }
    let mut figures = Vec::new();
    for link in &links {
        figures.push(measure(&a, &site, link).await?);
    }
    print_table(&figures);
    write_json(a.json.as_deref(), &figures)?;
    let short: Vec<String> = figures
        .iter()
        .filter(|f| f.tasks_received < a.rounds * a.fires)
        .map(|f| {
            format!(
                "{}: {} of {} reports of a new fire got no task",
                f.link,
                a.rounds * a.fires - f.tasks_received,
                a.rounds * a.fires
            )
        })
        .collect();
    if short.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!("{}", short.join("; "));
        Ok(ExitCode::FAILURE)
    }
}

/// One run of the load over `link` against a coordinator on site file `site`.
async fn measure(a: &ScaleArgs, site: &std::path::Path, link: &Link) -> anyhow::Result<Figures> {
    let (endpoint, client) = (&link.endpoint, &link.client);
    let launched = Instant::now();
    let metrics = format!("127.0.0.1:{}", free_loopback_port()?);
    let mut coordinator = child("coordinator", site)?
        .args(&link.coordinator)
        .args(["--metrics", &metrics])
        .spawn()
        .context("starting the coordinator")?;
    let pid = coordinator.id().context("the coordinator's pid")?;
    // Held until the end: the coordinator stops when its stdin closes, and `wait` would
    // close it if the child still owned it.
    let stdin = coordinator.stdin.take();
    // Connect once the coordinator listens (Zenoh would log every refused attempt).
    let addr = endpoint
        .split_once('/')
        .map_or(endpoint.as_str(), |(_, a)| a)
        .to_owned();
    // QUIC is UDP: no connection to watch for; the first session the router takes.
    let quic = endpoint.starts_with("quic/");
    if !quic {
        listening(&addr, "the coordinator", launched).await?;
    }
    let console = match link.console {
        true => Some(Console::attach(site, endpoint).await?),
        false => None,
    };
    let fleet = loop {
        match Bus::open(client, SiteId::new("scale")?).await {
            Ok(bus) => break bus,
            Err(e) if !quic || launched.elapsed() > Duration::from_secs(20) => {
                return Err(anyhow::Error::new(e).context("connecting to the coordinator"));
            }
            Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
        }
    };
    let keys = fleet.keys().clone();
    // Reports go out, and tasks come in, on a session of their own, as on a unit's own
    // link: queued behind the thousand states this process sends every 100 ms they would
    // measure this process, not the coordinator.
    let reporter = Bus::open(client, SiteId::new("scale")?).await?;
    let tasks = reporter.subscribe::<Task>(&keys.every_unit_task()).await?;
    // The fleet comes up once the coordinator answers status queries (its last step).
    while firefleet::net::query_status(&fleet).await.is_err() {
        anyhow::ensure!(
            launched.elapsed() < Duration::from_secs(20),
            "the coordinator did not come up within 20 s"
        );
        if let Some(status) = coordinator.try_wait()? {
            anyhow::bail!("the coordinator exited early: {status}");
        }
    }

    let ids: Vec<UnitId> = (0..a.units)
        .map(|i| UnitId::new(format!("u{i:05}")))
        .collect::<Result<_, _>>()?;
    let mut tokens = Vec::with_capacity(ids.len());
    for id in &ids {
        tokens.push(fleet.token(&Topic::UnitAlive(id.clone())).await?);
        // As each unit declares its report key when it starts (`firefleet_agent::node`).
        reporter.declare(&keys.unit_report(id)).await?;
    }
    let load = Arc::new(Load::new(a.units, a.rounds * a.fires));
    let index: Arc<BTreeMap<UnitId, usize>> = Arc::new(
        ids.iter()
            .cloned()
            .enumerate()
            .map(|(i, id)| (id, i))
            .collect(),
    );
    // Every unit drives to and fro about its post (2 m either way, up to 1 m/s), so that
    // each state says something new, as a working fleet's do: a console that sends only
    // what changed is measured at its worst.
    let pose = |i: usize, t: f64| {
        Pose2::new(
            50.0 + i as f64 * UNIT_SPACING_M + SWAY_M * (SWAY_RAD_S * t + i as f64).sin(),
            -1.75,
            0.0,
        )
    };
    let state = move |i: usize, id: &UnitId, t: f64, load: &Load| UnitState {
        t,
        speed: SWAY_M * SWAY_RAD_S * (SWAY_RAD_S * t + i as f64).cos(),
        task: *load.says[i].lock().expect("not poisoned"),
        task_seq: load.took(i).map(|(_, seq)| seq),
        epoch: load.took(i).map(|(epoch, _)| epoch),
        ..UnitState::idle(id.clone(), UnitKind::Ground, pose(i, t), 1500.0)
    };

    println!(
        "scale: {} units at 10 Hz, {} fires x {} rounds, coordinator pid {pid} on {endpoint} ({})",
        a.units, a.fires, a.rounds, link.name
    );
    let start = Instant::now();
    let epoch = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)?
        .as_secs_f64();
    let now = move || epoch + start.elapsed().as_secs_f64();
    // Unit states go out from their own task, tasks are taken in by another, so that
    // neither waits on the reports.
    let published = Arc::new(AtomicU64::new(0));
    // Each unit's state on its own key, as a unit puts it (the bus declares a publisher
    // per key on its first put).
    let state_keys: Vec<_> = ids.iter().map(|id| keys.unit_state(id)).collect();
    let publisher = {
        let (ids, published, load) = (ids.clone(), published.clone(), load.clone());
        let (n, fleet) = (a.units, fleet.clone());
        tokio::spawn(async move {
            let mut ticker = tokio::time::interval(Duration::from_millis(100));
            loop {
                ticker.tick().await;
                let t = now();
                for (i, (id, key)) in ids.iter().zip(&state_keys).enumerate() {
                    if fleet.put(key, &state(i, id, t, &load)).await.is_err() {
                        return;
                    }
                }
                published.fetch_add(n as u64, Ordering::Relaxed);
            }
        })
    };
    let receiver = {
        let load = load.clone();
        let fires = a.fires;
        tokio::spawn(async move {
            while let Some((_, task)) = tasks.recv().await {
                if let Some(&i) = index.get(&task.unit) {
                    load.take(i, &task, fires);
                }
            }
        })
    };
    tokio::time::sleep(WARM_UP).await;
    let cpu0 = cpu_time_s(pid)?;
    let inside0 = inside(&metrics).await?;
    let console0 = console.as_ref().map(Console::sample).transpose()?;
    let (t0, s0) = (Instant::now(), published.load(Ordering::Relaxed));
    let mut sent = Vec::with_capacity(a.rounds * a.fires);
    // The unit nearest a fire reports it first, the next nearest (the post after, or before
    // at the tunnel's end) at once after it.
    let nearest = |at: Point2| {
        let first = (((at.x - 50.0) / UNIT_SPACING_M).round() as usize).min(a.units - 1);
        let second = if first + 1 < a.units {
            first + 1
        } else {
            first.saturating_sub(1)
        };
        (first, second)
    };
    let report = |by: usize, at: Point2| {
        // The camera turned to the fire, as the cannon it rides on turns: the coordinator
        // refuses flames outside the camera's field of view, and a fire behind the unit's
        // heading (from the fifth round on, the rounds' fires having moved along) would
        // never be confirmed.
        let from = pose(by, 0.0).position();
        (
            keys.unit_report(&ids[by]),
            FlameReport {
                unit: ids[by].clone(),
                t: now(),
                observer: Pose2::new(from.x, from.y, from.bearing_to(at)),
                observations: vec![FlameObservation {
                    position: at,
                    cov: [0.25, 0.0, 0.25],
                    confidence: 0.9,
                    hrr_kw: None,
                }],
            },
        )
    };
    for round in 0..a.rounds {
        load.begin(round, a.fires);
        // A ticker of its own: one kept across the wait for the last round's fires to go
        // out would send this round's first reports in a burst to catch up.
        let mut ticker = tokio::time::interval(Duration::from_millis(a.report_interval_ms));
        for k in 0..a.fires {
            ticker.tick().await;
            if let Some(status) = coordinator.try_wait()? {
                anyhow::bail!("the coordinator exited early: {status}");
            }
            let at = fire_at(round, k);
            let (first, second) = nearest(at);
            let (key, timed) = report(first, at);
            sent.push(Instant::now());
            reporter.put(&key, &timed).await?;
            if second != first {
                let (key, seen) = report(second, at);
                reporter.put(&key, &seen).await?;
            }
        }
        let last_report = Instant::now();
        // Wait for the last answers, up to DRAIN.
        let deadline = last_report + DRAIN;
        while Instant::now() < deadline && load.unanswered(round, a.fires) > 0 {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        let unanswered = load.unanswered(round, a.fires);
        if unanswered > 0 || round + 1 == a.rounds {
            if unanswered > 0 {
                eprintln!("round {round}: {unanswered} fires got no task; no more rounds");
            }
            break;
        }
        tokio::time::sleep(OUT_AFTER.saturating_sub(last_report.elapsed())).await;
        // Every unit sent to one of this round's fires reports the flame it sprays, if it
        // was not one of the two that saw it, then says it is out.
        for (i, progress) in load.tasked() {
            let (first, second) = nearest(progress.target);
            if i != first && i != second {
                let (key, seen) = report(i, progress.target);
                reporter.put(&key, &seen).await?;
            }
            load.says_out(i, progress);
        }
        held_out(&fleet, round).await?;
    }
    publisher.abort();
    receiver.abort();
    let latency_ms: Vec<Option<f64>> = load
        .arrivals
        .lock()
        .expect("not poisoned")
        .iter()
        .zip(&sent)
        .map(|(got, s)| got.map(|g| g.duration_since(*s).as_secs_f64() * 1e3))
        .collect();
    let states = published.load(Ordering::Relaxed);
    let cpu = cpu_time_s(pid)? - cpu0;
    let inside = inside(&metrics).await?;
    let wall = t0.elapsed().as_secs_f64();
    let console_figures = match (&console, console0) {
        (Some(c), Some((cpu0, bytes0))) => {
            let (cpu, bytes) = c.sample()?;
            Some(((cpu - cpu0) / wall, (bytes - bytes0) as f64 / wall))
        }
        _ => None,
    };
    drop(console);
    drop(stdin);
    let _ = tokio::time::timeout(Duration::from_secs(5), coordinator.wait()).await;
    drop(tokens);
    fleet.close().await;
    reporter.close().await;

    let mut lat: Vec<f64> = latency_ms.iter().flatten().copied().collect();
    lat.sort_by(f64::total_cmp);
    Ok(Figures {
        link: link.name,
        units: a.units,
        fires: a.fires,
        reports: sent.len(),
        state_msgs_per_s: (states - s0) as f64 / wall,
        tasks_received: lat.len(),
        report_to_task_p50_ms: percentile(&lat, 50.0),
        report_to_task_p99_ms: percentile(&lat, 99.0),
        report_to_task_max_ms: lat.last().copied().unwrap_or(f64::NAN),
        inside_p99_at_most_ms: inside.since(&inside0).at_most(99.0) * 1e3,
        coordinator_cpu_share: cpu / wall,
        console_cpu_share: console_figures.map(|(cpu, _)| cpu),
        page_bytes_per_s: console_figures.map(|(_, bytes)| bytes),
        wall_s: wall,
    })
}

/// `firefleet <role> --scenario <site>`, quiet, a child of this process that ends with it.
fn child(role: &str, site: &std::path::Path) -> anyhow::Result<tokio::process::Command> {
    RoleCommand::new(role)
        .scenario(site)
        .die_with_parent()
        .child("warn,zenoh=error")
}

/// The coordinator's report-to-task histogram: each bucket's upper edge, s, and the
/// reports at or under it.
struct Histogram(Vec<(f64, u64)>);

impl Histogram {
    /// What was counted after `before`.
    fn since(&self, before: &Histogram) -> Histogram {
        Histogram(
            self.0
                .iter()
                .zip(&before.0)
                .map(|(&(le, n), &(_, n0))| (le, n.saturating_sub(n0)))
                .collect(),
        )
    }

    /// The upper edge of the bucket holding percentile `p`, s (infinite past the last).
    fn at_most(&self, p: f64) -> f64 {
        let total = self.0.last().map_or(0, |&(_, n)| n);
        self.0
            .iter()
            .find(|&&(_, n)| n as f64 >= p / 100.0 * total as f64)
            .map_or(f64::NAN, |&(le, _)| le)
    }
}

/// The report-to-task histogram from the coordinator's `/metrics` on `addr`.
async fn inside(addr: &str) -> anyhow::Result<Histogram> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut stream = tokio::net::TcpStream::connect(addr)
        .await
        .with_context(|| format!("the coordinator's metrics on {addr}"))?;
    stream
        .write_all(
            format!("GET /metrics HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n")
                .as_bytes(),
        )
        .await?;
    let mut text = String::new();
    stream.read_to_string(&mut text).await?;
    const BUCKET: &str = "firefleet_coordinator_report_to_task_seconds_bucket{le=\"";
    let buckets = text
        .lines()
        .filter_map(|l| l.strip_prefix(BUCKET))
        .map(|l| {
            let (le, n) = l.split_once("\"} ").context("a bucket's line")?;
            Ok((
                if le == "+Inf" {
                    f64::INFINITY
                } else {
                    le.parse()?
                },
                n.trim().parse()?,
            ))
        })
        .collect::<anyhow::Result<Vec<_>>>()
        .with_context(|| format!("the coordinator's metrics on {addr}"))?;
    anyhow::ensure!(
        !buckets.is_empty(),
        "no report-to-task histogram on {addr}/metrics"
    );
    Ok(Histogram(buckets))
}

/// A connection to `addr` once `who`, launched at `launched`, listens there (within 20 s).
async fn listening(
    addr: &str,
    who: &str,
    launched: Instant,
) -> anyhow::Result<tokio::net::TcpStream> {
    loop {
        if let Ok(s) = tokio::net::TcpStream::connect(addr).await {
            return Ok(s);
        }
        anyhow::ensure!(
            launched.elapsed() < Duration::from_secs(20),
            "{who} did not listen on {addr} within 20 s"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// A `firefleet console` process on the site, and one page following its stream.
struct Console {
    process: tokio::process::Child,
    pid: u32,
    /// Bytes of the stream the page has read.
    read: Arc<AtomicU64>,
    page: tokio::task::JoinHandle<()>,
}

impl Console {
    async fn attach(site: &std::path::Path, endpoint: &str) -> anyhow::Result<Self> {
        let http = format!("127.0.0.1:{}", free_loopback_port()?);
        let process = child("console", site)?
            .args(["--http", &http, "--mode", "client", "--connect", endpoint])
            .spawn()
            .context("starting the console")?;
        let pid = process.id().context("the console's pid")?;
        let launched = Instant::now();
        let mut stream = listening(&http, "the console", launched).await?;
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        stream
            .write_all(
                format!(
                    "GET /api/stream HTTP/1.1\r\nHost: {http}\r\nAccept: text/event-stream\r\n\r\n"
                )
                .as_bytes(),
            )
            .await?;
        let read = Arc::new(AtomicU64::new(0));
        let page = {
            let read = read.clone();
            tokio::spawn(async move {
                let mut buf = vec![0u8; 1 << 16];
                while let Ok(n @ 1..) = stream.read(&mut buf).await {
                    read.fetch_add(n as u64, Ordering::Relaxed);
                }
            })
        };
        Ok(Self {
            process,
            pid,
            read,
            page,
        })
    }

    /// The console's CPU time so far, s, and the bytes its page has read.
    fn sample(&self) -> anyhow::Result<(f64, u64)> {
        Ok((cpu_time_s(self.pid)?, self.read.load(Ordering::Relaxed)))
    }
}

impl Drop for Console {
    fn drop(&mut self) {
        self.page.abort();
        let _ = self.process.start_kill();
    }
}

fn print_table(figures: &[Figures]) {
    let row = |label: &str, cell: &dyn Fn(&Figures) -> String, note: &str| {
        let cells: String = figures
            .iter()
            .map(|f| format!(" {:>10}", cell(f)))
            .collect();
        println!("{label:<36}{cells}{note}");
    };
    row("link", &|f| f.link.to_owned(), "");
    row(
        "unit states published, per s",
        &|f| format!("{:.0}", f.state_msgs_per_s),
        "",
    );
    row(
        "reports answered with a task",
        &|f| format!("{}/{}", f.tasks_received, f.reports),
        "",
    );
    row(
        "report -> task p50, ms",
        &|f| format!("{:.2}", f.report_to_task_p50_ms),
        "",
    );
    row(
        "report -> task p99, ms",
        &|f| format!("{:.2}", f.report_to_task_p99_ms),
        "   (target 10 ms)",
    );
    row(
        "report -> task max, ms",
        &|f| format!("{:.2}", f.report_to_task_max_ms),
        "",
    );
    row(
        "  of it in the coordinator, ms, <=",
        &|f| format!("{:.2}", f.inside_p99_at_most_ms),
        "",
    );
    row(
        "coordinator CPU, % of one core",
        &|f| format!("{:.0}", f.coordinator_cpu_share * 100.0),
        "",
    );
    if figures.iter().any(|f| f.console_cpu_share.is_some()) {
        let or_dash = |v: Option<String>| v.unwrap_or_else(|| "-".into());
        row(
            "console CPU, % of one core",
            &|f| or_dash(f.console_cpu_share.map(|c| format!("{:.0}", c * 100.0))),
            "",
        );
        row(
            "console -> page stream, kB/s",
            &|f| or_dash(f.page_bytes_per_s.map(|b| format!("{:.0}", b / 1e3))),
            "",
        );
    }
    row("measured over, s", &|f| format!("{:.1}", f.wall_s), "");
}

/// What the load's units hold and say, shared by the task that publishes their states and
/// the one that takes in their tasks.
struct Load {
    /// Each unit's latest task's number, and the newest epoch: echoed in its states, as a
    /// real unit's are (the coordinator counts a unit whose states stop echoing its task
    /// as deaf). One coordinator, so one epoch.
    seq: Vec<AtomicU64>,
    epoch: AtomicU64,
    /// What each unit's state says of its task: the fire it put out, once it has.
    says: Vec<Mutex<Option<TaskProgress>>>,
    round: AtomicUsize,
    /// When each report's task came, round after round.
    arrivals: Mutex<Vec<Option<Instant>>>,
    /// This round's fires: the unit last sent to each, and what it will say of it.
    tasked: Mutex<Vec<Option<(usize, TaskProgress)>>>,
}

impl Load {
    fn new(units: usize, reports: usize) -> Self {
        Self {
            seq: (0..units).map(|_| AtomicU64::new(0)).collect(),
            epoch: AtomicU64::new(0),
            says: (0..units).map(|_| Mutex::new(None)).collect(),
            round: AtomicUsize::new(0),
            arrivals: Mutex::new(vec![None; reports]),
            tasked: Mutex::new(Vec::new()),
        }
    }

    /// Unit `i`'s latest task, (epoch, number).
    fn took(&self, i: usize) -> Option<(u64, u64)> {
        let seq = self.seq[i].load(Ordering::Relaxed);
        (seq > 0).then(|| (self.epoch.load(Ordering::Relaxed), seq))
    }

    fn begin(&self, round: usize, fires: usize) {
        self.round.store(round, Ordering::Relaxed);
        *self.tasked.lock().expect("not poisoned") = vec![None; fires];
    }

    /// Unit `i` is given `task`.
    fn take(&self, i: usize, task: &Task, fires: usize) {
        self.epoch.fetch_max(task.epoch, Ordering::Relaxed);
        if self.seq[i].fetch_max(task.seq, Ordering::Relaxed) < task.seq {
            // What it said of its last task no longer stands.
            *self.says[i].lock().expect("not poisoned") = None;
        }
        let TaskKind::Extinguish { fire, target, .. } = task.kind else {
            return;
        };
        let round = self.round.load(Ordering::Relaxed);
        let Some(k) = fire_of(round, target, fires) else {
            return;
        };
        self.arrivals.lock().expect("not poisoned")[round * fires + k]
            .get_or_insert_with(Instant::now);
        self.tasked.lock().expect("not poisoned")[k] = Some((
            i,
            TaskProgress {
                seq: task.seq,
                fire,
                phase: TaskPhase::Extinguished,
                target,
            },
        ));
    }

    /// This round's fires that have no task yet.
    fn unanswered(&self, round: usize, fires: usize) -> usize {
        self.arrivals.lock().expect("not poisoned")[round * fires..(round + 1) * fires]
            .iter()
            .filter(|a| a.is_none())
            .count()
    }

    /// The units sent to this round's fires, with what each will say of its fire.
    fn tasked(&self) -> Vec<(usize, TaskProgress)> {
        self.tasked
            .lock()
            .expect("not poisoned")
            .iter()
            .flatten()
            .copied()
            .collect()
    }

    /// Unit `i` says from now on that its fire is out.
    fn says_out(&self, i: usize, out: TaskProgress) {
        *self.says[i].lock().expect("not poisoned") = Some(out);
    }
}

/// Wait until the coordinator holds every fire out (round `round`'s units said so), asking
/// its status; within [`OUT_WITHIN`].
async fn held_out(bus: &Bus, round: usize) -> anyhow::Result<()> {
    let asked = Instant::now();
    loop {
        let (status, _) = firefleet::net::query_status(bus).await?;
        let burning: Vec<String> = status
            .fires
            .iter()
            .filter(|f| !matches!(f.state, FireState::Out | FireState::Lost))
            .map(|f| format!("{} ({})", f.id, f.state))
            .collect();
        if burning.is_empty() {
            return Ok(());
        }
        anyhow::ensure!(
            asked.elapsed() < OUT_WITHIN,
            "round {round}: {} fires not out {:.0} s after their units said so: {}",
            burning.len(),
            OUT_WITHIN.as_secs_f64(),
            burning.join(", ")
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}
