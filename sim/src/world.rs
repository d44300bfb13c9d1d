//! The simulated tunnel: state and one fixed time step.
//!
//! Deterministic: the same scenario, seed and sequence of commands give the same world.
//! The world knows nothing of Zenoh; [`crate::node`] drives it.

use firefleet_protocol::UnitId;
use firefleet_protocol::geometry::{Point2, Pose2, wrap_angle};
use firefleet_protocol::msg::{
    CannonState, HotSpot, RailCommand, RailSensors, SimTruth, TruthFire, TruthFireState, TruthUnit,
    UnitCommand, UnitKind, UnitSensors,
};
use firefleet_protocol::scenario::{FireSpec, Obstacle, Scenario, Tunnel};
use firefleet_protocol::spec::{GROUND, GroundSpec, MONORAIL};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::camera::{self, FlameTarget};
use crate::carriage::Carriage;
use crate::jet::{self, Landing};
use crate::physics;

/// A fire of the world.
#[derive(Debug, Clone)]
struct Fire {
    spec: FireSpec,
    alpha: f64,
    hrr_kw: f64,
    state: TruthFireState,
    wetted: bool,
    water_received_l: f64,
    /// While smouldering: water still needed to cool the fuel bed, L, and how long the
    /// fire has gone without water, s.
    cooling_left_l: f64,
    dry_s: f64,
}

impl Fire {
    /// A fire not yet ignited (it ignites at its spec's time).
    fn new(spec: FireSpec) -> Self {
        Self {
            alpha: physics::growth_alpha_kw_s2(spec.growth),
            spec,
            hrr_kw: 0.0,
            state: TruthFireState::Dormant,
            wetted: false,
            water_received_l: 0.0,
            cooling_left_l: 0.0,
            dry_s: 0.0,
        }
    }

    fn flame_centre(&self) -> camera::P3 {
        [self.spec.x_m, self.spec.y_m, self.flame_height() / 2.0]
    }

    fn flame_height(&self) -> f64 {
        physics::flame_height_m(self.hrr_kw, 2.0 * self.spec.radius_m)
    }

    /// Advance by `dt` with `density` mm/s of water on the burning area.
    fn step(&mut self, t: f64, dt: f64, density: f64, litres: f64) {
        match self.state {
            TruthFireState::Out => return,
            TruthFireState::Dormant if t + dt < self.spec.ignition_s => return,
            TruthFireState::Dormant => {
                self.state = TruthFireState::Burning;
                self.hrr_kw = self.alpha * (t + dt - self.spec.ignition_s).powi(2);
            }
            TruthFireState::Burning => {}
            TruthFireState::Smouldering => {
                self.water_received_l += litres;
                if litres > 0.0 {
                    self.dry_s = 0.0;
                    self.cooling_left_l -= litres;
                    if self.cooling_left_l <= 0.0 {
                        self.state = TruthFireState::Out;
                        self.hrr_kw = 0.0;
                    }
                } else {
                    self.dry_s += dt;
                    if self.dry_s >= physics::REIGNITE_AFTER_S {
                        // Abandoned too early: the hot fuel bed flares up again.
                        self.state = TruthFireState::Burning;
                        self.hrr_kw = physics::Q_OUT_KW;
                        self.wetted = false;
                    }
                }
                return;
            }
        }
        self.water_received_l += litres;
        if density > 0.0 {
            self.wetted = true;
            self.hrr_kw *= (-dt / physics::suppression_time_constant_s(density)).exp();
        } else {
            // Regrowth continues along the t-squared curve from the current size.
            let t_eq = (self.hrr_kw / self.alpha).sqrt();
            self.hrr_kw = self.alpha * (t_eq + dt).powi(2);
        }
        self.hrr_kw = self.hrr_kw.min(self.spec.peak_kw);
        if self.wetted && self.hrr_kw < physics::Q_OUT_KW {
            // Flames knocked down; the fuel bed still has to be cooled.
            self.state = TruthFireState::Smouldering;
            self.cooling_left_l =
                physics::COOLING_WATER_L_PER_M2 * physics::disk_area(self.spec.radius_m);
            self.dry_s = 0.0;
        }
    }
}

