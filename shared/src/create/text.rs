//! The text pattern: a word (or a few lines) in the built-in font ([`super::font`])
//! or a user's bitmap (CJK, a logo) drawn in heights — letters raised above (or
//! lowered below) a flat background — static and centred, or scrolling across the
//! matrix.
//!
//! Seen from below with the front row nearest, the bitmap's top row is at the back and
//! its left column at the left, so the word reads left to right. Glyph pixels are
//! scaled by a whole number of balls so the line fills the matrix's height (static
//! text also fits its width when it can), or by `balls_per_pixel`, and centred.
//!
//! A text whose ink does not all fit the matrix (wider than it when standing still, or
//! deeper) is noted ([`Change::Cropped`]), as is one with nothing to draw
//! ([`Change::Empty`]).
//!
//! A scrolling word runs on a loop: the matrix starts flat, the word enters at the
//! right (`scroll_m_s` > 0; at the left when negative), crosses and leaves, and enters
//! again. Between two neighbouring balls' columns the height follows the quintic smooth
//! step ([`smooth_step`]), so every ball's position is C2 in time — no jump when a
//! letter's edge passes a ball — and at the instants when the word stands on whole
//! columns (and always when static) every ball is exactly at its pixel's height.
//! A ball's peak speed is `depth · 15/8 · v/pitch` and its peak acceleration
//! `depth · 10/√3 · (v/pitch)²` (the smooth step's peak slope and curvature, v the
//! scroll speed).
//!
//! ```
//! use floatball_shared::create::{Grid, Params, Value, pattern};
//!
//! let grid = Grid::new(8, 12, 500.0, 7500.0);
//! let mut params = Params::new();
//! params.insert("text".into(), Value::Text("Hi".into()));
//! params.insert("scroll_m_s".into(), Value::Number(0.0));
//! let (field, _notes) = pattern("text").unwrap().field(&params, 0, &grid).unwrap();
//! let mut out_mm = vec![0.0; grid.unit_count()];
//! field.sample(&grid, 0.0, &mut out_mm);
//! // The balls seen from below, the back row first: # raised to 2200 mm, . at 3000 mm.
//! let seen: Vec<String> = (0..8)
//!     .rev()
//!     .map(|row| (0..12).map(|col| if out_mm[row * 12 + col] < 3000.0 { '#' } else { '.' }).collect())
//!     .collect();
//! assert_eq!(
//!     seen,
//!     [
//!         "##..##..##..",
//!         "##..##......",
//!         "##..##.###..",
//!         "######..##..",
//!         "##..##..##..",
//!         "##..##..##..",
//!         "##..##.####.",
//!         "............",
//!     ]
//! );
//! ```

use super::catalogue::PatternSpec;
use super::font::{Bitmap, missing, render};
use super::params::{ParamKind, ParamSpec, Reader};
use super::{Change, CreateError, Field, Grid, smooth_step};

/// The styles: letters above the background, or below it.
pub const STYLES: &[&str] = &["raised", "lowered"];

/// Most characters of the `text` parameter.
pub const MAX_TEXT_CHARS: usize = 64;

/// Most characters of the `bitmap` parameter (e.g. 64 lines of 63 pixels).
pub const MAX_BITMAP_CHARS: usize = 4096;

/// The text pattern's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "text",
        label: "Text",
        help: "The word to show, in the built-in font (Latin letters, digits, punctuation; \
               other characters show as ?). | or a new line starts another line.",
        kind: ParamKind::Text {
            default: "HELLO",
            max_chars: MAX_TEXT_CHARS,
        },
    },
    ParamSpec {
        key: "style",
        label: "Style",
        help: "Raised: letters above the background; lowered: letters below it.",
        kind: ParamKind::Choice {
            options: STYLES,
            default: "raised",
        },
    },
    ParamSpec {
        key: "scroll_m_s",
        label: "Scroll speed",
        help: "How fast the text moves across the matrix: 0 stands still, positive scrolls \
               right to left, negative left to right.",
        kind: ParamKind::number(-2.0, 2.0, 0.05, 0.35, "m/s"),
    },
    ParamSpec {
        key: "depth_mm",
        label: "Depth",
        help: "How far the letters stand out from the background.",
        kind: ParamKind::number(0.0, 3000.0, 10.0, 800.0, "mm"),
    },
    ParamSpec {
        key: "base_mm",
        label: "Background height",
        help: "Where the background balls hang, below the top.",
        kind: ParamKind::height_mm(3000.0),
    },
    ParamSpec {
        key: "balls_per_pixel",
        label: "Letter size",
        help: "Balls per pixel of the letters, across and deep (0: as large as the matrix's \
               depth allows).",
        kind: ParamKind::number(0.0, 16.0, 1.0, 0.0, ""),
    },
    ParamSpec {
        key: "bitmap",
        label: "Bitmap",
        help: "Your own picture instead of the text (CJK characters, a logo): lines of # \
               (ball raised) and . (background), separated by new lines or |.",
        kind: ParamKind::Text {
            default: "",
            max_chars: MAX_BITMAP_CHARS,
        },
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "text",
    label: "Text",
    help: "A word or a bitmap in raised or lowered balls, standing still or scrolling.",
    params: PARAMS,
    build,
};

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let bitmap = Bitmap::parse(reader.text("bitmap"));
    let (key, bitmap) = if bitmap.is_blank() {
        let missing = missing(reader.text("text"));
        reader.not_in_font(
            "text",
            missing,
            "(draw them with the bitmap parameter: lines of # and .)",
        );
        ("text", render(reader.text("text")))
    } else {
        ("bitmap", bitmap)
    };
    let depth_mm = reader.number("depth_mm");
    let swing_mm = if reader.choice("style") == "lowered" {
        depth_mm
    } else {
        -depth_mm
    };
    // A whole number of balls (a recipe may hold any number).
    #[allow(clippy::cast_possible_truncation)]
    let balls_per_pixel = reader.number("balls_per_pixel").round() as i64;
    let scroll_m_s = reader.number("scroll_m_s");
    let trimmed = bitmap.trimmed();
    if trimmed.is_blank() {
        reader.change(key, Change::Empty, "(type a text, or draw a bitmap)");
    } else {
        let scrolling = cols_per_s(grid, scroll_m_s) != 0.0;
        let scale = scale(grid, &trimmed, balls_per_pixel, scrolling);
        if let Some(change) = cropped(grid, &trimmed, scale, scrolling) {
            reader.change(
                key,
                change,
                "(choose a smaller letter size or a shorter text, or scroll it)",
            );
        }
    }
    Ok(Box::new(Text::new(
        grid,
        &bitmap,
        balls_per_pixel,
        scroll_m_s,
        reader.number("base_mm"),
        swing_mm,
    )))
}

