//! The simulated tunnel: state and one fixed time step.
//!
//! Deterministic: the same scenario, seed and sequence of commands give the same world.
//! The world knows nothing of Zenoh; [`crate::node`] drives it.
//!
//! Not here: the bus ([`crate::node`]) or wall-clock pacing.

use firefleet_model::UnitId;
use firefleet_model::UnitKind;
use firefleet_model::geometry::{OrientedBox, Point2, Pose2, wrap_angle};
use firefleet_model::scenario::{FireSpec, Obstacle, Scenario, Tunnel};
use firefleet_model::spec::GroundSpec;
use firefleet_protocol::msg::{
    CannonState, HotSpot, RailCommand, RailSensors, SimTruth, TruthFire, TruthFireState, TruthUnit,
    UnitCommand, UnitSensors,
};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::camera::{self, FlameTarget};
use crate::carriage::Carriage;
use crate::dts::Dts;
use crate::jet::{self, Landing};
use crate::physics;
use firefleet_model::Chainage;
use firefleet_model::infra::{DtsReading, ScadaMap, VentReading, Ventilation};

mod fire;
mod sensing;
mod snapshot;
use fire::Fire;
pub use snapshot::{Mismatch, Snapshot};

/// Every unit of a validated scenario has a profile of its kind.
const VALIDATED: &str = "a validated scenario's units have profiles of their kind";

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
    fn footprint_at(&self, pose: Pose2) -> OrientedBox {
        OrientedBox::new(pose, self.spec.length_m, self.spec.width_m)
    }

    /// What the body at `pose` would touch: a wall, a vehicle in `obstacles` or another
    /// unit's footprint in `others`; `None` where it is clear.
    fn contact<'o>(
        &self,
        pose: &Pose2,
        tunnel: &Tunnel,
        obstacles: &'o [Obstacle],
        others: &[OrientedBox],
    ) -> Option<Contact<'o>> {
        let me = self.footprint_at(*pose);
        let corners = me.corners();
        if !corners.iter().all(|c| tunnel.contains(*c, 0.0)) {
            return Some(Contact::Wall);
        }
        if let Some(k) = others.iter().position(|o| o.overlaps(&me)) {
            return Some(Contact::Unit(k));
        }
        // Sample the footprint's edges and centre against every box; boxes are larger than
        // the 0.5 m sampling pitch, so no overlap slips between samples.
        let touches = |o: &Obstacle| {
            let mut pts = vec![pose.position()];
            for k in 0..4 {
                let (a, b) = (corners[k], corners[(k + 1) % 4]);
                let n = (a.dist(b) / 0.5).ceil() as usize;
                pts.extend((0..n).map(|i| {
                    let s = i as f64 / n as f64;
                    Point2::new(a.x + s * (b.x - a.x), a.y + s * (b.y - a.y))
                }));
            }
            pts.iter().any(|p| o.footprint_contains(*p, 0.0))
                || o.corners().iter().any(|c| me.contains(*c))
        };
        let o = obstacles.iter().find(|o| touches(o))?;
        Some(Contact::Vehicle(&o.name))
    }

    /// Drive one step under the command, refused (a blocked step, and the body stopped
    /// until the next command) where the body would touch a wall, a vehicle or another
    /// unit; what it would have touched, if anything.
    fn drive<'o>(
        &mut self,
        dt: f64,
        tunnel: &Tunnel,
        obstacles: &'o [Obstacle],
        others: &[OrientedBox],
    ) -> Option<Contact<'o>> {
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
        if self.speed.abs() == 0.0 {
            return None;
        }
        let contact = self.contact(&next, tunnel, obstacles, others);
        if contact.is_some() {
            self.collided = true;
            self.collisions += 1;
            self.speed = 0.0;
            // The drive's bumper stop: the body stands until its controller sends a new
            // set-point, rather than pushing on under the last one. Otherwise a controller
            // whose commands stall (a lossy link retransmitting, for up to the watchdog's
            // 500 ms: 40 steps at x4) is charged a blocked step for every step of the stall.
            self.cmd.speed = 0.0;
        } else {
            self.pose = next;
        }
        contact
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

