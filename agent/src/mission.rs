//! A unit's side of the coordinator link, and the behavior-tree leaves that every kind of
//! unit shares for it.
//!
//! [`Mission`] holds the coordinator's latest task, the attack under way and how the last
//! task ended; [`register`] adds the leaves that read and change it (`HasAssignedFire`,
//! `LocateFire`, `IsTaskCurrent`, `ReportExtinguished`, `ErrorHandling`, ...) to any unit
//! context that implements [`Responder`]. Ground and monorail units differ in how they
//! see flames and how they stand down, not in how they take and report tasks.
//!
//! Commanders' goals bind here too. The coordinator's [`BarredSpace`] is kept (the newest
//! heard, for as long as the unit runs: a coordinator gone does not lift a keep-out), and
//! every task is reviewed against it ([`review`]): a task whose destination or way lies in
//! barred space is refused, reported in the unit's state and replaced by standby. While
//! the unit's body is leaving barred space ([`Mission::leaving`]) no attack starts or goes
//! on; one under way is suspended, not failed, and resumes once out.
//!
//! After a restart the unit knows nothing barred until it hears the coordinator (the set
//! is re-sent every second, and the agent asks for it at start: the coordinator and the
//! recorders answer). Nothing is kept on disk: a saved set could be stale (a goal cleared
//! or lapsed while the unit was down), and the unit has no clock it could trust across a
//! restart to tell.

use firefleet_bt::node::Io;
use firefleet_bt::{Leaf, Port, Registry, Status};
use firefleet_model::UnitKind;
use firefleet_model::scenario::Tunnel;
use firefleet_model::{FireId, Point2, UnitId};
use firefleet_protocol::msg::{Approach, BarredSpace, Refusal, TaskKind, TaskPhase, TaskProgress};

/// The coordinator link's state on the unit.
#[derive(Debug, Clone, Default)]
pub struct Mission {
    pub coordinator_present: bool,
    /// The newest barred space heard; `None` until the first.
    pub barred: Option<BarredSpace>,
    /// The unit's refusal of its latest task, if it refused it.
    pub refused: Option<Refusal>,
    /// The unit's body is on its way out of barred space.
    pub leaving: bool,
    /// The coordinator's latest task.
    pub task: Option<(u64, TaskKind)>,
    /// The epoch of the newest coordinator term a task came from since the coordinator in
    /// office took it: tasks of older terms are refused.
    pub epoch: u64,
    /// The coordinator in office changed since the last task: its next task is taken
    /// whatever its epoch (the routers vouch for who sent it; see
    /// [`firefleet_protocol::office`]).
    new_office: bool,
    /// The attack under way: coordinator task (seq, fire, where the fire is), or `None`
    /// when acting alone.
    pub job: Option<Option<(u64, FireId, Point2)>>,
    /// How the last coordinator task ended.
    pub outcome: Option<TaskProgress>,
}

impl Mission {
    /// A task arrived from the coordinator in office. Older or repeated tasks are
    /// ignored, and so is every task of a term older than the newest heard from it (`Err`
    /// with that epoch): that coordinator before a restart. The first task after the
    /// office changed hands is taken whatever its term: a split site that heals hands
    /// office back to a coordinator of an older term.
    pub fn on_task(&mut self, epoch: u64, seq: u64, kind: TaskKind) -> Result<(), u64> {
        if !self.new_office {
            if epoch < self.epoch {
                return Err(self.epoch);
            }
            if epoch == self.epoch && self.task.is_some_and(|(s, _)| s >= seq) {
                return Ok(());
            }
        }
        self.new_office = false;
        self.epoch = epoch;
        self.task = Some((seq, kind));
        self.refused = None;
        Ok(())
    }

    /// Another coordinator holds office now (`present`), or none does.
    pub fn office_changed(&mut self, present: bool) {
        self.coordinator_present = present;
        self.new_office = true;
    }

    /// A barred space arrived; true if it replaced the one kept (an older one, by site
    /// time, is ignored: a late or replayed message must not lift a newer keep-out).
    /// The coordinator re-sends the same set every second: that only brings its time on.
    pub fn on_barred(&mut self, b: BarredSpace) -> bool {
        match &mut self.barred {
            Some(old) if old.t > b.t => false,
            Some(old) if old.spans == b.spans => {
                old.t = b.t;
                false
            }
            _ => {
                self.barred = Some(b);
                true
            }
        }
    }

