//! A site's certificates for mutual TLS: a site CA and one certificate per identity, each
//! bound to its role and valid for a limited time.
//!
//! Each identity ([`Identity`]) gets a directory of its own, what a role's `--tls-dir`
//! takes and all a robot needs copied to it: the CA's certificate (`ca.pem`), its
//! certificate (`cert.pem`, the identity as its common name, which the router's access
//! rules match) and its key (`key.pem`). Keys are written 0600, created so (never readable
//! by others, not even for a moment), and never printed.
//!
//! **Roles.** Only a router's certificate may serve: it alone carries the server-auth
//! purpose and the host names the router is reached by, and clients check both (the name
//! they connect to, Zenoh's `verify_name_on_connect`), so a unit's stolen certificate
//! cannot stand in for the router. Every other certificate is for clients only and names
//! no host. A router's certificate also carries client-auth: a router linking to another
//! router is that router's client.
//!
//! **Validity.** Leaves are valid for [`DEFAULT_VALID_DAYS`] unless told otherwise (never
//! past the CA's own end, [`CA_VALID_DAYS`]); links close when a certificate expires
//! (`close_link_on_expiration`), and [`check`] refuses an expired one before a process
//! even tries. [`issue`] renews an identity in place (a new key, the old files replaced
//! whole) without touching the CA.
//!
//! **Revocation.** Zenoh's TLS and QUIC links check no revocation list, and its access
//! rules match a certificate by common name only, so revoking one certificate of a name
//! while another of the same name stays good is not something the router can do. [`revoke`]
//! therefore takes a *name* off the site: it is recorded in the PKI's `revoked` file and its
//! directory removed; [`crate::render`] gives a revoked name no rule (default deny: its
//! certificate still links, but may do nothing) and no configuration; the router applies
//! the rendered rules when it restarts. [`issue`] refuses a revoked name, since a new
//! certificate under it would give the stolen one its rules back. A robot whose
//! certificate was stolen rejoins under a new site CA (rotation: `pki init` into a new
//! directory, deployed whole; old certificates are worthless at once).
//!
//! Not here: the links themselves (Zenoh's, configured by [`crate::Connect`]).

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};

use firefleet_model::CommanderId;
use firefleet_model::scenario::Scenario;
use rcgen::{
    BasicConstraints, CertificateParams, DistinguishedName, DnType, ExtendedKeyUsagePurpose, IsCa,
    KeyPair, KeyUsagePurpose, SanType,
};
use time::OffsetDateTime;
use x509_parser::prelude::{FromDer, GeneralName, ParsedExtension, X509Certificate};

use crate::access::{Identity, Role};

/// Where the CA's own files live in a site PKI's directory.
pub const CA_DIR: &str = "ca";
/// Where the web CA's files live: it signs only the console's page (its `https-cert.pem`),
/// for the commanders' browsers to trust.
pub const WEB_CA_DIR: &str = "web-ca";
const WEB_CA_NAME: &str = "firefleet site web CA";
/// The file listing the names taken off the site, one `<identity> <date>` a line.
const REVOKED: &str = "revoked";
/// The CA's common name.
const CA_NAME: &str = "firefleet site CA";
/// How long a leaf certificate is valid unless told otherwise: a year, so a lost robot's
/// certificate does not outlive the next yearly inspection.
pub const DEFAULT_VALID_DAYS: u32 = 365;
/// How long a site CA is valid: ten years, the service life of the robots it serves.
pub const CA_VALID_DAYS: u32 = 3650;

/// Why a PKI could not be made, extended or read, or an identity's files cannot work.
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

fn refused(why: impl Into<String>) -> PkiError {
    PkiError::Refused(why.into())
}

/// What a new certificate is for beyond its identity.
#[derive(Debug, Clone)]
pub struct Terms {
    /// The hosts a router is reached by (default: localhost and 127.0.0.1); only a
    /// router's certificate names hosts.
    pub hosts: Vec<String>,
    /// Days from its start until it expires.
    pub valid_days: u32,
    /// When it is valid from (default: now, less an hour's grace for clocks a little
    /// behind). Earlier dates make a certificate already expired: what tests of the checks
    /// that refuse one start from.
    pub from: Option<OffsetDateTime>,
}

impl Default for Terms {
    fn default() -> Self {
        Self {
            hosts: Vec::new(),
            valid_days: DEFAULT_VALID_DAYS,
            from: None,
        }
    }
}

impl Terms {
    fn hosts(&self) -> Vec<String> {
        if self.hosts.is_empty() {
            vec!["localhost".into(), "127.0.0.1".into()]
        } else {
            self.hosts.clone()
        }
    }
}

