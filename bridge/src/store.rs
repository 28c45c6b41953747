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
//! SHA-256, time, units, duration) is kept in memory, built at start from the complete
//! files, so listing does not reread them.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
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

/// The shows on disk and a summary of each.
#[derive(Debug)]
pub struct ShowStore {
    dir: PathBuf,
    index: Mutex<BTreeMap<ShowName, ShowSummary>>,
    /// Held while a file is written or removed, so the index follows the disk.
    writing: Mutex<()>,
}

impl ShowStore {
    /// Opens `<data_dir>/shows/`, creating it if needed, removing what interrupted
    /// writes left there and in the data directory itself (the temporary files of the
    /// playlist, password, sessions and configuration), and summarising every complete
    /// show.
    ///
    /// # Errors
    /// If a directory cannot be created, read or cleaned.
    pub fn open(data_dir: &Path) -> Result<Self, StoreError> {
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
        let mut index = BTreeMap::new();
        for entry in std::fs::read_dir(&dir).map_err(io_error)? {
            let entry = entry.map_err(io_error)?;
            let file_name = entry.file_name();
            let Some(name) = file_name.to_str().and_then(ShowName::from_file_name) else {
                tracing::warn!("ignoring {}: not a show file name", entry.path().display());
                continue;
            };
            match summarise_file(&entry.path(), &name) {
                Ok(summary) => {
                    index.insert(name, summary);
                }
                Err(reason) => {
                    tracing::warn!("ignoring {}: {reason}", entry.path().display());
                }
            }
        }
        Ok(Self {
            dir,
            index: Mutex::new(index),
            writing: Mutex::new(()),
        })
    }

    /// Every show, by name.
    pub fn list(&self) -> Vec<ShowSummary> {
        self.index().values().cloned().collect()
    }

    /// Whether a show of that name is stored.
    pub fn contains(&self, name: &str) -> bool {
        ShowName::parse(name).is_ok_and(|name| self.index().contains_key(&name))
    }

    /// The stored native file of a show, byte for byte (what a download serves).
    ///
    /// # Errors
    /// [`StoreError::NotFound`], or an I/O error.
    pub fn file(&self, name: &ShowName) -> Result<Vec<u8>, StoreError> {
        let path = self.dir.join(name.file_name());
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
        let path = self.dir.join(name.file_name());
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
    /// limits) under `name`, replacing one of the same name. Returns its summary and
    /// whether it is new.
    ///
    /// # Errors
    /// [`StoreError::Unwritable`], or an I/O error; the store is then as before.
    ///
    /// The file is written as it is serialised (hashed on the way), never held whole in
    /// memory: a 10,000-ball minute is about 90 MB of JSON.
    pub fn put(&self, name: &ShowName, show: &Show) -> Result<(ShowSummary, bool), StoreError> {
        let _writing = self.writing.lock().unwrap_or_else(PoisonError::into_inner);
        let file_name = name.file_name();
        let mut unwritable = None;
        let mut written = None;
        durable::write_atomic_with(&self.dir, &file_name, |file| {
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
                path: self.dir.join(&file_name),
                source,
            },
        })?;
        let modified = std::fs::metadata(self.dir.join(&file_name))
            .and_then(|metadata| metadata.modified())
            .unwrap_or_else(|_| SystemTime::now());
        let (bytes, sha256) = written.unwrap_or_default();
        let summary = summary(name, bytes, &sha256, show, modified);
        let created = self.index().insert(name.clone(), summary.clone()).is_none();
        Ok((summary, created))
    }

    /// Removes a show.
    ///
    /// # Errors
    /// [`StoreError::NotFound`], or an I/O error.
    pub fn delete(&self, name: &ShowName) -> Result<(), StoreError> {
        let _writing = self.writing.lock().unwrap_or_else(PoisonError::into_inner);
        let file_name = name.file_name();
        durable::remove(&self.dir, &file_name).map_err(|source| match source.kind() {
            io::ErrorKind::NotFound => StoreError::NotFound(name.clone()),
            _ => StoreError::Io {
                path: self.dir.join(&file_name),
                source,
            },
        })?;
        self.index().remove(name);
        Ok(())
    }

    fn index(&self) -> std::sync::MutexGuard<'_, BTreeMap<ShowName, ShowSummary>> {
        self.index.lock().unwrap_or_else(PoisonError::into_inner)
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
        let store = ShowStore::open(dir.path()).expect("open");
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
        let store = ShowStore::open(dir.path()).expect("open");
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

        let reopened = ShowStore::open(dir.path()).expect("reopen");
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
        let store = ShowStore::open(dir.path()).expect("open");
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
}
