//! Sealing messages with this process's site identity, and checking the seals of others
//! against the site CA ([`firefleet_protocol::msg::Seal`] says what is signed and why).
//!
//! A bus opened with a TLS identity holds both ([`Bus::seals`](crate::Bus::seals)): the
//! key it links with signs, the CA it trusts vouches. A bus on a plain link has neither,
//! and a site without a PKI has no seals at all: anyone on its bus is trusted, as on the
//! demo's loopback.
//!
//! **What a checked seal means**: the certificate in it was signed by this site's CA and
//! is valid now, and its key signed exactly these bytes on this key at that time. Whether
//! that identity may say it, and whether the time is fresh, is for the receiver's rules.
//! A revoked name's certificate still seals: revocation acts at the routers (`pki`), and a
//! suspension in band is the coordinator's.
//!
//! Not here: what is sealed (`firefleet_protocol::msg::seal`), or who may seal what.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Mutex;
use std::time::Duration;

use firefleet_model::validate::Invalid;
use firefleet_protocol::msg::{Seal, Sealed, base64_of, sealed_bytes};
use ring::rand::SystemRandom;
use ring::signature::{
    ECDSA_P256_SHA256_ASN1, ECDSA_P256_SHA256_ASN1_SIGNING, EcdsaKeyPair, UnparsedPublicKey,
};
use time::OffsetDateTime;
use x509_parser::prelude::{FromDer, X509Certificate};

use crate::access::Identity;
use crate::pki::{Certified, PkiError, TlsFiles};

/// Why a seal does not hold.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SealError {
    #[error("{0}")]
    Malformed(#[from] Invalid),
    #[error("its certificate {0}")]
    Certificate(String),
    #[error("its signature does not verify (forged, or the message was changed)")]
    Signature,
}

/// This process's identity, able to seal.
pub struct Sealer {
    key: EcdsaKeyPair,
    rng: SystemRandom,
    cert: String,
    identity: Identity,
    /// The signatures of the last [`MADE_KEPT`] seals made here: a seal with this
    /// identity's certificate that is not among them was made with its key elsewhere
    /// (ECDSA signatures are randomised: nobody makes one of ours by chance).
    made: Mutex<std::collections::VecDeque<String>>,
}

/// How many of its own seals a sealer remembers: every goal and clear a busy console
/// sends in an incident, many times over.
const MADE_KEPT: usize = 4096;

impl std::fmt::Debug for Sealer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never the key.
        f.debug_struct("Sealer")
            .field("identity", &self.identity)
            .finish_non_exhaustive()
    }
}

impl Sealer {
    /// The identity in `files` (its certificate and key; `pki::check` has judged them).
    pub fn load(files: &TlsFiles) -> Result<Self, PkiError> {
        let refused = |why: String| PkiError::Refused(why);
        let certified = Certified::read(&files.cert)?;
        let pem = std::fs::read_to_string(&files.key).map_err(|source| PkiError::Io {
            what: format!("reading {}", files.key.display()),
            source,
        })?;
        let pkcs8 = rcgen::KeyPair::from_pem(&pem)
            .map_err(|e| refused(format!("{}: not a private key ({e})", files.key.display())))?
            .serialize_der();
        let rng = SystemRandom::new();
        let key = EcdsaKeyPair::from_pkcs8(&ECDSA_P256_SHA256_ASN1_SIGNING, &pkcs8, &rng).map_err(
            |e| {
                refused(format!(
                    "{}: seals need an ECDSA P-256 key, as firefleet pki makes ({e})",
                    files.key.display()
                ))
            },
        )?;
        Ok(Self {
            key,
            rng,
            cert: base64_of(certified.der()),
            identity: certified.identity,
            made: Mutex::default(),
        })
    }

    pub fn identity(&self) -> &Identity {
        &self.identity
    }

    /// Seal `payload` (`None`: a delete) as put on `key` now.
    pub fn seal(&self, key: &str, payload: Option<&[u8]>) -> Seal {
        let at_ms = u64::try_from(OffsetDateTime::now_utc().unix_timestamp_nanos() / 1_000_000)
            .unwrap_or(0);
        self.seal_at(key, payload, at_ms)
    }

