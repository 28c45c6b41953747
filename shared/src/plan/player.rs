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
//!   rule of [`schedule`]; repeat `cycles` times; next entry; after the last, stop or
//!   start over (loop).
//! - **E-stop** sends the configured stop ahead of everything on every gateway, drops
//!   what is queued, and stops; the next Start homes first and begins at the first
//!   entry — it never resumes mid-show.
//! - **Reset** stops the same way, homes every ball and restarts the playlist.
//! - A unit's error report, a link that goes down, or a ball that does not arrive stops
//!   the matrix and says what happened, in words.

use std::collections::HashMap;

use super::report::report_for;
use super::schedule::{self, ROUND_ROWS};
use super::stream::{self, WATERMARK_ROWS};
use super::{Installation, Plan, PlanOptions, RunMode};
use crate::api::{PlayerState, Status};
use crate::ascii::Batch;
use crate::feedback::{Ack, Feedback, Frame, Notification};
use crate::line::Line;
use crate::motion::Trapezoid;
use crate::show::Show;

/// How long after a bulk queue falls below [`REFILL_LOW_BYTES`] the next round may be
/// queued: the player keeps every link's queue shallow so an e-stop has little to drop
/// and refills follow the show's time closely.
pub const REFILL_LOW_BYTES: usize = 256;

/// How often the player wants to be polled while something is under way, µs.
pub const TICK_US: u64 = 10_000;

/// Time allowed for answers to position queries before asking again, µs (at least;
/// more on a slow line).
const CONFIRM_WAIT_US: u64 = 500_000;

/// When the balls' positions were unknown, the first question comes this soon.
const FIRST_QUERY_UNKNOWN_US: u64 = 300_000;

/// How long after the modelled arrival a ball may still not be there, µs.
const ARRIVAL_GRACE_US: u64 = 10_000_000;

/// Time after the last row for the last ball to settle, µs.
const END_MARGIN_US: u64 = 200_000;

/// Slack added to modelled move times, µs.
const MOVE_MARGIN_US: u64 = 50_000;

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
    /// Write `batch` on `gateway` ahead of its queued bulk (the synchronised start).
    Priority {
        /// The gateway.
        gateway: usize,
        /// The instructions.
        batch: Batch,
    },
    /// Stop the whole matrix now, through the caller's one e-stop path (every
    /// gateway's configured stop, ahead of everything, queued work dropped). The player
    /// asks for it when it fails on its own (a unit's error, a lost link, a ball that
    /// does not arrive); an operator's e-stop is sent by the caller, who then tells the
    /// player with [`Player::estop`].
    Estop,
}

/// A playlist planned and checked, ready to start: the slow part of Start, which the
/// caller may run away from the player (it needs only the installation).
#[derive(Debug, Clone)]
pub struct Prepared {
    plans: Vec<Plan>,
    entries: Vec<Entry>,
    loop_playlist: bool,
}

/// Plans every entry of a playlist for `installation`, refusing an invalid or
/// infeasible show (or a gateway that is not connected) before anything moves.
///
/// # Errors
/// [`StartError`] naming the entry and the reason.
pub fn prepare(
    installation: &Installation,
    entries: Vec<Entry>,
    loop_playlist: bool,
    links: &[LinkView],
) -> Result<Prepared, StartError> {
    if entries.is_empty() {
        return Err(StartError::Empty);
    }
    check_links(installation, links)?;
    let options = PlanOptions {
        repeat_forever: loop_playlist && entries.len() == 1,
    };
    let mut plans = Vec::with_capacity(entries.len());
    for (index, entry) in entries.iter().enumerate() {
        let plan =
            Plan::new(&entry.show, installation, options).map_err(|error| StartError::Invalid {
                entry: index + 1,
                show: entry.show.name.clone(),
                reason: error.to_string(),
            })?;
        let report = report_for(&plan, installation);
        if !report.feasible {
            return Err(StartError::Infeasible {
                entry: index + 1,
                show: entry.show.name.clone(),
                reason: report.reason.unwrap_or_default(),
                fixes: report.fixes,
            });
        }
        plans.push(plan);
    }
    Ok(Prepared {
        plans,
        entries,
        loop_playlist,
    })
}

