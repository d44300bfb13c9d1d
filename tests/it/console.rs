//! The console restarted alone mid-incident (issue #46: every role restarts alone without
//! the site losing what a commander relies on): with `--state-dir`, an acknowledged alarm
//! is still acknowledged, by the same commander, and the audit log still holds the goal the
//! commander issued before the restart.

use std::io::{Read, Write};
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};

use crate::support::{BIN, Fleet, patient, router, spawn_role};

const SCENARIO: &str = "vehicle-collision";

/// One HTTP/1.0 request to the console at `addr`: the status, the headers and the body.
fn http(
    addr: &str,
    method: &str,
    path: &str,
    cookie: Option<&str>,
    body: Option<&str>,
) -> (u16, String, String) {
    let mut s = std::net::TcpStream::connect(addr).unwrap();
    s.set_read_timeout(Some(Duration::from_secs(30))).unwrap();
    let mut req = format!("{method} {path} HTTP/1.0\r\nHost: {addr}\r\n");
    if let Some(c) = cookie {
        req.push_str(&format!("Cookie: {c}\r\n"));
    }
    if let Some(b) = body {
        req.push_str(&format!(
            "Content-Type: application/json\r\nContent-Length: {}\r\n",
            b.len()
        ));
    }
    req.push_str("\r\n");
    req.push_str(body.unwrap_or(""));
    s.write_all(req.as_bytes()).unwrap();
    let mut out = String::new();
    s.read_to_string(&mut out).unwrap();
    let (head, body) = out.split_once("\r\n\r\n").unwrap_or((&out, ""));
    let status = head
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (status, head.to_owned(), body.to_owned())
}

