//! The two file lists of the Files page as plain types: the show files kept in the
//! browser ([`LocalFile`], stored by [`crate::store`]) and the ones on the controller
//! ([`ShowSummary`]), each in a [`Listing`] with one selected entry.

use floatball_shared::api::ShowSummary;
use floatball_shared::show::{Refused, Show, ShowFormat, import};
use serde::{Deserialize, Serialize};

/// A show file kept in the browser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocalFile {
    /// The file name, with its extension (`wave.csv`).
    pub name: String,
    /// Its format.
    pub kind: ShowFormat,
    /// Its content.
    pub text: String,
    /// When it was added, ms since 1970.
    pub added_ms: f64,
}

impl LocalFile {
    /// A local file named `name` with content `text`; `None` when the name's
    /// extension is neither `.csv` nor `.json`.
    pub fn new(name: &str, text: String, added_ms: f64) -> Option<Self> {
        Some(Self {
            name: name.to_owned(),
            kind: ShowFormat::from_file_name(name)?,
            text,
            added_ms,
        })
    }

    /// The local copy of a show downloaded from the controller: `{name}.json`.
    pub fn downloaded(show_name: &str, json: String, added_ms: f64) -> Self {
        Self {
            name: format!("{show_name}.json"),
            kind: ShowFormat::Json,
            text: json,
            added_ms,
        }
    }

    /// The name the show gets on the controller: the file name without `.csv` or
    /// `.json`.
    pub fn show_name(&self) -> &str {
        self.name
            .rsplit_once('.')
            .map_or(self.name.as_str(), |(stem, _)| stem)
    }

    /// Size of the content, bytes.
    pub fn bytes(&self) -> u64 {
        self.text.len() as u64
    }

    /// The show, read for the preview by the one import ([`import`]) without an
    /// installation: a CSV file without a layout line is laid out as the most nearly
    /// square grid of its ball count, and limits are not checked (the preview shows
    /// the violations).
    ///
    /// # Errors
    /// What is wrong with the file ([`Refused::details`] in the parser's words).
    pub fn to_show(&self) -> Result<Show, Refused> {
        import(
            self.show_name(),
            self.text.as_bytes(),
            self.kind,
            None,
            None,
        )
    }
}

/// Something listed by name.
pub trait Named {
    /// Its name, unique in its list.
    fn name(&self) -> &str;
}

impl Named for LocalFile {
    fn name(&self) -> &str {
        &self.name
    }
}

impl Named for ShowSummary {
    fn name(&self) -> &str {
        &self.name
    }
}

/// A list sorted by name, with at most one selected entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Listing<T> {
    items: Vec<T>,
    selected: Option<String>,
}

impl<T> Default for Listing<T> {
    fn default() -> Self {
        Self {
            items: Vec::new(),
            selected: None,
        }
    }
}

impl<T: Named> Listing<T> {
    /// The entries, sorted by name.
    pub fn items(&self) -> &[T] {
        &self.items
    }

    /// Replaces every entry (after a reload from storage or the controller); the
    /// selection stays if its entry is still there.
    pub fn replace(&mut self, mut items: Vec<T>) {
        items.sort_by(|a, b| a.name().cmp(b.name()));
        items.dedup_by(|a, b| a.name() == b.name());
        self.items = items;
        if let Some(name) = &self.selected
            && !self.items.iter().any(|item| item.name() == name)
        {
            self.selected = None;
        }
    }

    /// Adds `item`, replacing an entry of the same name, and selects it.
    pub fn upsert(&mut self, item: T) {
        let name = item.name().to_owned();
        match self.items.binary_search_by(|probe| probe.name().cmp(&name)) {
            Ok(index) => self.items[index] = item,
            Err(index) => self.items.insert(index, item),
        }
        self.selected = Some(name);
    }

    /// Removes the entry named `name`; returns whether there was one.
    pub fn remove(&mut self, name: &str) -> bool {
        let before = self.items.len();
        self.items.retain(|item| item.name() != name);
        if self.selected.as_deref() == Some(name) {
            self.selected = None;
        }
        self.items.len() != before
    }

    /// Selects the entry named `name`, or clears the selection if there is none.
    pub fn select(&mut self, name: &str) {
        self.selected = self
            .items
            .iter()
            .any(|item| item.name() == name)
            .then(|| name.to_owned());
    }

