//! The goals in force, kept on the coordinator's own host.
//!
//! A commander's keep-out must outlive any combination of restarts: the coordinator, its
//! standby and the recorders all at once (a power cut, a shared host) left nobody on the
//! bus to answer `coord/goals`, and the keep-out was gone without a word. So every
//! coordinator and standby keeps the goals in force in its state directory, written each
//! time they change, and a starting coordinator takes them back before anything the bus
//! answers could be newer ([`crate::node`] weighs the three: this record, a standby's
//! memory, recorders' answers).
//!
//! What a restart needs is the set in force, which [`MAX_GOALS_IN_FORCE`] bounds to a few
//! kilobytes, so the record is that set, rewritten whole at each change
//! ([`firefleet_model::state_file`]: atomic, checksummed); the history of how it came to
//! be is in the recordings (`coord/log`, the goals and their acks), which `firefleet check`
//! and `replay` read. The body is JSON, so an operator can read what the coordinator will
//! take back with `cat`.
//!
//! [`MAX_GOALS_IN_FORCE`]: firefleet_protocol::msg::MAX_GOALS_IN_FORCE
//!
//! Not here: which record wins at a start ([`crate::node`]), or whether a goal taken back
//! still holds ([`crate::goals::Goals::restore`]).

use std::path::{Path, PathBuf};

use firefleet_model::state_file::{StateFile, StateFileError};
use firefleet_model::validate::Validate as _;
use firefleet_protocol::msg::GoalsInForce;

/// The record's file name in the state directory.
const FILE: &str = "goals-in-force.json";

/// The goals in force, in a state directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GoalJournal(StateFile);

impl GoalJournal {
    /// The record in `dir` ([`StateFile::in_dir`]).
    pub fn open(dir: &Path) -> Result<Self, StateFileError> {
        StateFile::in_dir(dir, FILE).map(Self)
    }

    /// The file the record is in.
    pub fn path(&self) -> PathBuf {
        self.0.path()
    }

    /// The goals in force as last stored; `None` if none were ever stored here.
    pub fn load(&self) -> Result<Option<GoalsInForce>, StateFileError> {
        let Some(body) = self.0.read()? else {
            return Ok(None);
        };
        let corrupt = |why: String| StateFileError::Corrupt {
            path: self.path(),
            why,
        };
        let goals: GoalsInForce = serde_json::from_slice(&body)
            .map_err(|e| corrupt(format!("not goals in force: {e}")))?;
        goals
            .validate()
            .map_err(|e| corrupt(format!("goals in force: {e}")))?;
        Ok(Some(goals))
    }

    /// Store `goals` in place of what was stored: whole or not at all.
    pub fn store(&self, goals: &GoalsInForce) -> Result<(), StateFileError> {
        let body = serde_json::to_vec_pretty(goals).expect("goals in force serialise");
        self.0.write(&body)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firefleet_model::{CommanderId, ZoneId};
    use firefleet_protocol::msg::{GoalInForce, GoalKind, MAX_GOALS_IN_FORCE, ZoneGoal};

    fn keep_out(t: f64) -> GoalsInForce {
        let rossi = CommanderId::new("rossi").unwrap();
        GoalsInForce {
            t,
            goals: vec![GoalInForce {
                goal: ZoneGoal::new(ZoneId::new("east").unwrap(), GoalKind::KeepOut, rossi),
                since: t - 3.0,
                until: Some(t + 600.0),
                proof: None,
            }],
            ..GoalsInForce::default()
        }
    }

    #[test]
    fn goals_stored_are_the_goals_loaded() {
        let d = tempfile::tempdir().unwrap();
        let j = GoalJournal::open(d.path()).unwrap();
        assert_eq!(j.load().unwrap(), None, "nothing stored yet");
        j.store(&keep_out(40.0)).unwrap();
        j.store(&keep_out(52.5)).unwrap();
        assert_eq!(j.load().unwrap(), Some(keep_out(52.5)));
    }

    #[test]
    fn a_record_that_checks_out_but_is_no_valid_set_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let j = GoalJournal::open(d.path()).unwrap();
        let mut bad = keep_out(40.0);
        bad.goals = vec![bad.goals[0].clone(); MAX_GOALS_IN_FORCE + 1];
        StateFile::in_dir(d.path(), FILE)
            .unwrap()
            .write(&serde_json::to_vec(&bad).unwrap())
            .unwrap();
        let e = j.load().unwrap_err().to_string();
        assert!(e.contains("goals in force: goals"), "{e}");
        StateFile::in_dir(d.path(), FILE)
            .unwrap()
            .write(b"[1, 2]")
            .unwrap();
        let e = j.load().unwrap_err().to_string();
        assert!(e.contains("not goals in force"), "{e}");
    }
}
