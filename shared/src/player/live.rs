//! Live mode as a state of the sequencer (issue 38), sans-IO: the balls follow live
//! input (Art-Net, sACN) through the motion filter ([`crate::live::filter`]), one
//! filter step and one output per drive period.
//!
//! - **Go live** ([`super::Sequencer::go_live`]) comes only from the caller (the
//!   operator's button in the app): no input, however it arrives, can enter live
//!   mode, and nothing here releases an e-stop. It is refused while a playlist runs
//!   ([`super::StartError::Busy`]) and on a family that does not carry live motion
//!   ([`super::StartError::LiveUnsupported`]).
//! - A show armed on the units ([`super::Drive::arm`]) is disarmed: live motion
//!   overwrites their tables.
//! - **Homing** first when the balls' positions are unknown (at start-up, after an
//!   e-stop or a failure), as Start does.
//! - **Prepare**, for a drive that must load something before motion (UIM2503
//!   units: their FIFO and its first rows, [`super::Drive::begin_live`] returns
//!   `true`): the sequencer polls the drive until it says when motion begins.
//! - **Approach**: from the known positions to the latest live targets (taken when
//!   it begins) at the installation's approach speed (at most the top speed) and the
//!   top acceleration: the motion filter's own steps towards fixed targets with the
//!   approach speed as the speed limit, so every period has a constant acceleration
//!   as when following (a PVT row is then exactly the motion, which a point-to-point
//!   profile switching mid-period is not); a ball without a target stays. Its
//!   progress is counted against the continuous move's time
//!   ([`crate::live::filter::Approach`]).
//! - **Follow**: each period the sequencer steps one [`MotionFilter`] (the
//!   installation's travel, top speed and top acceleration; the step is the drive's
//!   period) from the latest input ([`LiveInput`], handed with
//!   [`super::Sequencer::set_live_input`]) and gives the drive the filtered
//!   [`BallState`]s for the period's end ([`super::Drive::live_step`]). When the
//!   caller is late it skips the periods missed and steps once — the filter's time
//!   runs slower than the caller's, never faster, so no ball is asked for more than
//!   the limits — unless the drive's units run the outputs on their own clock
//!   ([`LiveSetup::every_period`], a FIFO of rows): then every period missed is
//!   stepped and given, in order.
//! - **A change goes at once** (drives that take an output whenever it comes,
//!   [`super::Drive::live_early_step_us`]: MBOX boxes): when the input changes after
//!   a quiet period (the last step took no change), the next step does not wait for
//!   the grid: it is taken as soon as the caller polls after the change, but not
//!   before the drive's gap after the last slot (half a period, at least 10 ms), on
//!   a whole millisecond after the last slot, and the grid goes on a period from it.
//!   That step is filtered for its real time — a filter of the same limits whose
//!   step is the time since the last slot — so no ball is asked for more speed or
//!   acceleration than the limits in the time it really has; its recorded row lasts
//!   that time (10 ms or more: a row's shortest). Only a change after a quiet
//!   period moves the grid: changes that keep coming (a fader moving) are taken on
//!   the grid, so the outputs come at most once more per period than without it,
//!   and only at the start of a movement. A following step of the period's length
//!   may then overshoot a target by at most `a_max·dt²/8` (the grids differ), within
//!   the limits.
//! - **Input lost** (the caller says so, after its configured time): every ball
//!   holds — the filter brakes it within the limits and it stays — and the status
//!   says `holding` ([`crate::api::LivePhase::Holding`]); input back, the balls
//!   follow again.
//! - **Leave** ([`super::Sequencer::leave_live`]): the balls brake to rest within the
//!   limits, [`LIVE_SETTLE_PERIODS`] more periods hold them there (a lost last output
//!   is repeated), then the matrix is idle with its positions known (Start approaches
//!   the show from there, without homing).
//! - **E-stop**, Reset, Home, a failure: stop as always; live mode is over and the
//!   positions are unknown (the next live request homes first). A recording under
//!   way is dropped.
//! - **Record** ([`super::Sequencer::start_recording`]) while the balls follow: every
//!   filtered step goes into a [`Recorder`]; [`super::Sequencer::stop_recording`]
//!   gives the show (braked to rest, within the limits by construction). Leaving
//!   live keeps recording the braking until the caller stops it.

use thiserror::Error;

use super::Phase;
use crate::api::{LivePhase, LiveStatus};
use crate::codes::{Code, Coded, Params};
use crate::live::filter::{Approach, BallState, FilterLimits, MotionFilter};
use crate::live::record::{RecordError, Recorder};
use crate::params;
use crate::show::{Layout, Show};

