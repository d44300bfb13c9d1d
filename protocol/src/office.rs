//! Who holds the coordinator's office: the one rule every party of a site applies alike
//! (units to obey, coordinators to stand down, consoles to alarm).
//!
//! Office is a lease. A coordinator holds it while its liveliness token
//! (`coord/office/<rank>/alive`) is alive, and declares that token only when it finds none (a
//! standby once the incumbent's has lapsed, a coordinator starting only if nobody holds
//! office). The access rules let each coordinator identity declare only the token of its
//! own rank and put only tasks on `unit/<id>/task/<rank>`, so who holds office and who
//! sent a task are the routers' word, never something a message announces. An epoch
//! announced in a task deposes nobody: it only orders one holder's tasks, and the next
//! holder's after them.
//!
//! Two leases alive at once means a partition healed with a coordinator on each side, two
//! standbys that claimed together, or a thief holding a coordinator's key. Then **the
//! lowest rank holds office** and every other lease is a rival: units refuse its tasks, it
//! stands down if it is a real coordinator, and consoles alarm while it lasts. The rule
//! needs no memory of who came first, so a unit that starts while two leases are alive
//! obeys the same one as a unit that saw them come, and a split site converges the moment
//! it heals. What it costs: a thief holding the key of a lower rank than the one in office
//! (a dead coordinator's, say) takes office until that identity is suspended; the console's
//! alarm names it within a second, and a suspended rank holds nothing.
//!
//! Not here: the liveliness tokens themselves (`firefleet-bus`), or who may suspend.

use std::collections::BTreeSet;

/// The leases of a site's coordinators as one party sees them.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Leases {
    alive: BTreeSet<u32>,
    suspended: BTreeSet<u32>,
}

impl Leases {
    /// The lease of `rank` appeared (`true`) or lapsed.
    pub fn set(&mut self, rank: u32, alive: bool) {
        if alive {
            self.alive.insert(rank);
        } else {
            self.alive.remove(&rank);
        }
    }

    /// The identity of `rank` is suspended: it holds nothing, alive or not.
    pub fn suspend(&mut self, rank: u32) {
        self.suspended.insert(rank);
    }

    /// Whether the identity of `rank` is suspended.
    pub fn is_suspended(&self, rank: u32) -> bool {
        self.suspended.contains(&rank)
    }

    /// The rank of the coordinator in office: the lowest whose lease is alive and whose
    /// identity is not suspended.
    pub fn holder(&self) -> Option<u32> {
        self.alive
            .iter()
            .copied()
            .find(|r| !self.suspended.contains(r))
    }

    /// Whether a task from `rank` is to be obeyed: it holds office.
    pub fn obeys(&self, rank: u32) -> bool {
        self.holder() == Some(rank)
    }

    /// The leases alive besides the holder's, suspended ones aside: rivals, in rank order.
    pub fn rivals(&self) -> impl Iterator<Item = u32> + '_ {
        let holder = self.holder();
        self.alive
            .iter()
            .copied()
            .filter(move |r| Some(*r) != holder && !self.suspended.contains(r))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_lowest_live_rank_holds_office_whatever_order_the_leases_came_in() {
        for order in [[0, 1], [1, 0]] {
            let mut l = Leases::default();
            for r in order {
                l.set(r, true);
            }
            assert_eq!(l.holder(), Some(0));
            assert!(l.obeys(0) && !l.obeys(1));
            assert_eq!(l.rivals().collect::<Vec<_>>(), [1]);
        }
    }

    #[test]
    fn a_lapsed_lease_hands_office_to_the_next_and_a_suspended_rank_holds_nothing() {
        let mut l = Leases::default();
        assert_eq!(l.holder(), None);
        l.set(0, true);
        l.set(2, true);
        l.set(0, false);
        assert_eq!(l.holder(), Some(2));
        l.set(0, true);
        l.suspend(0);
        assert_eq!(l.holder(), Some(2));
        assert_eq!(l.rivals().count(), 0, "suspended, not a rival");
        l.suspend(2);
        assert_eq!(l.holder(), None);
    }
}
