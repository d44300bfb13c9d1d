//! Identifiers as newtypes, so a unit id can never be passed where a site id is meant.
//!
//! Site and unit ids become chunks of Zenoh key expressions, so they are restricted to a
//! small alphabet that can never contain the key-expression specials (`/ * $ # ?`).
//!
//! Not here: key expressions built from them (`firefleet_protocol::keys`, which builds on this crate).

use std::fmt;
use std::str::FromStr;

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

/// Why a string is not a valid identifier.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("invalid {what} '{value}': {reason}")]
pub struct IdError {
    pub what: &'static str,
    pub value: String,
    pub reason: &'static str,
}

const MAX_ID_LEN: usize = 48;

fn check_chunk(what: &'static str, s: &str) -> Result<(), IdError> {
    let err = |reason| IdError {
        what,
        value: s.to_owned(),
        reason,
    };
    if s.is_empty() {
        return Err(err("must not be empty"));
    }
    if s.len() > MAX_ID_LEN {
        return Err(err("longer than 48 characters"));
    }
    if !s
        .bytes()
        .all(|b| b.is_ascii_lowercase() || b.is_ascii_digit() || b == b'-' || b == b'_')
    {
        return Err(err(
            "only lowercase letters, digits, '-' and '_' are allowed",
        ));
    }
    if !s.as_bytes()[0].is_ascii_alphanumeric() {
        return Err(err("must start with a letter or a digit"));
    }
    Ok(())
}

macro_rules! chunk_id {
    ($(#[$doc:meta])* $name:ident, $what:literal) => {
        $(#[$doc])*
        #[derive(Debug, Clone, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, JsonSchema)]
        #[serde(transparent)]
        pub struct $name(String);

        impl $name {
            pub fn new(s: impl Into<String>) -> Result<Self, IdError> {
                let s = s.into();
                check_chunk($what, &s)?;
                Ok(Self(s))
            }
            pub fn as_str(&self) -> &str {
                &self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(&self.0)
            }
        }

        impl PartialEq<str> for $name {
            fn eq(&self, other: &str) -> bool {
                self.0 == other
            }
        }

        impl FromStr for $name {
            type Err = IdError;
            fn from_str(s: &str) -> Result<Self, IdError> {
                Self::new(s)
            }
        }

        // Deserialization goes through `new` so that no invalid id can enter from a
        // message or a file.
        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                let s = String::deserialize(d)?;
                Self::new(s).map_err(serde::de::Error::custom)
            }
        }
    };
}

chunk_id!(
    /// A site (one tunnel incident installation); the first chunk after `ff/`.
    SiteId,
    "site id"
);
chunk_id!(
    /// A robot of the fleet, ground or monorail.
    UnitId,
    "unit id"
);
chunk_id!(
    /// A zone of the tunnel (a chainage range named in the site file).
    ZoneId,
    "zone id"
);
chunk_id!(
    /// An incident commander, as goals name their issuer: the last chunk of a goal's key,
    /// and the name in the commander's certificate (`commander:<name>`), so on a site with
    /// access rules the router, not the goal's text, says who issued it.
    CommanderId,
    "commander name"
);
chunk_id!(
    /// A router of a site beyond its first: the name in its certificate (`router:<name>`).
    RouterId,
    "router name"
);

/// A fused fire track, numbered by the coordinator that created it.
///
/// One form wherever a person or another language reads it: `f7` in key expressions, on
/// the command line, in logs and in JSON. Compact encodings (postcard on the bus) carry
/// the bare number. JSON from before this form (a bare number) is still read, so older
/// recordings keep loading.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FireId(pub u32);

impl Serialize for FireId {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            s.collect_str(self)
        } else {
            s.serialize_u32(self.0)
        }
    }
}

impl<'de> Deserialize<'de> for FireId {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Form {
            Text(String),
            Number(u32),
        }
        if !d.is_human_readable() {
            return u32::deserialize(d).map(FireId);
        }
        match Form::deserialize(d)? {
            Form::Text(s) => s.parse().map_err(serde::de::Error::custom),
            Form::Number(n) => Ok(FireId(n)),
        }
    }
}

impl JsonSchema for FireId {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "FireId".into()
    }

    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        schemars::json_schema!({
            "type": "string",
            "pattern": "^f[0-9]+$",
            "description": "A fire track's id: 'f' and the coordinator's number for it, as in the key ff/<site>/fire/<id>."
        })
    }
}

impl fmt::Display for FireId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "f{}", self.0)
    }
}

impl FromStr for FireId {
    type Err = IdError;
    fn from_str(s: &str) -> Result<Self, IdError> {
        s.strip_prefix('f')
            .and_then(|n| n.parse().ok())
            .map(FireId)
            .ok_or_else(|| IdError {
                what: "fire id",
                value: s.to_owned(),
                reason: "expected 'f' followed by a number",
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_reject_key_expression_specials() {
        for bad in ["", "a/b", "*", "a*", "$x", "A", "-a", "a b", "é"] {
            assert!(UnitId::new(bad).is_err(), "{bad:?} accepted");
        }
        assert!(UnitId::new("ugv-1").is_ok());
        assert!(SiteId::new("a".repeat(49)).is_err());
    }

    #[test]
    fn ids_deserialize_through_validation() {
        assert!(serde_json::from_str::<UnitId>("\"ugv_2\"").is_ok());
        let err = serde_json::from_str::<UnitId>("\"ugv/2\"").unwrap_err();
        assert!(err.to_string().contains("unit id"), "{err}");
    }

    #[test]
    fn fire_id_round_trips_through_text() {
        assert_eq!("f12".parse::<FireId>().unwrap(), FireId(12));
        assert_eq!(FireId(7).to_string(), "f7");
        assert!("12".parse::<FireId>().is_err());
    }

    #[test]
    fn a_fire_id_is_f7_in_json_a_number_in_postcard_and_old_json_still_reads() {
        assert_eq!(serde_json::to_string(&FireId(7)).unwrap(), "\"f7\"");
        assert_eq!(serde_json::from_str::<FireId>("\"f7\"").unwrap(), FireId(7));
        assert_eq!(serde_json::from_str::<FireId>("7").unwrap(), FireId(7));
        let e = serde_json::from_str::<FireId>("\"7\"").unwrap_err();
        assert!(
            e.to_string().contains("expected 'f' followed by a number"),
            "{e}"
        );
        let bytes = postcard::to_allocvec(&FireId(7)).unwrap();
        assert_eq!(bytes, [7]);
        assert_eq!(postcard::from_bytes::<FireId>(&bytes).unwrap(), FireId(7));
    }
}
