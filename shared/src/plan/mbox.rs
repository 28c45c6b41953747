//! The MBOX player: plays a playlist on MBOX boxes as a sans-IO state machine, with
//! the same semantics and [`PlayerState`]s as the UIM2503 player
//! ([`super::player`]). The bridge polls it with the time and sends the
//! [`MboxFrame`]s it returns, one datagram per box, all boxes in the same period.
//!
//! - **Start** checks every entry (layout, limits) before anything moves, homes first
//!   when the axes' positions are unknown (after startup or an e-stop), then for each
//!   entry: wait `delay_ms`; **approach** (every axis from its last commanded position
//!   to the show's first, at the installation's approach speed); **play** the show,
//!   one frame per period, sampled by the preview's evaluator ([`Sampler`]) one period
//!   ahead, so each frame tells every box where to be at the end of the period; repeat
//!   `cycles` times; next entry; after the last, stop or start over (loop).
//! - A box cannot report where its axes are, so the player tracks the last commanded
//!   positions. A move whose start is unknown (homing after an e-stop) lasts as long
//!   as the longest possible move (the whole travel at the approach speed), and every
//!   frame of a move carries the move's target and the time left, so each box moves
//!   from wherever it is, and a lost frame is made good by the next.
//! - A move, and the last show of a playlist, end with [`SETTLE_FRAMES`] more frames
//!   holding the final positions: positions are absolute, so a lost last frame is
//!   repeated.
//! - **Outputs**: while a show plays, each frame carries every box's digital and
//!   analog outputs sampled from the show's output tracks at the frame's show time
//!   (the clock of the positions; a box sets its outputs when the frame arrives).
//!   Frames of moves (approach, homing for Start, Reset or Home) and the settle frames
//!   after the last show carry 0, so the outputs are off when a show ends and while
//!   homing. A show without output tracks plays with every output 0.
//! - **E-stop** stops sending at once (the bridge sends the boxes' e-stop); the next
//!   Start homes first. **Reset** stops, homes and plays from the first entry;
//!   **Home** stops, homes and stays idle. No frame follows an e-stop, so the outputs
//!   stay whatever the boxes keep from the last frame until the next frame (homing
//!   sends 0).

use super::installation::Installation;
use super::player::{Entry, NextRun, PlaylistProgress, StartError, next_run};
use super::verdict::{Why, verdict_report};
use crate::api::{PlanReport, PlayerState, Status};
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
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterMove {
    /// Play the current entry.
    Play,
    /// Begin the playlist's first entry.
    First,
    /// Stay idle.
    Rest,
}

#[derive(Debug, Clone)]
enum Step {
    Idle,
    Waiting {
        until_us: u64,
    },
    Moving {
        /// Approaching or Homing.
        kind: PlayerState,
        targets_mm: Vec<f64>,
        began_us: u64,
        arrive_us: u64,
        after: AfterMove,
    },
    Playing {
        start_us: u64,
    },
    Stopped,
    Failed,
}

/// The MBOX player; see the [module documentation](self).
#[derive(Debug)]
pub struct MboxPlayer {
    config: MboxPlayerConfig,
    entries: Vec<Entry>,
    samplers: Vec<Sampler>,
    loop_playlist: bool,
    entry: usize,
    cycle: u32,
    step: Step,
    /// The last commanded positions, mm; `None` when unknown.
    believed_mm: Option<Vec<f64>>,
    /// The next frame slot, µs.
    next_slot_us: u64,
    frames: Vec<MboxFrame>,
    samples: Vec<f32>,
    last_error: Option<String>,
    show_time_ms: u64,
    progress: f64,
}

impl MboxPlayer {
    /// A player for the boxes in `config`, idle, positions unknown.
    #[must_use]
    pub fn new(config: MboxPlayerConfig) -> Self {
        Self {
            config,
            entries: Vec::new(),
            samplers: Vec::new(),
            loop_playlist: false,
            entry: 0,
            cycle: 0,
            step: Step::Idle,
            believed_mm: None,
            next_slot_us: 0,
            frames: Vec::new(),
            samples: Vec::new(),
            last_error: None,
            show_time_ms: 0,
            progress: 0.0,
        }
    }

