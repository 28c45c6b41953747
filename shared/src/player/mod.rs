//! The show sequencer: one state machine for the playlist on every drive family
//! (`docs/architecture.md` §1, §4–5). It owns everything that is not a family's own — the entries,
//! their delays and cycles, the loop, the approach before each show, the order of
//! load and play, what an e-stop voids, Reset, Home, "home first when the balls'
//! positions are unknown" (at start-up, after an e-stop or an error), the progress and
//! the status — and leaves every byte on the wire to a [`Drive`], the one place the
//! families differ.
//!
//! Sans-IO (quinn-proto's shape): the caller hands it the time and the operator's
//! requests, polls it when [`Sequencer::next_wakeup_us`] says, feeds the drive's own
//! inputs (answers, feedback) to the drive, and carries out what the drive queued.
//!
//! - **Start** begins the playlist when nothing runs: homing first when the positions
//!   are unknown, then for each entry: wait `delay_ms`; **approach** (every ball to
//!   the show's first position); **load** what the show needs on the units, if the
//!   drive has anything to load for this cycle; **play** it from a common start;
//!   repeat `cycles` times; next entry; after the last, rest or start over (loop).
//! - **Start at** an entry and a time inside it ([`Sequencer::start_at`], "play from
//!   anywhere"): the playlist begins at that entry; with a time, its first cycle
//!   plays a [`Lead`] — the entry's show cut at that time
//!   ([`crate::show::Show::from_time`]), prepared by the family as any show — without
//!   the entry's delay, and the status counts the show's time from the cut's start on
//!   the full show's clock (its time, length and progress). The entry's other cycles
//!   and the entries after it play in full, as after any start.
//! - **E-stop** (the caller sent the stop ahead of everything): the sequencer stops,
//!   the drive drops what it queued and forgets where the balls are, so the next Start
//!   homes first and begins at the first entry — it never resumes mid-show. A failure
//!   stays a failure (its reason stays visible).
//! - **Reset** stops the same way, then starts: homing first, the playlist from its
//!   first entry. **Home** stops, homes and rests.
//! - **A locate** ([`Sequencer::locate_at`], a timecode jump) stops without an
//!   e-stop: the drive ends the run under way where the balls are
//!   ([`Drive::interrupt`]), and the playlist begins at the new point as a start at
//!   it does — an approach from where the balls are, no homing.
//! - A drive's failure (a unit's error, a lost link, a ball that does not arrive)
//!   stops the matrix and says what happened, in words: the caller presses the e-stop
//!   when [`Sequencer::take_estop`] says so.
//! - **Live mode** ([`live`]): on the caller's request alone, from rest (homing first
//!   when the positions are unknown), the balls approach the live targets, then follow
//!   them through the motion filter, one step and one output per drive period
//!   ([`Drive::live_step`]); input lost → they hold; leaving brakes them to rest; the
//!   e-stop ends it as it stops everything. The filtered motion can be recorded as a
//!   show.

mod error;
pub mod live;
mod playlist;

pub use error::StartError;
pub use live::{LIVE_SETTLE_PERIODS, LiveInput, LiveSetup, RecordStartError};
pub use playlist::{Entry, EntryTiming, LinkView};
pub(crate) use playlist::{NextRun, PlaylistProgress, next_run};

use crate::api::{ArmedShow, PlayerState, Status};
use crate::live::filter::BallState;
use crate::live::record::Recorder;
use live::{Live, Motion};

/// How a step the drive carries out stands after a poll.
#[derive(Debug, Clone, PartialEq)]
pub enum Phase {
    /// Still under way.
    Pending,
    /// Over at `at_us` (on the caller's clock): the next step begins then.
    Done {
        /// When the step ended, µs.
        at_us: u64,
    },
    /// It failed: the matrix stops with this reason.
    Failed(String),
}

/// Which way a point-to-point move goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MoveKind {
    /// To a show's first position.
    Approach,
    /// To the installation's home position.
    Home,
}

/// One playlist entry as the sequencer runs it: its show's name and length, when and
/// how often it plays, and what the drive prepared of it.
#[derive(Debug, Clone)]
pub struct Run<E> {
    /// The show's name, for the status.
    pub name: String,
    /// The show's length, ms.
    pub duration_ms: u64,
    /// Its delay and cycles.
    pub timing: EntryTiming,
    /// The drive's prepared form (samplers, programs, plans).
    pub prepared: E,
}

/// Where a Start begins ([`Sequencer::start_at`]): at `entry` (0-based), from its
/// start or, with a `lead`, from a time inside its show.
#[derive(Debug, Clone)]
pub struct StartAt<E> {
    /// The entry, 0-based.
    pub entry: usize,
    /// The entry's show cut at a time, played as its first cycle; `None`: the entry
    /// from its start (after its delay).
    pub lead: Option<Lead<E>>,
}

