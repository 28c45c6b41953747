//! Live mode on MOONS' drives ([`crate::player::live`]) **by jogging**: a feed to
//! position (`FP`) sent while a drive moves waits for the move under way, so each
//! update would start from rest; a jog whose speed is changed (`CS`) continues the
//! motion. Every jog command is **unconfirmed** against a real drive's reference
//! (`docs/protocol-notes.md` §8, "Jogging"): this follows the twin ([`crate::scl::twin`]),
//! as the Q-program compiler's jogged stretches do.
//!
//! - **Prepare** (after the sequencer homed when the positions were unknown): `JS`
//!   at its smallest, `JA` and `JL` (the jog's ramps) at the installation's
//!   acceleration, and `VE AC DE` for the last exact feed, to every drive — in the
//!   drive's steps, never above (`at_most`).
//! - **Each period** the sequencer hands every ball's filtered state for the period's
//!   end (the approach too: the filter's steps at the approach speed). Each drive is
//!   told a speed for the step it runs next: `CS` while it jogs that way (sent only when the held speed
//!   changes); from rest `CJ CS` (`DI±1` first when the direction changes: `CJ`
//!   starts at once at the `JS` the drive has, never above the top speed, and the
//!   speed follows in the next request); when the filtered velocity turns round
//!   `SJ DI∓1 CJ CS` (the `CJ` waits for the stop); at rest `SJ`. The drive's own ramp
//!   (`JA`/`JL`) keeps the acceleration within the limits, and no speed asked is above
//!   the top speed.
//! - **The speed**: the drive keeps a model of each drive — the twin's own
//!   profiles ([`Profile`]) for the requests it took, when they reached it, shifted
//!   to the last position it read (`IP`, one drive per line per period,
//!   round-robin). The speed asked is the step's speed one period after the request
//!   reaches the drive (after what its lane has queued), plus a correction of how far
//!   the model says the drive would then be from the step: spread over two
//!   periods, at most the speed headroom, and no more than the drive's spare
//!   acceleration can take back (so it catches up without overshooting).
//! - **One period behind**: the drives run each period's filter step during the next
//!   period ([`LIVE_DELAY_PERIODS`]), while that period's requests go out on the
//!   line, so a drive's speed changes in time for the step it is for; the latency is
//!   three periods (up to one waiting for the slot, the step, the delay).
//! - **Headroom**: the filter runs at [`FOLLOW_SPEED_SHARE`] of the top speed and
//!   [`FOLLOW_ACCEL_SHARE`] of the top acceleration, as the drive holds them: a drive
//!   whose request arrives late (the line's requests go one after the other) ramps a
//!   little harder than the filter and catches up.
//! - **The period** is what the line carries ([`SclDrive::live_period_us`]): on RS-485
//!   one request at a time, each answered — every drive's `CS`, one `IP` and room for
//!   three more exchanges (a start from rest, `DI JS CJ`) per period, each exchange
//!   with [`TURNAROUND_US`] more; a drive jogging turns round by the sign of its `CS`
//!   (HCR p. 71), and a `CS` waits for the jog it changes;
//!   over eSCL each drive has its own datagrams. At least [`LIVE_PERIOD_MIN_MS`]; a
//!   line that needs more than [`LIVE_PERIOD_MAX_MS`] is refused
//!   ([`StartError::LiveLineTooSlow`]). When the line is late, a speed not yet sent is
//!   replaced by the newer one (the queue stays short).
//! - **End**: after the balls rest, each drive gets `DI` at the exact count and `FP`
//!   (after the `SJ`'s stop), then `IP` until it is there; that runs on while the
//!   matrix is idle, and a step begun meanwhile runs after it. The positions are known.
//! - **E-stop**: the port's `SK` stops every drive (at `DE`); everything queued is
//!   dropped and the positions are unknown ([`super::SclDrive`]'s `stop`).

use super::{
    Action, Check, Command, Lane, SclDrive, Stage, ask, asks_enabled_first, at_most, feed_settings,
};
use crate::line::Line;
use crate::live::filter::{BallState, FilterLimits};
use crate::player::{LiveSetup, StartError};
use crate::scl::twin::Profile;
use crate::scl::units;
use crate::show::Layout;

/// Periods the drives run the filtered motion later than the filter: a period's
/// requests go out on the line while the drives run the period before.
pub const LIVE_DELAY_PERIODS: u64 = 1;

/// The shortest live period, ms.
pub const LIVE_PERIOD_MIN_MS: u32 = 10;

/// The longest live period a line may need, ms (as UIM2503's longest row).
pub const LIVE_PERIOD_MAX_MS: u32 = 255;

/// Counted for each exchange on a line besides its bytes, µs: the drive's answer
/// delay and the bridge's turn (assumed; no figure of a real drive was read).
pub const TURNAROUND_US: u64 = 1_000;

/// The share of the catch-up speed a drive's spare acceleration could take back
/// exactly (what the periods' steps leave as margin).
pub const CATCH_UP_SHARE: f64 = 0.7;

/// At rest, the filter too, a drive its model puts farther than this from the
/// filtered position is fed there (`DI` at the exact count, `FP`), counts: jogging
/// has no hold on position, so a stop that came late (the bridge stalled under load
/// while the drive ramped down) would otherwise leave the ball off until it moves
/// again, and the jog runs [`END_MARGIN_MM`] inside the ends. Half a count: every
/// drive at rest stands on its exact count (until 47 it was 1 mm, and balls rested up
/// to 0.17 mm past the end of the travel).
pub const REST_TOLERANCE_COUNTS: f64 = 0.5;

