//! Continuity of command: no fire left without a unit because the unit on it was lost or
//! because the coordinator that sent it was replaced.
//!
//! Checked, from the history alone (not from what the coordinator logged about itself):
//! - **fire abandoned**: a unit sent to put out a fire falls silent (no state for a
//!   lease, [`crate::incident::LEASE_S`] unless told otherwise). By its last state plus
//!   the lease plus [`RELIEF_S`], another unit in play must be sent to that fire.
//! - **fire forgotten across a takeover**: when the tasks of a new epoch first appear (a
//!   coordinator took office), every fire a unit in play was sent to in an older epoch
//!   must, within [`TAKEOVER_S`], have a unit sent to it by the new term. A coordinator
//!   that took office without following the incident would stand such a unit down.
//!
//! Neither is owed when nothing needed doing: the ground truth says no fire burns there
//! any more (without ground truth, a real incident's recording, neither is checked: the
//! checker cannot tell a fire put out from a fire forgotten), the lost unit was heard
//! again in time, a commander's goal forbids attack there, or no unit that could have
//! gone was free (every ground unit in play, and every one of the lost unit's kind, busy
//! on a fire of its own: which fire waits is the assignment's choice, not a lapse of
//! continuity).
//!
//! A unit counts as silent only once the observer itself has heard the site for a lease
//! without hearing it: a recorder cut off with its router (a router restart) hears
//! nobody for a while, and that silence is the recorder's, not the units'.
//!
//! Fires are matched by place ([`firefleet_model::fire::same_fire`]), not by id: a new
//! coordinator's tracks are its own, numbered afresh.

use std::collections::BTreeMap;

use firefleet_model::UnitKind;
use firefleet_model::fire::same_fire;
use firefleet_model::{Point2, UnitId};
use firefleet_protocol::msg::{Task, TaskKind, UnitState};

use super::Violation;

/// Time a coordinator has, after a lost unit's lease, to send another unit to its fire,
/// site s: a coordinator ticks five times a wall-clock second, which is 0.8 s of site time
/// at four times real time.
pub const RELIEF_S: f64 = 1.0;
/// Time a new coordinator has, after its first task, to send its term's units to every
/// fire the old term was attacking, site s: it gives those tasks as it takes office.
pub const TAKEOVER_S: f64 = 1.0;
/// A stretch this long with no event at all is the observer's own silence, site s.
const OBSERVER_GAP_S: f64 = 1.0;
/// How often the units are looked over for silence, site s: events come thousands a
/// second in a large fleet, and a silence is measured against a lease of seconds.
const SCAN_EVERY_S: f64 = 0.1;

/// What made a fire's unit owed.
#[derive(Debug, Clone, PartialEq)]
enum Cause {
    /// `unit` was last heard at `heard`.
    Lost { unit: UnitId, heard: f64 },
    /// A coordinator took office in `epoch` at `at`.
    Takeover { epoch: u64, at: f64 },
}

/// A fire that must have a unit sent to it by `due`.
#[derive(Debug, Clone)]
struct Owed {
    cause: Cause,
    fire: Point2,
    /// The kind of the unit that had it: a unit of that kind could take its place.
    kind: UnitKind,
    due: f64,
}

enum Settled {
    Sent,
    Moot,
}

#[derive(Debug, Clone)]
struct Heard {
    at: f64,
    kind: UnitKind,
    /// Its silence since `at` is already owed for.
    noted: bool,
}

/// How the fires owed a unit were settled: a checker that never had anything to judge
/// proves nothing, so the count is shown beside the verdict.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Tally {
    /// Fires that needed a unit sent (a lost unit's, or the old term's at a takeover).
    pub owed: usize,
    /// ... and had one in time.
    pub sent: usize,
    /// ... and needed none by then: out, barred to attack, the unit back, nobody free, or
    /// no ground truth to judge by.
    pub moot: usize,
}

