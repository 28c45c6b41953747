//! The chase: a playlist kept in step with a timecode (`docs/show-control.md`).
//!
//! [`Chase`] is fed the timecode as it arrives ([`Chase::timecode`]: the time it
//! carries and the instant it arrived), what the player does ([`Chase::player`]: from
//! each status) and is asked, every few milliseconds, what to do now
//! ([`Chase::poll`]). It answers with an [`Action`] for the bridge to issue — never
//! more than one at a time: it waits for the player to show the result first.
//!
//! - **Cues** ([`cues`]): an entry with its own timecode start, or every entry laid
//!   out one after another from the playlist's timecode start (each after its delay,
//!   its show's length × its cycles after the one before). An entry's cue spans its
//!   show's first cycle: the show time at timecode `t` is `t − start`.
//! - **Start**: when the timecode, running, reaches a cue's start less the lead — how
//!   long from a Start until the show's clock is at the time asked for (approach,
//!   preload, a cut's run-up) — [`Action::Start`] of that entry at the time the show
//!   will have then: 0 when on time, later when the timecode started inside the cue.
//!   The lead is the plan's estimate for the cue when the bridge gives one
//!   ([`Chase::lead_wanted`], [`Chase::set_lead_estimate`]: approach and load,
//!   [`super::lead`]), corrected by how far the last measured lead was from its
//!   estimate; without one the configured lead until the first start is seen
//!   playing, and from then on the lead measured at the last start (separately for
//!   starts and locates; a locate's is a start's until one is measured).
//! - **Locate**: a sample more than the threshold away from where the running
//!   timecode was expected (a jump), or the show more than the threshold out of step
//!   while chasing, after the first second: [`Action::Locate`] (the show under way
//!   ends without an e-stop, the balls go from where they are to the new point and
//!   play from there) at the show time the timecode will have a locate's lead later,
//!   or [`Action::Stop`] when the new time is in no cue. The lead is measured once
//!   the player was seen not playing since (until then `playing` is the old show).
//! - **Loss**: no timecode, or a timecode that does not advance, for longer than the
//!   loss time while the chase has the matrix: [`OnLoss::Hold`] lets the show play on
//!   on the units' own clock (the chase takes it back when the timecode returns, with
//!   a locate if it is out of step); [`OnLoss::Stop`] stops and homes.
//! - **Refusals back off**: a refused action is tried again after [`RETRY_MS`], and
//!   each further refusal of the same action (a Start, or a Locate, of the same
//!   entry) doubles the wait up to [`RETRY_MAX_MS`] — a refused Start prepares the
//!   show each time (on MOONS' drives it compiles every ball's Q program). The wait
//!   is back to [`RETRY_MS`] (and the next try due at once) when the cues change
//!   (the playlist was edited), the player's state changes (an operator cleared the
//!   e-stop, the show played) or the timecode jumps.
//! - A cue the chase started and that was then stopped from elsewhere (an operator's
//!   Home) is not started again until the timecode leaves it or jumps.
//! - **Where the timecode is**: the running timecode's origin on the clock is the
//!   earliest its last second of samples puts it at ([`WINDOW_MS`]) — a sample is
//!   late, never early (its frame began before it was sent; it took time to arrive),
//!   so neither the frames' steps nor a late datagram shake the show's clock.
//! - **Offset and drift**: the offset is the show's time less the timecode's show
//!   time, taken at each status; the drift is how much the offset moved since the
//!   chase locked on, a second after the show began playing (the units' clock against
//!   the timecode's).
//! - **Clock trim** ([`Chase::trim`]): while chasing, the instant the timecode puts
//!   the show's time 0 at (the offset locked on kept), for the drive to pull the
//!   units' clock toward — so the drift is corrected where the family allows, without
//!   a locate.

use std::collections::VecDeque;

use serde::{Deserialize, Serialize};

use super::{FrameRate, Timecode};

/// Before a start at so little into a show, the show starts from its beginning
/// (a cut shorter than a frame or two is not worth its run-up).
pub const START_AT_ZERO_WITHIN_MS: u64 = 40;
/// After going `playing`, how long the offset is not acted on (the status's show time
/// settles).
pub const SETTLE_MS: u64 = 1_000;
/// How far back the running timecode's samples are read for where it is now, ms: a
/// frame's time comes late (it is sent when the frame began, or later, and takes time
/// to arrive), so the earliest origin over this window is the truest.
pub const WINDOW_MS: u64 = 1_000;

/// How long a Start waits for a lead being estimated ([`Chase::estimating`]), ms.
pub const ESTIMATE_WAIT_MS: u64 = 500;

/// How long a refused action is not tried again (the first time).
pub const RETRY_MS: u64 = 1_000;
/// The longest a refused action waits before it is tried again: each refusal of the
/// same action (a Start, or a Locate, of the same entry) doubles the wait, up to this.
pub const RETRY_MAX_MS: u64 = 30_000;
/// How long a Start or Locate may take to show `playing` before the chase gives up
/// waiting for it.
pub const PENDING_TIMEOUT_MS: u64 = 120_000;
/// A cue is not started with less than this left of its first cycle.
pub const MIN_LEFT_MS: u64 = 500;

/// What to do when the timecode stops or vanishes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OnLoss {
    /// The show plays on, on the units' own clock.
    Hold,
    /// Stop and home.
    Stop,
}

/// The chase's settings (`[timecode]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ChaseConfig {
    /// A jump of the timecode, or an offset of the show, beyond this is a locate, ms.
    pub locate_threshold_ms: u64,
    /// No timecode, or one standing still, for longer than this is a loss, ms.
    pub loss_ms: u64,
    /// What a loss does.
    pub on_loss: OnLoss,
    /// The lead assumed until one is measured, ms (a locate's: one and a half times
    /// this).
    pub lead_ms: u64,
}

/// Where an entry's first cycle sits on the timecode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Cue {
    /// The playlist entry, 0-based.
    pub entry: usize,
    /// The timecode of its show's time 0, ms since 00:00:00:00.
    pub start_ms: u64,
    /// Its show's length, ms.
    pub duration_ms: u64,
    /// Its delay, ms: a Start at its show's time 0 waits it first (a Start inside the
    /// show does not).
    pub delay_ms: u64,
}

