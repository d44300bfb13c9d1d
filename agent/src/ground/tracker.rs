//! Per-unit flame tracker: detections become site-frame flame estimates.
//!
//! Each detection is placed in the site frame with a covariance from the camera's noise
//! model ([`crate::ground::perception`]), associated with the nearest track within a Mahalanobis gate, and
//! fused into it. Tracks not seen for [`STALE_S`] are dropped. A track is confirmed after
//! [`CONFIRM_HITS`] hits, which suppresses one-frame false alarms.

use firefleet_model::geometry::{Gaussian2, Point2};
use firefleet_model::spec::GroundSpec;
use firefleet_protocol::msg::{FlameDetection, FlameObservation, MAX_HRR_KW, UnitSensors};

use crate::ground::perception;

/// Seconds without a detection after which a track is dropped.
pub const STALE_S: f64 = 3.0;
/// Hits needed before a track is trusted.
pub const CONFIRM_HITS: u32 = 3;
/// Association gate: squared Mahalanobis distance (chi-square, 2 dof, 99.9 %).
const GATE2: f64 = 13.8;
/// Random-walk growth of a track's covariance, m^2/s: flames flicker and creep.
const PROCESS_NOISE_M2_S: f64 = 0.02;
/// Floor of a track's variance, m^2: the flame has a size; no estimate is sharper.
const MIN_VAR_M2: f64 = 0.01;

/// One flame a unit believes in.
#[derive(Debug, Clone, PartialEq)]
pub struct Track {
    pub estimate: Gaussian2,
    pub confidence: f64,
    /// Half the flame's width, from its box and depth, m (smoothed).
    pub radius_m: f64,
    /// Heat release from the flame's size, kW (smoothed).
    pub hrr_kw: f64,
    pub hits: u32,
    pub last_seen: f64,
}

impl Track {
    pub fn confirmed(&self) -> bool {
        self.hits >= CONFIRM_HITS
    }
    pub fn position(&self) -> Point2 {
        self.estimate.mean
    }
}

/// The tracks of one unit.
#[derive(Debug, Clone, Default)]
pub struct FlameTracker {
    tracks: Vec<Track>,
    last_t: Option<f64>,
}

impl FlameTracker {
    /// Fold in one sensor frame: its detections, through the RGB-D camera, and `thermal`,
    /// what the unit's own detector found in the frame's thermal image (through the
    /// profile's thermal camera).
    pub fn update(&mut self, spec: &GroundSpec, s: &UnitSensors, thermal: &[FlameDetection]) {
        let dt = self.last_t.map_or(0.0, |t| (s.t - t).max(0.0));
        self.last_t = Some(s.t);
        for tr in &mut self.tracks {
            tr.estimate.inflate(PROCESS_NOISE_M2_S * dt);
        }
        let seen = s.detections.iter().map(|d| (d, &spec.camera)).chain(
            thermal
                .iter()
                .filter_map(|d| Some((d, spec.thermal_camera.as_ref()?))),
        );
        for (d, cam) in seen {
            let Some(located) =
                perception::locate(d, cam, &cam.looking_from(&s.pose, s.cannon.pan))
            else {
                continue;
            };
            let z = located.estimate;
            let nearest = self
                .tracks
                .iter_mut()
                .map(|tr| (tr.estimate.gate2(&z), tr))
                .filter(|(m2, _)| *m2 < GATE2)
                .min_by(|a, b| a.0.total_cmp(&b.0));
            match nearest {
                Some((_, tr)) => {
                    tr.estimate = tr.estimate.fuse(&z);
                    tr.estimate.cov[0] = tr.estimate.cov[0].max(MIN_VAR_M2);
                    tr.estimate.cov[2] = tr.estimate.cov[2].max(MIN_VAR_M2);
                    tr.hits += 1;
                    tr.confidence = 0.7 * tr.confidence + 0.3 * d.confidence;
                    tr.radius_m = 0.7 * tr.radius_m + 0.3 * located.radius_m;
                    tr.hrr_kw = 0.7 * tr.hrr_kw + 0.3 * located.heat_release_kw();
                    tr.last_seen = s.t;
                }
                None => self.tracks.push(Track {
                    estimate: z,
                    confidence: d.confidence,
                    radius_m: located.radius_m,
                    hrr_kw: located.heat_release_kw(),
                    hits: 1,
                    last_seen: s.t,
                }),
            }
        }
        self.tracks.retain(|tr| s.t - tr.last_seen <= STALE_S);
    }