/// The continuity checker's state; [`super::Invariants`] drives it.
#[derive(Debug)]
pub(super) struct Continuity {
    lease_s: f64,
    heard: BTreeMap<UnitId, Heard>,
    /// The task each unit obeys: the highest in (epoch, number) given to it.
    given: BTreeMap<UnitId, Task>,
    /// Where fires burn, by the latest ground truth; `None` without any.
    burning: Option<Vec<Point2>>,
    /// The newest epoch of any task.
    epoch: Option<u64>,
    owed: Vec<Owed>,
    /// The observer has heard the site without a gap since then.
    hearing_since: f64,
    last_event: Option<f64>,
    scanned_at: f64,
    tally: Tally,
}

impl Continuity {
    pub(super) fn new(lease_s: f64) -> Self {
        Self {
            lease_s,
            heard: BTreeMap::new(),
            given: BTreeMap::new(),
            burning: None,
            epoch: None,
            owed: Vec::new(),
            hearing_since: 0.0,
            last_event: None,
            scanned_at: f64::NEG_INFINITY,
            tally: Tally::default(),
        }
    }

    /// Something was heard at `t` (before it is taken).
    pub(super) fn heard_anything(&mut self, t: f64) {
        if self.last_event.is_none_or(|last| t - last > OBSERVER_GAP_S) {
            self.hearing_since = t;
        }
        self.last_event = Some(t);
    }

    pub(super) fn state(&mut self, st: &UnitState, t: f64) {
        self.heard.insert(
            st.unit.clone(),
            Heard {
                at: t,
                kind: st.kind,
                noted: false,
            },
        );
    }

    pub(super) fn burning(&mut self, fires: Vec<Point2>) {
        self.burning = Some(fires);
    }

    pub(super) fn task(&mut self, task: &Task, t: f64) {
        if self.epoch.is_some_and(|e| task.epoch > e) {
            let mut owed: Vec<Owed> = Vec::new();
            for (unit, old) in &self.given {
                let TaskKind::Extinguish { target, .. } = old.kind else {
                    continue;
                };
                let Some(kind) = self.in_play(unit, t) else {
                    continue;
                };
                // Every task held is of an older epoch: this one is the newest yet.
                if !owed.iter().any(|o| same_fire(o.fire, target)) {
                    owed.push(Owed {
                        cause: Cause::Takeover {
                            epoch: task.epoch,
                            at: t,
                        },
                        fire: target,
                        kind,
                        due: t + TAKEOVER_S,
                    });
                }
            }
            self.owed.extend(owed);
        }
        self.epoch = Some(self.epoch.map_or(task.epoch, |e| e.max(task.epoch)));
        if self
            .given
            .get(&task.unit)
            .is_none_or(|old| old.order() < task.order())
        {
            self.given.insert(task.unit.clone(), task.clone());
        }
    }

    /// Note the units fallen silent by `t` and settle what is due by then; `attack_barred`
    /// says where a commander's goal forbids attack.
    pub(super) fn settle(
        &mut self,
        t: f64,
        attack_barred: impl Fn(Point2) -> bool,
        violations: &mut Vec<Violation>,
    ) {
        if t - self.scanned_at >= SCAN_EVERY_S {
            self.scanned_at = t;
            self.note_silences(t);
        }
        if self.owed.iter().all(|o| o.due > t) {
            return;
        }
        let (due, later): (Vec<_>, Vec<_>) = std::mem::take(&mut self.owed)
            .into_iter()
            .partition(|o| o.due <= t);
        self.owed = later;
        for o in due {
            self.tally.owed += 1;
            match self.settled(&o, t, &attack_barred) {
                Some(Settled::Sent) => self.tally.sent += 1,
                Some(Settled::Moot) => self.tally.moot += 1,
                None => violations.push(match o.cause {
                    Cause::Lost { unit, heard } => Violation::FireAbandoned {
                        unit,
                        heard,
                        due: o.due,
                        fire: o.fire,
                    },
                    Cause::Takeover { epoch, at } => Violation::FireForgotten {
                        epoch,
                        t: at,
                        due: o.due,
                        fire: o.fire,
                    },
                }),
            }
        }
    }

    pub(super) fn tally(&self) -> Tally {
        self.tally
    }

