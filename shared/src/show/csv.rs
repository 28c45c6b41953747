//! CSV keyframe import: what 3D tools (3ds Max, Blender, TouchDesigner) export, turned
//! into a [`Show`] of PVT rows (`docs/architecture.md` §3).
//!
//! The file:
//! ```text
//! # rows=2 cols=3 pitch_mm=500        (optional; else the installation's layout)
//! time_ms,u0,u1,u2,u3,u4,u5
//! 0,1000,1000,1000,1000,1000,1000
//! 33.333,1010,1000,995,1000,1000,1000
//! …
//! ```
//! One column per ball in row-major order, positions in mm below the top. Times start at
//! 0 and strictly increase; they may have decimals and each is rounded to whole ms on its
//! own (so 30 fps frames do not drift). Blank lines are ignored; fields may be padded with
//! spaces.
//!
//! Conversion: every keyframe becomes a PVT row ending exactly on it. The ball starts at
//! rest on the first keyframe and ends at rest on the last; the velocity at each interior
//! keyframe is that of the smooth curve through the keyframes (the clamped cubic
//! spline), not forced to 0 at turning points, and limited only where the curve would
//! pass 0 or the travel, or break a speed or acceleration limit the keyframes joined by
//! straight lines keep ([`super::csv_curve`], with the installation's
//! [`CurveLimits`]). Gaps over 255 ms are split into equal rows on the same cubic; gaps
//! under 10 ms are an error.
//!
//! Every error names the line and the column (1-based; on the layout line the column is
//! the character position, elsewhere the field number, 1 = `time_ms`).
//!
//! A few keyframes far apart become many rows (a gap of an hour is over 14,000 rows per
//! ball), so [`import_csv_within`] checks the show's duration and the size of its
//! native file against [`ImportLimits`] from the keyframes alone, *before* it builds a
//! single row.
//!
//! ```
//! use floatball_shared::show::{Layout, import_csv};
//!
//! let installation = Layout { rows: 1, cols: 2, pitch_mm: 500.0 };
//! let show = import_csv("wave", "time_ms,u0,u1\n0,100,200\n500,300,200\n", installation)?;
//! assert_eq!(show.tracks[0].rows.len(), 2); // 500 ms split into 2 × 250 ms
//! assert_eq!(show.tracks[0].rows[1].position_mm, 300.0);
//! # Ok::<(), floatball_shared::show::CsvError>(())
//! ```

use thiserror::Error;

use crate::codes::{Code, Coded, Params};
use crate::params;

use super::csv_curve::{CurveLimits, keyframe_velocities};
use super::{DEFAULT_PITCH_MM, Layout, Show, Track, TrackRow, json_len};
use crate::motion::Segment;
use crate::uim2503::pvt::{ROW_MAX_MS, ROW_MIN_MS};

/// The most PVT rows an import may produce over all balls (about 240 MB), so that a
/// small file with huge gaps cannot exhaust memory.
pub const MAX_TOTAL_ROWS: usize = 10_000_000;

/// The latest keyframe time accepted, ms (24 hours).
pub const MAX_TIME_MS: f64 = 86_400_000.0;

/// Bounds on what an import may produce, checked before the show is built, and the
/// installation's limits the curve is kept within ([`CurveLimits`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ImportLimits {
    /// Longest show, ms: the last keyframe's time.
    pub max_duration_ms: u64,
    /// Largest native show file (compact JSON, [`Show::to_json`]) the import may
    /// produce, bytes.
    pub max_json_bytes: usize,
    /// The travel, speed and acceleration the keyframes' velocities respect
    /// ([`super::csv_curve`]).
    pub curve: CurveLimits,
}

/// Why [`import_csv_within`] refuses a file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum ImportError {
    /// The file is wrong, or the show lasts too long, at a known line.
    #[error(transparent)]
    Csv(#[from] CsvError),
    /// Converted to rows, the show's native file would be over the size limit.
    #[error(
        "converted to PVT rows the show would take {}{bytes} bytes, more than the limit \
         of {max_bytes} bytes; use fewer balls, a shorter show or keyframes closer \
         together",
        if *exact { "" } else { "at least " }
    )]
    TooLarge {
        /// The size (or, when not `exact`, the least size) of the converted show.
        bytes: usize,
        /// The limit.
        max_bytes: usize,
        /// Whether `bytes` is the exact size rather than a lower bound.
        exact: bool,
    },
}

/// The least bytes one row takes in a show file: `[0.0,0.0,10]` and a comma.
const MIN_ROW_JSON_BYTES: usize = 13;

/// The least bytes one track takes besides its rows: `{"start_mm":0.0,"rows":[]}`, less
/// the one comma [`MIN_ROW_JSON_BYTES`] counts too many.
const MIN_TRACK_JSON_BYTES: usize = 25;

/// A CSV file that cannot be imported: where, and what is wrong.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("line {line}, column {column}: {problem}")]
pub struct CsvError {
    /// 1-based line number.
    pub line: usize,
    /// 1-based column: the field number, or on the layout line the character position.
    pub column: usize,
    /// What is wrong there.
    pub problem: CsvProblem,
}