/// Log `rossi` in, waiting for the console to serve; the session cookie.
fn login(addr: &str) -> String {
    let until = Instant::now() + patient(Duration::from_secs(30));
    loop {
        if std::net::TcpStream::connect(addr).is_ok() {
            let (status, head, body) = http(
                addr,
                "POST",
                "/api/login",
                None,
                Some(r#"{"name":"rossi","password":"correct horse"}"#),
            );
            assert_eq!(status, 200, "{head}\n{body}");
            let cookie = head
                .lines()
                .find_map(|l| {
                    l.strip_prefix("set-cookie: ")
                        .or(l.strip_prefix("Set-Cookie: "))
                })
                .expect("a session cookie");
            return cookie.split(';').next().unwrap().to_owned();
        }
        assert!(Instant::now() < until, "the console never served");
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// A console's users file in `dir` with commander `rossi` ("correct horse"), made by the
/// binary's own `console add-user`.
fn users_file(dir: &std::path::Path) -> std::path::PathBuf {
    let users = dir.join("users.toml");
    let mut add = std::process::Command::new(BIN)
        .args(["console", "add-user", "--users"])
        .arg(&users)
        .arg("rossi")
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    add.stdin
        .take()
        .unwrap()
        .write_all(b"correct horse\n")
        .unwrap();
    assert!(add.wait().unwrap().success());
    users
}

fn json(body: &str) -> serde_json::Value {
    serde_json::from_str(body).unwrap_or_else(|e| panic!("{e}: {body}"))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_console_restarted_alone_keeps_its_acknowledgements_and_audit() {
    let (bus, endpoint) = router("tunnel-a").await;
    let dir = tempfile::tempdir().unwrap();
    let users = users_file(dir.path());
    let addr = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let state = dir.path().join("console");
    let console = || -> Child {
        spawn_role(
            SCENARIO,
            &endpoint,
            &[
                "console",
                "--http",
                &addr,
                "--users",
                users.to_str().unwrap(),
                "--state-dir",
                state.to_str().unwrap(),
            ],
        )
    };
    // The incident at real time, so that it lasts; the console first (index 0).
    let mut fleet = Fleet(vec![
        console(),
        spawn_role(
            SCENARIO,
            &endpoint,
            &[
                "sim",
                "--time-scale",
                "1",
                "--wait-for-fleet",
                "30",
                "--wait-for-coordinator",
            ],
        ),
        spawn_role(SCENARIO, &endpoint, &["coordinator", "--sim-clock"]),
        spawn_role(SCENARIO, &endpoint, &["agent", "--unit", "ugv-1"]),
        spawn_role(SCENARIO, &endpoint, &["agent", "--unit", "ugv-2"]),
    ]);
    let cookie = login(&addr);

    // The fire's zone barred: the units cannot obey and the coordinator says so, an alarm.
    let until = Instant::now() + patient(Duration::from_secs(60));
    loop {
        let (status, _, body) = http(
            &addr,
            "POST",
            "/api/goals",
            Some(&cookie),
            Some(r#"{"zone":"core","goal":"evacuate"}"#),
        );
        if status == 200 {
            break;
        }
        assert!(
            Instant::now() < until,
            "the goal was never taken: {status} {body}"
        );
        std::thread::sleep(Duration::from_millis(500));
    }
    let alarm = loop {
        let (_, _, body) = http(&addr, "GET", "/api/incident", Some(&cookie), None);
        let inc = json(&body);
        if let Some(a) = inc["alerts"].as_array().and_then(|a| a.first().cloned()) {
            break a;
        }
        assert!(Instant::now() < until, "no alarm raised: {}", inc["alerts"]);
        std::thread::sleep(Duration::from_millis(200));
    };
    let id = alarm["id"].as_u64().unwrap();
    let (status, _, body) = http(
        &addr,
        "POST",
        &format!("/api/alerts/{id}/ack"),
        Some(&cookie),
        None,
    );
    assert_eq!(status, 200, "{body}");
    let audit_before = json(&http(&addr, "GET", "/api/audit", Some(&cookie), None).2);
    let issued =
        |audit: &serde_json::Value| {
            audit.as_array().unwrap().iter().any(|e| {
                e["who"] == "rossi" && e["what"].as_str().is_some_and(|w| w.contains("core"))
            })
        };
    assert!(issued(&audit_before), "{audit_before}");

    // The console alone, killed and started again on the same state directory.
    fleet.0[0].kill().unwrap();
    fleet.0[0].wait().unwrap();
    fleet.0[0] = console();
    let cookie = login(&addr);
    let inc = json(&http(&addr, "GET", "/api/incident", Some(&cookie), None).2);
    let kept = inc["alerts"]
        .as_array()
        .unwrap()
        .iter()
        .find(|a| a["text"] == alarm["text"])
        .unwrap_or_else(|| panic!("the alarm is gone after the restart: {}", inc["alerts"]));
    assert_eq!(kept["acked_by"], "rossi", "{kept}");
    let audit_after = json(&http(&addr, "GET", "/api/audit", Some(&cookie), None).2);
    assert!(
        issued(&audit_after),
        "the audit lost the goal: {audit_after}"
    );
    assert!(
        audit_after.as_array().unwrap().len() >= audit_before.as_array().unwrap().len(),
        "{audit_after}"
    );
    drop(fleet);
    bus.close().await;
}

/// A standby that holds its token but does not follow (issue #47: standby unhealthy): the
/// test's own session stands by as rank 3 beside a real coordinator and console, and says
/// it follows goals it never heard. The console alarms it once the goals it heard 3 s
/// before are newer than what the standby says, and returns it to normal once it says the
/// goals the coordinator sends.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_standby_that_does_not_follow_the_coordinator_is_alarmed_until_it_does() {
    use firefleet_protocol::keys::Topic;
    use firefleet_protocol::msg::StandbyHealth;
    let (bus, endpoint) = router("tunnel-a").await;
    let dir = tempfile::tempdir().unwrap();
    let users = users_file(dir.path());
    let addr = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let fleet = Fleet(vec![
        spawn_role(
            SCENARIO,
            &endpoint,
            &[
                "console",
                "--http",
                &addr,
                "--users",
                users.to_str().unwrap(),
            ],
        ),
        spawn_role(SCENARIO, &endpoint, &["coordinator"]),
    ]);
    let cookie = login(&addr);
    let keys = bus.keys().clone();
    let goals = bus.subscribe(&keys.coord_goals()).await.unwrap();
    let _standing_by = bus.token(&Topic::CoordStandbyAlive(3)).await.unwrap();
    let alarm = |inc: &serde_json::Value| {
        inc["alerts"].as_array().and_then(|a| {
            a.iter()
                .find(|a| {
                    a["kind"] == "standby-not-following" && a["active"] == true && a["rank"] == 3
                })
                .cloned()
        })
    };
    // It says, every half second, that it follows the goals of t = 0 s.
    let until = Instant::now() + patient(Duration::from_secs(30));
    let stale = StandbyHealth {
        rank: 3,
        goals_t: Some(0.0),
        tracks: 0,
    };
    let raised = loop {
        bus.put(&keys.coord_standby_health(3), &stale)
            .await
            .unwrap();
        let inc = json(&http(&addr, "GET", "/api/incident", Some(&cookie), None).2);
        if let Some(a) = alarm(&inc) {
            break a;
        }
        assert!(Instant::now() < until, "never alarmed: {}", inc["alerts"]);
        tokio::time::sleep(Duration::from_millis(500)).await;
    };
    assert!(
        raised["text"]
            .as_str()
            .is_some_and(|t| t.contains("follows the goals in force of t=0.0 s")),
        "{raised}"
    );
    assert_eq!(raised["priority"], 2, "{raised}");
    // Now it follows: it says the newest goals it heard.
    let mut newest = None;
    loop {
        while let Some((_, g)) = goals.try_recv() {
            newest = Some(g.t);
        }
        let following = StandbyHealth {
            goals_t: newest,
            ..stale.clone()
        };
        bus.put(&keys.coord_standby_health(3), &following)
            .await
            .unwrap();
        let inc = json(&http(&addr, "GET", "/api/incident", Some(&cookie), None).2);
        if alarm(&inc).is_none() {
            break;
        }
        assert!(
            Instant::now() < until,
            "never back to normal: {}",
            inc["alerts"]
        );
        tokio::time::sleep(Duration::from_millis(500)).await;
    }
    drop(fleet);
    bus.close().await;
}
