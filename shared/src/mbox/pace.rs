//! Live frames paced at the box (issue 47), sans-IO: the bridge's sender turns each
//! live frame, at the instant it really leaves, into the line the box will run, so
//! that the ball keeps the installation's speed and acceleration — not only the
//! frame's targets.
//!
//! # The cause
//!
//! A box runs each frame as a straight line from **where the axis is when the frame
//! arrives** to the frame's target, over the frame's time; an early frame cuts the
//! line under way, a late one finds the axis resting at the last target
//! (`docs/protocol-notes.md`, "The twin" — the document's semantics, which the twin
//! follows and which are not changed here). Frames leave the bridge at their slot plus
//! a lateness that varies from frame to frame (a loaded host, a busy network), so:
//!
//! - a frame that leaves δ₁ after its slot followed by one that leaves δ₂ < δ₁ after
//!   its own cuts the first line (δ₁ − δ₂) short: the axis is behind by
//!   `v·(δ₁ − δ₂)`, and the second line covers its step **and** that lag in one
//!   period. On the twin, a step 0 → 1000 mm at 500 mm/s, 2000 mm/s², 20 ms frames:
//!   0–2.3 ms of lateness gives 555 mm/s (111 %; the reporter saw 512–579 mm/s),
//!   ±5 ms 736 mm/s;
//! - a frame that leaves later after its slot than the one before finds the axis
//!   resting for the difference: the ball stops and starts again, which second
//!   differences of positions read far above the top acceleration (6,225 mm/s² over
//!   20 ms for 0–2.3 ms of lateness, 22,000 for ±5 ms).
//!
//! The bridge's targets keep the limits; the box's lines do not. `time = "absolute"`
//! is no different: the box takes the time code's difference as the frame's time.
//!
//! # What the pacer does
//!
//! Per box and axis, in whole pulses, it keeps two copies of the twin's semantics
//! ([`super::twin`], its rounding included): the **ideal** — the frames as the drive
//! made them, each arriving at its slot (what the box did before, with no jitter) —
//! and the **model** — the frames as really sent, each from its actual send time. For
//! each live frame, at its send time, it chooses the line the box is to run from
//! where the model says the axis is:
//!
//! - **A velocity, held until the next frame**: the ideal's velocity for this frame,
//!   plus a correction of the distance between the model and the ideal delayed by the
//!   average lateness (over [`CORRECTION_PERIODS`] periods, and never faster than
//!   braking at the correction's share of the acceleration allows, so it does not
//!   overshoot). The line's target is where that velocity takes the axis in
//!   [`HOLD_PERIODS`] periods, and the frame asks for that long: the next frame, due
//!   in one, cuts it. A frame up to three periods late (60 ms at 20 ms) finds the axis
//!   still moving at that velocity — no rest — and the next line starts from where the
//!   model says it went. The jitter the bridge knows (its own send times) moves the
//!   ball along its path; it no longer changes its speed.
//! - **The limits at the ball**: the velocity stays within the top speed (less two
//!   pulses a window, for rounding), and changes from the line before by at most
//!   [`guard_accel_pulses_s2`] × [`ACCEL_WINDOW_US`] (or the period, if shorter) —
//!   and not at all within that window of the last change. When the ideal asks for
//!   more (frames leaving together after a stall, an axis that rested because a frame
//!   came too late) **the target is brought in**, and the lag is made good over the
//!   following frames with the speed the filter leaves ([`LIVE_SPEED_SHARE`]).
//! - **Exact ends**: a frame whose ideal rests (the drive asks for the same position
//!   as the frame before) aims the axis at that position, to the pulse, for when the
//!   next frame is due, once a line to it keeps the limits; a box at rest where the
//!   model says gets lines of half a period, so that an axis a pulse away (where jitter
//!   the bridge cannot see may leave it) gets there before the next frame cuts the
//!   line. A line never leaves the travel (its time is shortened, not below a period,
//!   or its target kept at the end): nothing passes either end.
//!
//! Frames that are not live (homing, approaches, shows) are sent as the drive made
//! them; the pacer only follows them ([`BoxPacer::observe`]) so that its model knows
//! where the axes are when live mode begins. An e-stop makes them unknown
//! ([`BoxPacer::forget`]): the next live mode homes first. **Shows have the same
//! excess** under send jitter (a show at the limits is the "before" of the figures
//! above: its frames are made the same way), but they are not paced: a show is
//! checked against the installation's full limits, and its lines could keep them at
//! the ball only by falling behind the show's clock; that needs shows checked against
//! the margin live mode takes, which is not done here.
//!
//! # Acceleration at the ball, and the shares of the limits
//!
//! A box's motion is piecewise linear: its velocity changes only when a frame
//! arrives. We read the acceleration at the ball as the reporter's checker did:
//! **second differences of positions sampled every `h`, 10 ms ≤ `h` ≤ 20 ms, at any
//! phase** (whole pulses, as `GET /api/sim/positions` gives them). A velocity step
//! `Δu` reads as up to `Δu/h`, so a 20 ms grid of frames from a filter at the full
//! acceleration (`Δu = a·20 ms`) reads `2a` at `h` = 10 ms even with perfect timing
//! (4,100 mm/s² on the twin before this change). Velocity changes at least a window
//! (10 ms) apart and each within `a·10 ms` read at most 9/8 of `a` for every `h` from
//! 10 to 20 ms (three such changes 10 ms apart, read over 13 ms), and whole pulses add
//! up to two pulses over `h²`; so the pacer's changes keep to `a/1.125` less two pulses
//! over (10 ms)² ([`guard_accel_pulses_s2`]: 1,578 mm/s² at 2000 mm/s² and 100 pulses a
//! mm). The live filter for MBOX boxes runs at [`LIVE_SPEED_SHARE`] (90 %) of the top
//! speed and at [`live_accel_share`] of the top acceleration — [`FILTER_SHARE_OF_GUARD`]
//! (85 %) of what the pacer allows a line to change in a period: **33.5 % at 20 ms
//! frames** (670 mm/s² of 2000), 67 % at 10 ms frames. A step over the whole travel
//! then takes 2.9 s instead of 2.25 s.
//!
//! # What the margin covers (the twin, a step 0 → 1000 mm and back, 4 seeds)
//!
//! | jitter | speed at the ball | acceleration (`h` 10–20 ms) | over 20 ms |
//! |---|---|---|---|
//! | none | 90 % | 75 % | 36 % |
//! | sends ±5 ms around the period | 91 % | 85 % | 59 % |
//! | ±5 ms, and 30 ms stalls twice a second | 94 % | 85 % | 61 % |
//! | ±5 ms, and 0.3 ms unseen | 92 % | 90 % | 58 % |
//! | ±5 ms, and 1 ms unseen | 92 % | 100 % | 66 % |
//! | ±5 ms, and 2 ms unseen | 93 % | 125 % | 77 % |
//!
//! - The bridge's own send jitter — the host's load, the sender's lateness — is
//!   known: the pacer takes each frame's real send time. Any jitter up to a frame
//!   three periods later than the one before keeps the limits; frames that leave
//!   together (a stall of the sender) have their velocity change wait for the window.
//! - **Beyond**: a frame more than three periods late (a stall of more than 60 ms)
//!   finds the axis resting — the box's own semantics, the one excess no frame can
//!   prevent; the pacer sees it and starts the axis again within the limits, the
//!   target brought in, and the lag is made good once the frames come again.
//! - Jitter after the send (the network, the box's own reception — on loopback the
//!   simulator's thread waking, 0.1 ms typically, up to 3 ms on a loaded 2-core host)
//!   is not seen: a line arriving `η` later than the one before runs about
//!   `v·η/(80 ms)` slower, and the next as much faster. The margin covers `η` up to
//!   1 ms (the acceleration, `h` from 10 ms; 3 ms over 20 ms) and well over 2 ms (the
//!   speed). A switched LAN adds tens of µs.

