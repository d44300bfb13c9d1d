//! Seals: a site identity's signature over one message exactly as it was put (or deleted)
//! on one key, so that whoever relays or recalls it later can tell who said it.
//!
//! A commander's goal and a clear of its goals travel sealed on a secure site: the seal
//! rides in the sample's Zenoh attachment (JSON [`Seal`]), so the goal's own JSON is what
//! it always was and any Zenoh client can seal one by following [`sealed_bytes`]. The
//! coordinator keeps each goal in force with its seal ([`Sealed`]) and each clear's seal
//! as a tombstone ([`Cleared`]), publishes them in `coord/goals`, and journals them: a
//! restarted coordinator checks every one again, so a recorder's answer (or a stolen
//! recorder key's) can add no goal nobody sealed and bring back none that was cleared.
//!
//! Why the exact bytes and not a canonical form: a signature over the payload as sent
//! needs no agreement on how JSON is written, which clients in other languages would get
//! wrong.
//!
//! Not here: the signature itself and the certificate checks (`firefleet-bus`'s `seal`,
//! which holds the keys) or who may seal what (the coordinator's rules).

use base64::Engine as _;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use firefleet_model::ids::{CommanderId, ZoneId};
use firefleet_model::validate::{Invalid, Validate};

/// The most bytes a seal's certificate (DER) may have: a site leaf is some 500.
pub const MAX_SEAL_CERT: usize = 4096;
/// The most bytes a seal's signature may have (an ECDSA P-256 one is at most 72).
pub const MAX_SEAL_SIG: usize = 512;

/// A signature by a site identity, as it rides in a sample's attachment (JSON).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct Seal {
    /// The signer's certificate, DER in standard base64: the site CA vouches for it.
    pub cert: String,
    /// When it was sealed, milliseconds since the Unix epoch on the signer's clock
    /// (wall time, not site time: a commander's tool need not hear the site clock to
    /// seal, and a seal outlives the rehearsal's clock).
    pub at_ms: u64,
    /// The signature over [`sealed_bytes`], standard base64 (ECDSA P-256 SHA-256, ASN.1
    /// DER: the key every `firefleet pki` certificate holds).
    pub sig: String,
}

/// What a seal signs: a fixed prefix, the whole key expression (site, zone, commander),
/// the time, and the payload of a put (`None`: a delete). Lines, so a person can see what
/// was signed:
///
/// ```text
/// firefleet seal 1
/// ff/<site>/zone/<zone>/goal/<commander>
/// <at_ms>
/// put            (or: delete)
/// <payload bytes, as sent>
/// ```
pub fn sealed_bytes(key: &str, at_ms: u64, payload: Option<&[u8]>) -> Vec<u8> {
    let mut out = format!(
        "firefleet seal 1\n{key}\n{at_ms}\n{}\n",
        if payload.is_some() { "put" } else { "delete" }
    )
    .into_bytes();
    out.extend_from_slice(payload.unwrap_or_default());
    out
}

impl Seal {
    /// The seal in `attachment` (a sample's), or why it is none.
    pub fn from_attachment(attachment: &[u8]) -> Result<Self, Invalid> {
        let seal: Self = serde_json::from_slice(attachment)
            .map_err(|e| Invalid::new("seal", format!("not a seal ({e})")))?;
        seal.validate()?;
        Ok(seal)
    }

    /// The attachment that carries this seal.
    pub fn to_attachment(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("a seal serializes")
    }

    /// The signer's certificate, DER.
    pub fn cert_der(&self) -> Result<Vec<u8>, Invalid> {
        decode("cert", &self.cert, MAX_SEAL_CERT)
    }

    /// The signature's bytes.
    pub fn sig_bytes(&self) -> Result<Vec<u8>, Invalid> {
        decode("sig", &self.sig, MAX_SEAL_SIG)
    }
}

fn decode(field: &str, text: &str, max: usize) -> Result<Vec<u8>, Invalid> {
    // Base64 is 4 characters for 3 bytes: refuse a long one before decoding it.
    if text.len() > max.div_ceil(3) * 4 {
        return Err(Invalid::new(field, format!("longer than {max} bytes")));
    }
    let bytes = base64::engine::general_purpose::STANDARD
        .decode(text)
        .map_err(|e| Invalid::new(field, format!("not base64 ({e})")))?;
    if bytes.len() > max {
        return Err(Invalid::new(field, format!("longer than {max} bytes")));
    }
    Ok(bytes)
}

/// Standard base64 of `bytes`, as seals carry them.
pub fn base64_of(bytes: &[u8]) -> String {
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

impl Validate for Seal {
    fn validate(&self) -> Result<(), Invalid> {
        self.cert_der()?;
        self.sig_bytes()?;
        Ok(())
    }
}

/// A message as it was sealed: its key, its payload exactly as sent (a goal's JSON; none
/// for a delete), and the seal. What is kept so that the seal can be checked again later.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Sealed {
    pub key: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub payload: Option<String>,
    pub seal: Seal,
}

impl Sealed {
    /// What the seal signs.
    pub fn bytes(&self) -> Vec<u8> {
        sealed_bytes(
            &self.key,
            self.seal.at_ms,
            self.payload.as_deref().map(str::as_bytes),
        )
    }
}

impl Validate for Sealed {
    fn validate(&self) -> Result<(), Invalid> {
        self.seal.validate().map_err(|e| e.within("seal"))
    }
}

/// A commander's clear of its goals on a zone, sealed: every goal of that commander on
/// that zone sealed before it stays cleared, whoever recalls it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
pub struct Cleared {
    pub zone: ZoneId,
    pub by: CommanderId,
    pub proof: Sealed,
}

impl Validate for Cleared {
    fn validate(&self) -> Result<(), Invalid> {
        if self.proof.payload.is_some() {
            return Err(Invalid::new("proof", "a clear seals a delete, not a put"));
        }
        self.proof.validate().map_err(|e| e.within("proof"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_sealed_names_key_time_and_kind() {
        let put = sealed_bytes("ff/s/zone/deep/goal/rossi", 7, Some(b"{}"));
        assert_eq!(
            put,
            b"firefleet seal 1\nff/s/zone/deep/goal/rossi\n7\nput\n{}"
        );
        let delete = sealed_bytes("ff/s/zone/deep/goal/rossi", 7, None);
        assert_eq!(
            delete,
            b"firefleet seal 1\nff/s/zone/deep/goal/rossi\n7\ndelete\n"
        );
        // An empty put is not a delete.
        assert_ne!(sealed_bytes("k", 7, Some(b"")), delete);
    }

    #[test]
    fn a_bad_attachment_is_named() {
        let e = Seal::from_attachment(b"nonsense").unwrap_err();
        assert!(e.to_string().contains("not a seal"), "{e}");
        let seal = Seal {
            cert: "***".into(),
            at_ms: 1,
            sig: base64_of(b"x"),
        };
        let e = Seal::from_attachment(&seal.to_attachment()).unwrap_err();
        assert_eq!(e.field, "cert");
        let huge = Seal {
            cert: base64_of(&vec![0; MAX_SEAL_CERT + 1]),
            ..seal
        };
        assert!(Seal::from_attachment(&huge.to_attachment()).is_err());
    }
}