/// A simulated ground vehicle with its cannon.
#[derive(Debug, Clone)]
struct Body {
    id: UnitId,
    spec: GroundSpec,
    pose: Pose2,
    speed: f64,
    steer: f64,
    cannon: CannonState,
    water_l: f64,
    cmd: UnitCommand,
    heat_flux: f64,
    heat_dose: f64,
    water_used: f64,
    collisions: u32,
    collided: bool,
}

impl Body {
    fn footprint_clear(&self, pose: &Pose2, tunnel: &Tunnel, obstacles: &[Obstacle]) -> bool {
        let (hl, hw) = (self.spec.length_m / 2.0, self.spec.width_m / 2.0);
        let corners = [(hl, hw), (-hl, hw), (-hl, -hw), (hl, -hw)]
            .map(|(x, y)| pose.to_site(Point2::new(x, y)));
        if !corners.iter().all(|c| tunnel.contains(*c, 0.0)) {
            return false;
        }
        // Sample the footprint's edges and centre against every box; boxes are larger than
        // the 0.5 m sampling pitch, so no overlap slips between samples.
        obstacles.iter().all(|o| {
            let mut pts = vec![pose.position()];
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let n = (a.dist(b) / 0.5).ceil() as usize;
                pts.extend((0..n).map(|i| {
                    let s = i as f64 / n as f64;
                    Point2::new(a.x + s * (b.x - a.x), a.y + s * (b.y - a.y))
                }));
            }
            !pts.iter().any(|p| o.footprint_contains(*p, 0.0))
                && !o.corners().iter().any(|c| inside(pose, &self.spec, *c))
        })
    }

    fn drive(&mut self, dt: f64, tunnel: &Tunnel, obstacles: &[Obstacle]) {
        let s = &self.spec;
        let target_v = self.cmd.speed.clamp(-s.max_speed_m_s, s.max_speed_m_s);
        let dv = (target_v - self.speed).clamp(-s.max_accel_m_s2 * dt, s.max_accel_m_s2 * dt);
        self.speed += dv;
        let target_steer = self.cmd.steer.clamp(-s.max_steer_rad, s.max_steer_rad);
        self.steer += (target_steer - self.steer)
            .clamp(-s.max_steer_rate_rad_s * dt, s.max_steer_rate_rad_s * dt);
        // Kinematic bicycle about the rear axle.
        let yaw = self.pose.yaw + self.speed / s.wheelbase_m * self.steer.tan() * dt;
        let next = Pose2::new(
            self.pose.x + self.speed * yaw.cos() * dt,
            self.pose.y + self.speed * yaw.sin() * dt,
            wrap_angle(yaw),
        );
        self.collided = false;
        if self.speed.abs() > 0.0 {
            if self.footprint_clear(&next, tunnel, obstacles) {
                self.pose = next;
            } else {
                self.collided = true;
                self.collisions += 1;
                self.speed = 0.0;
            }
        }
    }

    fn slew_cannon(&mut self, dt: f64) {
        let s = &self.spec;
        let pan = self
            .cmd
            .pan
            .clamp(-s.cannon_pan_limit_rad, s.cannon_pan_limit_rad);
        let tilt = self
            .cmd
            .tilt
            .clamp(s.cannon_tilt_min_rad, s.cannon_tilt_max_rad);
        self.cannon.pan += (pan - self.cannon.pan)
            .clamp(-s.cannon_pan_rate_rad_s * dt, s.cannon_pan_rate_rad_s * dt);
        self.cannon.tilt += (tilt - self.cannon.tilt).clamp(
            -s.cannon_tilt_rate_rad_s * dt,
            s.cannon_tilt_rate_rad_s * dt,
        );
        self.cannon.valve_open = self.cmd.valve_open && self.water_l > 0.0;
        self.cannon.flow_l_s = if self.cannon.valve_open {
            s.cannon_flow_l_s
        } else {
            0.0
        };
    }
}

