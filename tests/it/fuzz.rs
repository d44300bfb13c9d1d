//! Fuzzing every decoder of external input, on stable Rust: postcard messages, the
//! commanders' JSON, scenario TOML, behavior-tree XML, and what a secure site reads of a
//! certificate (PEM, X.509, the identity in its common name).
//!
//! Inputs are made two ways from a seeded generator (a failure names its seed and input,
//! so it replays): random bytes, and mutations of valid inputs (bytes flipped, inserted,
//! deleted, runs repeated, text spliced), which reach far deeper into a decoder than
//! random bytes do. A decoder must return, never panic, and what it accepts must survive a
//! round trip (postcard: decode, encode, decode gives the same message).
//!
//! `cargo test --test it fuzz::` runs a short pass of every decoder (CI). The documented long run
//! is `FUZZ_CASES=1000000 cargo test --release --test it fuzz::`, a million inputs per decoder.

#![allow(
    clippy::print_stdout,
    clippy::print_stderr,
    reason = "tests print what a person running them reads"
)]

use std::panic::{AssertUnwindSafe, catch_unwind};

use firefleet_bt::xml;
use firefleet_bus::access::Identity;
use firefleet_bus::pki::Certified;
use firefleet_model::scenario::Scenario;
use firefleet_model::{FireId, Point2, Pose2, UnitId, UnitKind, ZoneId};
use firefleet_protocol::codec::{decode, encode};
use firefleet_protocol::msg::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Inputs per decoder: `FUZZ_CASES`, or a short pass.
fn cases() -> u64 {
    std::env::var("FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3_000)
}

/// One input: a mutation of one of `seeds`, or (one time in eight) random bytes.
fn input(rng: &mut ChaCha8Rng, seeds: &[Vec<u8>]) -> Vec<u8> {
    if rng.random_ratio(1, 8) {
        let n = rng.random_range(0..96);
        return (0..n).map(|_| rng.random()).collect();
    }
    let mut b = seeds[rng.random_range(0..seeds.len())].clone();
    for _ in 0..rng.random_range(1..=4) {
        let at = rng.random_range(0..=b.len());
        match rng.random_range(0..6) {
            0 if at < b.len() => b[at] ^= 1 << rng.random_range(0..8),
            1 if at < b.len() => b[at] = rng.random(),
            2 => b.insert(at, rng.random()),
            3 if at < b.len() => {
                b.remove(at);
            }
            4 if at < b.len() => {
                let end = (at + rng.random_range(1..16)).min(b.len());
                let run = b[at..end].to_vec();
                b.splice(at..at, run);
            }
            5 => {
                let other = &seeds[rng.random_range(0..seeds.len())];
                if !other.is_empty() {
                    let from = rng.random_range(0..other.len());
                    let end = (from + rng.random_range(1..24)).min(other.len());
                    b.splice(at..at, other[from..end].iter().copied());
                }
            }
            _ => {}
        }
    }
    b
}

/// Feed `cases()` inputs made from `seeds` to `check`, which says whether the decoder
/// accepted the input and panics on a defect; on one, fail with the seed, the case and the
/// input. Prints how many inputs were accepted: a fuzzer whose inputs are all refused at
/// the first byte tests little.
fn fuzz(name: &str, seed: u64, seeds: &[Vec<u8>], check: impl Fn(&[u8]) -> bool) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut accepted = 0u64;
    for case in 0..cases() {
        let bytes = input(&mut rng, seeds);
        match catch_unwind(AssertUnwindSafe(|| check(&bytes))) {
            Ok(ok) => accepted += u64::from(ok),
            Err(_) => panic!(
                "{name}: seed {seed}, case {case}: input {:?} ({} bytes)",
                String::from_utf8_lossy(&bytes),
                bytes.len()
            ),
        }
    }
    eprintln!("{name}: {} inputs, {accepted} accepted", cases());
    assert!(accepted > 0, "{name}: no input was ever accepted");
}

/// Decoding `M` returns; what decodes encodes back to the same message.
fn round_trips<M: Message + PartialEq + std::fmt::Debug>(bytes: &[u8]) -> bool {
    let Ok(m) = decode::<M>(bytes) else {
        return false;
    };
    let again = decode::<M>(&encode(&m)).expect("a decoded message re-encodes");
    assert_eq!(again, m);
    true
}

fn unit() -> UnitId {
    UnitId::new("ugv-1").unwrap()
}

fn state() -> UnitState {
    UnitState {
        unit: unit(),
        kind: UnitKind::Ground,
        t: 12.5,
        pose: Pose2::new(40.0, -2.5, 0.1),
        speed: 1.2,
        mode: UnitMode::Navigating,
        water_l: 800.0,
        health: 1.0,
        heat_flux_kw_m2: 0.4,
        task: Some(TaskProgress {
            seq: 12_001,
            fire: FireId(3),
            phase: TaskPhase::Travelling,
            target: Point2::new(60.0, 1.0),
        }),
        autonomous: false,
        refused: Some(Refusal {
            seq: 11_000,
            reason: RefusalReason::WayBarred,
            goal: "ko".into(),
            zone: ZoneId::new("deep").unwrap(),
        }),
        task_seq: Some(12_001),
        epoch: Some(11_000),
    }
}

