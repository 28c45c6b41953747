//! Positions and colours of every ball at any show time, for the preview (which calls
//! it every frame) and anything else that draws a show.
//!
//! [`Sampler::new`] lays the show out for speed once; [`Sampler::sample`] then fills
//! caller-provided buffers without allocating. Each ball keeps a cursor on its current
//! row, so moving forward by small steps costs O(1) per ball; any jump, backwards too,
//! costs a binary search for the balls concerned. The evaluation is
//! [`hermite_position`], the same function the PVT evaluator uses, so the preview moves
//! balls as the simulated units do; it runs in `f32` here (within 10 µm of the `f64`
//! evaluator over a 7.5 m travel), which doubles the balls evaluated per instruction.
//!
//! Before time 0 every ball rests at its start position, after its last row at its last
//! position. Balls without colour keyframes are [`DEFAULT_COLOUR`].
//!
//! ```
//! use floatball_shared::show::{Layout, Sampler, Show, Track, TrackRow};
//!
//! let show = Show {
//!     outputs: Vec::new(),
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

use super::{Layout, Show, Track};
use crate::motion::hermite_position;

/// The colour of a ball whose track has no colour keyframes: white.
pub const DEFAULT_COLOUR: [u8; 3] = [255, 255, 255];

/// The largest magnitude of a sampling time, ms; times beyond are clamped, so that the
/// sentinel knots at ±`f64::MAX` always bound every interval.
const TIME_LIMIT_MS: f64 = 1e300;

/// A point of a ball's timeline: a time and what holds there.
#[derive(Debug, Clone, Copy)]
struct Knot<T> {
    time_ms: f64,
    value: T,
}

/// Balls laid out side by side in a block of the knot vector.
const LANES: usize = 32;

/// Per ball, a sequence of knots in time and a cursor on the interval between two of
/// them that holds the last sampled time. Each ball's knots are framed by sentinels at
/// `f64::MIN` and `f64::MAX` ms, so every finite time falls in exactly one interval.
///
/// Layout: balls go in blocks of [`LANES`]; within a block the knots are time-major
/// (knot k of every ball of the block, then knot k + 1, …), padded with the last
/// sentinel to the block's longest ball. When a preview plays, neighbouring balls
/// cross knots at nearly the same frames, so a frame's cursor moves read memory
/// nearly in sequence instead of one cache miss per ball.
#[derive(Debug, Clone)]
struct Timeline<T> {
    /// All blocks' knots.
    knots: Vec<Knot<T>>,
    /// Per block, the index of its first knot; one more entry marks the end.
    block_start: Vec<usize>,
    /// Per ball, the index in `knots` of the knot starting its current interval.
    current: Vec<usize>,
    /// Per ball, the current interval's start and end, ms (copied for a fast check).
    current_lo_ms: Vec<f64>,
    current_hi_ms: Vec<f64>,
    /// The times, `window_ms[0]..window_ms[1]`, within which none of the first
    /// `window_units` balls changes interval: the latest start and earliest end of
    /// their current intervals. Sampling inside it skips the cursors entirely.
    window_ms: [f64; 2],
    window_units: usize,
}

impl<T: Copy> Timeline<T> {
    fn with_capacity(units: usize, knots: usize) -> Self {
        Self {
            knots: Vec::with_capacity(knots),
            block_start: Vec::with_capacity(units / LANES + 2),
            current: Vec::with_capacity(units),
            current_lo_ms: Vec::with_capacity(units),
            current_hi_ms: Vec::with_capacity(units),
            window_ms: [0.0; 2],
            window_units: 0,
        }
    }

    /// Adds a block of `lanes` (1..=[`LANES`]) balls, each with at most `len` knots
    /// (sentinels included): `knot(lane, k)` is knot `k` of the block's ball `lane`,
    /// asked for every `k` in order and, past the ball's own last knot, its final
    /// sentinel again. Written straight into place, time-major.
    fn push_block(
        &mut self,
        lanes: usize,
        len: usize,
        mut knot: impl FnMut(usize, usize) -> Knot<T>,
    ) {
        debug_assert!((1..=LANES).contains(&lanes) && len >= 2);
        let start = self.knots.len();
        self.block_start.push(start);
        self.knots.reserve(len * LANES);
        for k in 0..len {
            let first = knot(0, k);
            self.knots.push(first);
            self.knots.extend((1..lanes).map(|lane| knot(lane, k)));
            // Lanes without a ball repeat the block's first ball; nothing reads them.
            self.knots.extend(std::iter::repeat_n(first, LANES - lanes));
        }
        for lane in 0..lanes {
            self.current.push(start + lane);
            self.current_lo_ms.push(self.knots[start + lane].time_ms);
            self.current_hi_ms
                .push(self.knots[start + LANES + lane].time_ms);
        }
    }

