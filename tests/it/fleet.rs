//! End-to-end: the real `firefleet` binary as separate processes over loopback Zenoh.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "tests print what a person running them reads"
)]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use crate::support::{
    BIN, Fleet, assert_says, cli, first_answer, free_endpoint, http_get, outcome, patient, router,
    router_at, spawn_role, spawn_watched, status_of, text, until_in_recording, until_line,
};
use firefleet_bus::{Ask, Bus, Inbox, free_loopback_port};
use firefleet_model::{FireId, Point2, Pose2, UnitId, ZoneId};
use firefleet_protocol::codec::{self, PROTOCOL_VERSION};
use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::{
    Bar, BarredSpace, FireState, FireTrack, FlameObservation, FlameReport, SimClock, SimTruth,
    Task, TaskKind, TaskPhase, TaskProgress, UnitState,
};

/// Run `firefleet demo` on `scenario` at 8x with `extra` arguments; its summary, after
/// checking that it succeeded and that no process dropped a message (in a clean run a
/// dropped message is a producer's bug).
fn demo(dir: &Path, scenario: &str, extra: &[&std::ffi::OsStr]) -> serde_json::Value {
    let summary = dir.join("summary.json");
    let out = Command::new(BIN)
        .args([
            "demo",
            "--scenario",
            scenario,
            "--time-scale",
            "8",
            "--summary-json",
        ])
        .arg(&summary)
        .args(extra)
        .env_remove("RUST_LOG")
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "demo exited with {}: {stderr}",
        out.status
    );
    assert!(!stderr.contains("dropped"), "{stderr}");
    serde_json::from_slice(&std::fs::read(&summary).unwrap()).unwrap()
}

#[test]
fn demo_fleet_puts_out_every_fire_and_records_the_incident() {
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("run.mcap");
    let s = demo(
        dir.path(),
        "cargo-truck",
        &["--record".as_ref(), recording.as_os_str()],
    );
    assert_eq!(s["fires_total"], 3);
    assert_eq!(s["fires_out"], 3);
    assert!(s["sim_time_s"].as_f64().unwrap() < 360.0);
    let procs = s["processes"].as_array().unwrap();
    assert!(
        procs.len() >= 5,
        "sim, coordinator, three agents (and a recorder): {procs:?}"
    );
    for role in [
        "sim",
        "coordinator",
        "agent:ugv-1",
        "agent:ugv-2",
        "agent:ugv-3",
        "recorder",
    ] {
        assert!(procs.iter().any(|p| p["role"] == role), "no {role} process");
    }
    for u in s["units"].as_array().unwrap() {
        assert_eq!(u["collisions"], 0, "{u}");
    }
    check_recording(&recording);
    let rec = recording.to_str().unwrap();
    let out = crate::support::firefleet(&["check", rec, "--scenario", "cargo-truck"]);
    assert_says(&out, 0, "0 violations");
    // A site's recordings are many files (one per recorder start): every one is checked,
    // and one that cannot be read fails the check without hiding the others' verdicts.
    let missing = recording.with_file_name("never-made.mcap");
    let out = crate::support::firefleet(&[
        "check",
        rec,
        missing.to_str().unwrap(),
        "--scenario",
        "cargo-truck",
    ]);
    assert_says(
        &out,
        1,
        "2 recordings checked: 1 with violations or unreadable",
    );
    assert!(text(&out).contains("0 violations"), "{}", text(&out));
    assert!(
        text(&out).contains("never-made.mcap: not checked"),
        "{}",
        text(&out)
    );

    // The timeline of the incident, from the recording alone.
    let replay = Command::new(BIN)
        .arg("replay")
        .arg(&recording)
        .output()
        .unwrap();
    assert!(replay.status.success());
    let timeline = String::from_utf8_lossy(&replay.stdout);
    assert!(timeline.contains("simulated fires out 3/3"), "{timeline}");
    assert!(
        timeline.contains("assign ugv-") && timeline.contains("runner-up"),
        "{timeline}"
    );
    assert!(timeline.contains("reported by"), "{timeline}");
}

#[test]
fn a_monorail_unit_puts_out_fires_beside_ground_units() {
    let dir = tempfile::tempdir().unwrap();
    let s = demo(dir.path(), "rail-tunnel", &[]);
    assert_eq!(s["fires_out"], 2);
    let procs = s["processes"].as_array().unwrap();
    assert!(
        procs.iter().any(|p| p["role"] == "agent:rail-1"),
        "{procs:?}"
    );
    let rail = s["units"]
        .as_array()
        .unwrap()
        .iter()
        .find(|u| u["id"] == "rail-1")
        .expect("the monorail unit is in the summary");
    assert!(rail["water_used_l"].as_f64().unwrap() > 0.0, "{rail}");
}

/// Every channel has a JSON schema, every message is JSON, and the scene is there.
fn check_recording(path: &Path) {
    let bytes = std::fs::read(path).unwrap();
    let summary = mcap::Summary::read(&bytes)
        .unwrap()
        .expect("the file has a summary section");
    assert!(summary.channels.len() >= 8);
    for c in summary.channels.values() {
        let schema = c
            .schema
            .as_ref()
            .unwrap_or_else(|| panic!("channel {} has no schema", c.topic));
        assert_eq!(schema.encoding, "jsonschema");
        assert_eq!(c.message_encoding, "json");
    }
    let mut scene = 0;
    let mut tasks = 0;
    let mut bt = 0;
    let mut log = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        serde_json::from_slice::<serde_json::Value>(&m.data).unwrap();
        let name = m.channel.schema.as_ref().unwrap().name.as_str();
        scene += usize::from(name == "foxglove.SceneUpdate");
        tasks += usize::from(name == "firefleet.Task");
        bt += usize::from(name == "firefleet.BtTransitions");
        log += usize::from(name == "foxglove.Log");
    }
    assert!(log >= 3, "coordinator decisions as foxglove.Log: {log}");
    assert!(
        scene > 10 && tasks >= 3,
        "scene updates {scene}, tasks {tasks}"
    );
    assert!(bt > 10, "behavior-tree transitions recorded: {bt}");
}

const HANDOVER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/handover.toml");

