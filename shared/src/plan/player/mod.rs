//! The player: plays a playlist on the matrix as a sans-IO state machine (DESIGN §4–5,
//! PROTOCOL §1.7). The bridge drives it with the time, the links' state and every
//! feedback frame, and carries out the [`Command`]s it returns.
//!
//! - **Start** plans every entry first and refuses an invalid or infeasible show before
//!   anything moves. Then, for each entry: wait `delay_ms`; **approach** (every ball to
//!   its first position point-to-point, for the modelled time, then confirmed by asking
//!   each unit where it is with `PA;`); **load** (configure, preload rows in rounds as
//!   the line drains, arm with `PV=0`, and confirm with a `PV;` query whose answer comes
//!   after everything before it was carried out); **start** every gateway with `*0;BG;`
//!   on its priority lane at once; **refill** streaming gateways round by round, by the
//!   rule of [`schedule`](super::schedule); repeat `cycles` times; next entry; after
//!   the last, stop or start over (loop).
//! - **E-stop** sends the configured stop ahead of everything on every gateway, drops
//!   what is queued, and stops; the next Start homes first and begins at the first
//!   entry — it never resumes mid-show.
//! - **Reset** stops the same way, homes every ball and restarts the playlist.
//! - A unit's error report, a link that goes down, or a ball that does not arrive stops
//!   the matrix and says what happened, in words.
//!
//! The player is split by phase, each an `impl Player` of its own:
//! - this module: the types, the state ([`Player`] and its steps) and the public
//!   interface (Start, E-stop, Reset, Home, feedback, polling);
//! - `prepare`: planning and checking a playlist before anything moves ([`prepare`],
//!   [`StartError`]);
//! - `moving`: the point-to-point moves — the approach to each show's start and homing —
//!   and confirming that every ball arrived;
//! - `loading`: configuring the units, preloading rows and arming them;
//! - `playing`: the synchronised start, refill rounds while a show runs, and moving on
//!   through cycles and entries;
//! - `arming`: loading the first entry's tables while the matrix is idle, so that Start
//!   needs only the approach ([`Player::arm`], [`Player::disarm`]).

mod arming;
mod loading;
mod moving;
mod playing;
mod prepare;

use std::collections::HashMap;
use std::sync::Arc;

use prepare::check_links;
pub use prepare::{Prepared, StartError, prepare};

use super::stream::WATERMARK_ROWS;
use super::{Installation, Plan};
use crate::api::{PlayerState, Status};
use crate::ascii::Batch;
use crate::feedback::{Ack, Feedback, Frame, Notification};
use crate::show::Show;

/// How long after a bulk queue falls below [`REFILL_LOW_BYTES`] the next round may be
/// queued: the player keeps every link's queue shallow so an e-stop has little to drop
/// and refills follow the show's time closely.
pub const REFILL_LOW_BYTES: usize = 256;

/// How long after the player decides to start the start is written on every gateway,
/// µs: time for the caller to hand it to every line — with a hundred gateways, behind
/// the rows queued in the same turn — and for each line to finish what it is writing
/// (the longest instruction at 9,600 baud takes 20.8 ms). A tenth of a second no
/// operator notices.
pub const START_LEAD_US: u64 = 100_000;

/// How often the player wants to be polled while something is under way, µs.
pub const TICK_US: u64 = 10_000;

/// Where a player is in its playlist, as the status shows it: the one place both
/// players (this one and [`super::mbox::MboxPlayer`]) turn it into a [`Status`].
#[derive(Debug, Clone)]
pub(crate) struct PlaylistProgress {
    pub(crate) state: PlayerState,
    /// The entry being played, its show's name and duration, ms; `None` when no
    /// entry is (idle, stopped, homing to rest).
    pub(crate) playing: Option<(usize, String, u64)>,
    pub(crate) show_time_ms: u64,
    pub(crate) cycle: u32,
    pub(crate) progress: f64,
    pub(crate) last_error: Option<String>,
}

