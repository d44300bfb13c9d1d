use firefleet_model::scenario::Scenario;
use firefleet_model::{RouterId, UnitId};

use super::*;

fn site() -> Scenario {
    Scenario::straight(100.0)
        .ground("ugv-1", 5.0, -2.0)
        .ground("ugv-2", 9.0, -2.0)
        .build()
}

fn unit(id: &str) -> Identity {
    Identity::Unit(UnitId::new(id).unwrap())
}

/// A site PKI with commander rossi in a temporary directory.
fn made() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pki");
    let rossi = CommanderId::new("rossi").unwrap();
    make_site(&site(), &[rossi], &Terms::default(), &out).unwrap();
    (dir, out)
}

#[test]
fn a_site_pki_has_a_key_only_its_owner_reads_per_identity() {
    let (_d, out) = made();
    let names = Identity::of_site(&site(), &[CommanderId::new("rossi").unwrap()]);
    for who in &names {
        let d = out.join(who.dir_name());
        for f in ["ca.pem", "cert.pem", "key.pem"] {
            assert!(d.join(f).is_file(), "{who}: {f}");
        }
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = fs::metadata(d.join("key.pem"))
                .unwrap()
                .permissions()
                .mode();
            assert_eq!(mode & 0o777, 0o600, "{who}");
        }
        assert_eq!(check(&TlsFiles::in_dir(&d), None).unwrap(), *who);
    }
    let again = make_site(&site(), &[], &Terms::default(), &out).unwrap_err();
    assert!(again.to_string().contains("not empty"), "{again}");
}