/// The handover fixture as processes: [simulator, coordinator, ugv-near, ugv-far]. The
/// simulator starts its clock once they are all up.
fn handover_fleet(endpoint: &str, coordinator: &[&str]) -> Fleet {
    Fleet(vec![
        spawn_role(
            HANDOVER,
            endpoint,
            &[
                "sim",
                "--time-scale",
                "6",
                "--wait-for-fleet",
                "30",
                "--wait-for-coordinator",
            ],
        ),
        spawn_role(HANDOVER, endpoint, coordinator),
        spawn_role(HANDOVER, endpoint, &["agent", "--unit", "ugv-near"]),
        spawn_role(HANDOVER, endpoint, &["agent", "--unit", "ugv-far"]),
    ])
}

/// The task progress of the first state that has one, within 90 s; `each` sees every
/// state up to it.
async fn first_at_work(
    states: &Inbox<UnitState>,
    mut each: impl FnMut(&UnitState),
) -> TaskProgress {
    tokio::time::timeout(patient(Duration::from_secs(90)), async {
        loop {
            let (_, st) = states.recv().await.expect("bus open");
            each(&st);
            if let Some(p) = st.task {
                return p;
            }
        }
    })
    .await
    .expect("no unit ever took the fire")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_killed_agent_s_fire_is_reassigned_and_put_out() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let near = UnitId::new("ugv-near").unwrap();
    let far = UnitId::new("ugv-far").unwrap();
    let near_state = bus
        .subscribe::<UnitState>(&keys.unit_state(&near))
        .await
        .unwrap();
    let far_tasks = bus.subscribe::<Task>(&keys.unit_tasks(&far)).await.unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();

    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock", "--lease-s", "3"]);

    let deadline = Instant::now() + patient(Duration::from_secs(120));

    // The near unit takes the fire and sets off: kill it on its way.
    let fire = tokio::time::timeout(patient(Duration::from_secs(90)), async {
        loop {
            let (_, st) = near_state.recv().await.expect("bus open");
            if let Some(p) = st.task
                && p.phase == TaskPhase::Travelling
            {
                return p.fire;
            }
        }
    })
    .await
    .map_err(|_| "near unit never set off")
    .unwrap();
    // The coordinator is up (it assigned the fire). Garbage on the bus changes nothing
    // and is counted.
    let report_key = keys.unit_report(&far);
    let bad_report = FlameReport {
        unit: far.clone(),
        t: 0.0,
        observer: Pose2::new(0.0, 0.0, 0.0),
        observations: vec![FlameObservation {
            position: Point2::new(f64::NAN, 0.0),
            cov: [0.1, 0.0, 0.1],
            confidence: 0.9,
            hrr_kw: None,
        }],
    };
    let mut stale_version = codec::encode(&bad_report);
    stale_version[0] = PROTOCOL_VERSION + 1;
    let ghost = FlameReport {
        unit: UnitId::new("ghost").unwrap(),
        observations: vec![FlameObservation {
            position: Point2::new(30.0, 0.0),
            cov: [0.1, 0.0, 0.1],
            confidence: 0.9,
            hrr_kw: None,
        }],
        ..bad_report.clone()
    };
    bus.put_raw(
        report_key.as_str(),
        vec![PROTOCOL_VERSION, 0xff, 0xff, 0xff],
    )
    .await
    .unwrap();
    bus.put_raw(report_key.as_str(), codec::encode(&bad_report))
        .await
        .unwrap();
    bus.put_raw(report_key.as_str(), stale_version)
        .await
        .unwrap();
    bus.put_raw(
        keys.unit_report(&UnitId::new("ghost").unwrap()).as_str(),
        codec::encode(&ghost),
    )
    .await
    .unwrap();

    fleet.0[2].kill().unwrap();
    fleet.0[2].wait().unwrap();
    let killed_at = Instant::now();

    // The far unit is sent to the same fire.
    let reassigned = tokio::time::timeout(patient(Duration::from_secs(30)), async {
        loop {
            let (_, task) = far_tasks.recv().await.expect("bus open");
            if let TaskKind::Extinguish { fire: f, .. } = task.kind {
                return f;
            }
        }
    })
    .await
    .map_err(|_| "the fire was never reassigned")
    .unwrap();
    assert_eq!(reassigned, fire);
    let reaction = killed_at.elapsed();
    // The figure for the notes: `cargo test --test it fleet::killed -- --nocapture`.
    eprintln!("unit killed -> its fire reassigned: {reaction:?} (wall time)");
    assert!(
        reaction < Duration::from_secs(5),
        "reassignment took {reaction:?}"
    );

    // And the fire goes out before the time limit.
    let truth = outcome(&truths, deadline.saturating_duration_since(Instant::now())).await;
    assert!(
        truth.all_out(),
        "fire still burning at the time limit: {truth:?}"
    );
    let near_truth = truth.units.iter().find(|u| u.id == near).unwrap();
    assert_eq!(
        near_truth.water_used_l, 0.0,
        "the killed unit never sprayed"
    );
    drop(fleet);
    bus.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_restarted_coordinator_takes_over_mid_incident() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let near_state = bus
        .subscribe::<UnitState>(&keys.unit_state(&UnitId::new("ugv-near").unwrap()))
        .await
        .unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("run.mcap");
    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["record", "--out", recording.to_str().unwrap()],
    ));

    // Kill the coordinator as soon as a unit works on the fire, and start a new one.
    let p = first_at_work(&near_state, |_| {}).await;
    let (old_seq, old_fire) = (p.seq, p.fire);
    fleet.0[1].kill().unwrap();
    fleet.0[1].wait().unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["coordinator", "--sim-clock"],
    ));

    // The new coordinator knows the fire and its tasks are taken: every fire goes out.
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(
        truth.all_out(),
        "fire forgotten after the coordinator restarted: {truth:?}"
    );
    let status = status_of(&bus, Duration::from_secs(10)).await;
    assert!(
        !status["fires"].as_array().unwrap().is_empty(),
        "the new coordinator knows the fire: {status}"
    );
    let tasks: Vec<u64> = status["units"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|u| u["task"]["seq"].as_u64())
        .collect();
    // The running task was adopted (it keeps its number); every new one is numbered above.
    assert!(
        tasks.iter().all(|s| *s >= old_seq),
        "new tasks {tasks:?} must outnumber the old {old_seq}"
    );
    let decisions = status["decisions"].to_string();
    assert!(
        decisions.contains(&format!("task {old_seq} on fire {old_fire}"))
            && decisions.contains("adopt"),
        "the new coordinator adopted the running task on the fire it recalled: {decisions}"
    );
    assert!(
        decisions.contains(&format!("recall fire {old_fire}")),
        "the new coordinator recalled the recorded track: {decisions}"
    );
    drop(fleet);
    bus.close().await;
}

