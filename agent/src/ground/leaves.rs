//! The ground unit's behavior-tree leaves: the paper's Algorithm 1 nodes, registered for the
//! [`Unit`] context with the coordinator-link leaves every unit shares
//! ([`crate::mission`]).
//!
//! Leaves are thin: they read and set the unit's services (navigation, cannon, tracker,
//! coordinator link) and the blackboard. They never block; anything that takes time runs
//! in a service and is polled (`IsArrival`, `StartWaterCannon`), as the paper's leaves poll
//! Autoware and the cannon driver.
//!
//! Not here: the trees that arrange them (`agent/trees/*.xml`) or the services they drive
//! ([`super::unit`]).

use firefleet_bt::node::Io;
use firefleet_bt::{Leaf, Port, Registry, StatefulAction, Status};
use firefleet_model::Point2;
use firefleet_protocol::msg::TaskKind;

use crate::ground::unit::{NavPurpose, Unit};

fn p(v: [f64; 2]) -> Point2 {
    Point2::new(v[0], v[1])
}

fn ok(b: bool) -> Status {
    if b { Status::Success } else { Status::Failure }
}

/// A point on the blackboard: `[x, y]` in the site frame.
type At = [f64; 2];

const CRUISE_GOAL: Port<At> = Port::output("goal", "cruise goal: the far end of the current lane");
const CRUISE_TO: Port<At> = Port::input("goal", "where to cruise to");
const FIRE_AS_SEEN: Port<At> = Port::inout("fire", "the fire, moved to where it is seen");
const SAME_FIRE_WITHIN: Port<f64> = Port::input(
    "within_m",
    "a flame seen this close to the fire is that fire",
)
.with_default("5.0");
const MOVED: Port<f64> = Port::input(
    "moved_m",
    "the fire has moved when seen further than this from where it was",
)
.with_default("1.5");
const FIRE: Port<At> = Port::input("fire", "the fire");
const FIRING_POSITION: Port<At> = Port::output("target", "the firing position");
const DRIVE_TO: Port<At> = Port::input("goal", "where to drive");
const PAN_TO_FIRE: Port<f64> = Port::output("pan", "cannon pan to the fire, rad");
const TILT_TO_FIRE: Port<f64> =
    Port::output("tilt", "cannon elevation landing the jet on the fire, rad");
const WANTED_PAN: Port<f64> = Port::input("pan", "wanted pan, rad");
const WANTED_TILT: Port<f64> = Port::input("tilt", "wanted tilt, rad");
const AIM_THRESHOLD: Port<f64> =
    Port::input("threshold_rad", "re-aim when the set-point is off by more").with_default("0.02");
const PAN: Port<f64> = Port::input("pan", "pan, rad");
const TILT: Port<f64> = Port::input("tilt", "elevation, rad");
const SCAN_AMPLITUDE: Port<f64> =
    Port::input("amplitude_rad", "sweep either side of straight ahead").with_default("1.5");

const COOLING: Port<i64> = Port::input(
    "msec",
    "keep spraying this long after the flame is gone and after the fuel bed last read hot",
)
.with_default("3000");
const COOLING_LIMIT: Port<i64> = Port::input(
    "limit_msec",
    "stop cooling after this long, whatever the bed reads",
)
.with_default("60000");
const BED_COOL_BELOW: Port<f64> = Port::input(
    "below_k",
    "the fuel bed is cool once the road around the fire reads under this, K",
)
// 200 C: 100 K under the surface temperature at which wood and char re-ignite under a
// pilot (about 300 C), for a bed seen at a slant, through the water standing on it.
.with_default("473.15");

/// Opens the valve once the cannon is on its set-point (Running while it slews).
struct StartWaterCannon;

impl StatefulAction<Unit> for StartWaterCannon {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut Unit) -> Status {
        self.on_running(io, u)
    }
    fn on_running(&mut self, _: &mut Io<'_>, u: &mut Unit) -> Status {
        if u.aim.is_none() {
            return Status::Failure;
        }
        if u.on_target() {
            u.valve = true;
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut Unit) {}
}

/// Sweeps the cannon, and the camera riding on it, left and right to look for fire: a
/// triangle wave of +-`amplitude_rad` at just under the pan slew rate. Runs until halted
/// (put it behind a FireDetection in a ReactiveFallback).
struct ScanForFire {
    since: f64,
}

impl StatefulAction<Unit> for ScanForFire {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut Unit) -> Status {
        self.since = u.now();
        self.on_running(io, u)
    }
    fn on_running(&mut self, io: &mut Io<'_>, u: &mut Unit) -> Status {
        let amplitude = io
            .get(&SCAN_AMPLITUDE)
            .unwrap_or(1.5)
            .clamp(0.0, u.spec.cannon_pan_limit_rad);
        let period = 4.0 * amplitude / (0.9 * u.spec.cannon_pan_rate_rad_s);
        // Phase 0 at the centre, heading left first.
        let phase = ((u.now() - self.since) / period + 0.25).fract();
        let tri = if phase < 0.5 {
            4.0 * phase - 1.0
        } else {
            3.0 - 4.0 * phase
        };
        u.scan = Some(amplitude * tri);
        Status::Running
    }
    fn on_halted(&mut self, _: &mut Io<'_>, u: &mut Unit) {
        u.scan = None;
    }
}