/// How far inside either end of the travel the drives jog, mm: the filtered motion is
/// squeezed into the travel less this at each end ([`inside`]: positions and speeds
/// scaled by `(travel − 2·margin)/travel`, so the limits still hold), and a drive that
/// comes to rest is fed to the exact count of the unsqueezed position
/// ([`REST_TOLERANCE_COUNTS`]). A jog has no hold on position: a speed or a stop that
/// reaches a drive late (the line's requests go one after the other, a loaded host
/// wakes late) carries it on past where the filter stopped — up to 0.17 mm was seen
/// through the bridge on a 1000 mm travel at 500 mm/s on a quiet host, 0.9 mm with both
/// cores of a 2-core host busy compiling — and at an end that would be past the
/// travel. The margin covers twice the worst seen; a stall of the bridge longer than
/// that while a drive runs towards an end is not covered (its rest feed brings it
/// back).
pub const END_MARGIN_MM: f64 = 2.0;

/// One eSCL exchange (a datagram and its answer on the network), µs (assumed).
pub const ESCL_EXCHANGE_US: u64 = 1_000;

/// The share of the top speed (as a drive holds it) the filter runs at: the rest lets
/// a drive that is behind catch up.
pub const FOLLOW_SPEED_SHARE: f64 = 0.9;

/// The share of the top acceleration (`JA`/`JL` as a drive holds them) the filter runs
/// at: a drive whose speed arrives late (the line's requests go one after the other)
/// ramps a little harder than the filter and catches up.
pub const FOLLOW_ACCEL_SHARE: f64 = 0.8;

/// The share of a line the period counts on (as the planner's).
const LINE_SHARE: f64 = crate::uim2503::schedule::LINE_UTILISATION;

/// The refusal of a `CS` while not jogging (HCR p. 304: `?7`, cannot process).
pub const CS_NOT_JOGGING: u16 = 7;

/// `CS`s a drive may refuse in a row (`?7`) while its jog has not begun, before live
/// mode stops naming it.
pub const EARLY_SPEEDS_MAX: u32 = 50;

/// How a gateway entry reaches its drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SclLine {
    /// An RS-485 line at this baud (8N1): one request at a time.
    Rs485 {
        /// Bits per second.
        baud: u32,
    },
    /// eSCL over UDP: each drive its own datagrams.
    Escl,
}

/// What live mode needs beyond [`super::SclDriveConfig`].
#[derive(Debug, Clone, PartialEq)]
pub struct SclLiveConfig {
    /// Each gateway entry's line, by index.
    pub lines: Vec<SclLine>,
    /// The installation's top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// The matrix (one ball per unit, row-major).
    pub layout: Layout,
}

/// What a drive does, as told.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(in crate::scl) enum Mode {
    /// At rest, or slowing down to it (`SJ` sent).
    Rest,
    /// Jogging; `true`: forward (counts growing, downwards).
    Jog(bool),
}

#[derive(Debug, Clone)]
pub(in crate::scl) struct LiveUnit {
    pub(in crate::scl) mode: Mode,
    /// The speed last asked, steps of `VE`'s resolution.
    sent_steps: i64,
    /// The filtered states a period before the period's start, at its start and at
    /// its end: the drive runs them one period later.
    pub(in crate::scl) prev: BallState,
    pub(in crate::scl) from: BallState,
    pub(in crate::scl) to: BallState,
    /// What the drive does, as its answers tell: see [`Model`].
    pub(in crate::scl) model: Model,
    /// Its lane in the live stage.
    lane: usize,
    /// One request and its answer on its lane, s: a speed reaches the drive after
    /// those queued before it on the lane, and is the filtered one that much later.
    exchange_s: f64,
    /// The count it was last fed to at rest ([`REST_TOLERANCE_COUNTS`]), until it jogs
    /// again.
    fed: Option<i32>,
    /// Its `CS`s refused in a row because its jog had not begun yet (`?7`).
    early_speeds: u32,
}

/// `state` as the drives jog it: squeezed into the travel less [`END_MARGIN_MM`] at
/// each end (at most a quarter of the travel), positions and speeds scaled alike, so
/// the limits hold and nothing a jog carries on past the filter leaves the travel.
fn inside(state: BallState, travel_mm: f64) -> BallState {
    if travel_mm <= 0.0 {
        return state;
    }
    let margin_mm = END_MARGIN_MM.min(travel_mm / 4.0);
    let scale = (travel_mm - 2.0 * margin_mm) / travel_mm;
    BallState {
        position_mm: margin_mm + state.position_mm.clamp(0.0, travel_mm) * scale,
        velocity_mm_s: state.velocity_mm_s * scale,
    }
}

/// Live motion under way.
#[derive(Debug, Clone)]
pub(in crate::scl) struct LiveRun {
    /// The travel, mm (the filter's: 0 to this).
    travel_mm: f64,
    period_us: u64,
    slot_us: u64,
    pub(in crate::scl) units: Vec<LiveUnit>,
    /// Each lane's units, and the next one read.
    lanes: Vec<(Vec<usize>, usize)>,
    counts_per_mm: f64,
    /// One step of `VE`, mm/s.
    step_mm_s: f64,
    /// The fastest speed asked, mm/s (the top speed as held).
    max_speed_mm_s: f64,
    /// `JA` = `JL` as held, mm/s².
    max_accel_mm_s2: f64,
}

