//! The show store: `<data-dir>/shows/`, one native JSON file per show.
//!
//! Show names are for people: any script, at most [`MAX_NAME_BYTES`] bytes, without
//! `/`, `\`, control characters, a leading `.` or `..` ([`ShowName`]). A new show's
//! name also may not hold invisible or text-direction characters, which make one name
//! look like another ([`ShowName::parse_new`]). On disk each show
//! is `<hex of the name's UTF-8>.json`, so every name is a safe file name of at most
//! 205 bytes and the listing gives the names back exactly.
//!
//! An upload is decoded (native JSON, or CSV converted with the installation's layout)
//! and validated against the installation's limits *before* anything is written
//! ([`decode_upload`]): not empty, at most `[uploads] max_duration` long, and at most
//! `max_bytes` as stored — a CSV's duration and converted size are checked from its
//! keyframes before its rows are built. Then it is written atomically
//! ([`crate::durable`]). A summary of
//! every show (size, SHA-256, time, units, duration) is kept in memory, built at
//! start from the complete files, so listing does not reread them.

use std::collections::BTreeMap;
use std::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
use std::time::SystemTime;

use floatball_shared::api::ShowSummary;
use floatball_shared::show::{
    CsvProblem, ImportError, ImportLimits, Show, import_csv_within, validate,
};
use sha2::{Digest, Sha256};

use crate::config::Config;
use crate::durable;

/// The directory of the show files inside the data directory.
pub const DIR_NAME: &str = "shows";

/// Longest show name, bytes of UTF-8.
pub const MAX_NAME_BYTES: usize = 100;

/// Most problems listed for one refused upload; the rest are counted.
pub const MAX_LISTED_PROBLEMS: usize = 10_000;

const EXTENSION: &str = ".json";

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

/// An upload that is not a show this installation can run: what is wrong, and every
/// problem.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{error}")]
pub struct Refused {
    /// One sentence.
    pub error: String,
    /// Each problem.
    pub details: Vec<String>,
    /// Refused for its size (`max_bytes`, 413) rather than its content (422).
    pub too_large: bool,
}

impl Refused {
    /// Refused for its content, with `details`.
    pub fn invalid(error: impl Into<String>, details: Vec<String>) -> Self {
        Self {
            error: error.into(),
            details,
            too_large: false,
        }
    }
}

/// A decoded, valid upload: the show and its native file as it will be stored.
#[derive(Debug, Clone, PartialEq)]
pub struct Upload {
    /// The show.
    pub show: Show,
    /// Its native JSON file.
    pub json: String,
}

/// How an upload's body is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UploadFormat {
    /// The native JSON show file.
    Json,
    /// CSV keyframes.
    Csv,
}

impl UploadFormat {
    /// From the request's `Content-Type`, or by a look at the body when it is absent or
    /// neither JSON nor CSV: a body starting with `{` is JSON.
    pub fn detect(content_type: Option<&str>, body: &[u8]) -> Self {
        let essence = content_type
            .and_then(|value| value.split(';').next())
            .map(|essence| essence.trim().to_ascii_lowercase());
        match essence.as_deref() {
            Some("application/json") => Self::Json,
            Some("text/csv") => Self::Csv,
            _ => {
                let start = body.strip_prefix("\u{feff}".as_bytes()).unwrap_or(body);
                match start.iter().find(|byte| !byte.is_ascii_whitespace()) {
                    Some(b'{') => Self::Json,
                    _ => Self::Csv,
                }
            }
        }
    }
}

