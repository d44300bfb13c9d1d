use std::path::{Path, PathBuf};

use firefleet_bus::pki::{Terms, TlsFiles, make_site};
use firefleet_bus::seal::{Sealer, Seals, by_coordinator};
use firefleet_model::scenario::Scenario;
use firefleet_model::{SiteId, ZoneId};
use firefleet_protocol::msg::GoalKind;

use super::*;

struct Site {
    _dir: tempfile::TempDir,
    pki: PathBuf,
    keys: Keys,
}

fn site() -> Site {
    let dir = tempfile::tempdir().unwrap();
    let pki = dir.path().join("pki");
    let scenario = Scenario::straight(100.0).ground("ugv-1", 5.0, -2.0).build();
    let commanders = [rossi(), CommanderId::new("bianchi").unwrap()];
    make_site(&scenario, &commanders, &Terms::default(), &pki).unwrap();
    Site {
        _dir: dir,
        pki,
        keys: Keys::new(SiteId::new("tunnel-a").unwrap()),
    }
}

fn rossi() -> CommanderId {
    CommanderId::new("rossi").unwrap()
}

fn sealer(pki: &Path, who: &str) -> Sealer {
    Sealer::load(&TlsFiles::in_dir(&pki.join(who))).unwrap()
}

fn check(pki: &Path) -> SealCheck {
    Seals::load(&TlsFiles::in_dir(&pki.join("coordinator")))
        .unwrap()
        .check
}

fn keep_out() -> ZoneGoal {
    ZoneGoal::new(ZoneId::new("deep").unwrap(), GoalKind::KeepOut, rossi())
}

/// `goal` put on rossi's key, sealed by `by` at `at_ms` (none: unsealed).
fn sample(s: &Site, goal: &ZoneGoal, by: Option<&Sealer>, at_ms: u64) -> Raw {
    let key = s.keys.zone_goal(&goal.zone, &rossi()).as_str().to_owned();
    let bytes = codec::encode(goal);
    Raw {
        attachment: by.map(|b| b.seal_at(&key, Some(&bytes), at_ms).to_attachment()),
        key,
        deleted: false,
        bytes,
    }
}

const NOW: u64 = 1_800_000_000_000;

#[test]
fn a_live_goal_takes_its_issuer_s_or_the_console_s_fresh_seal_only() {
    let s = site();
    let check = check(&s.pki);
    let (rossi_key, console) = (sealer(&s.pki, "commander-rossi"), sealer(&s.pki, "console"));
    let heard = |raw: &Raw| heard(Some(&check), raw, &rossi(), NOW);
    assert!(
        heard(&sample(&s, &keep_out(), Some(&rossi_key), NOW - 2_000))
            .unwrap()
            .is_some()
    );
    assert!(heard(&sample(&s, &keep_out(), Some(&console), NOW)).is_ok());
    let e = heard(&sample(&s, &keep_out(), None, NOW)).unwrap_err();
    assert!(e.starts_with("unsealed"), "{e}");
    let e = heard(&sample(&s, &keep_out(), Some(&rossi_key), NOW - 31_000)).unwrap_err();
    assert!(e.contains("31 s behind"), "{e}");
    // Another commander's own seal on rossi's key, or a role that commands nothing.
    let bianchi = sealer(&s.pki, "commander-bianchi");
    let e = heard(&sample(&s, &keep_out(), Some(&bianchi), NOW)).unwrap_err();
    assert!(
        e.contains("commander:bianchi, who may not speak for commander 'rossi'"),
        "{e}"
    );
    let e = heard(&sample(
        &s,
        &keep_out(),
        Some(&sealer(&s.pki, "recorder")),
        NOW,
    ))
    .unwrap_err();
    assert!(e.contains("recorder"), "{e}");
    // A goal changed after it was sealed.
    let mut changed = sample(&s, &keep_out(), Some(&rossi_key), NOW);
    changed.bytes = codec::encode(&ZoneGoal {
        goal: GoalKind::Evacuate,
        ..keep_out()
    });
    assert!(heard(&changed).unwrap_err().contains("does not verify"));
    // An open site seals nothing and checks nothing.
    assert_eq!(
        super::heard(None, &sample(&s, &keep_out(), None, 0), &rossi(), NOW),
        Ok(None)
    );
}

/// `goal` in force as the coordinator keeps it, proof and all.
fn in_force(s: &Site, goal: ZoneGoal, by: &Sealer, at_ms: u64) -> GoalInForce {
    let raw = sample(s, &goal, Some(by), at_ms);
    GoalInForce {
        goal,
        since: 1.0,
        until: None,
        proof: heard(Some(&check(&s.pki)), &raw, &rossi(), at_ms).unwrap(),
    }
}

