//! Smooth shows (issue 34, item 2): every stretch the ball moves one way between two
//! turning points (or rests) is a **jog** whose speed is changed every `step_s`, so the
//! ball glides through the show instead of stopping at every keyframe. Only buffered
//! commands, as a stored program must hold (HCR p. 13), the way HCR p. 64 stops a jog
//! inside a program (`MT1`, set in segment 1, so that `CJ` does not hold the program):
//!
//! ```text
//! DI-1          the direction (the sign of DI, HCR p. 64)
//! JS0.4125      the speed for the first step, rev/s
//! CJ            jog: speeds up at JA (HCR p. 64)
//! WT0.15        one step
//! RXJ-192       the next velocity in the J register: 0.25 rpm steps, signed as CS
//!               (HCR p. 64, p. 71); reached at JA (faster) or JL (slower)
//! WT0.15
//! …
//! RXJ-51        the last velocity …
//! WT0.08        … for this long, then
//! SMD           slow down to rest at JL (HCR p. 250)
//! WM            and wait until the motor stands (HCR p. 272)
//! DI250000      then, from where it stopped, exactly to the keyframe's count
//! FP
//! WM
//! ```
//!
//! Each speed is solved so that the ball is where the show is at the end of its step,
//! from where the drive really is: the speed as the drive holds it (a whole step of
//! 1/240 rev/s) and the ramp at `JA`/`JL` as the drive runs it (the twin's
//! [`Profile`]), so the rounding of one speed is taken back by the next and the
//! position never drifts. The last speed and when `SM` comes are chosen so that the
//! stop ends at the keyframe's count as close to its time as the steps allow; the
//! `FP` then takes the drive the fraction of a count (or few counts) left. Where the
//! show rests, `WT`; a stretch too short for two steps is an `FP` from rest to rest.
//!
//! A **stream** ([`super::stream`]) glides: it does not stop at the show's turning
//! points but turns the ball round with the sign of `J` (HCR p. 71: the sign is the
//! direction), each step's velocity solved signed — aimed at where the show is two
//! steps on and held for both, so that catching up does not overshoot — from rest
//! to the next rest; a
//! stretch too fast to make in its time is made at the top speed, late, rather than
//! refused (the report counts it).
//!
//! `JA` = `JL` is set once in segment 1, before any jog (HCR p. 150/155: not while
//! jogging): 1.5 × the show's largest acceleration (within the installation's limit).
//! The step is the shortest (a multiple of 10 ms, at least [`MIN_STEP_S`]) whose
//! lines fit the drive. How a drive ramps from one jog speed to the next (at
//! `JA`/`JL`, through 0 when the sign changes) is our reading of HCR p. 71 for `CS`,
//! taken for the `J` register too: `docs/protocol-notes.md` §8.

use super::keyframes::Samples;
use super::reduce::{Limits, Step, plan_step};
use super::{Keyframe, QProgram, QProgramConfig, QProgramError, Timed, Writer};
use crate::scl::command::{Command, Decimal, Register, StopRate};
use crate::scl::twin::Profile;
use crate::scl::units;
use crate::show::Track;

/// The shortest step between two speed changes, s.
pub(super) const MIN_STEP_S: f64 = 0.05;

/// How a program jogs: `JA` = `JL`, and the step between speed changes.
#[derive(Debug, Clone, Copy)]
pub(super) struct Plan {
    /// `JA` and `JL`, as written.
    pub accel: Decimal,
    /// The step between speed changes, s (a multiple of 10 ms).
    pub step_s: f64,
}

/// `JA` = `JL` for `samples`: 1.5 × the show's largest acceleration (second
/// differences over 10 ms), at most the limit, at least the smallest step.
pub(super) fn accel(samples: &Samples, config: &QProgramConfig) -> Option<Decimal> {
    let stride = 10;
    let p = &samples.positions_mm;
    let mut largest: f64 = 0.0;
    for k in stride..p.len().saturating_sub(stride) {
        let dt_s = (samples.times_ms[k + stride] - samples.times_ms[k - stride]) as f64 / 2000.0;
        if dt_s > 0.0 {
            let a = (p[k + stride] - 2.0 * p[k] + p[k - stride]) / (dt_s * dt_s);
            largest = largest.max(a.abs());
        }
    }
    let mm_s2 = (1.5 * largest).min(config.max_accel_mm_s2);
    let rev_s2 = mm_s2 * config.counts_per_mm / f64::from(config.steps_per_rev);
    let steps = ((rev_s2 / units::ACCELERATION.step + 1e-9).floor() as i64)
        .clamp(units::ACCELERATION.min_steps, units::ACCELERATION.max_steps);
    units::ACCELERATION.write(steps)
}

/// How many steps on a stream aims each step's velocity.
const STREAM_HORIZON_STEPS: f64 = 2.0;

