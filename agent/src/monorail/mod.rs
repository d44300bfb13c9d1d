//! The monorail unit's controller: its behavior tree ticking over a [`RailUnit`].
//!
//! The unit's services run the ROBOGAT scheme between sensor frames: the fuzzy system reads
//! the fire detector, the temperature and the distance to the fire along the rail; the
//! planner moves the jet point (approach, sweep, hold); the CLIK turns that into joint
//! set-points at 1 kHz, however far apart the frames are. The tree
//! (`trees/monorail_unit.xml`) decides which fire to attack and when the attack is over,
//! with the coordinator-link leaves every unit shares ([`crate::mission`]).
//!
//! The ROBOGAT paper's parts (`robogat-monorail-fuzzy-redundancy.txt`), all pure:
//! - [`kinematics`]: where the jet lands for given joints, and the Jacobians (eq. 1-2).
//! - [`clik`]: the weighted, damped pseudo-inverse CLIK with the null-space dexterity task
//!   (eq. 5-8), joint limits enforced.
//! - [`fis`]: the fuzzy system that sets the weights from fire, temperature and distance,
//!   built on the general Mamdani engine in [`fuzzy`].
//! - [`planner`]: the jet point's approach, sweep and hold (eq. 9).
//! - [`case_study`]: the paper's simulation case study, for the experiment and the bench.
//! - [`frame`]: the rail's frame in the site.
//!
//! A carriage sprays only from a dock, plugged into a hose point ([`firefleet_model::dock`]):
//! an attack holds the carriage's travel to the stretch of rail of the dock that serves
//! the fire (a joint limit, like barred space), so the approach runs it there, dry on the
//! way (a journey, not a fault), and the monitor's pan and tilt do the rest. A carriage is
//! at fault only when it stands at a hose point and has no water.
//!
//! Barred space binds the carriage as a joint limit: the carriage's travel is narrowed to
//! the stretch of rail it may be on (the CLIK then aims from the nearest allowed point,
//! the monitor's pan and tilt doing the rest), a search run stops short of barred space,
//! and a carriage inside it (a goal arrived while it was there) drops its attack and runs
//! out by the shortest way. A goal's `rail_allowed` lets carriages through.
//!
//! Pure: no I/O, no clock of its own. Not here: the ground unit ([`crate::ground`]).

pub mod case_study;
pub mod clik;
pub mod fis;
pub mod frame;
pub mod fuzzy;
pub mod kinematics;
mod leaves;
pub mod planner;

use std::sync::Arc;

use firefleet_bt::xml::{self, Document, XmlErrors};
use firefleet_model::Chainage;
use firefleet_model::UnitKind;
use firefleet_model::dock::{Dock, Reach};
use firefleet_model::scenario::{Rail, Scenario, Tunnel};
use firefleet_model::spec::{MAINS_WATER_L, MonorailSpec};
use firefleet_model::{Point2, Pose2, UnitId};
use firefleet_protocol::msg::{
    CLEAR_OF_BARRED_M, FlameObservation, FlameReport, RailCommand, RailJoints, RailSensors,
    UnitMode, UnitState, nearest_allowed,
};

use crate::controller::{Controller, Services};
use crate::mission::{Mission, Responder};
use crate::monorail::clik::{Clik, ClikParams, Target};
use crate::monorail::fis::{Fis, Inputs};
use crate::monorail::frame::RailFrame;
use crate::monorail::kinematics::{Joints, Limits, Monitor};
use crate::monorail::planner::{Phase, Planner, PlannerParams};

/// The shipped monorail-unit tree.
pub const MONORAIL_TREE: &str = include_str!("../../trees/monorail_unit.xml");

/// The shipped tree as a document.
pub fn default_tree() -> Document {
    xml::parse_str(MONORAIL_TREE, "monorail_unit.xml").expect("the shipped tree parses")
}

/// Hot spots older than this are forgotten, s.
const RECENTLY_SEEN_S: f64 = 1.0;
/// The CLIK's step, s (the paper's 1000 Hz).
const CLIK_DT_S: f64 = 1e-3;
/// Longest gap between frames the CLIK integrates over, s; a longer gap (a stalled
/// process) restarts from the measured joints instead.
const MAX_GAP_S: f64 = 0.25;
/// A monitor at least this far off its set-point has lost track; the CLIK restarts from
/// where the joints are.
const RESYNC_M: f64 = 2.0;
/// A run along the rail ends this close to its goal, m.
const RUN_DONE_M: f64 = 0.5;
/// Half-widths of the sweep over a fire, m. The case study's +-1.5 m by +-1 m spreads the
/// 8 L/s over about 20 m^2 once the jet's own footprint (over 1 m in radius at 10 m of
/// travel) is added, a seventh of it on a car-sized fire; +-0.5 m keeps about a third on
/// it and still moves the jet across the whole base.
const SWEEP_M: [f64; 2] = [0.5, 0.5];

