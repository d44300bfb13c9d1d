//! Radiometric thermal images of the burning tunnel, with the depth image registered to
//! them: what a tunnel robot's long-wave infrared core and its depth camera deliver.
//!
//! Each pixel casts one ray from the camera's optical centre and takes the first thing it
//! meets: the road, the walls, the ceiling, a vehicle's box, or the daylight beyond a
//! portal; flames on the way are semi-transparent volumes in front of it. Radiance is
//! mixed as a grey body's, `T_app^4 = tau T_s^4 + (1 - tau) T_path^4` (Stefan-Boltzmann in
//! place of the 8-14 um Planck band: it keeps the ordering of temperatures and is exact for
//! opaque surfaces, which is what a detector's thresholds see). Assumptions, each a
//! constant below where it has a value:
//! - **Flames** are vertical cylinders of the fire's radius and flame height standing on
//!   the road. Their gas is at McCaffrey's continuous-flame temperature (about 900 C rise)
//!   in the lower 40 % and cools linearly to a 500 K rise at the tip, Heskestad's
//!   definition of the mean flame height. A flame is optically thin at its edge and thick
//!   through its middle: emissivity `1 - exp(-kappa L)` over the path `L` through it, with
//!   `kappa` [`FLAME_ABSORPTION_PER_M`], the order luminous pool and crib fires show.
//! - **Flicker**: the height pulses at the puffing frequency `f = 1.5 / sqrt(D)` Hz
//!   (Pagni 1990; Zukoski), by [`FLICKER_AMPLITUDE`] about its mean, plus a random tongue
//!   each frame ([`FLICKER_NOISE`]). Hot metal does not flicker; this is what a detector
//!   tells them apart by.
//! - **The hot layer**: ceiling and wall surfaces in the top [`HOT_LAYER_SHARE`] of the
//!   tunnel read the ceiling gas temperature the world computes (Alpert's ceiling jet, in
//!   [`crate::physics`]); below it, surfaces are at ambient.
//! - **Vehicles** are boxes at the surface temperature the scene gives them: ambient for a
//!   parked car, a few hundred kelvin for a body heated by a nearby fire or an exhaust.
//! - **A knocked-down fire's fuel bed** is a disk of the fire's radius on the road at the
//!   surface temperature the scene gives it (the world's [`crate::physics::bed_surface_k`]):
//!   glowing char when the flames go, falling to water's boiling point as it is cooled. It
//!   does not flicker. The water on it is taken at the bed's temperature (a film on a hot
//!   surface), so no spray dims it.
//! - **Smoke**: soot absorbs about as `1 / lambda` (small particles, Rayleigh limit), so its
//!   extinction at 10 um is [`IR_PER_VISIBLE`] of the visible one the world gives; the smoke
//!   on a path is taken at ambient temperature. The depth camera works in the near infrared
//!   and loses a pixel once the round trip through the smoke leaves under 5 % of its light
//!   (`2 k z > 3` with the visible `k`).
//! - **Water spray** between the camera and a flame being sprayed passes
//!   [`SPRAY_TRANSMISSION`] of the flame's radiance (water absorbs strongly at 8-14 um; a
//!   round assumption, not a measurement) and is at ambient temperature.
//! - **The sensor**: temporal noise of [`ThermalCore::netd_k`] (NETD) a pixel and frame, a
//!   fixed pattern of [`ThermalCore::fixed_pattern_k`] that is the same every frame, and
//!   0.01 K counts saturating at 655.35 K ([`ThermalImage`]). Depth has the depth camera's
//!   noise and drops a share of a flame's pixels (bright, textureless, moving).
//! - **Geometry**: the tunnel is rendered as the straight tunnel tangent to its centreline
//!   at the camera; round a bend that misplaces distant wall pixels (at 40 m on a 300 m
//!   radius by 2.7 m), which are background to a detector. Beyond a portal is daylight at
//!   the scene's outside temperature with no depth.
//!
//! Deterministic: the noise comes from the caller's seeded generator, the fixed pattern
//! from the pixel's position.
//!
//! Not here: finding flames in these pixels (the agent's flame detector), the RGB-D box
//! detector the papers' experiments use ([`crate::camera`]).

use firefleet_model::Point2;
use firefleet_model::geometry::Pose2;
use firefleet_model::scenario::{Obstacle, Tunnel};
use firefleet_model::spec::CameraSpec;
use firefleet_model::tunnel::Station;
use firefleet_protocol::msg::ThermalImage;
use rand::Rng;
use rand_distr::StandardNormal;