/// What is wrong in a CSV file.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CsvProblem {
    /// Nothing but blank lines.
    #[error("the file is empty; it must start with a header line \"time_ms,u0,u1,…\"")]
    Empty,
    /// A layout line and nothing after it.
    #[error("the header line \"time_ms,u0,u1,…\" is missing after the layout line")]
    NoHeader,
    /// A `#` line that is not a layout line in first position.
    #[error(
        "a line starting with # is only allowed first, as the layout \"# rows=R cols=C pitch_mm=P\""
    )]
    MisplacedComment,
    /// A word on the layout line that is not `rows=`, `cols=` or `pitch_mm=`.
    #[error("\"{text}\" is not understood; the layout line reads \"# rows=R cols=C pitch_mm=P\"")]
    LayoutWord {
        /// The word.
        text: String,
    },
    /// A bad value on the layout line.
    #[error("{key} must be {expected}, not \"{text}\"")]
    LayoutValue {
        /// `rows`, `cols` or `pitch_mm`.
        key: &'static str,
        /// What it must be.
        expected: &'static str,
        /// The value found.
        text: String,
    },
    /// `rows=` or `cols=` missing from the layout line.
    #[error("the layout line has no {key}=…; it reads \"# rows=R cols=C pitch_mm=P\"")]
    LayoutMissing {
        /// The missing key.
        key: &'static str,
    },
    /// A header column that is not the expected name.
    #[error(
        "the header column is \"{found}\" but must be \"{expected}\" (header: time_ms,u0,u1,…)"
    )]
    HeaderName {
        /// The name found.
        found: String,
        /// The name expected here.
        expected: String,
    },
    /// The header has no ball columns.
    #[error("the header names no balls; it must be \"time_ms,u0,u1,…\"")]
    NoUnits,
    /// The number of ball columns differs from the layout's balls.
    #[error(
        "the file has {units} ball columns but the layout ({origin}) is {rows} rows × {cols} columns = {} balls",
        *rows as usize * *cols as usize
    )]
    LayoutMismatch {
        /// Ball columns in the header.
        units: usize,
        /// Layout rows.
        rows: u32,
        /// Layout columns.
        cols: u32,
        /// Where the layout came from, in words.
        origin: &'static str,
    },
    /// A line with a different number of fields than the header.
    #[error("this line has {found} fields but the header has {expected}")]
    FieldCount {
        /// Fields on the line.
        found: usize,
        /// Fields in the header.
        expected: usize,
    },
    /// A field that is not a finite number.
    #[error("\"{text}\" is not a number")]
    NotANumber {
        /// The field.
        text: String,
    },
    /// No keyframes after the header.
    #[error("there are no keyframes after the header")]
    NoKeyframes,
    /// The first keyframe is not at time 0.
    #[error("the first keyframe is at {time_ms} ms; it must be at 0")]
    FirstTimeNotZero {
        /// The time found.
        time_ms: f64,
    },
    /// A time not after the previous keyframe's.
    #[error("time {time_ms} ms is not after {previous_ms} ms on line {previous_line}")]
    TimeNotIncreasing {
        /// The time found.
        time_ms: f64,
        /// The previous keyframe's time.
        previous_ms: f64,
        /// The previous keyframe's line.
        previous_line: usize,
    },
    /// Two keyframes closer than a unit's shortest row (10 ms), after rounding to ms.
    #[error(
        "this keyframe is only {gap_ms} ms after the one on line {previous_line}; \
         keyframes must be at least {ROW_MIN_MS} ms apart"
    )]
    GapTooShort {
        /// The gap, ms.
        gap_ms: u64,
        /// The previous keyframe's line.
        previous_line: usize,
    },
    /// A time beyond [`MAX_TIME_MS`].
    #[error("time {time_ms} ms is later than the longest show accepted (24 hours)")]
    TooLate {
        /// The time found.
        time_ms: f64,
    },
    /// A keyframe later than the longest show allowed ([`ImportLimits`]).
    #[error("time {time_ms} ms is later than the longest show accepted here ({max_ms} ms)")]
    TooLong {
        /// The time found.
        time_ms: f64,
        /// The longest show, ms.
        max_ms: u64,
    },
    /// The show would have more than [`MAX_TOTAL_ROWS`] rows.
    #[error(
        "the show would have {rows} rows in all, more than {MAX_TOTAL_ROWS}; \
         use fewer balls or a shorter show"
    )]
    TooManyRows {
        /// Rows the import would produce.
        rows: usize,
    },
}

/// Imports CSV keyframes as a show named `name`. `installation` is the layout used when
/// the file has no `# rows=… cols=…` line (its pitch also when the line omits
/// `pitch_mm`). The curve is kept within the default installation's travel, speed and
/// acceleration ([`CurveLimits::DEFAULT`]); [`import_csv_within`] takes others.
///
/// # Errors
/// A [`CsvError`] naming the line and column of the first problem.
pub fn import_csv(name: &str, text: &str, installation: Layout) -> Result<Show, CsvError> {
    convert(name, text, Some(installation), CurveLimits::DEFAULT)
}

/// Imports CSV keyframes as [`import_csv`] does, but first checks, from the keyframes
/// alone, that the show lasts at most `limits.max_duration_ms` and that its native
/// file takes at most `limits.max_json_bytes`; only then are the rows built. So a
/// small file cannot make a huge show.
///
/// # Errors
/// [`ImportError::Csv`] naming the line and column of the first problem (a keyframe
/// past the longest show is [`CsvProblem::TooLong`]), or [`ImportError::TooLarge`].
pub fn import_csv_within(
    name: &str,
    text: &str,
    installation: Layout,
    limits: ImportLimits,
) -> Result<Show, ImportError> {
    convert_within(name, text, Some(installation), limits)
}

/// [`import_csv`], where an unknown installation (`None`) lays a file without a layout
/// line out as [`square_layout`], and the curve is kept within `curve`.
pub(super) fn convert(
    name: &str,
    text: &str,
    installation: Option<Layout>,
    curve: CurveLimits,
) -> Result<Show, CsvError> {
    let (layout, keyframes) = read(text, installation, MAX_TIME_MS as u64)?;
    Ok(Show {
        outputs: Vec::new(),
        name: name.to_owned(),
        layout,
        tracks: keyframes.into_tracks(curve),
    })
}

/// [`import_csv_within`], where an unknown installation (`None`) lays a file without a
/// layout line out as [`square_layout`].
pub(super) fn convert_within(
    name: &str,
    text: &str,
    installation: Option<Layout>,
    limits: ImportLimits,
) -> Result<Show, ImportError> {
    let (layout, keyframes) = read(text, installation, limits.max_duration_ms)?;
    let too_large = |bytes, exact| ImportError::TooLarge {
        bytes,
        max_bytes: limits.max_json_bytes,
        exact,
    };
    let header = Show {
        outputs: Vec::new(),
        name: name.to_owned(),
        layout,
        tracks: Vec::new(),
    }
    .to_json()
    .map_or(0, |json| json.len());
    let units = keyframes.positions_mm.len();
    let least = keyframes
        .rows_per_unit
        .saturating_mul(units)
        .saturating_mul(MIN_ROW_JSON_BYTES)
        .saturating_add(units.saturating_mul(MIN_TRACK_JSON_BYTES))
        .saturating_add(header);
    if least > limits.max_json_bytes {
        return Err(too_large(least, false));
    }
    let bytes = header + keyframes.tracks_json_bytes(limits.curve);
    if bytes > limits.max_json_bytes {
        return Err(too_large(bytes, true));
    }
    Ok(Show {
        outputs: Vec::new(),
        name: name.to_owned(),
        layout,
        tracks: keyframes.into_tracks(limits.curve),
    })
}

/// The layout of `units` balls when the installation is not known: the most nearly
/// square grid with exactly that many balls (rows ≤ columns),
/// [`DEFAULT_PITCH_MM`] apart.
fn square_layout(units: usize) -> Layout {
    let units = units.max(1);
    let rows = (1..=units)
        .take_while(|rows| rows * rows <= units)
        .filter(|rows| units.is_multiple_of(*rows))
        .last()
        .unwrap_or(1);
    Layout {
        rows: u32::try_from(rows).unwrap_or(1),
        cols: u32::try_from(units / rows).unwrap_or(u32::MAX),
        pitch_mm: DEFAULT_PITCH_MM,
    }
}

