//! The coordinator node's timing rules, pure and tested without a bus: how long a unit's
//! vanished liveliness token may stay away before the unit counts as lost
//! ([`TokenGrace`]), and how the once-a-second re-sending of every task and track is
//! spread over slices ([`Republish`]).
//!
//! Wall-clock time comes in as an argument (`now`), never read here: failing over to
//! another router takes wall-clock time whatever the site time's scale, so the grace is
//! wall-clock, and a test can give any instant.
//!
//! Not here: site-time rules (leases, freshness: the incident core) or the bus loop
//! ([`crate::node`]).

use std::collections::HashMap;
use std::time::{Duration, Instant};

use firefleet_model::{FireId, UnitId};
use firefleet_protocol::keys::{RESEND_MS, SETTLED_RESEND_MS};

/// How long a unit's vanished liveliness token may stay away before the unit counts as lost
/// ([`firefleet_protocol::keys::TOKEN_GRACE_MS`], wall-clock time, as failing over takes);
/// a unit that died is still lost by its lease when that comes first (at faster-than-real
/// site time).
pub const TOKEN_GRACE: Duration = Duration::from_millis(firefleet_protocol::keys::TOKEN_GRACE_MS);

/// Units whose tokens vanished and are not yet taken for lost: a unit whose router died is
/// back on the next within the grace, and one back within it never counted as gone.
#[derive(Debug, Default)]
pub struct TokenGrace {
    vanished: HashMap<UnitId, Instant>,
}

impl TokenGrace {
    /// `unit`'s token vanished at `now` (the first time counts while it stays away).
    pub fn vanished(&mut self, unit: &UnitId, now: Instant) {
        self.vanished.entry(unit.clone()).or_insert(now);
    }

    /// `unit`'s token is back: whether it was within the grace (so it never counted as
    /// gone, and its return is no news).
    pub fn back(&mut self, unit: &UnitId) -> bool {
        self.vanished.remove(unit).is_some()
    }

    /// The units away past the grace at `now`: now lost, and no longer waited for.
    pub fn lapsed(&mut self, now: Instant) -> Vec<UnitId> {
        let gone: Vec<UnitId> = self
            .vanished
            .iter()
            .filter(|(_, at)| now.saturating_duration_since(**at) >= TOKEN_GRACE)
            .map(|(u, _)| u.clone())
            .collect();
        for u in &gone {
            self.vanished.remove(u);
        }
        gone
    }
}

/// Every task and burning fire's track is re-sent once a second ([`RESEND_MS`]), a slice at a time:
/// re-sending a thousand units' tasks at once would hold up the loop (and a report behind
/// it) for tens of milliseconds. A settled fire's track (out or lost) is re-sent once every
/// [`SETTLED_RESEND_MS`] instead.
///
/// Thin slices, fifty a second: a slice's puts hold up the loop, and the links and the
/// receivers behind them, in one burst. In `firefleet-lab scale` at 1000 units (a hundred
/// tasks and forty tracks a slice at ten a second) a slice took 1.2 ms to publish on
/// average, 3.9 ms at most, and in a round whose reports came on the slices' beat (one
/// every 50 ms against one slice every 100 ms) every other report's task came 7-9 ms
/// later than the median: that one round set the run's report-to-task p99.
#[derive(Debug, Default)]
pub struct Republish {
    /// Slices since the start, modulo [`Self::SLICES`] × [`Self::SETTLED_EVERY`].
    round: usize,
}

impl Republish {
    /// Slices a re-send round ([`RESEND_MS`]) is cut into.
    pub const SLICES: usize = 50;
    /// Time between two slices.
    pub const PERIOD: Duration = Duration::from_millis(RESEND_MS / Self::SLICES as u64);
    /// Rounds between two re-sends of a settled fire's track.
    pub const SETTLED_EVERY: usize = (SETTLED_RESEND_MS / RESEND_MS) as usize;

    /// The next slice; whether it is the first of a second (when the whole picture is
    /// told: barred space, counts).
    pub fn advance(&mut self) -> bool {
        self.round = (self.round + 1) % (Self::SLICES * Self::SETTLED_EVERY);
        self.slice() == 0
    }

    fn slice(&self) -> usize {
        self.round % Self::SLICES
    }

    /// This slice's share of `items`: every [`Self::SLICES`]th, so over a second each is
    /// sent once.
    pub fn share<T>(&self, items: impl Iterator<Item = T>) -> impl Iterator<Item = T> {
        let slice = self.slice();
        items
            .enumerate()
            .filter(move |(i, _)| i % Self::SLICES == slice)
            .map(|(_, item)| item)
    }

    /// Whether `fire`'s track is due in this slice: once a second, or once every
    /// [`Self::SETTLED_EVERY`] seconds if it is `settled`. By the fire's id, which stays
    /// put as fires come and go.
    pub fn fire_due(&self, fire: FireId, settled: bool) -> bool {
        let n = fire.0 as usize;
        if settled {
            n % (Self::SLICES * Self::SETTLED_EVERY) == self.round
        } else {
            n % Self::SLICES == self.slice()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn u(s: &str) -> UnitId {
        UnitId::new(s).unwrap()
    }

    #[test]
    fn a_token_back_within_the_grace_never_counts_and_one_away_past_it_does() {
        let mut g = TokenGrace::default();
        let t0 = Instant::now();
        g.vanished(&u("a"), t0);
        g.vanished(&u("b"), t0);
        // Vanishing again while away does not restart the grace.
        g.vanished(&u("b"), t0 + TOKEN_GRACE / 2);
        assert!(g.lapsed(t0 + TOKEN_GRACE / 2).is_empty());
        assert!(g.back(&u("a")), "back within the grace");
        assert_eq!(g.lapsed(t0 + TOKEN_GRACE), vec![u("b")]);
        // Lost once: not again, and its return is news.
        assert!(g.lapsed(t0 + 3 * TOKEN_GRACE).is_empty());
        assert!(!g.back(&u("b")));
    }

    #[test]
    fn every_item_is_republished_once_a_second_and_the_second_starts_whole() {
        let mut r = Republish::default();
        let mut sent = vec![0; 37];
        let mut whole = 0;
        for _ in 0..Republish::SLICES {
            whole += usize::from(r.advance());
            for i in r.share(0..sent.len()) {
                sent[i] += 1;
            }
        }
        assert_eq!(whole, 1);
        assert!(sent.iter().all(|&n| n == 1), "{sent:?}");
    }

    #[test]
    fn a_burning_fire_is_resent_every_second_and_a_settled_one_every_ten() {
        let mut r = Republish::default();
        let fires = 0..37u32;
        let (mut burning, mut settled) = (vec![0; 37], vec![0; 37]);
        // Twenty seconds of slices, from any point in the round.
        r.advance();
        for _ in 0..20 * Republish::SLICES {
            r.advance();
            for f in fires.clone() {
                burning[f as usize] += usize::from(r.fire_due(FireId(f), false));
                settled[f as usize] += usize::from(r.fire_due(FireId(f), true));
            }
        }
        assert!(burning.iter().all(|&n| n == 20), "{burning:?}");
        assert!(
            settled.iter().all(|&n| n == 20 / Republish::SETTLED_EVERY),
            "{settled:?}"
        );
    }
}
