//! The player: plays a playlist on the matrix as a sans-IO state machine (`docs/architecture.md` §4–5,
//! `docs/uim2503.md` §4). The bridge drives it with the time, the links' state and every
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
//! The playlist's own logic — entries, delays, cycles, loop, approach, load, play,
//! E-stop, Reset, Home, "home first" and the status — is the show sequencer's
//! ([`crate::player::Sequencer`]), the same for every drive family. What is UIM2503's
//! is [`Uim2503Drive`], the sequencer's [`Drive`] here; [`Player`] is the sequencer over
//! it, with the interface the bridge and the tests use. The drive is split by phase,
//! each an `impl` of its own:
//! - this module: the types, the drive's state and its [`Drive`] side, and the
//!   player's public interface (Start, E-stop, Reset, Home, feedback, polling);
//! - `prepare`: planning and checking a playlist before anything moves ([`prepare`],
//!   [`StartError`]);
//! - `moving`: the point-to-point moves — the approach to each show's start and homing —
//!   and confirming that every ball arrived;
//! - `loading`: configuring the units, preloading rows and arming them;
//! - `playing`: the synchronised start and refill rounds while a show runs;
//! - `arming`: loading the first entry's tables while the matrix is idle, so that Start
//!   needs only the approach ([`Player::arm`], [`Player::disarm`]);
//! - [`live`]: live mode's rows streamed into a short FIFO on every unit
//!   ([`crate::player::live`]).

mod arming;
pub mod live;
mod loading;
mod moving;
mod playing;
mod prepare;

use std::collections::HashMap;
use std::sync::Arc;

use prepare::check_links;
pub use prepare::{Prepared, StartError, prepare};

use super::plan::Plan;
use super::stream::WATERMARK_ROWS;
use super::stretch::Stretch;
use crate::api::{ArmedShow, Status};
use crate::plan::Installation;
use crate::player::{Drive, Phase, Run, Sequencer, StartAt};
pub use crate::player::{Entry, EntryTiming, LinkView};
use crate::uim2503::ascii::Batch;
use crate::uim2503::feedback::{Ack, Feedback, Frame, Notification};

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

