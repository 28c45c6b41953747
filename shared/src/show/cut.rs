//! A show cut at a time: what a start from inside an entry plays first ("play from
//! anywhere", issue 37). [`Show::from_time`] gives the [`Cut`]; every family plays it
//! as it plays any show (UIM2503 plans it, MBOX samples it, MOONS' drives get a Q
//! program compiled from it), and the sequencer counts its clock from
//! [`Cut::start_ms`] ([`crate::player::StartAt`]).
//!
//! **The rule.** Balls stand still before a show begins, but at a time inside a show
//! they are usually moving. The cut therefore has two parts:
//!
//! 1. **The join** at [`Cut::joins_ms`]: the first instant at or after the time asked
//!    for at which every track can be cut, i.e. at which each track's row under way
//!    has at least 10 ms left (a unit's shortest row) or has just ended. From there on
//!    the cut show *is* the show: the rest of the row under way is the same cubic
//!    from the same position and velocity, the rows after it are the show's own.
//! 2. **The run-up** before it, of length `L` = [`Cut::run_up_ms`], the same for every
//!    ball: each ball starts at rest and accelerates constantly (at most at the
//!    acceleration given, `a`) so that it reaches the show's position and velocity
//!    exactly at the join. A ball moving at `v` there starts at `p − v·L/2` (at most
//!    `|v|·L/2` from the show's position `p`, and `L = ⌈max|v| / a⌉`, at least 10 ms);
//!    a ball at rest holds still. Without a moving ball there is no run-up.
//!
//! The cut show's time 0 is the show's time [`Cut::start_ms`] = join − run-up: the
//! player's clock counts the show's time from there, so from the join on every ball
//! is where the show has it at that time (to rounding), and during the run-up it is
//! on its parabola instead (physically it cannot be moving at the start). A run-up
//! that would begin before the show's start plays the show from its start instead
//! (every ball at rest at its `start_mm`). A run-up is never validated here: close to
//! the ends of the travel a fast ball's start `p − v·L/2` may lie outside it, and
//! the installation's check before Start then refuses it, naming the ball (pick
//! another time).
//!
//! Colour keys and the MBOX output tracks are shifted by [`Cut::start_ms`]: each
//! starts with the value it has at that time.

use super::{AnalogKey, ColourKey, DigitalKey, OutputTrack, Show, Track, TrackRow};
use crate::show::validate::DEFAULT_MAX_ACCEL_MM_S2;
use crate::uim2503::pvt::{ROW_MAX_MS, ROW_MIN_MS};

/// A show cut at a time ([`Show::from_time`]); see the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct Cut {
    /// The show from [`Cut::start_ms`] on: its time 0 is the show's `start_ms`.
    pub show: Show,
    /// The show's time at the cut show's time 0, ms (where the player's clock starts).
    pub start_ms: u64,
    /// The show's time from which the cut show is the show itself, ms
    /// (`start_ms + run_up_ms`).
    pub joins_ms: u64,
}

impl Cut {
    /// The run-up's length, ms (0: every ball was at rest at the join).
    #[must_use]
    pub fn run_up_ms(&self) -> u64 {
        self.joins_ms - self.start_ms
    }
}

/// Where a track stands at the join.
struct AtJoin {
    position_mm: f64,
    velocity_mm_s: f64,
    /// The rows after the join: the rest of the row under way (its remaining
    /// duration, ms; 0 at a row's end), and the index of that row.
    rest: Option<(usize, u32)>,
}

