//! The motion filter between live input and the balls, sans-IO: a fixed time step
//! `dt`; each step takes a ball's target position (or none: input lost or the ball
//! disabled, so it holds — decelerates to a stop and stays) and gives its next
//! position and velocity, so that
//! - speed ≤ the installation's top speed (and ≤ the ball's speed-limit channel, when
//!   patched: when the channel drops below the ball's speed the ball slows down at the
//!   top acceleration, the acceleration limit coming first);
//! - |acceleration| ≤ the top acceleration;
//! - the position stays within the travel [0, `travel_mm`], at every instant;
//! - a constant target is reached without overshoot or oscillation, in the least time
//!   the limits allow on the step grid (within the continuous time-optimal bound plus
//!   one step and a quarter — the quarter is the grid's own rounding: a speed ramp
//!   cannot end exactly at the top speed unless it is a multiple of `a_max·dt`, nor a
//!   short triangle exactly at its peak; a move shorter than `a_max·dt²` takes two
//!   steps, one to start and one to stop), and then held exactly.
//!
//! # How
//!
//! Each step has a constant acceleration (velocity changes by at most `h = a_max·dt`),
//! so positions between steps are the exact parabola, and a recording of the steps
//! ([`super::record`]) is a list of PVT rows a unit runs exactly as filtered.
//!
//! The tracker is time-optimal on that grid: the distance the ball needs to stop from
//! speed `u` braking at most `h` per step ([`MotionFilter::stopping_distance_mm`],
//! `B(u) = dt·(u/2 + k·u − h·k(k+1)/2)`, `k = ⌊u/h⌋`) is inverted in closed form, and
//! the next velocity is the largest one from which the ball can still stop exactly on
//! the target; then it is clamped into the step's window of acceleration, the speed
//! limit, and the velocities from which the ball can still stop inside the travel. The
//! filter also keeps every state reachable from rest inside the travel (the same
//! distance behind the ball), which is what lets a recording that starts while balls
//! move begin at rest ([`super::record`]). Braking (the hold) satisfies every one of
//! these at once, so a step always has an answer.
//!
//! A state the filter did not produce (moving towards an end faster than it can stop
//! there) is braked at the top acceleration, its position kept inside the travel.
//!
//! Limits hold up to floating-point rounding: the property tests allow 1e-6 (relative)
//! on speed, acceleration and position, nothing more.
//!
//! [`Approach`]: the plain point-to-point move from where the balls are to the first
//! live positions at the installation's approach speed, before the filter takes over.

use thiserror::Error;

use crate::motion::Trapezoid;

/// The installation's limits and the filter's step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterLimits {
    /// Lowest position, mm below the top (the top is 0).
    pub travel_mm: f64,
    /// Top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration, mm/s².
    pub max_accel_mm_s2: f64,
    /// The step, ms.
    pub dt_ms: u32,
}

impl FilterLimits {
    /// The default limits (a matrix of UFQ750 units, as
    /// [`crate::show::Limits::for_layout`] gives them) at a step of `dt_ms`.
    #[must_use]
    pub const fn default_at(dt_ms: u32) -> Self {
        Self {
            travel_mm: crate::show::DEFAULT_TRAVEL_MM,
            max_speed_mm_s: crate::show::validate::DEFAULT_MAX_SPEED_MM_S,
            max_accel_mm_s2: crate::show::validate::DEFAULT_MAX_ACCEL_MM_S2,
            dt_ms,
        }
    }
}

/// Limits the filter cannot work with.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum FilterError {
    /// A limit that is not a positive finite number (or a step of 0 ms).
    #[error("{what} must be positive and finite, found {value}")]
    Limit {
        /// Which limit.
        what: &'static str,
        /// Its value.
        value: f64,
    },
}

/// A ball's filtered position and velocity.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BallState {
    /// Position, mm below the top.
    pub position_mm: f64,
    /// Velocity, mm/s (positive = downwards).
    pub velocity_mm_s: f64,
}

