//! MBOX boxes under the show sequencer ([`crate::player`]): the [`Drive`] that turns
//! its steps into one frame per period for every box ([`MboxFrame`]), which the bridge
//! sends at the frame's slot, one datagram a box.
//!
//! - A box cannot report where its axes are, so the drive tracks the last commanded
//!   positions. A move whose start is unknown (homing after an e-stop) lasts as long
//!   as the longest possible move (the whole travel at the approach speed), and every
//!   frame of a move carries the move's target and the time left, so each box moves
//!   from wherever it is, and a lost frame is made good by the next.
//! - A move, and the last show of a playlist, end with [`SETTLE_FRAMES`] more frames
//!   holding the final positions: positions are absolute, so a lost last frame is
//!   repeated.
//! - A show is sampled by the preview's evaluator ([`Sampler`]) one period ahead, so
//!   each frame tells every box where to be at the end of the period; its outputs are
//!   sampled at the frame's show time. The show's first frame goes at its time 0 (the
//!   slot after the approach's last frame) with the sample one period in: every
//!   sample is sent, and each frame asks for exactly the period it covers. Frames of
//!   moves, and the settle frames after the last show, carry every output 0.
//! - Every frame says how long the box takes (`time_ms`): a move's frames the time
//!   left (at least a period), show and settle frames the period. In absolute time
//!   the bridge's time code counts on by exactly that much a frame (see
//!   `bridge/src/ports/mbox.rs`).
//! - Only the latest due slot is sent when the caller is late: a box goes to the
//!   newest position.
//! - **Live mode** ([`crate::player::live`]): one frame per period, the same frame as
//!   a show's, from the sequencer's filtered states for the period's end (`time_ms`
//!   the period, every output 0), carrying every box's limits in pulses
//!   ([`MboxFrame::pace`]): the bridge's sender paces each live frame at the instant
//!   it leaves ([`crate::mbox::pace`]), so the box's straight lines — from where its
//!   axes are when the frame arrives — keep the top speed and acceleration at the
//!   ball whatever the frames' send jitter (issue 47). For that margin the filter runs
//!   at [`crate::mbox::pace::LIVE_SPEED_SHARE`] of the top speed and
//!   [`crate::mbox::pace::live_accel_share`] of the top acceleration (90 % and a
//!   third at 20 ms frames). The filter's step is the frame period. A change after a
//!   quiet period does not wait for the grid ([`Drive::live_early_step_us`]): a box
//!   takes a frame whenever it comes (an early frame replaces the move under way from
//!   where the axes are, `docs/protocol-notes.md`, "The twin"), so its frame goes
//!   half a period (at least 10 ms) after the last one at the earliest, its step
//!   filtered for the time since the last frame, and the frames go on a period apart
//!   from it; each still asks for a period (`time_ms`; the pacer makes the box's line
//!   longer, the next frame cutting it). Boxes take frames over
//!   Ethernet, so no line limits the number of balls that move.
//! - **Live latency** ([`Drive::live_latency_us`]), from an input reaching the bridge
//!   to the frame that carries it leaving, at most: a period waiting for the frame
//!   that takes it (while the input keeps changing; after a quiet period half of one
//!   at most), the frame lead the bridge makes frames with, and the send lateness its
//!   sender measured lately ([`MboxDrive::set_send_timing`]) — 26 ms or so at 20 ms
//!   frames, where the status said 40 (two periods: it counted the frame's move,
//!   which begins as the frame arrives). Without the bridge (lead and lateness 0)
//!   it is the period.
//! - **Clock trim** ([`Drive::trim_clock`], a timecode chase): the show's time 0
//!   moves as far as the timecode puts it since the first trim, so each frame's
//!   sample time follows the timecode exactly rather than the bridge's free-running
//!   clock (never going back: a frame's show time is at least the one before's).
//!   Without a trim nothing changes.

use crate::live::filter::{BallState, FilterLimits};
use crate::mbox::pace::{BoxLimits, LIVE_SPEED_SHARE, PaceLimits, live_accel_share};
use crate::plan::Installation;
use crate::player::{Drive, LiveSetup, Phase, StartError};
use crate::show::{OutputSample, Sampler, Show};

/// Frames sent after a move or the playlist's end, holding the final positions.
pub const SETTLE_FRAMES: u64 = 5;

