//! Positions and colours of every ball at any show time, for the preview (which calls
//! it every frame) and anything else that draws a show.
//!
//! [`Sampler::new`] lays the show out for speed once; [`Sampler::sample`] then fills
//! caller-provided buffers without allocating. Each ball keeps a cursor on its current
//! row, so moving forward by small steps costs O(1) per ball; any jump, backwards too,
//! costs a binary search for the balls concerned. The evaluation is
//! [`hermite_position`], the same function the PVT evaluator uses, so the preview moves
//! balls exactly as the simulated units do.
//!
//! Before time 0 every ball rests at its start position, after its last row at its last
//! position. Balls without colour keyframes are [`DEFAULT_COLOUR`].
//!
//! ```
//! use floatball_shared::show::{Layout, Sampler, Show, Track, TrackRow};
//!
//! let show = Show {
//!     name: "one".into(),
//!     layout: Layout { rows: 1, cols: 1, pitch_mm: 500.0 },
//!     tracks: vec![Track {
//!         start_mm: 0.0,
//!         rows: vec![TrackRow::new(100.0, 0.0, 200)],
//!         colours: Vec::new(),
//!     }],
//! };
//! let mut sampler = Sampler::new(&show);
//! let mut positions_mm = vec![0.0f32; sampler.unit_count()];
//! let mut colours = vec![[0u8; 3]; sampler.unit_count()];
//! sampler.sample(100.0, &mut positions_mm, Some(&mut colours));
//! assert_eq!(positions_mm[0], 50.0); // half way, by symmetry
//! sampler.sample(200.0, &mut positions_mm, None);
//! assert_eq!(positions_mm[0], 100.0);
//! ```

use super::Show;
use crate::pvt::hermite_position;

/// The colour of a ball whose track has no colour keyframes: white.
pub const DEFAULT_COLOUR: [u8; 3] = [255, 255, 255];

/// The largest magnitude of a sampling time, ms; times beyond are clamped, so that the
/// sentinel knots at ±`f64::MAX` always bound every interval with finite lengths.
const TIME_LIMIT_MS: f64 = 1e300;

/// Per ball, a sequence of knots in time and a cursor on the interval between two of
/// them that holds the last sampled time. The knots of all balls are in one vector,
/// each ball's run framed by sentinel knots at `f64::MIN` and `f64::MAX` ms, so every
/// finite time falls in exactly one interval.
#[derive(Debug, Clone, Default)]
struct Timeline {
    /// Knot times, ms, all balls one after the other.
    knots_ms: Vec<f64>,
    /// Per ball, the index of its first knot; one more entry marks the end.
    first: Vec<usize>,
    /// Per ball, the index of the knot starting its current interval.
    current: Vec<usize>,
    /// Per ball, the current interval's start and end, ms (copied for a fast check).
    current_lo_ms: Vec<f64>,
    current_hi_ms: Vec<f64>,
}

impl Timeline {
    /// Starts a ball's knots with the sentinel before time.
    fn begin_unit(&mut self) {
        self.first.push(self.knots_ms.len());
        self.knots_ms.push(f64::MIN);
    }

    /// Ends a ball's knots with the sentinel after time, with the cursor on the first
    /// interval.
    fn end_unit(&mut self) {
        let first = self.first.last().copied().unwrap_or_default();
        self.knots_ms.push(f64::MAX);
        self.current.push(first);
        self.current_lo_ms.push(self.knots_ms[first]);
        self.current_hi_ms.push(self.knots_ms[first + 1]);
    }

    /// Closes the list of balls.
    fn finish(&mut self) {
        self.first.push(self.knots_ms.len());
    }

    /// Moves every ball's cursor to the interval holding `t_ms` and calls
    /// `moved(ball, knot, [start_ms, end_ms])` for each ball whose interval changed.
    #[inline]
    fn seek(&mut self, t_ms: f64, units: usize, mut moved: impl FnMut(usize, usize, [f64; 2])) {
        for unit in 0..units {
            if self.current_lo_ms[unit] <= t_ms && t_ms < self.current_hi_ms[unit] {
                continue;
            }
            let knot = self.find(unit, t_ms);
            self.current[unit] = knot;
            self.current_lo_ms[unit] = self.knots_ms[knot];
            self.current_hi_ms[unit] = self.knots_ms[knot + 1];
            moved(unit, knot, [self.knots_ms[knot], self.knots_ms[knot + 1]]);
        }
    }