    /// Seal `payload` as put on `key` at `at_ms` (ms since the epoch): for tests and
    /// attack harnesses that need a seal of another time.
    pub fn seal_at(&self, key: &str, payload: Option<&[u8]>, at_ms: u64) -> Seal {
        let sig = self
            .key
            .sign(&self.rng, &sealed_bytes(key, at_ms, payload))
            .expect("ECDSA signing fails only without randomness");
        let sig = base64_of(sig.as_ref());
        let mut made = self
            .made
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if made.len() == MADE_KEPT {
            made.pop_front();
        }
        made.push_back(sig.clone());
        Seal {
            cert: self.cert.clone(),
            at_ms,
            sig,
        }
    }

    /// Whether `seal` is one this sealer made (of the last [`MADE_KEPT`]).
    pub fn made(&self, seal: &Seal) -> bool {
        self.made
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .contains(&seal.sig)
    }
}

impl Seals {
    /// Whether `seal`, heard on `key` over `payload` (`None`: a delete), holds and was
    /// made with this process's own key by someone else: the key is stolen (or a second
    /// process runs with this identity, which a site must not do). A seal that does not
    /// hold is no proof of anything and says no.
    pub fn impostor(&self, key: &str, payload: Option<&[u8]>, seal: &Seal) -> bool {
        self.check
            .check(key, payload, seal)
            .is_ok_and(|signer| signer == self.sealer.identity && !self.sealer.made(seal))
    }
}

/// This host's clock, milliseconds since the Unix epoch: what live seals are dated by and
/// judged fresh against.
pub fn wall_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| u64::try_from(d.as_millis()).unwrap_or(u64::MAX))
}

/// How far a live seal's time may be from this host's clock: hosts of a site keep NTP
/// time within a fraction of a second; half a minute leaves room for a commander's laptop
/// that drifted, and is far shorter than any goal's life.
pub const FRESH: Duration = Duration::from_secs(30);

/// Whether a live seal's time is within [`FRESH`] of this host's clock.
pub fn fresh(proof: &Sealed, now_ms: u64) -> Result<(), String> {
    let apart = proof.seal.at_ms.abs_diff(now_ms);
    if apart > FRESH.as_millis() as u64 {
        return Err(format!(
            "sealed {:.0} s {} this host's clock, more than {} s: a replay, or a clock to set right",
            apart as f64 / 1000.0,
            if proof.seal.at_ms < now_ms {
                "behind"
            } else {
                "ahead of"
            },
            FRESH.as_secs()
        ));
    }
    Ok(())
}

/// A certificate the CA vouched for: who, and the public key to check with.
#[derive(Debug, Clone)]
struct Vouched {
    identity: Identity,
    /// The raw EC point of its key.
    point: Vec<u8>,
    not_before: OffsetDateTime,
    not_after: OffsetDateTime,
}

/// How many signers' certificates a checker remembers having verified: a site's
/// commanders, console and coordinators, with room for a new one now and then.
const VOUCHED_CACHE: usize = 256;

/// The site CA, checking seals.
#[derive(Debug)]
pub struct SealCheck {
    ca: Vec<u8>,
    /// Certificates already found signed by the CA, by their DER: checking one costs an
    /// X.509 parse and an ECDSA verify, and the same few sign every goal.
    vouched: Mutex<HashMap<Vec<u8>, Vouched>>,
}

impl SealCheck {
    /// The CA in PEM file `ca`.
    pub fn load(ca: &Path) -> Result<Self, PkiError> {
        let text = std::fs::read(ca).map_err(|source| PkiError::Io {
            what: format!("reading {}", ca.display()),
            source,
        })?;
        let (_, pem) = x509_parser::pem::parse_x509_pem(&text).map_err(|e| {
            PkiError::Refused(format!("{}: not a PEM certificate ({e})", ca.display()))
        })?;
        Ok(Self {
            ca: pem.contents,
            vouched: Mutex::default(),
        })
    }