/// One playlist entry as the cues see it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CueEntry {
    /// Its own timecode start, ms, if it has one.
    pub start_ms: Option<u64>,
    /// The delay before it, ms.
    pub delay_ms: u64,
    /// Its show's length, ms.
    pub duration_ms: u64,
    /// Its cycles.
    pub cycles: u32,
}

/// The cues of a playlist: an entry's own start, else the end of the entry before it
/// (its start + its show × its cycles) plus its delay, from the playlist's start
/// (`playlist_start_ms`, entry 1 at it plus its delay). Entries before any start have
/// no cue.
pub fn cues(entries: &[CueEntry], playlist_start_ms: Option<u64>) -> Vec<Cue> {
    let mut next = playlist_start_ms;
    let mut cues = Vec::new();
    for (entry, one) in entries.iter().enumerate() {
        let start = one.start_ms.or(next.map(|end| end + one.delay_ms));
        if let Some(start_ms) = start {
            cues.push(Cue {
                entry,
                start_ms,
                duration_ms: one.duration_ms,
                delay_ms: one.delay_ms,
            });
        }
        next = start.map(|start| start + one.duration_ms * u64::from(one.cycles.max(1)));
    }
    cues
}

/// What the player is doing, as the chase needs it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlayerView {
    /// Nothing under way: a Start may be issued.
    #[default]
    Idle,
    /// Approaching, loading, homing, waiting between entries.
    Busy,
    /// Playing entry `entry` (0-based), at show time `show_time_ms` when the status
    /// was made.
    Playing {
        /// The entry, 0-based.
        entry: usize,
        /// The show's time, ms.
        show_time_ms: u64,
    },
}

/// What the bridge is to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Start `entry` (0-based) at show time `time_ms`.
    Start {
        /// The entry, 0-based.
        entry: usize,
        /// The show time, ms.
        time_ms: u64,
    },
    /// End the show under way without an e-stop, go from where the balls are to
    /// `entry` (0-based) at `time_ms`, and play from there (a locate).
    Locate {
        /// The entry, 0-based.
        entry: usize,
        /// The show time, ms.
        time_ms: u64,
    },
    /// Stop and home (a Home).
    Stop,
}

/// The chase's state, as the Control page shows it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ChaseState {
    /// No timecode has arrived.
    #[default]
    NoTimecode,
    /// The timecode runs; no cue is due (or the one due was stopped from elsewhere).
    Waiting,
    /// A Start was issued; waiting for the show to play.
    Cued,
    /// The show plays in step with the timecode.
    Chasing,
    /// A locate was issued; waiting for the show to play from the new point.
    Locating,
    /// The timecode stopped or vanished; the show plays on on its own clock.
    Holding,
    /// The timecode stopped or vanished; the matrix was stopped and homed.
    Stopped,
    /// The timecode stopped or vanished while nothing played.
    Lost,
}

/// The chase as clients see it (`ServerMessage::Timecode`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TimecodeStatus {
    /// Where the timecode comes from: `artnet` or `mtc`.
    pub source: String,
    /// The chase's state.
    pub state: ChaseState,
    /// The timecode now (`HH:MM:SS:FF`, `;` before the frames for drop-frame).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timecode: Option<String>,
    /// Its frame rate.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rate: Option<FrameRate>,
    /// Whether it advances.
    pub running: bool,
    /// The entry chased, 1-based.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entry: Option<usize>,
    /// The show's time less the timecode's time into the entry's cue, ms (positive:
    /// the show is ahead).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub offset_ms: Option<i64>,
    /// The lead of a Start, ms.
    pub lead_ms: u64,
    /// The lead of a locate, ms.
    pub locate_lead_ms: u64,
    /// Whether the leads were measured (else they are the configured estimate).
    pub lead_measured: bool,
    /// How far the offset moved since the chase locked on, ms (the units' clock
    /// against the timecode's), and over how long.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drift_ms: Option<i64>,
    /// The time the drift was taken over, ms.
    pub drift_over_ms: u64,
    /// Locates issued so far.
    pub locates: u32,
    /// Why the last action was refused, if it was.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub refused: Option<String>,
}

/// What the chase has issued and waits on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// Nothing issued (a show may still play: started elsewhere).
    Idle,
    /// A Start (`locate` false) or Locate was issued at `issued_at_ms` for `entry` at
    /// show time `target_ms`.
    Pending {
        locate: bool,
        entry: usize,
        target_ms: u64,
        issued_at_ms: u64,
        /// The entry's delay, waited before a start at time 0.
        delay_ms: u64,
        /// The player was seen not playing since the action was issued: a locate
        /// ends the show under way without a stop, so until then `playing` is the
        /// old show's.
        left_playing: bool,
    },
    /// Playing in step since `since_ms`.
    Chasing { since_ms: u64 },
    /// Lost; holding.
    Holding,
    /// Lost; stopped.
    Stopped,
}

/// The last timecode sample.
#[derive(Debug, Clone, Copy)]
struct Sample {
    tc_ms: u64,
    at_ms: u64,
    /// It advanced from the one before.
    advancing: bool,
    rate: FrameRate,
}

/// The chase (see the module's documentation).
#[derive(Debug, Clone)]
pub struct Chase {
    config: ChaseConfig,
    source: String,
    cues: Vec<Cue>,
    last: Option<Sample>,
    /// When the timecode last advanced.
    advanced_at_ms: u64,
    /// A jump was seen and not yet acted on.
    jumped: bool,
    player: PlayerView,
    /// The offset at the last playing status, and when.
    offset: Option<(i64, u64)>,
    /// The offset when the chase locked on, and when.
    locked: Option<(i64, u64)>,
    phase: Phase,
    lead_ms: u64,
    locate_lead_ms: u64,
    lead_measured: bool,
    locate_measured: bool,
    /// The cue (its entry) the chase started last.
    started: Option<usize>,
    locates: u32,
    refused: Option<String>,
    retry_at_ms: u64,
    /// The action issued last, as refusals count it: (a locate, its entry).
    issued: Option<(bool, usize)>,
    /// The leads estimated from the plan ([`Chase::set_lead_estimate`]): per entry,
    /// the show time it was for, a Start's lead and a locate's, ms.
    estimates: Vec<(usize, u64, u64, u64)>,
    /// The estimate the last Start was issued with, ms.
    estimate_used: Option<u64>,
    /// Since when the bridge is estimating a lead ([`Chase::estimating`]), ms.
    estimating_since: Option<u64>,
    /// How much longer the last measured lead was than its estimate, ms.
    estimate_error_ms: Option<i64>,
    /// The running timecode's last [`WINDOW_MS`] of samples: when each arrived, and
    /// that less its time (where it puts the timecode's origin on the clock).
    window: VecDeque<(u64, i64)>,
    /// The last refused action and how long it waits now, ms.
    backoff: Option<((bool, usize), u64)>,
}

