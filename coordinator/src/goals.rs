//! Incident commanders' zone goals: which are in force, and what each asks of the fleet.
//!
//! Zones are chainage ranges from the site file. A goal names a zone and asks for
//! `extinguish` (the default behaviour, with a priority), `contain` (hold the fire front
//! before a chainage), `monitor` (watch, do not attack), `keep-out` (no unit enters or
//! travels through) or `evacuate` (units inside leave now, then as keep-out). Goals may
//! expire. Every submission is answered: accepted, or rejected with the reason.
//!
//! Rules:
//! - Commanders have a rank from the site file ([`Rank`]: the incident commander above
//!   sector commanders; one not listed is a sector commander). A goal of a higher rank
//!   governs wherever it overlaps one of a lower rank, whatever the priorities; within a
//!   rank, the higher priority. A commander may amend, override or clear the goals of any
//!   lower rank, never those of an equal one: a sector commander's stolen certificate can
//!   bar the tunnel, and the incident commander can lift it.
//! - A goal's issuer is the commander named by the key it arrived on (which the site's
//!   access rules let only that commander put): `issued_by` is filled in from it, and a
//!   goal whose `issued_by` names someone else is rejected rather than believed.
//! - A goal with the id of one in force replaces it (a commander amends a goal); a goal
//!   in force is amended or cleared only by its issuer or a higher rank.
//! - A zone holds one ask per priority: a different goal at a priority already taken on
//!   that zone is a conflict (the same ask from another commander stands beside it), rejected with the goal in the way, unless the new goal's
//!   issuer outranks that goal's, whose goal it then overrides; a goal at another priority
//!   stands beside it.
//! - Goals are bounded: [`MAX_GOALS_PER_COMMANDER`] per commander, [`MAX_GOALS_IN_FORCE`]
//!   in all (what one `coord/goals` message carries, so the goals in force are always
//!   stored and recalled whole).
//! - On a secure site a goal and a clear arrive sealed by their issuer (the node checks
//!   the seal; here is what follows from its time): a goal sealed before a clear that
//!   covers it (its issuer's, or a higher rank's on its zone), or before the version of
//!   the same goal in force, is a replay and is refused. The newest sealed clear of each
//!   commander on each zone is kept ([`GoalsInForce::cleared`]), so a restart keeps
//!   refusing what it cleared.
//! - Where zones overlap, the governing goal covering a chainage (rank, then priority)
//!   governs it, for
//!   what it bars as for what it asks: a keep-out under a higher-priority extinguish goal is
//!   open where the two overlap ([`Goals::barred_space`] is what units are told).
//! - A keep-out or evacuate goal bars monorail carriages too unless it says
//!   `rail_allowed`.
//!
//! Pure: no I/O, no clock of its own.

use firefleet_model::UnitKind;
use firefleet_model::scenario::{CommanderSpec, Rank, Zone, rank_of};
use firefleet_model::{Chainage, CommanderId, ZoneId};
use firefleet_protocol::msg::{
    Bar, BarredSpace, BarredSpan, Cleared, GoalAck, GoalInForce, GoalsInForce, MAX_GOALS_IN_FORCE,
    Sealed, ZoneGoal, nearest_allowed,
};

/// Goals one commander may hold in force: a goal or two for each of a site's zones is
/// what command needs; a stolen certificate past this is refused rather than crowding out
/// everyone else's.
pub const MAX_GOALS_PER_COMMANDER: usize = 16;

/// A goal in force.
#[derive(Debug, Clone, PartialEq)]
pub struct Active {
    pub goal: ZoneGoal,
    pub start: Chainage,
    pub end: Chainage,
    /// Site time it took effect.
    pub since: f64,
    /// Site time it lapses, if ever.
    pub until: Option<f64>,
    /// Its issuer's rank.
    pub rank: Rank,
    /// The goal as its issuer sealed it (a secure site).
    pub proof: Option<Sealed>,
}

impl Active {
    /// What orders it against the others covering a chainage: rank, then priority.
    pub fn precedence(&self) -> (Rank, u8) {
        (self.rank, self.goal.priority)
    }

    pub fn covers(&self, s: Chainage) -> bool {
        (self.start..=self.end).contains(&s)
    }

    /// Whether a unit may not be in or travel through the zone ([`firefleet_protocol::msg::GoalKind::bars_entry`]).
    pub fn bars_entry(&self) -> bool {
        self.goal.goal.bars_entry()
    }

    /// Whether fires in the zone are not to be attacked ([`firefleet_protocol::msg::GoalKind::bars_attack`]).
    pub fn bars_attack(&self) -> bool {
        self.goal.goal.bars_attack()
    }
}