impl PlaylistProgress {
    /// The status (the bridge adds the gateways). Homing names no show and no time
    /// (its progress is the homing's own, not the previous show's); the show time is
    /// only counted while a show plays, so no state carries a stale one.
    pub(crate) fn status(self) -> Status {
        let homing = self.state == PlayerState::Homing;
        let current = self.playing.filter(|_| !homing);
        let playing = current.is_some();
        let counting = playing && self.state == PlayerState::Playing;
        let (entry, show, show_duration_ms) = match current {
            Some((entry, show, duration_ms)) => (Some(entry), Some(show), duration_ms),
            None => (None, None, 0),
        };
        Status {
            state: self.state,
            entry,
            show,
            show_time_ms: if counting { self.show_time_ms } else { 0 },
            show_duration_ms,
            cycle: if playing { self.cycle } else { 0 },
            progress: self.progress,
            gateways: Vec::new(),
            last_error: self.last_error,
            armed: None,
            gateway_summary: crate::api::GatewaySummary::default(),
        }
    }
}

/// What follows a show's cycle: another cycle, the next entry, the playlist again, or
/// rest — the same for both players.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NextRun {
    /// The same entry again (`cycle` was counted up).
    Cycle,
    /// This entry from its start.
    Entry(usize),
    /// The playlist is over.
    Rest,
}

/// What follows cycle `cycle` of entry `entry` (of `entries`, each with its cycles).
pub(crate) fn next_run(
    entries: &[impl Cycles],
    entry: usize,
    cycle: &mut u32,
    loop_playlist: bool,
) -> NextRun {
    let cycles = entries.get(entry).map_or(1, |entry| entry.cycles().max(1));
    if *cycle < cycles {
        *cycle += 1;
        NextRun::Cycle
    } else if entry + 1 < entries.len() {
        NextRun::Entry(entry + 1)
    } else if loop_playlist {
        NextRun::Entry(0)
    } else {
        NextRun::Rest
    }
}

/// What the player needs to know about the machine.
#[derive(Debug, Clone)]
pub struct PlayerConfig {
    /// The installation.
    pub installation: Installation,
}

/// One playlist entry, with its show.
#[derive(Debug, Clone)]
pub struct Entry {
    /// The show.
    pub show: Show,
    /// Wait before the entry, ms.
    pub delay_ms: u64,
    /// Plays in a row (at least 1).
    pub cycles: u32,
}

/// When and how often an entry plays: what the player keeps of an [`Entry`] once its
/// show is planned (the plan has the rows; the show's tracks are not kept).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EntryTiming {
    /// Wait before the entry, ms.
    pub delay_ms: u64,
    /// Plays in a row (at least 1).
    pub cycles: u32,
}

impl Entry {
    /// When and how often it plays.
    #[must_use]
    pub fn timing(&self) -> EntryTiming {
        EntryTiming {
            delay_ms: self.delay_ms,
            cycles: self.cycles,
        }
    }
}

/// An entry's cycles, for [`next_run`]: both players' entries have them.
pub(crate) trait Cycles {
    /// Plays in a row.
    fn cycles(&self) -> u32;
}

impl Cycles for Entry {
    fn cycles(&self) -> u32 {
        self.cycles
    }
}

impl Cycles for EntryTiming {
    fn cycles(&self) -> u32 {
        self.cycles
    }
}

/// What the player knows of a link when it is polled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkView {
    /// The link is up.
    pub up: bool,
    /// Bytes waiting on its bulk lane.
    pub queued_bytes: usize,
}