impl Chase {
    /// A chase over `cues` from the timecode of `source` (`artnet`, `mtc`).
    pub fn new(config: ChaseConfig, source: &str, cues: Vec<Cue>) -> Self {
        Self {
            config,
            source: source.to_owned(),
            cues,
            last: None,
            advanced_at_ms: 0,
            jumped: false,
            player: PlayerView::Idle,
            offset: None,
            locked: None,
            phase: Phase::Idle,
            lead_ms: config.lead_ms,
            locate_lead_ms: config.lead_ms,
            lead_measured: false,
            locate_measured: false,
            started: None,
            locates: 0,
            refused: None,
            retry_at_ms: 0,
            issued: None,
            backoff: None,
            window: VecDeque::new(),
            estimates: Vec::new(),
            estimate_used: None,
            estimating_since: None,
            estimate_error_ms: None,
        }
    }

    /// The cues now (the playlist changed): a refusal's back-off starts over.
    pub fn set_cues(&mut self, cues: Vec<Cue>) {
        if cues != self.cues {
            self.reset_backoff();
        }
        self.cues = cues;
    }

    /// Forgets the refusals' back-off: the next try is due at once.
    fn reset_backoff(&mut self) {
        if self.backoff.take().is_some() {
            self.retry_at_ms = 0;
        }
    }

    /// How long the last refused action waits before it is tried again, ms (0: none
    /// refused).
    pub fn retry_wait_ms(&self) -> u64 {
        self.backoff.map_or(0, |(_, wait)| wait)
    }

    /// The cues.
    pub fn cues(&self) -> &[Cue] {
        &self.cues
    }

    /// A timecode sample: `timecode` arrived at `at_ms` (the bridge's clock).
    pub fn timecode(&mut self, timecode: Timecode, at_ms: u64) {
        let tc_ms = timecode.to_ms();
        let advancing = match self.last {
            None => false,
            Some(last) => {
                let expected = self.expected_at(last, at_ms);
                if tc_ms.abs_diff(expected) > self.config.locate_threshold_ms {
                    self.jumped = true;
                    self.reset_backoff();
                    self.estimates.clear();
                }
                tc_ms > last.tc_ms
            }
        };
        if advancing || self.last.is_none() {
            self.advanced_at_ms = at_ms;
        }
        if self.jumped || !advancing {
            self.window.clear();
        }
        if advancing {
            while self
                .window
                .front()
                .is_some_and(|&(at, _)| at + WINDOW_MS < at_ms)
            {
                self.window.pop_front();
            }
            self.window.push_back((at_ms, at_ms as i64 - tc_ms as i64));
        }
        self.last = Some(Sample {
            tc_ms,
            at_ms,
            advancing,
            rate: timecode.rate,
        });
    }

    /// A locate the sender announced (MTC's full frame): the timecode is at
    /// `timecode` now and stands there until it runs again.
    pub fn locate_to(&mut self, timecode: Timecode, at_ms: u64) {
        if let Some(last) = self.last
            && timecode.to_ms().abs_diff(self.expected_at(last, at_ms))
                > self.config.locate_threshold_ms
        {
            self.jumped = true;
            self.reset_backoff();
            self.estimates.clear();
        }
        self.last = Some(Sample {
            tc_ms: timecode.to_ms(),
            at_ms,
            advancing: false,
            rate: timecode.rate,
        });
    }

    /// Where `last` puts the timecode at `at_ms`: on from it when it was advancing
    /// (and not lost), else it.
    fn expected_at(&self, last: Sample, at_ms: u64) -> u64 {
        let elapsed = at_ms.saturating_sub(last.at_ms);
        if last.advancing && elapsed <= self.config.loss_ms {
            // A sample is never ahead of the time it arrives at (its frame began
            // before, and it took time to come): the earliest the last second's
            // samples put the clock's origin at is the truest.
            match self.window.iter().map(|&(_, origin)| origin).min() {
                Some(origin) => u64::try_from(at_ms as i64 - origin)
                    .unwrap_or(0)
                    .max(last.tc_ms),
                None => last.tc_ms + elapsed,
            }
        } else {
            last.tc_ms
        }
    }

    /// The timecode at `now_ms`, ms since 00:00:00:00.
    pub fn timecode_ms(&self, now_ms: u64) -> Option<u64> {
        self.last.map(|last| self.expected_at(last, now_ms))
    }

    /// What the player does, from a status made at `at_ms`.
    pub fn player(&mut self, view: PlayerView, at_ms: u64) {
        if std::mem::discriminant(&view) != std::mem::discriminant(&self.player) {
            self.reset_backoff();
            if self.phase == Phase::Idle {
                // Where the balls are changed (a Home, a show's end): estimated again.
                self.estimates.clear();
            }
        }
        self.player = view;
        let PlayerView::Playing {
            entry,
            show_time_ms,
        } = view
        else {
            self.offset = None;
            if let Phase::Pending { left_playing, .. } = &mut self.phase {
                *left_playing = true;
            }
            return;
        };
        let timecode_ms = self.timecode_ms(at_ms);
        self.offset = self.cue_of(entry).zip(timecode_ms).map(|(cue, tc)| {
            (
                show_time_ms as i64 - (tc as i64 - cue.start_ms as i64),
                at_ms,
            )
        });
        if let Phase::Pending {
            locate,
            entry: wanted,
            target_ms,
            issued_at_ms,
            delay_ms,
            left_playing: true,
        } = self.phase
            && wanted == entry
        {
            // The instant the show's clock is (or was) at the time asked for.
            let at_target = at_ms as i64 + (target_ms as i64 - show_time_ms as i64);
            let lead =
                u64::try_from(at_target - issued_at_ms as i64 - delay_ms as i64).unwrap_or(0);
            if locate {
                self.locate_lead_ms = lead;
                self.locate_measured = true;
            } else {
                self.lead_ms = lead;
                if let Some(estimate) = self.estimate_used.take() {
                    self.estimate_error_ms = Some(lead as i64 - estimate as i64);
                }
                if !self.locate_measured {
                    // Until a locate is measured: a start's (it approaches from where
                    // the balls are, as a start does).
                    self.locate_lead_ms = lead;
                }
            }
            self.lead_measured = true;
            self.phase = Phase::Chasing { since_ms: at_ms };
            self.locked = None;
        }
        // Locked on once the show's time settled (its first second of playing).
        if let Phase::Chasing { since_ms } = self.phase
            && self.locked.is_none()
            && at_ms >= since_ms + SETTLE_MS
        {
            self.locked = self.offset;
        }
    }