/// The attack under way.
#[derive(Debug, Clone, Copy)]
struct Attack {
    fire: Point2,
    /// Where the carriage sprays from: the attack holds its travel to this stretch.
    dock: Dock,
    planner: Planner,
    out: bool,
}

/// A monorail unit, its world model and its services.
pub struct RailUnit {
    pub(crate) id: UnitId,
    spec: MonorailSpec,
    rail: Rail,
    tunnel: Tunnel,
    /// The CLIK's limits on the whole rail; barred space narrows the carriage's.
    rail_limits: Limits,
    frame: RailFrame,
    sensors: RailSensors,
    fis: Fis,
    clik: Clik,
    /// The joints the CLIK drives; set-points for the carriage and the monitor.
    q: Joints,
    attack: Option<Attack>,
    /// Carriage set-point of a run along the rail with no attack (a search), m of rail.
    transit: Option<f64>,
    /// Carriage set-point of the way out of barred space, m of rail: it overrides the
    /// rest while the carriage is inside.
    exit: Option<f64>,
    pub(crate) valve: bool,
    pub(crate) mission: Mission,
    /// Hot spots of the latest frame with the time they were seen.
    spots: Vec<(FlameObservation, f64)>,
    last_step_t: Option<f64>,
    last_report_t: f64,
}

fn joints(j: &RailJoints) -> Joints {
    Joints::new(j.d, j.theta1, j.theta2, j.v0)
}

/// The CLIK's joint limits for `spec` on a rail of `length_m`.
pub fn limits(spec: &MonorailSpec, length_m: f64) -> Limits {
    Limits {
        lo: Joints::new(
            0.0,
            -spec.theta1_limit_rad,
            spec.theta2_min_rad,
            spec.v0_min_m_s,
        ),
        hi: Joints::new(
            length_m,
            spec.theta1_limit_rad,
            spec.theta2_max_rad,
            spec.v0_max_m_s,
        ),
    }
}

impl RailUnit {
    /// The unit `id` of `scenario`, which must be a monorail unit on a declared rail
    /// (scenario validation guarantees it for loaded scenarios).
    pub fn new(id: UnitId, spec: MonorailSpec, scenario: &Scenario) -> Option<Self> {
        let u = scenario.unit(&id)?;
        let rail = scenario.rail(u.rail.as_deref()?)?.clone();
        let start = RailJoints {
            d: u.x_m - rail.start_m,
            theta1: 0.0,
            theta2: -std::f64::consts::PI / 12.0,
            v0: 10.0,
        };
        let sensors = RailSensors {
            unit: id.clone(),
            t: 0.0,
            joints: start,
            speed: 0.0,
            valve_open: false,
            flow_l_s: 0.0,
            water_connected: false,
            fire_detected: false,
            temperature_c: 20.0,
            heat_flux_kw_m2: 0.0,
            hot_spots: Vec::new(),
        };
        Some(Self {
            id,
            spec,
            frame: RailFrame {
                x0: rail.start_m,
                y0: rail.y_m,
                height_m: rail.height_m,
            },
            clik: Clik {
                monitor: Monitor {
                    link_m: spec.link_m,
                },
                limits: limits(&spec, rail.length_m()),
                params: ClikParams {
                    scale: [
                        spec.carriage_speed_m_s,
                        spec.monitor_rate_rad_s,
                        spec.monitor_rate_rad_s,
                        spec.nozzle_rate_m_s2,
                    ],
                    ..ClikParams::ROBOGAT
                },
            },
            rail_limits: limits(&spec, rail.length_m()),
            tunnel: scenario.tunnel.clone(),
            rail,
            sensors,
            fis: Fis::new(),
            q: joints(&start),
            attack: None,
            transit: None,
            exit: None,
            valve: false,
            mission: Mission::default(),
            spots: Vec::new(),
            last_step_t: None,
            last_report_t: f64::NEG_INFINITY,
        })
    }

