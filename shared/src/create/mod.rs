//! Show creation: shows generated from patterns, for any grid and pitch, within the
//! installation's limits by construction (issue 19).
//!
//! A pattern ([`catalogue::PATTERNS`]) is a name, a help line and its parameters
//! described as data ([`params::ParamSpec`]: key, label, unit, range, default, step), so
//! the app builds its sliders, the CLI its `--help` and the property tests their
//! parameters from the same table. Built with parameters for a [`Grid`], a pattern is
//! a [`Field`]: every ball's position at any time. A [`Recipe`] is a timeline of
//! segments (pattern + parameters + duration) with smooth transitions; rendering it
//! ([`render()`]) gives a native [`Show`](crate::show::Show) that passes
//! [`validate`](crate::show::validate) for the installation's limits, and the notes of
//! what was clamped and which parameter to change.
//!
//! Everything here is sans-IO and deterministic (no clocks; randomness seeded by a
//! `seed` parameter), native and wasm32.
//!
//! # Layout
//! - this module: [`Grid`], the [`Field`] trait, [`CreateError`] and [`Note`];
//! - [`params`]: parameter descriptions ([`ParamSpec`], [`ParamKind`]), values
//!   ([`Value`], [`Params`]) and the [`Reader`] that reads them with defaults and
//!   clamping;
//! - [`catalogue`]: [`PATTERNS`], every pattern's name, label, help, parameters and
//!   builder; [`pattern()`] finds one by name;
//! - [`wave`], [`ripple`], [`rain`], [`plane`], [`breathe`], [`noise`]: the patterns;
//! - [`text`]: the text pattern — a word or a user's bitmap, raised or lowered, static
//!   or scrolling smoothly; [`font`]: its built-in bitmap font and the [`font::Bitmap`];
//! - [`picture`]: the image heightmap pattern — a PNG or JPEG picture as heights;
//! - [`recipe`]: the recipe (JSON), its segments and the timeline with transitions and
//!   easing from and to rest;
//! - [`render`]: recipe + grid + limits → show + notes, within the limits by
//!   construction.

pub mod breathe;
pub mod catalogue;
pub mod noise;
pub mod params;
pub mod plane;
pub mod rain;
pub mod recipe;
pub mod render;
pub mod ripple;
pub mod wave;

pub mod font;
pub mod picture;
pub mod text;

use std::fmt;

use thiserror::Error;

pub use catalogue::{PATTERNS, PatternSpec, pattern};
pub use params::{ParamKind, ParamSpec, Params, Reader, Value};
pub use recipe::{Recipe, Segment};
pub use render::{Generated, render};

/// The matrix a show is generated for (in a recipe file, `"grid"`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    /// Rows of balls (front to back).
    pub rows: u32,
    /// Balls in each row (left to right).
    pub cols: u32,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
    /// Lowest position a ball may reach, mm below the top (the installation's travel).
    pub travel_mm: f64,
}

impl Grid {
    /// A `rows` × `cols` grid of balls `pitch_mm` apart with `travel_mm` of travel.
    #[must_use]
    pub const fn new(rows: u32, cols: u32, pitch_mm: f64, travel_mm: f64) -> Self {
        Self {
            rows,
            cols,
            pitch_mm,
            travel_mm,
        }
    }

    /// Number of balls, `rows × cols`.
    #[must_use]
    pub fn unit_count(&self) -> usize {
        self.rows as usize * self.cols as usize
    }

    /// Centre of ball `unit` (row-major) in mm from the matrix's centre: (x to the
    /// right, y towards the back). Row 0 is the front row, column 0 the left one.
    #[must_use]
    pub fn xy_mm(&self, unit: usize) -> (f64, f64) {
        let cols = self.cols.max(1) as usize;
        let (row, col) = (unit / cols, unit % cols);
        let x = (col as f64 - (f64::from(self.cols) - 1.0) / 2.0) * self.pitch_mm;
        let y = (row as f64 - (f64::from(self.rows) - 1.0) / 2.0) * self.pitch_mm;
        (x, y)
    }

