//! Commanders' logins: who may steer the incident from the console.
//!
//! Passwords are kept only as Argon2id hashes (PHC strings, a random salt each) in a TOML
//! file that `firefleet console add-user` writes:
//!
//! ```toml
//! [users]
//! rossi = "$argon2id$v=19$m=19456,t=2,p=1$..."
//! ```
//!
//! A login opens a [`Sessions`] entry named by a random 256-bit token (the page's cookie),
//! which expires a fixed time after the login whatever happens in between: a console left
//! logged in at the portal does not stay a commander's forever. The user name is a
//! [`CommanderId`], so it is the name goals are issued under (`zone/<z>/goal/<name>`), never
//! text the page sends.
//!
//! Not here: HTTP (cookies are [`crate::http`]'s), TLS.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use argon2::Argon2;
use argon2::password_hash::rand_core::OsRng;
use argon2::password_hash::{PasswordHash, PasswordHasher, PasswordVerifier, SaltString};
use firefleet_model::CommanderId;
use rand::RngCore;
use serde::{Deserialize, Serialize};

/// The shortest password accepted (NIST SP 800-63B's minimum for a chosen secret).
pub const MIN_PASSWORD_LEN: usize = 8;

#[derive(Debug, thiserror::Error)]
pub enum AuthError {
    #[error("{path}: {reason}")]
    File { path: PathBuf, reason: String },
    #[error("the password is shorter than {MIN_PASSWORD_LEN} characters")]
    ShortPassword,
    #[error("hashing the password: {0}")]
    Hash(String),
}

/// The users file: commander name to password hash.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Users {
    #[serde(default)]
    users: BTreeMap<CommanderId, String>,
}

impl Users {
    /// Read a users file; every hash must parse, so a damaged file fails at start, not at
    /// a commander's login.
    pub fn load(path: &Path) -> Result<Self, AuthError> {
        let err = |reason: String| AuthError::File {
            path: path.to_owned(),
            reason,
        };
        let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
        let users: Users = toml::from_str(&text).map_err(|e| err(e.to_string()))?;
        for (name, hash) in &users.users {
            PasswordHash::new(hash)
                .map_err(|e| err(format!("users.{name}: not a password hash ({e})")))?;
        }
        Ok(users)
    }

    /// Read `path` if it exists (else start empty), set `name`'s password, write it back
    /// readable by its owner only.
    pub fn add(path: &Path, name: CommanderId, password: &str) -> Result<(), AuthError> {
        let mut users = if path.exists() {
            Self::load(path)?
        } else {
            Self::default()
        };
        users.users.insert(name, hash(password)?);
        let text = toml::to_string(&users).map_err(|e| AuthError::Hash(e.to_string()))?;
        write_private(path, &text).map_err(|e| AuthError::File {
            path: path.to_owned(),
            reason: e.to_string(),
        })
    }

    pub fn len(&self) -> usize {
        self.users.len()
    }

    pub fn is_empty(&self) -> bool {
        self.users.is_empty()
    }

    /// The commander, if `password` is theirs. An unknown name costs a hash too, so the
    /// answer's time does not tell which names exist.
    pub fn verify(&self, name: &str, password: &str) -> Option<CommanderId> {
        let known = CommanderId::new(name)
            .ok()
            .and_then(|id| self.users.get_key_value(&id));
        match known {
            Some((id, hash)) => {
                let hash = PasswordHash::new(hash).ok()?;
                Argon2::default()
                    .verify_password(password.as_bytes(), &hash)
                    .ok()
                    .map(|()| id.clone())
            }
            None => {
                let _ = hash(password);
                None
            }
        }
    }
}

fn hash(password: &str) -> Result<String, AuthError> {
    if password.chars().count() < MIN_PASSWORD_LEN {
        return Err(AuthError::ShortPassword);
    }
    let salt = SaltString::generate(&mut OsRng);
    Argon2::default()
        .hash_password(password.as_bytes(), &salt)
        .map(|h| h.to_string())
        .map_err(|e| AuthError::Hash(e.to_string()))
}