/// The point of `o`'s footprint nearest `p`.
fn nearest_on(o: &Obstacle, p: Point2) -> Point2 {
    let b = o.pose().to_body(p);
    let (hl, hw) = (o.length_m / 2.0, o.width_m / 2.0);
    o.pose()
        .to_site(Point2::new(b.x.clamp(-hl, hl), b.y.clamp(-hw, hw)))
}

fn inside(pose: &Pose2, spec: &GroundSpec, p: Point2) -> bool {
    let b = pose.to_body(p);
    b.x.abs() <= spec.length_m / 2.0 && b.y.abs() <= spec.width_m / 2.0
}

/// How close a parked vehicle is to catching fire.
#[derive(Debug, Clone, Copy, Default)]
struct Exposure {
    /// Flux-time product so far, kJ/m^2.
    ftp: f64,
    /// The fire burning on it, once it burns (index into the world's fires).
    fire: Option<usize>,
    /// Burning from the start (a scenario fire stands on it): it has no fire of its own.
    burning: bool,
}

/// The whole simulated world.
pub struct World {
    tunnel: Tunnel,
    obstacles: Vec<Obstacle>,
    t: f64,
    time_limit_s: f64,
    fires: Vec<Fire>,
    bodies: Vec<Body>,
    carriages: Vec<Carriage>,
    /// One per obstacle.
    exposure: Vec<Exposure>,
    rng: ChaCha8Rng,
}

impl World {
    pub fn new(scenario: &Scenario, seed: u64) -> Self {
        let fires = scenario
            .fires
            .iter()
            .map(|f| Fire::new(f.clone()))
            .collect();
        let carriages = scenario
            .units
            .iter()
            .filter(|u| u.kind == UnitKind::Monorail)
            .filter_map(|u| {
                let rail = scenario.rail(u.rail.as_deref()?)?;
                Some(Carriage::new(u.id.clone(), MONORAIL, rail.clone(), u.x_m))
            })
            .collect();
        let bodies = scenario
            .units
            .iter()
            .filter(|u| u.kind == UnitKind::Ground)
            .map(|u| Body {
                id: u.id.clone(),
                spec: GROUND,
                pose: u.pose(),
                speed: 0.0,
                steer: 0.0,
                cannon: CannonState::default(),
                water_l: GROUND.tank_l,
                cmd: UnitCommand::halt(&CannonState::default()),
                heat_flux: 0.0,
                heat_dose: 0.0,
                water_used: 0.0,
                collisions: 0,
                collided: false,
            })
            .collect();
        let mut w = Self {
            tunnel: scenario.tunnel.clone(),
            obstacles: scenario.obstacles.clone(),
            t: 0.0,
            time_limit_s: scenario.time_limit_s,
            fires,
            bodies,
            carriages,
            exposure: scenario
                .obstacles
                .iter()
                .map(|o| Exposure {
                    burning: scenario
                        .fires
                        .iter()
                        .any(|f| o.footprint_contains(f.position(), 0.5)),
                    ..Exposure::default()
                })
                .collect(),
            rng: ChaCha8Rng::seed_from_u64(seed),
        };
        // Fires that ignited before the start are already at their t-squared size.
        w.step_fires(0.0, &[]);
        w
    }

    pub fn time(&self) -> f64 {
        self.t
    }

    /// The ground units.
    pub fn unit_ids(&self) -> impl Iterator<Item = &UnitId> {
        self.bodies.iter().map(|b| &b.id)
    }

    /// The monorail units.
    pub fn rail_unit_ids(&self) -> impl Iterator<Item = &UnitId> {
        self.carriages.iter().map(|c| &c.id)
    }

    /// Set a monorail unit's joint set-points; `false` if there is no such unit.
    pub fn command_rail(&mut self, id: &UnitId, cmd: RailCommand) -> bool {
        let unit = self.carriages.iter_mut().find(|c| &c.id == id);
        unit.map(|c| c.cmd = cmd).is_some()
    }