use std::sync::Arc;

use super::drive::BoxCalibration;

/// The shortest step of sampled positions at which the acceleration limit holds at
/// the ball, µs: a line's velocity changes from the line before by at most
/// [`guard_accel_pulses_s2`] times this (or the period, if shorter), and not again
/// within it. The reporter's checker sampled every 10–20 ms.
pub const ACCEL_WINDOW_US: u64 = 10_000;

/// The share of the top speed the live filter runs at on MBOX boxes: the rest
/// recovers a lag (a target brought in) and absorbs the jitter the bridge does not
/// see.
pub const LIVE_SPEED_SHARE: f64 = 0.9;

/// The share of what the pacer allows a line's velocity to change that the live
/// filter's own steps use; the rest is the correction's.
pub const FILTER_SHARE_OF_GUARD: f64 = 0.85;

/// How many periods a paced line lasts: the next frame, due one period after, cuts
/// it; a frame up to three periods late finds the axis still moving. (Longer lines
/// make a box less sensitive to jitter the bridge cannot see, and let an axis coast
/// longer when frames stop coming.)
pub const HOLD_PERIODS: u64 = 4;

/// Over how many periods the distance between the ideal and the model is made good.
pub const CORRECTION_PERIODS: f64 = 2.0;

/// Over how many frames the average lateness is taken (an exponential average).
const LATENESS_FRAMES: f64 = 16.0;