/// Kelvin at 0 C.
pub const KELVIN_AT_0C: f64 = 273.15;
/// Absorption coefficient of a flame's gas and soot, 1/m.
pub const FLAME_ABSORPTION_PER_M: f64 = 1.0;
/// Temperature rise of the continuous flame (McCaffrey: about 900 C), K.
pub const FLAME_RISE_K: f64 = 880.0;
/// Temperature rise at the mean flame height (Heskestad), K.
pub const FLAME_TIP_RISE_K: f64 = 500.0;
/// Share of the flame's height that is continuous flame.
pub const CONTINUOUS_SHARE: f64 = 0.4;
/// Amplitude of the height's pulsation, share of the mean height.
pub const FLICKER_AMPLITUDE: f64 = 0.2;
/// One sigma of the height's frame-to-frame randomness, share of the mean height.
pub const FLICKER_NOISE: f64 = 0.08;
/// Share of the tunnel's height the hot gas layer fills.
pub const HOT_LAYER_SHARE: f64 = 0.25;
/// Soot's extinction at 10 um over the visible one.
pub const IR_PER_VISIBLE: f64 = 0.55 / 10.0;
/// Share of a flame's radiance a water spray in front of it passes.
pub const SPRAY_TRANSMISSION: f64 = 0.5;

/// Seconds between a core's frames: Lepton-class cores deliver under 9 Hz (export rules
/// on uncooled cores), 8.7 Hz.
pub const THERMAL_PERIOD_S: f64 = 1.0 / 8.7;
/// The hottest a vehicle's body reads, K: a burning one's panels glow at 600-800 C (the
/// core saturates far below either way).
pub const BURNING_BODY_K: f64 = 900.0;
/// What a vehicle's panel loses a kelvin above ambient, kW/m^2/K: convection (0.01-0.02)
/// and its own radiation linearised (0.01-0.03 from 300 to 500 K). A panel taking a flux
/// `q` settles `q / 0.04` above ambient; settling takes minutes a real panel's heat
/// capacity would add, which this steady value leaves out (it errs hot, which a detector
/// must survive).
pub const BODY_LOSS_KW_M2_K: f64 = 0.04;
/// Daylight beyond a portal over the tunnel's air, K (sunlit ground, sky near the horizon).
pub const DAYLIGHT_RISE_K: f64 = 10.0;
/// How much farther than the distance that stopped a ray a box or a flame must lie before
/// the ray leaves it untested, m: far above the rounding of either test, far below a
/// pixel's footprint.
const NEAR_MARGIN_M: f64 = 1e-6;

/// A radiometric core and where it sits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThermalCore {
    /// Intrinsics and mount; the depth camera is registered to it and keeps the range,
    /// noise and flame dropout given here.
    pub optics: CameraSpec,
    /// Temporal noise (noise-equivalent temperature difference), K.
    pub netd_k: f64,
    /// Fixed-pattern noise left after the core's flat-field correction, K.
    pub fixed_pattern_k: f64,
}

impl ThermalCore {
    /// A Lepton-class core with `optics` (the unit profile's `thermal_camera`): NETD
    /// 50 mK, 0.2 K of fixed pattern.
    pub fn lepton_class(optics: CameraSpec) -> Self {
        Self {
            optics,
            netd_k: 0.05,
            fixed_pattern_k: 0.2,
        }
    }
}

/// A flame standing on the road.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Flame {
    pub base: Point2,
    pub radius_m: f64,
    /// Mean flame height, m.
    pub height_m: f64,
    /// A jet is landing on it.
    pub sprayed: bool,
}

impl Flame {
    /// The height at time `t` before the frame's random tongue: the puffing pulsation,
    /// with a phase from the flame's position so that flames do not pulse together.
    fn pulsing_height(&self, t: f64) -> f64 {
        let f = 1.5 / (2.0 * self.radius_m).max(0.1).sqrt();
        let phase = (self.base.x * 12.9898 + self.base.y * 78.233).sin() * 43758.5453;
        self.height_m * (1.0 + FLICKER_AMPLITUDE * (std::f64::consts::TAU * f * t + phase).sin())
    }

    /// The distance from a camera at `eye` to the flame's column, m: no ray from it enters
    /// the flame sooner.
    fn near_m(&self, eye: Point2) -> f64 {
        (self.base.dist(eye) - self.radius_m).max(0.0)
    }

    /// Gas temperature at height `z` of a flame `h` high, K.
    fn gas_k(ambient_k: f64, z: f64, h: f64) -> f64 {
        let eta = (z / h).clamp(0.0, 1.0);
        let rise = if eta < CONTINUOUS_SHARE {
            FLAME_RISE_K
        } else {
            FLAME_RISE_K
                + (FLAME_TIP_RISE_K - FLAME_RISE_K) * (eta - CONTINUOUS_SHARE)
                    / (1.0 - CONTINUOUS_SHARE)
        };
        ambient_k + rise
    }
}