    /// Selects nothing (after a pick that added nothing, so that Upload does not act
    /// on a file the operator no longer looks at).
    pub fn clear_selection(&mut self) {
        self.selected = None;
    }

    /// The selected entry's name.
    pub fn selected_name(&self) -> Option<&str> {
        self.selected.as_deref()
    }

    /// The selected entry.
    pub fn selected(&self) -> Option<&T> {
        let name = self.selected.as_deref()?;
        self.items.iter().find(|item| item.name() == name)
    }

    /// The entry named `name`.
    pub fn get(&self, name: &str) -> Option<&T> {
        self.items.iter().find(|item| item.name() == name)
    }
}

/// How many problems a list shows before "show all" (an invalid 10-minute show has
/// thousands).
pub const SHOWN_PROBLEMS: usize = 20;

/// Most characters one message shows: a binary file read as CSV repeats its bytes.
pub const MAX_MESSAGE_CHARS: usize = 400;

/// `text`, cut to [`MAX_MESSAGE_CHARS`] characters with `…` when longer.
#[must_use]
pub fn clip_message(text: &str) -> String {
    match text.char_indices().nth(MAX_MESSAGE_CHARS) {
        Some((end, _)) => format!("{}…", &text[..end]),
        None => text.to_owned(),
    }
}

/// The file extensions the app and the bridge accept, for people: `.csv, .json`.
#[must_use]
pub fn supported_extensions() -> String {
    ShowFormat::ALL
        .map(|format| format!(".{}", format.extension()))
        .join(", ")
}

/// A size for people: `512 B`, `1.5 kB`, `2.3 MB`.
pub fn format_bytes(bytes: u64) -> String {
    match bytes {
        0..1_000 => format!("{bytes} B"),
        1_000..1_000_000 => format!("{:.1} kB", bytes as f64 / 1e3),
        _ => format!("{:.1} MB", bytes as f64 / 1e6),
    }
}

/// A show time for people: `m:ss.s`.
pub fn format_duration_ms(ms: u64) -> String {
    let tenths = ms / 100;
    format!("{}:{:02}.{}", tenths / 600, tenths / 10 % 60, tenths % 10)
}

/// A ball number as typed (the CSV's `uN`, from 0): digits, spaces around allowed.
#[must_use]
pub fn parse_ball(text: &str) -> Option<usize> {
    let text = text.trim();
    if text.is_empty() || !text.bytes().all(|byte| byte.is_ascii_digit()) {
        return None;
    }
    text.parse().ok()
}

