//! The playlist's limits and its one check: what the bridge refuses before it stores a
//! playlist (`PUT /api/playlist`) and what the web app refuses as the operator types.
//! The playlist itself is [`crate::api::Playlist`].

use std::fmt;

use crate::api::Playlist;
use crate::codes::{Code, Coded, Params};
use crate::params;

/// Most entries a playlist holds.
pub const MAX_ENTRIES: usize = 1000;

/// Longest delay before an entry, ms (one day).
pub const MAX_DELAY_MS: u64 = 24 * 60 * 60 * 1000;

/// Most cycles of one entry.
pub const MAX_CYCLES: u32 = 1_000_000;

/// Whether a delay before an entry is allowed: at most [`MAX_DELAY_MS`].
pub fn delay_in_range(delay_ms: u64) -> bool {
    delay_ms <= MAX_DELAY_MS
}

/// Whether a number of cycles is allowed: 1 to [`MAX_CYCLES`].
pub fn cycles_in_range(cycles: u32) -> bool {
    (1..=MAX_CYCLES).contains(&cycles)
}

/// One problem of a playlist; its `Display` is the English sentence, entries numbered
/// from 1.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PlaylistProblem {
    /// More than [`MAX_ENTRIES`] entries.
    TooManyEntries {
        /// Entries in the playlist.
        entries: usize,
    },
    /// An entry names a show that is not stored.
    UnknownShow {
        /// The entry, from 1.
        entry: usize,
        /// The show's name.
        show: String,
    },
    /// Cycles out of range: of an entry (from 1), or the default (`None`).
    Cycles {
        /// The entry, from 1; `None` for `default_cycles`.
        entry: Option<usize>,
        /// The cycles given.
        cycles: u32,
    },
    /// A delay out of range: of an entry (from 1), or the default (`None`).
    Delay {
        /// The entry, from 1; `None` for `default_delay_ms`.
        entry: Option<usize>,
        /// The delay given, ms.
        delay_ms: u64,
    },
    /// An entry's timecode start that is not a timecode `HH:MM:SS:FF`.
    Timecode {
        /// The entry, from 1.
        entry: usize,
        /// The text given.
        timecode: String,
    },
}

impl fmt::Display for PlaylistProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::TooManyEntries { entries } => write!(
                f,
                "the playlist has {entries} entries; at most {MAX_ENTRIES} are allowed"
            ),
            Self::UnknownShow { entry, show } => {
                write!(f, "entry {entry}: there is no show named \"{show}\"")
            }
            Self::Cycles { entry, cycles } => {
                match entry {
                    Some(entry) => write!(f, "entry {entry}: cycles")?,
                    None => f.write_str("default_cycles")?,
                }
                write!(f, " is {cycles}; it must be from 1 to {MAX_CYCLES}")
            }
            Self::Delay { entry, delay_ms } => {
                match entry {
                    Some(entry) => write!(f, "entry {entry}: delay_ms")?,
                    None => f.write_str("default_delay_ms")?,
                }
                write!(
                    f,
                    " is {delay_ms}; it must be at most {MAX_DELAY_MS} (one day)"
                )
            }
            Self::Timecode { entry, timecode } => write!(
                f,
                "entry {entry}: timecode_start \"{timecode}\" is not a timecode such as \
                 10:00:00:00 (HH:MM:SS:FF)"
            ),
        }
    }
}

impl Coded for PlaylistProblem {
    fn code(&self) -> Code {
        match self {
            Self::TooManyEntries { .. } => Code::PlaylistTooManyEntries,
            Self::UnknownShow { .. } => Code::PlaylistUnknownShow,
            Self::Cycles { entry: Some(_), .. } => Code::EntryCycles,
            Self::Cycles { entry: None, .. } => Code::DefaultCycles,
            Self::Delay { entry: Some(_), .. } => Code::EntryDelay,
            Self::Delay { entry: None, .. } => Code::DefaultDelay,
            Self::Timecode { .. } => Code::EntryTimecode,
        }
    }

    fn params(&self) -> Params {
        let mut params = match self {
            Self::TooManyEntries { entries } => {
                params! {"entries" => entries, "max" => MAX_ENTRIES}
            }
            Self::UnknownShow { entry, show } => params! {"entry" => entry, "show" => show},
            Self::Cycles { cycles, .. } => params! {"cycles" => cycles, "max" => MAX_CYCLES},
            Self::Delay { delay_ms, .. } => {
                params! {"delay_ms" => delay_ms, "max_ms" => MAX_DELAY_MS}
            }
            Self::Timecode { entry, timecode } => {
                params! {"entry" => entry, "timecode" => timecode}
            }
        };
        if let Self::Cycles {
            entry: Some(entry), ..
        }
        | Self::Delay {
            entry: Some(entry), ..
        } = self
        {
            params.insert("entry".into(), entry.to_string());
        }
        params
    }
}

