//! The show store: `<data-dir>/shows/`, one native JSON file per show.
//!
//! Show names are for people: any script, at most [`MAX_NAME_BYTES`] bytes, without
//! `/`, `\`, control characters, a leading `.` or `..` ([`ShowName`]). A new show's
//! name also may not hold invisible or text-direction characters, which make one name
//! look like another ([`ShowName::parse_new`]). On disk each show
//! is `<hex of the name's UTF-8>.json`, so every name is a safe file name of at most
//! 205 bytes and the listing gives the names back exactly.
//!
//! The store holds shows, not bytes: [`ShowStore::put`] takes a [`Show`] (imported and
//! checked against the installation by [`show::import`](fn@show::import) before it
//! gets here) and writes its native file atomically ([`crate::durable`]);
//! [`ShowStore::load`] reads one back through the same import. Only a download takes
//! the stored file as it is ([`ShowStore::file`]). A summary of every show (size,
//! SHA-256, time, units, duration) is kept in memory, so listing does not reread them,
//! and in the show index ([`INDEX_FILE`], written atomically with each show), so a
//! start reads no show: the index is checked against the files' sizes and times, and
//! the shows it lacks (an upgrade, a lost index, files copied in by hand) are
//! summarised by a thread of their own while the bridge already serves
//! ([`ShowStore::indexed`]).
//!
//! **Concurrency.** What the store knows ([`Known`]) is behind one mutex, held only to
//! read or change it — never across a file's reading or writing, nor while another
//! lock is taken. The index file has one writer, a thread of its own
//! ([`IndexWriter`]): asked after each change, it writes the latest summaries, so two
//! writes never race and a slow disk holds up no one but the caller waiting for its
//! own write. Two writes of the same show are ordered by their caller (the API's
//! catalogue lock); the indexing thread's summaries give way to any store or delete
//! that came meanwhile.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, Sender, SyncSender, channel, sync_channel};
use std::sync::{Arc, Mutex, PoisonError, Weak};
use std::time::SystemTime;

use floatball_shared::api::{Problem, ShowSummary};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::show::{self, Show, ShowFormat};
use sha2::{Digest, Sha256};

use crate::durable;

/// The directory of the show files inside the data directory.
pub const DIR_NAME: &str = "shows";

/// Longest show name, bytes of UTF-8.
pub const MAX_NAME_BYTES: usize = 100;

const EXTENSION: &str = ".json";

/// The buffer between a show file and its JSON reader or writer, bytes.
const READ_BUFFER_BYTES: usize = 1 << 16;

/// A valid show name.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ShowName(String);

/// Why a show name is refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum NameError {
    /// No characters.
    #[error("the show name is empty")]
    Empty,
    /// Over [`MAX_NAME_BYTES`].
    #[error("the show name is {bytes} bytes long; at most 100 bytes are allowed")]
    TooLong {
        /// Its length in bytes.
        bytes: usize,
    },
    /// A character that cannot be in a name.
    #[error("the show name must not contain {0}")]
    Forbidden(&'static str),
    /// An invisible or text-direction character, which makes the name look like another
    /// (or read backwards).
    #[error(
        "the show name must not contain U+{code:04X} ({kind}): such characters make a name \
         look like another"
    )]
    Misleading {
        /// The character's code point.
        code: u32,
        /// What it is, in words.
        kind: &'static str,
    },
}

/// What `c` is, if it is an invisible or text-direction character: the bidirectional
/// embeddings, overrides and isolates (U+202A–U+202E, U+2066–U+2069), the direction
/// marks (U+200E, U+200F, U+061C), and the zero-width characters (U+200B–U+200D,
/// U+2060–U+2064, U+FEFF).
fn misleading(c: char) -> Option<&'static str> {
    match c {
        '\u{202A}'..='\u{202E}' | '\u{2066}'..='\u{2069}' => {
            Some("a bidirectional override or isolate")
        }
        '\u{200E}' | '\u{200F}' | '\u{061C}' => Some("a text-direction mark"),
        '\u{200B}'..='\u{200D}' | '\u{2060}'..='\u{2064}' | '\u{FEFF}' => {
            Some("a zero-width character")
        }
        _ => None,
    }
}

impl ShowName {
    /// Checks a name.
    ///
    /// # Errors
    /// [`NameError`] saying what is wrong.
    pub fn parse(name: &str) -> Result<Self, NameError> {
        if name.is_empty() {
            return Err(NameError::Empty);
        }
        if name.len() > MAX_NAME_BYTES {
            return Err(NameError::TooLong { bytes: name.len() });
        }
        if name.contains('/') {
            return Err(NameError::Forbidden("`/`"));
        }
        if name.contains('\\') {
            return Err(NameError::Forbidden("`\\`"));
        }
        if name.chars().any(char::is_control) {
            return Err(NameError::Forbidden("control characters"));
        }
        if name.starts_with('.') {
            return Err(NameError::Forbidden("a leading `.`"));
        }
        if name.contains("..") {
            return Err(NameError::Forbidden("`..`"));
        }
        Ok(Self(name.to_owned()))
    }

    /// Checks the name of a show being stored: as [`parse`](Self::parse), and without
    /// invisible or text-direction characters. (Shows stored before this rule keep
    /// their names, so they can still be read and deleted.)
    ///
    /// # Errors
    /// [`NameError`] saying what is wrong.
    pub fn parse_new(name: &str) -> Result<Self, NameError> {
        let parsed = Self::parse(name)?;
        match name.chars().find_map(|c| Some((c, misleading(c)?))) {
            Some((c, kind)) => Err(NameError::Misleading {
                code: u32::from(c),
                kind,
            }),
            None => Ok(parsed),
        }
    }

    /// The name.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The file name it is stored under.
    fn file_name(&self) -> String {
        format!("{}{EXTENSION}", durable::hex(self.0.as_bytes()))
    }