/// A drive's motion as the requests it took make it (the twin's [`Profile`]s, at
/// `JA` = `JL`), shifted by what its last `IP` read: where it will be when a speed
/// asked now reaches it, so each speed is solved to put it where the filter is one
/// period on.
#[derive(Debug, Clone)]
pub(in crate::scl) struct Model {
    /// The profiles, each from its start, µs (the last few).
    pieces: Vec<(u64, Profile)>,
    /// Whether it jogs, and which way (1 or −1).
    jogging: bool,
    jog_dir: f64,
    /// `DI`'s sign: forward.
    forward: bool,
    /// `JS`, counts/s.
    jog_counts_s: f64,
    /// `JA` = `JL`, counts/s².
    rate_counts_s2: f64,
    /// The last `IP` minus the model there, counts.
    shift_counts: f64,
    /// `DI`'s value: where an `FP` goes, counts.
    di_counts: f64,
    /// The feeds' `VE` as held, counts/s (an `FP` to the exact count at rest).
    feed_counts_s: f64,
}

impl Model {
    fn at_rest(counts: f64, at_us: u64, rate_counts_s2: f64, feed_counts_s: f64) -> Self {
        Self {
            pieces: vec![(at_us, Profile::stop(counts, 0.0, rate_counts_s2))],
            jogging: false,
            jog_dir: 1.0,
            forward: true,
            jog_counts_s: 0.0,
            rate_counts_s2,
            shift_counts: 0.0,
            di_counts: counts,
            feed_counts_s,
        }
    }

    /// Position (counts, shifted) and velocity (counts/s) at `at_us`.
    pub(in crate::scl) fn at(&self, at_us: u64) -> (f64, f64) {
        let (x, v) = self.raw(at_us);
        (x + self.shift_counts, v)
    }

    fn raw(&self, at_us: u64) -> (f64, f64) {
        let piece = self
            .pieces
            .iter()
            .rev()
            .find(|(start_us, _)| *start_us <= at_us)
            .or_else(|| self.pieces.first());
        piece.map_or((0.0, 0.0), |(start_us, profile)| {
            profile.at(at_us.saturating_sub(*start_us) as f64 / 1e6)
        })
    }

    fn push(&mut self, at_us: u64, profile: Profile) {
        self.pieces.retain(|(start_us, _)| *start_us <= at_us);
        self.pieces.push((at_us, profile));
        if self.pieces.len() > 4 {
            self.pieces.remove(0);
        }
    }

    /// `command` reached the drive at `at_us`.
    fn take(&mut self, command: &Command, at_us: u64, per_rev: f64) {
        let held = |rev_s: Option<super::Decimal>| {
            rev_s
                .and_then(|v| units::VELOCITY.held(v))
                .map(|v| v * per_rev)
        };
        let rate = self.rate_counts_s2;
        match *command {
            Command::Distance { counts: Some(c) } => {
                self.forward = c >= 0;
                self.di_counts = f64::from(c);
            }
            Command::FeedToPosition if !self.jogging => {
                // The feed to the exact count at rest: a jog after it starts when it
                // ends (a `CJ` waits for the move before it).
                let (x, v) = self.raw(at_us);
                let feed = Profile::to_rest(x, v, self.di_counts, self.feed_counts_s, rate, rate);
                self.push(at_us, feed);
            }
            Command::JogSpeed { rev_s } => {
                if let Some(v) = held(rev_s) {
                    self.jog_counts_s = v;
                }
            }
            Command::ChangeSpeed { rev_s } => {
                // Signed: the sign is the direction (HCR p. 71).
                if let Some(v) = held(Some(rev_s.abs()))
                    && self.jogging
                {
                    self.jog_dir = if rev_s.is_negative() { -1.0 } else { 1.0 };
                    let (x, now_v) = self.raw(at_us);
                    let run_v = self.jog_dir * v;
                    self.push(at_us, Profile::run(x, now_v, run_v, rate, rate));
                }
            }
            Command::CommenceJogging if !self.jogging => {
                // After the motion under way (a stop) ends.
                let (start_us, x) = match self.pieces.last() {
                    Some((start_us, profile)) if profile.end_counts().is_some() => {
                        let end_us = start_us
                            .saturating_add((profile.duration_s() * 1e6).ceil() as u64)
                            .max(at_us);
                        (end_us, profile.at(f64::INFINITY).0)
                    }
                    _ => (at_us, self.raw(at_us).0),
                };
                self.jogging = true;
                self.jog_dir = if self.forward { 1.0 } else { -1.0 };
                let run_v = self.jog_dir * self.jog_counts_s;
                self.push(start_us, Profile::run(x, 0.0, run_v, rate, rate));
            }
            Command::StopJogging if self.jogging => {
                let (x, v) = self.raw(at_us);
                self.jogging = false;
                self.push(at_us, Profile::stop(x, v, rate));
            }
            _ => {}
        }
    }

