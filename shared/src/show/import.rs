//! The one way a show file becomes a [`Show`]: the bridge's upload, the bridge reading
//! its store, and the web app's preview all call [`import`].
//!
//! A file is bytes in one of the [`ShowFormat`]s. [`import`] reads them as UTF-8, then
//! as the native JSON file or as CSV keyframes ([`super::csv`]), and names the show.
//! With an installation's [`UploadLimits`] (the bridge, before it stores an upload) it
//! also refuses what that installation cannot run: an empty show, one longer than
//! `max_duration` or larger than `max_bytes` as stored (a CSV's from its keyframes,
//! before a row is built), and every violation of the motion limits ([`validate()`]).
//! Without them (the preview, which shows violations instead) the show is only read.
//!
//! Every refusal is a [`Refused`]: one sentence for the user ([`Display`]) and each
//! problem in detail ([`Refused::details`]).
//!
//! [`Display`]: core::fmt::Display
//!
//! ```
//! use floatball_shared::show::{Layout, ShowFormat, import};
//!
//! let layout = Layout { rows: 1, cols: 2, pitch_mm: 500.0 };
//! let csv = b"time_ms,u0,u1\n0,100,200\n500,300,200\n";
//! let show = import("wave", csv, ShowFormat::Csv, Some(layout), None)?;
//! assert_eq!((show.name.as_str(), show.duration_ms()), ("wave", 500));
//! # Ok::<(), floatball_shared::show::Refused>(())
//! ```

use std::fmt::Write as _;

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::api::Problem;
use crate::codes::{Code, Coded, Params};
use crate::params;

use super::csv::{self, CsvError, CsvProblem, ImportError, ImportLimits};
use super::csv_curve::CurveLimits;
use super::{Layout, Limits, Show, ShowError, Violation, output_box_message, validate};

/// Most problems [`Refused::details`] lists; the rest are counted.
pub const MAX_LISTED_PROBLEMS: usize = 10_000;

/// How a show file is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShowFormat {
    /// CSV keyframes (`time_ms,u0,u1,…`, [`super::csv`]).
    Csv,
    /// The native JSON show file (`docs/show-format.md`).
    Json,
}

impl ShowFormat {
    /// Every format.
    pub const ALL: [Self; 2] = [Self::Csv, Self::Json];

    /// The format a file name's extension says (`.csv`, `.json`, any case).
    #[must_use]
    pub fn from_file_name(name: &str) -> Option<Self> {
        let (_, extension) = name.rsplit_once('.')?;
        Self::ALL
            .into_iter()
            .find(|format| extension.eq_ignore_ascii_case(format.extension()))
    }

    /// The file name extension, without the dot.
    #[must_use]
    pub fn extension(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::Json => "json",
        }
    }

    /// The media type (`Content-Type`) of a file in this format.
    #[must_use]
    pub fn content_type(self) -> &'static str {
        match self {
            Self::Csv => "text/csv",
            Self::Json => "application/json",
        }
    }

    /// The short name shown to people.
    #[must_use]
    pub fn label(self) -> &'static str {
        match self {
            Self::Csv => "CSV",
            Self::Json => "JSON",
        }
    }
}

/// What an installation takes: the bounds [`import`] checks before a show is stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UploadLimits {
    /// The installation and its motion limits, which every ball must keep.
    pub motion: Limits,
    /// Longest show, ms (`[uploads] max_duration`).
    pub max_duration_ms: u64,
    /// Largest native show file as stored ([`Show::to_json`]), bytes (`[uploads]
    /// max_bytes`).
    pub max_json_bytes: usize,
    /// The installation's MBOX boxes, which output tracks must name; `None` where
    /// outputs are ignored (UIM2503).
    pub mbox_boxes: Option<usize>,
}

