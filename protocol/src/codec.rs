//! Encoding and decoding with validation.
//!
//! Postcard messages carry one leading byte, the protocol version, so that a unit running
//! an older build is told why it cannot be understood instead of being misread. JSON
//! messages are self-describing and carry no version byte: the commander API evolves by
//! adding optional fields.

use crate::msg::{Encoding, Message};
use firefleet_model::validate::Invalid;

/// Version of the postcard wire format. Bump on any incompatible change to a postcard
/// message.
pub const PROTOCOL_VERSION: u8 = 6;

/// Why bytes could not become a valid message.
#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    #[error("empty payload")]
    Empty,
    #[error("protocol version {got}, this build speaks {PROTOCOL_VERSION}")]
    Version { got: u8 },
    #[error("undecodable: {0}")]
    Postcard(#[from] postcard::Error),
    #[error("undecodable: {0} bytes after the message")]
    Trailing(usize),
    #[error("malformed JSON: {0}")]
    Json(#[from] serde_json::Error),
    #[error("invalid: {0}")]
    Invalid(#[from] Invalid),
}

impl CodecError {
    /// Short, stable name of the failure class, for counters.
    pub fn class(&self) -> &'static str {
        match self {
            CodecError::Empty
            | CodecError::Postcard(_)
            | CodecError::Trailing(_)
            | CodecError::Json(_) => "undecodable",
            CodecError::Version { .. } => "version",
            CodecError::Invalid(_) => "invalid",
        }
    }
}

/// Encode a message in its wire encoding.
pub fn encode<M: Message>(m: &M) -> Vec<u8> {
    match M::ENCODING {
        Encoding::Postcard => {
            let mut out = vec![PROTOCOL_VERSION];
            // Serialising our own plain-data types into a Vec cannot fail.
            out.extend(postcard::to_stdvec(m).expect("postcard serialisation of a message"));
            out
        }
        Encoding::Json => serde_json::to_vec(m).expect("JSON serialisation of a message"),
    }
}

/// Decode and validate a message.
pub fn decode<M: Message>(bytes: &[u8]) -> Result<M, CodecError> {
    let m: M = match M::ENCODING {
        Encoding::Postcard => {
            let (&v, body) = bytes.split_first().ok_or(CodecError::Empty)?;
            if v != PROTOCOL_VERSION {
                return Err(CodecError::Version { got: v });
            }
            // A message followed by more bytes is not the message its sender meant (or
            // carries something smuggled past validation): refused whole.
            let (m, rest) = postcard::take_from_bytes(body)?;
            if !rest.is_empty() {
                return Err(CodecError::Trailing(rest.len()));
            }
            m
        }
        Encoding::Json => serde_json::from_slice(bytes)?,
    };
    m.validate()?;
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::*;
    use firefleet_model::geometry::{Point2, Pose2};
    use firefleet_model::ids::{FireId, UnitId};
    use proptest::prelude::*;

    fn report(x: f64, conf: f64) -> FlameReport {
        FlameReport {
            unit: UnitId::new("u1").unwrap(),
            t: 1.5,
            observer: Pose2::new(0.0, 0.0, 0.0),
            observations: vec![FlameObservation {
                position: Point2::new(x, 1.0),
                cov: [0.2, 0.0, 0.2],
                confidence: conf,
                hrr_kw: None,
            }],
        }
    }

    #[test]
    fn postcard_round_trip_and_version_check() {
        let r = report(3.0, 0.9);
        let bytes = encode(&r);
        assert_eq!(bytes[0], PROTOCOL_VERSION);
        assert_eq!(decode::<FlameReport>(&bytes).unwrap(), r);
        let mut old = bytes.clone();
        old[0] = PROTOCOL_VERSION + 1;
        assert!(matches!(
            decode::<FlameReport>(&old),
            Err(CodecError::Version { .. })
        ));
        assert!(matches!(decode::<FlameReport>(&[]), Err(CodecError::Empty)));
    }

    #[test]
    fn trailing_bytes_and_absurd_magnitudes_are_refused() {
        let mut bytes = encode(&report(3.0, 0.9));
        bytes.push(0);
        let e = decode::<FlameReport>(&bytes).unwrap_err();
        assert!(matches!(e, CodecError::Trailing(1)), "{e}");
        assert_eq!(e.class(), "undecodable");
        let mut r = report(3.0, 0.9);
        r.observer.yaw = 1e308;
        let e = decode::<FlameReport>(&encode(&r)).unwrap_err();
        assert!(e.to_string().contains("observer.yaw"), "{e}");
        let e = decode::<FlameReport>(&encode(&report(1e12, 0.9))).unwrap_err();
        assert!(e.to_string().contains("observations[0].position.x"), "{e}");
        r.observer.yaw = -3.0;
        assert!(decode::<FlameReport>(&encode(&r)).is_ok());
    }

    #[test]
    fn invalid_values_are_rejected_with_the_field_named() {
        let e = decode::<FlameReport>(&encode(&report(f64::NAN, 0.9))).unwrap_err();
        match e {
            CodecError::Invalid(i) => assert_eq!(i.field, "observations[0].position.x"),
            other => panic!("{other}"),
        }
        let e = decode::<FlameReport>(&encode(&report(1.0, 1.5))).unwrap_err();
        assert!(e.to_string().contains("observations[0].confidence"), "{e}");
    }

    #[test]
    fn json_goal_rejects_unknown_fields_and_missing_contain_line() {
        let ok = br#"{"id":"g1","zone":"z1","goal":"keep-out","priority":2}"#;
        assert_eq!(decode::<ZoneGoal>(ok).unwrap().goal, GoalKind::KeepOut);
        assert!(
            decode::<ZoneGoal>(br#"{"id":"g1","zone":"z1","goal":"keep-out","colour":1}"#).is_err()
        );
        let e = decode::<ZoneGoal>(br#"{"id":"g1","zone":"z1","goal":"contain"}"#).unwrap_err();
        assert!(e.to_string().contains("before_m"), "{e}");
        assert!(decode::<ZoneGoal>(br#"{"id":"g1","zone":"Z/1","goal":"monitor"}"#).is_err());
        for p in ["999", "-1"] {
            let json = format!(r#"{{"id":"g1","zone":"z1","goal":"monitor","priority":{p}}}"#);
            let e = decode::<ZoneGoal>(json.as_bytes()).unwrap_err();
            assert!(
                e.to_string()
                    .contains(&format!("priority {p} is outside 0-255")),
                "{e}"
            );
        }
    }

    #[test]
    fn task_round_trip() {
        let t = Task {
            unit: UnitId::new("u1").unwrap(),
            epoch: 1,
            seq: 9,
            t: 3.0,
            kind: TaskKind::Extinguish {
                fire: FireId(2),
                target: Point2::new(50.0, -1.0),
                from: crate::msg::Approach::Start,
            },
        };
        assert_eq!(decode::<Task>(&encode(&t)).unwrap(), t);
    }

    proptest! {
        // Whatever arrives from the network, decoding returns (never panics).
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..256)) {
            let _ = decode::<UnitState>(&bytes);
            let _ = decode::<FlameReport>(&bytes);
            let _ = decode::<Task>(&bytes);
            let _ = decode::<UnitSensors>(&bytes);
            let _ = decode::<ZoneGoal>(&bytes);
        }
    }
}