    /// Whether its jog is under way at `at_us` (a `CJ` taken, and the stop before it
    /// ended).
    fn jogs_at(&self, at_us: u64) -> bool {
        self.jogging
            && self
                .pieces
                .last()
                .is_none_or(|(start_us, _)| *start_us <= at_us)
    }

    /// The drive said `counts` at `at_us`.
    fn read(&mut self, at_us: u64, counts: i64) {
        self.shift_counts = counts as f64 - self.raw(at_us).0;
    }
}

/// Position and velocity `tau_s` into a filter step from `a` to `b` lasting `dt_s`
/// (constant acceleration; past its end, at `b`'s velocity).
fn along(a: BallState, b: BallState, tau_s: f64, dt_s: f64) -> (f64, f64) {
    if tau_s > dt_s {
        return (
            b.position_mm + b.velocity_mm_s * (tau_s - dt_s),
            b.velocity_mm_s,
        );
    }
    let accel = (b.velocity_mm_s - a.velocity_mm_s) / dt_s;
    (
        a.position_mm + a.velocity_mm_s * tau_s + 0.5 * accel * tau_s * tau_s,
        a.velocity_mm_s + accel * tau_s,
    )
}

impl LiveRun {
    /// Where the drive is to have unit `unit` at `at_us`, mm: the filtered motion one
    /// period later ([`LIVE_DELAY_PERIODS`]).
    #[cfg(test)]
    pub(in crate::scl) fn reference_mm(&self, unit: usize, at_us: u64) -> Option<f64> {
        let state = self.units.get(unit)?;
        let dt = self.period_us as f64 / 1e6;
        let tau = (at_us as f64 - self.slot_us as f64) / 1e6;
        Some(if tau < 0.0 {
            state.prev.position_mm + state.prev.velocity_mm_s * tau
        } else if tau <= dt {
            along(state.prev, state.from, tau, dt).0
        } else {
            along(state.from, state.to, tau - dt, dt).0
        })
    }

    /// Unit `unit` was at `counts` at `at_us` (an `IP`): its model is shifted there.
    pub(super) fn read(&mut self, unit: usize, at_us: u64, counts: i64) {
        if let Some(state) = self.units.get_mut(unit) {
            state.model.read(at_us, counts);
        }
    }

    /// `command` reached unit `unit`'s drive at `at_us`.
    pub(super) fn took(&mut self, unit: usize, command: &Command, at_us: u64, per_rev: f64) {
        if let Some(state) = self.units.get_mut(unit) {
            if matches!(command, Command::ChangeSpeed { .. }) {
                state.early_speeds = 0;
            }
            state.model.take(command, at_us, per_rev);
        }
    }

    /// Unit `unit`'s drive refused a `CS` because its jog had not begun (`?7`: its
    /// `JS`/`CJ` still wait behind the move before them — HCR p. 71 takes a `CS` only
    /// while jogging). The speed is asked again next period; whether that has
    /// happened [`EARLY_SPEEDS_MAX`] times in a row (then it is a fault).
    pub(super) fn early_speed(&mut self, unit: usize) -> bool {
        let Some(state) = self.units.get_mut(unit) else {
            return true;
        };
        state.early_speeds += 1;
        state.sent_steps = 0;
        state.early_speeds > EARLY_SPEEDS_MAX
    }
}

impl SclDrive {
    /// The longest text of `command` with an address and CR, bytes.
    fn wire_len(command: &Command) -> usize {
        command.to_string().len() + 2
    }

    /// One `CS` and its answer on a line at `baud`, µs (with the turnaround).
    fn exchange_us(&self, baud: u32) -> u64 {
        let (cs, answer) = self.speed_bytes();
        Line::new(baud).time_us(cs + answer) + TURNAROUND_US
    }

    /// A `CS` at the top speed, and its answer, bytes (address and CR).
    fn speed_bytes(&self) -> (usize, usize) {
        let config = &self.config;
        let top = self
            .live_config
            .as_ref()
            .map_or(0.0, |live| live.max_speed_mm_s);
        let speed = at_most(
            &units::VELOCITY,
            top * config.counts_per_mm / f64::from(config.steps_per_rev),
        );
        (Self::wire_len(&Command::ChangeSpeed { rev_s: speed }), 3)
    }

    /// The period gateway `gateway`'s line needs for `units` drives, µs, and the
    /// time its requests take.
    fn line_period_us(&self, line: SclLine, units: usize) -> (u64, u64) {
        let config = &self.config;
        let (cs, _) = self.speed_bytes();
        let answer = 3; // `1*` or `1%`, CR
        let travel = config.counts(config.travel_mm).unsigned_abs();
        let ip = Self::wire_len(&Command::ImmediatePosition) + format!("IP=-{travel}").len() + 2;
        let turn = [
            Command::StopJogging,
            Command::Distance { counts: Some(-1) },
            Command::CommenceJogging,
        ]
        .iter()
        .map(|command| Self::wire_len(command) + answer)
        .sum::<usize>();
        match line {
            SclLine::Rs485 { baud } => {
                let bytes = units * (cs + answer) + ip + turn;
                let exchanges = units as u64 + 1 + 3;
                let line = Line::new(baud);
                let bytes_us = (bytes as f64 * line.byte_ms() * 1_000.0 / LINE_SHARE).ceil() as u64;
                let busy_us = bytes_us + exchanges * TURNAROUND_US;
                (busy_us, busy_us)
            }
            // Each drive its own datagrams: a `CS` and an `IP` (a turn-round: three).
            SclLine::Escl => (4 * ESCL_EXCHANGE_US, 2 * ESCL_EXCHANGE_US),
        }
    }

