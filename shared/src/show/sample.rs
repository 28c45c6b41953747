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

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::{ColourKey, Layout, Track, TrackRow};

    fn show() -> Show {
        let rows = |rows: &[(f64, f64, u32)]| rows.iter().copied().map(TrackRow::from).collect();
        Show {
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
                assert!(
                    (positions[unit] - want).abs() <= 1e-3,
                    "unit {unit} at {t_ms} ms: {} vs {want}",
                    positions[unit]
                );
            }
        }
    }

    fn expected_at_200() -> f32 {
        expected(&show().tracks[0], 200.0)
    }

    #[test]
    fn rows_end_exactly_and_the_ends_hold() {
        let show = show();
        let mut sampler = Sampler::new(&show);
        let mut positions = [0.0f32; 3];
        for (t_ms, want) in [
            (-1e9, [1000.0, 0.0, 50.0]),
            (0.0, [1000.0, 0.0, 50.0]),
            (200.0, [expected_at_200(), 7500.0, 50.0]),
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
            tracks in proptest::collection::vec(track(), 1..6),
            times in proptest::collection::vec(-100.0..8000.0f64, 1..40),
        ) {
            let show = Show {
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