/// What the bridge must do for the player.
#[derive(Debug, Clone, PartialEq)]
pub enum Command {
    /// Queue `batch` on `gateway`'s bulk lane.
    Bulk {
        /// The gateway.
        gateway: usize,
        /// The instructions.
        batch: Batch,
    },
    /// Write `batch` on `gateway` ahead of its queued bulk (the synchronised start),
    /// not before `at_us` on the player's clock: every gateway's start carries the same
    /// instant, [`START_LEAD_US`] after the player decided it, so the caller can keep
    /// each line free for it and write them all at once.
    Priority {
        /// The gateway.
        gateway: usize,
        /// The instructions.
        batch: Batch,
        /// When to write them, µs on the player's clock.
        at_us: u64,
    },
    /// Stop the whole matrix now, through the caller's one e-stop path (every
    /// gateway's configured stop, ahead of everything, queued work dropped). The player
    /// asks for it when it fails on its own (a unit's error, a lost link, a ball that
    /// does not arrive); an operator's e-stop is sent by the caller, who then tells the
    /// player with [`Player::estop`].
    Estop,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum MoveKind {
    Approach,
    Home,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AfterHome {
    /// Start the playlist from its first entry.
    Play,
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
        kind: MoveKind,
        targets: Vec<i32>,
        began_us: u64,
        /// The modelled arrival (the latest, when positions were unknown).
        arrive_us: u64,
        /// When to ask the units where they are next.
        next_query_us: u64,
        /// Whether a question was sent (answers before it are `PA=p;` echoes).
        queried: bool,
        confirmed: Vec<bool>,
    },
    Loading {
        /// Per run: the next row to load.
        next_row: Vec<usize>,
        configured: bool,
        armed: bool,
        /// Per run: the barrier query is answered.
        confirmed: Vec<bool>,
        total_rows: usize,
        loaded_rows: usize,
    },
    Playing {
        /// Per run: when its units began, µs.
        start_us: Vec<u64>,
        /// Per run: the next row to stream.
        next_row: Vec<usize>,
    },
    Stopped,
    Failed,
}

/// The player; see the [module documentation](self).
#[derive(Debug)]
pub struct Player {
    config: PlayerConfig,
    /// (gateway, station) → unit.
    units_by_address: HashMap<(usize, u8), usize>,
    /// Each entry's plan, shared with whoever prepared it (the bridge keeps the armed
    /// playlist's for the next Start).
    plans: Vec<Arc<Plan>>,
    entries: Vec<EntryTiming>,
    loop_playlist: bool,
    entry: usize,
    cycle: u32,
    step: Step,
    after_home: AfterHome,
    needs_home: bool,
    /// Where each ball is when at rest, counts; `None` when unknown.
    believed: Vec<Option<i32>>,
    /// The entry whose rows are in the units' tables (single-sequence mode).
    loaded_entry: Option<usize>,
    lowest_level: Vec<Option<u16>>,
    last_error: Option<String>,
    commands: Vec<Command>,
    show_time_ms: u64,
    progress: f64,
    /// The first entry's tables being loaded while idle (`arming`).
    arming: Option<arming::Arming>,
    /// An arming a Start took over, for entry 0's first load.
    preloaded: Option<arming::Arming>,
    /// Disarms so far ([`Player::disarms`]).
    disarms: u64,
}

impl Player {
    /// A player for the machine in `config`, idle, with the balls' positions unknown
    /// (the first Start homes them).
    pub fn new(config: PlayerConfig) -> Self {
        let units_by_address = config
            .installation
            .units
            .iter()
            .enumerate()
            .map(|(unit, address)| ((address.gateway, address.station), unit))
            .collect();
        let unit_count = config.installation.units.len();
        let gateway_count = config.installation.gateways.len();
        Self {
            config,
            units_by_address,
            plans: Vec::new(),
            entries: Vec::new(),
            loop_playlist: false,
            entry: 0,
            cycle: 0,
            step: Step::Idle,
            after_home: AfterHome::Rest,
            needs_home: true,
            believed: vec![None; unit_count],
            loaded_entry: None,
            lowest_level: vec![None; gateway_count],
            last_error: None,
            commands: Vec::new(),
            show_time_ms: 0,
            progress: 0.0,
            arming: None,
            preloaded: None,
            disarms: 0,
        }
    }

    /// The playlist's state as the status shows it (the bridge adds the links).
    pub fn status(&self) -> Status {
        let state = match &self.step {
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
            Step::Loading { .. } => PlayerState::Loading,
            Step::Playing { .. } => PlayerState::Playing,
            Step::Stopped => PlayerState::Stopped,
            Step::Failed => PlayerState::Error,
        };
        let homing_to_rest = matches!(
            self.step,
            Step::Moving {
                kind: MoveKind::Home,
                ..
            }
        ) && self.after_home == AfterHome::Rest;
        let active = self.is_active() && !homing_to_rest;
        let plan = active.then(|| self.plans.get(self.entry)).flatten();
        let mut status = PlaylistProgress {
            state,
            playing: plan.map(|plan| (self.entry, plan.show.clone(), plan.duration_ms)),
            show_time_ms: self.show_time_ms,
            cycle: self.cycle,
            progress: self.progress,
            last_error: self.last_error.clone(),
        }
        .status();
        status.armed = self.armed();
        status
    }

    /// The lowest FIFO water level of each gateway during the current show (modelled
    /// at each refill, and lowered by watermark notices).
    pub fn lowest_water_levels(&self) -> &[Option<u16>] {
        &self.lowest_level
    }

    /// The commands to carry out now, in order.
    pub fn take_commands(&mut self) -> Vec<Command> {
        std::mem::take(&mut self.commands)
    }