    /// The live period the lines carry, µs, and the longest time a period's requests
    /// take on a line, µs.
    ///
    /// # Errors
    /// [`StartError::LiveLineTooSlow`] for a line that needs more than
    /// [`LIVE_PERIOD_MAX_MS`].
    pub fn live_period_us(&self) -> Result<(u64, u64), StartError> {
        let Some(live) = &self.live_config else {
            return Err(StartError::LiveUnsupported {
                family: "MOONS' drives without their lines' settings",
            });
        };
        let mut period_us = u64::from(LIVE_PERIOD_MIN_MS) * 1_000;
        let mut busy_us = 0;
        for gateway in 0..self.config.gateways {
            let units = self
                .config
                .units
                .iter()
                .filter(|slot| slot.gateway == gateway)
                .count();
            if units == 0 {
                continue;
            }
            let line = live
                .lines
                .get(gateway)
                .copied()
                .unwrap_or(SclLine::Rs485 { baud: 9_600 });
            let (needs_us, line_busy_us) = self.line_period_us(line, units);
            let needs_ms = needs_us.div_ceil(1_000);
            if needs_ms > u64::from(LIVE_PERIOD_MAX_MS) {
                return Err(StartError::LiveLineTooSlow {
                    gateway,
                    units,
                    row_ms: needs_ms,
                    max_ms: u64::from(LIVE_PERIOD_MAX_MS),
                });
            }
            period_us = period_us.max(needs_ms * 1_000);
            busy_us = busy_us.max(line_busy_us);
        }
        Ok((period_us, busy_us))
    }

    /// The top speed and acceleration as a drive holds them (`CS`, `JA`), mm/s and
    /// mm/s²: never above the installation's.
    fn held_limits(&self) -> Option<(f64, f64)> {
        let live = self.live_config.as_ref()?;
        let config = &self.config;
        let mm_per_rev = f64::from(config.steps_per_rev) / config.counts_per_mm;
        let held = |resolution: &units::Resolution, value: f64| {
            resolution
                .held(at_most(resolution, value))
                .unwrap_or(0.0)
                .min(value)
                * mm_per_rev
        };
        Some((
            held(&units::VELOCITY, live.max_speed_mm_s / mm_per_rev),
            held(&units::ACCELERATION, config.max_accel_mm_s2 / mm_per_rev),
        ))
    }

    pub(super) fn live_setup_scl(&self) -> Result<LiveSetup, StartError> {
        let (period_us, _) = self.live_period_us()?;
        let Some(live) = &self.live_config else {
            return Err(StartError::LiveUnsupported {
                family: "MOONS' drives without their lines' settings",
            });
        };
        let (speed, accel) = self.held_limits().unwrap_or((0.0, 0.0));
        Ok(LiveSetup {
            limits: FilterLimits {
                travel_mm: self.config.travel_mm,
                max_speed_mm_s: FOLLOW_SPEED_SHARE * speed,
                max_accel_mm_s2: FOLLOW_ACCEL_SHARE * accel,
                dt_ms: u32::try_from(period_us / 1_000).unwrap_or(LIVE_PERIOD_MAX_MS),
            },
            approach_speed_mm_s: self.config.approach_speed_mm_s,
            layout: live.layout,
            // Up to a period waiting for the slot, the period's filter step, and the
            // period the drives run it later (its requests go out meanwhile).
            latency_us: (2 + LIVE_DELAY_PERIODS) * period_us,
            every_period: false,
        })
    }