impl BallState {
    /// At rest at `position_mm`.
    #[must_use]
    pub const fn at_rest(position_mm: f64) -> Self {
        Self {
            position_mm,
            velocity_mm_s: 0.0,
        }
    }
}

/// The filter: limits and step, shared by every ball (each ball's state is its own
/// [`BallState`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionFilter {
    limits: FilterLimits,
    dt_s: f64,
    /// Largest change of velocity in one step, mm/s.
    h: f64,
}

/// Within this of the target and at a speed below [`SNAP_MM_S`], the ball is on it.
const SNAP_MM: f64 = 1e-6;
const SNAP_MM_S: f64 = 1e-6;

impl MotionFilter {
    /// A filter for `limits`.
    ///
    /// # Errors
    /// [`FilterError`] if a limit is not positive and finite.
    pub fn new(limits: FilterLimits) -> Result<Self, FilterError> {
        for (what, value) in [
            ("travel_mm", limits.travel_mm),
            ("max_speed_mm_s", limits.max_speed_mm_s),
            ("max_accel_mm_s2", limits.max_accel_mm_s2),
            ("dt_ms", f64::from(limits.dt_ms)),
        ] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(FilterError::Limit { what, value });
            }
        }
        let dt_s = f64::from(limits.dt_ms) / 1000.0;
        Ok(Self {
            limits,
            dt_s,
            h: limits.max_accel_mm_s2 * dt_s,
        })
    }

    /// Its limits.
    #[must_use]
    pub const fn limits(&self) -> FilterLimits {
        self.limits
    }

    /// The step, s.
    #[must_use]
    pub const fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// How far a ball moving at `speed_mm_s` goes before it stands still, braking at
    /// the top acceleration on the step grid (at least `v²/(2·a_max)`, at most
    /// `a_max·dt²/8` more).
    #[must_use]
    pub fn stopping_distance_mm(&self, speed_mm_s: f64) -> f64 {
        let u = speed_mm_s.abs();
        let k = (u / self.h).floor();
        self.dt_s * (u / 2.0 + k * u - self.h * k * (k + 1.0) / 2.0)
    }

    /// The largest `u ≥ 0` with `(k+1)(u − h·k/2) ≤ s` (`k = ⌊u/h⌋`): the speed from
    /// which, after one more step, the ball stops `s·dt` further on (`s ≥ 0`).
    fn forward(&self, s: f64) -> f64 {
        let h = self.h;
        if s <= 0.0 {
            return 0.0;
        }
        let mut k = (((1.0 + 8.0 * s / h).sqrt() - 1.0) / 2.0).floor().max(0.0);
        if h * k * (k + 1.0) / 2.0 > s {
            k -= 1.0;
        } else if h * (k + 1.0) * (k + 2.0) / 2.0 <= s {
            k += 1.0;
        }
        s / (k + 1.0) + h * k / 2.0
    }

    /// The largest `u ≥ 0` with `k(u − h(k+1)/2) ≤ r` (`k = ⌊u/h⌋`): the speed
    /// the ball may reach this step and still have come from rest `r·dt` behind its
    /// position (plus half a step) — the backward twin of [`Self::forward`].
    fn backward(&self, r: f64) -> f64 {
        let h = self.h;
        if r < 0.0 {
            return 0.0;
        }
        let mut k = ((1.0 + (1.0 + 8.0 * r / h).sqrt()) / 2.0).floor().max(1.0);
        if k > 1.0 && h * k * (k - 1.0) / 2.0 > r {
            k -= 1.0;
        } else if h * (k + 1.0) * k / 2.0 <= r {
            k += 1.0;
        }
        r / k + h * (k + 1.0) / 2.0
    }

    /// `sign(s)·forward(|s|)`.
    fn signed_forward(&self, s: f64) -> f64 {
        if s < 0.0 {
            -self.forward(-s)
        } else {
            self.forward(s)
        }
    }

    /// One step of one ball: towards `target_mm` (clamped into the travel; `None` or
    /// not finite: hold), at most `speed_limit_mm_s` (the ball's channel, if patched)
    /// and the installation's limits.
    pub fn step(
        &self,
        state: &mut BallState,
        target_mm: Option<f64>,
        speed_limit_mm_s: Option<f64>,
    ) {
        let travel = self.limits.travel_mm;
        let (dt, h) = (self.dt_s, self.h);
        let p = if state.position_mm.is_finite() {
            state.position_mm.clamp(0.0, travel)
        } else {
            0.0
        };
        let v = if state.velocity_mm_s.is_finite() {
            state.velocity_mm_s
        } else {
            0.0
        };
        let brake = v - v.signum() * h.min(v.abs());
        // The window of this step's acceleration.
        let (mut lo, mut hi) = (v - h, v + h);
        // The speed limit, inside the window (the acceleration limit comes first).
        let mut vm = self.limits.max_speed_mm_s;
        if let Some(limit) = speed_limit_mm_s.filter(|limit| !limit.is_nan()) {
            vm = vm.min(limit.max(0.0));
        }
        if hi < -vm {
            lo = hi;
        } else if lo > vm {
            hi = lo;
        } else {
            lo = lo.max(-vm);
            hi = hi.min(vm);
        }
        // Stop inside the travel, and have come from rest inside it.
        let half = v * dt / 2.0;
        let up_forward = self.signed_forward((travel - p - half) / dt);
        let down_forward = self.signed_forward((-p - half) / dt);
        let up_backward = self.backward((p + half) / dt);
        let down_backward = -self.backward((travel - p - half) / dt);
        let lo_travel = down_forward.max(down_backward);
        let hi_travel = up_forward.min(up_backward);
        lo = lo.max(lo_travel);
        hi = hi.min(hi_travel);
        let target = target_mm
            .filter(|x| x.is_finite())
            .map(|x| x.clamp(0.0, travel));
        let wanted = match target {
            Some(x) => self.signed_forward((x - p) / dt - v / 2.0),
            None => 0.0,
        };
        let next_v = if lo <= hi {
            wanted.clamp(lo, hi)
        } else {
            brake
        };
        let mut next_p = (p + (v + next_v) * dt / 2.0).clamp(0.0, travel);
        let mut next_v = next_v;
        if let Some(x) = target
            && next_v.abs() <= SNAP_MM_S
            && (next_p - x).abs() <= SNAP_MM
            && (x - p).abs() <= SNAP_MM + (v.abs() + SNAP_MM_S) * dt
        {
            next_p = x;
            next_v = 0.0;
        } else if next_v.abs() <= SNAP_MM_S * 1e-3 && target.is_none() {
            next_v = 0.0;
        }
        state.position_mm = next_p;
        state.velocity_mm_s = next_v;
    }
}