/// Periods at rest sent after leaving live mode, before the matrix is idle.
pub const LIVE_SETTLE_PERIODS: u32 = 5;

/// The shortest step re-timed to a change of the input, µs: a recorded row's
/// shortest ([`crate::live::record`]).
pub const EARLY_STEP_MIN_US: u64 = 10_000;

/// How a drive family carries live motion ([`super::Drive::live_setup`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveSetup {
    /// The installation's limits; the filter's step is the drive's period.
    pub limits: FilterLimits,
    /// The approach's speed, mm/s (the installation's approach speed).
    pub approach_speed_mm_s: f64,
    /// The matrix (a recording's layout; one ball state per ball).
    pub layout: Layout,
    /// From an input to the balls following it, at most, µs (for the status).
    pub latency_us: u64,
    /// Every period needs its output even when the caller is late: the units run
    /// the outputs on their own clock (a FIFO of rows), so the sequencer steps once
    /// for each period missed. `false`: only the latest period is given (a box goes
    /// to the newest position; the filter's time runs slower, never faster).
    pub every_period: bool,
}

impl LiveSetup {
    /// The period, µs.
    #[must_use]
    pub fn period_us(&self) -> u64 {
        u64::from(self.limits.dt_ms.max(1)) * 1_000
    }
}

/// The latest live input, per ball (row-major, as in a show). Shorter slices than
/// the matrix leave the other balls without input; `speed_limits_mm_s` and `colours`
/// may be empty.
#[derive(Debug, Clone, Copy, Default)]
pub struct LiveInput<'a> {
    /// Each ball's target, mm below the top; `None`: no input for that ball (it
    /// holds), as [`crate::live::patch::BallTarget::filter_input`] gives.
    pub targets_mm: &'a [Option<f64>],
    /// Each ball's speed-limit channel, mm/s, if patched.
    pub speed_limits_mm_s: &'a [Option<f64>],
    /// Each ball's colour, if patched (recorded with the motion).
    pub colours: &'a [Option<[u8; 3]>],
    /// The input is lost (longer than the configured time): every ball holds.
    pub lost: bool,
}

/// Why a recording cannot start.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RecordStartError {
    /// The balls do not follow live input (not live, or homing, approaching or
    /// leaving).
    #[error("recording needs live mode with the balls following the input")]
    NotLive,
    /// The recorder refused (a period that is no row duration).
    #[error(transparent)]
    Record(#[from] RecordError),
}

impl Coded for RecordStartError {
    fn code(&self) -> Code {
        match self {
            Self::NotLive | Self::Record(RecordError::Balls { .. }) => Code::RecordNotLive,
            Self::Record(RecordError::Step { .. }) => Code::RecordStep,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Record(RecordError::Step {
                dt_ms,
                min_ms,
                max_ms,
            }) => params! {"dt_ms" => dt_ms, "min_ms" => min_ms, "max_ms" => max_ms},
            _ => Params::new(),
        }
    }
}

/// Where live motion stands.
#[derive(Debug, Clone)]
pub(super) enum Motion {
    /// Homing first (the sequencer's step is a home move).
    Homing,
    /// The drive prepares live motion; the approach waits.
    Preparing { approach: ApproachMove },
    /// From the known positions to the first targets, begun at `began_us`.
    Approaching {
        approach: ApproachMove,
        began_us: u64,
    },
    /// Through the filter.
    Following,
    /// Braking to rest; then `settled` periods at rest.
    Leaving { settled: u32 },
}

/// The approach: fixed targets, and how long the continuous move takes (for the
/// progress).
#[derive(Debug, Clone)]
pub(super) struct ApproachMove {
    targets_mm: Vec<Option<f64>>,
    speed_mm_s: f64,
    duration_s: f64,
}

/// Live mode's state in the sequencer.
#[derive(Debug, Clone)]
pub(super) struct Live {
    pub(super) setup: LiveSetup,
    pub(super) filter: MotionFilter,
    pub(super) motion: Motion,
    /// Every ball's state at the end of the last period given to the drive.
    pub(super) states: Vec<BallState>,
    targets_mm: Vec<Option<f64>>,
    speed_limits_mm_s: Vec<Option<f64>>,
    colours: Vec<Option<[u8; 3]>>,
    lost: bool,
    /// The next period's slot, µs.
    pub(super) next_slot_us: u64,
    /// The slot of the last step given to the drive, µs (`None` before the first).
    last_slot_us: Option<u64>,
    /// The least time after the last slot a change of the input may move the next
    /// step to, µs ([`super::Drive::live_early_step_us`]); `None`: never.
    early_gap_us: Option<u64>,
    /// The input changed (targets, speed limits, loss) since the last step.
    changed: bool,
    /// The last step followed the input and took no change.
    quiet: bool,
}

