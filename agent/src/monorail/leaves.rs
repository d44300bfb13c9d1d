//! The monorail unit's behavior-tree leaves, registered for the [`RailUnit`] context with
//! the coordinator-link leaves every unit shares ([`crate::mission`]).
//!
//! Not here: the kinematics and planner they drive ([`super::kinematics`], [`super::clik`],
//! [`super::planner`]) or the tree (`agent/trees/monorail_unit.xml`).

use firefleet_bt::node::Io;
use firefleet_bt::{Leaf, Port, Registry, StatefulAction, Status};
use firefleet_model::Point2;
use firefleet_protocol::msg::TaskKind;

use super::RailUnit;
use crate::monorail::planner::Phase;

const FIRE: Port<[f64; 2]> = Port::input("fire", "the fire");
const COOLING: Port<i64> = Port::input(
    "cooling_ms",
    "keep spraying this long after the last hot spot (a knocked-down fuel bed re-ignites if left hot)",
)
.with_default("3000");

fn fire(io: &Io<'_>) -> Option<Point2> {
    io.get(&FIRE).ok().map(|[x, y]| Point2::new(x, y))
}

/// Drives the jet onto the fire: Running while the carriage runs to the dock that serves
/// the fire and the planner approaches, Success once the jet point is on the fire;
/// Failure if no dock serves it.
struct ApproachAlongRail;

impl StatefulAction<RailUnit> for ApproachAlongRail {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut RailUnit) -> Status {
        let Some(f) = fire(io) else {
            return Status::Failure;
        };
        if !u.start_attack(u.flame_near(f, 3.0).unwrap_or(f)) {
            return Status::Failure;
        }
        self.on_running(io, u)
    }
    fn on_running(&mut self, _: &mut Io<'_>, u: &mut RailUnit) -> Status {
        match u.attack_phase() {
            Some(Phase::Approach) => Status::Running,
            Some(_) => Status::Success,
            None => Status::Failure,
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, u: &mut RailUnit) {
        u.stop_attack();
    }
}

/// Sweeps the fire with the valve open until no hot spot has been seen near it for the
/// cooling time, then holds the jet and shuts the valve. A fire the camera has not seen
/// during the attack (hidden from the carriage; sent by the coordinator on others' reports)
/// gets [`UNSEEN_FACTOR`] times the cooling time.
struct SprayFire {
    clear_since: Option<f64>,
    seen: bool,
}

const UNSEEN_FACTOR: f64 = 4.0;

impl StatefulAction<RailUnit> for SprayFire {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut RailUnit) -> Status {
        self.clear_since = None;
        self.seen = false;
        u.valve = true;
        self.on_running(io, u)
    }
    fn on_running(&mut self, io: &mut Io<'_>, u: &mut RailUnit) -> Status {
        let (Some(f), Ok(cooling_ms)) = (fire(io), io.get(&COOLING)) else {
            return Status::Failure;
        };
        if let Some(seen) = u.flame_near(f, 3.0) {
            self.clear_since = None;
            self.seen = true;
            // Follow the fire as the camera sees it.
            u.start_attack(seen);
            return Status::Running;
        }
        let since = *self.clear_since.get_or_insert(u.now());
        let factor = if self.seen { 1.0 } else { UNSEEN_FACTOR };
        if u.now() - since >= factor * cooling_ms as f64 / 1000.0 {
            u.fire_out();
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, u: &mut RailUnit) {
        u.stop_attack();
    }
}

/// Runs the carriage to the coordinator's search goal: Running on the way, Success there,
/// Failure without a search task.
struct SearchAlongRail;

impl StatefulAction<RailUnit> for SearchAlongRail {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut RailUnit) -> Status {
        self.on_running(io, u)
    }
    fn on_running(&mut self, _: &mut Io<'_>, u: &mut RailUnit) -> Status {
        let Some((_, TaskKind::Search { goal })) = u.mission.task else {
            u.stop_run();
            return Status::Failure;
        };
        // A new goal takes effect at once.
        u.run_to(goal);
        if u.run_done() {
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, u: &mut RailUnit) {
        u.stop_run();
    }
}

/// Every leaf the monorail unit's trees may use.
pub fn registry() -> Registry<RailUnit> {
    let mut r = Registry::new();
    crate::mission::register(&mut r);
    r.register(
        "InReach",
        vec![FIRE.spec()],
        Leaf::condition(|| {
            |io: &mut Io<'_>, u: &mut RailUnit| match fire(io) {
                Some(f) if u.in_reach(f) => Status::Success,
                _ => Status::Failure,
            }
        }),
    );
    r.register(
        "SearchAlongRail",
        vec![],
        Leaf::stateful(|| SearchAlongRail),
    );
    r.register(
        "ApproachAlongRail",
        vec![FIRE.spec()],
        Leaf::stateful(|| ApproachAlongRail),
    );
    r.register(
        "SprayFire",
        vec![FIRE.spec(), COOLING.spec()],
        Leaf::stateful(|| SprayFire {
            clear_since: None,
            seen: false,
        }),
    );
    r
}