    /// Half the matrix's diagonal, mm: the distance from its centre to a corner ball.
    #[must_use]
    pub fn half_diagonal_mm(&self) -> f64 {
        let width = (f64::from(self.cols) - 1.0).max(0.0) * self.pitch_mm;
        let depth = (f64::from(self.rows) - 1.0).max(0.0) * self.pitch_mm;
        width.hypot(depth) / 2.0
    }

    /// Checks that the grid has balls, a positive pitch and a positive travel.
    ///
    /// # Errors
    /// [`CreateError::EmptyGrid`] otherwise.
    pub fn check(&self) -> Result<(), CreateError> {
        let positive = |value: f64| value.is_finite() && value > 0.0;
        if self.unit_count() == 0 || !positive(self.pitch_mm) || !positive(self.travel_mm) {
            return Err(CreateError::EmptyGrid {
                rows: self.rows,
                cols: self.cols,
            });
        }
        Ok(())
    }
}

/// A pattern with its parameters fixed: every ball's position at any time.
///
/// Must be deterministic, smooth in time (C1 at least; C2 preferred) and cheap: the
/// renderer calls `sample` once per PVT row time (and a few more for its checks), so
/// it must not allocate (compute per-ball constants when the field is built).
pub trait Field {
    /// Position of every ball at `t_s` seconds after the pattern began, mm below the
    /// top, row-major into `out_mm` (`out_mm.len() == grid.unit_count()`). Values may
    /// leave 0..=travel; the renderer keeps them inside.
    fn sample(&self, grid: &Grid, t_s: f64, out_mm: &mut [f64]);
}

/// What was changed so the show stays within its limits (or its parameters' ranges,
/// or the font), and which parameter to change: shown next to that parameter's field.
#[derive(Debug, Clone, PartialEq)]
pub struct Note {
    /// The 0-based segment of the recipe concerned (messages count from 1).
    pub segment: usize,
    /// The segment's pattern.
    pub pattern: String,
    /// The parameter concerned (a key of the pattern's parameters, or `transition_s`,
    /// `duration_s` for the segment's own fields).
    pub key: String,
    /// What was changed.
    pub change: Change,
    /// Why, or what to do instead, ending the sentence: "so balls stay within 2000 mm/s".
    pub reason: String,
}

/// What a [`Note`] says was changed.
#[derive(Debug, Clone, PartialEq)]
pub enum Change {
    /// A number: the value asked for and the value used.
    Number {
        /// The value asked for.
        from: f64,
        /// The value used.
        to: f64,
        /// The values' unit (`"m/s"`, `"mm"`, `"%"`; may be empty).
        unit: String,
    },
    /// Characters of a text that the built-in font lacks, each drawn as `?`.
    NotInFont {
        /// Those characters, each once, in the order they first appear.
        chars: String,
    },
    /// A text or bitmap larger than the matrix at its letter size: only its middle is
    /// shown. Each side that does not fit is given as (balls needed, balls the matrix
    /// has); a scrolling text's width always fits.
    Cropped {
        /// Across (columns), if the width does not fit.
        across: Option<(u32, u32)>,
        /// Deep (rows), if the height does not fit.
        deep: Option<(u32, u32)>,
    },
    /// Nothing to draw (an empty text, only spaces): the matrix stays flat.
    Empty,
}

impl Note {
    /// A note of a number clamped `from` → `to`.
    #[must_use]
    pub fn number(
        segment: usize,
        pattern: &str,
        key: &str,
        (from, to): (f64, f64),
        unit: &str,
        reason: String,
    ) -> Self {
        Self {
            segment,
            pattern: pattern.to_owned(),
            key: key.to_owned(),
            change: Change::Number {
                from,
                to,
                unit: unit.to_owned(),
            },
            reason,
        }
    }

    /// The value asked for and the value used, if the note is of a number.
    #[must_use]
    pub fn numbers(&self) -> Option<(f64, f64)> {
        match self.change {
            Change::Number { from, to, .. } => Some((from, to)),
            Change::NotInFont { .. } | Change::Cropped { .. } | Change::Empty => None,
        }
    }
}