/// A box at a surface temperature: a vehicle's body, an exhaust, a hot engine bay.
#[derive(Debug, Clone, PartialEq)]
pub struct HotBox {
    pub shape: Obstacle,
    pub surface_k: f64,
}

/// A hot disk on the road: a knocked-down fire's fuel bed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HotBed {
    pub centre: Point2,
    pub radius_m: f64,
    pub surface_k: f64,
}

/// What the camera looks at.
pub struct Scene<'a> {
    pub tunnel: &'a Tunnel,
    pub boxes: &'a [HotBox],
    pub flames: &'a [Flame],
    pub beds: &'a [HotBed],
    pub ambient_k: f64,
    /// Daylight beyond the portals (sunlit ground and sky), K.
    pub outside_k: f64,
    /// Visible-light extinction of the smoke around the camera, 1/m.
    pub smoke_per_m: f64,
    /// Temperature of the hot gas under the ceiling at chainage `s` (m) over point `p`, K.
    /// The renderer reckons a hit's chainage along the tunnel's tangent at the camera (as
    /// it does to find the portals), which on a curve drifts from the centreline's by a
    /// fraction of the sagitta; the gas model varies over metres, not that.
    pub ceiling_k: &'a dyn Fn(f64, Point2) -> f64,
}

/// A ray from the camera: origin and direction in the site frame (direction scaled so that
/// the parameter is depth along the optical axis).
#[derive(Debug, Clone, Copy)]
struct Ray {
    o: [f64; 3],
    d: [f64; 3],
}

impl Ray {
    /// The ray of pixel (`u`, `v`) of camera `cam` at `origin`, its heading's sine and
    /// cosine `heading`.
    fn through(
        cam: &CameraSpec,
        origin: [f64; 3],
        heading: (f64, f64),
        u: usize,
        v: usize,
    ) -> Self {
        let c = cam.back_project(u as f64 + 0.5, v as f64 + 0.5, 1.0);
        let [forward, left, up] = [c[2], -c[0], -c[1]];
        let (sin, cos) = heading;
        Ray {
            o: origin,
            d: [cos * forward - sin * left, sin * forward + cos * left, up],
        }
    }

    fn at(&self, t: f64) -> [f64; 3] {
        std::array::from_fn(|k| self.o[k] + t * self.d[k])
    }
    fn metres_per_t(&self) -> f64 {
        self.d.iter().map(|c| c * c).sum::<f64>().sqrt()
    }
}

/// A box as the rays of one frame meet it: the camera in the box's frame, and the turn
/// from the site frame into it. Every ray of a frame leaves the same point, so what
/// depends on the point alone is worked out once a frame, not once a ray (a 3 km tunnel's
/// vehicles cost a `sin_cos` each per ray before).
struct BoxView {
    /// The camera in the box's frame (x along its length, z up from the road).
    eye: [f64; 3],
    /// Cosine and sine of the box's yaw.
    cos: f64,
    sin: f64,
    lo: [f64; 3],
    hi: [f64; 3],
    surface_k: f64,
    /// The distance from the camera to the box's nearest point, m: no ray meets the box
    /// sooner, so a ray already stopped nearer need not test it.
    near_m: f64,
}

impl BoxView {
    fn new(b: &HotBox, eye: [f64; 3]) -> Self {
        let o = &b.shape;
        let (sin, cos) = o.yaw_rad.sin_cos();
        let (dx, dy) = (eye[0] - o.x_m, eye[1] - o.y_m);
        let eye = [cos * dx + sin * dy, -sin * dx + cos * dy, eye[2]];
        let lo = [-o.length_m / 2.0, -o.width_m / 2.0, 0.0];
        let hi = [o.length_m / 2.0, o.width_m / 2.0, o.height_m];
        let gap = |k: usize| (lo[k] - eye[k]).max(eye[k] - hi[k]).max(0.0);
        Self {
            eye,
            cos,
            sin,
            lo,
            hi,
            surface_k: b.surface_k,
            near_m: (0..3).map(|k| gap(k).powi(2)).sum::<f64>().sqrt(),
        }
    }

    /// Where a ray from the eye enters the box, as its parameter (slab test in the box's
    /// frame).
    fn entry(&self, r: &Ray) -> Option<f64> {
        let (c, s) = (self.cos, self.sin);
        let dir = [c * r.d[0] + s * r.d[1], -s * r.d[0] + c * r.d[1], r.d[2]];
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for (k, dk) in dir.into_iter().enumerate() {
            if dk.abs() < 1e-12 {
                if self.eye[k] < self.lo[k] || self.eye[k] > self.hi[k] {
                    return None;
                }
            } else {
                let (ta, tb) = (
                    (self.lo[k] - self.eye[k]) / dk,
                    (self.hi[k] - self.eye[k]) / dk,
                );
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
                if t0 > t1 {
                    return None;
                }
            }
        }
        Some(t0)
    }
}