    /// Set a unit's actuator set-points; `false` if there is no such unit.
    pub fn command(&mut self, id: &UnitId, cmd: UnitCommand) -> bool {
        let unit = self.bodies.iter_mut().find(|b| &b.id == id);
        unit.map(|b| b.cmd = cmd).is_some()
    }

    /// One turn of ground unit `id`'s closed loop, in-process: its sensor frame to
    /// `control`, the command back to the unit, the world on by `dt`. Experiments and
    /// tests drive units through this, as the simulator's process does over the bus (and
    /// so with the same seed, the same run). `None`, and no step, for an unknown unit.
    pub fn step_unit(
        &mut self,
        id: &UnitId,
        dt: f64,
        control: impl FnOnce(&UnitSensors) -> UnitCommand,
    ) -> Option<UnitSensors> {
        let sensors = self.sensors(id)?;
        self.command(id, control(&sensors));
        self.step(dt);
        Some(sensors)
    }

    /// Stop a unit and shut its valve (its controller went silent).
    pub fn halt(&mut self, id: &UnitId) {
        if let Some(b) = self.bodies.iter_mut().find(|b| &b.id == id) {
            b.cmd = UnitCommand::halt(&b.cannon);
        }
        if let Some(c) = self.carriages.iter_mut().find(|c| &c.id == id) {
            c.halt();
        }
    }

    /// Advance the world by `dt` seconds.
    pub fn step(&mut self, dt: f64) {
        for b in &mut self.bodies {
            b.drive(dt, &self.tunnel, &self.obstacles);
            b.slew_cannon(dt);
        }
        // Where each open cannon's water lands this step.
        let mut sprays = Vec::new();
        for b in &mut self.bodies {
            if !b.cannon.valve_open {
                continue;
            }
            let litres = (b.cannon.flow_l_s * dt).min(b.water_l);
            b.water_l -= litres;
            b.water_used += litres;
            let nozzle = [b.pose.x, b.pose.y, b.spec.cannon_height_m];
            let landing = jet::trace(
                &self.tunnel,
                &self.obstacles,
                nozzle,
                b.pose.yaw + b.cannon.pan,
                b.cannon.tilt,
                &b.spec.nozzle,
            );
            sprays.push((landing, litres / dt));
        }
        for c in &mut self.carriages {
            c.step(dt);
            if !c.valve_open {
                continue;
            }
            let litres = c.spec.flow_l_s * dt;
            c.water_used += litres;
            let (nozzle, azimuth, elevation) = c.nozzle();
            let landing = jet::trace_at_speed(
                &self.tunnel,
                &self.obstacles,
                nozzle,
                azimuth,
                elevation,
                c.joints.v0,
            );
            sprays.push((landing, litres / dt));
        }
        let sprays = self.wet(dt, &sprays);
        self.step_fires(dt, &sprays);
        self.spread(dt);
        for i in 0..self.bodies.len() {
            let p = self.bodies[i].pose;
            let flux = self.radiant_flux([p.x, p.y, physics::UNIT_BODY_HEIGHT_M]);
            let b = &mut self.bodies[i];
            b.heat_flux = flux;
            b.heat_dose += flux * dt;
        }
        for i in 0..self.carriages.len() {
            let flux = self.radiant_flux(self.carriages[i].pivot());
            let c = &mut self.carriages[i];
            c.heat_flux = flux;
            c.heat_dose += flux * dt;
        }
        self.t += dt;
    }

