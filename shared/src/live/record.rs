//! Recording live motion as a show, sans-IO: [`Recorder`] collects the filtered
//! position and velocity of every ball each step ([`super::filter`]) and, optionally,
//! its colour, and [`Recorder::finish`] gives a [`Show`] in the native format, which
//! then plays, previews and uploads like any other.
//!
//! The show is within the installation's limits by construction:
//! - every filter step has a constant acceleration, so the PVT row from one step to
//!   the next (a cubic Hermite segment, [`crate::motion::Segment`]) is exactly the
//!   filtered parabola: the speed, acceleration and travel the filter kept are the
//!   show's; consecutive steps of equal acceleration become one row (up to 255 ms),
//!   so a ball at rest, cruising or braking hard costs a row per 255 ms;
//! - a show starts at rest, and a recording may start while balls move: each ball's
//!   track begins with a lead-in from rest, speeding up at the top acceleration on the
//!   step grid to the state it had when recording began (the filter keeps every state
//!   reachable that way inside the travel); balls with shorter lead-ins wait at rest,
//!   so every ball reaches its recorded start at the same show time,
//!   [`Recorder::lead_in_ms`];
//! - a show ends at rest: [`Recorder::finish`] brakes every ball as the filter holds
//!   (at the top acceleration) and pads every track to the same duration.
//!
//! Rows must last 10–255 ms, so the filter's step must too ([`RecordError::Step`]).

use thiserror::Error;

use super::filter::{BallState, MotionFilter};
use crate::show::{ColourKey, Layout, Show, Track, TrackRow};
use crate::uim2503::pvt::{ROW_MAX_MS as ROW_MAX, ROW_MIN_MS as ROW_MIN};

/// Shortest row, ms.
const ROW_MIN_MS: u32 = ROW_MIN as u32;
/// Longest row, ms.
const ROW_MAX_MS: u32 = ROW_MAX as u32;

/// Why a recording cannot start.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum RecordError {
    /// The filter's step is not a row duration units accept.
    #[error("a step of {dt_ms} ms cannot be recorded: rows last {min_ms}-{max_ms} ms")]
    Step {
        /// The step.
        dt_ms: u32,
        /// Shortest row.
        min_ms: u32,
        /// Longest row.
        max_ms: u32,
    },
    /// Not one state per ball of the layout.
    #[error("{states} ball states for a layout of {balls} balls")]
    Balls {
        /// States given.
        states: usize,
        /// Balls of the layout.
        balls: usize,
    },
}

/// One ball's recorded track.
#[derive(Debug, Clone)]
struct Recording {
    start_mm: f64,
    rows: Vec<TrackRow>,
    /// Where the last row begins (position and velocity).
    row_start: BallState,
    /// Where the last row ends.
    last: BallState,
    colours: Vec<ColourKey>,
    rgb: Option<[u8; 3]>,
}

impl Recording {
    fn at_rest(position_mm: f64) -> Self {
        Self {
            start_mm: position_mm,
            rows: Vec::new(),
            row_start: BallState::at_rest(position_mm),
            last: BallState::at_rest(position_mm),
            colours: Vec::new(),
            rgb: None,
        }
    }

    /// Appends the step from the last state to `next` over `dt_ms`, as a new row or by
    /// extending the last one when the acceleration is the same.
    fn push(&mut self, next: BallState, dt_ms: u32) {
        let dt_s = f64::from(dt_ms) / 1000.0;
        let accel = (next.velocity_mm_s - self.last.velocity_mm_s) / dt_s;
        if let Some(row) = self.rows.last_mut() {
            let row_s = f64::from(row.duration_ms) / 1000.0;
            let row_accel = (self.last.velocity_mm_s - self.row_start.velocity_mm_s) / row_s;
            if row.duration_ms + dt_ms <= ROW_MAX_MS
                && (accel - row_accel).abs() <= 1e-9 * (1.0 + accel.abs())
            {
                row.position_mm = next.position_mm;
                row.velocity_mm_s = next.velocity_mm_s;
                row.duration_ms += dt_ms;
                self.last = next;
                return;
            }
        }
        self.rows
            .push(TrackRow::new(next.position_mm, next.velocity_mm_s, dt_ms));
        self.row_start = self.last;
        self.last = next;
    }
}

/// Collects live motion into a show.
#[derive(Debug, Clone)]
pub struct Recorder {
    name: String,
    layout: Layout,
    filter: MotionFilter,
    dt_ms: u32,
    lead_in_steps: u64,
    steps: u64,
    /// The time the steps recorded so far last, ms.
    recorded_ms: u64,
    balls: Vec<Recording>,
}

