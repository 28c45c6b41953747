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
//!   ahead, so each frame tells every box where to be at the end of the period (the
//!   first, at the show's time 0, carries the sample one period in); repeat
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

use crate::api::{PlanReport, Status};
pub use crate::mbox::drive::{
    BoxCalibration, DEFAULT_PERIOD_US, MboxFrame, MboxPlayerConfig, SETTLE_FRAMES,
};
use crate::mbox::drive::{MboxDrive, MboxEntry};
use crate::plan::Installation;
use crate::plan::verdict::{Why, verdict_report};
use crate::player::{Entry, StartError};
use crate::player::{Run, Sequencer};
use crate::show::Show;

/// The MBOX player: the show sequencer ([`crate::player`]) over the boxes' drive
/// ([`crate::mbox::drive`]); see the [module documentation](self).
#[derive(Debug)]
pub struct MboxPlayer {
    sequencer: Sequencer<MboxDrive>,
}

/// The playlist as the sequencer runs it on boxes (checked with
/// [`MboxPlayer::check`]).
#[must_use]
pub fn runs(entries: Vec<Entry>) -> Vec<Run<MboxEntry>> {
    entries
        .into_iter()
        .map(|entry| Run {
            name: entry.show.name.clone(),
            duration_ms: entry.show.duration_ms(),
            timing: entry.timing(),
            prepared: MboxEntry::new(entry.show),
        })
        .collect()
}

impl MboxPlayer {
    /// A player for the boxes in `config`, idle, positions unknown.
    #[must_use]
    pub fn new(config: MboxPlayerConfig) -> Self {
        Self {
            sequencer: Sequencer::new(MboxDrive::new(config)),
        }
    }

    /// The boxes and installation it plays on.
    #[must_use]
    pub fn config(&self) -> &MboxPlayerConfig {
        self.sequencer.drive().config()
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
        self.sequencer.status()
    }

    /// Whether a playlist runs (waiting, moving or playing).
    #[must_use]
    pub fn is_running(&self) -> bool {
        self.sequencer.is_running()
    }

    /// The frames to send now, in order.
    pub fn take_frames(&mut self) -> Vec<MboxFrame> {
        self.sequencer.drive_mut().take_frames()
    }

    /// When the player wants to be polled next, µs; `None` while at rest.
    #[must_use]
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        self.sequencer.next_wakeup_us(now_us)
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
        Self::check(&self.sequencer.drive().config().installation, &entries)?;
        self.sequencer.start(now_us, runs(entries), loop_playlist)
    }

    /// Start with a playlist [`MboxPlayer::check`]ed already, unless a playlist runs.
    /// Returns whether it started.
    pub fn start_checked(&mut self, now_us: u64, entries: Vec<Entry>, loop_playlist: bool) -> bool {
        self.sequencer
            .start(now_us, runs(entries), loop_playlist)
            .is_ok()
    }

    /// E-stop: stops sending at once; positions become unknown.
    pub fn estop(&mut self) {
        self.sequencer.estop();
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
        let installation = self.sequencer.drive().config().installation.clone();
        let entries = entries
            .and_then(|entries| Self::check(&installation, &entries).map(|()| runs(entries)));
        self.sequencer.reset(now_us, entries, loop_playlist)
    }

    /// Home: stops, brings every axis home and stays idle.
    pub fn home(&mut self, now_us: u64) {
        self.sequencer.home(now_us);
    }

    /// Fails the running playlist with `reason` (the bridge presses the e-stop).
    pub fn fail_with(&mut self, reason: String) {
        self.sequencer.fail_with(reason);
    }

    /// A timecode chase's clock trim: entry `entry`'s (0-based) show has its time 0
    /// at `show_start_us` ([`crate::player::Drive::trim_clock`]: the frames follow it).
    pub fn trim_clock(&mut self, now_us: u64, entry: usize, show_start_us: i64) {
        self.sequencer.trim_clock(now_us, entry, show_start_us);
    }

    /// Moves on in time: emits the frames of every slot due by `now_us` (only the
    /// latest when late: a box goes to the newest position).
    pub fn poll(&mut self, now_us: u64) {
        self.sequencer.poll(now_us);
    }

    /// Live mode ([`crate::player::live`]): the sequencer under the player, for
    /// [`Sequencer::go_live`], [`Sequencer::set_live_input`],
    /// [`Sequencer::leave_live`], [`Sequencer::start_recording`] and
    /// [`Sequencer::stop_recording`]; frames come out of [`MboxPlayer::take_frames`]
    /// as for a show.
    pub fn sequencer_mut(&mut self) -> &mut Sequencer<MboxDrive> {
        &mut self.sequencer
    }

    /// The sequencer under the player.
    #[must_use]
    pub fn sequencer(&self) -> &Sequencer<MboxDrive> {
        &self.sequencer
    }
}

/// Why `show` cannot play on the MBOX `installation`: the first violation of its
/// limits (and how many more), a ball count that differs, or an output track for a box
/// it lacks. `None` when it can.
fn unfit_verdict(installation: &Installation, show: &Show) -> Option<Why> {
    crate::plan::report::unfit_verdict(installation, show)
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
#[path = "player_tests.rs"]
mod tests;