/// The goals in force on a site.
#[derive(Debug, Clone, Default)]
pub struct Goals {
    zones: Vec<Zone>,
    commanders: Vec<CommanderSpec>,
    active: Vec<Active>,
    /// Grows with every change to the goals in force: what depends on them only (what is
    /// barred, the goals published) need not be worked out again while it stands.
    revision: u64,
    /// Ids of goals lately lifted (cleared, lapsed, overridden), newest last: a unit that
    /// refuses a task for one of them has not heard yet.
    lifted: std::collections::VecDeque<String>,
    /// The newest sealed clear of each commander on each zone.
    cleared: Vec<Cleared>,
}

/// Lifted goal ids remembered.
const LIFTED_KEPT: usize = 64;

/// Seconds between two seal times, `later` after `earlier`.
fn ms_apart(later: u64, earlier: u64) -> f64 {
    later.saturating_sub(earlier) as f64 / 1000.0
}

/// Whether two goals ask the fleet for the same thing.
fn same_ask(a: &ZoneGoal, b: &ZoneGoal) -> bool {
    a.goal == b.goal && a.before_m == b.before_m && a.rail_allowed == b.rail_allowed
}

fn ack(g: &ZoneGoal, accepted: bool, reason: impl Into<String>) -> GoalAck {
    GoalAck {
        id: g.id.clone(),
        zone: g.zone.clone(),
        issued_by: g.issued_by.clone(),
        accepted,
        reason: reason.into(),
    }
}

impl Goals {
    /// The goals of a site with `zones`, whose commanders rank as `commanders` lists.
    pub fn new(zones: &[Zone], commanders: &[CommanderSpec]) -> Self {
        Self {
            zones: zones.to_vec(),
            commanders: commanders.to_vec(),
            active: Vec::new(),
            revision: 0,
            lifted: std::collections::VecDeque::new(),
            cleared: Vec::new(),
        }
    }

    fn note_lifted(&mut self, id: &str) {
        if self.lifted.len() == LIFTED_KEPT {
            self.lifted.pop_front();
        }
        self.lifted.push_back(id.to_owned());
    }

    /// Whether goal `id` was lately in force and bars nothing now (lifted, or amended to a
    /// goal that bars nothing).
    pub fn lifted(&self, id: &str) -> bool {
        match self.active.iter().find(|a| a.goal.id == id) {
            Some(a) => !a.bars_attack(),
            None => self.lifted.iter().any(|l| l == id),
        }
    }

    /// Take goal `g`, which arrived on zone `key_zone`'s key from commander `by` at site
    /// time `t`, unsealed (an open site).
    pub fn submit(&mut self, key_zone: &ZoneId, by: &CommanderId, g: ZoneGoal, t: f64) -> GoalAck {
        self.take(key_zone, by, g, t, None)
    }

    /// [`Goals::submit`] of a goal whose seal the node checked, `proof`.
    pub fn submit_sealed(
        &mut self,
        key_zone: &ZoneId,
        by: &CommanderId,
        g: ZoneGoal,
        t: f64,
        proof: Sealed,
    ) -> GoalAck {
        self.take(key_zone, by, g, t, Some(proof))
    }

    /// Why a goal of `by` with id `id` on `zone` sealed at `at_ms` is a replay, if it is:
    /// a clear that covers it was sealed later, or the version in force was.
    fn replayed(&self, zone: &ZoneId, by: &CommanderId, id: &str, at_ms: u64) -> Option<String> {
        let rank = rank_of(&self.commanders, by);
        if let Some(c) = self.cleared.iter().find(|c| {
            &c.zone == zone
                && c.proof.seal.at_ms >= at_ms
                && (&c.by == by || rank_of(&self.commanders, &c.by) > rank)
        }) {
            return Some(format!(
                "sealed before commander '{}' cleared zone '{zone}' ({:.1} s earlier): a replay",
                c.by,
                ms_apart(c.proof.seal.at_ms, at_ms)
            ));
        }
        self.active
            .iter()
            .filter_map(|a| Some((a, a.proof.as_ref()?.seal.at_ms)))
            .find(|(a, newer)| a.goal.id == id && *newer > at_ms)
            .map(|(_, newer)| {
                format!(
                    "sealed {:.1} s before the version of goal '{id}' in force: a replay",
                    ms_apart(newer, at_ms)
                )
            })
    }

