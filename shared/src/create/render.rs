//! Rendering a recipe into a show for a grid, within the installation's limits by
//! construction: `render(recipe, grid, limits)` gives a [`Show`] that passes
//! [`validate`](crate::show::validate) for `limits`, and the [`Note`]s of every value
//! changed on the way, each naming the parameter to change.
//!
//! 1. Every segment's pattern is built ([`PatternSpec::field`]); parameters out of
//!    their range are clamped (a note each).
//! 2. Each pattern is probed over its time (every eighth row, with its velocity and
//!    acceleration by central differences over 1 ms) and, if it leaves the travel (less
//!    a margin of 2 %) or moves faster than the limits allow, its motion is scaled
//!    about its middle and moved into the travel (a note naming its amplitude or its
//!    height). A pattern faster than the rows can follow is caught here.
//! 3. A transition too short for its two patterns is lengthened (a note naming
//!    `transition_s`), so that blending them takes at most half of each limit.
//! 4. The timeline ([`super::recipe`]) is sampled at every row time: positions; each
//!    row's velocity is the central difference of its neighbours (Catmull–Rom), so the
//!    rows are C1 Hermite curves through the samples. The show starts and ends at
//!    rest by playing the timeline slower over its first and last [`EASE_S`] (its
//!    speed rising smoothly from 0 to 1 and back), never faster than the patterns.
//! 5. Every row's exact peak speed and acceleration (the units' own cubic) are
//!    measured; a pattern too fast or too hard on its own is scaled down about its
//!    middle (a note naming its amplitude) and step 4 runs once more.
//! 6. What remains above a limit (a transition at its longest) scales
//!    the whole show's motion about the middle of the travel (a note saying which
//!    transition or pattern to change). Scaling every position about one point scales
//!    every row's speed and acceleration exactly, so the result is within the limits,
//!    including the rounding of positions and velocities to 0.1 mm (mm/s; 0.001 for
//!    rows shorter than 100 ms), whose worst effect is subtracted from the limits.
//!
//! The same recipe, grid and limits always give the same show, bit for bit.
//!
//! ```
//! use floatball_shared::create::{Grid, Params, Recipe, render};
//! use floatball_shared::plan::{Installation, report::report};
//! use floatball_shared::uim2503::plan::PlanOptions;
//! use floatball_shared::show::{Limits, validate};
//!
//! let recipe = Recipe::single("lobby", "wave", Params::new(), 10.0);
//! let grid = Grid::new(4, 4, 500.0, 7500.0);
//! let limits = Limits::for_layout(4, 4);
//! let generated = render(&recipe, &grid, &limits).unwrap();
//! assert!(generated.notes.is_empty());
//! assert_eq!(validate(&generated.show, &limits), []);
//! // The planner's verdict on it, as the page shows it before saving.
//! let installation = Installation::demo(4, 4, &[115_200]).unwrap();
//! assert!(report(&generated.show, &installation, PlanOptions::default()).feasible);
//! ```

use super::catalogue::{self, PatternSpec};
use super::params::{ParamKind, Value};
use super::recipe::{EASE_S, MAX_TRANSITION_S, Recipe, Span};
use super::{CreateError, Field, Grid, Note, number, smooth_step};
use crate::motion::Segment as Cubic;
use crate::show::{Layout, Limits, Show, Track, TrackRow};

/// A rendered recipe: the show and what was changed to keep it within the limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Generated {
    /// The show (its layout the grid's, its name the recipe's).
    pub show: Show,
    /// Every value changed, in the order found.
    pub notes: Vec<Note>,
}

/// Fraction of the travel kept free at the top and the bottom when a pattern is fitted
/// into it.
const MARGIN: f64 = 0.02;

/// Most rows a show made here may have, all balls together: 50 million, 1.2 GB in
/// memory (a 32 MiB upload, the default limit, holds about 1.5 million).
pub const MAX_ROWS: u64 = 50_000_000;

/// Step 2 probes the patterns every this many rows.
const PROBE_ROWS: f64 = 8.0;

/// A pattern scaled down for a limit aims this far below it (the samples of step 4
/// are exact, but the transitions around it change a little).
const SAFETY: f64 = 0.97;

/// One segment's pattern with the map that fits it into the limits:
/// `x ↦ target_mm + scale · (x − mid_mm)`.
struct Part {
    spec: &'static PatternSpec,
    field: Box<dyn Field>,
    span: Span,
    mid_mm: f64,
    target_mm: f64,
    scale: f64,
}

