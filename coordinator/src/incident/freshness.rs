//! Which messages are fresh: a unit's state or report is taken only if it is no older than
//! the last one taken from that unit on the same key, and within a tolerance of the site
//! clock.
//!
//! Why both: the router lets a stolen certificate put on its unit's keys, and a message
//! recorded earlier (a report of a fire since put out, a state from where the unit was a
//! minute ago) is as well formed as a new one. Ordering per sender stops a replay while the
//! unit itself still speaks; the window around the site clock stops one when it does not
//! (a unit lost, a recording replayed onto the live site) and a message dated ahead, which
//! would otherwise shut out every honest one after it.
//!
//! The window: [`BEHIND_S`] behind, [`AHEAD_S`] ahead, in site seconds. The simulator's
//! clock reaches the coordinator ten times a second and the units date their messages by
//! the same clock, so at the fastest time scale we run a whole pile-up at (x8) a message
//! a second of wall time late is still inside; on a real site the hosts' clocks agree to
//! within NTP's milliseconds. Equal times pass: a unit's state and its report of the same
//! instant are on different keys, and a repeat of the newest message changes nothing.
//!
//! **Order is judged against the site clock, not only the sender's last.** The newest
//! time kept for a sender is never later than the site clock when it was taken: a message
//! dated ahead (inside the window) counts as dated now. Otherwise one forward-dated lie from
//! a stolen key (a state 4.5 s ahead, sent again and again) made every real message
//! "older than the sender's last" for as long as the lies came, and the coordinator's
//! picture of that unit, or of a DTS zone, was the thief's alone (issue #52). The price: two
//! honest messages both dated ahead of the clock are not ordered among themselves, which
//! costs nothing, as both are within the hosts' clock difference of now.
//!
//! Pure: the caller says what time it is.

use firefleet_model::validate::Invalid;

/// How far behind the site clock a message may be dated, s.
pub const BEHIND_S: f64 = 10.0;
/// How far ahead of the site clock a message may be dated, s.
pub const AHEAD_S: f64 = 5.0;

/// The newest time taken from one sender on one key.
#[derive(Debug, Clone, Copy, Default)]
pub struct Newest(Option<f64>);

impl Newest {
    /// Take a message dated `sent` at site time `now`, or say why not.
    pub fn admit(&mut self, sent: f64, now: f64) -> Result<(), Invalid> {
        if sent < now - BEHIND_S {
            return Err(Invalid::new(
                "t",
                format!(
                    "{sent:.1} s is more than {BEHIND_S} s behind the site clock ({now:.1} s): stale or replayed"
                ),
            ));
        }
        if sent > now + AHEAD_S {
            return Err(Invalid::new(
                "t",
                format!(
                    "{sent:.1} s is more than {AHEAD_S} s ahead of the site clock ({now:.1} s)"
                ),
            ));
        }
        self.order(sent, now)
    }

    /// Take a message dated `sent` at site time `now` by order alone, whatever its distance
    /// from the clock (a reading its sender marks stale, dated when it was last good), or
    /// say why not.
    pub fn order(&mut self, sent: f64, now: f64) -> Result<(), Invalid> {
        if let Some(last) = self.0
            && sent < last
        {
            return Err(Invalid::new(
                "t",
                format!(
                    "{sent:.1} s is older than the sender's last message ({last:.1} s): replayed or reordered"
                ),
            ));
        }
        self.0 = Some(sent.min(now));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_is_taken_in_order_and_within_the_window_only() {
        let mut n = Newest::default();
        assert!(n.admit(100.0, 100.0).is_ok());
        assert!(
            n.admit(100.0, 100.5).is_ok(),
            "a repeat of the newest changes nothing"
        );
        assert!(
            n.admit(101.0, 100.5).is_ok(),
            "slightly ahead: clocks differ"
        );
        // The one ahead counts as dated 100.5 s, the clock when it came.
        let older = n.admit(100.4, 101.0).unwrap_err();
        assert!(
            older.to_string().contains("older than the sender's last"),
            "{older}"
        );
        let stale = Newest::default().admit(80.0, 100.0).unwrap_err();
        assert!(
            stale.to_string().contains("behind the site clock"),
            "{stale}"
        );
        let ahead = Newest::default().admit(106.0, 100.0).unwrap_err();
        assert!(
            ahead.to_string().contains("ahead of the site clock"),
            "{ahead}"
        );
        // A message dated ahead counts as dated now: the sender's next one, dated by the
        // clock, still passes, however often the one ahead is sent again.
        let mut n = Newest::default();
        for _ in 0..3 {
            assert!(n.admit(104.5, 100.0).is_ok());
        }
        assert!(
            n.admit(100.0, 100.0).is_ok(),
            "shut out by a forward-dated lie"
        );
        assert!(n.admit(99.0, 100.0).is_err(), "older than one taken now");
        let mut n = Newest::default();
        assert!(n.admit(1e9, 100.0).is_err());
        assert!(
            n.admit(100.0, 100.0).is_ok(),
            "a refused message sets nothing"
        );
    }
}
