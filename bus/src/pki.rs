//! A site's certificates for mutual TLS: a site CA and one certificate per identity.
//!
//! Each identity ([`Identity`]) gets a directory of its own, what a role's `--tls-dir`
//! takes and all a robot needs copied to it: the CA's certificate (`ca.pem`), its
//! certificate (`cert.pem`, the identity as its common name, which the router's access
//! rules match) and its key (`key.pem`). Keys are written 0600, created so (never readable
//! by others, not even for a moment), and never printed.
//!
//! Rotation: make a new site PKI into a new directory and deploy it whole (a new CA: old
//! certificates are worthless at once). Revocation of one identity: render the router's
//! access rules without it ([`crate::render`]) and restart the router: its certificate
//! still links, but default deny leaves it nothing to do.
//!
//! Not here: the TLS links themselves (Zenoh's, configured by [`crate::Connect`]).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;
use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa,
    KeyPair, KeyUsagePurpose, SanType,
};

use crate::access::Identity;

/// Where the CA's own files live in a site PKI's directory.
pub const CA_DIR: &str = "ca";
/// The CA's common name.
const CA_NAME: &str = "firefleet site CA";

/// Why a PKI could not be made or extended.
#[derive(Debug, thiserror::Error)]
pub enum PkiError {
    #[error("{what}: {source}")]
    Io {
        what: String,
        source: std::io::Error,
    },
    #[error("{what}: {source}")]
    Certificate { what: String, source: rcgen::Error },
    #[error("{0}")]
    Refused(String),
}

fn io(what: impl Into<String>) -> impl FnOnce(std::io::Error) -> PkiError {
    let what = what.into();
    |source| PkiError::Io { what, source }
}

fn cert(what: impl Into<String>) -> impl FnOnce(rcgen::Error) -> PkiError {
    let what = what.into();
    |source| PkiError::Certificate { what, source }
}

/// The hosts certificates are valid for: `given`, or loopback.
fn hosts(given: &[String]) -> Vec<String> {
    if given.is_empty() {
        vec!["localhost".into(), "127.0.0.1".into()]
    } else {
        given.to_vec()
    }
}

/// Write a site CA and a certificate for every identity of `scenario`'s site and
/// `commanders` (valid for `hosts`, default loopback) into `out`, which must not exist or
/// be empty; the identities.
pub fn make_site(
    scenario: &Scenario,
    commanders: &[CommanderId],
    hosts_given: &[String],
    out: &Path,
) -> Result<Vec<Identity>, PkiError> {
    let occupied = out.exists()
        && fs::read_dir(out)
            .map_err(io(format!("reading {}", out.display())))?
            .next()
            .is_some();
    if occupied {
        return Err(PkiError::Refused(format!(
            "{} exists and is not empty: a site PKI is written whole",
            out.display()
        )));
    }
    let names = Identity::of_site(scenario, commanders);
    let key = KeyPair::generate().map_err(cert("generating the CA key"))?;
    let ca = ca_params()
        .self_signed(&key)
        .map_err(cert("signing the CA"))?;
    let ca_dir = out.join(CA_DIR);
    write(&ca_dir, "ca.pem", &ca.pem(), false)?;
    write(&ca_dir, "ca.key", &key.serialize_pem(), true)?;
    let hosts = hosts(hosts_given);
    let signer = Signer {
        ca: &ca,
        key: &key,
        pem: &ca.pem(),
    };
    for name in &names {
        leaf(out, name, &hosts, &signer)?;
    }
    Ok(names)
}

/// Add a certificate for `who` (valid for `hosts`, default loopback) to the site PKI in
/// `pki`, signed by its CA; the identity's directory.
pub fn issue(pki: &Path, who: &Identity, hosts_given: &[String]) -> Result<PathBuf, PkiError> {
    let ca_dir = pki.join(CA_DIR);
    let key_pem = fs::read_to_string(ca_dir.join("ca.key"))
        .map_err(io(format!("reading the CA key in {}", ca_dir.display())))?;
    let key = KeyPair::from_pem(&key_pem).map_err(cert("the CA key"))?;
    // The issuer of a certificate is the CA's name and key: the same parameters signed by
    // the same key stand for the CA the site PKI was made with. The identity gets the
    // site's own CA certificate, not this stand-in (whose signature differs).
    let ca = ca_params().self_signed(&key).map_err(cert("the CA"))?;
    let pem = fs::read_to_string(ca_dir.join("ca.pem")).map_err(io(format!(
        "reading the CA certificate in {}",
        ca_dir.display()
    )))?;
    let signer = Signer {
        ca: &ca,
        key: &key,
        pem: &pem,
    };
    leaf(pki, who, &hosts(hosts_given), &signer)
}