    /// The show name a file name stands for, if it is one of ours.
    fn from_file_name(file_name: &str) -> Option<Self> {
        let hex = file_name.strip_suffix(EXTENSION)?;
        if hex.len() % 2 != 0 {
            return None;
        }
        let bytes = (0..hex.len())
            .step_by(2)
            .map(|at| u8::from_str_radix(hex.get(at..at + 2)?, 16).ok())
            .collect::<Option<Vec<u8>>>()?;
        Self::parse(&String::from_utf8(bytes).ok()?).ok()
    }
}

impl fmt::Display for ShowName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// A show or playlist this installation refuses, as the HTTP API answers it: what is
/// wrong (code, parameters, sentence), and every problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{error}")]
pub struct Refused {
    /// The refusal's code.
    pub code: Code,
    /// Its parameters.
    pub params: Params,
    /// One sentence.
    pub error: String,
    /// Each problem, in English.
    pub details: Vec<String>,
    /// Each problem as a code and parameters, one for one with `details`.
    pub problems: Vec<Problem>,
    /// Refused for its size (`max_bytes`, 413) rather than its content (422).
    pub too_large: bool,
}

impl Refused {
    /// Refused for its content with `code`, listing every problem of `problems`.
    pub fn invalid<E: Coded + fmt::Display>(
        code: Code,
        error: impl Into<String>,
        problems: &[E],
    ) -> Self {
        Self {
            code,
            params: Params::new(),
            error: error.into(),
            details: problems.iter().map(ToString::to_string).collect(),
            problems: problems.iter().map(Problem::of).collect(),
            too_large: false,
        }
    }
}

impl From<show::Refused> for Refused {
    fn from(refused: show::Refused) -> Self {
        Self {
            code: refused.code(),
            params: refused.params(),
            error: refused.to_string(),
            details: refused.details(),
            problems: refused.problems(),
            too_large: refused.too_large(),
        }
    }
}

/// Why the store cannot do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// No show of that name.
    #[error("there is no show named \"{0}\"")]
    NotFound(ShowName),
    /// A stored file that does not read as a show (changed on disk since it was
    /// stored, or written by a newer Floatball): in the parser's words.
    #[error("{}", refused.details().join("; "))]
    Unreadable {
        /// The show.
        name: ShowName,
        /// Why.
        refused: show::Refused,
    },
    /// The show cannot be written as its native file.
    #[error("the show \"{name}\" cannot be written as JSON: {source}")]
    Unwritable {
        /// The show.
        name: ShowName,
        /// Why.
        source: show::ShowError,
    },
    /// The disk said no.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
}

/// The show index's file in the data directory: every show's summary and the size
/// and modification time of the file it was made from ([`Indexed`]).
pub const INDEX_FILE: &str = "show-index.json";

/// The version of [`INDEX_FILE`]'s format; another is rebuilt.
const INDEX_VERSION: u32 = 1;

/// Summaries made while the index is rebuilt are written to [`INDEX_FILE`] every this
/// many, so a restart in the middle keeps what was done.
const INDEX_WRITE_EVERY: usize = 32;

/// What a show file looked like on disk: its size and modification time. A summary
/// is of the file while both are the same.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Stamp {
    bytes: u64,
    modified_ns: u64,
}

impl Stamp {
    fn of(metadata: &std::fs::Metadata) -> Self {
        let modified_ns = metadata
            .modified()
            .ok()
            .and_then(|modified| modified.duration_since(SystemTime::UNIX_EPOCH).ok())
            .map_or(0, |since| {
                u64::try_from(since.as_nanos()).unwrap_or(u64::MAX)
            });
        Self {
            bytes: metadata.len(),
            modified_ns,
        }
    }
}

/// One show in the index: its summary and when its file was last modified, ns since
/// 1970 (with `summary.bytes`, the file's [`Stamp`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Indexed {
    summary: ShowSummary,
    modified_ns: u64,
}

impl Indexed {
    fn stamp(&self) -> Stamp {
        Stamp {
            bytes: self.summary.bytes,
            modified_ns: self.modified_ns,
        }
    }
}

/// [`INDEX_FILE`] as written.
#[derive(Debug, serde::Serialize, serde::Deserialize)]
struct IndexFile {
    version: u32,
    shows: Vec<Indexed>,
}

/// Reads [`INDEX_FILE`]: the summaries by name; empty (all to be rebuilt) when it is
/// missing, unreadable or of another version.
fn read_index(data_dir: &Path) -> BTreeMap<ShowName, Indexed> {
    let path = data_dir.join(INDEX_FILE);
    let bytes = match std::fs::read(&path) {
        Ok(bytes) => bytes,
        Err(error) if error.kind() == io::ErrorKind::NotFound => return BTreeMap::new(),
        Err(error) => {
            tracing::warn!("{}: {error}; the show index is rebuilt", path.display());
            return BTreeMap::new();
        }
    };
    match serde_json::from_slice::<IndexFile>(&bytes) {
        Ok(file) if file.version == INDEX_VERSION => file
            .shows
            .into_iter()
            .filter_map(|indexed| {
                let name = ShowName::parse(&indexed.summary.name).ok()?;
                Some((name, indexed))
            })
            .collect(),
        Ok(file) => {
            tracing::warn!(
                "{}: version {} is not {INDEX_VERSION}; the show index is rebuilt",
                path.display(),
                file.version
            );
            BTreeMap::new()
        }
        Err(error) => {
            tracing::warn!("{}: {error}; the show index is rebuilt", path.display());
            BTreeMap::new()
        }
    }
}