/// Scroll speed `scroll_m_s` on `grid` in ball columns per second (0 when it cannot
/// scroll: no pitch, or a speed that is not a number).
fn cols_per_s(grid: &Grid, scroll_m_s: f64) -> f64 {
    if grid.pitch_mm > 0.0 && scroll_m_s.is_finite() {
        scroll_m_s * 1000.0 / grid.pitch_mm
    } else {
        0.0
    }
}

/// Balls per pixel of the `trimmed` bitmap on `grid`: `balls_per_pixel`, or when that
/// is 0 (or less) as many as fit the matrix's depth (and its width when the text
/// stands still); at least 1.
fn scale(grid: &Grid, trimmed: &Bitmap, balls_per_pixel: i64, scrolling: bool) -> i64 {
    let (rows, cols) = (i64::from(grid.rows), i64::from(grid.cols));
    let (width, height) = (to_i64(trimmed.width()), to_i64(trimmed.height()));
    let fit_height = if height > 0 { rows / height } else { 1 };
    let fit_width = if width > 0 { cols / width } else { 1 };
    let fits = if scrolling {
        fit_height
    } else {
        fit_height.min(fit_width)
    };
    if balls_per_pixel > 0 {
        balls_per_pixel
    } else {
        fits
    }
    .max(1)
}

/// The left column of a bitmap `width_balls` wide centred on `cols` columns (negative
/// when it is wider).
fn centred(cols: i64, width_balls: i64) -> i64 {
    (cols - width_balls).div_euclid(2)
}

/// [`Change::Cropped`] when some of the `trimmed` bitmap's ink, `scale` balls a pixel
/// and centred, falls off `grid` (across only when it stands still: a scrolling text
/// crosses the whole matrix); `None` when all of it is seen.
fn cropped(grid: &Grid, trimmed: &Bitmap, scale: i64, scrolling: bool) -> Option<Change> {
    let (rows, cols) = (i64::from(grid.rows), i64::from(grid.cols));
    let (width, height) = (to_i64(trimmed.width()), to_i64(trimmed.height()));
    let balls = |count: i64| u32::try_from(count).unwrap_or(u32::MAX);
    // Rows are trimmed to the ink: the bitmap's height is the ink's.
    let deep = (height * scale > rows).then(|| (balls(height * scale), grid.rows));
    // Columns may have blank ones at the edges (a glyph's spacing): only ink counts.
    let inked = |x: &usize| (0..trimmed.height()).any(|y| trimmed.ink(*x, y));
    let first = (0..trimmed.width()).find(inked).map_or(0, to_i64);
    let last = (0..trimmed.width()).rev().find(inked).map_or(0, to_i64);
    let lead = centred(cols, width * scale);
    let across = (!scrolling && (lead + first * scale < 0 || lead + (last + 1) * scale > cols))
        .then(|| (balls(width * scale), grid.cols));
    (across.is_some() || deep.is_some()).then_some(Change::Cropped { across, deep })
}

/// The text pattern with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Text {
    /// The tape: for every row of the bitmap and then a blank one, 1 where a column of
    /// balls is inked and 0 where not, `length` columns a row; when scrolling, one
    /// period and then the matrix's width again, so a ball's column and the one after
    /// never wrap.
    tape: Vec<u8>,
    /// Columns in each row of the tape.
    length: usize,
    /// The tape's period, columns, when scrolling; 0 when static.
    period: f64,
    /// Scroll speed, ball columns per second (positive moves the text to the left).
    cols_per_s: f64,
    /// The background's position, mm below the top.
    base_mm: f64,
    /// From the background to an inked pixel, mm (negative = raised).
    swing_mm: f64,
    /// Every ball's start in the tape (its bitmap row × length + its column), row-major.
    starts: Vec<usize>,
}