impl Show {
    /// The show cut at `from_ms` for a start from that time, with run-ups at up to
    /// `run_up_accel_mm_s2` (a value that is not a positive number: the default top
    /// acceleration); see the [module documentation](super::cut). `None` when nothing
    /// is left to play from there (`from_ms` at or after the show's end, or within its
    /// last 10 ms). At `from_ms` 0 it is the show itself.
    #[must_use]
    pub fn from_time(&self, from_ms: u64, run_up_accel_mm_s2: f64) -> Option<Cut> {
        let duration_ms = self.duration_ms();
        if from_ms >= duration_ms {
            return None;
        }
        let whole = || Cut {
            show: self.clone(),
            start_ms: 0,
            joins_ms: 0,
        };
        if from_ms == 0 {
            return Some(whole());
        }
        let joins_ms = self.join_at(from_ms);
        if joins_ms >= duration_ms {
            return None;
        }
        let states: Vec<AtJoin> = self
            .tracks
            .iter()
            .map(|track| at_join(track, joins_ms))
            .collect();
        let accel = if run_up_accel_mm_s2 > 0.0 && run_up_accel_mm_s2.is_finite() {
            run_up_accel_mm_s2
        } else {
            DEFAULT_MAX_ACCEL_MM_S2
        };
        let fastest = states
            .iter()
            .map(|state| state.velocity_mm_s.abs())
            .fold(0.0, f64::max);
        let run_up_ms = if fastest > 0.0 {
            // Whole ms, at least a row: the speed over the acceleration, rounded up.
            let needed = (fastest / accel * 1000.0).ceil();
            (needed as u64).max(u64::from(ROW_MIN_MS))
        } else {
            0
        };
        if run_up_ms > joins_ms {
            return Some(whole());
        }
        let start_ms = joins_ms - run_up_ms;
        let tracks = self
            .tracks
            .iter()
            .zip(&states)
            .map(|(track, state)| cut_track(track, state, run_up_ms, start_ms))
            .collect();
        let outputs = self
            .outputs
            .iter()
            .map(|output| shift_outputs(output, start_ms))
            .collect();
        Some(Cut {
            show: Show {
                name: self.name.clone(),
                layout: self.layout,
                tracks,
                outputs,
            },
            start_ms,
            joins_ms,
        })
    }

    /// The first instant at or after `from_ms` at which every track's row under way
    /// has ended or has at least a unit's shortest row left.
    fn join_at(&self, from_ms: u64) -> u64 {
        let min_ms = u64::from(ROW_MIN_MS);
        let mut t = from_ms;
        loop {
            let later = self
                .tracks
                .iter()
                .filter_map(|track| {
                    let end = row_end_after(track, t)?;
                    (end - t < min_ms).then_some(end)
                })
                .max();
            match later {
                Some(end) => t = end,
                None => return t,
            }
        }
    }
}

/// The end of the row of `track` under way at `t_ms` (strictly after it); `None` at
/// or after the track's end.
fn row_end_after(track: &Track, t_ms: u64) -> Option<u64> {
    let mut end = 0u64;
    for row in &track.rows {
        end += u64::from(row.duration_ms);
        if end > t_ms {
            return Some(end);
        }
    }
    None
}

fn at_join(track: &Track, joins_ms: u64) -> AtJoin {
    let mut last = (track.start_mm, 0.0);
    for (index, (start_ms, segment)) in track.segments().enumerate() {
        let duration_ms = u64::from(track.rows[index].duration_ms);
        let end_ms = start_ms + duration_ms;
        if start_ms == joins_ms {
            return AtJoin {
                position_mm: segment.p0,
                velocity_mm_s: segment.v0,
                rest: Some((index, 0)),
            };
        }
        if end_ms > joins_ms {
            let k = segment.kinematics((joins_ms - start_ms) as f64 / 1000.0);
            let left = u32::try_from(end_ms - joins_ms).unwrap_or(u32::MAX);
            return AtJoin {
                position_mm: k.position,
                velocity_mm_s: k.velocity,
                rest: Some((index, left)),
            };
        }
        last = (segment.p1, segment.v1);
    }
    // The track is over: its ball rests where it ended.
    AtJoin {
        position_mm: last.0,
        velocity_mm_s: 0.0,
        rest: None,
    }
}