impl Recorder {
    /// Starts recording `states` (one per ball of `layout`, row-major) as they are
    /// now; `filter` is the one that moves them.
    ///
    /// # Errors
    /// [`RecordError`] if the filter's step is no row duration or the states do not
    /// match the layout.
    pub fn new(
        name: impl Into<String>,
        layout: Layout,
        filter: MotionFilter,
        states: &[BallState],
    ) -> Result<Self, RecordError> {
        let dt_ms = filter.limits().dt_ms;
        if !(ROW_MIN_MS..=ROW_MAX_MS).contains(&dt_ms) {
            return Err(RecordError::Step {
                dt_ms,
                min_ms: ROW_MIN_MS,
                max_ms: ROW_MAX_MS,
            });
        }
        if states.len() != layout.unit_count() {
            return Err(RecordError::Balls {
                states: states.len(),
                balls: layout.unit_count(),
            });
        }
        let travel = filter.limits().travel_mm;
        let h = filter.limits().max_accel_mm_s2 * filter.dt_s();
        // Each ball's lead-in: its grid velocities from rest up to its speed now.
        let lead_ins: Vec<Vec<f64>> = states
            .iter()
            .map(|state| {
                // A filter's state is finite; anything else has no lead-in.
                let speed = if state.velocity_mm_s.is_finite() {
                    state.velocity_mm_s.abs()
                } else {
                    0.0
                };
                let mut speeds = Vec::new();
                let mut at = speed;
                while at > 0.0 {
                    speeds.push(at);
                    at = (at - h).max(0.0);
                }
                speeds.reverse();
                speeds
                    .into_iter()
                    .map(|speed| speed.copysign(state.velocity_mm_s))
                    .collect()
            })
            .collect();
        let lead_in_steps = lead_ins.iter().map(Vec::len).max().unwrap_or(0);
        let balls = states
            .iter()
            .zip(&lead_ins)
            .map(|(state, speeds)| {
                let rest = if speeds.is_empty() {
                    state.position_mm.clamp(0.0, travel)
                } else {
                    let behind = filter.stopping_distance_mm(state.velocity_mm_s);
                    (state.position_mm - state.velocity_mm_s.signum() * behind).clamp(0.0, travel)
                };
                let mut recording = Recording::at_rest(rest);
                for _ in speeds.len()..lead_in_steps {
                    recording.push(BallState::at_rest(rest), dt_ms);
                }
                let mut position = rest;
                let mut velocity = 0.0;
                for (i, &next) in speeds.iter().enumerate() {
                    position += (velocity + next) * filter.dt_s() / 2.0;
                    velocity = next;
                    let step = if i + 1 == speeds.len() {
                        *state
                    } else {
                        BallState {
                            position_mm: position,
                            velocity_mm_s: velocity,
                        }
                    };
                    recording.push(step, dt_ms);
                }
                recording
            })
            .collect();
        Ok(Self {
            name: name.into(),
            layout,
            filter,
            dt_ms,
            lead_in_steps: lead_in_steps as u64,
            steps: 0,
            recorded_ms: 0,
            balls,
        })
    }

    /// The show time at which the recorded motion begins (after the lead-ins), ms.
    #[must_use]
    pub fn lead_in_ms(&self) -> u64 {
        self.lead_in_steps * u64::from(self.dt_ms)
    }

    /// Steps recorded so far.
    #[must_use]
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// The time the steps recorded so far last, ms (after the lead-ins).
    #[must_use]
    pub fn recorded_ms(&self) -> u64 {
        self.recorded_ms
    }

    /// Records one filter step: every ball's state after it, and its colour (an empty
    /// slice, or `None` for a ball: no colour this step).
    pub fn push(&mut self, states: &[BallState], colours: &[Option<[u8; 3]>]) {
        self.push_step(states, colours, self.dt_ms);
    }

    /// Records one filter step of `dt_ms` (a step re-timed to a change of the input
    /// may be shorter than the filter's, [`crate::player::live`]; clamped into a
    /// row's 10–255 ms): as [`Recorder::push`].
    pub fn push_step(&mut self, states: &[BallState], colours: &[Option<[u8; 3]>], dt_ms: u32) {
        let dt_ms = dt_ms.clamp(ROW_MIN_MS, ROW_MAX_MS);
        self.steps += 1;
        self.recorded_ms += u64::from(dt_ms);
        let time_ms = self.lead_in_ms() + self.recorded_ms;
        for (ball, recording) in self.balls.iter_mut().enumerate() {
            let state = states.get(ball).copied().unwrap_or(recording.last);
            recording.push(state, dt_ms);
            if let Some(rgb) = colours.get(ball).copied().flatten()
                && recording.rgb != Some(rgb)
            {
                recording.rgb = Some(rgb);
                recording.colours.push(ColourKey { time_ms, rgb });
            }
        }
    }

