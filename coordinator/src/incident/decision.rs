//! The incident's decisions as data: what it decided, about whom, and why, in fields a
//! test or a checker can match on. Text is made only at the edges (the log, the status
//! snapshot, the `coord/log` messages the recorder keeps), through `Display`.
//!
//! Not here: deciding. Each variant is raised by the module that makes that decision.

use std::fmt;

use firefleet_bus::access::Identity;
use firefleet_model::scenario::Rank;
use firefleet_model::{Chainage, CommanderId, FireId, Point2, UnitId, ZoneId};
use firefleet_protocol::msg::{self, Approach, FireTrack, GoalKind, ZoneGoal};

use crate::fusion::witness::{CONTRADICT_AFTER_S, Record};

/// Why a unit counts as lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loss {
    /// Its liveliness token vanished: the process or its link is gone.
    TokenVanished,
    /// Nothing heard from it for longer than its lease.
    Silent,
    /// Its states go on, but none has echoed the number of the task it was given for
    /// [`super::Policy::deaf_after_s`]: it does not hear this coordinator (its task
    /// subscription broke, a one-way partition, or a forged task it prefers), so its fire
    /// is given to a unit that does.
    Deaf,
}

impl fmt::Display for Loss {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Loss::TokenVanished => "its liveliness token vanished",
            Loss::Silent => "silent beyond its lease",
            Loss::Deaf => "its states have stopped echoing its task",
        })
    }
}

