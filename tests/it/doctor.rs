//! `firefleet doctor` (issue #37) on a secure site of this machine: a host set up as the
//! guide says has no problem and learns the site's protocol version; each misconfiguration
//! an operator met (wrong platform, unreadable key, another role's certificate, an expired
//! one, a router dialled by a name its certificate does not list, a coordinator without the
//! simulator's clock) is named on one line with its fix, and the doctor exits 1.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::support::{BIN, Fleet, patient, text};
use firefleet_bus::access::Identity;
use firefleet_bus::pki::{self, Terms};
use firefleet_model::UnitId;

/// The site: vehicle-collision's file saying it is a real tunnel, its PKI (the router
/// certified for `localhost` and `router.tunnel.local`, not 127.0.0.1) and two renderings,
/// one dialling the router by a name it has, one by an address it has not.
struct Site {
    _dir: tempfile::TempDir,
    real: PathBuf,
    pki: PathBuf,
    good: PathBuf,
    misdialled: PathBuf,
    port: u16,
}

fn site() -> Site {
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("site.toml");
    let shipped = std::fs::read_to_string("model/scenarios/vehicle-collision.toml").unwrap();
    std::fs::write(&real, format!("simulated = false\n{shipped}")).unwrap();
    let pki = dir.path().join("pki");
    let run = crate::support::firefleet_ok;
    let (real_s, pki_s) = (real.to_str().unwrap(), pki.to_str().unwrap());
    run(&[
        "pki",
        "init",
        "--scenario",
        real_s,
        "--out",
        pki_s,
        "--host",
        "localhost",
        "--host",
        "router.tunnel.local",
    ]);
    let port = firefleet_bus::free_loopback_port().unwrap();
    let render = |out: &Path, host: &str| {
        run(&[
            "deploy",
            "render",
            "--scenario",
            real_s,
            "--pki",
            pki_s,
            "--out",
            out.to_str().unwrap(),
            "--listen",
            &format!("quic/127.0.0.1:{port}"),
            "--connect",
            &format!("quic/{host}:{port}"),
        ])
    };
    let (good, misdialled) = (dir.path().join("good"), dir.path().join("misdialled"));
    render(&good, "localhost");
    render(&misdialled, "127.0.0.1");
    Site {
        _dir: dir,
        real,
        pki,
        good,
        misdialled,
        port,
    }
}

fn doctor(scenario: &Path, config: &Path, args: &[&str]) -> Output {
    Command::new(BIN)
        .arg("doctor")
        .arg("--scenario")
        .arg(scenario)
        .arg("--zenoh-config")
        .arg(config)
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

/// The doctor found exactly one problem, and said `needle` of it, on its one line.
fn one_problem(out: &Output, needle: &str) {
    let said = text(out);
    let problems: Vec<&str> = said.lines().filter(|l| l.starts_with("PROBLEM")).collect();
    assert_eq!(out.status.code(), Some(1), "{said}");
    assert_eq!(problems.len(), 1, "{said}");
    assert!(problems[0].contains(needle), "{needle}:\n{said}");
    assert!(problems[0].contains(". Fix: "), "{said}");
}

#[test]
fn the_doctor_names_each_misconfiguration_on_one_line_with_its_fix() {
    let s = site();
    let spawn = |role: &[&str], config: &str| {
        Command::new(BIN)
            .args(role)
            .arg("--scenario")
            .arg(&s.real)
            .arg("--zenoh-config")
            .arg(s.good.join(config))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap()
    };
    let _fleet = Fleet(vec![
        spawn(&["router"], "router.json5"),
        spawn(&["coordinator"], "coordinator.json5"),
    ]);
    let ugv1 = s.good.join("unit-ugv-1.json5");

    // As the guide says: no problem, and the site's protocol version once the coordinator
    // answers.
    let deadline = Instant::now() + patient(Duration::from_secs(30));
    loop {
        let out = doctor(
            &s.real,
            &ugv1,
            &["--identity", "unit:ugv-1", "--platform", "ros2"],
        );
        let said = text(&out);
        if said.contains("protocol: the site speaks version") {
            assert!(out.status.success(), "{said}");
            assert!(said.contains("no problem found"), "{said}");
            assert!(
                said.contains("answers as router, certified for 'localhost'"),
                "{said}"
            );
            break;
        }
        assert!(
            Instant::now() < deadline,
            "never heard the coordinator: {said}"
        );
        std::thread::sleep(Duration::from_millis(300));
    }

    // The agent on the simulator's platform on a real site.
    one_problem(
        &doctor(&s.real, &ugv1, &["--identity", "unit:ugv-1", "--offline"]),
        "platform: --platform sim on site",
    );
    // A key the service's user cannot read (0600 and root's, read without LoadCredential=).
    if nix_user_exists("nobody") {
        one_problem(
            &doctor(
                &s.real,
                &ugv1,
                &[
                    "--identity",
                    "unit:ugv-1",
                    "--platform",
                    "ros2",
                    "--service-user",
                    "nobody",
                    "--offline",
                ],
            ),
            "cannot be read by nobody",
        );
    }
    // Another role's certificate.
    one_problem(
        &doctor(&s.real, &ugv1, &["--identity", "coordinator"]),
        "is unit:ugv-1's certificate, and this role runs as coordinator",
    );
    // An expired certificate (issued again, valid until yesterday).
    let ugv2 = Identity::Unit(UnitId::new("ugv-2").unwrap());
    let now = time::OffsetDateTime::now_utc();
    pki::issue(
        &s.pki,
        &ugv2,
        &Terms {
            from: Some(now - time::Duration::days(400)),
            valid_days: 399,
            ..Terms::default()
        },
    )
    .unwrap();
    one_problem(
        &doctor(
            &s.real,
            &s.good.join("unit-ugv-2.json5"),
            &["--identity", "unit:ugv-2", "--platform", "ros2"],
        ),
        "unit:ugv-2's certificate expired on",
    );
    // The router dialled by an address its certificate does not list.
    one_problem(
        &doctor(
            &s.real,
            &s.misdialled.join("unit-ugv-1.json5"),
            &["--identity", "unit:ugv-1", "--platform", "ros2"],
        ),
        &format!(
            "router quic/127.0.0.1:{}: 127.0.0.1:{} presents router's certificate, which is not for '127.0.0.1'",
            s.port, s.port
        ),
    );
    // A coordinator without the simulator's clock on a site whose file does not say it is
    // real (the shipped scenario, as a simulated site would run it).
    one_problem(
        &doctor(
            Path::new("vehicle-collision"),
            &s.good.join("coordinator.json5"),
            &["--identity", "coordinator", "--offline"],
        ),
        "clock: the coordinator keeps the system clock",
    );
}

fn nix_user_exists(name: &str) -> bool {
    std::fs::read_to_string("/etc/passwd")
        .is_ok_and(|p| p.lines().any(|l| l.split(':').next() == Some(name)))
}
