//! A unit's behavior tree recorded as BehaviorTree.CPP's FileLogger2 writes one: a
//! `.btlog` file Groot2 opens to replay what the unit's tree did after an incident.
//!
//! The file is the header ([`firefleet_bt::groot2::btlog_header`]: the tree's XML with
//! node uids, the start as Unix microseconds), then 9 bytes a transition, written as the
//! steps make them. Times are the tree's own (site time, which the simulator may run
//! faster than the wall clock), counted from the first step after the file was opened and
//! added to the wall-clock start: a replay shows the incident at site time.
//!
//! Not here: the records' bytes ([`firefleet_bt::groot2`]), serving the tree live
//! ([`crate::groot2`]).

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use firefleet_bt::groot2::{self, View};
use firefleet_bt::{Transition, Tree};

/// Why a `.btlog` could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BtLogError {
    /// BT.CPP's FileLogger2 (and Groot2's file dialog) take `.btlog` files only.
    #[error("{0}: a behavior-tree log's name ends in .btlog")]
    Extension(PathBuf),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
}

/// An open `.btlog`.
pub struct BtLog {
    out: BufWriter<File>,
    path: PathBuf,
    view: View,
    /// The tree time records count from: the first step's.
    t0: Option<f64>,
}

impl BtLog {
    /// Create `path` for `tree`, writing the header.
    pub fn create<C>(path: &Path, tree: &Tree<C>) -> Result<Self, BtLogError> {
        if path.extension().is_none_or(|e| e != "btlog") {
            return Err(BtLogError::Extension(path.to_owned()));
        }
        let io = |source| BtLogError::Io {
            path: path.to_owned(),
            source,
        };
        let view = View::new(tree);
        let start = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| i64::try_from(d.as_micros()).unwrap_or(i64::MAX));
        let mut out = BufWriter::new(File::create(path).map_err(io)?);
        out.write_all(&groot2::btlog_header(view.xml(), start))
            .map_err(io)?;
        Ok(Self {
            out,
            path: path.to_owned(),
            view,
            t0: None,
        })
    }

    /// Append the transitions of a step at tree time `now`.
    pub fn append(&mut self, fresh: &[Transition], now: f64) -> Result<(), BtLogError> {
        let t0 = *self.t0.get_or_insert(now);
        for t in fresh {
            let record = groot2::record(self.view.uid(t.node), t, t0);
            self.out
                .write_all(&record)
                .map_err(|source| BtLogError::Io {
                    path: self.path.clone(),
                    source,
                })?;
        }
        Ok(())
    }

    /// Write what is buffered (the agent does so with each batch of transitions it
    /// publishes, and when it stops).
    pub fn flush(&mut self) -> Result<(), BtLogError> {
        self.out.flush().map_err(|source| BtLogError::Io {
            path: self.path.clone(),
            source,
        })
    }
}