    fn planner_params(&self) -> PlannerParams {
        PlannerParams {
            v_dm: self.spec.carriage_speed_m_s,
            v_mm: self.spec.monitor_rate_rad_s,
            r_0m: self.spec.nozzle_rate_m_s2,
            sweep: SWEEP_M,
        }
    }

    pub fn now(&self) -> f64 {
        self.sensors.t
    }

    /// The carriage's chainage.
    pub fn position(&self) -> Point2 {
        Point2::new(self.rail.start_m + self.sensors.joints.d, self.rail.y_m)
    }

    /// The dock the carriage would work a fire at `p` from, if one serves it.
    fn dock_for(&self, p: Point2) -> Option<Dock> {
        self.rail
            .dock_for(p, &Reach::of(&self.spec), self.position().x)
    }

    /// Whether the monitor can work a fire at `p` from a dock of the rail.
    pub fn in_reach(&self, p: Point2) -> bool {
        self.dock_for(p).is_some()
    }

    /// Start (or retarget) the attack on the fire at `fire`; false if no dock serves it.
    pub fn start_attack(&mut self, fire: Point2) -> bool {
        if let Some(a) = &mut self.attack {
            a.fire = fire;
            return true;
        }
        let Some(dock) = self.dock_for(fire) else {
            return false;
        };
        let start = self.clik.monitor.position(&self.q, self.frame.height_m);
        self.attack = Some(Attack {
            fire,
            dock,
            planner: Planner::new(self.planner_params(), start),
            out: false,
        });
        true
    }

    /// Whether the carriage stands plugged into a hose point: where its water comes from.
    fn at_hose_point(&self) -> bool {
        self.rail
            .dock_at(self.position().x, self.spec.hose_reach_m)
            .is_some()
    }

    /// Where the attack is: approaching, sweeping, or holding the jet after the fire.
    pub fn attack_phase(&self) -> Option<Phase> {
        self.attack.map(|a| a.planner.phase())
    }

    /// The fire is out: hold the jet where it is and shut the valve.
    pub fn fire_out(&mut self) {
        if let Some(a) = &mut self.attack {
            a.out = true;
        }
        self.valve = false;
    }

    /// Drop the attack; the monitor holds where it is.
    pub fn stop_attack(&mut self) {
        self.attack = None;
        self.valve = false;
    }

    /// Run the carriage to the point of the rail nearest `goal`, the monitor held as it
    /// is: a search, the thermal camera looking as the carriage goes. An attack takes
    /// over the carriage.
    pub fn run_to(&mut self, goal: Point2) {
        self.transit = Some(goal.x.clamp(self.rail.start_m, self.rail.end_m) - self.rail.start_m);
    }

    /// Whether the carriage has reached the end of its run.
    pub fn run_done(&self) -> bool {
        self.transit
            .is_none_or(|d| (self.sensors.joints.d - self.run_end(d)).abs() < RUN_DONE_M)
    }

    /// Where a run to `d` (m of rail) ends: there, or short of barred space.
    fn run_end(&self, d: f64) -> f64 {
        let lim = &self.clik.limits;
        d.clamp(lim.lo[0], lim.hi[0])
    }

    pub fn stop_run(&mut self) {
        self.transit = None;
    }

    /// Hold the carriage to barred space: inside it, drop the attack and run out by the
    /// shortest way; outside, narrow its travel to the stretch of rail it is on.
    fn keep_out(&mut self) {
        let mut lim = self.rail_limits;
        let Some(barred) = &self.mission.barred else {
            self.clik.limits = lim;
            return;
        };
        let (x0, x1) = (self.rail.start_m, self.rail.end_m);
        let here = Chainage::new(self.position().x);
        if barred.entry_at(UnitKind::Monorail, here).is_some() {
            let ranges = barred.ranges(UnitKind::Monorail);
            self.exit = nearest_allowed(
                &ranges,
                here,
                CLEAR_OF_BARRED_M,
                Chainage::new(x0),
                Chainage::new(x1),
            )
            .map(|x| x.m() - x0);
            if !self.mission.leaving {
                match self.exit {
                    Some(d) => {
                        tracing::warn!(unit = %self.id, at = here.m(), to = d + x0, "inside barred space: leaving by the shortest way")
                    }
                    None => {
                        tracing::warn!(unit = %self.id, at = here.m(), "inside barred space and no way out along the rail: holding")
                    }
                }
                self.mission.leaving = true;
                self.stop_attack();
            }
            self.clik.limits = lim;
            return;
        }
        if self.mission.leaving {
            self.mission.leaving = false;
            self.exit = None;
            tracing::info!(unit = %self.id, "out of barred space");
        }
        let k = UnitKind::Monorail;
        lim.lo[0] = barred
            .reach(k, here, Chainage::new(x0), CLEAR_OF_BARRED_M)
            .m()
            - x0;
        lim.hi[0] = barred
            .reach(k, here, Chainage::new(x1), CLEAR_OF_BARRED_M)
            .m()
            - x0;
        self.clik.limits = lim;
    }

