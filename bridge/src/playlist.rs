//! The playlist (the vendor app's "configuration"): which shows Start plays, in which
//! order, with which delay and how many cycles; stored in `<data-dir>/playlist.json`.
//!
//! A new playlist is checked as a whole ([`check`]) — every show must be stored, every
//! count within the limits the app shares (`floatball_shared::playlist`) — and written atomically, so a restart finds exactly the last
//! playlist accepted.
//!
//! While the matrix runs the playlist or moves its balls ([`locked`]), the entries
//! cannot change ([`changes_what_plays`]): the bridge refuses such an edit with 409
//! `playlist_locked`, so what plays and what the status's `entry` points at stay the
//! list the operator sees. Loop and the defaults for new entries may still change.

use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};

use floatball_shared::api::{PlayerState, Playlist};
use floatball_shared::codes::Code;
use floatball_shared::playlist::problems;

use crate::durable;
use crate::store::Refused;

/// The playlist file's name inside the data directory.
pub const FILE_NAME: &str = "playlist.json";

/// Why the playlist cannot be read or written.
#[derive(Debug, thiserror::Error)]
pub enum PlaylistError {
    /// The disk said no.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The stored file is not a playlist.
    #[error("{}: not a playlist ({reason}); fix or delete it", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

/// The stored playlist.
#[derive(Debug)]
pub struct PlaylistStore {
    dir: PathBuf,
    current: Mutex<Playlist>,
}

impl PlaylistStore {
    /// Reads `<data_dir>/playlist.json`; an empty playlist if there is none yet.
    ///
    /// # Errors
    /// If the file cannot be read or is not a playlist.
    pub fn open(data_dir: &Path) -> Result<Self, PlaylistError> {
        let path = data_dir.join(FILE_NAME);
        let current = match std::fs::read_to_string(&path) {
            Ok(text) => serde_json::from_str(&text).map_err(|error| PlaylistError::Corrupt {
                path: path.clone(),
                reason: error.to_string(),
            })?,
            Err(error) if error.kind() == io::ErrorKind::NotFound => Playlist::default(),
            Err(source) => return Err(PlaylistError::Io { path, source }),
        };
        Ok(Self {
            dir: data_dir.to_owned(),
            current: Mutex::new(current),
        })
    }

    /// The playlist.
    pub fn get(&self) -> Playlist {
        self.lock().clone()
    }

    /// Replaces the playlist (already [checked](check)) on disk and in memory.
    ///
    /// # Errors
    /// An I/O error; the playlist is then as before.
    pub fn put(&self, playlist: Playlist) -> Result<(), PlaylistError> {
        let path = self.dir.join(FILE_NAME);
        let text = serde_json::to_vec_pretty(&playlist).map_err(|error| PlaylistError::Io {
            path: path.clone(),
            source: io::Error::other(error),
        })?;
        let mut current = self.lock();
        durable::write_atomic(&self.dir, FILE_NAME, &text)
            .map_err(|source| PlaylistError::Io { path, source })?;
        *current = playlist;
        Ok(())
    }