/// The approach before live motion: every ball from where it is to its first live
/// position, each a point-to-point move at the approach speed and the top
/// acceleration; done when the longest is.
#[derive(Debug, Clone, PartialEq)]
pub struct Approach {
    moves: Vec<Trapezoid>,
    duration_s: f64,
}

impl Approach {
    /// The moves from `from` to rest at `to` (ball by ball; a ball without a target
    /// stops where it is).
    #[must_use]
    pub fn new(from: &[BallState], to: &[Option<f64>], speed_mm_s: f64, accel_mm_s2: f64) -> Self {
        let moves: Vec<Trapezoid> = from
            .iter()
            .enumerate()
            .map(|(ball, state)| {
                let target = to.get(ball).copied().flatten().unwrap_or_else(|| {
                    let stop = state.velocity_mm_s * state.velocity_mm_s / (2.0 * accel_mm_s2);
                    state.position_mm + state.velocity_mm_s.signum() * stop
                });
                Trapezoid::new(
                    state.position_mm,
                    state.velocity_mm_s,
                    target,
                    speed_mm_s,
                    accel_mm_s2,
                )
            })
            .collect();
        let duration_s = moves.iter().map(Trapezoid::duration_s).fold(0.0, f64::max);
        Self { moves, duration_s }
    }

