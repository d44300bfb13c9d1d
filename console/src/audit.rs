//! The console's audit log: who issued, cleared and acknowledged what, and when, for the
//! after-action report. One JSON line per entry ([`LineLog`]), appended to a file in the
//! console's state directory and synced before the commander is answered, read back whole
//! at start: a restart, or a commander opening the page late, loses none of it. Served as
//! JSON and as CSV (`/api/audit`, `/api/audit.csv`).
//!
//! Not here: the incident's own history (the recordings keep every message; the
//! console's timeline is [`crate::history`]).

use std::collections::VecDeque;
use std::path::Path;
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::line_log::{LineLog, LogError};

/// The file in the state directory.
pub const FILE: &str = "audit.jsonl";
/// Entries kept in memory to serve (the file keeps them all).
pub const KEPT: usize = 10_000;

/// What a commander did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Action {
    Goal,
    Clear,
    Acknowledge,
    Shelve,
    Unshelve,
}

/// One thing a commander did through this console.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Entry {
    /// Wall time, ms since the Unix epoch.
    pub wall_ms: u64,
    /// Site time.
    pub t: f64,
    pub who: String,
    pub action: Action,
    /// What it was about: the goal, the zone, the alarm.
    pub what: String,
    /// What came of it: the coordinator's answer, or why there was none.
    pub outcome: String,
}

/// The audit log.
#[derive(Debug)]
pub struct Audit {
    file: Option<LineLog>,
    entries: Mutex<VecDeque<Entry>>,
}

impl Audit {
    /// A log kept only in memory (a console with no state directory: a restart loses it).
    pub fn in_memory() -> Self {
        Self {
            file: None,
            entries: Mutex::default(),
        }
    }

    /// The log in directory `dir` (made if missing), with what it already holds.
    pub fn open(dir: &Path) -> Result<Self, LogError> {
        let mut entries = VecDeque::new();
        let file = LineLog::open(dir, FILE, |e: Entry| {
            if entries.len() == KEPT {
                entries.pop_front();
            }
            entries.push_back(e);
        })?;
        Ok(Self {
            file: Some(file),
            entries: Mutex::new(entries),
        })
    }

    /// Keep `entry`: on disk (synced) first, then to serve. A write that fails is logged,
    /// not fatal: the commander's action stands, only its record is missing.
    pub fn note(&self, entry: Entry) {
        if let Some(file) = &self.file {
            file.append(&entry, true);
        }
        let mut entries = self
            .entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if entries.len() == KEPT {
            entries.pop_front();
        }
        entries.push_back(entry);
    }

    /// Every entry kept, oldest first.
    pub fn entries(&self) -> Vec<Entry> {
        self.entries
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .iter()
            .cloned()
            .collect()
    }

    /// The entries as CSV (RFC 4180, a header line first).
    pub fn csv(&self) -> String {
        let mut out = String::from("wall_ms,t,who,action,what,outcome\r\n");
        for e in self.entries() {
            let action = serde_json::to_value(e.action)
                .ok()
                .and_then(|v| v.as_str().map(str::to_owned))
                .unwrap_or_default();
            let fields = [
                e.wall_ms.to_string(),
                format!("{:.1}", e.t),
                e.who,
                action,
                e.what,
                e.outcome,
            ];
            let line: Vec<String> = fields.iter().map(|f| csv_field(f)).collect();
            out.push_str(&line.join(","));
            out.push_str("\r\n");
        }
        out
    }
}

/// `f` as a CSV field: quoted (and its quotes doubled) where it holds a comma, a quote or a
/// line break.
fn csv_field(f: &str) -> String {
    if f.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", f.replace('"', "\"\""))
    } else {
        f.to_owned()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs::OpenOptions;
    use std::io::Write;

    fn entry(what: &str) -> Entry {
        Entry {
            wall_ms: 1,
            t: 12.34,
            who: "rossi".into(),
            action: Action::Goal,
            what: what.into(),
            outcome: "accepted".into(),
        }
    }

    #[test]
    fn entries_outlive_a_restart_and_a_torn_last_line() {
        let dir = tempfile::tempdir().unwrap();
        let audit = Audit::open(dir.path()).unwrap();
        audit.note(entry("keep-out on zone deep"));
        audit.note(entry("monitor, \"quoted\", on zone west"));
        drop(audit);
        // A crash cut a third line short.
        let mut f = OpenOptions::new()
            .append(true)
            .open(dir.path().join(FILE))
            .unwrap();
        f.write_all(b"{\"wall_ms\": 3, \"t\"").unwrap();
        let back = Audit::open(dir.path()).unwrap();
        assert_eq!(back.entries().len(), 2);
        back.note(entry("after the crash"));
        drop(back);
        let back = Audit::open(dir.path()).unwrap();
        assert_eq!(
            back.entries().len(),
            3,
            "the entry after the torn line is kept"
        );
        let csv = back.csv();
        assert!(
            csv.starts_with(
                "wall_ms,t,who,action,what,outcome\r\n1,12.3,rossi,goal,keep-out on zone deep,accepted\r\n"
            ),
            "{csv}"
        );
        assert!(
            csv.contains("\"monitor, \"\"quoted\"\", on zone west\""),
            "{csv}"
        );
    }
}
