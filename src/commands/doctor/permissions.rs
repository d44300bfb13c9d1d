//! The doctor's look at who may read what the service reads: its key, its site file and
//! its Zenoh configuration, by the files' (and their directories') owner, group and mode.
//!
//! Who reads them: `--service-user USER` if given. Otherwise, run as root on a host of the
//! package (its group `firefleet` exists), files under `/etc/firefleet/` are read by the
//! packaged services' user: a dynamic uid of systemd's (`DynamicUser=yes`) that reads them
//! through that group (`SupplementaryGroups=firefleet`), so that is whom they are checked
//! for; the key comes through systemd's credentials and needs no such check. Run as
//! anyone else, the doctor reads as its own user, and reading is the check.

use super::*;

/// Whether the service can read its key: through systemd's credentials it always can;
/// reading the file itself, only if its user may.
pub(super) fn key_reader(f: &mut Findings, a: &DoctorArgs, files: &TlsFiles) -> bool {
    if std::env::var_os("CREDENTIALS_DIRECTORY").is_some_and(|d| files.key.starts_with(d)) {
        f.ok("TLS: the key is handed in by systemd (LoadCredential=)");
        return true;
    }
    let Some(user) = &a.service_user else {
        return true;
    };
    match readable_by(&files.key, user) {
        Ok(true) => {
            f.ok(format_args!("TLS: the key is readable by {user}"));
            true
        }
        Ok(false) => {
            f.problem(
                format_args!(
                    "TLS: {} cannot be read by {user}, the service's user (mode {:o}, owner uid {})",
                    files.key.display(),
                    std::fs::metadata(&files.key).map_or(0, |m| m.mode() & 0o777),
                    std::fs::metadata(&files.key).map_or(0, |m| m.uid())
                ),
                "run the service from the shipped systemd unit, which hands the key in with LoadCredential= (the file stays root's and 0600); do not loosen the key's mode",
            );
            false
        }
        Err(e) => {
            f.problem(
                format_args!("--service-user {user}: {e}"),
                "name a user of this host",
            );
            false
        }
    }
}

/// The site file and the Zenoh configuration, each readable by the service's reader
/// (the module's doc says who that is); one problem for each that is not.
pub(super) fn files_readable(f: &mut Findings, a: &DoctorArgs) {
    let site = a
        .scenario
        .scenario
        .as_deref()
        .map(Path::new)
        .filter(|p| p.is_file());
    for (what, path) in [
        ("site file", site),
        ("Zenoh configuration", a.zenoh.zenoh_config.as_deref()),
    ] {
        let Some(path) = path else { continue };
        let reader = match &a.service_user {
            Some(user) => match passwd_entry(user) {
                Ok((uid, gid)) => Reader::User {
                    name: user,
                    uid,
                    gid,
                },
                // Said once, by the key's check.
                Err(_) => return,
            },
            None => match packaged_reader(path) {
                Some(r) => r,
                None => continue,
            },
        };
        if !reader.may_read(path) {
            f.problem(
                format_args!("{what}: {} cannot be read by {reader}", path.display()),
                format_args!(
                    "install it as the guide does (install -m 0640 -g firefleet ... /etc/firefleet/), with every directory above it open to {reader}"
                ),
            );
        }
    }
}

/// Who reads a file, by the mode bits.
enum Reader<'a> {
    User {
        name: &'a str,
        uid: u32,
        gid: u32,
    },
    /// The packaged services' dynamic user: group `firefleet` and no file of its own.
    Packaged {
        gid: u32,
    },
}

impl std::fmt::Display for Reader<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reader::User { name, .. } => write!(f, "{name}, the service's user"),
            Reader::Packaged { .. } => {
                f.write_str("the packaged service (a dynamic user of group firefleet)")
            }
        }
    }
}

impl Reader<'_> {
    /// Whether it may read `path`, and pass through every directory above it.
    fn may_read(&self, path: &Path) -> bool {
        let Ok(path) = path.canonicalize() else {
            return false;
        };
        self.may(&path, 0o4) && path.ancestors().skip(1).all(|d| self.may(d, 0o1))
    }

    /// Whether the mode bits of `path` give it `want` (4 read, 1 execute).
    fn may(&self, path: &Path, want: u32) -> bool {
        let Ok(m) = std::fs::metadata(path) else {
            return false;
        };
        let mode = m.mode();
        let (owner, group) = match self {
            Reader::User { uid: 0, .. } => return true,
            Reader::User { name, uid, gid } => {
                (m.uid() == *uid, m.gid() == *gid || in_group(m.gid(), name))
            }
            Reader::Packaged { gid } => (false, m.gid() == *gid),
        };
        let bits = if owner {
            mode >> 6
        } else if group {
            mode >> 3
        } else {
            mode
        };
        bits & want != 0
    }
}

/// The packaged services' reader of `path`, if the doctor runs as root on a host of the
/// package and `path` is of the package's layout.
fn packaged_reader(path: &Path) -> Option<Reader<'static>> {
    let root = std::fs::metadata("/proc/self").is_ok_and(|m| m.uid() == 0);
    let packaged = path
        .canonicalize()
        .is_ok_and(|p| p.starts_with("/etc/firefleet"));
    if !root || !packaged {
        return None;
    }
    let groups = std::fs::read_to_string("/etc/group").ok()?;
    let gid = groups
        .lines()
        .map(|l| l.split(':').collect::<Vec<_>>())
        .find(|p| p.len() >= 3 && p[0] == "firefleet")?[2]
        .parse()
        .ok()?;
    Some(Reader::Packaged { gid })
}

/// Whether `user` (a name or a uid of this host) may read `path` by its mode bits.
fn readable_by(path: &Path, user: &str) -> anyhow::Result<bool> {
    let (uid, gid) = passwd_entry(user)?;
    std::fs::metadata(path)?;
    Ok(Reader::User {
        name: user,
        uid,
        gid,
    }
    .may(path, 0o4))
}

/// The uid and primary gid of `user` in /etc/passwd.
fn passwd_entry(user: &str) -> anyhow::Result<(u32, u32)> {
    let passwd = std::fs::read_to_string("/etc/passwd")?;
    passwd
        .lines()
        .map(|l| l.split(':').collect::<Vec<_>>())
        .filter(|p| p.len() >= 4)
        .find(|p| p[0] == user || p[2] == user)
        .and_then(|p| Some((p[2].parse().ok()?, p[3].parse().ok()?)))
        .ok_or_else(|| anyhow::anyhow!("no user '{user}' in /etc/passwd"))
}

/// Whether `user` is listed in group `gid` of /etc/group.
fn in_group(gid: u32, user: &str) -> bool {
    std::fs::read_to_string("/etc/group").is_ok_and(|g| {
        g.lines()
            .map(|l| l.split(':').collect::<Vec<_>>())
            .any(|p| p.len() >= 4 && p[2].parse() == Ok(gid) && p[3].split(',').any(|m| m == user))
    })
}