/// Reads the layout and the keyframes, refusing a keyframe after `max_time_ms`.
/// Without an `installation`, a file without a layout line is laid out as
/// [`square_layout`] of its ball columns, and the layout line's pitch defaults to
/// [`DEFAULT_PITCH_MM`].
fn read(
    text: &str,
    installation: Option<Layout>,
    max_time_ms: u64,
) -> Result<(Layout, Keyframes), CsvError> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text
        .lines()
        .enumerate()
        .map(|(i, line)| (i + 1, line))
        .filter(|(_, line)| !line.trim().is_empty());

    let (mut header_number, mut header) = lines.next().ok_or(CsvError {
        line: 1,
        column: 1,
        problem: CsvProblem::Empty,
    })?;
    let mut layout = None;
    if let Some(rest) = header.trim_start().strip_prefix('#') {
        let offset = header.len() - rest.len();
        let pitch_mm = installation.map_or(DEFAULT_PITCH_MM, |layout| layout.pitch_mm);
        layout = Some((
            parse_layout(header_number, offset, rest, pitch_mm)?,
            "from line 1",
        ));
        (header_number, header) = lines.next().ok_or(CsvError {
            line: header_number + 1,
            column: 1,
            problem: CsvProblem::NoHeader,
        })?;
    }
    let units = parse_header(header_number, header)?;
    let (layout, origin) = layout.unwrap_or(match installation {
        Some(installation) => (installation, "from the installation"),
        None => (square_layout(units), "a square grid of the ball columns"),
    });
    if units != layout.unit_count() {
        let column = units.min(layout.unit_count()) + 2;
        return Err(CsvError {
            line: header_number,
            column,
            problem: CsvProblem::LayoutMismatch {
                units,
                rows: layout.rows,
                cols: layout.cols,
                origin,
            },
        });
    }

    let keyframes = parse_keyframes(header_number, units, lines, max_time_ms)?;
    Ok((layout, keyframes))
}

fn parse_layout(
    line: usize,
    offset: usize,
    text: &str,
    default_pitch_mm: f64,
) -> Result<Layout, CsvError> {
    let (mut rows, mut cols, mut pitch_mm) = (None, None, default_pitch_mm);
    let base = text.as_ptr() as usize;
    for word in text.split_whitespace() {
        let column = offset + (word.as_ptr() as usize - base) + 1;
        let error = |problem| CsvError {
            line,
            column,
            problem,
        };
        let (key, value) = word.split_once('=').unwrap_or((word, ""));
        let count = |key: &'static str| {
            value.parse::<u32>().ok().filter(|&n| n > 0).ok_or_else(|| {
                error(CsvProblem::LayoutValue {
                    key,
                    expected: "a whole number of at least 1",
                    text: value.to_owned(),
                })
            })
        };
        match key {
            "rows" => rows = Some(count("rows")?),
            "cols" => cols = Some(count("cols")?),
            "pitch_mm" => {
                pitch_mm = value
                    .parse::<f64>()
                    .ok()
                    .filter(|&p| p > 0.0 && p.is_finite())
                    .ok_or_else(|| {
                        error(CsvProblem::LayoutValue {
                            key: "pitch_mm",
                            expected: "a positive number of mm",
                            text: value.to_owned(),
                        })
                    })?;
            }
            _ => {
                return Err(error(CsvProblem::LayoutWord {
                    text: word.to_owned(),
                }));
            }
        }
    }
    let missing = |key| CsvError {
        line,
        column: 1,
        problem: CsvProblem::LayoutMissing { key },
    };
    Ok(Layout {
        rows: rows.ok_or_else(|| missing("rows"))?,
        cols: cols.ok_or_else(|| missing("cols"))?,
        pitch_mm,
    })
}

/// Checks the header and returns the number of ball columns.
fn parse_header(line: usize, text: &str) -> Result<usize, CsvError> {
    if text.trim_start().starts_with('#') {
        return Err(CsvError {
            line,
            column: 1,
            problem: CsvProblem::MisplacedComment,
        });
    }
    let mut fields = 0;
    for (index, field) in text.split(',').enumerate() {
        let found = field.trim();
        let expected = match index {
            0 => "time_ms".to_owned(),
            _ => format!("u{}", index - 1),
        };
        if found != expected {
            return Err(CsvError {
                line,
                column: index + 1,
                problem: CsvProblem::HeaderName {
                    found: found.to_owned(),
                    expected,
                },
            });
        }
        fields += 1;
    }
    if fields < 2 {
        return Err(CsvError {
            line,
            column: 2,
            problem: CsvProblem::NoUnits,
        });
    }
    Ok(fields - 1)
}

/// Keyframes in columns: whole-ms times and, per ball, positions.
struct Keyframes {
    times_ms: Vec<u64>,
    positions_mm: Vec<Vec<f64>>,
    rows_per_unit: usize,
}

