//! Commanders' logins: who may steer the incident from the console.
//!
//! Passwords are kept only as Argon2id hashes (PHC strings, a random salt each) in a TOML
//! file that `firefleet console add-user` writes:
//!
//! ```toml
//! [users]                   # commanders: they read the incident and steer it
//! rossi = "$argon2id$v=19$m=19456,t=2,p=1$..."
//! [viewers]                 # they read it only (a control room's wall, a liaison)
//! ferri = "$argon2id$v=19$m=19456,t=2,p=1$..."
//! ```
//!
//! Checking a password costs one Argon2 verification whether the name is known or not (an
//! unknown name is checked against a hash made at start with the same parameters), so the
//! answer's time does not tell which names exist.
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
use argon2::password_hash::{self, PasswordHash, PasswordHasher, SaltString};
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

/// What a login may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Role {
    /// Reads the incident and steers it: goals, alert acknowledgements.
    Commander,
    /// Reads the incident only.
    Viewer,
}

/// The users file: name to password hash, commanders and viewers.
#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Users {
    #[serde(default)]
    users: BTreeMap<CommanderId, String>,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    viewers: BTreeMap<CommanderId, String>,
    /// What an unknown name is checked against: the same work as a known one.
    #[serde(skip)]
    decoy: std::sync::OnceLock<String>,
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
        for (table, list) in [("users", &users.users), ("viewers", &users.viewers)] {
            for (name, hash) in list {
                PasswordHash::new(hash)
                    .map_err(|e| err(format!("{table}.{name}: not a password hash ({e})")))?;
            }
        }
        if let Some(name) = users.users.keys().find(|n| users.viewers.contains_key(*n)) {
            return Err(err(format!("{name} is both a commander and a viewer")));
        }
        Ok(users)
    }

    /// Read `path` if it exists (else start empty), set `name`'s password and role, write
    /// it back readable by its owner only.
    pub fn add(
        path: &Path,
        name: CommanderId,
        password: &str,
        role: Role,
    ) -> Result<(), AuthError> {
        let mut users = if path.exists() {
            Self::load(path)?
        } else {
            Self::default()
        };
        let hash = hash(password)?;
        users.users.remove(&name);
        users.viewers.remove(&name);
        match role {
            Role::Commander => users.users.insert(name, hash),
            Role::Viewer => users.viewers.insert(name, hash),
        };
        let text = toml::to_string(&users).map_err(|e| AuthError::Hash(e.to_string()))?;
        write_private(path, &text).map_err(|e| AuthError::File {
            path: path.to_owned(),
            reason: e.to_string(),
        })
    }

    pub fn len(&self) -> usize {
        self.users.len() + self.viewers.len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Who logs in, and as what, if `password` is theirs. Exactly one Argon2 verification
    /// whatever the name and password (a short password included), so the time it takes
    /// does not tell a known name from an unknown one.
    pub fn verify(&self, name: &str, password: &str) -> Option<(CommanderId, Role)> {
        self.verify_in(&mut Vec::new(), name, password)
    }

    /// [`Users::verify`] with Argon2's working memory in `memory`, grown to what a hash
    /// needs and kept for the next check: Argon2 allocating its 19 MiB afresh every time
    /// grew a process by some 10 MB a check under glibc (a crowd of logins took a console
    /// to 5.9 GB).
    pub fn verify_in(
        &self,
        memory: &mut Vec<argon2::Block>,
        name: &str,
        password: &str,
    ) -> Option<(CommanderId, Role)> {
        let known = CommanderId::new(name).ok().and_then(|id| {
            let commander = self.users.get(&id).map(|h| (h, Role::Commander));
            commander
                .or_else(|| self.viewers.get(&id).map(|h| (h, Role::Viewer)))
                .map(|(h, role)| (id, h, role))
        });
        let decoy = self
            .decoy
            .get_or_init(|| hash("a decoy nobody can log in with").unwrap_or_default());
        let checked = known
            .as_ref()
            .map_or(decoy.as_str(), |(_, h, _)| h.as_str());
        let ok = matches_hash(memory, checked, password.as_bytes());
        known.filter(|_| ok).map(|(id, _, role)| (id, role))
    }
}

/// The most memory a stored hash may ask a check for, KiB: 64 MiB, three times what
/// `add-user` uses. A users file is the site's own, but a hash asking for gigabytes would
/// take them at every login.
const MAX_M_COST_KIB: u32 = 64 * 1024;