impl Part {
    fn sample(&self, grid: &Grid, t_s: f64, out_mm: &mut [f64]) {
        self.field.sample(grid, t_s - self.span.begin_s, out_mm);
        if self.scale != 1.0 || self.mid_mm != self.target_mm {
            for x in out_mm.iter_mut() {
                *x = self.target_mm + self.scale * (*x - self.mid_mm);
            }
        }
    }

    /// The value of the parameter `key` the recipe gives, or its default.
    fn value(&self, params: &super::Params, key: &str) -> Option<(f64, &'static str)> {
        let spec = self.spec.param(key)?;
        let ParamKind::Number {
            default,
            unit,
            min,
            max,
            ..
        } = spec.kind
        else {
            return None;
        };
        let value = match params.get(key) {
            Some(Value::Number(value)) => value.max(min).min(max),
            _ => default,
        };
        Some((value, unit))
    }
}

/// The timeline as the rows sample it: show time `t` plays the timeline at time
/// `τ(t)`, which starts and ends at rest: τ′ rises from 0 to 1 over the first
/// `ease_s` (τ′ = the smooth step of t / ease_s) and falls back to 0 over the last,
/// so every ball starts and ends at rest, no faster than its pattern, and the show is
/// `ease_s` longer than the timeline.
struct Timeline<'a> {
    parts: &'a [Part],
    grid: &'a Grid,
    show_s: f64,
    ease_s: f64,
    scratch: Vec<f64>,
}

/// ∫₀ˣ smooth_step = x⁶ − 3x⁵ + 2.5x⁴ (½ at 1).
fn eased(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    x * x * x * x * (x * x - 3.0 * x + 2.5)
}

impl<'a> Timeline<'a> {
    fn new(parts: &'a [Part], grid: &'a Grid, show_s: f64, ease_s: f64) -> Self {
        Self {
            parts,
            grid,
            show_s,
            ease_s,
            scratch: vec![0.0; grid.unit_count()],
        }
    }

    /// The timeline's time at show time `t_s`.
    fn warp(&self, t_s: f64) -> f64 {
        let ease_s = self.ease_s;
        if ease_s <= 0.0 {
            t_s
        } else if t_s < ease_s {
            ease_s * eased(t_s / ease_s)
        } else if t_s > self.show_s - ease_s {
            (self.show_s - ease_s) - ease_s * eased((self.show_s - t_s) / ease_s)
        } else {
            t_s - ease_s / 2.0
        }
    }

    /// The segment running at `t_s` (the earlier one during a transition).
    fn index(&self, t_s: f64) -> usize {
        self.parts
            .iter()
            .position(|part| t_s < part.span.out_s)
            .unwrap_or(self.parts.len().saturating_sub(1))
    }

    /// Zone of show time `t_s`: 2i while segment i runs alone, 2i + 1 during the
    /// transition from segment i to i + 1.
    fn zone(&self, t_s: f64) -> usize {
        let t_s = self.warp(t_s);
        let index = self.index(t_s);
        let span = self.parts[index].span;
        if t_s >= span.end_s && index + 1 < self.parts.len() {
            2 * index + 1
        } else {
            2 * index
        }
    }

    /// The timeline without easing.
    fn raw(&mut self, t_s: f64, out_mm: &mut [f64]) {
        let index = self.index(t_s);
        let part = &self.parts[index];
        part.sample(self.grid, t_s, out_mm);
        if t_s > part.span.end_s
            && let Some(next) = self.parts.get(index + 1)
        {
            let weight = smooth_step((t_s - part.span.end_s) / (part.span.out_s - part.span.end_s));
            next.sample(self.grid, t_s, &mut self.scratch);
            for (out, next) in out_mm.iter_mut().zip(&self.scratch) {
                *out += weight * (next - *out);
            }
        }
    }

    /// Every ball's position at show time `t_s`.
    fn position(&mut self, t_s: f64, out_mm: &mut [f64]) {
        self.raw(self.warp(t_s), out_mm);
    }
}

/// Peaks measured on the rows.
#[derive(Debug, Clone, Copy, Default)]
struct Peaks {
    speed_mm_s: f64,
    accel_mm_s2: f64,
}

/// The rows' exact peaks per zone, and the lowest and highest point reached.
struct Measure {
    zones: Vec<Peaks>,
    min_mm: f64,
    max_mm: f64,
}

