//! Who may operate the matrix: one operator password, bearer tokens, and a brake on
//! guessing.
//!
//! - [`Password`]: the operator password as an argon2id hash in `<data-dir>/password`.
//!   The first start writes the vendor's initial password `1234`, marked as the default
//!   until it is changed (uploads and control are refused until then). Deleting the file
//!   resets the password to `1234`. At most [`CHECK_PERMITS`] password checks run at
//!   once, each in an argon2 work area that is allocated once and reused
//!   ([`CheckPermit`]), so login traffic cannot grow the process's memory.
//! - [`Tokens`]: random 256-bit bearer tokens that expire after [`IDLE_EXPIRY`] without
//!   use. Only their SHA-256 digests are kept, in memory and in
//!   `<data-dir>/sessions.json`, so sessions survive a restart.
//! - [`LoginLimiter`]: at most [`MAX_FAILURES`] wrong passwords per client address in
//!   any [`FAILURE_WINDOW`]; then the address waits.
//! - [`Clock`]: the time all of these read, which tests move forward instead of
//!   sleeping.

use std::collections::{HashMap, VecDeque};
use std::io;
use std::net::IpAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use argon2::password_hash::phc::{Output, ParamsString, PasswordHash, Salt};
use argon2::{Algorithm, Argon2, Block, Params, Version};
use floatball_shared::codes::{self, Code, Coded};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use tokio::sync::{OwnedSemaphorePermit, Semaphore};

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

/// Password checks (argon2id runs) at once, at most. Each needs its own work area of
/// [`Params::DEFAULT_M_COST`] KiB (19 MiB), kept for reuse.
pub const CHECK_PERMITS: usize = 2;

/// How long a login or password change waits for a free check before it is answered
/// 503 with `Retry-After`.
pub const CHECK_QUEUE_WAIT: Duration = Duration::from_secs(10);

/// The largest argon2 memory cost a password file may ask for, KiB (64 MiB): a file
/// asking for more is refused as corrupt rather than allocated.
const MAX_M_COST_KIB: u32 = 64 * 1024;

/// Salt of a new hash, bytes.
const SALT_BYTES: usize = 16;

/// Hash output of a new hash, bytes.
const OUTPUT_BYTES: usize = 32;

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
    #[error("{}", Code::WrongCurrentPassword.english())]
    WrongPassword,
    /// The new password is not acceptable.
    #[error("{0}")]
    Unacceptable(PasswordRule),
}

/// The rule a new password breaks; its text is its code's English template.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PasswordRule {
    /// Fewer than [`MIN_PASSWORD_CHARS`] characters.
    TooShort,
    /// More than [`MAX_PASSWORD_BYTES`] bytes.
    TooLong,
    /// The initial password.
    IsDefault,
}

impl std::fmt::Display for PasswordRule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&codes::english_text(self.code(), &self.params()))
    }
}

impl std::error::Error for PasswordRule {}

impl Coded for PasswordRule {
    fn code(&self) -> Code {
        match self {
            Self::TooShort => Code::PasswordTooShort,
            Self::TooLong => Code::PasswordTooLong,
            Self::IsDefault => Code::PasswordIsDefault,
        }
    }

    fn params(&self) -> codes::Params {
        let mut params = codes::Params::new();
        match self {
            Self::TooShort => params.insert("min".into(), MIN_PASSWORD_CHARS.to_string()),
            Self::TooLong => params.insert("max_bytes".into(), MAX_PASSWORD_BYTES.to_string()),
            Self::IsDefault => params.insert("default".into(), DEFAULT_PASSWORD.to_owned()),
        };
        params
    }
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
    /// Held through a whole change (check, hash, durable write), so two changes cannot
    /// interleave; nothing on an async worker waits for it.
    record: Mutex<Record>,
    /// `record.default`, readable without the lock (request handlers ask it often).
    is_default: AtomicBool,
    checks: Checks,
}

/// Argon2 work areas, one per permit, allocated on first use and then reused, so the
/// memory password checks take is at most [`CHECK_PERMITS`] × 19 MiB for the life of
/// the process (freeing and reallocating 19 MiB per check let the allocator's arenas
/// grow to gigabytes under concurrent logins).
type WorkAreas = Arc<Mutex<Vec<Vec<Block>>>>;

/// The permits and work areas of the password checks.
#[derive(Debug)]
struct Checks {
    permits: Arc<Semaphore>,
    areas: WorkAreas,
}

