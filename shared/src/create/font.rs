//! The built-in bitmap font and monochrome bitmaps: what the `text` pattern draws.
//!
//! Glyphs come from the public-domain 8 × 8 font of the `font8x8` crate (IBM's VGA
//! font as collected by Marcel Sondaar and Daniel Hepper): Basic Latin (letters in both
//! cases, digits, punctuation), Latin-1 (accented letters: é, ü, ß, ñ …), Greek and
//! Hiragana. [`render`] lays text out proportionally — each glyph trimmed to its
//! inked columns, one blank column between glyphs, a space two columns wide — so a
//! 10-ball-wide matrix shows more than one letter; lines (separated by a newline or
//! `|`) are centred one under the other. A character the font lacks
//! is drawn as `?`; CJK and logos come as a user [`Bitmap`] instead
//! ([`Bitmap::parse`]: lines of `#` and `.`).
//!
//! ```
//! use floatball_shared::create::font::{Bitmap, render};
//!
//! let word = render("HI").trimmed();
//! assert_eq!(word.height(), 7);
//! assert!(word.ink(0, 0)); // the H's top left
//! let logo = Bitmap::parse("#.#\n.#.");
//! assert_eq!((logo.width(), logo.height()), (3, 2));
//! assert_eq!(logo.to_text(), "#.#\n.#.");
//! ```

use font8x8::{BASIC_FONTS, GREEK_FONTS, HIRAGANA_FONTS, LATIN_FONTS, UnicodeFonts};

/// Width and height of a glyph cell of the built-in font, pixels.
pub const GLYPH_PX: usize = 8;

/// Width of a space, pixels (between the blank columns either side of every glyph).
pub const SPACE_PX: usize = 2;

/// Blank columns between two glyphs, pixels.
pub const GAP_PX: usize = 1;

/// Blank rows between two lines of text, pixels (below the descenders' row).
pub const LINE_GAP_PX: usize = 1;

/// What separates the lines of a text: a newline, or `|` (as in [`Bitmap::parse`]).
pub const LINE_BREAKS: [char; 2] = ['\n', '|'];

/// A monochrome picture: `height` rows of `width` pixels, each inked or not.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Bitmap {
    width: usize,
    height: usize,
    /// Row-major, `true` = ink.
    pixels: Vec<bool>,
}