/// Why a show file is refused.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum Refused {
    /// The bytes are not UTF-8.
    #[error("the show file is not UTF-8 text")]
    NotUtf8 {
        /// The first byte that is not part of a UTF-8 character, 1-based.
        byte: usize,
    },
    /// Not a native show file.
    #[error("the show file cannot be read")]
    Unreadable(ShowError),
    /// CSV keyframes that cannot be converted.
    #[error("the CSV keyframes cannot be imported")]
    Csv(CsvError),
    /// No motion: one keyframe, or no rows.
    #[error("the show is empty: it has no motion")]
    Empty(ShowFormat),
    /// A CSV keyframe later than the longest show allowed.
    #[error(
        "the show is longer than the limit of {} ([uploads] max_duration)",
        human_duration(*max_duration_ms)
    )]
    KeyframeTooLate {
        /// The limit, ms.
        max_duration_ms: u64,
        /// The keyframe, by line.
        error: CsvError,
    },
    /// A show that lasts longer than allowed.
    #[error(
        "the show is longer than the limit of {} ([uploads] max_duration)",
        human_duration(*max_duration_ms)
    )]
    TooLong {
        /// The limit, ms.
        max_duration_ms: u64,
        /// The show's duration, ms.
        duration_ms: u64,
    },
    /// CSV keyframes that would become a native file over the size limit, known before
    /// a row is built.
    #[error(
        "the show as stored would be larger than the limit of {max_bytes} bytes \
         ([uploads] max_bytes)"
    )]
    ConvertedTooLarge {
        /// The size (or, when not `exact`, the least size) of the converted show, bytes.
        bytes: usize,
        /// The limit, bytes.
        max_bytes: usize,
        /// Whether `bytes` is the exact size rather than a lower bound.
        exact: bool,
    },
    /// A show whose native file would be over the size limit.
    #[error(
        "the show as stored would be larger than the limit of {max_bytes} bytes \
         ([uploads] max_bytes)"
    )]
    TooLarge {
        /// Its native file's size, bytes.
        bytes: usize,
        /// The limit, bytes.
        max_bytes: usize,
    },
    /// A show beyond the installation's limits.
    #[error(
        "the show does not fit this installation: {} problem{}",
        .0.len(),
        if .0.len() == 1 { "" } else { "s" }
    )]
    Unfit(Vec<Violation>),
    /// An output track for a box the installation lacks.
    #[error("{}", output_box_message(*box_index, *boxes))]
    OutputBox {
        /// The box the track names.
        box_index: usize,
        /// The installation's MBOX boxes.
        boxes: usize,
    },
}

impl Refused {
    /// Each problem, for the user: the parser's words, each violation, the size or
    /// duration found. At most [`MAX_LISTED_PROBLEMS`] violations are listed, then a
    /// count of the rest.
    #[must_use]
    pub fn details(&self) -> Vec<String> {
        match self {
            Self::NotUtf8 { .. } | Self::Unreadable(_) | Self::Csv(_) | Self::OutputBox { .. } => {
                vec![self.reason()]
            }
            Self::KeyframeTooLate { error, .. } => vec![error.to_string()],
            Self::Empty(ShowFormat::Csv) => {
                vec!["a CSV show needs at least two keyframes, the last after 0 ms".to_owned()]
            }
            Self::Empty(ShowFormat::Json) => vec!["every ball's \"rows\" is empty".to_owned()],
            Self::TooLong { duration_ms, .. } => {
                vec![format!("the show lasts {}", human_duration(*duration_ms))]
            }
            Self::ConvertedTooLarge {
                bytes,
                max_bytes,
                exact,
            } => vec![
                ImportError::TooLarge {
                    bytes: *bytes,
                    max_bytes: *max_bytes,
                    exact: *exact,
                }
                .to_string(),
            ],
            Self::TooLarge { bytes, .. } => vec![format!("as stored the show takes {bytes} bytes")],
            Self::Unfit(violations) => {
                let mut details: Vec<String> = violations
                    .iter()
                    .take(MAX_LISTED_PROBLEMS)
                    .map(ToString::to_string)
                    .collect();
                if violations.len() > MAX_LISTED_PROBLEMS {
                    details.push(format!(
                        "… and {} more problems",
                        violations.len() - MAX_LISTED_PROBLEMS
                    ));
                }
                details
            }
        }
    }

