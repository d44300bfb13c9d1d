//! Search coverage: which stretches of the tunnel some unit's sensor has looked at, and
//! when.
//!
//! Alone, every unit patrols its lane from end to end, so two units that came in through
//! one portal look at the same metres twice and the stretch between the portals' parties
//! is reached last. The coordinator knows where every unit has looked: it sends free units
//! to the stretches nobody has seen ([`Coverage::gaps`]), from both ends when it can.
//!
//! Coverage is kept along the tunnel's chainage in [`BIN_M`] bins, each with the last time a
//! unit's sensor range took it in. It says where to search next, not where fire cannot be:
//! a stretch counts as seen whatever stood between (a vehicle, the inner wall of a bend),
//! and a fire can start in a stretch after it was seen; stretches go stale after a while
//! and are searched again.

use firefleet_model::Chainage;

/// Width of a coverage bin along the chainage, m.
pub const BIN_M: f64 = 5.0;

/// When each stretch of a tunnel was last looked at.
#[derive(Debug, Clone)]
pub struct Coverage {
    /// Last time each bin was in some unit's sight; `NEG_INFINITY` if never.
    seen: Vec<f64>,
}

impl Coverage {
    /// A tunnel `length_m` long that nobody has looked at yet.
    pub fn new(length_m: f64) -> Self {
        let bins = (length_m.max(0.0) / BIN_M).ceil().max(1.0) as usize;
        Self {
            seen: vec![f64::NEG_INFINITY; bins],
        }
    }

    /// A sensor took in chainages `from` to `to` at `t`: every bin whose middle lies in
    /// that range counts as seen.
    pub fn look(&mut self, from: Chainage, to: Chainage, t: f64) {
        let (lo, hi) = (from.min(to).m(), from.max(to).m());
        if !(lo.is_finite() && hi.is_finite()) {
            return;
        }
        let first = ((lo / BIN_M - 0.5).ceil().max(0.0)) as usize;
        let last = (hi / BIN_M - 0.5).floor();
        if last < 0.0 {
            return;
        }
        let last = (last as usize).min(self.seen.len() - 1);
        for s in self.seen.iter_mut().take(last + 1).skip(first) {
            *s = s.max(t);
        }
    }

    /// The stretches nobody has looked at since `since`, as (start, end) chainages, in
    /// order along the tunnel.
    pub fn gaps(&self, since: f64) -> Vec<(Chainage, Chainage)> {
        let at = |bin: usize| Chainage::new(bin as f64 * BIN_M);
        let mut gaps = Vec::new();
        let mut open: Option<usize> = None;
        for (i, &t) in self.seen.iter().enumerate() {
            match (t < since, open) {
                (true, None) => open = Some(i),
                (false, Some(start)) => {
                    gaps.push((at(start), at(i)));
                    open = None;
                }
                _ => {}
            }
        }
        if let Some(start) = open {
            gaps.push((at(start), at(self.seen.len())));
        }
        gaps
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn ch(m: f64) -> Chainage {
        Chainage::new(m)
    }

    #[test]
    fn nothing_seen_is_one_gap_the_length_of_the_tunnel() {
        assert_eq!(Coverage::new(300.0).gaps(0.0), vec![(ch(0.0), ch(300.0))]);
    }

    #[test]
    fn two_parties_from_the_portals_leave_the_middle_unseen() {
        let mut c = Coverage::new(300.0);
        c.look(ch(0.0), ch(85.0), 30.0);
        c.look(ch(225.0), ch(300.0), 30.0);
        assert_eq!(c.gaps(0.0), vec![(ch(85.0), ch(225.0))]);
    }

    #[test]
    fn a_stretch_seen_long_ago_is_stale_again() {
        let mut c = Coverage::new(100.0);
        c.look(ch(0.0), ch(50.0), 10.0);
        c.look(ch(50.0), ch(100.0), 100.0);
        assert!(c.gaps(5.0).is_empty());
        assert_eq!(c.gaps(20.0), vec![(ch(0.0), ch(50.0))]);
    }

    #[test]
    fn sight_beyond_the_portals_is_clipped() {
        let mut c = Coverage::new(100.0);
        c.look(ch(-30.0), ch(10.0), 1.0);
        c.look(ch(95.0), ch(130.0), 1.0);
        assert_eq!(c.gaps(0.0), vec![(ch(10.0), ch(95.0))]);
        c.look(ch(-50.0), ch(-20.0), 1.0);
        c.look(ch(150.0), ch(200.0), 1.0);
        assert_eq!(c.gaps(0.0), vec![(ch(10.0), ch(95.0))]);
    }

    proptest! {
        /// Gaps are ordered, disjoint, within the tunnel, and exactly the bins not seen.
        #[test]
        fn gaps_are_exactly_the_unseen_bins(
            looks in prop::collection::vec((-20.0..320.0f64, 0.0..60.0f64, 0.0..10.0f64), 0..12),
            since in 0.0..10.0f64,
        ) {
            let mut c = Coverage::new(300.0);
            for &(from, len, t) in &looks {
                c.look(Chainage::new(from), Chainage::new(from + len), t);
            }
            let gaps = c.gaps(since);
            for w in gaps.windows(2) {
                prop_assert!(w[0].1 < w[1].0);
            }
            for k in 0..c.seen.len() {
                let mid = (k as f64 + 0.5) * BIN_M;
                let in_gap = gaps.iter().any(|&(a, b)| (a..b).contains(&ch(mid)));
                let seen = looks.iter().any(|&(from, len, t)| {
                    t >= since && (from..=from + len).contains(&mid)
                });
                prop_assert_eq!(in_gap, !seen, "bin {}", k);
            }
        }
    }
}