    /// How long the approach takes, s.
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// Ball `ball`'s position and velocity `t_s` after the approach began.
    #[must_use]
    pub fn state(&self, ball: usize, t_s: f64) -> Option<BallState> {
        let kinematics = self.moves.get(ball)?.kinematics(t_s);
        Some(BallState {
            position_mm: kinematics.position,
            velocity_mm_s: kinematics.velocity,
        })
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    pub(super) const LIMITS: FilterLimits = FilterLimits::default_at(20);

    pub(super) fn filter() -> MotionFilter {
        MotionFilter::new(LIMITS).unwrap()
    }

    #[test]
    fn the_stopping_distance_is_the_grid_braking() {
        let filter = filter();
        // h = 80 mm/s per step of 20 ms.
        assert_eq!(filter.stopping_distance_mm(0.0), 0.0);
        assert!((filter.stopping_distance_mm(40.0) - 0.4).abs() < 1e-12);
        // 160 → 80 → 0: 2.4 + 0.8 mm.
        assert!((filter.stopping_distance_mm(160.0) - 3.2).abs() < 1e-12);
        assert!((filter.stopping_distance_mm(-160.0) - 3.2).abs() < 1e-12);
        for speed in [1.0, 79.0, 80.0, 81.0, 1000.0, 2000.0] {
            let continuous = speed * speed / (2.0 * 4000.0);
            let grid = filter.stopping_distance_mm(speed);
            assert!(
                grid >= continuous - 1e-12
                    && grid <= continuous + 4000.0 * 0.02 * 0.02 / 8.0 + 1e-12
            );
        }
        // forward inverts B: from forward(s), one step and a stop cover s·dt.
        for s in [0.0, 1.0, 40.0, 80.0, 1234.5, 1e6] {
            let u = filter.forward(s);
            let covered = u * filter.dt_s() / 2.0 + filter.stopping_distance_mm(u);
            assert!(
                (covered - s * filter.dt_s()).abs() < 1e-9 * s.max(1.0),
                "{s}"
            );
        }
        for r in [0.0, 1.0, 80.0, 1234.5, 1e6] {
            let u = filter.backward(r);
            let back = filter.stopping_distance_mm(u) - u * filter.dt_s() / 2.0;
            assert!(
                (back - r * filter.dt_s()).abs() < 1e-9 * r.max(1.0) || u < filter.h,
                "{r}"
            );
        }
    }

    #[test]
    fn a_speed_limit_channel_slows_the_ball_at_the_top_acceleration() {
        let filter = filter();
        let mut state = BallState::at_rest(0.0);
        for _ in 0..40 {
            filter.step(&mut state, Some(7500.0), None);
        }
        assert_eq!(state.velocity_mm_s, 2000.0);
        filter.step(&mut state, Some(7500.0), Some(500.0));
        assert_eq!(state.velocity_mm_s, 1920.0, "one step of a_max·dt slower");
        for _ in 0..30 {
            filter.step(&mut state, Some(7500.0), Some(500.0));
        }
        assert_eq!(state.velocity_mm_s, 500.0);
        filter.step(&mut state, Some(7500.0), Some(0.0));
        assert_eq!(state.velocity_mm_s, 420.0);
    }

    #[test]
    fn limits_must_be_positive() {
        assert!(MotionFilter::new(FilterLimits { dt_ms: 0, ..LIMITS }).is_err());
        assert!(
            MotionFilter::new(FilterLimits {
                travel_mm: f64::NAN,
                ..LIMITS
            })
            .is_err()
        );
        assert!(
            MotionFilter::new(FilterLimits {
                max_accel_mm_s2: -1.0,
                ..LIMITS
            })
            .is_err()
        );
    }

    #[test]
    fn the_approach_brings_every_ball_to_rest_on_its_target() {
        let from = [
            BallState::at_rest(0.0),
            BallState {
                position_mm: 3000.0,
                velocity_mm_s: -500.0,
            },
        ];
        let approach = Approach::new(&from, &[Some(1000.0), None], 500.0, 4000.0);
        // Ball 0: 1000 mm at 500 mm/s, accelerating 0.125 s each way: 2.125 s.
        assert!((approach.duration_s() - 2.125).abs() < 1e-9);
        assert_eq!(approach.state(0, 2.125), Some(BallState::at_rest(1000.0)));
        let stopped = approach.state(1, 1.0).unwrap();
        assert!((stopped.position_mm - (3000.0 - 500.0 * 500.0 / 8000.0)).abs() < 1e-9);
        assert_eq!(stopped.velocity_mm_s, 0.0);
        assert_eq!(approach.state(2, 0.0), None);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::tests::{LIMITS, filter};
    use super::*;

    /// Relative tolerance of every limit: floating-point rounding only.
    const EPS: f64 = 1e-6;

    /// One step from `before` to `after` keeps every limit, at every instant (the
    /// step is a parabola: its speed peaks at an end, its position at an end or where
    /// it turns).
    fn check_step(filter: &MotionFilter, before: BallState, after: BallState, vm: f64) {
        let limits = filter.limits();
        let dt = filter.dt_s();
        let (v0, v1) = (before.velocity_mm_s, after.velocity_mm_s);
        let accel = (v1 - v0) / dt;
        assert!(
            accel.abs() <= limits.max_accel_mm_s2 * (1.0 + EPS),
            "acceleration {accel} from {before:?} to {after:?}"
        );
        assert!(v1.abs() <= vm * (1.0 + EPS) + EPS, "speed {v1} above {vm}");
        let moved = after.position_mm - before.position_mm;
        assert!(
            (moved - (v0 + v1) / 2.0 * dt).abs() <= EPS * limits.travel_mm,
            "not a parabola: {before:?} → {after:?}"
        );
        let mut extremes = vec![before.position_mm, after.position_mm];
        if v0 * v1 < 0.0 {
            extremes.push(before.position_mm - v0 * v0 / (2.0 * accel));
        }
        for position in extremes {
            assert!(
                (-EPS..=limits.travel_mm * (1.0 + EPS)).contains(&position),
                "position {position} outside the travel ({before:?} → {after:?})"
            );
        }
    }

    /// Continuous time-optimal rest-to-rest time over `distance`, s.
    fn optimal_s(distance: f64, limits: FilterLimits) -> f64 {
        let (v, a) = (limits.max_speed_mm_s, limits.max_accel_mm_s2);
        if distance >= v * v / a {
            distance / v + v / a
        } else {
            2.0 * (distance / a).sqrt()
        }
    }

    #[derive(Debug, Clone)]
    enum Input {
        /// A target (a fader's value, a jump).
        At(f64),
        /// Input lost.
        Lost,
    }

    fn input() -> impl Strategy<Value = Input> {
        prop_oneof![
            6 => (0.0..7500.0f64).prop_map(Input::At),
            1 => (-1000.0..9000.0f64).prop_map(Input::At),
            1 => Just(Input::Lost),
        ]
    }

    /// A sequence of inputs, each held for some steps, with noise.
    fn inputs() -> impl Strategy<Value = Vec<(Input, u8, f64, Option<f64>)>> {
        prop::collection::vec(
            (
                input(),
                1..40u8,
                -5.0..5.0f64,
                prop_oneof![3 => Just(None), 1 => (0.0..2500.0f64).prop_map(Some)],
            ),
            1..30,
        )
    }

    proptest! {
        #[test]
        fn no_step_breaks_a_limit_for_any_input(
            start in 0.0..7500.0f64,
            runs in inputs(),
            dt_ms in 10..100u32,
        ) {
            let filter = MotionFilter::new(FilterLimits { dt_ms, ..LIMITS }).unwrap();
            let mut state = BallState::at_rest(start);
            for (input, steps, noise, speed_limit) in runs {
                for step in 0..steps {
                    let target = match input {
                        Input::At(x) => Some(x + noise * f64::from(step % 3)),
                        Input::Lost => None,
                    };
                    let before = state;
                    filter.step(&mut state, target, speed_limit);
                    // The speed limit of a channel is met once the ball had time to
                    // slow down to it; the installation's always.
                    let vm = speed_limit.map_or(LIMITS.max_speed_mm_s, |limit| {
                        limit.min(LIMITS.max_speed_mm_s)
                    });
                    let allowed = vm
                        .max(before.velocity_mm_s.abs() - filter.h)
                        .min(LIMITS.max_speed_mm_s);
                    check_step(&filter, before, state, allowed);
                }
            }
        }

        #[test]
        fn a_constant_target_is_reached_in_optimal_time_and_held_exactly(
            start in 0.0..7500.0f64,
            target in 0.0..7500.0f64,
            dt_ms in 10..60u32,
        ) {
            let filter = MotionFilter::new(FilterLimits { dt_ms, ..LIMITS }).unwrap();
            let mut state = BallState::at_rest(start);
            // One step for the grid, and a quarter more: a speed ramp on the grid
            // cannot end exactly at the top speed (at most a_max·dt²/8 mm lost per
            // ramp, a_max·dt/(4·v_max) ≤ 1/4 step for both), nor a triangle exactly
            // at its peak (at most 2m + 2 − 2√(m(m+1)) − 1 ≤ 0.17 step for a move of
            // 2m + 2 ≥ 4 steps). A move shorter than a_max·dt² takes two steps (one
            // to start, one to stop), however short.
            let distance = (target - start).abs();
            let bound_s = if distance > LIMITS.max_accel_mm_s2 * filter.dt_s().powi(2) {
                optimal_s(distance, LIMITS) + 1.25 * filter.dt_s()
            } else {
                2.0 * filter.dt_s()
            };
            let steps = (bound_s / filter.dt_s()).floor() as usize + 1;
            let direction = (target - start).signum();
            let mut reached = None;
            for step in 1..=steps + 20 {
                let before = state;
                filter.step(&mut state, Some(target), None);
                check_step(&filter, before, state, LIMITS.max_speed_mm_s);
                // Never past the target, never back.
                prop_assert!((target - state.position_mm) * direction >= -1e-9);
                prop_assert!(state.velocity_mm_s * direction >= -1e-9);
                if reached.is_none() && state.position_mm == target && state.velocity_mm_s == 0.0 {
                    reached = Some(step);
                }
                if let Some(at) = reached {
                    prop_assert_eq!(state, BallState::at_rest(target), "held after step {}", at);
                }
            }
            let at = reached.expect("reached");
            prop_assert!(
                at as f64 * filter.dt_s() <= bound_s + 1e-9,
                "{} steps of {} ms, bound {} s", at, dt_ms, bound_s
            );
        }

        #[test]
        fn after_input_loss_the_ball_comes_to_rest_within_its_braking_distance(
            start in 0.0..7500.0f64,
            target in 0.0..7500.0f64,
            moving_steps in 1..100usize,
        ) {
            let filter = filter();
            let mut state = BallState::at_rest(start);
            for _ in 0..moving_steps {
                filter.step(&mut state, Some(target), None);
            }
            let lost = state;
            let v = lost.velocity_mm_s.abs();
            let a = LIMITS.max_accel_mm_s2;
            let mut steps = 0;
            while state.velocity_mm_s != 0.0 {
                let before = state;
                filter.step(&mut state, None, None);
                check_step(&filter, before, state, LIMITS.max_speed_mm_s);
                steps += 1;
                prop_assert!(steps < 1000);
            }
            let distance = (state.position_mm - lost.position_mm).abs();
            prop_assert!(distance <= v * v / (2.0 * a) + v * filter.dt_s() + 1e-9);
            prop_assert!(steps as f64 * filter.dt_s() <= v / a + filter.dt_s() + 1e-9);
            // And it stays.
            let rest = state;
            filter.step(&mut state, None, None);
            prop_assert_eq!(state, rest);
        }
    }
}