    fn take(
        &mut self,
        key_zone: &ZoneId,
        by: &CommanderId,
        mut g: ZoneGoal,
        t: f64,
        proof: Option<Sealed>,
    ) -> GoalAck {
        if let Some(why) = proof
            .as_ref()
            .and_then(|p| self.replayed(key_zone, by, &g.id, p.seal.at_ms))
        {
            return ack(&g, false, why);
        }
        if &g.zone != key_zone {
            return ack(
                &g,
                false,
                format!("names zone '{}' but was sent on zone '{key_zone}'", g.zone),
            );
        }
        match &g.issued_by {
            None => g.issued_by = Some(by.clone()),
            Some(named) if named != by => {
                return ack(
                    &g,
                    false,
                    format!(
                        "says it is issued by '{named}' but was sent on commander '{by}''s key"
                    ),
                );
            }
            Some(_) => {}
        }
        let rank = rank_of(&self.commanders, by);
        if let Some(a) = self
            .active
            .iter()
            .find(|a| a.goal.id == g.id && a.goal.issued_by.as_ref() != Some(by) && a.rank >= rank)
        {
            return ack(
                &g,
                false,
                format!(
                    "goal '{}' in force was issued by {} commander '{}': only its issuer or a higher rank amends it",
                    g.id,
                    a.rank,
                    a.goal.issuer()
                ),
            );
        }
        let Some(zone) = self.zones.iter().find(|z| z.id == g.zone) else {
            let known: Vec<&str> = self.zones.iter().map(|z| z.id.as_str()).collect();
            return ack(
                &g,
                false,
                format!("unknown zone '{}' (zones: {})", g.zone, known.join(", ")),
            );
        };
        if let Some(b) = g.before_m
            && !(zone.start_m..=zone.end_m).contains(&Chainage::new(b))
        {
            return ack(
                &g,
                false,
                format!(
                    "before_m {b} is outside zone '{}' ([{}, {}])",
                    g.zone, zone.start_m, zone.end_m
                ),
            );
        }
        // Another commander's goal asking the same at the same priority is concurrence,
        // not a conflict: both stand, and either may clear theirs.
        let in_the_way = self.active.iter().position(|a| {
            a.goal.zone == g.zone
                && a.goal.priority == g.priority
                && a.goal.id != g.id
                && !same_ask(&a.goal, &g)
        });
        if let Some(other) = in_the_way.map(|i| &self.active[i])
            && other.rank >= rank
        {
            return ack(
                &g,
                false,
                format!(
                    "conflicts with goal '{}' ({}) of {} commander '{}' on zone '{}' at priority {}: clear it or use another priority",
                    other.goal.id,
                    other.goal.goal,
                    other.rank,
                    other.goal.issuer(),
                    g.zone,
                    g.priority
                ),
            );
        }
        let replaced = self.active.iter().position(|a| a.goal.id == g.id);
        if replaced.is_none() {
            let held = self
                .active
                .iter()
                .filter(|a| a.goal.issued_by.as_ref() == Some(by))
                .count();
            if held >= MAX_GOALS_PER_COMMANDER {
                return ack(
                    &g,
                    false,
                    format!(
                        "commander '{by}' holds {held} goals in force, the most one commander may: amend or clear one first"
                    ),
                );
            }
            if self.active.len() - usize::from(in_the_way.is_some()) >= MAX_GOALS_IN_FORCE {
                return ack(
                    &g,
                    false,
                    format!(
                        "the site holds {MAX_GOALS_IN_FORCE} goals in force, the most it may: clear some first"
                    ),
                );
            }
        }
        self.revision += 1;
        let active = Active {
            start: zone.start_m,
            end: zone.end_m,
            since: t,
            until: g.expires_s.map(|e| t + e),
            rank,
            goal: g,
            proof,
        };
        let mut reason = match replaced {
            Some(i) => {
                self.active[i] = active.clone();
                "accepted, replacing the goal with the same id".to_owned()
            }
            None => {
                self.active.push(active.clone());
                "accepted".to_owned()
            }
        };
        if let Some(i) = in_the_way {
            let gone = self.active.remove(i);
            self.note_lifted(&gone.goal.id);
            reason = format!(
                "{reason}, overriding goal '{}' ({}) of {} commander '{}'",
                gone.goal.id,
                gone.goal.goal,
                gone.rank,
                gone.goal.issuer()
            );
        }
        ack(&active.goal, true, reason)
    }

    /// Take back a goal a previous coordinator had in force (`coord/goals`, as a recorder
    /// kept it) at site time `t`, under the same rules as a new one, keeping when it took
    /// effect and when it lapses; one already lapsed is not taken.
    pub fn restore(&mut self, g: &GoalInForce, t: f64) -> GoalAck {
        if g.until.is_some_and(|u| u <= t) {
            return ack(&g.goal, false, "lapsed while no coordinator ran");
        }
        let Some(by) = g.goal.issued_by.clone() else {
            return ack(&g.goal, false, "names no commander as its issuer");
        };
        let a = self.take(
            &g.goal.zone.clone(),
            &by,
            g.goal.clone(),
            g.since,
            g.proof.clone(),
        );
        if a.accepted
            && let Some(active) = self.active.iter_mut().find(|x| x.goal.id == g.goal.id)
        {
            active.until = g.until;
        }
        a
    }

    /// The goals in force as of `t`, for `coord/goals`.
    pub fn in_force(&self, t: f64) -> GoalsInForce {
        GoalsInForce {
            t,
            goals: self
                .active
                .iter()
                .map(|a| GoalInForce {
                    goal: a.goal.clone(),
                    since: a.since,
                    until: a.until,
                    proof: a.proof.clone(),
                })
                .collect(),
            cleared: self.cleared.clone(),
            ..GoalsInForce::default()
        }
    }