/// Every problem of `playlist`, entries numbered from 1: more than [`MAX_ENTRIES`]
/// entries, a show `show_exists` does not know, cycles or delays out of range (for the
/// entries and for the defaults). Empty when it is valid.
pub fn problems(playlist: &Playlist, show_exists: impl Fn(&str) -> bool) -> Vec<PlaylistProblem> {
    let mut problems = Vec::new();
    if playlist.entries.len() > MAX_ENTRIES {
        problems.push(PlaylistProblem::TooManyEntries {
            entries: playlist.entries.len(),
        });
    }
    let cycles = |entry, cycles| {
        (!cycles_in_range(cycles)).then_some(PlaylistProblem::Cycles { entry, cycles })
    };
    let delay = |entry, delay_ms| {
        (!delay_in_range(delay_ms)).then_some(PlaylistProblem::Delay { entry, delay_ms })
    };
    for (index, entry) in playlist.entries.iter().enumerate().take(MAX_ENTRIES) {
        let number = index + 1;
        if !show_exists(&entry.show) {
            problems.push(PlaylistProblem::UnknownShow {
                entry: number,
                show: entry.show.clone(),
            });
        }
        problems.extend(cycles(Some(number), entry.cycles));
        problems.extend(delay(Some(number), entry.delay_ms));
        if let Some(timecode) = &entry.timecode_start
            && !crate::timecode::timecode_text_valid(timecode)
        {
            problems.push(PlaylistProblem::Timecode {
                entry: number,
                timecode: timecode.clone(),
            });
        }
    }
    problems.extend(cycles(None, playlist.default_cycles));
    problems.extend(delay(None, playlist.default_delay_ms));
    problems
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::api::PlaylistEntry;

    /// Entries from (show, delay_ms, cycles).
    fn entries(list: &[(&str, u64, u32)]) -> Vec<PlaylistEntry> {
        list.iter()
            .map(|&(show, delay_ms, cycles)| PlaylistEntry {
                show: show.into(),
                delay_ms,
                cycles,
                timecode_start: None,
            })
            .collect()
    }

    #[test]
    fn the_ranges_end_where_the_constants_say() {
        assert!(delay_in_range(0) && delay_in_range(MAX_DELAY_MS));
        assert!(!delay_in_range(MAX_DELAY_MS + 1));
        assert!(cycles_in_range(1) && cycles_in_range(MAX_CYCLES));
        assert!(!cycles_in_range(0) && !cycles_in_range(MAX_CYCLES + 1));
    }

    #[test]
    fn every_problem_is_listed_in_order() {
        let playlist = Playlist {
            entries: entries(&[("rain", 0, 1), ("snow", MAX_DELAY_MS + 1, 0)]),
            loop_playlist: false,
            default_delay_ms: MAX_DELAY_MS + 1,
            default_cycles: 0,
        };
        let found = problems(&playlist, |show| show == "rain");
        assert_eq!(
            found.iter().map(Coded::code).collect::<Vec<_>>(),
            [
                Code::PlaylistUnknownShow,
                Code::EntryCycles,
                Code::EntryDelay,
                Code::DefaultCycles,
                Code::DefaultDelay
            ]
        );
        assert_eq!(found[1].params()["entry"], "2");
        assert_eq!(
            found.iter().map(ToString::to_string).collect::<Vec<_>>(),
            [
                "entry 2: there is no show named \"snow\"",
                "entry 2: cycles is 0; it must be from 1 to 1000000",
                "entry 2: delay_ms is 86400001; it must be at most 86400000 (one day)",
                "default_cycles is 0; it must be from 1 to 1000000",
                "default_delay_ms is 86400001; it must be at most 86400000 (one day)",
            ]
        );
        assert!(problems(&Playlist::default(), |_| false).is_empty());
        let long = Playlist {
            entries: entries(&[("rain", 0, 1); MAX_ENTRIES + 1]),
            ..Playlist::default()
        };
        assert_eq!(
            problems(&long, |_| true)
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>(),
            ["the playlist has 1001 entries; at most 1000 are allowed"]
        );
    }

    #[test]
    fn a_timecode_start_must_be_a_timecode() {
        let mut playlist = Playlist {
            entries: entries(&[("rain", 0, 1), ("snow", 0, 1), ("hail", 0, 1)]),
            ..Playlist::default()
        };
        playlist.entries[0].timecode_start = Some("10:00:00:00".into());
        playlist.entries[1].timecode_start = Some("00:01:00;02".into());
        playlist.entries[2].timecode_start = Some("10:00:00:30".into());
        let found = problems(&playlist, |_| true);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].code(), Code::EntryTimecode);
        assert_eq!(found[0].params()["entry"], "3");
        assert_eq!(
            found[0].to_string(),
            "entry 3: timecode_start \"10:00:00:30\" is not a timecode such as 10:00:00:00 \
             (HH:MM:SS:FF)"
        );
    }
}
