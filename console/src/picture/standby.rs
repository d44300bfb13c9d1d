//! Whether each standby coordinator follows the incident: one that holds its token but has
//! stopped hearing the coordinator in office (cut off from it, hung) would take office
//! knowing neither the goals in force nor the fires, and its token alone cannot tell. Each
//! standby says every second what it follows ([`StandbyHealth`]): the site time of the
//! newest goals in force it heard. The coordinator re-sends them every second, so a
//! standby that follows has heard, by now, the goals this console heard
//! [`STANDBY_SILENT_MS`] ago; one that has not, or that has said nothing for that long, is
//! not following: an alarm until it is again.
//!
//! Judged by when this console heard the goals (wall time), not by their site times: at
//! eight times real time one wall second is eight of the site's.
//!
//! Not here: a standby gone (its token vanished: the parent module).

use super::*;
use firefleet_protocol::msg::StandbyHealth;

/// A standby that has said nothing for this long, or has not heard the goals in force this
/// console heard this long ago, is not following, ms: three of its one-second words.
pub const STANDBY_SILENT_MS: u64 = 3000;
/// The coordinator's goals in force kept, by when heard, to judge the standbys by: past
/// [`STANDBY_SILENT_MS`] with room for a late word.
const GOALS_KEPT_MS: u64 = 3 * STANDBY_SILENT_MS;

/// What a standby said last, and since when its token has been present (ms).
#[derive(Debug, Clone, Copy)]
pub(super) struct Following {
    since_ms: u64,
    said_ms: Option<u64>,
    goals_t: Option<f64>,
}

impl Following {
    /// A standby first heard of at `now_ms`, that has said nothing yet.
    fn since(now_ms: u64) -> Self {
        Self {
            since_ms: now_ms,
            said_ms: None,
            goals_t: None,
        }
    }
}

impl Picture {
    /// Standby `rank`'s token appeared at `now_ms` (its silence is counted from then).
    pub(super) fn standby_appeared(&mut self, rank: u32, now_ms: u64) {
        self.following
            .entry(rank)
            .or_insert(Following::since(now_ms));
    }

    /// Standby `rank`'s token vanished: whether it followed is moot (its going is an
    /// alarm of its own).
    pub(super) fn standby_vanished(&mut self, rank: u32) {
        self.following.remove(&rank);
        if self.not_following.remove(&rank) {
            self.settle(|k| *k == AlertKind::StandbyNotFollowing { rank });
        }
    }

    /// What a standby says it follows, heard at `now_ms`.
    pub(super) fn standby_said(&mut self, now_ms: u64, h: StandbyHealth) {
        let f = self
            .following
            .entry(h.rank)
            .or_insert(Following::since(now_ms));
        f.said_ms = Some(now_ms);
        f.goals_t = h.goals_t;
    }

    /// The coordinator's goals in force of site time `t`, heard at `now_ms`.
    pub(super) fn goals_heard(&mut self, now_ms: u64, t: f64) {
        self.goals_heard_at.push_back((now_ms, t));
        while self
            .goals_heard_at
            .front()
            .is_some_and(|&(at, _)| now_ms > at.saturating_add(GOALS_KEPT_MS))
        {
            self.goals_heard_at.pop_front();
        }
    }

    /// Raise, or return to normal, each standby's not-following alarm at `now_ms`.
    pub(super) fn judge_standbys(&mut self, now_ms: u64) {
        // Long enough ago that every follower has since heard and said it.
        let due = |at: u64| at.saturating_add(STANDBY_SILENT_MS) <= now_ms;
        // The newest goals the console heard that long ago.
        let owed = self
            .goals_heard_at
            .iter()
            .filter(|&&(at, _)| due(at))
            .map(|&(_, t)| t)
            .reduce(f64::max);
        let ranks: Vec<u32> = self.standbys.iter().copied().collect();
        for rank in ranks {
            let Some(f) = self.following.get(&rank).copied() else {
                continue;
            };
            let silent_since = f.said_ms.unwrap_or(f.since_ms);
            let why = if due(silent_since) {
                Some(format!(
                    "has said nothing of what it follows for {:.0} s (hung, or cut off)",
                    now_ms.saturating_sub(silent_since) as f64 / 1000.0
                ))
            } else {
                match (owed, f.goals_t) {
                    (Some(owed), None) if due(f.since_ms) => Some(format!(
                        "has heard no goals in force from the coordinator (it sent those of \
                         t={owed:.1} s)"
                    )),
                    (Some(owed), Some(t)) if t < owed => Some(format!(
                        "follows the goals in force of t={t:.1} s; the coordinator sent \
                         those of t={owed:.1} s"
                    )),
                    _ => None,
                }
            };
            match why {
                Some(why) if self.not_following.insert(rank) => self.raise(
                    AlertKind::StandbyNotFollowing { rank },
                    format!(
                        "standby coordinator rank {rank} does not follow the incident: it \
                         {why}. If it took office it would not know the goals in force or \
                         the fires"
                    ),
                ),
                None if self.not_following.remove(&rank) => {
                    self.settle(|k| *k == AlertKind::StandbyNotFollowing { rank });
                }
                _ => {}
            }
        }
    }
}
