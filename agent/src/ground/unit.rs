//! The ground unit as its behavior tree sees it: state and the services leaves drive.
//!
//! In the paper the tree sits on top of Autoware (navigation) and a cannon driver; the
//! tree sets goals and polls for arrival while those services do the continuous work.
//! [`Unit`] plays that role here: a navigation service that plans (Hybrid A* to firing
//! positions, keeping the flame in view and away from the heat of tracked fires; grid A*
//! for cruising and as the fallback, with a Hybrid A* turn round first when a grid path
//! sets off behind the unit), follows the path (pure pursuit) and recovers from
//! touching an obstacle; a keep-out service that holds the navigation to commanders'
//! barred space (see below); a cannon service that
//! slews to the aim set-point and opens the valve on request; the flame tracker; and the
//! link state to the coordinator. Leaves ([`crate::ground::leaves`]) only read and set these.
//!
//! Barred space is enforced here, below the tree, so that no tree can plan through it: the
//! grids every planner searches (grid A* for cruising, patrol, search and recovery; Hybrid
//! A* to firing positions, backing included) carry a keep-out layer, the barred chainage
//! grown by the vehicle's half-diagonal so that the whole body stays out; a patrol stops
//! short of barred space; backing off an obstacle does not back into it; and a unit that
//! finds itself inside (a goal arrived while it was there) suspends whatever it was doing
//! and drives out by the shortest way, [`CLEAR_OF_BARRED_M`] past the edge, before the
//! tree may act again.

mod keep_out;
mod yielding;

use std::collections::VecDeque;
use std::f64::consts::FRAC_PI_2;
use std::sync::Arc;

use firefleet_model::UnitKind;
use firefleet_model::geometry::{Point2, Pose2, wrap_angle};
use firefleet_model::scenario::{Scenario, Tunnel};
use firefleet_model::spec::GroundSpec;
use firefleet_model::{Chainage, UnitId};
use firefleet_protocol::msg::{
    Approach, CLEAR_OF_BARRED_M, FlameDetection, FlameReport, INSIDE_PORTAL_M, TaskKind,
    ThermalImage, UnitCommand, UnitMode, UnitSensors, UnitState, nearest_allowed,
};

use crate::controller::Services;
use crate::mission::{Mission, Responder};

use crate::ground::aim;
use crate::ground::thermal::{self, ThermalDetector};
use crate::ground::tracker::FlameTracker;
use firefleet_model::heat::HeatSource;
use firefleet_nav::hybrid_astar::{Footprint, HybridAStar, Params};
use firefleet_nav::{self as nav, Follow, Grid, PurePursuit, Route};

/// Preferred distances from a fire to fire from, m, in order of preference. 5 to 6 m keeps
/// radiant heat from a 5 MW fire under about 5 kW/m^2 and the jet short and accurate.
const STANDOFF_M: [f64; 5] = [5.5, 6.5, 4.5, 8.0, 10.0];
/// Cannon pointing error below which the valve may open, rad.
const AIM_TOLERANCE_RAD: f64 = 0.05;
/// Grid resolution of the navigation map, m.
const GRID_RES_M: f64 = 0.25;
/// Clearance grid A* keeps between the vehicle's circumcircle and walls or vehicles, m.
const NAV_MARGIN_M: f64 = 0.25;
/// Clearance Hybrid A* keeps between the footprint and walls or vehicles, m: room for the
/// path follower's tracking error.
const HYBRID_MARGIN_M: f64 = 0.3;
/// How many firing spots Hybrid A* searches for at once, and the expansions it may spend
/// on them before the grid planner takes over: a bound on the planning done inside one
/// control step (about 3.5 us an expansion in the nav experiment's tunnel, so 0.35 s).
const HYBRID_BUDGET: usize = 100_000;
const HYBRID_SPOTS: usize = 6;
/// The straight a Hybrid A* path to a firing spot ends on, m, longest first.
const RUN_IN_M: [f64; 3] = [2.5, 1.5, 0.75];
/// Weight of Hybrid A*'s visibility term on the way to a fire, m of path.
const VISIBILITY_LAMBDA_M: f64 = 5.0;
/// How long after the last detection a flame still counts as seen, s.
const RECENTLY_SEEN_S: f64 = 2.0;
/// How far from the fire's spot a flame the unit sees is taken for the fire when it aims,
/// m: the fire's estimate, made from afar, is this good once the unit is in range.
const AIM_SEEN_WITHIN_M: f64 = 3.0;
/// The longest gap between two frames that still counts as the cameras looking
/// throughout ([`Unit::has_watched`]), s: frames come at 20 Hz, a thermal core's every
/// 0.12 s.
const WATCH_GAP_S: f64 = 0.5;
/// How far around a fire's estimated position the road is read for its fuel bed, m: the
/// estimate's error at firing range, about half a metre, and a metre of the bed.
const BED_LOOK_M: f64 = 1.5;
/// A thermal frame older than this says nothing of a bed, s (the core sends 8.7 a second).
const BED_FRAME_FRESH_S: f64 = 1.0;
/// Period of the sweep across a flame's base while spraying, s. With the sweep's half-width
/// at half the flame's radius, the pan rate stays far under the slew rate.
const SWEEP_PERIOD_S: f64 = 2.0;
/// Clearance a planned jet keeps from the ceiling, m.
const JET_CEILING_MARGIN_M: f64 = 0.3;
/// How far a navigation goal on a blocked cell is moved to a free one at most, m: half a
/// car's length and its inflation.
const GOAL_SHIFT_M: f64 = 4.0;
/// Backing off (or, if that is blocked too, pulling straight ahead) after touching
/// something, s.
const RECOVER_S: f64 = 1.5;
/// Speed of a recovery move, m/s.
const RECOVER_SPEED_M_S: f64 = 0.4;
/// How long a recovery move may go without a frame showing the body moving its way before
/// a contact counts as its refusal, s: longer than the time a command takes to reach the
/// body under load (see [`Recovery`]), short beside [`RECOVER_S`].
const RECOVER_PATIENCE_S: f64 = 1.0;
/// How often a unit inside barred space that found no way out tries again, s.
const LEAVE_RETRY_S: f64 = 1.0;
/// How far along a grid path that sets off behind it a unit turns round to, m: beyond the
/// three-point turn a two-lane bore leaves room for.
const TURN_ROUND_M: f64 = 8.0;