/// What the store knows about its shows.
#[derive(Debug, Default)]
struct Known {
    /// The shows checked against the disk (or stored since the start), by name.
    index: BTreeMap<ShowName, Indexed>,
    /// The index file as read at the start, until the shows on disk are checked
    /// against it ([`Library::scan`]); kept in the file meanwhile.
    loaded: Option<BTreeMap<ShowName, Indexed>>,
    /// Show files whose summary is missing or stale, with the stamp they had when
    /// found: summarised in the background ([`Library::summarise_pending`]).
    pending: BTreeMap<ShowName, Stamp>,
}

/// The shows on disk and a summary of each; shared with the indexing thread.
#[derive(Debug)]
struct Library {
    data_dir: PathBuf,
    dir: PathBuf,
    known: Mutex<Known>,
    /// The index file's writer.
    index_writer: IndexWriter,
    /// `true` once every show on disk is in the index.
    indexed: tokio::sync::watch::Sender<bool>,
    /// Whether the indexing thread was started ([`ShowStore::start_indexing`]).
    started: AtomicBool,
}

/// The shows on disk and a summary of each.
#[derive(Debug)]
pub struct ShowStore {
    library: Arc<Library>,
}

impl ShowStore {
    /// Opens `<data_dir>/shows/`, creating it if needed, and removes what interrupted
    /// writes left there and in the data directory itself (the temporary files of the
    /// playlist, password, sessions, configuration and show index). No show is read
    /// here: the summaries come from the show index ([`INDEX_FILE`]), checked against
    /// the files on disk by a thread of its own, which also summarises every show the
    /// index lacks or has stale (and writes the index again). Until that is done,
    /// [`indexed`](Self::indexed) is `false` and [`list`](Self::list) may lack shows.
    ///
    /// # Errors
    /// If a directory cannot be created, read or cleaned.
    pub fn open(data_dir: &Path) -> Result<Self, StoreError> {
        let store = Self::open_deferred(data_dir)?;
        store.start_indexing();
        Ok(store)
    }

    /// Starts the indexing thread (once; later calls do nothing). The bridge calls it
    /// once it listens ([`crate::server::run`]), so no show is read before the API,
    /// the WebSocket and the e-stop are up.
    pub fn start_indexing(&self) {
        if self.library.started.swap(true, Ordering::SeqCst) {
            return;
        }
        let indexing = Arc::clone(&self.library);
        let spawned = std::thread::Builder::new()
            .name("show-index".into())
            .spawn(move || indexing.index());
        if let Err(error) = spawned {
            // No thread to spare: index here (the caller waits for it).
            tracing::warn!("cannot start the show index's thread ({error}); indexing now");
            self.library.index();
        }
    }

    /// As [`open`](Self::open), without indexing: nothing is listed until
    /// [`start_indexing`](Self::start_indexing) has run.
    ///
    /// # Errors
    /// As [`open`](Self::open).
    pub fn open_deferred(data_dir: &Path) -> Result<Self, StoreError> {
        let removed = durable::remove_temporaries(data_dir).map_err(|source| StoreError::Io {
            path: data_dir.to_owned(),
            source,
        })?;
        if removed > 0 {
            tracing::warn!(
                "removed {removed} unfinished file(s) from {}",
                data_dir.display()
            );
        }
        let dir = data_dir.join(DIR_NAME);
        let io_error = |source| StoreError::Io {
            path: dir.clone(),
            source,
        };
        std::fs::create_dir_all(&dir).map_err(io_error)?;
        let removed = durable::remove_temporaries(&dir).map_err(io_error)?;
        if removed > 0 {
            tracing::warn!(
                "removed {removed} unfinished show file(s) from {}",
                dir.display()
            );
        }
        let (requests, waiting) = channel();
        let library = Arc::new(Library {
            data_dir: data_dir.to_owned(),
            dir,
            known: Mutex::new(Known {
                index: BTreeMap::new(),
                loaded: Some(read_index(data_dir)),
                pending: BTreeMap::new(),
            }),
            index_writer: IndexWriter { requests },
            indexed: tokio::sync::watch::Sender::new(false),
            started: AtomicBool::new(false),
        });
        let writer = Arc::downgrade(&library);
        std::thread::Builder::new()
            .name("show-index-writer".into())
            .spawn(move || IndexWriter::run(&writer, &waiting))
            .map_err(|source| StoreError::Io {
                path: data_dir.join(INDEX_FILE),
                source,
            })?;
        Ok(Self { library })
    }

    /// Whether every show on disk is in the index (and so in [`list`](Self::list)).
    pub fn indexed(&self) -> bool {
        *self.library.indexed.borrow()
    }

    /// Waits until every show is in the index, at most `limit`; returns whether it is.
    pub async fn wait_indexed(&self, limit: std::time::Duration) -> bool {
        let mut indexed = self.library.indexed.subscribe();
        tokio::time::timeout(limit, indexed.wait_for(|indexed| *indexed))
            .await
            .is_ok_and(|done| done.is_ok())
    }

    /// Every show in the index, by name: every stored show once
    /// [`indexed`](Self::indexed).
    pub fn list(&self) -> Vec<ShowSummary> {
        self.library
            .known()
            .index
            .values()
            .map(|indexed| indexed.summary.clone())
            .collect()
    }

    /// Whether a show of that name is stored (asking the disk while the index is not
    /// complete).
    pub fn contains(&self, name: &str) -> bool {
        let Ok(name) = ShowName::parse(name) else {
            return false;
        };
        if self.library.known().index.contains_key(&name) {
            return true;
        }
        !self.indexed() && self.library.dir.join(name.file_name()).is_file()
    }

    /// The stored native file of a show, byte for byte (what a download serves).
    ///
    /// # Errors
    /// [`StoreError::NotFound`], or an I/O error.
    pub fn file(&self, name: &ShowName) -> Result<Vec<u8>, StoreError> {
        let path = self.library.dir.join(name.file_name());
        std::fs::read(&path).map_err(|source| match source.kind() {
            io::ErrorKind::NotFound => StoreError::NotFound(name.clone()),
            _ => StoreError::Io { path, source },
        })
    }