    /// A hot spot seen lately within `within` of `of`.
    pub fn flame_near(&self, of: Point2, within: f64) -> Option<Point2> {
        self.spots
            .iter()
            .map(|(o, _)| o.position)
            .filter(|p| p.dist(of) <= within)
            .min_by(|a, b| a.dist(of).total_cmp(&b.dist(of)))
    }
}

impl Responder for RailUnit {
    fn id(&self) -> &UnitId {
        &self.id
    }
    fn kind(&self) -> UnitKind {
        UnitKind::Monorail
    }
    fn tunnel(&self) -> &Tunnel {
        &self.tunnel
    }
    fn position(&self) -> Point2 {
        RailUnit::position(self)
    }
    fn mission(&mut self) -> &mut Mission {
        &mut self.mission
    }
    fn flame_near(&self, of: Point2, within: f64) -> Option<Point2> {
        RailUnit::flame_near(self, of, within)
    }
    fn most_confident_flame(&self) -> Option<Point2> {
        // Nearest first: the thermal camera's confidence does not rank hot spots.
        let at = RailUnit::position(self);
        self.spots
            .iter()
            .map(|(o, _)| o.position)
            .filter(|p| {
                self.in_reach(*p)
                    && self
                        .mission
                        .permits(&self.tunnel, UnitKind::Monorail, at, *p, true)
            })
            .min_by(|a, b| a.dist(at).total_cmp(&b.dist(at)))
    }
    fn stand_down(&mut self) {
        self.stop_attack();
    }
}

impl Services for RailUnit {
    type Sensors = RailSensors;
    type Command = RailCommand;

    /// Take in a new sensor frame.
    fn sense(&mut self, s: &RailSensors) {
        let t = s.t;
        self.spots.retain(|(_, seen)| t - seen <= RECENTLY_SEEN_S);
        for h in &s.hot_spots {
            let var = h.sigma_m * h.sigma_m;
            self.spots.push((
                FlameObservation {
                    position: h.position,
                    cov: [var, 0.0, var],
                    confidence: 0.9,
                    hrr_kw: None,
                },
                t,
            ));
        }
        let measured = joints(&s.joints);
        if self.attack.is_none() || (measured - self.q).amax() > RESYNC_M {
            self.q = measured;
        }
        self.sensors = s.clone();
        self.keep_out();
    }

    /// Set-points for this frame: integrate the CLIK up to the frame's time.
    fn command(&mut self) -> RailCommand {
        let t = self.sensors.t;
        let gap = self.last_step_t.map_or(0.0, |l| t - l);
        self.last_step_t = Some(t);
        if let Some(mut a) = self.attack {
            if !(0.0..=MAX_GAP_S).contains(&gap) {
                self.q = joints(&self.sensors.joints);
            } else {
                // The dock bounds the carriage's travel as a joint limit, as barred space
                // does: the planner's approach runs the carriage there (dry on the way)
                // while the monitor comes round, and the CLIK works the fire from it.
                let s0 = self.rail.start_m;
                let lim = &mut self.clik.limits;
                lim.lo[0] = lim.lo[0].max(a.dock.lo_m - s0);
                lim.hi[0] = lim.hi[0].min(a.dock.hi_m - s0).max(lim.lo[0]);
                let fire = self.frame.from_site(a.fire);
                let inputs = Inputs {
                    fire: self.sensors.fire_detected,
                    temperature_c: self.sensors.temperature_c,
                    distance_m: (a.fire.x - self.position().x).abs(),
                };
                let z = self.frame.height_m;
                for _ in 0..(gap / CLIK_DT_S).round() as usize {
                    let w = self.fis.weights(inputs);
                    let j = self.clik.monitor.jet(&self.q, z).j_xy;
                    let plan = a.planner.step(CLIK_DT_S, w, &j, fire, a.out);
                    let target = Target {
                        p: plan.p,
                        pdot: plan.pdot,
                        z,
                        zdot: 0.0,
                    };
                    self.clik.step(&mut self.q, &target, w);
                }
                self.attack = Some(a);
            }
        } else if self.mission.leaving {
            // Held where it is when there is no way out.
            self.q[0] = self.exit.unwrap_or(self.sensors.joints.d);
        } else if let Some(d) = self.transit {
            // The carriage's drive keeps to its own speed limit; barred space bounds the
            // run.
            self.q[0] = self.run_end(d);
        }
        RailCommand {
            joints: RailJoints {
                d: self.q[0],
                theta1: self.q[1],
                theta2: self.q[2],
                v0: self.q[3],
            },
            valve_open: self.valve && self.sensors.water_connected,
        }
    }