    /// Clear commander `by`'s goals on `zone` as [`Goals::clear`] does, by a clear whose
    /// seal the node checked, `proof`, which is kept: a goal sealed before it stays
    /// cleared. A clear sealed before the newest one kept changes nothing.
    pub fn clear_sealed(
        &mut self,
        zone: &ZoneId,
        by: &CommanderId,
        proof: Sealed,
    ) -> Vec<ZoneGoal> {
        self.note_cleared(Cleared {
            zone: zone.clone(),
            by: by.clone(),
            proof,
        });
        self.clear(zone, by)
    }

    /// Keep `c` as its commander's newest clear of its zone, if it is newer. A goal in
    /// force sealed before it is not dropped here: [`Goals::clear`] does that, and a
    /// recalled clear comes before the goals recalled with it.
    pub fn note_cleared(&mut self, c: Cleared) {
        match self
            .cleared
            .iter_mut()
            .find(|k| k.zone == c.zone && k.by == c.by)
        {
            Some(k) if k.proof.seal.at_ms >= c.proof.seal.at_ms => {}
            Some(k) => *k = c,
            None => {
                // Bounded as the goals are: one per commander and zone, at most what one
                // message holds (the oldest goes first).
                if self.cleared.len() == MAX_GOALS_IN_FORCE {
                    self.cleared.remove(0);
                }
                self.cleared.push(c);
            }
        }
        self.revision += 1;
    }

    /// Clear commander `by`'s goals on `zone`, and those of every lower rank there; the
    /// goals cleared.
    pub fn clear(&mut self, zone: &ZoneId, by: &CommanderId) -> Vec<ZoneGoal> {
        let rank = rank_of(&self.commanders, by);
        let (gone, kept): (Vec<Active>, _) = self.active.drain(..).partition(|a| {
            &a.goal.zone == zone && (a.goal.issued_by.as_ref() == Some(by) || a.rank < rank)
        });
        self.active = kept;
        self.revision += u64::from(!gone.is_empty());
        for a in &gone {
            self.note_lifted(&a.goal.id);
        }
        gone.into_iter().map(|a: Active| a.goal).collect()
    }

    /// Drop the goals `lapses` picks (their issuer, or whoever sealed them, suspended); the
    /// goals dropped.
    pub fn lapse(&mut self, lapses: impl Fn(&Active) -> bool) -> Vec<ZoneGoal> {
        let (gone, kept) = self.active.drain(..).partition(|a| lapses(a));
        self.active = kept;
        self.revision += u64::from(!gone.is_empty());
        for a in &gone {
            self.note_lifted(&a.goal.id);
        }
        gone.into_iter().map(|a: Active| a.goal).collect()
    }

    /// Drop goals that lapsed by `t`; the goals dropped.
    pub fn expire(&mut self, t: f64) -> Vec<ZoneGoal> {
        let (gone, kept) = self
            .active
            .drain(..)
            .partition(|a| a.until.is_some_and(|u| u <= t));
        self.active = kept;
        self.revision += u64::from(!gone.is_empty());
        for a in &gone {
            self.note_lifted(&a.goal.id);
        }
        gone.into_iter().map(|a: Active| a.goal).collect()
    }

    /// Count a change to what the goals in force are published with beside the goals (a
    /// suspension, kept with them): it is told and journaled like a change of goals.
    pub fn touch(&mut self) {
        self.revision += 1;
    }

    /// Grows with every change to the goals in force.
    pub fn revision(&self) -> u64 {
        self.revision
    }

    pub fn active(&self) -> &[Active] {
        &self.active
    }

    /// The goal governing chainage `s`, if any.
    pub fn at(&self, s: Chainage) -> Option<&Active> {
        self.active
            .iter()
            .filter(|a| a.covers(s))
            .max_by_key(|a| a.precedence())
    }