#[test]
fn a_recalled_set_keeps_only_what_its_issuers_sealed() {
    let s = site();
    let check = check(&s.pki);
    let rossi_key = sealer(&s.pki, "commander-rossi");
    let good = in_force(&s, keep_out(), &rossi_key, NOW);
    // A stolen recorder key's forgeries: a goal changed under a good seal (rossi's
    // keep-out made an evacuate), one with no seal, one sealed by the recorder itself.
    let changed = GoalInForce {
        goal: ZoneGoal {
            goal: GoalKind::Evacuate,
            ..keep_out()
        },
        ..good.clone()
    };
    let unsealed = GoalInForce {
        proof: None,
        goal: ZoneGoal {
            id: "forged".into(),
            ..keep_out()
        },
        ..good.clone()
    };
    let by_recorder = in_force(&s, keep_out(), &sealer(&s.pki, "console"), NOW);
    let recorder_sealed = GoalInForce {
        proof: Some(Sealed {
            seal: sealer(&s.pki, "recorder").seal_at(
                &by_recorder.proof.as_ref().unwrap().key,
                by_recorder
                    .proof
                    .as_ref()
                    .unwrap()
                    .payload
                    .as_deref()
                    .map(str::as_bytes),
                NOW,
            ),
            ..by_recorder.proof.clone().unwrap()
        }),
        ..by_recorder
    };
    let set = GoalsInForce {
        t: 5.0,
        goals: vec![good.clone(), changed, unsealed, recorder_sealed],
        ..GoalsInForce::default()
    };
    let (kept, refused) = recalled(Some(&check), &s.keys, set, "a recorder's answer");
    assert_eq!(kept.goals, vec![good], "{refused:?}");
    assert_eq!(refused.len(), 3, "{refused:?}");
    assert!(
        refused[0].contains("changed since it was sealed"),
        "{refused:?}"
    );
    assert!(refused[1].contains("unsealed"), "{refused:?}");
    assert!(
        refused[2].contains("recorder, who may not speak"),
        "{refused:?}"
    );
}

#[test]
fn a_union_of_the_sets_lifts_nothing_a_set_leaves_out() {
    let s = site();
    let rossi_key = sealer(&s.pki, "commander-rossi");
    let old = in_force(&s, keep_out(), &rossi_key, NOW);
    let newer = in_force(
        &s,
        ZoneGoal {
            priority: 3,
            ..keep_out()
        },
        &rossi_key,
        NOW + 1_000,
    );
    let journal = GoalsInForce {
        t: 10.0,
        goals: vec![newer.clone()],
        ..GoalsInForce::default()
    };
    // A set dated later holding nothing, and an older one holding the older version.
    let empty = GoalsInForce {
        t: 20.0,
        ..GoalsInForce::default()
    };
    let stale = GoalsInForce {
        t: 5.0,
        goals: vec![old],
        ..GoalsInForce::default()
    };
    let kept = merged(vec![stale, empty, journal]).unwrap();
    assert_eq!(kept.t, 20.0);
    assert_eq!(kept.goals, vec![newer]);
    assert_eq!(merged(Vec::new()), None);
}

#[test]
fn a_recalled_fire_track_or_barred_space_is_taken_only_under_a_coordinator_s_seal_not_suspended() {
    let s = site();
    let check = check(&s.pki);
    let key = s.keys.fire(firefleet_model::FireId(3)).as_str().to_owned();
    let bytes = br#"{"id":3}"#.to_vec();
    let answer = |by: Option<&str>, bytes: &[u8]| Raw {
        key: key.clone(),
        deleted: false,
        bytes: bytes.to_vec(),
        attachment: by.map(|who| sealer(&s.pki, who).seal(&key, Some(bytes)).to_attachment()),
    };
    let nobody = |_: &Identity| false;
    // Either coordinator's seal: taken; on an open site, anything.
    for who in ["coordinator", "coordinator-1"] {
        assert_eq!(
            by_coordinator(Some(&check), &answer(Some(who), &bytes), nobody),
            Ok(())
        );
    }
    assert_eq!(by_coordinator(None, &answer(None, &bytes), nobody), Ok(()));
    // The recorder's own seal, none, or a track changed under a coordinator's seal: not.
    let e = by_coordinator(Some(&check), &answer(Some("recorder"), &bytes), nobody).unwrap_err();
    assert!(
        e.contains("sealed by recorder, not by a coordinator"),
        "{e}"
    );
    let e = by_coordinator(Some(&check), &answer(None, &bytes), nobody).unwrap_err();
    assert!(e.starts_with("unsealed"), "{e}");
    let mut changed = answer(Some("coordinator"), &bytes);
    changed.bytes = br#"{"id":4}"#.to_vec();
    let e = by_coordinator(Some(&check), &changed, nobody).unwrap_err();
    assert!(e.starts_with("seal refused"), "{e}");
    // The barred space a recorder passes on to a restarted unit: the same rule.
    let barred = s.keys.coord_barred().as_str().to_owned();
    let spans = br#"{"t":1.0,"spans":[]}"#.to_vec();
    let told = |by: &str| Raw {
        key: barred.clone(),
        deleted: false,
        bytes: spans.clone(),
        attachment: Some(
            sealer(&s.pki, by)
                .seal(&barred, Some(&spans))
                .to_attachment(),
        ),
    };
    assert_eq!(
        by_coordinator(Some(&check), &told("coordinator"), nobody),
        Ok(())
    );
    assert!(by_coordinator(Some(&check), &told("recorder"), nobody).is_err());
    // A coordinator whose key was stolen and suspended: not either.
    let suspended = |who: &Identity| who.dir_name() == "coordinator";
    let e = by_coordinator(
        Some(&check),
        &answer(Some("coordinator"), &bytes),
        suspended,
    )
    .unwrap_err();
    assert!(e.contains("suspended"), "{e}");
}