/// What the navigation service is driving to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NavPurpose {
    Cruise,
    Fire,
    /// Out of barred space, by the shortest way.
    Leave,
}

#[derive(Debug)]
struct Navigation {
    purpose: NavPurpose,
    goal: Point2,
    follow: PurePursuit,
    arrived: bool,
    /// Getting clear of what the body touched, then replanning.
    recover: Option<Recovery>,
    failed: bool,
    yielding: yielding::Yielding,
    /// The fire a firing position is the goal for, where the route was prepared for one:
    /// a unit that finds another standing on its spot chooses another.
    fire: Option<Point2>,
}

impl Navigation {
    fn new(purpose: NavPurpose, goal: Point2, route: Route) -> Self {
        Self {
            fire: None,
            purpose,
            goal,
            follow: PurePursuit::new(route),
            arrived: false,
            recover: None,
            failed: false,
            yielding: Default::default(),
        }
    }
}

/// A straight move to get clear after the body touched something: the other way from the
/// move that was refused (back, after running into something ahead); if that is refused
/// too, the other way again, and so on, each move for [`RECOVER_S`]. A unit whose rear
/// corner is against a wall cannot back off, and turning away swings the overhang behind
/// its rear axle into the wall; only straight ahead frees it (units on a 3 km tunnel were
/// pinned so for twenty seconds at a time, a blocked step every step).
///
/// A contact reported after a move began is not always that move's: the commands sent
/// before it may still be on their way to the body, and each of them is refused in turn.
/// Taken as the new move's refusal, each one turned the unit round again, towards the car
/// it had hit, so that with two steps between a frame and the body's answer (100 ms: a
/// loaded machine, or a lossy link's retransmissions) a unit pushed against a car for
/// minutes, a blocked step nearly every step. So a move counts as refused only once a
/// frame has shown the body moving its way, or after [`RECOVER_PATIENCE_S`] in which it
/// never did (refused from a standstill, as against that wall).
#[derive(Debug, Clone, Copy)]
struct Recovery {
    /// When the move was chosen, s of site time.
    since: f64,
    until: f64,
    /// Signed speed: negative backs.
    speed: f64,
    /// Whether a frame since `since` showed the body moving this way.
    under_way: bool,
}

impl Recovery {
    /// The move `speed` m/s (signed), chosen at `t`.
    fn toward(speed: f64, t: f64) -> Self {
        Self {
            since: t,
            until: t + RECOVER_S,
            speed,
            under_way: false,
        }
    }

    /// The move after a contact reported at `t`, with `current` the move under way, if
    /// any, and `moved` the sign of the body's speed when it last moved (0 if it never
    /// did): the other way from the move that was refused, backing if it is not known.
    fn after(current: Option<Recovery>, t: f64, moved: f64) -> Self {
        match current {
            Some(r) if r.under_way || t - r.since >= RECOVER_PATIENCE_S => {
                Self::toward(-r.speed, t)
            }
            // A move from before this one was refused: this one has not been tried yet.
            Some(r) => r,
            None if moved < 0.0 => Self::toward(RECOVER_SPEED_M_S, t),
            None => Self::toward(-RECOVER_SPEED_M_S, t),
        }
    }

    /// Take in a frame's `speed` of the body.
    fn saw(&mut self, speed: f64) {
        self.under_way |= speed * self.speed > 0.0;
    }
}

/// A firing position chosen for a fire and the route to it.
#[derive(Debug)]
struct Prepared {
    fire: Point2,
    spot: Point2,
    route: Route,
}

/// The point `d` metres along `path` and the index of the path's next point after it;
/// `None` if the path is shorter.
fn point_along(path: &[Point2], d: f64) -> Option<(usize, Point2)> {
    let mut left = d;
    for (i, w) in path.windows(2).enumerate() {
        let len = w[0].dist(w[1]);
        if len >= left && len > 0.0 {
            let at = w[0].offset(w[0].bearing_to(w[1]), left);
            return Some((i + 1, at));
        }
        left -= len;
    }
    None
}

