//! The Control page's playlist editing as a plain type (the vendor app's
//! "configuration", `docs/uim2503.md` §4): a [`Playlist`] plus one checkbox per entry. Move
//! up, move down, delete and edit act on the checked entries; add appends with the
//! defaults. Start, E-stop and Reset ignore the checkboxes (they are socket messages,
//! not edits).
//!
//! Also here: reading the delay and cycles typed in the edit and settings forms, and
//! the verdict of the bandwidth reports before Start.

use floatball_shared::api::{PlanReport, Playlist, PlaylistEntry, Status};
use floatball_shared::playlist::{cycles_in_range, delay_in_range};

use crate::client::Failure;

/// A playlist being edited, with one checkbox per entry.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlaylistEditor {
    playlist: Playlist,
    checked: Vec<bool>,
}

impl PlaylistEditor {
    /// Editing `playlist`, nothing checked.
    pub fn new(playlist: Playlist) -> Self {
        let checked = vec![false; playlist.entries.len()];
        Self { playlist, checked }
    }

    /// Takes the playlist as the bridge has it now. Checkboxes stay on entries that
    /// are unchanged at the same place; the others are cleared.
    pub fn replace(&mut self, playlist: Playlist) {
        let checked = playlist
            .entries
            .iter()
            .enumerate()
            .map(|(index, entry)| {
                self.checked.get(index).copied().unwrap_or(false)
                    && self.playlist.entries.get(index) == Some(entry)
            })
            .collect();
        self.playlist = playlist;
        self.checked = checked;
    }

    /// The playlist as edited.
    pub fn playlist(&self) -> &Playlist {
        &self.playlist
    }

    /// The entries in play order.
    pub fn entries(&self) -> &[PlaylistEntry] {
        &self.playlist.entries
    }

    /// Whether entry `index` is checked.
    pub fn is_checked(&self, index: usize) -> bool {
        self.checked.get(index).copied().unwrap_or(false)
    }

    /// Checks or unchecks entry `index`.
    pub fn set_checked(&mut self, index: usize, checked: bool) {
        if let Some(slot) = self.checked.get_mut(index) {
            *slot = checked;
        }
    }

    /// How many entries are checked.
    pub fn checked_count(&self) -> usize {
        self.checked.iter().filter(|checked| **checked).count()
    }

    /// The first checked entry (its values prefill the edit form).
    pub fn first_checked(&self) -> Option<&PlaylistEntry> {
        self.checked
            .iter()
            .position(|checked| *checked)
            .map(|index| &self.playlist.entries[index])
    }

    /// Appends `show` with the default delay and cycles, unchecked.
    pub fn add(&mut self, show: &str) {
        self.playlist.entries.push(PlaylistEntry {
            show: show.to_owned(),
            delay_ms: self.playlist.default_delay_ms,
            cycles: self.playlist.default_cycles.max(1),
            timecode_start: None,
        });
        self.checked.push(false);
    }

    /// Moves every checked entry one place up; a checked entry already at the top (or
    /// below another checked one that cannot move) stays. Returns whether anything
    /// moved.
    pub fn move_up(&mut self) -> bool {
        let mut moved = false;
        for index in 1..self.checked.len() {
            if self.checked[index] && !self.checked[index - 1] {
                self.swap(index - 1, index);
                moved = true;
            }
        }
        moved
    }

    /// Moves every checked entry one place down, the mirror of [`Self::move_up`].
    pub fn move_down(&mut self) -> bool {
        let mut moved = false;
        for index in (0..self.checked.len().saturating_sub(1)).rev() {
            if self.checked[index] && !self.checked[index + 1] {
                self.swap(index, index + 1);
                moved = true;
            }
        }
        moved
    }

    fn swap(&mut self, a: usize, b: usize) {
        self.playlist.entries.swap(a, b);
        self.checked.swap(a, b);
    }

    /// Deletes every checked entry; returns how many.
    pub fn delete_checked(&mut self) -> usize {
        let before = self.checked.len();
        let mut checked = self.checked.iter();
        self.playlist
            .entries
            .retain(|_| !checked.next().copied().unwrap_or(false));
        self.checked.retain(|checked| !checked);
        before - self.checked.len()
    }