    fn state(&self) -> UnitState {
        let s = &self.sensors;
        // Dry at a hose point is a fault; dry between hose points is a journey.
        let dry = self.at_hose_point() && !s.water_connected;
        let mode = if dry {
            UnitMode::Fault
        } else if self.valve {
            UnitMode::Extinguishing
        } else if self.attack_phase() == Some(Phase::Approach) {
            UnitMode::Navigating
        } else if self.attack.is_none() && !self.run_done() {
            UnitMode::Cruising
        } else {
            UnitMode::Idle
        };
        let p = self.position();
        UnitState {
            unit: self.id.clone(),
            kind: UnitKind::Monorail,
            t: s.t,
            pose: Pose2::new(p.x, p.y, 0.0),
            speed: s.speed,
            mode,
            water_l: if dry { 0.0 } else { MAINS_WATER_L },
            health: 1.0,
            heat_flux_kw_m2: s.heat_flux_kw_m2,
            task: self.mission.progress(mode == UnitMode::Extinguishing),
            autonomous: !self.mission.coordinator_present,
            refused: self.mission.refused.clone(),
            task_seq: self.mission.task.map(|(seq, _)| seq),
            epoch: self.mission.task.map(|_| self.mission.epoch),
        }
    }

    /// Hot spots seen since the last report, if any.
    fn report(&mut self) -> Option<FlameReport> {
        let since = self.last_report_t;
        self.last_report_t = self.sensors.t;
        let observations: Vec<FlameObservation> = self
            .spots
            .iter()
            .filter(|(_, seen)| *seen > since)
            .map(|(o, _)| *o)
            .collect();
        let p = self.position();
        (!observations.is_empty()).then(|| FlameReport {
            unit: self.id.clone(),
            t: self.sensors.t,
            observer: Pose2::new(p.x, p.y, 0.0),
            observations,
        })
    }

    fn barred_changed(&mut self) {
        self.keep_out();
    }

    fn time(s: &RailSensors) -> f64 {
        s.t
    }

    fn halt(s: &RailSensors) -> RailCommand {
        RailCommand {
            joints: s.joints,
            valve_open: false,
        }
    }
}

/// The control loop of one monorail unit.
pub type MonorailController = Controller<RailUnit>;

impl Controller<RailUnit> {
    /// A controller running `doc`'s main tree for unit `id` of `scenario`, ticked on every
    /// sensor frame; `None` if the scenario has no such monorail unit.
    pub fn with_tree(
        id: UnitId,
        spec: MonorailSpec,
        scenario: Arc<Scenario>,
        doc: &Document,
    ) -> Result<Option<Self>, XmlErrors> {
        let tree = xml::build(doc, &leaves::registry())?;
        Ok(RailUnit::new(id, spec, &scenario).map(|unit| Self::from_parts(tree, unit, 0.0)))
    }
}

/// Every leaf the monorail unit's trees may use.
pub fn registry() -> firefleet_bt::Registry<RailUnit> {
    leaves::registry()
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::profile::MONORAIL;

    #[test]
    fn the_working_reach_is_within_the_jets_range_at_two_thirds_of_full_speed() {
        let m = Monitor {
            link_m: MONORAIL.link_m,
        };
        for height in [4.0, 5.0, 6.0] {
            let r = m.range(0.0, 18.0, height);
            assert!(r >= MONORAIL.working_reach_m, "{height} m: {r}");
        }
    }
}