/// How much more than `a` velocity changes of `a·window` each, a window or more apart,
/// can read as second differences over 10–20 ms: three such changes a window apart,
/// read over 4/3 of a window, read 9/8 of `a`.
const SPACING_EXCESS: f64 = 1.125;

/// The acceleration, pulses/s², a paced line's velocity changes keep to (a change of
/// at most this times `window_us`, at least `window_us` after the last one): the top
/// acceleration less what three changes a window apart add ([`SPACING_EXCESS`]) and
/// what whole pulses add to a second difference over the window (two pulses); never
/// less than half of it.
#[must_use]
pub fn guard_accel_pulses_s2(limits: &BoxLimits, window_us: u64) -> f64 {
    let window_s = window_us.max(1) as f64 / 1e6;
    let spaced = limits.max_accel_pulses_s2 / SPACING_EXCESS;
    (spaced - 2.0 / (window_s * window_s)).max(spaced / 2.0)
}

/// The share of the top acceleration the live filter runs at on MBOX boxes of
/// `boxes` at a frame period of `period_us`: a filter step changes the velocity by
/// `share·a·period`, which must stay within [`FILTER_SHARE_OF_GUARD`] of what the
/// pacer allows a line's velocity to change in a period
/// ([`guard_accel_pulses_s2`] × `min(period, window)`) on every box. A third of `a` at
/// 20 ms frames and 100 pulses a mm (2000 mm/s²).
#[must_use]
pub fn live_accel_share(period_us: u64, boxes: &[BoxLimits]) -> f64 {
    let period_us = period_us.max(1);
    let window_us = ACCEL_WINDOW_US.min(period_us);
    boxes
        .iter()
        .filter(|limits| limits.max_accel_pulses_s2 > 0.0)
        .map(|limits| {
            FILTER_SHARE_OF_GUARD * guard_accel_pulses_s2(limits, window_us) * window_us as f64
                / (limits.max_accel_pulses_s2 * period_us as f64)
        })
        .fold(1.0, f64::min)
}

/// One box's limits in its own pulses (every axis of a box shares its calibration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxLimits {
    /// Top speed, pulses/s.
    pub max_speed_pulses_s: f64,
    /// Top acceleration, pulses/s².
    pub max_accel_pulses_s2: f64,
    /// The lower end of the travel, pulses.
    pub low_pulses: i32,
    /// The upper end of the travel, pulses.
    pub high_pulses: i32,
}

impl BoxLimits {
    /// The installation's top speed and acceleration and its travel in `calibration`'s
    /// pulses.
    #[must_use]
    pub fn new(
        calibration: &BoxCalibration,
        travel_mm: f64,
        max_speed_mm_s: f64,
        max_accel_mm_s2: f64,
    ) -> Self {
        let scale = calibration.pulses_per_mm.abs();
        let (top, bottom) = (calibration.pulses(0.0), calibration.pulses(travel_mm));
        Self {
            max_speed_pulses_s: max_speed_mm_s * scale,
            max_accel_pulses_s2: max_accel_mm_s2 * scale,
            low_pulses: top.min(bottom),
            high_pulses: top.max(bottom),
        }
    }
}

