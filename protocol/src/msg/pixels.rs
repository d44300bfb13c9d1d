//! A frame's pixel buffers on the wire: one little-endian byte string in postcard, plain
//! numbers in JSON.
//!
//! Postcard writes a `Vec<u16>` element by element, each a varint (three bytes for a
//! pixel near 293 K) through serde's visitor: for a 160x120 thermal frame and its depth
//! image that was most of what the simulator spent encoding a frame and most of what an
//! agent spent taking one in (debug builds, where our crates' copies of serde's generic
//! code are not optimised). As one byte string the buffer is a length and a copy each way
//! (the buffer's own bytes on a little-endian machine, through `bytemuck`), and a third
//! smaller. JSON (recordings, the schema) keeps the numbers a reader expects.
//!
//! [`to_le_bytes`] and [`from_le_bytes`] are the same conversion for whoever else carries
//! such buffers as bytes (a ROS 2 image's `data`).
//!
//! Not here: what the pixels mean ([`super::ThermalImage`]).

use std::borrow::Cow;
use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserialize, Deserializer, Visitor};
use serde::ser::{Serialize, Serializer};

/// A pixel type carried as fixed-width little-endian bytes: `u16` (counts), `f32` (depth).
pub trait Pixel: bytemuck::Pod + Serialize + for<'de> Deserialize<'de> {
    /// The pixel with its bytes in little-endian order (and back): nothing on a
    /// little-endian machine.
    fn le(self) -> Self;
}

impl Pixel for u16 {
    fn le(self) -> Self {
        self.to_le()
    }
}

impl Pixel for f32 {
    fn le(self) -> Self {
        f32::from_bits(self.to_bits().to_le())
    }
}

/// The buffer's bytes, little-endian: the buffer itself on a little-endian machine.
pub fn to_le_bytes<P: Pixel>(pixels: &[P]) -> Cow<'_, [u8]> {
    if cfg!(target_endian = "little") {
        Cow::Borrowed(bytemuck::cast_slice(pixels))
    } else {
        let swapped: Vec<P> = pixels.iter().map(|p| p.le()).collect();
        Cow::Owned(bytemuck::cast_slice(&swapped).to_vec())
    }
}

/// The pixels of little-endian `bytes`: one copy. A trailing part of a pixel is left out.
pub fn from_le_bytes<P: Pixel>(bytes: &[u8]) -> Vec<P> {
    let bytes = &bytes[..bytes.len() - bytes.len() % size_of::<P>()];
    let mut pixels = vec![P::zeroed(); bytes.len() / size_of::<P>()];
    bytemuck::cast_slice_mut(&mut pixels).copy_from_slice(bytes);
    if cfg!(target_endian = "big") {
        for p in &mut pixels {
            *p = p.le();
        }
    }
    pixels
}

pub(crate) fn serialize<P: Pixel, S: Serializer>(pixels: &[P], s: S) -> Result<S::Ok, S::Error> {
    if s.is_human_readable() {
        pixels.serialize(s)
    } else {
        s.serialize_bytes(&to_le_bytes(pixels))
    }
}

pub(crate) fn deserialize<'de, P: Pixel, D: Deserializer<'de>>(d: D) -> Result<Vec<P>, D::Error> {
    if d.is_human_readable() {
        return Vec::<P>::deserialize(d);
    }
    struct Bytes<P>(PhantomData<P>);
    impl<P: Pixel> Visitor<'_> for Bytes<P> {
        type Value = Vec<P>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            write!(f, "pixels of {} bytes each", size_of::<P>())
        }
        fn visit_bytes<E: de::Error>(self, bytes: &[u8]) -> Result<Vec<P>, E> {
            if !bytes.len().is_multiple_of(size_of::<P>()) {
                return Err(E::invalid_length(bytes.len(), &self));
            }
            Ok(from_le_bytes(bytes))
        }
    }
    d.deserialize_bytes(Bytes(PhantomData))
}

#[cfg(test)]
mod tests {
    #[derive(Debug, PartialEq, serde::Serialize, serde::Deserialize)]
    struct Frame {
        #[serde(with = "super")]
        counts: Vec<u16>,
        #[serde(with = "super")]
        depth: Vec<f32>,
    }

    #[test]
    fn pixels_are_one_byte_string_in_postcard_and_numbers_in_json() {
        let f = Frame {
            counts: vec![29_315, 0, u16::MAX],
            depth: vec![0.0, 7.25, -1.5],
        };
        let bytes = postcard::to_stdvec(&f).unwrap();
        // A length and the little-endian bytes, for each buffer.
        let mut want = vec![6, 0x83, 0x72, 0, 0, 0xff, 0xff, 12];
        for z in &f.depth {
            want.extend(z.to_le_bytes());
        }
        assert_eq!(bytes, want);
        assert_eq!(postcard::from_bytes::<Frame>(&bytes).unwrap(), f);
        let json = serde_json::to_string(&f).unwrap();
        assert_eq!(
            json,
            r#"{"counts":[29315,0,65535],"depth":[0.0,7.25,-1.5]}"#
        );
        assert_eq!(serde_json::from_str::<Frame>(&json).unwrap(), f);
    }

    #[test]
    fn a_byte_string_that_is_no_whole_number_of_pixels_is_refused() {
        // Three bytes of counts: a pixel and a half.
        let err = postcard::from_bytes::<Frame>(&[3, 1, 2, 3, 0]).unwrap_err();
        assert!(matches!(err, postcard::Error::SerdeDeCustom), "{err:?}");
    }
}