/// Write a site CA and a certificate for every identity of `scenario`'s site and
/// `commanders` into `out`, which must not exist or be empty; the identities.
pub fn make_site(
    scenario: &Scenario,
    commanders: &[CommanderId],
    terms: &Terms,
    out: &Path,
) -> Result<Vec<Identity>, PkiError> {
    let occupied = out.exists()
        && fs::read_dir(out)
            .map_err(io(format!("reading {}", out.display())))?
            .next()
            .is_some();
    if occupied {
        return Err(refused(format!(
            "{} exists and is not empty: a site PKI is written whole",
            out.display()
        )));
    }
    let names = Identity::of_site(scenario, commanders);
    let site = Signer::create(&out.join(CA_DIR), CA_NAME)?;
    let web = Signer::create(&out.join(WEB_CA_DIR), WEB_CA_NAME)?;
    // The hosts are the first router's and the console page's; a router the site file
    // lists is reached at its host (the first also at those given); the other identities
    // are clients and name none.
    let client = Terms {
        hosts: Vec::new(),
        ..terms.clone()
    };
    for name in &names {
        let listed = match name {
            Identity::Router(None) => scenario.routers.first(),
            Identity::Router(Some(r)) => scenario.routers.iter().find(|s| &s.name == r),
            _ => None,
        };
        let router_terms;
        let terms = match (name.role(), listed) {
            (Role::Router, Some(spec)) => {
                let mut hosts = vec![spec.host.clone()];
                if *name == Identity::ROUTER {
                    hosts.extend(terms.hosts.iter().filter(|h| **h != spec.host).cloned());
                }
                router_terms = Terms {
                    hosts,
                    ..terms.clone()
                };
                &router_terms
            }
            (Role::Router | Role::Console, _) => terms,
            _ => &client,
        };
        leaf(out, name, terms, &site, &web)?;
    }
    Ok(names)
}

/// Add a certificate for `who` to the site PKI in `pki`, signed by its CA, or renew the
/// one it has (a new key; the old files are replaced whole); the identity's directory.
/// A revoked name is refused (see the module doc).
pub fn issue(pki: &Path, who: &Identity, terms: &Terms) -> Result<PathBuf, PkiError> {
    if let Some((_, when)) = revoked(pki)?.into_iter().find(|(r, _)| r == who) {
        return Err(refused(format!(
            "{who} was revoked on {when}: a new certificate under that name would get the \
             revoked one's rules back (the router matches common names); re-admit it under a \
             new site CA (firefleet pki init into a new directory)"
        )));
    }
    let site = Signer::load(&pki.join(CA_DIR), CA_NAME)?;
    // A PKI from before the console had a web certificate gets its web CA now.
    let web_dir = pki.join(WEB_CA_DIR);
    let web = if web_dir.join("ca.key").is_file() {
        Signer::load(&web_dir, WEB_CA_NAME)?
    } else {
        Signer::create(&web_dir, WEB_CA_NAME)?
    };
    leaf(pki, who, terms, &site, &web)
}

/// Take `who`'s name off the site in `pki`: record it as revoked today and remove its
/// directory. Takes effect when the rules are rendered again and the router restarts.
pub fn revoke(pki: &Path, who: &Identity) -> Result<(), PkiError> {
    if *who == Identity::ROUTER {
        return Err(refused(
            "the site's first router cannot be revoked: make a new site CA",
        ));
    }
    if !pki.join(CA_DIR).join("ca.pem").is_file() {
        return Err(refused(format!("{} is no site PKI", pki.display())));
    }
    if revoked(pki)?.iter().any(|(r, _)| r == who) {
        return Err(refused(format!("{who} is revoked already")));
    }
    let mut f = fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(pki.join(REVOKED))
        .map_err(io(format!("opening {}", pki.join(REVOKED).display())))?;
    writeln!(f, "{who} {}", date(OffsetDateTime::now_utc()))
        .map_err(io(format!("writing {}", pki.join(REVOKED).display())))?;
    let dir = pki.join(who.dir_name());
    if dir.exists() {
        fs::remove_dir_all(&dir).map_err(io(format!("removing {}", dir.display())))?;
    }
    Ok(())
}

/// The names taken off the site in `pki`, with the day each was.
pub fn revoked(pki: &Path) -> Result<Vec<(Identity, String)>, PkiError> {
    let path = pki.join(REVOKED);
    let text = match fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io(format!("reading {}", path.display()))(e)),
    };
    text.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| {
            let (name, when) = l.split_once(' ').unwrap_or((l, "?"));
            let who = name
                .parse()
                .map_err(|e| refused(format!("{} line {}: {e}", path.display(), i + 1)))?;
            Ok((who, when.trim().to_owned()))
        })
        .collect()
}

