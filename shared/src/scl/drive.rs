//! MOONS' drives under the show sequencer ([`crate::player`]): the [`Drive`] that
//! turns its steps into SCL requests and reads their answers, sans-IO — the caller
//! sends each [`SclAsk`] to its drive and hands the answer back with
//! [`SclDrive::answer`]; time is the caller's. So a whole show on MOONS' drives runs
//! against the drive twin ([`super::twin`]) in simulated time.
//!
//! **Which way shows play, and why.** Each show plays from **Q programs stored on the
//! drives**, not by streaming moves: a drive runs its program on its own clock and the
//! only timing-critical act is the common start, so neither a busy RS-485 line at
//! 9600 baud nor a lost datagram can bend the show.
//!
//! Each step is a few stages, each stage a few lanes run side by side — one lane a
//! line, so the drives of one line are asked one after the other (half duplex) and
//! the lines work at once — and a lane is a list of requests, each sent when the one
//! before it was answered:
//! - **move** (home, approach): `VE AC DE DI FP` to every drive (lanes by line), at the
//!   installation's approach speed and acceleration — the first move of a run (a
//!   Start, Reset or Home) preceded by `ME`, so a drive the schedule disabled at its
//!   window's end (`MD`) moves again; then `IP` to each drive until it
//!   stands at its target, every [`WAIT_POLL_US`], at most the whole travel at the
//!   approach speed and 5 s more;
//! - **load** (the first cycle of an entry, when programs are uploaded) — only for
//!   programs of more than one segment, which must be stored (a `QC` returns by
//!   loading its caller from memory, HCR p. 210): each segment read with `QU n`
//!   (HCR p. 219) and, only where it differs, loaded with `QL` and its lines and saved
//!   with `QS n` (HCR p. 216, 218), then read back. A repeated Start of the same show
//!   writes nothing: each partition lasts about 10,000 writes (HCR p. 294). The writes
//!   are counted per drive ([`SclDrive::flash_writes`]);
//! - **play**: a program of one segment goes to the queue, never to memory: `QL`, its
//!   lines, and `QE` runs it (HCR p. 212); a stored one runs with `QX1` (lanes by
//!   line: every drive loaded first, then started one after the other). With a
//!   trigger, the trigger output is set to its idle level first (its drive runs
//!   nothing then), every other drive started (they wait at line 1, `WI`), and then
//!   the edge: where the trigger drive plays a ball, its own program's line 1 sets
//!   the output (`SO`, in place of its `WI`) and it is started last; else the bridge
//!   sets it, and back 100 ms later. The bridge never sends a buffered command to a
//!   drive whose program runs. The show's time 0 ([`Drive::show_start_us`]) is when
//!   the first start (or the edge) reached its drive, as the caller says with
//!   [`SclDrive::delivered`] — the status says `playing` from then on; then the
//!   show's length, and `SC` to each drive until no program runs and no motor moves
//!   (at most 10 s).
//!
//! - **live** ([`live`], given the lines with [`SclDrive::with_live`]): every drive
//!   jogs, its speed changed each period (`CS`) from the filtered motion; the period
//!   is what the lines carry.
//!
//! A refusal, a missed answer or a drive that does not arrive fails the step with a
//! sentence naming the drive; the sequencer stops the matrix.

use std::collections::VecDeque;

use super::qprogram::QProgram;
use super::units;
use super::{
    Answer, Command, Decimal, InputCondition, IoPoint, Level, QueueUpload, Reply, Segment,
};
use crate::live::filter::BallState;
use crate::player::{Drive, Phase};

pub mod budget;
pub mod live;

pub use budget::{StreamBudget, stream_budget};
pub use live::{LIVE_PERIOD_MAX_MS, LIVE_PERIOD_MIN_MS, SclLine, SclLiveConfig};

/// How often the drive asks while it waits for the drives (`IP`, `SC`), µs.
pub const WAIT_POLL_US: u64 = 20_000;

/// How long the trigger output stays low before it goes high, µs.
pub const TRIGGER_PULSE_US: u64 = 100_000;

/// How long after a show's length the programs may still run, µs.
pub const END_GRACE_US: u64 = 10_000_000;

/// Lines of a streamed show put in a drive's command buffer before its start (of its
/// 63 places, HCR p. 53).
pub const STREAM_PRIME_LINES: usize = 56;

/// Places of the command buffer a top-up leaves free (a line under way, slack).
pub const STREAM_RESERVE: usize = 2;

/// How often the bridge asks a streaming drive how much room its buffer has (`BS`),
/// µs: 63 places hold about 1.5 s of a show jogged every 50 ms.
pub const STREAM_REFILL_US: u64 = 150_000;

/// Status code bit: a Q program is running (HCR, `SC`).
pub const SC_PROGRAM_RUNNING: u16 = 0x4000;

/// Status code bit: the motor is moving (HCR, `SC`).
pub const SC_MOVING: u16 = 0x0010;

/// What a request's answer is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expect {
    /// One answer line.
    One,
    /// `QU`: `%`, then a header `QU{n+1}` and `n` lines (or `?` alone).
    Upload,
    /// A **global** line: sent without an address, so every drive on the RS-485 line
    /// takes it, and none answers (HCR p. 305) — the one `CT` that starts every
    /// streaming drive of a line at once. The request is done when it is written.
    Global,
}

impl Expect {
    /// What `command`'s answer is.
    #[must_use]
    pub fn of(command: &Command) -> Self {
        if matches!(command, Command::QueueUpload { .. }) {
            Self::Upload
        } else {
            Self::One
        }
    }
}

/// Whether `command` may go while the e-stop is latched: a query, or a stop. The one
/// "inert while latched" rule of MOONS' drives.
#[must_use]
pub fn is_inert(command: &Command) -> bool {
    command.is_query()
        || matches!(
            command,
            Command::StopKill | Command::Stop | Command::MotorDisable | Command::AlarmCode
        )
}

/// A unit's drive: its gateway entry, its place there, and how errors name it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DriveSlot {
    /// The gateway entry (one RS-485 line or one set of eSCL drives).
    pub gateway: usize,
    /// The drive's index on it (station − 1).
    pub drive: usize,
    /// How errors name it: `drive "1" on SCL gateway 0`.
    pub name: String,
}

