//! Who may operate the matrix: one operator password, bearer tokens, and a brake on
//! guessing.
//!
//! - [`Password`]: the operator password as an argon2id hash in `<data-dir>/password`.
//!   The first start writes the vendor's initial password `1234`, marked as the default
//!   until it is changed (uploads and control are refused until then). Deleting the file
//!   resets the password to `1234`.
//! - [`Tokens`]: random 256-bit bearer tokens, kept in memory only (a restart logs
//!   everyone out), that expire after [`IDLE_EXPIRY`] without use.
//! - [`LoginLimiter`]: at most [`MAX_FAILURES`] wrong passwords per client address in
//!   any [`FAILURE_WINDOW`]; then the address waits.
//! - [`Clock`]: the time all of these read, which tests move forward instead of
//!   sleeping.

use std::collections::{HashMap, VecDeque};
use std::io;
use std::net::IpAddr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use argon2::Argon2;
use argon2::password_hash::phc::PasswordHash;
use argon2::password_hash::{PasswordHasher, PasswordVerifier};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::durable;

/// The password file's name inside the data directory.
pub const FILE_NAME: &str = "password";

/// The initial password, as in the vendor's manual.
pub const DEFAULT_PASSWORD: &str = "1234";

/// Shortest new password accepted, characters.
pub const MIN_PASSWORD_CHARS: usize = 4;

/// Longest password accepted, bytes.
pub const MAX_PASSWORD_BYTES: usize = 1024;

/// A token unused for this long is no longer accepted.
pub const IDLE_EXPIRY: Duration = Duration::from_secs(12 * 60 * 60);

/// Wrong passwords allowed per client address within [`FAILURE_WINDOW`].
pub const MAX_FAILURES: usize = 5;

/// The sliding window [`MAX_FAILURES`] counts in.
pub const FAILURE_WINDOW: Duration = Duration::from_secs(60);

/// Most tokens kept at once; past it the least recently used is dropped.
const MAX_TOKENS: usize = 1000;

/// Most client addresses the limiter remembers at once.
const MAX_TRACKED_ADDRESSES: usize = 10_000;

/// The time as the auth rules see it: the system's monotonic clock, or in tests one
/// that can be moved forward.
#[derive(Debug, Clone, Default)]
pub struct Clock {
    skew: Option<Arc<Mutex<Duration>>>,
}

impl Clock {
    /// The system's monotonic clock.
    pub fn system() -> Self {
        Self::default()
    }

    /// A clock that runs with the system's but can be moved forward with
    /// [`advance`](Self::advance).
    pub fn adjustable() -> Self {
        Self {
            skew: Some(Arc::new(Mutex::new(Duration::ZERO))),
        }
    }

    /// Now.
    pub fn now(&self) -> Instant {
        let skew = self.skew.as_ref().map_or(Duration::ZERO, |skew| {
            *skew.lock().unwrap_or_else(PoisonError::into_inner)
        });
        Instant::now() + skew
    }

    /// Moves an [adjustable](Self::adjustable) clock forward by `by`; the system
    /// clock cannot be moved and is left alone.
    pub fn advance(&self, by: Duration) {
        if let Some(skew) = &self.skew {
            *skew.lock().unwrap_or_else(PoisonError::into_inner) += by;
        }
    }
}

/// Why the password cannot be read, checked or changed.
#[derive(Debug, thiserror::Error)]
pub enum PasswordError {
    /// The password file cannot be read or written.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The password file is not what this bridge writes.
    #[error(
        "{}: not a password file ({reason}); delete it to reset the password to {DEFAULT_PASSWORD}",
        path.display()
    )]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Hashing failed (it does not with the default parameters).
    #[error("cannot hash the password: {0}")]
    Hash(String),
    /// The hashing task did not finish.
    #[error("the password check was interrupted")]
    Interrupted,
    /// The current password given with a change is wrong.
    #[error("the current password is wrong")]
    WrongPassword,
    /// The new password is not acceptable.
    #[error("{0}")]
    Unacceptable(&'static str),
}

/// The password file's content.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Record {
    /// The argon2id PHC string.
    argon2id: String,
    /// Still the initial password.
    default: bool,
}

/// The operator password, stored hashed in the data directory.
#[derive(Debug)]
pub struct Password {
    dir: PathBuf,
    record: Mutex<Record>,
}