    /// A stored show.
    ///
    /// # Errors
    /// [`StoreError::NotFound`], [`StoreError::Unreadable`], or an I/O error.
    ///
    /// The file is read as a stream, not held whole beside the show (a 10,000-ball
    /// minute is about 90 MB of JSON); one that does not read is read again whole for
    /// the same words as an upload's refusal.
    pub fn load(&self, name: &ShowName) -> Result<Show, StoreError> {
        let path = self.library.dir.join(name.file_name());
        let file = std::fs::File::open(&path).map_err(|source| match source.kind() {
            io::ErrorKind::NotFound => StoreError::NotFound(name.clone()),
            _ => StoreError::Io {
                path: path.clone(),
                source,
            },
        })?;
        match Show::from_json_reader(io::BufReader::with_capacity(READ_BUFFER_BYTES, file)) {
            Ok(mut show) => {
                name.as_str().clone_into(&mut show.name);
                Ok(show)
            }
            Err(_) => decode(name, &self.file(name)?),
        }
    }

    /// Stores a show (already [imported](fn@show::import) with this installation's
    /// limits) under `name`, replacing one of the same name, and writes the show index
    /// after it. Returns its summary and whether it is new.
    ///
    /// # Errors
    /// [`StoreError::Unwritable`], or an I/O error; the store is then as before.
    ///
    /// The file is written as it is serialised (hashed on the way), never held whole in
    /// memory: a 10,000-ball minute is about 90 MB of JSON.
    pub fn put(&self, name: &ShowName, show: &Show) -> Result<(ShowSummary, bool), StoreError> {
        let library = &self.library;
        let file_name = name.file_name();
        let path = library.dir.join(&file_name);
        let existed = path.is_file();
        let mut unwritable = None;
        let mut written = None;
        durable::write_atomic_with(&library.dir, &file_name, |file| {
            let mut writer = io::BufWriter::with_capacity(READ_BUFFER_BYTES, Digesting::new(file));
            if let Err(source) = show.write_json(&mut writer) {
                // An I/O error comes back from the writer in serde's words; anything
                // else is the show's own.
                let io_failed = writer.get_mut().failed.take();
                unwritable = io_failed.is_none().then_some(source);
                return Err(io_failed.unwrap_or_else(|| io::Error::other("unwritable show")));
            }
            let digesting = writer
                .into_inner()
                .map_err(io::IntoInnerError::into_error)?;
            written = Some((digesting.bytes, digesting.sha256()));
            Ok(())
        })
        .map_err(|source| match unwritable.take() {
            Some(source) => StoreError::Unwritable {
                name: name.clone(),
                source,
            },
            None => StoreError::Io {
                path: path.clone(),
                source,
            },
        })?;
        let (bytes, sha256) = written.unwrap_or_default();
        let metadata = std::fs::metadata(&path).ok();
        let modified = metadata
            .as_ref()
            .and_then(|metadata| metadata.modified().ok())
            .unwrap_or_else(SystemTime::now);
        let summary = summary(name, bytes, &sha256, show, modified);
        let indexed = Indexed {
            summary: summary.clone(),
            modified_ns: metadata.map_or(0, |metadata| Stamp::of(&metadata).modified_ns),
        };
        {
            let mut known = library.known();
            known.pending.remove(name);
            known.index.insert(name.clone(), indexed);
        }
        library.index_writer.write_and_wait();
        Ok((summary, !existed))
    }

    /// Removes a show (and its summary from the show index).
    ///
    /// # Errors
    /// [`StoreError::NotFound`], or an I/O error.
    pub fn delete(&self, name: &ShowName) -> Result<(), StoreError> {
        let library = &self.library;
        let file_name = name.file_name();
        durable::remove(&library.dir, &file_name).map_err(|source| match source.kind() {
            io::ErrorKind::NotFound => StoreError::NotFound(name.clone()),
            _ => StoreError::Io {
                path: library.dir.join(&file_name),
                source,
            },
        })?;
        {
            let mut known = library.known();
            known.pending.remove(name);
            known.index.remove(name);
            if let Some(loaded) = known.loaded.as_mut() {
                loaded.remove(name);
            }
        }
        library.index_writer.write_and_wait();
        Ok(())
    }
}

impl Library {
    fn known(&self) -> std::sync::MutexGuard<'_, Known> {
        self.known.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// The indexing thread: [`scan`](Self::scan), then
    /// [`summarise_pending`](Self::summarise_pending); says when it is done.
    fn index(&self) {
        let started = std::time::Instant::now();
        let (stale, changed) = self.scan();
        if stale > 0 {
            tracing::info!("summarising {stale} show(s) missing from the show index");
        }
        let summarised = self.summarise_pending();
        if changed || summarised > 0 {
            self.index_writer.write_and_wait();
        }
        self.indexed.send_replace(true);
        if stale > 0 {
            tracing::info!(
                "the show index is complete: {summarised} show(s) summarised in {:.1} s",
                started.elapsed().as_secs_f64()
            );
        }
    }