/// The common start by a trigger output wired to every drive's start input.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Trigger {
    /// The drive whose output it is, by its index on gateway 0; `Err`: why there is
    /// none (the start fails with it).
    pub drive: Result<usize, String>,
    /// How errors name that drive.
    pub name: String,
    /// The output.
    pub output: IoPoint,
}

/// What the drive needs to know about the installation.
#[derive(Debug, Clone, PartialEq)]
pub struct SclDriveConfig {
    /// Every unit's drive, in unit order.
    pub units: Vec<DriveSlot>,
    /// Gateway entries.
    pub gateways: usize,
    /// Drive counts per mm of ball travel.
    pub counts_per_mm: f64,
    /// Counts per motor revolution (`EG`): the unit of `VE` and `AC`/`DE`.
    pub steps_per_rev: u32,
    /// Approach and homing speed, mm/s.
    pub approach_speed_mm_s: f64,
    /// Acceleration of every move, mm/s².
    pub max_accel_mm_s2: f64,
    /// The home position, mm.
    pub home_mm: f64,
    /// The whole travel, mm.
    pub travel_mm: f64,
    /// The common start by a trigger output, or `None`: `QX1` to every drive.
    pub trigger: Option<Trigger>,
}

impl SclDriveConfig {
    /// `position_mm` in drive counts.
    #[must_use]
    pub fn counts(&self, position_mm: f64) -> i32 {
        let counts = (position_mm * self.counts_per_mm).round();
        counts.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
    }

    /// How long a move across the whole travel may take at the approach speed, and
    /// some, µs.
    fn travel_limit_us(&self) -> u64 {
        let speed = self.approach_speed_mm_s.max(1.0);
        ((self.travel_mm / speed + 5.0) * 1e6) as u64
    }
}

/// A program's stored segments, each with its lines.
pub type Segments = Vec<(Segment, Vec<Command>)>;

/// A playlist entry prepared for the drives: where each ball starts, and each
/// ball's program when programs are uploaded (`None`: the drives' stored programs
/// run).
#[derive(Debug, Clone, PartialEq)]
pub struct SclEntry {
    /// Each unit's first position, counts.
    pub start_counts: Vec<i32>,
    /// Each unit's program's segments, in unit order.
    pub programs: Option<Vec<Segments>>,
    /// Each unit's program is streamed (its one list of lines into the command
    /// buffer), not stored.
    pub streamed: Vec<bool>,
    /// The show's length, ms.
    pub duration_ms: u64,
}

/// The levels of the trigger output: `(idle, fire)` for the start condition the
/// programs wait for (a falling edge or a low level fires low).
#[must_use]
pub fn trigger_levels(condition: InputCondition) -> (Level, Level) {
    match condition {
        InputCondition::Falling | InputCondition::Low => (Level::High, Level::Low),
        InputCondition::Rising | InputCondition::High => (Level::Low, Level::High),
    }
}

/// The program of the ball whose drive is the trigger: its line 1, the wait for the
/// start input, becomes the edge itself (`SO`, the output at its firing level), so
/// the bridge never writes to a drive whose program runs. Returns whether it did.
pub fn fire_from_program(segments: &mut Segments, output: IoPoint) -> bool {
    let Some((_, main)) = segments.first_mut() else {
        return false;
    };
    match main.first().copied() {
        Some(Command::WaitForInput { condition, .. }) => {
            let (_, fire) = trigger_levels(condition);
            main[0] = Command::SetOutput {
                output,
                level: fire,
            };
            true
        }
        _ => false,
    }
}

impl SclEntry {
    /// The entry of a show whose tracks start at `start_mm`, with `programs`.
    #[must_use]
    pub fn new(
        config: &SclDriveConfig,
        start_mm: impl IntoIterator<Item = f64>,
        programs: Option<Vec<QProgram>>,
        duration_ms: u64,
    ) -> Self {
        let streamed: Vec<bool> = programs
            .iter()
            .flatten()
            .map(|program| program.streamed)
            .collect();
        let mut programs: Option<Vec<Segments>> = programs.map(|programs| {
            programs
                .into_iter()
                .map(|program| program.segments)
                .collect()
        });
        // The trigger drive's ball fires the edge from its own program.
        if let (
            Some(programs),
            Some(Trigger {
                drive: Ok(drive),
                output,
                ..
            }),
        ) = (programs.as_mut(), config.trigger.as_ref())
            && let Some(unit) = config
                .units
                .iter()
                .position(|slot| slot.gateway == 0 && slot.drive == *drive)
            && let Some(segments) = programs.get_mut(unit)
        {
            fire_from_program(segments, *output);
        }
        Self {
            start_counts: start_mm.into_iter().map(|mm| config.counts(mm)).collect(),
            programs,
            streamed,
            duration_ms,
        }
    }
}

/// One request for the caller to send: `text` (SCL without the address) to drive
/// `drive` of gateway entry `gateway`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SclAsk {
    /// Hand it back with the answer ([`SclDrive::answer`]).
    pub id: u64,
    /// The gateway entry.
    pub gateway: usize,
    /// The drive's index there.
    pub drive: usize,
    /// The request.
    pub text: String,
    /// What its answer is.
    pub expect: Expect,
}

/// What an answer must be.
#[derive(Debug, Clone, PartialEq)]
enum Check {
    /// Anything but a refusal.
    NotRefused,
    /// `IP` at the target (asked again until the deadline).
    Position { target: i64 },
    /// `SC` without a program running or a motor moving (asked again until the
    /// deadline).
    Ended,
    /// `QU n` before a write: the segment as stored; where it differs from
    /// `commands`, the write follows.
    Compare {
        segment: Segment,
        commands: Vec<Command>,
    },
    /// `QL`'s `%`: the queue loads from the host.
    QueueLoad,
    /// A program line's `*` (`segment`: where it is saved; `None`: the queue).
    Line { segment: Option<Segment> },
    /// `QS n`'s `%`: one write to the segment's memory.
    Saved { segment: Segment },
    /// `BS`: the room in a streaming drive's buffer, filled with its next lines.
    Free,
    /// `QU`: the lines written.
    ReadBack {
        segment: Segment,
        commands: Vec<Command>,
    },
    /// Live mode's `IP`: the position read, for the position correction.
    Read,
}