    pub fn tracks(&self) -> &[Track] {
        &self.tracks
    }

    /// Confirmed tracks.
    pub fn confirmed(&self) -> impl Iterator<Item = &Track> {
        self.tracks.iter().filter(|t| t.confirmed())
    }

    /// Confirmed tracks seen since `since`, as observations for the coordinator.
    pub fn observations(&self, since: f64) -> Vec<FlameObservation> {
        self.confirmed()
            .filter(|t| t.last_seen >= since)
            .map(|t| FlameObservation {
                position: t.position(),
                cov: t.estimate.cov,
                confidence: t.confidence.clamp(0.0, 1.0),
                hrr_kw: Some(t.hrr_kw.clamp(0.0, MAX_HRR_KW)),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::UnitId;
    use firefleet_model::geometry::Pose2;
    use firefleet_model::profile::GROUND;
    use firefleet_protocol::msg::{CannonState, FlameDetection, ObjectClass};

    fn frame(t: f64, pose: Pose2, dets: Vec<FlameDetection>) -> UnitSensors {
        UnitSensors {
            unit: UnitId::new("u").unwrap(),
            t,
            pose,
            speed: 0.0,
            steer: 0.0,
            heat_flux_kw_m2: 0.0,
            water_l: 100.0,
            cannon: CannonState::default(),
            detections: dets,
            collided: false,
            thermal: None,
            nearby: Vec::new(),
        }
    }

    /// Detection of a flame at site point `f` (1 m up) from `pose`, its depth off by `err`.
    fn det(pose: &Pose2, f: Point2, err: f64) -> FlameDetection {
        let cam = GROUND.camera;
        let b = pose.to_body(f);
        let c = cam.body_to_camera([b.x, b.y, 1.0]);
        let [u, v] = cam.project(c).unwrap();
        FlameDetection {
            class: ObjectClass::Fire,
            confidence: 0.9,
            bbox: [u - 10.0, v - 20.0, u + 10.0, v + 20.0],
            depth: [(c[2] + err) as f32; 25],
        }
    }

    #[test]
    fn repeated_detections_from_a_moving_unit_fuse_into_one_accurate_track() {
        let mut tr = FlameTracker::default();
        let flame = Point2::new(30.0, 2.0);
        for k in 0..40 {
            let pose = Pose2::new(5.0 + 0.3 * k as f64, -2.0, 0.05);
            let err = if k % 2 == 0 { 0.3 } else { -0.3 };
            tr.update(
                &GROUND,
                &frame(0.1 * k as f64, pose, vec![det(&pose, flame, err)]),
                &[],
            );
        }
        assert_eq!(tr.tracks().len(), 1);
        let t = &tr.tracks()[0];
        assert!(t.confirmed());
        assert!(t.position().dist(flame) < 0.3, "{:?}", t.position());
    }

    #[test]
    fn two_flames_stay_two_tracks_and_stale_ones_go() {
        let mut tr = FlameTracker::default();
        let pose = Pose2::new(0.0, 0.0, 0.0);
        let (a, b) = (Point2::new(10.0, 1.5), Point2::new(10.0, -1.5));
        for k in 0..5 {
            tr.update(
                &GROUND,
                &frame(
                    0.1 * k as f64,
                    pose,
                    vec![det(&pose, a, 0.0), det(&pose, b, 0.0)],
                ),
                &[],
            );
        }
        assert_eq!(tr.confirmed().count(), 2);
        assert_eq!(tr.observations(0.3).len(), 2);
        tr.update(&GROUND, &frame(0.5 + STALE_S + 0.1, pose, vec![]), &[]);
        assert!(tr.tracks().is_empty());
    }
}