    /// Checks the show files on disk against the index read at the start (by size and
    /// modification time, no show is read): the shows whose summary is current go in
    /// the index, the others are marked pending. Returns how many are pending and
    /// whether the index file needs writing (a show or a summary to drop or add).
    ///
    /// A show deleted between the listing and the check is found pending and dropped
    /// when its summary cannot be read; one stored meanwhile is in the index already.
    fn scan(&self) -> (usize, bool) {
        let mut on_disk = Vec::new();
        match std::fs::read_dir(&self.dir) {
            Ok(entries) => {
                for entry in entries.filter_map(Result::ok) {
                    let file_name = entry.file_name();
                    let Some(name) = file_name.to_str().and_then(ShowName::from_file_name) else {
                        if !file_name.to_str().is_some_and(durable::is_temporary) {
                            tracing::warn!(
                                "ignoring {}: not a show file name",
                                entry.path().display()
                            );
                        }
                        continue;
                    };
                    match entry.metadata() {
                        Ok(metadata) if metadata.is_file() => {
                            on_disk.push((name, Stamp::of(&metadata)));
                        }
                        Ok(_) => {
                            tracing::warn!("ignoring {}: not a file", entry.path().display());
                        }
                        Err(error) => {
                            tracing::warn!("ignoring {}: {error}", entry.path().display());
                        }
                    }
                }
            }
            Err(error) => {
                tracing::error!("cannot list {}: {error}", self.dir.display());
            }
        }
        let mut known = self.known();
        let mut loaded = known.loaded.take().unwrap_or_default();
        let loaded_count = loaded.len();
        let mut kept = 0;
        for (name, stamp) in on_disk {
            if known.index.contains_key(&name) {
                // Stored since the start.
                continue;
            }
            match loaded.remove(&name) {
                Some(indexed) if indexed.stamp() == stamp => {
                    known.index.insert(name, indexed);
                    kept += 1;
                }
                _ => {
                    known.pending.insert(name, stamp);
                }
            }
        }
        (
            known.pending.len(),
            kept != loaded_count || !known.pending.is_empty(),
        )
    }

    /// Summarises every pending show, one at a time, reading each whole without
    /// holding any lock; a show stored or deleted meanwhile is left as that made it.
    /// Returns how many were summarised.
    fn summarise_pending(&self) -> usize {
        let mut summarised = 0;
        loop {
            let Some((name, stamp)) = self
                .known()
                .pending
                .iter()
                .next()
                .map(|(name, stamp)| (name.clone(), *stamp))
            else {
                return summarised;
            };
            let path = self.dir.join(name.file_name());
            let result = summarise_file(&path, &name);
            let mut known = self.known();
            if known.pending.get(&name) != Some(&stamp) {
                // Stored or deleted meanwhile: the store's own summary stands.
                continue;
            }
            known.pending.remove(&name);
            match result {
                Ok(summary) => {
                    known.index.insert(
                        name,
                        Indexed {
                            summary,
                            modified_ns: stamp.modified_ns,
                        },
                    );
                    summarised += 1;
                    if summarised % INDEX_WRITE_EVERY == 0 {
                        drop(known);
                        self.index_writer.write();
                    }
                }
                Err(reason) => {
                    tracing::warn!("ignoring {}: {reason}", path.display());
                }
            }
        }
    }

    /// What [`INDEX_FILE`] holds now: what is known (and, until the scan, what was
    /// read).
    fn index_file(&self) -> IndexFile {
        {
            let known = self.known();
            let mut shows: Vec<Indexed> = known.index.values().cloned().collect();
            if let Some(loaded) = &known.loaded {
                shows.extend(
                    loaded
                        .iter()
                        .filter(|(name, _)| !known.index.contains_key(*name))
                        .map(|(_, indexed)| indexed.clone()),
                );
            }
            IndexFile {
                version: INDEX_VERSION,
                shows,
            }
        }
    }
}

/// A request to the index writer: write, and say so on the sender if one is given.
type IndexRequest = Option<SyncSender<()>>;

/// The one writer of [`INDEX_FILE`]: a thread that, asked, takes every request
/// waiting, writes what the store knows then, and answers them all (see the
/// [module documentation](self)). It ends with the store.
#[derive(Debug)]
struct IndexWriter {
    requests: Sender<IndexRequest>,
}

impl IndexWriter {
    /// Asks for a write of the index and waits until one that began after the
    /// request is written (or failed, which is logged).
    fn write_and_wait(&self) {
        let (done, written) = sync_channel(1);
        if self.requests.send(Some(done)).is_ok() {
            let _ = written.recv();
        }
    }

    /// Asks for a write of the index without waiting.
    fn write(&self) {
        let _ = self.requests.send(None);
    }

    /// The thread: each request (with those waiting behind it) is one write of what
    /// `library` knows then; ends when the store is gone.
    fn run(library: &Weak<Library>, requests: &Receiver<IndexRequest>) {
        while let Ok(first) = requests.recv() {
            let mut waiting: Vec<SyncSender<()>> = first.into_iter().collect();
            waiting.extend(requests.try_iter().flatten());
            let Some(library) = library.upgrade() else {
                return;
            };
            let file = library.index_file();
            let written = serde_json::to_vec(&file)
                .map_err(io::Error::other)
                .and_then(|bytes| durable::write_atomic(&library.data_dir, INDEX_FILE, &bytes));
            if let Err(error) = written {
                tracing::warn!(
                    "cannot write {}: {error}; it is rebuilt at the next start",
                    library.data_dir.join(INDEX_FILE).display()
                );
            }
            drop(library);
            for done in waiting {
                let _ = done.send(());
            }
        }
    }
}

/// A stored file as the show `name`.
fn decode(name: &ShowName, bytes: &[u8]) -> Result<Show, StoreError> {
    show::import(name.as_str(), bytes, ShowFormat::Json, None, None).map_err(|refused| {
        StoreError::Unreadable {
            name: name.clone(),
            refused,
        }
    })
}

/// The summary of a stored file, read as a stream (hashed on the way).
fn summarise_file(path: &Path, name: &ShowName) -> Result<ShowSummary, String> {
    let modified = std::fs::metadata(path)
        .and_then(|metadata| metadata.modified())
        .map_err(|error| error.to_string())?;
    let file = std::fs::File::open(path).map_err(|error| error.to_string())?;
    let mut reader = io::BufReader::with_capacity(READ_BUFFER_BYTES, Digesting::new(file));
    let show = match Show::from_json_reader(&mut reader) {
        Ok(show) => {
            // Whatever follows the show (white space) is part of the file's hash.
            io::copy(&mut reader, &mut io::sink()).map_err(|error| error.to_string())?;
            show
        }
        Err(_) => {
            let bytes = std::fs::read(path).map_err(|error| error.to_string())?;
            decode(name, &bytes).map_err(|error| error.to_string())?
        }
    };
    let digesting = reader.get_ref();
    Ok(summary(
        name,
        digesting.bytes,
        &digesting.sha256(),
        &show,
        modified,
    ))
}