/// Reads an upload as a show named `name` and validates it for this installation.
///
/// # Errors
/// [`Refused`] with every problem: not UTF-8, not a show file, a CSV error, an empty
/// show, a show longer than `[uploads] max_duration`, each violation of the
/// installation's limits, or (with [`Refused::too_large`]) a stored file over
/// `max_bytes` — for a CSV known from its keyframes, before its rows are built.
pub fn decode_upload(
    name: &ShowName,
    body: &[u8],
    format: UploadFormat,
    config: &Config,
) -> Result<Upload, Refused> {
    let uploads = config.uploads;
    let max_duration = humantime::format_duration(uploads.max_duration);
    let too_long = |details: Vec<String>| {
        Refused::invalid(
            format!("the show is longer than the limit of {max_duration} ([uploads] max_duration)"),
            details,
        )
    };
    let too_large = |details: Vec<String>| Refused {
        error: format!(
            "the show as stored would be larger than the limit of {} bytes ([uploads] max_bytes)",
            uploads.max_bytes
        ),
        details,
        too_large: true,
    };
    let text = std::str::from_utf8(body).map_err(|error| {
        Refused::invalid(
            "the show file is not UTF-8 text",
            vec![format!(
                "byte {} is not part of a UTF-8 character",
                error.valid_up_to() + 1
            )],
        )
    })?;
    let mut show = match format {
        UploadFormat::Json => Show::from_json(text).map_err(|error| {
            Refused::invalid("the show file cannot be read", vec![error.to_string()])
        })?,
        UploadFormat::Csv => {
            let limits = ImportLimits {
                max_duration_ms: u64::try_from(uploads.max_duration.as_millis())
                    .unwrap_or(u64::MAX),
                max_json_bytes: uploads.max_bytes,
            };
            import_csv_within(name.as_str(), text, config.installation.layout(), limits).map_err(
                |error| match &error {
                    ImportError::TooLarge { .. } => too_large(vec![error.to_string()]),
                    ImportError::Csv(csv) if matches!(csv.problem, CsvProblem::TooLong { .. }) => {
                        too_long(vec![error.to_string()])
                    }
                    ImportError::Csv(_) => Refused::invalid(
                        "the CSV keyframes cannot be imported",
                        vec![error.to_string()],
                    ),
                },
            )?
        }
    };
    show.name = name.as_str().to_owned();
    let duration_ms = show.duration_ms();
    if duration_ms == 0 {
        return Err(Refused::invalid(
            "the show is empty: it has no motion",
            vec![match format {
                UploadFormat::Csv => {
                    "a CSV show needs at least two keyframes, the last after 0 ms".to_owned()
                }
                UploadFormat::Json => "every ball's \"rows\" is empty".to_owned(),
            }],
        ));
    }
    if u128::from(duration_ms) > uploads.max_duration.as_millis() {
        return Err(too_long(vec![format!(
            "the show lasts {}",
            humantime::format_duration(std::time::Duration::from_millis(duration_ms))
        )]));
    }
    let violations = validate(&show, &config.installation.limits);
    if !violations.is_empty() {
        let count = violations.len();
        let mut details: Vec<String> = violations
            .iter()
            .take(MAX_LISTED_PROBLEMS)
            .map(ToString::to_string)
            .collect();
        if count > MAX_LISTED_PROBLEMS {
            details.push(format!(
                "… and {} more problems",
                count - MAX_LISTED_PROBLEMS
            ));
        }
        return Err(Refused::invalid(
            format!(
                "the show does not fit this installation: {count} problem{}",
                if count == 1 { "" } else { "s" }
            ),
            details,
        ));
    }
    let json = show.to_json().map_err(|error| {
        Refused::invalid(
            "the show cannot be written as JSON",
            vec![error.to_string()],
        )
    })?;
    if json.len() > uploads.max_bytes {
        return Err(too_large(vec![format!(
            "as stored the show takes {} bytes",
            json.len()
        )]));
    }
    Ok(Upload { show, json })
}