/// Every ball's position at every row time, time-major: the position of ball `u` at
/// the end of row `r` (row 0: the start) is `positions_mm[r * units + u]`. Sampling,
/// measuring and writing the tracks then each run straight through memory.
struct Samples {
    units: usize,
    rows: usize,
    positions_mm: Vec<f64>,
}

impl Samples {
    fn new(units: usize, rows: usize) -> Self {
        Self {
            units,
            rows,
            positions_mm: vec![0.0; (rows + 1) * units],
        }
    }

    /// Every ball's position at the end of row `row` (0: the start).
    fn at(&self, row: usize) -> &[f64] {
        &self.positions_mm[row * self.units..(row + 1) * self.units]
    }

    /// Every ball's velocity at the end of row `row` (1..=rows) into `out_mm_s`: the
    /// central difference of its neighbours' positions (Catmull–Rom); the last row
    /// ends at rest.
    fn velocities(&self, row: usize, half_per_s: f64, out_mm_s: &mut [f64]) {
        if row >= self.rows {
            out_mm_s.fill(0.0);
            return;
        }
        for ((out, before), after) in out_mm_s
            .iter_mut()
            .zip(self.at(row - 1))
            .zip(self.at(row + 1))
        {
            *out = (after - before) * half_per_s;
        }
    }

    /// Samples the timeline's positions at every row time.
    fn sample(&mut self, timeline: &mut Timeline<'_>, dt_s: f64) {
        for (row, positions) in self.positions_mm.chunks_exact_mut(self.units).enumerate() {
            timeline.position(row as f64 * dt_s, positions);
        }
    }

    /// Measures the exact peak speed and acceleration of every row (the units' Hermite
    /// cubic through the positions with [`Samples::velocities`], in closed form: its
    /// acceleration is linear, so its speed peaks at an end or where the acceleration
    /// crosses 0) per zone (`zones[r - 1]` for row `r`), and the lowest and highest
    /// point reached where it may come within `edge_mm` of 0 or `travel_mm`
    /// (elsewhere the rows' ends: only points beyond the edges matter).
    fn measure(
        &self,
        zones: &[usize],
        zone_count: usize,
        dt_s: f64,
        (edge_mm, travel_mm): (f64, f64),
    ) -> Measure {
        let mut measured = Measure {
            zones: vec![Peaks::default(); zone_count],
            min_mm: f64::INFINITY,
            max_mm: f64::NEG_INFINITY,
        };
        let per_s = 1.0 / dt_s;
        let half_per_s = 0.5 / dt_s;
        // Between its ends a cubic strays at most 4/27 · T · (|v0| + |v1|) beyond them.
        let stray_per_mm_s = 4.0 / 27.0 * dt_s;
        let top_mm = travel_mm - edge_mm;
        let mut v0_mm_s = vec![0.0; self.units];
        let mut v1_mm_s = vec![0.0; self.units];
        for (row, zone) in (1..=self.rows).zip(zones) {
            self.velocities(row, half_per_s, &mut v1_mm_s);
            let (mut speed_mm_s, mut accel_mm_s2) = (0.0f64, 0.0f64);
            let (mut min_mm, mut max_mm) = (f64::INFINITY, f64::NEG_INFINITY);
            for (((&p0, &p1), &v0), &v1) in self
                .at(row - 1)
                .iter()
                .zip(self.at(row))
                .zip(&v0_mm_s)
                .zip(&v1_mm_s)
            {
                // Plain comparisons, not `f64::max`: no NaN handling in the hottest loop
                // (positions are finite).
                let slope = 6.0 * (p1 - p0) * per_s;
                let a0 = (slope - 4.0 * v0 - 2.0 * v1) * per_s;
                let a1 = (-slope + 2.0 * v0 + 4.0 * v1) * per_s;
                let (v0_abs, v1_abs) = (v0.abs(), v1.abs());
                let mut speed = if v0_abs > v1_abs { v0_abs } else { v1_abs };
                if (a0 > 0.0) != (a1 > 0.0) && a0 != a1 {
                    let s = a0 / (a0 - a1);
                    let peak = (v0 + dt_s * (a0 * s + (a1 - a0) * s * s / 2.0)).abs();
                    if peak > speed {
                        speed = peak;
                    }
                }
                if speed > speed_mm_s {
                    speed_mm_s = speed;
                }
                let (a0_abs, a1_abs) = (a0.abs(), a1.abs());
                let accel = if a0_abs > a1_abs { a0_abs } else { a1_abs };
                if accel > accel_mm_s2 {
                    accel_mm_s2 = accel;
                }
                let stray_mm = stray_per_mm_s * (v0_abs + v1_abs);
                let (mut low, mut high) = if p0 < p1 { (p0, p1) } else { (p1, p0) };
                if low - stray_mm < edge_mm || high + stray_mm > top_mm {
                    let range = Cubic::new(p0, v0, p1, v1, dt_s).position_range();
                    (low, high) = (range.min.value, range.max.value);
                }
                if low < min_mm {
                    min_mm = low;
                }
                if high > max_mm {
                    max_mm = high;
                }
            }
            if let Some(peaks) = measured.zones.get_mut(*zone) {
                peaks.speed_mm_s = peaks.speed_mm_s.max(speed_mm_s);
                peaks.accel_mm_s2 = peaks.accel_mm_s2.max(accel_mm_s2);
            }
            measured.min_mm = measured.min_mm.min(min_mm);
            measured.max_mm = measured.max_mm.max(max_mm);
            std::mem::swap(&mut v0_mm_s, &mut v1_mm_s);
        }
        measured
    }

