//! Recipes: a show as a small JSON file that regenerates it byte for byte — a name,
//! the row length, the matrix it was made for (optional) and a timeline of segments
//! (pattern + parameters + duration), each blending smoothly into the next over its
//! `transition_s`.
//!
//! ```json
//! { "format": "floatball-recipe", "version": 1, "name": "lobby wave",
//!   "row_ms": 200,
//!   "grid": { "rows": 10, "cols": 10, "pitch_mm": 500, "travel_mm": 7500 },
//!   "segments": [
//!     { "pattern": "wave", "params": { "wavelength_m": 3, "amplitude_mm": 800 },
//!       "duration_s": 20, "transition_s": 2 },
//!     { "pattern": "ripple", "params": {}, "duration_s": 20, "transition_s": 2 }
//!   ] }
//! ```
//!
//! # The timeline
//! Segment i's pattern starts (its time 0) when the transition into it begins, runs
//! alone for `duration_s`, then for its `transition_s` both it and the next pattern run
//! and the position blends from one to the other with the weight
//! [`smooth_step`](super::smooth_step) (6x⁵ − 15x⁴ + 10x³: zero slope and curvature at
//! both ends), so position and velocity are continuous at every boundary. The last
//! segment's `transition_s` is not used; a transition lasts at least
//! [`MIN_TRANSITION_S`] (a sudden switch would jump) and 2 s unless given. The show lasts the sum of the durations and
//! of the transitions between segments, rounded up to whole rows.
//!
//! The show starts and ends at rest: over its first [`EASE_S`] the timeline plays
//! from standstill up to its normal speed (the speed's rise a smooth step), and over
//! its last [`EASE_S`] back down to standstill, so every ball is at rest where its
//! pattern begins, ends at rest, and never moves faster than its pattern. This makes
//! the show [`EASE_S`] longer than the timeline (half at each end; less for a
//! timeline shorter than it).

use serde::{Deserialize, Serialize};

use super::params::{Params, Value};
use super::{CreateError, Grid};
use crate::uim2503::pvt::{ROW_MAX_MS, ROW_MIN_MS};

/// The `"format"` of a recipe file.
pub const FORMAT: &str = "floatball-recipe";

/// The recipe format version this code reads and writes.
pub const VERSION: u64 = 1;

/// Most segments in a recipe.
pub const MAX_SEGMENTS: usize = 64;

/// Longest show a recipe may make, s (an hour).
pub const MAX_SHOW_S: f64 = 3600.0;

/// Shortest segment, s.
pub const MIN_DURATION_S: f64 = 0.5;

/// Shortest transition, s: a sudden switch between two patterns would jump.
pub const MIN_TRANSITION_S: f64 = 0.5;

/// Longest transition, s.
pub const MAX_TRANSITION_S: f64 = 60.0;

/// Transition unless the segment says, s.
pub const DEFAULT_TRANSITION_S: f64 = 2.0;

/// Row length unless the recipe says, ms.
pub const DEFAULT_ROW_MS: u32 = 200;

/// Time the show takes to reach the timeline's speed from rest at the start, and to
/// come back to rest at the end, s.
pub const EASE_S: f64 = 2.0;

/// One segment of the timeline: a pattern with its parameters for `duration_s`, then
/// `transition_s` of blending into the next segment.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Segment {
    /// The pattern's name ([`super::PATTERNS`]).
    pub pattern: String,
    /// Its parameters; missing ones take their defaults.
    #[serde(default)]
    pub params: Params,
    /// Seconds the pattern runs alone.
    pub duration_s: f64,
    /// Seconds of smooth blending into the next segment ([`MIN_TRANSITION_S`] to
    /// [`MAX_TRANSITION_S`], default [`DEFAULT_TRANSITION_S`]); not used after the
    /// last segment.
    #[serde(default = "default_transition_s")]
    pub transition_s: f64,
}

fn default_transition_s() -> f64 {
    DEFAULT_TRANSITION_S
}

fn default_row_ms() -> u32 {
    DEFAULT_ROW_MS
}

/// A recipe: what regenerates a show.
#[derive(Debug, Clone, PartialEq)]
pub struct Recipe {
    /// The show's name.
    pub name: String,
    /// Every PVT row's length, ms (10–255).
    pub row_ms: u32,
    /// The matrix it was made for, if known: `floatball generate --recipe` renders for
    /// it unless told another; the app renders for the installation it is connected
    /// to, and offline for this grid's rows and columns.
    pub grid: Option<Grid>,
    /// The timeline.
    pub segments: Vec<Segment>,
}

/// The file as read and written.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    format: String,
    version: u64,
    name: String,
    #[serde(default = "default_row_ms")]
    row_ms: u32,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    grid: Option<Grid>,
    segments: Vec<Segment>,
}