/// A playlist as the drive plays it, and where it begins ([`Sequencer::reset_at`]).
pub type RunsAt<E> = (Vec<Run<E>>, StartAt<E>);

/// The first cycle of a start from a time: the entry's show cut there, as the drive
/// plays it.
#[derive(Debug, Clone)]
pub struct Lead<E> {
    /// The show's time at the cut's time 0, ms ([`crate::show::Cut::start_ms`]): the
    /// status counts the show's time from it.
    pub from_ms: u64,
    /// The cut as the drive's family prepared it.
    pub prepared: E,
}

/// The index a drive is given for a [`Lead`]'s load ([`Drive::begin_load`]): not an
/// entry of the playlist, so nothing loaded for it is taken for an entry's own (the
/// entry's next cycle, counted from 1 again, loads in full).
pub const LEAD_INDEX: usize = usize::MAX;

/// A drive family under the sequencer: what the units are told, and when a step is
/// over. The sequencer calls one `begin_*` per step, then [`Drive::poll`] until the
/// step is [`Phase::Done`] or [`Phase::Failed`].
pub trait Drive {
    /// An entry as the drive prepared it before Start.
    type Entry;

    /// A Start or Reset (with its first entry), or a Home (`None`), begins at
    /// `now_us`.
    fn begin_run(&mut self, now_us: u64, first: Option<&mut Self::Entry>);

    /// Every ball to the home position.
    fn begin_home(&mut self, now_us: u64);

    /// Every ball to `entry`'s first position; `false` when every ball is there
    /// already (the entry loads at once).
    fn begin_approach(&mut self, now_us: u64, entry: &mut Self::Entry) -> bool;

    /// Loads what cycle `cycle` of entry `index` needs on the units before its start;
    /// `false` when there is nothing to load (the show plays at once). A [`Lead`] is
    /// loaded as cycle 1 of entry [`LEAD_INDEX`], and the entry's cycles after it are
    /// counted from 1.
    fn begin_load(
        &mut self,
        now_us: u64,
        index: usize,
        entry: &mut Self::Entry,
        cycle: u32,
    ) -> bool;

    /// Plays `entry` from a common start; `last`: nothing follows it (the playlist's
    /// last cycle without a loop).
    fn begin_play(&mut self, now_us: u64, entry: &mut Self::Entry, last: bool);

    /// Lets time pass in the step under way; `entry` is the current entry.
    fn poll(&mut self, now_us: u64, entry: Option<&mut Self::Entry>) -> Phase;

    /// A fault that stops a running playlist whatever the step (a lost link, a unit's
    /// error), asked at every poll while a playlist runs, waiting included.
    fn fault(&mut self) -> Option<String> {
        None
    }

    /// When the drive wants a poll while the sequencer waits out an entry's delay
    /// (to watch its links), µs.
    fn waiting_wakeup_us(&self, _now_us: u64) -> Option<u64> {
        None
    }

    /// How far a move or a load under way is, 0 to 1 (a show's progress is the
    /// sequencer's, from its clock).
    fn progress(&self) -> f64;

    /// **The units' clock**: once a show was begun, when the units' show time 0 is on
    /// the caller's clock, µs — as soon as the drive knows it, which may be ahead of
    /// time (a start given for a set instant). `None` until then. The status counts
    /// the show's time from it and says `playing` from that instant on, `loading`
    /// before (with the time left, [`Status::show_starts_in_ms`]).
    fn show_start_us(&self) -> Option<u64>;

    /// Whether the units repeat the show on their own (a table looping on the units):
    /// the show's time then starts over at each length.
    fn show_repeats(&self) -> bool {
        false
    }

    /// **Clock trim** (a timecode chase, `docs/show-control.md`): the timecode puts
    /// the show's time 0 of the show playing now at `show_start_us` on the caller's
    /// clock (the offset the chase locked on kept). Only its changes count: the
    /// show's clock where it was at the first trim of the show moves as far as that
    /// instant moved since (a constant error in it — a status's latency — is not
    /// taken for drift). The drive pulls its show's clock toward it as far as its
    /// family can — MBOX frames follow it exactly, UIM2503
    /// rows not yet sent absorb at most ±1 ms each — and says so through
    /// [`Drive::show_start_us`]. Given only while a chase runs: without it nothing
    /// changes on the wire. The default: the drive cannot be trimmed (MOONS' drives
    /// run a Q program on their own clock) and ignores it.
    fn trim_clock(&mut self, _now_us: u64, _show_start_us: i64) {}

    /// The e-stop (or a failure): drop what is queued; positions become unknown.
    fn stop(&mut self);