/// The unit, its world model and its services.
pub struct Unit {
    pub(crate) id: UnitId,
    pub(crate) spec: GroundSpec,
    pub(crate) scenario: Arc<Scenario>,
    /// Walls and vehicles grown by the vehicle's radius and a margin, with the keep-out
    /// layer: what grid A* searches for the vehicle's centre.
    nav_grid: Grid,
    sight_grid: Grid,
    /// Walls and vehicles grown by [`HYBRID_MARGIN_M`], with the keep-out layer: what
    /// Hybrid A* checks the footprint against.
    hybrid_grid: Grid,
    /// `nav_grid` and `hybrid_grid` without the keep-out layer: the way out of barred
    /// space is planned on the first, and both are the base a new layer is laid on.
    open_nav_grid: Grid,
    open_hybrid_grid: Grid,
    /// A unit inside barred space that found no way out tries again at this time.
    leave_retry_at: f64,
    pub(crate) tracker: FlameTracker,
    /// Finds flames in the thermal core's frames, on a unit whose sensors send them.
    thermal: ThermalDetector,
    /// What it found in the newest frame, if that frame had a thermal image.
    found: Option<Vec<FlameDetection>>,
    /// The newest thermal image, the pose it was taken from and when: what a fuel bed is
    /// read in ([`Unit::bed_k`]).
    thermal_view: Option<(ThermalImage, Pose2, f64)>,
    /// The latest sensor frame.
    pub(crate) frame: UnitSensors,
    /// The sign of the body's speed in the last frame it moved in (0 before it has): the
    /// way it went when it touched something, for [`Recovery`].
    moved: f64,
    nav: Option<Navigation>,
    /// A firing route prepared for a goal (from `SetTargetToFire`), used by the next
    /// `StartNavigation` to that goal.
    prepared: Option<Prepared>,
    /// Cannon set-point (pan, tilt) and whether the valve is wanted open.
    pub(crate) aim: Option<(f64, f64)>,
    /// Pan set-point while sweeping the cannon (and its camera) to look for fire.
    pub(crate) scan: Option<f64>,
    /// Half-angle of the sweep across the flame base while spraying, rad.
    pub(crate) sweep_rad: f64,
    pub(crate) valve: bool,
    pub(crate) mission: Mission,
    /// Goal of the latest cruise, kept after arrival.
    cruising_to: Option<Point2>,
    /// Where the unit patrols to on its own (`patrol_goal`).
    patrol_goal: Point2,
    /// Weight of Hybrid A*'s visibility term on the way to a fire, m.
    pub(crate) visibility_lambda_m: f64,
    last_report_t: f64,
    /// Where the cameras looked in each frame of the last [`RECENTLY_SEEN_S`], oldest
    /// first, and the newest before that ([`Unit::has_watched`]).
    looks: VecDeque<Look>,
}

/// Where the cameras looked from in one frame.
#[derive(Debug, Clone, Copy)]
struct Look {
    t: f64,
    pose: Pose2,
    pan: f64,
}

impl Unit {
    /// A unit at its start pose in the scenario, until the first frame arrives.
    pub fn new(id: UnitId, spec: GroundSpec, scenario: Arc<Scenario>) -> Self {
        let start = scenario.unit(&id).map(|u| u.pose()).unwrap_or_default();
        let patrol_goal = patrol_goal(&scenario.tunnel, start.position());
        let frame = UnitSensors {
            unit: id.clone(),
            t: 0.0,
            pose: start,
            speed: 0.0,
            steer: 0.0,
            heat_flux_kw_m2: 0.0,
            water_l: spec.tank_l,
            cannon: Default::default(),
            detections: Vec::new(),
            collided: false,
            thermal: None,
            nearby: Vec::new(),
        };
        let nav_grid = Grid::from_scenario(&scenario, GRID_RES_M, nav_growth_m(&spec));
        let sight_grid = Grid::from_scenario(&scenario, GRID_RES_M, 0.0);
        let hybrid_grid = Grid::from_scenario(&scenario, GRID_RES_M, HYBRID_MARGIN_M);
        Self {
            id,
            spec,
            scenario,
            open_nav_grid: nav_grid.clone(),
            open_hybrid_grid: hybrid_grid.clone(),
            leave_retry_at: f64::NEG_INFINITY,
            nav_grid,
            sight_grid,
            hybrid_grid,
            tracker: FlameTracker::default(),
            thermal: ThermalDetector::default(),
            found: None,
            thermal_view: None,
            frame,
            moved: 0.0,
            nav: None,
            cruising_to: None,
            patrol_goal,
            visibility_lambda_m: VISIBILITY_LAMBDA_M,
            prepared: None,
            aim: None,
            scan: None,
            sweep_rad: 0.0,
            valve: false,
            mission: Mission::default(),
            last_report_t: f64::NEG_INFINITY,
            looks: VecDeque::with_capacity(64),
        }
    }

    pub fn pose(&self) -> Pose2 {
        self.frame.pose
    }
    pub fn now(&self) -> f64 {
        self.frame.t
    }

    /// Whether the unit has no water left (as its platform last said).
    pub fn tank_empty(&self) -> bool {
        self.frame.water_l <= 0.0
    }

    /// Set the sweep across the flame at `target`: half its estimated radius either side of
    /// the aim point, so that the jet's own spread covers the rest of the base.
    pub fn sweep_over(&mut self, target: Point2) {
        let radius = self
            .tracker
            .confirmed()
            .filter(|t| t.position().dist(target) < 1.0)
            .map(|t| t.radius_m)
            .next()
            .unwrap_or(0.0);
        self.sweep_rad = (0.5 * radius / self.pose().position().dist(target).max(1.0)).atan();
    }