/// What a period of live motion ended with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Period {
    /// More to come.
    Going,
    /// Left: the balls rest.
    Left,
}

impl Live {
    pub(super) fn new(setup: LiveSetup, filter: MotionFilter) -> Self {
        Self {
            setup,
            filter,
            motion: Motion::Homing,
            states: Vec::new(),
            targets_mm: Vec::new(),
            speed_limits_mm_s: Vec::new(),
            colours: Vec::new(),
            lost: false,
            next_slot_us: 0,
            last_slot_us: None,
            early_gap_us: None,
            changed: false,
            quiet: false,
        }
    }

    fn balls(&self) -> usize {
        self.setup.layout.unit_count()
    }

    /// Takes the latest input.
    pub(super) fn set_input(&mut self, input: LiveInput<'_>) {
        let balls = self.balls();
        let mut changed = fill(&mut self.targets_mm, input.targets_mm, balls);
        changed |= fill(&mut self.speed_limits_mm_s, input.speed_limits_mm_s, balls);
        fill(&mut self.colours, input.colours, balls);
        changed |= self.lost != input.lost;
        self.lost = input.lost;
        self.changed |= changed;
    }

    /// Whether a change of the input now would move the next step forward (see the
    /// module's doc): following, the last step quiet, nothing changed since.
    pub(super) fn awaits_change(&self) -> bool {
        self.early_gap_us.is_some()
            && self.last_slot_us.is_some()
            && self.quiet
            && !self.changed
            && matches!(self.motion, Motion::Following)
    }

    /// The earliest a step re-timed to a change may be taken, µs, if one is waiting.
    fn early_from_us(&self) -> Option<u64> {
        let gap_us = self.early_gap_us?;
        let last_us = self.last_slot_us?;
        (self.changed && self.quiet && matches!(self.motion, Motion::Following))
            .then(|| last_us.saturating_add(gap_us))
            .filter(|&from_us| from_us < self.next_slot_us)
    }

    /// When the next step is due, µs: the grid's slot, or earlier for a change after a
    /// quiet period.
    pub(super) fn next_step_us(&self) -> u64 {
        self.early_from_us()
            .map_or(self.next_slot_us, |from_us| from_us.min(self.next_slot_us))
    }

    /// The slot of a step re-timed to a change, due at `now_us`: a whole millisecond
    /// after the last slot, not after `now_us`.
    fn early_slot_us(&self, now_us: u64) -> Option<u64> {
        let from_us = self.early_from_us()?;
        let last_us = self.last_slot_us?;
        (now_us >= from_us && now_us < self.next_slot_us)
            .then(|| last_us + (now_us - last_us) / 1_000 * 1_000)
    }

    /// The balls rest at `positions_mm` at `now_us`: the approach to the latest
    /// targets begins (the first period's slot is `now_us`).
    pub(super) fn begin_approach(&mut self, now_us: u64, positions_mm: &[f64]) {
        let balls = self.balls();
        self.states = (0..balls)
            .map(|ball| {
                BallState::at_rest(
                    positions_mm
                        .get(ball)
                        .copied()
                        .unwrap_or(0.0)
                        .clamp(0.0, self.setup.limits.travel_mm),
                )
            })
            .collect();
        let targets: Vec<Option<f64>> = if self.lost {
            vec![None; balls]
        } else {
            self.clamped_targets()
        };
        let limits = self.setup.limits;
        let speed = self
            .setup
            .approach_speed_mm_s
            .min(limits.max_speed_mm_s)
            .max(f64::MIN_POSITIVE);
        let duration_s =
            Approach::new(&self.states, &targets, speed, limits.max_accel_mm_s2).duration_s();
        self.motion = Motion::Approaching {
            approach: ApproachMove {
                targets_mm: targets,
                speed_mm_s: speed,
                duration_s,
            },
            began_us: now_us,
        };
        self.next_slot_us = now_us;
        self.last_slot_us = None;
    }