/// The frame period unless configured, µs.
pub const DEFAULT_PERIOD_US: u64 = 20_000;

/// One box's calibration: millimetres below the top to pulses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxCalibration {
    /// How many axes it drives (3, 6 or 10).
    pub axes: usize,
    /// Pulses per millimetre of ball travel.
    pub pulses_per_mm: f64,
    /// +1, or −1 when the axis counts up as the ball rises.
    pub sign: i8,
    /// Pulses at 0 mm (the top).
    pub offset_pulses: i32,
}

impl BoxCalibration {
    /// `mm` in pulses, rounded and clamped to the wire's `i32`.
    #[must_use]
    pub fn pulses(&self, mm: f64) -> i32 {
        let pulses = f64::from(self.offset_pulses) + f64::from(self.sign) * mm * self.pulses_per_mm;
        // `as` saturates, and NaN (never produced from finite values) becomes 0.
        pulses.round() as i32
    }
}

/// What the MBOX player needs to know about the machine.
#[derive(Debug, Clone)]
pub struct MboxPlayerConfig {
    /// The installation (every unit's box and axis, limits, approach speed, home).
    pub installation: Installation,
    /// Each box's calibration, in gateway order.
    pub boxes: Vec<BoxCalibration>,
    /// The frame period, µs.
    pub period_us: u64,
}

/// One period's frame for every box: the bridge sends it at `slot_us`.
#[derive(Debug, Clone, PartialEq)]
pub struct MboxFrame {
    /// The slot it belongs to, µs on the player's clock.
    pub slot_us: u64,
    /// How long each box takes to reach the positions, ms (at least 1).
    pub time_ms: u32,
    /// Per box (gateway order), per axis: the target, pulses. Axes no unit uses hold
    /// their calibrated 0 mm.
    pub positions_pulses: Vec<Vec<i32>>,
    /// Per box (gateway order): its digital and analog outputs.
    pub outputs: Vec<OutputSample>,
    /// Live frames: every box's limits, for the sender to pace the frame at the
    /// instant it leaves ([`crate::mbox::pace`]); `None`: the frame goes as made
    /// (homing, approaches, shows).
    pub pace: Option<PaceLimits>,
}

/// A playlist entry prepared for the boxes: its show and the show's sampler.
#[derive(Debug, Clone)]
pub struct MboxEntry {
    /// The show (its output tracks are sampled for every frame).
    pub show: Show,
    /// The show's positions, sampled frame by frame.
    pub sampler: Sampler,
}

impl MboxEntry {
    /// `show`, ready to sample.
    #[must_use]
    pub fn new(show: Show) -> Self {
        let sampler = Sampler::new(&show);
        Self { show, sampler }
    }
}

#[derive(Debug, Clone)]
enum Step {
    Idle,
    Moving {
        targets_mm: Vec<f64>,
        began_us: u64,
        arrive_us: u64,
    },
    Playing {
        start_us: u64,
        /// Nothing follows: settle frames end the show.
        last: bool,
        /// The show time of the last frame, ms (a trim never takes it back).
        last_t_ms: u64,
        /// The first clock trim: the show's start then, and the start it gave, µs.
        trimmed_from: Option<(u64, i64)>,
    },
}

/// The MBOX drive; see the [module documentation](self).
#[derive(Debug)]
pub struct MboxDrive {
    config: MboxPlayerConfig,
    step: Step,
    /// The last commanded positions, mm; `None` when unknown.
    believed_mm: Option<Vec<f64>>,
    /// The next frame slot, µs.
    next_slot_us: u64,
    frames: Vec<MboxFrame>,
    samples: Vec<f32>,
    progress: f64,
    /// Every box's limits in its pulses, carried by live frames for the sender's pacer.
    pace: PaceLimits,
    /// How long before its slot a frame is made, µs (the bridge's frame lead).
    frame_lead_us: u64,
    /// The latest a frame left after its slot lately, µs, as the sender measured it.
    send_lateness_us: u64,
}

