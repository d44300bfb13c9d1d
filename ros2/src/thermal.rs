//! A thermal core's frames as ROS 2 images, and back, checked.
//!
//! Topics, relative to the robot's namespace:
//!
//! | topic | type | content |
//! |---|---|---|
//! | `thermal/image_raw` | sensor_msgs/Image | `mono16` (or `16UC1`), little-endian, 0.01 K a count (a radiometric core's TLinear output) |
//! | `thermal/depth` | sensor_msgs/Image | `32FC1`, metres along the optical axis, registered to the thermal image; 0 or NaN where there is none |
//! | `thermal/camera_info` | sensor_msgs/CameraInfo | the core's intrinsics (`k`), no distortion |
//!
//! Choices, and why:
//! - A frame is the thermal image and the depth image with the same stamp; either alone
//!   is held until its partner comes (a newer one replaces it).
//! - The agent places what it finds through its profile's `thermal_camera` (the mount is
//!   the profile's; ROS's TF is not read). A camera info whose size or intrinsics differ
//!   from the profile's (by more than half a pixel) makes every frame refused with the
//!   reason, rather than flames placed through the wrong lens. Without a camera info the
//!   profile's intrinsics are taken as they are.
//! - `mono16` and `16UC1` are the same bytes; cores' drivers publish either. Big-endian
//!   images are refused (no common core sends them).
//!
//! Not here: finding flames in the pixels (`firefleet_agent::ground::thermal`).

use firefleet_model::spec::CameraSpec;
use firefleet_model::validate::Validate;
use firefleet_protocol::msg::{ThermalImage, pixels};

use crate::msg::{CameraInfo, Header, Image};

pub const THERMAL_IMAGE: &str = "thermal/image_raw";
pub const THERMAL_DEPTH: &str = "thermal/depth";
pub const THERMAL_INFO: &str = "thermal/camera_info";

/// How far a camera info's intrinsics may be from the profile's, pixels.
const INTRINSICS_TOLERANCE_PX: f64 = 0.5;