    /// **A locate** ([`Sequencer::locate_at`]): the step under way ends without an
    /// e-stop — the drive drops what it queued and leaves the balls where its next
    /// move can take them from (the units' own stop, or the next move's first
    /// command, ends the show under way); the positions stay as known as they were.
    /// `false`: the drive cannot (nothing changed), and the locate is refused while a
    /// playlist runs. The default: it cannot.
    fn interrupt(&mut self, _now_us: u64) -> bool {
        false
    }

    /// When the step under way next needs a poll, µs.
    fn next_wakeup_us(&self, now_us: u64) -> Option<u64>;

    /// **Arming**, for a drive that can load a show ahead of Start while the matrix
    /// is idle (UIM2503 tables): takes `first`, the first entry of a playlist prepared
    /// at disarm count `disarms`, and loads it while idle ([`Drive::poll_idle`]).
    /// Returns whether it took it (not if a disarm came since `disarms`). The default:
    /// the drive arms nothing.
    fn arm(&mut self, _first: &Self::Entry, _disarms: u64) -> bool {
        false
    }

    /// Drops what is armed or being armed, and counts a disarm.
    fn disarm(&mut self) {}

    /// How many times the drive was disarmed (or ran, or stopped): an arming is taken
    /// only at the count it was prepared at.
    fn disarms(&self) -> u64 {
        0
    }

    /// The show armed or being armed, for the status.
    fn armed(&self) -> Option<ArmedShow> {
        None
    }

    /// When the drive wants a poll while the matrix is idle (an arming under way), µs.
    fn idle_wakeup_us(&self, _now_us: u64) -> Option<u64> {
        None
    }

    /// Lets time pass while the matrix is idle (an arming loads its next round).
    fn poll_idle(&mut self, _now_us: u64) {}

    /// **Live mode** ([`live`]): how the drive carries live motion — the limits, the
    /// period, the latency — or why it cannot. The default: it cannot
    /// ([`StartError::LiveUnsupported`]).
    ///
    /// # Errors
    /// Why the family cannot carry live motion.
    fn live_setup(&self) -> Result<LiveSetup, StartError> {
        Err(StartError::LiveUnsupported {
            family: "this drive family",
        })
    }

    /// Where the balls rest, mm (row-major), when the drive knows it (after a home, a
    /// show, live mode); `None` when it does not (live mode homes first).
    fn rest_positions_mm(&self) -> Option<Vec<f64>> {
        None
    }

    /// Live motion begins at `now_us`, the balls resting at `states`: `false` when
    /// the first period's slot is `now_us`; `true` when the drive prepares first (the
    /// sequencer polls it, and takes [`Phase::Done`]'s `at_us` as the first slot).
    fn begin_live(&mut self, _now_us: u64, _states: &[BallState]) -> bool {
        false
    }

    /// One live period from `slot_us`: every ball is to be at `states` (position and
    /// velocity) one period later. Called once per period, the slots in order (a
    /// drive with [`Drive::live_early_step_us`] may see a slot less than a period
    /// after the last: the grid re-timed to a change of the input).
    fn live_step(&mut self, _slot_us: u64, _states: &[BallState]) {}

    /// Whether a change of live input after a quiet period may move the next live
    /// slot forward ([`live`], "A change goes at once"): `Some(gap)`, the least time
    /// after the last slot, µs (whole ms, at least the shortest recordable step), the
    /// drive taking each frame whenever it comes and every slot's output lasting a
    /// period from it (MBOX boxes); `None` (the default): the slots stay on the
    /// period's grid (units that run the outputs on their own clock).
    fn live_early_step_us(&self) -> Option<u64> {
        None
    }

    /// Live motion is over at `at_us`: the balls rest at `states` (their positions
    /// are known).
    fn end_live(&mut self, _at_us: u64, _states: &[BallState]) {}

    /// The live latency the status reports now, µs, for a drive that measures it
    /// (MBOX boxes: from what their sender measures); `None` (the default): the
    /// setup's ([`LiveSetup::latency_us`]).
    fn live_latency_us(&self) -> Option<u64> {
        None
    }
}

/// Why `entries` cannot begin at `at`, if they cannot.
fn refusal<E>(entries: &[Run<E>], at: &StartAt<E>) -> Option<StartError> {
    if entries.is_empty() {
        return Some(StartError::Empty);
    }
    let Some(run) = entries.get(at.entry) else {
        return Some(StartError::NoSuchEntry {
            entry: at.entry.saturating_add(1),
            entries: entries.len(),
        });
    };
    match &at.lead {
        Some(lead) if lead.from_ms >= run.duration_ms => Some(StartError::PastTheEnd {
            entry: at.entry + 1,
            time_ms: lead.from_ms,
            duration_ms: run.duration_ms,
        }),
        _ => None,
    }
}

