//! The incident's tests, by concern, and the fixtures they share.

use super::*;
use firefleet_model::geometry::{Point2, Pose2};
use firefleet_model::profile::GROUND;
use firefleet_model::scenario::Zone;
use firefleet_model::{Chainage, CommanderId, ZoneId};
use firefleet_protocol::msg::FlameObservation;
use firefleet_protocol::msg::{
    FireState, FlameReport, GoalAck, GoalKind, TaskProgress, UnitMode, ZoneGoal,
};
use firefleet_protocol::testing::ground_state;

mod dispatch;
mod events;
mod infra;
mod search;
mod staging;
mod zones;

const TUNNEL: Tunnel = Tunnel::straight(200.0, 10.0, 6.0, 2);

/// Events dated as the units would date them: at the site time they arrive, and reports
/// seen from where their unit is, of flames at any distance and bearing (these tests place
/// fires for the decisions they test; freshness and a report's placement have tests of
/// their own).
trait Dated {
    fn state_at(&mut self, st: UnitState, t: f64) -> Result<Vec<Output>, Invalid>;
    fn report_at(&mut self, r: &FlameReport, t: f64) -> Result<Vec<Output>, Invalid>;
}

impl Dated for Incident {
    fn state_at(&mut self, st: UnitState, t: f64) -> Result<Vec<Output>, Invalid> {
        self.on_state(UnitState { t, ..st }, t)
    }

    fn report_at(&mut self, r: &FlameReport, t: f64) -> Result<Vec<Output>, Invalid> {
        // Seen from where the unit is.
        let observer = self
            .units
            .get(&r.unit)
            .and_then(|v| v.state.as_ref())
            .map_or(r.observer, |s| s.pose);
        let policy = self.policy;
        self.policy.report_reach_slack_m = f64::INFINITY;
        self.policy.report_cone_slack_m = f64::INFINITY;
        let out = self.on_report(
            &FlameReport {
                t,
                observer,
                ..r.clone()
            },
            t,
        );
        self.policy = policy;
        out
    }
}

fn u(s: &str) -> UnitId {
    UnitId::new(s).unwrap()
}

fn state(unit: &str, x: f64, task: Option<TaskProgress>) -> UnitState {
    UnitState {
        task,
        ..ground_state(unit, x, -2.0)
    }
}

/// `st` as a unit that hears the coordinator sends it: echoing the number of the task it
/// was given last.
fn echoing(i: &Incident, st: UnitState) -> UnitState {
    UnitState {
        task_seq: i.units[&st.unit].task.as_ref().map(|k| k.seq),
        epoch: i.units[&st.unit].task.as_ref().map(|k| k.epoch),
        ..st
    }
}

fn report(unit: &str, x: f64) -> FlameReport {
    FlameReport {
        unit: u(unit),
        t: 0.0,
        observer: Pose2::new(x - 15.0, -2.0, 0.0),
        observations: vec![FlameObservation {
            position: Point2::new(x, 1.0),
            cov: [0.2, 0.0, 0.2],
            confidence: 0.9,
            hrr_kw: None,
        }],
    }
}

/// `r` and the same flame reported by every unit in `also` at time `t`: a fire seen by two
/// sources is no longer provisional, and gets backups and reserves. The outputs of all.
fn corroborated(i: &mut Incident, r: &FlameReport, also: &[&str], t: f64) -> Vec<Output> {
    let mut out = i.report_at(r, t).unwrap();
    for other in also {
        let again = FlameReport {
            unit: u(other),
            ..r.clone()
        };
        out.extend(i.report_at(&again, t).unwrap());
    }
    out
}

/// Extinguish tasks only.
fn tasks(out: &[Output]) -> Vec<&Task> {
    all_tasks(out)
        .into_iter()
        .filter(|t| matches!(t.kind, TaskKind::Extinguish { .. }))
        .collect()
}

/// The kinds of the tasks in `out` for `unit`, in order.
fn kinds_for(out: &[Output], unit: &str) -> Vec<TaskKind> {
    all_tasks(out)
        .iter()
        .filter(|t| t.unit.as_str() == unit)
        .map(|t| t.kind)
        .collect()
}

fn all_tasks(out: &[Output]) -> Vec<&Task> {
    out.iter()
        .filter_map(|o| {
            if let Output::Task(t) = o {
                Some(t)
            } else {
                None
            }
        })
        .collect()
}

/// Unit b, given the first fire task in `out`, reports that fire extinguished.
fn b_puts_out_the_first_fire(i: &mut Incident, out: &[Output]) -> (FireId, Vec<Output>) {
    let task = tasks(out)[0].clone();
    let TaskKind::Extinguish { fire, .. } = task.kind else {
        panic!("not a fire task: {task:?}")
    };
    let done = TaskProgress {
        seq: task.seq,
        fire,
        phase: TaskPhase::Extinguished,
        target: Point2::new(60.0, 1.0),
    };
    // b saw the flame it sprayed.
    i.report_at(&report("b", 60.0), 15.0).unwrap();
    (
        fire,
        i.state_at(state("b", 55.0, Some(done)), 20.0).unwrap(),
    )
}

/// Two ground units, one per fire (the backup wave has tests of its own).
fn incident() -> Incident {
    let mut i = incident_with_backups();
    i.set_units_per_fire(1);
    i
}

/// Ground units a and b, neither heard from yet, in a tunnel searched at t = 0 (these
/// tests are about fires; searching has tests of its own).
fn unheard() -> Incident {
    let ground = Mobility::Ground(GroundBody::of(&GROUND));
    let mut i = Incident::new(
        TUNNEL,
        [(u("a"), ground.clone()), (u("b"), ground)],
        5.0,
        Strategy::Optimal,
    );
    i.coverage.look(Chainage::ZERO, TUNNEL.end(), 0.0);
    i
}

fn incident_with_backups() -> Incident {
    let mut i = unheard();
    for (n, x) in [("a", 10.0), ("b", 40.0)] {
        i.on_alive(&u(n), true, 0.0).unwrap();
        i.state_at(state(n, x, None), 0.0).unwrap();
    }
    i
}

/// Zone `id` from chainage `a` to `b`.
fn zone(id: &str, a: f64, b: f64) -> Zone {
    Zone {
        id: ZoneId::new(id).unwrap(),
        start_m: Chainage::new(a),
        end_m: Chainage::new(b),
    }
}

fn zoned() -> Incident {
    let mut i = incident();
    i.goals = Goals::new(&[zone("z1", 50.0, 100.0), zone("z2", 100.0, 200.0)], &[]);
    i
}

fn goal(
    id: &str,
    zone: &str,
    kind: GoalKind,
    priority: u8,
    before_m: Option<f64>,
) -> (ZoneId, ZoneGoal) {
    let zone = ZoneId::new(zone).unwrap();
    let g = ZoneGoal {
        id: id.into(),
        zone: zone.clone(),
        goal: kind,
        priority,
        before_m,
        expires_s: None,
        issued_by: Some(CommanderId::new("ic-1").unwrap()),
        rail_allowed: false,
    };
    (zone, g)
}

fn submit(i: &mut Incident, (zone, g): (ZoneId, ZoneGoal), t: f64) -> (GoalAck, Vec<Output>) {
    let by = g.issued_by.clone().unwrap();
    i.on_goal(&zone, &by, g, t, None)
}

/// The fire the first report of a test becomes.
const F1: FireId = FireId(1);

/// Whether the incident made a decision that `f` accepts.
fn decided(i: &Incident, f: impl Fn(&Decision) -> bool) -> bool {
    i.decisions().any(|d| f(&d.decision))
}