    /// Whether any entry plays `show`.
    pub fn uses(&self, show: &str) -> bool {
        self.lock().entries.iter().any(|entry| entry.show == show)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Playlist> {
        self.current.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Checks a playlist: every entry's show is stored (`show_exists`), and counts and
/// delays are within the shared limits ([`floatball_shared::playlist::problems`]).
///
/// # Errors
/// [`Refused`] listing every problem, entries numbered from 1.
pub fn check(playlist: &Playlist, show_exists: impl Fn(&str) -> bool) -> Result<(), Refused> {
    let problems = problems(playlist, show_exists);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(Refused::invalid(
            Code::PlaylistInvalid,
            Code::PlaylistInvalid.english(),
            &problems,
        ))
    }
}

/// Whether the playlist's entries are locked in player state `state`: while a show
/// waits, approaches, loads or plays, and while the balls home.
pub fn locked(state: PlayerState) -> bool {
    matches!(
        state,
        PlayerState::Waiting
            | PlayerState::Approaching
            | PlayerState::Loading
            | PlayerState::Playing
            | PlayerState::Homing
    )
}

/// Whether `new` changes what plays compared with `current`: an entry added, deleted,
/// moved, or its delay or cycles edited. Loop and the defaults do not.
pub fn changes_what_plays(current: &Playlist, new: &Playlist) -> bool {
    current.entries != new.entries
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::PlaylistEntry;
    use floatball_shared::playlist::MAX_DELAY_MS;

    use super::*;

    fn entry(show: &str, delay_ms: u64, cycles: u32) -> PlaylistEntry {
        PlaylistEntry {
            show: show.into(),
            delay_ms,
            cycles,
            timecode_start: None,
        }
    }

    #[test]
    fn a_playlist_survives_a_reopen() {
        let dir = tempfile::tempdir().expect("temp dir");
        let store = PlaylistStore::open(dir.path()).expect("open");
        assert_eq!(store.get(), Playlist::default());
        let playlist = Playlist {
            entries: vec![entry("波浪", 500, 2), entry("rain", 0, 1)],
            loop_playlist: true,
            default_delay_ms: 1000,
            default_cycles: 3,
        };
        store.put(playlist.clone()).expect("put");
        assert!(store.uses("波浪"));
        assert!(!store.uses("snow"));
        assert_eq!(
            PlaylistStore::open(dir.path()).expect("reopen").get(),
            playlist
        );
    }

    #[test]
    fn every_problem_is_listed() {
        let playlist = Playlist {
            entries: vec![entry("rain", 0, 1), entry("snow", MAX_DELAY_MS + 1, 0)],
            loop_playlist: false,
            default_delay_ms: 0,
            default_cycles: 0,
        };
        let refused = check(&playlist, |show| show == "rain").expect_err("invalid");
        assert_eq!(
            refused.details,
            [
                "entry 2: there is no show named \"snow\"",
                "entry 2: cycles is 0; it must be from 1 to 1000000",
                "entry 2: delay_ms is 86400001; it must be at most 86400000 (one day)",
                "default_cycles is 0; it must be from 1 to 1000000",
            ]
        );
        assert_eq!(check(&Playlist::default(), |_| false), Ok(()));
    }

    #[test]
    fn only_entries_are_locked_and_only_while_the_matrix_runs() {
        let running = [
            PlayerState::Waiting,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Homing,
        ];
        assert!(running.into_iter().all(locked));
        for calm in [PlayerState::Idle, PlayerState::Stopped, PlayerState::Error] {
            assert!(!locked(calm), "{calm:?}");
        }
        let current = Playlist {
            entries: vec![entry("rain", 0, 1), entry("snow", 500, 2)],
            ..Playlist::default()
        };
        let mut settings = current.clone();
        settings.loop_playlist = true;
        settings.default_delay_ms = 2000;
        settings.default_cycles = 3;
        assert!(!changes_what_plays(&current, &settings));
        let mut reordered = current.clone();
        reordered.entries.swap(0, 1);
        let mut cycles = current.clone();
        cycles.entries[1].cycles = 3;
        let mut deleted = current.clone();
        deleted.entries.pop();
        let mut added = current.clone();
        added.entries.push(entry("rain", 0, 1));
        for edit in [reordered, cycles, deleted, added] {
            assert!(changes_what_plays(&current, &edit), "{edit:?}");
        }
    }

    #[test]
    fn a_corrupt_file_is_reported() {
        let dir = tempfile::tempdir().expect("temp dir");
        std::fs::write(dir.path().join(FILE_NAME), "[").expect("write");
        let message = PlaylistStore::open(dir.path())
            .expect_err("corrupt")
            .to_string();
        assert!(message.contains("playlist.json"), "{message}");
    }
}