    fn cue_of(&self, entry: usize) -> Option<Cue> {
        self.cues.iter().copied().find(|cue| cue.entry == entry)
    }

    /// The cue whose first cycle holds `tc_ms` (with at least [`MIN_LEFT_MS`] left).
    fn cue_at(&self, tc_ms: u64) -> Option<Cue> {
        self.cues.iter().copied().find(|cue| {
            tc_ms >= cue.start_ms && tc_ms + MIN_LEFT_MS < cue.start_ms + cue.duration_ms
        })
    }

    /// An action was refused (`why`) at `now_ms`: nothing is waited on, and it is
    /// tried again (as the timecode is then) after [`RETRY_MS`], or twice the last
    /// wait (at most [`RETRY_MAX_MS`]) when the same action was refused last.
    pub fn refused(&mut self, why: String, now_ms: u64) {
        self.refused = Some(why);
        let wait_ms = match (self.backoff, self.issued) {
            (Some((last, wait_ms)), Some(issued)) if last == issued => {
                (wait_ms * 2).min(RETRY_MAX_MS)
            }
            _ => RETRY_MS,
        };
        self.backoff = self.issued.map(|issued| (issued, wait_ms));
        self.retry_at_ms = now_ms + wait_ms;
        self.started = None;
        if matches!(self.phase, Phase::Pending { .. }) {
            self.phase = Phase::Idle;
        }
    }

    /// What to do at `now_ms`, if anything.
    pub fn poll(&mut self, now_ms: u64) -> Option<Action> {
        let last = self.last?;
        if now_ms < self.retry_at_ms {
            return None;
        }
        let lost = now_ms.saturating_sub(last.at_ms) > self.config.loss_ms
            || now_ms.saturating_sub(self.advanced_at_ms) > self.config.loss_ms;
        let ours = !matches!(self.phase, Phase::Idle);
        if lost {
            return match self.phase {
                Phase::Holding | Phase::Stopped => None,
                _ if !ours => None,
                _ => match self.config.on_loss {
                    OnLoss::Hold => {
                        self.phase = Phase::Holding;
                        None
                    }
                    OnLoss::Stop => {
                        self.phase = Phase::Stopped;
                        self.started = None;
                        self.issued = None;
                        Some(Action::Stop)
                    }
                },
            };
        }
        let tc_ms = self.expected_at(last, now_ms);
        let jumped = std::mem::take(&mut self.jumped);
        if jumped {
            self.started = None;
        }
        match self.phase {
            Phase::Holding => {
                // The timecode is back: chase the show if it still plays.
                self.phase = if matches!(self.player, PlayerView::Playing { .. }) {
                    Phase::Chasing {
                        since_ms: now_ms.saturating_sub(SETTLE_MS),
                    }
                } else {
                    Phase::Idle
                };
                if jumped {
                    return self.locate(tc_ms, now_ms);
                }
                return None;
            }
            Phase::Stopped => {
                self.phase = Phase::Idle;
                return None;
            }
            Phase::Pending { issued_at_ms, .. } => {
                if jumped {
                    return self.locate(tc_ms, now_ms);
                }
                if now_ms.saturating_sub(issued_at_ms) > PENDING_TIMEOUT_MS {
                    self.phase = Phase::Idle;
                }
                return None;
            }
            Phase::Chasing { since_ms } => {
                match self.player {
                    PlayerView::Playing { .. } => {}
                    PlayerView::Busy => return None,
                    PlayerView::Idle => {
                        // The show ended, or was stopped from elsewhere.
                        self.phase = Phase::Idle;
                        return None;
                    }
                }
                let out_of_step = now_ms.saturating_sub(since_ms) > SETTLE_MS
                    && self.offset.is_some_and(|(offset, _)| {
                        offset.unsigned_abs() > self.config.locate_threshold_ms
                    });
                if jumped || out_of_step {
                    return self.locate(tc_ms, now_ms);
                }
                return None;
            }
            Phase::Idle => {}
        }
        if self.player != PlayerView::Idle {
            return None;
        }
        if self
            .estimating_since
            .is_some_and(|since| now_ms < since + ESTIMATE_WAIT_MS)
            && self.lead_wanted(now_ms).is_some()
        {
            // The cue's lead is being estimated: a moment more.
            return None;
        }
        if self
            .started
            .and_then(|entry| self.cue_of(entry))
            .is_some_and(|cue| {
                tc_ms + self.lead_for(cue.entry) < cue.start_ms
                    || tc_ms >= cue.start_ms + cue.duration_ms
            })
        {
            self.started = None;
        }
        // Due: from its start less the lead and its delay (a start at time 0 waits
        // the delay) to its end.
        let cue = self.cues.iter().copied().find(|cue| {
            let due = tc_ms + self.lead_for(cue.entry);
            due + cue.delay_ms >= cue.start_ms && due + MIN_LEFT_MS < cue.start_ms + cue.duration_ms
        })?;
        if self.started == Some(cue.entry) {
            return None;
        }
        let lead_ms = self.lead_for(cue.entry);
        let due = tc_ms + lead_ms;
        self.estimate_used = self.estimate_of(cue.entry);
        if self.estimate_used.is_some() {
            // The status shows the lead the Start goes with.
            self.lead_ms = lead_ms;
        }
        let mut time_ms = due.saturating_sub(cue.start_ms);
        let mut delay_ms = 0;
        if time_ms < START_AT_ZERO_WITHIN_MS {
            if cue.delay_ms == 0 || due < cue.start_ms {
                time_ms = 0;
                delay_ms = cue.delay_ms;
            } else {
                // Late for the delay: a start just inside the show, which has none.
                time_ms = START_AT_ZERO_WITHIN_MS;
            }
        }
        self.started = Some(cue.entry);
        self.refused = None;
        self.issued = Some((false, cue.entry));
        self.phase = Phase::Pending {
            locate: false,
            entry: cue.entry,
            target_ms: time_ms,
            issued_at_ms: now_ms,
            delay_ms,
            left_playing: !matches!(self.player, PlayerView::Playing { .. }),
        };
        Some(Action::Start {
            entry: cue.entry,
            time_ms,
        })
    }

