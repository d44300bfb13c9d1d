//! A cap on the bytes one channel may add to a recording each second.
//!
//! A sender allowed on its own keys could fill the disk with them: 1 MB messages on one
//! unit's `bt` key grew a recording to 407 MB in 8 s. The router bounds each unit key's
//! rate and size (`firefleet_bus::limits`); this bounds what reaches the file on any link,
//! the plain one included, per channel, so one channel's flood leaves the others whole.
//! What is over the budget is not written and is counted ([`Budget::dropped`]).
//!
//! Not here: messages refused as invalid (counted as skipped), or those the recorder
//! could not take off the bus in time (counted as dropped by the bus).

use std::collections::HashMap;
use std::time::{Duration, Instant};

/// Bytes a channel may add each second: fifty times an honest unit's heaviest channel at
/// the fastest demo (its behaviour-tree batches, ~1 kB of JSON five times a second at
/// time x8), so no honest run ever meets it.
pub const BYTES_PER_CHANNEL_S: usize = 256 * 1024;
/// Channels told apart before old windows are forgotten.
const MAX_CHANNELS: usize = 4096;

/// Per channel: when its current second began and the bytes taken in it.
#[derive(Debug)]
pub struct Budget {
    per_s: usize,
    by: HashMap<String, (Instant, usize)>,
    dropped: u64,
}

impl Budget {
    pub fn new(per_s: usize) -> Self {
        Self {
            per_s,
            by: HashMap::new(),
            dropped: 0,
        }
    }

    /// Whether `bytes` more on `channel` at `now` fit its budget (and if so, they are
    /// taken from it).
    pub fn admit(&mut self, channel: &str, bytes: usize, now: Instant) -> bool {
        if self.by.len() >= MAX_CHANNELS && !self.by.contains_key(channel) {
            self.by
                .retain(|_, (since, _)| now.duration_since(*since) < Duration::from_secs(1));
        }
        let (since, used) = self.by.entry(channel.to_owned()).or_insert((now, 0));
        if now.duration_since(*since) >= Duration::from_secs(1) {
            (*since, *used) = (now, 0);
        }
        if *used + bytes > self.per_s {
            self.dropped += 1;
            return false;
        }
        *used += bytes;
        true
    }

    /// Messages not written for being over their channel's budget.
    pub fn dropped(&self) -> u64 {
        self.dropped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flooded_channel_is_cut_at_its_budget_and_others_stay_whole() {
        let mut b = Budget::new(10_000);
        let t0 = Instant::now();
        let mut written = 0;
        for i in 0..3000u64 {
            let now = t0 + Duration::from_millis(i);
            if b.admit("ff/s/unit/ugv-2/bt", 1000, now) {
                written += 1000;
            }
            assert!(b.admit("ff/s/unit/ugv-1/state", 3, now));
        }
        // Three seconds: ten thousand bytes each.
        assert_eq!(written, 30_000);
        assert_eq!(b.dropped(), 3000 - 30);
    }
}