/// The jog velocity's register (HCR p. 64).
const JOG_REGISTER: char = 'J';

/// The step that fits `budget_lines`: each stretch costs about 11 lines and two a step.
pub(super) fn step_for(counts: &[i64], times_s: &[f64], budget_lines: usize) -> f64 {
    let (mut moving_s, mut stretches, mut rests) = (0.0, 0_usize, 0_usize);
    let mut last = 0_i64;
    for (c, t) in counts.windows(2).zip(times_s.windows(2)) {
        let direction = (c[1] - c[0]).signum();
        if direction == 0 {
            rests += 1;
        } else {
            moving_s += t[1] - t[0];
            if direction != last {
                stretches += 1;
            }
        }
        last = direction;
    }
    let room = budget_lines.saturating_sub(11 * stretches + rests).max(1) as f64;
    let step_s = (2.0 * moving_s / room).max(MIN_STEP_S);
    (step_s * 100.0).ceil() / 100.0
}

/// A speed (counts/s, not negative) as the drive holds it: whole steps, at least one;
/// the steps (1/240 rev/s, the `J` register's 0.25 rpm), `JS`'s text and counts/s.
fn held_speed(counts_s: f64, steps_per_rev: f64, max_steps: i64) -> (i64, Decimal, f64) {
    let unit = units::VELOCITY.step * steps_per_rev;
    let steps = ((counts_s / unit).round() as i64).clamp(units::VELOCITY.min_steps, max_steps);
    let written = units::VELOCITY.write(steps).unwrap_or(Decimal::from_int(0));
    (steps, written, steps as f64 * unit)
}

/// The smallest `x ≥ 0` where `f` (rising) reaches 0, by bisection within `[0, high]`.
fn solve(high: f64, f: impl Fn(f64) -> f64) -> f64 {
    if f(0.0) >= 0.0 {
        return 0.0;
    }
    if f(high) <= 0.0 {
        return high;
    }
    let (mut low, mut high) = (0.0, high);
    for _ in 0..60 {
        let middle = 0.5 * (low + high);
        if f(middle) < 0.0 {
            low = middle;
        } else {
            high = middle;
        }
    }
    0.5 * (low + high)
}