impl Password {
    /// Reads `<dir>/password`, creating it with the initial password `1234` if absent.
    ///
    /// # Errors
    /// [`PasswordError`] if the file cannot be read or written, or is not a password
    /// file.
    pub fn open(dir: &Path) -> Result<Self, PasswordError> {
        let path = dir.join(FILE_NAME);
        let record = match std::fs::read_to_string(&path) {
            Ok(text) => {
                let record: Record =
                    serde_json::from_str(&text).map_err(|error| PasswordError::Corrupt {
                        path: path.clone(),
                        reason: error.to_string(),
                    })?;
                PasswordHash::new(&record.argon2id).map_err(|error| PasswordError::Corrupt {
                    path: path.clone(),
                    reason: error.to_string(),
                })?;
                record
            }
            Err(error) if error.kind() == io::ErrorKind::NotFound => {
                let record = Record {
                    argon2id: hash(DEFAULT_PASSWORD)?,
                    default: true,
                };
                store(dir, &record)?;
                tracing::warn!(
                    "the operator password is the initial {DEFAULT_PASSWORD}: change it before \
                     uploading or controlling"
                );
                record
            }
            Err(source) => return Err(PasswordError::Io { path, source }),
        };
        Ok(Self {
            dir: dir.to_owned(),
            record: Mutex::new(record),
        })
    }

    /// Whether the password is still the initial `1234`.
    pub fn is_default(&self) -> bool {
        self.lock().default
    }

    /// Whether `candidate` is the password. Slow on purpose (argon2id): call it from
    /// a blocking thread.
    pub fn verify(&self, candidate: &str) -> bool {
        let phc = self.lock().argon2id.clone();
        verify(&phc, candidate)
    }