    /// Marks the end of the last block.
    fn finish(&mut self) {
        self.block_start.push(self.knots.len());
    }

    /// The current interval of `unit`: its two ends.
    #[inline]
    fn current_interval(&self, unit: usize) -> [Knot<T>; 2] {
        let index = self.current[unit];
        [self.knots[index], self.knots[index + LANES]]
    }

    /// Moves every ball's cursor to the interval holding `t_ms` and calls
    /// `moved(ball, interval)` for each ball whose interval changed.
    #[inline]
    fn seek(&mut self, t_ms: f64, units: usize, mut moved: impl FnMut(usize, [Knot<T>; 2])) {
        let [window_lo, window_hi] = self.window_ms;
        if units <= self.window_units && window_lo <= t_ms && t_ms < window_hi {
            return;
        }
        let mut window_ms = [f64::MIN, f64::MAX];
        for unit in 0..units {
            if !(self.current_lo_ms[unit] <= t_ms && t_ms < self.current_hi_ms[unit]) {
                let index = self.find(unit, t_ms);
                self.current[unit] = index;
                let interval = self.current_interval(unit);
                self.current_lo_ms[unit] = interval[0].time_ms;
                self.current_hi_ms[unit] = interval[1].time_ms;
                moved(unit, interval);
            }
            window_ms[0] = window_ms[0].max(self.current_lo_ms[unit]);
            window_ms[1] = window_ms[1].min(self.current_hi_ms[unit]);
        }
        self.window_ms = window_ms;
        self.window_units = units;
    }

    /// The index of the knot starting the interval of `unit` that holds `t_ms`: a few
    /// steps forward from the cursor for a playing preview, a binary search for any
    /// other jump.
    fn find(&self, unit: usize, t_ms: f64) -> usize {
        let current = self.current[unit];
        if t_ms >= self.current_hi_ms[unit] {
            // The next knot is at or before `t_ms`; the final sentinel (f64::MAX) is
            // after any sampling time, so stepping stops on this ball's knots.
            let mut index = current + LANES;
            for _ in 0..4 {
                if t_ms < self.knots[index + LANES].time_ms {
                    return index;
                }
                index += LANES;
            }
        }
        // Binary search over the ball's knots for the last one at or before `t_ms`:
        // knot 0 (f64::MIN) is, the block's last (a final sentinel) is not.
        let block = unit / LANES;
        let base = self.block_start[block] + unit % LANES;
        let time = |k: usize| self.knots[base + k * LANES].time_ms;
        let (mut at_or_before, mut after) = (
            0,
            (self.block_start[block + 1] - self.block_start[block]) / LANES - 1,
        );
        while after - at_or_before > 1 {
            let middle = at_or_before + (after - at_or_before) / 2;
            if time(middle) <= t_ms {
                at_or_before = middle;
            } else {
                after = middle;
            }
        }
        base + at_or_before * LANES
    }
}

/// The most knots `count` gives a ball of `block`.
fn longest(block: &[Track], count: fn(&Track) -> usize) -> usize {
    block.iter().map(count).max().unwrap_or(0)
}

/// A ball's position and velocity at a knot, mm and mm/s (in `f32`, as the sampler
/// evaluates: smaller knots are fewer bytes to read when cursors move).
type State = [f32; 2];

/// A show laid out for fast sampling: build once per show, sample every frame.
#[derive(Debug, Clone)]
pub struct Sampler {
    units: usize,
    duration_ms: u64,
    motion: Timeline<State>,
    /// Per ball, the current interval as a Hermite segment in structure-of-arrays form,
    /// so that the evaluation loop runs straight through: `s = (t - start) * scale`
    /// (start: the timeline's `current_lo_ms`), end positions, and end velocities times
    /// the interval's duration.
    scale_per_ms: Vec<f64>,
    p0_mm: Vec<f32>,
    m0_mm: Vec<f32>,
    p1_mm: Vec<f32>,
    m1_mm: Vec<f32>,
    colour: Timeline<[f32; 3]>,
    /// Per ball, the current colour interval: `s` as for motion, the colour at its
    /// start and the change over it.
    colour_scale_per_ms: Vec<f64>,
    colour_from: Vec<[f32; 3]>,
    colour_change: Vec<[f32; 3]>,
}