    fn clamped_targets(&self) -> Vec<Option<f64>> {
        let travel = self.setup.limits.travel_mm;
        (0..self.balls())
            .map(|ball| {
                self.targets_mm
                    .get(ball)
                    .copied()
                    .flatten()
                    .filter(|mm| mm.is_finite())
                    .map(|mm| mm.clamp(0.0, travel))
            })
            .collect()
    }

    /// The operator leaves: the balls brake to rest.
    pub(super) fn leave(&mut self) {
        if !matches!(self.motion, Motion::Leaving { .. }) {
            self.motion = Motion::Leaving { settled: 0 };
        }
    }

    /// One period of `dt_ms` (the setup's, or shorter for a step re-timed to a
    /// change): every ball's state at its end (in [`Live::states`]). Whether the
    /// period follows the input (a recording takes it).
    pub(super) fn period(&mut self, dt_ms: u32) -> (Period, bool) {
        self.quiet = !self.changed && matches!(self.motion, Motion::Following);
        self.changed = false;
        let own = self.filter;
        let filter = if dt_ms == own.limits().dt_ms {
            own
        } else {
            MotionFilter::new(FilterLimits {
                dt_ms,
                ..own.limits()
            })
            .unwrap_or(own)
        };
        match &self.motion {
            Motion::Homing | Motion::Preparing { .. } => (Period::Going, false),
            Motion::Approaching { approach, .. } => {
                let mut done = true;
                for (ball, state) in self.states.iter_mut().enumerate() {
                    let target = approach.targets_mm.get(ball).copied().flatten();
                    filter.step(state, target, Some(approach.speed_mm_s));
                    done &= state.velocity_mm_s == 0.0
                        && target.is_none_or(|mm| state.position_mm == mm);
                }
                if done {
                    self.motion = Motion::Following;
                }
                (Period::Going, false)
            }
            Motion::Following => {
                let lost = self.lost;
                for (ball, state) in self.states.iter_mut().enumerate() {
                    let target = if lost {
                        None
                    } else {
                        self.targets_mm.get(ball).copied().flatten()
                    };
                    let limit = self.speed_limits_mm_s.get(ball).copied().flatten();
                    filter.step(state, target, limit);
                }
                (Period::Going, true)
            }
            Motion::Leaving { settled } => {
                let settled = *settled;
                for state in &mut self.states {
                    filter.step(state, None, None);
                }
                let resting = self.states.iter().all(|state| state.velocity_mm_s == 0.0);
                let settled = if resting { settled + 1 } else { 0 };
                self.motion = Motion::Leaving { settled };
                let over = settled > LIVE_SETTLE_PERIODS;
                (if over { Period::Left } else { Period::Going }, true)
            }
        }
    }

    /// The colours of the latest input (for a recording).
    pub(super) fn colours(&self) -> &[Option<[u8; 3]>] {
        &self.colours
    }

    /// The phase for the status.
    pub(super) fn phase(&self) -> LivePhase {
        match self.motion {
            Motion::Homing => LivePhase::Homing,
            Motion::Preparing { .. } => LivePhase::Preparing,
            Motion::Approaching { .. } => LivePhase::Approaching,
            Motion::Following if self.lost => LivePhase::Holding,
            Motion::Following => LivePhase::Following,
            Motion::Leaving { .. } => LivePhase::Leaving,
        }
    }

    /// The approach's share behind at `now_us` (1 once following).
    pub(super) fn progress(&self, now_us: u64) -> f64 {
        match &self.motion {
            Motion::Homing | Motion::Preparing { .. } => 0.0,
            Motion::Approaching { approach, began_us } => {
                let duration_s = approach.duration_s;
                if duration_s <= 0.0 {
                    1.0
                } else {
                    (now_us.saturating_sub(*began_us) as f64 / 1e6 / duration_s).min(1.0)
                }
            }
            Motion::Following | Motion::Leaving { .. } => 1.0,
        }
    }

    /// The status, with the recording's.
    pub(super) fn status(&self, recorder: Option<&Recorder>) -> LiveStatus {
        let ms = |us: u64| u32::try_from(us.div_ceil(1_000)).unwrap_or(u32::MAX);
        LiveStatus {
            phase: self.phase(),
            input_lost: self.lost,
            period_ms: ms(self.setup.period_us()),
            latency_ms: ms(self.setup.latency_us),
            recording: recorder.is_some(),
            recorded_ms: recorder.map_or(0, |recorder| recorder.recorded_ms()),
        }
    }
}