#[derive(Debug, Clone, PartialEq)]
enum Action {
    Ask {
        unit: usize,
        command: Option<Command>,
        check: Check,
    },
    /// Wait so long, µs.
    Sleep(u64),
    /// Wait until the show's length has passed since its time 0.
    ShowEnd,
    /// The show's time 0 is when the request answered last on this lane reached its
    /// drive (the first `QX1`, the trigger's edge).
    Started,
    /// A global line to every drive of gateway entry `gateway` (its RS-485 line):
    /// [`Expect::Global`].
    Global { gateway: usize, command: Command },
    /// A unit's programs are written.
    Loaded,
    /// The end of a round of top-ups on a line: another round after
    /// [`STREAM_REFILL_US`] while any of `units` has lines left to stream.
    Refill { units: Vec<usize> },
}

#[derive(Debug, Default)]
struct Lane {
    actions: VecDeque<Action>,
    /// The request out, and what it was.
    waiting: Option<(u64, Action)>,
    /// When the request out reached its drive, µs, once the caller said so
    /// ([`SclDrive::delivered`]).
    waiting_delivered_us: Option<u64>,
    /// When the request answered last reached its drive (or was answered, if the
    /// caller did not say), µs.
    answered_delivered_us: Option<u64>,
    sleeping_until_us: Option<u64>,
}

impl Lane {
    fn of(actions: impl IntoIterator<Item = Action>) -> Self {
        Self {
            actions: actions.into_iter().collect(),
            ..Self::default()
        }
    }

    fn is_done(&self) -> bool {
        self.actions.is_empty() && self.waiting.is_none() && self.sleeping_until_us.is_none()
    }
}

type Stage = Vec<Lane>;

/// The MOONS' drive; see the [module documentation](self).
#[derive(Debug)]
pub struct SclDrive {
    config: SclDriveConfig,
    /// Every unit's drive, then the trigger's (it may drive no ball).
    slots: Vec<DriveSlot>,
    /// The stages to come of the step under way; the first runs.
    stages: VecDeque<Stage>,
    /// When the running stage began, µs.
    stage_began_us: u64,
    next_id: u64,
    asks: Vec<SclAsk>,
    failure: Option<String>,
    /// The show's time 0, µs, while playing.
    started_us: Option<u64>,
    duration_ms: u64,
    playing: bool,
    /// Loading: units written of all.
    loaded: usize,
    loading: bool,
    now_us: u64,
    /// What the next move does before it feeds.
    before_next_move: BeforeMove,
    /// How live mode jogs on these lines ([`SclDrive::with_live`]); `None`: live mode
    /// is refused.
    live_config: Option<SclLiveConfig>,
    /// Live motion under way ([`live`]).
    live: Option<live::LiveRun>,
    /// Where every drive rests, counts, when known (after a home or an approach, or
    /// live mode's end); `None` otherwise.
    believed_counts: Option<Vec<i32>>,
    /// The targets of the move under way, taken as known when it ends.
    moving_to: Option<Vec<i32>>,
    /// Live mode's last stages (`SJ`, the exact `FP`, the arrival) run on while idle:
    /// a step begun meanwhile runs after them.
    ending: bool,
    /// Each unit's drive: the segments it was told to save (`QS`) since the bridge
    /// started.
    flash_writes: Vec<u64>,
    /// Each streaming unit's lines still to send, while a streamed show plays.
    streams: Vec<VecDeque<Command>>,
}

/// What the next move does before it feeds, taken by that move.
#[derive(Debug, Clone, Copy, Default)]
struct BeforeMove {
    /// A locate ended the run under way: every drive stopped and its program killed
    /// (`SK`, at its deceleration), a stage of its own before the feed.
    kill: bool,
    /// Each run: `ME` first in every drive's feed (a disabled drive refuses to move,
    /// alarm `8000` No Move); live mode's first jog takes it too.
    enable: bool,
}

impl SclDrive {
    /// The drive for `config`.
    #[must_use]
    pub fn new(config: SclDriveConfig) -> Self {
        let mut slots = config.units.clone();
        if let Some(Trigger {
            drive: Ok(drive),
            name,
            ..
        }) = &config.trigger
        {
            slots.push(DriveSlot {
                gateway: 0,
                drive: *drive,
                name: name.clone(),
            });
        }
        Self {
            config,
            slots,
            stages: VecDeque::new(),
            stage_began_us: 0,
            next_id: 1,
            asks: Vec::new(),
            failure: None,
            started_us: None,
            duration_ms: 0,
            playing: false,
            loaded: 0,
            loading: false,
            now_us: 0,
            before_next_move: BeforeMove::default(),
            live_config: None,
            live: None,
            believed_counts: None,
            moving_to: None,
            ending: false,
            flash_writes: Vec::new(),
            streams: Vec::new(),
        }
    }

    /// Each unit's drive: how many segments it saved to its non-volatile memory
    /// (`QS`) since the bridge started, in unit order.
    #[must_use]
    pub fn flash_writes(&self) -> Vec<u64> {
        let mut counts = self.flash_writes.clone();
        counts.resize(self.config.units.len(), 0);
        counts
    }

    /// The unit whose drive is the trigger's, if the trigger drive plays a ball.
    fn trigger_unit(&self) -> Option<usize> {
        let drive = self.config.trigger.as_ref()?.drive.as_ref().ok()?;
        self.config
            .units
            .iter()
            .position(|slot| slot.gateway == 0 && slot.drive == *drive)
    }

    /// The drive with live mode on these lines ([`live`]).
    #[must_use]
    pub fn with_live(mut self, live: SclLiveConfig) -> Self {
        self.live_config = Some(live);
        self
    }

    /// The installation it drives.
    #[must_use]
    pub fn config(&self) -> &SclDriveConfig {
        &self.config
    }

    /// The requests to send now, in order.
    pub fn take_asks(&mut self) -> Vec<SclAsk> {
        std::mem::take(&mut self.asks)
    }