/// Whether `password` hashes to the PHC string `phc`, with Argon2's blocks in `memory`.
fn matches_hash(memory: &mut Vec<argon2::Block>, phc: &str, password: &[u8]) -> bool {
    let Ok(hash) = PasswordHash::new(phc) else {
        return false;
    };
    let (Ok(params), Ok(algorithm)) = (
        argon2::Params::try_from(&hash),
        argon2::Algorithm::try_from(hash.algorithm),
    ) else {
        return false;
    };
    let version = match hash.version.map(argon2::Version::try_from) {
        Some(Ok(v)) => v,
        Some(Err(_)) => return false,
        None => argon2::Version::default(),
    };
    let (Some(salt), Some(expected)) = (hash.salt, hash.hash) else {
        return false;
    };
    if params.m_cost() > MAX_M_COST_KIB {
        return false;
    }
    let mut salt_bytes = [0u8; 64];
    let Ok(salt) = salt.decode_b64(&mut salt_bytes) else {
        return false;
    };
    let blocks = params.block_count();
    if memory.len() < blocks {
        memory.resize(blocks, argon2::Block::default());
    }
    let mut out = [0u8; 64];
    let Some(out) = out.get_mut(..expected.len()) else {
        return false;
    };
    Argon2::new(algorithm, version, params)
        .hash_password_into_with_memory(password, salt, out, &mut memory[..blocks])
        .is_ok()
        && password_hash::Output::new(out).is_ok_and(|o| o == expected)
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

/// Sessions one name may hold open: a commander's tablet, laptop and the control room's
/// screen, not a thief's thousand.
pub const MAX_SESSIONS_PER_NAME: usize = 8;

/// One open session.
#[derive(Debug, Clone)]
struct Session {
    who: CommanderId,
    role: Role,
    opened: Instant,
    expires: Instant,
}

/// Password checks on a few threads of their own, with a bounded queue.
///
/// Argon2 takes 19 MiB a check. On tokio's blocking pool a crowd of logins ran on ever new
/// threads, each of which kept its own malloc arena full of freed 19 MiB blocks (glibc raises
/// its mmap threshold after the first such free, so the next ones come from the arenas): a
/// console checking two at a time still grew to 820 MB. Here the same `threads` threads
/// check every password, so memory stays at a few blocks per thread, and a login finding
/// [`CHECKS_QUEUED`] others waiting is told to try again rather than queued.
#[derive(Debug)]
pub struct Checker {
    jobs: std::sync::mpsc::SyncSender<Check>,
}

type Check = (
    String,
    String,
    tokio::sync::oneshot::Sender<Option<(CommanderId, Role)>>,
);

/// Logins that may wait for a password check.
pub const CHECKS_QUEUED: usize = 64;

/// Why a password was not checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CheckRefused {
    #[error("{CHECKS_QUEUED} logins are waiting already: try again in a moment")]
    Busy,
    #[error("the console is shutting down")]
    Gone,
}

impl Checker {
    /// `threads` threads checking passwords against `users`; they end with the checker.
    pub fn new(users: Users, threads: usize) -> Self {
        let (jobs, queue) = std::sync::mpsc::sync_channel::<Check>(CHECKS_QUEUED);
        let queue = std::sync::Arc::new(Mutex::new(queue));
        let users = std::sync::Arc::new(users);
        for i in 0..threads.max(1) {
            let (queue, users) = (queue.clone(), users.clone());
            let spawned = std::thread::Builder::new()
                .name(format!("password-check-{i}"))
                .spawn(move || {
                    let mut memory = Vec::new();
                    loop {
                        let next = queue
                            .lock()
                            .map_err(|_| ())
                            .and_then(|q| q.recv().map_err(|_| ()));
                        let Ok((name, password, reply)) = next else {
                            return;
                        };
                        let _ = reply.send(users.verify_in(&mut memory, &name, &password));
                    }
                });
            if let Err(e) = spawned {
                tracing::error!("no password-check thread: {e}");
            }
        }
        Self { jobs }
    }