/// The horizontal wedge every ray of a frame lies in: ahead of the camera and between the
/// directions of its image's two side edges (a pinhole core: a ray's `left / forward` is
/// set by its pixel's column alone, and its `forward` is its parameter, never negative).
/// A convex shape wholly outside the wedge meets no ray of the frame, so the frame's
/// per-ray work leaves it out, and the image is the same: on a 3 km tunnel most vehicles
/// and fires are behind a camera or beside its view.
struct Wedge {
    eye: Point2,
    /// The camera's heading, as cosine and sine.
    cos: f64,
    sin: f64,
    /// The least and the most `left / forward` of the frame's rays.
    left_per_forward: (f64, f64),
}

impl Wedge {
    /// The wedge of camera `cam` at `eye`, its heading's sine and cosine `heading`.
    fn new(cam: &CameraSpec, eye: Point2, heading: (f64, f64)) -> Self {
        // A ray's left over forward is -(u - cx) / fx at column u; the outermost rays go
        // through the centres of the first and last columns.
        let left = |u: f64| -(u - cam.cx) / cam.fx;
        let (sin, cos) = heading;
        Self {
            eye,
            cos,
            sin,
            left_per_forward: (left(cam.width_px - 0.5), left(0.5)),
        }
    }

    /// Whether the convex hull of `corners` may meet a ray of the frame: not when every
    /// corner is behind the camera, or every one beyond the same side edge.
    fn admits(&self, corners: &[Point2]) -> bool {
        let (lo, hi) = self.left_per_forward;
        let fl = corners.iter().map(|p| {
            let (dx, dy) = (p.x - self.eye.x, p.y - self.eye.y);
            (
                self.cos * dx + self.sin * dy,
                -self.sin * dx + self.cos * dy,
            )
        });
        // Clear of each boundary by a nanometre: the rays' directions are rounded too.
        const CLEAR_M: f64 = 1e-9;
        let outside = |side: &dyn Fn((f64, f64)) -> bool| fl.clone().all(side);
        !(outside(&|(f, _)| f < -CLEAR_M)
            || outside(&|(f, l)| l > hi * f + CLEAR_M)
            || outside(&|(f, l)| l < lo * f - CLEAR_M))
    }

    /// [`Wedge::admits`] for a disk or an upright cylinder of `radius` about `centre`, by
    /// the square that holds it.
    fn admits_round(&self, centre: Point2, radius: f64) -> bool {
        self.admits(
            &[(1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0)]
                .map(|(x, y)| Point2::new(centre.x + x * radius, centre.y + y * radius)),
        )
    }
}

/// What every ray of a frame shares: where the camera is in the tunnel, the tunnel's
/// heading there, and the boxes and fuel beds in its view, the boxes as seen from it,
/// nearest first.
///
/// Most rays stop on the road, a wall or the ceiling within metres, and a 3 km tunnel's
/// queue of vehicles lies tens to hundreds of metres ahead: a ray tests the boxes only
/// until the next is farther than what already stopped it ([`BoxView::near_m`]). The
/// first box a ray meets is the same as when every box was tested, so is the image.
struct View<'s> {
    scene: &'s Scene<'s>,
    here: Station,
    cos: f64,
    sin: f64,
    boxes: Vec<BoxView>,
    beds: Vec<&'s HotBed>,
}

impl<'s> View<'s> {
    fn new(scene: &'s Scene<'s>, eye: [f64; 3], wedge: &Wedge) -> Self {
        let here = scene.tunnel.station(Point2::new(eye[0], eye[1]));
        let (sin, cos) = scene.tunnel.heading_at(here.s).sin_cos();
        Self {
            scene,
            here,
            cos,
            sin,
            boxes: {
                let mut boxes: Vec<BoxView> = (scene.boxes.iter())
                    .filter(|b| wedge.admits(&b.shape.corners()))
                    .map(|b| BoxView::new(b, eye))
                    .collect();
                boxes.sort_by(|a, b| a.near_m.total_cmp(&b.near_m));
                boxes
            },
            beds: (scene.beds.iter())
                .filter(|b| wedge.admits_round(b.centre, b.radius_m))
                .collect(),
        }
    }

