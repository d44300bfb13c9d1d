//! Login throttling: failed logins cost the one who fails them ever more time.
//!
//! Every failed login counts against the client's address and against the name tried.
//! The first [`FREE_FAILURES`] cost nothing (a commander mistyping at 2 a.m.); after that
//! each failure closes the key for a delay that doubles, from one second up to
//! [`MAX_DELAY`], and a login from a closed address or for a closed name is refused at
//! once, without checking the password (429 with `Retry-After`). A success clears the
//! name and the address. By address *and* by name: one address guessing many names, and
//! many addresses guessing one name, are both slowed.
//!
//! What it costs a site: an attacker can keep a name closed (a commander then waits up to
//! [`MAX_DELAY`] between tries), which is the usual price; a commander whose name is being
//! guessed logs in from the console host's command line or under another name.
//!
//! Memory is bounded ([`MAX_KEYS`]): keys that are open and have not failed for a while
//! go first, then the oldest.
//!
//! Pure: the caller says what time it is.

use std::collections::HashMap;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Failures a key may have before delays start.
pub const FREE_FAILURES: u32 = 3;
/// The longest a key is closed after one failure.
pub const MAX_DELAY: Duration = Duration::from_secs(60);
/// Keys remembered at most.
pub const MAX_KEYS: usize = 4096;
/// A key that has not failed for this long starts afresh.
const FORGET_AFTER: Duration = Duration::from_secs(15 * 60);

#[derive(Debug, Clone, Copy)]
struct Strikes {
    failures: u32,
    closed_until: Instant,
    last: Instant,
}

/// Failed logins by key (`ip:…`, `name:…`).
#[derive(Debug, Default)]
pub struct Throttle {
    keys: Mutex<HashMap<String, Strikes>>,
}

impl Throttle {
    /// How long until all of `keys` are open again; `None` if they are now.
    pub fn closed_for(&self, keys: &[String], now: Instant) -> Option<Duration> {
        let map = self.keys.lock().expect("throttle lock");
        keys.iter()
            .filter_map(|k| map.get(k))
            .map(|s| s.closed_until.saturating_duration_since(now))
            .filter(|d| !d.is_zero())
            .max()
    }

    /// A login failed for `keys`.
    pub fn failed(&self, keys: &[String], now: Instant) {
        let mut map = self.keys.lock().expect("throttle lock");
        if map.len() + keys.len() > MAX_KEYS {
            map.retain(|_, s| s.closed_until > now && now.duration_since(s.last) < FORGET_AFTER);
        }
        while map.len() + keys.len() > MAX_KEYS {
            let Some(oldest) = map
                .iter()
                .min_by_key(|(_, s)| s.last)
                .map(|(k, _)| k.clone())
            else {
                break;
            };
            map.remove(&oldest);
        }
        for k in keys {
            let s = map.entry(k.clone()).or_insert(Strikes {
                failures: 0,
                closed_until: now,
                last: now,
            });
            if now.duration_since(s.last) >= FORGET_AFTER {
                s.failures = 0;
            }
            s.failures += 1;
            s.last = now;
            s.closed_until = now + delay(s.failures);
        }
    }

    /// A login succeeded for `keys`: they start afresh.
    pub fn succeeded(&self, keys: &[String]) {
        let mut map = self.keys.lock().expect("throttle lock");
        for k in keys {
            map.remove(k);
        }
    }
}

/// How long a key is closed after its `failures`-th failure.
fn delay(failures: u32) -> Duration {
    match failures.checked_sub(FREE_FAILURES + 1) {
        None => Duration::ZERO,
        Some(n) => Duration::from_secs(1u64 << n.min(16)).min(MAX_DELAY),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failures_close_a_key_for_ever_longer_after_the_free_ones_and_success_clears_it() {
        let t = Throttle::default();
        let t0 = Instant::now();
        let keys = ["ip:10.0.0.9".to_owned(), "name:rossi".to_owned()];
        for _ in 0..FREE_FAILURES {
            t.failed(&keys, t0);
            assert_eq!(t.closed_for(&keys, t0), None, "free");
        }
        let mut waits = Vec::new();
        let mut now = t0;
        for _ in 0..9 {
            t.failed(&keys, now);
            let wait = t.closed_for(&keys, now).unwrap();
            waits.push(wait.as_secs());
            now += wait;
            assert_eq!(t.closed_for(&keys, now), None);
        }
        assert_eq!(waits, [1, 2, 4, 8, 16, 32, 60, 60, 60]);
        // Another name from the same address is closed too; the same name from another
        // address too.
        t.failed(&keys, now);
        assert!(
            t.closed_for(&["ip:10.0.0.9".to_owned(), "name:verdi".to_owned()], now)
                .is_some()
        );
        assert!(
            t.closed_for(&["ip:10.0.0.7".to_owned(), "name:rossi".to_owned()], now)
                .is_some()
        );
        assert!(
            t.closed_for(&["ip:10.0.0.7".to_owned(), "name:verdi".to_owned()], now)
                .is_none()
        );
        t.succeeded(&keys);
        assert_eq!(t.closed_for(&keys, now), None);
        // After a success the next failure is a free one again.
        t.failed(&keys, now);
        assert!(t.closed_for(&keys, now).is_none());
    }

    #[test]
    fn memory_is_bounded() {
        let t = Throttle::default();
        let t0 = Instant::now();
        for k in 0..(2 * MAX_KEYS) {
            t.failed(&[format!("ip:{k}")], t0 + Duration::from_millis(k as u64));
        }
        assert!(t.keys.lock().unwrap().len() <= MAX_KEYS);
    }
}
