//! The console's logins under attack (issue #34): `cargo bench -p firefleet-console --bench
//! login_attack`.
//!
//! In this order, so that the memory figures are the console's, not the timing's:
//!
//! 1. A crowd of bad logins: the console served on loopback as `firefleet console` serves
//!    it, 64 clients each sending 50 logins with a wrong password, each on its own
//!    connection; how many were throttled (429), how many checked (401), and the process's
//!    resident memory before and at its peak. The target: under 200 MB.
//! 2. What a login's answer time tells: the median time of 100 password checks each for a
//!    known name with a wrong short password, a known name with a wrong long one, and an
//!    unknown name ([`Users::verify`], which the login handler runs once per attempt). The
//!    target: known and unknown within 5 ms of each other.
//!
//! Prints a table; no timed assertions.

#![allow(clippy::print_stdout, reason = "a bench binary prints its table")]

use std::sync::Arc;
use std::time::{Duration, Instant};

use firefleet_console::auth::{Role, Sessions, Users};
use firefleet_console::http::{Console, Peer, Serving};
use firefleet_console::picture::Picture;
use firefleet_console::site::SiteMap;
use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;
use tokio::io::{AsyncReadExt, AsyncWriteExt};

const CLIENTS: usize = 64;
const ATTEMPTS: usize = 50;

/// `VmRSS` and `VmHWM` of this process, MB.
fn memory_mb() -> (f64, f64) {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    let field = |name: &str| {
        status
            .lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.split_whitespace().nth(1))
            .and_then(|kb| kb.parse::<f64>().ok())
            .map_or(f64::NAN, |kb| kb / 1024.0)
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn median_ms(mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..100)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[50]
}

async fn attempt(addr: std::net::SocketAddr, k: usize) -> u16 {
    let body = format!(r#"{{"name":"rossi","password":"guess number {k}"}}"#);
    let request = format!(
        "POST /api/login HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let Ok(mut tcp) = tokio::net::TcpStream::connect(addr).await else {
        return 0;
    };
    if tcp.write_all(request.as_bytes()).await.is_err() {
        return 0;
    }
    let mut answer = Vec::new();
    let _ = tcp.read_to_end(&mut answer).await;
    std::str::from_utf8(&answer)
        .ok()
        .and_then(|a| a.split_whitespace().nth(1))
        .and_then(|s| s.parse().ok())
        .unwrap_or(0)
}

fn main() {
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join("users.toml");
    let rossi = CommanderId::new("rossi").expect("a name");
    Users::add(&path, rossi, "correct horse battery", Role::Commander).expect("a users file");
    let users = Users::load(&path).expect("the users file");

    let runtime = tokio::runtime::Runtime::new().expect("a runtime");
    runtime.block_on(async move {
        let text = include_str!("../../model/scenarios/rail-tunnel.toml");
        let scenario = Scenario::from_toml(text, "rail-tunnel.toml").expect("the scenario");
        let (console, _requests) = Console::new(
            Picture::new(SiteMap::new(&scenario)),
            users,
            Sessions::new(Duration::from_secs(3600)),
            Serving {
                secure: false,
                open_reads: false,
            },
            firefleet_console::http::Records::in_memory(),
        );
        let tcp = tokio::net::TcpListener::bind("127.0.0.1:0")
            .await
            .expect("a port");
        let addr = tcp.local_addr().expect("an address");
        let app = Console::router(Arc::clone(&console));
        tokio::spawn(async move {
            axum::serve(tcp, app.into_make_service_with_connect_info::<Peer>()).await
        });
        let (rss0, _) = memory_mb();
        let started = Instant::now();
        let clients: Vec<_> = (0..CLIENTS)
            .map(|c| {
                tokio::spawn(async move {
                    let mut statuses = Vec::with_capacity(ATTEMPTS);
                    for a in 0..ATTEMPTS {
                        statuses.push(attempt(addr, c * ATTEMPTS + a).await);
                    }
                    statuses
                })
            })
            .collect();
        let mut counts = std::collections::BTreeMap::<u16, usize>::new();
        for c in clients {
            for s in c.await.expect("a client") {
                *counts.entry(s).or_default() += 1;
            }
        }
        let took = started.elapsed();
        let (rss, peak) = memory_mb();
        println!();
        println!("{CLIENTS} clients x {ATTEMPTS} bad logins, one connection each, on loopback");
        println!(
            "  took                               {:8.1} s",
            took.as_secs_f64()
        );
        for (status, n) in &counts {
            let what = match status {
                401 => "checked and refused (401)",
                429 => "throttled (429)",
                _ => "other",
            };
            println!("  {what:35}{n:8}");
        }
        println!("  resident memory before             {rss0:8.1} MB");
        println!("  resident memory after              {rss:8.1} MB");
        println!("  resident memory at its peak        {peak:8.1} MB  (target: under 200 MB)");
        println!();
    });

    let users = Users::load(&path).expect("the users file");
    users.verify("warm-up", "x");
    let known_short = median_ms(|| assert!(users.verify("rossi", "short").is_none()));
    let known_long = median_ms(|| assert!(users.verify("rossi", "wrong horse battery").is_none()));
    let unknown = median_ms(|| assert!(users.verify("verdi", "short").is_none()));
    println!("password check, median of 100 (ms)");
    println!("  known name, short wrong password   {known_short:8.1}");
    println!("  known name, long wrong password    {known_long:8.1}");
    println!("  unknown name                       {unknown:8.1}");
    println!(
        "  known - unknown                    {:8.1}  (target: under 5 ms)",
        (known_short - unknown)
            .abs()
            .max((known_long - unknown).abs())
    );
}