    /// The show's time 0 on the caller's clock while a show plays, µs.
    #[must_use]
    pub fn started_us(&self) -> Option<u64> {
        self.started_us.filter(|_| self.playing)
    }

    /// Request `id` reached its drive at `at_us` (its last byte through the line):
    /// said before its answer, it times what the request does — a `QX1` or the
    /// trigger's edge is the show's time 0. Without it, the answer's time stands in.
    pub fn delivered(&mut self, id: u64, at_us: u64) {
        if let Some(lane) = Self::lane_waiting_for(&mut self.stages, id) {
            lane.waiting_delivered_us = Some(at_us);
        }
    }

    fn lane_waiting_for(stages: &mut VecDeque<Stage>, id: u64) -> Option<&mut Lane> {
        stages.front_mut().and_then(|stage| {
            stage
                .iter_mut()
                .find(|lane| lane.waiting.as_ref().is_some_and(|(out, _)| *out == id))
        })
    }

    /// The answer to request `id` at `now_us`: its lines (addresses removed), or why
    /// there is none. Answers to requests of a step that ended are ignored.
    pub fn answer(&mut self, now_us: u64, id: u64, answer: Result<Vec<String>, String>) {
        self.now_us = self.now_us.max(now_us);
        let Some(lane) = Self::lane_waiting_for(&mut self.stages, id) else {
            return;
        };
        let Some((_, action)) = lane.waiting.take() else {
            return;
        };
        lane.answered_delivered_us = Some(lane.waiting_delivered_us.take().unwrap_or(now_us));
        let Action::Ask {
            unit,
            command,
            check,
        } = &action
        else {
            return;
        };
        let deadline_us = self.stage_began_us.saturating_add(match check {
            Check::Ended => END_GRACE_US,
            _ => self.config.travel_limit_us(),
        });
        let limit_ms = self.config.travel_limit_us() / 1_000;
        let name = self
            .slots
            .get(*unit)
            .map_or_else(String::new, |slot| slot.name.clone());
        let read = match (&check, &answer) {
            (Check::Read, Ok(lines)) => lines
                .first()
                .and_then(|line| Reply::parse(line).ok())
                .and_then(|reply| reply.answer.value_i64()),
            _ => None,
        };
        let read_at_us = lane.answered_delivered_us.unwrap_or(now_us);
        if let (Check::Compare { segment, commands }, Ok(lines)) = (check, &answer) {
            // Stored as it is: nothing to write. Else load it and save it (one write
            // to the segment's memory), and read it back.
            let rest: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
            let same = matches!(
                QueueUpload::parse(&rest),
                Ok((_, QueueUpload::Lines(stored))) if stored == *commands
            );
            if !same {
                let write = write_segment(*unit, *segment, commands);
                for action in write.into_iter().rev() {
                    lane.actions.push_front(action);
                }
            }
            return self.after_answer(now_us);
        }
        if let (Check::Free, Ok(lines)) = (check, &answer)
            && let Some(free) = lines
                .first()
                .and_then(|line| Reply::parse(line).ok())
                .and_then(|reply| reply.answer.value_i64())
        {
            // As many of its next lines as its buffer has room for, before anything
            // else on this line.
            let room = usize::try_from(free)
                .unwrap_or(0)
                .saturating_sub(STREAM_RESERVE);
            if let Some(stream) = self.streams.get_mut(*unit) {
                let take = room.min(stream.len());
                let next: Vec<Command> = stream.drain(..take).collect();
                for command in next.into_iter().rev() {
                    lane.actions
                        .push_front(ask(*unit, command, Check::Line { segment: None }));
                }
            }
            return self.after_answer(now_us);
        }
        if let (Check::Saved { .. }, Ok(lines)) = (check, &answer)
            && matches!(
                lines.first().map(|line| Reply::parse(line)),
                Some(Ok(Reply {
                    answer: Answer::Executed,
                    ..
                }))
            )
        {
            if self.flash_writes.len() <= *unit {
                self.flash_writes.resize(unit + 1, 0);
            }
            self.flash_writes[*unit] += 1;
        }
        // Live: a speed that came before its jog began is asked again next period.
        let early = matches!(command, Some(Command::ChangeSpeed { .. }))
            && matches!(
                answer
                    .as_ref()
                    .ok()
                    .and_then(|lines| lines.first())
                    .map(|line| Reply::parse(line)),
                Some(Ok(Reply {
                    answer: Answer::Refused {
                        code: Some(live::CS_NOT_JOGGING)
                    },
                    ..
                }))
            );
        if early
            && let Some(live) = self.live.as_mut()
            && !live.early_speed(*unit)
        {
            return self.after_answer(now_us);
        }
        match judge(&name, command.as_ref(), check, answer, limit_ms) {
            Verdict::Ok => {
                if let Some(live) = self.live.as_mut() {
                    if let Some(counts) = read {
                        live.read(*unit, read_at_us, counts);
                    } else if let Some(command) = command {
                        let per_rev = f64::from(self.config.steps_per_rev);
                        live.took(*unit, command, read_at_us, per_rev);
                    }
                }
            }
            Verdict::Again(why) => {
                if now_us >= deadline_us {
                    self.failure.get_or_insert(why);
                } else {
                    lane.actions.push_front(action.clone());
                    lane.sleeping_until_us = Some(now_us + WAIT_POLL_US);
                }
            }
            Verdict::Failed(why) => {
                self.failure.get_or_insert(why);
            }
        }
        self.after_answer(now_us);
    }

    fn after_answer(&mut self, now_us: u64) {
        // Live mode (and its end) is not polled between its periods: the lane's next
        // request goes now.
        if self.live.is_some() || self.ending {
            self.advance(now_us);
        }
    }

    fn begin_stages(&mut self, now_us: u64, stages: Vec<Stage>) {
        self.now_us = now_us;
        let mut kept = if std::mem::take(&mut self.ending) {
            std::mem::take(&mut self.stages)
        } else {
            VecDeque::new()
        };
        kept.extend(stages);
        self.stages = kept;
        self.stage_began_us = now_us;
        self.failure = None;
        self.advance(now_us);
    }

