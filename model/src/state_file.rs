//! A file of a role's state that outlives the process: replaced whole, and refused when it
//! is not what was written.
//!
//! Roles that must not forget across a restart (the coordinator's goals in force, the
//! simulator's world) keep a small state in their state directory and take it back at
//! start. Writing a new file, syncing it, renaming it over the old and syncing the
//! directory is atomic on every POSIX file system: a crash or a power cut leaves the old
//! state or the new, never half of one, so no log, compaction or database is needed for a
//! state of a few kilobytes that is rewritten whole. The SHA-256 on the first line catches
//! what rename cannot (a file edited by hand, a disk that rotted, a copy cut short): such a
//! file is refused with the reason, never half-believed.
//!
//! Not here: what the state is, or what a role does with one it cannot take back (each
//! role says: the coordinator falls back on the bus, the simulator starts the rehearsal
//! anew).

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};

use sha2::Digest as _;

/// Why a state file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum StateFileError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    /// The file is there but is not one written whole by [`StateFile::write`].
    #[error("{}: {why}", path.display())]
    Corrupt { path: PathBuf, why: String },
}

/// One named state file in a state directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct StateFile {
    dir: PathBuf,
    name: String,
}

impl StateFile {
    /// The state file `name` in `dir`, a directory this process may write in (created if
    /// missing): checked now, so that a role that could not keep its state says so at
    /// start, not at the first write.
    pub fn in_dir(dir: &Path, name: &str) -> Result<Self, StateFileError> {
        let io = |source| StateFileError::Io {
            path: dir.to_owned(),
            source,
        };
        fs::create_dir_all(dir).map_err(io)?;
        let probe = dir.join(format!(".{name}.probe"));
        fs::write(&probe, b"").map_err(io)?;
        fs::remove_file(&probe).map_err(io)?;
        Ok(Self {
            dir: dir.to_owned(),
            name: name.to_owned(),
        })
    }

    pub fn path(&self) -> PathBuf {
        self.dir.join(&self.name)
    }

    /// What was last written; `None` if nothing ever was.
    pub fn read(&self) -> Result<Option<Vec<u8>>, StateFileError> {
        let path = self.path();
        let bytes = match fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(StateFileError::Io { path, source }),
        };
        let corrupt = |why: String| StateFileError::Corrupt {
            path: path.clone(),
            why,
        };
        let header = self.header();
        let end = bytes
            .iter()
            .position(|&b| b == b'\n')
            .ok_or_else(|| corrupt("no header line".into()))?;
        let (first, body) = (&bytes[..end], &bytes[end + 1..]);
        let sum = std::str::from_utf8(first)
            .ok()
            .and_then(|l| l.strip_prefix(&header))
            .map(str::trim)
            .ok_or_else(|| corrupt(format!("the first line is not '{header} <hex>'")))?;
        if sum != digest(body) {
            return Err(corrupt(
                "its checksum does not match its contents (edited, cut short or damaged on disk)"
                    .into(),
            ));
        }
        Ok(Some(body.to_vec()))
    }

    /// Write `body` in place of what was written: whole or not at all.
    pub fn write(&self, body: &[u8]) -> Result<(), StateFileError> {
        let path = self.path();
        let new = self.dir.join(format!("{}.new", self.name));
        let io = |path: &Path| {
            let path = path.to_owned();
            move |source| StateFileError::Io { path, source }
        };
        let mut f = fs::File::create(&new).map_err(io(&new))?;
        writeln!(f, "{} {}", self.header(), digest(body)).map_err(io(&new))?;
        f.write_all(body).map_err(io(&new))?;
        f.sync_all().map_err(io(&new))?;
        fs::rename(&new, &path).map_err(io(&path))?;
        // The rename itself is durable once the directory is.
        fs::File::open(&self.dir)
            .and_then(|d| d.sync_all())
            .map_err(io(&self.dir))
    }

    /// The first line's words before the checksum: the file names what it holds.
    fn header(&self) -> String {
        format!("# firefleet {}, sha256", self.name)
    }
}

fn digest(body: &[u8]) -> String {
    sha2::Sha256::digest(body)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn what_is_written_is_what_is_read_and_the_last_write_wins() {
        let d = tempfile::tempdir().unwrap();
        let f = StateFile::in_dir(&d.path().join("state"), "goals.json").unwrap();
        assert_eq!(f.read().unwrap(), None, "nothing written yet");
        f.write(b"{\"t\": 40}").unwrap();
        f.write(b"{\"t\": 52.5}").unwrap();
        assert_eq!(f.read().unwrap().as_deref(), Some(&b"{\"t\": 52.5}"[..]));
        // A restarted process on the same directory reads what the first kept.
        let again = StateFile::in_dir(&d.path().join("state"), "goals.json").unwrap();
        assert_eq!(
            again.read().unwrap().as_deref(),
            Some(&b"{\"t\": 52.5}"[..])
        );
        // Binary bodies, newlines and all, come back as they went.
        let bytes: Vec<u8> = (0..=255).collect();
        f.write(&bytes).unwrap();
        assert_eq!(f.read().unwrap(), Some(bytes));
    }

    #[test]
    fn a_file_edited_cut_short_or_of_another_name_is_refused_with_the_reason() {
        let d = tempfile::tempdir().unwrap();
        let f = StateFile::in_dir(d.path(), "goals.json").unwrap();
        f.write(b"{\"zone\": \"east\"}").unwrap();
        let text = fs::read_to_string(f.path()).unwrap();
        fs::write(f.path(), text.replace("east", "west")).unwrap();
        let e = f.read().unwrap_err().to_string();
        assert!(e.contains("checksum does not match"), "{e}");
        assert!(e.contains("goals.json"), "the error names the file: {e}");
        fs::write(f.path(), &text[..text.len() - 3]).unwrap();
        assert!(f.read().is_err());
        fs::write(f.path(), "{}").unwrap();
        let e = f.read().unwrap_err().to_string();
        assert!(e.contains("no header line"), "{e}");
        // Another role's file put in its place.
        let other = StateFile::in_dir(d.path(), "world.bin").unwrap();
        other.write(b"x").unwrap();
        fs::copy(other.path(), f.path()).unwrap();
        let e = f.read().unwrap_err().to_string();
        assert!(e.contains("first line is not"), "{e}");
    }

    #[test]
    fn a_directory_that_cannot_be_written_is_refused_at_once() {
        let d = tempfile::tempdir().unwrap();
        let file = d.path().join("a-file");
        fs::write(&file, b"").unwrap();
        let e = StateFile::in_dir(&file, "x").unwrap_err().to_string();
        assert!(e.contains("a-file"), "{e}");
    }
}