    /// Whether every camera of the unit faced `spot` ([`CameraSpec::faces`]) in every
    /// frame of the last [`RECENTLY_SEEN_S`], with no gap between frames over
    /// [`WATCH_GAP_S`]: long enough that a flame burning there would be among those seen
    /// recently ([`Self::flame_near`]). No flame near a fire is a knock-down only while
    /// the unit looks at the fire: a camera on a cannon still slewing onto it, or swung
    /// off it by a control loop seconds behind its body (the nemesis's delayed link),
    /// sees no flame because it looks elsewhere, and a unit that took that for "out"
    /// left a burning fire. The frames of the approach count: a unit that drove up facing
    /// the fire has watched it on arrival.
    ///
    /// [`CameraSpec::faces`]: firefleet_model::spec::CameraSpec::faces
    pub fn has_watched(&self, spot: Point2) -> bool {
        let since = self.now() - RECENTLY_SEEN_S;
        let Some(first) = self.looks.front().filter(|l| l.t <= since) else {
            return false;
        };
        let cameras = || std::iter::once(&self.spec.camera).chain(&self.spec.thermal_camera);
        let mut before = first.t;
        self.looks.iter().all(|l| {
            let unbroken = l.t - before <= WATCH_GAP_S;
            before = l.t;
            unbroken && cameras().all(|cam| cam.faces(&cam.looking_from(&l.pose, l.pan), spot))
        })
    }

    /// Keep where the cameras look from in the newest frame, and of the older frames those
    /// [`Self::has_watched`] reads.
    fn remember_look(&mut self) {
        let f = &self.frame;
        if self.looks.back().is_some_and(|l| l.t > f.t) {
            // The clock went back (a simulator started again): those looks are of
            // another time.
            self.looks.clear();
        }
        while self
            .looks
            .get(1)
            .is_some_and(|l| l.t <= f.t - RECENTLY_SEEN_S)
        {
            self.looks.pop_front();
        }
        self.looks.push_back(Look {
            t: f.t,
            pose: f.pose,
            pan: f.cannon.pan,
        });
    }

    /// Where the cannon aims for the fire at `fire`: the flame the unit sees within
    /// [`AIM_SEEN_WITHIN_M`] of it, else the fire's own spot, either moved off a parked
    /// vehicle's body as the firing position's target is ([`Scenario::fightable_at`]).
    ///
    /// The firing position was chosen for a shot at that point. Aimed at a spot inside the
    /// vehicle instead (a DTS zone's chainage on the axis, where a locomotive stands), no
    /// jet clears the body, and the unit stood at its firing position for the minute the
    /// tree allows an attack, then gave the fire up (long-rail: one demo of about ten here,
    /// and one CI run).
    pub fn aim_point(&self, fire: Point2) -> Point2 {
        let seen = self.flame_near(fire, AIM_SEEN_WITHIN_M).unwrap_or(fire);
        self.scenario.fightable_at(seen)
    }

    /// A confirmed flame seen within `RECENTLY_SEEN_S` and within `within` metres of `of`.
    pub fn flame_near(&self, of: Point2, within: f64) -> Option<Point2> {
        self.tracker
            .confirmed()
            .filter(|t| {
                self.now() - t.last_seen <= RECENTLY_SEEN_S && t.position().dist(of) <= within
            })
            .min_by(|a, b| a.position().dist(of).total_cmp(&b.position().dist(of)))
            .map(|t| t.position())
    }

    /// The confirmed flame seen within `RECENTLY_SEEN_S` that the detector is most
    /// confident of (ties: the nearest).
    pub fn most_confident_flame(&self) -> Option<Point2> {
        let at = self.pose().position();
        let tunnel = &self.scenario.tunnel;
        self.tracker
            .confirmed()
            .filter(|t| self.now() - t.last_seen <= RECENTLY_SEEN_S)
            .filter(|t| {
                self.mission
                    .permits(tunnel, UnitKind::Ground, at, t.position(), true)
            })
            .max_by(|a, b| {
                a.confidence
                    .total_cmp(&b.confidence)
                    .then(b.position().dist(at).total_cmp(&a.position().dist(at)))
            })
            .map(|t| t.position())
    }

    /// Cruise goal: the coordinator's, or else the patrol's (`patrol_goal`), stopped short
    /// of barred space.
    pub fn cruise_goal(&self) -> Point2 {
        match self.mission.task {
            Some((_, TaskKind::Cruise { goal } | TaskKind::Search { goal })) => goal,
            _ => {
                let Some(barred) = &self.mission.barred else {
                    return self.patrol_goal;
                };
                let t = &self.scenario.tunnel;
                let to = barred.reach(
                    UnitKind::Ground,
                    t.chainage(self.pose().position()),
                    t.chainage(self.patrol_goal),
                    CLEAR_OF_BARRED_M,
                );
                t.point_at(to, t.station(self.patrol_goal).d)
            }
        }
    }