    /// The tracks: every position scaled by `scale` about `centre_mm`, every velocity
    /// ([`Samples::velocities`]) by `scale`, each rounded by `round`; the last row
    /// ends at rest.
    fn tracks(&self, row_ms: u32, (centre_mm, scale): (f64, f64), grain: Grain) -> Vec<Track> {
        let half_per_s = 0.5 / (f64::from(row_ms) / 1000.0);
        let place =
            move |position_mm: f64| grain.round(centre_mm + scale * (position_mm - centre_mm));
        // Ball by ball, each reading its column of the samples: the cache lines of a
        // ball's column hold its neighbours' too, read by the next balls. Everything
        // the loop needs is copied into it, so nothing is read back through a pointer.
        let (units, rows) = (self.units, self.rows);
        let positions_mm = &self.positions_mm[..(rows + 1) * units];
        (0..units)
            .map(|unit| {
                let column = &positions_mm[unit..];
                let at = move |row: usize| column[row * units];
                let mut track_rows = Vec::with_capacity(rows);
                track_rows.extend((1..rows).map(move |row| {
                    let velocity_mm_s = (at(row + 1) - at(row - 1)) * half_per_s;
                    TrackRow::new(place(at(row)), grain.round(scale * velocity_mm_s), row_ms)
                }));
                track_rows.push(TrackRow::new(place(at(rows)), 0.0, row_ms));
                Track {
                    start_mm: place(at(0)),
                    rows: track_rows,
                    colours: Vec::new(),
                }
            })
            .collect()
    }
}

/// The resolution positions (mm) and velocities (mm/s) are rounded to.
#[derive(Debug, Clone, Copy)]
struct Grain {
    resolution: f64,
    /// `1 / resolution`, exactly.
    steps: f64,
}

impl Grain {
    /// What a row of `row_ms` holds: 0.1 mm, or 0.001 mm in rows shorter than 100 ms.
    fn of_row(row_ms: u32) -> Self {
        if row_ms >= 100 {
            Self {
                resolution: 0.1,
                steps: 10.0,
            }
        } else {
            Self {
                resolution: 0.001,
                steps: 1000.0,
            }
        }
    }

    /// `value` rounded to the nearest multiple of the resolution (multiplying by the
    /// steps, not dividing by the resolution: quicker).
    fn round(self, value: f64) -> f64 {
        round_even(value * self.steps) * self.resolution
    }
}

/// `value` rounded to the nearest whole number (ties to even), by the float unit's own
/// rounding: quicker than `f64::round` (a library call on many targets), the same on
/// every target. Exact for |value| < 2⁵¹; larger values are returned as they are.
fn round_even(value: f64) -> f64 {
    const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2⁵²
    if value.abs() < 2_251_799_813_685_248.0 {
        (value + MAGIC) - MAGIC
    } else {
        value
    }
}

/// The parameter a note about a pattern's swing names: its amplitude (or depth, or
/// slope), else the first length in mm that is not a height; `None` if it has none.
fn motion_key(spec: &PatternSpec) -> Option<&'static str> {
    ["amplitude_mm", "depth_mm", "slope_mm_m"]
        .into_iter()
        .find(|key| spec.param(key).is_some())
        .or_else(|| {
            spec.params
                .iter()
                .map(|param| param.key)
                .find(|key| key.ends_with("_mm") && !matches!(*key, "centre_mm" | "base_mm"))
        })
}