impl Text {
    /// `bitmap` on `grid`, each pixel `balls_per_pixel` × `balls_per_pixel` balls (0 or
    /// less: as large as fits), scrolling at `scroll_m_s` (0 = static), the background
    /// at `base_mm` and inked pixels `swing_mm` from it (negative = higher).
    #[must_use]
    pub fn new(
        grid: &Grid,
        bitmap: &Bitmap,
        balls_per_pixel: i64,
        scroll_m_s: f64,
        base_mm: f64,
        swing_mm: f64,
    ) -> Self {
        let bitmap = bitmap.trimmed();
        let (rows, cols) = (i64::from(grid.rows), i64::from(grid.cols));
        let (width, height) = (to_i64(bitmap.width()), to_i64(bitmap.height()));
        let cols_per_s = cols_per_s(grid, scroll_m_s);
        let scrolling = cols_per_s != 0.0;
        let scale = scale(grid, &bitmap, balls_per_pixel, scrolling);
        // The bitmap's top row (counted from the back) and left column on the tape.
        let top = (rows - height * scale).div_euclid(2);
        let (lead, period) = if scrolling {
            // The matrix's width of flat, then the text.
            (cols, cols + width * scale)
        } else {
            (centred(cols, width * scale), 0)
        };
        // A ball's column plus the offset (< period) and the column after it.
        let length = period + cols + 1;
        let ink = |py: usize, x: i64| {
            let x = if period > 0 { x % period } else { x };
            let dx = x - lead;
            dx >= 0 && usize::try_from(dx / scale).is_ok_and(|px| bitmap.ink(px, py))
        };
        // Rows 0..height are the bitmap's, row `height` is blank (`ink` is false there).
        let tape = (0..=bitmap.height())
            .flat_map(|py| (0..length).map(move |x| u8::from(ink(py, x))))
            .collect();
        let length = usize::try_from(length).unwrap_or(0);
        let starts = cells(grid)
            .into_iter()
            .map(|(col, row)| {
                // The bitmap's row under this row of balls, or the blank one.
                let dy = row - top;
                let py = if (0..height * scale).contains(&dy) {
                    dy / scale
                } else {
                    height
                };
                usize::try_from(py)
                    .ok()
                    .zip(usize::try_from(col).ok())
                    .map_or(usize::MAX, |(py, col)| py * length + col)
            })
            .collect();
        Self {
            tape,
            length,
            period: period as f64,
            cols_per_s,
            base_mm,
            swing_mm,
            starts,
        }
    }

    /// How far the tape has moved at `t_s`, columns (within one period; 0 when static).
    fn offset(&self, t_s: f64) -> f64 {
        let moved = self.cols_per_s * t_s;
        if self.period > 0.0 && moved.is_finite() {
            moved.rem_euclid(self.period)
        } else {
            0.0
        }
    }
}

impl Field for Text {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let offset = self.offset(t_s);
        let whole = offset.floor();
        let fraction = offset - whole;
        let step = smooth_step(fraction);
        // `whole` is a whole number in 0..=period: exact.
        #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
        let shift = whole as usize;
        for (out, &start) in out_mm.iter_mut().zip(&self.starts) {
            let at = start.saturating_add(shift);
            let from = self.tape.get(at).copied().unwrap_or(0);
            let to = self.tape.get(at.saturating_add(1)).copied().unwrap_or(0);
            let ink = match (from, to) {
                (0, 0) => 0.0,
                (1, 1) => 1.0,
                (0, _) => step,
                _ => 1.0 - step,
            };
            *out = self.base_mm + self.swing_mm * ink;
        }
    }
}

/// Every ball of `grid` as (column from the left, row from the back), row-major: where
/// a picture's pixel (x right, y down) lands when the matrix is seen from below with
/// its front row nearest.
pub(crate) fn cells(grid: &Grid) -> Vec<(i64, i64)> {
    let pitch_mm = if grid.pitch_mm > 0.0 {
        grid.pitch_mm
    } else {
        1.0
    };
    let half_cols = (f64::from(grid.cols) - 1.0) / 2.0;
    let half_rows = (f64::from(grid.rows) - 1.0) / 2.0;
    (0..grid.unit_count())
        .map(|unit| {
            let (x_mm, y_mm) = grid.xy_mm(unit);
            // Whole numbers of balls from the edges, rounded off the float error.
            #[allow(clippy::cast_possible_truncation)]
            let col = (x_mm / pitch_mm + half_cols).round() as i64;
            #[allow(clippy::cast_possible_truncation)]
            let row = (half_rows - y_mm / pitch_mm).round() as i64;
            (col, row)
        })
        .collect()
}

