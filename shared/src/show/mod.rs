//! Shows: what every ball of a matrix does over time, independent of the hardware
//! (`docs/architecture.md` §3).
//!
//! A [`Show`] is a name, a [`Layout`] (rows × columns of balls) and one [`Track`] per
//! ball in row-major order. Positions are in **mm below the top** (0 = top, the
//! installation's travel = lowest), velocities in mm/s, durations in whole ms. A track
//! is the ball's start position (at rest) and a list of PVT rows, each "be at
//! `position_mm` moving at `velocity_mm_s` after `duration_ms`", evaluated with the
//! same [`Segment`] as the units run; plus optional colour keyframes for the preview.
//! A show may also carry output tracks for MBOX boxes' digital and analog outputs
//! ([`mod@outputs`]; UIM2503 installations ignore them).
//!
//! - this module: the model and the native file format (JSON, `docs/show-format.md`);
//! - [`mod@import`]: the one way a file (native JSON or CSV) becomes a show, refused
//!   in words the user can act on, and checked against an installation before it is
//!   stored;
//! - [`csv`]: keyframe import from 3D tools;
//! - [`mod@cut`]: a show cut at a time, for a start from inside it;
//! - [`demo`]: the demo show (a travelling wave) the tests and benches share;
//! - [`mod@outputs`]: MBOX output tracks and their values at any time;
//! - [`mod@validate`]: checks against an installation's limits;
//! - [`sample`]: positions and colours of every ball at any time, for the preview.
//!
//! ```
//! use floatball_shared::show::{Layout, Show, Track, TrackRow};
//!
//! # fn main() -> Result<(), floatball_shared::show::ShowError> {
//! let track = Track {
//!     start_mm: 1000.0,
//!     rows: vec![TrackRow::new(1500.0, 0.0, 250)],
//!     colours: Vec::new(),
//! };
//! let show = Show {
//!     outputs: Vec::new(),
//!     name: "drop".into(),
//!     layout: Layout { rows: 1, cols: 1, pitch_mm: 500.0 },
//!     tracks: vec![track],
//! };
//! let json = show.to_json()?;
//! assert_eq!(Show::from_json(&json)?, show);
//! assert_eq!(show.duration_ms(), 250);
//! # Ok(())
//! # }
//! ```

pub mod csv;
pub mod csv_curve;
pub mod cut;
pub mod demo;
pub mod import;
pub mod outputs;
pub mod sample;
pub mod validate;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::codes::{Code, Coded, Params};
use crate::motion::Segment;
use crate::params;

pub use csv::{CsvError, CsvProblem, ImportError, ImportLimits, import_csv, import_csv_within};
pub use csv_curve::CurveLimits;
pub use cut::Cut;
pub use import::{Refused, ShowFormat, UploadLimits, import, read_json};
pub use outputs::{AnalogKey, DigitalKey, OutputProblem, OutputSample, OutputTrack};
pub use sample::Sampler;
pub use validate::{Limits, UnitRef, Violation, ViolationKind, validate};

/// The `"format"` of a native show file.
pub const FORMAT: &str = "floatball-show";

/// The native file format version this code reads and writes.
pub const VERSION: u64 = 1;

/// A UFQ750's travel, mm (manual: 7.5 m).
pub const DEFAULT_TRAVEL_MM: f64 = 7500.0;

/// Distance between neighbouring balls, mm, unless the installation configures it
/// (`pitch_mm`) — also what is assumed when a show's installation is not known (a CSV
/// file without a layout line, read in the web app).
pub const DEFAULT_PITCH_MM: f64 = 500.0;

/// The grid of balls, seen from below: `rows` × `cols`, `pitch_mm` apart.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Layout {
    /// Number of rows of balls.
    pub rows: u32,
    /// Number of balls in each row.
    pub cols: u32,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
}

impl Layout {
    /// Number of balls, `rows × cols`.
    #[must_use]
    pub fn unit_count(&self) -> usize {
        self.rows as usize * self.cols as usize
    }

    /// The 0-based (row, column) of the ball at row-major `unit` index.
    #[must_use]
    pub fn cell(&self, unit: usize) -> (u32, u32) {
        let cols = self.cols.max(1) as usize;
        (
            u32::try_from(unit / cols).unwrap_or(u32::MAX),
            u32::try_from(unit % cols).unwrap_or(u32::MAX),
        )
    }
}