fn write_private(path: &Path, text: &str) -> std::io::Result<()> {
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create(true).truncate(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    std::io::Write::write_all(&mut options.open(path)?, text.as_bytes())
}

/// Open sessions, by token.
#[derive(Debug)]
pub struct Sessions {
    ttl: Duration,
    open: Mutex<HashMap<String, (CommanderId, Instant)>>,
}

impl Sessions {
    /// Sessions that last `ttl` from their login.
    pub fn new(ttl: Duration) -> Self {
        Self {
            ttl,
            open: Mutex::new(HashMap::new()),
        }
    }

    pub fn ttl(&self) -> Duration {
        self.ttl
    }

    /// A new session for `who`; its token.
    pub fn open(&self, who: CommanderId, now: Instant) -> String {
        let mut bytes = [0u8; 32];
        rand::rng().fill_bytes(&mut bytes);
        let token: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        let mut open = self.open.lock().expect("sessions lock");
        open.retain(|_, (_, expires)| *expires > now);
        open.insert(token.clone(), (who, now + self.ttl));
        token
    }

    /// Who holds `token`, if the session is open and not expired.
    pub fn who(&self, token: &str, now: Instant) -> Option<CommanderId> {
        let mut open = self.open.lock().expect("sessions lock");
        match open.get(token) {
            Some((who, expires)) if *expires > now => Some(who.clone()),
            Some(_) => {
                open.remove(token);
                None
            }
            None => None,
        }
    }

    pub fn close(&self, token: &str) {
        self.open.lock().expect("sessions lock").remove(token);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_password_is_kept_as_a_hash_and_checked_against_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("users.toml");
        let rossi = CommanderId::new("rossi").unwrap();
        Users::add(&path, rossi.clone(), "correct horse").unwrap();
        Users::add(
            &path,
            CommanderId::new("bianchi").unwrap(),
            "battery staple",
        )
        .unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(!text.contains("correct horse") && text.contains("$argon2id$"));
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = std::fs::metadata(&path).unwrap().permissions().mode();
            assert_eq!(mode & 0o077, 0, "readable by its owner only");
        }
        let users = Users::load(&path).unwrap();
        assert_eq!(users.len(), 2);
        assert_eq!(users.verify("rossi", "correct horse"), Some(rossi));
        assert_eq!(users.verify("rossi", "battery staple"), None);
        assert_eq!(users.verify("verdi", "correct horse"), None);
        assert_eq!(users.verify("not a name!", "correct horse"), None);
        assert!(matches!(
            Users::add(&path, CommanderId::new("verdi").unwrap(), "short"),
            Err(AuthError::ShortPassword)
        ));
    }

    #[test]
    fn a_damaged_users_file_is_refused_at_load_naming_the_user() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("users.toml");
        std::fs::write(&path, "[users]\nrossi = \"hunter2\"\n").unwrap();
        let e = Users::load(&path).unwrap_err().to_string();
        assert!(e.contains("users.rossi") && e.contains("users.toml"), "{e}");
    }

    #[test]
    fn a_session_names_its_commander_until_it_expires_or_is_closed() {
        let sessions = Sessions::new(Duration::from_secs(60));
        let t0 = Instant::now();
        let rossi = CommanderId::new("rossi").unwrap();
        let a = sessions.open(rossi.clone(), t0);
        let b = sessions.open(rossi.clone(), t0);
        assert_ne!(a, b);
        assert_eq!(a.len(), 64);
        assert_eq!(sessions.who(&a, t0 + Duration::from_secs(59)), Some(rossi));
        assert_eq!(sessions.who(&a, t0 + Duration::from_secs(60)), None);
        assert_eq!(sessions.who("nope", t0), None);
        sessions.close(&b);
        assert_eq!(sessions.who(&b, t0), None);
    }
}