/// The bytes and SHA-256 of what passes through a reader or writer.
struct Digesting<T> {
    inner: T,
    hasher: Sha256,
    bytes: u64,
    /// The I/O error the inner writer gave (serde reports it in its own words).
    failed: Option<io::Error>,
}

impl<T> Digesting<T> {
    fn new(inner: T) -> Self {
        Self {
            inner,
            hasher: Sha256::new(),
            bytes: 0,
            failed: None,
        }
    }

    fn sha256(&self) -> String {
        durable::hex(&self.hasher.clone().finalize())
    }

    fn count(&mut self, bytes: &[u8]) {
        self.hasher.update(bytes);
        self.bytes += bytes.len() as u64;
    }
}

impl<T: io::Write> io::Write for Digesting<T> {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        match self.inner.write(bytes) {
            Ok(written) => {
                self.count(&bytes[..written]);
                Ok(written)
            }
            Err(error) => {
                let kind = error.kind();
                self.failed = Some(error);
                Err(io::Error::from(kind))
            }
        }
    }

    fn flush(&mut self) -> io::Result<()> {
        self.inner.flush()
    }
}

impl<T: io::Read> io::Read for Digesting<T> {
    fn read(&mut self, buffer: &mut [u8]) -> io::Result<usize> {
        let read = self.inner.read(buffer)?;
        self.count(&buffer[..read]);
        Ok(read)
    }
}