fn check_links(installation: &Installation, links: &[LinkView]) -> Result<(), StartError> {
    for gateway in 0..installation.gateways.len() {
        if !links.get(gateway).is_some_and(|link| link.up) {
            return Err(StartError::NotConnected { gateway });
        }
    }
    Ok(())
}

/// Why Start (or Reset) was refused. Nothing moved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StartError {
    /// The playlist has no entries.
    #[error("the playlist is empty: add a show first")]
    Empty,
    /// A show cannot be planned (invalid, wrong layout…).
    #[error("entry {entry} (\"{show}\") cannot run: {reason}")]
    Invalid {
        /// 1-based entry number.
        entry: usize,
        /// The show's name.
        show: String,
        /// Why.
        reason: String,
    },
    /// A show is valid but the lines cannot carry it.
    #[error("entry {entry} (\"{show}\") cannot run: {reason}")]
    Infeasible {
        /// 1-based entry number.
        entry: usize,
        /// The show's name.
        show: String,
        /// Why, with the numbers.
        reason: String,
        /// What would make it run.
        fixes: Vec<String>,
    },
    /// A gateway is not connected.
    #[error("gateway {gateway} is not connected")]
    NotConnected {
        /// The gateway.
        gateway: usize,
    },
    /// The matrix is already playing (press E-stop or Reset first).
    #[error("the matrix is already running a playlist")]
    Busy,
    /// The E-stop was pressed after this request was made: the request is void and
    /// the matrix stays stopped.
    #[error("the E-stop was pressed after this request was made; the matrix stays stopped")]
    Superseded,
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
    plans: Vec<Plan>,
    entries: Vec<Entry>,
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
        Status {
            state,
            entry: plan.map(|_| self.entry),
            show: plan.map(|plan| plan.show.clone()),
            show_time_ms: if plan.is_some() { self.show_time_ms } else { 0 },
            show_duration_ms: plan.map_or(0, |plan| plan.duration_ms),
            cycle: if plan.is_some() { self.cycle } else { 0 },
            progress: self.progress,
            gateways: Vec::new(),
            last_error: self.last_error.clone(),
        }
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
        self.estop();
        self.step = Step::Stopped;
        let result = prepare(&self.config.installation, entries, loop_playlist, links)
            .and_then(|prepared| self.start_prepared(now_us, prepared, links));
        if let Err(error) = &result {
            self.last_error = Some(error.to_string());
        }
        result
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

    /// When the player next needs to be polled, µs (`None` when idle).
    pub fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        match &self.step {
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
            Step::Idle | Step::Stopped | Step::Failed => {}
        }
    }

    // --------------------------------------------------------------- entries

    fn begin_entry(&mut self, now_us: u64, entry: usize) {
        self.entry = entry;
        self.cycle = 1;
        self.show_time_ms = 0;
        let delay_ms = self.entries.get(entry).map_or(0, |entry| entry.delay_ms);
        if delay_ms > 0 {
            self.step = Step::Waiting {
                until_us: now_us + delay_ms * 1000,
            };
        } else {
            self.begin_approach(now_us);
        }
    }

    fn cycle_done(&mut self, now_us: u64) {
        let Some(plan) = self.plans.get(self.entry) else {
            self.step = Step::Idle;
            return;
        };
        // The balls rest where their tracks end.
        for (position, unit) in self.believed.iter_mut().zip(&plan.units) {
            *position = Some(
                unit.rows
                    .last()
                    .map_or(unit.start_counts, |row| row.position_counts),
            );
        }
        let cycles = self
            .entries
            .get(self.entry)
            .map_or(1, |entry| entry.cycles.max(1));
        if self.cycle < cycles {
            self.cycle += 1;
            self.begin_approach(now_us);
        } else if self.entry + 1 < self.plans.len() {
            self.begin_entry(now_us, self.entry + 1);
        } else if self.loop_playlist {
            self.begin_entry(now_us, 0);
        } else {
            self.step = Step::Idle;
            self.progress = 1.0;
        }
    }

    // ----------------------------------------------------------------- moves

    fn begin_approach(&mut self, now_us: u64) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let targets: Vec<i32> = plan.units.iter().map(|unit| unit.start_counts).collect();
        if self
            .believed
            .iter()
            .zip(&targets)
            .all(|(believed, target)| *believed == Some(*target))
        {
            self.begin_load();
            return;
        }
        self.begin_move(now_us, MoveKind::Approach, targets);
    }

    fn begin_home(&mut self, now_us: u64) {
        let home = self
            .config
            .installation
            .counts(self.config.installation.home_mm)
            .unwrap_or(0);
        let targets = vec![home; self.config.installation.units.len()];
        self.begin_move(now_us, MoveKind::Home, targets);
    }

    fn begin_move(&mut self, now_us: u64, kind: MoveKind, targets: Vec<i32>) {
        let installation = &self.config.installation;
        let speed = installation
            .counts(installation.approach_speed_mm_s)
            .unwrap_or(1)
            .max(1);
        let accel = (installation.limits.max_accel_mm_s2 * installation.counts_per_mm).max(1.0);
        let travel = installation.limits.travel_mm * installation.counts_per_mm;
        let mut move_s: f64 = 0.0;
        for (believed, &target) in self.believed.iter().zip(&targets) {
            // Unknown positions: assume the farthest end of the travel.
            let from = believed.map_or_else(
                || {
                    if f64::from(target) < travel / 2.0 {
                        travel
                    } else {
                        0.0
                    }
                },
                f64::from,
            );
            let trapezoid = Trapezoid::new(from, 0.0, f64::from(target), f64::from(speed), accel);
            move_s = move_s.max(trapezoid.duration_s());
        }
        let mut line_us = 0u64;
        let runs = self.runs_for_move(&targets);
        for (gateway, line, batch) in runs {
            line_us = line_us.max(line.time_us(batch.len()));
            self.commands.push(Command::Bulk { gateway, batch });
        }
        let arrive_us = now_us + line_us + (move_s * 1e6).ceil() as u64 + MOVE_MARGIN_US;
        // Known positions: ask once the model says they are there. Unknown: ask early
        // and again until every ball answers its target.
        let all_known = self.believed.iter().all(Option::is_some);
        let next_query_us = if all_known {
            arrive_us
        } else {
            now_us + line_us + FIRST_QUERY_UNKNOWN_US
        };
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        let unit_count = targets.len();
        self.step = Step::Moving {
            kind,
            targets,
            began_us: now_us,
            arrive_us,
            next_query_us,
            queried: false,
            confirmed: vec![false; unit_count],
        };
        self.progress = 0.0;
    }

    /// The move batches per gateway, with its line: `SP`, every `PA` (one broadcast
    /// when shared), `BG`.
    fn runs_for_move(&self, targets: &[i32]) -> Vec<(usize, Line, Batch)> {
        let installation = &self.config.installation;
        let speed = installation
            .counts(installation.approach_speed_mm_s)
            .unwrap_or(1)
            .max(1);
        installation
            .gateways
            .iter()
            .enumerate()
            .filter_map(|(gateway, spec)| {
                let stations: Vec<(u8, i32)> = installation
                    .units_on(gateway)
                    .map(|unit| (installation.units[unit].station, targets[unit]))
                    .collect();
                (!stations.is_empty()).then(|| {
                    let line = Line::new(spec.baud);
                    (gateway, line, stream::move_to(speed, &stations))
                })
            })
            .collect()
    }

    fn poll_moving(&mut self, now_us: u64) {
        let Step::Moving {
            kind,
            targets,
            began_us,
            arrive_us,
            next_query_us,
            queried,
            confirmed,
        } = &mut self.step
        else {
            return;
        };
        let span = arrive_us.saturating_sub(*began_us).max(1);
        self.progress = (now_us.saturating_sub(*began_us) as f64 / span as f64).min(1.0);
        if confirmed.iter().all(|&done| done) {
            let (kind, targets) = (*kind, std::mem::take(targets));
            self.believed = targets.into_iter().map(Some).collect();
            self.progress = 1.0;
            match kind {
                MoveKind::Approach => self.begin_load(),
                MoveKind::Home => {
                    self.needs_home = false;
                    match self.after_home {
                        AfterHome::Play => self.begin_entry(now_us, 0),
                        AfterHome::Rest => self.step = Step::Idle,
                    }
                }
            }
            return;
        }
        if now_us < *next_query_us {
            return;
        }
        if now_us > *arrive_us + ARRIVAL_GRACE_US {
            let missing: Vec<usize> = confirmed
                .iter()
                .enumerate()
                .filter(|(_, done)| !**done)
                .map(|(unit, _)| unit)
                .collect();
            let count = missing.len();
            let first = missing
                .first()
                .map(|&unit| self.describe_unit(unit))
                .unwrap_or_default();
            self.fail(format!(
                "{count} ball(s) did not reach their position, first {first}; the matrix was stopped"
            ));
            return;
        }
        *queried = true;
        let confirmed = confirmed.clone();
        let installation = &self.config.installation;
        let mut slowest_us = 0;
        for (gateway, spec) in installation.gateways.iter().enumerate() {
            let stations: Vec<u8> = installation
                .units_on(gateway)
                .filter(|&unit| !confirmed[unit])
                .map(|unit| installation.units[unit].station)
                .collect();
            if !stations.is_empty() {
                let batch = stream::where_are(&stations);
                // Questions and answers both cross the line: leave room for them.
                slowest_us = slowest_us.max(3 * Line::new(spec.baud).time_us(batch.len() * 2));
                self.commands.push(Command::Bulk { gateway, batch });
            }
        }
        if let Step::Moving { next_query_us, .. } = &mut self.step {
            *next_query_us = now_us + CONFIRM_WAIT_US.max(slowest_us);
        }
    }

    // --------------------------------------------------------------- loading

    fn begin_load(&mut self) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let runs = plan.gateways.len();
        let reuse = self.loaded_entry == Some(self.entry)
            && plan.gateways.iter().all(|run| run.mode == RunMode::Single);
        let total_rows: usize = plan
            .gateways
            .iter()
            .map(|run| run.preload_rows * run.units.len())
            .sum();
        let next_row = if reuse {
            plan.gateways.iter().map(|run| run.preload_rows).collect()
        } else {
            vec![0; runs]
        };
        self.step = Step::Loading {
            next_row,
            configured: reuse,
            armed: false,
            confirmed: vec![false; runs],
            total_rows,
            loaded_rows: if reuse { total_rows } else { 0 },
        };
        self.show_time_ms = 0;
        self.poll_loading(&[]);
    }

    fn poll_loading(&mut self, links: &[LinkView]) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let Step::Loading {
            next_row,
            configured,
            armed,
            total_rows,
            loaded_rows,
            ..
        } = &mut self.step
        else {
            return;
        };
        let mut commands = Vec::new();
        if !*configured {
            for run in &plan.gateways {
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::configure(plan, run),
                });
            }
            *configured = true;
        }
        let queued = |gateway: usize| {
            links
                .get(gateway)
                .map_or(usize::MAX, |link| link.queued_bytes)
        };
        for (index, run) in plan.gateways.iter().enumerate() {
            let next = &mut next_row[index];
            if *next < run.preload_rows && queued(run.gateway) <= REFILL_LOW_BYTES {
                let to = (*next + ROUND_ROWS).min(run.preload_rows);
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::rows(plan, run, *next, to),
                });
                *loaded_rows += (to - *next) * run.units.len();
                *next = to;
            }
        }
        let all_loaded = plan
            .gateways
            .iter()
            .zip(next_row.iter())
            .all(|(run, &next)| next >= run.preload_rows);
        if all_loaded && !*armed {
            for run in &plan.gateways {
                if let Some(&first) = run.units.first() {
                    commands.push(Command::Bulk {
                        gateway: run.gateway,
                        batch: stream::arm_and_confirm(plan.units[first].address.station),
                    });
                }
            }
            *armed = true;
        }
        self.progress = if *total_rows == 0 {
            1.0
        } else {
            *loaded_rows as f64 / *total_rows as f64
        };
        self.commands.extend(commands);
    }

    fn barrier_answered(&mut self, now_us: u64, gateway: usize, station: u8, value: u16) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let Step::Loading {
            armed: true,
            confirmed,
            ..
        } = &mut self.step
        else {
            return;
        };
        let Some(index) = plan.gateways.iter().position(|run| run.gateway == gateway) else {
            return;
        };
        let run = &plan.gateways[index];
        let Some(&first) = run.units.first() else {
            return;
        };
        if plan.units[first].address.station != station {
            return;
        }
        let expected = match run.mode {
            // FIFO: the water level is the preload.
            RunMode::Fifo => u16::try_from(run.preload_rows).unwrap_or(u16::MAX),
            // Single and loop: the row it will start from.
            RunMode::Single | RunMode::Loop => 0,
        };
        if value != expected {
            let who = self.describe_unit(first);
            self.fail(format!(
                "{who} answered PV with {value} after loading, expected {expected}; the matrix was stopped"
            ));
            return;
        }
        confirmed[index] = true;
        if confirmed.iter().all(|&done| done) {
            self.loaded_entry = Some(self.entry);
            self.begin_play(now_us);
        }
    }

    // --------------------------------------------------------------- playing

    fn begin_play(&mut self, now_us: u64) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let mut start_us = Vec::with_capacity(plan.gateways.len());
        let mut next_row = Vec::with_capacity(plan.gateways.len());
        let begin = stream::begin();
        for run in &plan.gateways {
            start_us.push(now_us + run.line.time_us(begin.len()));
            next_row.push(run.preload_rows);
            self.commands.push(Command::Priority {
                gateway: run.gateway,
                batch: begin.clone(),
            });
        }
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        self.step = Step::Playing { start_us, next_row };
        self.show_time_ms = 0;
        self.progress = 0.0;
    }

    fn poll_playing(&mut self, now_us: u64, links: &[LinkView]) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let Step::Playing { start_us, next_row } = &mut self.step else {
            return;
        };
        let first_start = start_us.first().copied().unwrap_or(now_us);
        let elapsed_us = now_us.saturating_sub(first_start);
        let looping = plan.gateways.iter().all(|run| run.mode == RunMode::Loop);
        let duration_us = plan.duration_ms * 1000;
        self.show_time_ms = if looping && duration_us > 0 {
            (elapsed_us % duration_us) / 1000
        } else {
            (elapsed_us / 1000).min(plan.duration_ms)
        };
        self.progress = if plan.duration_ms == 0 {
            1.0
        } else {
            self.show_time_ms as f64 / plan.duration_ms as f64
        };
        let mut commands = Vec::new();
        for (index, run) in plan.gateways.iter().enumerate() {
            if run.mode != RunMode::Fifo {
                continue;
            }
            let next = &mut next_row[index];
            let total = schedule::longest(plan, run);
            let queued = links
                .get(run.gateway)
                .map_or(usize::MAX, |link| link.queued_bytes);
            if *next >= total || queued > REFILL_LOW_BYTES {
                continue;
            }
            let to = schedule::round_end(run, plan, *next);
            let show_ms = now_us.saturating_sub(start_us[index]) as f64 / 1000.0;
            if schedule::round_room_at_ms(plan, run, to) > show_ms {
                continue;
            }
            let batch = stream::rows(plan, run, *next, to);
            let landing_ms = show_ms + run.line.time_us(queued + batch.len()) as f64 / 1000.0;
            if let Some(level) = schedule::level_at(plan, run, *next, landing_ms) {
                let level = u16::try_from(level.max(0)).unwrap_or(u16::MAX);
                let lowest = &mut self.lowest_level[run.gateway];
                *lowest = Some(lowest.map_or(level, |lowest| lowest.min(level)));
            }
            commands.push(Command::Bulk {
                gateway: run.gateway,
                batch,
            });
            *next = to;
        }
        self.commands.extend(commands);
        if !looping && elapsed_us >= duration_us + END_MARGIN_US {
            self.cycle_done(now_us);
        }
    }
}