    /// What the goals in force bar, stretch by stretch, as units are told at site time
    /// `t`: each stretch where the governing goal bars attack or entry, adjacent stretches
    /// of one goal merged.
    pub fn barred_space(&self, t: f64) -> BarredSpace {
        let mut cuts: Vec<Chainage> = self.active.iter().flat_map(|a| [a.start, a.end]).collect();
        cuts.sort_by(Chainage::total_cmp);
        cuts.dedup();
        let mut spans: Vec<BarredSpan> = Vec::new();
        for w in cuts.windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let Some(g) = self.at(lo.midpoint(hi)).filter(|g| g.bars_attack()) else {
                continue;
            };
            match spans.last_mut() {
                Some(last) if last.goal == g.goal.id && last.end == lo => last.end = hi,
                _ => spans.push(BarredSpan {
                    goal: g.goal.id.clone(),
                    zone: g.goal.zone.clone(),
                    start: lo,
                    end: hi,
                    bar: if g.bars_entry() {
                        Bar::Entry
                    } else {
                        Bar::Attack
                    },
                    rail_allowed: g.goal.rail_allowed,
                }),
            }
        }
        BarredSpace { t, spans }
    }

    /// Chainage ranges a unit of kind `kind` may not enter or travel through.
    pub fn barred(&self, kind: UnitKind) -> Vec<(Chainage, Chainage)> {
        self.barred_space(0.0).ranges(kind)
    }

    /// The nearest chainage to `x` outside every range barred to ground units, `margin`
    /// (m) clear of it, within `[lo, hi]`; `None` if there is none.
    pub fn nearest_allowed(
        &self,
        x: Chainage,
        margin: f64,
        lo: Chainage,
        hi: Chainage,
    ) -> Option<Chainage> {
        nearest_allowed(&self.barred(UnitKind::Ground), x, margin, lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use firefleet_protocol::msg::GoalKind;

    use super::*;

    fn c(m: f64) -> Chainage {
        Chainage::new(m)
    }

    fn z(id: &str, start: f64, end: f64) -> Zone {
        Zone {
            id: ZoneId::new(id).unwrap(),
            start_m: Chainage::new(start),
            end_m: Chainage::new(end),
        }
    }

    fn goal(id: &str, zone: &str, kind: GoalKind, priority: u8) -> ZoneGoal {
        ZoneGoal {
            id: id.into(),
            zone: ZoneId::new(zone).unwrap(),
            goal: kind,
            priority,
            before_m: (kind == GoalKind::Contain).then_some(60.0),
            expires_s: None,
            issued_by: Some(CommanderId::new("ic").unwrap()),
            rail_allowed: false,
        }
    }

    /// A goal naming no issuer: the key it is sent on names them.
    fn unsigned(id: &str, zone: &str, kind: GoalKind, priority: u8) -> ZoneGoal {
        ZoneGoal {
            issued_by: None,
            ..goal(id, zone, kind, priority)
        }
    }

    fn goals() -> Goals {
        Goals::new(
            &[
                z("a", 0.0, 100.0),
                z("b", 100.0, 200.0),
                z("c", 50.0, 150.0),
            ],
            &[CommanderSpec {
                id: CommanderId::new("chief").unwrap(),
                rank: Rank::Incident,
            }],
        )
    }

    fn zid(s: &str) -> ZoneId {
        ZoneId::new(s).unwrap()
    }

    fn ic() -> CommanderId {
        CommanderId::new("ic").unwrap()
    }

    /// A proof of `g` on `by`'s key sealed at `at_ms`: the rules here read only its time
    /// (the node checks the signature).
    fn proof(zone: &str, by: &CommanderId, payload: Option<&str>, at_ms: u64) -> Sealed {
        Sealed {
            key: format!("ff/s/zone/{zone}/goal/{by}"),
            payload: payload.map(str::to_owned),
            seal: firefleet_protocol::msg::Seal {
                cert: String::new(),
                at_ms,
                sig: String::new(),
            },
        }
    }

    #[test]
    fn a_sealed_goal_older_than_a_clear_or_its_version_in_force_is_a_replay() {
        let mut g = goals();
        let chief = CommanderId::new("chief").unwrap();
        let keep_out = || unsigned("ko", "a", GoalKind::KeepOut, 0);
        let sealed_at = |at| proof("a", &ic(), Some("{}"), at);
        assert!(
            g.submit_sealed(&zid("a"), &ic(), keep_out(), 0.0, sealed_at(1_000))
                .accepted
        );
        // The same goal put again (the tool's resend): the same seal, taken.
        assert!(
            g.submit_sealed(&zid("a"), &ic(), keep_out(), 0.5, sealed_at(1_000))
                .accepted
        );
        // Amended at 2 s; the version of 1 s put again after it is a replay.
        let monitor = unsigned("ko", "a", GoalKind::Monitor, 0);
        assert!(
            g.submit_sealed(&zid("a"), &ic(), monitor, 1.0, sealed_at(2_000))
                .accepted
        );
        let a = g.submit_sealed(&zid("a"), &ic(), keep_out(), 1.5, sealed_at(1_000));
        assert!(!a.accepted && a.reason.contains("a replay"), "{a:?}");
        // The chief clears zone a at 3 s: every lower rank's goal there sealed before is
        // cleared for good, kept in the goals in force; one sealed after is taken.
        assert_eq!(
            g.clear_sealed(&zid("a"), &chief, proof("a", &chief, None, 3_000))
                .len(),
            1
        );
        let a = g.submit_sealed(&zid("a"), &ic(), keep_out(), 2.0, sealed_at(2_500));
        assert!(
            !a.accepted && a.reason.contains("cleared zone 'a'"),
            "{a:?}"
        );
        let kept = g.in_force(2.0);
        assert_eq!(kept.cleared.len(), 1);
        let mut back = goals();
        back.note_cleared(kept.cleared[0].clone());
        let a = back.submit_sealed(&zid("a"), &ic(), keep_out(), 2.0, sealed_at(2_500));
        assert!(!a.accepted, "the clear outlives a restart: {a:?}");
        // An older clear changes nothing kept; a goal sealed after the clear stands.
        back.note_cleared(Cleared {
            zone: zid("a"),
            by: chief.clone(),
            proof: proof("a", &chief, None, 500),
        });
        assert_eq!(back.in_force(0.0).cleared[0].proof.seal.at_ms, 3_000);
        assert!(
            back.submit_sealed(&zid("a"), &ic(), keep_out(), 3.0, sealed_at(3_001))
                .accepted
        );
        // Another zone's clear does not touch it.
        assert!(
            back.submit_sealed(
                &zid("b"),
                &ic(),
                unsigned("x", "b", GoalKind::Monitor, 0),
                3.0,
                proof("b", &ic(), Some("{}"), 10)
            )
            .accepted
        );
    }

    #[test]
    fn bad_goals_are_rejected_with_the_reason() {
        let mut g = goals();
        let a = g.submit(&zid("q"), &ic(), goal("g1", "q", GoalKind::Monitor, 0), 0.0);
        assert!(
            !a.accepted && a.reason.contains("unknown zone 'q' (zones: a, b, c)"),
            "{a:?}"
        );
        let a = g.submit(&zid("b"), &ic(), goal("g1", "a", GoalKind::Monitor, 0), 0.0);
        assert!(
            !a.accepted && a.reason.contains("sent on zone 'b'"),
            "{a:?}"
        );
        let a = g.submit(&zid("b"), &ic(), goal("g1", "b", GoalKind::Contain, 0), 0.0);
        assert!(
            !a.accepted && a.reason.contains("before_m 60 is outside zone 'b'"),
            "{a:?}"
        );
        assert!(g.active().is_empty(), "nothing rejected is in force");
    }

    #[test]
    fn one_goal_per_zone_and_priority_and_the_higher_priority_governs() {
        let mut g = goals();
        assert!(
            g.submit(&zid("a"), &ic(), goal("g1", "a", GoalKind::Monitor, 1), 0.0)
                .accepted
        );
        let a = g.submit(&zid("a"), &ic(), goal("g2", "a", GoalKind::KeepOut, 1), 0.0);
        assert!(
            !a.accepted && a.reason.contains("conflicts with goal 'g1'"),
            "{a:?}"
        );
        // Amending g1 is fine; a higher priority stands beside it and wins.
        assert!(
            g.submit(
                &zid("a"),
                &ic(),
                goal("g1", "a", GoalKind::Extinguish, 1),
                0.0
            )
            .accepted
        );
        assert!(
            g.submit(
                &zid("c"),
                &ic(),
                goal("g3", "c", GoalKind::Evacuate, 5),
                0.0
            )
            .accepted
        );
        assert_eq!(g.at(c(20.0)).unwrap().goal.id, "g1");
        assert_eq!(
            g.at(c(70.0)).unwrap().goal.id,
            "g3",
            "overlap: the higher priority"
        );
        assert!(g.at(c(180.0)).is_none());
        assert_eq!(g.barred(UnitKind::Ground), vec![(c(50.0), c(150.0))]);
        assert_eq!(g.clear(&zid("c"), &ic()).len(), 1);
        assert!(g.barred(UnitKind::Ground).is_empty());
    }

    #[test]
    fn the_key_names_the_issuer_and_only_the_issuer_amends_or_clears() {
        let mut g = goals();
        let rossi = CommanderId::new("rossi").unwrap();
        let mallory = CommanderId::new("mallory").unwrap();
        let mut unsigned = goal("k", "b", GoalKind::KeepOut, 0);
        unsigned.issued_by = None;
        assert!(g.submit(&zid("b"), &rossi, unsigned, 0.0).accepted);
        assert_eq!(
            g.active()[0].goal.issued_by,
            Some(rossi.clone()),
            "filled in from the key"
        );

        let mut lie = goal("m", "a", GoalKind::Monitor, 0);
        lie.issued_by = Some(rossi.clone());
        let a = g.submit(&zid("a"), &mallory, lie, 0.0);
        assert!(!a.accepted && a.reason.contains("'mallory''s key"), "{a:?}");

        let mut amend = goal("k", "b", GoalKind::Extinguish, 0);
        amend.issued_by = None;
        let a = g.submit(&zid("b"), &mallory, amend, 0.0);
        assert!(!a.accepted && a.reason.contains("only its issuer"), "{a:?}");
        assert!(g.clear(&zid("b"), &mallory).is_empty());
        assert_eq!(g.active()[0].goal.goal, GoalKind::KeepOut);
        assert_eq!(g.clear(&zid("b"), &rossi).len(), 1);
    }

    #[test]
    fn a_higher_rank_governs_overrides_and_clears_a_lower_one_and_equal_ranks_cannot() {
        let mut g = goals();
        let chief = CommanderId::new("chief").unwrap();
        let rossi = CommanderId::new("rossi").unwrap();
        let bianchi = CommanderId::new("bianchi").unwrap();
        // A sector commander (a stolen certificate, say) bars both zones at the top
        // priority.
        for (id, zone) in [("x", "a"), ("y", "b")] {
            let a = g.submit(
                &zid(zone),
                &rossi,
                unsigned(id, zone, GoalKind::KeepOut, 255),
                0.0,
            );
            assert!(a.accepted, "{a:?}");
        }
        // Another sector commander can neither amend, override nor clear them.
        let a = g.submit(
            &zid("a"),
            &bianchi,
            unsigned("x", "a", GoalKind::Extinguish, 255),
            1.0,
        );
        assert!(
            !a.accepted && a.reason.contains("sector commander 'rossi'"),
            "{a:?}"
        );
        let a = g.submit(
            &zid("a"),
            &bianchi,
            unsigned("z", "a", GoalKind::Extinguish, 255),
            1.0,
        );
        assert!(
            !a.accepted && a.reason.contains("conflicts with goal 'x'"),
            "{a:?}"
        );
        assert!(g.clear(&zid("a"), &bianchi).is_empty());
        // The incident commander's extinguish goal at priority 0 governs zone a over the
        // keep-out at 255; at the same priority it overrides the keep-out on b.
        let a = g.submit(
            &zid("a"),
            &chief,
            unsigned("open-a", "a", GoalKind::Extinguish, 0),
            2.0,
        );
        assert!(a.accepted, "{a:?}");
        assert_eq!(g.at(c(20.0)).unwrap().goal.id, "open-a");
        let a = g.submit(
            &zid("b"),
            &chief,
            unsigned("open-b", "b", GoalKind::Extinguish, 255),
            2.0,
        );
        assert!(
            a.accepted && a.reason.contains("overriding goal 'y'"),
            "{a:?}"
        );
        assert!(
            g.barred(UnitKind::Ground).is_empty(),
            "{:?}",
            g.barred_space(2.0)
        );
        // The sector commander cannot put it back over the incident commander's.
        let a = g.submit(
            &zid("b"),
            &rossi,
            unsigned("y", "b", GoalKind::KeepOut, 255),
            3.0,
        );
        assert!(
            !a.accepted && a.reason.contains("incident commander 'chief'"),
            "{a:?}"
        );
        // Clearing a zone, the incident commander clears the lower ranks' goals there too.
        let cleared: Vec<String> = g
            .clear(&zid("a"), &chief)
            .into_iter()
            .map(|x| x.id)
            .collect();
        assert_eq!(cleared, ["x", "open-a"]);
        assert!(g.clear(&zid("b"), &rossi).is_empty(), "not the chief's");
    }

    #[test]
    fn two_commanders_asking_the_same_each_hold_their_goal_under_their_own_id() {
        let mut g = goals();
        let rossi = CommanderId::new("rossi").unwrap();
        let bianchi = CommanderId::new("bianchi").unwrap();
        let form = |by: &CommanderId| ZoneGoal::new(zid("a"), GoalKind::KeepOut, by.clone());
        let a = g.submit(&zid("a"), &rossi, form(&rossi), 0.0);
        assert!(a.accepted && a.id == "rossi-a-keep-out", "{a:?}");
        let b = g.submit(&zid("a"), &bianchi, form(&bianchi), 1.0);
        assert!(b.accepted && b.id == "bianchi-a-keep-out", "{b:?}");
        assert_eq!(b.issued_by.as_ref(), Some(&bianchi));
        assert_eq!(g.active().len(), 2);
        // Either clearing theirs leaves the other's in force.
        g.clear(&zid("a"), &rossi);
        assert_eq!(g.active().len(), 1);
        assert_eq!(g.active()[0].goal.issuer(), "bianchi");
        // A different ask at that priority is still a conflict, named with its issuer.
        let c = g.submit(
            &zid("a"),
            &rossi,
            ZoneGoal::new(zid("a"), GoalKind::Extinguish, rossi.clone()),
            2.0,
        );
        assert!(
            !c.accepted
                && c.issued_by.as_ref() == Some(&rossi)
                && c.reason.contains("conflicts with goal 'bianchi-a-keep-out' (keep-out) of sector commander 'bianchi'"),
            "{c:?}"
        );
    }

    #[test]
    fn goals_are_bounded_per_commander_and_the_goals_in_force_fit_one_message() {
        let mut g = goals();
        let rossi = CommanderId::new("rossi").unwrap();
        for p in 0..MAX_GOALS_PER_COMMANDER {
            let id = format!("g{p}");
            let a = g.submit(
                &zid("a"),
                &rossi,
                unsigned(&id, "a", GoalKind::Monitor, p as u8),
                0.0,
            );
            assert!(a.accepted, "{a:?}");
        }
        let a = g.submit(
            &zid("a"),
            &rossi,
            unsigned("one-more", "a", GoalKind::Monitor, 200),
            0.0,
        );
        assert!(!a.accepted && a.reason.contains("holds 16 goals"), "{a:?}");
        let a = g.submit(
            &zid("a"),
            &rossi,
            unsigned("g3", "a", GoalKind::Extinguish, 3),
            0.0,
        );
        assert!(a.accepted, "amending is not adding: {a:?}");
        // Every other commander still has room, up to what one message carries.
        // Each goal its own zone and priority: 3 zones x priorities above rossi's.
        let mut n = MAX_GOALS_PER_COMMANDER;
        let mut slot = 3 * MAX_GOALS_PER_COMMANDER;
        'commanders: for k in 0.. {
            let by = CommanderId::new(format!("c{k}")).unwrap();
            for p in 0..MAX_GOALS_PER_COMMANDER {
                let zone = ["a", "b", "c"][slot % 3];
                let prio = u8::try_from(slot / 3).unwrap();
                slot += 1;
                let id = format!("{by}-{p}");
                let a = g.submit(
                    &zid(zone),
                    &by,
                    unsigned(&id, zone, GoalKind::Monitor, prio),
                    0.0,
                );
                if !a.accepted {
                    assert!(a.reason.contains("the site holds 256"), "{a:?}");
                    break 'commanders;
                }
                n += 1;
            }
        }
        assert_eq!(n, MAX_GOALS_IN_FORCE);
        let all = g.in_force(1.0);
        assert_eq!(all.goals.len(), MAX_GOALS_IN_FORCE);
        firefleet_model::validate::Validate::validate(&all).expect("stored and recalled whole");
    }

    #[test]
    fn units_are_told_what_the_governing_goal_bars_stretch_by_stretch() {
        let mut g = goals();
        // Keep-out on b [100, 200] at 0, extinguish on c [50, 150] above it, monitor on a.
        let mut keep_out = goal("k", "b", GoalKind::KeepOut, 0);
        keep_out.rail_allowed = true;
        assert!(g.submit(&zid("b"), &ic(), keep_out, 0.0).accepted);
        assert!(
            g.submit(
                &zid("c"),
                &ic(),
                goal("x", "c", GoalKind::Extinguish, 3),
                0.0
            )
            .accepted
        );
        assert!(
            g.submit(&zid("a"), &ic(), goal("m", "a", GoalKind::Monitor, 0), 0.0)
                .accepted
        );
        let b = g.barred_space(7.0);
        let spans: Vec<(&str, f64, f64, Bar)> = b
            .spans
            .iter()
            .map(|s| (s.goal.as_str(), s.start.m(), s.end.m(), s.bar))
            .collect();
        assert_eq!(
            spans,
            vec![
                ("m", 0.0, 50.0, Bar::Attack),
                ("k", 150.0, 200.0, Bar::Entry)
            ]
        );
        assert_eq!(b.t, 7.0);
        assert_eq!(g.barred(UnitKind::Ground), vec![(c(150.0), c(200.0))]);
        assert!(g.barred(UnitKind::Monorail).is_empty(), "rail allowed");
    }

    #[test]
    fn goals_in_force_are_taken_back_with_their_times_and_lapsed_ones_are_not() {
        let mut g = goals();
        let mut x = goal("g1", "b", GoalKind::KeepOut, 0);
        x.expires_s = Some(100.0);
        assert!(g.submit(&zid("b"), &ic(), x, 10.0).accepted);
        assert!(
            g.submit(
                &zid("a"),
                &ic(),
                goal("g2", "a", GoalKind::Monitor, 1),
                20.0
            )
            .accepted
        );
        let kept = g.in_force(30.0);
        let mut back = goals();
        for f in &kept.goals {
            assert!(back.restore(f, 50.0).accepted);
        }
        assert_eq!(back.in_force(30.0), kept, "same goals, same times");
        assert_eq!(back.barred(UnitKind::Ground), g.barred(UnitKind::Ground));
        let mut late = goals();
        let a = late.restore(&kept.goals[0], 110.0);
        assert!(!a.accepted && a.reason.contains("lapsed"), "{a:?}");
    }

    #[test]
    fn goals_lapse() {
        let mut g = goals();
        let mut x = goal("g1", "b", GoalKind::KeepOut, 0);
        x.expires_s = Some(30.0);
        assert!(g.submit(&zid("b"), &ic(), x, 10.0).accepted);
        assert!(g.expire(39.0).is_empty());
        assert_eq!(g.expire(40.0).len(), 1);
        assert!(g.active().is_empty());
    }

    #[test]
    fn the_nearest_allowed_chainage_is_outside_every_barred_zone() {
        let mut g = goals();
        g.submit(&zid("b"), &ic(), goal("g1", "b", GoalKind::KeepOut, 0), 0.0);
        for (from, hi, want) in [
            (40.0, 300.0, 40.0),
            (120.0, 300.0, 95.0),
            (190.0, 300.0, 205.0),
            (190.0, 200.0, 95.0),
        ] {
            let got = g.nearest_allowed(c(from), 5.0, c(0.0), c(hi));
            assert_eq!(got, Some(c(want)), "from {from} within [0, {hi}]");
        }
    }
}