    /// One lane per gateway entry, each unit's `actions` on its own entry's lane.
    fn by_line(&self, actions: impl Fn(usize) -> Vec<Action>) -> Stage {
        (0..self.config.gateways)
            .map(|gateway| {
                Lane::of(
                    self.config
                        .units
                        .iter()
                        .enumerate()
                        .filter(|(_, slot)| slot.gateway == gateway)
                        .flat_map(|(unit, _)| actions(unit)),
                )
            })
            .collect()
    }

    /// The feeds' speed (the approach's, rev/s) and ramps (the top acceleration,
    /// rev/s²), in whole steps as a drive holds them, never faster nor harder than
    /// set.
    fn feed_ramps(&self) -> (Decimal, Decimal) {
        let per_rev = f64::from(self.config.steps_per_rev);
        let velocity = at_most(
            &units::VELOCITY,
            self.config.approach_speed_mm_s * self.config.counts_per_mm / per_rev,
        );
        let accel = at_most(
            &units::ACCELERATION,
            self.config.max_accel_mm_s2 * self.config.counts_per_mm / per_rev,
        );
        (velocity, accel)
    }

    fn move_stages(&self, targets_counts: &[i32], enable: bool) -> Vec<Stage> {
        let (velocity, accel) = self.feed_ramps();
        let target = |unit: usize| targets_counts.get(unit).copied().unwrap_or(0);
        let feed = self.by_line(|unit| {
            asks_enabled_first(
                unit,
                enable,
                feed_settings(velocity, accel).into_iter().chain([
                    Command::Distance {
                        counts: Some(target(unit)),
                    },
                    Command::FeedToPosition,
                ]),
            )
        });
        let arrive = Lane::of((0..self.config.units.len()).map(|unit| {
            ask(
                unit,
                Command::ImmediatePosition,
                Check::Position {
                    target: i64::from(target(unit)),
                },
            )
        }));
        vec![feed, vec![arrive]]
    }

    fn begin_move(&mut self, now_us: u64, targets_counts: &[i32]) {
        self.playing = false;
        self.loading = false;
        self.believed_counts = None;
        self.moving_to = Some(targets_counts.to_vec());
        let before = std::mem::take(&mut self.before_next_move);
        let mut stages = self.move_stages(targets_counts, before.enable);
        if before.kill {
            let kill = self.by_line(|unit| vec![ask(unit, Command::StopKill, Check::NotRefused)]);
            stages.insert(0, kill);
        }
        self.begin_stages(now_us, stages);
    }

    /// Sends what is due and moves on through the stages; whether the step is over.
    fn advance(&mut self, now_us: u64) -> bool {
        loop {
            if self.failure.is_some() {
                return false;
            }
            let Some(stage) = self.stages.front_mut() else {
                return true;
            };
            for lane in stage.iter_mut() {
                if lane
                    .sleeping_until_us
                    .is_some_and(|until_us| now_us >= until_us)
                {
                    lane.sleeping_until_us = None;
                }
                while lane.waiting.is_none() && lane.sleeping_until_us.is_none() {
                    let Some(action) = lane.actions.pop_front() else {
                        break;
                    };
                    match &action {
                        Action::Ask { unit, command, .. } => {
                            let Some(slot) = self.slots.get(*unit) else {
                                continue;
                            };
                            let id = self.next_id;
                            self.next_id += 1;
                            self.asks.push(SclAsk {
                                id,
                                gateway: slot.gateway,
                                drive: slot.drive,
                                text: command
                                    .as_ref()
                                    .map(ToString::to_string)
                                    .unwrap_or_default(),
                                expect: command.as_ref().map_or(Expect::One, Expect::of),
                            });
                            lane.waiting = Some((id, action));
                        }
                        Action::Global { gateway, command } => {
                            let Some(drive) = self
                                .config
                                .units
                                .iter()
                                .find(|slot| slot.gateway == *gateway)
                                .map(|slot| slot.drive)
                            else {
                                continue;
                            };
                            let id = self.next_id;
                            self.next_id += 1;
                            self.asks.push(SclAsk {
                                id,
                                gateway: *gateway,
                                drive,
                                text: command.to_string(),
                                expect: Expect::Global,
                            });
                            lane.waiting = Some((id, action));
                        }
                        Action::Sleep(us) => lane.sleeping_until_us = Some(now_us + us),
                        Action::ShowEnd => {
                            let end_us = self.started_us.unwrap_or(now_us)
                                + self.duration_ms.saturating_mul(1_000);
                            if now_us < end_us {
                                lane.sleeping_until_us = Some(end_us);
                            }
                        }
                        Action::Started => {
                            let at_us = lane.answered_delivered_us.unwrap_or(now_us);
                            self.started_us =
                                Some(self.started_us.map_or(at_us, |first| first.min(at_us)));
                        }
                        Action::Loaded => self.loaded += 1,
                        Action::Refill { units } => {
                            let left: Vec<usize> = units
                                .iter()
                                .copied()
                                .filter(|&unit| {
                                    self.streams.get(unit).is_some_and(|s| !s.is_empty())
                                })
                                .collect();
                            if !left.is_empty() {
                                lane.actions.push_back(Action::Sleep(STREAM_REFILL_US));
                                lane.actions
                                    .extend(left.iter().map(|&unit| {
                                        ask(unit, Command::BufferStatus, Check::Free)
                                    }));
                                lane.actions.push_back(Action::Refill { units: left });
                            }
                        }
                    }
                }
            }
            if !stage.iter().all(Lane::is_done) {
                return false;
            }
            self.stages.pop_front();
            self.stage_began_us = now_us;
        }
    }
}

fn ask(unit: usize, command: Command, check: Check) -> Action {
    Action::Ask {
        unit,
        command: Some(command),
        check,
    }
}

/// `QL`, `commands` as the lines of the queue, `QS segment` and `QU segment` to read it
/// back: a stored segment written.
fn write_segment(unit: usize, segment: Segment, commands: &[Command]) -> Vec<Action> {
    let mut actions = vec![ask(
        unit,
        Command::QueueLoad { segment: None },
        Check::QueueLoad,
    )];
    actions.extend(commands.iter().map(|command| {
        ask(
            unit,
            *command,
            Check::Line {
                segment: Some(segment),
            },
        )
    }));
    actions.push(ask(
        unit,
        Command::QueueSave { segment },
        Check::Saved { segment },
    ));
    actions.push(ask(
        unit,
        Command::QueueUpload {
            segment: Some(segment),
        },
        Check::ReadBack {
            segment,
            commands: commands.to_vec(),
        },
    ));
    actions
}

