//! Whose word to take: each unit's standing as a witness of fires.
//!
//! One unit's word confirms a fire (fusion's held rule): a lone unit that stops short of a
//! flame must not wait for a second unit that may never come. The price is that one unit's
//! reports, from a detector gone wrong or from a stolen certificate, send the fleet to
//! fires that are not there, again and again. So each unit's reports are weighed by how its
//! past claims fared against what the others saw:
//!
//! - a claim is *corroborated* when another unit reports the same fire;
//! - it is *contradicted* when another unit had the claimed spot in clear view (a flame
//!   there is one its sensors cannot miss: the incident decides what that is) for
//!   [`CONTRADICT_AFTER_S`] in all while the claim was live, and never reported it. Only a
//!   claim nobody else shares is contradicted: two witnesses outweigh one unit that saw
//!   nothing.
//!
//! A unit's weight is `(PRIOR + corroborated) / (PRIOR + corroborated + PENALTY x
//! contradicted)`: 1 until anything contradicts it. Its reports' confidences are scaled by
//! the weight; below [`DOUBT_BELOW`] the unit is *doubted*: its word alone no longer
//! confirms or reignites a fire, and a fire only it claims, once contradicted, goes back to
//! tentative (nobody is sent to it). Its reports are still fused: a doubted unit that
//! reports a fire somebody else also sees adds to it.
//!
//! How fast: a unit none of whose fires anyone else has seen is doubted at its first
//! contradiction (weight 0.4): one look by the unit sent to verify its claim. A liar with a
//! stolen certificate would otherwise send a unit to a second fake, and a third, each
//! costing the fleet a unit for the time a look takes. A unit one of whose fires another
//! has seen survives one contradiction (0.5: a flame hidden behind a parked car from where
//! the other looked); with two borne out, two. The price is an honest unit's first lone
//! claim behind such a car before anything it said was borne out: its word then needs a
//! second unit until a fire it reports is seen by another.
//!
//! What this does not stop: a liar that repeats the real fires the others report earns
//! corroboration for them, and so buys `PENALTY` contradictions' worth of credit per real
//! fire. The incident names every doubted unit, so a commander can take it off the site.
//!
//! Not here: what a unit has in clear view (the incident knows the units' sensors), fusing.

use std::collections::BTreeMap;

use firefleet_model::UnitId;

/// Seconds in all that another unit must have a claimed flame in clear view, without
/// reporting it, to contradict the claim: a flame in clear view is reported within a
/// second or two (the units' trackers keep a flame after three frames), and a unit
/// driving past a spot has it in view for less.
pub const CONTRADICT_AFTER_S: f64 = 10.0;
/// Below this weight a unit is doubted.
pub const DOUBT_BELOW: f64 = 0.5;
/// The credit every unit starts with, in corroborations.
const PRIOR: f64 = 2.0;
/// How many corroborations one contradiction undoes.
const PENALTY: f64 = 3.0;

/// How a unit's claims have fared.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Record {
    /// Fires it reported that another unit reported too.
    pub corroborated: u32,
    /// Fires only it reported that another unit had in clear view and never saw.
    pub contradicted: u32,
    /// Fires confirmed on its word alone that nothing bore out without a contradiction:
    /// lost with nobody else ever seeing them, or found to be another of its own lone
    /// fires (merged into it: a unit whose one flame starts a track, confirmed, a few
    /// metres from the track it already holds is seeing double, or making fires up).
    pub lone_unborne: u32,
}

impl Record {
    /// The weight of the unit's reports, in (0, 1].
    pub fn weight(&self) -> f64 {
        let c = f64::from(self.corroborated);
        let k = f64::from(self.contradicted);
        (PRIOR + c) / (PRIOR + c + PENALTY * k)
    }

    pub fn doubted(&self) -> bool {
        self.weight() < DOUBT_BELOW
    }

    /// Its lone claims nothing bore out: contradicted, lost with nobody else seeing them,
    /// or merged into another of its own. Unlike the weight, corroboration buys none of these back: a liar repeating
    /// the real fires the others see earns credit for its word, not for new fires of its
    /// own ([`lone_starts`]).
    pub fn unborne(&self) -> u32 {
        self.contradicted.saturating_add(self.lone_unborne)
    }
}

