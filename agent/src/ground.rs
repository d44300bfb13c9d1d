//! The ground unit's control loop (until the behavior tree replaces it).
//!
//! One call to [`GroundController::step`] per sensor frame: update the flame tracker, decide
//! what to do, and return actuator set-points. What to do:
//!
//! - with a task from the coordinator: drive to a firing position for the task's fire, aim,
//!   spray until the camera no longer sees the flame;
//! - without a task: cruise along the tunnel looking for fire, and stop to hold when a
//!   flame is close (the coordinator decides who attacks it);
//! - with no coordinator at all: attack the nearest flame it sees, on its own.
//!
//! Pure: no I/O, no clock of its own (time comes with the sensor frame).

use std::sync::Arc;

use firefleet_protocol::geometry::{Point2, Pose2, wrap_angle};
use firefleet_protocol::msg::{
    FlameReport, TaskKind, TaskPhase, TaskProgress, UnitCommand, UnitKind, UnitMode, UnitSensors,
    UnitState,
};
use firefleet_protocol::scenario::Scenario;
use firefleet_protocol::spec::GroundSpec;
use firefleet_protocol::{FireId, UnitId};

use crate::aim;
use crate::nav::{self, Follow, Grid, PurePursuit};
use crate::tracker::FlameTracker;

/// Preferred distances from a fire to fire from, m, in order of preference. 5 to 6 m keeps
/// radiant heat from a 5 MW fire under about 5 kW/m^2 and the jet short and accurate.
const STANDOFF_M: [f64; 5] = [5.5, 6.5, 4.5, 8.0, 10.0];
/// A cruising unit stops to hold when it sees a flame this close, m.
const HOLD_RANGE_M: f64 = 20.0;
/// Spray is declared successful after the flame has been out of sight this long while the
/// camera was looking at it, s.
const OUT_CONFIRM_S: f64 = 2.0;
/// Give up a fire that cannot be confirmed out after this long spraying, s.
const SPRAY_GIVE_UP_S: f64 = 60.0;
/// Cannon pointing error below which the valve opens, rad.
const AIM_TOLERANCE_RAD: f64 = 0.05;
/// Grid resolution of the navigation map, m.
const GRID_RES_M: f64 = 0.25;

/// What the unit is doing.
#[derive(Debug)]
enum Activity {
    Hold,
    Cruise(PurePursuit),
    Attack(Attack),
    /// Backing away after touching something, until `until`, then resuming.
    Recover {
        until: f64,
        then: Box<Activity>,
    },
    Fault,
}

/// Working on one fire.
#[derive(Debug)]
struct Attack {
    /// The coordinator's task, or `None` when acting alone.
    task: Option<(u64, FireId)>,
    target: Point2,
    travel: Option<PurePursuit>,
    spray_since: Option<f64>,
    last_seen: f64,
}

/// The control loop of one ground unit.
pub struct GroundController {
    unit: UnitId,
    spec: GroundSpec,
    scenario: Arc<Scenario>,
    nav_grid: Grid,
    sight_grid: Grid,
    tracker: FlameTracker,
    activity: Activity,
    coordinator_present: bool,
    /// Latest task from the coordinator: `(seq, kind)`.
    task: Option<(u64, TaskKind)>,
    /// How the last coordinator task ended, echoed in the state.
    outcome: Option<TaskProgress>,
    last_report_t: f64,
}

impl GroundController {
    pub fn new(unit: UnitId, spec: GroundSpec, scenario: Arc<Scenario>) -> Self {
        let nav_grid = Grid::from_scenario(&scenario, GRID_RES_M, spec.circumradius_m() + 0.25);
        let sight_grid = Grid::from_scenario(&scenario, GRID_RES_M, 0.0);
        Self {
            unit,
            spec,
            scenario,
            nav_grid,
            sight_grid,
            tracker: FlameTracker::default(),
            activity: Activity::Hold,
            coordinator_present: false,
            task: None,
            outcome: None,
            last_report_t: f64::NEG_INFINITY,
        }
    }