/// `value` with `scale` decimals, as a parameter.
/// `value` in whole steps of `resolution` ([`units`]): at most `value`, within the
/// drive's range (its smallest value when `value` is below it).
/// A feed's speed (`VE`, rev/s) and ramps (`AC`, `DE`, rev/s²).
fn feed_settings(velocity: Decimal, accel: Decimal) -> [Command; 3] {
    [
        Command::Velocity {
            rev_s: Some(velocity),
        },
        Command::Acceleration {
            rev_s2: Some(accel),
        },
        Command::Deceleration {
            rev_s2: Some(accel),
        },
    ]
}

/// `commands` to `unit` in order, each answered without a refusal; after `ME` when
/// `enable`.
fn asks_enabled_first(
    unit: usize,
    enable: bool,
    commands: impl IntoIterator<Item = Command>,
) -> Vec<Action> {
    enable
        .then_some(Command::MotorEnable)
        .into_iter()
        .chain(commands)
        .map(|command| ask(unit, command, Check::NotRefused))
        .collect()
}

fn at_most(resolution: &units::Resolution, value: f64) -> Decimal {
    let steps = (value / resolution.step + 1e-9).floor() as i64;
    let steps = steps.clamp(resolution.min_steps.max(1), resolution.max_steps);
    resolution
        .write(steps)
        .unwrap_or_else(|| Decimal::from_int(0))
}

enum Verdict {
    Ok,
    /// Not yet: ask again (this is why, when time is up).
    Again(String),
    Failed(String),
}

/// What the answer `lines` to `command` (on drive `name`) means for `check`.
fn judge(
    name: &str,
    command: Option<&Command>,
    check: &Check,
    lines: Result<Vec<String>, String>,
    limit_ms: u64,
) -> Verdict {
    let lines = match lines {
        Ok(lines) => lines,
        Err(why) => return Verdict::Failed(why),
    };
    let text = command.map(ToString::to_string).unwrap_or_default();
    let first = lines.first().map(|line| Reply::parse(line));
    let unparsed = || format!("{name} answered {:?}", lines.join(" "));
    match check {
        Check::NotRefused | Check::Position { .. } | Check::Ended | Check::Read => {
            if let Some(Ok(Reply {
                answer: Answer::Refused { code },
                ..
            })) = &first
            {
                return Verdict::Failed(format!(
                    "{name} refused {text}{}",
                    code.map(|code| format!(" (code {code})"))
                        .unwrap_or_default()
                ));
            }
            let answer = match first {
                Some(Ok(reply)) => reply.answer,
                _ if *check == Check::NotRefused => return Verdict::Ok,
                _ => {
                    return Verdict::Failed(format!(
                        "{name} answered {text} with {:?}",
                        lines.join(" ")
                    ));
                }
            };
            match check {
                Check::Position { target } => {
                    let at = answer.value_i64();
                    if at == Some(*target) {
                        Verdict::Ok
                    } else {
                        Verdict::Again(format!(
                            "{name} is at {} counts, not {target}, {limit_ms} ms after it was sent \
                             there",
                            at.map_or_else(|| "?".to_owned(), |at| at.to_string()),
                        ))
                    }
                }
                Check::Ended => {
                    let code = answer.value_hex_u16().unwrap_or(0);
                    if code & (SC_PROGRAM_RUNNING | SC_MOVING) == 0 {
                        Verdict::Ok
                    } else {
                        Verdict::Again(format!(
                            "{name} still runs its program (status code {code:04X}) after the \
                             show's end"
                        ))
                    }
                }
                _ => Verdict::Ok,
            }
        }
        Check::Compare { .. } | Check::Free => Verdict::Ok,
        Check::QueueLoad | Check::Saved { .. } => match first {
            Some(Ok(Reply {
                answer: Answer::Executed,
                ..
            })) => Verdict::Ok,
            Some(Ok(Reply {
                answer: Answer::Refused { code },
                ..
            })) => Verdict::Failed(format!(
                "{name} refused {text}{}: it does not take programs from the bridge (a \
                 drive without Q programs?). Load each drive's program with MOONS' Q \
                 Programmer (the app offers every ball's program as a download) and set \
                 programs = \"stored\" in [scl]",
                code.map(|code| format!(" (code {code})"))
                    .unwrap_or_default()
            )),
            Some(Ok(reply)) => {
                Verdict::Failed(format!("{name} answered {text} with {}", reply.answer))
            }
            _ => Verdict::Failed(unparsed()),
        },
        Check::Line { segment } => match first {
            Some(Ok(Reply {
                answer: Answer::Buffered,
                ..
            })) => Verdict::Ok,
            Some(Ok(reply)) => Verdict::Failed(format!(
                "{name} answered line {text} of {} with {}",
                segment.map_or_else(|| "the queue".to_owned(), |s| format!("segment {s}")),
                reply.answer
            )),
            _ => Verdict::Failed(unparsed()),
        },
        Check::ReadBack { segment, commands } => {
            let rest: Vec<&str> = lines.iter().skip(1).map(String::as_str).collect();
            match QueueUpload::parse(&rest) {
                Ok((_, QueueUpload::Lines(read_back))) if read_back == *commands => Verdict::Ok,
                Ok((_, QueueUpload::Lines(read_back))) => Verdict::Failed(format!(
                    "{name} holds {} lines in segment {segment} after the upload, not the {} \
                     written (or not the same)",
                    read_back.len(),
                    commands.len()
                )),
                Ok((_, other)) => Verdict::Failed(format!(
                    "{name} answered {text} with {}",
                    other.lines().join(" ")
                )),
                Err(error) => Verdict::Failed(format!(
                    "{name} answered {text} with {:?}: {error}",
                    lines.join(" ")
                )),
            }
        }
    }
}

impl Drive for SclDrive {
    type Entry = SclEntry;

    /// Live motion by jogging ([`live`]): the period from what the lines carry.
    fn live_setup(&self) -> Result<crate::player::LiveSetup, crate::player::StartError> {
        self.live_setup_scl()
    }