    /// A locate to where the timecode `tc_ms` will be a locate's lead from `now_ms`.
    fn locate(&mut self, tc_ms: u64, now_ms: u64) -> Option<Action> {
        let due = tc_ms + self.locate_lead_for(tc_ms);
        self.locates += 1;
        self.locked = None;
        self.refused = None;
        let Some(cue) = self.cue_at(due) else {
            self.issued = None;
            self.phase = Phase::Idle;
            self.started = None;
            return matches!(self.player, PlayerView::Idle)
                .then_some(())
                .map_or(Some(Action::Stop), |()| None);
        };
        self.started = Some(cue.entry);
        self.issued = Some((true, cue.entry));
        let time_ms = due - cue.start_ms;
        self.phase = Phase::Pending {
            locate: true,
            entry: cue.entry,
            target_ms: time_ms,
            issued_at_ms: now_ms,
            delay_ms: 0,
            left_playing: !matches!(self.player, PlayerView::Playing { .. }),
        };
        Some(Action::Locate {
            entry: cue.entry,
            time_ms,
        })
    }

    /// The plan's estimate of entry `entry`'s lead, if one was given.
    fn estimate_of(&self, entry: usize) -> Option<u64> {
        self.estimates
            .iter()
            .find(|(of, ..)| *of == entry)
            .map(|&(_, _, lead_ms, _)| lead_ms)
    }

    /// The lead of a locate from timecode `tc_ms`: measured, or the plan's estimate
    /// for the cue there (or the next), or a start's and half again.
    fn locate_lead_for(&self, tc_ms: u64) -> u64 {
        if self.locate_measured {
            return self.locate_lead_ms;
        }
        self.cues
            .iter()
            .filter(|cue| tc_ms < cue.start_ms + cue.duration_ms)
            .min_by_key(|cue| cue.start_ms)
            .and_then(|cue| {
                self.estimates
                    .iter()
                    .find(|(of, ..)| *of == cue.entry)
                    .map(|&(_, _, _, locate_ms)| locate_ms)
            })
            .unwrap_or(self.locate_lead_ms)
    }

    /// The lead a Start of `entry` is reckoned with: the plan's estimate for it,
    /// corrected by how far the last measured lead was from its estimate; without an
    /// estimate the lead measured last, or the configured one.
    fn lead_for(&self, entry: usize) -> u64 {
        match self.estimate_of(entry) {
            Some(estimate) => {
                u64::try_from(estimate as i64 + self.estimate_error_ms.unwrap_or(0)).unwrap_or(0)
            }
            None => self.lead_ms,
        }
    }

    /// The cue whose lead the chase wants estimated at `now_ms`: the next one due
    /// (entry, 0-based, and the show time a Start of it would ask for), unless its
    /// estimate is there already (made again after a jump, or when the player's state
    /// changed while idle). `None` when no cue is ahead or nothing is wanted.
    pub fn lead_wanted(&self, now_ms: u64) -> Option<(usize, u64)> {
        let tc_ms = self.timecode_ms(now_ms)?;
        let cue = self
            .cues
            .iter()
            .copied()
            .filter(|cue| tc_ms + MIN_LEFT_MS < cue.start_ms + cue.duration_ms)
            .min_by_key(|cue| cue.start_ms)?;
        let time_ms = (tc_ms + self.lead_for(cue.entry)).saturating_sub(cue.start_ms);
        let time_ms = if time_ms < START_AT_ZERO_WITHIN_MS {
            0
        } else {
            time_ms
        };
        // Once a cue: again only after a jump or a change of the player's state while
        // idle (estimating reads and plans the show; inside a running cue the time
        // asked for moves on with the timecode).
        let known = self.estimates.iter().any(|&(entry, ..)| entry == cue.entry);
        (!known).then_some((cue.entry, time_ms))
    }

    /// The bridge is estimating the lead [`Chase::lead_wanted`] asked for, since
    /// `now_ms`: a Start of that cue waits for it (at most [`ESTIMATE_WAIT_MS`]).
    pub fn estimating(&mut self, now_ms: u64) {
        self.estimating_since = Some(now_ms);
    }

    /// The plan's estimate of the lead of a Start of `entry` at show time `time_ms`
    /// (approach and load, [`super::lead`]), and of a locate into it (which homes
    /// first): the chase starts that cue with it (and what the last measured lead
    /// taught it) rather than the configured lead, and locates with the other until a
    /// locate was measured.
    pub fn set_lead_estimate(&mut self, entry: usize, time_ms: u64, lead_ms: u64, locate_ms: u64) {
        self.estimating_since = None;
        self.estimates.retain(|(of, ..)| *of != entry);
        self.estimates.push((entry, time_ms, lead_ms, locate_ms));
    }

    /// The clock trim while chasing: the entry (0-based) and the instant, ms on the
    /// clock the chase is given, at which the timecode puts that entry's show time 0
    /// — the offset locked on kept, so the trim removes the drift, not the offset.
    /// `None` unless chasing a running timecode, locked on.
    pub fn trim(&self, now_ms: u64) -> Option<(usize, i64)> {
        let Phase::Chasing { .. } = self.phase else {
            return None;
        };
        let PlayerView::Playing { entry, .. } = self.player else {
            return None;
        };
        let last = self.last.filter(|last| last.advancing)?;
        if now_ms.saturating_sub(last.at_ms) > self.config.loss_ms {
            return None;
        }
        let (locked, _) = self.locked?;
        let cue = self.cue_of(entry)?;
        // show(t) = tc(t) − cue start + locked = t − start  ⇒
        // start = t − tc(t) + cue start − locked (the timecode where the offsets
        // take it, `expected_at`).
        let tc_ms = self.expected_at(last, now_ms);
        Some((
            entry,
            now_ms as i64 - tc_ms as i64 + cue.start_ms as i64 - locked,
        ))
    }

