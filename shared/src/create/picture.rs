//! The image heightmap pattern: a PNG or JPEG picture becomes heights — bright parts
//! high, dark parts low (or the other way round) — optionally rising slowly out of a
//! flat matrix.
//!
//! The picture is decoded by the `image` crate (PNG and JPEG only; within
//! [`MAX_SIDE_PX`] a side and [`MAX_DECODED_BYTES`] decoded, so a small file cannot
//! ask for gigabytes), turned upright by its EXIF orientation, and reduced to its
//! brightness (Rec. 709 luma, as `image` computes it) composited over black by its
//! alpha: a transparent background counts as dark. Each ball's cell — a square of
//! the grid's pitch, the picture's top at the back of the matrix — takes the average
//! over the pixels it covers, weighted by how much of each it covers ([`cell_levels`]).
//! With `fit` = `contain` the whole picture is shown and the cells beside it are dark;
//! with `cover` it fills the matrix and its edges are cut.
//!
//! A level `v` in 0..=1 (after `invert`: `1 − v`; transparent and outside stay 0) is
//! the position `low_mm + (high_mm − low_mm) · v`. With `reveal_s` > 0 the balls start
//! flat at `low_mm` and reach the picture after `reveal_s` seconds along the quintic
//! smooth step, with zero speed at both ends.
//!
//! The last picture's levels are remembered (per thread), so moving a height or reveal
//! slider on the page does not decode the file again.

use std::cell::RefCell;
use std::io::Cursor;

use image::{DynamicImage, GrayAlphaImage, ImageDecoder, ImageError, ImageReader};

use super::catalogue::PatternSpec;
use super::params::{ParamKind, ParamSpec, Reader};
use super::text::cells;
use super::{CreateError, Field, Grid, smooth_step};

/// Largest picture file, bytes (4 MiB).
pub const MAX_PICTURE_BYTES: usize = 4 * 1024 * 1024;

/// Largest picture width or height, pixels.
pub const MAX_SIDE_PX: u32 = 8192;

/// Most memory a decoded picture may take, bytes (256 MiB: an 8192 × 8192 RGB picture
/// fits, a 16-bit RGBA one of that size does not).
pub const MAX_DECODED_BYTES: u64 = 256 * 1024 * 1024;

/// How the picture is fitted to the matrix.
pub const FITS: &[&str] = &["contain", "cover"];

/// Whether bright parts hang low instead of high.
pub const INVERT: &[&str] = &["no", "yes"];

/// The picture pattern's parameters.
pub const PARAMS: &[ParamSpec] = &[
    ParamSpec {
        key: "image",
        label: "Picture",
        help: "A PNG or JPEG picture (a file path on the command line).",
        kind: ParamKind::Bytes {
            max_bytes: MAX_PICTURE_BYTES,
        },
    },
    ParamSpec {
        key: "fit",
        label: "Fit",
        help: "Contain shows the whole picture (dark beside it); cover fills the matrix and \
               cuts the picture's edges.",
        kind: ParamKind::Choice {
            options: FITS,
            default: "contain",
        },
    },
    ParamSpec {
        key: "invert",
        label: "Invert",
        help: "Yes hangs bright parts low and dark parts high.",
        kind: ParamKind::Choice {
            options: INVERT,
            default: "no",
        },
    },
    ParamSpec {
        key: "high_mm",
        label: "Bright height",
        help: "Where the brightest parts hang, below the top.",
        kind: ParamKind::height_mm(2000.0),
    },
    ParamSpec {
        key: "low_mm",
        label: "Dark height",
        help: "Where the darkest parts (and the background) hang, below the top.",
        kind: ParamKind::height_mm(4000.0),
    },
    ParamSpec {
        key: "reveal_s",
        label: "Reveal",
        help: "Seconds the picture takes to rise out of a flat matrix (0: shown at once).",
        kind: ParamKind::number(0.0, 60.0, 0.5, 0.0, "s"),
    },
];

/// The catalogue's entry.
pub const PATTERN: PatternSpec = PatternSpec {
    name: "image",
    label: "Picture",
    help: "A PNG or JPEG picture as heights: bright parts high, dark parts low.",
    params: PARAMS,
    build,
};

