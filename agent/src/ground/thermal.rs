//! Flames found in a radiometric thermal image's pixels, with the registered depth image:
//! the detector a unit with only a thermal camera runs in place of a box detector.
//!
//! Each frame, in three steps:
//! 1. **Segmentation** by hysteresis: a region starts at pixels at or above
//!    [`DetectorConfig::seed_k`] (a flame's core saturates the core's 655 K scale; the hot
//!    layer, exhausts and sunlit portals stay below) and grows through 4-connected pixels
//!    at or above [`DetectorConfig::grow_k`], so a region takes in the flame's cooler,
//!    thinner edges.
//! 2. **Persistence**: each region is matched to the nearest region of the previous frames
//!    (centroid within [`DetectorConfig::match_px`]). The size and the top row of its core
//!    (the pixels at or above the seed temperature; what the flame heats around it is
//!    steady and would hide the flicker) over the last [`DetectorConfig::window`] frames
//!    are fitted with straight lines (the camera closing in changes them steadily), and
//!    what is left is flicker. Flames pulse at 1-3 Hz by tens of
//!    per cent; hot metal does not move. A region is a flame once seen in
//!    [`DetectorConfig::min_frames`] frames with a detrended flicker of at least
//!    [`DetectorConfig::min_flicker`].
//! 3. **Position**, from the core: the range to the flame's visible surface is the median
//!    of its valid depth pixels or where the ray through its bottom row meets the road (a
//!    flame stands on it), the nearer of the two: smoke blinds a depth camera long before
//!    long-wave infrared, and a thin flame is transparent to it. The road ray is used only
//!    as near as one pixel of its row costs [`DetectorConfig::max_road_error_m`], and no
//!    range beyond the camera's is reported. Half the core's width at that range is added:
//!    a flame's axis is behind its visible surface by its radius.
//!
//! Out come [`FlameDetection`]s, as a box detector's, so placing them in the site frame
//! and their covariance are the same code for both ([`crate::ground::perception`]): the
//! box is the core's, and every cell of the depth window holds the detector's range to
//! the flame's axis.
//!
//! Beside the detector, [`road_hottest_k`] reads a patch of road: a knocked-down fire's
//! fuel bed, which a unit keeps cooling while it glows.
//!
//! Not here: the images themselves (the robot's drivers, or the simulator's renderer),
//! tracking flames in the site frame ([`crate::ground::tracker`]).

use firefleet_model::Point2;
use firefleet_model::geometry::Pose2;
use firefleet_model::spec::CameraSpec;
use firefleet_model::validate::Validate;
use firefleet_protocol::msg::{DEPTH_WINDOW, FlameDetection, ObjectClass, ThermalImage};

/// The detector's thresholds. [`DetectorConfig::default`] is the tuning the lab's
/// detection table measures (`firefleet-lab thermal`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DetectorConfig {
    /// A region starts at a pixel this hot, K.
    pub seed_k: f64,
    /// and takes in neighbours this hot, K.
    pub grow_k: f64,
    /// Smallest region, pixels.
    pub min_pixels: usize,
    /// Frames a region's size is kept over.
    pub window: usize,
    /// Frames a region must be seen in before it is a flame.
    pub min_frames: usize,
    /// Smallest detrended flicker: RMS of the size about its line, over the mean size.
    pub min_flicker: f64,
    /// Farthest a region's centroid moves between frames, pixels.
    pub match_px: f64,
    /// Fewest valid depth pixels for a range from depth.
    pub min_depth_px: usize,
    /// Largest error, m, a range from the road ray may have for one pixel of error in the
    /// foot's row. That error is `z^2 / (f_y h)` (`h` the camera's height), so it sets the
    /// farthest such range: `sqrt(error f_y h)`, 12 m for a 147 px focal length 1 m up.
    pub max_road_error_m: f64,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self {
            seed_k: 640.0,
            grow_k: 450.0,
            min_pixels: 4,
            window: 8,
            min_frames: 4,
            min_flicker: 0.04,
            match_px: 12.0,
            min_depth_px: 4,
            max_road_error_m: 1.0,
        }
    }
}