    pub(super) fn begin_live_scl(&mut self, now_us: u64, states: &[BallState]) -> bool {
        let Ok((period_us, _)) = self.live_period_us() else {
            self.failure = Some("live mode: the lines carry no live period".into());
            return true;
        };
        let escl = |gateway: usize| {
            self.live_config
                .as_ref()
                .and_then(|live| live.lines.get(gateway))
                .is_some_and(|line| *line == SclLine::Escl)
        };
        // A lane a line, or a drive over eSCL.
        let mut lanes: Vec<(Vec<usize>, usize)> = Vec::new();
        let mut lane_of = vec![0; self.config.units.len()];
        for gateway in 0..self.config.gateways {
            let on: Vec<usize> = (0..self.config.units.len())
                .filter(|&unit| self.config.units[unit].gateway == gateway)
                .collect();
            if on.is_empty() {
                continue;
            }
            if escl(gateway) {
                for unit in on {
                    lane_of[unit] = lanes.len();
                    lanes.push((vec![unit], 0));
                }
            } else {
                for &unit in &on {
                    lane_of[unit] = lanes.len();
                }
                lanes.push((on, 0));
            }
        }
        // One request and its answer on each drive's lane.
        let mut leads = vec![0.0; self.config.units.len()];
        for (units, _) in &lanes {
            for &unit in units {
                let gateway = self.config.units[unit].gateway;
                let exchange_us = match self
                    .live_config
                    .as_ref()
                    .and_then(|live| live.lines.get(gateway))
                {
                    Some(SclLine::Rs485 { baud }) => self.exchange_us(*baud),
                    _ => ESCL_EXCHANGE_US,
                };
                leads[unit] = exchange_us as f64 / 1e6;
            }
        }
        let mm_per_rev = f64::from(self.config.steps_per_rev) / self.config.counts_per_mm;
        let (speed, accel) = self.held_limits().unwrap_or((0.0, 0.0));
        let rates = accel * self.config.counts_per_mm;
        let (feed_velocity, _) = self.feed_ramps();
        let feed_counts_s = units::VELOCITY.held(feed_velocity).unwrap_or(0.0)
            * f64::from(self.config.steps_per_rev);
        let units = lane_of
            .iter()
            .enumerate()
            .map(|(unit, &lane)| {
                let state = states
                    .get(unit)
                    .copied()
                    .unwrap_or_else(|| BallState::at_rest(0.0));
                let jogged = inside(state, self.config.travel_mm);
                LiveUnit {
                    mode: Mode::Rest,
                    sent_steps: 0,
                    prev: jogged,
                    from: jogged,
                    to: jogged,
                    model: Model::at_rest(
                        f64::from(self.config.counts(state.position_mm)),
                        now_us,
                        rates,
                        feed_counts_s,
                    ),
                    lane,
                    exchange_s: leads.get(unit).copied().unwrap_or(0.0),
                    fed: None,
                    early_speeds: 0,
                }
            })
            .collect();
        self.live = Some(LiveRun {
            travel_mm: self.config.travel_mm,
            period_us,
            slot_us: now_us,
            units,
            lanes,
            counts_per_mm: self.config.counts_per_mm,
            step_mm_s: units::VELOCITY.step * mm_per_rev,
            max_speed_mm_s: speed,
            max_accel_mm_s2: accel,
        });
        self.playing = false;
        self.loading = false;
        self.believed_counts = None;
        self.moving_to = None;
        // The jog's ramps, and the last feed's speed and ramps.
        let (velocity, accel) = self.feed_ramps();
        // Enabled first when the run did not move them yet (a drive disabled at a
        // schedule window's end refuses to move, alarm `8000` No Move).
        let enable = std::mem::take(&mut self.before_next_move.enable);
        let prepare = self.by_line(|unit| {
            asks_enabled_first(
                unit,
                enable,
                [
                    // A jog starts at `JS`, its speed following in the next request: the
                    // smallest, never the power-up `JS`.
                    Command::JogSpeed {
                        rev_s: units::VELOCITY.write(1),
                    },
                    Command::JogAcceleration {
                        rev_s2: Some(accel),
                    },
                    Command::JogDeceleration {
                        rev_s2: Some(accel),
                    },
                ]
                .into_iter()
                .chain(feed_settings(velocity, accel)),
            )
        });
        self.begin_stages(now_us, vec![prepare]);
        true
    }

    /// The live stage's lanes (made when none runs).
    fn live_lanes(&mut self) -> Option<&mut Stage> {
        let lanes = self.live.as_ref()?.lanes.len();
        if self.stages.is_empty() {
            self.stages
                .push_back((0..lanes).map(|_| Lane::default()).collect());
        }
        let stage = self.stages.front_mut()?;
        stage.resize_with(lanes, Lane::default);
        Some(stage)
    }