/// Every box's limits, in gateway order: what a live frame carries so the sender can
/// pace it ([`super::drive::MboxFrame::pace`]).
pub type PaceLimits = Arc<[BoxLimits]>;

/// A frame as the box is to get it: its targets and its time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Paced {
    /// Per axis: the target, pulses.
    pub positions_pulses: Vec<i32>,
    /// The frame's time, ms.
    pub time_ms: u32,
}

/// A line as the twin runs it: from `from` at `start_us` to `to` at `end_us`, then at
/// rest, in whole pulses, its position rounded towards `from` as the twin rounds it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Line {
    from_pulses: i64,
    to_pulses: i64,
    start_us: u64,
    end_us: u64,
}

impl Line {
    const fn at_rest(pulses: i64) -> Self {
        Self {
            from_pulses: pulses,
            to_pulses: pulses,
            start_us: 0,
            end_us: 0,
        }
    }

    fn position_pulses(&self, now_us: u64) -> i64 {
        if now_us >= self.end_us {
            return self.to_pulses;
        }
        if now_us <= self.start_us {
            return self.from_pulses;
        }
        let span = i128::from(self.end_us - self.start_us);
        let elapsed = i128::from(now_us - self.start_us);
        let travel = i128::from(self.to_pulses - self.from_pulses);
        // Between `from` and `to`: it fits.
        self.from_pulses + i64::try_from(travel * elapsed / span).unwrap_or(0)
    }

    /// Its velocity at `now_us`, pulses/s (0 at rest).
    fn velocity_pulses_s(&self, now_us: u64) -> f64 {
        if now_us >= self.end_us || now_us < self.start_us {
            return 0.0;
        }
        (self.to_pulses - self.from_pulses) as f64 / (self.end_us - self.start_us) as f64 * 1e6
    }

    /// Whether it rests from its start (a frame asking for where the last one went).
    const fn flat(&self) -> bool {
        self.from_pulses == self.to_pulses
    }

    fn retarget(&mut self, now_us: u64, target_pulses: i64, duration_us: u64) {
        *self = Self {
            from_pulses: self.position_pulses(now_us),
            to_pulses: target_pulses,
            start_us: now_us,
            end_us: now_us.saturating_add(duration_us.max(1)),
        };
    }
}

/// One axis: the ideal and the model.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct AxisPace {
    ideal: Line,
    model: Line,
    /// When the model's velocity last changed, µs: a frame that changed it, or the
    /// end of a line the next frame came too late to cut.
    changed_us: u64,
}

impl AxisPace {
    const fn new(pulses: i64) -> Self {
        let rest = Line::at_rest(pulses);
        Self {
            ideal: rest,
            model: rest,
            changed_us: 0,
        }
    }

    /// When the model's velocity last changed before `now_us`.
    fn changed_before(&self, now_us: u64) -> u64 {
        if self.model.end_us <= now_us && !self.model.flat() {
            self.changed_us.max(self.model.end_us)
        } else {
            self.changed_us
        }
    }
}

/// What the pacer wants of one axis in a frame.
#[derive(Debug, Clone, Copy)]
enum Plan {
    /// Its ideal rests at `to`, and the line that reaches it in one period keeps the
    /// limits: aimed to be there when the next frame is due.
    Arrive { at: i64, to: i64 },
    /// A velocity held until the next frame, pulses/s.
    Move { at: i64, velocity: f64 },
}

/// One box's pacer; see the [module documentation](self).
#[derive(Debug, Clone, Default)]
pub struct BoxPacer {
    /// Per axis; empty while the axes' positions are unknown.
    axes: Vec<AxisPace>,
    /// How late frames leave after their slot, on average lately, µs: the model
    /// follows the ideal this much later.
    lateness_us: Option<f64>,
}