    /// The frame period, µs (at least 1 ms).
    fn period_us(&self) -> u64 {
        self.config.period_us.max(1_000)
    }

    /// Checks every entry against the installation before anything moves.
    ///
    /// # Errors
    /// [`StartError::Empty`] or [`StartError::Invalid`] naming the entry.
    pub fn check(installation: &Installation, entries: &[Entry]) -> Result<(), StartError> {
        if entries.is_empty() {
            return Err(StartError::Empty);
        }
        for (index, entry) in entries.iter().enumerate() {
            if let Some(reason) = unfit_verdict(installation, &entry.show) {
                return Err(StartError::Invalid {
                    entry: index + 1,
                    show: entry.show.name.clone(),
                    reason: Box::new(reason),
                });
            }
        }
        Ok(())
    }

    /// The playlist's state as the status shows it (the bridge adds the boxes).
    #[must_use]
    pub fn status(&self) -> Status {
        let state = match &self.step {
            Step::Idle => PlayerState::Idle,
            Step::Waiting { .. } => PlayerState::Waiting,
            Step::Moving { kind, .. } => *kind,
            Step::Playing { .. } => PlayerState::Playing,
            Step::Stopped => PlayerState::Stopped,
            Step::Failed => PlayerState::Error,
        };
        let homing_to_rest = matches!(
            self.step,
            Step::Moving {
                after: AfterMove::Rest,
                ..
            }
        );
        let active = self.is_running() && !homing_to_rest;
        let entry = active.then(|| self.entries.get(self.entry)).flatten();
        PlaylistProgress {
            state,
            playing: entry.map(|entry| {
                (
                    self.entry,
                    entry.show.name.clone(),
                    entry.show.duration_ms(),
                )
            }),
            show_time_ms: self.show_time_ms,
            cycle: self.cycle,
            progress: self.progress,
            last_error: self.last_error.clone(),
        }
        .status()
    }

    /// Whether a playlist runs (waiting, moving or playing).
    #[must_use]
    pub fn is_running(&self) -> bool {
        matches!(
            self.step,
            Step::Waiting { .. } | Step::Moving { .. } | Step::Playing { .. }
        )
    }

    /// The frames to send now, in order.
    pub fn take_frames(&mut self) -> Vec<MboxFrame> {
        std::mem::take(&mut self.frames)
    }