    fn rest_positions_mm(&self) -> Option<Vec<f64>> {
        if self.live.is_some() {
            return None;
        }
        let per_mm = self.config.counts_per_mm;
        self.believed_counts
            .as_ref()
            .map(|counts| counts.iter().map(|&c| f64::from(c) / per_mm).collect())
    }

    fn begin_live(&mut self, now_us: u64, states: &[BallState]) -> bool {
        self.begin_live_scl(now_us, states)
    }

    fn live_step(&mut self, slot_us: u64, states: &[BallState]) {
        self.live_step_scl(slot_us, states);
    }

    fn end_live(&mut self, at_us: u64, states: &[BallState]) {
        self.end_live_scl(at_us, states);
    }

    /// A refusal or a missed answer while live (the sequencer does not poll the drive
    /// between periods).
    fn fault(&mut self) -> Option<String> {
        if self.live.is_some() {
            self.failure.take()
        } else {
            None
        }
    }

    fn idle_wakeup_us(&self, now_us: u64) -> Option<u64> {
        if self.ending {
            self.next_wakeup_us(now_us)
        } else {
            None
        }
    }

    /// Live mode's end runs on while idle; should it fail, the positions are unknown
    /// (the next Start or live mode homes first).
    fn poll_idle(&mut self, now_us: u64) {
        if !self.ending {
            return;
        }
        self.now_us = self.now_us.max(now_us);
        let done = self.advance(now_us);
        if self.failure.take().is_some() {
            self.stages.clear();
            self.believed_counts = None;
            self.ending = false;
        } else if done {
            self.ending = false;
        }
    }

    fn begin_run(&mut self, now_us: u64, _first: Option<&mut SclEntry>) {
        self.now_us = now_us;
        self.before_next_move.enable = true;
    }

    fn begin_home(&mut self, now_us: u64) {
        let home = vec![self.config.counts(self.config.home_mm); self.config.units.len()];
        self.begin_move(now_us, &home);
    }

    fn begin_approach(&mut self, now_us: u64, entry: &mut SclEntry) -> bool {
        let start = entry.start_counts.clone();
        self.begin_move(now_us, &start);
        true
    }

    fn begin_load(&mut self, now_us: u64, _index: usize, entry: &mut SclEntry, cycle: u32) -> bool {
        self.believed_counts = None;
        let Some(programs) = entry.programs.as_ref().filter(|_| cycle == 1) else {
            return false;
        };
        // Programs of more than one segment are stored: each segment compared with
        // what the drive holds, written only where it differs.
        let mut actions = Vec::new();
        for (unit, segments) in programs.iter().enumerate() {
            let streamed = entry.streamed.get(unit).copied().unwrap_or(false);
            if segments.len() > 1 && !streamed {
                for (segment, commands) in segments {
                    actions.push(ask(
                        unit,
                        Command::QueueUpload {
                            segment: Some(*segment),
                        },
                        Check::Compare {
                            segment: *segment,
                            commands: commands.clone(),
                        },
                    ));
                }
            }
            actions.push(Action::Loaded);
        }
        self.playing = false;
        self.loading = true;
        self.loaded = 0;
        self.begin_stages(now_us, vec![vec![Lane::of(actions)]]);
        true
    }