impl fmt::Display for Note {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (key, pattern, segment) = (&self.key, &self.pattern, self.segment + 1);
        match &self.change {
            Change::Number { from, to, unit } => {
                let unit = if unit.is_empty() {
                    String::new()
                } else {
                    format!(" {unit}")
                };
                write!(
                    f,
                    "{key} of {pattern} {segment} clamped from {} to {}{unit} {}",
                    number(*from),
                    number(*to),
                    self.reason
                )
            }
            Change::NotInFont { chars } => write!(
                f,
                "{key} of {pattern} {segment}: {chars} not in the built-in font, drawn as ? {}",
                self.reason
            ),
            Change::Cropped { across, deep } => {
                let side = |(needed, has): (u32, u32), way: &str| {
                    format!("{needed} balls {way} on a matrix {has} {way}")
                };
                let sides: Vec<String> = across
                    .map(|side_of| side(side_of, "across"))
                    .into_iter()
                    .chain(deep.map(|side_of| side(side_of, "deep")))
                    .collect();
                write!(
                    f,
                    "{key} of {pattern} {segment}: {}, only its middle is shown {}",
                    sides.join(" and "),
                    self.reason
                )
            }
            Change::Empty => write!(
                f,
                "{key} of {pattern} {segment}: nothing to draw, the matrix stays flat {}",
                self.reason
            ),
        }
    }
}

/// The quintic smooth step `6x⁵ − 15x⁴ + 10x³` of `x` clamped to 0..=1: 0 at 0, 1 at 1,
/// with zero slope and curvature at both ends (so blends and fronts built on it are C2).
#[must_use]
pub fn smooth_step(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * x * (x * (x * 6.0 - 15.0) + 10.0)
}

/// `value` with at most 3 decimals and no trailing zeros, as notes and messages
/// write it (the app's too).
#[must_use]
pub fn number(value: f64) -> String {
    let text = format!("{value:.3}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".to_owned()
    } else {
        text.to_owned()
    }
}