fn parse_keyframes<'a>(
    header_line: usize,
    units: usize,
    lines: impl Iterator<Item = (usize, &'a str)>,
    max_time_ms: u64,
) -> Result<Keyframes, CsvError> {
    let mut keyframes = Keyframes {
        times_ms: Vec::new(),
        positions_mm: vec![Vec::new(); units],
        rows_per_unit: 0,
    };
    let mut previous: Option<(usize, f64, u64)> = None;
    let mut last_line = header_line;
    for (line, text) in lines {
        last_line = line;
        let error = |column, problem| CsvError {
            line,
            column,
            problem,
        };
        if text.trim_start().starts_with('#') {
            return Err(error(1, CsvProblem::MisplacedComment));
        }
        let mut fields = text.split(',');
        let time_text = fields.next().unwrap_or_default();
        let time_ms = parse_number(time_text).ok_or_else(|| {
            error(
                1,
                CsvProblem::NotANumber {
                    text: time_text.trim().to_owned(),
                },
            )
        })?;
        if time_ms > MAX_TIME_MS {
            return Err(error(1, CsvProblem::TooLate { time_ms }));
        }
        // Rounded on its own, so that 33.333 ms frames do not accumulate drift.
        let rounded = time_ms.round();
        // Within 0..=MAX_TIME_MS (or negative, refused below), so the cast is exact.
        if rounded > 0.0 && rounded as u64 > max_time_ms {
            return Err(error(
                1,
                CsvProblem::TooLong {
                    time_ms,
                    max_ms: max_time_ms,
                },
            ));
        }
        match previous {
            None if rounded != 0.0 => {
                return Err(error(1, CsvProblem::FirstTimeNotZero { time_ms }));
            }
            None => {}
            Some((previous_line, previous_ms, _)) if time_ms <= previous_ms => {
                return Err(error(
                    1,
                    CsvProblem::TimeNotIncreasing {
                        time_ms,
                        previous_ms,
                        previous_line,
                    },
                ));
            }
            Some((previous_line, _, previous_rounded)) => {
                // Within 0..=MAX_TIME_MS, so the cast is exact.
                let gap_ms = rounded as u64 - previous_rounded;
                if gap_ms < u64::from(ROW_MIN_MS) {
                    return Err(error(
                        1,
                        CsvProblem::GapTooShort {
                            gap_ms,
                            previous_line,
                        },
                    ));
                }
                keyframes.rows_per_unit += usize::try_from(split_count(gap_ms)).unwrap_or(0);
                let rows = keyframes.rows_per_unit.saturating_mul(units);
                if rows > MAX_TOTAL_ROWS {
                    return Err(error(1, CsvProblem::TooManyRows { rows }));
                }
            }
        }
        let mut found = 1;
        for (column, field) in keyframes.positions_mm.iter_mut().zip(&mut fields) {
            found += 1;
            let value = parse_number(field).ok_or_else(|| {
                error(
                    found,
                    CsvProblem::NotANumber {
                        text: field.trim().to_owned(),
                    },
                )
            })?;
            column.push(value);
        }
        let extra = fields.count();
        if found + extra != units + 1 {
            let column = if extra > 0 { units + 2 } else { found + 1 };
            return Err(error(
                column,
                CsvProblem::FieldCount {
                    found: found + extra,
                    expected: units + 1,
                },
            ));
        }
        keyframes.times_ms.push(rounded as u64);
        previous = Some((line, time_ms, rounded as u64));
    }
    if keyframes.times_ms.is_empty() {
        return Err(CsvError {
            line: last_line + 1,
            column: 1,
            problem: CsvProblem::NoKeyframes,
        });
    }
    Ok(keyframes)
}

fn parse_number(field: &str) -> Option<f64> {
    field
        .trim()
        .parse::<f64>()
        .ok()
        .filter(|value| value.is_finite())
}

/// Rows a gap becomes: as few as keep each within 255 ms.
fn split_count(gap_ms: u64) -> u64 {
    gap_ms.div_ceil(u64::from(ROW_MAX_MS))
}

impl Keyframes {
    /// The tracks, taking the keyframes: each ball's column is freed once its track is
    /// built, so the keyframes and the show are never both whole in memory (a
    /// 10,000-ball minute of 5 keyframes a second is 24 MB of keyframes for 72 MB of
    /// rows).
    fn into_tracks(mut self, limits: CurveLimits) -> Vec<Track> {
        let mut velocities_mm_s = vec![0.0; self.times_ms.len()];
        let mut scratch = Vec::new();
        std::mem::take(&mut self.positions_mm)
            .into_iter()
            .map(|positions_mm| {
                keyframe_velocities(
                    &self.times_ms,
                    &positions_mm,
                    limits,
                    &mut velocities_mm_s,
                    &mut scratch,
                );
                self.track(&positions_mm, &velocities_mm_s)
            })
            .collect()
    }

    /// The bytes the tracks take in a show file (compact JSON, with the commas between
    /// them), computed row by row without keeping any.
    fn tracks_json_bytes(&self, limits: CurveLimits) -> usize {
        let mut velocities_mm_s = vec![0.0; self.times_ms.len()];
        let mut scratch = Vec::new();
        let tracks: usize = self
            .positions_mm
            .iter()
            .map(|positions_mm| {
                keyframe_velocities(
                    &self.times_ms,
                    positions_mm,
                    limits,
                    &mut velocities_mm_s,
                    &mut scratch,
                );
                let empty = Track {
                    start_mm: positions_mm.first().copied().unwrap_or_default(),
                    rows: Vec::new(),
                    colours: Vec::new(),
                };
                let (rows, bytes) = self
                    .rows(positions_mm, &velocities_mm_s)
                    .fold((0usize, 0usize), |(rows, bytes), row| {
                        (rows + 1, bytes + json_len(&row))
                    });
                json_len(&empty) + bytes + rows.saturating_sub(1)
            })
            .sum();
        tracks + self.positions_mm.len().saturating_sub(1)
    }

    fn track(&self, positions_mm: &[f64], velocities_mm_s: &[f64]) -> Track {
        let mut rows = Vec::with_capacity(self.rows_per_unit);
        rows.extend(self.rows(positions_mm, velocities_mm_s));
        Track {
            start_mm: positions_mm.first().copied().unwrap_or_default(),
            rows,
            colours: Vec::new(),
        }
    }

    /// One ball's rows, in order.
    fn rows<'a>(
        &'a self,
        positions_mm: &'a [f64],
        velocities_mm_s: &'a [f64],
    ) -> impl Iterator<Item = TrackRow> + 'a {
        (1..self.times_ms.len()).flat_map(move |i| {
            let gap_ms = self.times_ms[i] - self.times_ms[i - 1];
            let (p0, v0) = (positions_mm[i - 1], velocities_mm_s[i - 1]);
            let (p1, v1) = (positions_mm[i], velocities_mm_s[i]);
            // Equal rows (to the ms) on the same cubic, so the curve is unchanged.
            let pieces = split_count(gap_ms);
            let segment = Segment::new(p0, v0, p1, v1, gap_ms as f64 / 1000.0);
            let (short_ms, longer) = (gap_ms / pieces, gap_ms % pieces);
            (1..=pieces).map(move |piece| {
                // The time at the end of this piece: `piece` pieces, the first `longer`
                // of them 1 ms longer.
                let elapsed_ms = short_ms * piece + piece.min(longer);
                let duration_ms = short_ms + u64::from(piece <= longer);
                let (position_mm, velocity_mm_s) = if piece == pieces {
                    (p1, v1)
                } else {
                    let k = segment.kinematics_at_fraction(elapsed_ms as f64 / gap_ms as f64);
                    (k.position, k.velocity)
                };
                TrackRow::new(position_mm, velocity_mm_s, ms_u32(duration_ms))
            })
        })
    }
}

/// A row's duration; rows are at most 255 ms, so this never saturates.
fn ms_u32(ms: u64) -> u32 {
    u32::try_from(ms).unwrap_or(u32::MAX)
}

impl Coded for CsvError {
    fn code(&self) -> Code {
        self.problem.code()
    }

    /// The problem's parameters, and where: `line` and `column`.
    fn params(&self) -> Params {
        let mut params = self.problem.params();
        params.insert("line".into(), self.line.to_string());
        params.insert("column".into(), self.column.to_string());
        params
    }
}