    /// In one line: the parser's words when the file does not read as a show (the only
    /// refusals without limits, as in the preview); otherwise which limit refused it
    /// (the sentence and [`details`](Self::details) say by how much).
    #[must_use]
    pub fn reason(&self) -> String {
        match self {
            Self::NotUtf8 { byte } => format!("byte {byte} is not part of a UTF-8 character"),
            Self::Unreadable(error) => error.to_string(),
            Self::Csv(error) => error.to_string(),
            Self::Empty(_) => "the show is empty: it has no motion".to_owned(),
            Self::KeyframeTooLate { .. } | Self::TooLong { .. } => {
                "the show is longer than [uploads] max_duration".to_owned()
            }
            Self::ConvertedTooLarge { .. } | Self::TooLarge { .. } => {
                "the show as stored is larger than [uploads] max_bytes".to_owned()
            }
            Self::Unfit(_) => "the show does not fit this installation".to_owned(),
            Self::OutputBox { .. } => self.to_string(),
        }
    }

    /// Refused for its size (`max_bytes`) rather than its content.
    #[must_use]
    pub fn too_large(&self) -> bool {
        matches!(self, Self::ConvertedTooLarge { .. } | Self::TooLarge { .. })
    }
}

/// Reads a show file in `format` as the show `name`.
///
/// `layout` is the installation's, for a CSV file without a `# rows=… cols=…` line;
/// when it is not known (`None`: the web app previews files without asking a
/// controller) such a file is laid out as the most nearly square grid of its ball
/// columns, [`DEFAULT_PITCH_MM`](super::DEFAULT_PITCH_MM) apart. With `limits`, the
/// show must also be one that installation takes (see the [module](self) docs); a CSV's
/// duration and size are checked from its keyframes before its rows are built.
///
/// # Errors
/// [`Refused`]: not UTF-8, not a show file, bad CSV; and with `limits`, empty, too
/// long, too large as stored, or beyond the motion limits (every violation).
// Inlined so that a caller without limits (the web app) leaves out the code that only
// checks them.
#[inline]
pub fn import(
    name: &str,
    bytes: &[u8],
    format: ShowFormat,
    layout: Option<Layout>,
    limits: Option<&UploadLimits>,
) -> Result<Show, Refused> {
    match limits {
        None => read(name, bytes, format, layout),
        Some(limits) => admit(name, bytes, format, layout, limits),
    }
}

/// A native (JSON) show file as it is, without limits: what [`import`] gives for
/// [`ShowFormat::Json`] without limits, for a caller that must not carry the CSV
/// reader (the web app's first load; its CSV reading is a chunk of its own).
///
/// # Errors
/// [`Refused`]: not UTF-8, not a show file.
pub fn read_json(name: &str, bytes: &[u8]) -> Result<Show, Refused> {
    from_json(name, utf8(bytes)?)
}

/// The show file as it is, without limits.
fn read(
    name: &str,
    bytes: &[u8],
    format: ShowFormat,
    layout: Option<Layout>,
) -> Result<Show, Refused> {
    let text = utf8(bytes)?;
    match format {
        ShowFormat::Json => from_json(name, text),
        ShowFormat::Csv => {
            csv::convert(name, text, layout, CurveLimits::DEFAULT).map_err(Refused::Csv)
        }
    }
}