    /// Sets the delay and cycles of every checked entry (the others keep theirs);
    /// returns how many changed.
    pub fn edit_checked(&mut self, delay_ms: u64, cycles: u32) -> usize {
        let mut count = 0;
        for (entry, checked) in self.playlist.entries.iter_mut().zip(&self.checked) {
            if *checked {
                entry.delay_ms = delay_ms;
                entry.cycles = cycles;
                count += 1;
            }
        }
        count
    }

    /// Gives every checked entry the timecode start `start` (`None`: none); returns
    /// how many changed.
    pub fn set_timecode_checked(&mut self, start: Option<&str>) -> usize {
        let mut count = 0;
        for (entry, checked) in self.playlist.entries.iter_mut().zip(&self.checked) {
            if *checked && entry.timecode_start.as_deref() != start {
                entry.timecode_start = start.map(str::to_owned);
                count += 1;
            }
        }
        count
    }

    /// Sets the defaults for new entries and whether the playlist loops.
    pub fn set_settings(&mut self, default_delay_ms: u64, default_cycles: u32, looped: bool) {
        self.playlist.default_delay_ms = default_delay_ms;
        self.playlist.default_cycles = default_cycles;
        self.playlist.loop_playlist = looped;
    }

    /// The entry the status says plays, for the highlight: its index, and only when
    /// the entry at that index here is the show the status names (a playlist this
    /// page has not fetched yet never gets the wrong show marked).
    pub fn playing_entry(&self, status: &Status) -> Option<usize> {
        let index = status.entry?;
        let show = status.show.as_deref()?;
        (self.playlist.entries.get(index)?.show == show).then_some(index)
    }

    /// Each show of the playlist once, in order of first appearance.
    pub fn shows(&self) -> Vec<String> {
        let mut shows: Vec<String> = Vec::new();
        for entry in &self.playlist.entries {
            if !shows.contains(&entry.show) {
                shows.push(entry.show.clone());
            }
        }
        shows
    }
}

/// A number typed in a form that cannot be used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputError {
    /// Not a number, negative, or longer than a day.
    Delay,
    /// Not a whole number from 1 to 1 000 000.
    Cycles,
}

/// Reads a delay typed in seconds (`1.5`, `1,5`, `0`) as ms.
///
/// # Errors
/// [`InputError::Delay`].
pub fn parse_delay_s(text: &str) -> Result<u64, InputError> {
    let seconds: f64 = text
        .trim()
        .replace(',', ".")
        .parse()
        .map_err(|_| InputError::Delay)?;
    let ms = (seconds * 1000.0).round();
    // `as` saturates: anything past `u64::MAX` ms is out of range all the same.
    if ms.is_finite() && ms >= 0.0 && delay_in_range(ms as u64) {
        Ok(ms as u64)
    } else {
        Err(InputError::Delay)
    }
}

/// Shows a delay in seconds as it is typed back (`1.5`, `0`).
pub fn format_delay_s(delay_ms: u64) -> String {
    let text = format!("{:.3}", delay_ms as f64 / 1000.0);
    text.trim_end_matches('0').trim_end_matches('.').to_owned()
}

/// Reads a number of cycles (1 to [`floatball_shared::playlist::MAX_CYCLES`], as the
/// bridge accepts).
///
/// # Errors
/// [`InputError::Cycles`].
pub fn parse_cycles(text: &str) -> Result<u32, InputError> {
    match text.trim().parse::<u32>() {
        Ok(cycles) if cycles_in_range(cycles) => Ok(cycles),
        _ => Err(InputError::Cycles),
    }
}

/// What the bridge's bandwidth report says about one show.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The report is being fetched.
    Pending,
    /// The show can run.
    Feasible(PlanReport),
    /// The show cannot run; the report says why.
    Infeasible(PlanReport),
    /// This bridge has no planner yet.
    Unavailable,
    /// The report could not be fetched: why, rendered when shown (so it follows a
    /// language switch).
    Failed(Failure),
}

impl Verdict {
    /// The verdict of a fetched report (`None`: no planner).
    pub fn of(report: Option<PlanReport>) -> Self {
        match report {
            Some(report) if report.feasible => Verdict::Feasible(report),
            Some(report) => Verdict::Infeasible(report),
            None => Verdict::Unavailable,
        }
    }