impl Default for Sampler {
    /// A sampler of no balls: what a holder keeps while it lays out the next show, so
    /// that the next one can reuse the memory of the last (50 MB for 100 × 100 balls
    /// over a minute).
    fn default() -> Self {
        Self::new(&Show {
            name: String::new(),
            layout: Layout {
                rows: 0,
                cols: 0,
                pitch_mm: 0.0,
            },
            tracks: Vec::new(),
            outputs: Vec::new(),
        })
    }
}

impl Sampler {
    /// Lays `show` out for sampling, with every ball's cursor before time 0. Rows of
    /// 0 ms (invalid, but a preview may still show the show) are instant jumps.
    #[must_use]
    pub fn new(show: &Show) -> Self {
        let units = show.tracks.len();
        // Every block is as long as its longest ball.
        let knots = |count: fn(&Track) -> usize| -> usize {
            show.tracks
                .chunks(LANES)
                .map(|block| LANES * longest(block, count))
                .sum()
        };
        let motion_knots = |track: &Track| track.rows.len() + 3;
        let colour_knots = |track: &Track| track.colours.len() + 2;
        let mut motion = Timeline::with_capacity(units, knots(motion_knots));
        let mut colour = Timeline::with_capacity(units, knots(colour_knots));
        for block in show.tracks.chunks(LANES) {
            // Motion: a sentinel at rest at the start, the start itself at 0 ms, the
            // rows, and a sentinel at rest at the last position.
            let len = longest(block, motion_knots);
            let mut time_ms = [0u64; LANES];
            motion.push_block(block.len(), len, |lane, k| {
                let track = &block[lane];
                let start_mm = track.start_mm as f32;
                match k {
                    0 => Knot {
                        time_ms: f64::MIN,
                        value: [start_mm, 0.0],
                    },
                    1 => Knot {
                        time_ms: 0.0,
                        value: [start_mm, 0.0],
                    },
                    _ => match track.rows.get(k - 2) {
                        Some(row) => {
                            time_ms[lane] += u64::from(row.duration_ms);
                            Knot {
                                time_ms: time_ms[lane] as f64,
                                value: [row.position_mm as f32, row.velocity_mm_s as f32],
                            }
                        }
                        None => Knot {
                            time_ms: f64::MAX,
                            value: [
                                track
                                    .rows
                                    .last()
                                    .map_or(track.start_mm, |row| row.position_mm)
                                    as f32,
                                0.0,
                            ],
                        },
                    },
                }
            });
            // Colour: its first colour before the first key, the keys, its last colour
            // after the last.
            let len = longest(block, colour_knots);
            colour.push_block(block.len(), len, |lane, k| {
                let keys = &block[lane].colours;
                match k.checked_sub(1).map(|index| keys.get(index)) {
                    None => Knot {
                        time_ms: f64::MIN,
                        value: rgb_f32(keys.first().map_or(DEFAULT_COLOUR, |key| key.rgb)),
                    },
                    Some(Some(key)) => Knot {
                        time_ms: key.time_ms as f64,
                        value: rgb_f32(key.rgb),
                    },
                    Some(None) => Knot {
                        time_ms: f64::MAX,
                        value: rgb_f32(keys.last().map_or(DEFAULT_COLOUR, |key| key.rgb)),
                    },
                }
            });
        }
        motion.finish();
        colour.finish();
        let mut sampler = Self {
            units,
            duration_ms: show.duration_ms(),
            scale_per_ms: Vec::with_capacity(units),
            p0_mm: Vec::with_capacity(units),
            m0_mm: Vec::with_capacity(units),
            p1_mm: Vec::with_capacity(units),
            m1_mm: Vec::with_capacity(units),
            motion,
            colour,
            colour_scale_per_ms: Vec::with_capacity(units),
            colour_from: Vec::with_capacity(units),
            colour_change: Vec::with_capacity(units),
        };
        for unit in 0..units {
            let fade = Fade::new(sampler.colour.current_interval(unit));
            sampler.colour_scale_per_ms.push(fade.scale_per_ms);
            sampler.colour_from.push(fade.from);
            sampler.colour_change.push(fade.change);
            let segment = HermiteInterval::new(sampler.motion.current_interval(unit));
            sampler.scale_per_ms.push(segment.scale_per_ms);
            sampler.p0_mm.push(segment.p0_mm);
            sampler.m0_mm.push(segment.m0_mm);
            sampler.p1_mm.push(segment.p1_mm);
            sampler.m1_mm.push(segment.m1_mm);
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
            scale_per_ms,
            p0_mm,
            m0_mm,
            p1_mm,
            m1_mm,
            ..
        } = self;
        motion.seek(t_ms, units, |unit, interval| {
            let segment = HermiteInterval::new(interval);
            scale_per_ms[unit] = segment.scale_per_ms;
            p0_mm[unit] = segment.p0_mm;
            m0_mm[unit] = segment.m0_mm;
            p1_mm[unit] = segment.p1_mm;
            m1_mm[unit] = segment.m1_mm;
        });
        let segments = motion.current_lo_ms[..units]
            .iter()
            .zip(&scale_per_ms[..units])
            .zip(&p0_mm[..units])
            .zip(&m0_mm[..units])
            .zip(&p1_mm[..units])
            .zip(&m1_mm[..units]);
        for (out, (((((start, scale), p0), m0), p1), m1)) in
            positions_mm[..units].iter_mut().zip(segments)
        {
            let s = ((t_ms - start) * scale).clamp(0.0, 1.0) as f32;
            *out = hermite_position(*p0, *m0, *p1, *m1, s);
        }
        if let Some(colours) = colours {
            self.sample_colours(t_ms, colours);
        }
    }