/// One PVT row of a track: be at `position_mm` moving at `velocity_mm_s` after
/// `duration_ms`. In a file it is the array `[position_mm, velocity_mm_s, duration_ms]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(from = "(f64, f64, u32)", into = "(f64, f64, u32)")]
pub struct TrackRow {
    /// Target position, mm below the top.
    pub position_mm: f64,
    /// Velocity at the target, mm/s (positive = downwards).
    pub velocity_mm_s: f64,
    /// Duration, ms (a unit accepts 10–255).
    pub duration_ms: u32,
}

impl TrackRow {
    /// A row reaching `position_mm` at `velocity_mm_s` after `duration_ms`.
    #[must_use]
    pub const fn new(position_mm: f64, velocity_mm_s: f64, duration_ms: u32) -> Self {
        Self {
            position_mm,
            velocity_mm_s,
            duration_ms,
        }
    }
}

impl From<(f64, f64, u32)> for TrackRow {
    fn from((position_mm, velocity_mm_s, duration_ms): (f64, f64, u32)) -> Self {
        Self::new(position_mm, velocity_mm_s, duration_ms)
    }
}

impl From<TrackRow> for (f64, f64, u32) {
    fn from(row: TrackRow) -> Self {
        (row.position_mm, row.velocity_mm_s, row.duration_ms)
    }
}

/// A colour keyframe for the preview (the units' lamps are not controlled over the
/// protocol). Between keyframes the colour changes linearly; before the first and after
/// the last it holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColourKey {
    /// Show time, ms.
    pub time_ms: u64,
    /// Red, green, blue.
    pub rgb: [u8; 3],
}

/// One ball's motion: it starts at rest at `start_mm`, then runs `rows` in order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Track {
    /// Start position, mm below the top; the ball is at rest there at time 0.
    pub start_mm: f64,
    /// The PVT rows.
    #[serde(deserialize_with = "rows_exactly")]
    pub rows: Vec<TrackRow>,
    /// Colour keyframes in strictly increasing time (may be empty).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub colours: Vec<ColourKey>,
}

/// A track's rows as read from a file, their vector no larger than they are: a JSON
/// array does not say its length, so the vector grows by doubling while it is read
/// (301 rows would keep room for 512, 70 % more than the rows: 51 MB more for a
/// 10,000-ball minute). Shrunk as soon as each track's rows are read, so the spare
/// room is never held for more than one track at a time.
fn rows_exactly<'de, D>(deserializer: D) -> Result<Vec<TrackRow>, D::Error>
where
    D: serde::Deserializer<'de>,
{
    let mut rows = Vec::<TrackRow>::deserialize(deserializer)?;
    rows.shrink_to_fit();
    Ok(rows)
}

impl Track {
    /// Total duration of the rows, ms.
    #[must_use]
    pub fn duration_ms(&self) -> u64 {
        self.rows.iter().map(|row| u64::from(row.duration_ms)).sum()
    }

    /// Each row as a segment in mm, mm/s and seconds, with its start time in ms.
    pub fn segments(&self) -> impl Iterator<Item = (u64, Segment)> + '_ {
        let mut from = (self.start_mm, 0.0, 0u64);
        self.rows.iter().map(move |row| {
            let (p0, v0, start_ms) = from;
            let segment = Segment::new(
                p0,
                v0,
                row.position_mm,
                row.velocity_mm_s,
                f64::from(row.duration_ms) / 1000.0,
            );
            from = (
                row.position_mm,
                row.velocity_mm_s,
                start_ms + u64::from(row.duration_ms),
            );
            (start_ms, segment)
        })
    }
}

/// A show: a name, the layout it was made for and one track per ball, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct Show {
    /// A name for people.
    pub name: String,
    /// The grid the show was made for.
    pub layout: Layout,
    /// One track per ball, row-major (`tracks[row * cols + col]`).
    pub tracks: Vec<Track>,
    /// The MBOX boxes' output tracks, at most one per box (may be empty: outputs 0).
    pub outputs: Vec<OutputTrack>,
}