/// The parameter a note about a pattern's height names.
fn height_key(spec: &PatternSpec) -> Option<&'static str> {
    ["centre_mm", "base_mm"]
        .into_iter()
        .find(|key| spec.param(key).is_some())
}

/// A note that segment `index`'s motion was scaled by `scale` (or moved by
/// `shift_mm` when `shift`), naming its parameter.
fn part_note(
    recipe: &Recipe,
    parts: &[Part],
    index: usize,
    scale: f64,
    shift_mm: Option<f64>,
    reason: String,
) -> Note {
    let part = &parts[index];
    let params = &recipe.segments[index].params;
    let key = match shift_mm {
        Some(_) => height_key(part.spec),
        None => motion_key(part.spec),
    };
    let (key, from, to, unit) = match key.and_then(|key| Some((key, part.value(params, key)?))) {
        Some((key, (value, unit))) => {
            let to = match shift_mm {
                Some(shift_mm) => value + shift_mm,
                None => value * scale,
            };
            (key.to_owned(), value, to, unit.to_owned())
        }
        None => match shift_mm {
            Some(shift_mm) => ("height".to_owned(), 0.0, shift_mm, "mm".to_owned()),
            None => ("motion".to_owned(), 100.0, 100.0 * scale, "%".to_owned()),
        },
    };
    Note::number(index, part.spec.name, &key, (from, to), &unit, reason)
}

/// The rows of every ball of `recipe`'s show, and its easing time.
fn rows_of(recipe: &Recipe) -> (usize, f64) {
    let dt_s = f64::from(recipe.row_ms) / 1000.0;
    let timeline_s = recipe.duration_s();
    let ease_s = EASE_S.min(timeline_s);
    let rows = (((timeline_s + ease_s) / dt_s - 1e-9).ceil() as usize).max(1);
    (rows, ease_s)
}

/// Refuses a show of more than [`MAX_ROWS`] rows in all.
fn rows_within(recipe: &Recipe, balls: usize) -> Result<(), CreateError> {
    let (rows, _) = rows_of(recipe);
    if rows as u64 * balls as u64 > MAX_ROWS {
        return Err(CreateError::TooManyRows {
            rows,
            balls,
            max: MAX_ROWS,
        });
    }
    Ok(())
}