    /// What a ray from the eye meets first that stops it: its parameter, surface
    /// temperature, and whether it is inside the tunnel (a depth camera can range it).
    fn first_surface(&self, r: &Ray) -> (f64, f64, bool) {
        let (scene, here) = (self.scene, self.here);
        let tunnel = scene.tunnel;
        let along = self.cos * r.d[0] + self.sin * r.d[1];
        let across = -self.sin * r.d[0] + self.cos * r.d[1];
        let half = tunnel.width_m / 2.0;
        let mut t = f64::INFINITY;
        if r.d[2] < 0.0 {
            t = t.min(-r.o[2] / r.d[2]);
        }
        if r.d[2] > 0.0 {
            t = t.min((tunnel.height_m - r.o[2]) / r.d[2]);
        }
        if across > 0.0 {
            t = t.min((half - here.d) / across);
        } else if across < 0.0 {
            t = t.min((-half - here.d) / across);
        }
        let s_hit = here.s.m() + along * t;
        if !(0.0..=tunnel.length_m).contains(&s_hit) {
            return (t, scene.outside_k, false);
        }
        let p = r.at(t);
        let at = Point2::new(p[0], p[1]);
        let on_road = p[2].abs() < 1e-6;
        let mut surface = if p[2] >= tunnel.height_m * (1.0 - HOT_LAYER_SHARE) {
            (scene.ceiling_k)(s_hit, at)
        } else {
            scene.ambient_k
        };
        if on_road {
            for b in (self.beds.iter()).filter(|b| b.centre.dist(at) <= b.radius_m) {
                surface = surface.max(b.surface_k);
            }
        }
        let metres_per_t = r.metres_per_t();
        for b in &self.boxes {
            // A box entered at exactly the distance that stopped the ray would not be
            // taken either; the margin leaves the slab test to decide within rounding.
            if b.near_m > t * metres_per_t + NEAR_MARGIN_M {
                break;
            }
            if let Some(tb) = b.entry(r).filter(|tb| *tb < t) {
                t = tb;
                surface = b.surface_k;
            }
        }
        (t, surface, true)
    }
}

/// The part of a ray inside a flame `h` high: entry and exit parameters.
fn through_flame(f: &Flame, h: f64, r: &Ray) -> Option<(f64, f64)> {
    let (px, py) = (r.o[0] - f.base.x, r.o[1] - f.base.y);
    let a = r.d[0] * r.d[0] + r.d[1] * r.d[1];
    let b = 2.0 * (px * r.d[0] + py * r.d[1]);
    let c = px * px + py * py - f.radius_m * f.radius_m;
    let disc = b * b - 4.0 * a * c;
    if a < 1e-12 || disc <= 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let (mut t0, mut t1) = ((-b - s) / (2.0 * a), (-b + s) / (2.0 * a));
    if r.d[2].abs() > 1e-12 {
        let (za, zb) = (-r.o[2] / r.d[2], (h - r.o[2]) / r.d[2]);
        t0 = t0.max(za.min(zb));
        t1 = t1.min(za.max(zb));
    } else if !(0.0..=h).contains(&r.o[2]) {
        return None;
    }
    let t0 = t0.max(0.0);
    (t1 > t0).then_some((t0, t1))
}

/// Grey-body mix: `T^4 = tau Ta^4 + (1 - tau) Tb^4`.
fn mix(tau: f64, a: f64, b: f64) -> f64 {
    // The fourth root as two square roots: `powf` was a tenth of a frame.
    (tau * a.powi(4) + (1.0 - tau) * b.powi(4)).sqrt().sqrt()
}

/// A fixed-pattern offset for pixel `i`, in [-1, 1]: a hash of its index, so the pattern is
/// the same every frame and in every run.
fn fixed_pattern(i: usize) -> f64 {
    let mut z = (i as u64).wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    (z as f64 / u64::MAX as f64) * 2.0 - 1.0
}

/// A standard normal draw.
fn gauss(rng: &mut impl Rng) -> f64 {
    rng.sample(StandardNormal)
}

