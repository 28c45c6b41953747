//! The playlist's limits and its one check: what the bridge refuses before it stores a
//! playlist (`PUT /api/playlist`) and what the web app refuses as the operator types.
//! The playlist itself is [`crate::api::Playlist`].

use crate::api::Playlist;

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

/// Every problem of `playlist`, in words, entries numbered from 1: more than
/// [`MAX_ENTRIES`] entries, a show `show_exists` does not know, cycles or delays out of
/// range (for the entries and for the defaults). Empty when it is valid.
pub fn problems(playlist: &Playlist, show_exists: impl Fn(&str) -> bool) -> Vec<String> {
    let mut problems = Vec::new();
    if playlist.entries.len() > MAX_ENTRIES {
        problems.push(format!(
            "the playlist has {} entries; at most {MAX_ENTRIES} are allowed",
            playlist.entries.len()
        ));
    }
    let cycles = |what: &str, cycles: u32| {
        (!cycles_in_range(cycles))
            .then(|| format!("{what} is {cycles}; it must be from 1 to {MAX_CYCLES}"))
    };
    let delay = |what: &str, delay_ms: u64| {
        (!delay_in_range(delay_ms))
            .then(|| format!("{what} is {delay_ms}; it must be at most {MAX_DELAY_MS} (one day)"))
    };
    for (index, entry) in playlist.entries.iter().enumerate().take(MAX_ENTRIES) {
        let number = index + 1;
        if !show_exists(&entry.show) {
            problems.push(format!(
                "entry {number}: there is no show named \"{}\"",
                entry.show
            ));
        }
        problems.extend(cycles(&format!("entry {number}: cycles"), entry.cycles));
        problems.extend(delay(&format!("entry {number}: delay_ms"), entry.delay_ms));
    }
    problems.extend(cycles("default_cycles", playlist.default_cycles));
    problems.extend(delay("default_delay_ms", playlist.default_delay_ms));
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
        assert_eq!(
            problems(&playlist, |show| show == "rain"),
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
            problems(&long, |_| true),
            ["the playlist has 1001 entries; at most 1000 are allowed"]
        );
    }
}
