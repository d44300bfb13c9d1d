//! End-to-end: a recorder killed outright (SIGKILL) at seeded random instants while a
//! fleet's traffic flows leaves files that the standard Python `mcap` reader opens, and
//! that `firefleet replay` reads up to where the recorder died.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "tests print what a person running them reads"
)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use crate::support::{firefleet, router, spawn_role, text};
use firefleet_model::UnitKind;
use firefleet_model::testing::python_package;
use firefleet_model::{Pose2, UnitId};
use firefleet_protocol::msg::{SimClock, UnitMode, UnitState};
use firefleet_recorder::parts::{INDEX, Index, Recording, parts_dir};
use rand::{Rng, SeedableRng};

const KILLS: usize = 20;
const SEED: u64 = 20;

/// Whether Python's `mcap` package is importable. CI installs it and sets
/// `FIREFLEET_REQUIRE_PYTHON_MCAP`, so there a missing package fails the test; elsewhere
/// the test says loudly that it checked nothing.
fn python_mcap() -> bool {
    python_package("mcap", "mcap>=1,<2", "FIREFLEET_REQUIRE_PYTHON_MCAP")
}

fn state(unit: &UnitId, t: f64) -> UnitState {
    UnitState {
        unit: unit.clone(),
        kind: UnitKind::Ground,
        t,
        pose: Pose2::new(5.0 + t, -2.5, 0.0),
        speed: 1.0,
        mode: UnitMode::Idle,
        water_l: 1000.0,
        health: 1.0,
        heat_flux_kw_m2: 0.5,
        task: None,
        autonomous: false,
        task_seq: None,
        epoch: None,
        refused: None,
    }
}

/// The finished parts of the recording `out` (every `*.mcap` in its parts directory).
fn finished_parts(out: &Path) -> Vec<PathBuf> {
    let mut parts: Vec<PathBuf> = std::fs::read_dir(parts_dir(out))
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    parts.retain(|p| p.extension().is_some_and(|e| e == "mcap"));
    parts.sort();
    parts
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_recorder_killed_at_any_instant_leaves_files_every_mcap_reader_opens() {
    let checked_by_python = python_mcap();
    let (bus, endpoint) = router("tunnel-a").await;
    let keys = bus.keys().clone();
    // The traffic: two units' states at 50 Hz and the site clock, as a fleet sends them.
    let traffic = {
        let (bus_keys, bus) = (keys.clone(), bus.clone());
        tokio::spawn(async move {
            let units = [UnitId::new("ugv-1").unwrap(), UnitId::new("ugv-2").unwrap()];
            let start = Instant::now();
            let mut tick = tokio::time::interval(Duration::from_millis(20));
            loop {
                tick.tick().await;
                let t = start.elapsed().as_secs_f64();
                for u in &units {
                    let _ = bus.put(&bus_keys.unit_state(u), &state(u, t)).await;
                }
                let clock = SimClock { t, time_scale: 1.0 };
                let _ = bus.put(&bus_keys.sim_clock(), &clock).await;
            }
        })
    };
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(SEED);
    let mut files = Vec::new();
    let mut outs = Vec::new();
    for k in 0..KILLS {
        let out = dir.path().join(format!("run-{k:02}.mcap"));
        let mut recorder = spawn_role(
            "vehicle-collision",
            &endpoint,
            &[
                "record",
                "--out",
                out.to_str().unwrap(),
                "--part-seconds",
                "1",
            ],
        );
        // From the moment it has begun its first part: before, there is nothing to lose.
        let begun = Instant::now();
        while !parts_dir(&out).is_dir() {
            assert!(
                begun.elapsed() < Duration::from_secs(20),
                "the recorder never began"
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
        let after = Duration::from_secs_f64(rng.random_range(0.0..3.5));
        tokio::time::sleep(after).await;
        recorder.kill().unwrap();
        recorder.wait().unwrap();
        let parts = finished_parts(&out);
        // The index lists every finished part but perhaps the last (killed between its
        // rename and the index's), and nothing else.
        if let Ok(json) = std::fs::read(parts_dir(&out).join(INDEX)) {
            let index: Index = serde_json::from_slice(&json).unwrap();
            let listed: Vec<&str> = index.parts.iter().map(|p| p.file.as_str()).collect();
            let on_disk: Vec<String> = parts
                .iter()
                .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
                .collect();
            assert!(
                on_disk.len() - listed.len() <= 1
                    && on_disk.iter().zip(&listed).all(|(a, b)| a == b),
                "kill {k}: index {listed:?}, parts {on_disk:?}"
            );
        }
        // firefleet reads the whole of what was recorded: the finished parts and the one
        // being written up to its last complete chunk.
        let recording = Recording::load(&out).unwrap();
        let states = recording
            .messages()
            .filter_map(Result::ok)
            .filter(|m| m.channel.topic.ends_with("/state"))
            .count();
        let expected = (after.as_secs_f64() * 100.0) as usize;
        eprintln!(
            "kill {k:2} {:.2} s into the recording: {} finished parts, {states} states read",
            after.as_secs_f64(),
            parts.len()
        );
        if after > Duration::from_secs(2) {
            // At most the last second (the chunk being written) and a part's start lost.
            assert!(
                states + 250 >= expected,
                "kill {k}: {states} states read of about {expected} sent"
            );
        }
        let replay = firefleet(&["replay", out.to_str().unwrap()]);
        assert!(replay.status.success(), "kill {k}: {}", text(&replay));
        files.extend(parts);
        outs.push(out);
    }
    traffic.abort();
    assert!(
        files.len() >= KILLS,
        "too few finished parts to say anything: {files:?}"
    );
    if checked_by_python {
        // Every finished file, through make_reader (the seeking reader, which needs a
        // finished file) and every message in it.
        let script = "import sys, json\nfrom mcap.reader import make_reader\nout = {}\nfor f in sys.argv[1:]:\n    with open(f, 'rb') as s:\n        out[f] = sum(1 for _ in make_reader(s).iter_messages())\nprint(json.dumps(out))\n";
        let py = Command::new("python3")
            .arg("-c")
            .arg(script)
            .args(&files)
            .output()
            .unwrap();
        assert!(py.status.success(), "{}", text(&py));
        let counts: std::collections::BTreeMap<String, u64> =
            serde_json::from_slice(&py.stdout).unwrap();
        assert_eq!(counts.len(), files.len());
        assert!(
            counts.values().all(|&n| n > 0),
            "a part with no message: {counts:?}"
        );
        eprintln!(
            "Python's mcap opened all {} finished parts of {KILLS} killed recordings ({} messages)",
            counts.len(),
            counts.values().sum::<u64>()
        );
    }
    bus.close().await;
}
