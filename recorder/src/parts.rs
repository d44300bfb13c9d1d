//! A recording on disk, safe against the recorder being killed at any instant.
//!
//! Most MCAP readers open a file only once it is finished: Python's `mcap` seeks to the
//! footer first, and a file cut short has none. A recorder killed outright (SIGKILL, the
//! OOM killer, power lost) would leave nothing they can open. So a recording to
//! `run.mcap` is written as parts in `run.mcap.parts/`: each part is a whole MCAP file
//! (with the `firefleet` metadata record and the tunnel's scene, so it stands alone),
//! written as `NNNN.mcap.partial` and renamed to `NNNN.mcap` only once finished. A rename
//! is atomic, so whenever the recorder dies every `*.mcap` in the directory is a finished
//! file that any reader opens, and at most the part being written (a few seconds,
//! [`PART_EVERY`]) is missing from them; firefleet's own readers read that one too, up to
//! its last complete chunk. `index.json` lists the finished parts, rewritten (atomically,
//! likewise) after each.
//!
//! When the recording ends normally the parts are merged into `run.mcap` and the directory
//! removed, so a recording is one file, as every tool expects. Readers ([`Recording::load`])
//! take either: the file, or, when the recorder did not live to merge, the parts.
//!
//! Not here: what is recorded ([`mod@crate::record`]).

use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde::{Deserialize, Serialize};

/// How long a part is written before it is finished and the next begun: what a recorder
/// killed outright loses, at most, to readers of finished files.
pub const PART_EVERY: Duration = Duration::from_secs(5);

/// The extension of the part being written.
const PARTIAL: &str = "partial";
/// The index of the finished parts, in the parts directory.
pub const INDEX: &str = "index.json";

/// Where the parts of the recording `out` go.
pub fn parts_dir(out: &Path) -> PathBuf {
    let mut name = out.as_os_str().to_owned();
    name.push(".parts");
    PathBuf::from(name)
}

/// The path of part `n` in `dir`, finished or being written.
pub(crate) fn part_path(dir: &Path, n: u32, finished: bool) -> PathBuf {
    let name = format!("{n:04}.mcap");
    if finished {
        dir.join(name)
    } else {
        dir.join(format!("{name}.{PARTIAL}"))
    }
}

/// One finished part, as the index lists it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Part {
    pub file: String,
    pub messages: u64,
}

/// `index.json`: the finished parts in order.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Index {
    pub parts: Vec<Part>,
}

impl Index {
    /// Write the index into `dir` atomically (a reader never sees half of one).
    pub(crate) fn store(&self, dir: &Path) -> io::Result<()> {
        let tmp = dir.join(format!("{INDEX}.{PARTIAL}"));
        fs::write(&tmp, serde_json::to_vec_pretty(self).expect("serialises"))?;
        fs::rename(tmp, dir.join(INDEX))
    }
}

/// Why a recording could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    #[error("{path}: {source}")]
    Io { path: String, source: io::Error },
    #[error("{0}: neither a recording nor the parts of one ({1} does not exist either)")]
    Missing(String, String),
}

/// A recording's files in memory, in order: the one merged file, or the parts of a
/// recording whose recorder did not live to merge them (the finished ones, then the one it
/// was writing, if any).
#[derive(Debug, Clone, Default)]
pub struct Recording {
    pub files: Vec<(PathBuf, Vec<u8>)>,
}

impl Recording {
    /// The recording at `path`: the file, or the parts directory `path` names, or the
    /// parts directory of the file `path` would have been.
    pub fn load(path: &Path) -> Result<Self, LoadError> {
        let read = |p: &Path| {
            fs::read(p).map_err(|source| LoadError::Io {
                path: p.display().to_string(),
                source,
            })
        };
        if path.is_file() {
            return Ok(Self {
                files: vec![(path.to_owned(), read(path)?)],
            });
        }
        let dir = if path.is_dir() {
            path.to_owned()
        } else {
            parts_dir(path)
        };
        if !dir.is_dir() {
            return Err(LoadError::Missing(
                path.display().to_string(),
                dir.display().to_string(),
            ));
        }
        let mut files = Vec::new();
        for n in 0.. {
            let (done, partial) = (part_path(&dir, n, true), part_path(&dir, n, false));
            if done.is_file() {
                files.push((done.clone(), read(&done)?));
            } else {
                if partial.is_file() {
                    files.push((partial.clone(), read(&partial)?));
                }
                break;
            }
        }
        Ok(Self { files })
    }

    /// One file's bytes as a recording (tests, and files already in memory).
    pub fn from_bytes(bytes: Vec<u8>) -> Self {
        Self {
            files: vec![(PathBuf::new(), bytes)],
        }
    }

    /// Every message of every file in order. A file that ends in a corrupt or cut-short
    /// record yields that error and then ends; the next file follows.
    pub fn messages(&self) -> impl Iterator<Item = mcap::McapResult<mcap::Message<'static>>> + '_ {
        self.files.iter().flat_map(|(_, bytes)| stream(bytes))
    }
}

type Messages<'a> = Box<dyn Iterator<Item = mcap::McapResult<mcap::Message<'static>>> + 'a>;

/// The messages of one file: an error at its start (not an MCAP file) is its only item.
fn stream(bytes: &[u8]) -> Messages<'_> {
    match mcap::MessageStream::new(bytes) {
        Ok(stream) => Box::new(stream),
        Err(e) => Box::new(std::iter::once(Err(e))),
    }
}