/// One identity of a site PKI as [`list`] shows it.
#[derive(Debug, Clone)]
pub struct Listed {
    pub identity: Identity,
    /// Its certificate, or why it has none (revoked, and when).
    pub certificate: Result<Certified, String>,
}

/// Every identity of the site PKI in `pki`, revoked ones included, in a stable order.
pub fn list(pki: &Path) -> Result<Vec<Listed>, PkiError> {
    let mut out = Vec::new();
    let entries = fs::read_dir(pki).map_err(io(format!("reading {}", pki.display())))?;
    for e in entries {
        let e = e.map_err(io(format!("reading {}", pki.display())))?;
        let path = e.path().join("cert.pem");
        if e.file_name() == CA_DIR || e.file_name() == WEB_CA_DIR || !path.is_file() {
            continue;
        }
        let c = Certified::read(&path)?;
        out.push(Listed {
            identity: c.identity.clone(),
            certificate: Ok(c),
        });
    }
    for (who, when) in revoked(pki)? {
        out.push(Listed {
            identity: who,
            certificate: Err(format!("revoked on {when}")),
        });
    }
    out.sort_by(|a, b| a.identity.cmp(&b.identity));
    Ok(out)
}

/// What a certificate says, as far as a site cares.
#[derive(Debug, Clone)]
pub struct Certified {
    pub identity: Identity,
    pub not_before: OffsetDateTime,
    pub not_after: OffsetDateTime,
    /// It may serve TLS (server-auth).
    pub server: bool,
    /// The host names and addresses it is valid for.
    pub hosts: Vec<String>,
    /// Its public key (SubjectPublicKeyInfo, DER).
    spki: Vec<u8>,
    der: Vec<u8>,
}

impl Certified {
    /// Read the certificate of a site identity in PEM file `path`.
    pub fn read(path: &Path) -> Result<Self, PkiError> {
        let text = fs::read(path).map_err(io(format!("reading {}", path.display())))?;
        Self::from_pem(&text, &path.display().to_string())
    }

    /// The certificate of a site identity in PEM text `pem`, which `source` names in
    /// errors.
    pub fn from_pem(pem: &[u8], source: &str) -> Result<Self, PkiError> {
        Self::of(parse_pem(pem, source)?, source)
    }

    /// The certificate of a site identity in DER bytes `der` (as a TLS peer presents it),
    /// which `source` names in errors.
    pub fn from_der(der: &[u8], source: &str) -> Result<Self, PkiError> {
        Self::of(parse_der(der, source)?, source)
    }

    fn of(p: Parsed, source: &str) -> Result<Self, PkiError> {
        let identity =
            p.cn.parse()
                .map_err(|e| refused(format!("{source}: common name: {e}")))?;
        Ok(Self {
            identity,
            not_before: p.not_before,
            not_after: p.not_after,
            server: p.server,
            hosts: p.hosts,
            spki: p.spki,
            der: p.der,
        })
    }

    /// The certificate itself, DER.
    pub fn der(&self) -> &[u8] {
        &self.der
    }

    /// Whole days from `now` until it expires (negative: expired).
    pub fn days_left(&self, now: OffsetDateTime) -> i64 {
        (self.not_after - now).whole_days()
    }
}

/// Any certificate as read, its common name whatever it is (a CA's is no identity).
#[derive(Debug, Clone)]
struct Parsed {
    cn: String,
    not_before: OffsetDateTime,
    not_after: OffsetDateTime,
    server: bool,
    hosts: Vec<String>,
    spki: Vec<u8>,
    der: Vec<u8>,
}

/// The certificate in PEM file `path`.
fn parse(path: &Path) -> Result<Parsed, PkiError> {
    let text = fs::read(path).map_err(io(format!("reading {}", path.display())))?;
    parse_pem(&text, &path.display().to_string())
}

/// [`parse`] of the PEM text `text`, which `source` names in errors.
fn parse_pem(text: &[u8], source: &str) -> Result<Parsed, PkiError> {
    let (_, pem) = x509_parser::pem::parse_x509_pem(text)
        .map_err(|e| refused(format!("{source}: not a PEM certificate ({e})")))?;
    parse_der(&pem.contents, source)
}

