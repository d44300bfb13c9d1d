//! What the world shows its units and the checker: each unit's sensor frame (camera,
//! heat, tank, odometry, cannon), each carriage's, the flames a camera could see, and the
//! ground truth.
//!
//! Not here: the world's own step (the parent module) or a camera's optics
//! ([`crate::camera`]).

use super::*;
use crate::thermal::{
    self, BODY_LOSS_KW_M2_K, BURNING_BODY_K, DAYLIGHT_RISE_K, Flame, HotBed, HotBox, Scene,
    THERMAL_PERIOD_S, ThermalCore,
};
use firefleet_model::spec::CameraSpec;
use firefleet_protocol::msg::{NEARBY_RANGE_M, NearbyBody, ThermalImage};

/// A carriage's thermal camera reports a hot spot on the road this hot or hotter, K: 200 C,
/// where a knocked-down bed is still worth cooling (it re-ignites above
/// [`physics::IGNITION_K`]; the margin is for a bed seen at a slant through water).
pub const HOT_SPOT_K: f64 = 473.15;

impl World {
    /// The flames a camera could see now, one per visible fire, in scenario order.
    fn visible_flames(&self) -> impl Iterator<Item = (usize, FlameTarget)> + '_ {
        self.fires
            .iter()
            .enumerate()
            .filter(|(_, f)| {
                f.state == TruthFireState::Burning && f.hrr_kw >= physics::Q_VISIBLE_KW
            })
            .map(|(i, f)| {
                (
                    i,
                    FlameTarget {
                        centre: f.flame_centre(),
                        radius_m: f.spec.radius_m,
                        height_m: f.flame_height(),
                    },
                )
            })
    }

    /// Whether ground unit `id`'s camera has fire `fire` (scenario index) in view now: in
    /// its image, within range, hidden by no wall or vehicle. Ground truth for experiments;
    /// `None` for an unknown unit.
    pub fn flame_in_view(&self, id: &UnitId, fire: usize) -> Option<bool> {
        let b = self.bodies.iter().find(|b| &b.id == id)?;
        let eye = b.spec.camera.looking_from(&b.pose, b.cannon.pan);
        Some(self.visible_flames().any(|(i, f)| {
            i == fire && camera::in_view(&b.spec.camera, &eye, &f, &self.tunnel, &self.obstacles)
        }))
    }

    /// What unit `id`'s sensors read now; `None` for an unknown unit.
    ///
    /// With [`Perception::Pixels`] a unit with a thermal core gets a thermal frame every
    /// [`THERMAL_PERIOD_S`] and no boxes.
    pub fn sensors(&mut self, id: &UnitId) -> Option<UnitSensors> {
        let i = self.bodies.iter().position(|b| &b.id == id)?;
        let b = &self.bodies[i];
        let eye = b.spec.camera.looking_from(&b.pose, b.cannon.pan);
        let smoke = physics::SMOKE_EXTINCTION_PER_M + self.smoke_downstream(b.pose.position());
        let core = b
            .spec
            .thermal_camera
            .filter(|_| self.perception == Perception::Pixels);
        let (detections, thermal) = match core {
            Some(optics) => {
                let due = self.t >= self.thermal_due[i];
                if due {
                    // On the core's own clock: the first frame period after now.
                    self.thermal_due[i] =
                        ((self.t / THERMAL_PERIOD_S).floor() + 1.0) * THERMAL_PERIOD_S;
                }
                let eye = optics.looking_from(&b.pose, b.cannon.pan);
                (
                    Vec::new(),
                    due.then(|| self.thermal_frame(optics, &eye, smoke)),
                )
            }
            None => {
                let flames: Vec<FlameTarget> = self.visible_flames().map(|(_, f)| f).collect();
                let detections = camera::detect(
                    &b.spec.camera,
                    &eye,
                    &flames,
                    &self.tunnel,
                    &self.obstacles,
                    smoke,
                    &mut self.rng,
                );
                (detections, None)
            }
        };
        let b = &self.bodies[i];
        Some(UnitSensors {
            unit: b.id.clone(),
            t: self.t,
            pose: b.pose,
            speed: b.speed,
            steer: b.steer,
            heat_flux_kw_m2: b.heat_flux,
            water_l: b.water_l,
            cannon: b.cannon,
            detections,
            collided: b.collided,
            thermal,
            nearby: self.nearby(i),
        })
    }

    /// The other ground units within [`NEARBY_RANGE_M`] of body `i`, as its range sensor's
    /// tracker reports them. Exact and unoccluded: the simulator models neither the
    /// tracker's error (the margins the unit keeps cover a tenth of a metre) nor one unit
    /// hiding another from the sensor.
    fn nearby(&self, i: usize) -> Vec<NearbyBody> {
        let at = self.bodies[i].pose.position();
        (self.bodies.iter().enumerate())
            .filter(|&(j, o)| j != i && o.pose.position().dist(at) <= NEARBY_RANGE_M)
            .map(|(_, o)| NearbyBody {
                pose: o.pose,
                length_m: o.spec.length_m,
                width_m: o.spec.width_m,
                speed: o.speed,
            })
            .collect()
    }

    /// A thermal core's frame from `eye` through smoke `smoke_per_m`: burning fires as
    /// flames (sprayed while water lands on them), knocked-down ones as their hot fuel
    /// beds, vehicles warmed by the flux the fires
    /// send them at their middle (up to [`BURNING_BODY_K`], where one burns), the ceiling
    /// gas as the world computes it.
    fn thermal_frame(&mut self, optics: CameraSpec, eye: &Pose2, smoke_per_m: f64) -> ThermalImage {
        let ambient_k = physics::AMBIENT_C + thermal::KELVIN_AT_0C;
        let flames: Vec<Flame> = self
            .fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning && f.hrr_kw >= physics::Q_VISIBLE_KW)
            .map(|f| Flame {
                base: f.spec.position(),
                radius_m: f.spec.radius_m,
                height_m: f.flame_height(),
                sprayed: f.wetted,
            })
            .collect();
        let beds: Vec<HotBed> = self
            .fires
            .iter()
            .filter_map(|f| {
                Some(HotBed {
                    centre: f.spec.position(),
                    radius_m: f.spec.radius_m,
                    surface_k: f.bed_k()?,
                })
            })
            .collect();
        let boxes: Vec<HotBox> = self
            .obstacles
            .iter()
            .map(|o| HotBox {
                shape: o.clone(),
                surface_k: (ambient_k
                    + self.radiant_flux([o.x_m, o.y_m, o.height_m / 2.0]) / BODY_LOSS_KW_M2_K)
                    .min(BURNING_BODY_K),
            })
            .collect();
        let height = self.tunnel.height_m;
        let rise = self.ceiling_rise_at(height);
        let ceiling = |s: f64, p: Point2| ambient_k + rise(s, p);
        let scene = Scene {
            tunnel: &self.tunnel,
            boxes: &boxes,
            flames: &flames,
            beds: &beds,
            ambient_k,
            outside_k: ambient_k + DAYLIGHT_RISE_K,
            smoke_per_m,
            ceiling_k: &ceiling,
        };
        let core = ThermalCore::lepton_class(optics);
        let mut rng = self.rng.clone();
        let image = thermal::render(&core, eye, &scene, self.t, &mut rng);
        self.rng = rng;
        image
    }

    /// What monorail unit `id`'s sensors read now; `None` for an unknown unit.
    ///
    /// The fire detector and the thermal camera see burning fires within range whose flame
    /// the carriage has a line of sight to, and the camera knocked-down beds still at
    /// [`HOT_SPOT_K`] or more; it places each with a Gaussian error growing with range. The temperature is the ceiling gas's ([`World::ceiling_rise_c`]).
    pub fn rail_sensors(&mut self, id: &UnitId) -> Option<RailSensors> {
        let c = self.carriages.iter().find(|c| &c.id == id)?;
        let m = c.pivot();
        let spec = c.spec;
        let mut fire_detected = false;
        let mut hot_spots = Vec::new();
        let temperature_c = physics::AMBIENT_C
            + self.ceiling_rise_c(firefleet_model::Point2::new(m[0], m[1]), m[2]);
        for f in &self.fires {
            // The flame detector sees flames; the thermal camera sees them and a knocked-
            // down fire's bed while it glows above HOT_SPOT_K, which the carriage then
            // keeps cooling as a ground unit with a thermal core does.
            let flame = f.state == TruthFireState::Burning && f.hrr_kw >= physics::Q_VISIBLE_KW;
            let glowing = f.bed_k().is_some_and(|k| k >= HOT_SPOT_K);
            if !flame && !glowing {
                continue;
            }
            let r = f
                .spec
                .position()
                .dist(firefleet_model::Point2::new(m[0], m[1]));
            let centre = if flame {
                f.flame_centre()
            } else {
                [f.spec.x_m, f.spec.y_m, 0.0]
            };
            let range = (r * r + (m[2] - centre[2]).powi(2)).sqrt();
            if range > spec.detector_range_m
                || camera::line_blocked(&self.tunnel, &self.obstacles, m, centre)
            {
                continue;
            }
            fire_detected |= flame;
            let sigma = spec.hot_spot_sigma_a_m + spec.hot_spot_sigma_b * range;
            let noise = Normal::new(0.0, sigma).expect("sigma is positive");
            hot_spots.push(HotSpot {
                position: firefleet_model::Point2::new(
                    f.spec.x_m + noise.sample(&mut self.rng),
                    f.spec.y_m + noise.sample(&mut self.rng),
                ),
                sigma_m: sigma,
            });
        }
        Some(RailSensors {
            unit: c.id.clone(),
            t: self.t,
            joints: c.joints,
            speed: c.speed,
            valve_open: c.valve_open,
            flow_l_s: if c.valve_open { spec.flow_l_s } else { 0.0 },
            water_connected: c.connected(),
            fire_detected,
            temperature_c,
            heat_flux_kw_m2: c.heat_flux,
            hot_spots,
        })
    }

    pub fn truth(&self) -> SimTruth {
        SimTruth {
            t: self.t,
            time_limit_s: self.time_limit_s,
            fires: self
                .fires
                .iter()
                .map(|f| TruthFire {
                    name: f.spec.name.clone(),
                    position: f.spec.position(),
                    hrr_kw: f.hrr_kw,
                    state: f.state,
                    water_received_l: f.water_received_l,
                })
                .collect(),
            units: self
                .bodies
                .iter()
                .map(|b| TruthUnit {
                    id: b.id.clone(),
                    pose: b.pose,
                    heat_dose_kj_m2: b.heat_dose,
                    water_used_l: b.water_used,
                    collisions: b.collisions,
                })
                .chain(self.carriages.iter().map(|c| TruthUnit {
                    id: c.id.clone(),
                    pose: c.pose(),
                    heat_dose_kj_m2: c.heat_dose,
                    water_used_l: c.water_used,
                    collisions: 0,
                }))
                .collect(),
        }
    }
}