    /// Who logs in, and as what, if `password` is `name`'s ([`Users::verify`]).
    pub async fn verify(
        &self,
        name: String,
        password: String,
    ) -> Result<Option<(CommanderId, Role)>, CheckRefused> {
        let (reply, answer) = tokio::sync::oneshot::channel();
        self.jobs
            .try_send((name, password, reply))
            .map_err(|e| match e {
                std::sync::mpsc::TrySendError::Full(_) => CheckRefused::Busy,
                std::sync::mpsc::TrySendError::Disconnected(_) => CheckRefused::Gone,
            })?;
        answer.await.map_err(|_| CheckRefused::Gone)
    }
}

/// Open sessions, by token.
#[derive(Debug)]
pub struct Sessions {
    ttl: Duration,
    open: Mutex<HashMap<String, Session>>,
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

    /// A new session for `who` as `role`; its token. Past [`MAX_SESSIONS_PER_NAME`] the
    /// name's oldest session is closed.
    pub fn open(&self, who: CommanderId, role: Role, now: Instant) -> String {
        let mut bytes = [0u8; 32];
        rand::rng().fill_bytes(&mut bytes);
        let token: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        let mut open = self.open.lock().expect("sessions lock");
        open.retain(|_, s| s.expires > now);
        let mut theirs: Vec<(Instant, String)> = open
            .iter()
            .filter(|(_, s)| s.who == who)
            .map(|(t, s)| (s.opened, t.clone()))
            .collect();
        theirs.sort();
        let over = (theirs.len() + 1).saturating_sub(MAX_SESSIONS_PER_NAME);
        for (_, old) in theirs.into_iter().take(over) {
            open.remove(&old);
        }
        let session = Session {
            who,
            role,
            opened: now,
            expires: now + self.ttl,
        };
        open.insert(token.clone(), session);
        token
    }

    /// Who holds `token` and as what, if the session is open and not expired.
    pub fn who(&self, token: &str, now: Instant) -> Option<(CommanderId, Role)> {
        let mut open = self.open.lock().expect("sessions lock");
        match open.get(token) {
            Some(s) if s.expires > now => Some((s.who.clone(), s.role)),
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
        Users::add(&path, rossi.clone(), "correct horse", Role::Commander).unwrap();
        Users::add(
            &path,
            CommanderId::new("bianchi").unwrap(),
            "battery staple",
            Role::Viewer,
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
        assert_eq!(
            users.verify("rossi", "correct horse"),
            Some((rossi.clone(), Role::Commander))
        );
        assert_eq!(
            users.verify("bianchi", "battery staple"),
            Some((CommanderId::new("bianchi").unwrap(), Role::Viewer))
        );
        assert_eq!(users.verify("rossi", "battery staple"), None);
        assert_eq!(users.verify("rossi", "short"), None);
        assert_eq!(users.verify("verdi", "correct horse"), None);
        assert_eq!(users.verify("not a name!", "correct horse"), None);
        assert!(matches!(
            Users::add(
                &path,
                CommanderId::new("verdi").unwrap(),
                "short",
                Role::Commander
            ),
            Err(AuthError::ShortPassword)
        ));
        // Made a viewer, rossi is no longer a commander.
        Users::add(&path, rossi.clone(), "correct horse", Role::Viewer).unwrap();
        let users = Users::load(&path).unwrap();
        assert_eq!(users.len(), 2);
        assert_eq!(
            users.verify("rossi", "correct horse"),
            Some((rossi, Role::Viewer))
        );
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
        let a = sessions.open(rossi.clone(), Role::Commander, t0);
        let b = sessions.open(rossi.clone(), Role::Commander, t0);
        assert_ne!(a, b);
        assert_eq!(a.len(), 64);
        assert_eq!(
            sessions.who(&a, t0 + Duration::from_secs(59)),
            Some((rossi.clone(), Role::Commander))
        );
        assert_eq!(sessions.who(&a, t0 + Duration::from_secs(60)), None);
        assert_eq!(sessions.who("nope", t0), None);
        sessions.close(&b);
        assert_eq!(sessions.who(&b, t0), None);
        // One name holds a bounded number of sessions: the oldest goes.
        let tokens: Vec<String> = (0..=MAX_SESSIONS_PER_NAME as u64)
            .map(|k| sessions.open(rossi.clone(), Role::Viewer, t0 + Duration::from_millis(k)))
            .collect();
        assert_eq!(sessions.who(&tokens[0], t0), None, "the oldest closed");
        assert!(tokens[1..].iter().all(|t| sessions.who(t, t0).is_some()));
    }
}
