//! The console's alarms as they stand, kept in its state directory: each alarm's state,
//! its counts and who acknowledged it, so that a restarted console (a crash, an upgrade,
//! a power cut) neither forgets an alarm nor sounds again one a commander acknowledged.
//!
//! The whole table is rewritten (a [`StateFile`]: atomic and checksummed) within
//! [`KEEP_EVERY_MS`] of an alarm's change, and at once when one is acknowledged, before the
//! commander is answered. The bound matters under attack: an impostor's every message
//! raises its alarm again, and a rewrite with two syncs per message would be the console's
//! busiest work. The table is small: open alarms and the last closed ones
//! [`crate::picture`] keeps.
//! Read back at start; a file that cannot be believed is said and moved aside (to
//! `alarms.json.unread`), and the console starts without it: the live site raises again
//! what still holds, and the audit log keeps who acknowledged what.
//!
//! Not here: the alarms' lifecycle ([`crate::picture`]) or who did what ([`crate::audit`]).

use std::path::Path;
use std::sync::Mutex;

use firefleet_model::state_file::{StateFile, StateFileError};

use crate::picture::Alert;

/// The file in the state directory.
pub const FILE: &str = "alarms.json";

/// The longest an alarm's change waits to be kept, ms.
pub const KEEP_EVERY_MS: u64 = 1000;

/// Where the alarms are kept, if anywhere.
#[derive(Debug)]
pub struct AlarmFile {
    file: Option<StateFile>,
    /// Whether a change is not kept yet, and when the table was last kept (ms).
    unkept: Mutex<(bool, u64)>,
}

impl AlarmFile {
    /// Alarms kept only in memory (a console with no state directory: a restart loses them).
    pub fn in_memory() -> Self {
        Self::new(None)
    }

    fn new(file: Option<StateFile>) -> Self {
        Self {
            file,
            unkept: Mutex::new((false, 0)),
        }
    }

    /// Whether the table is to be kept now, at `now_ms`, `changed` saying whether an alarm
    /// changed since the last call: a change waits at most [`KEEP_EVERY_MS`].
    pub fn due(&self, changed: bool, now_ms: u64) -> bool {
        let mut unkept = self
            .unkept
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        unkept.0 |= changed;
        self.file.is_some() && unkept.0 && now_ms >= unkept.1 + KEEP_EVERY_MS
    }

    /// The alarm file in `dir` (made if missing), and the alarms it holds: none if there is
    /// no file yet, or if it cannot be believed (then said, and moved aside).
    pub fn open(dir: &Path) -> Result<(Self, Vec<Alert>), StateFileError> {
        let file = StateFile::in_dir(dir, FILE)?;
        let alarms = match file.read() {
            Ok(None) => Ok(Vec::new()),
            Ok(Some(body)) => serde_json::from_slice(&body)
                .map_err(|e| format!("{}: not alarms ({e})", file.path().display())),
            Err(e) => Err(e.to_string()),
        };
        let alarms = alarms.unwrap_or_else(|why| {
            let aside = dir.join(format!("{FILE}.unread"));
            let moved = std::fs::rename(file.path(), &aside).map_or_else(
                |e| format!("not moved aside: {e}"),
                |()| format!("moved to {}", aside.display()),
            );
            tracing::error!("{why}; the console starts without the alarms kept ({moved})");
            Vec::new()
        });
        Ok((Self::new(Some(file)), alarms))
    }

    /// Keep `alarms` in place of what was kept, at `now_ms`. A write that fails is logged,
    /// not fatal: the alarms stand in memory, only their copy is behind (and tried again
    /// at the next change).
    pub fn keep(&self, alarms: &[Alert], now_ms: u64) {
        if let Some(file) = &self.file {
            let body = serde_json::to_vec(alarms).expect("alarms serialize");
            match file.write(&body) {
                Ok(()) => {
                    *self
                        .unkept
                        .lock()
                        .unwrap_or_else(std::sync::PoisonError::into_inner) = (false, now_ms)
                }
                Err(e) => tracing::error!("the alarms not kept: {e}"),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::picture::{AlertKind, Event, LOST_CONFIRM_MS, Picture};
    use crate::site::SiteMap;
    use firefleet_model::UnitId;
    use firefleet_model::scenario::Scenario;

    fn picture() -> Picture {
        let text = include_str!("../../model/scenarios/rail-tunnel.toml");
        Picture::new(SiteMap::new(
            &Scenario::from_toml(text, "rail-tunnel.toml").unwrap(),
        ))
    }

    #[test]
    fn a_restarted_console_has_its_alarms_back_acknowledged_as_they_were() {
        let dir = tempfile::tempdir().unwrap();
        let ugv = UnitId::new("ugv-1").unwrap();
        let mut before = picture();
        before.observe(0, Event::Link(true));
        before.observe(0, Event::CoordinatorAlive(0, true));
        before.observe(0, Event::UnitAlive(ugv.clone(), true));
        before.observe(0, Event::UnitAlive(ugv.clone(), false));
        before.delta(LOST_CONFIRM_MS).unwrap();
        let lost = before.alerts()[0].clone();
        assert!(matches!(&lost.kind, AlertKind::UnitLost { unit } if *unit == ugv));
        assert!(before.acknowledge(lost.id, "rossi"));
        let (file, kept) = AlarmFile::open(dir.path()).unwrap();
        assert!(kept.is_empty(), "nothing kept yet");
        assert!(file.due(true, 5_000), "a change, the first");
        file.keep(&before.alerts(), 5_000);
        assert!(!file.due(true, 5_500), "the next change waits");
        assert!(
            file.due(false, 6_000),
            "and is kept a second after the last"
        );

        // The console restarts: the alarm is back, acknowledged by rossi, in the first
        // picture a page gets and in the first delta.
        let (_, kept) = AlarmFile::open(dir.path()).unwrap();
        assert_eq!(kept, before.alerts());
        let mut after = picture();
        after.restore_alerts(kept);
        assert_eq!(after.incident().alerts, before.alerts());
        let first = after.delta(0).unwrap();
        assert_eq!(first.alerts[0].acked_by.as_deref(), Some("rossi"));
        // The unit heard again: back to normal, and closed (it was acknowledged).
        after.observe(0, Event::Link(true));
        after.observe(0, Event::UnitAlive(ugv, true));
        assert!(after.alerts()[0].closed(), "{:?}", after.alerts()[0]);
    }

    #[test]
    fn an_alarm_file_that_cannot_be_believed_is_moved_aside_and_the_console_starts_without_it() {
        let dir = tempfile::tempdir().unwrap();
        let (file, _) = AlarmFile::open(dir.path()).unwrap();
        file.keep(&[], 0);
        let path = dir.path().join(FILE);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes.extend_from_slice(b"tampered");
        std::fs::write(&path, &bytes).unwrap();
        let (file, kept) = AlarmFile::open(dir.path()).unwrap();
        assert!(kept.is_empty());
        assert_eq!(
            std::fs::read(dir.path().join(format!("{FILE}.unread"))).unwrap(),
            bytes,
            "kept for the operator as it was"
        );
        // And the next alarms are kept afresh.
        file.keep(&[], 0);
        assert!(AlarmFile::open(dir.path()).unwrap().1.is_empty());
    }
}