    /// The chase as clients see it at `now_ms`.
    pub fn status(&self, now_ms: u64) -> TimecodeStatus {
        let lost = self.last.is_some_and(|last| {
            now_ms.saturating_sub(last.at_ms) > self.config.loss_ms
                || now_ms.saturating_sub(self.advanced_at_ms) > self.config.loss_ms
        });
        let state = match (self.last, self.phase) {
            (None, _) => ChaseState::NoTimecode,
            (_, Phase::Pending { locate: false, .. }) => ChaseState::Cued,
            (_, Phase::Pending { locate: true, .. }) => ChaseState::Locating,
            (_, Phase::Holding) => ChaseState::Holding,
            (_, Phase::Stopped) => ChaseState::Stopped,
            (_, Phase::Chasing { .. }) if !lost => ChaseState::Chasing,
            _ if lost => ChaseState::Lost,
            _ => ChaseState::Waiting,
        };
        let entry = match (self.phase, self.player) {
            (Phase::Pending { entry, .. }, _) | (_, PlayerView::Playing { entry, .. }) => {
                Some(entry + 1)
            }
            _ => None,
        };
        let drift = self
            .locked
            .zip(self.offset)
            .map(|((first, since), (now, at))| (now - first, at.saturating_sub(since)));
        TimecodeStatus {
            source: self.source.clone(),
            state,
            timecode: self.last.map(|last| {
                Timecode::from_ms(self.expected_at(last, now_ms), last.rate).to_string()
            }),
            rate: self.last.map(|last| last.rate),
            running: self.last.is_some_and(|last| last.advancing) && !lost,
            entry,
            offset_ms: self.offset.map(|(offset, _)| offset),
            lead_ms: self.lead_ms,
            locate_lead_ms: self.locate_lead_ms,
            lead_measured: self.lead_measured,
            drift_ms: drift.map(|(drift, _)| drift),
            drift_over_ms: drift.map_or(0, |(_, over)| over),
            locates: self.locates,
            refused: self.refused.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: FrameRate = FrameRate::Ebu25;

    fn config(on_loss: OnLoss) -> ChaseConfig {
        ChaseConfig {
            locate_threshold_ms: 500,
            loss_ms: 1_000,
            on_loss,
            lead_ms: 2_000,
        }
    }

    /// Entry 0 at 10:00:00:00 for a minute, entry 1 right after it (delay 5 s).
    fn two_cues() -> Vec<Cue> {
        cues(
            &[
                CueEntry {
                    start_ms: None,
                    delay_ms: 0,
                    duration_ms: 60_000,
                    cycles: 1,
                },
                CueEntry {
                    start_ms: None,
                    delay_ms: 5_000,
                    duration_ms: 30_000,
                    cycles: 2,
                },
                CueEntry {
                    start_ms: Some(11 * 3_600_000),
                    delay_ms: 0,
                    duration_ms: 10_000,
                    cycles: 1,
                },
            ],
            Some(10 * 3_600_000),
        )
    }

    /// Tells the chase the player's status at `at_ms`: playing `entry` at show time
    /// `show_time_ms`.
    fn playing(chase: &mut Chase, entry: usize, show_time_ms: u64, at_ms: u64) {
        chase.player(
            PlayerView::Playing {
                entry,
                show_time_ms,
            },
            at_ms,
        );
    }

    /// Feeds a running timecode from `from_ms` (timecode) at `at_ms` (clock) for
    /// `for_ms`, a frame at a time, polling after each; returns the actions with the
    /// clock time they came at.
    fn run(chase: &mut Chase, from_ms: u64, at_ms: u64, for_ms: u64) -> Vec<(u64, Action)> {
        let mut actions = Vec::new();
        let mut t = 0;
        while t <= for_ms {
            chase.timecode(Timecode::from_ms(from_ms + t, RATE), at_ms + t);
            if let Some(action) = chase.poll(at_ms + t) {
                actions.push((at_ms + t, action));
            }
            t += 40;
        }
        actions
    }

    #[test]
    fn cues_follow_the_playlist() {
        let cues = two_cues();
        assert_eq!(cues.len(), 3);
        assert_eq!(cues[1].start_ms, 10 * 3_600_000 + 65_000);
        assert_eq!(cues[2].start_ms, 11 * 3_600_000);
        assert!(super::cues(&[], None).is_empty());
    }

    #[test]
    fn a_cue_starts_the_lead_ahead_and_the_lead_is_measured() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        assert_eq!(chase.poll(0), None);
        assert_eq!(chase.status(0).state, ChaseState::NoTimecode);
        let start = 10 * 3_600_000 - 5_000;
        let actions = run(&mut chase, start, 0, 3_400);
        // Due at 10:00:00:00 less the 2 s lead: 3 s in.
        assert_eq!(
            actions,
            vec![(
                3_000,
                Action::Start {
                    entry: 0,
                    time_ms: 0
                }
            )]
        );
        assert_eq!(chase.status(3_000).state, ChaseState::Cued);
        // The show plays at 3 s: at 3.4 s a status says its time is 0.2 s — it
        // reached 0 at 3.2 s, 0.2 s after the start: the lead is 0.2 s, not 2.
        chase.player(PlayerView::Busy, 3_100);
        playing(&mut chase, 0, 200, 3_400);
        let status = chase.status(3_400);
        assert_eq!(status.state, ChaseState::Chasing);
        assert_eq!(status.lead_ms, 200);
        assert!(status.lead_measured);
        assert_eq!(status.entry, Some(1));
        // The timecode's show time at 3.4 s is −1.6 s: the show is 1.8 s ahead.
        assert_eq!(status.offset_ms, Some(1_800));
        assert_eq!(status.timecode.as_deref(), Some("09:59:58:10"));
    }

    #[test]
    fn a_late_timecode_starts_inside_the_show_and_out_of_step_relocates() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        let actions = run(&mut chase, 10 * 3_600_000 + 20_000, 0, 0);
        assert_eq!(
            actions,
            vec![(
                0,
                Action::Start {
                    entry: 0,
                    time_ms: 22_000
                }
            )]
        );
        // In step at first…
        run(&mut chase, 10 * 3_600_000 + 20_040, 40, 1_960);
        playing(&mut chase, 0, 22_000, 2_000);
        assert_eq!(chase.status(2_000).offset_ms, Some(0));
        // …then 600 ms behind, after the settling second: a locate, aimed at the
        // timecode plus the locate's lead (the start's until one is measured).
        let actions = run(&mut chase, 10 * 3_600_000 + 22_000, 2_000, 1_000);
        assert!(actions.is_empty(), "{actions:?}");
        playing(&mut chase, 0, 22_500, 3_100);
        assert_eq!(chase.status(3_100).offset_ms, Some(-600));
        let actions = run(&mut chase, 10 * 3_600_000 + 23_120, 3_120, 0);
        assert_eq!(
            actions,
            vec![(
                3_120,
                Action::Locate {
                    entry: 0,
                    time_ms: 23_120 + 2_000
                }
            )]
        );
        assert_eq!(chase.status(3_120).locates, 1);
        // The old show plays on until the locate ends it: not taken for the new one.
        playing(&mut chase, 0, 23_100, 3_200);
        assert_eq!(chase.status(3_200).state, ChaseState::Locating);
        chase.player(PlayerView::Busy, 3_300);
        playing(&mut chase, 0, 25_120, 3_600);
        let status = chase.status(3_600);
        assert_eq!(status.state, ChaseState::Chasing);
        // At the time asked for 480 ms after the locate was issued.
        assert_eq!(status.locate_lead_ms, 480);
    }