/// One hot region of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Region {
    /// Pixels at or above the seed temperature: the flame's core, whose size flickers. A
    /// region also takes in what the flame heats around it (a car's body, the layer),
    /// which is steady and would hide the flicker.
    core: usize,
    /// The core's `[u_min, v_min, u_max, v_max]`, pixel edges.
    bbox: [f64; 4],
    /// The core's centroid, pixels.
    centroid: [f64; 2],
    /// Median valid depth over the core, m, if enough of its pixels had one.
    depth_m: Option<f64>,
}

/// A region followed over frames.
#[derive(Debug, Clone)]
struct Followed {
    last: Region,
    /// The core's size, top row and height, pixels, oldest first, at most `window`.
    shapes: Vec<[f64; 3]>,
    /// Frames it was seen in.
    seen: usize,
    /// Matched in the current frame.
    matched: bool,
}

impl Followed {
    fn keep(&mut self, r: &Region, window: usize) {
        self.shapes
            .push([r.core as f64, r.bbox[1], r.bbox[3] - r.bbox[1]]);
        if self.shapes.len() > window {
            self.shapes.remove(0);
        }
    }

    /// How much the core flickers: its size's or its top's RMS about their least-squares
    /// lines, over its mean size or height, whichever is more. The top matters where a
    /// flame rises from something burning that is as hot and steady as its core (a
    /// vehicle's body: the size's share of flicker is small there; the flame's tip still
    /// pulses).
    fn flicker(&self) -> f64 {
        let column = |k: usize| self.shapes.iter().map(move |s| s[k]);
        let mean = |k: usize| column(k).sum::<f64>() / self.shapes.len() as f64;
        (detrended_rms(column(0)) / mean(0).max(1.0))
            .max(detrended_rms(column(1)) / mean(2).max(1.0))
    }
}

/// RMS of a series about its least-squares line; 0 for fewer than 3 values.
fn detrended_rms(ys: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = ys.clone().count();
    if n < 3 {
        return 0.0;
    }
    let nf = n as f64;
    let mean_x = (nf - 1.0) / 2.0;
    let mean_y = ys.clone().sum::<f64>() / nf;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (i, y) in ys.clone().enumerate() {
        let dx = i as f64 - mean_x;
        sxy += dx * (y - mean_y);
        sxx += dx * dx;
    }
    let slope = sxy / sxx;
    let rss: f64 = ys
        .enumerate()
        .map(|(i, y)| (y - mean_y - slope * (i as f64 - mean_x)).powi(2))
        .sum();
    (rss / nf).sqrt()
}

/// The detector of one camera; it keeps the regions of the last frames.
#[derive(Debug, Clone, Default)]
pub struct ThermalDetector {
    config: DetectorConfig,
    followed: Vec<Followed>,
}

impl ThermalDetector {
    pub fn new(config: DetectorConfig) -> Self {
        Self {
            config,
            followed: Vec::new(),
        }
    }

    /// The flames in the next frame, `img`, taken by a camera with `optics`. An image
    /// that fails validation (buffers that do not match its size, say) or is not the size
    /// `optics` says shows nothing: every path from a robot checks its frames before they
    /// get here, so this only keeps a malformed one from panicking the unit or being read
    /// through the wrong lens.
    pub fn detect(&mut self, img: &ThermalImage, optics: &CameraSpec) -> Vec<FlameDetection> {
        let sized =
            f64::from(img.width) == optics.width_px && f64::from(img.height) == optics.height_px;
        if !sized || img.validate().is_err() {
            return Vec::new();
        }
        let cfg = self.config;
        let regions = segment(img, &cfg);
        for f in &mut self.followed {
            f.matched = false;
        }
        for r in regions {
            let near = self
                .followed
                .iter_mut()
                .filter(|f| !f.matched)
                .map(|f| (dist(f.last.centroid, r.centroid), f))
                .filter(|(d, _)| *d <= cfg.match_px)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match near {
                Some((_, f)) => {
                    f.last = r;
                    f.seen += 1;
                    f.matched = true;
                    f.keep(&r, cfg.window);
                }
                None => {
                    let mut f = Followed {
                        last: r,
                        shapes: Vec::with_capacity(cfg.window + 1),
                        seen: 1,
                        matched: true,
                    };
                    f.keep(&r, cfg.window);
                    self.followed.push(f);
                }
            }
        }
        self.followed.retain(|f| f.matched);
        self.followed
            .iter()
            .filter(|f| f.seen >= cfg.min_frames && f.flicker() >= cfg.min_flicker)
            .filter_map(|f| detection(&f.last, f.flicker(), optics, &cfg))
            .collect()
    }
}