    /// Start: plans every entry (refusing an invalid or infeasible one before anything
    /// moves), homes first if the balls' positions are unknown (after an e-stop), then
    /// plays from the first entry.
    ///
    /// # Errors
    /// [`StartError`]: nothing was changed.
    pub fn start(
        &mut self,
        now_us: u64,
        entries: Vec<Entry>,
        loop_playlist: bool,
        links: &[LinkView],
    ) -> Result<(), StartError> {
        if !self.is_at_rest() {
            return Err(StartError::Busy);
        }
        let prepared = prepare(&self.config.installation, entries, loop_playlist, links)?;
        self.start_prepared(now_us, prepared, links)
    }

    /// Start with a playlist [`prepare`]d already: as [`Player::start`].
    ///
    /// # Errors
    /// [`StartError::Busy`] while a playlist runs, [`StartError::NotConnected`] when a
    /// link went down since it was prepared; nothing was changed.
    pub fn start_prepared(
        &mut self,
        now_us: u64,
        prepared: Prepared,
        links: &[LinkView],
    ) -> Result<(), StartError> {
        if !self.is_at_rest() {
            return Err(StartError::Busy);
        }
        check_links(&self.config.installation, links)?;
        let Prepared {
            plans,
            entries,
            loop_playlist,
        } = prepared;
        self.plans = plans;
        self.entries = entries;
        self.loop_playlist = loop_playlist;
        self.last_error = None;
        self.loaded_entry = None;
        self.lowest_level.iter_mut().for_each(|level| *level = None);
        self.take_arming_for();
        if self.needs_home {
            self.after_home = AfterHome::Play;
            self.begin_home(now_us);
        } else {
            self.begin_entry(now_us, 0);
        }
        Ok(())
    }

    /// Whether nothing runs: a Start may begin.
    fn is_at_rest(&self) -> bool {
        matches!(self.step, Step::Idle | Step::Stopped | Step::Failed)
    }

    /// The e-stop was sent (by the caller, ahead of everything on every gateway): the
    /// player stops, forgets where the balls are, and homes before the next show. A
    /// failure stays a failure (its reason stays visible).
    pub fn estop(&mut self) {
        if !matches!(self.step, Step::Failed) {
            self.step = Step::Stopped;
        }
        self.needs_home = true;
        self.loaded_entry = None;
        self.preloaded = None;
        self.disarm();
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        self.progress = 0.0;
    }

    /// Reset: stop at once, then home every ball and play the playlist from its first
    /// entry. If the playlist cannot start, the matrix stays stopped and the error says
    /// why.
    ///
    /// # Errors
    /// [`StartError`] (the matrix is stopped all the same).
    pub fn reset(
        &mut self,
        now_us: u64,
        entries: Vec<Entry>,
        loop_playlist: bool,
        links: &[LinkView],
    ) -> Result<(), StartError> {
        let prepared = prepare(&self.config.installation, entries, loop_playlist, links);
        self.reset_prepared(now_us, prepared, links)
    }

    /// Reset with a playlist [`prepare`]d already (the caller sent the stop first).
    ///
    /// # Errors
    /// As [`Player::reset`].
    pub fn reset_prepared(
        &mut self,
        now_us: u64,
        prepared: Result<Prepared, StartError>,
        links: &[LinkView],
    ) -> Result<(), StartError> {
        self.estop();
        self.step = Step::Stopped;
        let result = prepared.and_then(|prepared| self.start_prepared(now_us, prepared, links));
        if let Err(error) = &result {
            self.last_error = Some(error.to_string());
        }
        result
    }

    /// Home: stop (the caller sent the stop first), bring every ball to the home
    /// position, and stay idle there.
    ///
    /// # Errors
    /// [`StartError::NotConnected`]: the matrix is stopped, and stays so.
    pub fn home(&mut self, now_us: u64, links: &[LinkView]) -> Result<(), StartError> {
        self.estop();
        self.step = Step::Stopped;
        if let Err(error) = check_links(&self.config.installation, links) {
            self.last_error = Some(error.to_string());
            return Err(error);
        }
        self.last_error = None;
        self.after_home = AfterHome::Rest;
        self.begin_home(now_us);
        Ok(())
    }