/// A show file that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ShowError {
    /// The text is not JSON, or a field is missing, unknown or of the wrong type.
    #[error("the show file is not valid: {message}")]
    Invalid {
        /// What serde found, with its line and column.
        message: String,
    },
    /// The JSON is not a Floatball show.
    #[error("this is not a Floatball show file: \"format\" is {found:?}, expected \"{FORMAT}\"")]
    WrongFormat {
        /// The `"format"` found (empty when missing).
        found: String,
    },
    /// A version this code does not read (a newer Floatball wrote it).
    #[error(
        "this show file is format version {found}, but this Floatball reads version {VERSION}; \
         update Floatball to open it"
    )]
    UnsupportedVersion {
        /// The `"version"` found.
        found: u64,
    },
    /// The layout has no balls or a pitch that is not a positive number.
    #[error("the layout must have at least one row and one column and a positive pitch_mm")]
    EmptyLayout,
    /// The number of tracks differs from rows × cols.
    #[error("the show has {tracks} tracks but its layout is {rows} × {cols} = {} balls", *rows as usize * *cols as usize)]
    TrackCount {
        /// Tracks in the show.
        tracks: usize,
        /// Layout rows.
        rows: u32,
        /// Layout columns.
        cols: u32,
    },
    /// A position or velocity is not a finite number.
    #[error("track {unit}: a position or velocity is not a finite number")]
    NotFinite {
        /// The track's index.
        unit: usize,
    },
    /// An output track that cannot be played.
    #[error("{}", output_message(*box_index, *key, *problem))]
    Output {
        /// The box of the track.
        box_index: usize,
        /// The keyframe: whether analog, and its index; `None` for the whole track.
        key: Option<(bool, usize)>,
        /// What is wrong.
        problem: OutputProblem,
    },
    /// Colour keyframes out of order.
    #[error("track {unit}: colour keyframe {index} is not later than the one before")]
    ColourOrder {
        /// The track's index.
        unit: usize,
        /// The keyframe's index.
        index: usize,
    },
}

/// The file as read.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileIn {
    format: String,
    version: u64,
    name: String,
    layout: Layout,
    units: Vec<Track>,
    #[serde(default)]
    outputs: Vec<OutputTrack>,
}

/// The file as written, borrowing the show.
#[derive(Serialize)]
struct FileOut<'a> {
    format: &'static str,
    version: u64,
    name: &'a str,
    layout: &'a Layout,
    units: &'a [Track],
    #[serde(skip_serializing_if = "<[OutputTrack]>::is_empty")]
    outputs: &'a [OutputTrack],
}

/// Just the identifying fields, to explain why a file does not read as this version.
#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<u64>,
}

impl Show {
    /// Reads a native show file and [checks](Self::check) it.
    ///
    /// # Errors
    /// [`ShowError`]: not JSON or not the expected shape, another format, another
    /// version (refused with a message saying so), or an inconsistent show.
    pub fn from_json(text: &str) -> Result<Self, ShowError> {
        Self::from_file(serde_json::from_str::<FileIn>(text), || Some(text))
    }

    /// Reads a native show file from `reader` as [`from_json`](Self::from_json) reads
    /// its text, without holding the text: a 10,000-ball minute is about 90 MB of
    /// JSON for 72 MB of show. A file that does not read is refused in serde's words
    /// only; [`from_json`](Self::from_json) on its text also says when it is another
    /// format or a newer version.
    ///
    /// # Errors
    /// As [`from_json`](Self::from_json).
    pub fn from_json_reader(reader: impl std::io::Read) -> Result<Self, ShowError> {
        Self::from_file(serde_json::from_reader::<_, FileIn>(reader), || None)
    }