    fn sample_colours(&mut self, t_ms: f64, colours: &mut [[u8; 3]]) {
        let units = self.units.min(colours.len());
        let Self {
            colour,
            colour_scale_per_ms,
            colour_from,
            colour_change,
            ..
        } = self;
        colour.seek(t_ms, units, |unit, interval| {
            let fade = Fade::new(interval);
            colour_scale_per_ms[unit] = fade.scale_per_ms;
            colour_from[unit] = fade.from;
            colour_change[unit] = fade.change;
        });
        let fades = colour.current_lo_ms[..units]
            .iter()
            .zip(&colour_scale_per_ms[..units])
            .zip(&colour_from[..units])
            .zip(&colour_change[..units]);
        for (out, (((start, scale), from), change)) in colours[..units].iter_mut().zip(fades) {
            let s = ((t_ms - start) * scale).clamp(0.0, 1.0) as f32;
            for channel in 0..3 {
                // In 0..=255 by construction, so adding 0.5 and truncating rounds.
                out[channel] = (from[channel] + change[channel] * s + 0.5) as u8;
            }
        }
    }
}

/// An interval of a ball's colour: a linear fade.
struct Fade {
    scale_per_ms: f64,
    from: [f32; 3],
    change: [f32; 3],
}

impl Fade {
    /// The fade between two keyframes; before the first and after the last the colour
    /// holds (scale 0 keeps `s` at 0).
    fn new([from, to]: [Knot<[f32; 3]>; 2]) -> Self {
        if from.time_ms == f64::MIN || to.time_ms == f64::MAX {
            let held = if from.time_ms == f64::MIN {
                to.value
            } else {
                from.value
            };
            return Self {
                scale_per_ms: 0.0,
                from: held,
                change: [0.0; 3],
            };
        }
        Self {
            scale_per_ms: 1.0 / (to.time_ms - from.time_ms),
            from: from.value,
            change: [0, 1, 2].map(|channel| to.value[channel] - from.value[channel]),
        }
    }
}

/// An interval of a ball's motion in the form [`hermite_position`] takes.
struct HermiteInterval {
    scale_per_ms: f64,
    p0_mm: f32,
    m0_mm: f32,
    p1_mm: f32,
    m1_mm: f32,
}