    /// Start driving to `goal`; false if no path exists. A goal on a blocked cell (a
    /// cruise goal the coordinator set in a lane a parked car stands in) is moved to the
    /// nearest free point within `GOAL_SHIFT_M`.
    pub fn navigate(&mut self, goal: Point2, purpose: NavPurpose) -> bool {
        if self.mission.leaving {
            return false;
        }
        let prepared = self.prepared.take().filter(|p| p.spot.dist(goal) < 1e-9);
        let to = self
            .nav_grid
            .nearest_free(goal, GOAL_SHIFT_M)
            .unwrap_or(goal);
        let fire = prepared.as_ref().map(|p| p.fire);
        let path = match prepared {
            Some(p) => Some(p.route),
            None => nav::plan(&self.nav_grid, self.pose().position(), to)
                .map(|p| self.route_along(&self.hybrid_grid, p)),
        };
        match path {
            Some(p) => {
                self.nav = Some(Navigation {
                    fire,
                    ..Navigation::new(purpose, to, p)
                });
                if purpose == NavPurpose::Cruise {
                    self.cruising_to = Some(goal);
                }
                true
            }
            None => false,
        }
    }

    pub fn stop_navigation(&mut self, purpose: NavPurpose) {
        if self.nav.as_ref().is_some_and(|n| n.purpose == purpose) {
            self.nav = None;
        }
    }

    /// The goal of the cruise under way (kept after arrival), if any.
    pub fn cruising_to(&self) -> Option<Point2> {
        self.cruising_to
    }

    /// Whether the navigation for `purpose` under way failed: after getting clear of what
    /// the body touched, no path to its goal was left. It never arrives, so the tree must
    /// ask this beside [`Self::arrived`].
    pub fn navigation_failed(&self, purpose: NavPurpose) -> bool {
        self.nav
            .as_ref()
            .is_some_and(|n| n.purpose == purpose && n.failed)
    }

    pub fn nav_purpose(&self) -> Option<NavPurpose> {
        self.nav.as_ref().map(|n| n.purpose)
    }

    /// Arrived at the current navigation goal (the way out of barred space is not one
    /// the tree set).
    pub fn arrived(&self) -> bool {
        self.nav
            .as_ref()
            .is_some_and(|n| n.arrived && n.purpose != NavPurpose::Leave)
    }

    /// A Hybrid A* route over `grid` from the unit to the cheapest to reach of `spots`,
    /// arriving facing `target` and keeping it in view; the spot and the route, or `None`
    /// if the search finds none within budget.
    fn hybrid_route(
        &self,
        grid: &Grid,
        from: Point2,
        spots: &[Point2],
        target: Point2,
    ) -> Option<(Point2, Route)> {
        let planner = self.hybrid_planner(grid);
        let start = Pose2::new(from.x, from.y, self.pose().yaw);
        // Plan to a pose short of each spot and finish on a straight run-in: a follower
        // settles its heading on a straight, while on the end of a curve it lags behind
        // the path by degrees. The longest run-in there is room for; none at worst.
        let goals: Vec<Pose2> = spots
            .iter()
            .map(|&spot| {
                let facing = spot.bearing_to(target);
                let back = |d: f64| {
                    let p = spot.offset(facing + std::f64::consts::PI, d);
                    Pose2::new(p.x, p.y, facing)
                };
                RUN_IN_M
                    .into_iter()
                    .find(|&len| {
                        (0..=8).all(|k| planner.pose_free(&back(len * f64::from(k) / 8.0)))
                    })
                    .map_or(back(0.0), back)
            })
            .collect();
        let plan = planner.plan_any(start, &goals, Some(target)).ok()?;
        let (spot, goal) = (spots[plan.goal], goals[plan.goal]);
        // A point every half metre or so is plenty for pure pursuit.
        let mut route = Route::from_poses(&plan.poses, &plan.reverse, 2);
        if goal.position() != spot {
            route.push_forward(spot);
        }
        Some((spot, route))
    }

    /// A grid path from the unit's position as a route: forwards, unless it sets off
    /// behind the unit; then Hybrid A* on `hybrid_grid` plans the turn round, backing where
    /// it must, to the point [`TURN_ROUND_M`] along the path, facing along it, and the
    /// route goes on forwards from there. (Pure pursuit alone, with its look-ahead point
    /// behind the vehicle, steers by the sine of an angle near 180 degrees, next to
    /// nothing: a unit sent back the way it came drove on, away from its goal, for a
    /// minute, until it ran into a parked van and wedged itself against the wall.) The
    /// path forwards if no turn is found within the planning budget.
    fn route_along(&self, hybrid_grid: &Grid, path: Vec<Point2>) -> Route {
        let pose = self.pose();
        let behind = point_along(&path, TURN_ROUND_M).is_some_and(|(_, turned)| {
            wrap_angle(pose.position().bearing_to(turned) - pose.yaw).abs() > FRAC_PI_2
        });
        if behind {
            self.manoeuvre_along(hybrid_grid, path, TURN_ROUND_M)
        } else {
            Route::forward(path)
        }
    }

    /// A grid path from the unit's position as a route that starts with a manoeuvre:
    /// Hybrid A* on `hybrid_grid` plans the way, backing where it must, to the point `d`
    /// along the path, facing along it, and the route goes on forwards from there. The
    /// path forwards if no manoeuvre is found within the planning budget.
    fn manoeuvre_along(&self, hybrid_grid: &Grid, path: Vec<Point2>, d: f64) -> Route {
        let Some((next, to)) = point_along(&path, d) else {
            return Route::forward(path);
        };
        let after = path[next];
        if to.dist(after) < 1e-9 {
            return Route::forward(path);
        }
        let goal = Pose2::new(to.x, to.y, to.bearing_to(after));
        let planner = self.hybrid_planner(hybrid_grid);
        let Ok(plan) = planner.plan(self.pose(), goal, None) else {
            return Route::forward(path);
        };
        let mut route = Route::from_poses(&plan.poses, &plan.reverse, 2);
        for &p in &path[next..] {
            route.push_forward(p);
        }
        route
    }