impl MboxDrive {
    /// The drive for the boxes in `config`, positions unknown.
    #[must_use]
    pub fn new(config: MboxPlayerConfig) -> Self {
        let limits = config.installation.limits;
        let pace = config
            .boxes
            .iter()
            .map(|calibration| {
                BoxLimits::new(
                    calibration,
                    limits.travel_mm,
                    limits.max_speed_mm_s,
                    limits.max_accel_mm_s2,
                )
            })
            .collect();
        Self {
            pace,
            frame_lead_us: 0,
            send_lateness_us: 0,
            config,
            step: Step::Idle,
            believed_mm: None,
            next_slot_us: 0,
            frames: Vec::new(),
            samples: Vec::new(),
            progress: 0.0,
        }
    }

    /// The configuration it drives.
    #[must_use]
    pub fn config(&self) -> &MboxPlayerConfig {
        &self.config
    }

    /// The frames to send now, in order.
    pub fn take_frames(&mut self) -> Vec<MboxFrame> {
        std::mem::take(&mut self.frames)
    }

    /// How the frames are sent (the bridge, before each poll): made `frame_lead_us`
    /// before their slot, and leaving at most `send_lateness_us` after it lately. The
    /// live latency counts both ([`Drive::live_latency_us`]).
    pub fn set_send_timing(&mut self, frame_lead_us: u64, send_lateness_us: u64) {
        self.frame_lead_us = frame_lead_us;
        self.send_lateness_us = send_lateness_us;
    }

    /// The frame period, µs (at least 1 ms).
    fn period_us(&self) -> u64 {
        self.config.period_us.max(1_000)
    }

    /// The live latency, µs ([`Drive::live_latency_us`]).
    fn live_latency(&self) -> u64 {
        self.period_us() / 1_000 * 1_000 + self.frame_lead_us + self.send_lateness_us
    }

    fn begin_move(&mut self, now_us: u64, targets_mm: Vec<f64>) {
        self.next_slot_us = self.next_slot_us.max(now_us);
        let installation = &self.config.installation;
        let speed = installation.approach_speed_mm_s.max(f64::MIN_POSITIVE);
        let distance_mm = match &self.believed_mm {
            Some(believed) => believed
                .iter()
                .zip(&targets_mm)
                .map(|(from, to)| (to - from).abs())
                .fold(0.0, f64::max),
            None => installation.limits.travel_mm,
        };
        let move_us = (distance_mm / speed * 1e6).ceil() as u64;
        self.progress = 0.0;
        self.step = Step::Moving {
            targets_mm,
            began_us: now_us,
            arrive_us: now_us + move_us,
        };
    }

    /// The frame of one slot, and whether the step is over with it.
    fn slot(&mut self, slot_us: u64, entry: Option<&mut MboxEntry>) -> Phase {
        let period = self.period_us();
        match &self.step {
            Step::Moving {
                targets_mm,
                began_us,
                arrive_us,
            } => {
                let (targets_mm, began_us, arrive_us) = (targets_mm.clone(), *began_us, *arrive_us);
                let left_us = arrive_us.saturating_sub(slot_us).max(period);
                self.push_frame(slot_us, left_us, &targets_mm, None);
                if slot_us >= arrive_us + SETTLE_FRAMES * period {
                    self.believed_mm = Some(targets_mm);
                    self.progress = 1.0;
                    self.step = Step::Idle;
                    // Over when its last frame's period is: the next step's first
                    // frame takes the next slot.
                    Phase::Done {
                        at_us: slot_us + period,
                    }
                } else {
                    let span = arrive_us.saturating_sub(began_us).max(1) as f64;
                    let done = slot_us.saturating_sub(began_us) as f64;
                    self.progress = (done / span).min(1.0);
                    Phase::Pending
                }
            }
            Step::Playing {
                start_us,
                last,
                last_t_ms,
                ..
            } => {
                let (start_us, last, last_t_ms) = (*start_us, *last, *last_t_ms);
                let Some(entry) = entry else {
                    return Phase::Pending;
                };
                let duration_ms = entry.sampler.duration_ms();
                let t_ms = (slot_us.saturating_sub(start_us) / 1_000).max(last_t_ms);
                if let Step::Playing { last_t_ms, .. } = &mut self.step {
                    *last_t_ms = t_ms;
                }
                self.samples.resize(entry.sampler.unit_count(), 0.0);
                let ahead_ms = (t_ms + period / 1_000).min(duration_ms);
                entry
                    .sampler
                    .sample(ahead_ms as f64, &mut self.samples, None);
                let targets_mm: Vec<f64> = self.samples.iter().map(|&mm| f64::from(mm)).collect();
                // The show's time and progress are the sequencer's, from
                // `show_start_us`.
                self.push_frame(slot_us, period, &targets_mm, Some((&entry.show, t_ms)));
                // Where the boxes are at the end of the frame's period (a locate moves
                // on from there).
                self.believed_mm = Some(targets_mm);
                let settle_ms = if last {
                    SETTLE_FRAMES * period / 1_000
                } else {
                    0
                };
                if t_ms + period / 1_000 >= duration_ms + settle_ms {
                    self.step = Step::Idle;
                    Phase::Done {
                        at_us: slot_us + period,
                    }
                } else {
                    Phase::Pending
                }
            }
            Step::Idle => Phase::Pending,
        }
    }