    /// The show of a file as serde read it; `text` gives the file's text to explain a
    /// foreign or newer file.
    fn from_file<'a>(
        file: Result<FileIn, serde_json::Error>,
        text: impl FnOnce() -> Option<&'a str>,
    ) -> Result<Self, ShowError> {
        let file = match file {
            Ok(file) => file,
            Err(error) => {
                // Explain a foreign or newer file better than by its first odd field.
                if let Some(header) =
                    text().and_then(|text| serde_json::from_str::<Header>(text).ok())
                {
                    check_header(header.format.as_deref(), header.version)?;
                }
                return Err(ShowError::Invalid {
                    message: error.to_string(),
                });
            }
        };
        check_header(Some(&file.format), Some(file.version))?;
        let show = Self {
            name: file.name,
            layout: file.layout,
            tracks: file.units,
            outputs: file.outputs,
        };
        show.check()?;
        Ok(show)
    }

    /// Writes the native show file (compact JSON).
    ///
    /// # Errors
    /// [`ShowError::Invalid`] if serialisation fails.
    pub fn to_json(&self) -> Result<String, ShowError> {
        serde_json::to_string(&self.file()).map_err(|error| ShowError::Invalid {
            message: error.to_string(),
        })
    }

    /// Writes the native show file ([`to_json`](Self::to_json)'s bytes) to `writer`
    /// without building it in memory first (a 10,000-ball minute is about 90 MB).
    ///
    /// # Errors
    /// [`ShowError::Invalid`] if serialisation or the writer fails.
    pub fn write_json(&self, writer: impl std::io::Write) -> Result<(), ShowError> {
        serde_json::to_writer(writer, &self.file()).map_err(|error| ShowError::Invalid {
            message: error.to_string(),
        })
    }

    /// The size of its native file ([`to_json`](Self::to_json)) in bytes, counted
    /// without writing it.
    #[must_use]
    pub fn json_bytes(&self) -> usize {
        json_len(&self.file())
    }

    fn file(&self) -> FileOut<'_> {
        FileOut {
            format: FORMAT,
            version: VERSION,
            name: &self.name,
            layout: &self.layout,
            units: &self.tracks,
            outputs: &self.outputs,
        }
    }

    /// Checks that the show is consistent in itself (not against an installation: see
    /// [`validate()`]): a non-empty layout, one track per ball, finite numbers, colour
    /// keyframes in order. [`from_json`](Self::from_json) and [`import_csv`] only
    /// return shows that pass; call it on shows built in code.
    ///
    /// # Errors
    /// The first inconsistency found.
    pub fn check(&self) -> Result<(), ShowError> {
        let layout = self.layout;
        if layout.rows == 0
            || layout.cols == 0
            || !layout.pitch_mm.is_finite()
            || layout.pitch_mm <= 0.0
        {
            return Err(ShowError::EmptyLayout);
        }
        if self.tracks.len() != layout.unit_count() {
            return Err(ShowError::TrackCount {
                tracks: self.tracks.len(),
                rows: layout.rows,
                cols: layout.cols,
            });
        }
        for (unit, track) in self.tracks.iter().enumerate() {
            let finite = track.start_mm.is_finite()
                && track
                    .rows
                    .iter()
                    .all(|row| row.position_mm.is_finite() && row.velocity_mm_s.is_finite());
            if !finite {
                return Err(ShowError::NotFinite { unit });
            }
            if let Some(index) = track
                .colours
                .windows(2)
                .position(|pair| pair[1].time_ms <= pair[0].time_ms)
            {
                return Err(ShowError::ColourOrder {
                    unit,
                    index: index + 1,
                });
            }
        }
        let duration_ms = self.duration_ms();
        for (index, output) in self.outputs.iter().enumerate() {
            let box_index = output.box_index;
            let found = if self.outputs[..index]
                .iter()
                .any(|other| other.box_index == box_index)
            {
                Some((None, OutputProblem::BoxTwice))
            } else {
                output.problem(duration_ms)
            };
            if let Some((key, problem)) = found {
                return Err(ShowError::Output {
                    box_index,
                    key,
                    problem,
                });
            }
        }
        Ok(())
    }

    /// The first box an output track names that an installation with `boxes` MBOX
    /// boxes lacks.
    #[must_use]
    pub fn output_box_beyond(&self, boxes: usize) -> Option<usize> {
        self.outputs
            .iter()
            .map(|output| output.box_index)
            .find(|&box_index| box_index >= boxes)
    }

    /// The outputs of box `box_index` at show time `t_ms`: 0 without a track for it,
    /// and at and after the show's end.
    #[must_use]
    pub fn outputs_at(&self, box_index: usize, t_ms: u64) -> OutputSample {
        if t_ms >= self.duration_ms() {
            return OutputSample::default();
        }
        self.output_sample(box_index, t_ms)
    }

    /// The outputs of boxes `0..boxes` at `t_ms`, as [`Show::outputs_at`] gives each:
    /// the show's duration (every row of every track) is worked out once, and not at
    /// all without output tracks — a frame of a thousand boxes must not sum it a
    /// thousand times.
    #[must_use]
    pub fn outputs_of_boxes(&self, boxes: usize, t_ms: u64) -> Vec<OutputSample> {
        if self.outputs.is_empty() || t_ms >= self.duration_ms() {
            return vec![OutputSample::default(); boxes];
        }
        (0..boxes)
            .map(|box_index| self.output_sample(box_index, t_ms))
            .collect()
    }

    fn output_sample(&self, box_index: usize, t_ms: u64) -> OutputSample {
        self.outputs
            .iter()
            .find(|output| output.box_index == box_index)
            .map_or_else(OutputSample::default, |output| output.sample(t_ms))
    }

    /// The longest track's duration, ms.
    #[must_use]
    pub fn duration_ms(&self) -> u64 {
        self.tracks
            .iter()
            .map(Track::duration_ms)
            .max()
            .unwrap_or(0)
    }
}