/// The simulator killed mid-incident and started again on its state directory carries the
/// rehearsal on: its clock goes on from where the world was kept, not from 0 (which every
/// role would refuse as stale, wedging the site), the unit at work is where it was, and the
/// fire still goes out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_simulator_restarted_mid_incident_carries_the_rehearsal_on() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let near = UnitId::new("ugv-near").unwrap();
    let near_state = bus
        .subscribe::<UnitState>(&keys.unit_state(&near))
        .await
        .unwrap();
    let clock = bus.subscribe::<SimClock>(&keys.sim_clock()).await.unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("sim");
    let sim = || {
        spawn_role(
            HANDOVER,
            &endpoint,
            &[
                "sim",
                "--time-scale",
                "6",
                "--wait-for-fleet",
                "30",
                "--state-dir",
                state.to_str().unwrap(),
            ],
        )
    };
    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    fleet.0[0].kill().unwrap();
    fleet.0[0].wait().unwrap();
    fleet.0[0] = sim();

    // Killed once the near unit is on its way to the fire, a few seconds in.
    first_at_work(&near_state, |_| {}).await;
    let mut before = None;
    while let Some((_, c)) = clock.try_recv() {
        before = Some(c.t);
    }
    let (_, c) = clock.recv().await.expect("bus open");
    let before = before.map_or(c.t, |b: f64| b.max(c.t));
    let (_, truth) = truths.recv().await.expect("bus open");
    let pose_before = truth.units.iter().find(|u| u.id == near).unwrap().pose;
    fleet.0[0].kill().unwrap();
    fleet.0[0].wait().unwrap();
    while clock.try_recv().is_some() {}
    while truths.try_recv().is_some() {}
    fleet.0[0] = sim();

    let (_, after) = tokio::time::timeout(patient(Duration::from_secs(20)), clock.recv())
        .await
        .expect("the restarted simulator never ran")
        .expect("bus open");
    // Kept every site second: at most that much is lost.
    assert!(
        after.t >= before - 1.0 - 1e-6,
        "the clock went back from {before:.2} s to {:.2} s",
        after.t
    );
    let (_, truth) = truths.recv().await.expect("bus open");
    let pose_after = truth.units.iter().find(|u| u.id == near).unwrap().pose;
    assert!(
        pose_after.position().dist(pose_before.position()) < 3.0,
        "the unit was put back at its start: {pose_before:?} -> {pose_after:?}"
    );
    // Unread, the clock's inbox would fill and hold up this session (the router) with it.
    drop(clock);
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(
        truth.all_out(),
        "the rehearsal did not carry on after the simulator's restart: {truth:?}"
    );
    drop(fleet);
    bus.close().await;
}

/// With nothing recorded, a coordinator restarted mid-incident waits for the site clock and
/// hears the units' task numbers before its first decision: every task it gives is dated by
/// the site clock and numbered at or above what the units hold (a unit ignores a lower one).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_restarted_with_nothing_recorded_outnumbers_the_units_from_its_first_task() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let states = bus
        .subscribe::<UnitState>(&keys.every_unit_state())
        .await
        .unwrap();
    let tasks = bus
        .subscribe::<Task>(&keys.every_unit_task())
        .await
        .unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    let mut held = 0;
    first_at_work(&states, |st| held = held.max(st.task_seq.unwrap_or(0))).await;
    fleet.0[1].kill().unwrap();
    fleet.0[1].wait().unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    while let Some((_, st)) = states.try_recv() {
        held = held.max(st.task_seq.unwrap_or(0));
    }
    let mut now = 0.0;
    while let Some((_, truth)) = truths.try_recv() {
        now = truth.t;
    }
    while tasks.try_recv().is_some() {}
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["coordinator", "--sim-clock"],
    ));
    let (_, first) = tokio::time::timeout(patient(Duration::from_secs(20)), tasks.recv())
        .await
        .expect("the new coordinator gave no task")
        .expect("bus open");
    let until = Instant::now() + Duration::from_secs(3);
    let mut given = vec![first];
    while let Ok(Some((_, k))) = tokio::time::timeout_at(until.into(), tasks.recv()).await {
        given.push(k);
    }
    for k in &given {
        assert!(
            k.t >= now,
            "decided before the site clock (t = {now:.1} s): {k:?}"
        );
        assert!(
            k.seq >= held,
            "numbered below the {held} a unit holds: {k:?}"
        );
    }
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(truth.all_out(), "{truth:?}");
    drop(fleet);
    bus.close().await;
}