/// The cooling pass after a knock-down: keeps the jet on the fire's fuel bed until `msec`
/// have passed with the bed not read hot (under `below_k` in the thermal camera's
/// frames), then Success; Success after `limit_msec` whatever it reads (a tank is
/// finite, and a bed that stays hot that long is the coordinator's to send help to), and
/// at once when the tank is empty (nothing left to spray; the unit's state says so, and
/// the coordinator relieves it). A unit with no thermal camera reads nothing: a fixed pass
/// of `msec`, the BT paper's.
struct CoolBed {
    since: f64,
    cool_since: f64,
}

impl StatefulAction<Unit> for CoolBed {
    fn on_start(&mut self, io: &mut Io<'_>, u: &mut Unit) -> Status {
        self.since = u.now();
        self.cool_since = u.now();
        self.on_running(io, u)
    }
    fn on_running(&mut self, io: &mut Io<'_>, u: &mut Unit) -> Status {
        let (Ok(fire), Ok(msec), Ok(limit), Ok(below)) = (
            io.get(&FIRE),
            io.get(&COOLING),
            io.get(&COOLING_LIMIT),
            io.get(&BED_COOL_BELOW),
        ) else {
            return Status::Failure;
        };
        let now = u.now();
        if u.bed_k(p(fire)).is_some_and(|k| k >= below) {
            self.cool_since = now;
        }
        let ms = |s: f64| (s * 1000.0) as i64;
        if ms(now - self.cool_since) >= msec || ms(now - self.since) >= limit || u.tank_empty() {
            Status::Success
        } else {
            Status::Running
        }
    }
    fn on_halted(&mut self, _: &mut Io<'_>, _: &mut Unit) {}
}

/// Every leaf the ground unit's trees may use.
pub fn registry() -> Registry<Unit> {
    let mut r = Registry::new();
    crate::mission::register(&mut r);

    r.register(
        "SetGoal",
        vec![CRUISE_GOAL.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| {
                let g = u.cruise_goal();
                ok(io.set(&CRUISE_GOAL, [g.x, g.y]).is_ok())
            }
        }),
    );
    r.register(
        "StartCruise",
        vec![CRUISE_TO.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| match io.get(&CRUISE_TO) {
                Ok(g) => ok(u.navigate(p(g), NavPurpose::Cruise)),
                Err(_) => Status::Failure,
            }
        }),
    );
    r.register(
        "IsArrival",
        vec![],
        Leaf::condition(|| |_: &mut Io<'_>, u: &mut Unit| ok(u.arrived())),
    );
    // A navigation that failed never arrives: the fire branch asks this beside IsArrival
    // and plans again, then gives the fire up (ErrorHandling tells the coordinator).
    // Before, IsArrival was retried for ever and the unit held its fire standing still.
    r.register(
        "IsNavigationFailed",
        vec![],
        Leaf::condition(
            || |_: &mut Io<'_>, u: &mut Unit| ok(u.navigation_failed(NavPurpose::Fire)),
        ),
    );
    // No cruise under way is a change too: a keep-out that stopped the cruise under the
    // tree (the unit leaving barred space) left the tree waiting for an arrival that
    // could never come, and the unit idle for good once the keep-out was lifted. So is a
    // cruise whose navigation failed: the cruise starts again and plans afresh.
    r.register(
        "CruiseGoalUnchanged",
        vec![],
        Leaf::condition(|| {
            |_: &mut Io<'_>, u: &mut Unit| {
                ok(!u.navigation_failed(NavPurpose::Cruise)
                    && u.cruising_to()
                        .is_some_and(|g| g.dist(u.cruise_goal()) < 0.5))
            }
        }),
    );
    r.register(
        "IsSearching",
        vec![],
        Leaf::condition(|| {
            |_: &mut Io<'_>, u: &mut Unit| {
                ok(matches!(u.mission.task, Some((_, TaskKind::Search { .. }))))
            }
        }),
    );
    r.register(
        "StopCruise",
        vec![],
        Leaf::action(|| {
            |_: &mut Io<'_>, u: &mut Unit| {
                u.stop_navigation(NavPurpose::Cruise);
                Status::Success
            }
        }),
    );
    r.register(
        "FireWhereExpected",
        vec![FIRE_AS_SEEN.spec(), SAME_FIRE_WITHIN.spec(), MOVED.spec()], Leaf::action(|| {
            // Success while the fire is where the blackboard says (or not in view); a fire
            // seen elsewhere is written back and the leaf fails, so that a retry around the
            // navigation plans again to the fire as it now is. The coordinator's estimate
            // comes from units that saw it from afar; the unit's own camera, closing in,
            // does better.
            |io: &mut Io<'_>, u: &mut Unit| {
                let (Ok(f), Ok(within), Ok(moved)) = (
                    io.get(&FIRE_AS_SEEN),
                    io.get(&SAME_FIRE_WITHIN),
                    io.get(&MOVED),
                )
                else {
                    return Status::Failure;
                };
                match u.flame_near(p(f), within) {
                    Some(seen) if seen.dist(p(f)) > moved => {
                        tracing::info!(unit = %u.id, from = ?f, to = ?seen, "the fire is not where expected; planning again");
                        let _ = io.set(&FIRE_AS_SEEN, [seen.x, seen.y]);
                        Status::Failure
                    }
                    _ => Status::Success,
                }
            }
        }),
    );
    r.register(
        "SetTargetToFire",
        vec![FIRE.spec(), FIRING_POSITION.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| {
                let Ok(f) = io.get(&FIRE) else {
                    return Status::Failure;
                };
                match u.firing_position(p(f)) {
                    Some(t) => ok(io.set(&FIRING_POSITION, [t.x, t.y]).is_ok()),
                    None => {
                        tracing::warn!(unit = %u.id, fire = ?f, "no reachable firing position");
                        Status::Failure
                    }
                }
            }
        }),
    );
    r.register(
        "StartNavigation",
        vec![DRIVE_TO.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| match io.get(&DRIVE_TO) {
                Ok(g) => ok(u.navigate(p(g), NavPurpose::Fire)),
                Err(_) => Status::Failure,
            }
        }),
    );
    r.register(
        "ComputeRelativePosition",
        vec![FIRE.spec(), PAN_TO_FIRE.spec(), TILT_TO_FIRE.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| {
                let Ok(f) = io.get(&FIRE) else {
                    return Status::Failure;
                };
                // Re-aim at the flame as the camera sees it now.
                let target = u.aim_point(p(f));
                u.sweep_over(target);
                match u.aim_at(target) {
                    Some((pan, tilt)) => ok(
                        io.set(&PAN_TO_FIRE, pan).is_ok() && io.set(&TILT_TO_FIRE, tilt).is_ok()
                    ),
                    None => Status::Failure,
                }
            }
        }),
    );
    r.register(
        "RelativePosAboveThreshold",
        vec![WANTED_PAN.spec(), WANTED_TILT.spec(), AIM_THRESHOLD.spec()],
        Leaf::condition(|| {
            |io: &mut Io<'_>, u: &mut Unit| {
                let (Ok(pan), Ok(tilt), Ok(th)) = (
                    io.get(&WANTED_PAN),
                    io.get(&WANTED_TILT),
                    io.get(&AIM_THRESHOLD),
                ) else {
                    return Status::Failure;
                };
                ok(u.aim
                    .is_none_or(|(p0, t0)| (p0 - pan).abs() > th || (t0 - tilt).abs() > th))
            }
        }),
    );
    r.register(
        "AimWaterCannon",
        vec![PAN.spec(), TILT.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut Unit| match (io.get(&PAN), io.get(&TILT)) {
                (Ok(pan), Ok(tilt)) => {
                    u.aim = Some((pan, tilt));
                    Status::Success
                }
                _ => Status::Failure,
            }
        }),
    );
    r.register(
        "ScanForFire",
        vec![SCAN_AMPLITUDE.spec()],
        Leaf::stateful(|| ScanForFire { since: 0.0 }),
    );
    r.register(
        "IsCannonNotStarted",
        vec![],
        Leaf::condition(|| |_: &mut Io<'_>, u: &mut Unit| ok(!u.valve)),
    );
    r.register(
        "StartWaterCannon",
        vec![],
        Leaf::stateful(|| StartWaterCannon),
    );
    r.register(
        "FireInView",
        vec![FIRE.spec()],
        // Success while the unit's cameras have faced the fire long enough to have seen a
        // flame there ([`Unit::has_watched`]): what makes "no flame near it" a knock-down.
        Leaf::condition(|| {
            |io: &mut Io<'_>, u: &mut Unit| match io.get(&FIRE) {
                Ok(f) => ok(u.has_watched(p(f))),
                Err(_) => Status::Failure,
            }
        }),
    );
    r.register(
        "CoolBed",
        vec![
            FIRE.spec(),
            COOLING.spec(),
            COOLING_LIMIT.spec(),
            BED_COOL_BELOW.spec(),
        ],
        Leaf::stateful(|| CoolBed {
            since: 0.0,
            cool_since: 0.0,
        }),
    );
    r.register(
        "StopWaterCannon",
        vec![],
        Leaf::action(|| {
            |_: &mut Io<'_>, u: &mut Unit| {
                u.valve = false;
                u.aim = None;
                Status::Success
            }
        }),
    );
    r
}
