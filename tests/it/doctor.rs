//! `firefleet doctor` (issue #37) on a secure site of this machine: a host set up as the
//! guide says has no problem and learns the site's protocol version; each misconfiguration
//! an operator met (wrong platform, unreadable key, another role's certificate, an expired
//! one, a router dialled by a name its certificate does not list, a coordinator without the
//! simulator's clock) is named on one line with its fix, and the doctor exits 1; on a
//! revoked robot's host it says the name is revoked.

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use crate::support::{BIN, Fleet, http_get, patient, text};
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
    let (good, misdialled) = (dir.path().join("good"), dir.path().join("misdialled"));
    render(&real, &pki, port, &good, "localhost");
    render(&real, &pki, port, &misdialled, "127.0.0.1");
    // Open to every user as far as the files' own modes allow, as /etc/firefleet is to
    // the services' group: the checks below for the service's user look at those modes.
    use std::os::unix::fs::PermissionsExt as _;
    for d in [dir.path(), &good, &misdialled] {
        std::fs::set_permissions(d, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    Site {
        _dir: dir,
        real,
        pki,
        good,
        misdialled,
        port,
    }
}

/// The site's configurations rendered into `out`, the router listening on `port` on
/// loopback and dialled as `host`.
fn render(real: &Path, pki: &Path, port: u16, out: &Path, host: &str) {
    crate::support::firefleet_ok(&[
        "deploy",
        "render",
        "--scenario",
        real.to_str().unwrap(),
        "--pki",
        pki.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--listen",
        &format!("quic/127.0.0.1:{port}"),
        "--connect",
        &format!("quic/{host}:{port}"),
    ]);
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
    let metrics = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    let _fleet = Fleet(vec![
        spawn(&["router", "--metrics", &metrics], "router.json5"),
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
                said.contains("answers as router, certified for 'localhost'")
                    && said.contains("its rules admit unit:ugv-1 (router 'router' answered)"),
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

    // The router counts its links by what is at the far end, its clients too (the
    // coordinator): Zenoh's session info would show it none.
    let (code, text_of_metrics) = http_get(&metrics, "/metrics");
    assert_eq!(code, 200, "{text_of_metrics}");
    let clients = text_of_metrics
        .lines()
        .find_map(|l| l.strip_prefix("firefleet_links{with=\"client\"} "))
        .and_then(|v| v.parse::<f64>().ok());
    assert!(clients >= Some(1.0), "{text_of_metrics}");
    // That admin space is the router's own: a site identity asking it gets nothing.
    let asked = tokio::runtime::Runtime::new().unwrap().block_on(async {
        let connect = firefleet_bus::Connect {
            config_file: Some(ugv1.clone()),
            ..firefleet_bus::Connect::default()
        };
        let bus =
            firefleet_bus::Bus::open(&connect, firefleet_model::SiteId::new("tunnel-a").unwrap())
                .await
                .unwrap();
        let router = firefleet_bus::render::router_zid(bus.keys().site(), &Identity::ROUTER);
        let answers = bus
            .ask(
                &format!("@/{router}/**"),
                firefleet_bus::Ask::within(Duration::from_secs(1)),
            )
            .await
            .unwrap();
        let n = answers.all().await.len();
        bus.close().await;
        n
    });
    assert_eq!(asked, 0, "ugv-1 read the router's admin space");

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
    // A configuration the service's user cannot read (its key handed in by systemd).
    if nix_user_exists("nobody") {
        use std::os::unix::fs::PermissionsExt as _;
        let private = s.good.join("unit-ugv-1-private.json5");
        std::fs::copy(&ugv1, &private).unwrap();
        std::fs::set_permissions(&private, std::fs::Permissions::from_mode(0o600)).unwrap();
        let key_dir = s.pki.join("unit-ugv-1");
        let out = Command::new(BIN)
            .args(["doctor", "--scenario"])
            .arg(&s.real)
            .arg("--zenoh-config")
            .arg(&private)
            .args(["--identity", "unit:ugv-1", "--platform", "ros2"])
            .args(["--service-user", "nobody", "--offline"])
            .env("CREDENTIALS_DIRECTORY", &key_dir)
            .output()
            .unwrap();
        one_problem(&out, "Zenoh configuration: ");
        assert!(
            text(&out).contains("unit-ugv-1-private.json5 cannot be read by nobody"),
            "{}",
            text(&out)
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

/// A robot's name revoked: while the router runs the rules from before, the doctor on the
/// robot's host finds it admitted (which is how a router left on old rules shows); once
/// the router runs the rules rendered after, the doctor says the name is revoked.
#[test]
fn the_doctor_on_a_revoked_robots_host_says_it_is_revoked() {
    let s = site();
    let router = |rules: &Path| {
        Fleet(vec![
            Command::new(BIN)
                .args(["router", "--scenario"])
                .arg(&s.real)
                .arg("--zenoh-config")
                .arg(rules.join("router.json5"))
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .unwrap(),
        ])
    };
    let ugv2 = s.good.join("unit-ugv-2.json5");
    let args = ["--identity", "unit:ugv-2", "--platform", "ros2"];
    // The doctor's findings once the router is up (its knock answered).
    let once_up = || {
        let deadline = Instant::now() + patient(Duration::from_secs(30));
        loop {
            let out = doctor(&s.real, &ugv2, &args);
            if text(&out).contains("answers as router") {
                return out;
            }
            assert!(Instant::now() < deadline, "the router never answered");
            std::thread::sleep(Duration::from_millis(200));
        }
    };

    let old_rules = router(&s.good);
    let said = text(&once_up());
    assert!(said.contains("its rules admit unit:ugv-2"), "{said}");
    assert!(!said.contains("PROBLEM"), "{said}");

    // Revoked at the PKI and the rules rendered again; the robot's host keeps its files.
    let kept = s._dir.path().join("ugv-2-host");
    copy_dir(&s.pki.join("unit-ugv-2"), &kept);
    crate::support::firefleet_ok(&[
        "pki",
        "revoke",
        "--pki",
        s.pki.to_str().unwrap(),
        "unit:ugv-2",
    ]);
    let revoked = s._dir.path().join("revoked");
    render(&s.real, &s.pki, s.port, &revoked, "localhost");
    assert!(!revoked.join("unit-ugv-2.json5").exists());
    copy_dir(&kept, &s.pki.join("unit-ugv-2"));
    drop(old_rules);
    let _new_rules = router(&revoked);
    one_problem(&once_up(), "the site has revoked this name");
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        std::fs::copy(entry.path(), to.join(entry.file_name())).unwrap();
    }
}

fn nix_user_exists(name: &str) -> bool {
    std::fs::read_to_string("/etc/passwd")
        .is_ok_and(|p| p.lines().any(|l| l.split(':').next() == Some(name)))
}

/// A site file whose `[[routers]]` entry names a wrong address (nothing answers there): the
/// fix names the entry and the name's resolution, not only the firewall; and a key that is
/// not the certificate's is one problem, not three.
#[test]
fn the_doctor_points_a_wrong_router_address_at_the_site_files_entry() {
    let dir = tempfile::tempdir().unwrap();
    let site = dir.path().join("site.toml");
    let shipped = std::fs::read_to_string("model/scenarios/vehicle-collision.toml").unwrap();
    let port = firefleet_bus::free_loopback_port().unwrap();
    std::fs::write(
        &site,
        format!(
            "simulated = false\n{shipped}\n[[routers]]\nname = \"west\"\nhost = \"localhost\"\nport = {port}\nchainage_m = 0.0\n"
        ),
    )
    .unwrap();
    let (pki, out) = (dir.path().join("pki"), dir.path().join("out"));
    let (site_s, pki_s) = (site.to_str().unwrap(), pki.to_str().unwrap());
    crate::support::firefleet_ok(&["pki", "init", "--scenario", site_s, "--out", pki_s]);
    crate::support::firefleet_ok(&[
        "deploy",
        "render",
        "--scenario",
        site_s,
        "--pki",
        pki_s,
        "--out",
        out.to_str().unwrap(),
    ]);
    let ugv1 = out.join("unit-ugv-1.json5");
    let args = [
        "--identity",
        "unit:ugv-1",
        "--platform",
        "ros2",
        "--timeout-s",
        "1",
    ];
    // Nobody listens at the entry's port.
    let said = doctor(&site, &ugv1, &args);
    one_problem(&said, &format!("nothing answers at 127.0.0.1:{port}"));
    assert!(
        text(&said).contains("the site file's [[routers]] entry 'west'")
            && text(&said).contains("DNS or /etc/hosts"),
        "{}",
        text(&said)
    );
    // ugv-2's key beside ugv-1's certificate: said once, by the identity's check.
    std::fs::copy(
        pki.join("unit-ugv-2").join("key.pem"),
        pki.join("unit-ugv-1").join("key.pem"),
    )
    .unwrap();
    let said = doctor(&site, &ugv1, &args);
    let problems = text(&said)
        .lines()
        .filter(|l| l.starts_with("PROBLEM"))
        .count();
    assert_eq!(problems, 1, "{}", text(&said));
    assert!(text(&said).contains("key"), "{}", text(&said));
}