    /// Hybrid A* for this vehicle over `grid`, within the planning budget, away from the
    /// heat of every flame the unit tracks.
    fn hybrid_planner<'g>(&self, grid: &'g Grid) -> HybridAStar<'g> {
        let mut params = Params::for_radius(self.spec.min_turn_radius_m());
        params.lambda_m = self.visibility_lambda_m;
        params.max_expansions = HYBRID_BUDGET;
        let footprint = Footprint {
            length_m: self.spec.length_m,
            width_m: self.spec.width_m,
        };
        // Every flame the unit tracks radiates, the one it is sent to included.
        let heat = self
            .tracker
            .confirmed()
            .map(|t| HeatSource {
                at: t.position(),
                hrr_kw: t.hrr_kw,
            })
            .collect();
        HybridAStar::new(grid, footprint, params).with_heat(heat)
    }

    /// Choose a firing position for a fire at `target` and prepare the path to it: free for
    /// the vehicle, with line of sight and a jet solution under the ceiling, arriving along
    /// the line towards the fire so that the camera faces it.
    ///
    /// On the side the task names (upwind while the air moves: the unit drives round the
    /// fire to it if it came from downwind); if no spot there can be reached, on the unit's
    /// own side after all: an attack from downwind beats none. A fire reported inside a
    /// parked vehicle is fought at the vehicle's nearest face.
    pub fn firing_position(&mut self, target: Point2) -> Option<Point2> {
        let target = self.scenario.fightable_at(target);
        let (spot, route) = self.firing_route(target, &self.nav_grid, &self.hybrid_grid)?;
        self.prepared = Some(Prepared {
            fire: target,
            spot,
            route,
        });
        Some(spot)
    }

    /// A firing position for a fire at `target` and the route to it, planned on the
    /// navigation grid `nav` and the Hybrid A* grid `hybrid` (the unit's own, or those
    /// with the other units it sees laid on them): on the side the task names if one
    /// there can be reached, else on either.
    fn firing_route(&self, target: Point2, nav: &Grid, hybrid: &Grid) -> Option<(Point2, Route)> {
        let side = self.mission.approach();
        (side != Approach::Either)
            .then(|| self.firing_route_from(target, side, nav, hybrid))
            .flatten()
            .or_else(|| self.firing_route_from(target, Approach::Either, nav, hybrid))
    }

    fn firing_route_from(
        &self,
        target: Point2,
        side: Approach,
        nav: &Grid,
        hybrid: &Grid,
    ) -> Option<(Point2, Route)> {
        let from = self.pose().position();
        let t = &self.scenario.tunnel;
        let axis = t.heading_at(t.chainage(target));
        // Spots on the unit's side of the fire (or the side asked for): towards the unit
        // where it can see the fire's spot, else back along the road (round a bend the
        // straight line to the unit runs through the wall).
        let towards_start = match side {
            Approach::Start => true,
            Approach::End => false,
            Approach::Either => t.chainage(from) < t.chainage(target),
        };
        let home = if side == Approach::Either && t.segment_inside(target, from) {
            target.bearing_to(from)
        } else if towards_start {
            axis + std::f64::consts::PI
        } else {
            axis
        };
        // Straight towards the unit first, then alternately either side, 20 deg steps, and
        // last straight past the fire: a fire at the far end of a train is fought from
        // beyond it, the walkway beside the train the way there.
        let offsets = std::iter::once(0.0)
            .chain((1..=8).flat_map(|k| {
                let a = f64::from(k) * 0.35;
                [a, -a]
            }))
            .chain(std::iter::once(std::f64::consts::PI));
        let mut spots = offsets
            .flat_map(|off| STANDOFF_M.map(|r| (off, r, target.offset(home + off, r))))
            .filter(|&(_, _, spot)| {
                nav.free(spot)
                    && !self.unit_on(spot)
                    && self.sight_grid.segment_free(spot, target)
                    && self.firing_solution(spot, target).is_ok()
            });
        // A kinematically feasible path that arrives facing the flame and keeps it in
        // view, backing where it must (say, to turn round in a narrow bore), to the
        // cheapest to reach of the best few spots: one is often out of reach (beside a
        // car parked askew, say), and one search to all of them costs less than one each.
        // Else the grid path, with a lead-in along the line to the fire where there is
        // room.
        let best: Vec<Point2> = spots
            .clone()
            .take(HYBRID_SPOTS)
            .map(|(_, _, spot)| spot)
            .collect();
        self.hybrid_route(hybrid, from, &best, target).or_else(|| {
            spots.find_map(|(off, r, spot)| {
                let lead_in = target.offset(home + off, r + 2.5);
                let path = if nav.free(lead_in) && nav.segment_free(lead_in, spot) {
                    nav::plan(nav, from, lead_in).map(|mut p| {
                        p.push(spot);
                        p
                    })
                } else {
                    nav::plan(nav, from, spot)
                };
                Some((spot, self.route_along(hybrid, path?)))
            })
        })
    }

    /// The shot from a nozzle above `from` onto the road at `target`: the low arc if it is
    /// within the cannon's elevation limits and clears the ceiling and the parked vehicles,
    /// else the high arc, else none.
    pub fn firing_solution(
        &self,
        from: Point2,
        target: Point2,
    ) -> Result<aim::Shot, aim::NoSolution> {
        let (d, h, az) = (
            from.dist(target),
            self.spec.cannon_height_m,
            from.bearing_to(target),
        );
        let t = &self.scenario.tunnel;
        let (lo, hi) = (self.spec.cannon_tilt_min_rad, self.spec.cannon_tilt_max_rad);
        aim::solve(&self.spec.nozzle, d, -h, |th, v| {
            if !(lo..=hi).contains(&th) {
                return false;
            }
            // Sample the arc every 0.25 m up to half a metre short of the target (which is
            // on the road, beside whatever burns).
            let n = ((d - 0.5) / 0.25).ceil().max(1.0) as usize;
            (1..=n).all(|k| {
                let x = (d - 0.5) * k as f64 / n as f64;
                let z = h + aim::height_at(x, th, v);
                let p = from.offset(az, x);
                z < t.height_m - JET_CEILING_MARGIN_M
                    && t.contains(p, 0.0)
                    && !self
                        .scenario
                        .obstacles
                        .iter()
                        .any(|o| z <= o.height_m && o.footprint_contains(p, 0.0))
            })
        })
    }

    /// Cannon set-points that land the jet on `target`, or `None` with no firing solution.
    pub fn aim_at(&self, target: Point2) -> Option<(f64, f64)> {
        let nozzle = self.pose().position();
        let pan = wrap_angle(nozzle.bearing_to(target) - self.pose().yaw).clamp(
            -self.spec.cannon_pan_limit_rad,
            self.spec.cannon_pan_limit_rad,
        );
        let shot = self.firing_solution(nozzle, target).ok()?;
        Some((pan, shot.elevation))
    }

    /// The hottest the road reads around `fire` in the newest thermal frame, K: the fuel
    /// bed a knocked-down fire leaves ([`thermal::road_hottest_k`]). `None` on a unit with
    /// no thermal camera, with no frame in the last [`BED_FRAME_FRESH_S`], or with the bed
    /// out of view.
    pub fn bed_k(&self, fire: Point2) -> Option<f64> {
        let optics = self.spec.thermal_camera.as_ref()?;
        let (image, eye, t) = self.thermal_view.as_ref()?;
        if self.now() - t > BED_FRAME_FRESH_S {
            return None;
        }
        thermal::road_hottest_k(image, optics, eye, fire, BED_LOOK_M)
    }

    /// The cannon is at its set-point.
    pub fn on_target(&self) -> bool {
        self.aim.is_some_and(|(p, t)| {
            (self.frame.cannon.pan - p).abs() < AIM_TOLERANCE_RAD
                && (self.frame.cannon.tilt - t).abs() < AIM_TOLERANCE_RAD
        })
    }
}