/// The show file, if the installation of `limits` takes it.
fn admit(
    name: &str,
    bytes: &[u8],
    format: ShowFormat,
    layout: Option<Layout>,
    limits: &UploadLimits,
) -> Result<Show, Refused> {
    let text = utf8(bytes)?;
    let show = match format {
        ShowFormat::Json => from_json(name, text)?,
        ShowFormat::Csv => {
            let within = ImportLimits {
                max_duration_ms: limits.max_duration_ms,
                max_json_bytes: limits.max_json_bytes,
                curve: CurveLimits::from(&limits.motion),
            };
            csv::convert_within(name, text, layout, within).map_err(|error| match error {
                ImportError::TooLarge {
                    bytes,
                    max_bytes,
                    exact,
                } => Refused::ConvertedTooLarge {
                    bytes,
                    max_bytes,
                    exact,
                },
                ImportError::Csv(error) if matches!(error.problem, CsvProblem::TooLong { .. }) => {
                    Refused::KeyframeTooLate {
                        max_duration_ms: limits.max_duration_ms,
                        error,
                    }
                }
                ImportError::Csv(error) => Refused::Csv(error),
            })?
        }
    };
    let duration_ms = show.duration_ms();
    if duration_ms == 0 {
        return Err(Refused::Empty(format));
    }
    if duration_ms > limits.max_duration_ms {
        return Err(Refused::TooLong {
            max_duration_ms: limits.max_duration_ms,
            duration_ms,
        });
    }
    let violations = validate(&show, &limits.motion);
    if !violations.is_empty() {
        return Err(Refused::Unfit(violations));
    }
    if let Some(boxes) = limits.mbox_boxes
        && let Some(box_index) = show.output_box_beyond(boxes)
    {
        return Err(Refused::OutputBox { box_index, boxes });
    }
    let bytes = show.json_bytes();
    if bytes > limits.max_json_bytes {
        return Err(Refused::TooLarge {
            bytes,
            max_bytes: limits.max_json_bytes,
        });
    }
    Ok(show)
}

fn utf8(bytes: &[u8]) -> Result<&str, Refused> {
    std::str::from_utf8(bytes).map_err(|error| Refused::NotUtf8 {
        byte: error.valid_up_to() + 1,
    })
}

fn from_json(name: &str, text: &str) -> Result<Show, Refused> {
    let mut show = Show::from_json(text).map_err(Refused::Unreadable)?;
    name.clone_into(&mut show.name);
    Ok(show)
}

/// A duration as the bridge's configuration writes one (`30m`, `1s 500ms`, `1day 2h`):
/// each unit that is not zero, largest first, as `humantime` formats durations
/// (a year is 365.25 days, a month 30.44 days).
#[must_use]
pub fn human_duration(duration_ms: u64) -> String {
    const UNITS_MS: [(u64, &str); 7] = [
        (31_557_600_000, "year"),
        (2_630_016_000, "month"),
        (86_400_000, "day"),
        (3_600_000, "h"),
        (60_000, "m"),
        (1000, "s"),
        (1, "ms"),
    ];
    let mut text = String::new();
    let mut rest_ms = duration_ms;
    for (unit_ms, unit) in UNITS_MS {
        let count = rest_ms / unit_ms;
        rest_ms %= unit_ms;
        if count > 0 {
            let plural = if count > 1 && unit.len() > 2 { "s" } else { "" };
            let space = if text.is_empty() { "" } else { " " };
            let _ = write!(text, "{space}{count}{unit}{plural}");
        }
    }
    if text.is_empty() {
        text.push_str("0s");
    }
    text
}

impl Coded for Refused {
    fn code(&self) -> Code {
        match self {
            Self::NotUtf8 { .. } => Code::NotUtf8,
            Self::Unreadable(_) => Code::ShowFileUnreadable,
            Self::Csv(_) => Code::CsvUnreadable,
            Self::Empty(_) => Code::ShowEmpty,
            Self::KeyframeTooLate { .. } | Self::TooLong { .. } => Code::ShowTooLong,
            Self::ConvertedTooLarge { .. } | Self::TooLarge { .. } => Code::ShowTooLarge,
            Self::Unfit(_) => Code::ShowUnfit,
            Self::OutputBox { .. } => Code::OutputBox,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::NotUtf8 { byte } => params! {"byte" => byte},
            Self::Unreadable(_) | Self::Csv(_) | Self::Empty(_) => Params::new(),
            Self::KeyframeTooLate {
                max_duration_ms, ..
            }
            | Self::TooLong {
                max_duration_ms, ..
            } => params! {"limit_ms" => max_duration_ms},
            Self::ConvertedTooLarge { max_bytes, .. } | Self::TooLarge { max_bytes, .. } => {
                params! {"limit_bytes" => max_bytes}
            }
            Self::Unfit(violations) => params! {"count" => violations.len()},
            Self::OutputBox { box_index, boxes } => params! {"box" => box_index, "boxes" => boxes},
        }
    }
}