    /// Whether a unit of kind `kind` at `from` may go to `to` (and attack there if
    /// `attack`) as the barred space kept stands.
    pub fn permits(
        &self,
        tunnel: &Tunnel,
        kind: UnitKind,
        from: Point2,
        to: Point2,
        attack: bool,
    ) -> bool {
        self.barred.as_ref().is_none_or(|b| {
            b.refuses(
                tunnel,
                kind,
                tunnel.chainage(from),
                tunnel.chainage(to),
                attack,
            )
            .is_none()
        })
    }

    /// The coordinator's Extinguish task not yet finished, if any.
    pub fn assigned_fire(&self) -> Option<(u64, FireId, Point2)> {
        match self.task {
            Some((seq, TaskKind::Extinguish { fire, target, .. }))
                if self.outcome.is_none_or(|o| o.seq != seq) =>
            {
                Some((seq, fire, target))
            }
            _ => None,
        }
    }

    /// The side of its fire the coordinator's Extinguish task says to fire from (upwind
    /// while the air moves); `Either` without one.
    pub fn approach(&self) -> Approach {
        match self.task {
            Some((_, TaskKind::Extinguish { from, .. })) if self.assigned_fire().is_some() => from,
            _ => Approach::Either,
        }
    }

    /// Record how the coordinator task `task` ended.
    pub fn finish(&mut self, task: i64, phase: TaskPhase) {
        if let Some(Some((seq, fire, target))) = self.job
            && seq as i64 == task
        {
            self.outcome = Some(TaskProgress {
                seq,
                fire,
                phase,
                target,
            });
        }
        self.job = None;
    }

    /// The attack on coordinator task `task` (-1: acting alone) stopped before the fire
    /// was out. If the coordinator has since replaced or withdrawn the task nothing
    /// failed and nothing is reported (it has moved on, and a failure would bar the unit
    /// from that fire for a while); else the task failed. `None` if there was no attack.
    /// A unit leaving barred space suspends its attack: nothing failed, and it resumes
    /// once out.
    pub fn stop_short(&mut self, task: i64) -> Option<Stopped> {
        let stopped = match self.job? {
            _ if self.leaving => Stopped::Withdrawn,
            Some((seq, ..)) if self.assigned_fire().is_none_or(|a| a.0 != seq) => {
                Stopped::Withdrawn
            }
            _ => Stopped::Failed,
        };
        match stopped {
            Stopped::Failed => self.finish(task, TaskPhase::Failed),
            Stopped::Withdrawn => self.job = None,
        }
        Some(stopped)
    }

    /// The task progress to report: the attack under way, or how the last one ended.
    pub fn progress(&self, spraying: bool) -> Option<TaskProgress> {
        match self.job {
            Some(Some((seq, fire, target))) => Some(TaskProgress {
                seq,
                fire,
                target,
                phase: if spraying {
                    TaskPhase::Spraying
                } else {
                    TaskPhase::Travelling
                },
            }),
            _ => self.outcome,
        }
    }
}

/// Why an attack stopped before the fire was out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stopped {
    /// The unit gave up: no path, no firing solution, no water, out of time.
    Failed,
    /// The coordinator replaced or withdrew the task.
    Withdrawn,
}

/// What the shared leaves need of a unit.
pub trait Responder: 'static {
    fn id(&self) -> &UnitId;
    fn kind(&self) -> UnitKind;
    fn tunnel(&self) -> &Tunnel;
    /// Where the unit is (a monorail unit: its carriage).
    fn position(&self) -> Point2;
    fn mission(&mut self) -> &mut Mission;
    /// A flame seen lately within `within` metres of `of`.
    fn flame_near(&self, of: Point2, within: f64) -> Option<Point2>;
    /// The flame to attack when acting alone.
    fn most_confident_flame(&self) -> Option<Point2>;
    /// Stop travelling to and spraying the fire.
    fn stand_down(&mut self);
}