    /// When the player wants to be polled next, µs; `None` while at rest.
    #[must_use]
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        match &self.step {
            Step::Idle | Step::Stopped | Step::Failed => None,
            Step::Waiting { until_us } => Some((*until_us).max(now_us)),
            _ => Some(self.next_slot_us.max(now_us)),
        }
    }

    /// Start: checks the playlist, homes first if the positions are unknown, then plays
    /// from the first entry.
    ///
    /// # Errors
    /// [`StartError::Busy`] while a playlist runs, or why the playlist cannot run;
    /// nothing was changed.
    pub fn start(
        &mut self,
        now_us: u64,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        if self.is_running() {
            return Err(StartError::Busy);
        }
        Self::check(&self.config.installation, &entries)?;
        self.start_checked(now_us, entries, loop_playlist);
        Ok(())
    }

    /// Start with a playlist [`MboxPlayer::check`]ed already, unless a playlist runs.
    /// Returns whether it started.
    pub fn start_checked(&mut self, now_us: u64, entries: Vec<Entry>, loop_playlist: bool) -> bool {
        if self.is_running() {
            return false;
        }
        self.samplers = entries
            .iter()
            .map(|entry| Sampler::new(&entry.show))
            .collect();
        self.entries = entries;
        self.loop_playlist = loop_playlist;
        self.last_error = None;
        self.next_slot_us = now_us;
        if self.believed_mm.is_none() {
            self.begin_home(now_us, AfterMove::First);
        } else {
            self.begin_entry(now_us, 0);
        }
        true
    }

    /// E-stop: stops sending at once; positions become unknown.
    pub fn estop(&mut self) {
        if !matches!(self.step, Step::Failed) {
            self.step = Step::Stopped;
        }
        self.believed_mm = None;
        self.frames.clear();
        self.progress = 0.0;
    }

    /// Reset: stops, homes and plays the playlist from its first entry.
    ///
    /// # Errors
    /// Why the playlist cannot run; the player stays stopped.
    pub fn reset(
        &mut self,
        now_us: u64,
        entries: Result<Vec<Entry>, StartError>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        self.estop();
        self.step = Step::Stopped;
        let result = entries.and_then(|entries| self.start(now_us, entries, loop_playlist));
        if let Err(error) = &result {
            self.last_error = Some(error.to_string());
        }
        result
    }

    /// Home: stops, brings every axis home and stays idle.
    pub fn home(&mut self, now_us: u64) {
        self.estop();
        self.last_error = None;
        self.next_slot_us = now_us;
        self.begin_home(now_us, AfterMove::Rest);
    }

    /// Fails the running playlist with `reason` (the bridge presses the e-stop).
    pub fn fail_with(&mut self, reason: String) {
        if self.is_running() {
            self.estop();
            self.step = Step::Failed;
            self.last_error = Some(reason);
        }
    }

    /// Moves on in time: emits the frames of every slot due by `now_us` (only the
    /// latest when late: a box goes to the newest position).
    pub fn poll(&mut self, now_us: u64) {
        if let Step::Waiting { until_us } = self.step {
            if now_us < until_us {
                return;
            }
            self.next_slot_us = self.next_slot_us.max(until_us);
            self.begin_approach(until_us);
        }
        if !self.is_running() || now_us < self.next_slot_us {
            return;
        }
        let period = self.period_us();
        let behind = (now_us - self.next_slot_us) / period;
        let slot_us = self.next_slot_us + behind * period;
        self.next_slot_us = slot_us + period;
        self.slot(slot_us);
    }

    /// The frame of one slot, and what follows it.
    fn slot(&mut self, slot_us: u64) {
        let period = self.period_us();
        match &self.step {
            Step::Moving {
                targets_mm,
                began_us,
                arrive_us,
                after,
                ..
            } => {
                let (targets_mm, began_us, arrive_us, after) =
                    (targets_mm.clone(), *began_us, *arrive_us, *after);
                let left_us = arrive_us.saturating_sub(slot_us).max(period);
                self.push_frame(slot_us, left_us, &targets_mm, None);
                if slot_us >= arrive_us + SETTLE_FRAMES * period {
                    self.believed_mm = Some(targets_mm);
                    self.progress = 1.0;
                    match after {
                        AfterMove::Rest => self.step = Step::Idle,
                        AfterMove::First => self.begin_entry(slot_us, 0),
                        AfterMove::Play => self.begin_play(slot_us),
                    }
                } else {
                    let span = arrive_us.saturating_sub(began_us).max(1) as f64;
                    let done = slot_us.saturating_sub(began_us) as f64;
                    self.progress = (done / span).min(1.0);
                }
            }
            Step::Playing { start_us } => {
                let start_us = *start_us;
                let Some(sampler) = self.samplers.get_mut(self.entry) else {
                    return;
                };
                let duration_ms = sampler.duration_ms();
                let t_ms = slot_us.saturating_sub(start_us) / 1_000;
                self.samples.resize(sampler.unit_count(), 0.0);
                let ahead_ms = (t_ms + period / 1_000).min(duration_ms);
                sampler.sample(ahead_ms as f64, &mut self.samples, None);
                let targets_mm: Vec<f64> = self.samples.iter().map(|&mm| f64::from(mm)).collect();
                self.show_time_ms = t_ms.min(duration_ms);
                self.progress = if duration_ms == 0 {
                    1.0
                } else {
                    (self.show_time_ms as f64 / duration_ms as f64).min(1.0)
                };
                self.push_frame(slot_us, period, &targets_mm, Some(t_ms));
                let last = self.entry + 1 == self.entries.len()
                    && self.cycle >= self.entries[self.entry].cycles.max(1)
                    && !self.loop_playlist;
                let settle_ms = if last {
                    SETTLE_FRAMES * period / 1_000
                } else {
                    0
                };
                if t_ms + period / 1_000 >= duration_ms + settle_ms {
                    self.believed_mm = Some(targets_mm);
                    self.next_run(slot_us + period);
                }
            }
            _ => {}
        }
    }

    /// After a show's cycle: the next cycle, entry, the playlist again, or rest.
    fn next_run(&mut self, now_us: u64) {
        match next_run(
            &self.entries,
            self.entry,
            &mut self.cycle,
            self.loop_playlist,
        ) {
            NextRun::Cycle => self.begin_approach(now_us),
            NextRun::Entry(entry) => self.begin_entry(now_us, entry),
            NextRun::Rest => {
                self.step = Step::Idle;
                self.progress = 1.0;
            }
        }
    }

    fn begin_entry(&mut self, now_us: u64, entry: usize) {
        self.entry = entry;
        self.cycle = 1;
        self.show_time_ms = 0;
        self.progress = 0.0;
        let delay_us = self
            .entries
            .get(entry)
            .map_or(0, |entry| entry.delay_ms.saturating_mul(1_000));
        if delay_us > 0 {
            self.step = Step::Waiting {
                until_us: now_us + delay_us,
            };
        } else {
            self.begin_approach(now_us);
        }
    }

    fn begin_approach(&mut self, now_us: u64) {
        let Some(sampler) = self.samplers.get_mut(self.entry) else {
            return;
        };
        self.samples.resize(sampler.unit_count(), 0.0);
        sampler.sample(0.0, &mut self.samples, None);
        let targets: Vec<f64> = self.samples.iter().map(|&mm| f64::from(mm)).collect();
        self.show_time_ms = 0;
        self.begin_move(now_us, PlayerState::Approaching, targets, AfterMove::Play);
    }

    fn begin_home(&mut self, now_us: u64, after: AfterMove) {
        let installation = &self.config.installation;
        let targets = vec![installation.home_mm; installation.units.len()];
        self.begin_move(now_us, PlayerState::Homing, targets, after);
    }

    fn begin_move(
        &mut self,
        now_us: u64,
        kind: PlayerState,
        targets_mm: Vec<f64>,
        after: AfterMove,
    ) {
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
            kind,
            targets_mm,
            began_us: now_us,
            arrive_us: now_us + move_us,
            after,
        };
    }

    fn begin_play(&mut self, now_us: u64) {
        self.show_time_ms = 0;
        self.progress = 0.0;
        self.step = Step::Playing { start_us: now_us };
    }

    /// Turns every unit's target into each box's frame, with the outputs of the
    /// current show at `show_t_ms` (0 without).
    fn push_frame(
        &mut self,
        slot_us: u64,
        time_us: u64,
        targets_mm: &[f64],
        show_t_ms: Option<u64>,
    ) {
        let installation = &self.config.installation;
        let show = self.entries.get(self.entry).map(|entry| &entry.show);
        let boxes = self.config.boxes.len();
        let outputs = match (show, show_t_ms) {
            (Some(show), Some(t_ms)) => show.outputs_of_boxes(boxes, t_ms),
            _ => vec![OutputSample::default(); boxes],
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
        });
    }
}