    /// Owe a relief for every unit sent to a fire that fell silent by `t`.
    fn note_silences(&mut self, t: f64) {
        let lease = self.lease_s;
        let since = self.hearing_since;
        for (unit, h) in &mut self.heard {
            if h.noted || t - h.at.max(since) <= lease {
                continue;
            }
            h.noted = true;
            if let Some(Task {
                kind: TaskKind::Extinguish { target, .. },
                ..
            }) = self.given.get(unit)
            {
                self.owed.push(Owed {
                    cause: Cause::Lost {
                        unit: unit.clone(),
                        heard: h.at,
                    },
                    fire: *target,
                    kind: h.kind,
                    due: h.at.max(since) + lease + RELIEF_S,
                });
            }
        }
    }

    /// How `o` stands at `t`: `None` if it is broken.
    fn settled(
        &self,
        o: &Owed,
        t: f64,
        attack_barred: &impl Fn(Point2) -> bool,
    ) -> Option<Settled> {
        let Some(burning) = &self.burning else {
            return Some(Settled::Moot);
        };
        if !burning.iter().any(|&f| same_fire(f, o.fire)) || attack_barred(o.fire) {
            return Some(Settled::Moot);
        }
        let (lost, since_epoch) = match &o.cause {
            Cause::Lost { unit, heard } => {
                if self.heard.get(unit).is_some_and(|h| h.at > *heard) {
                    return Some(Settled::Moot);
                }
                (Some(unit), 0)
            }
            Cause::Takeover { epoch, .. } => (None, *epoch),
        };
        let mut free = false;
        for (unit, task) in &self.given {
            let Some(kind) = self.in_play(unit, t).filter(|_| Some(unit) != lost) else {
                continue;
            };
            match task.kind {
                TaskKind::Extinguish { target, .. } if same_fire(target, o.fire) => {
                    if task.epoch >= since_epoch {
                        return Some(Settled::Sent);
                    }
                }
                TaskKind::Extinguish { .. } => {}
                _ => free |= kind == UnitKind::Ground || kind == o.kind,
            }
        }
        // Units never tasked at all are free too.
        free |= self.heard.iter().any(|(unit, h)| {
            !self.given.contains_key(unit)
                && t - h.at <= self.lease_s
                && (h.kind == UnitKind::Ground || h.kind == o.kind)
        });
        (!free).then_some(Settled::Moot)
    }

    /// The kind of `unit` if it was heard within a lease of `t`.
    fn in_play(&self, unit: &UnitId, t: f64) -> Option<UnitKind> {
        self.heard
            .get(unit)
            .filter(|h| t - h.at <= self.lease_s)
            .map(|h| h.kind)
    }
}

#[cfg(test)]
mod tests {
    use firefleet_model::FireId;
    use firefleet_model::scenario::Scenario;

    use super::*;
    use crate::incident::LEASE_S;
    use crate::invariants::tests::state_of;
    use crate::invariants::{Event, Invariants};
    use firefleet_protocol::msg::Approach;

    const FIRE: Point2 = Point2 { x: 200.0, y: 0.0 };

    fn unit(id: &str) -> UnitId {
        UnitId::new(id).unwrap()
    }

    fn state(id: &str) -> Event {
        state_of(&unit(id), 50.0, 0.0, None)
    }

    fn task(id: &str, epoch: u64, seq: u64, kind: TaskKind) -> Event {
        Event::Task(Task {
            unit: unit(id),
            epoch,
            seq,
            t: 0.0,
            kind,
        })
    }

    fn attack(at: Point2) -> TaskKind {
        TaskKind::Extinguish {
            fire: FireId(1),
            target: at,
            from: Approach::Either,
        }
    }

    /// Two ground units: `a` sent to the fire at 200 m, `b` free; from `silent_from` on
    /// only `b` is heard (ten times a second), until `until`, with `then` at `then_at`.
    fn run(
        burning: bool,
        silent_from: f64,
        until: f64,
        then: Option<(f64, Event)>,
    ) -> (Vec<Violation>, Tally) {
        let site = Scenario::straight(400.0)
            .ground("a", 5.0, -2.5)
            .ground("b", 10.0, -2.5)
            .build();
        let mut inv = Invariants::new(&site);
        inv.observe(
            0.0,
            Event::Burning(if burning { vec![FIRE] } else { vec![] }),
        );
        inv.observe(0.0, task("a", 16, 100, attack(Point2::new(201.0, 0.5))));
        inv.observe(0.0, task("b", 16, 101, TaskKind::Standby));
        let mut then = then;
        for i in 0..(until * 10.0) as usize {
            let t = i as f64 / 10.0;
            if let Some((at, e)) = then.take_if(|(at, _)| *at <= t) {
                inv.observe(at, e);
            }
            if t < silent_from {
                inv.observe(t, state("a"));
            }
            inv.observe(t, state("b"));
        }
        (inv.violations().to_vec(), inv.continuity())
    }

