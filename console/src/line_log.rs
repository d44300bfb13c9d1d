//! A file of JSON lines that only grows: what the console keeps of the incident where a
//! restart must find it (the audit log, the timeline's snapshots). Appended a line at a
//! time and read back whole at start.
//!
//! Why lines and not the state file the roles keep: such a log only grows, rewriting it
//! whole at every entry would cost more with every entry, and a crash can at worst cut the
//! last line short. Read back, a line that does not parse is skipped and said, and a torn
//! last line is ended so that the next entry starts a line of its own.
//!
//! Not here: what the lines mean ([`crate::audit`], [`crate::history`]).

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::Serialize;
use serde::de::DeserializeOwned;

/// Why a log cannot be kept.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {source}")]
pub struct LogError {
    path: PathBuf,
    source: std::io::Error,
}

/// An open log.
#[derive(Debug)]
pub struct LineLog {
    path: PathBuf,
    file: Mutex<File>,
}

impl LineLog {
    /// The log `name` in directory `dir` (both made if missing), each entry it already
    /// holds given to `each`, oldest first.
    pub fn open<T: DeserializeOwned>(
        dir: &Path,
        name: &str,
        mut each: impl FnMut(T),
    ) -> Result<Self, LogError> {
        let path = dir.join(name);
        let err = |source| LogError {
            path: path.clone(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(err)?;
        if let Ok(f) = File::open(&path) {
            for (n, line) in BufReader::new(f).lines().enumerate() {
                match serde_json::from_str::<T>(&line.map_err(err)?) {
                    Ok(entry) => each(entry),
                    Err(e) => tracing::warn!(
                        "{}: line {} skipped ({e}): cut short by a crash?",
                        path.display(),
                        n + 1
                    ),
                }
            }
        }
        let mut file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(&path)
            .map_err(err)?;
        let torn = std::fs::read(&path)
            .map_err(err)?
            .last()
            .is_some_and(|b| *b != b'\n');
        if torn {
            file.write_all(b"\n").map_err(err)?;
        }
        Ok(Self {
            path,
            file: Mutex::new(file),
        })
    }

    /// Append `entry`, synced to the disk if `sync` (before a commander is told an action
    /// was taken, say). A write that fails is logged, not fatal: what the entry records
    /// stands in memory, only its copy is missing.
    pub fn append<T: Serialize>(&self, entry: &T, sync: bool) {
        let mut line = serde_json::to_vec(entry).expect("an entry serializes");
        line.push(b'\n');
        let mut f = self
            .file
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        let written = f
            .write_all(&line)
            .and_then(|()| if sync { f.sync_data() } else { Ok(()) });
        if let Err(e) = written {
            tracing::error!("{}: an entry not kept: {e}", self.path.display());
        }
    }
}