/// `track` from the run-up's start: the run-up (when there is one and the track goes
/// on), then the rest of its rows.
fn cut_track(track: &Track, state: &AtJoin, run_up_ms: u64, start_ms: u64) -> Track {
    let colours = shift_colours(&track.colours, start_ms);
    let Some((index, left_ms)) = state.rest else {
        return Track {
            start_mm: state.position_mm,
            rows: Vec::new(),
            colours,
        };
    };
    let (p, v) = (state.position_mm, state.velocity_mm_s);
    let run_up_s = run_up_ms as f64 / 1000.0;
    let accel = if run_up_ms > 0 { v / run_up_s } else { 0.0 };
    let start_mm = p - v * run_up_s / 2.0;
    let mut rows = Vec::with_capacity(track.rows.len() - index + 2);
    let pieces = run_up_ms.div_ceil(u64::from(ROW_MAX_MS));
    let mut done_ms = 0u64;
    for piece in 0..pieces {
        // Near-equal pieces of whole ms, each within a unit's row lengths.
        let piece_ms = run_up_ms / pieces + u64::from(piece < run_up_ms % pieces);
        done_ms += piece_ms;
        let row = if done_ms == run_up_ms {
            TrackRow::new(p, v, 0)
        } else {
            let tau_s = done_ms as f64 / 1000.0;
            TrackRow::new(start_mm + accel * tau_s * tau_s / 2.0, accel * tau_s, 0)
        };
        rows.push(TrackRow {
            duration_ms: u32::try_from(piece_ms).unwrap_or(u32::MAX),
            ..row
        });
    }
    if left_ms > 0 {
        let row = track.rows[index];
        rows.push(TrackRow {
            duration_ms: left_ms,
            ..row
        });
        rows.extend_from_slice(&track.rows[index + 1..]);
    } else {
        rows.extend_from_slice(&track.rows[index..]);
    }
    Track {
        start_mm,
        rows,
        colours,
    }
}

/// Colour keys from `start_ms` on, shifted: the colour at `start_ms` first (the keys
/// hold before the first and after the last, and change linearly between).
fn shift_colours(keys: &[ColourKey], start_ms: u64) -> Vec<ColourKey> {
    if keys.is_empty() {
        return Vec::new();
    }
    let after = keys.partition_point(|key| key.time_ms <= start_ms);
    let first = match (after.checked_sub(1).map(|i| keys[i]), keys.get(after)) {
        (Some(before), Some(next)) => {
            let done = (start_ms - before.time_ms) as f64 / (next.time_ms - before.time_ms) as f64;
            let mut rgb = [0u8; 3];
            for (channel, out) in rgb.iter_mut().enumerate() {
                let from = f64::from(before.rgb[channel]);
                let to = f64::from(next.rgb[channel]);
                // Between two u8 values: `as` cannot overflow.
                *out = (from + (to - from) * done).round() as u8;
            }
            rgb
        }
        (Some(before), None) => before.rgb,
        (None, _) => keys[0].rgb,
    };
    let mut shifted = vec![ColourKey {
        time_ms: 0,
        rgb: first,
    }];
    shifted.extend(
        keys[after..]
            .iter()
            .filter(|key| key.time_ms > start_ms)
            .map(|key| ColourKey {
                time_ms: key.time_ms - start_ms,
                rgb: key.rgb,
            }),
    );
    shifted
}