    /// A task arrived from the coordinator. Older or repeated tasks are ignored.
    pub fn on_task(&mut self, seq: u64, kind: TaskKind) {
        if self.task.is_some_and(|(s, _)| s >= seq) {
            return;
        }
        self.task = Some((seq, kind));
    }

    /// The coordinator appeared or disappeared.
    pub fn set_coordinator_present(&mut self, present: bool) {
        self.coordinator_present = present;
    }

    /// One control step for sensor frame `s`.
    pub fn step(&mut self, s: &UnitSensors) -> UnitCommand {
        self.tracker.update(&self.spec, s);
        if s.water_l <= 0.0 && !matches!(self.activity, Activity::Fault) {
            self.finish(TaskPhase::Failed);
            self.activity = Activity::Fault;
        }
        if s.collided && !matches!(self.activity, Activity::Recover { .. } | Activity::Fault) {
            let then = std::mem::replace(&mut self.activity, Activity::Hold);
            self.activity = Activity::Recover {
                until: s.t + 1.5,
                then: Box::new(then),
            };
        }
        self.decide(s);
        self.act(s)
    }

    /// Choose the activity from the task, the coordinator's presence and what is seen.
    fn decide(&mut self, s: &UnitSensors) {
        if matches!(self.activity, Activity::Fault | Activity::Recover { .. }) {
            return;
        }
        let current = match &self.activity {
            Activity::Attack(a) => a.task,
            _ => None,
        };
        match self.task {
            Some((seq, TaskKind::Extinguish { fire, target }))
                if self.coordinator_present || current.is_some() =>
            {
                if current.map(|(s, _)| s) != Some(seq) && self.outcome.is_none_or(|o| o.seq != seq)
                {
                    self.activity = Activity::Attack(Attack::new(Some((seq, fire)), target, s.t));
                }
                return;
            }
            Some((_, TaskKind::Standby)) if current.is_some() => self.activity = Activity::Hold,
            _ => {}
        }
        if matches!(self.activity, Activity::Attack(_)) {
            return;
        }
        let pose = s.pose.position();
        let nearest = self
            .tracker
            .confirmed()
            .min_by(|a, b| a.position().dist(pose).total_cmp(&b.position().dist(pose)));
        match nearest {
            Some(t) if !self.coordinator_present => {
                self.activity = Activity::Attack(Attack::new(None, t.position(), s.t));
            }
            Some(t) if t.position().dist(pose) < HOLD_RANGE_M => self.activity = Activity::Hold,
            _ => {
                if matches!(self.activity, Activity::Hold) {
                    self.activity = self.cruise(&s.pose);
                }
            }
        }
    }

    /// A cruise along the current lane to the far end of the tunnel, or hold if there.
    fn cruise(&self, pose: &Pose2) -> Activity {
        let t = &self.scenario.tunnel;
        let lane = (0..t.lanes)
            .map(|i| t.lane_center_y(i))
            .min_by(|a, b| (a - pose.y).abs().total_cmp(&(b - pose.y).abs()))
            .unwrap_or(0.0);
        let goal = Point2::new(t.length_m - 10.0, lane);
        if pose.position().dist(goal) < 2.0 {
            return Activity::Hold;
        }
        match nav::plan(&self.nav_grid, pose.position(), goal) {
            Some(path) => Activity::Cruise(PurePursuit::new(path)),
            None => Activity::Hold,
        }
    }

    fn act(&mut self, s: &UnitSensors) -> UnitCommand {
        let halt = UnitCommand::halt(&s.cannon);
        match &mut self.activity {
            Activity::Hold | Activity::Fault => halt,
            Activity::Cruise(pp) => match pp.follow(&s.pose, &self.spec) {
                Follow::Drive { speed, steer } => UnitCommand {
                    speed,
                    steer,
                    ..halt
                },
                Follow::Arrived => {
                    self.activity = Activity::Hold;
                    halt
                }
            },
            Activity::Recover { until, .. } => {
                if s.t < *until {
                    UnitCommand {
                        speed: -0.4,
                        steer: 0.0,
                        ..halt
                    }
                } else {
                    let Activity::Recover { then, .. } =
                        std::mem::replace(&mut self.activity, Activity::Hold)
                    else {
                        unreachable!()
                    };
                    self.activity = match *then {
                        Activity::Attack(mut a) => {
                            a.travel = None;
                            Activity::Attack(a)
                        }
                        Activity::Cruise(_) => self.cruise(&s.pose),
                        other => other,
                    };
                    halt
                }
            }
            Activity::Attack(_) => self.attack(s),
        }
    }