impl Coded for CsvProblem {
    fn code(&self) -> Code {
        match self {
            Self::Empty => Code::CsvEmpty,
            Self::NoHeader => Code::CsvNoHeader,
            Self::MisplacedComment => Code::CsvMisplacedComment,
            Self::LayoutWord { .. } => Code::CsvLayoutWord,
            Self::LayoutValue { .. } => Code::CsvLayoutValue,
            Self::LayoutMissing { .. } => Code::CsvLayoutMissing,
            Self::HeaderName { .. } => Code::CsvHeaderName,
            Self::NoUnits => Code::CsvNoUnits,
            Self::LayoutMismatch { .. } => Code::CsvLayoutMismatch,
            Self::FieldCount { .. } => Code::CsvFieldCount,
            Self::NotANumber { .. } => Code::CsvNotANumber,
            Self::NoKeyframes => Code::CsvNoKeyframes,
            Self::FirstTimeNotZero { .. } => Code::CsvFirstTimeNotZero,
            Self::TimeNotIncreasing { .. } => Code::CsvTimeNotIncreasing,
            Self::GapTooShort { .. } => Code::CsvGapTooShort,
            Self::TooLate { .. } => Code::CsvTooLate,
            Self::TooLong { .. } => Code::CsvTooLong,
            Self::TooManyRows { .. } => Code::CsvTooManyRows,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Empty
            | Self::NoHeader
            | Self::MisplacedComment
            | Self::NoUnits
            | Self::NoKeyframes => Params::new(),
            Self::LayoutWord { text } | Self::NotANumber { text } => params! {"text" => text},
            Self::LayoutValue { key, text, .. } => params! {"key" => key, "text" => text},
            Self::LayoutMissing { key } => params! {"key" => key},
            Self::HeaderName { found, expected } => {
                params! {"found" => found, "expected" => expected}
            }
            Self::LayoutMismatch {
                units, rows, cols, ..
            } => params! {"units" => units, "rows" => rows, "cols" => cols},
            Self::FieldCount { found, expected } => {
                params! {"found" => found, "expected" => expected}
            }
            Self::FirstTimeNotZero { time_ms } | Self::TooLate { time_ms } => {
                params! {"time_ms" => time_ms}
            }
            Self::TimeNotIncreasing {
                time_ms,
                previous_ms,
                previous_line,
            } => params! {
                "time_ms" => time_ms,
                "previous_ms" => previous_ms,
                "previous_line" => previous_line,
            },
            Self::GapTooShort {
                gap_ms,
                previous_line,
            } => params! {
                "gap_ms" => gap_ms,
                "previous_line" => previous_line,
                "min_ms" => ROW_MIN_MS,
            },
            Self::TooLong { time_ms, max_ms } => params! {"time_ms" => time_ms, "max_ms" => max_ms},
            Self::TooManyRows { rows } => params! {"rows" => rows, "max_rows" => MAX_TOTAL_ROWS},
        }
    }
}