    /// Turns every unit's target into each box's frame, with the outputs of `show` at
    /// its time (0 without).
    fn push_frame(
        &mut self,
        slot_us: u64,
        time_us: u64,
        targets_mm: &[f64],
        show_at: Option<(&Show, u64)>,
    ) {
        let installation = &self.config.installation;
        let boxes = self.config.boxes.len();
        let outputs = match show_at {
            Some((show, t_ms)) => show.outputs_of_boxes(boxes, t_ms),
            None => vec![OutputSample::default(); boxes],
        };
        let mut positions: Vec<Vec<i32>> = self
            .config
            .boxes
            .iter()
            .map(|calibration| vec![calibration.pulses(0.0); calibration.axes])
            .collect();
        for (address, &mm) in installation.units.iter().zip(targets_mm) {
            let Some(calibration) = self.config.boxes.get(address.gateway) else {
                continue;
            };
            if let Some(axis) = positions
                .get_mut(address.gateway)
                .and_then(|axes| axes.get_mut(usize::from(address.station).wrapping_sub(1)))
            {
                *axis = calibration.pulses(mm);
            }
        }
        self.frames.push(MboxFrame {
            slot_us,
            time_ms: u32::try_from(time_us / 1_000).unwrap_or(u32::MAX).max(1),
            positions_pulses: positions,
            outputs,
            pace: None,
        });
    }
}

impl Drive for MboxDrive {
    type Entry = MboxEntry;

    fn begin_run(&mut self, now_us: u64, _first: Option<&mut MboxEntry>) {
        self.next_slot_us = now_us;
    }

    fn begin_home(&mut self, now_us: u64) {
        let installation = &self.config.installation;
        let targets = vec![installation.home_mm; installation.units.len()];
        self.begin_move(now_us, targets);
    }

    fn begin_approach(&mut self, now_us: u64, entry: &mut MboxEntry) -> bool {
        self.samples.resize(entry.sampler.unit_count(), 0.0);
        entry.sampler.sample(0.0, &mut self.samples, None);
        let targets: Vec<f64> = self.samples.iter().map(|&mm| f64::from(mm)).collect();
        self.begin_move(now_us, targets);
        true
    }

    fn begin_load(
        &mut self,
        _now_us: u64,
        _index: usize,
        _entry: &mut MboxEntry,
        _cycle: u32,
    ) -> bool {
        // Boxes take positions frame by frame: nothing is loaded ahead.
        false
    }

    fn begin_play(&mut self, now_us: u64, _entry: &mut MboxEntry, last: bool) {
        // The show's time 0 is a slot: its frame (the sample one period in) is the
        // show's first.
        let start_us = now_us.max(self.next_slot_us);
        self.next_slot_us = start_us;
        self.progress = 0.0;
        self.step = Step::Playing {
            start_us,
            last,
            last_t_ms: 0,
            trimmed_from: None,
        };
    }

    fn poll(&mut self, now_us: u64, entry: Option<&mut MboxEntry>) -> Phase {
        if matches!(self.step, Step::Idle) || now_us < self.next_slot_us {
            return Phase::Pending;
        }
        let period = self.period_us();
        let behind = (now_us - self.next_slot_us) / period;
        let slot_us = self.next_slot_us + behind * period;
        self.next_slot_us = slot_us + period;
        self.slot(slot_us, entry)
    }