/// A standby coordinator follows the incident, and when the coordinator in charge is
/// killed takes over with no recorder running: it knows the fire, numbers above the units,
/// and the fire goes out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_standby_coordinator_takes_over_when_the_one_in_charge_is_killed() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let states = bus
        .subscribe::<UnitState>(&keys.every_unit_state())
        .await
        .unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["coordinator", "--sim-clock", "--standby", "--rank", "1"],
    ));
    let fire = first_at_work(&states, |_| {}).await.fire;
    fleet.0[1].kill().unwrap();
    fleet.0[1].wait().unwrap();
    let killed = Instant::now();
    let key = keys.expr(&Topic::CoordStatus);
    let status = loop {
        let answers = bus
            .ask(&key, Ask::within(Duration::from_secs(10)))
            .await
            .unwrap();
        if let Some(answer) = answers.recv().await {
            break serde_json::from_slice::<serde_json::Value>(&answer.bytes).unwrap();
        }
        assert!(
            killed.elapsed() < Duration::from_secs(10),
            "no coordinator took over"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    eprintln!(
        "standby took over {:.2} s after the kill",
        killed.elapsed().as_secs_f64()
    );
    assert!(
        status["decisions"]
            .to_string()
            .contains(&format!("recall fire {fire}")),
        "the standby took the fire it followed: {status}"
    );
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(truth.all_out(), "{truth:?}");
    drop(fleet);
    bus.close().await;
}

/// Send `signal` (`STOP`, `CONT`) to a child process.
fn signal(child: &std::process::Child, signal: &str) {
    let ok = Command::new("kill")
        .args([format!("-{signal}"), child.id().to_string()])
        .status()
        .unwrap()
        .success();
    assert!(ok, "kill -{signal} {}", child.id());
}

/// The coordinator in office paused (SIGSTOP, as a hung host or a cut link would leave it)
/// until its lease lapses: the standby takes office in a newer term. Resumed, its lease is
/// back and the lowest rank holds office (`firefleet_protocol::office`): the standby steps
/// down, the units take the resumed coordinator's tasks although its term is older (the
/// office changed hands), and from then on no task of the standby's term is sent. The fire
/// goes out.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_paused_coordinator_that_comes_back_holds_office_again_and_its_standby_stands_down() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let states = bus
        .subscribe::<UnitState>(&keys.every_unit_state())
        .await
        .unwrap();
    let tasks = bus
        .subscribe::<Task>(&keys.every_unit_task())
        .await
        .unwrap();
    let log = bus
        .subscribe::<firefleet_protocol::msg::Decision>(&keys.coord_log())
        .await
        .unwrap();
    let mut fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["coordinator", "--sim-clock", "--standby", "--rank", "1"],
    ));
    first_at_work(&states, |_| {}).await;
    let first = tokio::time::timeout(patient(Duration::from_secs(10)), tasks.recv())
        .await
        .unwrap()
        .unwrap()
        .1
        .epoch;
    signal(&fleet.0[1], "STOP");
    // The standby's term begins once the paused coordinator's lease lapses. (Every inbox
    // is read all along: a full one would hold up the test's whole session.)
    let paused = Instant::now();
    let second = tokio::time::timeout(patient(Duration::from_secs(40)), async {
        loop {
            tokio::select! {
                Some((_, task)) = tasks.recv() => if task.epoch != first {
                    return task.epoch;
                },
                Some(_) = states.recv() => {}
                Some(_) = log.recv() => {}
            }
        }
    })
    .await
    .expect("the standby never took office");
    assert!(second > first);
    assert_eq!(second % 16, 1, "the standby's term is of its rank");
    eprintln!(
        "the standby took office {:.1} s after the pause",
        paused.elapsed().as_secs_f64()
    );
    signal(&fleet.0[1], "CONT");
    let stepped_down = tokio::time::timeout(patient(Duration::from_secs(20)), async {
        loop {
            tokio::select! {
                Some((_, d)) = log.recv() => if d.text.starts_with("stepped down") {
                    return d.text;
                },
                Some(_) = states.recv() => {}
                Some(_) = tasks.recv() => {}
            }
        }
    })
    .await
    .expect("the standby never stepped down");
    assert!(
        stepped_down.contains("coordinator holds office")
            && stepped_down.contains("coordinator:1 stands by"),
        "{stepped_down}"
    );
    // Every unit is back on the resumed coordinator's term, and from the standby's
    // step-down on nobody gives a task of its term.
    while tasks.try_recv().is_some() {}
    tokio::time::timeout(patient(Duration::from_secs(20)), async {
        let mut back = std::collections::BTreeSet::new();
        loop {
            tokio::select! {
                Some((_, st)) = states.recv() => if st.epoch.is_some_and(|e| e % 16 == 0) {
                    back.insert(st.unit);
                    if back.len() == 2 {
                        return;
                    }
                },
                Some((_, task)) = tasks.recv() => assert_eq!(task.epoch % 16, 0, "{task:?}"),
                Some(_) = log.recv() => {}
            }
        }
    })
    .await
    .expect("the units never took the resumed coordinator's tasks");
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(truth.all_out(), "{truth:?}");
    drop(fleet);
    bus.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_fire_nobody_works_on_survives_a_coordinator_restart() {
    let (bus, endpoint) = router("handover").await;
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("run.mcap");
    let mut fleet = Fleet(vec![spawn_role(
        HANDOVER,
        &endpoint,
        &["record", "--out", recording.to_str().unwrap()],
    )]);
    // The coordinator that died had tracked f7; the recorder kept its last track.
    until_recorded(&bus, &f7()).await;
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["coordinator", "--sim-clock"],
    ));
    assert_f7_recalled(&status_of(&bus, Duration::from_secs(30)).await);
    drop(fleet);
    bus.close().await;
}

/// The last track of fire f7 as a coordinator that has since died published it: confirmed,
/// nobody on it, nobody looking at it now.
fn f7() -> FireTrack {
    FireTrack {
        id: FireId(7),
        t: 30.0,
        position: Point2::new(70.0, 1.0),
        cov: [0.3, 0.0, 0.3],
        confidence: 0.9,
        state: FireState::Confirmed,
        assigned: Vec::new(),
        seen_by: vec![UnitId::new("ugv-near").unwrap()],
        hrr_kw: Some(4000.0),
    }
}

/// Publish `track` until the recorder on the bus answers a recall query with it.
async fn until_recorded(bus: &Bus, track: &FireTrack) {
    let keys = bus.keys().clone();
    tokio::time::timeout(patient(Duration::from_secs(30)), async {
        loop {
            bus.put(&keys.fire(track.id), track).await.unwrap();
            let answers = bus
                .ask(
                    keys.every_fire().as_str(),
                    Ask::within(Duration::from_secs(10)),
                )
                .await
                .unwrap();
            if answers.recv().await.is_some() {
                return;
            }
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
    })
    .await
    .expect("the recorder never answered with the track");
}

/// The coordinator whose status this is took f7 back under its id.
fn assert_f7_recalled(status: &serde_json::Value) {
    let fires = status["fires"].as_array().unwrap();
    assert_eq!(fires.len(), 1, "{status}");
    assert_eq!(fires[0]["id"], "f7", "the fire keeps its id: {status}");
    assert_eq!(fires[0]["state"], "confirmed", "{status}");
    assert!(
        status["decisions"].to_string().contains("recall fire f7"),
        "{status}"
    );
}

/// The recorder dies too (killed outright, its file never finished); a coordinator
/// started with `--resume` on what it left still keeps the fire.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_resumed_from_a_killed_recorders_file_keeps_the_fire() {
    let (bus, endpoint) = router("handover").await;
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("run.mcap");
    let recorder = Fleet(vec![spawn_role(
        HANDOVER,
        &endpoint,
        &["record", "--out", recording.to_str().unwrap()],
    )]);
    until_recorded(&bus, &f7()).await;
    // The recorder writes its file out as it goes: the fire must be in it.
    until_in_recording(&recording, "/fire/f7", "", Duration::from_secs(10)).await;
    drop(recorder);
    let _coordinator = Fleet(vec![spawn_role(
        HANDOVER,
        &endpoint,
        &[
            "coordinator",
            "--sim-clock",
            "--resume",
            recording.to_str().unwrap(),
        ],
    )]);
    assert_f7_recalled(&status_of(&bus, Duration::from_secs(30)).await);
    bus.close().await;
}