impl Bitmap {
    /// A blank bitmap of `width` × `height` pixels.
    #[must_use]
    pub fn blank(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: vec![false; width.saturating_mul(height)],
        }
    }

    /// Reads lines of pixels: `.`, space, `0`, `-` and `_` are blank, every other
    /// character is ink (`#`, `X`, `1`, `*`, a CJK character …). Lines are separated
    /// by a newline or `|` (handy on a command line); a carriage return is ignored.
    /// Empty lines at the start and end are dropped; shorter lines are blank to the
    /// right. Never fails: any text is some bitmap.
    #[must_use]
    pub fn parse(text: &str) -> Self {
        let lines: Vec<Vec<bool>> = text
            .split(['\n', '|'])
            .map(|line| {
                line.chars()
                    .filter(|c| *c != '\r')
                    .map(|c| !matches!(c, '.' | ' ' | '0' | '-' | '_'))
                    .collect()
            })
            .collect();
        let first = lines.iter().position(|line| !line.is_empty());
        let last = lines.iter().rposition(|line| !line.is_empty());
        let lines = match (first, last) {
            (Some(first), Some(last)) => &lines[first..=last],
            _ => &[][..],
        };
        let width = lines.iter().map(Vec::len).max().unwrap_or(0);
        let mut bitmap = Self::blank(width, lines.len());
        for (y, line) in lines.iter().enumerate() {
            for (x, ink) in line.iter().enumerate() {
                bitmap.set(x, y, *ink);
            }
        }
        bitmap
    }

    /// Width, pixels.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height, pixels.
    #[must_use]
    pub fn height(&self) -> usize {
        self.height
    }

    /// Whether pixel (`x` to the right, `y` down) is inked; blank outside the bitmap.
    #[must_use]
    pub fn ink(&self, x: usize, y: usize) -> bool {
        x < self.width && y < self.height && self.pixels[y * self.width + x]
    }

    /// Inks (or blanks) pixel (`x`, `y`); nothing outside the bitmap.
    pub fn set(&mut self, x: usize, y: usize, ink: bool) {
        if x < self.width && y < self.height {
            self.pixels[y * self.width + x] = ink;
        }
    }

    /// Whether no pixel is inked.
    #[must_use]
    pub fn is_blank(&self) -> bool {
        !self.pixels.contains(&true)
    }

    /// The bitmap without its blank rows at the top and bottom (all of them if it is
    /// blank): what is centred on the matrix's height.
    #[must_use]
    pub fn trimmed(&self) -> Self {
        let inked = |y: usize| (0..self.width).any(|x| self.ink(x, y));
        let Some(top) = (0..self.height).find(|y| inked(*y)) else {
            return Self::blank(self.width, 0);
        };
        let bottom = (0..self.height).rfind(|y| inked(*y)).unwrap_or(top);
        Self {
            width: self.width,
            height: bottom + 1 - top,
            pixels: self.pixels[top * self.width..(bottom + 1) * self.width].to_vec(),
        }
    }

    /// The bitmap as lines of `#` (ink) and `.` (blank), as [`parse`](Self::parse)
    /// reads them.
    #[must_use]
    pub fn to_text(&self) -> String {
        (0..self.height)
            .map(|y| {
                (0..self.width)
                    .map(|x| if self.ink(x, y) { '#' } else { '.' })
                    .collect::<String>()
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// The built-in font's glyph for `c`: eight rows, top first; bit `x` of a row is the
/// pixel `x` from the left. `None` when the font has no glyph for it.
#[must_use]
pub fn glyph(c: char) -> Option<[u8; GLYPH_PX]> {
    BASIC_FONTS
        .get(c)
        .or_else(|| LATIN_FONTS.get(c))
        .or_else(|| GREEK_FONTS.get(c))
        .or_else(|| HIRAGANA_FONTS.get(c))
}

/// Whether the built-in font draws `c` (otherwise [`render`] draws `?`).
#[must_use]
pub fn has_glyph(c: char) -> bool {
    c.is_whitespace() || glyph(c).is_some()
}

/// The characters of `text` that the built-in font lacks (and [`render`] draws as
/// `?`), each once, in the order they first appear; whitespace and control characters
/// are not drawn and not missing.
#[must_use]
pub fn missing(text: &str) -> String {
    let mut missing = String::new();
    for c in text.chars() {
        if !c.is_control() && !has_glyph(c) && !missing.contains(c) {
            missing.push(c);
        }
    }
    missing
}

/// `text` in the built-in font: each line (separated by a newline or `|`) eight
/// pixels high (top row first, the descenders of g, j, p, q, y in the last), centred
/// under the one before with [`LINE_GAP_PX`] blank rows between. Every glyph keeps
/// only its inked columns, with [`GAP_PX`] blank between glyphs; whitespace is a
/// [`SPACE_PX`]-wide blank; a character the font lacks is a `?`.
#[must_use]
pub fn render(text: &str) -> Bitmap {
    let mut lines: Vec<Bitmap> = text.split(LINE_BREAKS).map(render_line).collect();
    if lines.len() == 1 {
        return lines.remove(0);
    }
    let width = lines.iter().map(Bitmap::width).max().unwrap_or(0);
    let pitch = GLYPH_PX + LINE_GAP_PX;
    let mut bitmap = Bitmap::blank(width, pitch * lines.len() - LINE_GAP_PX);
    for (index, line) in lines.iter().enumerate() {
        let left = (width - line.width()) / 2;
        for y in 0..line.height() {
            for x in 0..line.width() {
                if line.ink(x, y) {
                    bitmap.set(left + x, index * pitch + y, true);
                }
            }
        }
    }
    bitmap
}

/// One line of `text` in the built-in font, eight pixels high.
fn render_line(text: &str) -> Bitmap {
    // (columns of the glyph, its rows) for every character.
    let glyphs: Vec<(std::ops::Range<usize>, [u8; GLYPH_PX])> = text
        .chars()
        .map(|c| {
            let rows = if c.is_whitespace() || c.is_control() {
                [0; GLYPH_PX]
            } else {
                glyph(c).or_else(|| glyph('?')).unwrap_or([0; GLYPH_PX])
            };
            let mask = rows.iter().fold(0u8, |mask, row| mask | row);
            let columns = if mask == 0 {
                0..SPACE_PX
            } else {
                mask.trailing_zeros() as usize..GLYPH_PX - mask.leading_zeros() as usize
            };
            (columns, rows)
        })
        .collect();
    let width = glyphs
        .iter()
        .map(|(columns, _)| columns.len())
        .sum::<usize>()
        + GAP_PX * glyphs.len().saturating_sub(1);
    let mut bitmap = Bitmap::blank(width, GLYPH_PX);
    let mut left = 0;
    for (columns, rows) in &glyphs {
        for (y, row) in rows.iter().enumerate() {
            for (x, bit) in columns.clone().enumerate() {
                bitmap.set(left + x, y, row & (1 << bit) != 0);
            }
        }
        left += columns.len() + GAP_PX;
    }
    bitmap
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn latin_letters_digits_and_punctuation_have_glyphs() {
        for c in ('A'..='Z')
            .chain('a'..='z')
            .chain('0'..='9')
            .chain("!?.,:;-+'\"()/&@#%".chars())
        {
            assert!(glyph(c).is_some_and(|rows| rows != [0; 8]), "{c:?}");
        }
        for c in "éèüöäßñçÉÜÅ".chars() {
            assert!(glyph(c).is_some_and(|rows| rows != [0; 8]), "{c:?}");
        }
        assert!(has_glyph(' '));
        assert!(!has_glyph('字'));
        assert_eq!(missing("Hi 字 ok 字幕\t?"), "字幕");
        assert_eq!(missing("Grüße, ΑΒΓ あ 42!"), "");
    }

    #[test]
    fn an_a_is_the_font_bitmap_trimmed_to_its_columns() {
        let a = render("A");
        assert_eq!(
            a.to_text(),
            "..##..\n.####.\n##..##\n##..##\n######\n##..##\n##..##\n......"
        );
        assert_eq!(a.trimmed().height(), 7);
    }

    #[test]
    fn glyphs_are_one_column_apart_and_spaces_two_wide() {
        let i = render("I").width();
        let ii = render("II");
        assert_eq!(ii.width(), 2 * i + GAP_PX);
        assert!((0..8).all(|y| !ii.ink(i, y)), "the gap is blank");
        assert_eq!(render("I I").width(), 2 * i + SPACE_PX + 2 * GAP_PX);
        assert_eq!(render("").width(), 0);
        assert!(render("").is_blank());
    }

    #[test]
    fn lines_are_centred_one_under_the_other() {
        let two = render("II|I");
        let i = render("I");
        let ii = render("II");
        assert_eq!(two.width(), ii.width());
        assert_eq!(two.height(), 2 * GLYPH_PX + LINE_GAP_PX);
        assert_eq!(render("II\nI"), two);
        let left = (ii.width() - i.width()) / 2;
        for y in 0..GLYPH_PX {
            for x in 0..two.width() {
                assert_eq!(two.ink(x, y), ii.ink(x, y), "first line at {x}, {y}");
                let below = x
                    .checked_sub(left)
                    .is_some_and(|x| x < i.width() && i.ink(x, y));
                assert_eq!(two.ink(x, GLYPH_PX + LINE_GAP_PX + y), below, "{x}, {y}");
            }
        }
        assert!(
            (0..two.width()).all(|x| !two.ink(x, GLYPH_PX)),
            "the gap is blank"
        );
        // An empty line in the middle is a blank line; the text's own lines only.
        assert_eq!(render("A||A").height(), 3 * GLYPH_PX + 2 * LINE_GAP_PX);
        assert_eq!(missing("A|B\nC"), "");
    }

    #[test]
    fn a_character_the_font_lacks_is_a_question_mark() {
        assert_eq!(render("字"), render("?"));
    }

    #[test]
    fn bitmaps_parse_from_lines_of_hashes_and_dots() {
        let bitmap = Bitmap::parse("\n#..#\r\n.##|#\n\n");
        assert_eq!(bitmap.to_text(), "#..#\n.##.\n#...");
        assert!(bitmap.ink(0, 2) && !bitmap.ink(1, 2) && !bitmap.ink(9, 9));
        assert_eq!(Bitmap::parse("口口\n口.").to_text(), "##\n#.");
        assert!(Bitmap::parse("").is_blank());
        assert_eq!(Bitmap::parse("...\n.#.\n...").trimmed().to_text(), ".#.");
        assert_eq!(Bitmap::parse("...").trimmed().height(), 0);
    }
}