    /// The knot starting the interval of `unit` that holds `t_ms`: a few steps forward
    /// from the cursor for a playing preview, a binary search for any other jump.
    fn find(&self, unit: usize, t_ms: f64) -> usize {
        // `last` is the sentinel at f64::MAX, beyond any sampling time.
        let (first, last) = (self.first[unit], self.first[unit + 1] - 1);
        let mut knot = self.current[unit];
        if t_ms >= self.knots_ms[knot] {
            for _ in 0..4 {
                if t_ms < self.knots_ms[knot + 1] {
                    return knot;
                }
                knot += 1;
            }
        }
        // The sentinel at f64::MIN makes `after` at least 1.
        let after = self.knots_ms[first..last].partition_point(|&k| k <= t_ms);
        first + after.saturating_sub(1)
    }
}

/// A show laid out for fast sampling: build once per show, sample every frame.
#[derive(Debug, Clone)]
pub struct Sampler {
    units: usize,
    duration_ms: u64,
    motion: Timeline,
    /// Per knot: the position (mm) and velocity (mm/s) there.
    knot_position_mm: Vec<f64>,
    knot_velocity_mm_s: Vec<f64>,
    /// Per ball, the current interval as a Hermite segment: end positions and end
    /// velocities times the interval's duration (structure of arrays, so the evaluation
    /// loop runs straight through them).
    p0_mm: Vec<f64>,
    m0_mm: Vec<f64>,
    p1_mm: Vec<f64>,
    m1_mm: Vec<f64>,
    colour: Timeline,
    /// Per colour knot: the colour.
    knot_rgb: Vec<[f32; 3]>,
}

impl Sampler {
    /// Lays `show` out for sampling, with every ball's cursor at time 0. Rows of 0 ms
    /// (invalid, but a preview may still show the show) are instant jumps.
    #[must_use]
    pub fn new(show: &Show) -> Self {
        let units = show.tracks.len();
        let rows: usize = show.tracks.iter().map(|track| track.rows.len()).sum();
        let mut sampler = Self {
            units,
            duration_ms: show.duration_ms(),
            motion: Timeline {
                knots_ms: Vec::with_capacity(rows + 3 * units),
                ..Timeline::default()
            },
            knot_position_mm: Vec::with_capacity(rows + 3 * units),
            knot_velocity_mm_s: Vec::with_capacity(rows + 3 * units),
            p0_mm: Vec::with_capacity(units),
            m0_mm: Vec::with_capacity(units),
            p1_mm: Vec::with_capacity(units),
            m1_mm: Vec::with_capacity(units),
            colour: Timeline::default(),
            knot_rgb: Vec::new(),
        };
        for track in &show.tracks {
            let knot = |sampler: &mut Self, time_ms: f64, position_mm: f64, velocity_mm_s| {
                sampler.motion.knots_ms.push(time_ms);
                sampler.knot_position_mm.push(position_mm);
                sampler.knot_velocity_mm_s.push(velocity_mm_s);
            };
            sampler.motion.begin_unit();
            sampler.knot_position_mm.push(track.start_mm);
            sampler.knot_velocity_mm_s.push(0.0);
            knot(&mut sampler, 0.0, track.start_mm, 0.0);
            let mut time_ms = 0u64;
            for row in &track.rows {
                time_ms += u64::from(row.duration_ms);
                knot(
                    &mut sampler,
                    time_ms as f64,
                    row.position_mm,
                    row.velocity_mm_s,
                );
            }
            let last_mm = track
                .rows
                .last()
                .map_or(track.start_mm, |row| row.position_mm);
            sampler.motion.end_unit();
            sampler.knot_position_mm.push(last_mm);
            sampler.knot_velocity_mm_s.push(0.0);

            sampler.colour.begin_unit();
            let first = track.colours.first().map_or(DEFAULT_COLOUR, |key| key.rgb);
            sampler.knot_rgb.push(rgb_f32(first));
            for key in &track.colours {
                sampler.colour.knots_ms.push(key.time_ms as f64);
                sampler.knot_rgb.push(rgb_f32(key.rgb));
            }
            let last = track.colours.last().map_or(DEFAULT_COLOUR, |key| key.rgb);
            sampler.colour.end_unit();
            sampler.knot_rgb.push(rgb_f32(last));
        }
        sampler.motion.finish();
        sampler.colour.finish();
        for unit in 0..units {
            let knot = sampler.motion.current[unit];
            let span_ms = [
                sampler.motion.knots_ms[knot],
                sampler.motion.knots_ms[knot + 1],
            ];
            let [p0, m0, p1, m1] = interval_segment(
                span_ms,
                &sampler.knot_position_mm,
                &sampler.knot_velocity_mm_s,
                knot,
            );
            sampler.p0_mm.push(p0);
            sampler.m0_mm.push(m0);
            sampler.p1_mm.push(p1);
            sampler.m1_mm.push(m1);
        }
        sampler
    }

