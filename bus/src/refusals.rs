//! Refused messages logged as counted summaries: the first refusal of a sender for a
//! reason is logged at once, the rest once per [`INTERVAL`] as a count with the last
//! reason, so a flood of bad messages costs a line per sender and reason per interval, not
//! a line per message (a flood once wrote 518 MB of log in 15 s).
//!
//! A sender is what the message came on (a unit's key names the unit, and on a secure site
//! the router has checked that only that unit sends on it). At most [`MAX_SENDERS`] senders
//! are told apart; beyond that, refusals are summed under one entry, so a sender forging
//! many keys cannot make this grow.
//!
//! Not here: the counts a status reports ([`crate::RejectCounts`]).

use std::collections::HashMap;
use std::fmt::Display;
use std::time::{Duration, Instant};

/// How often a sender's refusals for one reason are summed up in the log.
pub const INTERVAL: Duration = Duration::from_secs(10);
/// How many senders are told apart.
pub const MAX_SENDERS: usize = 256;
const OTHERS: &str = "(other senders)";

#[derive(Debug)]
struct Since {
    /// Refused since the last line.
    unlogged: u64,
    logged_at: Instant,
}

/// The state of the summaries; [`Refusals::note`] says what to log, if anything.
#[derive(Debug, Default)]
pub struct Refusals {
    by: HashMap<(String, &'static str), Since>,
}

impl Refusals {
    /// Note that a message from `from` was refused for `class` (`reason` says how), at
    /// `now`; the line to log, if one is due.
    pub fn note(
        &mut self,
        from: &str,
        class: &'static str,
        reason: &dyn Display,
        now: Instant,
    ) -> Option<String> {
        let known = self.by.contains_key(&(from.to_owned(), class));
        let from = if known || self.by.len() < MAX_SENDERS {
            from
        } else {
            OTHERS
        };
        match self.by.get_mut(&(from.to_owned(), class)) {
            None => {
                self.by.insert(
                    (from.to_owned(), class),
                    Since {
                        unlogged: 0,
                        logged_at: now,
                    },
                );
                Some(format!("{from}: refused ({class}): {reason}"))
            }
            Some(s) => {
                s.unlogged += 1;
                if now.duration_since(s.logged_at) < INTERVAL {
                    return None;
                }
                // The summary is written on the refusal that ends the interval, so its
                // reason is the last one: nothing is kept (or formatted) in between.
                let line = format!(
                    "{from}: {} more refused ({class}) in {:.0} s; the last: {reason}",
                    s.unlogged,
                    now.duration_since(s.logged_at).as_secs_f64(),
                );
                s.unlogged = 0;
                s.logged_at = now;
                Some(line)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flood_is_a_line_per_sender_and_reason_per_interval() {
        let mut r = Refusals::default();
        let t0 = Instant::now();
        let mut lines = Vec::new();
        for i in 0..100_000u32 {
            let now = t0 + Duration::from_micros(u64::from(i) * 300);
            lines.extend(r.note("ff/s/unit/ugv-2/state", "invalid", &format!("bad {i}"), now));
        }
        // 30 s of flood: the first, then one summary per 10 s.
        assert_eq!(lines.len(), 3, "{lines:?}");
        assert_eq!(lines[0], "ff/s/unit/ugv-2/state: refused (invalid): bad 0");
        assert!(
            lines[1].starts_with(
                "ff/s/unit/ugv-2/state: 33334 more refused (invalid) in 10 s; the last: bad 33334"
            ),
            "{}",
            lines[1]
        );
        // Another reason, another sender: lines of their own.
        let later = t0 + Duration::from_secs(31);
        assert!(
            r.note("ff/s/unit/ugv-2/state", "undecodable", &"x", later)
                .is_some()
        );
        assert!(
            r.note("ff/s/unit/ugv-1/state", "invalid", &"x", later)
                .is_some()
        );
    }

    #[test]
    fn forged_senders_are_summed_beyond_a_bound() {
        let mut r = Refusals::default();
        let now = Instant::now();
        let firsts = (0..10_000)
            .filter_map(|i| r.note(&format!("ff/s/unit/u{i}/state"), "invalid", &"x", now))
            .count();
        assert_eq!(firsts, MAX_SENDERS + 1);
        assert_eq!(r.by.len(), MAX_SENDERS + 1);
    }
}
