//! End-to-end on a secure site: the real `firefleet` binary as separate processes over
//! QUIC with mutual TLS on loopback, a site PKI, the rendered access rules and bounds, and a
//! router enforcing them; what a stolen, revoked, expired or misplaced certificate can do.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "tests print what a person running them reads"
)]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::support::{BIN, Fleet, assert_says, cli, outcome, patient, pki_init, status_of, text};
use firefleet_bus::{Ask, Bus};
use firefleet_model::{FireId, Point2, Pose2, UnitId};
use firefleet_protocol::codec;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{
    BarredSpace, FireState, FireTrack, SimTruth, Task, TaskKind, UnitState, epoch_after,
};

/// `firefleet status` on `endpoint`, as the identity in `tls` (none: no certificate).
fn status(scenario: &str, tls: Option<&Path>, endpoint: &str) -> std::process::Output {
    let mut c = Command::new(BIN);
    c.args(["status", "--scenario", scenario, "--mode", "client"])
        .args(["--connect", endpoint]);
    if let Some(dir) = tls {
        c.arg("--tls-dir").arg(dir);
    }
    c.output().unwrap()
}

/// Ask for the status as `tls` on `endpoint` until it answers, or fail saying `who`.
fn until_answered(scenario: &str, tls: &Path, endpoint: &str, who: &str) {
    let deadline = Instant::now() + patient(Duration::from_secs(30));
    while !status(scenario, Some(tls), endpoint).status.success() {
        assert!(Instant::now() < deadline, "{who} never got an answer");
        std::thread::sleep(Duration::from_millis(300));
    }
}

/// A coordinator that is also a router on `endpoint`, serving with the identity in `tls`.
fn coordinator_router(scenario: &str, endpoint: &str, tls: &Path) -> Fleet {
    Fleet(vec![
        Command::new(BIN)
            .args(["coordinator", "--scenario", scenario, "--mode", "router"])
            .args(["--listen", endpoint, "--tls-dir"])
            .arg(tls)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    ])
}

#[test]
fn mutual_tls_lets_in_only_the_site_s_identities() {
    let dir = tempfile::tempdir().unwrap();
    let pki = pki_init(dir.path(), "rail-tunnel");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        for key in ["ca/ca.key", "unit-ugv-1/key.pem", "commander-rossi/key.pem"] {
            let mode = std::fs::metadata(pki.join(key))
                .unwrap()
                .permissions()
                .mode();
            assert_eq!(mode & 0o777, 0o600, "{key}");
        }
    }
    let port = firefleet_bus::free_loopback_port().unwrap();
    let endpoint = format!("quic/127.0.0.1:{port}");
    let _router = coordinator_router("rail-tunnel", &endpoint, &pki.join("router"));
    let rossi = pki.join("commander-rossi");
    // A commander of this site gets the status once the router is up.
    until_answered("rail-tunnel", &rossi, &endpoint, "the site's commander");
    // No certificate, plain TCP, or a certificate of another site's CA: no link at all.
    assert!(!status("rail-tunnel", None, &endpoint).status.success());
    let plain = format!("tcp/127.0.0.1:{port}");
    assert!(!status("rail-tunnel", None, &plain).status.success());
    let other = dir.path().join("other");
    let out = crate::support::firefleet(&[
        "pki",
        "init",
        "--scenario",
        "rail-tunnel",
        "--out",
        other.to_str().unwrap(),
    ]);
    assert!(out.status.success());
    let mixed = dir.path().join("mixed");
    std::fs::create_dir(&mixed).unwrap();
    std::fs::copy(pki.join("ca/ca.pem"), mixed.join("ca.pem")).unwrap();
    for f in ["cert.pem", "key.pem"] {
        std::fs::copy(other.join("coordinator").join(f), mixed.join(f)).unwrap();
    }
    // Refused before a link is tried: it can never work.
    let out = status("rail-tunnel", Some(&mixed), &endpoint);
    assert_says(&out, 2, "not signed by the CA");
    // With an identity, a plain endpoint, or Zenoh's TLS link, is refused before anything
    // is sent.
    assert_says(
        &status("rail-tunnel", Some(&rossi), &plain),
        2,
        "is not QUIC",
    );
    let tls = format!("tls/127.0.0.1:{port}");
    assert_says(&status("rail-tunnel", Some(&rossi), &tls), 2, "zenoh#2557");
}