/// How the picture is fitted to the matrix.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fit {
    /// The whole picture, cells beside it dark.
    Contain,
    /// The matrix filled, the picture's edges cut.
    Cover,
}

fn build(reader: &mut Reader<'_>, grid: &Grid) -> Result<Box<dyn Field>, CreateError> {
    let bytes = reader.bytes("image")?;
    let fit = if reader.choice("fit") == "cover" {
        Fit::Cover
    } else {
        Fit::Contain
    };
    let invert = reader.choice("invert") == "yes";
    let levels = cached_levels(bytes, grid.rows, grid.cols, fit, invert).map_err(|message| {
        CreateError::Picture {
            key: "image".to_owned(),
            message,
        }
    })?;
    Ok(Box::new(Picture::new(
        grid,
        &levels,
        reader.number("low_mm"),
        reader.number("high_mm"),
        reader.number("reveal_s"),
    )))
}

/// The last picture's cell levels and what they were computed from.
struct Cached {
    bytes: Vec<u8>,
    rows: u32,
    cols: u32,
    fit: Fit,
    invert: bool,
    levels: Vec<f64>,
}

thread_local! {
    /// The last picture's levels: the page rebuilds the pattern on every move of a
    /// slider, and decoding a photo takes far longer than the 16 ms a frame has; only
    /// a new file, grid, fit or inversion decodes it again. Holds one file (≤ 4 MiB)
    /// and one level per ball; the result is the same with or without it.
    static LAST: RefCell<Option<Cached>> = const { RefCell::new(None) };
}

/// [`decode`] and [`cell_levels`], remembering the last result (see [`LAST`]).
fn cached_levels(
    bytes: Vec<u8>,
    rows: u32,
    cols: u32,
    fit: Fit,
    invert: bool,
) -> Result<Vec<f64>, String> {
    let hit = LAST.with_borrow(|last| {
        last.as_ref()
            .filter(|last| {
                (last.rows, last.cols, last.fit, last.invert) == (rows, cols, fit, invert)
                    && last.bytes == bytes
            })
            .map(|last| last.levels.clone())
    });
    if let Some(levels) = hit {
        return Ok(levels);
    }
    let levels = cell_levels(&decode(&bytes)?, rows, cols, fit, invert);
    LAST.set(Some(Cached {
        bytes,
        rows,
        cols,
        fit,
        invert,
        levels: levels.clone(),
    }));
    Ok(levels)
}

/// Decodes a PNG or JPEG picture, upright, to its brightness and alpha.
///
/// # Errors
/// Why it cannot be used, in words: empty, not a PNG or JPEG, damaged (the decoder's
/// words), or too large.
pub fn decode(bytes: &[u8]) -> Result<GrayAlphaImage, String> {
    if bytes.is_empty() {
        return Err("no picture was given".to_owned());
    }
    let reader = ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|error| error.to_string())?;
    if reader.format().is_none() {
        return Err("it is neither a PNG nor a JPEG picture".to_owned());
    }
    let too_large = || {
        format!(
            "it is larger than {MAX_SIDE_PX} × {MAX_SIDE_PX} pixels or {} MB decoded; make it smaller",
            MAX_DECODED_BYTES / (1024 * 1024)
        )
    };
    let mut decoder = reader.into_decoder().map_err(|error| words(&error))?;
    let (width, height) = decoder.dimensions();
    if width > MAX_SIDE_PX || height > MAX_SIDE_PX || decoder.total_bytes() > MAX_DECODED_BYTES {
        return Err(too_large());
    }
    let orientation = decoder.orientation().map_err(|error| words(&error))?;
    let mut picture = DynamicImage::from_decoder(decoder).map_err(|error| match error {
        ImageError::Limits(_) => too_large(),
        error => words(&error),
    })?;
    picture.apply_orientation(orientation);
    Ok(picture.to_luma_alpha8())
}

/// The decoder's error in words.
fn words(error: &ImageError) -> String {
    match error {
        ImageError::Unsupported(_) => format!("{error}; only PNG and JPEG pictures are read"),
        _ => error.to_string(),
    }
}