/// One decision of the incident.
#[derive(Debug, Clone, PartialEq)]
pub enum Decision {
    /// A commander's goal, taken (`accepted`) or refused, with the reason.
    Goal {
        goal: ZoneGoal,
        accepted: bool,
        reason: String,
    },
    /// A commander cleared a zone's goals; this one of them.
    GoalCleared {
        zone: ZoneId,
        goal: String,
        by: CommanderId,
    },
    /// `by` asked that identity `target` be suspended; not yet enough asks to suspend it.
    SuspendAsked {
        target: String,
        by: String,
    },
    /// An ask to suspend `target` not taken, for `reason`.
    SuspendRefused {
        target: String,
        reason: String,
    },
    /// Identity `target` is suspended, as `by` asked: nothing of it is taken.
    Suspended {
        target: String,
        by: Vec<String>,
    },
    /// A goal lapsed because whoever issued or sealed it is suspended.
    GoalSuspended {
        zone: ZoneId,
        goal: String,
        issuer: String,
    },
    /// A commander's clear of a zone lifted nothing there: goal `held` of a commander of
    /// an equal or higher rank holds, which only that commander or a higher rank lifts.
    ClearHeld {
        zone: ZoneId,
        by: CommanderId,
        held: String,
        issuer: String,
        rank: Rank,
    },
    GoalExpired {
        zone: ZoneId,
        goal: String,
    },
    /// A goal a previous coordinator had in force since `since`, taken back.
    GoalRecalled {
        goal: ZoneGoal,
        since: f64,
    },
    /// A goal bars attacking the fire the unit was on.
    Withdraw {
        unit: UnitId,
        fire: FireId,
        goal: String,
        kind: GoalKind,
        zone: ZoneId,
    },
    /// The unit is inside a zone it may not be in, and no chainage is free to send it to.
    Trapped {
        unit: UnitId,
        zone: ZoneId,
        goal: String,
    },
    /// The unit is inside a zone it may not be in: it leaves on its own, and is told
    /// where to hold once out.
    Evacuate {
        unit: UnitId,
        zone: ZoneId,
        to: Chainage,
        goal: String,
    },
    /// This coordinator took office in `epoch`, as the coordinator of `rank`.
    TookOffice {
        epoch: u64,
        rank: u32,
    },
    /// The coordinator of rank `holder` holds office ([`firefleet_protocol::office`]: the
    /// lowest rank whose lease is alive): this one, of `rank`, stands down.
    SteppedDown {
        rank: u32,
        holder: u32,
    },
    /// The coordinator of `rank` claims office (its lease, or its tasks) while this one
    /// holds it: units refuse its tasks.
    Rival {
        rank: u32,
    },
    /// Tasks on this coordinator's own key (`rank`) that it never sent: someone else holds
    /// its key.
    Impostor {
        rank: u32,
    },
    /// The unit took task `foreign`, which this coordinator never gave (its own for the
    /// unit was `ours`): the unit's task is given again above it.
    Superseded {
        unit: UnitId,
        foreign: u64,
        ours: u64,
    },
    /// The unit refused its task, which would need barred space.
    Refused {
        unit: UnitId,
        refusal: msg::Refusal,
    },
    Joined {
        unit: UnitId,
    },
    /// A unit lost for its silence was heard again, or one lost as deaf echoed its task
    /// again, `after_s` after it was lost.
    Rejoined {
        unit: UnitId,
        was: Loss,
        after_s: f64,
    },
    /// A unit is lost; the fire it was on, if any, needs another.
    Lost {
        unit: UnitId,
        why: Loss,
        fire: Option<FireId>,
    },
    /// A track a previous coordinator published, taken back after a restart.
    Recall {
        track: FireTrack,
    },
    FireOut {
        fire: FireId,
        by: UnitId,
    },
    /// A unit attacking a fire reported it out while another still sees it burning or
    /// sprays it: the claimant is freed, nobody else.
    OutDisputed {
        fire: FireId,
        by: UnitId,
        /// The units that still see it or spray it.
        against: Vec<UnitId>,
    },
    /// A unit reported out a fire no unit has seen burn (the DTS placed it): it cannot
    /// have seen it go out, so the fire stays open; the claimant is freed.
    OutUnseen {
        fire: FireId,
        by: UnitId,
    },
    /// A fire the DTS alone placed that `looks` units were sent to and never saw: no more
    /// are sent until one sees it ([`super::Policy::dts_unseen_looks`]).
    AlarmUnverified {
        fire: FireId,
        looks: u32,
    },
    /// Two readings of DTS zone `zone` on the bridge's key, `dt_s` apart, that one
    /// detector cannot give (the second moved from `before_c` to `after_c` at a rise of
    /// `rise_c_min`): someone else holds the bridge's key, and its word is doubted
    /// ([`super::infra::DTS_DOUBT_S`]).
    ScadaContradicted {
        zone: u16,
        before_c: f64,
        after_c: f64,
        dt_s: f64,
        rise_c_min: f64,
    },
    /// The bridge's readings agreed with each other for [`super::infra::DTS_DOUBT_S`]:
    /// its word is believed again.
    ScadaBelieved,
    /// A fire reported out whose DTS zone heats up again: it burns.
    ReheatedZone {
        fire: FireId,
        from_m: f64,
        to_m: f64,
        rise_c_min: f64,
    },
    GaveUp {
        unit: UnitId,
        fire: FireId,
    },
    /// A unit's task given before a restart, taken over.
    Adopt {
        unit: UnitId,
        seq: u64,
        fire: FireId,
        target: Point2,
    },
    Confirmed {
        fire: FireId,
        at: Point2,
    },
    /// `by` had the fire `witness` alone claims in clear view and never saw it.
    Contradicted {
        fire: FireId,
        witness: UnitId,
        by: UnitId,
    },
    /// A unit's flame reports were contradicted often enough that its word alone no longer
    /// confirms a fire ([`crate::fusion::witness`]).
    Doubted {
        unit: UnitId,
        record: Record,
    },
    /// A fire only doubted units claim, contradicted, is tentative again: nobody is sent.
    Disbelieved {
        fire: FireId,
    },
    Reignited {
        fire: FireId,
    },
    /// Two tracks are one fire: `removed` is now `kept`.
    Merged {
        removed: FireId,
        kept: FireId,
    },
    /// Unseen for a minute and unattended.
    FireLost {
        fire: FireId,
    },
    /// A ground unit sent to search the unseen stretch `from`-`to`.
    Search {
        unit: UnitId,
        from: Chainage,
        to: Chainage,
        goal: Point2,
    },
    SearchRail {
        unit: UnitId,
        to: Point2,
    },
    /// A free unit waits short of a fire, in reserve.
    Stage {
        unit: UnitId,
        at: Point2,
        fire: FireId,
    },
    /// Past fires a goal leaves burning, a free unit searches on.
    SearchOn {
        unit: UnitId,
        goal: Point2,
    },
    ReleaseToPatrol {
        unit: UnitId,
    },
    /// Another unit takes `fire` because it gets there sooner; `unit` stays on as its
    /// backup (`as_backup`) or is released.
    Relieved {
        unit: UnitId,
        fire: FireId,
        by: UnitId,
        by_s: f64,
        own_s: f64,
        as_backup: bool,
    },
    BackupTakesOver {
        unit: UnitId,
        fire: FireId,
    },
    /// `fire`'s attackers changed `changes` times within the churn window: they are held,
    /// no unit joining or leaving it by choice until fewer have
    /// ([`crate::invariants::churn::HOLD_AT`]).
    Held {
        fire: FireId,
        changes: usize,
    },
    /// `unit`'s fire `from` merged into `kept`, which has attackers of its own that it
    /// holds or that suffice: `unit` is released rather than added to them.
    MergedAway {
        unit: UnitId,
        from: FireId,
        kept: FireId,
    },
    /// A unit on its way to `from` goes to `to` instead (`was_backup`: it was a spare hand
    /// there).
    Leaves {
        unit: UnitId,
        from: FireId,
        to: FireId,
        was_backup: bool,
    },
    /// A unit sent to a fire (as its first attacker, or as a `backup`), with its cost and
    /// the next best unit's.
    Assign {
        unit: UnitId,
        fire: FireId,
        backup: bool,
        cost_s: f64,
        runner_up: Option<(UnitId, f64)>,
        /// The side the unit attacks from while the air moves; `None` in still air.
        side: Option<AttackSide>,
    },
    /// A free unit downwind of a burning fire withdraws out of its smoke.
    LeaveSmoke {
        unit: UnitId,
        fire: FireId,
        to: Point2,
    },
    /// A DTS alarm peak between `from_m` and `to_m`, up to `max_c`, is a new fire.
    DtsAlarm {
        fire: FireId,
        from_m: f64,
        to_m: f64,
        max_c: f64,
    },
    /// A fire the DTS alone had placed was seen by a unit at `at`: its units go there.
    Located {
        fire: FireId,
        at: Point2,
    },
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decision::Goal {
                goal: g,
                accepted,
                reason,
            } => {
                write!(
                    f,
                    "goal '{}' ({:?}, priority {}) on zone {} from '{}'",
                    g.id,
                    g.goal,
                    g.priority,
                    g.zone,
                    g.issuer()
                )?;
                if *accepted {
                    write!(f, ": {reason}")
                } else {
                    write!(f, " rejected: {reason}")
                }
            }
            Decision::GoalCleared { zone, goal, by } => {
                write!(f, "goal '{goal}' on zone {zone} cleared by {by}")
            }
            Decision::SuspendAsked { target, by } => write!(
                f,
                "{by} asks that {target} be suspended: a second commander's ask (or the coordinator host's operator's) suspends it"
            ),
            Decision::SuspendRefused { target, reason } => {
                write!(f, "an ask to suspend {target} not taken: {reason}")
            }
            Decision::Suspended { target, by } => write!(
                f,
                "{target} suspended (asked by {}): nothing of it is taken; revoke it for good (firefleet pki revoke)",
                by.join(", ")
            ),
            Decision::GoalSuspended { zone, goal, issuer } => write!(
                f,
                "goal '{goal}' on zone {zone} by {issuer} lapsed: its issuer or sealer is suspended"
            ),
            Decision::ClearHeld {
                zone,
                by,
                held,
                issuer,
                rank,
            } => write!(
                f,
                "{by}'s clear of zone {zone} lifted nothing there: goal '{held}' of {rank} commander '{issuer}' holds, which only {issuer} or a higher rank lifts"
            ),
            Decision::GoalExpired { zone, goal } => {
                write!(f, "goal '{goal}' on zone {zone} expired")
            }
            Decision::GoalRecalled { goal, since } => write!(
                f,
                "recall goal '{}' ({:?}, priority {}) on zone {}, in force since t = {since:.1} s: kept before this coordinator started",
                goal.id, goal.goal, goal.priority, goal.zone
            ),
            Decision::Withdraw {
                unit,
                fire,
                goal,
                kind,
                zone,
            } => write!(
                f,
                "withdraw {unit} from fire {fire}: goal '{goal}' ({kind:?}) on zone {zone}"
            ),
            Decision::Trapped { unit, zone, goal } => write!(
                f,
                "{unit} cannot obey goal '{goal}' on zone {zone}: no chainage it could leave \
                 to is free; it holds where it is"
            ),
            Decision::Evacuate {
                unit,
                zone,
                to,
                goal,
            } => write!(
                f,
                "evacuate {unit} from zone {zone} to chainage {to:.1}: goal '{goal}' (the unit leaves on its own, by the same way)"
            ),
            Decision::Refused { unit, refusal } => write!(f, "{unit} {refusal}"),
            Decision::TookOffice { epoch, rank } => write!(
                f,
                "took office in epoch {epoch} (rank {rank}): tasks of every earlier epoch are refused by the units that take one of this"
            ),
            Decision::SteppedDown { rank, holder } => write!(
                f,
                "stepped down: {} holds office (the lowest rank whose lease is alive), so {} stands by",
                Identity::Coordinator(*holder),
                Identity::Coordinator(*rank)
            ),
            Decision::Rival { rank } => write!(
                f,
                "{} claims office while this coordinator holds it: units refuse its tasks; if it lasts, someone else holds its key",
                Identity::Coordinator(*rank)
            ),
            Decision::Impostor { rank } => write!(
                f,
                "someone else holds the key of {}: tasks were sent on its key that it never sent",
                Identity::Coordinator(*rank)
            ),
            Decision::Superseded {
                unit,
                foreign,
                ours,
            } => write!(
                f,
                "{unit} took task {foreign}, which this coordinator never gave (its task was {ours}): given again above it"
            ),
            Decision::Joined { unit } => write!(f, "unit {unit} joined"),
            Decision::Rejoined { unit, was, after_s } => write!(
                f,
                "unit {unit} back in play {after_s:.1} s after it was lost ({was}): {}",
                match was {
                    Loss::Deaf => "it echoes its task again",
                    Loss::Silent | Loss::TokenVanished => "it is heard again",
                }
            ),
            Decision::Lost { unit, why, fire } => {
                write!(f, "unit {unit} lost ({why})")?;
                match fire {
                    Some(fire) => write!(f, "; fire {fire} needs a new unit"),
                    None => Ok(()),
                }
            }
            Decision::Recall { track } => {
                write!(
                    f,
                    "recall fire {} at ({:.1}, {:.1}), {:?} at t = {:.1} s, seen by [{}]: tracked before this coordinator started",
                    track.id,
                    track.position.x,
                    track.position.y,
                    track.state,
                    track.t,
                    names(&track.seen_by)
                )
            }
            Decision::FireOut { fire, by } => write!(f, "fire {fire} out, reported by {by}"),
            Decision::OutDisputed { fire, by, against } => write!(
                f,
                "{by} reports fire {fire} out, but {} still {} it: only {by} is freed",
                names(against),
                if against.len() == 1 {
                    "sees or sprays"
                } else {
                    "see or spray"
                }
            ),
            Decision::AlarmUnverified { fire, looks } => write!(
                f,
                "fire {fire}: the DTS alone placed it, and {looks} units sent there never saw \
                 it: no more are sent until one sees it (the alarm stays open)"
            ),
            Decision::OutUnseen { fire, by } => write!(
                f,
                "{by} reports fire {fire} out, but no unit has seen it burn (the DTS placed \
                 it): it stays open, only {by} is freed"
            ),
            Decision::ScadaContradicted {
                zone,
                before_c,
                after_c,
                dt_s,
                rise_c_min,
            } => write!(
                f,
                "someone else holds the key of {}: DTS zone {zone} read {before_c:.1} C, then \
                 {after_c:.1} C {dt_s:.1} s later at a rise of {rise_c_min:+.1} K/min, which \
                 no one detector gives; nothing on its key (DTS, ventilation) is believed \
                 until its readings agree for {:.0} s",
                Identity::Scada,
                super::infra::DTS_DOUBT_S
            ),
            Decision::ScadaBelieved => write!(
                f,
                "the readings on {}'s key agreed for {:.0} s: its DTS and ventilation are \
                 believed again",
                Identity::Scada,
                super::infra::DTS_DOUBT_S
            ),
            Decision::ReheatedZone {
                fire,
                from_m,
                to_m,
                rise_c_min,
            } => write!(
                f,
                "fire {fire} reported out, but its DTS zone {from_m:.0}-{to_m:.0} m heats up \
                 again ({rise_c_min:+.0} C/min): it burns"
            ),
            Decision::GaveUp { unit, fire } => write!(f, "unit {unit} gave up fire {fire}"),
            Decision::Adopt {
                unit,
                seq,
                fire,
                target,
            } => write!(
                f,
                "adopt {unit}'s task {seq} on fire {fire} at ({:.1}, {:.1}): given before this coordinator started",
                target.x, target.y
            ),
            Decision::Confirmed { fire, at } => {
                write!(f, "fire {fire} confirmed at ({:.1}, {:.1})", at.x, at.y)
            }
            Decision::Contradicted { fire, witness, by } => write!(
                f,
                "fire {fire}: {by} had it in clear view for {CONTRADICT_AFTER_S:.0} s and never \
                 saw it, only {witness} claims it"
            ),
            Decision::Doubted { unit, record } => write!(
                f,
                "unit {unit}'s flame reports doubted ({} contradicted, {} corroborated: weight \
                 {:.2}): its word alone no longer confirms a fire",
                record.contradicted,
                record.corroborated,
                record.weight()
            ),
            Decision::Disbelieved { fire } => write!(
                f,
                "fire {fire} back to tentative: only doubted units claim it, nobody is sent"
            ),
            Decision::Reignited { fire } => write!(f, "fire {fire} reignited"),
            Decision::Merged { removed, kept } => {
                write!(f, "fire {removed} is fire {kept} seen again: merged")
            }
            Decision::FireLost { fire } => {
                write!(f, "fire {fire} lost: unseen for a minute and unattended")
            }
            Decision::Search {
                unit,
                from,
                to,
                goal,
            } => write!(
                f,
                "send {unit} searching the unseen stretch {from:.0}-{to:.0} m, to ({:.1}, {:.1})",
                goal.x, goal.y
            ),
            Decision::SearchRail { unit, to } => {
                write!(f, "send {unit} searching along its rail to {:.0} m", to.x)
            }
            Decision::Stage { unit, at, fire } => write!(
                f,
                "stage {unit} at ({:.1}, {:.1}), in reserve for fire {fire}",
                at.x, at.y
            ),
            Decision::SearchOn { unit, goal } => write!(
                f,
                "send {unit} on to search past the fires left burning, to ({:.1}, {:.1})",
                goal.x, goal.y
            ),
            Decision::ReleaseToPatrol { unit } => {
                write!(f, "release {unit} to patrol: no active fire")
            }
            Decision::Relieved {
                unit,
                fire,
                by,
                by_s,
                own_s,
                as_backup,
            } => {
                if *as_backup {
                    write!(f, "{unit} stays on fire {fire} as a backup")?;
                } else {
                    write!(f, "release {unit} from fire {fire}")?;
                }
                write!(
                    f,
                    ": {by} gets there in {by_s:.1} s, {unit} in about {own_s:.1} s"
                )
            }
            Decision::BackupTakesOver { unit, fire } => {
                write!(f, "backup {unit} takes fire {fire} over")
            }
            Decision::Held { fire, changes } => write!(
                f,
                "fire {fire}'s attackers held: they changed {changes} times within {:.0} s; \
                 no unit joins or leaves it by choice until fewer have",
                crate::invariants::churn::WINDOW_S
            ),
            Decision::MergedAway { unit, from, kept } => write!(
                f,
                "release {unit} from fire {from}: it is fire {kept}, which has attackers of \
                 its own"
            ),
            Decision::Leaves {
                unit,
                from,
                to,
                was_backup,
            } => {
                if *was_backup {
                    write!(f, "{unit} leaves fire {from}, where it was a backup")
                } else {
                    write!(
                        f,
                        "{unit} leaves fire {from} for fire {to}, where it does more"
                    )
                }
            }
            Decision::Assign {
                unit,
                fire,
                backup,
                cost_s,
                runner_up,
                side,
            } => {
                let verb = if *backup { "send backup" } else { "assign" };
                write!(f, "{verb} {unit} to fire {fire}: cost {cost_s:.1} s; ")?;
                match runner_up {
                    Some((u, c)) => write!(f, "runner-up {u} at {c:.1} s")?,
                    None => write!(f, "no other free unit")?,
                }
                match side {
                    Some(s) if s.downwind => write!(
                        f,
                        "; from the {}, downwind (looked for from upwind in vain): air flows \
                         towards the {} at {:.1} m/s",
                        s.from, s.towards, s.air_m_s
                    ),
                    Some(s) => write!(
                        f,
                        "; from the {}: air flows towards the {} at {:.1} m/s",
                        s.from, s.towards, s.air_m_s
                    ),
                    None => Ok(()),
                }
            }
            Decision::DtsAlarm {
                fire,
                from_m,
                to_m,
                max_c,
            } => write!(
                f,
                "DTS alarm at chainage {from_m:.0}-{to_m:.0} m ({max_c:.0} C): fire {fire}, sent for before any unit has seen it"
            ),
            Decision::LeaveSmoke { unit, fire, to } => write!(
                f,
                "{unit} is downwind of fire {fire}, in its smoke: it withdraws to ({:.1}, {:.1}), towards the downstream portal",
                to.x, to.y
            ),
            Decision::Located { fire, at } => write!(
                f,
                "fire {fire}, placed by the DTS, seen by a unit at ({:.1}, {:.1}): its units go there",
                at.x, at.y
            ),
        }
    }
}