/// Just the identifying fields, to explain why a file does not read.
#[derive(Deserialize)]
struct Header {
    format: Option<String>,
    version: Option<u64>,
}

/// Where each segment lies on the show's time axis, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Span {
    /// When the pattern's own time is 0: the start of the transition into it (the
    /// show's start for the first).
    pub begin_s: f64,
    /// When it runs alone from.
    pub alone_s: f64,
    /// When the transition out of it begins (it stops running alone).
    pub end_s: f64,
    /// When the transition out of it ends (= `end_s` for the last segment).
    pub out_s: f64,
}

impl Recipe {
    /// A recipe of one segment: `pattern` with `params` for `duration_s`.
    #[must_use]
    pub fn single(name: &str, pattern: &str, params: Params, duration_s: f64) -> Self {
        Self {
            name: name.to_owned(),
            row_ms: DEFAULT_ROW_MS,
            grid: None,
            segments: vec![Segment {
                pattern: pattern.to_owned(),
                params,
                duration_s,
                transition_s: DEFAULT_TRANSITION_S,
            }],
        }
    }

    /// Reads a recipe and [checks](Self::check) its timeline.
    ///
    /// # Errors
    /// [`CreateError::Recipe`] for text that is not a recipe of this version (unknown
    /// fields refused), or the errors of [`check`](Self::check).
    pub fn from_json(text: &str) -> Result<Self, CreateError> {
        let file = match serde_json::from_str::<File>(text) {
            Ok(file) => file,
            Err(error) => {
                if let Ok(header) = serde_json::from_str::<Header>(text) {
                    check_header(header.format.as_deref(), header.version)?;
                }
                return Err(CreateError::Recipe {
                    message: error.to_string(),
                });
            }
        };
        check_header(Some(&file.format), Some(file.version))?;
        let recipe = Self {
            name: file.name,
            row_ms: file.row_ms,
            grid: file.grid,
            segments: file.segments,
        };
        recipe.check()?;
        Ok(recipe)
    }

    /// The recipe as its file holds it: every number rounded to 15 significant digits
    /// (see [`Recipe::to_json`]). [`super::render`] renders this, so the show made on
    /// the page and the one made from the saved recipe are the same, row for row.
    #[must_use]
    pub fn filed(&self) -> Self {
        Self {
            name: self.name.clone(),
            row_ms: self.row_ms,
            grid: self.grid.map(|grid| Grid {
                pitch_mm: digits15(grid.pitch_mm),
                travel_mm: digits15(grid.travel_mm),
                ..grid
            }),
            segments: self
                .segments
                .iter()
                .map(|segment| Segment {
                    pattern: segment.pattern.clone(),
                    params: segment
                        .params
                        .iter()
                        .map(|(key, value)| {
                            let value = match value {
                                Value::Number(number) => Value::Number(digits15(*number)),
                                Value::Text(text) => Value::Text(text.clone()),
                            };
                            (key.clone(), value)
                        })
                        .collect(),
                    duration_s: digits15(segment.duration_s),
                    transition_s: digits15(segment.transition_s),
                })
                .collect(),
        }
    }

    /// The recipe as pretty JSON (parameters in key order: the same recipe always
    /// gives the same text). Numbers are written with at most 15 significant digits
    /// ([`Recipe::filed`]), so the file reads back as exactly the recipe it holds and
    /// writes back as the same text: a recipe file renders the same show every time,
    /// and the same show as the recipe it was saved from.
    ///
    /// # Errors
    /// [`CreateError::Recipe`] if serialisation fails.
    pub fn to_json(&self) -> Result<String, CreateError> {
        let filed = self.filed();
        let file = File {
            format: FORMAT.to_owned(),
            version: VERSION,
            name: filed.name,
            row_ms: filed.row_ms,
            grid: filed.grid,
            segments: filed.segments,
        };
        serde_json::to_string_pretty(&file)
            .map(|mut text| {
                text.push('\n');
                text
            })
            .map_err(|error| CreateError::Recipe {
                message: error.to_string(),
            })
    }