/// Why a thermal frame from a robot was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FrameError {
    #[error("{topic}: encoding {found:?}, expected {expected}")]
    Encoding {
        topic: &'static str,
        found: String,
        expected: &'static str,
    },
    #[error("{topic}: big-endian pixels are not taken")]
    BigEndian { topic: &'static str },
    #[error("{topic}: {what}")]
    Layout { topic: &'static str, what: String },
    #[error("{THERMAL_DEPTH} is {depth_w}x{depth_h}, {THERMAL_IMAGE} {w}x{h}: not registered")]
    Unregistered {
        w: u32,
        h: u32,
        depth_w: u32,
        depth_h: u32,
    },
    #[error("{THERMAL_INFO}: {what} differs from the profile's thermal_camera ({profile})")]
    Intrinsics { what: &'static str, profile: String },
    #[error("the frame: {0}")]
    Invalid(String),
}

/// `img`'s data, checked against its encoding, byte order and size (rows may be padded
/// past their pixels: `step` bytes a row, of which `from_ros` reads the pixels').
fn checked<'a>(
    img: &'a Image,
    topic: &'static str,
    encodings: &[&'static str],
    bytes_per_pixel: u32,
) -> Result<&'a [u8], FrameError> {
    if !encodings.contains(&img.encoding.as_str()) {
        return Err(FrameError::Encoding {
            topic,
            found: img.encoding.clone(),
            expected: encodings[0],
        });
    }
    if img.is_bigendian != 0 {
        return Err(FrameError::BigEndian { topic });
    }
    let fits = img
        .width
        .checked_mul(bytes_per_pixel)
        .is_some_and(|row| img.step >= row);
    if !fits {
        return Err(FrameError::Layout {
            topic,
            what: format!("step {} is short of {} pixels", img.step, img.width),
        });
    }
    let want = u64::from(img.step) * u64::from(img.height);
    if img.data.len() as u64 != want {
        return Err(FrameError::Layout {
            topic,
            what: format!(
                "{} bytes of data for {} rows of {} bytes",
                img.data.len(),
                img.height,
                img.step
            ),
        });
    }
    Ok(&img.data)
}

/// The profile's intrinsics checked against a camera info.
fn check_info(info: &CameraInfo, optics: &CameraSpec) -> Result<(), FrameError> {
    let profile = || {
        format!(
            "{}x{}, fx {} fy {} cx {} cy {}",
            optics.width_px, optics.height_px, optics.fx, optics.fy, optics.cx, optics.cy
        )
    };
    if f64::from(info.width) != optics.width_px || f64::from(info.height) != optics.height_px {
        return Err(FrameError::Intrinsics {
            what: "the image size",
            profile: profile(),
        });
    }
    let k = &info.k;
    for (what, got, want) in [
        ("fx", k[0], optics.fx),
        ("fy", k[4], optics.fy),
        ("cx", k[2], optics.cx),
        ("cy", k[5], optics.cy),
    ] {
        // Written so that a NaN is refused too.
        let close = (got - want).abs() <= INTRINSICS_TOLERANCE_PX;
        if !close {
            return Err(FrameError::Intrinsics {
                what,
                profile: profile(),
            });
        }
    }
    Ok(())
}

/// A frame from a robot's thermal image and the depth registered to it, checked against
/// its camera info (if one came) and the profile's `optics`.
pub fn from_ros(
    thermal: &Image,
    depth: &Image,
    info: Option<&CameraInfo>,
    optics: &CameraSpec,
) -> Result<ThermalImage, FrameError> {
    let t = checked(thermal, THERMAL_IMAGE, &["mono16", "16UC1"], 2)?;
    let d = checked(depth, THERMAL_DEPTH, &["32FC1"], 4)?;
    if (depth.width, depth.height) != (thermal.width, thermal.height) {
        return Err(FrameError::Unregistered {
            w: thermal.width,
            h: thermal.height,
            depth_w: depth.width,
            depth_h: depth.height,
        });
    }
    if let Some(info) = info {
        check_info(info, optics)?;
    }
    if f64::from(thermal.width) != optics.width_px || f64::from(thermal.height) != optics.height_px
    {
        return Err(FrameError::Layout {
            topic: THERMAL_IMAGE,
            what: format!(
                "{}x{} pixels, where the profile's thermal_camera has {}x{}",
                thermal.width, thermal.height, optics.width_px, optics.height_px
            ),
        });
    }
    let (w, h) = (thermal.width as usize, thermal.height as usize);
    let (ts, ds) = (thermal.step as usize, depth.step as usize);
    let mut centikelvin = Vec::with_capacity(w * h);
    let mut depth_m = Vec::with_capacity(w * h);
    for v in 0..h {
        centikelvin.extend(pixels::from_le_bytes::<u16>(&t[v * ts..v * ts + 2 * w]));
        depth_m.extend(pixels::from_le_bytes::<f32>(&d[v * ds..v * ds + 4 * w]));
    }
    // No value is 0 here; ROS depth images also say it with NaN.
    for z in depth_m.iter_mut().filter(|z| !z.is_finite()) {
        *z = 0.0;
    }
    let image = ThermalImage {
        width: thermal.width as u16,
        height: thermal.height as u16,
        centikelvin,
        depth_m,
    };
    image
        .validate()
        .map_err(|e| FrameError::Invalid(e.to_string()))?;
    Ok(image)
}

/// A frame as the robot publishes it: the thermal image, the depth image and the camera
/// info, stamped `t` in frame `frame_id`, for a core with `optics`.
pub fn to_ros(
    img: &ThermalImage,
    t: f64,
    frame_id: &str,
    optics: &CameraSpec,
) -> (Image, Image, CameraInfo) {
    let (w, h) = (u32::from(img.width), u32::from(img.height));
    let header = Header::new(t, frame_id);
    let thermal = Image {
        header: header.clone(),
        height: h,
        width: w,
        encoding: "mono16".into(),
        is_bigendian: 0,
        step: 2 * w,
        data: pixels::to_le_bytes(&img.centikelvin).into_owned(),
    };
    let depth = Image {
        header: header.clone(),
        height: h,
        width: w,
        encoding: "32FC1".into(),
        is_bigendian: 0,
        step: 4 * w,
        data: pixels::to_le_bytes(&img.depth_m).into_owned(),
    };
    let (fx, fy, cx, cy) = (optics.fx, optics.fy, optics.cx, optics.cy);
    let info = CameraInfo {
        header,
        height: h,
        width: w,
        distortion_model: "plumb_bob".into(),
        d: vec![0.0; 5],
        k: [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
        r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        p: [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        ..CameraInfo::default()
    };
    (thermal, depth, info)
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;

    fn frame() -> (ThermalImage, CameraSpec) {
        let optics = GROUND.thermal_camera.unwrap();
        let n = 160 * 120;
        let img = ThermalImage {
            width: 160,
            height: 120,
            centikelvin: (0..n).map(|i| 29_000 + (i % 1000) as u16).collect(),
            depth_m: (0..n).map(|i| (i % 7) as f32).collect(),
        };
        (img, optics)
    }

    #[test]
    fn a_frame_goes_through_ros_and_back_unchanged() {
        let (img, optics) = frame();
        let (t, d, info) = to_ros(&img, 12.5, "ugv_1/thermal_optical_frame", &optics);
        assert_eq!(from_ros(&t, &d, Some(&info), &optics).unwrap(), img);
    }

    #[test]
    fn padded_rows_and_nan_depth_are_read_as_ros_means_them() {
        let (img, optics) = frame();
        let (mut t, mut d, _) = to_ros(&img, 1.0, "f", &optics);
        let pad = |im: &mut Image, extra: usize| {
            let row = im.step as usize;
            im.data = im
                .data
                .chunks(row)
                .flat_map(|r| r.iter().copied().chain(std::iter::repeat_n(0xAB, extra)))
                .collect();
            im.step += extra as u32;
        };
        pad(&mut t, 6);
        d.data[4..8].copy_from_slice(&f32::NAN.to_le_bytes());
        let back = from_ros(&t, &d, None, &optics).unwrap();
        assert_eq!(back.centikelvin, img.centikelvin);
        assert_eq!(back.depth_m[1], 0.0);
    }

    #[test]
    fn bad_frames_are_refused_with_the_reason() {
        let (img, optics) = frame();
        let (t, d, info) = to_ros(&img, 1.0, "f", &optics);
        let rgb = Image {
            encoding: "rgb8".into(),
            ..t.clone()
        };
        assert_eq!(
            from_ros(&rgb, &d, None, &optics).unwrap_err().to_string(),
            "thermal/image_raw: encoding \"rgb8\", expected mono16"
        );
        let short = Image {
            data: t.data[..100].to_vec(),
            ..t.clone()
        };
        assert!(
            from_ros(&short, &d, None, &optics)
                .unwrap_err()
                .to_string()
                .contains("100 bytes of data for 120 rows of 320 bytes")
        );
        let other_lens = CameraInfo {
            k: [200.0, 0.0, 80.0, 0.0, 200.0, 60.0, 0.0, 0.0, 1.0],
            ..info.clone()
        };
        assert!(matches!(
            from_ros(&t, &d, Some(&other_lens), &optics),
            Err(FrameError::Intrinsics { what: "fx", .. })
        ));
        let big = Image {
            is_bigendian: 1,
            ..d.clone()
        };
        assert_eq!(
            from_ros(&t, &big, None, &optics).unwrap_err(),
            FrameError::BigEndian {
                topic: THERMAL_DEPTH
            }
        );
    }
}