    fn begin_play(&mut self, now_us: u64, entry: &mut SclEntry, _last: bool) {
        self.believed_counts = None;
        self.playing = true;
        self.loading = false;
        self.started_us = None;
        self.duration_ms = entry.duration_ms;
        let programs = entry.programs.as_ref();
        let streamed = |unit: usize| entry.streamed.get(unit).copied().unwrap_or(false);
        let lines_of = |unit: usize| -> Option<&Vec<Command>> {
            programs
                .and_then(|programs| programs.get(unit))
                .filter(|segments| segments.len() == 1)
                .and_then(|segments| segments.first())
                .map(|(_, commands)| commands)
        };
        let queued = |unit: usize| lines_of(unit).filter(|_| !streamed(unit));
        // Each line must carry its streams, or the buffers run dry mid-show.
        if let Some(live) = &self.live_config {
            for (gateway, line) in live.lines.iter().enumerate() {
                let streaming = (0..self.config.units.len())
                    .filter(|&unit| streamed(unit) && self.config.units[unit].gateway == gateway)
                    .count();
                let budget = stream_budget(*line, crate::scl::qprogram::STREAM_STEP_S).drives;
                if streaming > budget {
                    self.failure = Some(format!(
                        "SCL gateway {gateway} would stream the show to {streaming} drives; \
                         its line carries {budget} ({line:?}): give the drives a faster \
                         line (115200 baud, or eSCL), fewer drives a line, or shows short \
                         enough to store"
                    ));
                    return;
                }
            }
        }
        // A streamed show: every drive paused (`PS`), its buffer filled, the rest sent
        // as it plays (HCR p. 206, 53).
        self.streams = (0..self.config.units.len())
            .map(|unit| match lines_of(unit).filter(|_| streamed(unit)) {
                Some(lines) => lines.iter().copied().collect(),
                None => VecDeque::new(),
            })
            .collect();
        let primes: Vec<Vec<Command>> = self
            .streams
            .iter_mut()
            .map(|stream| {
                let take = STREAM_PRIME_LINES.min(stream.len());
                stream.drain(..take).collect()
            })
            .collect();
        let trigger_unit = self.trigger_unit();
        let mut stages = Vec::new();
        // Programs of one segment to the queue, never to memory (HCR p. 216).
        let load = self.by_line(|unit| match queued(unit) {
            None if streamed(unit) => {
                let mut actions = vec![ask(unit, Command::Pause, Check::NotRefused)];
                actions.extend(
                    primes[unit]
                        .iter()
                        .map(|command| ask(unit, *command, Check::Line { segment: None })),
                );
                actions
            }
            Some(commands) => {
                let mut actions = vec![ask(
                    unit,
                    Command::QueueLoad { segment: None },
                    Check::QueueLoad,
                )];
                actions.extend(
                    commands
                        .iter()
                        .map(|command| ask(unit, *command, Check::Line { segment: None })),
                );
                actions
            }
            None => Vec::new(),
        });
        let Some(first) = Segment::new(1) else {
            return;
        };
        let start = |unit: usize| {
            if streamed(unit) {
                ask(unit, Command::Continue, Check::NotRefused)
            } else if queued(unit).is_some() {
                ask(unit, Command::QueueExecuteLoaded, Check::NotRefused)
            } else {
                ask(
                    unit,
                    Command::QueueExecute { segment: first },
                    Check::NotRefused,
                )
            }
        };
        match self.config.trigger.clone() {
            None => {
                stages.push(load);
                // Each line's first drive starts when its start is through: the
                // earliest is the show's time 0 (the others follow one request each).
                // The streaming drives of an RS-485 line start together, on one `CT`
                // without an address (HCR p. 72, 305).
                let rs485 = |gateway: usize| {
                    self.live_config.as_ref().is_some_and(|live| {
                        matches!(live.lines.get(gateway), Some(SclLine::Rs485 { .. }))
                    })
                };
                let mut fire = self.by_line(|unit| {
                    let gateway = self.config.units[unit].gateway;
                    if streamed(unit) && rs485(gateway) {
                        Vec::new()
                    } else {
                        vec![start(unit)]
                    }
                });
                for (gateway, lane) in fire.iter_mut().enumerate() {
                    let streams = (0..self.config.units.len())
                        .any(|unit| streamed(unit) && self.config.units[unit].gateway == gateway);
                    if streams && rs485(gateway) {
                        lane.actions.push_front(Action::Global {
                            gateway,
                            command: Command::Continue,
                        });
                    }
                    if !lane.actions.is_empty() {
                        lane.actions.insert(1, Action::Started);
                    }
                }
                stages.push(fire);
            }
            Some(Trigger { drive, output, .. }) => {
                if let Err(why) = drive {
                    self.failure = Some(why);
                    return;
                }
                let condition = programs
                    .and_then(|programs| programs.first())
                    .and_then(|segments| segments.first())
                    .and_then(|(_, commands)| {
                        commands.iter().find_map(|command| match command {
                            Command::WaitForInput { condition, .. } => Some(*condition),
                            _ => None,
                        })
                    })
                    .unwrap_or(InputCondition::Falling);
                let (idle, fire) = trigger_levels(condition);
                // The trigger drive's slot follows the units'.
                let trigger_slot = self.config.units.len();
                let set = |unit: usize, level| {
                    ask(
                        unit,
                        Command::SetOutput { output, level },
                        Check::NotRefused,
                    )
                };
                // The wire at its idle level while the trigger drive runs nothing.
                stages.push(vec![Lane::of([set(trigger_slot, idle)])]);
                stages.push(load);
                // Every other drive started: each waits at its `WI`.
                stages.push(self.by_line(|unit| {
                    if Some(unit) == trigger_unit {
                        Vec::new()
                    } else {
                        vec![start(unit)]
                    }
                }));
                // The edge: the trigger ball's own program sets it, or the bridge.
                stages.push(vec![match trigger_unit {
                    Some(unit) => Lane::of([start(unit), Action::Started]),
                    None => Lane::of([
                        set(trigger_slot, fire),
                        Action::Started,
                        Action::Sleep(TRIGGER_PULSE_US),
                        set(trigger_slot, idle),
                    ]),
                }]);
            }
        }
        // The show plays: each line tops up its streaming drives' buffers.
        let mut playing = vec![Lane::of([Action::ShowEnd])];
        for gateway in 0..self.config.gateways {
            let units: Vec<usize> = (0..self.config.units.len())
                .filter(|&unit| {
                    self.config.units[unit].gateway == gateway
                        && self.streams.get(unit).is_some_and(|s| !s.is_empty())
                })
                .collect();
            if !units.is_empty() {
                playing.push(Lane::of([Action::Refill { units }]));
            }
        }
        stages.push(playing);
        let ended = Lane::of(
            (0..self.config.units.len()).map(|unit| ask(unit, Command::StatusCode, Check::Ended)),
        );
        stages.push(vec![ended]);
        self.begin_stages(now_us, stages);
    }

    fn poll(&mut self, now_us: u64, _entry: Option<&mut SclEntry>) -> Phase {
        self.now_us = self.now_us.max(now_us);
        let done = self.advance(now_us);
        if let Some(why) = self.failure.take() {
            self.stages.clear();
            self.moving_to = None;
            return Phase::Failed(why);
        }
        if done {
            self.loading = false;
            if let Some(targets) = self.moving_to.take() {
                self.believed_counts = Some(targets);
            }
            Phase::Done { at_us: now_us }
        } else {
            Phase::Pending
        }
    }

    fn show_start_us(&self) -> Option<u64> {
        self.started_us.filter(|_| self.playing)
    }

    fn progress(&self) -> f64 {
        if self.loading {
            return self.loaded as f64 / self.config.units.len().max(1) as f64;
        }
        0.0
    }

    fn stop(&mut self) {
        self.stages.clear();
        self.streams.clear();
        self.asks.clear();
        self.failure = None;
        self.playing = false;
        self.loading = false;
        self.started_us = None;
        self.before_next_move.kill = false;
        self.live = None;
        self.believed_counts = None;
        self.moving_to = None;
        self.ending = false;
    }

    /// A locate: what was queued is dropped, and the next move begins with `SK` to
    /// every drive (their programs end, their motion stops at `DE`); the drives keep
    /// their positions, and the move's `FP` takes them on from there.
    fn interrupt(&mut self, _now_us: u64) -> bool {
        self.stop();
        self.before_next_move.kill = true;
        true
    }

    fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        let sleeping = self
            .stages
            .front()
            .into_iter()
            .flatten()
            .filter_map(|lane| lane.sleeping_until_us)
            .min();
        // While playing, the status counts the show's time: a poll every 20 ms.
        let counting = (self.playing && self.started_us.is_some()).then_some(now_us + WAIT_POLL_US);
        match (sleeping, counting) {
            (Some(a), Some(b)) => Some(a.min(b).max(now_us)),
            (a, b) => a.or(b).map(|at| at.max(now_us)),
        }
    }
}

#[cfg(test)]
mod tests;