    /// Check `seal` on `payload` (`None`: a delete) put on `key`: the identity that
    /// sealed it.
    pub fn check(
        &self,
        key: &str,
        payload: Option<&[u8]>,
        seal: &Seal,
    ) -> Result<Identity, SealError> {
        let der = seal.cert_der()?;
        let sig = seal.sig_bytes()?;
        let signer = self.vouch(&der)?;
        let now = OffsetDateTime::now_utc();
        if now > signer.not_after {
            return Err(SealError::Certificate(format!(
                "({}) expired on {}",
                signer.identity,
                crate::pki::date(signer.not_after)
            )));
        }
        if now < signer.not_before {
            return Err(SealError::Certificate(format!(
                "({}) is not valid yet",
                signer.identity
            )));
        }
        UnparsedPublicKey::new(&ECDSA_P256_SHA256_ASN1, &signer.point)
            .verify(&sealed_bytes(key, seal.at_ms, payload), &sig)
            .map_err(|_| SealError::Signature)?;
        Ok(signer.identity)
    }

    /// [`SealCheck::check`] of a message kept with its seal.
    pub fn check_sealed(&self, sealed: &Sealed) -> Result<Identity, SealError> {
        self.check(
            &sealed.key,
            sealed.payload.as_deref().map(str::as_bytes),
            &sealed.seal,
        )
    }

    /// The certificate `der` if this site's CA signed it.
    fn vouch(&self, der: &[u8]) -> Result<Vouched, SealError> {
        let mut vouched = self
            .vouched
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if let Some(v) = vouched.get(der) {
            return Ok(v.clone());
        }
        let bad = |why: &str| SealError::Certificate(why.to_owned());
        let (_, leaf) =
            X509Certificate::from_der(der).map_err(|_| bad("is not an X.509 certificate"))?;
        let (_, ca) = X509Certificate::from_der(&self.ca).map_err(|_| bad("has no CA to check"))?;
        leaf.verify_signature(Some(ca.public_key()))
            .map_err(|_| bad("is not signed by this site's CA"))?;
        let c = Certified::from_der(der, "the seal's certificate")
            .map_err(|e| SealError::Certificate(format!("names no identity ({e})")))?;
        let v = Vouched {
            identity: c.identity,
            point: leaf.public_key().subject_public_key.data.to_vec(),
            not_before: c.not_before,
            not_after: c.not_after,
        };
        if vouched.len() >= VOUCHED_CACHE {
            vouched.clear();
        }
        vouched.insert(der.to_vec(), v.clone());
        Ok(v)
    }
}

/// Whether `heard` (a message, or an answer passing one on) carries the seal of a
/// coordinator not `suspended`, whoever passes it on: what a coordinator puts for others
/// to take back (a fire track a recorder keeps for the next coordinator's recall, the
/// barred space a recorder gives a restarted unit) is believed only so, since a recorder's
/// key can answer anything. Nothing is checked on an open site (`check` is none).
pub fn by_coordinator(
    check: Option<&SealCheck>,
    heard: &crate::Raw,
    suspended: impl Fn(&Identity) -> bool,
) -> Result<(), String> {
    let Some(check) = check else {
        return Ok(());
    };
    let attachment = heard
        .attachment
        .as_ref()
        .ok_or("unsealed: on this site a coordinator seals what it puts here")?;
    let seal = Seal::from_attachment(attachment).map_err(|e| format!("unsealed: {e}"))?;
    match check.check(&heard.key, Some(&heard.bytes), &seal) {
        Ok(signer @ Identity::Coordinator(_)) if suspended(&signer) => {
            Err(format!("sealed by {signer}, which is suspended"))
        }
        Ok(Identity::Coordinator(_)) => Ok(()),
        Ok(signer) => Err(format!("sealed by {signer}, not by a coordinator")),
        Err(e) => Err(format!("seal refused: {e}")),
    }
}

/// A process's seals: its own identity to seal with, its CA to check others'.
#[derive(Debug)]
pub struct Seals {
    pub sealer: Sealer,
    pub check: SealCheck,
}

impl Seals {
    /// The seals of the identity in `files`.
    pub fn load(files: &TlsFiles) -> Result<Self, PkiError> {
        Ok(Self {
            sealer: Sealer::load(files)?,
            check: SealCheck::load(&files.ca)?,
        })
    }
}

#[cfg(test)]
mod tests;