    /// Number of balls (the length `sample` fills).
    #[must_use]
    pub fn unit_count(&self) -> usize {
        self.units
    }

    /// The show's duration, ms.
    #[must_use]
    pub fn duration_ms(&self) -> u64 {
        self.duration_ms
    }

    /// Fills `positions_mm` (mm below the top, row-major) and, if given, `colours` with
    /// every ball's state at `t_ms` of show time. Buffers shorter than
    /// [`unit_count`](Self::unit_count) get the first balls only. Never allocates.
    pub fn sample(&mut self, t_ms: f64, positions_mm: &mut [f32], colours: Option<&mut [[u8; 3]]>) {
        let t_ms = if t_ms.is_nan() {
            0.0
        } else {
            t_ms.clamp(-TIME_LIMIT_MS, TIME_LIMIT_MS)
        };
        let units = self.units.min(positions_mm.len());
        let Self {
            motion,
            knot_position_mm,
            knot_velocity_mm_s,
            p0_mm,
            m0_mm,
            p1_mm,
            m1_mm,
            ..
        } = self;
        motion.seek(t_ms, units, |unit, knot, span_ms| {
            let [p0, m0, p1, m1] =
                interval_segment(span_ms, knot_position_mm, knot_velocity_mm_s, knot);
            p0_mm[unit] = p0;
            m0_mm[unit] = m0;
            p1_mm[unit] = p1;
            m1_mm[unit] = m1;
        });
        let lo = &self.motion.current_lo_ms[..units];
        let hi = &self.motion.current_hi_ms[..units];
        let p0 = &self.p0_mm[..units];
        let m0 = &self.m0_mm[..units];
        let p1 = &self.p1_mm[..units];
        let m1 = &self.m1_mm[..units];
        for (i, out) in positions_mm[..units].iter_mut().enumerate() {
            let s = ((t_ms - lo[i]) / (hi[i] - lo[i])).clamp(0.0, 1.0);
            *out = hermite_position(p0[i], m0[i], p1[i], m1[i], s) as f32;
        }
        if let Some(colours) = colours {
            self.sample_colours(t_ms, colours);
        }
    }

    fn sample_colours(&mut self, t_ms: f64, colours: &mut [[u8; 3]]) {
        let units = self.units.min(colours.len());
        self.colour.seek(t_ms, units, |_, _, _| {});
        for (unit, out) in colours[..units].iter_mut().enumerate() {
            let knot = self.colour.current[unit];
            let (lo, hi) = (self.colour.knots_ms[knot], self.colour.knots_ms[knot + 1]);
            let s = ((t_ms - lo) / (hi - lo)).clamp(0.0, 1.0) as f32;
            let (c0, c1) = (self.knot_rgb[knot], self.knot_rgb[knot + 1]);
            for channel in 0..3 {
                let value = c0[channel] + (c1[channel] - c0[channel]) * s;
                // In 0..=255 by construction; `as` saturates anyway.
                out[channel] = value.round() as u8;
            }
        }
    }
}

/// `[p0, m0, p1, m1]` of the interval starting at `knot` for [`hermite_position`]: end
/// positions and end velocities times the interval's duration. The intervals before
/// time and after the last row hold still.
fn interval_segment(
    [lo, hi]: [f64; 2],
    position_mm: &[f64],
    velocity_mm_s: &[f64],
    knot: usize,
) -> [f64; 4] {
    if lo == f64::MIN || hi == f64::MAX {
        let p = if lo == f64::MIN {
            position_mm[knot + 1]
        } else {
            position_mm[knot]
        };
        return [p, 0.0, p, 0.0];
    }
    // Whole ms apart, so this is the row's duration exactly, as `Segment` has it.
    let duration_s = (hi - lo) / 1000.0;
    [
        position_mm[knot],
        velocity_mm_s[knot] * duration_s,
        position_mm[knot + 1],
        velocity_mm_s[knot + 1] * duration_s,
    ]
}

fn rgb_f32(rgb: [u8; 3]) -> [f32; 3] {
    rgb.map(f32::from)
}