/// The level (0 = dark, 1 = bright; inverted if `invert`) of each cell of a `rows` ×
/// `cols` grid of square cells laid over `picture`, row-major from the picture's top
/// row: the average over the pixels each cell covers, weighted by the area covered.
/// Transparent pixels and cells beside the picture (with [`Fit::Contain`]) count as 0.
#[must_use]
pub fn cell_levels(
    picture: &GrayAlphaImage,
    rows: u32,
    cols: u32,
    fit: Fit,
    invert: bool,
) -> Vec<f64> {
    let (width, height) = (f64::from(picture.width()), f64::from(picture.height()));
    let mut levels = vec![0.0; rows as usize * cols as usize];
    if rows == 0 || cols == 0 || picture.width() == 0 || picture.height() == 0 {
        return levels;
    }
    let (per_col, per_row) = (width / f64::from(cols), height / f64::from(rows));
    // A cell's side, pixels.
    let side = match fit {
        Fit::Contain => per_col.max(per_row),
        Fit::Cover => per_col.min(per_row),
    };
    let xs = spans(
        (width - f64::from(cols) * side) / 2.0,
        side,
        cols,
        picture.width(),
    );
    let ys = spans(
        (height - f64::from(rows) * side) / 2.0,
        side,
        rows,
        picture.height(),
    );
    let area = side * side;
    for (row, ys) in ys.iter().enumerate() {
        for (col, xs) in xs.iter().enumerate() {
            let mut sum = 0.0;
            for &(y, wy) in ys {
                for &(x, wx) in xs {
                    let [luma, alpha] = picture.get_pixel(x, y).0;
                    let luma = f64::from(luma) / 255.0;
                    let level = if invert { 1.0 - luma } else { luma };
                    sum += wy * wx * level * f64::from(alpha) / 255.0;
                }
            }
            levels[row * cols as usize + col] = sum / area;
        }
    }
    levels
}

/// For each of `count` cells of `side` pixels, the first starting at `start`: the
/// pixels of `0..len` it covers and how much of each (0..=1).
fn spans(start: f64, side: f64, count: u32, len: u32) -> Vec<Vec<(u32, f64)>> {
    (0..count)
        .map(|cell| {
            let from = start + f64::from(cell) * side;
            let to = from + side;
            // Pixel indices within 0..len, as floats then whole numbers.
            let first = from.floor().clamp(0.0, f64::from(len));
            let last = to.ceil().clamp(0.0, f64::from(len));
            #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
            let (first, last) = (first as u32, last as u32);
            (first..last)
                .filter_map(|pixel| {
                    let p = f64::from(pixel);
                    let covered = to.min(p + 1.0) - from.max(p);
                    (covered > 0.0).then_some((pixel, covered))
                })
                .collect()
        })
        .collect()
}

/// The picture pattern with its parameters fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct Picture {
    /// Every ball's position in the picture, mm below the top, row-major.
    target_mm: Vec<f64>,
    /// Where the balls start when revealing, mm below the top.
    flat_mm: f64,
    /// Seconds to rise into the picture (0 = at once).
    reveal_s: f64,
}

impl Picture {
    /// The picture on `grid` with cell `levels` (row-major from the picture's top, as
    /// [`cell_levels`] gives them): level 0 at `low_mm`, 1 at `high_mm`; rising from
    /// flat at `low_mm` over `reveal_s` seconds.
    #[must_use]
    pub fn new(grid: &Grid, levels: &[f64], low_mm: f64, high_mm: f64, reveal_s: f64) -> Self {
        let cols = i64::from(grid.cols);
        let target_mm = cells(grid)
            .into_iter()
            .map(|(col, row)| {
                let level = usize::try_from(row * cols + col)
                    .ok()
                    .and_then(|cell| levels.get(cell))
                    .copied()
                    .unwrap_or(0.0);
                low_mm + (high_mm - low_mm) * level
            })
            .collect();
        Self {
            target_mm,
            flat_mm: low_mm,
            reveal_s,
        }
    }
}