fn goal_json() -> Vec<Vec<u8>> {
    [
        r#"{"id": "ic-7", "zone": "deep", "goal": "keep-out", "priority": 2, "expires_s": 600, "issued_by": "IC Rossi"}"#,
        r#"{"id": "ic-8", "zone": "portal", "goal": "contain", "before_m": 60.0}"#,
        r#"{"id": "r", "zone": "deep", "goal": "evacuate", "rail_allowed": true}"#,
    ]
    .map(|s| s.as_bytes().to_vec())
    .to_vec()
}

#[test]
fn fleet_messages() {
    let task = Task {
        unit: unit(),
        epoch: 11_000,
        seq: 12_001,
        t: 12.0,
        kind: TaskKind::Extinguish {
            fire: FireId(3),
            target: Point2::new(60.0, 1.0),
            from: Approach::Either,
        },
    };
    let report = FlameReport {
        unit: unit(),
        t: 12.5,
        observer: Pose2::new(40.0, -2.5, 0.0),
        observations: vec![FlameObservation {
            position: Point2::new(60.0, 1.0),
            cov: [0.2, 0.0, 0.2],
            confidence: 0.9,
            hrr_kw: Some(4000.0),
        }],
    };
    let barred = BarredSpace {
        t: 12.0,
        spans: vec![BarredSpan {
            goal: "ko".into(),
            zone: ZoneId::new("deep").unwrap(),
            start: firefleet_model::Chainage::new(100.0),
            end: firefleet_model::Chainage::new(300.0),
            bar: Bar::Entry,
            rail_allowed: false,
        }],
    };
    let track = FireTrack {
        id: FireId(3),
        t: 12.0,
        position: Point2::new(60.0, 1.0),
        cov: [0.3, 0.0, 0.3],
        confidence: 0.95,
        state: FireState::Assigned,
        assigned: vec![unit()],
        seen_by: vec![unit()],
        hrr_kw: Some(5000.0),
    };
    let decision = Decision {
        t: 12.0,
        text: "assign ugv-1 to fire f3: cost 4.2 s".into(),
        impostor: None,
    };
    let seeds = vec![
        encode(&state()),
        encode(&task),
        encode(&report),
        encode(&barred),
        encode(&track),
        encode(&decision),
    ];
    fuzz("UnitState", 1, &seeds, round_trips::<UnitState>);
    fuzz("Task", 2, &seeds, round_trips::<Task>);
    fuzz("FlameReport", 3, &seeds, round_trips::<FlameReport>);
    fuzz("BarredSpace", 4, &seeds, round_trips::<BarredSpace>);
    fuzz("FireTrack", 8, &seeds, round_trips::<FireTrack>);
    fuzz("Decision", 9, &seeds, round_trips::<Decision>);
}

#[test]
fn commander_json() {
    fuzz("ZoneGoal", 5, &goal_json(), round_trips::<ZoneGoal>);
}

#[test]
fn scenario_toml() {
    let seeds: Vec<Vec<u8>> = [
        include_str!("../../model/scenarios/rail-tunnel.toml"),
        include_str!("../../model/scenarios/pileup.toml"),
    ]
    .map(|s| s.as_bytes().to_vec())
    .to_vec();
    fuzz("scenario", 6, &seeds, |b| {
        let Ok(s) = Scenario::from_toml(&String::from_utf8_lossy(b), "fuzz") else {
            return false;
        };
        // What loads passes its own checks again: loading validated all of it.
        s.validate().expect("a loaded scenario is valid");
        true
    });
}

#[test]
fn behavior_tree_xml() {
    let seeds: Vec<Vec<u8>> = [
        include_str!("../../agent/trees/ground_unit.xml"),
        include_str!("../../agent/trees/monorail_unit.xml"),
        include_str!("../../examples/trees/patrol.xml"),
    ]
    .map(|s| s.as_bytes().to_vec())
    .to_vec();
    let ground = firefleet_agent::ground::leaves::registry();
    fuzz("bt xml", 7, &seeds, |b| {
        let Ok(doc) = xml::parse_str(&String::from_utf8_lossy(b), "fuzz.xml") else {
            return false;
        };
        if xml::validate(&doc, &ground).is_err() {
            return false;
        }
        xml::build(&doc, &ground).expect("a document that validates builds");
        true
    });
}

#[test]
fn site_certificates() {
    let dir = tempfile::tempdir().unwrap();
    let site = Scenario::straight(100.0).ground("ugv-1", 5.0, -2.0).build();
    let rossi = firefleet_model::CommanderId::new("rossi").unwrap();
    let pki = dir.path().join("pki");
    firefleet_bus::pki::make_site(&site, &[rossi], &Default::default(), &pki).unwrap();
    let seeds: Vec<Vec<u8>> = ["router", "unit-ugv-1", "commander-rossi", "console"]
        .iter()
        .map(|who| std::fs::read(pki.join(who).join("cert.pem")).unwrap())
        .collect();
    fuzz("certificate", 10, &seeds, |b| {
        let Ok(c) = Certified::from_pem(b, "fuzz.pem") else {
            return false;
        };
        // What is accepted names an identity of the site, which reads back the same.
        assert_eq!(
            c.identity.to_string().parse::<Identity>().unwrap(),
            c.identity
        );
        true
    });
    let names: Vec<Vec<u8>> = [
        "unit:ugv-1",
        "commander:rossi",
        "router:b",
        "router",
        "console",
    ]
    .map(|s| s.as_bytes().to_vec())
    .to_vec();
    fuzz("identity", 11, &names, |b| {
        let Ok(who) = String::from_utf8_lossy(b).parse::<Identity>() else {
            return false;
        };
        assert_eq!(who.to_string().parse::<Identity>().unwrap(), who);
        true
    });
}