/// The hottest the road reads within `radius_m` of `at`, K: over the pixels of `img` whose
/// rays meet the road there, seen from `eye` (the camera's pose,
/// [`CameraSpec::looking_from`]) through `optics`. `None` if no pixel's ray does (the
/// patch is out of view or beyond the camera's range), or if the image is malformed or
/// not the size `optics` says. What a unit reads a knocked-down fire's fuel bed by: its
/// glow does not flicker, so it is no flame to [`ThermalDetector`], but a bed left hot
/// re-ignites.
pub fn road_hottest_k(
    img: &ThermalImage,
    optics: &CameraSpec,
    eye: &Pose2,
    at: Point2,
    radius_m: f64,
) -> Option<f64> {
    let sized =
        f64::from(img.width) == optics.width_px && f64::from(img.height) == optics.height_px;
    if !sized || img.validate().is_err() {
        return None;
    }
    let (w, h) = (usize::from(img.width), usize::from(img.height));
    let mut hottest: Option<f64> = None;
    for v in 0..h {
        // The optical axis is level: a row below the principal point meets the road at the
        // depth where the ray's drop is the camera's height.
        let drop_per_m = (v as f64 + 0.5 - optics.cy) / optics.fy;
        if drop_per_m <= 0.0 {
            continue;
        }
        let z = optics.mount_height_m / drop_per_m;
        if z > optics.range_m {
            continue;
        }
        for u in 0..w {
            let [forward, left, _] =
                optics.camera_to_body(optics.back_project(u as f64 + 0.5, v as f64 + 0.5, z));
            if eye.to_site(Point2::new(forward, left)).dist(at) <= radius_m {
                let k = img.kelvin(u, v);
                hottest = Some(hottest.map_or(k, |m| m.max(k)));
            }
        }
    }
    hottest
}

fn dist(a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1])
}

/// The hot regions of a frame, by hysteresis on the temperature.
fn segment(img: &ThermalImage, cfg: &DetectorConfig) -> Vec<Region> {
    let (w, h) = (usize::from(img.width), usize::from(img.height));
    let count = |k: f64| (k / ThermalImage::KELVIN_PER_COUNT).round() as u16;
    let (seed, grow) = (count(cfg.seed_k), count(cfg.grow_k));
    let mut taken = vec![false; w * h];
    let mut stack = Vec::new();
    let mut depths = Vec::new();
    let mut out = Vec::new();
    for start in 0..w * h {
        if taken[start] || img.centikelvin[start] < seed {
            continue;
        }
        taken[start] = true;
        stack.push(start);
        depths.clear();
        let (mut n, mut core, mut su, mut sv) = (0usize, 0usize, 0.0, 0.0);
        let mut bbox = [usize::MAX, usize::MAX, 0, 0];
        while let Some(i) = stack.pop() {
            let (u, v) = (i % w, i / w);
            n += 1;
            if img.centikelvin[i] >= seed {
                core += 1;
                if let Some(z) = img.depth(u, v) {
                    depths.push(z);
                }
                su += u as f64 + 0.5;
                sv += v as f64 + 0.5;
                bbox = [
                    bbox[0].min(u),
                    bbox[1].min(v),
                    bbox[2].max(u),
                    bbox[3].max(v),
                ];
            }
            let neighbours = [
                (u > 0).then(|| i - 1),
                (u + 1 < w).then(|| i + 1),
                (v > 0).then(|| i - w),
                (v + 1 < h).then(|| i + w),
            ];
            for j in neighbours.into_iter().flatten() {
                if !taken[j] && img.centikelvin[j] >= grow {
                    taken[j] = true;
                    stack.push(j);
                }
            }
        }
        if n < cfg.min_pixels {
            continue;
        }
        let depth_m = (depths.len() >= cfg.min_depth_px).then(|| {
            depths.sort_unstable_by(f64::total_cmp);
            depths[depths.len() / 2]
        });
        out.push(Region {
            core,
            bbox: [
                bbox[0] as f64,
                bbox[1] as f64,
                bbox[2] as f64 + 1.0,
                bbox[3] as f64 + 1.0,
            ],
            centroid: [su / core as f64, sv / core as f64],
            depth_m,
        });
    }
    out
}