impl Field for Picture {
    fn sample(&self, _grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        let shown = if self.reveal_s > 0.0 && t_s.is_finite() {
            smooth_step(t_s / self.reveal_s)
        } else {
            1.0
        };
        for (out, target) in out_mm.iter_mut().zip(&self.target_mm) {
            *out = self.flat_mm + (target - self.flat_mm) * shown;
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use image::{ImageFormat, Luma, LumaA, Rgb, RgbImage};

    use super::super::params::{Params, Value, encode_base64};
    use super::*;

    fn png(picture: &DynamicImage) -> Vec<u8> {
        let mut bytes = Vec::new();
        picture
            .write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
            .unwrap();
        bytes
    }

    fn field(
        grid: &Grid,
        image: &[u8],
        params: &[(&str, Value)],
    ) -> Result<Box<dyn Field>, CreateError> {
        let mut all: Params = params
            .iter()
            .map(|(key, value)| ((*key).to_owned(), value.clone()))
            .collect();
        all.insert("image".into(), Value::Text(encode_base64(image)));
        PATTERN.field(&all, 0, grid).map(|(field, _)| field)
    }

    fn sample(field: &dyn Field, grid: &Grid, t_s: f64) -> Vec<f64> {
        let mut out_mm = vec![f64::NAN; grid.unit_count()];
        field.sample(grid, t_s, &mut out_mm);
        out_mm
    }

    /// A 100 × 10 grey picture brightening left to right: pixel x is 30 + 2x.
    fn gradient() -> Vec<u8> {
        png(&DynamicImage::ImageLuma8(image::ImageBuffer::from_fn(
            100,
            10,
            |x, _| Luma([u8::try_from(30 + 2 * x).unwrap()]),
        )))
    }

    #[test]
    fn a_gradient_gives_evenly_rising_heights() {
        // Ten columns of ten pixels: column c averages 30 + 2 (10c + 4.5) = 39 + 20c.
        let grid = Grid::new(1, 10, 500.0, 7500.0);
        let out_mm = sample(field(&grid, &gradient(), &[]).unwrap().as_ref(), &grid, 0.0);
        for (col, mm) in out_mm.iter().enumerate() {
            let level = (39.0 + 20.0 * col as f64) / 255.0;
            let want = 4000.0 + (2000.0 - 4000.0) * level;
            assert!(
                (mm - want).abs() < 1e-9,
                "column {col}: {mm} mm, want {want}"
            );
        }
        // Inverted, and with other heights: dark high.
        let inverted = field(
            &grid,
            &gradient(),
            &[
                ("invert", Value::Text("yes".into())),
                ("high_mm", Value::Number(1000.0)),
                ("low_mm", Value::Number(5000.0)),
            ],
        )
        .unwrap();
        let out_mm = sample(inverted.as_ref(), &grid, 0.0);
        for (col, mm) in out_mm.iter().enumerate() {
            let level = 1.0 - (39.0 + 20.0 * col as f64) / 255.0;
            assert!(
                (mm - (5000.0 - 4000.0 * level)).abs() < 1e-9,
                "column {col}: {mm}"
            );
        }
    }

    #[test]
    fn cells_cover_fractions_of_pixels() {
        // The gradient (100 × 10) on one row of three cells.
        let picture = image::load_from_memory(&gradient())
            .unwrap()
            .to_luma_alpha8();
        let levels = cell_levels(&picture, 1, 3, Fit::Cover, false);
        let side = 100.0 / 3.0;
        // Cover: square cells of min(100/3, 10/1) = 10 pixels, centred: 35..65.
        for (col, level) in levels.iter().enumerate() {
            let mean = 30.0 + 2.0 * (35.0 + 10.0 * col as f64 + 4.5);
            assert!((level - mean / 255.0).abs() < 1e-12, "{col}: {level}");
        }
        // Contain: cells of max(33⅓, 10) = 33⅓ pixels; the one row is 33⅓ tall around
        // a 10-pixel picture, so each cell is 30 % picture, 70 % dark beside it.
        let levels = cell_levels(&picture, 1, 3, Fit::Contain, false);
        for (col, level) in levels.iter().enumerate() {
            let (from, to) = (col as f64 * side, (col + 1) as f64 * side);
            let mut sum = 0.0;
            for x in 0..100u32 {
                let p = f64::from(x);
                let covered = (to.min(p + 1.0) - from.max(p)).max(0.0);
                sum += covered * 10.0 * (30.0 + 2.0 * p) / 255.0;
            }
            assert!(
                (level - sum / (side * side)).abs() < 1e-12,
                "{col}: {level}"
            );
        }
    }

    #[test]
    fn the_pictures_top_is_at_the_back_and_transparency_is_dark() {
        // Top half white, bottom half black; the right half transparent.
        let picture = DynamicImage::ImageLumaA8(image::ImageBuffer::from_fn(40, 40, |x, y| {
            LumaA([if y < 20 { 255 } else { 0 }, if x < 20 { 255 } else { 0 }])
        }));
        let grid = Grid::new(2, 2, 500.0, 7500.0);
        let out_mm = sample(
            field(&grid, &png(&picture), &[]).unwrap().as_ref(),
            &grid,
            0.0,
        );
        // Row 0 is the front: dark (4000); row 1 the back: bright on the left only.
        assert_eq!(out_mm, vec![4000.0, 4000.0, 2000.0, 4000.0]);
    }

    #[test]
    fn a_jpeg_decodes_to_its_brightness() {
        let picture = DynamicImage::ImageRgb8(RgbImage::from_pixel(64, 48, Rgb([200, 120, 40])));
        let mut jpeg = Vec::new();
        picture
            .write_to(&mut Cursor::new(&mut jpeg), ImageFormat::Jpeg)
            .unwrap();
        assert_eq!(&jpeg[..2], &[0xFF, 0xD8]);
        let decoded = decode(&jpeg).unwrap();
        assert_eq!(decoded.dimensions(), (64, 48));
        // Rec. 709: 0.2126·200 + 0.7152·120 + 0.0722·40 = 131.2 (JPEG loses a little).
        let levels = cell_levels(&decoded, 3, 4, Fit::Cover, false);
        for level in levels {
            assert!((level * 255.0 - 131.2).abs() < 3.0, "{}", level * 255.0);
        }
        let grid = Grid::new(3, 4, 500.0, 7500.0);
        assert!(field(&grid, &jpeg, &[]).is_ok());
    }

    #[test]
    fn what_is_not_a_picture_is_refused_in_words() {
        let grid = Grid::new(3, 3, 500.0, 7500.0);
        let refuse = |bytes: &[u8]| field(&grid, bytes, &[]).err().unwrap().to_string();
        let garbage = refuse(b"this is not a picture at all");
        assert!(
            garbage.contains("the picture in \"image\" cannot be read"),
            "{garbage}"
        );
        assert!(garbage.contains("neither a PNG nor a JPEG"), "{garbage}");
        assert!(garbage.contains("use a PNG or JPEG file"), "{garbage}");
        // A damaged PNG: its signature, then nothing sensible.
        let mut damaged = gradient();
        damaged.truncate(40);
        let damaged = refuse(&damaged);
        assert!(damaged.contains("cannot be read ("), "{damaged}");
        let gif = refuse(b"GIF89a\x01\x00\x01\x00\x00\x00\x00;");
        assert!(gif.contains("only PNG and JPEG pictures are read"), "{gif}");
        let empty = refuse(b"");
        assert!(empty.contains("no picture was given"), "{empty}");
        let missing = PATTERN
            .field(&Params::new(), 0, &grid)
            .err()
            .unwrap()
            .to_string();
        assert!(missing.contains("no picture was given"), "{missing}");
        // Too wide.
        let wide = png(&DynamicImage::ImageLuma8(image::ImageBuffer::new(
            MAX_SIDE_PX + 1,
            1,
        )));
        let wide = refuse(&wide);
        assert!(wide.contains("larger than 8192 × 8192 pixels"), "{wide}");
    }

    #[test]
    fn the_reveal_rises_smoothly_from_flat() {
        let grid = Grid::new(1, 10, 500.0, 7500.0);
        let revealed = field(&grid, &gradient(), &[("reveal_s", Value::Number(4.0))]).unwrap();
        assert!(
            sample(revealed.as_ref(), &grid, 0.0)
                .iter()
                .all(|&mm| mm == 4000.0)
        );
        let full = sample(field(&grid, &gradient(), &[]).unwrap().as_ref(), &grid, 0.0);
        assert_eq!(sample(revealed.as_ref(), &grid, 4.0), full);
        assert_eq!(sample(revealed.as_ref(), &grid, 400.0), full);
        // Zero speed at both ends, finite in between.
        let h = 1e-4;
        for t_s in [0.0, 4.0] {
            let (a, b) = (
                sample(revealed.as_ref(), &grid, t_s - h),
                sample(revealed.as_ref(), &grid, t_s + h),
            );
            assert!(a.iter().zip(&b).all(|(a, b)| (b - a).abs() < 1e-6));
        }
        let mid = sample(revealed.as_ref(), &grid, 2.0);
        assert!(
            mid.iter()
                .zip(&full)
                .all(|(m, f)| (m - (4000.0 + f) / 2.0).abs() < 1e-9)
        );
    }

    #[test]
    fn the_remembered_picture_gives_what_decoding_gives() {
        let bytes = gradient();
        let fresh = cell_levels(&decode(&bytes).unwrap(), 3, 5, Fit::Contain, true);
        // Twice: the first decodes (or finds another test's), the second remembers.
        for _ in 0..2 {
            assert_eq!(
                cached_levels(bytes.clone(), 3, 5, Fit::Contain, true).unwrap(),
                fresh
            );
        }
        // Anything else different decodes again.
        let other = cell_levels(&decode(&bytes).unwrap(), 3, 5, Fit::Cover, true);
        assert_ne!(other, fresh);
        assert_eq!(
            cached_levels(bytes.clone(), 3, 5, Fit::Cover, true).unwrap(),
            other
        );
        let mut changed = bytes.clone();
        changed.truncate(50);
        assert!(cached_levels(changed, 3, 5, Fit::Cover, true).is_err());
        assert_eq!(cached_levels(bytes, 3, 5, Fit::Cover, true).unwrap(), other);
    }

    #[test]
    fn pictures_are_deterministic() {
        let grid = Grid::new(5, 7, 500.0, 7500.0);
        let params = [("fit", Value::Text("cover".into()))];
        let one = sample(
            field(&grid, &gradient(), &params).unwrap().as_ref(),
            &grid,
            1.0,
        );
        let two = sample(
            field(&grid, &gradient(), &params).unwrap().as_ref(),
            &grid,
            1.0,
        );
        assert_eq!(one, two);
        assert!(one.iter().all(|mm| (2000.0..=4000.0).contains(mm)));
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use image::{ImageBuffer, ImageFormat, LumaA};
    use proptest::prelude::*;

    use super::super::params::Params;
    use super::super::params::{ParamKind, Value, encode_base64};
    use super::super::text::proptests::{grid, limits_for, params};
    use super::super::{Recipe, Segment, render};
    use super::*;
    use crate::show::validate;

    /// A small picture of any size and pixels, as a PNG.
    fn png() -> impl Strategy<Value = Vec<u8>> {
        (1..=24u32, 1..=24u32)
            .prop_flat_map(|(width, height)| {
                (
                    Just((width, height)),
                    proptest::collection::vec(any::<[u8; 2]>(), (width * height) as usize),
                )
            })
            .prop_map(|((width, height), pixels)| {
                let picture = ImageBuffer::from_fn(width, height, |x, y| {
                    LumaA(pixels[(y * width + x) as usize])
                });
                let mut bytes = Vec::new();
                DynamicImage::ImageLumaA8(picture)
                    .write_to(&mut Cursor::new(&mut bytes), ImageFormat::Png)
                    .unwrap();
                bytes
            })
    }

    fn number(params: &super::super::params::Params, key: &str) -> f64 {
        match (params.get(key), PATTERN.param(key).map(|spec| spec.kind)) {
            (Some(Value::Number(value)), _) => *value,
            (_, Some(ParamKind::Number { default, .. })) => default,
            _ => f64::NAN,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(128))]

        /// For any picture and parameters the page allows: every ball stays between
        /// the dark and bright heights, finite, and revealing moves it no faster than
        /// the smooth step allows; the same picture gives the same positions.
        #[test]
        fn pictures_stay_between_their_heights_and_reveal_smoothly(
            mut params in params(PARAMS),
            picture in png(),
            grid in grid(),
            t_s in 0.0..120.0f64,
        ) {
            params.insert("image".into(), Value::Text(encode_base64(&picture)));
            let (field, notes) = PATTERN.field(&params, 0, &grid).unwrap();
            prop_assert!(notes.is_empty());
            let (again, _) = PATTERN.field(&params, 0, &grid).unwrap();
            let (low_mm, high_mm) = (number(&params, "low_mm"), number(&params, "high_mm"));
            let reveal_s = number(&params, "reveal_s");
            let max_speed = if reveal_s > 0.0 { (high_mm - low_mm).abs() * 15.0 / 8.0 / reveal_s } else { 0.0 };
            let n = grid.unit_count();
            let (mut a, mut b, mut c) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let h = 1e-4;
            field.sample(&grid, t_s - h, &mut a);
            field.sample(&grid, t_s, &mut b);
            field.sample(&grid, t_s + h, &mut c);
            let mut d = vec![0.0; n];
            again.sample(&grid, t_s, &mut d);
            prop_assert_eq!(&b, &d);
            for unit in 0..n {
                prop_assert!(b[unit].is_finite());
                prop_assert!(b[unit] >= low_mm.min(high_mm) - 1e-9 && b[unit] <= low_mm.max(high_mm) + 1e-9);
                let speed = (c[unit] - a[unit]) / (2.0 * h);
                prop_assert!(speed.abs() <= max_speed * 1.001 + 1e-6, "{} > {}", speed, max_speed);
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]

        /// Any picture and parameters the page allows render into a show that passes
        /// validation, the same show every time; and so does a timeline from a wave
        /// through a word to the picture, with transitions, continuous across them.
        #[test]
        fn any_picture_renders_within_the_limits_alone_and_after_a_word(
            mut params in params(PARAMS),
            words in params(super::super::text::PARAMS),
            picture in png(),
            grid in grid(),
            duration_s in 1.0..8.0f64,
            transition_s in 0.5..4.0f64,
        ) {
            params.insert("image".into(), Value::Text(encode_base64(&picture)));
            let limits = limits_for(&grid);
            let alone = Recipe::single("p", "image", params.clone(), duration_s);
            let once = render(&alone, &grid, &limits).unwrap();
            prop_assert_eq!(validate(&once.show, &limits), vec![]);
            let segment = |pattern: &str, params: Params| Segment {
                pattern: pattern.to_owned(),
                params,
                duration_s,
                transition_s,
            };
            let timeline = Recipe {
                name: "wave, word, picture".into(),
                row_ms: 100,
                grid: None,
                segments: vec![
                    segment("wave", Params::new()),
                    segment("text", words),
                    segment("image", params),
                ],
            };
            let once = render(&timeline, &grid, &limits).unwrap();
            prop_assert_eq!(validate(&once.show, &limits), vec![]);
            // Continuous: between rows, no step beyond what the limits allow.
            for track in &once.show.tracks {
                let (mut p0, mut v0) = (track.start_mm, 0.0f64);
                for row in &track.rows {
                    let dt_s = f64::from(row.duration_ms) / 1000.0;
                    prop_assert!((row.position_mm - p0).abs() <= limits.max_speed_mm_s * dt_s + 1e-6);
                    prop_assert!((row.velocity_mm_s - v0).abs() <= limits.max_accel_mm_s2 * dt_s + 1e-6);
                    (p0, v0) = (row.position_mm, row.velocity_mm_s);
                }
                prop_assert_eq!(v0, 0.0);
            }
            let json = timeline.to_json().unwrap();
            let again = render(&Recipe::from_json(&json).unwrap(), &grid, &limits).unwrap();
            prop_assert_eq!(once.show.to_json().unwrap(), again.show.to_json().unwrap());
        }
    }
}
