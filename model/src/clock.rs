//! How every process reads time.
//!
//! Algorithms never call `Instant::now()` or `SystemTime::now()` themselves: they take a
//! [`Clock`]. In the simulator the clock follows the simulator's `sim/clock` messages (the
//! ROS `/clock` convention), so a fleet run ten times faster than real time behaves the same
//! as one run in real time; on real hardware it is the system clock.
//!
//! Not here: timers or scheduling; a clock only tells the time.

use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{SystemTime, UNIX_EPOCH};

/// A source of site time, seconds.
pub trait Clock: Send + Sync {
    fn now(&self) -> f64;
}

/// Wall-clock time: seconds since the UNIX epoch, comparable across synchronised machines.
#[derive(Debug, Default, Clone, Copy)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn now(&self) -> f64 {
        SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map(|d| d.as_secs_f64())
            .unwrap_or(0.0)
    }
}

/// Time set from outside: by the simulator's clock messages, or by a test.
///
/// Cloning shares the same time. Time never runs backwards: an older value (a reordered
/// message) is ignored.
#[derive(Debug, Default, Clone)]
pub struct ExternalClock(Arc<AtomicU64>);

impl ExternalClock {
    pub fn new(t: f64) -> Self {
        Self(Arc::new(AtomicU64::new(t.to_bits())))
    }
    pub fn set(&self, t: f64) {
        if !t.is_finite() {
            return;
        }
        let _ = self
            .0
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |old| {
                (t > f64::from_bits(old)).then_some(t.to_bits())
            });
    }
}

impl Clock for ExternalClock {
    fn now(&self) -> f64 {
        f64::from_bits(self.0.load(Ordering::Acquire))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn external_clock_is_shared_and_monotonic() {
        let c = ExternalClock::new(1.0);
        let c2 = c.clone();
        c.set(2.5);
        assert_eq!(c2.now(), 2.5);
        c.set(2.0);
        c.set(f64::NAN);
        assert_eq!(c2.now(), 2.5);
    }
}