    #[test]
    fn a_silent_units_fire_must_go_to_a_free_unit_within_its_lease_and_a_second() {
        let (v, tally) = run(true, 2.0, 20.0, None);
        assert_eq!(v.len(), 1, "{v:?}");
        assert_eq!((tally.owed, tally.sent, tally.moot), (1, 0, 0));
        let Violation::FireAbandoned {
            unit, heard, due, ..
        } = &v[0]
        else {
            panic!("{v:?}")
        };
        assert_eq!((unit.as_str(), *heard), ("a", 1.9));
        assert!((due - (1.9 + LEASE_S + RELIEF_S)).abs() < 1e-9);

        // Sent before the deadline: kept.
        let relief = task("b", 16, 102, attack(Point2::new(199.0, -1.0)));
        let (v, tally) = run(true, 2.0, 20.0, Some((7.5, relief)));
        assert!(v.is_empty(), "{v:?}");
        assert_eq!((tally.owed, tally.sent), (1, 1));
        // Heard again in time (and silent since for less than a lease), or the fire went
        // out: nothing to send.
        for (v, tally) in [
            run(true, 2.0, 12.0, Some((7.5, state("a")))),
            run(false, 2.0, 20.0, None),
        ] {
            assert!(v.is_empty(), "{v:?}");
            assert_eq!((tally.owed, tally.moot), (1, 1));
        }
    }

    #[test]
    fn with_no_unit_free_the_fire_waits_and_nothing_is_broken() {
        let busy = task("b", 16, 102, attack(Point2::new(300.0, 0.0)));
        let (v, tally) = run(true, 2.0, 20.0, Some((1.0, busy)));
        assert!(v.is_empty(), "{v:?}");
        assert_eq!((tally.owed, tally.moot), (1, 1));
    }

    #[test]
    fn a_new_term_must_send_somebody_to_every_fire_the_old_one_was_attacking() {
        // At 5 s epoch 33 takes office and stands `a` down: the fire is forgotten.
        let (v, _) = run(
            true,
            99.0,
            10.0,
            Some((5.0, task("a", 33, 500, TaskKind::Standby))),
        );
        assert_eq!(v.len(), 1, "{v:?}");
        assert!(
            matches!(
                v[0],
                Violation::FireForgotten {
                    epoch: 33,
                    t: 5.0,
                    ..
                }
            ),
            "{v:?}"
        );
        // It adopts the attack: nothing forgotten.
        let adopted = task("a", 33, 500, attack(Point2::new(201.0, 0.5)));
        let (v, tally) = run(true, 99.0, 10.0, Some((5.0, adopted)));
        assert!(v.is_empty(), "{v:?}");
        assert_eq!((tally.owed, tally.sent), (1, 1));
    }

    #[test]
    fn the_observers_own_silence_is_nobodys_loss() {
        let site = Scenario::straight(400.0)
            .ground("a", 5.0, -2.5)
            .ground("b", 10.0, -2.5)
            .build();
        let mut inv = Invariants::new(&site);
        inv.observe(0.0, Event::Burning(vec![FIRE]));
        inv.observe(0.0, task("a", 16, 100, attack(FIRE)));
        inv.observe(0.0, task("b", 16, 101, TaskKind::Standby));
        inv.observe(0.0, state("a"));
        inv.observe(0.0, state("b"));
        // The recorder hears nothing for 20 s (its router restarted), then `b` first.
        for i in 0..30 {
            let t = 20.0 + f64::from(i) / 10.0;
            inv.observe(t, state("b"));
            if i > 0 {
                inv.observe(t, state("a"));
            }
        }
        assert!(inv.violations().is_empty(), "{:?}", inv.violations());
    }
}
