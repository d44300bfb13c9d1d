//! ROS 2's serialized form: a 4-byte encapsulation header, then the message in OMG CDR.
//!
//! The header's second byte says the byte order (`0x01` little-endian, what every ROS 2
//! platform we know of sends; `0x00` big-endian, which we read too); the last two bytes are
//! options we neither set nor need. Alignment in the body is relative to the byte after the
//! header. The body is `cdr-encoding`'s.
//!
//! Not here: which fields a message has ([`crate::msg`]).

use byteorder::{BigEndian, LittleEndian};
use serde::{Deserialize, Serialize};

/// Encapsulation ids (RTPS 10.2): plain CDR, big- and little-endian.
const CDR_BE: [u8; 2] = [0x00, 0x00];
const CDR_LE: [u8; 2] = [0x00, 0x01];

/// Why bytes are not a message of the expected type.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    #[error("shorter than the 4-byte encapsulation header ({0} bytes)")]
    NoHeader(usize),
    #[error("encapsulation {0:02x}{1:02x} is not plain CDR")]
    Encapsulation(u8, u8),
    #[error("CDR body: {0}")]
    Body(#[from] cdr_encoding::Error),
    #[error("{0} bytes after the message's last field")]
    Trailing(usize),
}

/// `m` as ROS 2 sends it (little-endian CDR).
pub fn encode<M: Serialize>(m: &M) -> Vec<u8> {
    let mut out = vec![CDR_LE[0], CDR_LE[1], 0, 0];
    // Serializing plain data into a Vec cannot fail.
    let body = cdr_encoding::to_vec::<M, LittleEndian>(m).expect("CDR of a plain message");
    out.extend_from_slice(&body);
    out
}

/// A message from what a ROS 2 publisher sent.
///
/// Up to three bytes after the last field are accepted: publishers pad the body to a
/// multiple of four, as the options bytes of the header may say.
pub fn decode<M: for<'de> Deserialize<'de>>(bytes: &[u8]) -> Result<M, CdrError> {
    let (header, body) = bytes
        .split_first_chunk::<4>()
        .ok_or(CdrError::NoHeader(bytes.len()))?;
    let (m, used) = match [header[0], header[1]] {
        CDR_LE => cdr_encoding::from_bytes::<M, LittleEndian>(body)?,
        CDR_BE => cdr_encoding::from_bytes::<M, BigEndian>(body)?,
        [a, b] => return Err(CdrError::Encapsulation(a, b)),
    };
    match body.len() - used {
        0..=3 => Ok(m),
        n => Err(CdrError::Trailing(n)),
    }
}

/// A `sequence<uint8>` field (an image's `data`) as one run of bytes: CDR writes it as a
/// 4-aligned length and the bytes either way, but serde's element-by-element path costs a
/// call a byte (a thermal frame's 115 kB took an agent most of its time in debug builds,
/// where our crates' copies of the codec's generic code are not optimised). JSON keeps the
/// numbers.
pub mod octets {
    use std::fmt;

    use serde::de::{self, Deserializer, Visitor};
    use serde::{Deserialize, Serializer};

    pub fn serialize<S: Serializer>(bytes: &[u8], s: S) -> Result<S::Ok, S::Error> {
        if s.is_human_readable() {
            s.collect_seq(bytes)
        } else {
            s.serialize_bytes(bytes)
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<u8>, D::Error> {
        if d.is_human_readable() {
            return Vec::<u8>::deserialize(d);
        }
        struct Octets;
        impl<'de> Visitor<'de> for Octets {
            type Value = Vec<u8>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a sequence of octets")
            }
            fn visit_bytes<E: de::Error>(self, bytes: &[u8]) -> Result<Vec<u8>, E> {
                Ok(bytes.to_vec())
            }
            fn visit_byte_buf<E: de::Error>(self, bytes: Vec<u8>) -> Result<Vec<u8>, E> {
                Ok(bytes)
            }
        }
        d.deserialize_byte_buf(Octets)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::msg::*;

    #[test]
    fn known_layouts() {
        // std_msgs/String "hi": header, length 3 (with NUL), 'h' 'i' NUL.
        #[derive(Serialize)]
        struct S {
            data: String,
        }
        assert_eq!(
            encode(&S { data: "hi".into() }),
            [0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0]
        );
        // A bool then a float64: the float aligns to 8 from the body's start.
        #[derive(Serialize)]
        struct BF {
            b: bool,
            f: f64,
        }
        let bytes = encode(&BF { b: true, f: 1.0 });
        assert_eq!(bytes.len(), 4 + 8 + 8);
        assert_eq!(&bytes[12..], 1.0f64.to_le_bytes());
    }

    #[test]
    fn round_trips_and_refuses_garbage() {
        let m = JointState {
            header: Header::new(1.5, "ugv_1/base_link"),
            name: vec!["a".into(), "bc".into()],
            position: vec![0.5, -1.0],
            velocity: vec![],
            effort: vec![],
        };
        let bytes = encode(&m);
        assert_eq!(decode::<JointState>(&bytes).unwrap(), m);
        assert!(matches!(
            decode::<JointState>(&bytes[..3]),
            Err(CdrError::NoHeader(3))
        ));
        assert!(decode::<JointState>(&bytes[..bytes.len() - 9]).is_err());
        let mut wrong = bytes.clone();
        wrong[1] = 0x07;
        assert!(matches!(
            decode::<JointState>(&wrong),
            Err(CdrError::Encapsulation(0, 7))
        ));
        let mut long = bytes;
        long.extend_from_slice(&[0; 8]);
        assert!(matches!(
            decode::<JointState>(&long),
            Err(CdrError::Trailing(8))
        ));
    }
}