impl Writer<'_> {
    /// The show's position at `t_s`, counts (the sample at the nearest ms, held at
    /// the ends).
    fn show_counts(&self, samples: &Samples, t_s: f64) -> f64 {
        let last = samples.times_ms.len().saturating_sub(1);
        let index = samples
            .times_ms
            .partition_point(|&t_ms| (t_ms as f64) < t_s * 1000.0 - 0.5)
            .min(last);
        samples.positions_mm[index] * self.config.counts_per_mm
    }

    /// Jogs from where the drive stands (at rest, `self.at_counts`, at `self.now_s`) to
    /// `to_counts`, arriving at `target_ms` as near as the steps allow.
    #[allow(clippy::too_many_lines)]
    fn jog_to(
        &mut self,
        samples: &Samples,
        plan: &Plan,
        to_counts: i64,
        target_ms: u64,
    ) -> Result<(), QProgramError> {
        let steps_per_rev = self.limits.steps_per_rev;
        let rate = units::ACCELERATION.held(plan.accel).unwrap_or(0.0) * steps_per_rev;
        let max_steps = ((self.limits.max_speed_counts_s / (units::VELOCITY.step * steps_per_rev))
            .floor() as i64)
            .clamp(units::VELOCITY.min_steps, units::VELOCITY.max_steps);
        let max_speed = max_steps as f64 * units::VELOCITY.step * steps_per_rev;
        let target_s = target_ms as f64 / 1000.0;
        // A stream glides through its turning points (the sign of `J` turns the ball
        // round, HCR p. 71): its first way is where the show goes first.
        let first_way = if self.streamed {
            self.show_counts(samples, self.now_s + plan.step_s) - self.at_counts as f64
        } else {
            (to_counts - self.at_counts) as f64
        };
        let direction: f64 = if first_way >= 0.0 { 1.0 } else { -1.0 };
        let at_ms = target_ms;
        let out_of_range = |counts: i64| QProgramError::OutOfRange {
            at_ms,
            position_mm: counts as f64 / self.config.counts_per_mm,
        };
        let counts = i32::try_from(to_counts).map_err(|_| out_of_range(to_counts))?;
        self.lines.push(Command::Distance {
            counts: Some(if direction > 0.0 { 1 } else { -1 }),
        });
        let (mut x, mut v) = (self.at_counts as f64, 0.0);
        let mut jogging = false;
        let step = plan.step_s;
        // Every step but the last: the speed that puts the ball where the show is at
        // the step's end.
        while target_s - self.now_s >= 1.5 * step {
            let t_next = self.now_s + step;
            let want = self.show_counts(samples, t_next);
            let velocity = if self.streamed {
                // Signed: where the ball is rises with the velocity. Aimed at the
                // show some steps on, held for them, so that catching up does not
                // overshoot (the next step aims again).
                let horizon_s = STREAM_HORIZON_STEPS * step;
                let ahead = self.show_counts(samples, self.now_s + horizon_s);
                solve(2.0 * max_speed, |shifted| {
                    let (end, _) =
                        Profile::run(x, v, shifted - max_speed, rate, rate).at(horizon_s);
                    end - ahead
                }) - max_speed
            } else {
                direction
                    * solve(max_speed, |speed| {
                        let (end, _) = Profile::run(x, v, direction * speed, rate, rate).at(step);
                        direction * (end - want)
                    })
            };
            (x, v) = self.jog_for(
                (x, v),
                &mut jogging,
                velocity,
                step,
                (rate, steps_per_rev, max_steps),
            );
        }
        // The last speed and the wait before `SJ`: the stop ends at `to_counts`, as
        // near `target_s` as the 10 ms of `WT` allow.
        let goal = to_counts as f64;
        // (A glide comes to its end from either side.)
        let direction = if self.streamed {
            if goal >= x { 1.0 } else { -1.0 }
        } else {
            direction
        };
        let left_s = (target_s - self.now_s).max(0.0);
        let mut best: Option<(f64, f64, f64)> = None; // (|late|, wait, speed)
        let waits = (left_s / units::WAIT.step).round() as i64;
        for hundredths in 0..=waits.max(0) {
            let wait_s = hundredths as f64 * units::WAIT.step;
            let stop_at = |speed: f64| {
                let (x1, v1) = if hundredths == 0 {
                    (x, v)
                } else {
                    Profile::run(x, v, direction * speed, rate, rate).at(wait_s)
                };
                let stop = Profile::stop(x1, v1, rate);
                (stop.end_counts().unwrap_or(x1), stop.duration_s())
            };
            let speed = if hundredths == 0 {
                0.0
            } else {
                solve(max_speed, |speed| direction * (stop_at(speed).0 - goal))
            };
            let (end, stop_s) = stop_at(speed);
            let late = (self.now_s + wait_s + stop_s - target_s).abs()
                + (end - goal).abs() / max_speed.max(1.0);
            if best.is_none_or(|(least, _, _)| late < least) {
                best = Some((late, wait_s, speed));
            }
        }
        let (_, wait_s, speed) = best.unwrap_or((0.0, 0.0, 0.0));
        if wait_s > 0.0 {
            (x, v) = self.jog_for(
                (x, v),
                &mut jogging,
                direction * speed,
                wait_s,
                (rate, steps_per_rev, max_steps),
            );
        }
        if jogging {
            // HCR p. 64: a program stops its jog with `SM` (`SJ` is immediate), and
            // waits for the stop with `WM`.
            self.lines.push(Command::StopMove {
                rate: StopRate::Decel,
            });
            self.lines.push(Command::WaitOnMove);
            let stop = Profile::stop(x, v, rate);
            x = stop.end_counts().unwrap_or(x);
            let stop_s = stop.duration_s();
            self.push_profile(stop);
            self.now_s += stop_s;
        } else {
            // Nothing moved: `DI` alone set the direction.
            self.lines.pop();
        }
        // Exactly to the keyframe's count, from where the stop ended.
        if (x - goal).abs() > 1e-9 {
            let speed = self.fix_speed();
            if self.speed != Some(speed) {
                self.lines.push(Command::Velocity { rev_s: Some(speed) });
                self.speed = Some(speed);
            }
            self.lines.push(Command::Distance {
                counts: Some(counts),
            });
            self.lines.push(Command::FeedToPosition);
            self.lines.push(Command::WaitOnMove);
            let held = units::VELOCITY.held(speed).unwrap_or(0.0) * steps_per_rev;
            let accel = self.limits.accel_counts_s2;
            let fix = Profile::to_rest(x, 0.0, goal, held, accel, accel);
            let fix_s = fix.duration_s();
            self.push_profile(fix);
            self.now_s += fix_s;
        }
        self.at_counts = to_counts;
        self.keyframes.push(Keyframe {
            time_ms: target_ms,
            position_mm: goal / self.config.counts_per_mm,
        });
        Ok(())
    }

    /// The `VE` of the short `FP` that ends a jog exactly on its count: the top speed.
    fn fix_speed(&self) -> Decimal {
        let top = (self.limits.max_speed_counts_s
            / (units::VELOCITY.step * self.limits.steps_per_rev))
            .floor() as i64;
        units::VELOCITY
            .write(top.clamp(units::VELOCITY.min_steps, units::VELOCITY.max_steps))
            .unwrap_or(Decimal::from_int(1))
    }

    /// Jogs from `(x, v)` (counts, counts/s) at `velocity` (counts/s, signed) for
    /// `for_s`: `JS` and `CJ` when not yet `jogging`, else `RXJ` (signed), then the
    /// `WT`; the speed as the drive holds it ([`held_speed`]; `rate` counts/s²,
    /// `max_steps` of `VE`). Returns where the drive is then.
    fn jog_for(
        &mut self,
        (x, v): (f64, f64),
        jogging: &mut bool,
        velocity: f64,
        for_s: f64,
        (rate, steps_per_rev, max_steps): (f64, f64, i64),
    ) -> (f64, f64) {
        let (steps, written, held) = held_speed(velocity.abs(), steps_per_rev, max_steps);
        let register = Register::new(JOG_REGISTER);
        self.lines
            .push(if *jogging && let Some(register) = register {
                // The stretch's way, also for a speed of 0 (−0.0 going backward): a
                // signed J of the other sign would turn the ball round (HCR p. 71).
                let signed = if velocity.is_sign_negative() {
                    -steps
                } else {
                    steps
                };
                Command::RegisterLoad {
                    register,
                    value: i32::try_from(signed).unwrap_or(0),
                }
            } else {
                Command::JogSpeed {
                    rev_s: Some(written),
                }
            });
        if !*jogging {
            self.lines.push(Command::CommenceJogging);
            *jogging = true;
        }
        let profile = Profile::run(x, v, velocity.signum() * held, rate, rate);
        let end = profile.at(for_s);
        self.push_profile(profile);
        self.wait(for_s);
        end
    }

    /// A piece of the program from now on, for the deviation.
    fn push_profile(&mut self, profile: Profile) {
        self.timed.push(Timed {
            start_s: self.now_s,
            from_counts: self.at_counts,
            to_counts: self.at_counts,
            trapezoid: super::moves::Trapezoid {
                distance: 0.0,
                speed: 1.0,
                accel: 1.0,
                decel: 1.0,
            },
            profile: Some(profile),
        });
    }

    /// The whole program, jogging through every stretch.
    pub(super) fn write_jog(
        mut self,
        plan: &Plan,
        (samples, candidates, counts): (&Samples, &[usize], &[i64]),
        track: &Track,
        budget_lines: usize,
    ) -> Result<QProgram, QProgramError> {
        let start_counts = self.at_counts;
        self.first = Some(self.limits);
        self.jog_accel = Some(plan.accel);
        self.multitasking = true;
        let mut index = 0;
        while index + 1 < candidates.len() {
            let direction = (counts[index + 1] - counts[index]).signum();
            // The stretch: as far as the direction holds.
            let mut end = index + 1;
            // A stream glides on through turning points, to the next rest.
            let goes_on = |way: i64| {
                if self.streamed && direction != 0 {
                    way != 0
                } else {
                    way == direction
                }
            };
            while end + 1 < candidates.len() && goes_on((counts[end + 1] - counts[end]).signum()) {
                end += 1;
            }
            let target_ms = samples.times_ms[candidates[end]];
            let target_s = target_ms as f64 / 1000.0;
            if direction == 0 {
                self.wait(target_s - self.now_s);
            } else {
                let distance = (counts[end] - self.at_counts).abs() as f64;
                let duration_s = target_s - self.now_s;
                if duration_s >= 2.0 * plan.step_s {
                    self.jog_to(samples, plan, counts[end], target_ms)?;
                } else {
                    // Too short to jog: from rest to rest.
                    let limits: Limits = self.limits;
                    let then_wait = match plan_step(distance, duration_s, &limits) {
                        Some(Step::Move { then_wait, .. }) => then_wait,
                        _ if self.streamed => {
                            // A stream plays on: the move at the top speed, late (the
                            // report counts it), rather than no show at all.
                            let speed = self.fix_speed();
                            self.feed(counts[end], speed, target_ms)?;
                            self.keyframes.push(Keyframe {
                                time_ms: target_ms,
                                position_mm: counts[end] as f64 / self.config.counts_per_mm,
                            });
                            index = end;
                            continue;
                        }
                        _ => {
                            return Err(QProgramError::TooFast {
                                at_ms: target_ms,
                                max_speed_mm_s: self.config.max_speed_mm_s,
                                max_accel_mm_s2: self.config.max_accel_mm_s2,
                            });
                        }
                    };
                    let from_ms = samples.times_ms[candidates[index]];
                    let ideal_s = (target_ms - from_ms) as f64 / 1000.0;
                    self.feed_by(counts[end], target_ms, ideal_s, then_wait)?;
                }
            }
            index = end;
        }
        self.finish(samples, track, budget_lines, start_counts)
    }
}