/// A box's output track from `start_ms` on, shifted: each output starts with its value
/// at `start_ms` (as a keyframe at 0, unless it is before the output's first
/// keyframe, where it is 0 until then anyway).
fn shift_outputs(track: &OutputTrack, start_ms: u64) -> OutputTrack {
    let now = track.sample(start_ms);
    let mut digital = Vec::new();
    if track
        .digital
        .first()
        .is_some_and(|key| key.time_ms <= start_ms)
    {
        digital.push(DigitalKey {
            time_ms: 0,
            bits: now.digital_bits,
        });
    }
    digital.extend(
        track
            .digital
            .iter()
            .filter(|key| key.time_ms > start_ms)
            .map(|key| DigitalKey {
                time_ms: key.time_ms - start_ms,
                bits: key.bits,
            }),
    );
    let mut analog = Vec::new();
    for channel in 0..2u8 {
        if track
            .analog
            .iter()
            .any(|key| key.channel == channel && key.time_ms <= start_ms)
        {
            analog.push(AnalogKey {
                time_ms: 0,
                channel,
                value: now.analog[usize::from(channel)],
            });
        }
    }
    analog.extend(
        track
            .analog
            .iter()
            .filter(|key| key.time_ms > start_ms)
            .map(|key| AnalogKey {
                time_ms: key.time_ms - start_ms,
                channel: key.channel,
                value: key.value,
            }),
    );
    OutputTrack {
        box_index: track.box_index,
        digital,
        analog,
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::demo;
    use crate::show::validate::{Limits, validate};

    /// Position of `track` at `t_ms` (at rest at its start before, at its end after).
    fn position(track: &Track, t_ms: f64) -> f64 {
        let mut last = track.start_mm;
        for (start_ms, segment) in track.segments() {
            let end_ms = start_ms as f64 + segment.duration_s * 1000.0;
            if t_ms < end_ms {
                return segment.position((t_ms - start_ms as f64).max(0.0) / 1000.0);
            }
            last = segment.p1;
        }
        last
    }

    pub(super) fn check_cut(show: &Show, from_ms: u64, accel: f64) -> Cut {
        let cut = show.from_time(from_ms, accel).expect("cut");
        cut.show.check().expect("consistent");
        assert!(cut.joins_ms >= from_ms || cut.joins_ms == 0, "{cut:?}");
        assert_eq!(cut.show.duration_ms() + cut.start_ms, show.duration_ms());
        for (unit, (cut_track, track)) in cut.show.tracks.iter().zip(&show.tracks).enumerate() {
            assert!(
                cut_track
                    .rows
                    .iter()
                    .all(|row| (10..=255).contains(&row.duration_ms)),
                "unit {unit}: {:?}",
                cut_track.rows
            );
            // From the join on, the cut is the show.
            let mut t = cut.joins_ms as f64;
            while t <= show.duration_ms() as f64 {
                let expected = position(track, t);
                let got = position(cut_track, t - cut.start_ms as f64);
                assert!(
                    (expected - got).abs() < 1e-6,
                    "unit {unit} at {t} ms: {got} vs {expected}"
                );
                t += 3.5;
            }
        }
        cut
    }

    #[test]
    fn from_0_is_the_show_and_past_the_end_is_nothing() {
        let show = demo::wave(2, 3, 20, 200);
        let cut = show.from_time(0, 2000.0).unwrap();
        assert_eq!((cut.show, cut.start_ms, cut.joins_ms), (show.clone(), 0, 0));
        assert_eq!(show.from_time(4000, 2000.0), None);
        assert_eq!(show.from_time(3995, 2000.0), None);
        assert!(show.from_time(3990, 2000.0).is_some());
    }

    #[test]
    fn a_cut_mid_show_joins_the_show_after_a_run_up_within_the_limits() {
        let show = demo::wave(2, 3, 20, 200);
        let cut = check_cut(&show, 2_345, 2_000.0);
        assert_eq!(cut.joins_ms, 2_345);
        assert!(cut.run_up_ms() >= 10, "{cut:?}");
        let limits = Limits::for_layout(2, 3);
        // The run-up breaks no limit (the demo wave's own last row does brake harder).
        let run_up_ms = cut.run_up_ms() as f64;
        let in_run_up: Vec<_> = validate(&cut.show, &limits)
            .into_iter()
            .filter(|violation| violation.time_ms.is_none_or(|t| t <= run_up_ms))
            .collect();
        assert_eq!(in_run_up, []);
        // The run-up: from rest, at most the acceleration given.
        for track in &cut.show.tracks {
            for (_, segment) in track
                .segments()
                .take_while(|(start, _)| *start < cut.run_up_ms())
            {
                assert!(segment.peak_speed().value <= 800.0);
                let accel = segment.kinematics_at_fraction(0.5).acceleration;
                assert!(accel.abs() <= 2_000.0 + 1e-6, "{accel}");
            }
        }
    }

    #[test]
    fn the_join_waits_for_every_track_to_have_a_row_of_10_ms_left() {
        let mut show = demo::wave(1, 2, 20, 200);
        // Unit 1 in rows of 100 ms: 195 leaves 5 ms of unit 1's row (and unit 0's).
        show.tracks[1].rows = show.tracks[1]
            .rows
            .iter()
            .flat_map(|row| [TrackRow::new(row.position_mm, row.velocity_mm_s, 100); 2])
            .collect();
        let cut = check_cut(&show, 195, 10_000.0);
        assert_eq!(cut.joins_ms, 200);
        let cut = check_cut(&show, 290, 10_000.0);
        assert_eq!(cut.joins_ms, 290);
        let cut = check_cut(&show, 391, 10_000.0);
        assert_eq!(cut.joins_ms, 400);
    }

    #[test]
    fn a_run_up_before_the_start_plays_from_the_start() {
        let show = demo::wave(1, 3, 20, 200);
        let cut = show.from_time(30, 100.0).unwrap();
        assert_eq!((cut.start_ms, cut.joins_ms), (0, 0));
        assert_eq!(cut.show, show);
    }

    #[test]
    fn colours_and_outputs_start_with_their_value_at_the_cut() {
        let mut show = demo::wave(1, 1, 20, 100);
        show.tracks[0].colours = vec![
            ColourKey {
                time_ms: 0,
                rgb: [0, 0, 0],
            },
            ColourKey {
                time_ms: 1_000,
                rgb: [200, 100, 0],
            },
            ColourKey {
                time_ms: 1_500,
                rgb: [0, 0, 50],
            },
        ];
        show.outputs = vec![OutputTrack {
            box_index: 0,
            digital: vec![
                DigitalKey {
                    time_ms: 100,
                    bits: 1,
                },
                DigitalKey {
                    time_ms: 1_800,
                    bits: 3,
                },
            ],
            analog: vec![
                AnalogKey {
                    time_ms: 0,
                    channel: 0,
                    value: 0,
                },
                AnalogKey {
                    time_ms: 1_000,
                    channel: 0,
                    value: 1_000,
                },
                AnalogKey {
                    time_ms: 1_900,
                    channel: 1,
                    value: 7,
                },
            ],
        }];
        show.check().unwrap();
        let cut = check_cut(&show, 700, 4_000.0);
        let start = cut.start_ms;
        assert!(start > 0 && start < 700, "{cut:?}");
        for t in [0, 50, 300, 1_000, 1_150, 1_299] {
            assert_eq!(
                cut.show.outputs_at(0, t),
                show.outputs_at(0, t + start),
                "{t}"
            );
        }
        let colours = &cut.show.tracks[0].colours;
        assert_eq!(colours[0].time_ms, 0);
        let expected = (200.0 * start as f64 / 1000.0).round() as u8;
        assert_eq!(colours[0].rgb[0], expected);
        assert_eq!(colours[1].time_ms, 1_000 - start);
        assert_eq!(colours.len(), 3);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::tests::check_cut;
    use crate::show::demo;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]

        #[test]
        fn from_the_join_on_the_cut_is_the_show(
            rows in 1u32..4,
            cols in 1u32..4,
            row_ms in 10u32..256,
            from_permille in 0u64..1000,
            accel in 500.0f64..8000.0,
        ) {
            let show = demo::wave(rows, cols, 12, row_ms);
            let from_ms = show.duration_ms() * from_permille / 1000;
            if show.from_time(from_ms, accel).is_some() {
                let cut = check_cut(&show, from_ms, accel);
                prop_assert!(cut.start_ms <= from_ms);
            }
        }
    }
}