impl HermiteInterval {
    /// The cubic between two knots; before time and after the last row the ball holds
    /// still (scale 0 keeps `s` at 0, where the position is exactly `p0`).
    fn new([from, to]: [Knot<State>; 2]) -> Self {
        let ([p0, v0], [p1, v1]) = (from.value, to.value);
        if from.time_ms == f64::MIN || to.time_ms == f64::MAX {
            let p = if from.time_ms == f64::MIN { p1 } else { p0 };
            return Self {
                scale_per_ms: 0.0,
                p0_mm: p,
                m0_mm: 0.0,
                p1_mm: p,
                m1_mm: 0.0,
            };
        }
        let span_ms = to.time_ms - from.time_ms;
        let duration_s = (span_ms * 0.001) as f32;
        Self {
            scale_per_ms: 1.0 / span_ms,
            p0_mm: p0,
            m0_mm: v0 * duration_s,
            p1_mm: p1,
            m1_mm: v1 * duration_s,
        }
    }
}

fn rgb_f32(rgb: [u8; 3]) -> [f32; 3] {
    rgb.map(f32::from)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::{ColourKey, Layout, Track, TrackRow};

    fn show() -> Show {
        let rows = |rows: &[(f64, f64, u32)]| rows.iter().copied().map(TrackRow::from).collect();
        Show {
            outputs: Vec::new(),
            name: "sampler".into(),
            layout: Layout {
                rows: 1,
                cols: 3,
                pitch_mm: 500.0,
            },
            tracks: vec![
                Track {
                    start_mm: 1000.0,
                    rows: rows(&[
                        (1200.0, 800.0, 250),
                        (1500.0, 0.0, 100),
                        (900.0, -300.0, 255),
                        (800.0, 0.0, 95),
                    ]),
                    colours: vec![
                        ColourKey {
                            time_ms: 100,
                            rgb: [0, 0, 0],
                        },
                        ColourKey {
                            time_ms: 300,
                            rgb: [200, 100, 255],
                        },
                    ],
                },
                Track {
                    start_mm: 0.0,
                    rows: rows(&[(7500.0, 0.0, 200), (0.0, 0.0, 200), (10.0, 0.0, 300)]),
                    colours: Vec::new(),
                },
                Track {
                    start_mm: 50.0,
                    rows: Vec::new(),
                    colours: Vec::new(),
                },
            ],
        }
    }

    /// The position by the PVT evaluator directly.
    fn expected(track: &Track, t_ms: f64) -> f32 {
        let mut position = track.start_mm;
        for (start_ms, segment) in track.segments() {
            let start_ms = start_ms as f64;
            if t_ms < start_ms {
                break;
            }
            position = segment.position(((t_ms - start_ms) / 1000.0).min(segment.duration_s));
        }
        position as f32
    }

    #[test]
    fn follows_the_pvt_evaluator() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        assert_eq!(sampler.unit_count(), 3);
        assert_eq!(sampler.duration_ms(), 700);
        let mut positions = [0.0f32; 3];
        for step in -20..=900 {
            let t_ms = f64::from(step) * 0.9;
            sampler.sample(t_ms, &mut positions, None);
            for (unit, track) in show.tracks.iter().enumerate() {
                let want = expected(track, t_ms);
                // Evaluated in f32: within 10 µm of the f64 evaluator.
                assert!(
                    (positions[unit] - want).abs() <= 0.01,
                    "unit {unit} at {t_ms} ms: {} vs {want}",
                    positions[unit]
                );
            }
        }
    }

    #[test]
    fn the_default_sampler_has_no_balls_and_samples_nothing() {
        let mut sampler = Sampler::default();
        assert_eq!((sampler.unit_count(), sampler.duration_ms()), (0, 0));
        let mut positions = [7.0f32; 2];
        let mut colours = [[1u8; 3]; 2];
        for t_ms in [-1.0, 0.0, 500.0, f64::NAN] {
            sampler.sample(t_ms, &mut positions, Some(&mut colours));
        }
        assert_eq!((positions, colours), ([7.0; 2], [[1; 3]; 2]));
    }

    #[test]
    fn rows_end_exactly_and_the_ends_hold() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        let mut positions = [0.0f32; 3];
        for (t_ms, want) in [
            (-1e9, [1000.0, 0.0, 50.0]),
            (0.0, [1000.0, 0.0, 50.0]),
            (250.0, [1200.0, 6328.125, 50.0]),
            (350.0, [1500.0, 1171.875, 50.0]),
            (700.0, [800.0, 10.0, 50.0]),
            (1e12, [800.0, 10.0, 50.0]),
            (f64::INFINITY, [800.0, 10.0, 50.0]),
            (f64::NAN, [1000.0, 0.0, 50.0]),
        ] {
            sampler.sample(t_ms, &mut positions, None);
            assert_eq!(positions, want, "at {t_ms} ms");
        }
    }

    #[test]
    fn any_order_of_times_gives_the_same_answer() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        let times = [
            500.0, 10.0, 10.5, 699.0, 0.0, -5.0, 260.0, 259.0, 1000.0, 351.0,
        ];
        for t_ms in times {
            let mut fresh = [0.0f32; 3];
            Sampler::new(&show).sample(t_ms, &mut fresh, None);
            let mut reused = [0.0f32; 3];
            sampler.sample(t_ms, &mut reused, None);
            assert_eq!(fresh, reused, "at {t_ms} ms");
        }
    }

    #[test]
    fn colours_interpolate_and_hold() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        let mut positions = [0.0f32; 3];
        let mut colours = [[1u8; 3]; 3];
        for (t_ms, want) in [
            (0.0, [0, 0, 0]),
            (100.0, [0, 0, 0]),
            (200.0, [100, 50, 128]),
            (300.0, [200, 100, 255]),
            (5000.0, [200, 100, 255]),
            (150.0, [50, 25, 64]),
        ] {
            sampler.sample(t_ms, &mut positions, Some(&mut colours));
            assert_eq!(colours[0], want, "at {t_ms} ms");
            assert_eq!(colours[1], DEFAULT_COLOUR);
        }
    }

    #[test]
    fn short_buffers_get_the_first_balls() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        let mut positions = [0.0f32; 1];
        let mut colours = [[0u8; 3]; 2];
        sampler.sample(250.0, &mut positions, Some(&mut colours));
        assert_eq!(positions, [1200.0]);
        assert_eq!(colours[1], DEFAULT_COLOUR);
        sampler.sample(250.0, &mut [], Some(&mut []));
        let mut all = [0.0f32; 3];
        sampler.sample(250.0, &mut all, None);
        assert_eq!(all, [1200.0, 6328.125, 50.0]);
    }

    #[test]
    fn a_zero_ms_row_is_an_instant_jump() {
        let mut show = show();
        show.tracks[2].rows = vec![
            TrackRow::new(50.0, 0.0, 100),
            TrackRow::new(500.0, 0.0, 0),
            TrackRow::new(500.0, 0.0, 100),
        ];
        let mut sampler = Sampler::new(&show);
        let mut positions = [0.0f32; 3];
        sampler.sample(99.0, &mut positions, None);
        assert_eq!(positions[2], 50.0);
        sampler.sample(100.0, &mut positions, None);
        assert_eq!(positions[2], 500.0);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;
    use crate::show::{Layout, Track, TrackRow};

    fn track() -> impl Strategy<Value = Track> {
        (
            0.0..7500.0f64,
            proptest::collection::vec((0.0..7500.0f64, -3000.0..3000.0f64, 10u32..=255), 0..30),
        )
            .prop_map(|(start_mm, rows)| Track {
                start_mm,
                rows: rows.into_iter().map(TrackRow::from).collect(),
                colours: Vec::new(),
            })
    }

    proptest! {
        #[test]
        fn reused_sampler_matches_a_fresh_one_and_the_evaluator(
            tracks in proptest::collection::vec(track(), 1..80),
            times in proptest::collection::vec(-100.0..8000.0f64, 1..40),
        ) {
            let show = Show {
                outputs: Vec::new(),
                name: "p".into(),
                layout: Layout { rows: 1, cols: u32::try_from(tracks.len()).unwrap(), pitch_mm: 1.0 },
                tracks,
            };
            let mut sampler = Sampler::new(&show);
            let mut reused = vec![0.0f32; show.tracks.len()];
            let mut fresh = vec![0.0f32; show.tracks.len()];
            for t_ms in times {
                sampler.sample(t_ms, &mut reused, None);
                Sampler::new(&show).sample(t_ms, &mut fresh, None);
                prop_assert_eq!(&reused, &fresh);
                for (unit, track) in show.tracks.iter().enumerate() {
                    let mut want = track.start_mm;
                    for (start_ms, segment) in track.segments() {
                        if t_ms >= start_ms as f64 {
                            let tau_s = ((t_ms - start_ms as f64) / 1000.0).min(segment.duration_s);
                            want = segment.position(tau_s);
                        }
                    }
                    prop_assert!((f64::from(reused[unit]) - want).abs() < 1e-3 * want.abs().max(1.0));
                }
            }
        }
    }
}