/// A count as a signed number (a bitmap's size is far below `i64::MAX`).
fn to_i64(count: usize) -> i64 {
    i64::try_from(count).unwrap_or(i64::MAX)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::font::glyph;
    use super::super::params::{Params, Value};
    use super::*;

    const BASE_MM: f64 = 3000.0;
    const DEPTH_MM: f64 = 800.0;

    /// The text pattern with `params` on `grid` as segment `segment`: its field and
    /// its notes.
    fn built(
        grid: &Grid,
        params: &[(&str, Value)],
        segment: usize,
    ) -> (Box<dyn Field>, Vec<crate::create::Note>) {
        let params: Params = params
            .iter()
            .map(|(key, value)| ((*key).to_owned(), value.clone()))
            .collect();
        PATTERN.field(&params, segment, grid).unwrap()
    }

    fn field(grid: &Grid, params: &[(&str, Value)]) -> Box<dyn Field> {
        built(grid, params, 0).0
    }

    fn sample(field: &dyn Field, grid: &Grid, t_s: f64) -> Vec<f64> {
        let mut out_mm = vec![f64::NAN; grid.unit_count()];
        field.sample(grid, t_s, &mut out_mm);
        out_mm
    }

    /// The balls at their letter's height, as rows of `#` (raised) and `.`, the back
    /// row first — the way the bitmap is drawn.
    fn picture(grid: &Grid, out_mm: &[f64], letter_mm: f64) -> String {
        (0..grid.rows)
            .rev()
            .map(|row| {
                (0..grid.cols)
                    .map(|col| {
                        let mm = out_mm[(row * grid.cols + col) as usize];
                        if (mm - letter_mm).abs() < 1e-9 {
                            '#'
                        } else {
                            assert!((mm - BASE_MM).abs() < 1e-9, "{mm}");
                            '.'
                        }
                    })
                    .collect::<String>()
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    /// The font's own bits for `c`, rows `rows` and columns `cols`, each pixel
    /// `scale` × `scale` balls, placed at (`left`, `top`) on a `width` × `height` canvas.
    #[allow(clippy::too_many_arguments)]
    fn expected(
        c: char,
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        scale: usize,
        left: usize,
        top: usize,
        width: usize,
        height: usize,
    ) -> String {
        let bits = glyph(c).unwrap();
        (0..height)
            .map(|y| {
                (0..width)
                    .map(|x| {
                        let inside = x >= left
                            && y >= top
                            && (x - left) / scale < cols.len()
                            && (y - top) / scale < rows.len();
                        let on = inside && {
                            let bit = cols.start + (x - left) / scale;
                            bits[rows.start + (y - top) / scale] & (1 << bit) != 0
                        };
                        if on { '#' } else { '.' }
                    })
                    .collect::<String>()
            })
            .collect::<Vec<_>>()
            .join("\n")
    }

    #[test]
    fn a_static_letter_raises_exactly_the_balls_of_its_glyph() {
        // 'A' inks rows 0..7 and columns 0..6 of its cell: on 10 × 10 it is centred
        // one ball down and two in.
        let grid = Grid::new(10, 10, 500.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("text", Value::Text("A".into())),
                ("scroll_m_s", Value::Number(0.0)),
            ],
        );
        let want = expected('A', 0..7, 0..6, 1, 2, 1, 10, 10);
        for t_s in [0.0, 3.7, 100.0] {
            let out_mm = sample(text.as_ref(), &grid, t_s);
            assert_eq!(picture(&grid, &out_mm, BASE_MM - DEPTH_MM), want);
        }
        // Scaled: 16 rows hold it twice as large (14 rows, one spare at each side).
        let grid = Grid::new(16, 20, 300.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("text", Value::Text("A".into())),
                ("scroll_m_s", Value::Number(0.0)),
            ],
        );
        let out_mm = sample(text.as_ref(), &grid, 1.0);
        assert_eq!(
            picture(&grid, &out_mm, BASE_MM - DEPTH_MM),
            expected('A', 0..7, 0..6, 2, 4, 1, 20, 16)
        );
    }

    #[test]
    fn lines_stand_one_under_the_other() {
        // "A|A" on 18 × 8: two A's (7 inked rows each, one blank and one gap row
        // between), 16 rows in all, centred: the first from row 1, the second from 10.
        let grid = Grid::new(18, 8, 500.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("text", Value::Text("A|A".into())),
                ("scroll_m_s", Value::Number(0.0)),
            ],
        );
        let first = expected('A', 0..7, 0..6, 1, 1, 1, 8, 18);
        let second = expected('A', 0..7, 0..6, 1, 1, 10, 8, 18);
        let want: String = first
            .chars()
            .zip(second.chars())
            .map(|(a, b)| if a == '#' || b == '#' { '#' } else { a })
            .collect();
        let out_mm = sample(text.as_ref(), &grid, 2.0);
        assert_eq!(picture(&grid, &out_mm, BASE_MM - DEPTH_MM), want);
    }

    #[test]
    fn characters_the_font_lacks_are_drawn_as_question_marks_with_a_note() {
        let grid = Grid::new(10, 30, 500.0, 7500.0);
        let notes = |params: &[(&str, Value)]| built(&grid, params, 1).1;
        let notes_of = notes(&[("text", Value::Text("字A幕字".into()))]);
        assert_eq!(notes_of.len(), 1, "{notes_of:?}");
        assert_eq!((notes_of[0].segment, notes_of[0].key.as_str()), (1, "text"));
        assert_eq!(
            notes_of[0].change,
            crate::create::Change::NotInFont {
                chars: "字幕".into()
            }
        );
        assert_eq!(
            notes_of[0].to_string(),
            "text of text 2: 字幕 not in the built-in font, drawn as ? \
             (draw them with the bitmap parameter: lines of # and .)"
        );
        // What is drawn is the same as for question marks.
        let still = |text: &str| {
            let text = field(
                &grid,
                &[
                    ("text", Value::Text(text.into())),
                    ("scroll_m_s", Value::Number(0.0)),
                ],
            );
            sample(text.as_ref(), &grid, 1.0)
        };
        assert_eq!(still("字A"), still("?A"));
        // Letters the font has, or a bitmap given instead of the text: no note.
        assert!(notes(&[("text", Value::Text("Grüße 42".into()))]).is_empty());
        assert!(
            notes(&[
                ("text", Value::Text("字".into())),
                ("bitmap", Value::Text("#.#|.#.".into())),
            ])
            .is_empty()
        );
    }

    #[test]
    fn the_rendered_show_raises_the_letters_balls_while_the_word_stands() {
        // "A" standing on 10 × 10 for 10 s: once the show has eased in (2 s), the row at
        // every whole second has the glyph's balls at 2200 mm and the others at 3000.
        let grid = Grid::new(10, 10, 500.0, 7500.0);
        let params: Params = [
            ("text".to_owned(), Value::Text("A".into())),
            ("scroll_m_s".to_owned(), Value::Number(0.0)),
        ]
        .into_iter()
        .collect();
        let recipe = crate::create::Recipe::single("a", "text", params, 10.0);
        let limits = crate::show::Limits::for_layout(10, 10);
        let generated = crate::create::render(&recipe, &grid, &limits).unwrap();
        assert!(generated.notes.is_empty(), "{:?}", generated.notes);
        assert_eq!(crate::show::validate(&generated.show, &limits), []);
        let want = expected('A', 0..7, 0..6, 1, 2, 1, 10, 10);
        let row_ms = u64::from(recipe.row_ms);
        for at_ms in [4000u64, 6000, 9000] {
            let row = usize::try_from(at_ms / row_ms).unwrap() - 1;
            let out_mm: Vec<f64> = generated
                .show
                .tracks
                .iter()
                .map(|track| {
                    let mm = track.rows[row].position_mm;
                    // Rounded to 0.1 mm as a show file holds it.
                    if (mm - (BASE_MM - DEPTH_MM)).abs() <= 0.05 {
                        BASE_MM - DEPTH_MM
                    } else {
                        assert!((mm - BASE_MM).abs() <= 0.05, "{mm}");
                        BASE_MM
                    }
                })
                .collect();
            assert_eq!(
                picture(&grid, &out_mm, BASE_MM - DEPTH_MM),
                want,
                "at {at_ms} ms"
            );
        }
    }

    #[test]
    fn letters_take_the_size_asked_for() {
        // 'A' at 2 balls a pixel on 20 × 20: 14 rows by 12 columns, centred; at 1 on the
        // same grid the automatic size (2) is not used.
        let grid = Grid::new(20, 20, 500.0, 7500.0);
        for (size, want) in [
            (2.0, expected('A', 0..7, 0..6, 2, 4, 3, 20, 20)),
            (0.0, expected('A', 0..7, 0..6, 2, 4, 3, 20, 20)),
            (1.0, expected('A', 0..7, 0..6, 1, 7, 6, 20, 20)),
            (1.4, expected('A', 0..7, 0..6, 1, 7, 6, 20, 20)),
        ] {
            let text = field(
                &grid,
                &[
                    ("text", Value::Text("A".into())),
                    ("scroll_m_s", Value::Number(0.0)),
                    ("balls_per_pixel", Value::Number(size)),
                ],
            );
            let out_mm = sample(text.as_ref(), &grid, 0.0);
            assert_eq!(picture(&grid, &out_mm, BASE_MM - DEPTH_MM), want, "{size}");
        }
    }

    #[test]
    fn lowered_letters_hang_below_the_background() {
        let grid = Grid::new(10, 10, 500.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("text", Value::Text("T".into())),
                ("scroll_m_s", Value::Number(0.0)),
                ("style", Value::Text("lowered".into())),
                ("depth_mm", Value::Number(1200.0)),
                ("base_mm", Value::Number(2500.0)),
            ],
        );
        let out_mm = sample(text.as_ref(), &grid, 0.0);
        let low = out_mm.iter().filter(|&&mm| mm == 3700.0).count();
        let back = out_mm.iter().filter(|&&mm| mm == 2500.0).count();
        assert_eq!(low + back, 100);
        let t = glyph('T').unwrap();
        let inked: u32 = t.iter().map(|row| row.count_ones()).sum();
        assert_eq!(low, inked as usize);
    }

    #[test]
    fn a_scrolling_word_stands_on_whole_columns_at_whole_steps() {
        // 1 m/s at 500 mm: two columns a second. After 5 s the tape has moved ten
        // columns — the matrix's width — so the word's first column is at the left.
        let grid = Grid::new(8, 10, 500.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("text", Value::Text("H".into())),
                ("scroll_m_s", Value::Number(1.0)),
            ],
        );
        let out_mm = sample(text.as_ref(), &grid, 0.0);
        assert!(out_mm.iter().all(|&mm| mm == BASE_MM), "it starts flat");
        // 'H' inks rows 0..7 and columns 0..6; 8 rows: scale 1, one spare row at the
        // bottom (the front).
        let at_5 = sample(text.as_ref(), &grid, 5.0);
        assert_eq!(
            picture(&grid, &at_5, BASE_MM - DEPTH_MM),
            expected('H', 0..7, 0..6, 1, 0, 0, 10, 8)
        );
        // Half a second earlier it stood one column further right.
        let at_4_5 = sample(text.as_ref(), &grid, 4.5);
        assert_eq!(
            picture(&grid, &at_4_5, BASE_MM - DEPTH_MM),
            expected('H', 0..7, 0..6, 1, 1, 0, 10, 8)
        );
        // It loops: the tape is 10 + 6 columns long, 8 s.
        assert_eq!(sample(text.as_ref(), &grid, 13.0), at_5);
        // Negative speeds scroll the other way: the word enters at the left with its
        // last column first.
        let back = field(
            &grid,
            &[
                ("text", Value::Text("H".into())),
                ("scroll_m_s", Value::Number(-1.0)),
            ],
        );
        let at_1 = sample(back.as_ref(), &grid, 1.0);
        assert_eq!(
            picture(&grid, &at_1, BASE_MM - DEPTH_MM),
            expected('H', 0..7, 4..6, 1, 0, 0, 10, 8)
        );
    }

    #[test]
    fn scrolling_is_smooth_in_time() {
        // Peak speed depth · 15/8 · columns/s and acceleration depth · 10/√3 ·
        // (columns/s)²: check finite differences against them, everywhere, and that
        // positions stay between the background and the letters.
        let grid = Grid::new(6, 7, 400.0, 7500.0);
        let scroll_m_s = 0.6;
        let cols_per_s = scroll_m_s * 1000.0 / 400.0;
        let text = field(
            &grid,
            &[
                ("text", Value::Text("Ag!".into())),
                ("scroll_m_s", Value::Number(scroll_m_s)),
            ],
        );
        let max_speed = DEPTH_MM * 15.0 / 8.0 * cols_per_s;
        let max_accel = DEPTH_MM * 10.0 / 3f64.sqrt() * cols_per_s * cols_per_s;
        let h = 1e-3;
        let mut moved = 0.0f64;
        for step in 0..4000 {
            let t_s = f64::from(step) * 0.0071;
            let (a, b, c) = (
                sample(text.as_ref(), &grid, t_s - h),
                sample(text.as_ref(), &grid, t_s),
                sample(text.as_ref(), &grid, t_s + h),
            );
            for unit in 0..grid.unit_count() {
                assert!((BASE_MM - DEPTH_MM..=BASE_MM).contains(&b[unit]));
                let speed = (c[unit] - a[unit]) / (2.0 * h);
                let accel = (c[unit] - 2.0 * b[unit] + a[unit]) / (h * h);
                assert!(speed.abs() <= max_speed * 1.001, "{t_s} s: {speed} mm/s");
                assert!(accel.abs() <= max_accel * 1.01, "{t_s} s: {accel} mm/s²");
                moved = moved.max(speed.abs());
            }
        }
        // The bound is reached, not just respected: the word does move.
        assert!(moved > max_speed * 0.95, "{moved} of {max_speed}");
    }

    #[test]
    fn a_text_larger_than_the_matrix_or_with_nothing_to_draw_gets_a_note() {
        let notes = |grid: &Grid, params: &[(&str, Value)]| built(grid, params, 0).1;
        let text = |text: &str| ("text", Value::Text(text.into()));
        let still = ("scroll_m_s", Value::Number(0.0));
        let ten = Grid::new(10, 10, 500.0, 7500.0);
        // Five letters, 38 pixels, standing on 10 columns: only the middle shows.
        let cut = notes(&ten, &[text("HELLO"), still.clone()]);
        assert_eq!(cut.len(), 1, "{cut:?}");
        assert_eq!(
            (cut[0].key.as_str(), &cut[0].change),
            (
                "text",
                &Change::Cropped {
                    across: Some((38, 10)),
                    deep: None
                }
            )
        );
        assert_eq!(
            cut[0].to_string(),
            "text of text 1: 38 balls across on a matrix 10 across, only its middle is \
             shown (choose a smaller letter size or a shorter text, or scroll it)"
        );
        // Scrolling, the same word crosses the whole matrix: no note.
        assert_eq!(notes(&ten, &[text("HELLO")]), []);
        // One letter fits; at 2 balls a pixel it needs 12 × 14 of the 10 × 10.
        assert_eq!(notes(&ten, &[text("A"), still.clone()]), []);
        let big = notes(
            &ten,
            &[
                text("A"),
                still.clone(),
                ("balls_per_pixel", Value::Number(2.0)),
            ],
        );
        assert_eq!(
            big[0].change,
            Change::Cropped {
                across: Some((12, 10)),
                deep: Some((14, 10))
            }
        );
        assert!(
            big[0].to_string().contains(
                "12 balls across on a matrix 10 across and 14 balls deep on a matrix 10 deep"
            ),
            "{}",
            big[0]
        );
        // Scrolling on a matrix shallower than a letter: only the depth is cut.
        let shallow = Grid::new(5, 10, 500.0, 7500.0);
        assert_eq!(
            notes(&shallow, &[text("A")])[0].change,
            Change::Cropped {
                across: None,
                deep: Some((7, 5))
            }
        );
        // Only ink counts: blank columns off the matrix are no loss.
        let narrow = Grid::new(3, 3, 500.0, 7500.0);
        let bitmap = |rows: &str| ("bitmap", Value::Text(rows.into()));
        assert_eq!(notes(&narrow, &[bitmap("..#.."), still.clone()]), []);
        let off = notes(&narrow, &[bitmap("#...."), still.clone()]);
        assert_eq!(
            (off[0].key.as_str(), &off[0].change),
            (
                "bitmap",
                &Change::Cropped {
                    across: Some((5, 3)),
                    deep: None
                }
            )
        );
        // Nothing to draw: an empty text, only spaces, a blank bitmap and no text.
        for params in [
            vec![text("")],
            vec![text("   ")],
            vec![text(""), bitmap("...|...")],
        ] {
            let empty = notes(&ten, &params);
            assert_eq!(
                empty
                    .iter()
                    .map(|note| (note.key.as_str(), &note.change))
                    .collect::<Vec<_>>(),
                [("text", &Change::Empty)],
                "{params:?}"
            );
            assert_eq!(
                empty[0].to_string(),
                "text of text 1: nothing to draw, the matrix stays flat (type a text, or \
                 draw a bitmap)"
            );
        }
    }

    #[test]
    fn a_user_bitmap_replaces_the_text() {
        let grid = Grid::new(4, 5, 500.0, 7500.0);
        let text = field(
            &grid,
            &[
                ("bitmap", Value::Text("#.#|.#.|#.#".into())),
                ("scroll_m_s", Value::Number(0.0)),
            ],
        );
        let out_mm = sample(text.as_ref(), &grid, 2.0);
        assert_eq!(
            picture(&grid, &out_mm, BASE_MM - DEPTH_MM),
            ".#.#.\n..#..\n.#.#.\n....." // the spare row at the front
        );
        // A blank bitmap falls back to the text; no text at all is a flat field.
        let blank = field(
            &grid,
            &[
                ("bitmap", Value::Text("...".into())),
                ("text", Value::Text(String::new())),
            ],
        );
        assert!(
            sample(blank.as_ref(), &grid, 1.0)
                .iter()
                .all(|&mm| mm == BASE_MM)
        );
    }

    #[test]
    fn the_tape_holds_the_bitmap_rows_not_the_balls_rows() {
        // A bitmap one pixel tall and 4095 wide on 200 rows scales by 200: the tape
        // holds its one row (and a blank one), not 200.
        let grid = Grid::new(200, 10, 500.0, 7500.0);
        let bitmap = Bitmap::parse(&"#.".repeat(2047));
        let text = Text::new(&grid, &bitmap, 0, 0.5, BASE_MM, -DEPTH_MM);
        assert_eq!(text.length, 10 + 4094 * 200 + 10 + 1);
        assert_eq!(text.tape.len(), 2 * text.length);
        // After the flat width, every ball's column shows the first pixel: all inked.
        let out_mm = sample(&text, &grid, 10.0); // 0.5 m/s at 500 mm: a column a second
        assert!(
            out_mm.iter().all(|&mm| mm == BASE_MM - DEPTH_MM),
            "{out_mm:?}"
        );
    }

    #[test]
    fn text_is_deterministic_and_never_fails() {
        let grid = Grid::new(3, 4, 500.0, 7500.0);
        let params = [
            ("text", Value::Text("Grüße 字 ½!".into())),
            ("scroll_m_s", Value::Number(-0.7)),
        ];
        let (one, two) = (field(&grid, &params), field(&grid, &params));
        for t_s in [0.0, 0.33, 1e6, -5.0] {
            let a = sample(one.as_ref(), &grid, t_s);
            assert!(a.iter().all(|mm| mm.is_finite()));
            assert_eq!(a, sample(two.as_ref(), &grid, t_s));
        }
        // Odd times do not panic and keep to the two heights' range.
        for t_s in [f64::NAN, f64::INFINITY, f64::MAX] {
            let a = sample(one.as_ref(), &grid, t_s);
            assert!(
                a.iter()
                    .all(|&mm| (BASE_MM - DEPTH_MM..=BASE_MM).contains(&mm))
            );
        }
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
pub(crate) mod proptests {
    use proptest::prelude::*;

    use super::super::params::{ParamKind, Params, Value};
    use super::*;

    /// Any value the page allows for `spec`: a number in its range (on its ends now
    /// and then), one of its choices, text of its length (letters the font has and
    /// has not, `#`, `.`, `|`), or no value at all (the default).
    fn value(spec: &'static ParamSpec) -> BoxedStrategy<Option<Value>> {
        let given = match spec.kind {
            ParamKind::Number { min, max, .. } => prop_oneof![
                1 => Just(min),
                1 => Just(max),
                6 => min..=max,
            ]
            .prop_map(Value::Number)
            .boxed(),
            ParamKind::Choice { options, .. } => proptest::sample::select(options)
                .prop_map(|option| Value::Text(option.to_owned()))
                .boxed(),
            ParamKind::Text { max_chars, .. } => proptest::collection::vec(
                proptest::sample::select(
                    &['A', 'g', 'W', '1', ' ', '#', '.', '|', '\n', 'ß', '字'][..],
                ),
                0..=max_chars.min(40),
            )
            .prop_map(|chars| Value::Text(chars.into_iter().collect()))
            .boxed(),
            ParamKind::Bytes { .. } => Just(Value::Text(String::new())).boxed(),
        };
        proptest::option::weighted(0.8, given).boxed()
    }

    /// Any parameters the page allows for a pattern whose parameters are `specs`
    /// (bytes parameters left out: the caller gives the file).
    pub(crate) fn params(specs: &'static [ParamSpec]) -> BoxedStrategy<Params> {
        specs
            .iter()
            .filter(|spec| !matches!(spec.kind, ParamKind::Bytes { .. }))
            .map(|spec| value(spec).prop_map(move |value| (spec.key, value)))
            .collect::<Vec<_>>()
            .prop_map(|values| {
                values
                    .into_iter()
                    .filter_map(|(key, value)| Some((key.to_owned(), value?)))
                    .collect()
            })
            .boxed()
    }

    /// A small grid: 1..=12 × 1..=12 balls, 100–1000 mm apart.
    pub(crate) fn grid() -> impl Strategy<Value = Grid> {
        (1..=12u32, 1..=12u32, 100.0..=1000.0f64)
            .prop_map(|(rows, cols, pitch_mm)| Grid::new(rows, cols, pitch_mm, 7500.0))
    }

    fn number(params: &Params, key: &str) -> f64 {
        match (params.get(key), PATTERN.param(key).map(|spec| spec.kind)) {
            (Some(Value::Number(value)), _) => *value,
            (_, Some(ParamKind::Number { default, .. })) => default,
            _ => f64::NAN,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        /// For any parameters the page allows: every ball stays between the background
        /// and the letters, finite, and moves no faster (and accelerates no harder) than
        /// the smooth step allows at the scroll speed; the same parameters give the
        /// same positions.
        #[test]
        fn text_stays_between_its_heights_and_is_smooth(
            params in params(PARAMS),
            grid in grid(),
            t0_s in 0.0..600.0f64,
        ) {
            let (field, notes) = PATTERN.field(&params, 0, &grid).unwrap();
            // No number is clamped: only characters the font lacks, a text larger
            // than the matrix or an empty one are noted.
            prop_assert!(notes.iter().all(|note| note.numbers().is_none()), "{notes:?}");
            let (again, _) = PATTERN.field(&params, 0, &grid).unwrap();
            let base_mm = number(&params, "base_mm");
            let depth_mm = number(&params, "depth_mm");
            let cols_per_s = number(&params, "scroll_m_s").abs() * 1000.0 / grid.pitch_mm;
            let max_speed = depth_mm * 15.0 / 8.0 * cols_per_s;
            let max_accel = depth_mm * 10.0 / 3f64.sqrt() * cols_per_s * cols_per_s;
            let (low, high) = (base_mm - depth_mm, base_mm + depth_mm);
            let n = grid.unit_count();
            let (mut a, mut b, mut c, mut d) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let h = 1e-3;
            for step in 0..50 {
                let t_s = t0_s + f64::from(step) * 0.037;
                field.sample(&grid, t_s - h, &mut a);
                field.sample(&grid, t_s, &mut b);
                field.sample(&grid, t_s + h, &mut c);
                again.sample(&grid, t_s, &mut d);
                prop_assert_eq!(&b, &d);
                for unit in 0..n {
                    prop_assert!(b[unit].is_finite());
                    prop_assert!((low - 1e-9..=high + 1e-9).contains(&b[unit]), "{}", b[unit]);
                    let speed = (c[unit] - a[unit]) / (2.0 * h);
                    let accel = (c[unit] - 2.0 * b[unit] + a[unit]) / (h * h);
                    prop_assert!(speed.abs() <= max_speed * 1.001 + 1e-6, "{} > {}", speed, max_speed);
                    // The second difference's rounding error is about 1e-13 · mm / h².
                    prop_assert!(accel.abs() <= max_accel * 1.01 + 1e-6 * high.max(1.0), "{} > {}", accel, max_accel);
                }
            }
        }
    }

    /// The installation's limits for `grid`.
    pub(crate) fn limits_for(grid: &Grid) -> crate::show::Limits {
        let mut limits = crate::show::Limits::for_layout(grid.rows, grid.cols);
        limits.travel_mm = grid.travel_mm;
        limits
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]

        /// Any text, bitmap and parameters the page allows render into a show that
        /// passes validation, the same show every time.
        #[test]
        fn any_text_renders_within_the_limits(
            params in params(PARAMS),
            grid in grid(),
            duration_s in 1.0..12.0f64,
            row_ms in proptest::sample::select(&[20u32, 100, 200, 255][..]),
        ) {
            let mut recipe = crate::create::Recipe::single("t", "text", params, duration_s);
            recipe.row_ms = row_ms;
            let limits = limits_for(&grid);
            let once = crate::create::render(&recipe, &grid, &limits).unwrap();
            prop_assert_eq!(crate::show::validate(&once.show, &limits), vec![]);
            let twice = crate::create::render(&recipe, &grid, &limits).unwrap();
            prop_assert_eq!(once.show.to_json().unwrap(), twice.show.to_json().unwrap());
            prop_assert_eq!(once.notes, twice.notes);
        }
    }
}