    #[test]
    fn a_jump_locates_and_a_jump_out_of_every_cue_stops() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000, 0, 0);
        playing(&mut chase, 0, 2_000, 2_000);
        assert!(run(&mut chase, 10 * 3_600_000 + 40, 40, 2_000).is_empty());
        // To entry 1's second cue (65 s in) + 10 s.
        let actions = run(&mut chase, 10 * 3_600_000 + 75_000, 2_080, 0);
        assert_eq!(
            actions,
            vec![(
                2_080,
                Action::Locate {
                    entry: 1,
                    time_ms: 10_000 + 2_000
                }
            )]
        );
        assert_eq!(chase.status(2_080).state, ChaseState::Locating);
        // Playing again; then a jump to 12:00, in no cue.
        chase.player(PlayerView::Busy, 2_100);
        playing(&mut chase, 1, 12_000, 6_080);
        assert_eq!(chase.status(6_080).locate_lead_ms, 4_000);
        let actions = run(&mut chase, 12 * 3_600_000, 6_120, 0);
        assert_eq!(actions, vec![(6_120, Action::Stop)]);
        assert_eq!(chase.status(6_120).locates, 2);
    }

    #[test]
    fn loss_holds_or_stops_and_a_stopped_cue_is_not_restarted() {
        for on_loss in [OnLoss::Hold, OnLoss::Stop] {
            let mut chase = Chase::new(config(on_loss), "mtc", two_cues());
            run(&mut chase, 10 * 3_600_000 - 2_000, 0, 0);
            playing(&mut chase, 0, 0, 2_000);
            run(&mut chase, 10 * 3_600_000 - 1_960, 40, 3_000);
            // Silence: at 1 s past the last sample, nothing; after, the loss.
            let last = 3_040;
            assert_eq!(chase.poll(last + 1_000), None);
            let action = chase.poll(last + 1_001);
            match on_loss {
                OnLoss::Hold => {
                    assert_eq!(action, None);
                    assert_eq!(chase.status(last + 1_001).state, ChaseState::Holding);
                }
                OnLoss::Stop => {
                    assert_eq!(action, Some(Action::Stop));
                    assert_eq!(chase.status(last + 1_001).state, ChaseState::Stopped);
                }
            }
            assert_eq!(chase.poll(last + 2_000), None);
        }
        // A timecode that stands still is a loss too.
        let mut chase = Chase::new(config(OnLoss::Stop), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000 - 2_000, 0, 0);
        chase.player(PlayerView::Busy, 100);
        let parked = Timecode::from_ms(10 * 3_600_000 - 2_000, RATE);
        let mut actions = Vec::new();
        for at in (1_000..3_000).step_by(40) {
            chase.timecode(parked, at);
            actions.extend(chase.poll(at));
        }
        assert_eq!(actions, vec![Action::Stop]);
        // Stopped from elsewhere (an operator's Home): the cue is not started again.
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000 - 2_000, 0, 2_000);
        playing(&mut chase, 0, 0, 2_000);
        chase.player(PlayerView::Idle, 2_500);
        assert!(run(&mut chase, 10 * 3_600_000 + 540, 2_540, 3_000).is_empty());
        assert_eq!(chase.status(5_540).state, ChaseState::Waiting);
    }

    #[test]
    fn a_refusal_waits_a_second() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        let actions = run(&mut chase, 10 * 3_600_000 - 2_000, 0, 0);
        assert_eq!(actions.len(), 1);
        chase.refused("the e-stop is latched".to_owned(), 10);
        assert_eq!(
            chase.status(10).refused.as_deref(),
            Some("the e-stop is latched")
        );
        // Tried again a second later, as the timecode is then.
        assert_eq!(
            run(&mut chase, 10 * 3_600_000 - 1_960, 40, 3_000),
            vec![(
                1_040,
                Action::Start {
                    entry: 0,
                    time_ms: 1_040
                }
            )]
        );
    }

    #[test]
    fn refusals_of_the_same_start_back_off_to_30_s_and_a_change_starts_over() {
        // One entry of 200 s at 10:00:00:00.
        let long = || {
            cues(
                &[CueEntry {
                    start_ms: None,
                    delay_ms: 0,
                    duration_ms: 200_000,
                    cycles: 1,
                }],
                Some(10 * 3_600_000),
            )
        };
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", long());
        let from = 10 * 3_600_000 - 2_000;
        // Refused each time it is tried: the waits double, 1, 2, 4, 8, 16, 30, 30 s.
        let mut at = 0;
        let mut tries = Vec::new();
        let mut refusals = 0;
        while at <= 100_000 {
            chase.timecode(Timecode::from_ms(from + at, RATE), at);
            if let Some(Action::Start { entry: 0, .. }) = chase.poll(at) {
                tries.push(at);
                chase.refused("the show cannot be compiled".to_owned(), at);
                refusals += 1;
            }
            at += 40;
        }
        assert_eq!(refusals, tries.len());
        let waits: Vec<u64> = tries.windows(2).map(|w| w[1] - w[0]).collect();
        assert_eq!(
            waits,
            [1_000, 2_000, 4_000, 8_000, 16_000, 30_000, 30_000],
            "{tries:?}"
        );
        assert_eq!(chase.retry_wait_ms(), RETRY_MAX_MS);
        // The playlist edited: tried again at once, then after a second.
        let mut edited = long();
        edited[0].duration_ms += 1_000;
        chase.set_cues(edited);
        assert_eq!(chase.retry_wait_ms(), 0);
        chase.timecode(Timecode::from_ms(from + at, RATE), at);
        assert!(matches!(
            chase.poll(at),
            Some(Action::Start { entry: 0, .. })
        ));
        chase.refused("the show cannot be compiled".to_owned(), at);
        assert_eq!(chase.retry_wait_ms(), RETRY_MS);
        chase.refused("the show cannot be compiled".to_owned(), at);
        assert_eq!(chase.retry_wait_ms(), 2 * RETRY_MS);
        // The player's state changed (an operator's Home cleared an e-stop): at once.
        chase.player(PlayerView::Busy, at + 10);
        chase.player(PlayerView::Idle, at + 20);
        assert_eq!(chase.retry_wait_ms(), 0);
        chase.timecode(Timecode::from_ms(from + at + 40, RATE), at + 40);
        assert!(matches!(
            chase.poll(at + 40),
            Some(Action::Start { entry: 0, .. })
        ));
        chase.refused("the e-stop is latched".to_owned(), at + 40);
        chase.refused("the e-stop is latched".to_owned(), at + 40);
        assert_eq!(chase.retry_wait_ms(), 2 * RETRY_MS);
        // A jump of the timecode: back-off forgotten, the locate is due at once.
        let jumped = 10 * 3_600_000 + 150_000;
        chase.timecode(Timecode::from_ms(jumped, RATE), at + 80);
        assert_eq!(chase.retry_wait_ms(), 0);
        assert!(chase.poll(at + 80).is_some());
    }

    #[test]
    fn the_trim_puts_the_show_s_start_where_the_timecode_has_it_keeping_the_offset() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000 - 2_000, 0, 0);
        assert_eq!(chase.trim(0), None, "not chasing");
        run(&mut chase, 10 * 3_600_000 - 1_960, 40, 1_960);
        // Playing at 2 s, 30 ms ahead of the timecode: locked on at +30.
        playing(&mut chase, 0, 30, 2_000);
        // Locked on after the settling second.
        assert_eq!(chase.trim(2_000), None);
        run(&mut chase, 10 * 3_600_000 + 40, 2_040, 960);
        playing(&mut chase, 0, 1_030, 3_000);
        assert_eq!(chase.trim(3_000), Some((0, 2_000 - 30)));
        // The timecode runs 0.5 % fast: 10 s on the clock are 10.05 s of timecode. The
        // show's time 0 by the timecode is then 50 ms earlier on the clock.
        // Frame n arrives at the instant the sender's clock reaches it.
        let mut at = 3_000;
        for frame in 1..=251u64 {
            at = 3_000 + frame * 40 * 1_000 / 1_005;
            chase.timecode(
                Timecode::from_ms(10 * 3_600_000 + 1_000 + frame * 40, RATE),
                at,
            );
        }
        assert_eq!(at, 12_990);
        let (entry, start_ms) = chase.trim(13_000).unwrap();
        assert_eq!(entry, 0);
        assert!((start_ms - (2_000 - 30 - 50)).abs() <= 1, "{start_ms}");
        // Lost: no trim.
        assert_eq!(chase.trim(12_990 + 1_001), None);
    }

    #[test]
    fn a_planned_lead_starts_the_first_cue_and_a_measured_one_corrects_it() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000 - 10_000, 0, 0);
        // The next cue is entry 0 at its start: its lead is wanted once.
        assert_eq!(chase.lead_wanted(0), Some((0, 0)));
        chase.set_lead_estimate(0, 0, 3_500, 6_000);
        assert_eq!(chase.lead_wanted(0), None);
        // Started 3.5 s ahead of the cue (not the configured 2 s): at 6.5 s (the first
        // poll past it).
        let actions = run(&mut chase, 10 * 3_600_000 - 9_960, 40, 7_000);
        assert_eq!(
            actions,
            vec![(
                6_520,
                Action::Start {
                    entry: 0,
                    time_ms: 0
                }
            )]
        );
        assert_eq!(chase.status(6_520).lead_ms, 3_500);
        // It took 3.8 s: entry 1's estimate (4 s) is reckoned 300 ms longer.
        playing(&mut chase, 0, 0, 6_520 + 3_800);
        assert_eq!(chase.status(10_320).lead_ms, 3_800);
        chase.set_lead_estimate(1, 0, 4_000, 6_000);
        assert_eq!(chase.lead_for(1), 4_300);
        // Until a locate is measured, one into entry 1 is reckoned with its estimate.
        assert_eq!(chase.locate_lead_for(10 * 3_600_000 + 61_000), 6_000);
        // An entry without an estimate takes the measured lead.
        assert_eq!(chase.lead_for(2), 3_800);
    }

    #[test]
    fn drift_is_the_offset_s_change_since_locking_on() {
        let mut chase = Chase::new(config(OnLoss::Hold), "artnet", two_cues());
        run(&mut chase, 10 * 3_600_000 - 2_000, 0, 0);
        let mut at = 40;
        for show_time_ms in [0u64, 10_000, 20_000] {
            let tc_at = show_time_ms + 2_000;
            run(
                &mut chase,
                10 * 3_600_000 - 2_000 + at,
                at,
                tc_at.saturating_sub(at),
            );
            at = tc_at + 40;
            // The units' clock gains 1 ms every 10 s.
            playing(&mut chase, 0, show_time_ms + show_time_ms / 10_000, tc_at);
        }
        // Locked on at the second status (the first second settles).
        let status = chase.status(at);
        assert_eq!(status.drift_ms, Some(1));
        assert_eq!(status.drift_over_ms, 10_000);
    }
}
