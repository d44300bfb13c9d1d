//! The systemd units of `deploy/systemd/` (issue #37): they name exactly the files `pki
//! init` and `deploy render` write, systemd rates each of them "OK" (an exposure of 2.5 or
//! less, `systemd-analyze security --offline=true`), and a process handed its identity as
//! systemd credentials joins a secure site with a configuration whose own key paths it
//! could not read.
//!
//! Not here: running the units under systemd (this machine's systemd is not PID 1); the
//! namespace site of the deploy guide does that.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use crate::support::{BIN, Fleet, patient, text};

const UNITS: &str = "deploy/systemd";

fn units() -> Vec<(String, String)> {
    let mut out: Vec<(String, String)> = std::fs::read_dir(UNITS)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "service"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    out.sort();
    out
}

/// The values of `key=` lines of a unit.
fn values<'a>(unit: &'a str, key: &str) -> Vec<&'a str> {
    let prefix = format!("{key}=");
    unit.lines()
        .filter_map(|l| l.strip_prefix(prefix.as_str()))
        .collect()
}

/// `firefleet pki init` and `deploy render` for rail-tunnel, as deploy/README.md says, in
/// `dir`: the PKI and the rendered configurations.
fn site(dir: &Path) -> (PathBuf, PathBuf) {
    let (pki, cfg) = (
        crate::support::pki_init(dir, "rail-tunnel"),
        dir.join("cfg"),
    );
    let run = crate::support::firefleet_ok;
    run(&[
        "pki",
        "issue",
        "--pki",
        pki.to_str().unwrap(),
        "--role",
        "router",
        "--name",
        "b",
        "--host",
        "router-b.tunnel.local",
    ]);
    run(&[
        "deploy",
        "render",
        "--scenario",
        "rail-tunnel",
        "--pki",
        pki.to_str().unwrap(),
        "--out",
        cfg.to_str().unwrap(),
        "--commander",
        "rossi",
        "--listen",
        "quic/0.0.0.0:7447",
        "--connect",
        "quic/router.tunnel.local:7447",
        "--router",
        "b=quic/router-b.tunnel.local:7447",
        "--pki-at",
        "/etc/firefleet/pki",
    ]);
    (pki, cfg)
}

#[test]
fn every_unit_is_rated_ok_by_systemd() {
    if !firefleet_model::testing::program(
        "systemd-analyze",
        "apt-get install systemd",
        "FIREFLEET_REQUIRE_SYSTEMD_ANALYZE",
    ) {
        return;
    }
    let units = units();
    assert!(units.len() >= 8, "{units:?}");
    for (name, _) in &units {
        let path = std::fs::canonicalize(Path::new(UNITS).join(name)).unwrap();
        let out = Command::new("systemd-analyze")
            .args(["security", "--offline=true", "--no-pager"])
            .arg(&path)
            .output()
            .unwrap();
        let said = text(&out);
        let exposure: f64 = said
            .lines()
            .find_map(|l| l.split("Overall exposure level for ").nth(1))
            .and_then(|rest| rest.split(": ").nth(1))
            .and_then(|v| v.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name}: no exposure level in\n{said}"));
        assert!(exposure <= 2.5, "{name}: exposure {exposure}\n{said}");
    }
}

#[test]
fn every_unit_names_what_pki_init_and_deploy_render_write() {
    let dir = tempfile::tempdir().unwrap();
    let (pki, cfg) = site(dir.path());
    for (name, text) in units() {
        // A template's instance: a unit of the site, or its further router.
        let instance = if name.starts_with("firefleet-router@") {
            "b"
        } else {
            "ugv-1"
        };
        let text = text.replace("%i", instance);
        // The service is told when it is ready, and stays in its sandbox.
        for (key, value) in [
            ("Type", "notify"),
            ("DynamicUser", "yes"),
            ("ProtectSystem", "strict"),
        ] {
            assert_eq!(values(&text, key), [value], "{name}: {key}");
        }
        let exec = values(&text, "ExecStart").concat();
        assert!(
            exec.contains("--scenario /etc/firefleet/site.toml"),
            "{name}"
        );
        let config = exec
            .split("--zenoh-config /etc/firefleet/")
            .nth(1)
            .and_then(|rest| rest.split_whitespace().next())
            .unwrap_or_else(|| panic!("{name}: no --zenoh-config"));
        assert!(
            cfg.join(config).is_file(),
            "{name}: deploy render writes no {config}"
        );
        let creds = values(&text, "LoadCredential");
        for file in ["ca.pem", "cert.pem", "key.pem"] {
            assert!(
                creds.iter().any(|c| c.starts_with(&format!("{file}:"))),
                "{name}: no {file} credential"
            );
        }
        for c in creds {
            let (_, source) = c.split_once(':').unwrap();
            let Some(rel) = source.strip_prefix("/etc/firefleet/pki/") else {
                assert_eq!(source, "/etc/firefleet/console-users.toml", "{name}");
                continue;
            };
            assert!(pki.join(rel).is_file(), "{name}: pki init writes no {rel}");
        }
    }
}

#[test]
fn a_process_reads_its_identity_from_systemd_s_credentials() {
    let dir = tempfile::tempdir().unwrap();
    let (pki, cfg) = site(dir.path());
    let port = firefleet_bus::free_loopback_port().unwrap();
    let endpoint = format!("quic/127.0.0.1:{port}");
    // The rendered configuration's key paths are under /etc/firefleet/pki, which is not
    // there: only the credentials directory holds the identity, as under systemd.
    let spawn = |role: &[&str], config: &str, identity: &str| {
        Command::new(BIN)
            .args(role)
            .args(["--scenario", "rail-tunnel", "--zenoh-config"])
            .arg(cfg.join(config))
            .args(["--listen", &endpoint])
            .env("CREDENTIALS_DIRECTORY", pki.join(identity))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap()
    };
    let _fleet = Fleet(vec![spawn(
        &["coordinator", "--mode", "router"],
        "router.json5",
        "router",
    )]);
    let rossi = pki.join("commander-rossi");
    let deadline = Instant::now() + patient(Duration::from_secs(30));
    loop {
        let out = Command::new(BIN)
            .args(["status", "--scenario", "rail-tunnel", "--mode", "client"])
            .args(["--connect", &endpoint, "--tls-dir"])
            .arg(&rossi)
            .output()
            .unwrap();
        if out.status.success() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the coordinator holding its identity as credentials never answered: {}",
            text(&out)
        );
        std::thread::sleep(Duration::from_millis(300));
    }
    // Without the credentials the same configuration cannot link, and says which file.
    let out = Command::new(BIN)
        .args(["status", "--scenario", "rail-tunnel", "--zenoh-config"])
        .arg(cfg.join("commander-rossi.json5"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        text(&out).contains("/etc/firefleet/pki/commander-rossi"),
        "{}",
        text(&out)
    );
}