/// Hold the unit's task against the barred space it keeps: a task that would need barred
/// space is refused (logged, reported in the unit's state, and replaced by standby, so
/// that nothing acts on it), and an attack the unit chose alone where attack is now barred
/// is stopped. Called on every new task and every new barred space.
pub fn review<C: Responder>(u: &mut C) {
    let (kind, from) = (u.kind(), u.tunnel().chainage(u.position()));
    let task = match u.mission().task {
        Some((seq, TaskKind::Cruise { goal } | TaskKind::Search { goal })) => {
            Some((seq, goal, false))
        }
        Some((seq, TaskKind::Extinguish { target, .. })) => Some((seq, target, true)),
        Some((_, TaskKind::Standby)) | None => None,
    };
    let task = task.map(|(seq, to, attack)| (seq, u.tunnel().chainage(to), attack));
    // Out of the mission while the tunnel is read beside it; put back below.
    let Some(barred) = u.mission().barred.take() else {
        return;
    };
    let refusal = task.and_then(|(seq, to, attack)| {
        barred
            .refuses(u.tunnel(), kind, from, to, attack)
            .map(|(why, span)| Refusal::new(seq, why, span))
    });
    let m = u.mission();
    let alone = m.job == Some(None) && !barred.spans.is_empty();
    m.barred = Some(barred);
    if let Some(r) = refusal {
        tracing::warn!(unit = %u.id(), "{r}");
        let m = u.mission();
        m.task = Some((r.seq, TaskKind::Standby));
        m.refused = Some(r);
        u.stand_down();
    } else if alone {
        // The flame it chose alone may now be barred: drop the attack, and the tree picks
        // again among the flames it may attack.
        u.stand_down();
    }
}

fn ok(b: bool) -> Status {
    if b { Status::Success } else { Status::Failure }
}

const FLAME_WITHIN: Port<f64> = Port::input(
    "within_m",
    "how far from the unit (or from `near`) a flame counts",
)
.with_default("30");
const NEAR: Port<[f64; 2]> = Port::input(
    "near",
    "look for a flame near this point instead of near the unit",
)
.optional();
const LOCATED_FIRE: Port<[f64; 2]> = Port::output("fire", "where the fire is");
const LOCATED_TASK: Port<i64> = Port::output("task", "coordinator task seq, -1 when acting alone");
const TASK: Port<i64> = Port::input("task", "the task being worked on");
const DONE_TASK: Port<i64> = Port::input("task", "the task that is done");
const FAILED_TASK: Port<i64> = Port::input("task", "the task that failed").with_default("-1");