    /// Where water lands: on the road (a disk as wide as the jet's spread), or on a vehicle,
    /// which cools it and, if it burns, puts the water on its fire. Returns the water on
    /// the road and on burning vehicles as (landing point, wetted radius, flow L/s).
    fn wet(&mut self, dt: f64, sprays: &[(Landing, f64)]) -> Vec<(Point2, f64, f64)> {
        let mut wetted = vec![false; self.obstacles.len()];
        let mut out = Vec::new();
        for &(landing, flow) in sprays {
            match landing {
                Landing::Road { at, travel_m } => {
                    let r = physics::jet_spread_radius_m(travel_m);
                    for (i, o) in self.obstacles.iter().enumerate() {
                        wetted[i] |= o.footprint_contains(at, r);
                    }
                    out.push((at, r, flow));
                }
                Landing::Vehicle { index } => {
                    wetted[index] = true;
                    if let Some(f) = self.exposure[index].fire {
                        let fire = &self.fires[f].spec;
                        out.push((fire.position(), fire.radius_m, flow));
                    }
                }
                Landing::Blocked => {}
            }
        }
        for (e, wet) in self.exposure.iter_mut().zip(wetted) {
            if wet {
                e.ftp *= (-dt / physics::VEHICLE_COOLING_TAU_S).exp();
            }
        }
        out
    }

    /// Heat parked vehicles with the fires' radiation; one that has taken enough catches
    /// fire (see [`physics::VEHICLE_FTP_KJ_M2`]).
    fn spread(&mut self, dt: f64) {
        for i in 0..self.obstacles.len() {
            let e = self.exposure[i];
            if e.burning || e.fire.is_some() {
                continue;
            }
            let o = &self.obstacles[i];
            // The hottest side: the footprint point nearest each burning fire, half-way up.
            let flux = self
                .fires
                .iter()
                .filter(|f| f.state == TruthFireState::Burning)
                .map(|f| {
                    let p = nearest_on(o, f.spec.position());
                    let c = f.flame_centre();
                    let r = ((c[0] - p.x).powi(2)
                        + (c[1] - p.y).powi(2)
                        + (c[2] - o.height_m / 2.0).powi(2))
                    .sqrt();
                    physics::radiant_flux_kw_m2(f.hrr_kw, r.max(f.spec.radius_m))
                })
                .sum::<f64>();
            let over = flux - physics::VEHICLE_CRITICAL_FLUX_KW_M2;
            if over <= 0.0 {
                continue;
            }
            self.exposure[i].ftp += over * dt;
            if self.exposure[i].ftp < physics::VEHICLE_FTP_KJ_M2 {
                continue;
            }
            let area = o.length_m * o.width_m;
            let spec = FireSpec {
                name: format!("{}-spread", o.name),
                x_m: o.x_m,
                y_m: o.y_m,
                growth: firefleet_protocol::scenario::Growth::Fast,
                peak_kw: (physics::VEHICLE_PEAK_KW_PER_M2 * area)
                    .clamp(physics::VEHICLE_PEAK_MIN_KW, physics::VEHICLE_PEAK_MAX_KW),
                ignition_s: self.t,
                radius_m: 0.5 * o.length_m.min(o.width_m),
            };
            tracing::info!(vehicle = %o.name, t = self.t, "fire spread to a parked vehicle");
            self.exposure[i].fire = Some(self.fires.len());
            self.fires.push(Fire::new(spec));
        }
    }

    /// Radiant heat flux from every burning fire at `at`, kW/m^2.
    fn radiant_flux(&self, at: camera::P3) -> f64 {
        self.fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
            .map(|f| {
                let c = f.flame_centre();
                let r = ((c[0] - at[0]).powi(2) + (c[1] - at[1]).powi(2) + (c[2] - at[2]).powi(2))
                    .sqrt();
                physics::radiant_flux_kw_m2(f.hrr_kw, r.max(f.spec.radius_m))
            })
            .sum()
    }

