//! The two file lists of the Files page as plain types: the show files kept in the
//! browser ([`LocalFile`], stored by [`crate::store`]) and the ones on the controller
//! ([`ShowSummary`]), each in a [`Listing`] with one selected entry.

use floatball_shared::api::ShowSummary;
use floatball_shared::show::{Layout, Show, import_csv};
use serde::{Deserialize, Serialize};

/// Distance between balls assumed for a CSV file without a layout line, mm.
pub const PREVIEW_PITCH_MM: f64 = 500.0;

/// The two show file formats the app reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FileKind {
    /// CSV keyframes (`time_ms,u0,u1,…`).
    Csv,
    /// The native JSON format.
    Json,
}

impl FileKind {
    /// The kind a file name's extension says (`.csv`, `.json`, any case).
    pub fn from_name(name: &str) -> Option<Self> {
        let (_, extension) = name.rsplit_once('.')?;
        match extension.to_ascii_lowercase().as_str() {
            "csv" => Some(FileKind::Csv),
            "json" => Some(FileKind::Json),
            _ => None,
        }
    }

    /// The `Content-Type` of an upload.
    pub fn content_type(self) -> &'static str {
        match self {
            FileKind::Csv => "text/csv",
            FileKind::Json => "application/json",
        }
    }

    /// The short label shown in lists.
    pub fn label(self) -> &'static str {
        match self {
            FileKind::Csv => "CSV",
            FileKind::Json => "JSON",
        }
    }
}

/// A show file kept in the browser.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LocalFile {
    /// The file name, with its extension (`wave.csv`).
    pub name: String,
    /// Its format.
    pub kind: FileKind,
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
            kind: FileKind::from_name(name)?,
            text,
            added_ms,
        })
    }

    /// The local copy of a show downloaded from the controller: `{name}.json`.
    pub fn downloaded(show_name: &str, json: String, added_ms: f64) -> Self {
        Self {
            name: format!("{show_name}.json"),
            kind: FileKind::Json,
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

    /// The show, parsed for the preview. A CSV file without a layout line is laid
    /// out as the most nearly square grid of its ball count.
    ///
    /// # Errors
    /// What is wrong with the file, in the shared parser's words.
    pub fn to_show(&self) -> Result<Show, String> {
        match self.kind {
            FileKind::Json => Show::from_json(&self.text).map_err(|err| err.to_string()),
            FileKind::Csv => {
                let units = csv_unit_count(&self.text).unwrap_or(1);
                import_csv(self.show_name(), &self.text, square_layout(units))
                    .map_err(|err| err.to_string())
            }
        }
    }
}

/// The number of ball columns in a CSV header (`time_ms,u0,u1` → 2), if there is a
/// header.
pub fn csv_unit_count(text: &str) -> Option<usize> {
    let header = text
        .lines()
        .map(str::trim)
        .find(|line| !line.is_empty() && !line.starts_with('#'))?;
    Some(header.split(',').count().saturating_sub(1))
}

/// The most nearly square grid with exactly `units` balls (rows ≤ columns).
pub fn square_layout(units: usize) -> Layout {
    let units = units.max(1);
    let rows = (1..=units)
        .take_while(|rows| rows * rows <= units)
        .filter(|rows| units.is_multiple_of(*rows))
        .last()
        .unwrap_or(1);
    Layout {
        rows: u32::try_from(rows).unwrap_or(1),
        cols: u32::try_from(units / rows).unwrap_or(u32::MAX),
        pitch_mm: PREVIEW_PITCH_MM,
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

#[cfg(test)]
mod tests {
    use super::*;

    fn local(name: &str) -> LocalFile {
        LocalFile::new(name, String::new(), 0.0).unwrap()
    }

    #[test]
    fn kinds_come_from_the_extension() {
        assert_eq!(FileKind::from_name("wave.CSV"), Some(FileKind::Csv));
        assert_eq!(FileKind::from_name("a.b.json"), Some(FileKind::Json));
        assert_eq!(FileKind::from_name("notes.txt"), None);
        assert_eq!(FileKind::from_name("csv"), None);
        assert!(LocalFile::new("x.png", String::new(), 0.0).is_none());
    }

    #[test]
    fn show_names_drop_the_extension() {
        assert_eq!(local("波浪.csv").show_name(), "波浪");
        assert_eq!(local("a.b.json").show_name(), "a.b");
        let copy = LocalFile::downloaded("wave", "{}".into(), 1.0);
        assert_eq!(copy.name, "wave.json");
        assert_eq!(copy.show_name(), "wave");
    }

    #[test]
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

    #[test]
    fn upsert_replaces_a_file_of_the_same_name() {
        let mut list = Listing::default();
        list.upsert(local("a.csv"));
        list.upsert(LocalFile::new("a.csv", "new".into(), 2.0).unwrap());
        assert_eq!(list.items().len(), 1);
        assert_eq!(list.get("a.csv").unwrap().text, "new");
    }

    #[test]
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

    #[test]
    fn csv_without_a_layout_is_previewed_as_a_square_grid() {
        assert_eq!(csv_unit_count("# rows=1 cols=2\ntime_ms,u0,u1\n"), Some(2));
        assert_eq!(csv_unit_count("\n\n"), None);
        let layout = square_layout(12);
        assert_eq!((layout.rows, layout.cols), (3, 4));
        let layout = square_layout(7);
        assert_eq!((layout.rows, layout.cols), (1, 7));
        let layout = square_layout(0);
        assert_eq!((layout.rows, layout.cols), (1, 1));

        let file = LocalFile::new(
            "four.csv",
            "time_ms,u0,u1,u2,u3\n0,100,100,100,100\n500,200,300,400,500\n".into(),
            0.0,
        )
        .unwrap();
        let show = file.to_show().unwrap();
        assert_eq!((show.layout.rows, show.layout.cols), (2, 2));
        assert_eq!(show.name, "four");
        assert_eq!(show.duration_ms(), 500);
    }

    #[test]
    fn unreadable_files_say_why() {
        let file = LocalFile::new("bad.csv", "time_ms,u0\n0,1\n5,2\n".into(), 0.0).unwrap();
        let error = file.to_show().unwrap_err();
        assert!(error.starts_with("line 3"), "{error}");
        let file = LocalFile::new("bad.json", "{".into(), 0.0).unwrap();
        assert!(file.to_show().unwrap_err().contains("not valid"));
    }

    #[test]
    fn sizes_and_durations_read_well() {
        assert_eq!(format_bytes(999), "999 B");
        assert_eq!(format_bytes(1_500), "1.5 kB");
        assert_eq!(format_bytes(2_345_678), "2.3 MB");
        assert_eq!(format_duration_ms(0), "0:00.0");
        assert_eq!(format_duration_ms(65_340), "1:05.3");
        assert_eq!(format_duration_ms(3_600_000), "60:00.0");
    }
}