impl BoxPacer {
    /// A pacer for a box whose positions are unknown.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// The box's positions became unknown (an e-stop: every axis stops where it is).
    pub fn forget(&mut self) {
        self.axes.clear();
        self.lateness_us = None;
    }

    /// Counts a frame of slot `slot_us` leaving at `send_us` in the average lateness;
    /// returns it, µs.
    fn late(&mut self, slot_us: u64, send_us: u64) -> u64 {
        let lateness_us = send_us.saturating_sub(slot_us) as f64;
        let average = self.lateness_us.map_or(lateness_us, |average| {
            average + (lateness_us - average) / LATENESS_FRAMES
        });
        self.lateness_us = Some(average);
        average.round() as u64
    }

    /// Where the model says every axis is at `now_us`, pulses (empty: unknown).
    #[must_use]
    pub fn model_pulses(&self, now_us: u64) -> Vec<i64> {
        self.axes
            .iter()
            .map(|axis| axis.model.position_pulses(now_us))
            .collect()
    }

    /// A frame of slot `slot_us` sent as the drive made it at `send_us`: `targets`
    /// in `time_ms`. With the positions unknown, the axes are taken to be at the
    /// targets once the frame's time is over (a move's frames repeat their target).
    pub fn observe(&mut self, slot_us: u64, send_us: u64, time_ms: u32, targets: &[i32]) {
        let duration_us = u64::from(time_ms.max(1)) * 1_000;
        if self.axes.len() != targets.len() {
            self.axes = targets
                .iter()
                .map(|&target| AxisPace::new(i64::from(target)))
                .collect();
        }
        for (axis, &target) in self.axes.iter_mut().zip(targets) {
            axis.ideal.retarget(slot_us, i64::from(target), duration_us);
            axis.model.retarget(send_us, i64::from(target), duration_us);
            axis.changed_us = send_us;
        }
        self.late(slot_us, send_us);
    }

