//! The doctor's look at the identity's certificate: role and name, dates, the site's CA,
//! the key its own.

use super::*;

/// The identity the role presents: its files, whose they are, their dates, chain and key.
/// Whether it can link.
pub(super) fn identity(f: &mut Findings, a: &DoctorArgs, links: &Links) -> bool {
    let want = &a.identity;
    let Some(files) = &links.tls else {
        if links
            .connect
            .iter()
            .chain(&links.listen)
            .any(|e| e.starts_with("quic/"))
        {
            f.problem(
                "TLS: QUIC endpoints but no complete identity (ca.pem, cert.pem, key.pem)",
                "use the configuration firefleet deploy render wrote for this identity",
            );
            return false;
        }
        f.note("a plain link, no TLS identity: for a closed network or a bench only");
        return true;
    };
    let reissue = format!(
        "issue it again on the PKI machine (firefleet pki issue --pki pki --role {}{}) and copy pki/{}/ to this host",
        want.role(),
        match want {
            Identity::Unit(u) => format!(" --name {u}"),
            Identity::Commander(c) => format!(" --name {c}"),
            Identity::Router(Some(r)) => format!(" --name {r}"),
            _ => String::new(),
        },
        want.dir_name()
    );
    let mut fine = true;
    for (what, path) in [
        ("CA", &files.ca),
        ("certificate", &files.cert),
        ("key", &files.key),
    ] {
        if let Err(e) = std::fs::File::open(path) {
            f.problem(
                format_args!(
                    "TLS: the {what} {} cannot be read here: {e}",
                    path.display()
                ),
                format_args!(
                    "copy pki/{}/ of the site's PKI to where the configuration names it",
                    want.dir_name()
                ),
            );
            fine = false;
        }
    }
    if !fine {
        return false;
    }
    let cert = match Certified::read(&files.cert) {
        Ok(c) => c,
        Err(e) => {
            f.problem(format_args!("TLS: {e}"), &reissue);
            return false;
        }
    };
    if &cert.identity != want {
        f.problem(
            format_args!(
                "TLS: {} is {}'s certificate, and this role runs as {want}",
                files.cert.display(),
                cert.identity
            ),
            format_args!(
                "copy pki/{}/ (not pki/{}/) to this host",
                want.dir_name(),
                cert.identity.dir_name()
            ),
        );
        fine = false;
    }
    let now = OffsetDateTime::now_utc();
    let days = cert.days_left(now);
    if now > cert.not_after {
        f.problem(
            format_args!(
                "TLS: {}'s certificate expired on {}",
                cert.identity,
                pki::date(cert.not_after)
            ),
            &reissue,
        );
        fine = false;
    } else if days < 30 {
        f.note(format_args!(
            "TLS: {}'s certificate expires in {days} days ({}): renew it soon",
            cert.identity,
            pki::date(cert.not_after)
        ));
    }
    if fine {
        let expect = if links.router {
            Expect::Role(Role::Router)
        } else {
            Expect::Identity(want.clone())
        };
        match pki::check(files, Some(&expect)) {
            Ok(_) => f.ok(format_args!(
                "TLS: {}'s certificate, of the site's CA, valid until {}, the key its own",
                cert.identity,
                pki::date(cert.not_after)
            )),
            Err(e) => {
                f.problem(format_args!("TLS: {e}"), &reissue);
                fine = false;
            }
        }
    }
    key_reader(f, a, files) && fine
}