/// Add the shared leaves to `r`.
pub fn register<C: Responder>(r: &mut Registry<C>) {
    r.register(
        "FireDetection",
        vec![FLAME_WITHIN.spec(), NEAR.spec()],
        Leaf::condition(|| {
            |io: &mut Io<'_>, u: &mut C| {
                let within = io.get(&FLAME_WITHIN).unwrap_or(30.0);
                let of = io
                    .get(&NEAR)
                    .map(|[x, y]| Point2::new(x, y))
                    .unwrap_or(u.position());
                ok(u.flame_near(of, within).is_some())
            }
        }),
    );
    r.register(
        "IsAttacking",
        vec![],
        Leaf::condition(|| |_: &mut Io<'_>, u: &mut C| ok(u.mission().job.is_some())),
    );
    r.register(
        "HasAssignedFire",
        vec![],
        Leaf::condition(|| {
            |_: &mut Io<'_>, u: &mut C| {
                let m = u.mission();
                ok(!m.leaving && m.assigned_fire().is_some())
            }
        }),
    );
    r.register(
        "IsAutonomous",
        vec![],
        Leaf::condition(|| |_: &mut Io<'_>, u: &mut C| ok(!u.mission().coordinator_present)),
    );
    r.register(
        "LocateFire",
        vec![LOCATED_FIRE.spec(), LOCATED_TASK.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut C| {
                if u.mission().leaving {
                    return Status::Failure;
                }
                let (fire, task) = match u.mission().assigned_fire() {
                    Some((seq, id, target)) => {
                        let fire = u.flame_near(target, 3.0).unwrap_or(target);
                        u.mission().job = Some(Some((seq, id, fire)));
                        (fire, seq as i64)
                    }
                    None => match u.most_confident_flame() {
                        Some(f) => {
                            u.mission().job = Some(None);
                            (f, -1)
                        }
                        None => return Status::Failure,
                    },
                };
                ok(io.set(&LOCATED_FIRE, [fire.x, fire.y]).is_ok()
                    && io.set(&LOCATED_TASK, task).is_ok())
            }
        }),
    );
    r.register(
        "IsTaskCurrent",
        vec![TASK.spec()],
        Leaf::condition(|| {
            |io: &mut Io<'_>, u: &mut C| {
                let Ok(task) = io.get(&TASK) else {
                    return Status::Failure;
                };
                let m = u.mission();
                ok(!m.leaving
                    && match m.assigned_fire() {
                        Some((seq, _, _)) => seq as i64 == task,
                        // Acting alone is current until a coordinator assigns something.
                        None => task < 0 || m.task.is_some_and(|(s, _)| s as i64 == task),
                    })
            }
        }),
    );
    r.register(
        "ReportExtinguished",
        vec![DONE_TASK.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut C| {
                let task = io.get(&DONE_TASK).unwrap_or(-1);
                tracing::info!(unit = %u.id(), task, "flame out");
                u.stand_down();
                u.mission().finish(task, TaskPhase::Extinguished);
                Status::Success
            }
        }),
    );
    r.register(
        "ErrorHandling",
        vec![FAILED_TASK.spec()],
        Leaf::action(|| {
            |io: &mut Io<'_>, u: &mut C| {
                let task = io.get(&FAILED_TASK).unwrap_or(-1);
                u.stand_down();
                match u.mission().stop_short(task) {
                    Some(Stopped::Failed) => {
                        tracing::warn!(unit = %u.id(), task, "attack abandoned")
                    }
                    Some(Stopped::Withdrawn) => {
                        tracing::info!(unit = %u.id(), task, "task withdrawn")
                    }
                    None => {}
                }
                Status::Failure
            }
        }),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    fn extinguish(fire: u32) -> TaskKind {
        TaskKind::Extinguish {
            fire: FireId(fire),
            target: Point2::new(50.0, 0.0),
            from: Approach::Either,
        }
    }

    /// A unit attacking the fire of task 1.
    fn attacking() -> Mission {
        let mut m = Mission::default();
        m.on_task(0, 1, extinguish(1)).unwrap();
        m.job = Some(m.assigned_fire());
        m
    }

    #[test]
    fn an_older_term_is_refused_until_the_office_changes_hands() {
        let mut m = Mission::default();
        m.on_task(33, 40, extinguish(1)).unwrap();
        assert_eq!(m.on_task(17, 90, TaskKind::Standby), Err(33));
        m.on_task(33, 39, TaskKind::Standby).unwrap();
        assert_eq!(
            m.task.map(|(s, _)| s),
            Some(40),
            "an older task of the term is ignored"
        );
        // A split site healed: the coordinator of an older term holds office again.
        m.office_changed(true);
        m.on_task(17, 90, TaskKind::Standby).unwrap();
        assert_eq!((m.epoch, m.task.map(|(s, _)| s)), (17, Some(90)));
        assert_eq!(m.on_task(16, 95, TaskKind::Standby), Err(17));
    }

    #[test]
    fn only_a_newer_and_different_barred_space_changes_anything() {
        let space = |t: f64, end: f64| BarredSpace {
            t,
            spans: vec![firefleet_protocol::msg::BarredSpan {
                goal: "g".into(),
                zone: firefleet_model::ZoneId::new("z").unwrap(),
                start: firefleet_model::Chainage::new(10.0),
                end: firefleet_model::Chainage::new(end),
                bar: firefleet_protocol::msg::Bar::Entry,
                rail_allowed: false,
            }],
        };
        let mut m = Mission::default();
        assert!(m.on_barred(space(5.0, 20.0)));
        assert!(!m.on_barred(space(6.0, 20.0)), "the same set again");
        assert!(
            !m.on_barred(BarredSpace::default()),
            "older: a late message"
        );
        assert!(
            m.barred
                .as_ref()
                .is_some_and(|b| b.t == 6.0 && !b.spans.is_empty())
        );
        assert!(m.on_barred(space(7.0, 30.0)));
        assert!(
            m.on_barred(BarredSpace {
                t: 8.0,
                spans: Vec::new()
            }),
            "lifted"
        );
    }

    #[test]
    fn a_task_given_up_is_reported_failed() {
        let mut m = attacking();
        assert_eq!(m.stop_short(1), Some(Stopped::Failed));
        assert_eq!(
            m.progress(false).map(|p| (p.seq, p.phase)),
            Some((1, TaskPhase::Failed))
        );
        assert_eq!(m.stop_short(1), None, "nothing left to stop");
    }

    #[test]
    fn a_task_replaced_or_withdrawn_is_not_reported_failed() {
        for then in [extinguish(2), TaskKind::Standby] {
            let mut m = attacking();
            m.on_task(0, 2, then).unwrap();
            assert_eq!(m.stop_short(1), Some(Stopped::Withdrawn), "{then:?}");
            assert_eq!(m.progress(false), None, "{then:?}");
            assert!(m.job.is_none());
        }
    }

    #[test]
    fn alone_a_stopped_attack_is_a_failed_one() {
        let mut m = Mission {
            job: Some(None),
            ..Mission::default()
        };
        assert_eq!(m.stop_short(-1), Some(Stopped::Failed));
        assert!(m.job.is_none());
    }
}