/// The issue's rogue router: a unit's certificate on the router's address. Our own
/// commands refuse to serve with it; a router that does anyway (Zenoh's own, configured by
/// hand) gets no client, because clients check the router's name and purpose.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_router_with_a_unit_s_certificate_gets_no_client() {
    let dir = tempfile::tempdir().unwrap();
    let pki = pki_init(dir.path(), "rail-tunnel");
    let port = firefleet_bus::free_loopback_port().unwrap();
    let endpoint = format!("quic/127.0.0.1:{port}");
    let ugv3 = pki.join("unit-ugv-1");
    let out = Command::new(BIN)
        .args([
            "coordinator",
            "--scenario",
            "rail-tunnel",
            "--mode",
            "router",
        ])
        .args(["--listen", &endpoint, "--tls-dir"])
        .arg(&ugv3)
        .output()
        .unwrap();
    assert_says(
        &out,
        2,
        "unit:ugv-1's certificate, but this process runs as a router",
    );
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", r#""router""#).unwrap();
    config
        .insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    config
        .insert_json5("listen/endpoints", &format!(r#"["{endpoint}"]"#))
        .unwrap();
    let link = firefleet_bus::mtls_link(&ugv3);
    config
        .insert_json5("transport/link/tls", &link.to_string())
        .unwrap();
    let rogue = zenoh::open(config).await.unwrap();
    let asked = std::sync::Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let count = asked.clone();
    let _answer = rogue
        .declare_queryable("ff/tunnel-r/coord/status")
        .callback(move |q| {
            count.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            tokio::spawn(async move {
                let _ = q.reply(q.key_expr().clone(), "{}").await;
            });
        })
        .await
        .unwrap();
    let rossi = pki.join("commander-rossi");
    let deadline = Instant::now() + Duration::from_secs(5);
    while Instant::now() < deadline {
        let out = status("rail-tunnel", Some(&rossi), &endpoint);
        assert!(
            !out.status.success(),
            "a rogue router answered: {}",
            text(&out)
        );
    }
    assert_eq!(
        asked.load(std::sync::atomic::Ordering::Relaxed),
        0,
        "a client's question reached the rogue router"
    );
    rogue.close().await.unwrap();
}

/// A second router issued into an existing PKI links to the first and serves the site's
/// clients; a revoked name keeps its link but loses every rule once the rules are
/// rendered again and the router restarted, as `firefleet pki revoke` says.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_router_joins_and_a_revoked_unit_loses_its_rules() {
    let dir = tempfile::tempdir().unwrap();
    let scenario = "vehicle-collision";
    let pki = pki_init(dir.path(), scenario);
    let out = crate::support::firefleet(&[
        "pki",
        "issue",
        "--pki",
        pki.to_str().unwrap(),
        "--role",
        "router",
        "--name",
        "b",
        "--host",
        "127.0.0.1",
        "--valid-days",
        "30",
    ]);
    assert_says(&out, 0, "router:b");
    let listed = crate::support::firefleet(&["pki", "list", "--pki", pki.to_str().unwrap()]);
    assert_says(&listed, 0, "router:b");
    assert!(text(&listed).contains("unit:ugv-2"), "{}", text(&listed));
    let (a, b) = (
        format!(
            "quic/127.0.0.1:{}",
            firefleet_bus::free_loopback_port().unwrap()
        ),
        format!(
            "quic/127.0.0.1:{}",
            firefleet_bus::free_loopback_port().unwrap()
        ),
    );
    let cfg = dir.path().join("cfg");
    let render = || {
        let out = crate::support::firefleet(&[
            "deploy",
            "render",
            "--scenario",
            scenario,
            "--pki",
            pki.to_str().unwrap(),
            "--out",
            cfg.to_str().unwrap(),
            "--commander",
            "rossi",
            "--simulated",
            "--listen",
            &a,
            "--connect",
            &a,
            "--router",
            &format!("b={b}"),
        ]);
        assert!(out.status.success(), "{}", text(&out));
    };
    render();
    let router = |name: &str| {
        Command::new(BIN)
            .args(["router", "--scenario", scenario, "--zenoh-config"])
            .arg(cfg.join(name))
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let routers = Fleet(vec![router("router.json5"), router("router-b.json5")]);
    // The coordinator on the first router answers a commander on the second.
    let _coordinator = Fleet(vec![
        Command::new(BIN)
            .args(["coordinator", "--scenario", scenario, "--zenoh-config"])
            .arg(cfg.join("coordinator.json5"))
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    ]);
    until_answered(
        scenario,
        &pki.join("commander-rossi"),
        &b,
        "a commander on the second router",
    );

    // ugv-2's files, as a thief would keep them.
    let stolen = dir.path().join("stolen");
    std::fs::create_dir(&stolen).unwrap();
    for f in ["ca.pem", "cert.pem", "key.pem"] {
        std::fs::copy(pki.join("unit-ugv-2").join(f), stolen.join(f)).unwrap();
    }
    let recorder = cfg.join("recorder.json5");
    let thief = open_tls(&stolen, &a).await;
    assert!(
        heard(thief, &recorder, &a).await,
        "ugv-2 was not heard before it was revoked"
    );

    let out = crate::support::firefleet(&[
        "pki",
        "revoke",
        "--pki",
        pki.to_str().unwrap(),
        "unit:ugv-2",
    ]);
    // The way to enforce it names every router of the site, not one.
    assert_says(
        &out,
        0,
        "router: install router.json5 in /etc/firefleet/, then systemctl restart firefleet-router\n",
    );
    assert_says(
        &out,
        0,
        "router:b: install router-b.json5 in /etc/firefleet/, then systemctl restart firefleet-router@b",
    );
    render();
    let rules = std::fs::read_to_string(cfg.join("router.json5")).unwrap();
    assert!(!rules.contains("unit:ugv-2"), "a revoked name kept a rule");
    assert!(!cfg.join("unit-ugv-2.json5").exists());
    let out = crate::support::firefleet(&[
        "pki",
        "issue",
        "--pki",
        pki.to_str().unwrap(),
        "--role",
        "unit",
        "--name",
        "ugv-2",
    ]);
    assert_says(&out, 2, "revoked on");
    // The documented step: restart the routers with the new rules.
    drop(routers);
    let routers = Fleet(vec![router("router.json5"), router("router-b.json5")]);
    until_answered(
        scenario,
        &pki.join("commander-rossi"),
        &a,
        "the commander after the restart",
    );
    let thief = open_tls(&stolen, &a).await;
    assert!(
        !heard(thief, &recorder, &a).await,
        "a revoked unit was still heard"
    );
    drop(routers);
}

/// Whether a recorder (configuration `recorder`, on `endpoint`) hears the states `thief`
/// puts on ugv-2's key.
async fn heard(thief: Bus, recorder: &Path, endpoint: &str) -> bool {
    let ugv2 = UnitId::new("ugv-2").unwrap();
    let observer = open_as(recorder, &[endpoint]).await;
    let states = observer
        .subscribe::<UnitState>(&observer.keys().unit_state(&ugv2))
        .await
        .unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    for _ in 0..20 {
        thief
            .put(&thief.keys().unit_state(&ugv2), &forged_state(&ugv2))
            .await
            .unwrap();
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let got = tokio::time::timeout(Duration::from_secs(2), states.recv())
        .await
        .is_ok();
    thief.close().await;
    observer.close().await;
    got
}

/// A session from configuration `config`, connecting to `endpoints` only, once it links.
async fn open_as(config: &Path, endpoints: &[&str]) -> Bus {
    let connect = firefleet_bus::Connect {
        config_file: Some(config.to_owned()),
        connect: endpoints.iter().map(|e| (*e).to_owned()).collect(),
        ..Default::default()
    };
    join(&connect).await
}

/// A client session with the TLS identity in `dir` on `endpoint`, once it links.
async fn open_tls(dir: &Path, endpoint: &str) -> Bus {
    let connect = firefleet_bus::Connect {
        mode: Some(firefleet_bus::Mode::Client),
        connect: vec![endpoint.to_owned()],
        tls: Some(dir.to_owned()),
        ..Default::default()
    };
    join(&connect).await
}

async fn join(connect: &firefleet_bus::Connect) -> Bus {
    let site = firefleet_model::SiteId::new("tunnel-a").unwrap();
    let deadline = Instant::now() + patient(Duration::from_secs(60));
    loop {
        match Bus::open(connect, site.clone()).await {
            Ok(bus) => return bus,
            Err(e) if Instant::now() > deadline => panic!("never got in: {e}"),
            Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
        }
    }
}

/// A site deployed as `deploy/README.md` says: a PKI, the rendered access rules and a
/// router process enforcing them on a free loopback port.
struct SecureSite {
    dir: tempfile::TempDir,
    scenario: &'static str,
    endpoint: String,
    _router: Fleet,
}

impl SecureSite {
    fn new(scenario: &'static str) -> Self {
        Self::with_commanders(scenario, &["rossi"])
    }

    /// The site with these commanders' certificates.
    fn with_commanders(scenario: &'static str, commanders: &[&str]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        let path = |p: &str| dir.path().join(p).to_str().unwrap().to_owned();
        let cfg = path("cfg");
        let pki = crate::support::pki_init_for(dir.path(), scenario, commanders);
        let pki = pki.to_str().unwrap();
        let port = firefleet_bus::free_loopback_port().unwrap();
        let endpoint = format!("quic/127.0.0.1:{port}");
        let mut args = vec![
            "deploy",
            "render",
            "--scenario",
            scenario,
            "--pki",
            pki,
            "--out",
            &cfg,
            "--simulated",
            "--listen",
            &endpoint,
            "--connect",
            &endpoint,
        ];
        for c in commanders {
            args.extend(["--commander", c]);
        }
        let out = crate::support::firefleet(&args);
        assert!(out.status.success(), "{}", text(&out));
        let router = Command::new(BIN)
            .args(["router", "--scenario", scenario, "--zenoh-config"])
            .arg(dir.path().join("cfg/router.json5"))
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap();
        Self {
            dir,
            scenario,
            endpoint,
            _router: Fleet(vec![router]),
        }
    }

    /// The client configuration of identity `who` (`unit-ugv-1`, `commander-rossi`, ...).
    fn config(&self, who: &str) -> String {
        let p = self.dir.path().join(format!("cfg/{who}.json5"));
        p.to_str().unwrap().to_owned()
    }

    /// A role of the fleet as identity `who`.
    fn spawn(&self, who: &str, args: &[&str]) -> std::process::Child {
        Command::new(BIN)
            .args(args)
            .args([
                "--scenario",
                self.scenario,
                "--zenoh-config",
                &self.config(who),
            ])
            .env("RUST_LOG", "warn,zenoh=error")
            .stdin(std::process::Stdio::null())
            .stdout(std::process::Stdio::null())
            .spawn()
            .unwrap()
    }

    /// `firefleet suspend` as identity `who`, asking that `target` be suspended.
    fn suspend(&self, who: &str, target: &str) -> std::process::Output {
        Command::new(BIN)
            .args(["suspend", "--scenario", self.scenario, "--zenoh-config"])
            .arg(self.config(who))
            .args(["--identity", target, "--reason", "key stolen"])
            .output()
            .unwrap()
    }

    /// A session in this test as identity `who`, once the router takes it.
    async fn open(&self, who: &str) -> Bus {
        let connect = firefleet_bus::Connect {
            config_file: Some(self.config(who).into()),
            ..Default::default()
        };
        let site = firefleet_model::SiteId::new("tunnel-a").unwrap();
        let deadline = Instant::now() + patient(Duration::from_secs(60));
        loop {
            match Bus::open(&connect, site.clone()).await {
                Ok(bus) => return bus,
                Err(e) if Instant::now() > deadline => panic!("{who} never got in: {e}"),
                Err(_) => tokio::time::sleep(Duration::from_millis(200)).await,
            }
        }
    }
}

/// Whether `seen` (everything a recorder received) holds a sample on a key ending in
/// `tail` whose payload `is_forged` says is the attacker's.
fn got_through(
    seen: &[(String, zenoh::sample::SampleKind, Vec<u8>)],
    tail: &str,
    is_forged: impl Fn(&[u8]) -> bool,
) -> bool {
    seen.iter()
        .any(|(k, _, bytes)| k.ends_with(tail) && is_forged(bytes))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stolen_unit_certificate_cannot_stop_a_secure_fleet() {
    let site = SecureSite::new("vehicle-collision");
    let ugv1 = UnitId::new("ugv-1").unwrap();
    // What gets past the router is what a recorder hears.
    let observer = site.open("recorder").await;
    let keys = observer.keys().clone();
    let seen = observer
        .zenoh_session()
        .declare_subscriber(keys.all())
        .with(zenoh::handlers::FifoChannel::new(1_000_000))
        .await
        .unwrap();
    let truths = observer
        .subscribe::<SimTruth>(&keys.sim_truth())
        .await
        .unwrap();
    let thief = site.open("unit-ugv-2").await;
    let session = thief.zenoh_session();

    // Impostor liveliness (zenoh#1562: tokens passing a deny-all policy): the
    // coordinator's token and another unit's, before either exists.
    let _coord_token = session
        .liveliness()
        .declare_token(keys.expr(&Topic::CoordAlive(0)))
        .await
        .unwrap();
    let _unit_token = session
        .liveliness()
        .declare_token(keys.expr(&Topic::UnitAlive(ugv1.clone())))
        .await
        .unwrap();
    // Answers to the fire recall and the barred space, for whoever asks.
    let fake_fires = session
        .declare_queryable(keys.every_fire().as_str())
        .await
        .unwrap();
    let fake_coord = session.declare_queryable(keys.every_coord()).await.unwrap();
    let answer = tokio::spawn(async move {
        loop {
            tokio::select! {
                Ok(q) = fake_fires.recv_async() => {
                    let _ = q.reply(keys_fire99(), codec::encode(&forged_fire())).await;
                }
                Ok(q) = fake_coord.recv_async() => {
                    let key = q.key_expr().to_string();
                    let _ = q.reply(key, codec::encode(&BarredSpace { t: 1e6, spans: vec![] })).await;
                }
                else => break,
            }
        }
    });
    tokio::time::sleep(Duration::from_secs(1)).await;
    let alive = observer.tokens_alive(&keys.every_alive()).await.unwrap();
    assert!(alive.is_empty(), "impostor tokens got through: {alive:?}");

    let mut fleet = Fleet(vec![
        site.spawn("coordinator", &["coordinator", "--sim-clock"]),
        site.spawn("unit-ugv-1", &["agent", "--unit", "ugv-1"]),
        site.spawn("unit-ugv-2", &["agent", "--unit", "ugv-2"]),
    ]);
    fleet.0.push(site.spawn(
        "sim",
        &[
            "sim",
            "--time-scale",
            "4",
            "--wait-for-fleet",
            "30",
            "--wait-for-coordinator",
        ],
    ));
    // Once the fleet runs, every attack of the issue from ugv-2's stolen certificate.
    tokio::time::timeout(patient(Duration::from_secs(60)), truths.recv())
        .await
        .expect("the simulator never started");
    let forged_task = Task {
        unit: ugv1.clone(),
        epoch: u64::MAX,
        seq: u64::MAX,
        t: 0.0,
        kind: TaskKind::Standby,
    };
    thief
        .put(&keys.unit_task(&ugv1, 0), &forged_task)
        .await
        .unwrap();
    let evil = r#"{"id": "evil", "zone": "core", "goal": "monitor", "priority": 255}"#;
    for by in ["ugv-2", "rossi"] {
        session
            .put(format!("ff/tunnel-a/zone/core/goal/{by}"), evil)
            .await
            .unwrap();
        session
            .delete(format!("ff/tunnel-a/zone/core/goal/{by}"))
            .await
            .unwrap();
    }
    session
        .put(keys_fire99(), codec::encode(&forged_fire()))
        .await
        .unwrap();
    let mut spoofed = forged_state(&ugv1);
    thief.put(&keys.unit_state(&ugv1), &spoofed).await.unwrap();
    let drive = firefleet_protocol::msg::UnitCommand {
        speed: 3.21,
        steer: 0.5,
        pan: 0.0,
        tilt: 0.0,
        valve_open: false,
    };
    for _ in 0..200 {
        thief.put(&keys.sim_cmd(&ugv1), &drive).await.unwrap();
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Its own keys are the application's to check: a state with an impossible heading.
    let ugv2 = UnitId::new("ugv-2").unwrap();
    spoofed.unit = ugv2.clone();
    spoofed.pose.yaw = 1e308;
    session
        .put(keys.unit_state(&ugv2).as_str(), codec::encode(&spoofed))
        .await
        .unwrap();
    // A unit may not ask for the incident's status (of anyone but its own queryable).
    let replies = session
        .get(keys.expr(&Topic::CoordStatus))
        .allowed_destination(zenoh::sample::Locality::Remote)
        .timeout(Duration::from_secs(2))
        .await
        .unwrap();
    assert!(
        !matches!(replies.recv_async().await, Ok(r) if r.result().is_ok()),
        "a unit was answered the status"
    );

    // A commander's certificate sets a goal under its own name; under another's the router
    // would drop it unanswered, which the tool says before sending it.
    let goal = |by: &str| {
        Command::new(BIN)
            .args(["goal", "set", "--scenario", site.scenario, "--zenoh-config"])
            .arg(site.config("commander-rossi"))
            .args(["--zone", "far", "--goal", "extinguish", "--priority", "1"])
            .args(["--issued-by", by])
            .output()
            .unwrap()
    };
    assert_says(&goal("rossi"), 0, "accepted");
    let refused = goal("bianchi");
    assert!(
        !refused.status.success()
            && text(&refused).contains(
                "commander:rossi: the site's router takes goals from it only as --issued-by rossi"
            ),
        "{}",
        text(&refused)
    );
    // No certificate: no link.
    let plain = cli(
        site.scenario,
        &site.endpoint.replace("quic/", "tcp/"),
        &["status"],
    );
    assert!(!plain.status.success());

    let truth = outcome(&truths, Duration::from_secs(120)).await;
    assert!(
        truth.all_out(),
        "the fleet lost to a stolen certificate: {truth:?}"
    );
    let mut seen_all = Vec::new();
    while let Ok(Some(s)) = seen.try_recv() {
        seen_all.push((
            s.key_expr().to_string(),
            s.kind(),
            s.payload().to_bytes().to_vec(),
        ));
    }
    assert!(!got_through(&seen_all, "unit/ugv-1/task", |b| {
        codec::decode::<Task>(b).is_ok_and(|t| t.seq == u64::MAX)
    }));
    assert!(!got_through(&seen_all, "goal/ugv-2", |_| true));
    assert!(!seen_all.iter().any(|(k, kind, _)| {
        k.ends_with("goal/rossi") && *kind == zenoh::sample::SampleKind::Delete
    }));
    assert!(!got_through(&seen_all, "goal/rossi", |b| {
        String::from_utf8_lossy(b).contains("evil")
    }));
    assert!(!got_through(&seen_all, "fire/f99", |_| true));
    assert!(!got_through(&seen_all, "unit/ugv-1/state", |b| {
        codec::decode::<UnitState>(b).is_ok_and(|s| s.water_l == 4321.0)
    }));
    assert!(!got_through(&seen_all, "sim/unit/ugv-1/cmd", |b| {
        codec::decode::<firefleet_protocol::msg::UnitCommand>(b).is_ok_and(|c| c.speed == 3.21)
    }));
    assert!(
        seen_all
            .iter()
            .any(|(k, _, _)| k.ends_with("unit/ugv-1/state")),
        "the recorder heard nothing of the real fleet"
    );
    // The coordinator's recall and the units' barred space were answered only by those
    // allowed to: the thief's queryables got no question.
    let coordinator = site.open("coordinator").await;
    let every = Ask {
        every_answer: true,
        ..Ask::within(Duration::from_secs(2))
    };
    let answers = coordinator
        .ask(keys.every_fire().as_str(), every)
        .await
        .unwrap();
    while let Some(answer) = answers.recv().await {
        assert!(!answer.key.ends_with("f99"), "a forged fire was answered");
    }
    let commander = site.open("commander-rossi").await;
    let status = status_of(&commander, Duration::from_secs(10)).await;
    assert!(
        status["rejected"]["invalid"].as_u64().unwrap_or(0) >= 1,
        "the impossible state of the thief's own unit was not refused: {status}"
    );
    assert!(!status["goals"].to_string().contains("evil"), "{status}");
    answer.abort();
    for b in [thief, observer, coordinator, commander] {
        b.close().await;
    }
}

fn keys_fire99() -> String {
    "ff/tunnel-a/fire/f99".to_owned()
}

fn forged_fire() -> FireTrack {
    FireTrack {
        id: FireId(99),
        t: 1e6,
        position: Point2::new(150.0, 0.0),
        cov: [0.3, 0.0, 0.3],
        confidence: 1.0,
        state: FireState::Out,
        assigned: Vec::new(),
        seen_by: vec![UnitId::new("ugv-2").unwrap()],
        hrr_kw: None,
    }
}

fn forged_state(unit: &UnitId) -> UnitState {
    UnitState {
        t: 1.0,
        ..UnitState::idle(
            unit.clone(),
            firefleet_model::UnitKind::Ground,
            Pose2::new(20.0, 0.0, 0.0),
            4321.0,
        )
    }
}

/// Issue #52's first finding, and its "done when": a stolen recorder key answers a
/// restarted coordinator's recall with goals nobody sealed, a goal changed under its
/// issuer's seal, and a goal its issuer had cleared (sealed, so it is a perfect replay),
/// in a set dated now that leaves out a goal still in force, and fire tracks the
/// coordinator never sealed. The coordinator takes back only the goal in force.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stolen_recorder_key_cannot_forge_replay_or_lift_goals_at_recall() {
    use firefleet_protocol::msg::{GoalInForce, GoalKind, GoalsInForce};
    let site = SecureSite::new("vehicle-collision");
    let state = site.dir.path().join("coordinator-state");
    let coordinator = || {
        site.spawn(
            "coordinator",
            &["coordinator", "--state-dir", state.to_str().unwrap()],
        )
    };
    let mut fleet = Fleet(vec![coordinator()]);
    let thief = site.open("recorder").await;
    let keys = thief.keys().clone();
    let published = thief.subscribe(&keys.coord_goals()).await.unwrap();
    let goal = |args: &[&str]| {
        Command::new(BIN)
            .args([
                "goal",
                args[0],
                "--scenario",
                site.scenario,
                "--zenoh-config",
            ])
            .arg(site.config("commander-rossi"))
            .args(&args[1..])
            .output()
            .unwrap()
    };
    let deadline = Instant::now() + patient(Duration::from_secs(30));
    while !goal(&["set", "--zone", "far", "--goal", "keep-out"])
        .status
        .success()
    {
        assert!(
            Instant::now() < deadline,
            "the coordinator never took a goal"
        );
    }
    assert_says(
        &goal(&["set", "--zone", "core", "--goal", "monitor"]),
        0,
        "accepted",
    );
    // What the coordinator published with both in force, seals and all.
    let both = loop {
        let (_, g) = tokio::time::timeout(patient(Duration::from_secs(10)), published.recv())
            .await
            .expect("no goals published")
            .unwrap();
        if g.goals.len() == 2 {
            break g;
        }
    };
    assert!(both.goals.iter().all(|g| g.proof.is_some()), "{both:?}");
    assert!(goal(&["clear", "--zone", "far"]).status.success());
    let commander = site.open("commander-rossi").await;
    let deadline = Instant::now() + patient(Duration::from_secs(10));
    while status_of(&commander, Duration::from_secs(5)).await["goals"]
        .as_array()
        .map_or(0, Vec::len)
        != 1
    {
        assert!(Instant::now() < deadline, "the clear was not taken");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    for c in &mut fleet.0 {
        c.kill().unwrap();
        c.wait().unwrap();
    }

    let of = |zone: &str| -> GoalInForce {
        both.goals
            .iter()
            .find(|g| g.goal.zone.as_str() == zone)
            .unwrap()
            .clone()
    };
    let replayed = of("far");
    let changed = GoalInForce {
        goal: firefleet_protocol::msg::ZoneGoal {
            goal: GoalKind::Evacuate,
            ..of("core").goal
        },
        ..of("core")
    };
    let unsealed = GoalInForce {
        goal: firefleet_protocol::msg::ZoneGoal {
            id: "forged-portal".into(),
            zone: firefleet_model::ZoneId::new("portal").unwrap(),
            ..replayed.goal.clone()
        },
        proof: None,
        ..replayed.clone()
    };
    let now = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_secs_f64();
    let forged = GoalsInForce {
        t: now,
        goals: vec![replayed, changed, unsealed],
        ..GoalsInForce::default()
    };
    let answers = thief
        .zenoh_session()
        .declare_queryable(keys.coord_goals().as_str())
        .await
        .unwrap();
    // And a fire that never was, with the recorder's own seal, and another with none: the
    // coordinator seals the tracks it puts, and a recall takes only those.
    let fires = thief.serve(keys.every_fire().as_str()).await.unwrap();
    let bytes = codec::encode(&forged_fire());
    let sealed = firefleet_bus::Raw {
        key: keys_fire99(),
        deleted: false,
        attachment: Some(
            thief
                .seals()
                .unwrap()
                .sealer
                .seal(&keys_fire99(), Some(&bytes))
                .to_attachment(),
        ),
        bytes,
    };
    let unsealed = firefleet_bus::Raw {
        key: keys_fire99().replace("f99", "f98"),
        attachment: None,
        ..sealed.clone()
    };
    let answering = tokio::spawn(async move {
        loop {
            tokio::select! {
                Ok(q) = answers.recv_async() => {
                    let _ = q.reply(q.key_expr().clone(), codec::encode(&forged)).await;
                }
                Some(q) = fires.recv() => {
                    for forged in [&sealed, &unsealed] {
                        let _ = q.answer_as_heard(forged).await;
                    }
                }
                else => break,
            }
        }
    });
    fleet.0.push(coordinator());
    // Its first answer after the restart is what it took back.
    let status = status_of(&commander, Duration::from_secs(30)).await;
    let ids: Vec<&str> = status["goals"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["rossi-core-monitor"], "{status}");
    assert_eq!(status["goals"][0]["goal"], "monitor", "{status}");
    assert_eq!(status["fires"], serde_json::json!([]), "{status}");
    // The changed and the unsealed goal refused for their seals, the replay by its clear,
    // and both fire tracks for theirs.
    assert!(
        status["rejected"]["seal"].as_u64() >= Some(4),
        "{}",
        status["rejected"]
    );
    answering.abort();
    for b in [thief, commander] {
        b.close().await;
    }
}

/// Issue #52, item 3: a goal sealed with the console's key that the console never sent.
/// The coordinator takes it (the console speaks for any commander), and the console,
/// which hears its own goal keys, raises "someone else holds the key of console" within
/// 2 s.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_goal_sealed_with_the_console_s_stolen_key_raises_the_impostor_alarm() {
    use firefleet_bus::goal;
    use firefleet_protocol::msg::{GoalKind, ZoneGoal};
    let site = SecureSite::new("vehicle-collision");
    let addr = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let _fleet = Fleet(vec![
        site.spawn("coordinator", &["coordinator"]),
        site.spawn("console", &["console", "--http", &addr]),
    ]);
    console_linked(&addr).await;
    let thief = site.open("console").await;
    let rossi = firefleet_model::CommanderId::new("rossi").unwrap();
    let keep_out = ZoneGoal::new(
        firefleet_model::ZoneId::new("far").unwrap(),
        GoalKind::KeepOut,
        rossi.clone(),
    );
    let ack = goal::issue(&thief, &keep_out, &rossi, goal::ACK_TIMEOUT)
        .await
        .unwrap();
    assert!(ack.accepted, "{ack:?}");
    let (alarm, took) = console_alarm(&addr, "impostor").await;
    println!("impostor alarm on the console {took:.2} s after the coordinator's ack");
    assert_eq!(alarm["priority"], 1, "{alarm}");
    assert_eq!(alarm["active"], true, "{alarm}");
    assert!(
        alarm["text"]
            .as_str()
            .unwrap()
            .contains("someone else holds the key of console"),
        "{alarm}"
    );
    thief.close().await;
}

/// Issue #52, item 4: a stolen commander key's keep-outs, cut off in band. One
/// commander's ask suspends nobody; the operator's at the coordinator's host (its key)
/// does: the commander's goals lapse at once, its further goals are refused, `status`
/// shows it, and a restarted coordinator keeps the suspension.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stolen_commander_key_is_suspended_in_band_and_stays_so_across_a_restart() {
    let site = SecureSite::new("vehicle-collision");
    let state = site.dir.path().join("coordinator-state");
    let coordinator = || {
        site.spawn(
            "coordinator",
            &["coordinator", "--state-dir", state.to_str().unwrap()],
        )
    };
    let mut fleet = Fleet(vec![coordinator()]);
    let cli = |who: &str, args: &[&str]| {
        Command::new(BIN)
            .args([args[0], args[1]])
            .args(["--scenario", site.scenario, "--zenoh-config"])
            .arg(site.config(who))
            .args(&args[2..])
            .output()
            .unwrap()
    };
    // The thief, with rossi's key, bars both zones the fleet works in.
    let deadline = Instant::now() + patient(Duration::from_secs(30));
    while !cli(
        "commander-rossi",
        &["goal", "set", "--zone", "far", "--goal", "keep-out"],
    )
    .status
    .success()
    {
        assert!(
            Instant::now() < deadline,
            "the coordinator never took a goal"
        );
    }
    assert_says(
        &cli(
            "commander-rossi",
            &["goal", "set", "--zone", "core", "--goal", "keep-out"],
        ),
        0,
        "accepted",
    );
    let suspend = |who: &str| site.suspend(who, "commander:rossi");
    // One commander alone (rossi itself, who noticed) suspends nobody.
    assert_says(&suspend("commander-rossi"), 0, "a second commander's ask");
    let watcher = site.open("recorder").await;
    let goals = watcher
        .subscribe(&watcher.keys().coord_goals())
        .await
        .unwrap();
    // The operator, with the coordinator's own files.
    let asked = Instant::now();
    assert_says(&suspend("coordinator"), 0, "commander:rossi is suspended");
    loop {
        let (_, g) = tokio::time::timeout(patient(Duration::from_secs(5)), goals.recv())
            .await
            .expect("no goals published")
            .unwrap();
        if g.goals.is_empty() {
            assert_eq!(g.suspensions.len(), 2, "both asks kept: {g:?}");
            break;
        }
    }
    println!(
        "rossi's keep-outs lapsed {:.2} s after the operator's ask",
        asked.elapsed().as_secs_f64()
    );
    assert_says(
        &cli(
            "commander-rossi",
            &["goal", "set", "--zone", "far", "--goal", "monitor"],
        ),
        1,
        "is suspended",
    );
    // A restart keeps it: the journal holds the asks, checked again.
    for c in &mut fleet.0 {
        c.kill().unwrap();
        c.wait().unwrap();
    }
    fleet.0.push(coordinator());
    let commander = site.open("commander-rossi").await;
    let status = status_of(&commander, Duration::from_secs(30)).await;
    assert_eq!(
        status["suspended"],
        serde_json::json!(["commander-rossi"]),
        "{status}"
    );
    assert_eq!(status["goals"], serde_json::json!([]), "{status}");
    for b in [watcher, commander] {
        b.close().await;
    }
}

/// Issue #52, items 2 to 4, for the coordinators' keys. A thief holding the standby's key
/// (`coordinator:1`) claims office and tasks a unit in a newer term: the unit refuses (the
/// lowest rank holds office), the coordinator in office stays in office, and the console
/// raises "rival coordinator" within 2 s. Then a thief holding the key of the coordinator
/// in office tasks on its key: the coordinator hears tasks it never sent, and the console
/// raises "someone else holds the key of coordinator" within 2 s. Two commanders suspend
/// that identity: the standby takes office, the unit obeys it, and the thief's next task
/// is refused.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stolen_coordinator_keys_command_nobody_or_are_alarmed_and_suspended() {
    let site = SecureSite::with_commanders("vehicle-collision", &["rossi", "bianchi"]);
    let addr = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let mut fleet = Fleet(vec![
        site.spawn("coordinator", &["coordinator", "--sim-clock"]),
        site.spawn(
            "coordinator-1",
            &["coordinator", "--sim-clock", "--standby", "--rank", "1"],
        ),
        site.spawn("console", &["console", "--http", &addr]),
        site.spawn("unit-ugv-1", &["agent", "--unit", "ugv-1"]),
        site.spawn("unit-ugv-2", &["agent", "--unit", "ugv-2"]),
    ]);
    fleet.0.push(site.spawn(
        "sim",
        &[
            "sim",
            "--time-scale",
            "2",
            "--wait-for-fleet",
            "30",
            "--wait-for-coordinator",
        ],
    ));
    let rival = site.open("coordinator-1").await;
    // What ugv-1 is told and does, heard all along as a recorder hears it.
    let watcher = site.open("recorder").await;
    let keys = rival.keys().clone();
    let ugv1 = UnitId::new("ugv-1").unwrap();
    let tasks = watcher.subscribe(&keys.unit_tasks(&ugv1)).await.unwrap();
    let states = watcher.subscribe(&keys.unit_state(&ugv1)).await.unwrap();
    let (_, real) = tokio::time::timeout(patient(Duration::from_secs(90)), tasks.recv())
        .await
        .expect("the coordinator never tasked ugv-1")
        .unwrap();
    console_linked(&addr).await;

    // The standby's stolen key: a lease of rank 1 and a task of a newer term of its rank.
    let _claim = rival.token(&Topic::CoordAlive(1)).await.unwrap();
    let forged = Task {
        epoch: epoch_after(real.seq + 100, 1),
        seq: epoch_after(real.seq + 100, 1),
        kind: TaskKind::Standby,
        ..real.clone()
    };
    rival.put(&keys.unit_task(&ugv1, 1), &forged).await.unwrap();
    let (alarm, took) = console_alarm(&addr, "rival-coordinator").await;
    assert_eq!(alarm["priority"], 1, "{alarm}");
    assert!(
        alarm["text"]
            .as_str()
            .unwrap()
            .starts_with("coordinator:1 claims office while coordinator holds it"),
        "{alarm}"
    );
    println!("rival coordinator alarm on the console {took:.2} s after the claim");
    // The unit keeps obeying the coordinator in office, which keeps tasking it.
    let until = Instant::now() + Duration::from_secs(3);
    let mut heard_real = false;
    while Instant::now() < until {
        tokio::select! {
            Some((_, st)) = states.recv() => assert_ne!(st.epoch, Some(forged.epoch), "ugv-1 obeyed the rival"),
            Some((topic, t)) = tasks.recv() => heard_real |= topic == Topic::UnitTask(ugv1.clone(), 0) && t.epoch == real.epoch,
            _ = tokio::time::sleep(Duration::from_millis(100)) => {}
        }
    }
    assert!(
        heard_real,
        "the coordinator in office stopped tasking ugv-1"
    );
    rival.close().await;

    // The key of the coordinator in office: tasks on its own key that it never sent.
    let thief = site.open("coordinator").await;
    let mut stolen = real.clone();
    stolen.seq = real.seq + 1;
    stolen.kind = TaskKind::Standby;
    thief
        .put(&thief.keys().unit_task(&ugv1, 0), &stolen)
        .await
        .unwrap();
    let (alarm, took) = console_alarm(&addr, "impostor").await;
    assert_eq!(alarm["priority"], 1, "{alarm}");
    assert!(
        alarm["text"]
            .as_str()
            .unwrap()
            .starts_with("someone else holds the key of coordinator:"),
        "{alarm}"
    );
    println!("impostor alarm on the console {took:.2} s after the stolen coordinator key's task");
    // Two commanders suspend the stolen identity: the standby takes office, and ugv-1
    // obeys it.
    let suspend = |who: &str| site.suspend(who, "coordinator");
    assert_says(&suspend("commander-rossi"), 0, "a second commander's ask");
    let asked = Instant::now();
    assert_says(&suspend("commander-bianchi"), 0, "coordinator is suspended");
    let took_office = tokio::time::timeout(patient(Duration::from_secs(20)), async {
        loop {
            let (_, st) = states.recv().await.unwrap();
            if st.epoch.is_some_and(|e| e % 16 == 1) {
                return asked.elapsed().as_secs_f64();
            }
        }
    })
    .await
    .expect("ugv-1 never obeyed the standby");
    println!("ugv-1 obeyed the standby {took_office:.2} s after the second ask");
    // The thief's lease and task on the suspended key, numbered above everything: the
    // standby stays in office, and the task is refused.
    let _claim = thief.token(&Topic::CoordAlive(0)).await.unwrap();
    let mut last = stolen.clone();
    last.epoch = epoch_after(real.seq + 1000, 0);
    last.seq = last.epoch;
    thief
        .put(&thief.keys().unit_task(&ugv1, 0), &last)
        .await
        .unwrap();
    let until = Instant::now() + Duration::from_secs(3);
    while Instant::now() < until {
        if let Ok(Some((_, st))) =
            tokio::time::timeout(Duration::from_millis(200), states.recv()).await
        {
            assert!(
                st.epoch.is_none_or(|e| e % 16 == 1),
                "ugv-1 obeyed the suspended key: {st:?}"
            );
        }
    }
    for b in [thief, watcher] {
        b.close().await;
    }
}

/// Wait until the console at `addr` has its link to the site.
async fn console_linked(addr: &str) {
    let deadline = Instant::now() + patient(Duration::from_secs(60));
    while crate::support::get_json(addr, "/api/incident").is_none_or(|i| i["link"] != true) {
        assert!(Instant::now() < deadline, "the console never linked");
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// The console's first alarm of `kind`, and the seconds it took to show from now;
/// fails past 2 s (the issue's bound).
async fn console_alarm(addr: &str, kind: &str) -> (serde_json::Value, f64) {
    let from = Instant::now();
    loop {
        let inc = crate::support::get_json(addr, "/api/incident").unwrap_or_default();
        if let Some(a) = inc["alerts"]
            .as_array()
            .and_then(|a| a.iter().find(|a| a["kind"] == kind).cloned())
        {
            return (a, from.elapsed().as_secs_f64());
        }
        assert!(
            from.elapsed() < patient(Duration::from_secs(2)),
            "no {kind} alarm: {}",
            inc["alerts"]
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}