    /// The live frame of slot `slot_us` (`targets` in `time_ms`, as the drive made it)
    /// as it is to leave at `send_us` for a box of `limits`; see the
    /// [module documentation](self). With the positions unknown it goes as made.
    pub fn pace(
        &mut self,
        limits: &BoxLimits,
        slot_us: u64,
        send_us: u64,
        time_ms: u32,
        targets: &[i32],
    ) -> Paced {
        if self.axes.len() != targets.len() {
            self.observe(slot_us, send_us, time_ms, targets);
            return Paced {
                positions_pulses: targets.to_vec(),
                time_ms: time_ms.max(1),
            };
        }
        let period_us = u64::from(time_ms.max(1)) * 1_000;
        let period_s = period_us as f64 / 1e6;
        let window_us = ACCEL_WINDOW_US.min(period_us);
        let accel = guard_accel_pulses_s2(limits, window_us);
        // The most a line's velocity may change from the line before, a window or more
        // after its last change; sooner, not at all.
        let full_step_pulses_s = accel * window_us as f64 / 1e6;
        // The top speed, less what two whole pulses add to a first difference over
        // the window.
        let speed = (limits.max_speed_pulses_s - 2e6 / window_us as f64)
            .max(limits.max_speed_pulses_s * 0.5);
        // What the correction may use of the acceleration: what a filter step leaves.
        let correction_accel =
            accel * (1.0 - FILTER_SHARE_OF_GUARD) * window_us as f64 / period_us as f64;
        let (low, high) = (i64::from(limits.low_pulses), i64::from(limits.high_pulses));
        let hold_us = HOLD_PERIODS * period_us;
        let mut duration_us = hold_us;
        // The ideal as the box would run it had every frame left as late as they do
        // on average.
        let ideal_at_us = send_us.saturating_sub(self.late(slot_us, send_us));
        let mut plans = Vec::with_capacity(targets.len());
        for (axis, &target) in self.axes.iter_mut().zip(targets) {
            let target = i64::from(target);
            // Where the ideal is at `ideal_at_us` (on its last line, if before this
            // slot), and the velocity of this frame's line.
            let ideal_before = axis.ideal;
            axis.ideal.retarget(slot_us, target, period_us);
            let ideal_line = if ideal_at_us < slot_us {
                ideal_before
            } else {
                axis.ideal
            };
            let at = axis.model.position_pulses(send_us);
            let before = axis.model.velocity_pulses_s(send_us);
            let step_pulses_s = if send_us.saturating_sub(axis.changed_before(send_us)) >= window_us
            {
                full_step_pulses_s
            } else {
                0.0
            };
            let within = |velocity: f64| {
                (velocity - before).abs() <= step_pulses_s && velocity.abs() <= speed
            };
            if axis.ideal.flat() && within((target - at) as f64 / period_s) {
                // Extended past `to` as far as it is from it, a line that would leave
                // the travel makes the frame a period long.
                let beyond = target + (target - at) * (HOLD_PERIODS as i64 - 1);
                if !(low..=high).contains(&beyond) {
                    duration_us = period_us;
                }
                plans.push(Plan::Arrive { at, to: target });
                continue;
            }
            let error = (ideal_line.position_pulses(ideal_at_us) - at) as f64;
            let correction = error.signum()
                * (error.abs() / (CORRECTION_PERIODS * period_s))
                    .min((2.0 * correction_accel * error.abs()).sqrt());
            let ideal = axis.ideal.velocity_pulses_s(ideal_at_us.max(slot_us));
            let velocity = (ideal + correction)
                .clamp(before - step_pulses_s, before + step_pulses_s)
                .clamp(-speed, speed);
            // A line that would leave the travel within the frame's time shortens it
            // (not below a period: that line stops at the end).
            if velocity != 0.0 {
                let room = if velocity > 0.0 { high - at } else { at - low };
                let reach_us = room.max(0) as f64 / velocity.abs() * 1e6;
                if reach_us < duration_us as f64 {
                    duration_us = (reach_us as u64 / 1_000 * 1_000).max(period_us);
                }
            }
            plans.push(Plan::Move { at, velocity });
        }
        // Every axis resting where its ideal rests, as far as the model knows: the line
        // to it is made to end well before the next frame, so that an axis a pulse or
        // two away from it — where the jitter the bridge does not see may leave it —
        // gets there (a line cut before its end stops short, rounded towards its start).
        if plans
            .iter()
            .all(|plan| matches!(plan, Plan::Arrive { at, to } if at == to))
            && self
                .axes
                .iter()
                .all(|axis| axis.model.velocity_pulses_s(send_us) == 0.0)
        {
            duration_us = (period_us / 2).max(1_000) / 1_000 * 1_000;
        }
        let duration_s = duration_us as f64 / 1e6;
        let mut positions = Vec::with_capacity(plans.len());
        for (axis, plan) in self.axes.iter_mut().zip(plans) {
            let target = match plan {
                // Where the line through `to` one period on is at the frame's end.
                Plan::Arrive { at, to } if duration_us >= period_us => {
                    let beyond = (to - at) as f64 * duration_us as f64 / period_us as f64;
                    // Within the travel: the cast cannot saturate.
                    (at + beyond.round() as i64).clamp(low, high)
                }
                Plan::Arrive { to, .. } => to,
                Plan::Move { at, velocity } => {
                    // Within the travel: the cast cannot saturate.
                    ((at as f64 + velocity * duration_s).round() as i64).clamp(low, high)
                }
            };
            let before = axis.model.velocity_pulses_s(send_us);
            axis.changed_us = axis.changed_before(send_us);
            axis.model.retarget(send_us, target, duration_us);
            // A change of less than a pulse over the line is the rounding's, not one.
            if (axis.model.velocity_pulses_s(send_us) - before).abs() > 1e6 / duration_us as f64 {
                axis.changed_us = send_us;
            }
            positions.push(i32::try_from(target).unwrap_or(i32::MAX));
        }
        Paced {
            positions_pulses: positions,
            time_ms: u32::try_from(duration_us / 1_000).unwrap_or(u32::MAX),
        }
    }
}

#[cfg(test)]
mod tests;