    pub(super) fn live_step_scl(&mut self, slot_us: u64, states: &[BallState]) {
        self.now_us = self.now_us.max(slot_us);
        let Some(mut run) = self.live.take() else {
            return;
        };
        run.slot_us = slot_us;
        let mm_per_rev = f64::from(self.config.steps_per_rev) / self.config.counts_per_mm;
        let per_rev = f64::from(self.config.steps_per_rev);
        let top_steps = ((run.max_speed_mm_s / mm_per_rev / units::VELOCITY.step + 1e-9).floor()
            as i64)
            .clamp(1, units::VELOCITY.max_steps);
        let mut asks: Vec<(usize, usize, Vec<Command>, bool)> = Vec::new();
        // Requests each lane has queued (or out) ahead of this period's.
        let mut queued: Vec<usize> = (0..run.lanes.len())
            .map(|lane| {
                self.stages
                    .front()
                    .and_then(|stage| stage.get(lane))
                    .map_or(0, |lane| {
                        lane.actions.len() + usize::from(lane.waiting.is_some())
                    })
            })
            .collect();
        for (unit, state) in run.units.iter_mut().enumerate() {
            // The filter's state (the rest feed's exact count), and as jogged: inside
            // the ends by the margin.
            let exact = states.get(unit).copied();
            let next = exact.map_or(state.to, |exact| inside(exact, run.travel_mm));
            let exact = exact.unwrap_or(next);
            state.prev = state.from;
            state.from = state.to;
            state.to = next;
            // The drive runs this period's filter step during the next period: it
            // moves if the filter moves at either end of the step, the way it goes at
            // the step's start (or, from rest, at its end).
            let velocity = if state.from.velocity_mm_s.abs() >= run.step_mm_s {
                state.from.velocity_mm_s
            } else {
                next.velocity_mm_s
            };
            let moving = velocity.abs() >= run.step_mm_s;
            let forward = velocity > 0.0;
            let period_s = run.period_us as f64 / 1e6;
            let write = |steps: i64| {
                units::VELOCITY
                    .write(steps)
                    .unwrap_or_else(|| super::Decimal::from_int(0))
            };
            let way = Command::Distance {
                counts: Some(if forward { 1 } else { -1 }),
            };
            // `DI`'s sign as the drive will have it when this period's requests go.
            let mut last_forward = state.model.forward;
            if let Some(lane) = self.stages.front().and_then(|stage| stage.get(state.lane)) {
                let out = lane.waiting.iter().map(|(_, action)| action);
                for action in out.chain(lane.actions.iter()) {
                    if let Action::Ask {
                        unit: of,
                        command: Some(Command::Distance { counts: Some(c) }),
                        ..
                    } = action
                        && *of == unit
                    {
                        last_forward = *c >= 0;
                    }
                }
            }
            // What the speed `steps` takes, from the mode the drive is told to be in:
            // jogging, a `CS` whose sign is the way (HCR p. 71: it turns the ball
            // round through 0 at `JA`/`JL`); from rest, `JS` and `CJ` (buffered: they
            // start the jog once the drive stands, and a `CS` is only for a jog).
            let commands = |steps: i64| -> (Vec<Command>, bool) {
                let speed = write(steps);
                match state.mode {
                    Mode::Jog(_) => (
                        vec![Command::ChangeSpeed {
                            rev_s: if forward {
                                speed
                            } else {
                                super::Decimal::new(-speed.mantissa(), speed.scale())
                                    .unwrap_or(speed)
                            },
                        }],
                        true,
                    ),
                    Mode::Rest => {
                        let start = [
                            Command::JogSpeed { rev_s: Some(speed) },
                            Command::CommenceJogging,
                        ];
                        if last_forward == forward {
                            (start.to_vec(), false)
                        } else {
                            (std::iter::once(way).chain(start).collect(), false)
                        }
                    }
                }
            };
            if !moving {
                if let Mode::Jog(_) = state.mode {
                    state.mode = Mode::Rest;
                    asks.push((state.lane, unit, vec![Command::StopJogging], false));
                    continue;
                }
                // At rest where the model (its requests, shifted to its last read)
                // says, off the filter: fed to the exact count, once.
                let target = self.config.counts(exact.position_mm);
                let (at, speed) = state.model.at(slot_us);
                let off_counts = (at - f64::from(target)).abs();
                if !state.model.jogging
                    && speed == 0.0
                    && off_counts >= REST_TOLERANCE_COUNTS
                    && state.fed != Some(target)
                {
                    state.fed = Some(target);
                    let feed = vec![
                        Command::Distance {
                            counts: Some(target),
                        },
                        Command::FeedToPosition,
                    ];
                    asks.push((state.lane, unit, feed, false));
                }
                continue;
            }
            state.fed = None;
            // When this one arrives: after what the lane has queued.
            let count = commands(1).0.len();
            let before = queued.get(state.lane).copied().unwrap_or(0) + count;
            if let Some(queued) = queued.get_mut(state.lane) {
                *queued = before;
            }
            let lead_s = before as f64 * state.exchange_s;
            // The speed it is to have one period after this one arrives.
            let (goal_mm, goal_mm_s) = along(state.from, next, lead_s, period_s);
            let ahead = if (goal_mm_s > 0.0) == forward {
                goal_mm_s
            } else {
                0.0
            };
            // The drive as its requests under way leave it, when this one arrives.
            let lead_us = (lead_s * 1e6) as u64;
            let arrives_us = slot_us + lead_us;
            let mut model = state.model.clone();
            if let Some(lane) = self.stages.front().and_then(|stage| stage.get(state.lane)) {
                // The request out lands first; a speed queued is replaced.
                let waiting = lane
                    .waiting
                    .iter()
                    .map(|(_, action)| (slot_us, action, true));
                let queued = lane
                    .actions
                    .iter()
                    .map(|action| (arrives_us, action, false));
                for (at_us, action, out) in waiting.chain(queued) {
                    if let Action::Ask {
                        unit: of,
                        command: Some(command),
                        ..
                    } = action
                        && *of == unit
                        && (out || !matches!(command, Command::ChangeSpeed { .. }))
                    {
                        model.take(command, at_us, per_rev);
                    }
                }
            }
            // Where it is to be one period after this one arrives.
            let until_us = arrives_us + run.period_us;
            let target = goal_mm * run.counts_per_mm;
            let sign = if forward { 1.0 } else { -1.0 };
            let short = |steps: i64| {
                let mut trial = model.clone();
                for command in commands(steps).0 {
                    trial.take(&command, arrives_us, per_rev);
                }
                sign * (target - trial.at(until_us).0)
            };
            // The step's speed one period after it arrives, and a correction of what
            // the drive would then be short of the step (or past it), spread
            // over two periods and bounded: the drive's ramp keeps the acceleration.
            let to_steps = |mm_s: f64| {
                ((mm_s / mm_per_rev / units::VELOCITY.step + 1e-9).floor() as i64)
                    .clamp(1, top_steps)
            };
            let feed_mm_s = ahead.abs();
            let behind_mm = short(to_steps(feed_mm_s)) / run.counts_per_mm;
            let bound = run.max_speed_mm_s * (1.0 - FOLLOW_SPEED_SHARE);
            // No faster than the drive's spare acceleration can take back by the
            // time it has caught up (else it overshoots).
            let spare = (1.0 - FOLLOW_ACCEL_SHARE) * run.max_accel_mm_s2;
            let catch_up = (behind_mm.abs() / (2.0 * period_s))
                .min(CATCH_UP_SHARE * (2.0 * spare * behind_mm.abs()).sqrt())
                .min(bound);
            let correction = catch_up.copysign(behind_mm);
            let low = to_steps(feed_mm_s + correction);
            let steps = low;
            let (list, replace) = commands(steps);
            if replace && steps == state.sent_steps {
                continue;
            }
            // A `CS` is only for a jog under way (HCR p. 71; a drive refuses it, `?7`,
            // while its `JS`/`CJ` still wait behind a stop): held back until then.
            if replace && !model.jogs_at(arrives_us) {
                continue;
            }
            state.mode = Mode::Jog(forward);
            state.sent_steps = steps;
            asks.push((state.lane, unit, list, replace));
        }
        // One position read per lane, round-robin, unless one waits to go.
        let mut reads = Vec::new();
        for (lane, (units, next)) in run.lanes.iter_mut().enumerate() {
            if let Some(&unit) = units.get(*next % units.len().max(1)) {
                reads.push((lane, unit));
                *next = (*next + 1) % units.len().max(1);
            }
        }
        self.live = Some(run);
        let Some(stage) = self.live_lanes() else {
            return;
        };
        for (lane, unit, commands, replace) in asks {
            let Some(lane) = stage.get_mut(lane) else {
                continue;
            };
            if replace && let Some(command) = commands.first() {
                queue_speed(lane, unit, *command);
            } else {
                // A speed not yet sent is void: what follows replaces it.
                drop_unsent_speeds(lane, unit);
                lane.actions.extend(
                    commands
                        .into_iter()
                        .map(|command| ask(unit, command, Check::NotRefused)),
                );
            }
        }
        for (lane, unit) in reads {
            let Some(lane) = stage.get_mut(lane) else {
                continue;
            };
            let reading = lane.actions.iter().any(|action| {
                matches!(
                    action,
                    Action::Ask {
                        check: Check::Read,
                        ..
                    }
                )
            });
            if !reading {
                lane.actions
                    .push_back(ask(unit, Command::ImmediatePosition, Check::Read));
            }
        }
        self.advance(slot_us);
    }