    fn attack(&mut self, s: &UnitSensors) -> UnitCommand {
        let halt = UnitCommand::halt(&s.cannon);
        let Activity::Attack(a) = &mut self.activity else {
            return halt;
        };
        // Follow the flame as the camera sees it.
        if let Some(t) = self.tracker.nearest_confirmed(a.target, 3.0) {
            a.target = t.position();
            a.last_seen = a.last_seen.max(t.last_seen);
        }
        if a.spray_since.is_none() {
            if a.travel.is_none() {
                match firing_path(
                    &self.nav_grid,
                    &self.sight_grid,
                    &self.spec,
                    &self.scenario,
                    s.pose.position(),
                    a.target,
                ) {
                    Some(path) => a.travel = Some(PurePursuit::new(path)),
                    None => {
                        tracing::warn!(unit = %self.unit, target = ?a.target, "no firing position reachable");
                        self.finish(TaskPhase::Failed);
                        self.activity = Activity::Hold;
                        return halt;
                    }
                }
            }
            let pp = a.travel.as_mut().expect("planned above");
            match pp.follow(&s.pose, &self.spec) {
                Follow::Drive { speed, steer } => {
                    return UnitCommand {
                        speed,
                        steer,
                        ..self.aim_command(s, false)
                    };
                }
                Follow::Arrived => a.spray_since = Some(s.t),
            }
        }
        let Activity::Attack(a) = &self.activity else {
            return halt;
        };
        let since = a.spray_since.unwrap_or(s.t);
        let looking = self.in_view(&s.pose, a.target);
        if looking && s.t - a.last_seen >= OUT_CONFIRM_S && s.t - since >= 1.0 {
            tracing::info!(unit = %self.unit, target = ?a.target, "flame out");
            self.finish(TaskPhase::Extinguished);
            self.activity = Activity::Hold;
            return halt;
        }
        if s.t - since > SPRAY_GIVE_UP_S {
            self.finish(TaskPhase::Failed);
            self.activity = Activity::Hold;
            return halt;
        }
        self.aim_command(s, true)
    }

    /// Cannon set-points towards the current target; the valve opens only when on target.
    fn aim_command(&self, s: &UnitSensors, spray: bool) -> UnitCommand {
        let Activity::Attack(a) = &self.activity else {
            return UnitCommand::halt(&s.cannon);
        };
        let nozzle = s.pose.position();
        let pan = wrap_angle(nozzle.bearing_to(a.target) - s.pose.yaw).clamp(
            -self.spec.cannon_pan_limit_rad,
            self.spec.cannon_pan_limit_rad,
        );
        let tilt = aim::elevations(
            nozzle.dist(a.target),
            -self.spec.cannon_height_m,
            self.spec.cannon_muzzle_speed_m_s,
        )
        .map(|e| e.low)
        .unwrap_or(s.cannon.tilt);
        let on_target = (s.cannon.pan - pan).abs() < AIM_TOLERANCE_RAD
            && (s.cannon.tilt - tilt).abs() < AIM_TOLERANCE_RAD;
        UnitCommand {
            speed: 0.0,
            steer: 0.0,
            pan,
            tilt,
            valve_open: spray && (on_target || s.cannon.valve_open),
        }
    }

    fn in_view(&self, pose: &Pose2, p: Point2) -> bool {
        let b = pose.to_body(p);
        b.y.atan2(b.x).abs() < 0.45 * self.spec.camera_hfov_rad
            && b.x.hypot(b.y) < self.spec.camera_range_m * 0.8
            && self.sight_grid.segment_free(pose.position(), p)
    }