/// A flame's detection from its region: the range to its axis and a confidence that grows
/// with its flicker; `None` with no range, or one beyond the camera's.
fn detection(
    r: &Region,
    flicker: f64,
    optics: &CameraSpec,
    cfg: &DetectorConfig,
) -> Option<FlameDetection> {
    // The ray through the core's bottom row meets the road at the depth where the
    // camera's height is the ray's drop. Where the flame's foot is hidden (behind a car,
    // say) the lowest visible point is above the road and this is too far, never too near,
    // unless the image's bottom edge cuts the core. Near the horizon a pixel is metres.
    let farthest = (cfg.max_road_error_m * optics.fy * optics.mount_height_m).sqrt();
    let drop_per_m = (r.bbox[3] - optics.cy) / optics.fy;
    let road = (drop_per_m > 0.0 && r.bbox[3] < optics.height_px)
        .then(|| optics.mount_height_m / drop_per_m)
        .filter(|z| *z <= farthest);
    // A thin flame is transparent to a depth camera, which ranges the wall behind it, so
    // the nearer of the two is the flame.
    let surface = match (r.depth_m, road) {
        (Some(d), Some(g)) => d.min(g),
        (d, g) => d.or(g)?,
    };
    if surface > optics.range_m {
        return None;
    }
    let radius_m = (r.bbox[2] - r.bbox[0]) / 2.0 * surface / optics.fx;
    let axis = (surface + radius_m) as f32;
    Some(FlameDetection {
        class: ObjectClass::Fire,
        confidence: (0.5 + 2.0 * flicker).clamp(0.05, 0.99),
        bbox: r.bbox,
        depth: [axis; DEPTH_WINDOW * DEPTH_WINDOW],
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;
    use firefleet_model::scenario::{Obstacle, Tunnel};
    use firefleet_sim::thermal::{Flame, HotBed, HotBox, Scene, ThermalCore, render};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    use crate::ground::perception;

    const AMBIENT: f64 = 293.15;

    /// Frames at 10 Hz of a camera at (100, 0) looking down +x at `flames`, `boxes` and
    /// `beds`.
    fn frames(
        (flames, boxes, beds): (&[Flame], &[HotBox], &[HotBed]),
        smoke: f64,
        n: usize,
    ) -> Vec<ThermalImage> {
        let tunnel = Tunnel::straight(300.0, 10.0, 6.0, 2);
        let core =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"));
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let scene = Scene {
            tunnel: &tunnel,
            boxes,
            flames,
            beds,
            ambient_k: AMBIENT,
            outside_k: 310.0,
            smoke_per_m: smoke,
            ceiling_k: &|_, _| AMBIENT + 60.0,
        };
        (0..n)
            .map(|k| {
                render(
                    &core,
                    &Pose2::new(100.0, 0.0, 0.0),
                    &scene,
                    k as f64 * 0.1,
                    &mut rng,
                )
            })
            .collect()
    }

    fn run(images: &[ThermalImage]) -> Vec<Vec<FlameDetection>> {
        let optics =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"))
                .optics;
        let mut d = ThermalDetector::new(DetectorConfig::default());
        images.iter().map(|i| d.detect(i, &optics)).collect()
    }

    fn flame_at(x: f64, y: f64) -> Flame {
        Flame {
            base: Point2::new(x, y),
            radius_m: 0.5,
            height_m: 1.8,
            sprayed: false,
        }
    }

    /// Where a detection places the flame.
    fn place(d: &FlameDetection) -> Point2 {
        let optics =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"))
                .optics;
        perception::locate(d, &optics, &Pose2::new(100.0, 0.0, 0.0))
            .unwrap()
            .estimate
            .mean
    }

    #[test]
    fn a_flame_at_6_m_is_found_within_half_a_metre_after_a_few_frames() {
        let out = run(&frames((&[flame_at(106.0, 0.5)], &[], &[]), 0.01, 12));
        assert!(
            out[..3].iter().all(Vec::is_empty),
            "not before it persisted"
        );
        let found: Vec<Point2> = out[4..].iter().flatten().map(place).collect();
        assert!(found.len() >= 6, "{found:?}");
        for p in found {
            assert!(p.dist(Point2::new(106.0, 0.5)) < 0.5, "{p:?}");
        }
    }

    #[test]
    fn a_malformed_image_or_one_of_another_size_shows_nothing() {
        let optics = GROUND.thermal_camera.unwrap();
        let mut d = ThermalDetector::default();
        let short = ThermalImage {
            width: 160,
            height: 120,
            centikelvin: vec![u16::MAX; 100],
            depth_m: vec![1.0; 100],
        };
        assert!(d.detect(&short, &optics).is_empty());
        let other_core = ThermalImage {
            width: 80,
            height: 60,
            centikelvin: vec![u16::MAX; 80 * 60],
            depth_m: vec![1.0; 80 * 60],
        };
        assert!(d.detect(&other_core, &optics).is_empty());
        assert!(d.followed.is_empty(), "neither was even segmented");
    }

    #[test]
    fn hot_metal_that_does_not_flicker_is_no_flame() {
        let engine = HotBox {
            shape: Obstacle {
                name: "burnt-out car".into(),
                x_m: 110.0,
                y_m: 0.0,
                length_m: 4.0,
                width_m: 1.8,
                height_m: 1.4,
                yaw_rad: 0.0,
            },
            surface_k: 650.0,
        };
        let out = run(&frames((&[], &[engine], &[]), 0.01, 12));
        assert!(out.iter().all(Vec::is_empty), "{out:?}");
    }

    #[test]
    fn in_smoke_that_blinds_depth_the_flame_is_placed_from_where_it_meets_the_road() {
        let out = run(&frames((&[flame_at(110.0, -1.0)], &[], &[]), 0.8, 12));
        let found: Vec<Point2> = out.iter().flatten().map(place).collect();
        assert!(found.len() >= 4, "{found:?}");
        for p in found {
            assert!(p.dist(Point2::new(110.0, -1.0)) < 1.0, "{p:?}");
        }
    }

    /// A knocked-down fire's glowing bed: no flame, but the road under it reads hot, only
    /// there, and only through the pose the frame was taken from.
    #[test]
    fn a_hot_bed_is_no_flame_and_the_road_reads_its_temperature_where_it_lies() {
        let bed = HotBed {
            centre: Point2::new(106.0, 0.5),
            radius_m: 1.0,
            surface_k: 600.0,
        };
        let images = frames((&[], &[], &[bed]), 0.01, 12);
        let out = run(&images);
        assert!(out.iter().all(Vec::is_empty), "{out:?}");
        let optics = GROUND.thermal_camera.expect("luf60 has a thermal core");
        let eye = Pose2::new(100.0, 0.0, 0.0);
        let read = |at: Point2| road_hottest_k(&images[11], &optics, &eye, at, 0.5);
        let k = read(bed.centre).expect("in view");
        assert!((k - 600.0).abs() < 2.0, "{k}");
        let k = read(Point2::new(109.0, 0.5)).expect("in view");
        assert!((k - AMBIENT).abs() < 2.0, "beyond it: {k}");
        assert_eq!(read(Point2::new(90.0, 0.0)), None, "behind the camera");
        let turned = Pose2::new(100.0, 0.0, 0.3);
        assert_eq!(
            road_hottest_k(&images[11], &optics, &turned, bed.centre, 0.5).map(|k| k > 500.0),
            Some(false),
            "read from the wrong pose, the patch is elsewhere in the image"
        );
    }
}