/// What the player needs to know about the machine.
#[derive(Debug, Clone)]
pub struct PlayerConfig {
    /// The installation.
    pub installation: Installation,
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

/// Where the drive is in the step the sequencer gave it.
#[derive(Debug, Clone)]
enum Step {
    Idle,
    Moving {
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
        /// The clock trim of a timecode chase: the stretch of the rows not yet sent
        /// ([`crate::uim2503::stretch`]); `None`: rows as planned.
        stretch: Option<Stretch>,
        /// The stretch reached by the units at the last poll, ms.
        stretched_ms: f64,
        /// The first trim: when it came, and the show's start it gave, µs.
        first_trim: Option<(u64, i64)>,
    },
}

/// UIM2503 gateways under the show sequencer ([`crate::player`]): the [`Drive`] that
/// turns its steps into each gateway's instruction batches ([`Command`]) and reads the
/// units' feedback — moves confirmed by `PA;`, tables loaded in rounds and confirmed
/// by the `PV;` barrier, the synchronised start, refills while a show streams; and
/// arming while the matrix is idle.
#[derive(Debug)]
pub struct Uim2503Drive {
    config: PlayerConfig,
    /// (gateway, station) → unit.
    units_by_address: HashMap<(usize, u8), usize>,
    /// The entry the step under way belongs to, and its plan.
    entry: usize,
    plan: Option<Arc<Plan>>,
    step: Step,
    /// Where each ball is when at rest, counts; `None` when unknown.
    believed: Vec<Option<i32>>,
    /// The entry whose rows are in the units' tables (single-sequence mode).
    loaded_entry: Option<usize>,
    lowest_level: Vec<Option<u16>>,
    commands: Vec<Command>,
    progress: f64,
    /// The links as last polled.
    links: Vec<LinkView>,
    /// The first entry's tables being loaded while idle (`arming`).
    arming: Option<arming::Arming>,
    /// An arming a Start took over, for entry 0's first load.
    preloaded: Option<arming::Arming>,
    /// Disarms so far ([`Player::disarms`]).
    disarms: u64,
    /// Live mode's rows on the units, while live.
    live: Option<live::LiveStream>,
    /// The positions asked after live mode, until every unit answered.
    after_live: Option<live::AfterLive>,
}

impl Uim2503Drive {
    /// The drive for the machine in `config`, idle, the balls' positions unknown.
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
            entry: 0,
            plan: None,
            step: Step::Idle,
            believed: vec![None; unit_count],
            loaded_entry: None,
            lowest_level: vec![None; gateway_count],
            commands: Vec::new(),
            progress: 0.0,
            links: Vec::new(),
            arming: None,
            preloaded: None,
            disarms: 0,
            live: None,
            after_live: None,
        }
    }

    /// The links as they are now, for the next poll (each gateway's state and queued
    /// bytes: the load and refill rounds follow the lines' draining).
    pub fn set_links(&mut self, links: &[LinkView]) {
        self.links.clear();
        self.links.extend_from_slice(links);
    }

    /// The batches to queue now, in order ([`Command::Bulk`] and
    /// [`Command::Priority`]; the e-stop is the sequencer's, [`Sequencer::take_estop`]).
    pub fn take_commands(&mut self) -> Vec<Command> {
        std::mem::take(&mut self.commands)
    }

    /// The lowest FIFO water level of each gateway during the current show (modelled
    /// at each refill, and lowered by watermark notices).
    pub fn lowest_water_levels(&self) -> &[Option<u16>] {
        &self.lowest_level
    }

    /// A feedback frame from `gateway`, for the drive under `sequencer`: a unit's
    /// error fails the run (or drops an arming), a watermark notice lowers the water
    /// level, a position answer confirms a move (or, after live mode, says where a
    /// unit stopped), a `PV;` answer the load's barrier (while live, a water level
    /// that fails live mode when the unit stopped taking rows).
    pub fn handle_feedback(
        sequencer: &mut Sequencer<Self>,
        now_us: u64,
        gateway: usize,
        frame: &Frame,
    ) {
        let Ok(feedback) = Feedback::from_frame(frame) else {
            return;
        };
        let running = sequencer.is_running();
        let drive = sequencer.drive_mut();
        let unit = drive
            .units_by_address
            .get(&(gateway, frame.station()))
            .copied();
        let who = |drive: &Uim2503Drive| match unit {
            Some(unit) => drive.describe_unit(unit),
            None => format!("gateway {gateway}, station {}", frame.station()),
        };
        match feedback {
            Feedback::Error(error) if running => {
                let reason = format!("{}: {error}", who(drive));
                sequencer.fail(reason);
            }
            Feedback::Error(error) if drive.arming.is_some() => {
                let who = who(drive);
                if let Some(note) = drive.arming_refused(who, error) {
                    sequencer.set_last_error(Some(note));
                }
            }
            Feedback::Notification(Notification::PVT_WATERMARK) => {
                if let Some(level) = drive.lowest_level.get_mut(gateway) {
                    let watermark = u16::from(WATERMARK_ROWS);
                    *level = Some(level.map_or(watermark, |level| level.min(watermark)));
                }
            }
            Feedback::Ack(Ack::PtpPosition { position_counts }) if drive.after_live_under_way() => {
                // Only questions are sent after live mode: each answer is a position.
                if let Some(unit) = unit
                    && let Some(note) = drive.after_live_answered(unit, position_counts)
                {
                    sequencer.set_last_error(Some(note));
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
                ) = (unit, &mut drive.step)
                    && targets.get(unit) == Some(&position_counts)
                {
                    confirmed[unit] = true;
                }
                let phase = drive.poll_moving(now_us);
                sequencer.advance(phase);
            }
            Feedback::Ack(Ack::PvtStart { value }) if drive.live.is_some() => {
                if let Some(reason) = drive.live_ran_dry(gateway, frame.station(), value) {
                    sequencer.fail(reason);
                } else {
                    let phase =
                        drive.live_barrier_answered(now_us, gateway, frame.station(), value);
                    sequencer.advance(phase);
                }
            }
            Feedback::Ack(Ack::PvtStart { value }) => {
                let phase = drive.barrier_answered(now_us, gateway, frame.station(), value);
                sequencer.advance(phase);
            }
            _ => {}
        }
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
}

impl Drive for Uim2503Drive {
    type Entry = Arc<Plan>;