/// What a body's refused move would have touched.
#[derive(Clone, Copy)]
enum Contact<'o> {
    Wall,
    /// A parked vehicle, by name.
    Vehicle(&'o str),
    /// Another unit, by its place among the footprints the body was checked against.
    Unit(usize),
}

/// The point of `o`'s footprint nearest `p`.
fn nearest_on(o: &Obstacle, p: Point2) -> Point2 {
    let b = o.pose().to_body(p);
    let (hl, hw) = (o.length_m / 2.0, o.width_m / 2.0);
    o.pose()
        .to_site(Point2::new(b.x.clamp(-hl, hl), b.y.clamp(-hw, hw)))
}

/// How close a parked vehicle is to catching fire.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
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
    ventilation: Option<Ventilation>,
    /// The linear heat detector, on a site with a SCADA map.
    dts: Option<Dts>,
    perception: Perception,
    /// When each ground unit's thermal core delivers its next frame, s (one per body).
    thermal_due: Vec<f64>,
}

/// What a ground unit's flame detection is made of.
///
/// A simulator process ([`crate::SimOptions`], `firefleet sim`) renders pixels unless
/// told otherwise: the agents then run the detector a thermal-only robot runs. A
/// [`World`] made in process starts with boxes, the stand-in the papers' experiments and
/// their reproductions in the lab were run with (their figures depend on its random
/// draws); [`World::set_perception`] changes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Perception {
    /// Boxes drawn from the ground truth ([`camera::detect`]), the RGB-D detector's
    /// stand-in the papers' experiments were run with.
    Boxes,
    /// Thermal images ([`crate::thermal`]) for units with a thermal core, which find flames
    /// in them themselves; boxes for units without one.
    Pixels,
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
                let spec = scenario.monorail_spec(&u.id).expect(VALIDATED);
                Some(Carriage::new(u.id.clone(), spec, rail.clone(), u.x_m))
            })
            .collect();
        let bodies: Vec<Body> = scenario
            .units
            .iter()
            .filter(|u| u.kind == UnitKind::Ground)
            .map(|u| {
                let spec = scenario.ground_spec(&u.id).expect(VALIDATED);
                (u, spec)
            })
            .map(|(u, spec)| Body {
                id: u.id.clone(),
                spec,
                pose: u.pose(),
                speed: 0.0,
                steer: 0.0,
                cannon: CannonState::default(),
                water_l: spec.tank_l,
                cmd: UnitCommand::halt(&CannonState::default()),
                heat_flux: 0.0,
                heat_dose: 0.0,
                water_used: 0.0,
                collisions: 0,
                collided: false,
            })
            .collect();
        let thermal_due = vec![0.0; bodies.len()];
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
            ventilation: scenario.ventilation.clone(),
            dts: scenario
                .scada
                .clone()
                .map(|m| Dts::new(m, scenario.tunnel.length_m)),
            perception: Perception::Boxes,
            thermal_due,
        };
        // Fires that ignited before the start are already at their t-squared size, and the
        // detector has been measuring all along.
        w.step_fires(0.0, &[]);
        w.measure_dts();
        w
    }

    /// Choose what ground units' flame detection is made of.
    pub fn set_perception(&mut self, p: Perception) {
        self.perception = p;
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

    /// The set-points monorail unit `id` is following.
    pub fn rail_command(&self, id: &UnitId) -> Option<RailCommand> {
        Some(self.carriages.iter().find(|c| &c.id == id)?.cmd)
    }

    /// A ground unit's specification and the set-points it is following.
    pub fn ground_unit(&self, id: &UnitId) -> Option<(GroundSpec, UnitCommand)> {
        let b = self.bodies.iter().find(|b| &b.id == id)?;
        Some((b.spec, b.cmd))
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
        // One body after another, each against the others where they stand now: a body
        // refused a move stays where it was, so no two ever overlap.
        for i in 0..self.bodies.len() {
            let others: Vec<OrientedBox> = (self.bodies.iter().enumerate())
                .filter(|&(j, _)| j != i)
                .map(|(_, o)| o.footprint_at(o.pose))
                .collect();
            let b = &mut self.bodies[i];
            let contact = b.drive(dt, &self.tunnel, &self.obstacles, &others);
            b.slew_cannon(dt);
            if let Some(c) = contact {
                let (unit, at) = (&self.bodies[i].id, self.bodies[i].pose);
                let t = self.t;
                match c {
                    Contact::Wall => tracing::debug!(%unit, ?at, t, "blocked by a wall"),
                    Contact::Vehicle(vehicle) => {
                        tracing::debug!(%unit, ?at, vehicle, t, "blocked by a vehicle");
                    }
                    // The footprints skip the body's own place.
                    Contact::Unit(k) => {
                        let other = &self.bodies[if k < i { k } else { k + 1 }].id;
                        tracing::debug!(%unit, ?at, %other, t, "blocked by another unit");
                    }
                }
            }
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
            let flux = self.radiant_flux([p.x, p.y, physics::UNIT_BODY_HEIGHT_M])
                + self.convective_flux(p.position());
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
        self.measure_dts();
    }

    /// Air velocity along the tunnel, m/s, positive towards its end.
    fn air_m_s(&self) -> f64 {
        self.ventilation.as_ref().map_or(0.0, |v| v.air_m_s)
    }

    /// Gas temperature rise under the ceiling over `p` from every burning fire, degrees C
    /// ([`physics::ceiling_rise_c`]), `height_m` above the road.
    pub fn ceiling_rise_c(&self, p: Point2, height_m: f64) -> f64 {
        self.ceiling_rise_at(height_m)(self.tunnel.chainage(p).m(), p)
    }

    /// [`World::ceiling_rise_c`] over point `p` at chainage `s` (m), with every burning
    /// fire's chainage and jet ([`physics::CeilingJet`]) worked out once: a thermal frame
    /// asks it for thousands of pixels.
    pub(crate) fn ceiling_rise_at(&self, height_m: f64) -> impl Fn(f64, Point2) -> f64 + use<> {
        let u = self.air_m_s();
        let sign = u.signum();
        let fires: Vec<(physics::CeilingJet, f64, Point2)> = self
            .fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
            .map(|f| {
                let at = f.spec.position();
                let jet = physics::CeilingJet::new(f.hrr_kw, height_m, u);
                (jet, self.tunnel.chainage(at).m(), at)
            })
            .collect();
        move |s, p| {
            fires
                .iter()
                .map(|(jet, s_fire, at)| jet.rise_c((s - s_fire) * sign, at.dist(p)))
                .sum()
        }
    }

    /// Each burning fire as seen from `p`: its heat release, how far `p` lies downstream of
    /// it along the air (negative: upstream; along the tunnel in still air), and how far
    /// from it.
    fn burning_from(&self, p: Point2) -> impl Iterator<Item = (f64, f64, f64)> + '_ {
        let sign = self.air_m_s().signum();
        let s = self.tunnel.chainage(p).m();
        self.fires
            .iter()
            .filter(|f| f.state == TruthFireState::Burning)
            .map(move |f| {
                let at = f.spec.position();
                let along = (s - self.tunnel.chainage(at).m()) * sign;
                (f.hrr_kw, along, at.dist(p))
            })
    }

    /// Heat a body at `p` takes from the hot gas the air carries downstream of burning
    /// fires, kW/m^2 ([`physics::DESTRATIFIED_SHARE`]); none in still air or upstream.
    fn convective_flux(&self, p: Point2) -> f64 {
        let u = self.air_m_s();
        if u.abs() < physics::STILL_AIR_M_S {
            return 0.0;
        }
        let h = self.tunnel.height_m;
        self.burning_from(p)
            .filter(|(_, along, _)| *along > 0.0)
            .map(|(q, along, r)| {
                physics::H_CONVECTIVE_KW_M2_K
                    * physics::DESTRATIFIED_SHARE
                    * physics::ceiling_rise_c(q, along, r, h, u)
            })
            .sum()
    }

    /// Extinction the smoke the air carries downstream of burning fires adds at `p`, 1/m
    /// ([`physics::SMOKE_DOWNSTREAM_PER_M`]); none in still air or upstream.
    fn smoke_downstream(&self, p: Point2) -> f64 {
        if self.air_m_s().abs() < physics::STILL_AIR_M_S {
            return 0.0;
        }
        let downstream = self
            .burning_from(p)
            .any(|(q, along, _)| q >= physics::Q_VISIBLE_KW && along > 0.0);
        if downstream {
            physics::SMOKE_DOWNSTREAM_PER_M
        } else {
            0.0
        }
    }

    /// A DTS measurement, when one is due.
    fn measure_dts(&mut self) {
        let Some(mut dts) = self.dts.take() else {
            return;
        };
        if dts.due(self.t) {
            let rise = self.ceiling_rise_at(self.tunnel.height_m);
            dts.measure(self.t, |s| {
                physics::AMBIENT_C + rise(s, self.tunnel.point_at(Chainage::new(s), 0.0))
            });
        }
        self.dts = Some(dts);
    }

    /// The tunnel's length, m.
    pub fn length_m(&self) -> f64 {
        self.tunnel.length_m
    }

    /// The site's SCADA map, if it has one.
    pub fn scada_map(&self) -> Option<&ScadaMap> {
        self.dts.as_ref().map(Dts::map)
    }

    /// The linear heat detector's latest measurement (site time, zones), on a site with a
    /// SCADA map.
    pub fn dts(&self) -> Option<(f64, &[DtsReading])> {
        self.dts.as_ref()?.readings()
    }

    /// What the ventilation's instruments read: the air velocity and each fan's state (a
    /// site without ventilation reads still air and no fans).
    pub fn vent(&self) -> VentReading {
        VentReading {
            air_m_s: self.air_m_s(),
            fans: self
                .ventilation
                .as_ref()
                .map_or_else(Vec::new, |v| vec![v.fan_state(); v.fans.len()]),
        }
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
        // How far off a vehicle's body its flames' centre stands once it catches, m: the
        // flames climb the face that caught (and parked vehicles can stand less than a
        // metre apart, so no further than half way to the fire that lit it).
        const SPREAD_FLAME_OFF_BODY_M: f64 = 0.25;
        for i in 0..self.obstacles.len() {
            let e = self.exposure[i];
            if e.burning || e.fire.is_some() {
                continue;
            }
            let o = &self.obstacles[i];
            // The hottest side: the footprint point nearest each burning fire, half-way up.
            let mut flux = 0.0;
            let centre = o.pose().position();
            let mut hottest = (0.0, centre, centre);
            for f in self
                .fires
                .iter()
                .filter(|f| f.state == TruthFireState::Burning)
            {
                let p = nearest_on(o, f.spec.position());
                let c = f.flame_centre();
                let r = ((c[0] - p.x).powi(2)
                    + (c[1] - p.y).powi(2)
                    + (c[2] - o.height_m / 2.0).powi(2))
                .sqrt();
                let q = physics::radiant_flux_kw_m2(f.hrr_kw, r.max(f.spec.radius_m));
                flux += q;
                if q > hottest.0 {
                    hottest = (q, p, f.spec.position());
                }
            }
            let over = flux - physics::VEHICLE_CRITICAL_FLUX_KW_M2;
            if over <= 0.0 {
                continue;
            }
            self.exposure[i].ftp += over * dt;
            if self.exposure[i].ftp < physics::VEHICLE_FTP_KJ_M2 {
                continue;
            }
            let area = o.length_m * o.width_m;
            let radius_m = 0.5 * o.length_m.min(o.width_m);
            // The vehicle catches on the side the heat came from, and its flames stand
            // there, just off the body (a fire's centre inside a vehicle's box is hidden
            // from every camera by the box itself, and a spread fire found only by the DTS
            // was fought late; issue #51).
            let (_, side, source) = hottest;
            let off = SPREAD_FLAME_OFF_BODY_M.min(side.dist(source) / 2.0);
            let at = side.offset(side.bearing_to(source), off);
            let spec = FireSpec {
                name: format!("{}-spread", o.name),
                x_m: at.x,
                y_m: at.y,
                growth: firefleet_model::scenario::Growth::Fast,
                peak_kw: (physics::VEHICLE_PEAK_KW_PER_M2 * area)
                    .clamp(physics::VEHICLE_PEAK_MIN_KW, physics::VEHICLE_PEAK_MAX_KW),
                ignition_s: self.t,
                radius_m,
            };
            tracing::info!(vehicle = %o.name, t = %format_args!("{:.2}", self.t), "fire spread to a parked vehicle");
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
}

#[cfg(test)]
mod tests;