    /// A feedback frame from `gateway`.
    pub fn handle_feedback(&mut self, now_us: u64, gateway: usize, frame: &Frame) {
        let Ok(feedback) = Feedback::from_frame(frame) else {
            return;
        };
        let unit = self
            .units_by_address
            .get(&(gateway, frame.station()))
            .copied();
        match feedback {
            Feedback::Error(error) if self.is_active() => {
                let who = match unit {
                    Some(unit) => self.describe_unit(unit),
                    None => format!("gateway {gateway}, station {}", frame.station()),
                };
                self.fail(format!("{who}: {error}"));
            }
            Feedback::Error(error) if self.arming.is_some() => {
                let who = match unit {
                    Some(unit) => self.describe_unit(unit),
                    None => format!("gateway {gateway}, station {}", frame.station()),
                };
                self.arming_refused(who, error);
            }
            Feedback::Notification(Notification::PVT_WATERMARK) => {
                if let Some(level) = self.lowest_level.get_mut(gateway) {
                    let watermark = u16::from(WATERMARK_ROWS);
                    *level = Some(level.map_or(watermark, |level| level.min(watermark)));
                }
            }
            Feedback::Ack(Ack::PtpPosition { position_counts }) => {
                // `PA=p;` itself is acknowledged with its target: only answers to the
                // position queries, sent once the move should be over, confirm it.
                if let (
                    Some(unit),
                    Step::Moving {
                        targets,
                        confirmed,
                        queried: true,
                        ..
                    },
                ) = (unit, &mut self.step)
                    && targets.get(unit) == Some(&position_counts)
                {
                    confirmed[unit] = true;
                }
                self.poll_moving(now_us);
            }
            Feedback::Ack(Ack::PvtStart { value }) => {
                self.barrier_answered(now_us, gateway, frame.station(), value);
            }
            _ => {}
        }
    }

    fn is_active(&self) -> bool {
        matches!(
            self.step,
            Step::Waiting { .. }
                | Step::Moving { .. }
                | Step::Loading { .. }
                | Step::Playing { .. }
        )
    }

    fn describe_unit(&self, unit: usize) -> String {
        let limits = &self.config.installation.limits;
        let cols = limits.cols.max(1) as usize;
        let address = self.config.installation.units[unit];
        format!(
            "ball (row {}, col {}) on gateway {}, station {}",
            unit / cols + 1,
            unit % cols + 1,
            address.gateway,
            address.station
        )
    }

    /// Stops everything with `reason` as the last error: asks the caller for the
    /// e-stop ([`Command::Estop`]) and stays failed until the next Start.
    fn fail(&mut self, reason: String) {
        self.commands.push(Command::Estop);
        self.estop();
        self.step = Step::Failed;
        self.last_error = Some(reason);
    }

    /// Stops with `reason` as the last error, for a fault the caller found (a stalled
    /// link): as a failure of the player's own, the e-stop is asked for.
    pub fn fail_with(&mut self, reason: String) {
        if self.is_active() {
            self.fail(reason);
        }
    }

    /// Whether a playlist (or a homing move) is under way.
    pub fn is_running(&self) -> bool {
        self.is_active()
    }

    /// When the player next needs to be polled, µs (`None` when idle with nothing
    /// being armed).
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        match &self.step {
            Step::Idle if self.arming_under_way() => Some(now_us + TICK_US),
            Step::Idle | Step::Stopped | Step::Failed => None,
            Step::Waiting { until_us } => Some((*until_us).min(now_us + TICK_US)),
            _ => Some(now_us + TICK_US),
        }
    }

    /// Lets time pass: moves on between steps, queues rows, checks the links.
    pub fn poll(&mut self, now_us: u64, links: &[LinkView]) {
        if self.is_active()
            && let Some(gateway) = (0..self.config.installation.gateways.len())
                .find(|&gateway| !links.get(gateway).is_some_and(|link| link.up))
        {
            self.fail(format!(
                "the link to gateway {gateway} was lost; the matrix was stopped"
            ));
            return;
        }
        match self.step {
            Step::Waiting { until_us } => {
                if now_us >= until_us {
                    self.begin_approach(now_us);
                } else {
                    self.progress = 0.0;
                }
            }
            Step::Moving { .. } => self.poll_moving(now_us),
            Step::Loading { .. } => self.poll_loading(links),
            Step::Playing { .. } => self.poll_playing(now_us, links),
            Step::Idle => self.poll_arming(links),
            Step::Stopped | Step::Failed => {}
        }
    }
}
