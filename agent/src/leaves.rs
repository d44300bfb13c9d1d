//! The ground unit's behavior-tree leaves: the paper's Algorithm 1 nodes, registered for the
//! [`Unit`] context with the coordinator-link leaves every unit shares
//! ([`crate::mission`]).
//!
//! Leaves are thin: they read and set the unit's services (navigation, cannon, tracker,
//! coordinator link) and the blackboard. They never block; anything that takes time runs
//! in a service and is polled (`IsArrival`, `StartWaterCannon`), as the paper's leaves poll
//! Autoware and the cannon driver.

use firefleet_bt::node::Io;
use firefleet_bt::{PortSpec, PortType, Registry, StatefulAction, Status};
use firefleet_protocol::Point2;
use firefleet_protocol::msg::TaskKind;

use crate::unit::{NavPurpose, Unit};

fn p(v: [f64; 2]) -> Point2 {
    Point2::new(v[0], v[1])
}

fn ok(b: bool) -> Status {
    if b { Status::Success } else { Status::Failure }
}

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
            .get::<f64>(0)
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

/// Every leaf the ground unit's trees may use.
pub fn registry() -> Registry<Unit> {
    use PortType::{Double, Point};
    let mut r = Registry::new();
    crate::mission::register(&mut r);

    r.register_action(
        "SetGoal",
        vec![PortSpec::output(
            "goal",
            Point,
            "cruise goal: the far end of the current lane",
        )],
        || {
            |io: &mut Io<'_>, u: &mut Unit| {
                let g = u.cruise_goal();
                ok(io.set(0, [g.x, g.y]).is_ok())
            }
        },
    );
    r.register_action(
        "StartCruise",
        vec![PortSpec::input("goal", Point, "where to cruise to")],
        || {
            |io: &mut Io<'_>, u: &mut Unit| match io.get::<[f64; 2]>(0) {
                Ok(g) => ok(u.navigate(p(g), NavPurpose::Cruise)),
                Err(_) => Status::Failure,
            }
        },
    );
    r.register_condition("IsArrival", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| ok(u.arrived())
    });
    r.register_condition("CruiseGoalUnchanged", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| {
            ok(u.cruising_to()
                .is_none_or(|g| g.dist(u.cruise_goal()) < 0.5))
        }
    });
    r.register_condition("IsSearching", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| {
            ok(matches!(u.mission.task, Some((_, TaskKind::Search { .. }))))
        }
    });
    r.register_action("StopCruise", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| {
            u.stop_navigation(NavPurpose::Cruise);
            Status::Success
        }
    });
    r.register_action(
        "FireWhereExpected",
        vec![
            PortSpec::inout("fire", Point, "the fire, moved to where it is seen"),
            PortSpec::input(
                "within_m",
                Double,
                "a flame seen this close to the fire is that fire",
            )
            .with_default("5.0"),
            PortSpec::input(
                "moved_m",
                Double,
                "the fire has moved when seen further than this from where it was",
            )
            .with_default("1.5"),
        ],
        || {
            // Success while the fire is where the blackboard says (or not in view); a fire
            // seen elsewhere is written back and the leaf fails, so that a retry around the
            // navigation plans again to the fire as it now is. The coordinator's estimate
            // comes from units that saw it from afar; the unit's own camera, closing in,
            // does better.
            |io: &mut Io<'_>, u: &mut Unit| {
                let (Ok(f), Ok(within), Ok(moved)) =
                    (io.get::<[f64; 2]>(0), io.get::<f64>(1), io.get::<f64>(2))
                else {
                    return Status::Failure;
                };
                match u.flame_near(p(f), within) {
                    Some(seen) if seen.dist(p(f)) > moved => {
                        tracing::info!(unit = %u.id, from = ?f, to = ?seen, "the fire is not where expected; planning again");
                        let _ = io.set(0, [seen.x, seen.y]);
                        Status::Failure
                    }
                    _ => Status::Success,
                }
            }
        },
    );
    r.register_action(
        "SetTargetToFire",
        vec![
            PortSpec::input("fire", Point, "the fire"),
            PortSpec::output("target", Point, "the firing position"),
        ],
        || {
            |io: &mut Io<'_>, u: &mut Unit| {
                let Ok(f) = io.get::<[f64; 2]>(0) else {
                    return Status::Failure;
                };
                match u.firing_position(p(f)) {
                    Some(t) => ok(io.set(1, [t.x, t.y]).is_ok()),
                    None => {
                        tracing::warn!(unit = %u.id, fire = ?f, "no reachable firing position");
                        Status::Failure
                    }
                }
            }
        },
    );
    r.register_action(
        "StartNavigation",
        vec![PortSpec::input("goal", Point, "where to drive")],
        || {
            |io: &mut Io<'_>, u: &mut Unit| match io.get::<[f64; 2]>(0) {
                Ok(g) => ok(u.navigate(p(g), NavPurpose::Fire)),
                Err(_) => Status::Failure,
            }
        },
    );
    r.register_action(
        "ComputeRelativePosition",
        vec![
            PortSpec::input("fire", Point, "the fire"),
            PortSpec::output("pan", Double, "cannon pan to the fire, rad"),
            PortSpec::output(
                "tilt",
                Double,
                "cannon elevation landing the jet on the fire, rad",
            ),
        ],
        || {
            |io: &mut Io<'_>, u: &mut Unit| {
                let Ok(f) = io.get::<[f64; 2]>(0) else {
                    return Status::Failure;
                };
                // Re-aim at the flame as the camera sees it now.
                let target = u.flame_near(p(f), 3.0).unwrap_or(p(f));
                u.sweep_over(target);
                match u.aim_at(target) {
                    Some((pan, tilt)) => ok(io.set(1, pan).is_ok() && io.set(2, tilt).is_ok()),
                    None => Status::Failure,
                }
            }
        },
    );
    r.register_condition(
        "RelativePosAboveThreshold",
        vec![
            PortSpec::input("pan", Double, "wanted pan, rad"),
            PortSpec::input("tilt", Double, "wanted tilt, rad"),
            PortSpec::input(
                "threshold_rad",
                Double,
                "re-aim when the set-point is off by more",
            )
            .with_default("0.02"),
        ],
        || {
            |io: &mut Io<'_>, u: &mut Unit| {
                let (Ok(pan), Ok(tilt), Ok(th)) =
                    (io.get::<f64>(0), io.get::<f64>(1), io.get::<f64>(2))
                else {
                    return Status::Failure;
                };
                ok(u.aim
                    .is_none_or(|(p0, t0)| (p0 - pan).abs() > th || (t0 - tilt).abs() > th))
            }
        },
    );
    r.register_action(
        "AimWaterCannon",
        vec![
            PortSpec::input("pan", Double, "pan, rad"),
            PortSpec::input("tilt", Double, "elevation, rad"),
        ],
        || {
            |io: &mut Io<'_>, u: &mut Unit| match (io.get::<f64>(0), io.get::<f64>(1)) {
                (Ok(pan), Ok(tilt)) => {
                    u.aim = Some((pan, tilt));
                    Status::Success
                }
                _ => Status::Failure,
            }
        },
    );
    r.register_stateful(
        "ScanForFire",
        vec![
            PortSpec::input(
                "amplitude_rad",
                Double,
                "sweep either side of straight ahead",
            )
            .with_default("1.5"),
        ],
        || ScanForFire { since: 0.0 },
    );
    r.register_condition("IsCannonNotStarted", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| ok(!u.valve)
    });
    r.register_stateful("StartWaterCannon", vec![], || StartWaterCannon);
    r.register_action("StopWaterCannon", vec![], || {
        |_: &mut Io<'_>, u: &mut Unit| {
            u.valve = false;
            u.aim = None;
            Status::Success
        }
    });
    r
}