/// The file a ball's Q program is saved as: `<show>-unit<N>.q`.
#[must_use]
pub fn qprogram_file_name(show: &str, unit: usize) -> String {
    format!("{show}-unit{unit}.q")
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn local(name: &str) -> LocalFile {
        LocalFile::new(name, String::new(), 0.0).unwrap()
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn kinds_come_from_the_extension() {
        assert_eq!(local("wave.CSV").kind, ShowFormat::Csv);
        assert_eq!(local("a.b.json").kind, ShowFormat::Json);
        assert!(LocalFile::new("notes.txt", String::new(), 0.0).is_none());
        assert!(LocalFile::new("csv", String::new(), 0.0).is_none());
        assert!(LocalFile::new("x.png", String::new(), 0.0).is_none());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn show_names_drop_the_extension() {
        assert_eq!(local("波浪.csv").show_name(), "波浪");
        assert_eq!(local("a.b.json").show_name(), "a.b");
        let copy = LocalFile::downloaded("wave", "{}".into(), 1.0);
        assert_eq!(copy.name, "wave.json");
        assert_eq!(copy.show_name(), "wave");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn listings_stay_sorted_and_keep_a_valid_selection() {
        let mut list = Listing::default();
        list.upsert(local("b.csv"));
        list.upsert(local("a.csv"));
        list.upsert(local("c.json"));
        let names: Vec<_> = list.items().iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["a.csv", "b.csv", "c.json"]);
        assert_eq!(list.selected_name(), Some("c.json"));
        list.select("b.csv");
        assert_eq!(list.selected().map(|f| f.name.as_str()), Some("b.csv"));
        list.select("nope");
        assert_eq!(list.selected_name(), None);
        list.select("a.csv");
        assert!(list.remove("a.csv"));
        assert!(!list.remove("a.csv"));
        assert_eq!(list.selected_name(), None);
        assert_eq!(list.items().len(), 2);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn upsert_replaces_a_file_of_the_same_name() {
        let mut list = Listing::default();
        list.upsert(local("a.csv"));
        list.upsert(LocalFile::new("a.csv", "new".into(), 2.0).unwrap());
        assert_eq!(list.items().len(), 1);
        assert_eq!(list.get("a.csv").unwrap().text, "new");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn replace_keeps_the_selection_only_if_still_there() {
        let summary = |name: &str| ShowSummary {
            name: name.into(),
            bytes: 1,
            sha256: String::new(),
            modified: String::new(),
            units: 1,
            duration_ms: 1,
        };
        let mut list = Listing::default();
        list.replace(vec![summary("b"), summary("a")]);
        list.select("b");
        list.replace(vec![summary("b"), summary("c")]);
        assert_eq!(list.selected_name(), Some("b"));
        list.replace(vec![summary("c")]);
        assert_eq!(list.selected_name(), None);
        assert_eq!(list.items()[0].name, "c");
    }

    fn preview(name: &str, text: &str) -> Result<Show, Refused> {
        LocalFile::new(name, text.into(), 0.0).unwrap().to_show()
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn csv_without_a_layout_is_previewed_as_a_square_grid() {
        let four = "time_ms,u0,u1,u2,u3\n0,100,100,100,100\n500,200,300,400,500\n";
        let show = preview("four.csv", four).unwrap();
        assert_eq!((show.layout.rows, show.layout.cols), (2, 2));
        assert_eq!(show.name, "four");
        assert_eq!(show.duration_ms(), 500);
        let seven = "time_ms,u0,u1,u2,u3,u4,u5,u6\n0,1,1,1,1,1,1,1\n";
        let show = preview("seven.csv", seven).unwrap();
        assert_eq!((show.layout.rows, show.layout.cols), (1, 7));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn previews_are_not_held_to_limits() {
        // Beyond any travel, and still: shown, with its problems listed by the preview.
        let show = preview("deep.csv", "time_ms,u0\n0,90000\n").unwrap();
        assert_eq!(show.tracks[0].start_mm, 90_000.0);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn unreadable_files_say_why() {
        let error = preview("bad.csv", "time_ms,u0\n0,1\n5,2\n").unwrap_err();
        assert!(
            matches!(&error, Refused::Csv(csv) if csv.line == 3),
            "{error:?}"
        );
        assert!(error.details()[0].starts_with("line 3"), "{error:?}");
        let error = preview("bad.json", "{").unwrap_err();
        assert!(matches!(error, Refused::Unreadable(_)), "{error:?}");
        assert!(error.details()[0].contains("not valid"), "{error:?}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn ball_numbers_are_plain_digits() {
        assert_eq!(parse_ball("0"), Some(0));
        assert_eq!(parse_ball(" 42 "), Some(42));
        for bad in ["", " ", "-1", "+3", "1.5", "u3", "9999999999999999999999"] {
            assert_eq!(parse_ball(bad), None, "{bad:?}");
        }
        assert_eq!(qprogram_file_name("wave", 7), "wave-unit7.q");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn long_messages_are_clipped_on_a_character_boundary() {
        assert_eq!(clip_message("short"), "short");
        let long = "é".repeat(MAX_MESSAGE_CHARS + 5);
        let clipped = clip_message(&long);
        assert_eq!(clipped.chars().count(), MAX_MESSAGE_CHARS + 1);
        assert!(clipped.ends_with('…'));
        let exact = "x".repeat(MAX_MESSAGE_CHARS);
        assert_eq!(clip_message(&exact), exact);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn supported_extensions_name_every_format() {
        assert_eq!(supported_extensions(), ".csv, .json");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_selection_can_be_cleared() {
        let mut list = Listing::default();
        list.upsert(local("a.csv"));
        list.clear_selection();
        assert_eq!(list.selected_name(), None);
        assert_eq!(list.items().len(), 1);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn sizes_and_durations_read_well() {
        assert_eq!(format_bytes(999), "999 B");
        assert_eq!(format_bytes(1_500), "1.5 kB");
        assert_eq!(format_bytes(2_345_678), "2.3 MB");
        assert_eq!(format_duration_ms(0), "0:00.0");
        assert_eq!(format_duration_ms(65_340), "1:05.3");
        assert_eq!(format_duration_ms(3_600_000), "60:00.0");
    }
}