/// The length of `value` as compact JSON.
pub(crate) fn json_len(value: &impl serde::Serialize) -> usize {
    struct Count(usize);
    impl std::io::Write for Count {
        fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
            self.0 += bytes.len();
            Ok(bytes.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let mut count = Count(0);
    // Shows are numbers, strings and arrays of them: writing them cannot fail.
    let _ = serde_json::to_writer(&mut count, value);
    count.0
}

/// Why a show's output track for `box_index` cannot play on `boxes` MBOX boxes.
pub(crate) fn output_box_message(box_index: usize, boxes: usize) -> String {
    if boxes == 0 {
        format!("the show has outputs for box {box_index} but the installation has no MBOX boxes")
    } else {
        format!(
            "the show has outputs for box {box_index} but the installation's MBOX boxes are 0–{}",
            boxes - 1
        )
    }
}

fn output_message(box_index: usize, key: Option<(bool, usize)>, problem: OutputProblem) -> String {
    let place = match key {
        None => format!("outputs of box {box_index}"),
        Some((analog, index)) => format!(
            "outputs of box {box_index}, {} keyframe {index}",
            if analog { "analog" } else { "digital" }
        ),
    };
    let what = match problem {
        OutputProblem::BoxTwice => "the box has more than one output track".to_owned(),
        OutputProblem::ReservedBits { bits } => format!(
            "bits {bits:#06x} set reserved bits; only outputs 1–12 (bits 0x0001–0x0800, \
             at most 4095) exist"
        ),
        OutputProblem::Channel { channel } => {
            format!("analog channel {channel} does not exist; a box has channels 0 and 1")
        }
        OutputProblem::Order => {
            "time_ms is not later than the keyframe before (of the same channel)".to_owned()
        }
        OutputProblem::AfterEnd {
            time_ms,
            duration_ms,
        } => format!("time_ms {time_ms} is after the show's end at {duration_ms} ms"),
    };
    format!("{place}: {what}")
}

fn check_header(format: Option<&str>, version: Option<u64>) -> Result<(), ShowError> {
    match (format, version) {
        (Some(FORMAT), Some(VERSION) | None) => Ok(()),
        (Some(FORMAT), Some(found)) => Err(ShowError::UnsupportedVersion { found }),
        (found, _) => Err(ShowError::WrongFormat {
            found: found.unwrap_or_default().to_owned(),
        }),
    }
}

impl Coded for ShowError {
    fn code(&self) -> Code {
        match self {
            Self::Invalid { .. } => Code::ShowInvalid,
            Self::WrongFormat { .. } => Code::ShowWrongFormat,
            Self::UnsupportedVersion { .. } => Code::ShowUnsupportedVersion,
            Self::EmptyLayout => Code::ShowEmptyLayout,
            Self::TrackCount { .. } => Code::ShowTrackCount,
            Self::NotFinite { .. } => Code::ShowNotFinite,
            Self::Output { .. } => Code::ShowOutput,
            Self::ColourOrder { .. } => Code::ShowColourOrder,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Invalid { message } => params! {"message" => message},
            Self::WrongFormat { found } => params! {"found" => found},
            Self::UnsupportedVersion { found } => params! {"found" => found, "version" => VERSION},
            Self::EmptyLayout => Params::new(),
            Self::TrackCount { tracks, rows, cols } => {
                params! {"tracks" => tracks, "rows" => rows, "cols" => cols}
            }
            Self::NotFinite { unit } => params! {"track" => unit},
            Self::Output {
                box_index,
                key,
                problem,
            } => params! {
                "box" => box_index,
                "detail" => output_message(*box_index, *key, *problem),
            },
            Self::ColourOrder { unit, index } => params! {"track" => unit, "index" => index},
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn a_show_read_from_a_stream_is_the_show_read_from_its_text_with_no_spare_room() {
        let show = demo::wave(3, 4, 300, 200);
        let json = show.to_json().expect("json");
        let mut written = Vec::new();
        show.write_json(&mut written).expect("write");
        assert_eq!(written, json.as_bytes());
        let from_text = Show::from_json(&json).expect("text");
        let from_stream = Show::from_json_reader(json.as_bytes()).expect("stream");
        assert_eq!(from_text, show);
        assert_eq!(from_stream, show);
        for track in from_text.tracks.iter().chain(&from_stream.tracks) {
            assert!(track.rows.len() > 64);
            assert_eq!(track.rows.capacity(), track.rows.len());
        }
        let cut = &json[..json.len() / 2];
        let refused = Show::from_json_reader(cut.as_bytes());
        assert!(
            matches!(refused, Err(ShowError::Invalid { .. })),
            "{refused:?}"
        );
        assert_eq!(refused, Show::from_json(cut));
    }

    const EXAMPLE: &str = r#"{
        "format": "floatball-show",
        "version": 1,
        "name": "two balls",
        "layout": {"rows": 1, "cols": 2, "pitch_mm": 600},
        "units": [
            {"start_mm": 500, "rows": [[1000, 2000, 250], [1500, 0, 250]],
             "colours": [{"time_ms": 0, "rgb": [255, 0, 0]}, {"time_ms": 500, "rgb": [0, 0, 255]}]},
            {"start_mm": 500, "rows": [[500, 0, 250], [500, 0, 250]]}
        ]
    }"#;

    #[test]
    fn reads_and_round_trips_a_show() {
        let show = Show::from_json(EXAMPLE).unwrap();
        assert_eq!(show.name, "two balls");
        assert_eq!(show.layout.unit_count(), 2);
        assert_eq!(show.tracks[0].rows[0], TrackRow::new(1000.0, 2000.0, 250));
        assert_eq!(show.tracks[0].colours[1].rgb, [0, 0, 255]);
        assert!(show.tracks[1].colours.is_empty());
        assert_eq!(show.duration_ms(), 500);
        let json = show.to_json().unwrap();
        assert!(json.starts_with(r#"{"format":"floatball-show","version":1,"#));
        assert!(json.contains("[1000.0,2000.0,250]"));
        assert_eq!(Show::from_json(&json).unwrap(), show);
        assert_eq!(show.json_bytes(), json.len());
    }

    #[test]
    fn segments_chain_from_rest_at_the_start() {
        let show = Show::from_json(EXAMPLE).unwrap();
        let segments: Vec<_> = show.tracks[0].segments().collect();
        assert_eq!(segments[0].0, 0);
        assert_eq!(
            segments[0].1,
            Segment::new(500.0, 0.0, 1000.0, 2000.0, 0.25)
        );
        assert_eq!(segments[1].0, 250);
        assert_eq!(
            segments[1].1,
            Segment::new(1000.0, 2000.0, 1500.0, 0.0, 0.25)
        );
    }

    #[test]
    fn a_future_version_is_refused_clearly() {
        let newer = EXAMPLE.replace(r#""version": 1"#, r#""version": 2"#);
        let error = Show::from_json(&newer).unwrap_err();
        assert_eq!(error, ShowError::UnsupportedVersion { found: 2 });
        assert!(error.to_string().contains("update Floatball"));
        // Even when the newer file has fields this version does not know.
        let newer = newer.replace(r#""name""#, r#""tempo": 120, "name""#);
        assert_eq!(
            Show::from_json(&newer),
            Err(ShowError::UnsupportedVersion { found: 2 })
        );
    }

    #[test]
    fn other_files_are_refused() {
        let other = EXAMPLE.replace("floatball-show", "something-else");
        assert_eq!(
            Show::from_json(&other),
            Err(ShowError::WrongFormat {
                found: "something-else".into()
            })
        );
        assert!(matches!(
            Show::from_json("{\"format\": \"floatball-show\""),
            Err(ShowError::Invalid { .. })
        ));
        let error = Show::from_json(r#"{"hello": 1}"#).unwrap_err();
        assert_eq!(error, ShowError::WrongFormat { found: "".into() });
        let typo = EXAMPLE.replace("pitch_mm", "pich_mm");
        let error = Show::from_json(&typo).unwrap_err();
        assert!(error.to_string().contains("pich_mm"), "{error}");
        let bad_row = EXAMPLE.replace("[1500, 0, 250]", "[1500, 0, -250]");
        assert!(matches!(
            Show::from_json(&bad_row),
            Err(ShowError::Invalid { .. })
        ));
    }

    #[test]
    fn inconsistent_shows_are_refused() {
        let missing = EXAMPLE.replace(r#""cols": 2"#, r#""cols": 3"#);
        assert_eq!(
            Show::from_json(&missing),
            Err(ShowError::TrackCount {
                tracks: 2,
                rows: 1,
                cols: 3
            })
        );
        let empty = EXAMPLE.replace(r#""rows": 1,"#, r#""rows": 0,"#);
        assert_eq!(Show::from_json(&empty), Err(ShowError::EmptyLayout));
        let order = EXAMPLE.replace(r#""time_ms": 500"#, r#""time_ms": 0"#);
        assert_eq!(
            Show::from_json(&order),
            Err(ShowError::ColourOrder { unit: 0, index: 1 })
        );
        let mut show = Show::from_json(EXAMPLE).unwrap();
        show.tracks[1].rows[0].velocity_mm_s = f64::NAN;
        assert_eq!(show.check(), Err(ShowError::NotFinite { unit: 1 }));
    }

    /// `EXAMPLE` (500 ms long) with output tracks.
    fn with_outputs(outputs: &str) -> String {
        EXAMPLE.replace(
            r#""name": "two balls","#,
            &format!(r#""name": "two balls", "outputs": {outputs},"#),
        )
    }

    #[test]
    fn files_without_outputs_read_and_write_exactly_as_before() {
        let old = concat!(
            r#"{"format":"floatball-show","version":1,"name":"one","#,
            r#""layout":{"rows":1,"cols":1,"pitch_mm":500.0},"#,
            r#""units":[{"start_mm":1000.0,"rows":[[1500.0,0.0,250]]}]}"#
        );
        let show = Show::from_json(old).unwrap();
        assert!(show.outputs.is_empty());
        assert_eq!(show.to_json().unwrap(), old);
        assert_eq!(show.json_bytes(), old.len());
        assert!(
            !Show::from_json(EXAMPLE)
                .unwrap()
                .to_json()
                .unwrap()
                .contains("outputs")
        );
    }

    #[test]
    fn output_tracks_round_trip() {
        let text = with_outputs(
            r#"[{"box": 1, "digital": [{"time_ms": 0, "bits": 4095}, {"time_ms": 250, "bits": 0}],
                 "analog": [{"time_ms": 0, "channel": 1, "value": 65535}]},
                {"box": 0, "analog": [{"time_ms": 100, "channel": 0, "value": 7}]}]"#,
        );
        let show = Show::from_json(&text).unwrap();
        assert_eq!(show.outputs.len(), 2);
        assert_eq!(
            show.outputs[0].digital[0],
            DigitalKey {
                time_ms: 0,
                bits: 4095
            }
        );
        assert!(show.outputs[1].digital.is_empty());
        let json = show.to_json().unwrap();
        assert!(json.contains(r#""outputs":[{"box":1,"digital":[{"time_ms":0,"bits":4095}"#));
        assert!(json.contains(r#"{"box":0,"analog":[{"time_ms":100,"channel":0,"value":7}]}"#));
        assert_eq!(Show::from_json(&json).unwrap(), show);
        assert_eq!(show.json_bytes(), json.len());
    }

    #[test]
    fn unplayable_output_tracks_are_refused_with_what_is_wrong() {
        let refused = |outputs: &str| Show::from_json(&with_outputs(outputs)).unwrap_err();
        let error = refused(r#"[{"box": 0, "digital": [{"time_ms": 0, "bits": 4096}]}]"#);
        assert_eq!(
            error,
            ShowError::Output {
                box_index: 0,
                key: Some((false, 0)),
                problem: OutputProblem::ReservedBits { bits: 4096 }
            }
        );
        assert!(error.to_string().contains("reserved bits"), "{error}");
        let error = refused(
            r#"[{"box": 0, "digital": [{"time_ms": 10, "bits": 1}, {"time_ms": 10, "bits": 0}]}]"#,
        );
        assert_eq!(
            error.to_string(),
            "outputs of box 0, digital keyframe 1: time_ms is not later than the keyframe \
             before (of the same channel)"
        );
        // Each analog channel has its own order.
        let both = r#"[{"box": 0, "analog": [{"time_ms": 10, "channel": 0, "value": 1},
                        {"time_ms": 5, "channel": 1, "value": 1}]}]"#;
        assert!(Show::from_json(&with_outputs(both)).is_ok());
        let error = refused(&both.replace(r#""channel": 1"#, r#""channel": 0"#));
        assert!(matches!(
            error,
            ShowError::Output {
                key: Some((true, 1)),
                problem: OutputProblem::Order,
                ..
            }
        ));
        let error =
            refused(r#"[{"box": 3, "analog": [{"time_ms": 0, "channel": 2, "value": 1}]}]"#);
        assert_eq!(
            error.to_string(),
            "outputs of box 3, analog keyframe 0: analog channel 2 does not exist; a box has \
             channels 0 and 1"
        );
        let error = refused(r#"[{"box": 0, "digital": [{"time_ms": 501, "bits": 1}]}]"#);
        assert_eq!(
            error.to_string(),
            "outputs of box 0, digital keyframe 0: time_ms 501 is after the show's end at \
             500 ms"
        );
        let error = refused(r#"[{"box": 1}, {"box": 1}]"#);
        assert_eq!(
            error.to_string(),
            "outputs of box 1: the box has more than one output track"
        );
        let error =
            refused(r#"[{"box": 0, "analog": [{"time_ms": 0, "channel": 0, "value": 65536}]}]"#);
        assert!(matches!(error, ShowError::Invalid { .. }));
        assert!(error.to_string().contains("u16"), "{error}");
        let error = refused(r#"[{"box": 0, "digital": [{"at_ms": 0, "bits": 1}]}]"#);
        assert!(error.to_string().contains("at_ms"), "{error}");
    }

    /// The fenced block after `opening` in the format's documentation.
    fn documented(opening: &str) -> &'static str {
        let doc = include_str!("../../../docs/show-format.md");
        let start = doc.find(opening).unwrap() + opening.len();
        let end = start + doc[start..].find("```").unwrap();
        &doc[start..end]
    }

    #[test]
    fn the_documented_examples_are_valid() {
        let show = Show::from_json(documented("```json\n")).unwrap();
        assert_eq!(show.tracks.len(), 4);
        assert_eq!(show.duration_ms(), 1000);
        assert_eq!(validate(&show, &Limits::for_layout(2, 2)), []);
        let installation = Layout {
            rows: 1,
            cols: 1,
            pitch_mm: 1.0,
        };
        let show = import_csv("doc", documented("```text\n"), installation).unwrap();
        assert_eq!(show.layout.unit_count(), 3);
        assert_eq!(show.tracks[2].rows[2].position_mm, 950.0);
        let show = Show::from_json(documented("<!-- outputs example -->\n```json\n")).unwrap();
        assert_eq!(show.duration_ms(), 500);
        assert_eq!(show.outputs[0].analog.len(), 3);
        let at = |t_ms| {
            let sample = show.outputs_at(0, t_ms);
            (sample.digital_bits, sample.analog)
        };
        assert_eq!(at(0), (1, [0, 0]));
        assert_eq!(at(250), (4095, [32768, 32768]));
        assert_eq!(at(500), (0, [0, 0]));
        assert_eq!(validate(&show, &Limits::for_layout(1, 1)), []);
    }

    #[test]
    fn cells_are_row_major() {
        let layout = Layout {
            rows: 3,
            cols: 4,
            pitch_mm: 500.0,
        };
        assert_eq!(layout.cell(0), (0, 0));
        assert_eq!(layout.cell(5), (1, 1));
        assert_eq!(layout.cell(11), (2, 3));
    }
}