/// How far the navigation grid grows what blocks it: the circle round the vehicle and
/// [`NAV_MARGIN_M`], so that a centre on a free cell leaves the body clear.
fn nav_growth_m(spec: &GroundSpec) -> f64 {
    spec.circumradius_m() + NAV_MARGIN_M
}

/// Where a unit that starts at `start` patrols to on its own: 10 m short of the far end of
/// the tunnel, in the lane it starts in. The far end from where it starts, not from where
/// it is (a goal that flipped at the middle would turn it round there): a unit that comes
/// in at either portal sweeps the whole bore.
fn patrol_goal(t: &Tunnel, start: Point2) -> Point2 {
    let at = t.station(start);
    let end = if at.s.m() < t.length_m / 2.0 {
        t.end() - 10.0
    } else {
        Chainage::new(10.0)
    };
    t.point_at(end, t.lane_nearest(at.d))
}

impl Responder for Unit {
    fn id(&self) -> &UnitId {
        &self.id
    }
    fn kind(&self) -> UnitKind {
        UnitKind::Ground
    }
    fn tunnel(&self) -> &Tunnel {
        &self.scenario.tunnel
    }
    fn position(&self) -> Point2 {
        self.pose().position()
    }
    fn mission(&mut self) -> &mut Mission {
        &mut self.mission
    }
    fn flame_near(&self, of: Point2, within: f64) -> Option<Point2> {
        Unit::flame_near(self, of, within)
    }
    fn most_confident_flame(&self) -> Option<Point2> {
        Unit::most_confident_flame(self)
    }
    fn stand_down(&mut self) {
        self.valve = false;
        self.aim = None;
        self.stop_navigation(NavPurpose::Fire);
    }
}

impl Services for Unit {
    type Sensors = UnitSensors;
    type Command = UnitCommand;

    /// Take in a new sensor frame, finding flames in its thermal image if it has one.
    fn sense(&mut self, frame: &UnitSensors) {
        self.found = match (&frame.thermal, &self.spec.thermal_camera) {
            (Some(image), Some(optics)) => Some(self.thermal.detect(image, optics)),
            _ => None,
        };
        let thermal = self.found.as_deref().unwrap_or_default();
        self.tracker.update(&self.spec, frame, thermal);
        if let Some(r) = self.nav.as_mut().and_then(|n| n.recover.as_mut()) {
            r.saw(frame.speed);
        }
        if frame.collided
            && let Some(n) = &mut self.nav
        {
            n.recover = Some(Recovery::after(n.recover, frame.t, self.moved));
        }
        if frame.speed != 0.0 {
            self.moved = frame.speed.signum();
        }
        self.frame = frame.clone();
        self.remember_look();
        // The image is the detector's and the bed reading's; the frame is kept for its
        // readings.
        if let (Some(image), Some(optics)) = (self.frame.thermal.take(), &self.spec.thermal_camera)
        {
            let eye = optics.looking_from(&frame.pose, frame.cannon.pan);
            self.thermal_view = Some((image, eye, frame.t));
        }
        self.keep_out();
    }