impl Checks {
    fn new() -> Self {
        Self {
            permits: Arc::new(Semaphore::new(CHECK_PERMITS)),
            areas: Arc::new(Mutex::new(Vec::with_capacity(CHECK_PERMITS))),
        }
    }

    fn permit(&self, permit: OwnedSemaphorePermit) -> CheckPermit {
        let area = self
            .areas
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .pop()
            .unwrap_or_default();
        CheckPermit {
            _permit: permit,
            area,
            areas: Arc::clone(&self.areas),
        }
    }
}

/// The right to run one password check now, with its argon2 work area; dropping it
/// frees the permit and returns the area for the next check.
#[derive(Debug)]
pub struct CheckPermit {
    _permit: OwnedSemaphorePermit,
    area: Vec<Block>,
    areas: WorkAreas,
}

impl CheckPermit {
    /// The first `blocks` blocks of the work area, grown (once) if it is smaller.
    fn memory(&mut self, blocks: usize) -> &mut [Block] {
        if self.area.len() < blocks {
            self.area.resize(blocks, Block::new());
        }
        &mut self.area[..blocks]
    }
}

impl Drop for CheckPermit {
    fn drop(&mut self) {
        let area = std::mem::take(&mut self.area);
        if !area.is_empty() {
            self.areas
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push(area);
        }
    }
}

/// Every password check is taken: the caller waited [`CHECK_QUEUE_WAIT`] in vain.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the bridge is busy checking other passwords")]
pub struct Busy;