/// The new tracks a unit with `unborne` lone claims nothing bore out may start on its word
/// alone: a burst of `burst` less one for each, at least one, refilled one per `every_s`
/// doubled for each (up to 2^6 times: a unit reporting real fires after its detector's
/// bad spell is slowed, not silenced). An honest unit's first lone claim behind a parked
/// car halves its rate; a liar whose fakes are found out one after another (or left to be
/// lost) gets one new fire in minutes, where a fixed rate gave it one every `every_s`
/// for the whole incident.
pub fn lone_starts(unborne: u32, burst: f64, every_s: f64) -> (f64, f64) {
    let halvings = unborne.min(6);
    (
        (burst - f64::from(unborne)).max(1.0),
        every_s * f64::from(1u32 << halvings),
    )
}

/// Every unit's record.
#[derive(Debug, Clone, Default)]
pub struct Witnesses {
    records: BTreeMap<UnitId, Record>,
}

impl Witnesses {
    pub fn record(&self, unit: &UnitId) -> Record {
        self.records.get(unit).copied().unwrap_or_default()
    }

    pub fn weight(&self, unit: &UnitId) -> f64 {
        self.record(unit).weight()
    }

    pub fn doubted(&self, unit: &UnitId) -> bool {
        self.record(unit).doubted()
    }

    pub(super) fn corroborate(&mut self, unit: &UnitId) {
        let r = self.records.entry(unit.clone()).or_default();
        r.corroborated = r.corroborated.saturating_add(1);
    }

    /// Count a fire confirmed on `unit`'s word alone that nothing bore out
    /// ([`Record::lone_unborne`]).
    pub(super) fn lone_unborne(&mut self, unit: &UnitId) {
        let r = self.records.entry(unit.clone()).or_default();
        r.lone_unborne = r.lone_unborne.saturating_add(1);
    }

    /// Count a contradiction against `unit`; whether that made it doubted.
    pub(super) fn contradict(&mut self, unit: &UnitId) -> bool {
        let r = self.records.entry(unit.clone()).or_default();
        let was = r.doubted();
        r.contradicted = r.contradicted.saturating_add(1);
        !was && r.doubted()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_unit_is_believed_until_contradicted_and_doubted_by_one_look_unless_borne_out_before() {
        let r = |corroborated, contradicted| Record {
            corroborated,
            contradicted,
            lone_unborne: 0,
        };
        assert_eq!(r(0, 0).weight(), 1.0);
        assert_eq!(r(5, 0).weight(), 1.0);
        assert!((r(0, 1).weight() - 0.4).abs() < 1e-12);
        assert!(r(0, 1).doubted(), "nothing borne out: one look");
        assert!(!r(1, 1).doubted(), "one hidden flame does not make a liar");
        assert!(r(1, 2).doubted());
        assert!(!r(4, 2).doubted(), "corroboration buys credit back");
        assert!(r(4, 3).doubted());
    }

    #[test]
    fn each_lone_claim_nothing_bore_out_shrinks_the_burst_and_doubles_the_wait() {
        assert_eq!(lone_starts(0, 4.0, 5.0), (4.0, 5.0));
        assert_eq!(lone_starts(1, 4.0, 5.0), (3.0, 10.0));
        assert_eq!(lone_starts(5, 4.0, 5.0), (1.0, 160.0));
        assert_eq!(
            lone_starts(40, 4.0, 5.0),
            (1.0, 320.0),
            "slowed, never silenced"
        );
        let r = Record {
            corroborated: 9,
            contradicted: 1,
            lone_unborne: 2,
        };
        assert_eq!(r.unborne(), 3, "credit does not buy unborne claims back");
    }

    #[test]
    fn contradiction_says_when_it_tips_a_unit_into_doubt() {
        let mut w = Witnesses::default();
        let liar = UnitId::new("ugv-2").unwrap();
        w.corroborate(&liar);
        assert!(!w.contradict(&liar));
        assert!(w.contradict(&liar), "the second tips it");
        assert!(!w.contradict(&liar), "already doubted");
        assert!(w.doubted(&liar));
        assert!((w.weight(&liar) - 0.25).abs() < 1e-12);
        assert_eq!(w.weight(&UnitId::new("ugv-1").unwrap()), 1.0);
    }
}