impl Coded for ImportError {
    fn code(&self) -> Code {
        match self {
            Self::Csv(error) => error.code(),
            Self::TooLarge { .. } => Code::CsvConvertedTooLarge,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Csv(error) => error.params(),
            Self::TooLarge {
                bytes, max_bytes, ..
            } => params! {"bytes" => bytes, "max_bytes" => max_bytes},
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    /// One row of two balls, 500 mm apart.
    pub(in crate::show) const ONE_BY_TWO: Layout = Layout {
        rows: 1,
        cols: 2,
        pitch_mm: 500.0,
    };

    fn import(text: &str) -> Result<Show, CsvError> {
        import_csv("test", text, ONE_BY_TWO)
    }

    fn error_at(text: &str) -> (usize, usize, CsvProblem) {
        let error = import(text).unwrap_err();
        (error.line, error.column, error.problem)
    }

    #[test]
    fn imports_keyframes_as_rows_ending_on_them() {
        let show =
            import("time_ms,u0,u1\n0,100,200\n100,200,200\n200,400,100\n300,400,0\n").unwrap();
        assert_eq!(show.layout, ONE_BY_TWO);
        let track = &show.tracks[0];
        assert_eq!(track.start_mm, 100.0);
        let rows: Vec<_> = track
            .rows
            .iter()
            .map(|r| (r.position_mm, r.duration_ms))
            .collect();
        assert_eq!(rows, [(200.0, 100), (400.0, 100), (400.0, 100)]);
        // Rising into a hold: the velocity at 200 is positive, at the end 0 (at rest).
        assert!(track.rows[0].velocity_mm_s > 0.0);
        assert_eq!(track.rows[2].velocity_mm_s, 0.0);
        // Velocities are the smooth curve's (the clamped spline), not forced to 0 where
        // the slope changes: ball 1, level and then falling, is already moving up at
        // 100 ms.
        assert!(show.tracks[1].rows[0].velocity_mm_s < 0.0);
        show.check().unwrap();
    }

    const ROOMY: ImportLimits = ImportLimits {
        max_duration_ms: 30 * 60 * 1000,
        max_json_bytes: 32 * 1024 * 1024,
        curve: CurveLimits::DEFAULT,
    };

    #[test]
    fn the_size_is_known_exactly_before_the_rows_are_built() {
        // Gaps that split into rows of unequal length, curves with decimals.
        let text = "time_ms,u0,u1\n0,100,200\n1000.4,1234.5,17\n1513,10,17\n9999,7000,3.25\n";
        let show = import_csv_within("exact", text, ONE_BY_TWO, ROOMY).unwrap();
        assert_eq!(show, import_csv("exact", text, ONE_BY_TWO).unwrap());
        let bytes = show.to_json().unwrap().len();
        let just = ImportLimits {
            max_json_bytes: bytes,
            ..ROOMY
        };
        assert_eq!(import_csv_within("exact", text, ONE_BY_TWO, just), Ok(show));
        let under = ImportLimits {
            max_json_bytes: bytes - 1,
            ..ROOMY
        };
        assert_eq!(
            import_csv_within("exact", text, ONE_BY_TWO, under),
            Err(ImportError::TooLarge {
                bytes,
                max_bytes: bytes - 1,
                exact: true
            })
        );
    }

    #[test]
    fn keyframes_far_apart_are_refused_before_they_become_rows() {
        // Two keyframes 7 hours apart: nearly 100,000 rows per ball.
        let text = "time_ms,u0,u1\n0,0,0\n25200000,100,100\n";
        let Err(ImportError::Csv(error)) = import_csv_within("far", text, ONE_BY_TWO, ROOMY) else {
            panic!("not refused for its duration");
        };
        assert_eq!((error.line, error.column), (3, 1));
        assert!(matches!(
            error.problem,
            CsvProblem::TooLong {
                max_ms: 1_800_000,
                ..
            }
        ));
        assert!(error.to_string().contains("1800000 ms"), "{error}");
        // Within the duration but not the size: refused by the least size it can have.
        let long = ImportLimits {
            max_duration_ms: 86_400_000,
            max_json_bytes: 1024 * 1024,
            curve: CurveLimits::DEFAULT,
        };
        match import_csv_within("far", text, ONE_BY_TWO, long) {
            Err(ImportError::TooLarge {
                bytes,
                max_bytes,
                exact: false,
            }) => {
                assert!(bytes > 2 * 98_000 * MIN_ROW_JSON_BYTES, "{bytes}");
                assert_eq!(max_bytes, 1024 * 1024);
            }
            other => panic!("{other:?}"),
        }
    }

    /// `centre − amplitude · cos(2π t / period)` sampled at `rate` keyframes a second
    /// for whole periods (so from rest to rest), positions to 0.001 mm as a 3D tool
    /// exports them.
    fn sampled_sine(period_s: f64, amplitude: f64, centre: f64, periods: u32, rate: u32) -> String {
        let w = 2.0 * std::f64::consts::PI / period_s;
        let frames = (period_s * f64::from(periods * rate)).round() as u32;
        let mut text = String::from("time_ms,u0\n");
        for k in 0..=frames {
            let t = f64::from(k) / f64::from(rate);
            let p = centre - amplitude * (w * t).cos();
            text.push_str(&format!("{},{p:.3}\n", (t * 1000.0).round()));
        }
        text
    }

    #[test]
    fn a_sampled_sine_is_kept_and_accepted() {
        use crate::show::{Limits, Refused, ShowFormat, UploadLimits, import};
        let one = Layout {
            rows: 1,
            cols: 1,
            pitch_mm: 500.0,
        };
        let upload = UploadLimits {
            motion: Limits::for_layout(1, 1),
            max_duration_ms: 30 * 60 * 1000,
            max_json_bytes: 1 << 20,
            mbox_boxes: None,
        };
        let admit = |text: &str| {
            import(
                "s",
                text.as_bytes(),
                ShowFormat::Csv,
                Some(one),
                Some(&upload),
            )
        };
        // The issue's wave: 3 s, 880 mm (peaks 1843 mm/s, 3860 mm/s²), 10 keyframes a
        // second, three periods. Accepted, and within 0.5 mm of the sine everywhere.
        let w = 2.0 * std::f64::consts::PI / 3.0;
        let show = admit(&sampled_sine(3.0, 880.0, 1500.0, 3, 10)).expect("accepted");
        let mut largest: f64 = 0.0;
        for (start_ms, segment) in show.tracks[0].segments() {
            for i in 0..=(segment.duration_s * 1000.0).round() as u32 {
                let tau = f64::from(i) / 1000.0;
                let t = start_ms as f64 / 1000.0 + tau;
                largest =
                    largest.max((segment.position(tau) - (1500.0 - 880.0 * (w * t).cos())).abs());
            }
        }
        assert!(largest <= 0.5, "{largest} mm");
        // Its peak acceleration is the sine's to within 1 %.
        let peak = show.tracks[0]
            .segments()
            .map(|(_, segment)| segment.peak_acceleration().value)
            .fold(0.0, f64::max);
        assert!((peak / (880.0 * w * w) - 1.0).abs() < 0.01, "{peak}");
        // The raised cosine of the issue, from rest at the top: accepted at 10 a second.
        assert!(admit(&sampled_sine(2.9, 750.0, 750.0, 2, 10)).is_ok());
        // Exactly when the sine is within the limits: 940 mm (4123 mm/s²) is refused
        // for its acceleration, at every rate.
        for rate in [25, 10, 5] {
            assert!(
                admit(&sampled_sine(3.0, 880.0, 1500.0, 3, rate)).is_ok(),
                "{rate}"
            );
            let Err(Refused::Unfit(violations)) = admit(&sampled_sine(3.0, 940.0, 1500.0, 3, rate))
            else {
                panic!("940 mm at {rate} a second accepted");
            };
            assert!(
                violations
                    .iter()
                    .all(|v| matches!(v.kind, crate::show::ViolationKind::Acceleration { .. }))
            );
        }
    }

    #[test]
    fn interior_velocity_is_the_clamped_splines() {
        // Equal spacing, slopes 10 and 30 mm/s, at rest at both ends: the C² condition
        // 2 (10 + 10) v = 3 (10·10 + 30·10) gives v = 30 mm/s.
        let show = import("time_ms,u0,u1\n0,0,0\n100,1,0\n200,4,0\n").unwrap();
        assert!((show.tracks[0].rows[0].velocity_mm_s - 30.0).abs() < 1e-9);
    }

    #[test]
    fn layout_line_and_padding() {
        let show = import_csv(
            "t",
            "# rows=2 cols=1 pitch_mm=750\r\n time_ms , u0 , u1 \r\n\r\n0, 1 ,2\r\n10,1,2\r\n",
            Layout {
                rows: 9,
                cols: 9,
                pitch_mm: 1.0,
            },
        )
        .unwrap();
        assert_eq!(
            show.layout,
            Layout {
                rows: 2,
                cols: 1,
                pitch_mm: 750.0
            }
        );
        // pitch_mm may be left out: the installation's is used.
        let show = import("# cols=2 rows=1\ntime_ms,u0,u1\n0,1,2\n").unwrap();
        assert_eq!(show.layout, ONE_BY_TWO);
        assert!(show.tracks[0].rows.is_empty());
    }

    #[test]
    fn without_an_installation_the_grid_is_as_square_as_the_ball_count_allows() {
        let grid = |units| {
            let layout = square_layout(units);
            (layout.rows, layout.cols)
        };
        assert_eq!(grid(12), (3, 4));
        assert_eq!(grid(7), (1, 7));
        assert_eq!(grid(16), (4, 4));
        assert_eq!(grid(0), (1, 1));
        assert_eq!(square_layout(2).pitch_mm, DEFAULT_PITCH_MM);

        let four = "time_ms,u0,u1,u2,u3\n0,100,100,100,100\n500,200,300,400,500\n";
        let show = convert("four", four, None, CurveLimits::DEFAULT).unwrap();
        assert_eq!(show.layout, square_layout(4));
        assert_eq!(show.name, "four");
        assert_eq!(show.duration_ms(), 500);
        // A layout line still wins, with the assumed pitch when it names none.
        let show = convert(
            "t",
            "# rows=1 cols=2\ntime_ms,u0,u1\n0,1,2\n",
            None,
            CurveLimits::DEFAULT,
        )
        .unwrap();
        assert_eq!(
            show.layout,
            Layout {
                rows: 1,
                cols: 2,
                pitch_mm: DEFAULT_PITCH_MM
            }
        );
        // And it is checked against the columns as with an installation.
        let error = convert(
            "t",
            "# rows=2 cols=2\ntime_ms,u0,u1\n0,1,2\n",
            None,
            CurveLimits::DEFAULT,
        )
        .unwrap_err();
        assert_eq!((error.line, error.column), (2, 4));
        assert!(matches!(
            error.problem,
            CsvProblem::LayoutMismatch { units: 2, .. }
        ));
    }

    #[test]
    fn decimal_times_round_on_their_own() {
        let mut csv = String::from("time_ms,u0,u1\n");
        for frame in 0..=300 {
            let t = f64::from(frame) * 100.0 / 3.0;
            csv.push_str(&format!("{t:.3},{},0\n", frame % 7));
        }
        let show = import(&csv).unwrap();
        let track = &show.tracks[0];
        assert_eq!(track.rows.len(), 300);
        assert_eq!(track.duration_ms(), 10_000, "no drift over 300 frames");
        let durations: Vec<_> = track.rows.iter().take(3).map(|r| r.duration_ms).collect();
        assert_eq!(durations, [33, 34, 33]);
    }

    #[test]
    fn long_gaps_split_on_the_same_cubic() {
        let show = import("time_ms,u0,u1\n0,0,0\n100,500,0\n1100,1500,0\n1200,1600,0\n").unwrap();
        let track = &show.tracks[0];
        let durations: Vec<_> = track.rows.iter().map(|r| r.duration_ms).collect();
        assert_eq!(durations, [100, 250, 250, 250, 250, 100]);
        assert_eq!(track.rows[4].position_mm, 1500.0);
        // The pieces trace the cubic of the unsplit gap.
        let v100 = track.rows[0].velocity_mm_s;
        let v1100 = track.rows[4].velocity_mm_s;
        let whole = Segment::new(500.0, v100, 1500.0, v1100, 1.0);
        let pieces: Vec<_> = track.segments().collect();
        for &(start_ms, piece) in &pieces[1..5] {
            for i in 0..=10 {
                let tau = piece.duration_s * f64::from(i) / 10.0;
                let on_whole = whole.position((start_ms as f64 - 100.0) / 1000.0 + tau);
                assert!((piece.position(tau) - on_whole).abs() < 1e-9);
            }
        }
        // 1001 ms: 4 rows of 251 and 250 ms, summing exactly.
        let show = import("time_ms,u0,u1\n0,0,0\n1001,10,0\n").unwrap();
        let durations: Vec<_> = show.tracks[0].rows.iter().map(|r| r.duration_ms).collect();
        assert_eq!(durations, [251, 250, 250, 250]);
    }

    #[test]
    fn errors_name_line_and_column() {
        assert_eq!(error_at(""), (1, 1, CsvProblem::Empty));
        assert_eq!(
            error_at("# rows=1 cols=2\n\n"),
            (2, 1, CsvProblem::NoHeader)
        );
        assert_eq!(
            error_at("time_ms,u0,u2\n"),
            (
                1,
                3,
                CsvProblem::HeaderName {
                    found: "u2".into(),
                    expected: "u1".into()
                }
            )
        );
        assert_eq!(error_at("time_ms\n0\n"), (1, 2, CsvProblem::NoUnits));
        assert_eq!(
            error_at("time_ms,u0,u1,u2\n"),
            (
                1,
                4,
                CsvProblem::LayoutMismatch {
                    units: 3,
                    rows: 1,
                    cols: 2,
                    origin: "from the installation"
                }
            )
        );
        assert_eq!(
            error_at("# rows=2 cols=2\ntime_ms,u0,u1\n").2,
            CsvProblem::LayoutMismatch {
                units: 2,
                rows: 2,
                cols: 2,
                origin: "from line 1"
            }
        );
        assert_eq!(
            error_at("# rows=1 colz=2\ntime_ms,u0,u1\n"),
            (
                1,
                10,
                CsvProblem::LayoutWord {
                    text: "colz=2".into()
                }
            )
        );
        assert_eq!(error_at("# rows=0 cols=2\n").1, 3);
        assert_eq!(
            error_at("# rows=1\ntime_ms,u0,u1\n").2,
            CsvProblem::LayoutMissing { key: "cols" }
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n# hello\n"),
            (2, 1, CsvProblem::MisplacedComment)
        );
        assert_eq!(error_at("time_ms,u0,u1\n"), (2, 1, CsvProblem::NoKeyframes));
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,x1\n"),
            (2, 3, CsvProblem::NotANumber { text: "x1".into() })
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,NaN\n").1,
            3,
            "non-finite numbers are refused"
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1\n"),
            (
                2,
                3,
                CsvProblem::FieldCount {
                    found: 2,
                    expected: 3
                }
            )
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,2,3\n"),
            (
                2,
                4,
                CsvProblem::FieldCount {
                    found: 4,
                    expected: 3
                }
            )
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n5,1,2\n"),
            (2, 1, CsvProblem::FirstTimeNotZero { time_ms: 5.0 })
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,2\n\n100,1,2\n100,1,2\n"),
            (
                5,
                1,
                CsvProblem::TimeNotIncreasing {
                    time_ms: 100.0,
                    previous_ms: 100.0,
                    previous_line: 4
                }
            )
        );
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,2\n9.4,1,2\n"),
            (
                3,
                1,
                CsvProblem::GapTooShort {
                    gap_ms: 9,
                    previous_line: 2
                }
            )
        );
        // 9.6 ms rounds to 10: accepted.
        assert!(import("time_ms,u0,u1\n0,1,2\n9.6,1,2\n").is_ok());
        assert_eq!(
            error_at("time_ms,u0,u1\n0,1,2\n86400001,1,2\n"),
            (
                3,
                1,
                CsvProblem::TooLate {
                    time_ms: 86_400_001.0
                }
            )
        );
        let wide = Layout {
            rows: 1,
            cols: 40,
            pitch_mm: 500.0,
        };
        let header: Vec<_> = (0..40).map(|u| format!("u{u}")).collect();
        let zeros = vec!["0"; 40].join(",");
        let csv = format!(
            "time_ms,{}\n0,{zeros}\n86400000,{zeros}\n",
            header.join(",")
        );
        let error = import_csv("t", &csv, wide).unwrap_err();
        assert_eq!((error.line, error.column), (3, 1));
        assert!(matches!(error.problem, CsvProblem::TooManyRows { .. }));
        // The message reads as a sentence with its place.
        let error = import("time_ms,u0,u1\n0,1,x\n").unwrap_err();
        assert_eq!(error.to_string(), "line 2, column 3: \"x\" is not a number");
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;
    use crate::show::{DEFAULT_TRAVEL_MM, Limits, ViolationKind, validate};

    /// Balls, then keyframes as (gap before it in ms with decimals, a position per
    /// ball in [0, travel], often right at the ends).
    fn keyframes() -> impl Strategy<Value = (usize, Vec<(f64, Vec<f64>)>)> {
        (1usize..4).prop_flat_map(|units| {
            let position =
                prop_oneof![Just(0.0), Just(DEFAULT_TRAVEL_MM), 0.0..=DEFAULT_TRAVEL_MM,];
            let frame = (10.5..700.0f64, proptest::collection::vec(position, units));
            (Just(units), proptest::collection::vec(frame, 1..30))
        })
    }

    /// The CSV text, and the keyframe times (ms) as the importer rounds them.
    fn csv(units: usize, frames: &[(f64, Vec<f64>)]) -> (String, Vec<u64>) {
        let header: Vec<_> = (0..units).map(|u| format!("u{u}")).collect();
        let mut text = format!("time_ms,{}\n", header.join(","));
        let mut times_ms = Vec::new();
        let mut time_ms = 0.0;
        for (index, (gap_ms, positions)) in frames.iter().enumerate() {
            if index > 0 {
                time_ms += gap_ms;
            }
            let time = format!("{time_ms:.3}");
            times_ms.push(time.parse::<f64>().unwrap().round() as u64);
            let values: Vec<_> = positions.iter().map(f64::to_string).collect();
            text.push_str(&format!("{time},{}\n", values.join(",")));
        }
        (text, times_ms)
    }

    proptest! {
        #[test]
        fn the_size_known_before_building_is_the_files_size((units, frames) in keyframes()) {
            let (text, _) = csv(units, &frames);
            let layout = Layout { rows: 1, cols: u32::try_from(units).unwrap(), pitch_mm: 500.0 };
            let show = import_csv("p", &text, layout).unwrap();
            let bytes = show.to_json().unwrap().len();
            let limits = |max_json_bytes| ImportLimits {
                max_duration_ms: 86_400_000,
                max_json_bytes,
                curve: CurveLimits::DEFAULT,
            };
            prop_assert_eq!(import_csv_within("p", &text, layout, limits(bytes)), Ok(show));
            prop_assert!(
                matches!(
                    import_csv_within("p", &text, layout, limits(bytes - 1)),
                    Err(ImportError::TooLarge { .. })
                ),
                "one byte less is too large"
            );
        }

        #[test]
        fn imported_tracks_pass_every_keyframe_and_stay_in_travel((units, frames) in keyframes()) {
            let (text, times_ms) = csv(units, &frames);
            let layout = Layout { rows: 1, cols: u32::try_from(units).unwrap(), pitch_mm: 500.0 };
            let show = import_csv("p", &text, layout).unwrap();
            show.check().unwrap();
            for (unit, track) in show.tracks.iter().enumerate() {
                let keyframe = |i: usize| frames[i].1[unit];
                prop_assert_eq!(track.start_mm, keyframe(0));
                // Walk the rows: every keyframe time is a row end exactly on the keyframe,
                // and the curve never leaves 0 … travel (it may pass its keyframes: turning
                // points are not flattened).
                let mut next = 1;
                for (start_ms, segment) in track.segments() {
                    let end_ms = start_ms + (segment.duration_s * 1000.0).round() as u64;
                    let (a, b) = (keyframe(next - 1), keyframe(next));
                    let range = segment.position_range();
                    let slack = 1e-9 * DEFAULT_TRAVEL_MM;
                    prop_assert!(range.min.value >= -slack, "{range:?} {a} {b}");
                    prop_assert!(range.max.value <= DEFAULT_TRAVEL_MM + slack, "{range:?} {a} {b}");
                    prop_assert!((10..=255).contains(&((segment.duration_s * 1000.0).round() as u64)));
                    if end_ms == times_ms[next] {
                        prop_assert_eq!(segment.p1, b);
                        next += 1;
                    } else {
                        prop_assert!(end_ms < times_ms[next]);
                    }
                }
                prop_assert_eq!(next, frames.len(), "every keyframe reached");
                prop_assert_eq!(track.rows.last().map_or(0.0, |row| row.velocity_mm_s), 0.0);
            }
            // Validation agrees: no ball leaves the travel.
            let violations = validate(&show, &Limits::for_layout(1, layout.cols));
            prop_assert!(!violations.iter().any(|v| matches!(
                v.kind,
                ViolationKind::AboveTop { .. } | ViolationKind::BelowTravel { .. }
            )), "{violations:?}");
        }

        #[test]
        fn any_travel_is_kept(
            (units, frames) in keyframes(),
            travel in 50.0..=DEFAULT_TRAVEL_MM,
            speed in 100.0..3000.0f64,
            accel in 100.0..6000.0f64,
        ) {
            // The same keyframes scaled into a shorter travel, with other limits.
            let scale = travel / DEFAULT_TRAVEL_MM;
            let frames: Vec<_> = frames
                .into_iter()
                .map(|(gap, positions)| (gap, positions.iter().map(|p| p * scale).collect()))
                .collect();
            let (text, _) = csv(units, &frames);
            let layout = Layout { rows: 1, cols: u32::try_from(units).unwrap(), pitch_mm: 500.0 };
            let limits = ImportLimits {
                max_duration_ms: 86_400_000,
                max_json_bytes: usize::MAX,
                curve: CurveLimits { travel_mm: travel, max_speed_mm_s: speed, max_accel_mm_s2: accel },
            };
            let show = import_csv_within("p", &text, layout, limits).unwrap();
            for (unit, track) in show.tracks.iter().enumerate() {
                prop_assert_eq!(track.start_mm, frames[0].1[unit]);
                for (_, segment) in track.segments() {
                    let range = segment.position_range();
                    // The keyframes, scaled, may lie a rounding beyond the travel.
                    let slack = 1e-9 * DEFAULT_TRAVEL_MM;
                    let bottom = travel.max(segment.p0).max(segment.p1);
                    prop_assert!(range.min.value >= -slack, "{range:?}");
                    prop_assert!(range.max.value <= bottom + slack, "{range:?} {travel}");
                }
            }
        }

        #[test]
        fn any_text_is_imported_or_refused_without_panic(text in "[0-9u#=,.\\-e \n]{0,120}") {
            let layout = Layout { rows: 1, cols: 2, pitch_mm: 500.0 };
            let _ = import_csv("p", &format!("time_ms,u0,u1\n{text}"), layout);
            let _ = import_csv("p", &text, layout);
        }
    }
}