    /// Checks the timeline: at least one and at most [`MAX_SEGMENTS`] segments, every
    /// duration from [`MIN_DURATION_S`] and transition from [`MIN_TRANSITION_S`] to
    /// [`MAX_TRANSITION_S`],
    /// the whole show at most [`MAX_SHOW_S`], rows of 10–255 ms, the grid (if any) not
    /// empty. (The patterns and their parameters are checked when rendered.)
    ///
    /// # Errors
    /// The [`CreateError`] saying what to change.
    pub fn check(&self) -> Result<(), CreateError> {
        if let Some(grid) = &self.grid {
            grid.check()?;
        }
        if self.segments.is_empty() {
            return Err(CreateError::EmptyTimeline);
        }
        if self.segments.len() > MAX_SEGMENTS {
            return Err(CreateError::TooManySegments {
                segments: self.segments.len(),
                max: MAX_SEGMENTS,
            });
        }
        if !(u32::from(ROW_MIN_MS)..=u32::from(ROW_MAX_MS)).contains(&self.row_ms) {
            return Err(CreateError::Recipe {
                message: format!(
                    "row_ms is {}; a row must last {ROW_MIN_MS} to {ROW_MAX_MS} ms",
                    self.row_ms
                ),
            });
        }
        for (index, segment) in self.segments.iter().enumerate() {
            let within =
                |value: f64, min: f64, max: f64| value.is_finite() && (min..=max).contains(&value);
            if !within(segment.duration_s, MIN_DURATION_S, MAX_SHOW_S) {
                return Err(CreateError::Duration {
                    segment: index + 1,
                    key: "duration_s",
                    value: segment.duration_s,
                    min_s: MIN_DURATION_S,
                    max_s: MAX_SHOW_S,
                });
            }
            if !within(segment.transition_s, MIN_TRANSITION_S, MAX_TRANSITION_S) {
                return Err(CreateError::Duration {
                    segment: index + 1,
                    key: "transition_s",
                    value: segment.transition_s,
                    min_s: MIN_TRANSITION_S,
                    max_s: MAX_TRANSITION_S,
                });
            }
        }
        let seconds = self.duration_s();
        if seconds > MAX_SHOW_S {
            return Err(CreateError::TooLong {
                seconds,
                max_s: MAX_SHOW_S,
            });
        }
        Ok(())
    }

    /// The timeline's length, s: the durations and the transitions between segments
    /// (before rounding up to whole rows).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.spans().last().map_or(0.0, |span| span.out_s)
    }

    /// Where each segment lies in time.
    #[must_use]
    pub fn spans(&self) -> Vec<Span> {
        let last = self.segments.len().saturating_sub(1);
        let mut begin_s = 0.0;
        let mut alone_s = 0.0;
        self.segments
            .iter()
            .enumerate()
            .map(|(index, segment)| {
                let end_s = alone_s + segment.duration_s;
                let out_s = if index < last {
                    end_s + segment.transition_s
                } else {
                    end_s
                };
                let span = Span {
                    begin_s,
                    alone_s,
                    end_s,
                    out_s,
                };
                begin_s = end_s;
                alone_s = out_s;
                span
            })
            .collect()
    }
}

/// `value` rounded to 15 significant digits: JSON readers read such a number back
/// exactly (a 17-digit one may come back a bit off).
fn digits15(value: f64) -> f64 {
    format!("{value:.14e}").parse().unwrap_or(value)
}

