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
//! Why one file replaced whole rather than an append-only log or an embedded database:
//! what a restart needs is the set in force, which [`MAX_GOALS_IN_FORCE`] bounds to a few
//! kilobytes; the history of how it came to be is in the recordings (`coord/log`, the goals
//! and their acks), which `firefleet check` and `replay` read. Writing a new file, syncing
//! it, renaming it over the old and syncing the directory is atomic on every POSIX file
//! system: a crash leaves the old set or the new, never half of one. The SHA-256 on the
//! first line catches what rename cannot (a file edited by hand, a disk that rotted); such
//! a file is refused with the reason, never half-believed. The body is JSON, so an operator
//! can read what the coordinator will take back with `cat`.
//!
//! [`MAX_GOALS_IN_FORCE`]: firefleet_protocol::msg::MAX_GOALS_IN_FORCE
//!
//! Not here: which record wins at a start ([`crate::node`]), or whether a goal taken back
//! still holds ([`crate::goals::Goals::restore`]).

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use firefleet_model::validate::Validate as _;
use firefleet_protocol::msg::GoalsInForce;
use sha2::Digest as _;

/// The record's file name in the state directory.
const FILE: &str = "goals-in-force.json";

/// The first line's words before the checksum.
const HEADER: &str = "# firefleet goals in force, sha256";

/// Why the record could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum JournalError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The file is there but is no record this coordinator wrote whole.
    #[error("{}: {why}", path.display())]
    Corrupt { path: PathBuf, why: String },
}

/// The goals in force, in a state directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GoalJournal {
    dir: PathBuf,
}

impl GoalJournal {
    /// The record in `dir`, which must be a directory this process may write in: checked
    /// now, so that a coordinator that could not keep its goals says so at start, not at
    /// the first keep-out.
    pub fn open(dir: &Path) -> Result<Self, JournalError> {
        let io = |source| JournalError::Io {
            path: dir.to_owned(),
            source,
        };
        fs::create_dir_all(dir).map_err(io)?;
        let probe = dir.join(format!(".{FILE}.probe"));
        fs::write(&probe, b"").map_err(io)?;
        fs::remove_file(&probe).map_err(io)?;
        Ok(Self {
            dir: dir.to_owned(),
        })
    }

    /// The file the record is in.
    pub fn path(&self) -> PathBuf {
        self.dir.join(FILE)
    }

    /// The goals in force as last stored; `None` if none were ever stored here.
    pub fn load(&self) -> Result<Option<GoalsInForce>, JournalError> {
        let path = self.path();
        let text = match fs::read_to_string(&path) {
            Ok(t) => t,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(JournalError::Io { path, source }),
        };
        let corrupt = |why: String| JournalError::Corrupt {
            path: path.clone(),
            why,
        };
        let (first, body) = text
            .split_once('\n')
            .ok_or_else(|| corrupt("no header line".into()))?;
        let sum = first
            .strip_prefix(HEADER)
            .map(str::trim)
            .ok_or_else(|| corrupt(format!("the first line is not '{HEADER} <hex>'")))?;
        if sum != digest(body) {
            return Err(corrupt(
                "its checksum does not match its contents (edited, or damaged on disk)".into(),
            ));
        }
        let goals: GoalsInForce =
            serde_json::from_str(body).map_err(|e| corrupt(format!("not goals in force: {e}")))?;
        goals
            .validate()
            .map_err(|e| corrupt(format!("goals in force: {e}")))?;
        Ok(Some(goals))
    }

    /// Store `goals` in place of what was stored: whole or not at all.
    pub fn store(&self, goals: &GoalsInForce) -> Result<(), JournalError> {
        let path = self.path();
        let new = self.dir.join(format!("{FILE}.new"));
        let io = |path: &Path| {
            let path = path.to_owned();
            move |source| JournalError::Io { path, source }
        };
        let body = serde_json::to_string_pretty(goals).expect("goals in force serialise");
        let mut f = fs::File::create(&new).map_err(io(&new))?;
        writeln!(f, "{HEADER} {}", digest(&body)).map_err(io(&new))?;
        f.write_all(body.as_bytes()).map_err(io(&new))?;
        f.sync_all().map_err(io(&new))?;
        fs::rename(&new, &path).map_err(io(&path))?;
        // The rename itself is durable once the directory is.
        fs::File::open(&self.dir)
            .and_then(|d| d.sync_all())
            .map_err(io(&self.dir))
    }
}

fn digest(body: &str) -> String {
    sha2::Sha256::digest(body.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
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
            }],
            stranded: Vec::new(),
            trapped: Vec::new(),
        }
    }

    #[test]
    fn goals_stored_are_the_goals_loaded_and_the_newest_store_wins() {
        let d = tempfile::tempdir().unwrap();
        let j = GoalJournal::open(&d.path().join("state")).unwrap();
        assert_eq!(j.load().unwrap(), None, "nothing stored yet");
        j.store(&keep_out(40.0)).unwrap();
        j.store(&keep_out(52.5)).unwrap();
        assert_eq!(j.load().unwrap(), Some(keep_out(52.5)));
        // A second coordinator on the same directory (a restart) reads what the first kept.
        let again = GoalJournal::open(&d.path().join("state")).unwrap();
        assert_eq!(again.load().unwrap(), Some(keep_out(52.5)));
    }

    #[test]
    fn a_record_edited_or_damaged_is_refused_with_the_reason() {
        let d = tempfile::tempdir().unwrap();
        let j = GoalJournal::open(d.path()).unwrap();
        j.store(&keep_out(40.0)).unwrap();
        let text = fs::read_to_string(j.path()).unwrap();
        // A goal moved to another zone by hand: the checksum no longer holds.
        fs::write(j.path(), text.replace("\"east\"", "\"west\"")).unwrap();
        let e = j.load().unwrap_err().to_string();
        assert!(e.contains("checksum does not match"), "{e}");
        assert!(e.contains(FILE), "the error names the file: {e}");
        // Cut short (a disk full mid-write by something other than `store`).
        fs::write(j.path(), &text[..text.len() / 2]).unwrap();
        assert!(j.load().is_err());
        fs::write(j.path(), "{}").unwrap();
        let e = j.load().unwrap_err().to_string();
        assert!(e.contains("no header line"), "{e}");
    }

    #[test]
    fn a_record_that_checks_out_but_breaks_the_goals_bounds_is_refused() {
        let d = tempfile::tempdir().unwrap();
        let j = GoalJournal::open(d.path()).unwrap();
        let mut bad = keep_out(40.0);
        bad.goals = vec![bad.goals[0].clone(); MAX_GOALS_IN_FORCE + 1];
        let body = serde_json::to_string_pretty(&bad).unwrap();
        fs::write(j.path(), format!("{HEADER} {}\n{body}", digest(&body))).unwrap();
        assert!(j.load().is_err());
    }

    #[test]
    fn a_directory_that_cannot_be_written_is_refused_at_open() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("a-file");
        fs::write(&file, b"").unwrap();
        let e = GoalJournal::open(&file).unwrap_err().to_string();
        assert!(e.contains("a-file"), "{e}");
    }
}