/// `into` as `from`, one per ball (missing: `None`); whether it changed.
fn fill<T: Copy + PartialEq>(into: &mut Vec<Option<T>>, from: &[Option<T>], balls: usize) -> bool {
    let changed = into.len() != balls
        || into
            .iter()
            .enumerate()
            .any(|(ball, now)| *now != from.get(ball).copied().flatten());
    into.clear();
    into.extend(from.iter().copied().take(balls));
    into.resize(balls, None);
    changed
}

impl<D: super::Drive> super::Sequencer<D> {
    /// **Go live** (the operator's request, never a packet's): from rest — idle,
    /// stopped or after an error — homes first when the positions are unknown, then
    /// the balls approach the latest input ([`super::Sequencer::set_live_input`];
    /// give it first) and follow it. A previous error is cleared, and a recording
    /// not taken ([`super::Sequencer::stop_recording`]) is dropped.
    ///
    /// # Errors
    /// [`super::StartError::Busy`] while a playlist runs or live mode is on;
    /// [`super::StartError::LiveUnsupported`] when the drive family cannot carry live
    /// motion, or its limits cannot make a filter. Nothing was changed.
    pub fn go_live(&mut self, now_us: u64) -> Result<(), super::StartError> {
        self.now_us = self.now_us.max(now_us);
        if self.is_running() {
            return Err(super::StartError::Busy);
        }
        let setup = self.drive.live_setup()?;
        let filter =
            MotionFilter::new(setup.limits).map_err(|_| super::StartError::LiveUnsupported {
                family: "an installation without positive limits",
            })?;
        let mut live = Live::new(setup, filter);
        // Whole milliseconds, and never a step shorter than a recorded row's shortest.
        live.early_gap_us = self
            .drive
            .live_early_step_us()
            .map(|gap_us| gap_us.max(EARLY_STEP_MIN_US).div_ceil(1_000) * 1_000);
        // The input handed before the request, kept.
        if let Some(previous) = self.live_input.take() {
            live.set_input(LiveInput {
                targets_mm: &previous.0,
                speed_limits_mm_s: &previous.1,
                colours: &previous.2,
                lost: previous.3,
            });
        }
        self.live = Some(live);
        self.recorder = None;
        self.last_error = None;
        self.progress = 0.0;
        // Live motion overwrites what was armed on the units (UIM2503 tables).
        self.drive.disarm();
        self.drive.begin_run(now_us, None);
        let rest = if self.needs_home {
            None
        } else {
            self.drive.rest_positions_mm()
        };
        match rest {
            Some(_) => self.begin_live_motion(now_us),
            None => self.begin_home(now_us, super::AfterMove::Live),
        }
        Ok(())
    }

    /// Hands the latest live input (each period, or whenever it changes): the next
    /// periods follow it. Before [`super::Sequencer::go_live`] it is kept for the
    /// approach; at rest otherwise it is ignored. Nothing here can start anything.
    pub fn set_live_input(&mut self, input: LiveInput<'_>) {
        let running = self.is_running();
        match self.live.as_mut() {
            Some(live) => live.set_input(input),
            None if !running => {
                self.live_input = Some((
                    input.targets_mm.to_vec(),
                    input.speed_limits_mm_s.to_vec(),
                    input.colours.to_vec(),
                    input.lost,
                ));
            }
            None => {}
        }
    }

    /// **Leave live mode** (the operator): the balls brake to rest within the limits,
    /// then the matrix is idle, positions known; while homing for live mode, the
    /// homing goes on and rests. Returns whether live mode was on.
    pub fn leave_live(&mut self, now_us: u64) -> bool {
        self.now_us = self.now_us.max(now_us);
        let Some(live) = self.live.as_mut() else {
            return false;
        };
        if matches!(live.motion, Motion::Homing) {
            self.live = None;
            if let super::Step::Moving { kind, .. } = self.step {
                self.step = super::Step::Moving {
                    kind,
                    after: super::AfterMove::Rest,
                };
            }
        } else {
            live.leave();
        }
        true
    }

    /// Whether live mode is on (homing for it, approaching, following, holding or
    /// leaving).
    #[must_use]
    pub fn is_live(&self) -> bool {
        self.live.is_some()
    }

    /// Every ball's filtered state at the end of the last live period (empty before
    /// the approach): what the drive was given, for a preview.
    #[must_use]
    pub fn live_states(&self) -> &[BallState] {
        self.live.as_ref().map_or(&[], |live| &live.states)
    }

