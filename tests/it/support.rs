//! The process harness the end-to-end tests share: the `firefleet` binary, a router owned
//! by the test, roles started as client processes, one-shot commands against them.
//!
//! Every module of the test binary uses part of it.
#![allow(dead_code)]

use std::process::{Child, Command, Output, Stdio};

use std::time::{Duration, Instant};

use firefleet::children::RoleCommand;
use firefleet_bus::{Ask, Bus, Connect, Inbox, Mode, free_loopback_port};
use firefleet_model::SiteId;
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::SimTruth;

pub const BIN: &str = env!("CARGO_BIN_EXE_firefleet");

/// Child processes, killed when the test ends, pass or fail.
pub struct Fleet(pub Vec<Child>);

impl Drop for Fleet {
    fn drop(&mut self) {
        for c in &mut self.0 {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `firefleet ARGS` run from the repository root, to completion.
pub fn firefleet(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

/// `firefleet ARGS`, which must succeed (else the test fails with what it said).
pub fn firefleet_ok(args: &[&str]) {
    let out = firefleet(args);
    assert!(out.status.success(), "{args:?}: {}", text(&out));
}

/// Standard output and standard error, as text.
pub fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `firefleet ARGS` as a client of the router at `endpoint`, on `scenario`'s site; it logs
/// warnings, or what `FF_TEST_LOG` says (e.g. `info,zenoh=error` to follow a fleet test's
/// decisions).
fn client(scenario: &str, endpoint: &str, args: &[&str]) -> Command {
    let (role, own) = args.split_first().expect("a command");
    let role = RoleCommand::new(role)
        .args(own)
        .scenario(scenario)
        .client_of(endpoint);
    let mut c = Command::new(BIN);
    c.args(role.to_args()).env(
        "RUST_LOG",
        std::env::var("FF_TEST_LOG").unwrap_or("warn,zenoh=error".into()),
    );
    c
}

/// Start one role of the fleet as a client of the test's router at `endpoint`.
pub fn spawn_role(scenario: &str, endpoint: &str, args: &[&str]) -> Child {
    client(scenario, endpoint, args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .spawn()
        .unwrap()
}

/// Start a long-running command as a client of the router at `endpoint`, its standard
/// output read line by line into the receiver.
pub fn spawn_watched(
    scenario: &str,
    endpoint: &str,
    args: &[&str],
) -> (Child, std::sync::mpsc::Receiver<String>) {
    use std::io::BufRead as _;
    let mut child = client(scenario, endpoint, args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .spawn()
        .unwrap();
    let out = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(out).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                return;
            }
        }
    });
    (child, rx)
}

/// Wait for a line containing `needle` (the lines before it are passed over).
pub fn until_line(lines: &std::sync::mpsc::Receiver<String>, needle: &str, within: Duration) {
    let deadline = Instant::now() + patient(within);
    let mut seen = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match lines.recv_timeout(left) {
            Ok(line) if line.contains(needle) => return,
            Ok(line) => seen.push(line),
            Err(_) => {
                let tail = seen[seen.len().saturating_sub(20)..].join("\n");
                panic!("no line with {needle:?} within {within:?}; the last:\n{tail}")
            }
        }
    }
}

/// Run a one-shot command against the router at `endpoint` on `scenario`'s site.
pub fn cli(scenario: &str, endpoint: &str, args: &[&str]) -> Output {
    client(scenario, endpoint, args).output().unwrap()
}

/// A Zenoh router owned by the test on a free loopback port for `site`, and its endpoint.
pub async fn router(site: &str) -> (Bus, String) {
    // A port found free may be taken by another test's process before this router binds
    // it (every test binary runs at once): another port is tried then.
    let mut last = None;
    for _ in 0..5 {
        let endpoint = free_endpoint();
        match open_router(site, &endpoint).await {
            Ok(bus) => return (bus, endpoint),
            Err(e) => last = Some(e),
        }
    }
    panic!("no free port for the test's router: {last:?}")
}

/// `tcp/127.0.0.1:PORT` on a port nothing listens on.
pub fn free_endpoint() -> String {
    format!("tcp/127.0.0.1:{}", free_loopback_port().unwrap())
}

/// A Zenoh router owned by the test, listening on `endpoint` for `site`.
pub async fn router_at(site: &str, endpoint: &str) -> Bus {
    open_router(site, endpoint).await.unwrap()
}

async fn open_router(site: &str, endpoint: &str) -> Result<Bus, firefleet_bus::BusError> {
    let router = Connect {
        mode: Some(Mode::Router),
        listen: vec![endpoint.to_owned()],
        ..Connect::default()
    };
    Bus::open(&router, SiteId::new(site).unwrap()).await
}

/// Asserts that `out` exited with `code` and that what it printed says `needle`.
pub fn assert_says(out: &Output, code: i32, needle: &str) {
    let t = text(out);
    assert_eq!(out.status.code(), Some(code), "{t}");
    assert!(t.contains(needle), "expected {needle:?} in: {t}");
}

/// `firefleet ARGS --json FILE`, which must succeed: the JSON it wrote.
pub fn json_of(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.json");
    let out = firefleet(&[args, &["--json", path.to_str().unwrap()]].concat());
    assert!(out.status.success(), "{}", text(&out));
    serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap()
}

/// A wall-clock wait for something the fleet's processes must do (join, answer, put a fire
/// out), times `FIREFLEET_TEST_PATIENCE` (a number, default 1): on a loaded machine (two
/// cores, every test binary at once) the processes take longer, and a deadline that only
/// guards against a hang can be given more without weakening any test. Windows in which
/// something must *not* happen are not scaled.
pub fn patient(d: std::time::Duration) -> std::time::Duration {
    let factor = std::env::var("FIREFLEET_TEST_PATIENCE")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
        .filter(|f| f.is_finite() && *f >= 1.0)
        .unwrap_or(1.0);
    d.mul_f64(factor)
}

/// The ground truth once every fire is out or the time limit is reached.
pub async fn outcome(truths: &Inbox<SimTruth>, within: Duration) -> SimTruth {
    tokio::time::timeout(patient(within), async {
        loop {
            let (_, t) = truths.recv().await.expect("bus open");
            if t.all_out() || t.t >= t.time_limit_s {
                return t;
            }
        }
    })
    .await
    .expect("no outcome before the wall-clock deadline")
}

/// The first answer to a query on `key` that `take` accepts, asking again until one comes
/// (or `within` passes).
pub async fn first_answer<T>(
    bus: &Bus,
    key: &str,
    within: Duration,
    take: impl Fn(&[u8]) -> Option<T>,
) -> T {
    tokio::time::timeout(patient(within), async {
        loop {
            let answers = bus
                .ask(key, Ask::within(Duration::from_secs(10)))
                .await
                .unwrap();
            while let Some(answer) = answers.recv().await {
                if let Some(v) = take(&answer.bytes) {
                    return v;
                }
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    })
    .await
    .unwrap_or_else(|_| panic!("no answer on {key}"))
}

/// The coordinator's status, queried over the bus until one answers (or `within` passes).
pub async fn status_of(bus: &Bus, within: Duration) -> serde_json::Value {
    let key = bus.keys().expr(&Topic::CoordStatus);
    first_answer(bus, &key, within, |b| serde_json::from_slice(b).ok()).await
}

/// Wait until the recording at `path` (its file, or the parts a recorder writes out as it
/// goes) holds a message on a key ending in `key_tail` whose JSON contains `needle`: what
/// a later step reads back from the file is in it. Panics after `within` (patient).
pub async fn until_in_recording(
    path: &std::path::Path,
    key_tail: &str,
    needle: &str,
    within: Duration,
) {
    let deadline = std::time::Instant::now() + patient(within);
    loop {
        let held = firefleet_recorder::parts::Recording::load(path).is_ok_and(|r| {
            r.messages().flatten().any(|m| {
                m.channel.topic.ends_with(key_tail)
                    && String::from_utf8_lossy(&m.data).contains(needle)
            })
        });
        if held {
            return;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "{} never held {key_tail} with {needle:?}",
            path.display()
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// Wait until the simulator's clock on `bus` reads `t` s of site time or more. Panics
/// after `within` (patient).
pub async fn until_site_time(bus: &Bus, t: f64, within: Duration) {
    let clock = bus
        .subscribe::<firefleet_protocol::msg::SimClock>(&bus.keys().sim_clock())
        .await
        .unwrap();
    tokio::time::timeout(patient(within), async {
        loop {
            match clock.recv().await {
                Some((_, c)) if c.t >= t => return,
                Some(_) => {}
                None => panic!("bus closed"),
            }
        }
    })
    .await
    .unwrap_or_else(|_| panic!("site time never reached {t} s"));
}

/// `firefleet pki init` for `scenario` into `dir/pki`, with commander rossi; the PKI.
pub fn pki_init(dir: &std::path::Path, scenario: &str) -> std::path::PathBuf {
    pki_init_for(dir, scenario, &["rossi"])
}

/// [`pki_init`] with these commanders.
pub fn pki_init_for(
    dir: &std::path::Path,
    scenario: &str,
    commanders: &[&str],
) -> std::path::PathBuf {
    let pki = dir.join("pki");
    let mut args = vec![
        "pki",
        "init",
        "--scenario",
        scenario,
        "--out",
        pki.to_str().unwrap(),
    ];
    for c in commanders {
        args.extend(["--commander", c]);
    }
    let out = firefleet(&args);
    assert!(out.status.success(), "{}", text(&out));
    pki
}

/// `GET path` from `addr` over plain HTTP/1.0 (never a chunked body): the status code and
/// the body (0 and nothing if nothing answers).
pub fn http_get(addr: &str, path: &str) -> (u16, String) {
    use std::io::{Read, Write};
    let Ok(mut s) = std::net::TcpStream::connect(addr) else {
        return (0, String::new());
    };
    s.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    write!(s, "GET {path} HTTP/1.0\r\nHost: {addr}\r\n\r\n").unwrap();
    let mut reply = String::new();
    if s.read_to_string(&mut reply).is_err() {
        return (0, String::new());
    }
    let code = reply
        .split_whitespace()
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    let body = reply.split_once("\r\n\r\n").map_or("", |(_, b)| b);
    (code, body.to_owned())
}

/// One GET of the console's API, the body as JSON.
pub fn get_json(addr: &str, path: &str) -> Option<serde_json::Value> {
    serde_json::from_str(&http_get(addr, path).1).ok()
}