impl Refused {
    /// The [`details`](Self::details) as codes and parameters, one for one.
    #[must_use]
    pub fn problems(&self) -> Vec<Problem> {
        let coded = |code: Code, params: Params| Problem {
            code: code.as_str().to_owned(),
            params,
        };
        match self {
            Self::NotUtf8 { .. } | Self::OutputBox { .. } => vec![Problem::of(self)],
            Self::Unreadable(error) => vec![Problem::of(error)],
            Self::Csv(error) | Self::KeyframeTooLate { error, .. } => vec![Problem::of(error)],
            Self::Empty(ShowFormat::Csv) => vec![coded(Code::CsvNeedsMotion, Params::new())],
            Self::Empty(ShowFormat::Json) => vec![coded(Code::JsonNeedsMotion, Params::new())],
            Self::TooLong { duration_ms, .. } => {
                vec![coded(
                    Code::ShowLasts,
                    params! {"duration_ms" => duration_ms},
                )]
            }
            Self::ConvertedTooLarge {
                bytes,
                max_bytes,
                exact,
            } => vec![Problem::of(&ImportError::TooLarge {
                bytes: *bytes,
                max_bytes: *max_bytes,
                exact: *exact,
            })],
            Self::TooLarge { bytes, .. } => {
                vec![coded(Code::ShowTakes, params! {"bytes" => bytes})]
            }
            Self::Unfit(violations) => {
                let mut problems: Vec<Problem> = violations
                    .iter()
                    .take(MAX_LISTED_PROBLEMS)
                    .map(Problem::of)
                    .collect();
                if violations.len() > MAX_LISTED_PROBLEMS {
                    problems.push(coded(
                        Code::MoreProblems,
                        params! {"count" => violations.len() - MAX_LISTED_PROBLEMS},
                    ));
                }
                problems
            }
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::csv::tests::ONE_BY_TWO;
    use super::super::{Track, TrackRow};
    use super::*;

    fn limits() -> UploadLimits {
        UploadLimits {
            motion: Limits::for_layout(1, 2),
            max_duration_ms: 30 * 60 * 1000,
            max_json_bytes: 1 << 20,
            mbox_boxes: None,
        }
    }

    fn show(rows: Vec<TrackRow>) -> Show {
        let track = Track {
            start_mm: 0.0,
            rows,
            colours: Vec::new(),
        };
        Show {
            outputs: Vec::new(),
            name: "in the file".into(),
            layout: ONE_BY_TWO,
            tracks: vec![track.clone(), track],
        }
    }

    fn down_and_up() -> Show {
        show(vec![
            TrackRow::new(40.0, 0.0, 250),
            TrackRow::new(0.0, 0.0, 250),
        ])
    }

    fn refused(bytes: &[u8], format: ShowFormat, limits: &UploadLimits) -> Refused {
        import("test", bytes, format, Some(ONE_BY_TWO), Some(limits)).unwrap_err()
    }

    #[test]
    fn read_json_is_import_of_a_json_file_without_limits() {
        let json = down_and_up().to_json().unwrap();
        let read = read_json("named", json.as_bytes()).unwrap();
        assert_eq!(read.name, "named");
        assert_eq!(
            read,
            import("named", json.as_bytes(), ShowFormat::Json, None, None).unwrap()
        );
        assert!(matches!(
            read_json("x", b"\xff"),
            Err(Refused::NotUtf8 { byte: 1 })
        ));
        assert!(matches!(
            read_json("x", b"time_ms,0_0"),
            Err(Refused::Unreadable(_))
        ));
    }

    #[test]
    fn formats_come_from_the_extension_and_name_their_media_type() {
        assert_eq!(
            ShowFormat::from_file_name("wave.CSV"),
            Some(ShowFormat::Csv)
        );
        assert_eq!(
            ShowFormat::from_file_name("a.b.json"),
            Some(ShowFormat::Json)
        );
        assert_eq!(ShowFormat::from_file_name("notes.txt"), None);
        assert_eq!(ShowFormat::from_file_name("csv"), None);
        assert_eq!(ShowFormat::Csv.content_type(), "text/csv");
        assert_eq!(ShowFormat::Json.content_type(), "application/json");
        assert_eq!(ShowFormat::Csv.label(), "CSV");
        // Kept in the browser's storage by these names.
        assert_eq!(
            serde_json::to_string(&ShowFormat::ALL).unwrap(),
            r#"["csv","json"]"#
        );
    }

    #[test]
    fn native_files_are_read_and_named() {
        let json = down_and_up().to_json().unwrap();
        let read = import("test", json.as_bytes(), ShowFormat::Json, None, None).unwrap();
        assert_eq!(read.name, "test");
        assert_eq!(read.tracks, down_and_up().tracks);
        let admitted = import(
            "test",
            json.as_bytes(),
            ShowFormat::Json,
            Some(ONE_BY_TWO),
            Some(&limits()),
        )
        .unwrap();
        assert_eq!(admitted, read);
    }

    #[test]
    fn csv_files_use_the_installation_or_a_square_grid() {
        let csv = b"time_ms,u0,u1,u2,u3\n0,100,100,100,100\n500,200,300,400,500\n";
        let show = import("four", csv, ShowFormat::Csv, None, None).unwrap();
        assert_eq!((show.layout.rows, show.layout.cols), (2, 2));
        assert_eq!(show.layout.pitch_mm, crate::show::DEFAULT_PITCH_MM);
        assert_eq!(show.name, "four");
        assert_eq!(show.duration_ms(), 500);

        let installation = Layout {
            rows: 4,
            cols: 1,
            pitch_mm: 800.0,
        };
        let show = import("four", csv, ShowFormat::Csv, Some(installation), None).unwrap();
        assert_eq!(show.layout, installation);
        let error = import("four", csv, ShowFormat::Csv, Some(ONE_BY_TWO), None).unwrap_err();
        assert!(
            matches!(&error, Refused::Csv(csv) if matches!(csv.problem, CsvProblem::LayoutMismatch { .. })),
            "{error:?}"
        );
    }

    #[test]
    fn without_limits_a_show_is_only_read() {
        // Empty, and far beyond the travel: the preview shows such a show.
        let still = import("s", b"time_ms,u0\n0,1\n", ShowFormat::Csv, None, None).unwrap();
        assert_eq!(still.duration_ms(), 0);
        let deep = show(vec![TrackRow::new(90_000.0, 0.0, 250)]);
        let json = deep.to_json().unwrap();
        assert!(import("d", json.as_bytes(), ShowFormat::Json, None, None).is_ok());
    }

    #[test]
    fn bytes_that_are_not_utf8_are_refused_where_they_go_wrong() {
        let error = refused(b"time_ms\xff", ShowFormat::Csv, &limits());
        assert_eq!(error, Refused::NotUtf8 { byte: 8 });
        assert_eq!(error.to_string(), "the show file is not UTF-8 text");
        assert_eq!(error.details(), ["byte 8 is not part of a UTF-8 character"]);
        let error = import("x", b"\xfe", ShowFormat::Json, None, None).unwrap_err();
        assert_eq!(error, Refused::NotUtf8 { byte: 1 });
    }

    #[test]
    fn files_that_do_not_read_say_why_in_the_parsers_words() {
        let error = import("bad", b"{", ShowFormat::Json, None, None).unwrap_err();
        assert!(matches!(
            error,
            Refused::Unreadable(ShowError::Invalid { .. })
        ));
        assert_eq!(error.to_string(), "the show file cannot be read");
        assert!(error.details()[0].contains("not valid"), "{error:?}");

        let error = import(
            "bad",
            b"time_ms,u0\n0,1\n5,2\n",
            ShowFormat::Csv,
            None,
            None,
        )
        .unwrap_err();
        assert!(
            matches!(&error, Refused::Csv(csv) if csv.line == 3),
            "{error:?}"
        );
        assert_eq!(error.to_string(), "the CSV keyframes cannot be imported");
        assert!(error.details()[0].starts_with("line 3"), "{error:?}");
        assert!(!error.too_large());
    }

    #[test]
    fn empty_shows_are_refused_with_limits() {
        let error = refused(b"time_ms,u0,u1\n0,0,0\n", ShowFormat::Csv, &limits());
        assert_eq!(error, Refused::Empty(ShowFormat::Csv));
        assert_eq!(error.to_string(), "the show is empty: it has no motion");
        assert!(error.details()[0].contains("two keyframes"));
        let json = show(Vec::new()).to_json().unwrap();
        let error = refused(json.as_bytes(), ShowFormat::Json, &limits());
        assert_eq!(error, Refused::Empty(ShowFormat::Json));
        assert!(error.details()[0].contains("\"rows\" is empty"));
    }

    #[test]
    fn outputs_for_a_box_an_mbox_installation_lacks_are_refused() {
        let mut show = down_and_up();
        show.outputs = vec![super::super::OutputTrack {
            box_index: 2,
            digital: Vec::new(),
            analog: Vec::new(),
        }];
        let json = show.to_json().unwrap();
        // Where outputs are ignored (UIM2503), or with a third box, it is taken.
        assert!(
            import(
                "o",
                json.as_bytes(),
                ShowFormat::Json,
                None,
                Some(&limits())
            )
            .is_ok()
        );
        let three = UploadLimits {
            mbox_boxes: Some(3),
            ..limits()
        };
        assert!(import("o", json.as_bytes(), ShowFormat::Json, None, Some(&three)).is_ok());
        let two = UploadLimits {
            mbox_boxes: Some(2),
            ..limits()
        };
        let error = refused(json.as_bytes(), ShowFormat::Json, &two);
        assert_eq!(
            error,
            Refused::OutputBox {
                box_index: 2,
                boxes: 2
            }
        );
        assert_eq!(
            error.details(),
            ["the show has outputs for box 2 but the installation's MBOX boxes are 0–1"]
        );
    }

    #[test]
    fn shows_longer_than_the_limit_are_refused() {
        let limits = UploadLimits {
            max_duration_ms: 1000,
            ..limits()
        };
        let csv = b"time_ms,u0,u1\n0,0,0\n500,20,20\n1000,0,0\n1500,20,20\n";
        let error = refused(csv, ShowFormat::Csv, &limits);
        assert!(
            matches!(&error, Refused::KeyframeTooLate { max_duration_ms: 1000, error } if error.line == 5),
            "{error:?}"
        );
        assert_eq!(
            error.to_string(),
            "the show is longer than the limit of 1s ([uploads] max_duration)"
        );
        assert!(error.details()[0].starts_with("line 5"), "{error:?}");

        let long = show(vec![TrackRow::new(40.0, 0.0, 250); 6]);
        let error = refused(
            long.to_json().unwrap().as_bytes(),
            ShowFormat::Json,
            &limits,
        );
        assert_eq!(
            error,
            Refused::TooLong {
                max_duration_ms: 1000,
                duration_ms: 1500
            }
        );
        assert_eq!(error.details(), ["the show lasts 1s 500ms"]);
        assert!(!error.too_large());
    }

    #[test]
    fn shows_larger_than_the_limit_as_stored_are_refused() {
        // Keyframes ten minutes apart: too large before a row is built.
        let limits = UploadLimits {
            max_json_bytes: 2048,
            ..limits()
        };
        let csv = b"time_ms,u0,u1\n0,0,0\n600000,20,20\n";
        let error = refused(csv, ShowFormat::Csv, &limits);
        assert!(
            matches!(
                error,
                Refused::ConvertedTooLarge {
                    max_bytes: 2048,
                    exact: false,
                    ..
                }
            ),
            "{error:?}"
        );
        assert!(error.too_large());
        assert_eq!(
            error.to_string(),
            "the show as stored would be larger than the limit of 2048 bytes ([uploads] max_bytes)"
        );
        assert!(
            error.details()[0].contains("converted to PVT rows"),
            "{error:?}"
        );

        // A native file is measured as it will be stored: named, compact.
        let json = down_and_up().to_json().unwrap();
        let mut named = down_and_up();
        named.name = "a much longer name than the file had".into();
        let stored_bytes = named.to_json().unwrap().len();
        let limits = UploadLimits {
            max_json_bytes: stored_bytes - 1,
            ..limits
        };
        let error = import(
            &named.name,
            json.as_bytes(),
            ShowFormat::Json,
            Some(ONE_BY_TWO),
            Some(&limits),
        )
        .unwrap_err();
        assert_eq!(
            error,
            Refused::TooLarge {
                bytes: stored_bytes,
                max_bytes: stored_bytes - 1
            }
        );
        assert!(error.too_large());
        assert_eq!(
            error.details(),
            [format!("as stored the show takes {stored_bytes} bytes")]
        );
        let limits = UploadLimits {
            max_json_bytes: stored_bytes,
            ..limits
        };
        let admitted = import(
            &named.name,
            json.as_bytes(),
            ShowFormat::Json,
            Some(ONE_BY_TWO),
            Some(&limits),
        );
        assert_eq!(admitted, Ok(named));
    }

    #[test]
    fn shows_beyond_the_installation_list_every_problem() {
        let csv = b"time_ms,u0,u1\n0,0,0\n200,9000,0\n";
        let error = refused(csv, ShowFormat::Csv, &limits());
        let Refused::Unfit(violations) = &error else {
            panic!("{error:?}")
        };
        assert!(violations.len() >= 2, "{error:?}");
        assert_eq!(
            error.to_string(),
            format!(
                "the show does not fit this installation: {} problems",
                violations.len()
            )
        );
        assert_eq!(error.details().len(), violations.len());

        let json = down_and_up().to_json().unwrap();
        let limits = UploadLimits {
            motion: Limits::for_layout(2, 2),
            ..limits()
        };
        let error = refused(json.as_bytes(), ShowFormat::Json, &limits);
        assert_eq!(
            error.to_string(),
            "the show does not fit this installation: 1 problem"
        );
        assert!(
            error.details()[0].contains("2 rows × 2 columns"),
            "{error:?}"
        );
    }

    #[test]
    fn long_lists_of_problems_are_cut_and_counted() {
        let json = show(vec![TrackRow::new(9000.0, 0.0, 250)])
            .to_json()
            .unwrap();
        let Refused::Unfit(violations) = refused(json.as_bytes(), ShowFormat::Json, &limits())
        else {
            panic!("beyond the travel")
        };
        let many = Refused::Unfit(vec![violations[0]; MAX_LISTED_PROBLEMS + 3]);
        let details = many.details();
        assert_eq!(details.len(), MAX_LISTED_PROBLEMS + 1);
        assert_eq!(details[MAX_LISTED_PROBLEMS], "… and 3 more problems");
    }

    #[test]
    fn the_reason_is_the_parsers_words_or_the_limit() {
        let csv = b"time_ms,u0\n0,1\n5,2\n";
        let error = import("bad", csv, ShowFormat::Csv, None, None).unwrap_err();
        assert_eq!(error.reason(), error.details()[0]);
        let error = import("bad", b"\xff", ShowFormat::Csv, None, None).unwrap_err();
        assert_eq!(error.reason(), error.details()[0]);
        let error = import("bad", b"[]", ShowFormat::Json, None, None).unwrap_err();
        assert_eq!(error.reason(), error.details()[0]);
        for (refused, limit) in [
            (Refused::Empty(ShowFormat::Csv), "empty"),
            (
                Refused::TooLong {
                    max_duration_ms: 1,
                    duration_ms: 2,
                },
                "max_duration",
            ),
            (
                Refused::TooLarge {
                    bytes: 2,
                    max_bytes: 1,
                },
                "max_bytes",
            ),
            (Refused::Unfit(Vec::new()), "does not fit"),
        ] {
            assert!(refused.reason().contains(limit), "{refused:?}");
        }
    }

    #[test]
    fn durations_read_as_the_configuration_writes_them() {
        for (duration_ms, text) in [
            (0, "0s"),
            (1000, "1s"),
            (1500, "1s 500ms"),
            (30 * 60 * 1000, "30m"),
            (25 * 3600 * 1000 + 1, "1day 1h 1ms"),
            (2 * 86_400_000 + 61_000, "2days 1m 1s"),
            (2_630_016_000, "1month"),
            (2 * 31_557_600_000, "2years"),
        ] {
            assert_eq!(human_duration(duration_ms), text, "{duration_ms} ms");
        }
    }
}
