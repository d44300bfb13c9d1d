//! Following who holds the coordinator's office from the bus: the leases heard, and the
//! coordinators suspended by asks whose seals this process checked itself.
//!
//! A unit obeys only the holder ([`firefleet_protocol::office`]), and a standby takes
//! office only when nobody holds it, so both need the suspensions as well as the leases:
//! a thief holding the key of the coordinator in office keeps its lease alive, and only a
//! suspension (two commanders' sealed asks, [`crate::suspension`]) takes the office from
//! it. Neither takes a suspension on anyone's word: each checks every ask's seal against
//! the site CA, live ones for freshness, and kept ones (those the goals in force carry,
//! for a process that starts after the asks) for their seal alone.
//!
//! Not here: the rule itself ([`firefleet_protocol::office::Leases`]), or what a unit or a
//! standby does when the holder changes.

use firefleet_protocol::keys::Topic;
use firefleet_protocol::msg::Sealed;
use firefleet_protocol::office::Leases;

use crate::Raw;
use crate::seal::SealCheck;
use crate::suspension::{self, Suspensions};

/// The office as one process follows it.
#[derive(Debug, Default)]
pub struct Office {
    leases: Leases,
    suspensions: Suspensions,
}

impl Office {
    /// The rank holding office now ([`Leases::holder`]).
    pub fn holder(&self) -> Option<u32> {
        self.leases.holder()
    }

    /// Whether a task from `rank` is obeyed.
    pub fn obeys(&self, rank: u32) -> bool {
        self.leases.obeys(rank)
    }

    /// Whether the coordinator of `rank` is suspended.
    pub fn suspended(&self, rank: u32) -> bool {
        self.leases.is_suspended(rank)
    }

    /// A token heard: a coordinator's lease appeared or lapsed (any other topic is not a
    /// lease and changes nothing). The holder before.
    pub fn token(&mut self, topic: &Topic, alive: bool) -> Option<u32> {
        let before = self.holder();
        if let Topic::CoordAlive(rank) = topic {
            self.leases.set(*rank, alive);
        }
        before
    }

    /// An ask to suspend heard live at `now_ms` (this host's clock), checked with `check`.
    /// The holder before, or why the ask was not taken.
    pub fn ask(
        &mut self,
        check: Option<&SealCheck>,
        sample: &Raw,
        now_ms: u64,
    ) -> Result<Option<u32>, String> {
        let before = self.holder();
        let (target, by, proof) = suspension::heard(check, sample, now_ms)?;
        self.suspensions
            .ask(&target, &by, proof)
            .map_err(|e| e.to_string())?;
        self.apply();
        Ok(before)
    }

    /// The asks kept with goals in force someone published, each taken if its seal holds.
    /// The holder before.
    pub fn kept(&mut self, check: &SealCheck, proofs: &[Sealed]) -> Option<u32> {
        let before = self.holder();
        self.suspensions.take_sealed(check, proofs);
        self.apply();
        before
    }

    /// The sealed asks of every identity suspended, to take back with the goals in force.
    pub fn asks(&self) -> Vec<Sealed> {
        self.suspensions.proofs()
    }

    fn apply(&mut self) {
        for rank in self.suspensions.coordinators() {
            self.leases.suspend(rank);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leases_come_and_go_and_the_holder_before_each_change_is_told() {
        let mut o = Office::default();
        assert_eq!(o.token(&Topic::CoordAlive(1), true), None);
        assert_eq!(o.token(&Topic::CoordAlive(0), true), Some(1));
        assert!(o.obeys(0) && !o.obeys(1));
        assert_eq!(o.token(&Topic::CoordStatus, true), Some(0), "no lease");
        assert_eq!(o.token(&Topic::CoordAlive(0), false), Some(0));
        assert_eq!(o.holder(), Some(1));
    }

    #[test]
    fn two_commanders_sealed_asks_take_office_from_a_coordinator_and_no_coordinator_s_does() {
        use crate::pki::{Terms, TlsFiles, make_site};
        use crate::seal::Seals;
        use firefleet_model::CommanderId;
        use firefleet_model::scenario::Scenario;

        let dir = tempfile::tempdir().unwrap();
        let site = Scenario::straight(100.0).ground("ugv-1", 5.0, -2.0).build();
        let commanders = ["rossi", "bianchi"].map(|c| CommanderId::new(c).unwrap());
        make_site(&site, &commanders, &Terms::default(), dir.path()).unwrap();
        let seals = |who: &str| Seals::load(&TlsFiles::in_dir(&dir.path().join(who))).unwrap();
        let check = seals("unit-ugv-1").check;
        let ask = |by: &str, at_ms: Option<u64>| {
            let key = format!("ff/tunnel-a/trust/suspend/coordinator/{by}");
            let body = br#"{"reason": "stolen"}"#;
            let sealer = seals(by).sealer;
            let seal = match at_ms {
                Some(at) => sealer.seal_at(&key, Some(body), at),
                None => sealer.seal(&key, Some(body)),
            };
            Raw {
                key,
                deleted: false,
                bytes: body.to_vec(),
                attachment: Some(seal.to_attachment()),
            }
        };
        let now = |r: &Raw| {
            firefleet_protocol::msg::Seal::from_attachment(r.attachment.as_ref().unwrap())
                .unwrap()
                .at_ms
        };
        let mut o = Office::default();
        o.token(&Topic::CoordAlive(0), true);
        o.token(&Topic::CoordAlive(1), true);
        // The standby's key asks: no coordinator suspends another.
        let standby = ask("coordinator-1", None);
        o.ask(Some(&check), &standby, now(&standby)).unwrap();
        assert_eq!(o.holder(), Some(0));
        // An unsealed ask, and one sealed an hour ago, are refused.
        let mut unsealed = ask("commander-rossi", None);
        unsealed.attachment = None;
        assert!(o.ask(Some(&check), &unsealed, now(&standby)).is_err());
        let stale = ask("commander-rossi", Some(now(&standby) - 3_600_000));
        assert!(o.ask(Some(&check), &stale, now(&standby)).is_err());
        // One commander alone does not suspend; the second does, and office passes on.
        let rossi = ask("commander-rossi", None);
        assert_eq!(o.ask(Some(&check), &rossi, now(&rossi)), Ok(Some(0)));
        assert_eq!(o.holder(), Some(0));
        let bianchi = ask("commander-bianchi", None);
        assert_eq!(o.ask(Some(&check), &bianchi, now(&bianchi)), Ok(Some(0)));
        assert_eq!(o.holder(), Some(1));
        assert!(o.suspended(0) && !o.obeys(0));
        // A process starting later takes the same asks from the goals in force.
        let proof = |r: &Raw| Sealed {
            key: r.key.clone(),
            payload: Some(String::from_utf8(r.bytes.clone()).unwrap()),
            seal: firefleet_protocol::msg::Seal::from_attachment(r.attachment.as_ref().unwrap())
                .unwrap(),
        };
        let mut late = Office::default();
        late.token(&Topic::CoordAlive(0), true);
        late.kept(&check, &[proof(&rossi)]);
        assert_eq!(late.holder(), Some(0));
        late.kept(&check, &[proof(&rossi), proof(&bianchi)]);
        assert_eq!(
            late.holder(),
            None,
            "suspended, and nobody else holds a lease"
        );
    }
}