    /// Actuator set-points for this step: the navigation service drives, the cannon holds
    /// its aim, the valve follows the request.
    fn command(&mut self) -> UnitCommand {
        let f = &self.frame;
        // Aiming, scanning, or parked straight ahead (the camera rides on the cannon).
        let (mut pan, tilt) = self
            .aim
            .or(self.scan.map(|p| (p, 0.0)))
            .unwrap_or((0.0, 0.0));
        if self.valve {
            pan += self.sweep_rad * (std::f64::consts::TAU * f.t / SWEEP_PERIOD_S).sin();
        }
        let mut cmd = UnitCommand {
            speed: 0.0,
            steer: 0.0,
            pan,
            tilt,
            valve_open: self.valve && f.water_l > 0.0,
        };
        let (pose, speed, steer, now, spec) = (f.pose, f.speed, f.steer, f.t, self.spec);
        // Getting clear does not move into barred space (a unit already inside does, on its
        // way out). Looked at only while recovering: this runs on every frame.
        let toward_barred = self.nav.as_ref().and_then(|n| n.recover).is_some_and(|r| {
            let back = if r.speed < 0.0 {
                std::f64::consts::PI
            } else {
                0.0
            };
            self.in_barred(pose.position().offset(pose.yaw + back, 1.0))
        });
        let Some(n) = &self.nav else { return cmd };
        if n.arrived || n.failed {
            return cmd;
        }
        if let Some(r) = n.recover {
            let moving_in = n.purpose != NavPurpose::Leave && toward_barred;
            if now < r.until && !moving_in {
                cmd.speed = r.speed;
                return cmd;
            }
            let (grid, hybrid) = if n.purpose == NavPurpose::Leave {
                (&self.open_nav_grid, &self.open_hybrid_grid)
            } else {
                (&self.nav_grid, &self.hybrid_grid)
            };
            let route =
                nav::plan(grid, pose.position(), n.goal).map(|p| self.route_along(hybrid, p));
            let Some(n) = &mut self.nav else { return cmd };
            n.recover = None;
            match route {
                Some(route) => n.follow = PurePursuit::new(route),
                None => {
                    tracing::warn!(unit = %self.id, goal = ?n.goal, "no path after recovering; navigation failed");
                    n.failed = true;
                    return cmd;
                }
            }
        }
        let Some(n) = &mut self.nav else { return cmd };
        match n.follow.follow(&pose, speed, steer, &spec) {
            Follow::Drive { speed, steer } => {
                cmd.steer = steer;
                let n = &self.nav.as_ref().expect("navigating").follow;
                let blocker = (speed != 0.0)
                    .then(|| self.unit_in_the_way(n, speed))
                    .flatten()
                    .copied();
                if let Some(by) = blocker {
                    self.held(&by);
                } else {
                    self.unheld();
                    cmd.speed = speed;
                }
            }
            Follow::Arrived => n.arrived = true,
        }
        cmd
    }

    /// The unit's state for the bus.
    fn state(&self) -> UnitState {
        let f = &self.frame;
        let mode = if f.water_l <= 0.0 {
            UnitMode::Fault
        } else if self.valve || self.aim.is_some() {
            UnitMode::Extinguishing
        } else {
            match self.nav_purpose() {
                Some(NavPurpose::Fire) => UnitMode::Navigating,
                Some(NavPurpose::Cruise | NavPurpose::Leave) if !self.arrived() => {
                    UnitMode::Cruising
                }
                _ => UnitMode::Idle,
            }
        };
        let task = self.mission.progress(mode == UnitMode::Extinguishing);
        UnitState {
            unit: self.id.clone(),
            kind: UnitKind::Ground,
            t: f.t,
            pose: f.pose,
            speed: f.speed,
            mode,
            water_l: f.water_l.max(0.0),
            health: 1.0,
            heat_flux_kw_m2: f.heat_flux_kw_m2,
            task,
            autonomous: !self.mission.coordinator_present,
            refused: self.mission.refused.clone(),
            task_seq: self.mission.task.map(|(seq, _)| seq),
            epoch: self.mission.task.map(|_| self.mission.epoch),
        }
    }

    fn found(&self) -> Option<&[FlameDetection]> {
        self.found.as_deref()
    }

    /// Flames seen since the last report, if any.
    fn report(&mut self) -> Option<FlameReport> {
        let observations = self.tracker.observations(self.last_report_t);
        self.last_report_t = self.frame.t;
        (!observations.is_empty()).then(|| FlameReport {
            unit: self.id.clone(),
            t: self.frame.t,
            observer: self
                .spec
                .camera
                .looking_from(&self.frame.pose, self.frame.cannon.pan),
            observations,
        })
    }

    fn barred_changed(&mut self) {
        self.lay_keepout();
        self.keep_out();
    }

    fn time(s: &UnitSensors) -> f64 {
        s.t
    }

    fn halt(s: &UnitSensors) -> UnitCommand {
        UnitCommand::halt(&s.cannon)
    }
}

#[cfg(test)]
mod tests;