/// What follows a move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterMove {
    /// Load and play the current entry.
    Play,
    /// Begin the playlist's first entry.
    First,
    /// Rest.
    Rest,
    /// Begin live motion (the approach to the live targets).
    Live,
}

/// A show's clock at an instant ([`Sequencer::status_at`]).
#[derive(Debug, Clone, Copy, PartialEq)]
enum ShowClock {
    /// The drive has not given the start yet.
    NotGiven,
    /// The start is given: the units start this many µs from now.
    Given { starts_in_us: u64 },
    /// The units play: their show time, and the share of the show behind them.
    Running { show_time_ms: u64, progress: f64 },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Idle,
    Waiting {
        until_us: u64,
    },
    Moving {
        kind: MoveKind,
        after: AfterMove,
    },
    Loading,
    Playing,
    /// Live motion: approaching, following, holding or leaving ([`live`]).
    Live,
    Stopped,
    Failed,
}

/// The sequencer over drive `D`; see the [module documentation](self).
#[derive(Debug)]
pub struct Sequencer<D: Drive> {
    drive: D,
    entries: Vec<Run<D::Entry>>,
    loop_playlist: bool,
    entry: usize,
    cycle: u32,
    step: Step,
    /// The balls' positions are unknown: the next Start homes first.
    needs_home: bool,
    last_error: Option<String>,
    /// The latest time the sequencer was given, µs ([`Sequencer::status`]).
    now_us: u64,
    progress: f64,
    /// The sequencer failed on its own: the caller must press the e-stop.
    estop_wanted: bool,
    /// Where the run under way began ([`Sequencer::start_at`]): the entry, and the
    /// lead until it has played.
    start_at: StartAt<D::Entry>,
    /// The entry's first cycle was a lead: the drive counts its cycles from the next.
    led: bool,
    /// Live mode, from the request until it is left or stopped.
    live: Option<Live>,
    /// A recording of live motion, until it is taken.
    recorder: Option<Recorder>,
    /// Live input handed before live mode began (targets, speed limits, colours,
    /// lost): the approach's targets.
    live_input: Option<LiveInputs>,
}

/// Live input kept ([`Sequencer::set_live_input`] before [`Sequencer::go_live`]).
type LiveInputs = (
    Vec<Option<f64>>,
    Vec<Option<f64>>,
    Vec<Option<[u8; 3]>>,
    bool,
);

impl<D: Drive> Sequencer<D> {
    /// A sequencer over `drive`, idle, positions unknown (the first Start homes).
    pub fn new(drive: D) -> Self {
        Self {
            drive,
            entries: Vec::new(),
            loop_playlist: false,
            entry: 0,
            cycle: 0,
            step: Step::Idle,
            needs_home: true,
            last_error: None,
            now_us: 0,
            progress: 0.0,
            estop_wanted: false,
            start_at: StartAt {
                entry: 0,
                lead: None,
            },
            led: false,
            live: None,
            recorder: None,
            live_input: None,
        }
    }

    /// The lead, while it is what the entry under way plays.
    fn lead(&self) -> Option<&Lead<D::Entry>> {
        self.start_at
            .lead
            .as_ref()
            .filter(|_| self.entry == self.start_at.entry)
    }

    /// The drive, and what it plays for the entry under way: its lead, or its
    /// prepared form.
    fn drive_and_current(&mut self) -> (&mut D, Option<&mut D::Entry>) {
        let current = match self.start_at.lead.as_mut() {
            Some(lead) if self.entry == self.start_at.entry => Some(&mut lead.prepared),
            _ => self
                .entries
                .get_mut(self.entry)
                .map(|run| &mut run.prepared),
        };
        (&mut self.drive, current)
    }

    /// The drive.
    pub fn drive(&self) -> &D {
        &self.drive
    }

    /// The drive, to hand it its inputs and take its outputs.
    pub fn drive_mut(&mut self) -> &mut D {
        &mut self.drive
    }

    /// The playlist's state as the status shows it (the caller adds the links), at the
    /// latest time the sequencer was given; [`Sequencer::status_at`] for another.
    #[must_use]
    pub fn status(&self) -> Status {
        self.status_at(self.now_us)
    }