/// The thermal and depth images a core looking from `eye` (the camera's pose: the body's,
/// turned by the pan if it rides on the cannon) takes of `scene` at time `t`.
pub fn render(
    core: &ThermalCore,
    eye: &Pose2,
    scene: &Scene,
    t: f64,
    rng: &mut impl Rng,
) -> ThermalImage {
    let cam = &core.optics;
    let (w, h) = (cam.width_px as usize, cam.height_px as usize);
    let centre = eye.to_site(Point2::new(cam.mount_forward_m, 0.0));
    let heading = (eye.yaw.sin(), eye.yaw.cos());
    let ir_per_m = scene.smoke_per_m * IR_PER_VISIBLE;
    // One random tongue per flame per frame.
    let heights: Vec<f64> = scene
        .flames
        .iter()
        .map(|f| {
            let tongue = 1.0 + FLICKER_NOISE * gauss(rng);
            (f.pulsing_height(t) * tongue).max(0.05 * f.height_m)
        })
        .collect();
    let mut image = ThermalImage {
        width: w as u16,
        height: h as u16,
        centikelvin: vec![0; w * h],
        depth_m: vec![0.0; w * h],
    };
    // The flames a pixel's ray crosses: (entry, exit, flame, its height this frame).
    let mut crossed: Vec<(f64, f64, &Flame, f64)> = Vec::with_capacity(scene.flames.len());
    let origin = [centre.x, centre.y, cam.mount_height_m];
    let wedge = Wedge::new(cam, centre, heading);
    let view = View::new(scene, origin, &wedge);
    // The flames in view, with their heights this frame (every flame's tongue was drawn
    // above, in view or not, so that the generator's sequence does not depend on it).
    // Nearest first, by the distance to the flame's column, so that a ray tests flames
    // only as far as the surface that stops it (as [`View`] does boxes).
    let mut in_view: Vec<(f64, &Flame, f64)> = (scene.flames.iter().zip(heights))
        .filter(|(f, _)| wedge.admits_round(f.base, f.radius_m))
        .map(|(f, fh)| (f.near_m(centre), f, fh))
        .collect();
    in_view.sort_by(|a, b| a.0.total_cmp(&b.0));
    for v in 0..h {
        for u in 0..w {
            let ray = Ray::through(cam, origin, heading, u, v);
            let (t_hit, surface_k, ranged) = view.first_surface(&ray);
            let mut kelvin = surface_k;
            let mut depth = ranged.then_some(t_hit);
            // Flames in front of the surface, the farthest first, each over what is behind.
            let reach_m = t_hit * ray.metres_per_t() + NEAR_MARGIN_M;
            crossed.clear();
            crossed.extend(
                (in_view.iter())
                    .take_while(|(near_m, ..)| *near_m <= reach_m)
                    .filter_map(|&(_, f, fh)| {
                        let (t0, t1) = through_flame(f, fh, &ray)?;
                        (t0 < t_hit).then_some((t0, t1.min(t_hit), f, fh))
                    }),
            );
            crossed.sort_by(|a, b| b.0.total_cmp(&a.0));
            for &(t0, t1, f, fh) in &crossed {
                let mid = ray.at((t0 + t1) / 2.0)[2];
                let eps = 1.0 - (-FLAME_ABSORPTION_PER_M * (t1 - t0) * ray.metres_per_t()).exp();
                kelvin = mix(1.0 - eps, kelvin, Flame::gas_k(scene.ambient_k, mid, fh));
                if f.sprayed {
                    kelvin = mix(SPRAY_TRANSMISSION, kelvin, scene.ambient_k);
                }
                if eps > 0.5 {
                    depth = (rng.random::<f64>() >= cam.depth_dropout).then_some(t0);
                }
            }
            let path_m = crossed.last().map_or(t_hit, |c| c.0) * ray.metres_per_t();
            kelvin = mix((-ir_per_m * path_m).exp(), kelvin, scene.ambient_k);
            let i = v * w + u;
            kelvin += core.netd_k * gauss(rng) + core.fixed_pattern_k * fixed_pattern(i);
            image.centikelvin[i] = (kelvin / ThermalImage::KELVIN_PER_COUNT)
                .round()
                .clamp(0.0, f64::from(u16::MAX)) as u16;
            image.depth_m[i] = depth
                .filter(|z| *z <= cam.range_m && 2.0 * scene.smoke_per_m * z < 3.0)
                .map_or(0.0, |z| {
                    let sigma = cam.depth_sigma_m(z);
                    (z + sigma * gauss(rng)).max(0.1) as f32
                });
        }
    }
    image
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::GROUND;
    use firefleet_model::validate::Validate;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    const AMBIENT: f64 = 293.15;

    fn road() -> Tunnel {
        Tunnel::straight(300.0, 10.0, 6.0, 2)
    }

    fn shot(flames: &[Flame], boxes: &[HotBox], smoke: f64, seed: u64) -> ThermalImage {
        shot_with_beds(flames, boxes, &[], smoke, seed)
    }

    fn shot_with_beds(
        flames: &[Flame],
        boxes: &[HotBox],
        beds: &[HotBed],
        smoke: f64,
        seed: u64,
    ) -> ThermalImage {
        let tunnel = road();
        let scene = Scene {
            tunnel: &tunnel,
            boxes,
            flames,
            beds,
            ambient_k: AMBIENT,
            outside_k: 310.0,
            smoke_per_m: smoke,
            ceiling_k: &|_, _| AMBIENT + 40.0,
        };
        let core =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"));
        render(
            &core,
            &Pose2::new(50.0, 0.0, 0.0),
            &scene,
            1.0,
            &mut ChaCha8Rng::seed_from_u64(seed),
        )
    }

    fn flame(x: f64) -> Flame {
        Flame {
            base: Point2::new(x, 0.0),
            radius_m: 0.6,
            height_m: 2.0,
            sprayed: false,
        }
    }

    #[test]
    fn what_a_frame_leaves_out_of_view_no_ray_of_it_meets_nor_anything_nearer_than_its_near_m() {
        // Cars and flames on a 2 m grid round a camera looking 0.4 rad off the axis.
        let core =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"));
        let cam = &core.optics;
        let eye = Pose2::new(50.0, 0.0, 0.4);
        let centre = eye.to_site(Point2::new(cam.mount_forward_m, 0.0));
        let origin = [centre.x, centre.y, cam.mount_height_m];
        let heading = eye.yaw.sin_cos();
        let wedge = Wedge::new(cam, centre, heading);
        let spots: Vec<Point2> = (0..21)
            .flat_map(|i| (0..9).map(move |j| (f64::from(i), f64::from(j))))
            .map(|(i, j)| Point2::new(30.0 + 2.0 * i, -8.0 + 2.0 * j))
            .filter(|p| p.dist(centre) > 2.0)
            .collect();
        let cars: Vec<Obstacle> = (spots.iter())
            .map(|p| Obstacle {
                name: "car".into(),
                x_m: p.x,
                y_m: p.y,
                length_m: 1.2,
                width_m: 0.8,
                height_m: 1.4,
                yaw_rad: 0.3,
            })
            .collect();
        let boxes: Vec<BoxView> = (cars.iter())
            .map(|c| {
                let hot = HotBox {
                    shape: c.clone(),
                    surface_k: 400.0,
                };
                BoxView::new(&hot, origin)
            })
            .collect();
        let flames: Vec<Flame> = (spots.iter())
            .map(|&base| Flame {
                base,
                radius_m: 0.5,
                height_m: 2.0,
                sprayed: false,
            })
            .collect();
        let (mut met_car, mut met_flame) = (vec![false; cars.len()], vec![false; flames.len()]);
        for v in 0..cam.height_px as usize {
            for u in 0..cam.width_px as usize {
                let ray = Ray::through(cam, origin, heading, u, v);
                // Nothing is met nearer than its `near_m`, which the nearest-first early
                // outs rely on.
                let metres_per_t = ray.metres_per_t();
                for (met, b) in met_car.iter_mut().zip(&boxes) {
                    let entry = b.entry(&ray);
                    *met |= entry.is_some();
                    if let Some(tb) = entry {
                        assert!(tb * metres_per_t >= b.near_m - 1e-9, "a car met sooner");
                    }
                }
                for (met, f) in met_flame.iter_mut().zip(&flames) {
                    let entry = through_flame(f, f.height_m, &ray);
                    *met |= entry.is_some();
                    if let Some((t0, _)) = entry {
                        let near = f.near_m(centre);
                        assert!(t0 * metres_per_t >= near - 1e-9, "a flame met sooner");
                    }
                }
            }
        }
        for (car, met) in cars.iter().zip(&met_car) {
            let (x, y) = (car.x_m, car.y_m);
            assert!(
                !met || wedge.admits(&car.corners()),
                "a ray meets the car at ({x}, {y}), left out"
            );
        }
        for (f, met) in flames.iter().zip(&met_flame) {
            let at = f.base;
            assert!(
                !met || wedge.admits_round(at, f.radius_m),
                "a ray meets the flame at {at:?}, left out"
            );
        }
        let kept = cars.iter().filter(|c| wedge.admits(&c.corners())).count();
        let met = met_car.iter().filter(|m| **m).count();
        assert!(kept < cars.len() / 2, "{kept} of {} cars kept", cars.len());
        assert!(met > 10 && kept >= met, "{met} met, {kept} kept");
    }

    /// Pixels above 500 K.
    fn hot_area(img: &ThermalImage) -> usize {
        img.centikelvin.iter().filter(|k| **k > 50_000).count()
    }

    /// The pixel a site point projects to.
    fn pixel(p: [f64; 3]) -> (usize, usize) {
        let core =
            ThermalCore::lepton_class(GROUND.thermal_camera.expect("luf60 has a thermal core"));
        let c = core.optics.body_to_camera([p[0] - 50.0, p[1], p[2]]);
        let [u, v] = core.optics.project(c).unwrap();
        (u as usize, v as usize)
    }

    #[test]
    fn a_flame_is_hot_where_the_pinhole_model_puts_it_and_its_depth_is_its_range() {
        let img = shot(&[flame(60.0)], &[], 0.01, 1);
        img.validate().unwrap();
        let (u, v) = pixel([59.4, 0.0, 0.5]);
        assert!(img.kelvin(u, v) > 600.0, "flame core {}", img.kelvin(u, v));
        let (u, v) = pixel([59.4, 3.0, 0.5]);
        assert!(
            (img.kelvin(u, v) - AMBIENT).abs() < 2.0,
            "wall beside it at ambient: {}",
            img.kelvin(u, v)
        );
        let depths: Vec<f64> = (0..160)
            .flat_map(|u| (0..120).map(move |v| (u, v)))
            .filter(|&(u, v)| img.kelvin(u, v) > 600.0)
            .filter_map(|(u, v)| img.depth(u, v))
            .collect();
        assert!(depths.len() > 20);
        let mean = depths.iter().sum::<f64>() / depths.len() as f64;
        let near_surface = 60.0 - 0.6 - 50.0 - GROUND.camera.mount_forward_m;
        assert!(
            (mean - near_surface).abs() < 0.5,
            "{mean} vs {near_surface}"
        );
    }

    #[test]
    fn the_same_seed_gives_the_same_image_and_the_flame_flickers_between_frames() {
        assert_eq!(
            shot(&[flame(60.0)], &[], 0.01, 7),
            shot(&[flame(60.0)], &[], 0.01, 7)
        );
        let areas: Vec<usize> = (0..8)
            .map(|s| hot_area(&shot(&[flame(60.0)], &[], 0.01, s)))
            .collect();
        let (lo, hi) = (areas.iter().min().unwrap(), areas.iter().max().unwrap());
        assert!(
            *hi as f64 > 1.1 * *lo as f64,
            "flame area varies: {areas:?}"
        );
    }

    #[test]
    fn smoke_dims_a_flame_but_long_wave_infrared_still_sees_it_where_depth_is_lost() {
        let clear = shot(&[flame(65.0)], &[], 0.01, 2);
        let thick = shot(&[flame(65.0)], &[], 1.0, 2);
        // The core saturates on the flame (655 K), so compare what reads above 500 K.
        assert!(hot_area(&thick) < hot_area(&clear), "dimmer at the edges");
        assert!(hot_area(&thick) > hot_area(&clear) / 2, "and still there");
        let (u, v) = pixel([64.4, 0.0, 0.5]);
        assert_eq!(thick.kelvin(u, v), 655.35, "saturated");
        assert_eq!(
            thick.depth(u, v),
            None,
            "14 m is beyond the depth camera in this smoke"
        );
    }

    #[test]
    fn a_hot_body_reads_its_surface_temperature_and_a_spray_cools_a_flame() {
        let car = HotBox {
            shape: Obstacle {
                name: "car".into(),
                x_m: 60.0,
                y_m: 0.0,
                length_m: 4.0,
                width_m: 1.8,
                height_m: 1.4,
                yaw_rad: 0.0,
            },
            surface_k: 450.0,
        };
        let img = shot(&[], &[car], 0.01, 3);
        let (u, v) = pixel([58.0, 0.0, 0.7]);
        assert!(
            (img.kelvin(u, v) - 450.0).abs() < 2.0,
            "{}",
            img.kelvin(u, v)
        );
        let dry = shot(&[flame(60.0)], &[], 0.01, 4);
        let wet = shot(
            &[Flame {
                sprayed: true,
                ..flame(60.0)
            }],
            &[],
            0.01,
            4,
        );
        assert!(
            hot_area(&wet) < hot_area(&dry),
            "the spray cools the flame's thin edges"
        );
    }

    #[test]
    fn a_knocked_down_fires_bed_reads_its_surface_temperature_on_the_road_only() {
        let bed = HotBed {
            centre: Point2::new(58.0, 0.0),
            radius_m: 1.0,
            // Under the core's 655 K ceiling.
            surface_k: 600.0,
        };
        let img = shot_with_beds(&[], &[], &[bed], 0.01, 5);
        let (u, v) = pixel([58.0, 0.0, 0.0]);
        assert!(
            (img.kelvin(u, v) - 600.0).abs() < 2.0,
            "{}",
            img.kelvin(u, v)
        );
        for p in [[58.0, 2.0, 0.0], [56.0, 0.0, 0.0], [60.0, 0.0, 0.5]] {
            let (u, v) = pixel(p);
            assert!(
                (img.kelvin(u, v) - AMBIENT).abs() < 2.0,
                "{p:?}: {}",
                img.kelvin(u, v)
            );
        }
    }
}