/// What signs a site's certificates: the CA, its key, and the CA certificate every
/// identity is given.
struct Signer<'a> {
    ca: &'a rcgen::Certificate,
    key: &'a KeyPair,
    pem: &'a str,
}

fn ca_params() -> CertificateParams {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name.push(DnType::CommonName, CA_NAME);
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    p
}

/// Write identity `who`'s directory under `out`: the CA's certificate, its certificate
/// (server and client, valid for `hosts`) and key. The directory.
fn leaf(
    out: &Path,
    who: &Identity,
    hosts: &[String],
    by: &Signer<'_>,
) -> Result<PathBuf, PkiError> {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name
        .push(DnType::CommonName, who.to_string());
    p.subject_alt_names = hosts
        .iter()
        .map(|h| match h.parse() {
            Ok(ip) => Ok(SanType::IpAddress(ip)),
            Err(_) => Ok(SanType::DnsName(
                h.clone().try_into().map_err(cert(format!("host {h}")))?,
            )),
        })
        .collect::<Result<_, PkiError>>()?;
    p.key_usages = vec![
        KeyUsagePurpose::DigitalSignature,
        KeyUsagePurpose::KeyEncipherment,
    ];
    p.extended_key_usages = vec![
        ExtendedKeyUsagePurpose::ServerAuth,
        ExtendedKeyUsagePurpose::ClientAuth,
    ];
    let key = KeyPair::generate().map_err(cert("generating a key"))?;
    let signed = p
        .signed_by(&key, by.ca, by.key)
        .map_err(cert(format!("signing {who}")))?;
    let dir = out.join(who.dir_name());
    write(&dir, "ca.pem", by.pem, false)?;
    write(&dir, "cert.pem", &signed.pem(), false)?;
    write(&dir, "key.pem", &key.serialize_pem(), true)?;
    Ok(dir)
}

/// Write `text` to `dir/file`, creating `dir`; a secret is created 0600.
fn write(dir: &Path, file: &str, text: &str, secret: bool) -> Result<(), PkiError> {
    fs::create_dir_all(dir).map_err(io(format!("creating {}", dir.display())))?;
    let path = dir.join(file);
    let mut open = fs::OpenOptions::new();
    open.write(true).create_new(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        open.mode(if secret { 0o600 } else { 0o644 });
    }
    let mut f = open
        .open(&path)
        .map_err(io(format!("creating {}", path.display())))?;
    f.write_all(text.as_bytes())
        .map_err(io(format!("writing {}", path.display())))
}

#[cfg(test)]
mod tests {
    use firefleet_model::scenario::Scenario;

    use super::*;

    #[test]
    fn a_site_pki_has_a_key_only_its_owner_reads_per_identity() {
        let dir = tempfile::tempdir().unwrap();
        let site = Scenario::straight(100.0).ground("ugv-1", 5.0, -2.0).build();
        let rossi = CommanderId::new("rossi").unwrap();
        let out = dir.path().join("pki");
        let names = make_site(&site, std::slice::from_ref(&rossi), &[], &out).unwrap();
        assert!(names.contains(&Identity::Commander(rossi)));
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
        }
        let again = make_site(&site, &[], &[], &out).unwrap_err();
        assert!(again.to_string().contains("not empty"), "{again}");
        // A commander who joins later gets a certificate of the same CA.
        let bianchi = Identity::Commander(CommanderId::new("bianchi").unwrap());
        let added = issue(&out, &bianchi, &[]).unwrap();
        assert!(added.join("cert.pem").is_file());
        let ca = |d: &Path| fs::read_to_string(d.join("ca.pem")).unwrap();
        assert_eq!(ca(&added), ca(&out.join(CA_DIR)));
    }
}