    /// `sprays`: (landing point, wetted radius, flow L/s) of every jet reaching the road.
    fn step_fires(&mut self, dt: f64, sprays: &[(Point2, f64, f64)]) {
        for f in &mut self.fires {
            let fire_area = physics::disk_area(f.spec.radius_m);
            let flow_on_fire: f64 = sprays
                .iter()
                .map(|(at, r, flow)| {
                    flow * physics::disk_overlap_area(
                        *r,
                        f.spec.radius_m,
                        at.dist(f.spec.position()),
                    ) / physics::disk_area(*r)
                })
                .sum();
            f.step(self.t, dt, flow_on_fire / fire_area, flow_on_fire * dt);
        }
    }

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
    pub fn sensors(&mut self, id: &UnitId) -> Option<UnitSensors> {
        let flames: Vec<FlameTarget> = self.visible_flames().map(|(_, f)| f).collect();
        let b = self.bodies.iter().find(|b| &b.id == id)?;
        let detections = camera::detect(
            &b.spec.camera,
            &b.spec.camera.looking_from(&b.pose, b.cannon.pan),
            &flames,
            &self.tunnel,
            &self.obstacles,
            &mut self.rng,
        );
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
        })
    }

    /// What monorail unit `id`'s sensors read now; `None` for an unknown unit.
    ///
    /// The fire detector and the thermal camera see burning fires within range whose flame
    /// the carriage has a line of sight to; the camera places each with a Gaussian error
    /// growing with range. The temperature is Alpert's ceiling jet summed over the fires.
    pub fn rail_sensors(&mut self, id: &UnitId) -> Option<RailSensors> {
        let c = self.carriages.iter().find(|c| &c.id == id)?;
        let m = c.pivot();
        let spec = c.spec;
        let mut fire_detected = false;
        let mut hot_spots = Vec::new();
        let mut temperature_c = physics::AMBIENT_C;
        for f in self
            .fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
        {
            let r = f
                .spec
                .position()
                .dist(firefleet_protocol::Point2::new(m[0], m[1]));
            temperature_c += physics::ceiling_jet_rise_c(f.hrr_kw, r, m[2]);
            let centre = f.flame_centre();
            let range = (r * r + (m[2] - centre[2]).powi(2)).sqrt();
            if f.hrr_kw < physics::Q_VISIBLE_KW
                || range > spec.detector_range_m
                || camera::line_blocked(&self.tunnel, &self.obstacles, m, centre)
            {
                continue;
            }
            fire_detected = true;
            let sigma = spec.hot_spot_sigma_a_m + spec.hot_spot_sigma_b * range;
            let noise = Normal::new(0.0, sigma).expect("sigma is positive");
            hot_spots.push(HotSpot {
                position: firefleet_protocol::Point2::new(
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

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_protocol::scenario::Growth;
    use firefleet_protocol::testing::ScenarioBuilder;

    /// A 100 m tunnel with a car, a 3 MW fire just short of it, and unit u1.
    fn site() -> ScenarioBuilder {
        Scenario::straight(100.0)
            .name("w")
            .section(10.0, 6.0)
            .time_limit(200.0)
            .obstacle("car", (20.0, -2.5), [4.0, 1.8, 1.5])
            .fire("f", 15.0, 0.0, 3000.0)
            .ignition(-100.0)
            .ground("u1", 5.0, -2.5)
    }

    fn world() -> World {
        World::new(&site().build(), 1)
    }

    fn u1() -> UnitId {
        UnitId::new("u1").unwrap()
    }

    /// Unit u1 stands still and sprays at `pan`, `tilt`.
    fn spray(w: &mut World, pan: f64, tilt: f64) {
        w.command(
            &u1(),
            UnitCommand {
                speed: 0.0,
                steer: 0.0,
                pan,
                tilt,
                valve_open: true,
            },
        );
    }

    #[test]
    fn fire_grows_as_t_squared_to_its_peak() {
        let mut w = world();
        // Burning for 100 s at the fast rate: 0.0469 * 100^2 = 469 kW.
        assert!((w.truth().fires[0].hrr_kw - 469.0).abs() < 1.0);
        // 253 s after ignition it would pass 3000 kW; it stays capped there.
        for _ in 0..4000 {
            w.step(0.05);
        }
        assert_eq!(w.truth().fires[0].hrr_kw, 3000.0);
    }

    /// Knock the fire down, then either keep the water on for `soak_s` or walk away.
    fn knock_down_then(soak_s: f64) -> World {
        let mut w = world();
        let d = 10.0f64.hypot(2.5);
        let v = GROUND.nozzle.exit_speed_m_s(d);
        let (g, h) = (physics::G, 1.2);
        let tilt =
            ((v * v - (v.powi(4) - g * (g * d * d - 2.0 * h * v * v)).sqrt()) / (g * d)).atan();
        let mut cmd = UnitCommand {
            speed: 0.0,
            steer: 0.0,
            pan: (2.5f64).atan2(10.0),
            tilt,
            valve_open: true,
        };
        w.command(&u1(), cmd);
        while w.truth().fires[0].state == TruthFireState::Burning {
            w.step(0.05);
        }
        assert_eq!(w.truth().fires[0].state, TruthFireState::Smouldering);
        for _ in 0..(soak_s / 0.05) as usize {
            w.step(0.05);
        }
        cmd.valve_open = false;
        w.command(&u1(), cmd);
        for _ in 0..300 {
            w.step(0.05);
        }
        w
    }

    #[test]
    fn a_knocked_down_fire_reignites_unless_it_is_cooled() {
        assert_eq!(
            knock_down_then(0.0).truth().fires[0].state,
            TruthFireState::Burning,
            "abandoned at knock-down"
        );
        // 5 L/m^2 over the 3.14 m^2 bed at about 10 L/s: under 2 s of cooling.
        assert_eq!(
            knock_down_then(3.0).truth().fires[0].state,
            TruthFireState::Out
        );
    }

    #[test]
    fn driving_into_a_vehicle_stops_the_unit() {
        let mut w = world();
        w.command(
            &u1(),
            UnitCommand {
                speed: 1.5,
                steer: 0.0,
                pan: 0.0,
                tilt: 0.0,
                valve_open: false,
            },
        );
        for _ in 0..400 {
            w.step(0.05);
        }
        let t = w.truth();
        assert!(t.units[0].collisions > 0);
        assert!(
            t.units[0].pose.x < 20.0 - 2.0 - 0.8 + 0.1,
            "stopped before the car: {}",
            t.units[0].pose.x
        );
    }

    #[test]
    fn water_on_the_fire_puts_it_out_and_water_beside_it_does_not() {
        let aim = |w: &mut World, pan: f64| {
            // Unit at x=5 faces +x; the fire is 10 m ahead and 2.5 m left. Low-arc elevation
            // for that shot from 1.2 m at the nozzle's equation-9 speed for its reach.
            let d = 10.0f64.hypot(2.5);
            let v = GROUND.nozzle.exit_speed_m_s(d);
            let (g, h) = (physics::G, 1.2);
            let tilt =
                ((v * v - (v.powi(4) - g * (g * d * d - 2.0 * h * v * v)).sqrt()) / (g * d)).atan();
            spray(w, pan, tilt);
        };
        let mut off = world();
        aim(&mut off, 0.6);
        let mut on = world();
        aim(&mut on, (2.5f64).atan2(10.0));
        for _ in 0..400 {
            off.step(0.05);
            on.step(0.05);
        }
        assert_eq!(on.truth().fires[0].state, TruthFireState::Out);
        assert_eq!(off.truth().fires[0].state, TruthFireState::Burning);
        assert!(on.truth().units[0].water_used_l > 0.0);
    }

    #[test]
    fn same_seed_same_world() {
        let run = |seed| {
            let mut w = World::new(&site().build(), seed);
            w.command(
                &u1(),
                UnitCommand {
                    speed: 1.0,
                    steer: 0.1,
                    pan: 0.0,
                    tilt: 0.0,
                    valve_open: false,
                },
            );
            (0..100)
                .map(|_| {
                    w.step(0.05);
                    w.sensors(&u1()).unwrap()
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(3), run(3));
        assert_ne!(run(3), run(4));
    }

    #[test]
    fn a_monorail_monitor_puts_out_a_fire_under_its_rail() {
        let site = site()
            .rail("r", 0.0, 100.0, &[20.0])
            .rail_height(5.5)
            .monorail("m", "r", 5.0)
            .build();
        let mut w = World::new(&site, 1);
        let m = UnitId::new("m").unwrap();
        let s = w.rail_sensors(&m).unwrap();
        assert!(s.fire_detected && s.water_connected);
        assert!((s.hot_spots[0].position.x - 15.0).abs() < 1.0);
        assert!(s.temperature_c > physics::AMBIENT_C);
        // The nozzle speed whose jet lands nearest the fire 10 m ahead, monitor at -15 deg.
        let c = w.carriages[0].clone();
        let (nozzle, azimuth, elevation) = c.nozzle();
        let v0 = (26..=266)
            .map(|k| k as f64 / 10.0)
            .min_by_key(|v| {
                match jet::trace_at_speed(&w.tunnel, &w.obstacles, nozzle, azimuth, elevation, *v) {
                    Landing::Road { at, .. } => (at.dist(Point2::new(15.0, 0.0)) * 1e3) as i64,
                    Landing::Blocked | Landing::Vehicle { .. } => i64::MAX,
                }
            })
            .unwrap();
        let mut joints = c.joints;
        joints.v0 = v0;
        w.command_rail(
            &m,
            RailCommand {
                joints,
                valve_open: true,
            },
        );
        for _ in 0..600 {
            w.step(0.05);
        }
        assert_eq!(w.truth().fires[0].state, TruthFireState::Out);
        let carriage = w.truth().units.into_iter().find(|u| u.id == m).unwrap();
        assert!(carriage.water_used_l > 0.0);
    }

    /// A 5 MW car fire in one lane, a car in the next lane 0.7 m away, after 400 s; `hose`
    /// puts a jet on the exposed car while the unit's water lasts.
    fn neighbours(hose: bool) -> World {
        let site = Scenario::straight(100.0)
            .name("spread")
            .section(10.0, 6.0)
            .time_limit(900.0)
            .car("burning", 50.0, -1.25)
            .car("exposed", 50.0, 1.25)
            .fire("car", 50.0, -1.25, 5000.0)
            .growth(Growth::Ultrafast)
            .ignition(-300.0)
            .ground("u1", 30.0, 3.0)
            .build();
        let mut w = World::new(&site, 1);
        if hose {
            // A jet into the exposed car's rear, 18 m away: the lowest elevation that hits it.
            let pan = (1.25f64 - 3.0).atan2(18.0);
            let nozzle = [30.0, 3.0, GROUND.cannon_height_m];
            let tilt = (0..60)
                .map(|k| k as f64 * 0.01)
                .find(|th| {
                    jet::trace(&w.tunnel, &w.obstacles, nozzle, pan, *th, &GROUND.nozzle)
                        == Landing::Vehicle { index: 1 }
                })
                .expect("some elevation hits the exposed car");
            spray(&mut w, pan, tilt);
        }
        // 400 s: the unit's tank (150 s of water) is empty well before the end.
        for _ in 0..(400.0 / 0.05) as usize {
            w.step(0.05);
        }
        w
    }

    #[test]
    fn fire_spreads_to_an_exposed_vehicle_and_water_on_it_holds_it_back() {
        let spread = neighbours(false).truth();
        assert_eq!(spread.fires.len(), 2, "{:?}", spread.fires);
        assert_eq!(spread.fires[1].name, "exposed-spread");
        assert_ne!(spread.fires[1].state, TruthFireState::Dormant);
        let cooled = neighbours(true).truth();
        assert_eq!(cooled.fires.len(), 1, "{:?}", cooled.fires);
    }

    #[test]
    fn heat_flux_rises_near_the_fire() {
        let mut w = world();
        w.step(0.05);
        let far = w.sensors(&u1()).unwrap().heat_flux_kw_m2;
        assert!(far > 0.0 && far < 1.0, "{far}");
    }
}