/// Renders `recipe` for `grid` within `limits`.
///
/// # Errors
/// The recipe's ([`Recipe::check`]) or grid's ([`Grid::check`]) problems, an unknown
/// pattern or parameter, a parameter of the wrong type, a picture that cannot be used.
pub fn render(recipe: &Recipe, grid: &Grid, limits: &Limits) -> Result<Generated, CreateError> {
    // Its numbers as its file holds them: the saved recipe renders this very show.
    let mut recipe = recipe.filed();
    recipe.check()?;
    grid.check()?;
    // At least as many rows as the recipe asks for (step 3 may add some): refused
    // before anything is built.
    rows_within(&recipe, grid.unit_count())?;
    let spans = recipe.spans();
    let mut notes = Vec::new();
    let mut parts = Vec::with_capacity(recipe.segments.len());
    for (index, (segment, span)) in recipe.segments.iter().zip(&spans).enumerate() {
        let spec = catalogue::find(&segment.pattern)?;
        let (field, clamped) = spec.field(&segment.params, index, grid)?;
        notes.extend(clamped);
        parts.push(Part {
            spec,
            field,
            span: *span,
            mid_mm: 0.0,
            target_mm: 0.0,
            scale: 1.0,
        });
    }
    let row_ms = recipe.row_ms;
    let dt_s = f64::from(row_ms) / 1000.0;
    // The timeline's time at the show's end as the recipe gives it (≥ its length: the
    // rows round up).
    let timeline_end_s = recipe.duration_s() + dt_s;
    let travel_mm = limits.travel_mm.min(grid.travel_mm);
    let units = grid.unit_count();

    // What the rows may reach, less the worst effect of rounding positions and
    // velocities to `resolution`.
    let grain = Grain::of_row(row_ms);
    let half = grain.resolution / 2.0;
    // How close to 0 and the travel the rows may come, so rounding keeps them inside.
    let edge_mm = half + 1e-3;
    let speed_allowed = limits.max_speed_mm_s * 0.999 - (3.0 * half / dt_s + 2.0 * half);
    let accel_allowed =
        limits.max_accel_mm_s2 * 0.999 - (12.0 * half / (dt_s * dt_s) + 8.0 * half / dt_s);
    let limit_words = format!(
        "so balls stay within {} mm/s and {} mm/s²",
        number(limits.max_speed_mm_s),
        number(limits.max_accel_mm_s2)
    );

    // 2. Fit every pattern into the travel and, as far as it shows between rows,
    // its speed and acceleration into the limits (velocities and accelerations by
    // central differences over 1 ms: a pattern faster than the rows can follow is
    // caught here, not aliased away).
    let margin_mm = travel_mm * MARGIN;
    let (low_mm, high_mm) = (margin_mm, travel_mm - margin_mm);
    let travel_words = format!(
        "so the balls stay within the travel of {} mm",
        number(travel_mm)
    );
    let h_s = 1e-3;
    let mut before = vec![0.0; units];
    let mut now = vec![0.0; units];
    let mut after = vec![0.0; units];
    for index in 0..parts.len() {
        let part = &parts[index];
        let (from_s, to_s) = (
            part.span.begin_s,
            if index + 1 == parts.len() {
                timeline_end_s
            } else {
                part.span.out_s
            },
        );
        let samples = (((to_s - from_s) / (PROBE_ROWS * dt_s)).ceil() as usize).max(1);
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let mut peaks = Peaks::default();
        for sample in 0..=samples {
            let t_s = from_s + (to_s - from_s) * sample as f64 / samples as f64;
            part.sample(grid, t_s - h_s, &mut before);
            part.sample(grid, t_s, &mut now);
            part.sample(grid, t_s + h_s, &mut after);
            for ((&b, &mm), &a) in before.iter().zip(&now).zip(&after) {
                lo = lo.min(mm);
                hi = hi.max(mm);
                peaks.speed_mm_s = peaks.speed_mm_s.max((a - b).abs() / (2.0 * h_s));
                peaks.accel_mm_s2 = peaks
                    .accel_mm_s2
                    .max((a - 2.0 * mm + b).abs() / (h_s * h_s));
            }
        }
        let mid_mm = (lo + hi) / 2.0;
        let fit = if hi - lo > high_mm - low_mm {
            (high_mm - low_mm) / (hi - lo)
        } else {
            1.0
        };
        let over =
            (fit * peaks.speed_mm_s / speed_allowed).max(fit * peaks.accel_mm_s2 / accel_allowed);
        let scale = if over > SAFETY {
            fit * SAFETY / over
        } else {
            fit
        };
        let half_mm = scale * (hi - lo) / 2.0;
        let target_mm = mid_mm.max(low_mm + half_mm).min(high_mm - half_mm);
        if fit < 1.0 {
            notes.push(part_note(
                &recipe,
                &parts,
                index,
                fit,
                None,
                travel_words.clone(),
            ));
        }
        if scale < fit {
            notes.push(part_note(
                &recipe,
                &parts,
                index,
                scale,
                None,
                limit_words.clone(),
            ));
        }
        if (target_mm - mid_mm).abs() > 0.05 {
            notes.push(part_note(
                &recipe,
                &parts,
                index,
                1.0,
                Some(target_mm - mid_mm),
                travel_words.clone(),
            ));
        }
        let part = &mut parts[index];
        (part.mid_mm, part.target_mm, part.scale) = (mid_mm, target_mm, scale);
    }

    // 2b. Lengthen the transitions too short for their patterns. Blending from a to b
    // with the smooth step w over T seconds adds w′(b − a) to the speed and
    // 2w′(b′ − a′) + w″(b − a) to the acceleration, at most 1.875 D / T and
    // 3.75 V / T + 5.77 D / T² for a difference D and a difference of velocities V:
    // T is chosen so these take at most half of each limit (the patterns' own motion
    // takes the rest; what is left over is step 6's).
    let mut a_velocity = vec![0.0; units];
    for index in 0..parts.len().saturating_sub(1) {
        let (a, b) = (&parts[index], &parts[index + 1]);
        let span = a.span;
        let (mut difference_mm, mut relative_mm_s) = (0.0f64, 0.0f64);
        for t_s in [span.end_s, (span.end_s + span.out_s) / 2.0, span.out_s] {
            a.sample(grid, t_s - h_s, &mut before);
            a.sample(grid, t_s + h_s, &mut after);
            for ((v, b), a) in a_velocity.iter_mut().zip(&before).zip(&after) {
                *v = (a - b) / (2.0 * h_s);
            }
            a.sample(grid, t_s, &mut now);
            b.sample(grid, t_s, &mut before);
            for (a, b) in now.iter().zip(&before) {
                difference_mm = difference_mm.max((a - b).abs());
            }
            b.sample(grid, t_s - h_s, &mut now);
            b.sample(grid, t_s + h_s, &mut after);
            for ((va, b0), b1) in a_velocity.iter().zip(&now).zip(&after) {
                relative_mm_s = relative_mm_s.max(((b1 - b0) / (2.0 * h_s) - va).abs());
            }
        }
        let (speed_share, accel_share) = (0.5 * speed_allowed, 0.5 * accel_allowed);
        let cross = 3.75 * relative_mm_s;
        let needed_s = (1.875 * difference_mm / speed_share).max(
            (cross + (cross * cross + 4.0 * accel_share * 5.77 * difference_mm).sqrt())
                / (2.0 * accel_share),
        );
        let asked_s = recipe.segments[index].transition_s;
        if needed_s > asked_s {
            let longer_s = ((needed_s * 10.0).ceil() / 10.0).min(MAX_TRANSITION_S);
            recipe.segments[index].transition_s = longer_s;
            notes.push(Note::number(
                index,
                a.spec.name,
                "transition_s",
                (asked_s, longer_s),
                "s",
                format!(
                    "so balls moving up to {} mm from one pattern to the next stay within {} mm/s and {} mm/s²",
                    number(difference_mm),
                    number(limits.max_speed_mm_s),
                    number(limits.max_accel_mm_s2)
                ),
            ));
        }
    }
    let recipe = &recipe;
    for (part, span) in parts.iter_mut().zip(recipe.spans()) {
        part.span = span;
    }
    let (rows, ease_s) = rows_of(recipe);
    let show_s = rows as f64 * dt_s;
    rows_within(recipe, units)?;

    // 3 and 4: sample, measure, scale down the patterns too fast on their own, once.
    let zone_count = 2 * parts.len() - 1;
    let mut samples = Samples::new(units, rows);
    let mut measured;
    let mut zones = Vec::with_capacity(rows);
    {
        // A row's cubic depends on the positions at its ends and, through their
        // velocities, one row on either side: it belongs to a transition if any of
        // them does, else to the segment at its middle.
        let timeline = Timeline::new(&parts, grid, show_s, ease_s);
        let at: Vec<usize> = (0..=rows)
            .map(|row| timeline.zone(row as f64 * dt_s))
            .collect();
        zones.extend((1..=rows).map(|row| {
            at[row.saturating_sub(2)..=(row + 1).min(rows)]
                .iter()
                .copied()
                .find(|zone| zone % 2 == 1)
                .unwrap_or_else(|| timeline.zone((row as f64 - 0.5) * dt_s))
        }));
    }
    let mut pass = 0;
    loop {
        let mut timeline = Timeline::new(&parts, grid, show_s, ease_s);
        samples.sample(&mut timeline, dt_s);
        measured = samples.measure(&zones, zone_count, dt_s, (edge_mm, travel_mm));
        pass += 1;
        if pass > 1 {
            break;
        }
        let mut rescaled = false;
        for index in 0..parts.len() {
            let peaks = measured.zones[2 * index];
            let over = (peaks.speed_mm_s / speed_allowed).max(peaks.accel_mm_s2 / accel_allowed);
            if over > 1.0 {
                let scale = parts[index].scale * SAFETY / over;
                let note = part_note(recipe, &parts, index, scale, None, limit_words.clone());
                // One note per parameter: step 2's, if any, with the value now used.
                match notes.iter_mut().find(|old| {
                    (old.segment, &old.key, &old.reason) == (note.segment, &note.key, &note.reason)
                }) {
                    Some(old) => old.change = note.change,
                    None => notes.push(note),
                }
                parts[index].scale = scale;
                rescaled = true;
            }
        }
        if !rescaled {
            break;
        }
    }

    // 5. Scale the whole show's motion about the middle of the travel.
    let centre_mm = travel_mm / 2.0;
    let mut scale: f64 = 1.0;
    let mut worst: Option<(usize, f64)> = None;
    for (zone, peaks) in measured.zones.iter().enumerate() {
        let need = (speed_allowed / peaks.speed_mm_s).min(accel_allowed / peaks.accel_mm_s2);
        if need < scale {
            scale = need;
            worst = Some((zone, need));
        }
    }
    if measured.max_mm > travel_mm - edge_mm {
        scale = scale.min((travel_mm - edge_mm - centre_mm) / (measured.max_mm - centre_mm));
    }
    if measured.min_mm < edge_mm {
        scale = scale.min((centre_mm - edge_mm) / (centre_mm - measured.min_mm));
    }
    let scale = scale.clamp(0.0, 1.0);
    if scale < 1.0 {
        let (segment, advice) = match worst {
            Some((zone, _)) if zone % 2 == 1 => (
                zone / 2,
                if recipe.segments[zone / 2].transition_s >= MAX_TRANSITION_S {
                    format!(
                        "; the blend from segment {} into {} is the hardest part, its \
                         transition_s at its longest: bring the two patterns' heights closer",
                        zone / 2 + 1,
                        zone / 2 + 2
                    )
                } else {
                    format!(
                        "; the blend from segment {} into {} is the hardest part: make its \
                         transition_s longer",
                        zone / 2 + 1,
                        zone / 2 + 2
                    )
                },
            ),
            Some((zone, _)) => (zone / 2, String::new()),
            None => (0, String::new()),
        };
        notes.push(Note::number(
            segment,
            parts[segment].spec.name,
            "motion",
            (100.0, 100.0 * scale),
            "%",
            format!(
                "(the whole show) {limit_words} and within the travel of {} mm{advice}",
                number(travel_mm)
            ),
        ));
    }
    let tracks = samples.tracks(row_ms, (centre_mm, scale), grain);
    Ok(Generated {
        show: Show {
            name: recipe.name.clone(),
            layout: Layout {
                rows: grid.rows,
                cols: grid.cols,
                pitch_mm: grid.pitch_mm,
            },
            tracks,
            outputs: Vec::new(),
        },
        notes,
    })
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn rounding_is_to_the_nearest_and_ties_to_even() {
        assert_eq!(round_even(2.4), 2.0);
        assert_eq!(round_even(2.6), 3.0);
        assert_eq!(round_even(2.5), 2.0);
        assert_eq!(round_even(3.5), 4.0);
        assert_eq!(round_even(-2.6), -3.0);
        assert_eq!(round_even(-0.4), 0.0);
        assert_eq!(round_even(1e300), 1e300);
        assert_eq!(round_even(12345.6789 * 10.0) / 10.0, 12345.7);
    }

    #[test]
    fn a_recipe_renders_the_same_show_as_its_saved_file() {
        // A slider's arithmetic leaves numbers of 17 digits (50.00000000000001, one
        // bit above the wavelength's maximum; 0.1 + 0.2); the saved file holds 15. The
        // recipe on the page and the file read back give the same show and the same
        // notes — none here: 50.00000000000001 is 50 on file.
        let params: super::super::Params = [
            ("amplitude_mm", 800.000_000_000_000_1),
            ("speed_m_s", 0.1 + 0.2),
            ("wavelength_m", 50.000_000_000_000_01),
        ]
        .into_iter()
        .map(|(key, value)| (key.to_owned(), super::super::Value::Number(value)))
        .collect();
        let mut recipe = Recipe::single("w", "wave", params, 5.0 + 1e-15);
        recipe.segments.push(recipe.segments[0].clone());
        recipe.segments[0].transition_s = 0.1 + 0.2 + 2.0;
        let grid = Grid::new(4, 5, 500.0, 7500.0);
        let limits = Limits::for_layout(4, 5);
        let page = render(&recipe, &grid, &limits).unwrap();
        let file = Recipe::from_json(&recipe.to_json().unwrap()).unwrap();
        assert_eq!(file, recipe.filed());
        assert_ne!(file, recipe);
        let saved = render(&file, &grid, &limits).unwrap();
        assert_eq!(page.notes, saved.notes);
        assert_eq!(page.notes, []);
        assert_eq!(page.show, saved.show);
        // Filing twice changes nothing more.
        assert_eq!(recipe.filed().filed(), recipe.filed());
    }

    #[test]
    fn the_timeline_starts_and_ends_slowly() {
        assert_eq!(eased(0.0), 0.0);
        assert_eq!(eased(1.0), 0.5);
        assert_eq!(eased(2.0), 0.5);
        // Its slope is the smooth step: 0 at 0, 1 at 1.
        let h = 1e-6;
        assert!((eased(h) - eased(0.0)) / h < 1e-12);
        assert!(((eased(1.0) - eased(1.0 - h)) / h - 1.0).abs() < 1e-5);
        assert!(((eased(0.5 + h) - eased(0.5 - h)) / (2.0 * h) - 0.5).abs() < 1e-6);
    }
}