    fn live_setup(&self) -> Result<crate::player::LiveSetup, StartError> {
        self.live_setup_uim()
    }

    fn rest_positions_mm(&self) -> Option<Vec<f64>> {
        self.rest_mm()
    }

    fn begin_live(&mut self, _now_us: u64, states: &[crate::live::filter::BallState]) -> bool {
        self.begin_live_stream(states)
    }

    fn live_step(&mut self, _slot_us: u64, states: &[crate::live::filter::BallState]) {
        self.live_rows(states);
    }

    fn end_live(&mut self, at_us: u64, states: &[crate::live::filter::BallState]) {
        self.end_live_stream(at_us, states);
    }

    fn begin_run(&mut self, _now_us: u64, first: Option<&mut Arc<Plan>>) {
        if let Some(first) = first {
            self.loaded_entry = None;
            self.lowest_level.iter_mut().for_each(|level| *level = None);
            self.take_arming_for(first);
        }
    }

    fn begin_home(&mut self, now_us: u64) {
        self.begin_home_move(now_us);
    }

    fn begin_approach(&mut self, now_us: u64, plan: &mut Arc<Plan>) -> bool {
        self.plan = Some(Arc::clone(plan));
        self.begin_approach_move(now_us, plan)
    }

    fn begin_load(
        &mut self,
        _now_us: u64,
        index: usize,
        plan: &mut Arc<Plan>,
        _cycle: u32,
    ) -> bool {
        self.entry = index;
        self.plan = Some(Arc::clone(plan));
        self.begin_loading();
        true
    }

    fn begin_play(&mut self, now_us: u64, plan: &mut Arc<Plan>, _last: bool) {
        self.plan = Some(Arc::clone(plan));
        self.begin_playing(now_us);
    }

    fn poll(&mut self, now_us: u64, _entry: Option<&mut Arc<Plan>>) -> Phase {
        let links = std::mem::take(&mut self.links);
        let phase = match self.step {
            Step::Moving { .. } => self.poll_moving(now_us),
            Step::Loading { .. } => {
                self.poll_loading(&links);
                Phase::Pending
            }
            Step::Playing { .. } => self.poll_playing(now_us, &links),
            Step::Idle => Phase::Pending,
        };
        self.links = links;
        phase
    }

    fn fault(&mut self) -> Option<String> {
        (0..self.config.installation.gateways.len())
            .find(|&gateway| !self.links.get(gateway).is_some_and(|link| link.up))
            .map(|gateway| {
                format!("the link to gateway {gateway} was lost; the matrix was stopped")
            })
    }

    fn waiting_wakeup_us(&self, now_us: u64) -> Option<u64> {
        Some(now_us + TICK_US)
    }

    fn progress(&self) -> f64 {
        self.progress
    }

    fn show_start_us(&self) -> Option<u64> {
        match &self.step {
            // Every gateway's units begin once `*0;BG;` is through their line; the
            // first gateway's are the show's clock (as for the show's end).
            Step::Playing {
                start_us,
                stretched_ms,
                ..
            } => start_us.first().map(|&start_us| {
                start_us.saturating_add_signed((stretched_ms * 1_000.0).round() as i64)
            }),
            _ => None,
        }
    }

    fn trim_clock(&mut self, now_us: u64, show_start_us: i64) {
        self.trim_playing(now_us, show_start_us);
    }

    fn show_repeats(&self) -> bool {
        matches!(self.step, Step::Playing { .. })
            && self.plan.as_ref().is_some_and(|plan| {
                plan.gateways
                    .iter()
                    .all(|run| run.mode == crate::uim2503::plan::RunMode::Loop)
            })
    }

    fn stop(&mut self) {
        self.step = Step::Idle;
        self.live = None;
        self.after_live = None;
        self.loaded_entry = None;
        self.preloaded = None;
        self.disarm_tables();
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        self.progress = 0.0;
    }

    /// A locate: what was queued is dropped and the positions are unknown (the balls
    /// stop wherever the show had them); the next move's `PA=…;BG;` ends the PVT
    /// motion on every unit ("another mode", `docs/uim2503.md` §3) and takes each ball on
    /// from where it is, asked for until it arrives.
    fn interrupt(&mut self, _now_us: u64) -> bool {
        self.stop();
        true
    }

    fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        Some(now_us + TICK_US)
    }

    fn arm(&mut self, first: &Arc<Plan>, disarms: u64) -> bool {
        self.arm_plan(first, disarms)
    }

    fn disarm(&mut self) {
        self.disarm_tables();
    }

    fn disarms(&self) -> u64 {
        self.disarms
    }

    fn armed(&self) -> Option<ArmedShow> {
        self.armed_show()
    }

    fn idle_wakeup_us(&self, now_us: u64) -> Option<u64> {
        (self.arming_under_way() || self.after_live_under_way()).then_some(now_us + TICK_US)
    }

    fn poll_idle(&mut self, now_us: u64) {
        let links = std::mem::take(&mut self.links);
        self.poll_arming(&links);
        self.links = links;
        self.poll_after_live(now_us);
    }
}

/// The player: the show sequencer over the UIM2503 drive; see the [module
/// documentation](self).
#[derive(Debug)]
pub struct Player {
    sequencer: Sequencer<Uim2503Drive>,
}

/// The playlist as the sequencer runs it: each entry's plan with its timing, and
/// whether it loops.
pub fn runs(prepared: Prepared) -> (Vec<Run<Arc<Plan>>>, bool) {
    let Prepared {
        plans,
        entries,
        loop_playlist,
    } = prepared;
    let runs = plans
        .into_iter()
        .zip(entries)
        .map(|(plan, timing)| Run {
            name: plan.show.clone(),
            duration_ms: plan.duration_ms,
            timing,
            prepared: plan,
        })
        .collect();
    (runs, loop_playlist)
}

impl Player {
    /// A player for the machine in `config`, idle, with the balls' positions unknown
    /// (the first Start homes them).
    pub fn new(config: PlayerConfig) -> Self {
        Self {
            sequencer: Sequencer::new(Uim2503Drive::new(config)),
        }
    }

    fn drive(&self) -> &Uim2503Drive {
        self.sequencer.drive()
    }

    fn drive_mut(&mut self) -> &mut Uim2503Drive {
        self.sequencer.drive_mut()
    }

    fn installation(&self) -> &Installation {
        &self.drive().config.installation
    }

    /// The playlist's state as the status shows it (the bridge adds the links).
    pub fn status(&self) -> Status {
        self.sequencer.status()
    }

    /// The lowest FIFO water level of each gateway during the current show (modelled
    /// at each refill, and lowered by watermark notices).
    pub fn lowest_water_levels(&self) -> &[Option<u16>] {
        self.drive().lowest_water_levels()
    }

    /// The commands to carry out now, in order; [`Command::Estop`] last when the
    /// player stopped on its own.
    pub fn take_commands(&mut self) -> Vec<Command> {
        let mut commands = self.drive_mut().take_commands();
        if self.sequencer.take_estop() {
            commands.push(Command::Estop);
        }
        commands
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
        if self.sequencer.is_running() {
            return Err(StartError::Busy);
        }
        let prepared = prepare(self.installation(), entries, loop_playlist, links)?;
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
        if self.sequencer.is_running() {
            return Err(StartError::Busy);
        }
        check_links(self.installation(), links)?;
        let (runs, loop_playlist) = runs(prepared);
        self.sequencer.start(now_us, runs, loop_playlist)
    }

    /// Start at entry `entry` (0-based) of a playlist [`prepare`]d already, from a time
    /// inside its show with `lead`: the show's time at the cut's start and the cut
    /// prepared as a one-entry playlist ([`crate::show::Show::from_time`],
    /// [`Sequencer::start_at`]).
    ///
    /// # Errors
    /// As [`Player::start_prepared`], and [`Sequencer::start_at`]'s refusals.
    pub fn start_prepared_at(
        &mut self,
        now_us: u64,
        prepared: Prepared,
        (entry, lead): (usize, Option<(u64, Prepared)>),
        links: &[LinkView],
    ) -> Result<(), StartError> {
        if self.sequencer.is_running() {
            return Err(StartError::Busy);
        }
        check_links(self.installation(), links)?;
        let (entries, loop_playlist) = runs(prepared);
        let lead = lead.and_then(|(from_ms, cut)| {
            let plan = runs(cut).0.into_iter().next()?.prepared;
            Some(crate::player::Lead {
                from_ms,
                prepared: plan,
            })
        });
        let at = crate::player::StartAt { entry, lead };
        self.sequencer.start_at(now_us, entries, loop_playlist, at)
    }

