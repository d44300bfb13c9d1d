//! The doctor's look at who may read the identity's key: the service's user, by the
//! file's owner, group and mode.

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

/// Whether `user` (a name or a uid of this host) may read `path` by its mode bits.
fn readable_by(path: &Path, user: &str) -> anyhow::Result<bool> {
    let (uid, gid) = passwd_entry(user)?;
    if uid == 0 {
        return Ok(true);
    }
    let m = std::fs::metadata(path)?;
    let mode = m.mode();
    Ok(if m.uid() == uid {
        mode & 0o400 != 0
    } else if m.gid() == gid || in_group(m.gid(), user) {
        mode & 0o040 != 0
    } else {
        mode & 0o004 != 0
    })
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