/// Why the store cannot do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// No show of that name.
    #[error("there is no show named \"{0}\"")]
    NotFound(ShowName),
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

    /// The stored file of a show.
    ///
    /// # Errors
    /// [`StoreError::NotFound`], or an I/O error.
    pub fn read(&self, name: &ShowName) -> Result<Vec<u8>, StoreError> {
        let path = self.dir.join(name.file_name());
        std::fs::read(&path).map_err(|source| match source.kind() {
            io::ErrorKind::NotFound => StoreError::NotFound(name.clone()),
            _ => StoreError::Io { path, source },
        })
    }

    /// Stores a show (already validated, with its native file `json`) under `name`,
    /// replacing one of the same name. Returns its summary and whether it is new.
    ///
    /// # Errors
    /// An I/O error; the store is then as before.
    pub fn put(
        &self,
        name: &ShowName,
        show: &Show,
        json: &str,
    ) -> Result<(ShowSummary, bool), StoreError> {
        let _writing = self.writing.lock().unwrap_or_else(PoisonError::into_inner);
        let file_name = name.file_name();
        durable::write_atomic(&self.dir, &file_name, json.as_bytes()).map_err(|source| {
            StoreError::Io {
                path: self.dir.join(&file_name),
                source,
            }
        })?;
        let modified = std::fs::metadata(self.dir.join(&file_name))
            .and_then(|metadata| metadata.modified())
            .unwrap_or_else(|_| SystemTime::now());
        let summary = summary(name, json.as_bytes(), show, modified);
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

fn summarise_file(path: &Path, name: &ShowName) -> Result<ShowSummary, String> {
    let bytes = std::fs::read(path).map_err(|error| error.to_string())?;
    let modified = std::fs::metadata(path)
        .and_then(|metadata| metadata.modified())
        .map_err(|error| error.to_string())?;
    let text = std::str::from_utf8(&bytes).map_err(|error| error.to_string())?;
    let show = Show::from_json(text).map_err(|error| error.to_string())?;
    Ok(summary(name, &bytes, &show, modified))
}

fn summary(name: &ShowName, bytes: &[u8], show: &Show, modified: SystemTime) -> ShowSummary {
    ShowSummary {
        name: name.as_str().to_owned(),
        bytes: bytes.len() as u64,
        sha256: durable::hex(&Sha256::digest(bytes)),
        modified: humantime::format_rfc3339_seconds(modified).to_string(),
        units: u32::try_from(show.tracks.len()).unwrap_or(u32::MAX),
        duration_ms: show.duration_ms(),
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::show::{Layout, Track, TrackRow};

    use super::*;
    use crate::config::Overrides;

    fn config(rows: u32, cols: u32) -> Config {
        Config::parse(
            Path::new("floatball.toml"),
            &format!("[matrix]\nrows = {rows}\ncols = {cols}\n"),
            &Overrides::default(),
        )
        .expect("config")
    }

    fn show(rows: u32, cols: u32) -> Show {
        Show {
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
    fn the_format_follows_the_content_type_or_the_first_character() {
        assert_eq!(
            UploadFormat::detect(Some("application/json; charset=utf-8"), b"x"),
            UploadFormat::Json
        );
        assert_eq!(
            UploadFormat::detect(Some("text/csv"), b"{"),
            UploadFormat::Csv
        );
        assert_eq!(
            UploadFormat::detect(None, b"  \n{\"a\":1}"),
            UploadFormat::Json
        );
        assert_eq!(
            UploadFormat::detect(Some("application/octet-stream"), b"time_ms,u0"),
            UploadFormat::Csv
        );
    }

    #[test]
    fn uploads_are_validated_against_the_installation() {
        let name = ShowName::parse("test").expect("name");
        let json = show(1, 2).to_json().expect("json");
        let decoded =
            decode_upload(&name, json.as_bytes(), UploadFormat::Json, &config(1, 2)).expect("ok");
        assert_eq!(decoded.show.name, "test");
        assert_eq!(decoded.json, decoded.show.to_json().expect("json"));

        let refused = decode_upload(&name, json.as_bytes(), UploadFormat::Json, &config(2, 2))
            .expect_err("wrong layout");
        assert_eq!(refused.details.len(), 1, "{refused:?}");
        assert!(
            refused.details[0].contains("2 rows × 2 columns"),
            "{refused:?}"
        );

        let csv = "time_ms,u0,u1\n0,0,0\n200,9000,0\n";
        let refused = decode_upload(&name, csv.as_bytes(), UploadFormat::Csv, &config(1, 2))
            .expect_err("beyond travel and too fast");
        assert!(refused.details.len() >= 2, "{refused:?}");
        assert!(refused.error.contains("problems"), "{refused:?}");

        let refused = decode_upload(&name, b"\xff\xfe", UploadFormat::Csv, &config(1, 2))
            .expect_err("not UTF-8");
        assert!(refused.error.contains("UTF-8"), "{refused:?}");
    }

    #[test]
    fn shows_are_stored_listed_read_and_deleted() {
        let dir = tempfile::tempdir().expect("temp dir");
        let store = ShowStore::open(dir.path()).expect("open");
        let name = ShowName::parse("波浪").expect("name");
        let mut stored = show(1, 2);
        stored.name = name.to_string();
        let json = stored.to_json().expect("json");
        let (summary, created) = store.put(&name, &stored, &json).expect("put");
        assert!(created);
        assert_eq!(summary.name, "波浪");
        assert_eq!(summary.units, 2);
        assert_eq!(summary.duration_ms, 500);
        assert_eq!(summary.sha256.len(), 64);
        assert!(summary.modified.ends_with('Z'), "{}", summary.modified);
        let bytes = store.read(&name).expect("read");
        assert_eq!(summary.bytes, bytes.len() as u64);
        assert!(!store.put(&name, &stored, &json).expect("replace").1);

        let reopened = ShowStore::open(dir.path()).expect("reopen");
        assert_eq!(reopened.list(), store.list());
        assert!(reopened.contains("波浪"));

        reopened.delete(&name).expect("delete");
        assert!(matches!(
            reopened.delete(&name),
            Err(StoreError::NotFound(_))
        ));
        assert!(matches!(reopened.read(&name), Err(StoreError::NotFound(_))));
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
    }
}