fn check_header(format: Option<&str>, version: Option<u64>) -> Result<(), CreateError> {
    match (format, version) {
        (Some(FORMAT), Some(VERSION) | None) => Ok(()),
        (Some(FORMAT), Some(found)) => Err(CreateError::Recipe {
            message: format!(
                "this recipe is format version {found}, but this Floatball reads version \
                 {VERSION}; update Floatball to open it"
            ),
        }),
        (found, _) => Err(CreateError::Recipe {
            message: format!(
                "this is not a Floatball recipe: \"format\" is {:?}, expected \"{FORMAT}\"",
                found.unwrap_or_default()
            ),
        }),
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const EXAMPLE: &str = r#"{ "format": "floatball-recipe", "version": 1, "name": "lobby wave",
      "row_ms": 200,
      "segments": [
        { "pattern": "wave", "params": { "wavelength_m": 3, "amplitude_mm": 800, "speed_m_s": 0.5, "direction": "right" },
          "duration_s": 20, "transition_s": 2 },
        { "pattern": "ripple", "params": { "speed_m_s": 0.5 }, "duration_s": 10, "transition_s": 3 }
      ] }"#;

    #[test]
    fn reads_and_round_trips_a_recipe() {
        let recipe = Recipe::from_json(EXAMPLE).unwrap();
        assert_eq!(recipe.name, "lobby wave");
        assert_eq!(recipe.segments.len(), 2);
        assert_eq!(
            recipe.segments[0].params["direction"],
            Value::Text("right".into())
        );
        assert_eq!(
            recipe.segments[0].params["amplitude_mm"],
            Value::Number(800.0)
        );
        let json = recipe.to_json().unwrap();
        assert!(json.starts_with("{\n  \"format\": \"floatball-recipe\",\n  \"version\": 1,"));
        assert_eq!(Recipe::from_json(&json).unwrap(), recipe);
        assert_eq!(Recipe::from_json(&json).unwrap().to_json().unwrap(), json);
        // Numbers a reader could not read back exactly are written so it can.
        let mut odd = recipe.clone();
        odd.segments[0]
            .params
            .insert("wavelength_m".into(), Value::Number(11.399999999999999));
        odd.segments[0].duration_s = 1.1 + 2.2;
        let json = odd.to_json().unwrap();
        assert!(json.contains("\"wavelength_m\": 11.4\n"), "{json}");
        assert!(json.contains("\"duration_s\": 3.3,"), "{json}");
        assert_eq!(Recipe::from_json(&json).unwrap().to_json().unwrap(), json);
        // The row length defaults.
        let short = EXAMPLE.replace(r#""row_ms": 200,"#, "");
        assert_eq!(Recipe::from_json(&short).unwrap().row_ms, DEFAULT_ROW_MS);
    }

    #[test]
    fn a_recipe_keeps_the_grid_it_was_made_for() {
        // None given, none written.
        let recipe = Recipe::from_json(EXAMPLE).unwrap();
        assert_eq!(recipe.grid, None);
        assert!(!recipe.to_json().unwrap().contains("grid"));
        // Given: read, written after the row length, and read back the same.
        let with_grid = EXAMPLE.replace(
            r#""row_ms": 200,"#,
            r#""row_ms": 200, "grid": { "rows": 6, "cols": 8, "pitch_mm": 600, "travel_mm": 5000 },"#,
        );
        let recipe = Recipe::from_json(&with_grid).unwrap();
        assert_eq!(recipe.grid, Some(Grid::new(6, 8, 600.0, 5000.0)));
        let json = recipe.to_json().unwrap();
        assert!(
            json.contains(
                "\"row_ms\": 200,\n  \"grid\": {\n    \"rows\": 6,\n    \"cols\": 8,\n    \"pitch_mm\": 600.0,\n    \"travel_mm\": 5000.0\n  },"
            ),
            "{json}"
        );
        assert_eq!(Recipe::from_json(&json).unwrap(), recipe);
        // An empty grid, or one with a field it does not know, is refused.
        let refused = |text: &str| Recipe::from_json(text).unwrap_err().to_string();
        assert!(refused(&with_grid.replace(r#""rows": 6"#, r#""rows": 0"#)).contains("0 × 8"));
        assert!(
            refused(&with_grid.replace(r#""pitch_mm": 600"#, r#""pitch": 600"#)).contains("pitch")
        );
    }

    #[test]
    fn the_timeline_puts_transitions_between_segments() {
        let recipe = Recipe::from_json(EXAMPLE).unwrap();
        let spans = recipe.spans();
        assert_eq!(
            spans[0],
            Span {
                begin_s: 0.0,
                alone_s: 0.0,
                end_s: 20.0,
                out_s: 22.0
            }
        );
        // The last segment's transition is not used.
        assert_eq!(
            spans[1],
            Span {
                begin_s: 20.0,
                alone_s: 22.0,
                end_s: 32.0,
                out_s: 32.0
            }
        );
        assert_eq!(recipe.duration_s(), 32.0);
    }

    #[test]
    fn bad_recipes_are_refused_with_what_to_change() {
        let refused = |text: &str| Recipe::from_json(text).unwrap_err().to_string();
        assert!(
            refused(&EXAMPLE.replace("floatball-recipe", "floatball-show"))
                .contains("not a Floatball recipe")
        );
        assert!(
            refused(&EXAMPLE.replace(r#""version": 1"#, r#""version": 2"#))
                .contains("update Floatball")
        );
        assert!(
            refused(&EXAMPLE.replace(r#""row_ms""#, r#""tempo": 1, "row_ms""#)).contains("tempo")
        );
        assert!(
            refused(&EXAMPLE.replace(r#""duration_s": 10"#, r#""durations": 10"#))
                .contains("durations")
        );
        assert!(refused(&EXAMPLE.replace("200", "300")).contains("10 to 255 ms"));
        assert_eq!(
            refused(&EXAMPLE.replace(r#""duration_s": 10"#, r#""duration_s": 0.1"#)),
            "segment 2: duration_s is 0.1 s; it must be from 0.5 to 3600 s"
        );
        assert!(
            refused(&EXAMPLE.replace(r#""transition_s": 3"#, r#""transition_s": -1"#))
                .contains("transition_s is -1")
        );
        assert!(
            refused(&EXAMPLE.replace(r#""duration_s": 20"#, r#""duration_s": 3590"#))
                .contains("at most 3600 s")
        );
        let mut recipe = Recipe::from_json(EXAMPLE).unwrap();
        recipe.segments.clear();
        assert_eq!(recipe.check(), Err(CreateError::EmptyTimeline));
        recipe.segments =
            vec![Recipe::single("x", "wave", Params::new(), 1.0).segments[0].clone(); 65];
        assert!(matches!(
            recipe.check(),
            Err(CreateError::TooManySegments {
                segments: 65,
                max: 64
            })
        ));
    }
}