    /// Replaces the password if `old` is the current one. Slow (two argon2id runs):
    /// call it from a blocking thread.
    ///
    /// # Errors
    /// [`PasswordError::WrongPassword`], [`PasswordError::Unacceptable`] (too short,
    /// too long, or the initial password), or an I/O error writing the file (the old
    /// password then stays).
    pub fn change(&self, old: &str, new: &str) -> Result<(), PasswordError> {
        // Held throughout, so two changes cannot interleave.
        let mut record = self.lock();
        if !verify(&record.argon2id, old) {
            return Err(PasswordError::WrongPassword);
        }
        if new.chars().count() < MIN_PASSWORD_CHARS {
            return Err(PasswordError::Unacceptable(
                "the new password must have at least 4 characters",
            ));
        }
        if new.len() > MAX_PASSWORD_BYTES {
            return Err(PasswordError::Unacceptable(
                "the new password must have at most 1024 bytes",
            ));
        }
        if new == DEFAULT_PASSWORD {
            return Err(PasswordError::Unacceptable(
                "the new password must not be the initial password 1234",
            ));
        }
        let changed = Record {
            argon2id: hash(new)?,
            default: false,
        };
        store(&self.dir, &changed)?;
        *record = changed;
        Ok(())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Record> {
        self.record.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

fn hash(password: &str) -> Result<String, PasswordError> {
    Argon2::default()
        .hash_password(password.as_bytes())
        .map(|hash| hash.to_string())
        .map_err(|error| PasswordError::Hash(error.to_string()))
}

fn verify(phc: &str, candidate: &str) -> bool {
    if candidate.len() > MAX_PASSWORD_BYTES {
        return false;
    }
    PasswordHash::new(phc).is_ok_and(|hash| {
        Argon2::default()
            .verify_password(candidate.as_bytes(), &hash)
            .is_ok()
    })
}

fn store(dir: &Path, record: &Record) -> Result<(), PasswordError> {
    let path = dir.join(FILE_NAME);
    let text = serde_json::to_vec_pretty(record).map_err(|error| PasswordError::Io {
        path: path.clone(),
        source: io::Error::other(error),
    })?;
    durable::write_atomic(dir, FILE_NAME, &text)
        .map_err(|source| PasswordError::Io { path, source })
}

/// The file that keeps the sessions across restarts: the SHA-256 of every live token
/// (never a token itself), so phones and kiosks reconnect after the bridge restarts
/// without logging in again.
const SESSIONS_FILE: &str = "sessions.json";

/// The bearer tokens handed out by `POST /api/login`, each with its last use. Tokens
/// are known by their SHA-256; a restart counts as a use of every token it keeps.
#[derive(Debug, Default)]
pub struct Tokens {
    last_used: Mutex<HashMap<String, Instant>>,
    /// Where the sessions are kept; `None` keeps them in memory only.
    dir: Option<PathBuf>,
}

fn digest(token: &str) -> String {
    durable::hex(&Sha256::digest(token.as_bytes()))
}

impl Tokens {
    /// No tokens, kept in memory only.
    pub fn new() -> Self {
        Self::default()
    }

    /// The tokens kept in `dir` (none if the file is missing or unreadable, which is
    /// logged), valid from `now`; changes are written back there.
    pub fn open(dir: &Path, now: Instant) -> Self {
        let path = dir.join(SESSIONS_FILE);
        let digests: Vec<String> = match std::fs::read(&path) {
            Ok(bytes) => serde_json::from_slice(&bytes).unwrap_or_else(|error| {
                tracing::warn!("{}: {error}; everyone logs in again", path.display());
                Vec::new()
            }),
            Err(error) if error.kind() == io::ErrorKind::NotFound => Vec::new(),
            Err(error) => {
                tracing::warn!("{}: {error}; everyone logs in again", path.display());
                Vec::new()
            }
        };
        let last_used = digests
            .into_iter()
            .take(MAX_TOKENS)
            .map(|digest| (digest, now))
            .collect();
        Self {
            last_used: Mutex::new(last_used),
            dir: Some(dir.to_path_buf()),
        }
    }

    /// A new random token, valid from `now`.
    ///
    /// # Errors
    /// If the system's random source fails.
    pub fn issue(&self, now: Instant) -> Result<String, getrandom::Error> {
        let mut bytes = [0u8; 32];
        getrandom::fill(&mut bytes)?;
        let token = durable::hex(&bytes);
        let mut tokens = self.lock();
        tokens.retain(|_, last_used| !expired(*last_used, now));
        if tokens.len() >= MAX_TOKENS
            && let Some(oldest) = tokens
                .iter()
                .min_by_key(|(_, last_used)| **last_used)
                .map(|(digest, _)| digest.clone())
        {
            tokens.remove(&oldest);
        }
        tokens.insert(digest(&token), now);
        self.keep(&tokens);
        Ok(token)
    }

    /// Whether `token` is valid at `now`; a valid token's idle time starts again.
    pub fn touch(&self, token: &str, now: Instant) -> bool {
        let mut tokens = self.lock();
        let digest = digest(token);
        match tokens.get_mut(&digest) {
            Some(last_used) if !expired(*last_used, now) => {
                *last_used = now.max(*last_used);
                true
            }
            Some(_) => {
                tokens.remove(&digest);
                self.keep(&tokens);
                false
            }
            None => false,
        }
    }

    /// Whether `token` is valid at `now`, without counting this as a use.
    pub fn is_valid(&self, token: &str, now: Instant) -> bool {
        self.lock()
            .get(&digest(token))
            .is_some_and(|last_used| !expired(*last_used, now))
    }

    /// Ends `token` (logout).
    pub fn revoke(&self, token: &str) {
        let mut tokens = self.lock();
        tokens.remove(&digest(token));
        self.keep(&tokens);
    }

    /// Ends every token but `keep` (after a password change).
    pub fn revoke_others(&self, keep: &str) {
        let keep = digest(keep);
        let mut tokens = self.lock();
        tokens.retain(|digest, _| *digest == keep);
        self.keep(&tokens);
    }

    /// Writes the live tokens' digests, if they are kept on disk. A failure is logged:
    /// the sessions still work until the next restart.
    fn keep(&self, tokens: &HashMap<String, Instant>) {
        let Some(dir) = &self.dir else { return };
        let mut digests: Vec<&String> = tokens.keys().collect();
        digests.sort();
        let written = serde_json::to_vec(&digests)
            .map_err(io::Error::other)
            .and_then(|bytes| durable::write_atomic(dir, SESSIONS_FILE, &bytes));
        if let Err(error) = written {
            tracing::warn!(
                "cannot keep the sessions in {}: {error}",
                dir.join(SESSIONS_FILE).display()
            );
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, Instant>> {
        self.last_used
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
    }
}

fn expired(last_used: Instant, now: Instant) -> bool {
    now.saturating_duration_since(last_used) >= IDLE_EXPIRY
}

/// Counts wrong passwords per client address in a sliding window.
#[derive(Debug, Default)]
pub struct LoginLimiter {
    failures: Mutex<HashMap<IpAddr, VecDeque<Instant>>>,
}

impl LoginLimiter {
    /// Nothing counted yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Starts a password attempt from `address` at `now`. The attempt counts as a
    /// failure until [`forgive`](Self::forgive) says it succeeded, so that attempts
    /// made at the same time cannot slip past the limit while the (slow) check runs.
    ///
    /// # Errors
    /// How long `address` must wait: until the oldest failure in the window leaves it.
    pub fn attempt(&self, address: IpAddr, now: Instant) -> Result<(), Duration> {
        let mut failures = self.lock();
        if failures.len() >= MAX_TRACKED_ADDRESSES {
            failures.retain(|_, times| {
                forget_old(times, now);
                !times.is_empty()
            });
        }
        let times = failures.entry(address.to_canonical()).or_default();
        forget_old(times, now);
        match times.front() {
            Some(oldest) if times.len() >= MAX_FAILURES => {
                Err((*oldest + FAILURE_WINDOW).saturating_duration_since(now))
            }
            _ => {
                times.push_back(now);
                Ok(())
            }
        }
    }

    /// The attempt `address` started at `at` was right: it no longer counts.
    pub fn forgive(&self, address: IpAddr, at: Instant) {
        let mut failures = self.lock();
        let address = address.to_canonical();
        if let Some(times) = failures.get_mut(&address) {
            if let Some(position) = times.iter().rposition(|time| *time == at) {
                times.remove(position);
            }
            if times.is_empty() {
                failures.remove(&address);
            }
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<IpAddr, VecDeque<Instant>>> {
        self.failures.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

fn forget_old(times: &mut VecDeque<Instant>, now: Instant) {
    while times
        .front()
        .is_some_and(|time| now.saturating_duration_since(*time) >= FAILURE_WINDOW)
    {
        times.pop_front();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sessions_survive_a_restart_and_the_file_holds_no_token() {
        let dir = tempfile::tempdir().unwrap();
        let start = Instant::now();
        let tokens = Tokens::open(dir.path(), start);
        let kept = tokens.issue(start).unwrap();
        let ended = tokens.issue(start).unwrap();
        tokens.revoke(&ended);
        let file = std::fs::read_to_string(dir.path().join(SESSIONS_FILE)).unwrap();
        assert!(!file.contains(&kept) && !file.contains(&ended), "{file}");

        let later = start + Duration::from_secs(3600);
        let restarted = Tokens::open(dir.path(), later);
        assert!(restarted.touch(&kept, later));
        assert!(!restarted.is_valid(&ended, later));
        // The restart counts as a use: 12 h idle from then.
        assert!(restarted.is_valid(&kept, later + IDLE_EXPIRY - Duration::from_secs(1)));
        assert!(!restarted.is_valid(&kept, later + IDLE_EXPIRY + Duration::from_secs(1)));
    }

    #[test]
    fn a_damaged_sessions_file_means_logging_in_again() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(SESSIONS_FILE), b"{not json").unwrap();
        let tokens = Tokens::open(dir.path(), Instant::now());
        assert!(!tokens.is_valid("anything", Instant::now()));
        let token = tokens.issue(Instant::now()).unwrap();
        assert!(Tokens::open(dir.path(), Instant::now()).is_valid(&token, Instant::now()));
    }

    #[test]
    fn the_first_start_writes_the_initial_password() {
        let dir = tempfile::tempdir().expect("temp dir");
        let password = Password::open(dir.path()).expect("open");
        assert!(password.is_default());
        assert!(password.verify("1234"));
        assert!(!password.verify("12345"));
        let text = std::fs::read_to_string(dir.path().join(FILE_NAME)).expect("file");
        assert!(text.contains("$argon2id$"), "{text}");
        assert!(!text.contains("\"1234\""), "{text}");
    }

    #[test]
    fn a_change_is_stored_and_survives_a_reopen() {
        let dir = tempfile::tempdir().expect("temp dir");
        let password = Password::open(dir.path()).expect("open");
        assert!(matches!(
            password.change("0000", "secret"),
            Err(PasswordError::WrongPassword)
        ));
        assert!(matches!(
            password.change("1234", "abc"),
            Err(PasswordError::Unacceptable(_))
        ));
        assert!(matches!(
            password.change("1234", "1234"),
            Err(PasswordError::Unacceptable(_))
        ));
        assert!(password.is_default());
        password.change("1234", "秘密的口令").expect("change");
        assert!(!password.is_default());
        let reopened = Password::open(dir.path()).expect("reopen");
        assert!(!reopened.is_default());
        assert!(reopened.verify("秘密的口令"));
        assert!(!reopened.verify("1234"));
    }

    #[test]
    fn a_corrupt_password_file_says_how_to_reset() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(dir.path().join(FILE_NAME), "hello").expect("write");
        let message = Password::open(dir.path()).expect_err("corrupt").to_string();
        assert!(message.contains("delete it to reset"), "{message}");
    }

    #[test]
    fn tokens_expire_after_twelve_idle_hours() {
        let tokens = Tokens::new();
        let start = Instant::now();
        let token = tokens.issue(start).expect("token");
        assert_eq!(token.len(), 64);
        assert!(tokens.touch(&token, start + Duration::from_secs(11 * 3600)));
        // Used at 11 h: valid until 23 h.
        assert!(tokens.touch(&token, start + Duration::from_secs(22 * 3600)));
        let later = start + Duration::from_secs(22 * 3600) + IDLE_EXPIRY;
        assert!(tokens.is_valid(&token, later - Duration::from_secs(1)));
        assert!(!tokens.is_valid(&token, later));
        assert!(!tokens.touch(&token, later));
        assert!(
            !tokens.touch(&token, start),
            "an expired token is gone for good"
        );
        assert!(!tokens.touch("not a token", start));
    }

    #[test]
    fn revoked_tokens_are_refused() {
        let tokens = Tokens::new();
        let now = Instant::now();
        let (a, b) = (tokens.issue(now).expect("a"), tokens.issue(now).expect("b"));
        assert_ne!(a, b);
        tokens.revoke_others(&a);
        assert!(tokens.touch(&a, now));
        assert!(!tokens.touch(&b, now));
        tokens.revoke(&a);
        assert!(!tokens.touch(&a, now));
    }

    #[test]
    fn five_failures_in_a_minute_make_an_address_wait() {
        let limiter = LoginLimiter::new();
        let client: IpAddr = "192.0.2.7".parse().expect("ip");
        let other: IpAddr = "192.0.2.8".parse().expect("ip");
        let start = Instant::now();
        for second in 0..5 {
            assert_eq!(
                limiter.attempt(client, start + Duration::from_secs(second * 10)),
                Ok(())
            );
        }
        let now = start + Duration::from_secs(45);
        assert_eq!(limiter.attempt(client, now), Err(Duration::from_secs(15)));
        assert_eq!(limiter.attempt(other, now), Ok(()));
        // The first failure leaves the window at 60 s: one more try is allowed.
        assert_eq!(
            limiter.attempt(client, start + Duration::from_secs(60)),
            Ok(())
        );
        assert!(
            limiter
                .attempt(client, start + Duration::from_secs(61))
                .is_err()
        );
    }

    #[test]
    fn right_passwords_do_not_count() {
        let limiter = LoginLimiter::new();
        let client: IpAddr = "192.0.2.7".parse().expect("ip");
        let start = Instant::now();
        for attempt in 0..10 {
            let at = start + Duration::from_millis(attempt);
            assert_eq!(limiter.attempt(client, at), Ok(()));
            limiter.forgive(client, at);
        }
    }

    #[test]
    fn ipv4_mapped_addresses_count_as_their_ipv4_address() {
        let limiter = LoginLimiter::new();
        let now = Instant::now();
        let mapped: IpAddr = "::ffff:192.0.2.7".parse().expect("ip");
        for _ in 0..5 {
            assert_eq!(limiter.attempt(mapped, now), Ok(()));
        }
        assert!(
            limiter
                .attempt("192.0.2.7".parse().expect("ip"), now)
                .is_err()
        );
    }

    #[test]
    fn an_adjustable_clock_moves_forward() {
        let clock = Clock::adjustable();
        let before = clock.now();
        clock.advance(IDLE_EXPIRY);
        assert!(clock.now() >= before + IDLE_EXPIRY);
    }
}