fn summary(
    name: &ShowName,
    bytes: u64,
    sha256: &str,
    show: &Show,
    modified: SystemTime,
) -> ShowSummary {
    ShowSummary {
        name: name.as_str().to_owned(),
        bytes,
        sha256: sha256.to_owned(),
        modified: humantime::format_rfc3339_seconds(modified).to_string(),
        units: u32::try_from(show.tracks.len()).unwrap_or(u32::MAX),
        duration_ms: show.duration_ms(),
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use floatball_shared::show::{Layout, Track, TrackRow};

    use super::*;

    /// A show of `rows` × `cols` balls, each 40 mm down and back in 500 ms.
    pub(crate) fn show(rows: u32, cols: u32) -> Show {
        Show {
            outputs: Vec::new(),
            name: "whatever".into(),
            layout: Layout {
                rows,
                cols,
                pitch_mm: 500.0,
            },
            tracks: (0..rows * cols)
                .map(|_| Track {
                    start_mm: 0.0,
                    rows: vec![TrackRow::new(40.0, 0.0, 250), TrackRow::new(0.0, 0.0, 250)],
                    colours: Vec::new(),
                })
                .collect(),
        }
    }

    /// Opens the store in `dir` and waits until its index is complete.
    pub(crate) fn open_indexed(dir: &Path) -> ShowStore {
        let store = ShowStore::open(dir).expect("open");
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while !store.indexed() {
            assert!(std::time::Instant::now() < deadline, "indexed within 10 s");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        store
    }

    #[test]
    fn names_in_any_script_are_allowed() {
        for name in ["波浪", "Welle 1", "موجة", "a.b", "x-y_z (2)"] {
            let parsed = ShowName::parse(name).expect(name);
            assert_eq!(ShowName::from_file_name(&parsed.file_name()), Some(parsed));
        }
        let longest = "波".repeat(33); // 99 bytes
        assert!(ShowName::parse(&longest).is_ok());
    }

    #[test]
    fn bad_names_are_refused() {
        for name in [
            "", "a/b", "a\\b", "a\nb", "a\u{7f}", ".hidden", "a..b", "..",
        ] {
            assert!(ShowName::parse(name).is_err(), "{name:?}");
        }
        assert_eq!(
            ShowName::parse(&"波".repeat(34)),
            Err(NameError::TooLong { bytes: 102 })
        );
        assert_eq!(ShowName::from_file_name("2e2e.json"), None);
        assert_eq!(ShowName::from_file_name("zz.json"), None);
        assert_eq!(ShowName::from_file_name("616.json"), None);
    }

    #[test]
    fn new_names_with_invisible_or_direction_characters_are_refused() {
        for code in [
            0x202A, 0x202B, 0x202C, 0x202D, 0x202E, 0x2066, 0x2067, 0x2068, 0x2069, 0x200E, 0x200F,
            0x061C, 0x200B, 0x200C, 0x200D, 0x2060, 0xFEFF,
        ] {
            let c = char::from_u32(code).expect("char");
            let name = format!("show{c}gpj.exe");
            let refused = ShowName::parse_new(&name).expect_err(&format!("U+{code:04X}"));
            assert!(
                matches!(refused, NameError::Misleading { code: found, .. } if found == code),
                "{refused:?}"
            );
            assert!(
                refused.to_string().contains(&format!("U+{code:04X}")),
                "{refused}"
            );
            // Stored before the rule: still a name the store can list and delete.
            assert!(ShowName::parse(&name).is_ok());
        }
        for name in ["波浪", "موجة", "Welle 1", "שלום"] {
            assert!(ShowName::parse_new(name).is_ok(), "{name}");
        }
    }

    #[test]
    fn a_file_that_does_not_read_is_refused_as_an_upload_of_it_would_be() {
        let dir = tempfile::tempdir().expect("temp dir");
        let store = open_indexed(dir.path());
        let name = ShowName::parse("odd").expect("name");
        for bytes in [
            &br#"{"format":"blender-scene","version":3}"#[..],
            br#"{"format":"floatball-show","version":9}"#,
            b"\xff\xfe not text",
            b"{\"format\": \"floatball-show\", \"version\": 1, \"name\": ",
        ] {
            std::fs::write(dir.path().join(DIR_NAME).join(name.file_name()), bytes).expect("write");
            let expected =
                show::import("odd", bytes, ShowFormat::Json, None, None).expect_err("not a show");
            match store.load(&name) {
                Err(StoreError::Unreadable { refused, .. }) => assert_eq!(refused, expected),
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn shows_are_stored_listed_read_and_deleted() {
        let dir = tempfile::tempdir().expect("temp dir");
        let store = open_indexed(dir.path());
        let name = ShowName::parse("波浪").expect("name");
        let mut stored = show(1, 2);
        stored.name = name.to_string();
        let (summary, created) = store.put(&name, &stored).expect("put");
        assert!(created);
        assert_eq!(summary.name, "波浪");
        assert_eq!(summary.units, 2);
        assert_eq!(summary.duration_ms, 500);
        assert_eq!(summary.sha256.len(), 64);
        assert!(summary.modified.ends_with('Z'), "{}", summary.modified);
        let bytes = store.file(&name).expect("file");
        assert_eq!(bytes, stored.to_json().expect("json").as_bytes());
        assert_eq!(summary.bytes, bytes.len() as u64);
        assert_eq!(summary.sha256, durable::hex(&Sha256::digest(&bytes)));
        assert_eq!(store.load(&name).expect("load"), stored);
        assert!(!store.put(&name, &stored).expect("replace").1);

        let reopened = open_indexed(dir.path());
        assert_eq!(reopened.list(), store.list());
        assert!(reopened.contains("波浪"));

        reopened.delete(&name).expect("delete");
        assert!(matches!(
            reopened.delete(&name),
            Err(StoreError::NotFound(_))
        ));
        assert!(matches!(reopened.file(&name), Err(StoreError::NotFound(_))));
        assert!(matches!(reopened.load(&name), Err(StoreError::NotFound(_))));
        assert!(reopened.list().is_empty());
    }

    #[test]
    fn unfinished_and_foreign_files_are_not_listed() {
        let dir = tempfile::tempdir().expect("temp dir");
        let shows = dir.path().join(DIR_NAME);
        std::fs::create_dir_all(&shows).expect("mkdir");
        std::fs::write(shows.join(".61.json.0a0b.tmp"), b"{\"half").expect("write");
        std::fs::write(shows.join("readme.txt"), b"hello").expect("write");
        std::fs::write(shows.join("61.json"), b"{\"broken").expect("write");
        let store = open_indexed(dir.path());
        assert!(store.list().is_empty());
        assert!(!shows.join(".61.json.0a0b.tmp").exists());
        // Broken on disk: loading it says so, in the parser's words.
        let name = ShowName::parse("a").expect("name");
        let error = store.load(&name).expect_err("broken");
        assert!(
            matches!(
                &error,
                StoreError::Unreadable {
                    refused: show::Refused::Unreadable(_),
                    ..
                }
            ),
            "{error:?}"
        );
        assert!(
            error.to_string().starts_with("the show file is not valid"),
            "{error}"
        );
    }

    /// Stores `names` (a 1 × 2 show each, a different depth each) in a new store in
    /// `dir`; returns the list.
    fn stored(dir: &Path, names: &[&str]) -> Vec<ShowSummary> {
        let store = open_indexed(dir);
        for (index, name) in names.iter().enumerate() {
            let name = ShowName::parse(name).expect("name");
            let mut one = show(1, 2);
            one.tracks[0].rows[0] = TrackRow::new(10.0 + index as f64, 0.0, 250);
            store.put(&name, &one).expect("put");
        }
        store.list()
    }

    fn index_path(dir: &Path) -> PathBuf {
        dir.join(INDEX_FILE)
    }

    /// The summaries [`INDEX_FILE`] holds (of this version), by name.
    fn index_summaries(dir: &Path) -> Vec<ShowSummary> {
        let file: IndexFile =
            serde_json::from_slice(&std::fs::read(index_path(dir)).expect("index"))
                .expect("an index");
        assert_eq!(file.version, INDEX_VERSION);
        let mut summaries: Vec<ShowSummary> = file
            .shows
            .into_iter()
            .map(|indexed| indexed.summary)
            .collect();
        summaries.sort_by(|a, b| a.name.cmp(&b.name));
        summaries
    }

    #[test]
    fn the_index_is_written_with_each_show_and_a_start_reads_no_show() {
        let dir = tempfile::tempdir().expect("temp dir");
        let list = stored(dir.path(), &["波浪", "rain"]);
        assert_eq!(index_summaries(dir.path()), list);

        // Garbage of the same size and time in a show file: the start takes the
        // summary from the index without reading the show.
        let name = ShowName::parse("rain").expect("name");
        let path = dir.path().join(DIR_NAME).join(name.file_name());
        let modified = std::fs::metadata(&path)
            .and_then(|meta| meta.modified())
            .expect("time");
        let garbage = vec![b'x'; usize::try_from(list[0].bytes).expect("size")];
        std::fs::write(&path, garbage).expect("write");
        std::fs::File::options()
            .write(true)
            .open(&path)
            .and_then(|file| file.set_modified(modified))
            .expect("set the time back");
        assert_eq!(open_indexed(dir.path()).list(), list);
    }

    /// Shows stored and deleted from many threads at once: each call returns with
    /// the index written after its own change, and the index in the end is exactly
    /// the shows on disk (writes of the index never overtake one another).
    #[test]
    fn the_index_follows_stores_and_deletes_from_many_threads() {
        let dir = tempfile::tempdir().expect("temp dir");
        let store = Arc::new(open_indexed(dir.path()));
        let workers: Vec<_> = (0..4)
            .map(|worker| {
                let store = Arc::clone(&store);
                std::thread::spawn(move || {
                    for round in 0..12 {
                        let name = ShowName::parse(&format!("w{worker}-{round}")).expect("name");
                        let mut one = show(1, 2);
                        one.tracks[0].rows[0] = TrackRow::new(10.0 + round as f64, 0.0, 250);
                        store.put(&name, &one).expect("put");
                        let file: IndexFile = serde_json::from_slice(
                            &std::fs::read(index_path(store.library.data_dir.as_path()))
                                .expect("index"),
                        )
                        .expect("an index");
                        assert!(
                            file.shows
                                .iter()
                                .any(|indexed| indexed.summary.name == name.as_str()),
                            "{name} is in the index once put returns"
                        );
                        if round % 3 == 0 {
                            store.delete(&name).expect("delete");
                        }
                    }
                })
            })
            .collect();
        for worker in workers {
            worker.join().expect("a worker");
        }
        let list = store.list();
        assert_eq!(list.len(), 4 * 8);
        assert_eq!(
            index_summaries(dir.path()),
            list,
            "the index is the last word"
        );
        drop(store);
        assert_eq!(open_indexed(dir.path()).list(), list);
    }

    #[test]
    fn a_missing_or_corrupt_index_is_rebuilt_from_the_shows() {
        let dir = tempfile::tempdir().expect("temp dir");
        let list = stored(dir.path(), &["波浪", "rain", "snow"]);
        for index in [
            None,
            Some(&b"{\"version\":1,\"shows\":[{\"summ"[..]),
            Some(b"\xff\x00"),
            Some(b"{\"version\":99,\"shows\":[]}"),
        ] {
            match index {
                None => std::fs::remove_file(index_path(dir.path())).expect("remove"),
                Some(bytes) => std::fs::write(index_path(dir.path()), bytes).expect("write"),
            }
            let store = open_indexed(dir.path());
            assert_eq!(store.list(), list, "{index:?}");
            let file: IndexFile =
                serde_json::from_slice(&std::fs::read(index_path(dir.path())).expect("index"))
                    .expect("written again whole");
            assert_eq!(file.shows.len(), 3);
        }
    }

    #[test]
    fn stale_and_unknown_entries_are_summarised_again_or_dropped() {
        let dir = tempfile::tempdir().expect("temp dir");
        let list = stored(dir.path(), &["a", "b", "c"]);
        let shows = dir.path().join(DIR_NAME);
        let file_of = |name: &str| shows.join(ShowName::parse(name).expect("name").file_name());
        // "a" changed behind the store's back, "b" deleted, "d" copied in by hand.
        let changed = show(1, 3).to_json().expect("json");
        std::fs::write(file_of("a"), &changed).expect("write a");
        std::fs::remove_file(file_of("b")).expect("remove b");
        std::fs::copy(file_of("c"), file_of("d")).expect("copy d");
        let store = open_indexed(dir.path());
        let now = store.list();
        let names: Vec<&str> = now.iter().map(|summary| summary.name.as_str()).collect();
        assert_eq!(names, ["a", "c", "d"]);
        assert_eq!(now[0].units, 3);
        assert_eq!(
            now[0].sha256,
            durable::hex(&Sha256::digest(changed.as_bytes()))
        );
        assert_eq!(now[1], list[2]);
        assert_eq!(now[2].sha256, list[2].sha256);
        // The index now says so too.
        drop(store);
        let file: IndexFile =
            serde_json::from_slice(&std::fs::read(index_path(dir.path())).expect("index"))
                .expect("index");
        assert_eq!(file.shows.len(), 3);
        assert_eq!(open_indexed(dir.path()).list(), now);
    }

    #[test]
    fn shows_stored_or_deleted_while_indexing_are_as_the_store_left_them() {
        let dir = tempfile::tempdir().expect("temp dir");
        stored(dir.path(), &["old", "gone", "replaced"]);
        std::fs::remove_file(index_path(dir.path())).expect("no index");
        let store = ShowStore::open_deferred(dir.path()).expect("open");
        assert!(!store.indexed());
        assert!(store.list().is_empty(), "nothing is listed before the scan");
        // Still, the playlist may name a stored show.
        assert!(store.contains("old"));
        assert!(!store.contains("nothing"));

        let name = |text: &str| ShowName::parse(text).expect("name");
        // Stored before the scan.
        let (new, created) = store.put(&name("new"), &show(1, 1)).expect("put");
        assert!(created);
        store.library.scan();
        assert_eq!(
            store.library.known().pending.len(),
            3,
            "old, gone, replaced"
        );
        // Stored and deleted after the scan, before they are summarised.
        let (replaced, created) = store.put(&name("replaced"), &show(2, 2)).expect("put");
        assert!(!created, "it was on disk");
        store.delete(&name("gone")).expect("delete");
        assert_eq!(store.library.summarise_pending(), 1, "only old");
        store.library.index();
        assert!(store.indexed());
        let list = store.list();
        let names: Vec<&str> = list.iter().map(|summary| summary.name.as_str()).collect();
        assert_eq!(names, ["new", "old", "replaced"]);
        assert_eq!(list[0], new);
        assert_eq!(list[2], replaced);
        assert_eq!(open_indexed(dir.path()).list(), list);
    }

    #[test]
    fn an_interrupted_index_write_leaves_the_old_index() {
        let dir = tempfile::tempdir().expect("temp dir");
        let list = stored(dir.path(), &["a", "b"]);
        // What a kill during the index's write leaves: its temporary file.
        std::fs::write(
            dir.path().join(format!(".{INDEX_FILE}.00ff.tmp")),
            b"{\"ver",
        )
        .expect("write");
        let store = open_indexed(dir.path());
        assert_eq!(store.list(), list);
        assert!(!dir.path().join(format!(".{INDEX_FILE}.00ff.tmp")).exists());
    }
}