/// Why a show cannot be created. Every message says what to change.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CreateError {
    /// No pattern has this name.
    #[error("there is no pattern \"{name}\"; the patterns are: {known}")]
    UnknownPattern {
        /// The name asked for.
        name: String,
        /// The known names, comma-separated.
        known: String,
    },
    /// The pattern has no parameter of this key.
    #[error("pattern \"{pattern}\" has no parameter \"{key}\"; its parameters are: {known}")]
    UnknownParam {
        /// The pattern.
        pattern: String,
        /// The key given.
        key: String,
        /// The pattern's keys, comma-separated.
        known: String,
    },
    /// A parameter's value is of the wrong type or not one of its choices.
    #[error("parameter \"{key}\" of pattern \"{pattern}\" must be {expected}")]
    WrongType {
        /// The pattern.
        pattern: String,
        /// The parameter.
        key: String,
        /// What it must be, in words ("a number from 0.5 to 50 m", "one of: left, right").
        expected: String,
    },
    /// A picture that cannot be decoded.
    #[error("the picture in \"{key}\" cannot be read ({message}); use a PNG or JPEG file")]
    Picture {
        /// The parameter.
        key: String,
        /// The decoder's words.
        message: String,
    },
    /// A picture (or other file) larger than its parameter allows.
    #[error(
        "the file in \"{key}\" has {bytes} bytes; at most {max_bytes} are allowed, use a smaller one"
    )]
    TooLarge {
        /// The parameter.
        key: String,
        /// Its size, bytes.
        bytes: usize,
        /// The limit, bytes.
        max_bytes: usize,
    },
    /// A recipe with no segments.
    #[error("the recipe has no segments; add at least one pattern")]
    EmptyTimeline,
    /// A recipe with more segments than allowed.
    #[error("the recipe has {segments} segments; at most {max} are allowed, remove some")]
    TooManySegments {
        /// Segments in the recipe.
        segments: usize,
        /// The limit.
        max: usize,
    },
    /// A show longer than allowed.
    #[error("the show would last {seconds} s; at most {max_s} s are allowed, shorten its segments")]
    TooLong {
        /// The show's duration, s.
        seconds: f64,
        /// The limit, s.
        max_s: f64,
    },
    /// A segment's duration or transition that is not a number of seconds in range.
    #[error("segment {segment}: {key} is {value} s; it must be from {min_s} to {max_s} s")]
    Duration {
        /// The segment, counted from 1.
        segment: usize,
        /// `duration_s` or `transition_s`.
        key: &'static str,
        /// The value found.
        value: f64,
        /// The smallest allowed, s.
        min_s: f64,
        /// The largest allowed, s.
        max_s: f64,
    },
    /// A show with more rows in all than a renderer holds in memory.
    #[error(
        "the show would have {rows} rows for each of {balls} balls, {} in all; at most \
         {max} are made: shorten it, use longer rows (row_ms) or fewer balls",
        *rows as u64 * *balls as u64
    )]
    TooManyRows {
        /// Rows per ball.
        rows: usize,
        /// Balls.
        balls: usize,
        /// The most rows in all.
        max: u64,
    },
    /// A grid without balls, or with a pitch or travel that is not positive.
    #[error(
        "the grid of {rows} × {cols} balls cannot hold a show; give at least one row and one \
         column and a positive pitch and travel"
    )]
    EmptyGrid {
        /// Rows asked for.
        rows: u32,
        /// Columns asked for.
        cols: u32,
    },
    /// A recipe file that cannot be read.
    #[error("the recipe is not valid: {message}")]
    Recipe {
        /// What is wrong, with serde's line and column.
        message: String,
    },
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn balls_are_placed_about_the_centre_row_major() {
        let grid = Grid::new(2, 3, 500.0, 7500.0);
        assert_eq!(grid.unit_count(), 6);
        assert_eq!(grid.xy_mm(0), (-500.0, -250.0));
        assert_eq!(grid.xy_mm(1), (0.0, -250.0));
        assert_eq!(grid.xy_mm(5), (500.0, 250.0));
        assert!((grid.half_diagonal_mm() - 1000f64.hypot(500.0) / 2.0).abs() < 1e-9);
        assert_eq!(Grid::new(1, 1, 500.0, 7500.0).xy_mm(0), (0.0, 0.0));
    }

    #[test]
    fn empty_grids_are_refused() {
        assert!(Grid::new(1, 1, 500.0, 7500.0).check().is_ok());
        for grid in [
            Grid::new(0, 3, 500.0, 7500.0),
            Grid::new(3, 0, 500.0, 7500.0),
            Grid::new(3, 3, 0.0, 7500.0),
            Grid::new(3, 3, 500.0, f64::NAN),
        ] {
            let error = grid.check().unwrap_err();
            assert!(matches!(error, CreateError::EmptyGrid { .. }), "{error}");
            assert!(error.to_string().contains("at least one row"), "{error}");
        }
    }

    #[test]
    fn the_smooth_step_is_flat_at_both_ends() {
        assert_eq!(smooth_step(-1.0), 0.0);
        assert_eq!(smooth_step(0.0), 0.0);
        assert_eq!(smooth_step(0.5), 0.5);
        assert_eq!(smooth_step(1.0), 1.0);
        assert_eq!(smooth_step(2.0), 1.0);
        let h = 1e-6;
        assert!(smooth_step(h) < 1e-15);
        assert!((1.0 - smooth_step(1.0 - h)) < 1e-15);
    }

    #[test]
    fn notes_read_as_a_sentence() {
        let note = Note::number(
            0,
            "wave",
            "speed_m_s",
            (6.0, 2.4),
            "m/s",
            "so balls stay within 2000 mm/s".into(),
        );
        assert_eq!(
            note.to_string(),
            "speed_m_s of wave 1 clamped from 6 to 2.4 m/s so balls stay within 2000 mm/s"
        );
        assert_eq!(number(0.1 + 0.2), "0.3");
        assert_eq!(number(2.0), "2");
        assert_eq!(number(-0.0001), "0");
    }
}