    fn progress(&self) -> f64 {
        self.progress
    }

    fn show_start_us(&self) -> Option<u64> {
        match self.step {
            Step::Playing { start_us, .. } => Some(start_us),
            _ => None,
        }
    }

    fn trim_clock(&mut self, _now_us: u64, show_start_us: i64) {
        if let Step::Playing {
            start_us,
            trimmed_from,
            ..
        } = &mut self.step
        {
            // The show's start moves as far as the timecode's has since the first.
            let (own_us, first_us) = *trimmed_from.get_or_insert((*start_us, show_start_us));
            *start_us = own_us.saturating_add_signed(show_start_us - first_us);
        }
    }

    fn stop(&mut self) {
        self.step = Step::Idle;
        self.believed_mm = None;
        self.frames.clear();
        self.progress = 0.0;
    }

    /// A locate: the boxes follow frames, so the next move's frames take them on
    /// from where the last frame sent them — a show's frame says where they are at
    /// its period's end; a move's only where they head for (then the next move is
    /// timed for the whole travel, as from unknown positions).
    fn interrupt(&mut self, _now_us: u64) -> bool {
        if matches!(self.step, Step::Moving { .. }) {
            self.believed_mm = None;
        }
        self.step = Step::Idle;
        self.progress = 0.0;
        true
    }

    fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        Some(self.next_slot_us.max(now_us))
    }

    fn live_setup(&self) -> Result<LiveSetup, StartError> {
        let installation = &self.config.installation;
        let limits = installation.limits;
        let dt_ms = u32::try_from(self.period_us() / 1_000).unwrap_or(u32::MAX);
        Ok(LiveSetup {
            limits: FilterLimits {
                travel_mm: limits.travel_mm,
                max_speed_mm_s: limits.max_speed_mm_s * LIVE_SPEED_SHARE,
                max_accel_mm_s2: limits.max_accel_mm_s2
                    * live_accel_share(self.period_us(), &self.pace),
                dt_ms,
            },
            approach_speed_mm_s: installation.approach_speed_mm_s,
            layout: installation.layout(),
            latency_us: self.live_latency(),
            every_period: false,
        })
    }

    /// From an input reaching the bridge to the frame that carries it leaving, at most:
    /// a period waiting for the frame that takes it (while the input keeps changing;
    /// a change after a quiet period waits half of one at most), the frame lead, and
    /// the send lateness measured lately. The box starts the frame's line as it
    /// arrives: the ball follows from then (a switched LAN adds tens of µs).
    fn live_latency_us(&self) -> Option<u64> {
        Some(self.live_latency())
    }

    fn rest_positions_mm(&self) -> Option<Vec<f64>> {
        match self.step {
            Step::Idle => self.believed_mm.clone(),
            _ => None,
        }
    }

    fn begin_live(&mut self, now_us: u64, _states: &[BallState]) -> bool {
        self.step = Step::Idle;
        self.believed_mm = None;
        self.progress = 0.0;
        self.next_slot_us = self.next_slot_us.max(now_us);
        false
    }

    /// Half a period, at least 10 ms (none when that is a period or more).
    fn live_early_step_us(&self) -> Option<u64> {
        let period_us = self.period_us() / 1_000 * 1_000;
        let gap_us = (period_us / 2)
            .div_ceil(1_000)
            .saturating_mul(1_000)
            .max(crate::player::live::EARLY_STEP_MIN_US);
        (gap_us < period_us).then_some(gap_us)
    }

    fn live_step(&mut self, slot_us: u64, states: &[BallState]) {
        let period_us = self.config.period_us.max(1_000) / 1_000 * 1_000;
        let targets_mm: Vec<f64> = states.iter().map(|state| state.position_mm).collect();
        self.push_frame(slot_us, period_us, &targets_mm, None);
        if let Some(frame) = self.frames.last_mut() {
            frame.pace = Some(PaceLimits::clone(&self.pace));
        }
        self.next_slot_us = slot_us + period_us;
    }

    fn end_live(&mut self, at_us: u64, states: &[BallState]) {
        self.believed_mm = Some(states.iter().map(|state| state.position_mm).collect());
        self.next_slot_us = self.next_slot_us.max(at_us);
        self.progress = 1.0;
    }
}