    /// The show: every ball braked to rest, every track as long as the longest.
    #[must_use]
    pub fn finish(mut self) -> Show {
        let mut longest = 0u64;
        let mut braked: Vec<u64> = Vec::with_capacity(self.balls.len());
        for recording in &mut self.balls {
            let mut steps = 0u64;
            let mut state = recording.last;
            while state.velocity_mm_s != 0.0 && steps < 100_000 {
                self.filter.step(&mut state, None, None);
                recording.push(state, self.dt_ms);
                steps += 1;
            }
            longest = longest.max(steps);
            braked.push(steps);
        }
        let tracks = self
            .balls
            .into_iter()
            .zip(braked)
            .map(|(mut recording, steps)| {
                for _ in steps..longest {
                    let rest = BallState::at_rest(recording.last.position_mm);
                    recording.push(rest, self.dt_ms);
                }
                Track {
                    start_mm: recording.start_mm,
                    rows: recording.rows,
                    colours: recording.colours,
                }
            })
            .collect();
        Show {
            outputs: Vec::new(),
            name: self.name,
            layout: self.layout,
            tracks,
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::filter::FilterLimits;
    use super::*;
    use crate::show::{Limits, validate};

    pub(super) const LIMITS: FilterLimits = FilterLimits::default_at(20);

    pub(super) const LAYOUT: Layout = Layout {
        rows: 2,
        cols: 3,
        pitch_mm: 500.0,
    };

    pub(super) fn limits() -> Limits {
        Limits {
            travel_mm: LIMITS.travel_mm,
            max_speed_mm_s: LIMITS.max_speed_mm_s,
            max_accel_mm_s2: LIMITS.max_accel_mm_s2,
            rows: LAYOUT.rows,
            cols: LAYOUT.cols,
        }
    }

    #[test]
    fn a_recording_started_while_moving_begins_at_rest_inside_the_travel() {
        let filter = MotionFilter::new(LIMITS).unwrap();
        // Three balls: leaving the top as fast as they can, at full speed upwards,
        // and at rest.
        let mut states = vec![
            BallState::at_rest(0.0),
            BallState::at_rest(7000.0),
            BallState::at_rest(300.0),
            BallState::at_rest(0.0),
            BallState::at_rest(7500.0),
            BallState::at_rest(10.0),
        ];
        let targets = [
            Some(7500.0),
            Some(0.0),
            None,
            Some(7500.0),
            Some(0.0),
            Some(10.0),
        ];
        for _ in 0..3 {
            for (state, target) in states.iter_mut().zip(targets) {
                filter.step(state, target, None);
            }
        }
        assert_eq!(states[0].velocity_mm_s, 240.0);
        let recorder = Recorder::new("moving", LAYOUT, filter, &states).unwrap();
        assert_eq!(recorder.lead_in_ms(), 60);
        let show = recorder.finish();
        assert_eq!(show.tracks[0].start_mm, 0.0, "it came from rest at the top");
        assert_eq!(show.tracks[2].start_mm, 300.0);
        assert!(validate(&show, &limits()).is_empty());
        // Rows of equal acceleration are merged: ball 2 at rest is one row per 255 ms.
        assert!(show.tracks[2].rows.len() <= 2, "{:?}", show.tracks[2].rows);
    }

    #[test]
    fn refuses_steps_that_are_no_row_and_a_wrong_ball_count() {
        let fast = MotionFilter::new(FilterLimits { dt_ms: 5, ..LIMITS }).unwrap();
        assert_eq!(
            Recorder::new("x", LAYOUT, fast, &[BallState::default(); 6]).err(),
            Some(RecordError::Step {
                dt_ms: 5,
                min_ms: 10,
                max_ms: 255
            })
        );
        let filter = MotionFilter::new(LIMITS).unwrap();
        assert_eq!(
            Recorder::new("x", LAYOUT, filter, &[BallState::default(); 5]).err(),
            Some(RecordError::Balls {
                states: 5,
                balls: 6
            })
        );
    }

    /// A step re-timed to a change of live input (`crate::player::live`) is shorter
    /// than the filter's: it is recorded as a row of its own length, and the show
    /// passes through its state at that time.
    #[test]
    fn a_shorter_step_is_recorded_for_its_time() {
        let filter = MotionFilter::new(LIMITS).unwrap();
        let short = MotionFilter::new(FilterLimits {
            dt_ms: 13,
            ..LIMITS
        })
        .unwrap();
        let mut states = vec![BallState::at_rest(1000.0); 6];
        let mut recorder = Recorder::new("x", LAYOUT, filter, &states).unwrap();
        for state in &mut states {
            short.step(state, Some(3000.0), None);
        }
        let after_short = states[0];
        recorder.push_step(&states, &[], 13);
        for _ in 0..50 {
            for state in &mut states {
                filter.step(state, Some(3000.0), None);
            }
            recorder.push(&states, &[]);
        }
        assert_eq!(recorder.recorded_ms(), 13 + 50 * 20);
        let show = recorder.finish();
        assert!(validate(&show, &limits()).is_empty());
        let mut sampler = crate::show::Sampler::new(&show);
        let mut at = [0.0f32; 6];
        sampler.sample(13.0, &mut at, None);
        assert!((f64::from(at[0]) - after_short.position_mm).abs() < 1e-3);
        sampler.sample(1013.0, &mut at, None);
        assert!((f64::from(at[0]) - states[0].position_mm).abs() < 1e-3);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::super::filter::FilterLimits;
    use super::tests::{LAYOUT, LIMITS, limits};
    use super::*;
    use crate::show::validate;

    /// A fader: a target per step, jumping now and then, some steps lost.
    fn faders() -> impl Strategy<Value = Vec<Vec<Option<f64>>>> {
        prop::collection::vec(
            prop::collection::vec(
                prop_oneof![8 => (0.0..7500.0f64).prop_map(Some), 1 => Just(None)],
                6,
            ),
            1..12,
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]

        /// A random-fader run, recording from the middle of it (balls moving), gives a
        /// show `validate` accepts.
        #[test]
        fn a_recorded_random_fader_run_validates(
            starts in prop::collection::vec(0.0..7500.0f64, 6),
            before in faders(),
            during in faders(),
            hold_steps in 1..30usize,
            dt_ms in 10..60u32,
        ) {
            let filter = MotionFilter::new(FilterLimits { dt_ms, ..LIMITS }).unwrap();
            let mut states: Vec<BallState> = starts.iter().map(|&p| BallState::at_rest(p)).collect();
            let run = |states: &mut Vec<BallState>, faders: &[Vec<Option<f64>>], recorder: Option<&mut Recorder>| {
                let mut recorder = recorder;
                for targets in faders {
                    for _ in 0..hold_steps {
                        for (state, target) in states.iter_mut().zip(targets) {
                            filter.step(state, *target, None);
                        }
                        if let Some(recorder) = recorder.as_deref_mut() {
                            let colours: Vec<Option<[u8; 3]>> = targets
                                .iter()
                                .map(|t| t.map(|x| [(x / 30.0) as u8, 0, 255]))
                                .collect();
                            recorder.push(states, &colours);
                        }
                    }
                }
            };
            run(&mut states, &before, None);
            let mut recorder = Recorder::new("live", LAYOUT, filter, &states).unwrap();
            run(&mut states, &during, Some(&mut recorder));
            let steps = recorder.steps();
            let lead_in_ms = recorder.lead_in_ms();
            let show = recorder.finish();
            let violations = validate(&show, &limits());
            prop_assert!(violations.is_empty(), "{:?}", &violations[..violations.len().min(3)]);
            prop_assert!(show.duration_ms() >= lead_in_ms + steps * u64::from(dt_ms));
            // The recorded part is the filtered motion: at the end of the recorded
            // steps, each track is where its ball was.
            let sampler = show.tracks.iter().map(|track| {
                let at_ms = lead_in_ms + steps * u64::from(dt_ms);
                let mut elapsed = 0;
                let mut position = track.start_mm;
                for row in &track.rows {
                    if elapsed >= at_ms { break; }
                    elapsed += u64::from(row.duration_ms);
                    position = row.position_mm;
                }
                (elapsed, position)
            });
            for ((elapsed, position), state) in sampler.zip(&states) {
                if elapsed == lead_in_ms + steps * u64::from(dt_ms) {
                    prop_assert!((position - state.position_mm).abs() < 1e-6);
                }
            }
        }
    }
}