/// [`parse`] of the DER bytes `der`, which `source` names in errors.
fn parse_der(der: &[u8], source: &str) -> Result<Parsed, PkiError> {
    let bad = |why: String| refused(format!("{source}: {why}"));
    let (_, c) = X509Certificate::from_der(der)
        .map_err(|e| bad(format!("not an X.509 certificate ({e})")))?;
    let cn = c
        .subject()
        .iter_common_name()
        .next()
        .and_then(|n| n.as_str().ok())
        .ok_or_else(|| bad("no common name".into()))?
        .to_owned();
    let mut server = false;
    let mut hosts = Vec::new();
    for ext in c.extensions() {
        match ext.parsed_extension() {
            ParsedExtension::ExtendedKeyUsage(u) => server = u.server_auth,
            ParsedExtension::SubjectAlternativeName(san) => {
                hosts.extend(san.general_names.iter().filter_map(|n| match n {
                    GeneralName::DNSName(d) => Some((*d).to_owned()),
                    GeneralName::IPAddress(b) => ip(b).map(|a| a.to_string()),
                    _ => None,
                }))
            }
            _ => {}
        }
    }
    Ok(Parsed {
        cn,
        not_before: c.validity().not_before.to_datetime(),
        not_after: c.validity().not_after.to_datetime(),
        server,
        hosts,
        spki: c.public_key().raw.to_vec(),
        der: der.to_vec(),
    })
}

fn ip(bytes: &[u8]) -> Option<std::net::IpAddr> {
    match bytes.len() {
        4 => <[u8; 4]>::try_from(bytes).ok().map(Into::into),
        16 => <[u8; 16]>::try_from(bytes).ok().map(Into::into),
        _ => None,
    }
}

/// The expiry date as `pki list` and messages show it.
pub fn date(t: OffsetDateTime) -> String {
    format!("{}-{:02}-{:02}", t.year(), u8::from(t.month()), t.day())
}

/// The three files a TLS identity runs on.
#[derive(Debug, Clone)]
pub struct TlsFiles {
    pub ca: PathBuf,
    pub cert: PathBuf,
    pub key: PathBuf,
}

impl TlsFiles {
    /// The files of an identity directory as `pki` writes it.
    pub fn in_dir(dir: &Path) -> Self {
        Self {
            ca: dir.join("ca.pem"),
            cert: dir.join("cert.pem"),
            key: dir.join("key.pem"),
        }
    }
}

/// Who a process must be to run: a role, or one identity exactly.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Expect {
    Role(Role),
    Identity(Identity),
}

/// Check, before any link is tried, that `files` can ever work for a process that must be
/// `expect`: every file readable, the certificate signed by the CA, the key its own, valid
/// now, of the right role (and, for a router, able to serve). The identity.
pub fn check(files: &TlsFiles, expect: Option<&Expect>) -> Result<Identity, PkiError> {
    let ca = parse(&files.ca)?;
    let c = Certified::read(&files.cert)?;
    let key_pem =
        fs::read_to_string(&files.key).map_err(io(format!("reading {}", files.key.display())))?;
    let key = KeyPair::from_pem(&key_pem)
        .map_err(|e| refused(format!("{}: not a private key ({e})", files.key.display())))?;
    if key.public_key_der() != c.spki {
        return Err(refused(format!(
            "{}: not the key of {} ({})",
            files.key.display(),
            files.cert.display(),
            c.identity
        )));
    }
    let signed = X509Certificate::from_der(&c.der)
        .ok()
        .zip(X509Certificate::from_der(&ca.der).ok())
        .is_some_and(|((_, leaf), (_, ca))| leaf.verify_signature(Some(ca.public_key())).is_ok());
    if !signed {
        return Err(refused(format!(
            "{}: not signed by the CA in {} (a certificate of another site?)",
            files.cert.display(),
            files.ca.display()
        )));
    }
    let now = OffsetDateTime::now_utc();
    if now > c.not_after {
        return Err(refused(format!(
            "{}: {}'s certificate expired on {} (renew it: firefleet pki issue)",
            files.cert.display(),
            c.identity,
            date(c.not_after)
        )));
    }
    if now < c.not_before {
        return Err(refused(format!(
            "{}: {}'s certificate is valid only from {} (is this machine's clock right?)",
            files.cert.display(),
            c.identity,
            date(c.not_before)
        )));
    }
    let fits = match expect {
        None => true,
        Some(Expect::Role(r)) => c.identity.role() == *r,
        Some(Expect::Identity(i)) => c.identity == *i,
    };
    if !fits {
        let wanted = match expect {
            Some(Expect::Role(r)) => format!("a {r}"),
            Some(Expect::Identity(i)) => i.to_string(),
            None => unreachable!("anyone fits"),
        };
        return Err(refused(format!(
            "{}: {}'s certificate, but this process runs as {wanted}",
            files.cert.display(),
            c.identity
        )));
    }
    if c.identity.role() == Role::Router && !c.server {
        return Err(refused(format!(
            "{}: {} cannot serve TLS (no server-auth): issue it again with firefleet pki issue --role router",
            files.cert.display(),
            c.identity
        )));
    }
    Ok(c.identity)
}

mod issuing;
use issuing::{Signer, leaf};

#[cfg(test)]
mod tests;