/// `firefleet goal set --zone deep` with `args` on the rail tunnel, sent again until it is
/// accepted (the coordinator needs a moment to join) or 20 s pass; the last answer.
async fn set_goal(endpoint: &str, args: &[&str]) -> std::process::Output {
    let set: Vec<&str> = ["goal", "set", "--zone", "deep"]
        .iter()
        .chain(args)
        .copied()
        .collect();
    let deadline = Instant::now() + patient(Duration::from_secs(20));
    loop {
        let out = cli("rail-tunnel", endpoint, &set);
        if out.status.success() || Instant::now() > deadline {
            return out;
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commanders_goals_are_answered_listed_and_cleared() {
    let (bus, endpoint) = router("tunnel-r").await;
    let fleet = Fleet(vec![spawn_role("rail-tunnel", &endpoint, &["coordinator"])]);
    let out = set_goal(&endpoint, &["--goal", "keep-out", "--priority", "1"]).await;
    assert_says(
        &out,
        0,
        "goal 'firefleet-cli-deep-keep-out' on zone deep: accepted",
    );

    let out = cli(
        "rail-tunnel",
        &endpoint,
        &["goal", "set", "--zone", "nowhere", "--goal", "monitor"],
    );
    assert_says(&out, 1, "unknown zone 'nowhere' (zones: portal, deep)");
    let out = cli(
        "rail-tunnel",
        &endpoint,
        &[
            "goal",
            "set",
            "--zone",
            "deep",
            "--goal",
            "monitor",
            "--priority",
            "1",
            "--id",
            "m",
        ],
    );
    assert_says(&out, 1, "conflicts with goal 'firefleet-cli-deep-keep-out'");
    let out = cli(
        "rail-tunnel",
        &endpoint,
        &["goal", "set", "--zone", "deep", "--goal", "contain"],
    );
    assert_eq!(
        out.status.code(),
        Some(2),
        "refused before sending: contain needs before_m"
    );
    assert!(text(&out).contains("before_m"), "{}", text(&out));

    // Any Zenoh client may send JSON; a malformed goal is answered too.
    let acks = bus
        .subscribe(&bus.keys().zone_ack(&ZoneId::new("deep").unwrap()))
        .await
        .unwrap();
    let put = |key: &'static str, json: &'static str| bus.put_raw(key, json.into());
    put(
        "ff/tunnel-r/zone/deep/goal/x",
        r#"{"id": "x", "zone": "deep", "goal": "flood"}"#,
    )
    .await
    .unwrap();
    let (_, ack) = tokio::time::timeout(patient(Duration::from_secs(5)), acks.recv())
        .await
        .unwrap()
        .unwrap();
    assert!(
        !ack.accepted && ack.reason.starts_with("malformed"),
        "{ack:?}"
    );
    // A key whose zone chunk is no zone id at all has no ack key: counted, not lost.
    let invalid = |v: &serde_json::Value| v["rejected"]["invalid"].as_u64().unwrap_or(0);
    let before = invalid(&status_of(&bus, Duration::from_secs(5)).await);
    put(
        "ff/tunnel-r/zone/WEST/goal/x",
        r#"{"id": "w", "zone": "WEST", "goal": "monitor"}"#,
    )
    .await
    .unwrap();
    let deadline = Instant::now() + patient(Duration::from_secs(5));
    while invalid(&status_of(&bus, Duration::from_secs(5)).await) == before {
        assert!(
            Instant::now() < deadline,
            "a goal on zone/WEST was not counted"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }

    let out = cli("rail-tunnel", &endpoint, &["goal", "list"]);
    assert!(
        text(&out).contains("firefleet-cli-deep-keep-out") && text(&out).contains("keep-out"),
        "{}",
        text(&out)
    );
    let out = cli("rail-tunnel", &endpoint, &["status"]);
    assert!(
        text(&out).contains("goals:") && text(&out).contains("firefleet-cli-deep-keep-out"),
        "{}",
        text(&out)
    );
    assert!(
        cli(
            "rail-tunnel",
            &endpoint,
            &["goal", "clear", "--zone", "deep"]
        )
        .status
        .success()
    );
    // "Cleared" is said once the coordinator holds the goal no more, not when the delete
    // left: the list asked right after has none.
    let out = cli("rail-tunnel", &endpoint, &["goal", "list"]);
    assert!(text(&out).contains("(none)"), "not cleared: {}", text(&out));

    // With nobody to hold the goals, a clear is not said to be done.
    drop(fleet);
    let out = cli(
        "rail-tunnel",
        &endpoint,
        &["goal", "clear", "--zone", "deep"],
    );
    assert_says(&out, 2, "no answer from a coordinator within 5 s");
}

/// `status --watch` says, round after round, who is in office and who could take over:
/// a standby gone is said ("NO STANDBY"), and a coordinator gone too.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn status_watch_shows_the_office_and_the_standby_as_they_come_and_go() {
    let (_router, endpoint) = router("tunnel-r").await;
    let mut fleet = Fleet(vec![
        spawn_role("rail-tunnel", &endpoint, &["coordinator"]),
        spawn_role(
            "rail-tunnel",
            &endpoint,
            &["coordinator", "--standby", "--rank", "1"],
        ),
    ]);
    let (watch, lines) = spawn_watched("rail-tunnel", &endpoint, &["status", "--watch", "0.3"]);
    fleet.0.push(watch);
    let within = Duration::from_secs(20);
    until_line(
        &lines,
        "office: coordinator in office; standing by: rank 1",
        within,
    );
    for (k, said) in [
        (
            1,
            "office: coordinator in office; NO STANDBY: nobody could take over",
        ),
        (0, "office: NO COORDINATOR IN OFFICE; NO STANDBY"),
    ] {
        fleet.0[k].kill().unwrap();
        fleet.0[k].wait().unwrap();
        until_line(&lines, said, within);
    }
    until_line(&lines, "NO COORDINATOR ANSWERS", within);
}

/// A power cut: the coordinator and its standby go down together, with no recorder
/// running. Each kept the goals in force in its state directory, so a coordinator started
/// on either host bars what was barred from its first word; and a clear outlives a restart
/// as a goal does (a cleared keep-out does not come back).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn goals_outlive_the_coordinator_and_its_standby_going_down_together() {
    let (bus, endpoint) = router("tunnel-r").await;
    let told = bus.subscribe(&bus.keys().coord_barred()).await.unwrap();
    let dir = tempfile::tempdir().unwrap();
    let (here, standby_host) = (dir.path().join("coordinator"), dir.path().join("standby"));
    let coordinator = |state: &Path, extra: &[&str]| {
        let args: Vec<&str> = ["coordinator", "--state-dir", state.to_str().unwrap()]
            .iter()
            .chain(extra)
            .copied()
            .collect();
        spawn_role("rail-tunnel", &endpoint, &args)
    };
    let mut fleet = Fleet(vec![
        coordinator(&here, &[]),
        coordinator(&standby_host, &["--standby", "--rank", "1"]),
    ]);
    let out = set_goal(&endpoint, &["--goal", "keep-out", "--rail-allowed"]).await;
    assert_says(&out, 0, "accepted");
    let barred = barred_answer(&bus, Duration::from_secs(5)).await.spans;
    // The standby keeps what it follows: wait until its record has the goal.
    let record = standby_host.join("goals-in-force.json");
    let deadline = Instant::now() + patient(Duration::from_secs(10));
    while !std::fs::read_to_string(&record)
        .unwrap_or_default()
        .contains("firefleet-cli-deep-keep-out")
    {
        assert!(Instant::now() < deadline, "the standby never kept the goal");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let restart = |fleet: &mut Fleet, state: &Path| {
        for c in &mut fleet.0 {
            c.kill().unwrap();
            c.wait().unwrap();
        }
        while told.try_recv().is_some() {}
        fleet.0.push(coordinator(state, &[]));
    };
    let first_word = || async {
        let (_, first) = tokio::time::timeout(patient(Duration::from_secs(20)), told.recv())
            .await
            .expect("the restarted coordinator never published the barred space")
            .expect("bus open");
        first.spans
    };
    restart(&mut fleet, &standby_host);
    assert_eq!(first_word().await, barred, "lifted by the power cut");
    let status = status_of(&bus, Duration::from_secs(10)).await;
    assert_eq!(
        status["goals"][0]["id"], "firefleet-cli-deep-keep-out",
        "{status}"
    );
    // Cleared, then everything down again: the clear is what is kept.
    assert!(
        cli(
            "rail-tunnel",
            &endpoint,
            &["goal", "clear", "--zone", "deep"]
        )
        .status
        .success()
    );
    let deadline = Instant::now() + patient(Duration::from_secs(10));
    while std::fs::read_to_string(&record)
        .unwrap_or_default()
        .contains("firefleet-cli-deep-keep-out")
    {
        assert!(Instant::now() < deadline, "the clear was never kept");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    restart(&mut fleet, &standby_host);
    assert_eq!(
        first_word().await,
        Vec::new(),
        "a cleared keep-out came back"
    );
    bus.close().await;
}

/// The barred space on `coord/barred` as whoever answers a query (the coordinator, or a
/// recorder once it is gone) gives it, once it bars something.
async fn barred_answer(bus: &Bus, within: Duration) -> BarredSpace {
    let key = bus.keys().coord_barred();
    first_answer(bus, key.as_str(), within, |b| {
        codec::decode::<BarredSpace>(b)
            .ok()
            .filter(|b| !b.spans.is_empty())
    })
    .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn barred_space_reaches_the_units_and_outlives_the_coordinator_and_the_recorder() {
    let (bus, endpoint) = router("tunnel-r").await;
    let told = bus.subscribe(&bus.keys().coord_barred()).await.unwrap();
    let dir = tempfile::tempdir().unwrap();
    let recording = dir.path().join("run.mcap");
    let mut fleet = Fleet(vec![
        spawn_role("rail-tunnel", &endpoint, &["coordinator"]),
        spawn_role(
            "rail-tunnel",
            &endpoint,
            &["record", "--out", recording.to_str().unwrap()],
        ),
    ]);
    let out = set_goal(&endpoint, &["--goal", "keep-out", "--rail-allowed"]).await;
    assert_says(&out, 0, "accepted");
    // Every unit hears it on the fleet-wide key.
    let b = tokio::time::timeout(patient(Duration::from_secs(5)), async {
        loop {
            let (_, b) = told.recv().await.expect("bus open");
            if !b.spans.is_empty() {
                return b;
            }
        }
    })
    .await
    .expect("the barred space was never published");
    let s = &b.spans[0];
    assert_eq!(
        (
            s.goal.as_str(),
            s.zone.as_str(),
            s.start.m(),
            s.end.m(),
            s.bar,
            s.rail_allowed
        ),
        (
            "firefleet-cli-deep-keep-out",
            "deep",
            100.0,
            300.0,
            Bar::Entry,
            true
        ),
        "{b:?}"
    );
    // A unit starting now asks, and the coordinator answers; with the coordinator gone,
    // the recorder does.
    assert_eq!(
        barred_answer(&bus, Duration::from_secs(5)).await.spans,
        b.spans
    );
    // Both answer once the recorder has heard it (it may have started after the change
    // was published; the re-send reaches it within a second). Answers on one key are
    // consolidated into one unless asked otherwise.
    let key = bus.keys().coord_barred();
    let deadline = Instant::now() + patient(Duration::from_secs(10));
    loop {
        let every = Ask {
            every_answer: true,
            ..Ask::within(Duration::from_secs(10))
        };
        let answers = bus.ask(key.as_str(), every).await.unwrap();
        let mut barring = 0;
        while let Some(answer) = answers.recv().await {
            if codec::decode::<BarredSpace>(&answer.bytes).is_ok_and(|a| a.spans == b.spans) {
                barring += 1;
            }
        }
        if barring >= 2 {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the recorder never kept the barred space"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    fleet.0[0].kill().unwrap();
    fleet.0[0].wait().unwrap();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(
        barred_answer(&bus, Duration::from_secs(5)).await.spans,
        b.spans
    );
    // A coordinator started now takes the goal back before it tells the units anything:
    // its first word on the barred space still bars deep (a restart lifts no keep-out).
    while told.try_recv().is_some() {}
    fleet
        .0
        .push(spawn_role("rail-tunnel", &endpoint, &["coordinator"]));
    let (_, first) = tokio::time::timeout(patient(Duration::from_secs(20)), told.recv())
        .await
        .expect("the new coordinator never published the barred space")
        .expect("bus open");
    assert_eq!(first.spans, b.spans, "lifted by the restart");
    let recalled = |status: &serde_json::Value| {
        assert_eq!(
            status["goals"][0]["id"], "firefleet-cli-deep-keep-out",
            "{status}"
        );
        assert!(
            status["decisions"].to_string().contains(
                "recall goal 'firefleet-cli-deep-keep-out' (KeepOut, priority 0) on zone deep"
            ),
            "{status}"
        );
    };
    recalled(&status_of(&bus, Duration::from_secs(10)).await);
    // The recorder is killed outright (its file never finished) and the coordinator
    // stopped: one started with --resume on that file, no recorder running, still bars
    // deep from its first word. The goals are in the file it wrote out as it went.
    until_in_recording(
        &recording,
        "/coord/goals",
        "firefleet-cli-deep-keep-out",
        Duration::from_secs(10),
    )
    .await;
    for k in [1, 2] {
        fleet.0[k].kill().unwrap();
        fleet.0[k].wait().unwrap();
    }
    while told.try_recv().is_some() {}
    fleet.0.push(spawn_role(
        "rail-tunnel",
        &endpoint,
        &["coordinator", "--resume", recording.to_str().unwrap()],
    ));
    let (_, first) = tokio::time::timeout(patient(Duration::from_secs(20)), told.recv())
        .await
        .expect("the resumed coordinator never published the barred space")
        .expect("bus open");
    assert_eq!(first.spans, b.spans, "lifted by a restart with no recorder");
    recalled(&status_of(&bus, Duration::from_secs(10)).await);
    bus.close().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn forged_tasks_do_not_leave_a_unit_deaf_to_its_coordinator() {
    let (bus, endpoint) = router("handover").await;
    let keys = bus.keys().clone();
    let near = UnitId::new("ugv-near").unwrap();
    let near_state = bus
        .subscribe::<UnitState>(&keys.unit_state(&near))
        .await
        .unwrap();
    let truths = bus.subscribe::<SimTruth>(&keys.sim_truth()).await.unwrap();
    let _fleet = handover_fleet(&endpoint, &["coordinator", "--sim-clock"]);
    // Once the near unit is on its way to the fire, an impostor tells it to stand by: once
    // numbered near u64::MAX (refused: ahead of the clock), once just above its task
    // (taken; the coordinator sees a number it never gave and tasks the unit again above).
    let (epoch, taken) = tokio::time::timeout(patient(Duration::from_secs(90)), async {
        loop {
            let (_, st) = near_state.recv().await.expect("bus open");
            if st.task.is_some_and(|p| p.phase == TaskPhase::Travelling) {
                let seq = st.task_seq.expect("a unit on a task echoes its number");
                return (st.epoch.expect("and its epoch"), seq);
            }
        }
    })
    .await
    .expect("the near unit never set off");
    // In the coordinator's own epoch: a task of an older one the unit refuses outright.
    for seq in [u64::MAX, taken + 500] {
        let forged = Task {
            unit: near.clone(),
            epoch,
            seq,
            t: 0.0,
            kind: TaskKind::Standby,
        };
        bus.put(&keys.unit_task(&near, forged.rank()), &forged)
            .await
            .unwrap();
    }
    // The near unit itself is back on the coordinator's numbering (not only the far one
    // covering for it).
    tokio::time::timeout(patient(Duration::from_secs(30)), async {
        loop {
            let (_, st) = near_state.recv().await.expect("bus open");
            if st.task_seq.is_some_and(|s| s > taken + 500 && s < u64::MAX) {
                return;
            }
        }
    })
    .await
    .expect("the near unit never took the coordinator's task again");
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(
        truth.all_out(),
        "a forged task kept the fire burning: {truth:?}"
    );
    let status = status_of(&bus, Duration::from_secs(10)).await;
    assert!(
        status["decisions"].to_string().contains(&format!(
            "took task {}, which this coordinator never gave",
            taken + 500
        )),
        "{status}"
    );
    bus.close().await;
}

/// A robot powered up before the site's router: its agent waits, trying again, and joins
/// once the router listens; a command a person waits on fails at once instead.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_unit_started_before_its_router_waits_and_joins_it() {
    let endpoint = free_endpoint();
    let mut fleet = Fleet(vec![spawn_role(
        "vehicle-collision",
        &endpoint,
        &["agent", "--unit", "ugv-1"],
    )]);
    let status = cli("vehicle-collision", &endpoint, &["status"]);
    assert_says(&status, 2, "joining the Zenoh network");
    tokio::time::sleep(Duration::from_secs(3)).await;
    assert!(
        fleet.0[0].try_wait().unwrap().is_none(),
        "the agent gave up before its router came"
    );
    let router = router_at("tunnel-a", &endpoint).await;
    let token = router
        .keys()
        .expr(&Topic::UnitAlive(UnitId::new("ugv-1").unwrap()));
    let deadline = Instant::now() + patient(Duration::from_secs(20));
    loop {
        if !router.tokens_alive(&token).await.unwrap().is_empty() {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the agent never joined its router"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    router.close().await;
}

/// Two processes can hold `coord/office/0/alive` at once (the coordinator and a thief of its key,
/// or a second one started by mistake): the lease must count as lapsed only when the last
/// of them is, or a standby would take over beside a coordinator still in charge. Zenoh's routers keep twin tokens apart; this holds them to it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_coordinator_token_is_gone_only_when_every_holder_is() {
    let (router, endpoint) = router("tunnel-a").await;
    let client = || async {
        let c = firefleet_bus::Connect {
            mode: Some(firefleet_bus::Mode::Client),
            connect: vec![endpoint.clone()],
            ..Default::default()
        };
        Bus::open(&c, router.keys().site().clone()).await.unwrap()
    };
    let (a, b, watcher) = (client().await, client().await, client().await);
    let key = router.keys().expr(&Topic::CoordAlive(0));
    let seen = watcher.watch_tokens(&key).await.unwrap();
    let ta = a.token(&Topic::CoordAlive(0)).await.unwrap();
    let tb = b.token(&Topic::CoordAlive(0)).await.unwrap();
    let (_, alive) = tokio::time::timeout(patient(Duration::from_secs(2)), seen.recv())
        .await
        .unwrap()
        .unwrap();
    assert!(alive);
    drop(ta);
    a.close().await;
    let after_one = tokio::time::timeout(Duration::from_secs(2), async {
        loop {
            let (topic, alive) = seen.recv().await.unwrap();
            if !alive {
                return topic;
            }
        }
    })
    .await;
    assert!(
        after_one.is_err(),
        "the token counted gone while b still holds it"
    );
    drop(tb);
    let gone = tokio::time::timeout(patient(Duration::from_secs(2)), async {
        loop {
            let (topic, alive) = seen.recv().await.unwrap();
            if !alive {
                return topic;
            }
        }
    })
    .await;
    assert!(gone.is_ok(), "the token never counted gone");
    for bus in [b, watcher, router] {
        bus.close().await;
    }
}

/// A robot added to the site while the coordinator still runs on the old site file: its
/// agent is linked but not ready, its /readyz saying the coordinator's reason, until the
/// coordinator is restarted with the new site file and tasks it; then ready.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_agent_the_coordinator_does_not_know_is_not_ready_and_says_why() {
    let (_router, endpoint) = router("tunnel-r").await;
    let dir = tempfile::tempdir().unwrap();
    let added = dir.path().join("site.toml");
    let shipped = std::fs::read_to_string("model/scenarios/rail-tunnel.toml").unwrap();
    std::fs::write(
        &added,
        format!("{shipped}\n[[units]]\nid = \"ugv-9\"\nkind = \"ground\"\nx_m = 5.0\ny_m = 2.5\n"),
    )
    .unwrap();
    let added = added.to_str().unwrap();
    // The simulator has the robot's body (its file is the new one); the coordinator the
    // old file.
    let mut fleet = Fleet(vec![
        spawn_role("rail-tunnel", &endpoint, &["coordinator", "--sim-clock"]),
        spawn_role(added, &endpoint, &["sim", "--time-scale", "4"]),
    ]);
    let addr = format!("127.0.0.1:{}", firefleet_bus::free_loopback_port().unwrap());
    fleet.0.push(spawn_role(
        added,
        &endpoint,
        &["agent", "--unit", "ugv-9", "--metrics", &addr],
    ));
    let readyz = |code: u16, needle: &str| {
        let deadline = Instant::now() + patient(Duration::from_secs(30));
        loop {
            let (got, body) = http_get(&addr, "/readyz");
            if got == code && body.contains(needle) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "/readyz never said {code} {needle:?}: {got} {body}"
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    };
    readyz(
        503,
        "unknown unit 'ugv-9': not in this coordinator's site file",
    );
    // The coordinator restarted with the new site file takes it (tasks it): ready.
    fleet.0[0].kill().unwrap();
    fleet.0[0].wait().unwrap();
    fleet.0[0] = spawn_role(added, &endpoint, &["coordinator", "--sim-clock"]);
    readyz(200, "ready");
}

/// Issue #37: every long-running role serves /healthz, /readyz and Prometheus /metrics
/// with `--metrics`; the coordinator's figures follow the incident, and a unit whose
/// router is gone is alive but not ready.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn roles_serve_health_readiness_and_metrics() {
    let (bus, endpoint) = router("handover").await;
    let truths = bus
        .subscribe::<SimTruth>(&bus.keys().sim_truth())
        .await
        .unwrap();
    let at = || format!("127.0.0.1:{}", free_loopback_port().unwrap());
    let (coord, agent) = (at(), at());
    let mut fleet = handover_fleet(
        &endpoint,
        &["coordinator", "--sim-clock", "--metrics", &coord],
    );
    // ugv-far again, serving its metrics.
    let mut plain = fleet.0.pop().unwrap();
    plain.kill().unwrap();
    plain.wait().unwrap();
    fleet.0.push(spawn_role(
        HANDOVER,
        &endpoint,
        &["agent", "--unit", "ugv-far", "--metrics", &agent],
    ));
    let truth = outcome(&truths, Duration::from_secs(90)).await;
    assert!(truth.all_out(), "{truth:?}");
    for addr in [&coord, &agent] {
        assert_eq!(http_get(addr, "/healthz").0, 200, "{addr}");
        assert_eq!(http_get(addr, "/readyz").0, 200, "{addr}");
    }
    // A unit of another release (a rolling upgrade half done): refused, counted, and shown
    // as such in the status, not as lost.
    let far = UnitId::new("ugv-far").unwrap();
    bus.put_raw(
        bus.keys().unit_state(&far).as_str(),
        vec![PROTOCOL_VERSION + 1, 0, 0],
    )
    .await
    .unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let out = cli(HANDOVER, &endpoint, &["status"]);
    let said = text(&out);
    let line = said
        .lines()
        .find(|l| l.contains("ugv-far"))
        .unwrap_or_default();
    assert!(
        line.contains(" other ")
            && line.contains(&format!(
                "OTHER PROTOCOL: speaks version {}",
                PROTOCOL_VERSION + 1
            )),
        "{said}"
    );
    let (code, text) = http_get(&coord, "/metrics");
    assert_eq!(code, 200, "{text}");
    let value = |series: &str| -> f64 {
        text.lines()
            .find_map(|l| l.strip_prefix(series)?.strip_prefix(' ')?.parse().ok())
            .unwrap_or_else(|| panic!("no {series} in\n{text}"))
    };
    assert_eq!(value("firefleet_links{with=\"router\"}"), 1.0);
    assert_eq!(value("firefleet_links{with=\"client\"}"), 0.0);
    assert_eq!(value("firefleet_ready"), 1.0);
    assert!(value("firefleet_messages_sent_total") > 10.0);
    assert!(value("firefleet_messages_received_total") > 10.0);
    for reason in ["undecodable", "version", "invalid", "overflow"] {
        value(&format!(
            "firefleet_messages_rejected_total{{reason=\"{reason}\"}}"
        ));
    }
    assert!(value("firefleet_coordinator_reports_total") >= 1.0);
    assert!(value("firefleet_coordinator_report_to_task_seconds_count") >= 1.0);
    value("firefleet_coordinator_report_to_task_seconds_bucket{le=\"0.001\"}");
    value("firefleet_coordinator_fires");
    value("firefleet_coordinator_tasks");
    value("firefleet_coordinator_lease_misses_total");
    assert_eq!(value("firefleet_coordinator_in_office"), 1.0);

    // The router gone: the agent lives on, and says it is not ready.
    bus.close().await;
    let deadline = Instant::now() + patient(Duration::from_secs(15));
    while http_get(&agent, "/readyz").0 != 503 {
        assert!(
            Instant::now() < deadline,
            "the agent still says it is ready"
        );
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
    assert_eq!(http_get(&agent, "/healthz").0, 200);
    drop(fleet);
}