    /// A timecode chase's clock trim: entry `entry`'s (0-based) show has its time 0 at
    /// `show_start_us` ([`Drive::trim_clock`]: streamed rows not yet sent absorb at
    /// most ±1 ms each).
    pub fn trim_clock(&mut self, now_us: u64, entry: usize, show_start_us: i64) {
        self.sequencer.trim_clock(now_us, entry, show_start_us);
    }

    /// The e-stop was sent (by the caller, ahead of everything on every gateway): the
    /// player stops, forgets where the balls are, and homes before the next show. A
    /// failure stays a failure (its reason stays visible).
    pub fn estop(&mut self) {
        self.sequencer.estop();
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
        let prepared = prepare(self.installation(), entries, loop_playlist, links);
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
        let checked = prepared.and_then(|prepared| {
            check_links(self.installation(), links)?;
            Ok(runs(prepared))
        });
        let loop_playlist = checked.as_ref().is_ok_and(|(_, looping)| *looping);
        self.sequencer
            .reset(now_us, checked.map(|(runs, _)| runs), loop_playlist)
    }

    /// A locate to entry `entry` (0-based) from its start: the show under way ends
    /// without an e-stop ([`Sequencer::locate_at`]) and every ball goes from where it
    /// is to the entry's start, then plays.
    ///
    /// # Errors
    /// Why the playlist cannot run (nothing changed: a show under way plays on).
    pub fn locate(
        &mut self,
        now_us: u64,
        entries: Vec<Entry>,
        loop_playlist: bool,
        entry: usize,
        links: &[LinkView],
    ) -> Result<(), StartError> {
        let prepared = prepare(self.installation(), entries, loop_playlist, links);
        let checked = prepared.and_then(|prepared| {
            check_links(self.installation(), links)?;
            Ok(runs(prepared))
        });
        let loop_playlist = checked.as_ref().is_ok_and(|(_, looping)| *looping);
        let at = StartAt { entry, lead: None };
        self.sequencer
            .locate_at(now_us, checked.map(|(runs, _)| (runs, at)), loop_playlist)
    }

    /// Home: stop (the caller sent the stop first), bring every ball to the home
    /// position, and stay idle.
    ///
    /// # Errors
    /// [`StartError::NotConnected`]: the matrix is stopped, and stays so.
    pub fn home(&mut self, now_us: u64, links: &[LinkView]) -> Result<(), StartError> {
        if let Err(error) = check_links(self.installation(), links) {
            self.sequencer.stop_with(Some(error.to_string()));
            return Err(error);
        }
        self.sequencer.home(now_us);
        Ok(())
    }

    /// A feedback frame from `gateway`.
    pub fn handle_feedback(&mut self, now_us: u64, gateway: usize, frame: &Frame) {
        Uim2503Drive::handle_feedback(&mut self.sequencer, now_us, gateway, frame);
    }

    /// Stops with `reason` as the last error, for a fault the caller found (a stalled
    /// link): as a failure of the player's own, the e-stop is asked for.
    pub fn fail_with(&mut self, reason: String) {
        self.sequencer.fail(reason);
    }

    /// Whether a playlist (or a homing move) is under way.
    pub fn is_running(&self) -> bool {
        self.sequencer.is_running()
    }

    /// When the player next needs to be polled, µs (`None` when idle with nothing
    /// being armed).
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        self.sequencer.next_wakeup_us(now_us)
    }

    /// Lets time pass: moves on between steps, queues rows, checks the links.
    pub fn poll(&mut self, now_us: u64, links: &[LinkView]) {
        self.sequencer.drive_mut().set_links(links);
        self.sequencer.poll(now_us);
    }

    /// The sequencer under the player: live mode ([`Sequencer::go_live`],
    /// [`Sequencer::set_live_input`], [`Sequencer::leave_live`], the recording); its
    /// rows come out of [`Player::take_commands`] as a show's do.
    pub fn sequencer_mut(&mut self) -> &mut Sequencer<Uim2503Drive> {
        &mut self.sequencer
    }

    /// The sequencer under the player, to read.
    pub fn sequencer(&self) -> &Sequencer<Uim2503Drive> {
        &self.sequencer
    }
}