impl Password {
    /// Reads `<dir>/password`, creating it with the initial password `1234` if absent.
    ///
    /// # Errors
    /// [`PasswordError`] if the file cannot be read or written, or is not a password
    /// file.
    pub fn open(dir: &Path) -> Result<Self, PasswordError> {
        let path = dir.join(FILE_NAME);
        let checks = Checks::new();
        let record = match std::fs::read_to_string(&path) {
            Ok(text) => {
                let record: Record =
                    serde_json::from_str(&text).map_err(|error| PasswordError::Corrupt {
                        path: path.clone(),
                        reason: error.to_string(),
                    })?;
                Stored::parse(&record.argon2id).map_err(|reason| PasswordError::Corrupt {
                    path: path.clone(),
                    reason,
                })?;
                record
            }
            Err(error) if error.kind() == io::ErrorKind::NotFound => {
                // Nothing else runs yet: a permit is free.
                let permit = Arc::clone(&checks.permits)
                    .try_acquire_owned()
                    .map_err(|_| PasswordError::Interrupted)?;
                let record = Record {
                    argon2id: hash(&mut checks.permit(permit), DEFAULT_PASSWORD)?,
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
            is_default: AtomicBool::new(record.default),
            record: Mutex::new(record),
            checks,
        })
    }

    /// Whether the password is still the initial `1234`.
    pub fn is_default(&self) -> bool {
        self.is_default.load(Ordering::Acquire)
    }

    /// Waits for a free password check, in the order of asking, at most `wait`.
    ///
    /// # Errors
    /// [`Busy`] if none came free in time.
    pub async fn admit(&self, wait: Duration) -> Result<CheckPermit, Busy> {
        let permits = Arc::clone(&self.checks.permits);
        match tokio::time::timeout(wait, permits.acquire_owned()).await {
            Ok(Ok(permit)) => Ok(self.checks.permit(permit)),
            // The semaphore is never closed; a timeout is the only real case.
            Ok(Err(_)) | Err(_) => Err(Busy),
        }
    }

    /// A free password check now, if there is one.
    pub fn try_admit(&self) -> Option<CheckPermit> {
        let permit = Arc::clone(&self.checks.permits).try_acquire_owned().ok()?;
        Some(self.checks.permit(permit))
    }

    /// Whether `candidate` is the password. Slow on purpose (argon2id): call it from
    /// a blocking thread, with a permit from [`admit`](Self::admit).
    pub fn verify(&self, permit: &mut CheckPermit, candidate: &str) -> bool {
        let phc = self.lock().argon2id.clone();
        verify(permit, &phc, candidate)
    }

    /// Replaces the password if `old` is the current one. Slow (two argon2id runs):
    /// call it from a blocking thread, with a permit from [`admit`](Self::admit).
    ///
    /// # Errors
    /// [`PasswordError::WrongPassword`], [`PasswordError::Unacceptable`] (too short,
    /// too long, or the initial password), or an I/O error writing the file (the old
    /// password then stays).
    pub fn change(
        &self,
        permit: &mut CheckPermit,
        old: &str,
        new: &str,
    ) -> Result<(), PasswordError> {
        // Held throughout, so two changes cannot interleave.
        let mut record = self.lock();
        if !verify(permit, &record.argon2id, old) {
            return Err(PasswordError::WrongPassword);
        }
        if new.chars().count() < MIN_PASSWORD_CHARS {
            return Err(PasswordError::Unacceptable(PasswordRule::TooShort));
        }
        if new.len() > MAX_PASSWORD_BYTES {
            return Err(PasswordError::Unacceptable(PasswordRule::TooLong));
        }
        if new == DEFAULT_PASSWORD {
            return Err(PasswordError::Unacceptable(PasswordRule::IsDefault));
        }
        let changed = Record {
            argon2id: hash(permit, new)?,
            default: false,
        };
        store(&self.dir, &changed)?;
        *record = changed;
        self.is_default.store(false, Ordering::Release);
        Ok(())
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Record> {
        self.record.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// A stored argon2 hash, taken apart.
struct Stored {
    argon2: Argon2<'static>,
    salt: Vec<u8>,
    hash: Vec<u8>,
    blocks: usize,
}

impl Stored {
    /// Reads a PHC string (`$argon2id$v=19$m=…,t=…,p=…$salt$hash`).
    fn parse(phc: &str) -> Result<Self, String> {
        let parsed = PasswordHash::new(phc).map_err(|error| error.to_string())?;
        let algorithm = Algorithm::try_from(parsed.algorithm.as_str())
            .map_err(|_| format!("{} is not an argon2 algorithm", parsed.algorithm))?;
        let version = parsed
            .version
            .map(Version::try_from)
            .transpose()
            .map_err(|_| "unknown argon2 version".to_owned())?
            .unwrap_or_default();
        let params = Params::try_from(&parsed).map_err(|error| error.to_string())?;
        if params.m_cost() > MAX_M_COST_KIB {
            return Err(format!(
                "the hash asks for {} KiB of memory; at most {MAX_M_COST_KIB} are allowed",
                params.m_cost()
            ));
        }
        let salt = parsed.salt.ok_or("the hash has no salt")?;
        let hash = parsed.hash.ok_or("the hash has no output")?;
        let blocks = params.block_count();
        Ok(Self {
            argon2: Argon2::new(algorithm, version, params),
            salt: salt.as_ref().to_vec(),
            hash: hash.as_bytes().to_vec(),
            blocks,
        })
    }
}

/// A new argon2id hash of `password` with the default parameters and a random salt,
/// computed in the permit's work area.
fn hash(permit: &mut CheckPermit, password: &str) -> Result<String, PasswordError> {
    let failed = |error: &dyn std::fmt::Display| PasswordError::Hash(error.to_string());
    let params = Params::DEFAULT;
    let mut salt = [0u8; SALT_BYTES];
    getrandom::fill(&mut salt).map_err(|error| failed(&error))?;
    let mut output = [0u8; OUTPUT_BYTES];
    let memory = permit.memory(params.block_count());
    Argon2::new(Algorithm::Argon2id, Version::V0x13, params.clone())
        .hash_password_into_with_memory(password.as_bytes(), &salt, &mut output, memory)
        .map_err(|error| failed(&error))?;
    let phc = PasswordHash {
        algorithm: Algorithm::Argon2id.ident(),
        version: Some(Version::V0x13.into()),
        params: ParamsString::try_from(&params).map_err(|error| failed(&error))?,
        salt: Some(Salt::new(&salt).map_err(|error| failed(&error))?),
        hash: Some(Output::new(&output).map_err(|error| failed(&error))?),
    };
    Ok(phc.to_string())
}

/// Whether `candidate` hashes to the stored `phc`, computed in the permit's work area
/// and compared in constant time.
fn verify(permit: &mut CheckPermit, phc: &str, candidate: &str) -> bool {
    if candidate.len() > MAX_PASSWORD_BYTES {
        return false;
    }
    let Ok(stored) = Stored::parse(phc) else {
        return false;
    };
    let mut output = [0u8; Output::MAX_LENGTH];
    let Some(output) = output.get_mut(..stored.hash.len()) else {
        return false;
    };
    let memory = permit.memory(stored.blocks);
    stored
        .argon2
        .hash_password_into_with_memory(candidate.as_bytes(), &stored.salt, output, memory)
        .is_ok()
        && constant_time_eq(output, &stored.hash)
}

/// Whether `a` and `b` are equal, taking the same time wherever they differ.
fn constant_time_eq(a: &[u8], b: &[u8]) -> bool {
    if a.len() != b.len() {
        return false;
    }
    let difference = a
        .iter()
        .zip(b)
        .fold(0u8, |difference, (x, y)| difference | (x ^ y));
    std::hint::black_box(difference) == 0
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

    fn check(password: &Password) -> CheckPermit {
        password.try_admit().expect("a free check")
    }

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
        assert!(password.verify(&mut check(&password), "1234"));
        assert!(!password.verify(&mut check(&password), "12345"));
        let text = std::fs::read_to_string(dir.path().join(FILE_NAME)).expect("file");
        assert!(text.contains("$argon2id$"), "{text}");
        assert!(!text.contains("\"1234\""), "{text}");
    }

    #[test]
    fn hashes_agree_with_the_argon2_crate_both_ways() {
        use argon2::password_hash::{PasswordHasher, PasswordVerifier};
        let dir = tempfile::tempdir().expect("temp dir");
        let password = Password::open(dir.path()).expect("open");
        // A file written by an earlier version (the crate's own hasher) still verifies.
        let earlier = Argon2::default()
            .hash_password(b"old secret")
            .expect("hash")
            .to_string();
        assert!(verify(&mut check(&password), &earlier, "old secret"));
        assert!(!verify(&mut check(&password), &earlier, "old secreT"));
        // Ours verifies with the crate's own verifier, and keeps the default parameters.
        let ours = hash(&mut check(&password), "new secret").expect("hash");
        assert!(
            ours.starts_with("$argon2id$v=19$m=19456,t=2,p=1$"),
            "{ours}"
        );
        let parsed = PasswordHash::new(&ours).expect("phc");
        assert!(
            Argon2::default()
                .verify_password(b"new secret", &parsed)
                .is_ok()
        );
        assert!(verify(&mut check(&password), &ours, "new secret"));
        assert!(!verify(&mut check(&password), "not a hash", "new secret"));
    }

    #[test]
    fn checks_are_limited_and_their_memory_is_reused() {
        let dir = tempfile::tempdir().expect("temp dir");
        let password = Password::open(dir.path()).expect("open");
        let first = check(&password);
        let mut second = check(&password);
        assert!(
            password.try_admit().is_none(),
            "only {CHECK_PERMITS} at once"
        );
        assert!(password.verify(&mut second, "1234"));
        let area = second.area.as_ptr();
        drop(second);
        drop(first);
        let mut again = check(&password);
        assert!(password.verify(&mut again, "1234"));
        let areas = password.checks.areas.lock().expect("areas");
        assert!(
            areas.iter().any(|kept| kept.as_ptr() == area) || again.area.as_ptr() == area,
            "the work area is reused"
        );
        assert!(areas.len() < CHECK_PERMITS, "one area is in use");
    }

    #[test]
    fn a_password_file_asking_for_too_much_memory_is_corrupt() {
        let dir = tempfile::tempdir().expect("temp dir");
        let greedy = "$argon2id$v=19$m=4194304,t=1,p=1$c2FsdHNhbHRzYWx0$\
                      AAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAAA";
        std::fs::write(
            dir.path().join(FILE_NAME),
            serde_json::json!({ "argon2id": greedy, "default": false }).to_string(),
        )
        .expect("write");
        let message = Password::open(dir.path()).expect_err("greedy").to_string();
        assert!(message.contains("KiB of memory"), "{message}");
    }

    #[test]
    fn a_change_is_stored_and_survives_a_reopen() {
        let dir = tempfile::tempdir().expect("temp dir");
        let password = Password::open(dir.path()).expect("open");
        assert!(matches!(
            password.change(&mut check(&password), "0000", "secret"),
            Err(PasswordError::WrongPassword)
        ));
        assert!(matches!(
            password.change(&mut check(&password), "1234", "abc"),
            Err(PasswordError::Unacceptable(_))
        ));
        assert!(matches!(
            password.change(&mut check(&password), "1234", "1234"),
            Err(PasswordError::Unacceptable(_))
        ));
        assert!(password.is_default());
        password
            .change(&mut check(&password), "1234", "秘密的口令")
            .expect("change");
        assert!(!password.is_default());
        let reopened = Password::open(dir.path()).expect("reopen");
        assert!(!reopened.is_default());
        assert!(reopened.verify(&mut check(&reopened), "秘密的口令"));
        assert!(!reopened.verify(&mut check(&reopened), "1234"));
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