/// Why `show` cannot play on the MBOX `installation`: the first violation of its
/// limits (and how many more), a ball count that differs, or an output track for a box
/// it lacks. `None` when it can.
fn unfit_verdict(installation: &Installation, show: &Show) -> Option<Why> {
    super::report::unfit_verdict(installation, show)
        .or_else(|| unknown_output_box(installation, show))
}

/// The verdict on `show` for an MBOX installation (`GET /api/plan/{name}`, shown before
/// Start). Boxes take one frame per period over Ethernet — 66 bytes per 10-axis box
/// every 20 ms is 3.3 kB/s — so no line limits a show as a UIM2503's serial line does:
/// it can run when it fits the installation, by the same check as Start. The report
/// has no per-gateway line figures (those describe serial lines).
#[must_use]
pub fn report(show: &Show, installation: &Installation) -> PlanReport {
    let why = unfit_verdict(installation, show);
    verdict_report(show.name.clone(), why.as_ref(), &[], Vec::new())
}

/// Why `show`'s outputs cannot play on `installation`: a track for a box it lacks.
fn unknown_output_box(installation: &Installation, show: &Show) -> Option<Why> {
    let boxes = installation.mbox_boxes().unwrap_or(0);
    let box_index = show.output_box_beyond(boxes)?;
    Some(Why::OutputBox { box_index, boxes })
}

#[cfg(test)]
#[path = "mbox_tests.rs"]
mod tests;