/// The side a unit attacks from while the air moves: the portal on that side, the portal
/// the air flows towards, and how fast, m/s; downwind when those are one.
#[derive(Debug, Clone, PartialEq)]
pub struct AttackSide {
    pub from: String,
    pub towards: String,
    pub air_m_s: f64,
    pub downwind: bool,
}

impl AttackSide {
    /// Attacking from `side` in air moving at `air_m_s` (positive towards the end), with
    /// `portals` the names at chainage 0 and at the end.
    pub fn new(side: Approach, air_m_s: f64, portals: &[String; 2]) -> Option<Self> {
        let from = match side {
            Approach::Start => &portals[0],
            Approach::End => &portals[1],
            Approach::Either => return None,
        };
        let towards_end = air_m_s > 0.0;
        Some(Self {
            from: from.clone(),
            towards: portals[usize::from(towards_end)].clone(),
            air_m_s: air_m_s.abs(),
            downwind: (side == Approach::End) == towards_end,
        })
    }
}

/// A decision and the site time it was made.
#[derive(Debug, Clone, PartialEq)]
pub struct Logged {
    pub t: f64,
    pub decision: Decision,
}

impl Logged {
    /// The decision as the bus and the status snapshot carry it.
    pub fn to_msg(&self) -> msg::Decision {
        msg::Decision {
            t: self.t,
            text: self.decision.to_string(),
            impostor: match self.decision {
                Decision::Impostor { rank } => Some(Identity::Coordinator(rank).to_string()),
                Decision::ScadaContradicted { .. } => Some(Identity::Scada.to_string()),
                _ => None,
            },
        }
    }
}

/// Units as a list for a sentence: `ugv-1, ugv-2`.
fn names(units: &[UnitId]) -> String {
    let names: Vec<&str> = units.iter().map(UnitId::as_str).collect();
    names.join(", ")
}
