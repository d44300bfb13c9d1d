//! Making certificates: the site CA's signer, a role's leaf certificate with its names
//! and usages, and writing them with the modes their secrecy needs.
//!
//! Not here: what a PKI directory holds and who may use it (the parent module).

use super::*;

/// A CA that signs certificates: its certificate (as a signer), its key, its certificate
/// as every holder is given it, and the day it ends (no certificate outlives it).
pub(super) struct Signer {
    ca: rcgen::Certificate,
    key: KeyPair,
    pem: String,
    not_after: OffsetDateTime,
}

impl Signer {
    /// A new CA named `name`, written to `dir` (`ca.pem`, and `ca.key` 0600).
    pub(super) fn create(dir: &Path, name: &str) -> Result<Self, PkiError> {
        let key = KeyPair::generate().map_err(cert(format!("generating the key of {name}")))?;
        let now = OffsetDateTime::now_utc();
        let mut params = ca_params(name);
        params.not_before = now - time::Duration::hours(1);
        params.not_after = now + time::Duration::days(CA_VALID_DAYS.into());
        let not_after = params.not_after;
        let ca = params
            .self_signed(&key)
            .map_err(cert(format!("signing {name}")))?;
        write(dir, "ca.pem", &ca.pem(), false)?;
        write(dir, "ca.key", &key.serialize_pem(), true)?;
        Ok(Self {
            pem: ca.pem(),
            ca,
            key,
            not_after,
        })
    }

    /// The CA named `name` that `create` wrote to `dir`.
    pub(super) fn load(dir: &Path, name: &str) -> Result<Self, PkiError> {
        let key_pem = fs::read_to_string(dir.join("ca.key"))
            .map_err(io(format!("reading the CA key in {}", dir.display())))?;
        let key = KeyPair::from_pem(&key_pem).map_err(cert("the CA key"))?;
        let pem = fs::read_to_string(dir.join("ca.pem")).map_err(io(format!(
            "reading the CA certificate in {}",
            dir.display()
        )))?;
        let written = parse(&dir.join("ca.pem"))?;
        // The issuer of a certificate is the CA's name and key: the same parameters signed
        // by the same key stand for the CA as it was made. Holders get the CA's own
        // certificate (`pem`), not this stand-in (whose signature differs).
        let ca = ca_params(name).self_signed(&key).map_err(cert("the CA"))?;
        Ok(Self {
            ca,
            key,
            pem,
            not_after: written.not_after,
        })
    }

    /// Sign `p` for a new key; the certificate and the key.
    pub(super) fn sign(
        &self,
        mut p: CertificateParams,
        valid_days: u32,
        from: Option<OffsetDateTime>,
        what: &str,
    ) -> Result<(rcgen::Certificate, KeyPair), PkiError> {
        if valid_days == 0 {
            return Err(refused("a certificate must be valid for at least a day"));
        }
        // An hour's grace for clocks a little behind the one that issued it.
        let from = from.unwrap_or_else(|| OffsetDateTime::now_utc() - time::Duration::hours(1));
        let not_after = from + time::Duration::hours(1) + time::Duration::days(valid_days.into());
        if not_after > self.not_after {
            return Err(refused(format!(
                "{what} would outlive its CA (valid until {}): fewer days, or a new CA",
                date(self.not_after)
            )));
        }
        p.not_before = from;
        p.not_after = not_after;
        let key = KeyPair::generate().map_err(cert("generating a key"))?;
        let signed = p
            .signed_by(&key, &self.ca, &self.key)
            .map_err(cert(format!("signing {what}")))?;
        Ok((signed, key))
    }
}

fn ca_params(name: &str) -> CertificateParams {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name.push(DnType::CommonName, name);
    p.is_ca = IsCa::Ca(BasicConstraints::Unconstrained);
    p.key_usages = vec![
        KeyUsagePurpose::KeyCertSign,
        KeyUsagePurpose::CrlSign,
        KeyUsagePurpose::DigitalSignature,
    ];
    p
}

/// Subject alternative names for `hosts`.
fn sans(hosts: &[String]) -> Result<Vec<SanType>, PkiError> {
    hosts
        .iter()
        .map(|h| match h.parse() {
            Ok(ip) => Ok(SanType::IpAddress(ip)),
            Err(_) => Ok(SanType::DnsName(
                h.clone().try_into().map_err(cert(format!("host {h}")))?,
            )),
        })
        .collect()
}

/// Write identity `who`'s directory under `out`: the site CA's certificate, its
/// certificate and key, replacing what was there whole; for the console, also its web
/// server's certificate and key, signed by the `web` CA. The directory.
pub(super) fn leaf(
    out: &Path,
    who: &Identity,
    terms: &Terms,
    site: &Signer,
    web: &Signer,
) -> Result<PathBuf, PkiError> {
    let mut p = CertificateParams::default();
    p.distinguished_name = DistinguishedName::new();
    p.distinguished_name
        .push(DnType::CommonName, who.to_string());
    p.key_usages = vec![
        KeyUsagePurpose::DigitalSignature,
        KeyUsagePurpose::KeyEncipherment,
    ];
    p.extended_key_usages = vec![ExtendedKeyUsagePurpose::ClientAuth];
    match who.role() {
        Role::Router => {
            p.extended_key_usages
                .push(ExtendedKeyUsagePurpose::ServerAuth);
            p.subject_alt_names = sans(&terms.hosts())?;
        }
        Role::Console => {}
        _ if !terms.hosts.is_empty() => {
            return Err(refused(format!(
                "{who} is no router: only a router's certificate (and the console's web page) names hosts"
            )));
        }
        _ => {}
    }
    let (signed, key) = site.sign(p, terms.valid_days, terms.from, &who.to_string())?;
    let dir = out.join(who.dir_name());
    if who.role() == Role::Console {
        // The console's page is a web server for the commanders' browsers. Its certificate
        // comes from a CA of its own, which the browsers trust and Zenoh's links do not:
        // were it the site CA's, a stolen console key on the router's host would pass
        // for the router.
        let mut page = CertificateParams::default();
        page.distinguished_name = DistinguishedName::new();
        page.distinguished_name
            .push(DnType::CommonName, "firefleet console");
        page.key_usages = vec![
            KeyUsagePurpose::DigitalSignature,
            KeyUsagePurpose::KeyEncipherment,
        ];
        page.extended_key_usages = vec![ExtendedKeyUsagePurpose::ServerAuth];
        page.subject_alt_names = sans(&terms.hosts())?;
        let (https, https_key) =
            web.sign(page, terms.valid_days, terms.from, "the console's page")?;
        replace(&dir, "web-ca.pem", &web.pem, false)?;
        replace(&dir, "https-key.pem", &https_key.serialize_pem(), true)?;
        replace(&dir, "https-cert.pem", &https.pem(), false)?;
    }
    replace(&dir, "ca.pem", &site.pem, false)?;
    replace(&dir, "key.pem", &key.serialize_pem(), true)?;
    replace(&dir, "cert.pem", &signed.pem(), false)?;
    Ok(dir)
}

/// Write `text` to `dir/file` whole (a new file renamed over the old one), creating `dir`.
fn replace(dir: &Path, file: &str, text: &str, secret: bool) -> Result<(), PkiError> {
    let tmp = format!(".{file}.new");
    let _ = fs::remove_file(dir.join(&tmp));
    write(dir, &tmp, text, secret)?;
    fs::rename(dir.join(&tmp), dir.join(file))
        .map_err(io(format!("replacing {}", dir.join(file).display())))
}

/// Write `text` to the new file `dir/file`, creating `dir`; a secret is created 0600.
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