    /// **Record**: from the next period on, every filtered step goes into a show
    /// named `name` (a recording under way is replaced).
    ///
    /// # Errors
    /// [`RecordStartError::NotLive`] unless the balls follow (or hold) live input;
    /// [`RecordStartError::Record`] when the period is no row duration.
    pub fn start_recording(&mut self, name: impl Into<String>) -> Result<(), RecordStartError> {
        let Some(live) = self
            .live
            .as_ref()
            .filter(|live| matches!(live.motion, Motion::Following))
        else {
            return Err(RecordStartError::NotLive);
        };
        self.recorder = Some(Recorder::new(
            name,
            live.setup.layout,
            live.filter,
            &live.states,
        )?);
        Ok(())
    }

    /// Whether a recording is under way.
    #[must_use]
    pub fn is_recording(&self) -> bool {
        self.recorder.is_some()
    }

    /// Stops the recording: the show (every ball braked to rest within the limits),
    /// or `None` when nothing was recorded (none begun, or an e-stop dropped it).
    pub fn stop_recording(&mut self) -> Option<Show> {
        self.recorder.take().map(Recorder::finish)
    }

    /// The homing for live mode is over at `at_us`, or the request found the
    /// positions known: the approach begins.
    pub(super) fn begin_live_motion(&mut self, at_us: u64) {
        let Some(positions) = self.drive.rest_positions_mm() else {
            self.fail("live mode: the balls' positions are unknown after homing".into());
            return;
        };
        let Some(live) = self.live.as_mut() else {
            return;
        };
        live.begin_approach(at_us, &positions);
        self.step = super::Step::Live;
        if self.drive.begin_live(at_us, &live.states)
            && let Motion::Approaching { approach, .. } = &live.motion
        {
            live.motion = Motion::Preparing {
                approach: approach.clone(),
            };
        }
    }

    /// While the drive prepares live motion: what it said (after a poll, or an input
    /// of its own that ended the preparation); done, the approach begins at `at_us`.
    pub(super) fn live_prepared(&mut self, phase: Phase) {
        let Some(live) = self.live.as_mut() else {
            return;
        };
        let Motion::Preparing { approach } = &live.motion else {
            return;
        };
        match phase {
            Phase::Pending => {}
            Phase::Failed(reason) => self.fail(reason),
            Phase::Done { at_us } => {
                live.motion = Motion::Approaching {
                    approach: approach.clone(),
                    began_us: at_us,
                };
                live.next_slot_us = at_us;
            }
        }
    }

    /// Whether a change of the live input now would move the next live step forward
    /// (a drive with [`super::Drive::live_early_step_us`], following, the last step
    /// quiet, no change since): the caller then wakes on the input's change and polls
    /// at once.
    #[must_use]
    pub fn live_awaits_change(&self) -> bool {
        self.live.as_ref().is_some_and(Live::awaits_change)
    }

    /// Live motion's period, when due: skips the periods missed (the filter's time
    /// runs slower, never faster), steps once, hands the drive the states; or a step
    /// re-timed to a change of the input (see the module's doc).
    pub(super) fn poll_live(&mut self, now_us: u64) {
        let Some(live) = self.live.as_mut() else {
            return;
        };
        if matches!(live.motion, Motion::Preparing { .. }) {
            let phase = self.drive.poll(now_us, None);
            self.live_prepared(phase);
            return;
        }
        let period_us = live.setup.period_us();
        let period_ms = live.setup.limits.dt_ms.max(1);
        loop {
            let (slot_us, dt_ms) = if now_us >= live.next_slot_us {
                let behind = (now_us - live.next_slot_us) / period_us;
                let slot_us = if live.setup.every_period {
                    live.next_slot_us
                } else {
                    live.next_slot_us + behind * period_us
                };
                (slot_us, period_ms)
            } else if let Some(slot_us) = live.early_slot_us(now_us)
                && let Some(last_us) = live.last_slot_us
            {
                let dt_ms = u32::try_from((slot_us - last_us) / 1_000).unwrap_or(period_ms);
                (slot_us, dt_ms)
            } else {
                break;
            };
            live.last_slot_us = Some(slot_us);
            live.next_slot_us = slot_us + period_us;
            let (period, filtered) = live.period(dt_ms);
            if filtered && let Some(recorder) = self.recorder.as_mut() {
                recorder.push_step(&live.states, live.colours(), dt_ms);
            }
            self.drive.live_step(slot_us, &live.states);
            if period == Period::Left {
                self.drive.end_live(slot_us + period_us, &live.states);
                self.live = None;
                self.needs_home = false;
                self.progress = 1.0;
                self.step = super::Step::Idle;
                return;
            }
        }
    }
}