    /// Record how the current coordinator task ended.
    fn finish(&mut self, phase: TaskPhase) {
        if let Activity::Attack(Attack {
            task: Some((seq, fire)),
            ..
        }) = &self.activity
        {
            self.outcome = Some(TaskProgress {
                seq: *seq,
                fire: *fire,
                phase,
            });
        }
    }

    /// The unit's state for the bus.
    pub fn state(&self, s: &UnitSensors) -> UnitState {
        let (mode, task) = match &self.activity {
            Activity::Hold => (UnitMode::Idle, None),
            Activity::Cruise(_) => (UnitMode::Cruising, None),
            Activity::Fault => (UnitMode::Fault, None),
            Activity::Recover { then, .. } => match then.as_ref() {
                Activity::Attack(a) => (UnitMode::Navigating, a.progress()),
                _ => (UnitMode::Cruising, None),
            },
            Activity::Attack(a) if a.spray_since.is_some() => {
                (UnitMode::Extinguishing, a.progress())
            }
            Activity::Attack(a) => (UnitMode::Navigating, a.progress()),
        };
        UnitState {
            unit: self.unit.clone(),
            kind: UnitKind::Ground,
            t: s.t,
            pose: s.pose,
            speed: s.speed,
            mode,
            water_l: s.water_l.max(0.0),
            health: 1.0,
            heat_flux_kw_m2: s.heat_flux_kw_m2,
            task: task.or(self.outcome),
            autonomous: !self.coordinator_present,
        }
    }

    /// Flames seen since the last report, if any.
    pub fn report(&mut self, s: &UnitSensors) -> Option<FlameReport> {
        let observations = self.tracker.observations(self.last_report_t);
        self.last_report_t = s.t;
        (!observations.is_empty()).then(|| FlameReport {
            unit: self.unit.clone(),
            t: s.t,
            observer: s.pose,
            observations,
        })
    }
}

impl Attack {
    fn new(task: Option<(u64, FireId)>, target: Point2, t: f64) -> Self {
        Self {
            task,
            target,
            travel: None,
            spray_since: None,
            last_seen: t,
        }
    }

    fn progress(&self) -> Option<TaskProgress> {
        let (seq, fire) = self.task?;
        let phase = if self.spray_since.is_some() {
            TaskPhase::Spraying
        } else {
            TaskPhase::Travelling
        };
        Some(TaskProgress { seq, fire, phase })
    }
}

/// A path from `from` to a firing position for a fire at `target`: free for the vehicle,
/// with line of sight and a jet solution that stays under the ceiling, arriving along the
/// line towards the fire so that the camera faces it.
fn firing_path(
    nav: &Grid,
    sight: &Grid,
    spec: &GroundSpec,
    scenario: &Scenario,
    from: Point2,
    target: Point2,
) -> Option<Vec<Point2>> {
    let home = target.bearing_to(from);
    let offsets = (0..=8).flat_map(|k| {
        let a = k as f64 * 0.35;
        if k == 0 { vec![0.0] } else { vec![a, -a] }
    });
    for off in offsets {
        for r in STANDOFF_M {
            let spot = target.offset(home + off, r);
            if !nav.free(spot) || !sight.segment_free(spot, target) {
                continue;
            }
            let Ok(e) = aim::elevations(r, -spec.cannon_height_m, spec.cannon_muzzle_speed_m_s)
            else {
                continue;
            };
            if spec.cannon_height_m + aim::apex_height(e.low, spec.cannon_muzzle_speed_m_s)
                >= scenario.tunnel.height_m
            {
                continue;
            }
            // Arrive along the ray from the fire so the camera faces it.
            let lead_in = target.offset(home + off, r + 2.5);
            let path = if nav.free(lead_in) && nav.segment_free(lead_in, spot) {
                nav::plan(nav, from, lead_in).map(|mut p| {
                    p.push(spot);
                    p
                })
            } else {
                nav::plan(nav, from, spot)
            };
            if path.is_some() {
                return path;
            }
        }
    }
    None
}