    /// The state at `now_us` alone ([`Sequencer::status_at`]'s, without building the
    /// rest).
    #[must_use]
    pub fn state_at(&self, now_us: u64) -> PlayerState {
        match self.step {
            Step::Idle => PlayerState::Idle,
            Step::Waiting { .. } => PlayerState::Waiting,
            Step::Moving {
                kind: MoveKind::Approach,
                ..
            } => PlayerState::Approaching,
            Step::Moving {
                kind: MoveKind::Home,
                ..
            } => PlayerState::Homing,
            Step::Loading => PlayerState::Loading,
            Step::Playing => match self.show_clock(now_us) {
                ShowClock::Running { .. } => PlayerState::Playing,
                ShowClock::Given { .. } | ShowClock::NotGiven => PlayerState::Loading,
            },
            Step::Live => match self.live.as_ref().map(|live| &live.motion) {
                Some(Motion::Preparing { .. }) => PlayerState::Loading,
                Some(Motion::Approaching { .. }) => PlayerState::Approaching,
                _ => PlayerState::Playing,
            },
            Step::Stopped => PlayerState::Stopped,
            Step::Failed => PlayerState::Error,
        }
    }

    /// The playlist's state as the status shows it at `now_us` (the caller adds the
    /// links): while a show plays, its time is the units' clock at `now_us`
    /// ([`Drive::show_start_us`]), so a status is as exact as the instant it is made.
    #[must_use]
    pub fn status_at(&self, now_us: u64) -> Status {
        let state = self.state_at(now_us);
        let homing_to_rest = matches!(
            self.step,
            Step::Moving {
                after: AfterMove::Rest,
                ..
            }
        );
        let active = self.is_running() && !homing_to_rest && self.live.is_none();
        let entry = active.then(|| self.entries.get(self.entry)).flatten();
        let (show_time_ms, progress, starts_in_ms) = match self.step {
            Step::Playing => match self.show_clock(now_us) {
                ShowClock::Running {
                    show_time_ms,
                    progress,
                } => (show_time_ms, progress, None),
                // Loaded, the start under way: the `loading` phase is complete.
                ShowClock::Given { starts_in_us } => (0, 1.0, Some(starts_in_us.div_ceil(1_000))),
                ShowClock::NotGiven => (0, 1.0, None),
            },
            Step::Live => (
                0,
                self.live.as_ref().map_or(1.0, |live| live.progress(now_us)),
                None,
            ),
            _ => (0, self.progress, None),
        };
        let mut status = PlaylistProgress {
            state,
            playing: entry.map(|run| (self.entry, run.name.clone(), run.duration_ms)),
            show_time_ms,
            starts_in_ms,
            cycle: self.cycle,
            progress,
            last_error: self.last_error.clone(),
        }
        .status();
        status.armed = self.drive.armed();
        status.live = self.live.as_ref().map(|live| {
            let mut live = live.status(self.recorder.as_ref());
            if let Some(latency_us) = self.drive.live_latency_us() {
                live.latency_ms = u32::try_from(latency_us.div_ceil(1_000)).unwrap_or(u32::MAX);
            }
            Box::new(live)
        });
        status
    }

    /// The show's clock at `now_us`: the units' show time and the progress once they
    /// started, or how long until they start.
    fn show_clock(&self, now_us: u64) -> ShowClock {
        let Some(start_us) = self.drive.show_start_us() else {
            return ShowClock::NotGiven;
        };
        if now_us < start_us {
            return ShowClock::Given {
                starts_in_us: start_us - now_us,
            };
        }
        let duration_ms = self
            .entries
            .get(self.entry)
            .map_or(0, |run| run.duration_ms);
        let elapsed_ms = (now_us - start_us) / 1_000;
        let show_time_ms = if let Some(lead) = self.lead() {
            // The cut's clock is the full show's from the cut's start.
            (lead.from_ms + elapsed_ms).min(duration_ms)
        } else if self.drive.show_repeats() && duration_ms > 0 {
            elapsed_ms % duration_ms
        } else {
            elapsed_ms.min(duration_ms)
        };
        let progress = if duration_ms == 0 {
            1.0
        } else {
            show_time_ms as f64 / duration_ms as f64
        };
        ShowClock::Running {
            show_time_ms,
            progress,
        }
    }

    /// When the state changes on the clock alone — a show's given start — µs: the
    /// caller publishes the status then.
    #[must_use]
    pub fn next_state_change_us(&self, now_us: u64) -> Option<u64> {
        match (self.step, self.drive.show_start_us()) {
            (Step::Playing, Some(start_us)) if start_us > now_us => Some(start_us),
            _ => None,
        }
    }

    /// A clock trim from a timecode chase ([`Drive::trim_clock`]): the show of entry
    /// `entry` (0-based) has its time 0 at `show_start_us` by the timecode. Handed to
    /// the drive only while that entry plays (a lead's cut starts that much later, at
    /// its `from_ms`); ignored otherwise.
    pub fn trim_clock(&mut self, now_us: u64, entry: usize, show_start_us: i64) {
        if self.step != Step::Playing || self.entry != entry {
            return;
        }
        let from_ms = self.lead().map_or(0, |lead| lead.from_ms);
        self.drive.trim_clock(
            now_us,
            show_start_us.saturating_add((from_ms * 1_000) as i64),
        );
    }