    pub(super) fn end_live_scl(&mut self, at_us: u64, states: &[BallState]) {
        self.now_us = self.now_us.max(at_us);
        let Some(run) = self.live.take() else {
            return;
        };
        let targets: Vec<i32> = (0..self.config.units.len())
            .map(|unit| {
                let state = states
                    .get(unit)
                    .copied()
                    .or_else(|| run.units.get(unit).map(|u| u.to))
                    .unwrap_or_default();
                self.config.counts(state.position_mm)
            })
            .collect();
        if self.stages.is_empty() {
            self.stages
                .push_back((0..run.lanes.len()).map(|_| Lane::default()).collect());
        }
        if let Some(stage) = self.stages.front_mut() {
            for (unit, state) in run.units.iter().enumerate() {
                let Some(lane) = stage.get_mut(state.lane) else {
                    continue;
                };
                drop_unsent_speeds(lane, unit);
                // Reads not yet sent are of no use now.
                lane.actions.retain(|action| {
                    !matches!(
                        action,
                        Action::Ask {
                            check: Check::Read,
                            ..
                        }
                    )
                });
                if let Mode::Jog(_) = state.mode {
                    lane.actions
                        .push_back(ask(unit, Command::StopJogging, Check::NotRefused));
                }
                // `FP` waits for the stop, then feeds to the exact count.
                lane.actions.push_back(ask(
                    unit,
                    Command::Distance {
                        counts: Some(targets[unit]),
                    },
                    Check::NotRefused,
                ));
                lane.actions
                    .push_back(ask(unit, Command::FeedToPosition, Check::NotRefused));
            }
        }
        let arrive = Lane::of((0..self.config.units.len()).map(|unit| {
            ask(
                unit,
                Command::ImmediatePosition,
                Check::Position {
                    target: i64::from(targets[unit]),
                },
            )
        }));
        self.stages.push_back(vec![arrive]);
        self.stage_began_us = at_us;
        self.believed_counts = Some(targets);
        self.ending = true;
        self.advance(at_us);
    }
}

/// `command` (a `CS`) for `unit` on `lane`: replaces the unit's last request when it
/// is a speed not yet sent, or goes last.
fn queue_speed(lane: &mut Lane, unit: usize, command: Command) {
    let last = lane
        .actions
        .iter_mut()
        .rev()
        .find_map(|action| match action {
            Action::Ask {
                unit: of,
                command: Some(command),
                ..
            } if *of == unit => Some(command),
            _ => None,
        });
    match last {
        Some(last @ Command::ChangeSpeed { .. }) => *last = command,
        _ => lane
            .actions
            .push_back(ask(unit, command, Check::NotRefused)),
    }
}

/// Drops `unit`'s `CS` not yet sent on `lane`.
fn drop_unsent_speeds(lane: &mut Lane, unit: usize) {
    lane.actions.retain(|action| {
        !matches!(
            action,
            Action::Ask {
                unit: of,
                command: Some(Command::ChangeSpeed { .. }),
                ..
            } if *of == unit
        )
    });
}
