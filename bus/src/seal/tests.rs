use std::path::PathBuf;

use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;

use super::*;
use crate::pki::{Terms, make_site};

/// Two site PKIs (ours, and another site's) with commander rossi.
fn sites() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let site = Scenario::straight(100.0).ground("ugv-1", 5.0, -2.0).build();
    let rossi = CommanderId::new("rossi").unwrap();
    let (ours, theirs) = (dir.path().join("ours"), dir.path().join("theirs"));
    for out in [&ours, &theirs] {
        make_site(&site, std::slice::from_ref(&rossi), &Terms::default(), out).unwrap();
    }
    (dir, ours, theirs)
}

const KEY: &str = "ff/tunnel-a/zone/deep/goal/rossi";

#[test]
fn a_seal_holds_for_exactly_what_was_sealed_by_whom() {
    let (_d, ours, _) = sites();
    let rossi = Seals::load(&TlsFiles::in_dir(&ours.join("commander-rossi"))).unwrap();
    assert_eq!(rossi.sealer.identity().to_string(), "commander:rossi");
    let goal = br#"{"id":"a","zone":"deep","goal":"keep-out"}"#;
    let seal = rossi.sealer.seal(KEY, Some(goal));
    let check = SealCheck::load(&ours.join("coordinator/ca.pem")).unwrap();
    assert_eq!(
        check.check(KEY, Some(goal), &seal).unwrap().to_string(),
        "commander:rossi"
    );
    // Checked again from the cache, the same.
    assert!(check.check(KEY, Some(goal), &seal).is_ok());
    // Another payload, key, time or kind: the signature no longer verifies.
    let other = br#"{"id":"a","zone":"deep","goal":"evacuate"}"#;
    assert_eq!(
        check.check(KEY, Some(other), &seal),
        Err(SealError::Signature)
    );
    let elsewhere = "ff/tunnel-a/zone/west/goal/rossi";
    assert_eq!(
        check.check(elsewhere, Some(goal), &seal),
        Err(SealError::Signature)
    );
    assert_eq!(check.check(KEY, None, &seal), Err(SealError::Signature));
    let later = Seal {
        at_ms: seal.at_ms + 1,
        ..seal.clone()
    };
    assert_eq!(
        check.check(KEY, Some(goal), &later),
        Err(SealError::Signature)
    );
    // Another identity's certificate on rossi's signature: does not verify either.
    let console = Seals::load(&TlsFiles::in_dir(&ours.join("console"))).unwrap();
    let borrowed = Seal {
        cert: console.sealer.seal(KEY, None).cert,
        ..seal
    };
    assert_eq!(
        check.check(KEY, Some(goal), &borrowed),
        Err(SealError::Signature)
    );
    // A delete seals too.
    let clear = rossi.sealer.seal(KEY, None);
    assert!(check.check(KEY, None, &clear).is_ok());
}

#[test]
fn another_site_s_identity_cannot_seal_for_this_one() {
    let (_d, ours, theirs) = sites();
    let stranger = Sealer::load(&TlsFiles::in_dir(&theirs.join("commander-rossi"))).unwrap();
    let check = SealCheck::load(&ours.join("ca/ca.pem")).unwrap();
    let seal = stranger.seal(KEY, Some(b"{}"));
    let e = check.check(KEY, Some(b"{}"), &seal).unwrap_err();
    assert!(
        e.to_string().contains("not signed by this site's CA"),
        "{e}"
    );
    let garbage = Seal {
        cert: base64_of(b"not a certificate"),
        ..seal
    };
    let e = check.check(KEY, Some(b"{}"), &garbage).unwrap_err();
    assert!(e.to_string().contains("not an X.509 certificate"), "{e}");
}

#[test]
fn an_expired_certificate_seals_nothing() {
    let (_d, ours, _) = sites();
    let old = Terms {
        from: Some(OffsetDateTime::now_utc() - time::Duration::days(40)),
        valid_days: 30,
        ..Terms::default()
    };
    let who = Identity::Commander(CommanderId::new("bianchi").unwrap());
    let dir = crate::pki::issue(&ours, &who, &old).unwrap();
    let sealer = Sealer::load(&TlsFiles::in_dir(&dir)).unwrap();
    let check = SealCheck::load(&ours.join("ca/ca.pem")).unwrap();
    let e = check.check(KEY, None, &sealer.seal(KEY, None)).unwrap_err();
    assert!(e.to_string().contains("expired"), "{e}");
}

#[test]
fn a_seal_made_with_this_key_elsewhere_is_an_impostor_s() {
    let (_d, ours, _) = sites();
    let files = TlsFiles::in_dir(&ours.join("console"));
    let (console, thief) = (Seals::load(&files).unwrap(), Sealer::load(&files).unwrap());
    let mine = console.sealer.seal(KEY, Some(b"{}"));
    assert!(console.sealer.made(&mine));
    assert!(!console.impostor(KEY, Some(b"{}"), &mine));
    let stolen = thief.seal(KEY, Some(b"{}"));
    assert!(console.impostor(KEY, Some(b"{}"), &stolen));
    // Another identity's seal, or one that does not hold, is none of this key's business.
    let rossi = Sealer::load(&TlsFiles::in_dir(&ours.join("commander-rossi"))).unwrap();
    assert!(!console.impostor(KEY, Some(b"{}"), &rossi.seal(KEY, Some(b"{}"))));
    assert!(!console.impostor(KEY, Some(b"[]"), &stolen));
}