#[test]
fn only_a_router_certificate_serves_and_names_hosts() {
    let (_d, out) = made();
    let router = Certified::read(&out.join("router/cert.pem")).unwrap();
    assert!(router.server);
    assert_eq!(router.hosts, ["localhost", "127.0.0.1"]);
    for who in ["unit-ugv-1", "coordinator", "commander-rossi", "console"] {
        let c = Certified::read(&out.join(who).join("cert.pem")).unwrap();
        assert!(!c.server, "{who} can serve");
        assert!(c.hosts.is_empty(), "{who} names hosts");
    }
    // A year by default, and never past the CA.
    let now = OffsetDateTime::now_utc();
    assert!(
        (364..=365).contains(&router.days_left(now)),
        "{}",
        router.days_left(now)
    );
    let terms = Terms {
        valid_days: CA_VALID_DAYS + 1,
        ..Terms::default()
    };
    let e = issue(&out, &unit("ugv-1"), &terms).unwrap_err();
    assert!(e.to_string().contains("outlive its CA"), "{e}");
    let e = issue(
        &out,
        &unit("ugv-1"),
        &Terms {
            hosts: vec!["robot.example".into()],
            ..Terms::default()
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("only a router"), "{e}");
}

#[test]
fn issue_adds_routers_and_renews_without_touching_the_ca() {
    let (_d, out) = made();
    let ca_before = fs::read(out.join("ca/ca.pem")).unwrap();
    let b = Identity::Router(Some(RouterId::new("b").unwrap()));
    let terms = Terms {
        hosts: vec!["router-b.site".into(), "10.0.0.2".into()],
        valid_days: 30,
        from: None,
    };
    let dir = issue(&out, &b, &terms).unwrap();
    let c = Certified::read(&dir.join("cert.pem")).unwrap();
    assert_eq!(c.identity, b);
    assert_eq!(c.hosts, ["router-b.site", "10.0.0.2"]);
    assert_eq!(c.days_left(OffsetDateTime::now_utc()), 29);
    assert_eq!(
        check(&TlsFiles::in_dir(&dir), Some(&Expect::Role(Role::Router))).unwrap(),
        b
    );
    // Renewal: a new key and certificate, the same CA.
    let ugv = out.join("unit-ugv-1");
    let (cert0, key0) = (
        fs::read(ugv.join("cert.pem")).unwrap(),
        fs::read(ugv.join("key.pem")).unwrap(),
    );
    issue(&out, &unit("ugv-1"), &Terms::default()).unwrap();
    assert_ne!(fs::read(ugv.join("cert.pem")).unwrap(), cert0);
    assert_ne!(fs::read(ugv.join("key.pem")).unwrap(), key0);
    assert_eq!(fs::read(ugv.join("ca.pem")).unwrap(), ca_before);
    assert_eq!(fs::read(out.join("ca/ca.pem")).unwrap(), ca_before);
    check(
        &TlsFiles::in_dir(&ugv),
        Some(&Expect::Identity(unit("ugv-1"))),
    )
    .unwrap();
    let names: Vec<String> = list(&out)
        .unwrap()
        .iter()
        .map(|l| l.identity.to_string())
        .collect();
    assert!(names.contains(&"router:b".to_owned()), "{names:?}");
}

#[test]
fn a_revoked_name_is_listed_and_never_issued_again() {
    let (_d, out) = made();
    revoke(&out, &unit("ugv-2")).unwrap();
    assert!(!out.join("unit-ugv-2").exists());
    let gone = revoked(&out).unwrap();
    assert_eq!(gone.len(), 1);
    assert_eq!(gone[0].0, unit("ugv-2"));
    let e = issue(&out, &unit("ugv-2"), &Terms::default()).unwrap_err();
    assert!(e.to_string().contains("revoked on"), "{e}");
    let e = revoke(&out, &unit("ugv-2")).unwrap_err();
    assert!(e.to_string().contains("revoked already"), "{e}");
    assert!(revoke(&out, &Identity::ROUTER).is_err());
    let listed = list(&out).unwrap();
    let l = listed.iter().find(|l| l.identity == unit("ugv-2")).unwrap();
    assert!(
        l.certificate
            .as_ref()
            .is_err_and(|e| e.starts_with("revoked on"))
    );
}

#[test]
fn files_that_can_never_work_are_refused_naming_the_file() {
    let (d, out) = made();
    let ugv1 = TlsFiles::in_dir(&out.join("unit-ugv-1"));
    // Another identity's key.
    let swapped = TlsFiles {
        key: out.join("unit-ugv-2/key.pem"),
        ..ugv1.clone()
    };
    let e = check(&swapped, None).unwrap_err().to_string();
    assert!(e.contains("unit-ugv-2/key.pem: not the key of"), "{e}");
    // The wrong identity or role for the process.
    let e = check(&ugv1, Some(&Expect::Identity(unit("ugv-2"))))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("unit:ugv-1's certificate, but this process runs as unit:ugv-2"),
        "{e}"
    );
    let e = check(&ugv1, Some(&Expect::Role(Role::Router)))
        .unwrap_err()
        .to_string();
    assert!(e.contains("runs as a router"), "{e}");
    // Unreadable, or not a key at all.
    let e = check(
        &TlsFiles {
            key: d.path().join("nothing.pem"),
            ..ugv1.clone()
        },
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("nothing.pem"), "{e}");
    let e = check(
        &TlsFiles {
            key: ugv1.cert.clone(),
            ..ugv1.clone()
        },
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not a private key"), "{e}");
    // Another site's CA.
    let other = d.path().join("other");
    make_site(&site(), &[], &Terms::default(), &other).unwrap();
    let e = check(
        &TlsFiles {
            ca: other.join("ca/ca.pem"),
            ..ugv1.clone()
        },
        None,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("not signed by the CA"), "{e}");
    // Expired: a certificate whose validity ended yesterday, signed by the site CA.
    let now = OffsetDateTime::now_utc();
    let terms = Terms {
        from: Some(now - time::Duration::days(400)),
        valid_days: 399,
        ..Terms::default()
    };
    issue(&out, &unit("ugv-1"), &terms).unwrap();
    let e = check(&ugv1, None).unwrap_err().to_string();
    assert!(e.contains("unit:ugv-1's certificate expired on"), "{e}");
}

#[test]
fn the_console_page_has_a_web_certificate_the_links_do_not_trust() {
    let (_d, out) = made();
    let console = out.join("console");
    let page = Certified::read(&console.join("https-cert.pem"));
    // Its common name is no identity of the site: it cannot be read as one.
    assert!(page.is_err());
    let page = parse(&console.join("https-cert.pem")).unwrap();
    assert!(page.server);
    assert_eq!(page.hosts, ["localhost", "127.0.0.1"]);
    // Signed by the web CA, not the site CA the links check.
    let files = TlsFiles {
        ca: console.join("ca.pem"),
        cert: console.join("https-cert.pem"),
        key: console.join("https-key.pem"),
    };
    assert!(check(&files, None).is_err());
    let web = TlsFiles {
        ca: console.join("web-ca.pem"),
        ..files
    };
    assert!(
        check(&web, None).is_err(),
        "its name is no identity: refused as one"
    );
    let web_ca = parse(&console.join("web-ca.pem")).unwrap();
    let site_ca = parse(&console.join("ca.pem")).unwrap();
    assert_ne!(web_ca.spki, site_ca.spki);
}

#[test]
fn a_site_made_with_hosts_names_them_in_the_router_s_certificate_only() {
    // deploy/README.md's step 1: `pki init ... --host router.tunnel.local --host 10.20.0.1`.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pki");
    let terms = Terms {
        hosts: vec!["router.tunnel.local".into(), "10.20.0.1".into()],
        ..Terms::default()
    };
    make_site(&site(), &[], &terms, &out).unwrap();
    let router = Certified::read(&out.join("router/cert.pem")).unwrap();
    assert_eq!(router.hosts, ["router.tunnel.local", "10.20.0.1"]);
    let unit = Certified::read(&out.join("unit-ugv-1/cert.pem")).unwrap();
    assert!(unit.hosts.is_empty() && !unit.server, "{unit:?}");
}