    /// A word for tests and styling.
    pub fn key(&self) -> &'static str {
        match self {
            Verdict::Pending => "pending",
            Verdict::Feasible(_) => "feasible",
            Verdict::Infeasible(_) => "infeasible",
            Verdict::Unavailable => "unavailable",
            Verdict::Failed(_) => "failed",
        }
    }
}

/// Whether Start may be pressed: not when the playlist is empty or a report says a
/// show cannot run (the bridge would refuse it anyway; the reason is on screen).
pub fn can_start(editor: &PlaylistEditor, verdicts: &[(String, Verdict)]) -> bool {
    !editor.entries().is_empty()
        && !verdicts
            .iter()
            .any(|(_, verdict)| matches!(verdict, Verdict::Infeasible(_)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn editor(shows: &[&str]) -> PlaylistEditor {
        let mut editor = PlaylistEditor::new(Playlist::default());
        for show in shows {
            editor.add(show);
        }
        editor
    }

    fn names(editor: &PlaylistEditor) -> Vec<&str> {
        editor.entries().iter().map(|e| e.show.as_str()).collect()
    }

    fn check(editor: &mut PlaylistEditor, indices: &[usize]) {
        for index in indices {
            editor.set_checked(*index, true);
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn add_uses_the_defaults() {
        let mut editor = PlaylistEditor::new(Playlist {
            default_delay_ms: 1500,
            default_cycles: 3,
            ..Playlist::default()
        });
        editor.add("wave");
        assert_eq!(
            editor.entries(),
            [PlaylistEntry {
                show: "wave".into(),
                delay_ms: 1500,
                cycles: 3,
                timecode_start: None,
            }]
        );
        assert!(!editor.is_checked(0));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn move_up_moves_each_checked_entry_and_keeps_the_checks() {
        let mut editor = editor(&["a", "b", "c", "d"]);
        check(&mut editor, &[1, 3]);
        assert!(editor.move_up());
        assert_eq!(names(&editor), ["b", "a", "d", "c"]);
        assert!(editor.is_checked(0) && editor.is_checked(2));
        assert!(editor.move_up());
        assert_eq!(names(&editor), ["b", "d", "a", "c"]);
        assert!(!editor.move_up(), "both checked entries are at the top");
        assert_eq!(names(&editor), ["b", "d", "a", "c"]);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn move_down_is_the_mirror() {
        let mut editor = editor(&["a", "b", "c", "d"]);
        check(&mut editor, &[0, 2]);
        assert!(editor.move_down());
        assert_eq!(names(&editor), ["b", "a", "d", "c"]);
        assert!(editor.is_checked(1) && editor.is_checked(3));
        assert!(editor.move_down());
        assert_eq!(names(&editor), ["b", "d", "a", "c"]);
        assert!(!editor.move_down());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn nothing_checked_moves_nothing() {
        let mut editor = editor(&["a", "b"]);
        assert!(!editor.move_up());
        assert!(!editor.move_down());
        assert_eq!(editor.delete_checked(), 0);
        assert_eq!(editor.edit_checked(5, 5), 0);
        assert_eq!(names(&editor), ["a", "b"]);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn delete_removes_all_checked() {
        let mut editor = editor(&["a", "b", "c", "d"]);
        check(&mut editor, &[0, 2, 3]);
        assert_eq!(editor.delete_checked(), 3);
        assert_eq!(names(&editor), ["b"]);
        assert_eq!(editor.checked_count(), 0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_timecode_start_goes_to_the_checked_entries_and_is_cleared_by_none() {
        let mut editor = editor(&["a", "b", "c"]);
        check(&mut editor, &[0, 2]);
        assert_eq!(editor.set_timecode_checked(Some("10:00:00:00")), 2);
        assert_eq!(editor.set_timecode_checked(Some("10:00:00:00")), 0);
        let starts: Vec<_> = editor
            .entries()
            .iter()
            .map(|entry| entry.timecode_start.clone())
            .collect();
        assert_eq!(
            starts,
            [Some("10:00:00:00".into()), None, Some("10:00:00:00".into())]
        );
        assert_eq!(editor.set_timecode_checked(None), 2);
        assert!(
            editor
                .entries()
                .iter()
                .all(|entry| entry.timecode_start.is_none())
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn edit_changes_only_the_checked_entries() {
        let mut editor = editor(&["a", "b", "c"]);
        check(&mut editor, &[0, 2]);
        assert_eq!(editor.edit_checked(2500, 4), 2);
        let values: Vec<_> = editor
            .entries()
            .iter()
            .map(|e| (e.delay_ms, e.cycles))
            .collect();
        assert_eq!(values, [(2500, 4), (0, 1), (2500, 4)]);
        assert_eq!(editor.first_checked().map(|e| e.delay_ms), Some(2500));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn replace_keeps_checks_on_unchanged_entries() {
        let mut editor = editor(&["a", "b", "c"]);
        check(&mut editor, &[0, 1]);
        let mut newer = editor.playlist().clone();
        newer.entries[1].cycles = 9;
        newer.entries.push(newer.entries[0].clone());
        editor.replace(newer);
        assert!(editor.is_checked(0));
        assert!(!editor.is_checked(1), "changed under the operator");
        assert!(!editor.is_checked(3));
        assert_eq!(editor.entries().len(), 4);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_highlight_marks_only_the_entry_that_plays() {
        let editor = editor(&["a", "b", "a"]);
        let status = |entry, show: &str| Status {
            entry,
            show: Some(show.into()),
            ..Status::default()
        };
        assert_eq!(editor.playing_entry(&status(Some(2), "a")), Some(2));
        assert_eq!(editor.playing_entry(&status(Some(1), "b")), Some(1));
        assert_eq!(
            editor.playing_entry(&status(Some(1), "a")),
            None,
            "the list here differs from the one that plays"
        );
        assert_eq!(editor.playing_entry(&status(Some(3), "a")), None);
        assert_eq!(editor.playing_entry(&status(None, "a")), None);
        assert_eq!(editor.playing_entry(&Status::default()), None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn settings_and_shows() {
        let mut editor = editor(&["a", "b", "a"]);
        editor.set_settings(1000, 2, true);
        assert!(editor.playlist().loop_playlist);
        editor.add("c");
        assert_eq!(editor.entries()[3].cycles, 2);
        assert_eq!(editor.shows(), ["a", "b", "c"]);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn typed_numbers_are_checked() {
        assert_eq!(parse_delay_s("1.5"), Ok(1500));
        assert_eq!(parse_delay_s(" 2,25 "), Ok(2250));
        assert_eq!(parse_delay_s("0"), Ok(0));
        assert_eq!(parse_delay_s("-1"), Err(InputError::Delay));
        assert_eq!(parse_delay_s("abc"), Err(InputError::Delay));
        assert_eq!(parse_delay_s("1e9"), Err(InputError::Delay));
        assert_eq!(parse_cycles("3"), Ok(3));
        assert_eq!(parse_cycles("0"), Err(InputError::Cycles));
        assert_eq!(parse_cycles("1.5"), Err(InputError::Cycles));
        assert_eq!(parse_cycles("1000000"), Ok(1_000_000));
        assert_eq!(parse_cycles("1000001"), Err(InputError::Cycles));
        assert_eq!(parse_delay_s("86400"), Ok(86_400_000));
        assert_eq!(parse_delay_s("86400.001"), Err(InputError::Delay));
        assert_eq!(format_delay_s(1500), "1.5");
        assert_eq!(format_delay_s(0), "0");
        assert_eq!(format_delay_s(2000), "2");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn start_waits_for_a_playlist_and_refuses_infeasible_shows() {
        let report = |feasible| PlanReport {
            show: "a".into(),
            feasible,
            reason: (!feasible).then(|| "9600 baud cannot carry 100 units".into()),
            fixes: Vec::new(),
            reason_problem: None,
            fix_problems: Vec::new(),
            preload_ms: 0,
            advice: Vec::new(),
            gateways: Vec::new(),
        };
        assert!(!can_start(&editor(&[]), &[]));
        let playlist = editor(&["a"]);
        assert!(can_start(&playlist, &[]));
        let ok = [("a".to_owned(), Verdict::of(Some(report(true))))];
        assert!(can_start(&playlist, &ok));
        let unknown = [("a".to_owned(), Verdict::of(None))];
        assert_eq!(unknown[0].1, Verdict::Unavailable);
        assert!(can_start(&playlist, &unknown));
        let bad = [("a".to_owned(), Verdict::of(Some(report(false))))];
        assert_eq!(bad[0].1.key(), "infeasible");
        assert!(!can_start(&playlist, &bad));
    }
}