    /// Whether a playlist (or a homing move) is under way.
    #[must_use]
    pub fn is_running(&self) -> bool {
        matches!(
            self.step,
            Step::Waiting { .. } | Step::Moving { .. } | Step::Loading | Step::Playing | Step::Live
        )
    }

    /// Whether nothing runs and nothing stopped: idle.
    #[must_use]
    pub fn is_idle(&self) -> bool {
        self.step == Step::Idle
    }

    /// The entry under way (0-based).
    #[must_use]
    pub fn entry(&self) -> usize {
        self.entry
    }

    /// Whether the next Start homes first.
    #[must_use]
    pub fn needs_home(&self) -> bool {
        self.needs_home
    }

    /// Whether the sequencer failed on its own since the last call: the caller presses
    /// the e-stop (every unit stops, whatever it was doing).
    pub fn take_estop(&mut self) -> bool {
        std::mem::take(&mut self.estop_wanted)
    }

    /// When the sequencer wants to be polled next, µs; `None` while at rest.
    #[must_use]
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        match self.step {
            Step::Idle => self.drive.idle_wakeup_us(now_us),
            Step::Stopped | Step::Failed => None,
            Step::Waiting { until_us } => Some(
                self.drive
                    .waiting_wakeup_us(now_us)
                    .map_or(until_us, |wake_us| wake_us.min(until_us))
                    .max(now_us),
            ),
            // A given start is not a poll's business (the drive's clock may run ahead
            // of the caller's): the caller asks for it apart,
            // [`Sequencer::next_state_change_us`].
            Step::Moving { .. } | Step::Loading | Step::Playing => {
                self.drive.next_wakeup_us(now_us)
            }
            Step::Live => match self.live.as_ref() {
                Some(live) if matches!(live.motion, Motion::Preparing { .. }) => {
                    self.drive.next_wakeup_us(now_us)
                }
                Some(live) => Some(live.next_step_us().max(now_us)),
                None => None,
            },
        }
    }

    /// Start: homes first if the positions are unknown, then plays `entries` from the
    /// first.
    ///
    /// # Errors
    /// [`StartError::Busy`] while a playlist runs, [`StartError::Empty`] without
    /// entries; nothing was changed.
    pub fn start(
        &mut self,
        now_us: u64,
        entries: Vec<Run<D::Entry>>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        self.start_at(
            now_us,
            entries,
            loop_playlist,
            StartAt {
                entry: 0,
                lead: None,
            },
        )
    }

    /// Start at an entry, from its start or from a time inside it ([`StartAt`]; see
    /// the [module documentation](self)): homes first if the positions are unknown.
    ///
    /// # Errors
    /// As [`Sequencer::start`]; [`StartError::NoSuchEntry`] for an entry the playlist
    /// lacks, [`StartError::PastTheEnd`] for a lead from the show's end or later.
    pub fn start_at(
        &mut self,
        now_us: u64,
        entries: Vec<Run<D::Entry>>,
        loop_playlist: bool,
        at: StartAt<D::Entry>,
    ) -> Result<(), StartError> {
        self.now_us = self.now_us.max(now_us);
        if self.is_running() {
            return Err(StartError::Busy);
        }
        if let Some(refusal) = refusal(&entries, &at) {
            return Err(refusal);
        }
        self.entries = entries;
        self.loop_playlist = loop_playlist;
        self.last_error = None;
        self.start_at = at;
        self.entry = self.start_at.entry;
        let (drive, first) = self.drive_and_current();
        drive.begin_run(now_us, first);
        if self.needs_home {
            self.begin_home(now_us, AfterMove::First);
        } else {
            self.begin_entry(now_us, self.start_at.entry);
        }
        Ok(())
    }

    /// The e-stop was sent (by the caller, ahead of everything): the sequencer stops,
    /// the drive drops what it queued, and the next Start homes first.
    pub fn estop(&mut self) {
        if self.step != Step::Failed {
            self.step = Step::Stopped;
        }
        self.needs_home = true;
        self.drive.stop();
        self.progress = 0.0;
        self.start_at.lead = None;
        self.live = None;
        self.recorder = None;
    }

    /// Reset (the caller sent the stop first): stops, then homes and plays `entries`
    /// from the first. If they cannot play, the matrix stays stopped and the error says
    /// why.
    ///
    /// # Errors
    /// Why the playlist cannot run.
    pub fn reset(
        &mut self,
        now_us: u64,
        entries: Result<Vec<Run<D::Entry>>, StartError>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        let at = StartAt {
            entry: 0,
            lead: None,
        };
        self.reset_at(now_us, entries.map(|entries| (entries, at)), loop_playlist)
    }

    /// Reset to an entry, from its start or a time inside it ([`StartAt`]): as
    /// [`Sequencer::reset`], then as [`Sequencer::start_at`].
    ///
    /// # Errors
    /// Why the playlist cannot run.
    pub fn reset_at(
        &mut self,
        now_us: u64,
        entries: Result<RunsAt<D::Entry>, StartError>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        self.estop();
        self.step = Step::Stopped;
        let result =
            entries.and_then(|(entries, at)| self.start_at(now_us, entries, loop_playlist, at));
        if let Err(error) = &result {
            self.last_error = Some(error.to_string());
        }
        result
    }

    /// **A locate** (a timecode jump): the run under way, if any, ends without an
    /// e-stop ([`Drive::interrupt`]), then the playlist begins at `entries`' start
    /// point as [`Sequencer::start_at`] does — from where the balls are, without
    /// homing (unless the positions were unknown). Nothing was sent to stop anything:
    /// the caller presses no e-stop.
    ///
    /// # Errors
    /// Why the playlist cannot run, or [`StartError::Busy`] when the drive cannot
    /// interrupt the run under way or the matrix is live: then nothing changed (a show
    /// under way plays on).
    pub fn locate_at(
        &mut self,
        now_us: u64,
        entries: Result<RunsAt<D::Entry>, StartError>,
        loop_playlist: bool,
    ) -> Result<(), StartError> {
        self.now_us = self.now_us.max(now_us);
        // A locate that cannot begin leaves the show under way playing.
        let (entries, at) = entries?;
        if let Some(refusal) = refusal(&entries, &at) {
            return Err(refusal);
        }
        if self.is_running() {
            // Live mode is left only by the operator (braking within the limits).
            if self.is_live() || !self.drive.interrupt(now_us) {
                return Err(StartError::Busy);
            }
            self.step = Step::Stopped;
            self.progress = 0.0;
            self.start_at.lead = None;
        }
        self.start_at(now_us, entries, loop_playlist, at)
    }

    /// Home (the caller sent the stop first): stops, brings every ball home and rests.
    pub fn home(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        self.estop();
        self.last_error = None;
        self.drive.begin_run(now_us, None);
        self.begin_home(now_us, AfterMove::Rest);
    }

    /// Arms `first` (the first entry of a playlist prepared at disarm count
    /// `disarms`) while the matrix is idle ([`Drive::arm`]); `false` when it is not
    /// idle or the drive did not take it.
    pub fn arm(&mut self, first: &D::Entry, disarms: u64) -> bool {
        self.is_idle() && self.drive.arm(first, disarms)
    }

    /// Fails the running playlist with `reason`, for a fault the caller found (a lost
    /// link): stops as an e-stop does (the caller presses it).
    pub fn fail_with(&mut self, reason: String) {
        if self.is_running() {
            self.estop();
            self.step = Step::Failed;
            self.last_error = Some(reason);
        }
    }

    /// Stops (the caller sent the stop) and stays stopped, saying `error` (why a
    /// Home could not begin, say).
    pub fn stop_with(&mut self, error: Option<String>) {
        self.estop();
        self.step = Step::Stopped;
        self.last_error = error;
    }

    /// Says `error` in the status without changing the state (a drive's note while at
    /// rest).
    pub fn set_last_error(&mut self, error: Option<String>) {
        self.last_error = error;
    }

    /// Fails the running playlist on the drive's own account (a unit's error, a ball
    /// that does not arrive): stops, and asks the caller for the e-stop
    /// ([`Sequencer::take_estop`]).
    pub fn fail(&mut self, reason: String) {
        if self.is_running() {
            self.estop_wanted = true;
            self.fail_with(reason);
        }
    }

    /// Lets time pass: checks the drive for a fault, ends an entry's delay, and polls
    /// the drive once in the step under way, moving on when it is over; while idle,
    /// lets the drive arm ([`Drive::poll_idle`]).
    pub fn poll(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        if self.is_idle() {
            self.drive.poll_idle(now_us);
            return;
        }
        if self.is_running()
            && let Some(reason) = self.drive.fault()
        {
            self.fail(reason);
            return;
        }
        if self.step == Step::Live {
            self.poll_live(now_us);
            return;
        }
        match self.step {
            Step::Waiting { until_us } if now_us < until_us => {
                self.progress = 0.0;
                return;
            }
            Step::Waiting { until_us } => self.begin_approach(until_us),
            _ => {}
        }
        if !self.in_drive_step() {
            return;
        }
        let (drive, entry) = self.drive_and_current();
        let phase = drive.poll(now_us, entry);
        self.advance(phase);
    }

    /// Whether the drive carries out the step under way (a move, a load, a show).
    fn in_drive_step(&self) -> bool {
        matches!(
            self.step,
            Step::Moving { .. } | Step::Loading | Step::Playing
        )
    }

    /// What the drive said of the step under way — after a poll, or after an input
    /// that ended it (an answer, a unit's feedback) — taken: the next step begins
    /// when it is over, the matrix stops when it failed.
    pub fn advance(&mut self, phase: Phase) {
        if self.step == Step::Live {
            self.live_prepared(phase);
            return;
        }
        if !self.in_drive_step() {
            return;
        }
        if self.step != Step::Playing {
            self.progress = self.drive.progress();
        }
        match phase {
            Phase::Pending => {}
            Phase::Failed(reason) => self.fail(reason),
            Phase::Done { at_us } => self.step_done(at_us),
        }
    }

    /// The step under way is over at `at_us`: the next begins.
    fn step_done(&mut self, at_us: u64) {
        match self.step {
            Step::Moving { kind, after } => {
                if kind == MoveKind::Home {
                    self.needs_home = false;
                }
                match after {
                    AfterMove::Rest => {
                        self.step = Step::Idle;
                        self.progress = 1.0;
                    }
                    AfterMove::First => self.begin_entry(at_us, self.start_at.entry),
                    AfterMove::Play => self.begin_load(at_us),
                    AfterMove::Live => self.begin_live_motion(at_us),
                }
            }
            Step::Loading => self.begin_play(at_us),
            Step::Playing => {
                // A lead played: the entry's next cycle is the full show.
                if self.lead().is_some() {
                    self.start_at.lead = None;
                    self.led = true;
                }
                self.after_play(at_us);
            }
            Step::Idle | Step::Waiting { .. } | Step::Live | Step::Stopped | Step::Failed => {}
        }
    }

    /// A show's cycle is over at `at_us`: the next cycle, the next entry, or rest.
    fn after_play(&mut self, at_us: u64) {
        match next_run(
            &self.timings(),
            self.entry,
            &mut self.cycle,
            self.loop_playlist,
        ) {
            NextRun::Cycle => self.begin_approach(at_us),
            NextRun::Entry(entry) => self.begin_entry(at_us, entry),
            NextRun::Rest => {
                self.step = Step::Idle;
                self.progress = 1.0;
            }
        }
    }

    fn timings(&self) -> Vec<EntryTiming> {
        self.entries.iter().map(|run| run.timing).collect()
    }

    fn begin_entry(&mut self, now_us: u64, entry: usize) {
        self.entry = entry;
        self.cycle = 1;
        self.led = false;
        self.progress = 0.0;
        // A start from inside a show does not wait out the delay before it.
        let delay_us = if self.lead().is_some() {
            0
        } else {
            self.entries
                .get(entry)
                .map_or(0, |run| run.timing.delay_ms.saturating_mul(1_000))
        };
        if delay_us > 0 {
            self.step = Step::Waiting {
                until_us: now_us + delay_us,
            };
        } else {
            self.begin_approach(now_us);
        }
    }

    fn begin_approach(&mut self, now_us: u64) {
        self.step = Step::Moving {
            kind: MoveKind::Approach,
            after: AfterMove::Play,
        };
        let (drive, Some(prepared)) = self.drive_and_current() else {
            return;
        };
        if drive.begin_approach(now_us, prepared) {
            self.progress = self.drive.progress();
        } else {
            self.begin_load(now_us);
        }
    }

    fn begin_home(&mut self, now_us: u64, after: AfterMove) {
        self.step = Step::Moving {
            kind: MoveKind::Home,
            after,
        };
        self.drive.begin_home(now_us);
        self.progress = self.drive.progress();
    }

    fn begin_load(&mut self, now_us: u64) {
        // A lead is an entry of its own to the drive; the entry's cycles after it are
        // counted from 1.
        let (index, cycle) = if self.lead().is_some() {
            (LEAD_INDEX, 1)
        } else {
            (self.entry, self.cycle - u32::from(self.led))
        };
        let (drive, Some(prepared)) = self.drive_and_current() else {
            return;
        };
        if drive.begin_load(now_us, index, prepared, cycle) {
            self.step = Step::Loading;
            self.progress = self.drive.progress();
        } else {
            self.begin_play(now_us);
        }
    }

    fn begin_play(&mut self, now_us: u64) {
        let last = self.entry + 1 == self.entries.len()
            && self.cycle >= self.entries[self.entry].timing.cycles.max(1)
            && !self.loop_playlist;
        self.progress = 0.0;
        self.step = Step::Playing;
        let (drive, Some(prepared)) = self.drive_and_current() else {
            return;
        };
        drive.begin_play(now_us, prepared, last);
    }
}

#[cfg(test)]
mod live_tests;
#[cfg(test)]
mod tests;
