//! Q programs from shows: one ball's [`Track`] compiled to the program a MOONS' drive
//! stores and runs without a host (issue 15, item 2; the layout is
//! `docs/protocol-notes.md` §8 and the user's view `docs/moons.md`).
//!
//! This module owns the API ([`QProgramConfig`], [`compile`], [`QProgram`] and its
//! listing [`QProgram::text`], [`Keyframe`], [`Reduction`], [`QProgramError`]) and the
//! layout of the segments; [`mod@keyframes`] samples the show and finds the candidate
//! keyframes, [`mod@reduce`] chooses the moves, [`mod@moves`] is the drive's trapezoid,
//! [`mod@jog`] writes smooth shows as jogs.
//!
//! Two programs are compiled and the one closer to the show is kept: the ball
//! **jogging** through every stretch it moves one way, its speed changed every step
//! ([`mod@jog`], issue 34 item 2), and moves **from rest to rest**, below.
//!
//! What a rest-to-rest program is:
//! - every move is an absolute `FP` (`DI` = mm × `counts_per_mm`) **from rest to
//!   rest**, a trapezoid (`AC` = `DE`, rev/s², from a ladder: the limit, the limit / √2,
//!   / 2, … and the one that suits the show's typical move; set in segment 1 for the
//!   first move, written again only when it changes) whose cruise speed (`VE`, rev/s) is
//!   solved so the move ends at its keyframe's time; where the ball rests, `WT` (s);
//! - every value is one a drive takes, a whole number of the steps it holds
//!   ([`super::units`]: `VE` 1/240 rev/s from 0.0042, `AC`/`DE` 1/6 rev/s² from 0.167,
//!   `WT` 0.01 s), written so that any drive holds exactly that step;
//! - the compiler keeps the drive's clock: it times every move from the values as the
//!   drive holds them, as the drive computes the trapezoid, and gives the next move what
//!   is left to its keyframe, so rounding never accumulates: every move ends at exactly
//!   its count, at most [`LATE_S`] (5 ms) late and [`KEEP_SPEED_S`] (10 ms, a player's
//!   tick, [`crate::uim2503::player::TICK_US`]) early. A move keeps the `VE` of the one
//!   before when that ends it within that window (a line saved: a periodic show needs
//!   `DI` and `FP` alone); a move that no step of `VE` ends within it (a slow one, or
//!   one slower than the smallest `VE`) runs at the speed rounded up to a step, arrives
//!   early, and a `WT` makes up the rest;
//! - `MT0` (moves block the program); time 0 is when the program starts, or when the
//!   start input meets its condition (`WI`, line 1) if one is configured; the drive
//!   must stand at the track's start position then (the bridge brings it there);
//! - segment 1 is the main program: `[WI]`, `MT0`, `AC`, `DE`, then `QC2`, `QC3`, …
//!   one call per segment of moves and, looping, `QG` back to the first call; segments
//!   2..=12 hold at most 61 move lines each and end with `QC` (return). A program whose
//!   moves fit in segment 1 keeps them there (and loops to its first move). At most
//!   12 segments of at most 62 lines;
//! - when the show's moves do not fit, fewer, longer moves are chosen so that the
//!   largest |show − program| is smallest ([`mod@reduce`]); the [`Reduction`] says how
//!   far and where, reduced or not, and a program deviating more than
//!   `tolerance_mm` is refused ([`QProgramError::TooFar`]). Three choices are made and
//!   the closest to the show that fits is kept: one acceleration for all moves with
//!   every `VE` counted (it surely fits); each move at the acceleration that suits it,
//!   counting moves that keep the speed and acceleration before them (`DI`, `FP`); one
//!   acceleration, counted so. The hopeful ones are written out and kept only if they
//!   fit (asked again with less room, up to 8 times, when they do not).

mod jog;
mod keyframes;
mod moves;
mod reduce;
mod stream;
#[cfg(test)]
mod tests;

use std::fmt::Write as _;

use thiserror::Error;

use super::command::{Command, Decimal, InputCondition, IoPoint, QLine, Segment};
use super::twin::Profile;
use super::units;
use crate::codes::{Code, Coded, Params};
use crate::params;
use crate::show::Track;
use keyframes::Samples;
use moves::{Trapezoid, solve_speed};
use reduce::{Count, Edge, Limits, Step};

/// Decimals written in `VE` (rev/s); a drive holds whole steps of 1/240 rev/s
/// ([`units::VELOCITY`]: 83⅓ counts/s at 20 000 steps/rev).
pub const VE_DECIMALS: u8 = units::VELOCITY.decimals;
/// Decimals written in `AC` and `DE` (rev/s²); a drive holds whole steps of 1/6 rev/s²
/// ([`units::ACCELERATION`]).
pub const AC_DECIMALS: u8 = units::ACCELERATION.decimals;
/// Decimals written in `WT` (s): whole hundredths ([`units::WAIT`]).
pub const WT_DECIMALS: u8 = units::WAIT.decimals;
/// How early before its keyframe's time a move may end, s: a player's tick
/// ([`crate::uim2503::player::TICK_US`]); and [`LATE_S`], how late. A move keeps the
/// `VE` of the one before (a line saved) when that ends it within these; a move that no
/// step of `VE` ends within them ends early and waits (`WT`, to half a hundredth). One
/// step of `VE` (1/240 rev/s) moves the end of a move of `T` s at `v` rev/s by up to
/// `T / (240 v)` s — 13 ms for a 1 m swing in 4 s — so the 4 ms the compiler kept
/// with `VE`s of 0.0001 rev/s (finer than a drive holds them) cannot be kept.
pub const KEEP_SPEED_S: f64 = 0.010;
/// How late after its keyframe's time a move may end, s (the next move is planned this
/// much quicker).
pub const LATE_S: f64 = 0.005;
/// While choosing moves, an edge's deviation is measured every this many grid samples
/// (10 ms); the report measures it on every sample (1 ms).
const COST_STRIDE: usize = 10;
/// Lines of a segment (the drive's limit).
pub const SEGMENT_LINES: usize = QLine::MAX as usize;
/// Segments of a program (the drive's limit).
pub const SEGMENTS: usize = Segment::MAX as usize;
/// The most move lines a program holds: 11 segments of 61 lines and their `QC`.
pub const MOVE_LINES: usize = (SEGMENTS - 1) * (SEGMENT_LINES - 1);

/// How a track is compiled: the drive's scale and limits, the start input, looping and
/// the tolerance. Built for an installation by the bridge (`bridge::http::qprogram`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QProgramConfig {
    /// Drive counts per mm of ball travel (`DI` = mm × this).
    pub counts_per_mm: f64,
    /// Counts per motor revolution (`EG`): the unit of `VE` and `AC`/`DE`.
    pub steps_per_rev: u32,
    /// The input every drive waits on before it starts (`WI`), or `None` to start at
    /// once when the program is executed.
    pub start: Option<(IoPoint, InputCondition)>,
    /// Run the show again and again (`QG`); the ball returns to its start first.
    pub loop_show: bool,
    /// The largest deviation from the show accepted, mm.
    pub tolerance_mm: f64,
    /// The highest speed a move may cruise at, mm/s.
    pub max_speed_mm_s: f64,
    /// The highest acceleration (and deceleration), mm/s².
    pub max_accel_mm_s2: f64,
}

/// A drive's steps per revolution unless configured (`EG`, the factory setting).
pub const DEFAULT_STEPS_PER_REV: u32 = 20_000;

/// The largest deviation from the show a program may have unless configured, mm.
pub const DEFAULT_TOLERANCE_MM: f64 = 5.0;

/// The common start input unless configured (`WI3F`: input 3, a falling edge).
pub const DEFAULT_START_INPUT: u8 = 3;

impl Default for QProgramConfig {
    /// 100 counts/mm, 20 000 steps/rev, start on a falling edge of input 3, no loop,
    /// 5 mm tolerance, 2000 mm/s, 4000 mm/s².
    fn default() -> Self {
        Self {
            counts_per_mm: 100.0,
            steps_per_rev: DEFAULT_STEPS_PER_REV,
            start: IoPoint::new(DEFAULT_START_INPUT).map(|input| (input, InputCondition::Falling)),
            loop_show: false,
            tolerance_mm: DEFAULT_TOLERANCE_MM,
            max_speed_mm_s: 2000.0,
            max_accel_mm_s2: 4000.0,
        }
    }
}

/// Where and when one move of the program ends: the position it stops at (exactly
/// its count) and the show time it must be there by.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Keyframe {
    /// Show time, ms (from the start).
    pub time_ms: u64,
    /// Position, mm below the top (the count the move ends at, in mm).
    pub position_mm: f64,
}

/// What the compiler did to the show: how many rows it had, how many moves and lines
/// the program keeps, and the largest |show − program| and when (sampled every 1 ms;
/// a show longer than 20 minutes more coarsely, at most 1.2 million samples).
/// Given whether or not the show was reduced: unreduced, it is what moving from rest to
/// rest costs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reduction {
    /// PVT rows of the track.
    pub track_rows: usize,
    /// `FP` moves in the program.
    pub moves: usize,
    /// Lines of every segment together.
    pub lines: usize,
    /// The largest |show − program| position, mm.
    pub max_deviation_mm: f64,
    /// When it happens, ms of show time.
    pub at_ms: u64,
}

pub use stream::{STREAM_STEP_S, Streaming, compile_for_drive, compile_streamed};

/// A compiled program: its segments in order (segment 1 the main program), where each
/// move ends, and the report.
#[derive(Debug, Clone, PartialEq)]
pub struct QProgram {
    /// The stored segments, each at most 62 commands — or, when [`Self::streamed`],
    /// one list of any length that the bridge streams into the drive's command buffer.
    pub segments: Vec<(Segment, Vec<Command>)>,
    /// Too long for a drive's 12 segments: streamed ([`compile_streamed`]).
    pub streamed: bool,
    /// Where each `FP` move ends, in order.
    pub keyframes: Vec<Keyframe>,
    /// What the compiler did to the show.
    pub report: Reduction,
}

impl QProgram {
    /// The listing: a header line per segment (`[segment 1: main, 17 lines]`, never a
    /// command), then one command per line, LF-separated.
    #[must_use]
    pub fn text(&self) -> String {
        let mut text = String::new();
        for (segment, commands) in &self.segments {
            let role = match (self.streamed, segment.get()) {
                (true, _) => "streamed",
                (false, 1) => "main",
                (false, _) => "moves",
            };
            let _ = writeln!(
                text,
                "[segment {segment}: {role}, {} lines]",
                commands.len()
            );
            for command in commands {
                let _ = writeln!(text, "{command}");
            }
        }
        text
    }

    /// Lines of every segment together.
    #[must_use]
    pub fn lines(&self) -> usize {
        self.segments
            .iter()
            .map(|(_, commands)| commands.len())
            .sum()
    }
}

/// Why a track was not compiled.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum QProgramError {
    /// The program that fits deviates from the show more than the tolerance.
    #[error(
        "the program would be {deviation_mm:.1} mm off the show at {at_ms} ms, more than the \
         tolerance of {tolerance_mm} mm (the show has too many moves for a drive's 12 segments \
         of 62 lines, or moves that a rest-to-rest move cannot follow closely)"
    )]
    TooFar {
        /// The deviation, mm.
        deviation_mm: f64,
        /// When, ms of show time.
        at_ms: u64,
        /// The configured tolerance, mm.
        tolerance_mm: f64,
    },
    /// No rest-to-rest move within the limits reaches the ball's position in time.
    #[error(
        "the ball cannot be at its position at {at_ms} ms: a move from rest to rest would need \
         more than {max_speed_mm_s} mm/s or {max_accel_mm_s2} mm/s²"
    )]
    TooFast {
        /// Show time of the position that cannot be reached, ms.
        at_ms: u64,
        /// The speed limit, mm/s.
        max_speed_mm_s: f64,
        /// The acceleration limit, mm/s².
        max_accel_mm_s2: f64,
    },
    /// A position is not a number or out of the drive's 32-bit range.
    #[error("the position {position_mm} mm at {at_ms} ms is out of the drive's range")]
    OutOfRange {
        /// Show time, ms.
        at_ms: u64,
        /// The position, mm.
        position_mm: f64,
    },
    /// The moves need more lines than a drive holds.
    #[error("the program needs {lines} lines, more than a drive's {limit}")]
    TooManyLines {
        /// Lines needed.
        lines: usize,
        /// Lines available.
        limit: usize,
    },
    /// A setting of the configuration cannot be used.
    #[error("the Q program setting {field} must be {must}")]
    InvalidConfig {
        /// The setting.
        field: &'static str,
        /// What it must be.
        must: &'static str,
    },
}

impl Coded for QProgramError {
    fn code(&self) -> Code {
        match self {
            Self::TooFar { .. } => Code::QprogramTooFar,
            Self::TooFast { .. } => Code::QprogramTooFast,
            Self::OutOfRange { .. } => Code::QprogramOutOfRange,
            Self::TooManyLines { .. } => Code::QprogramTooManyLines,
            Self::InvalidConfig { .. } => Code::QprogramSetting,
        }
    }

    /// The figures (mm with one decimal), and `time_s` (three decimals) when the
    /// error happens at a moment of the show.
    fn params(&self) -> Params {
        let time_s = |at_ms: u64| format!("{:.3}", at_ms as f64 / 1000.0);
        match self {
            Self::TooFar {
                deviation_mm,
                at_ms,
                tolerance_mm,
            } => params! {
                "deviation_mm" => format!("{deviation_mm:.1}"),
                "tolerance_mm" => tolerance_mm,
                "time_s" => time_s(*at_ms),
            },
            Self::TooFast {
                at_ms,
                max_speed_mm_s,
                max_accel_mm_s2,
            } => params! {
                "max_speed_mm_s" => max_speed_mm_s,
                "max_accel_mm_s2" => max_accel_mm_s2,
                "time_s" => time_s(*at_ms),
            },
            Self::OutOfRange { at_ms, position_mm } => params! {
                "position_mm" => position_mm,
                "time_s" => time_s(*at_ms),
            },
            Self::TooManyLines { lines, limit } => params! {"lines" => lines, "limit" => limit},
            Self::InvalidConfig { field, must } => params! {"field" => field, "must" => must},
        }
    }
}

/// Compiles one ball's track.
///
/// # Errors
/// [`QProgramError::TooFar`] when the program that fits deviates more than the
/// tolerance (with the figure and where); [`QProgramError::TooFast`] when the show
/// asks for more than the limits; the others for a bad configuration or positions.
pub fn compile(track: &Track, config: &QProgramConfig) -> Result<QProgram, QProgramError> {
    compile_within(track, config, MOVE_LINES)
}

/// [`compile`] with at most `budget_lines` move lines (tests give it less room).
pub(crate) fn compile_within(
    track: &Track,
    config: &QProgramConfig,
    budget_lines: usize,
) -> Result<QProgram, QProgramError> {
    compile_moves(track, config, budget_lines, true)
}

/// [`compile`] from rest to rest only, never jogging (the tests of those moves).
#[cfg(test)]
pub(crate) fn compile_rest_to_rest(
    track: &Track,
    config: &QProgramConfig,
    budget_lines: usize,
) -> Result<QProgram, QProgramError> {
    compile_moves(track, config, budget_lines, false)
}

/// [`compile`] with at most `budget_lines` move lines, trying jogs if `jogs`.
fn compile_moves(
    track: &Track,
    config: &QProgramConfig,
    budget_lines: usize,
    jogs: bool,
) -> Result<QProgram, QProgramError> {
    check(config)?;
    let samples = keyframes::sample(track);
    let candidates = keyframes::candidates(&samples);
    let counts = candidates
        .iter()
        .map(|&k| to_counts(samples.positions_mm[k], samples.times_ms[k], config))
        .collect::<Result<Vec<_>, _>>()?;
    let steps_per_rev = f64::from(config.steps_per_rev);
    let max_speed_counts_s = config.max_speed_mm_s * config.counts_per_mm;
    let window = ((candidates.len() * 3 * 5).div_ceil(2 * budget_lines.max(1))).clamp(6, 48);

    let levels: Vec<(Limits, Vec<Vec<Edge>>)> =
        accelerations(&samples, &candidates, &counts, config)
            .into_iter()
            .enumerate()
            .map(|(level, accel_rev_s2)| {
                let limits = Limits {
                    accel_counts_s2: units::ACCELERATION.held(accel_rev_s2).unwrap_or(0.0)
                        * steps_per_rev,
                    max_speed_counts_s,
                    steps_per_rev,
                    counts_per_mm: config.counts_per_mm,
                };
                let incoming = reduce::edges(
                    &samples,
                    &candidates,
                    &counts,
                    &limits,
                    (level, window),
                    COST_STRIDE,
                );
                (limits, incoming)
            })
            .collect();
    let all_limits: Vec<Limits> = levels.iter().map(|(limits, _)| *limits).collect();
    // Room for the first move's acceleration and the move back to the start of a loop.
    let room = budget_lines.saturating_sub(if config.loop_show { 5 } else { 0 });
    let write = |path: &[Edge]| {
        Writer::new(config, &all_limits, counts.first().copied().unwrap_or(0)).write(
            path,
            &samples,
            &candidates,
            &counts,
            track,
            budget_lines,
        )
    };
    let one_each: Vec<&[Vec<Edge>]> = levels.iter().map(|(_, incoming)| &incoming[..]).collect();
    // First one acceleration for every move, every move's lines counted in full: a
    // program that surely fits.
    let Some((set, threshold_mm)) = best_set(&one_each, room, Count::Surely) else {
        let at = levels
            .first()
            .and_then(|(_, incoming)| reduce::unreachable(incoming))
            .unwrap_or(0);
        return Err(QProgramError::TooFast {
            at_ms: candidates.get(at).map_or(0, |&k| samples.times_ms[k]),
            max_speed_mm_s: config.max_speed_mm_s,
            max_accel_mm_s2: config.max_accel_mm_s2,
        });
    };
    let too_many = QProgramError::TooManyLines {
        lines: room + 1,
        limit: room,
    };
    let path = reduce::refine(
        one_each[set],
        &samples,
        &candidates,
        threshold_mm,
        room,
        Count::Surely,
    )
    .ok_or(too_many)?;
    let mut program = write(&path)?;
    // Then hoping that moves keep the speed (and the acceleration) of the one before,
    // a `VE` (`AC`, `DE`) saved a move: first each move at the acceleration that suits
    // it, then one for all. Taken if it fits after all and comes closer to the show.
    let mixed: Vec<Vec<Edge>> = (0..candidates.len())
        .map(|to| {
            levels
                .iter()
                .flat_map(|(_, incoming)| incoming[to].iter().copied())
                .collect()
        })
        .collect();
    for sets in [vec![&mixed[..]], one_each] {
        let mut hope = room;
        for _ in 0..8 {
            let Some((set, hoped_mm)) = best_set(&sets, hope, Count::Hopefully) else {
                break;
            };
            let Some(mut path) = reduce::refine(
                sets[set],
                &samples,
                &candidates,
                hoped_mm,
                hope,
                Count::Hopefully,
            ) else {
                break;
            };
            keep_accelerations(&mut path, &levels, hoped_mm);
            match write(&path) {
                Ok(hoped) => {
                    if hoped.report.max_deviation_mm < program.report.max_deviation_mm {
                        program = hoped;
                    }
                    break;
                }
                Err(QProgramError::TooManyLines { lines, .. }) => {
                    // Ask for what was over, and 3 % more.
                    hope = (hope * room * 97 / 100 / lines.max(1)).min(hope.saturating_sub(1));
                }
                Err(_) => break,
            }
        }
    }
    // Then jogging through every stretch (issue 34, item 2): taken if it comes closer.
    if let Some(accel) = jog::accel(&samples, config).filter(|_| jogs) {
        let times_s: Vec<f64> = candidates
            .iter()
            .map(|&k| samples.times_ms[k] as f64 / 1000.0)
            .collect();
        let jog = |step_s: f64| {
            let plan = jog::Plan { accel, step_s };
            Writer::new(config, &all_limits, counts.first().copied().unwrap_or(0)).write_jog(
                &plan,
                (&samples, &candidates, &counts),
                track,
                budget_lines,
            )
        };
        // The shortest step that fits: from the estimate, longer while the lines are
        // over, then shorter while they fit (at most 12 tries).
        let mut step_s = jog::step_for(&counts, &times_s, room);
        let mut best: Option<QProgram> = None;
        let mut shorter = true;
        for _ in 0..12 {
            match jog(step_s) {
                Ok(jogged) => {
                    let closer = best.as_ref().is_none_or(|best| {
                        jogged.report.max_deviation_mm < best.report.max_deviation_mm
                    });
                    if closer {
                        best = Some(jogged);
                    }
                    if !shorter || step_s <= jog::MIN_STEP_S + 1e-9 {
                        break;
                    }
                    step_s = ((step_s - 0.01) * 100.0).round() / 100.0;
                }
                Err(QProgramError::TooManyLines { lines, .. }) => {
                    if best.is_some() {
                        break;
                    }
                    // Longer steps, for what was over and 5 % more.
                    shorter = false;
                    let longer = step_s * lines as f64 / room.max(1) as f64 * 1.05;
                    step_s = (longer * 100.0).ceil().max(step_s * 100.0 + 1.0) / 100.0;
                }
                Err(_) => break,
            }
        }
        if let Some(jogged) = best
            && jogged.report.max_deviation_mm < program.report.max_deviation_mm
        {
            program = jogged;
        }
    }
    within_tolerance(program, config)
}

/// `program`, or [`QProgramError::TooFar`] when it strays from the show more than the
/// tolerance.
fn within_tolerance(program: QProgram, config: &QProgramConfig) -> Result<QProgram, QProgramError> {
    if program.report.max_deviation_mm > config.tolerance_mm {
        return Err(QProgramError::TooFar {
            deviation_mm: program.report.max_deviation_mm,
            at_ms: program.report.at_ms,
            tolerance_mm: config.tolerance_mm,
        });
    }
    Ok(program)
}

/// Moves `path`'s edges to the acceleration of the move before them where that keeps
/// them within `threshold_mm` (an `AC` and a `DE` saved each time).
fn keep_accelerations(path: &mut [Edge], levels: &[(Limits, Vec<Vec<Edge>>)], threshold_mm: f64) {
    let mut level: Option<usize> = None;
    for edge in path.iter_mut() {
        if !matches!(edge.step, Step::Move { .. }) {
            continue;
        }
        if let Some(before) = level.filter(|&before| before != edge.level) {
            let same = levels.get(before).and_then(|(_, incoming)| {
                incoming
                    .get(edge.to)?
                    .iter()
                    .find(|other| other.from == edge.from && other.cost_mm <= threshold_mm)
            });
            if let Some(same) = same {
                *edge = *same;
            }
        }
        level = Some(edge.level);
    }
}

/// The set of edges (index into `sets`) whose path within `budget_lines` deviates
/// least, and that deviation (the first of equals: the highest acceleration).
fn best_set(sets: &[&[Vec<Edge>]], budget_lines: usize, count: Count) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for (index, incoming) in sets.iter().enumerate() {
        if let Some(deviation_mm) = reduce::bottleneck(incoming, budget_lines, count)
            && best.is_none_or(|(_, least)| deviation_mm < least)
        {
            best = Some((index, deviation_mm));
        }
    }
    best
}

/// Refuses settings the compiler cannot work with.
fn check(config: &QProgramConfig) -> Result<(), QProgramError> {
    let positive = |value: f64| value.is_finite() && value > 0.0;
    let refuse = |field, must| Err(QProgramError::InvalidConfig { field, must });
    if !positive(config.counts_per_mm) {
        return refuse("counts_per_mm", "a number above 0");
    }
    if config.steps_per_rev == 0 {
        return refuse("steps_per_rev", "above 0");
    }
    if !positive(config.max_speed_mm_s) {
        return refuse("max_speed_mm_s", "a number above 0");
    }
    if !positive(config.max_accel_mm_s2) {
        return refuse("max_accel_mm_s2", "a number above 0");
    }
    if config.tolerance_mm.is_nan() || config.tolerance_mm < 0.0 {
        return refuse("tolerance_mm", "a number, 0 or more");
    }
    Ok(())
}

/// A position in counts, within the drive's 32 bits.
fn to_counts(position_mm: f64, at_ms: u64, config: &QProgramConfig) -> Result<i64, QProgramError> {
    let counts = (position_mm * config.counts_per_mm).round();
    if counts.is_finite() && counts.abs() <= f64::from(i32::MAX) {
        Ok(counts as i64)
    } else {
        Err(QProgramError::OutOfRange { at_ms, position_mm })
    }
}

/// The accelerations tried, as `AC` writes them (rev/s²), highest first: the limit,
/// the limit / √2, / 2, … / 8√2, and the one that suits the show's typical move (a
/// third of the time accelerating, a third cruising, a third braking: 4.5 d / t², the
/// median over the moves between neighbouring candidates).
fn accelerations(
    samples: &Samples,
    candidates: &[usize],
    counts: &[i64],
    config: &QProgramConfig,
) -> Vec<Decimal> {
    let scale = config.counts_per_mm / f64::from(config.steps_per_rev);
    let max_rev_s2 = config.max_accel_mm_s2 * scale;
    let mut natural: Vec<f64> = candidates
        .windows(2)
        .zip(counts.windows(2))
        .filter(|(_, c)| c[0] != c[1])
        .map(|(k, c)| {
            let t_s = (samples.times_ms[k[1]] - samples.times_ms[k[0]]) as f64 / 1000.0;
            4.5 * (c[1] - c[0]).abs() as f64 / (t_s * t_s) / f64::from(config.steps_per_rev)
        })
        .collect();
    natural.sort_by(f64::total_cmp);
    let mut rev_s2: Vec<f64> = (0..8)
        .map(|halvings| max_rev_s2 / 2_f64.powf(f64::from(halvings) / 2.0))
        .collect();
    if let Some(&median) = natural.get(natural.len() / 2) {
        rev_s2.push(median.min(max_rev_s2));
    }
    let mut written: Vec<Decimal> = rev_s2
        .into_iter()
        .filter_map(|value| {
            // Whole steps of the drive, rounded down so the limit is never exceeded; at
            // least the smallest step, at most the largest.
            let steps = (value / units::ACCELERATION.step + 1e-9).floor() as i64;
            units::ACCELERATION
                .write(steps.clamp(units::ACCELERATION.min_steps, units::ACCELERATION.max_steps))
        })
        .collect();
    written.dedup();
    written
}

/// A move the program makes, for the deviation: it starts at `start_s` from `from`
/// (an `FP` trapezoid), or a piece of a jog (`profile`: where the drive is, in counts,
/// from `start_s` on, until the next one starts).
#[derive(Debug, Clone)]
struct Timed {
    start_s: f64,
    from_counts: i64,
    to_counts: i64,
    trapezoid: Trapezoid,
    profile: Option<Profile>,
}

/// Writes the chosen path as commands, keeping the drive's clock.
#[derive(Debug)]
struct Writer<'a> {
    config: &'a QProgramConfig,
    /// The accelerations an edge's `level` names.
    levels: &'a [Limits],
    /// The acceleration of the move being written.
    limits: Limits,
    /// The acceleration of the first move: the one segment 1 sets.
    first: Option<Limits>,
    /// The drive's clock: when the last command written ends, s.
    now_s: f64,
    /// Where the drive stands, counts.
    at_counts: i64,
    /// The last `VE` written.
    speed: Option<Decimal>,
    lines: Vec<Command>,
    timed: Vec<Timed>,
    keyframes: Vec<Keyframe>,
    /// `JA` and `JL` of a program that jogs ([`mod@jog`]), set in segment 1.
    jog_accel: Option<Decimal>,
    /// `MT1` (a program that jogs, so that `CJ` does not hold it): every `FP` is
    /// followed by `WM`.
    multitasking: bool,
    /// Streamed, not stored: no segments, any length ([`stream`]).
    streamed: bool,
}

impl<'a> Writer<'a> {
    fn new(config: &'a QProgramConfig, levels: &'a [Limits], start_counts: i64) -> Self {
        let limits = levels.first().copied().unwrap_or(Limits {
            accel_counts_s2: config.max_accel_mm_s2 * config.counts_per_mm,
            max_speed_counts_s: config.max_speed_mm_s * config.counts_per_mm,
            steps_per_rev: f64::from(config.steps_per_rev),
            counts_per_mm: config.counts_per_mm,
        });
        Self {
            config,
            levels,
            limits,
            first: None,
            now_s: 0.0,
            at_counts: start_counts,
            speed: None,
            lines: Vec::new(),
            timed: Vec::new(),
            keyframes: Vec::new(),
            jog_accel: None,
            multitasking: false,
            streamed: false,
        }
    }

    /// The acceleration of `level` for the next move: set by segment 1 for the first
    /// move, by `AC` and `DE` when it changes.
    fn accelerate(&mut self, level: usize) {
        let Some(&limits) = self.levels.get(level) else {
            return;
        };
        if self.first.is_none() {
            self.first = Some(limits);
        } else if limits.accel_counts_s2 != self.limits.accel_counts_s2
            && let Some(rev_s2) = accel_decimal(&limits)
        {
            self.lines.push(Command::Acceleration {
                rev_s2: Some(rev_s2),
            });
            self.lines.push(Command::Deceleration {
                rev_s2: Some(rev_s2),
            });
        }
        self.limits = limits;
    }

    /// `WT` for `seconds` in whole steps of the drive (the nearest), if that is any
    /// time; a wait longer than the largest `WT` is written as several.
    fn wait(&mut self, seconds: f64) {
        let mut steps = (seconds / units::WAIT.step).round() as i64;
        while steps >= 1 {
            let now = steps.min(units::WAIT.max_steps);
            let Some(s) = units::WAIT.write(now) else {
                return;
            };
            self.lines.push(Command::WaitTime { s });
            self.now_s += now as f64 * units::WAIT.step;
            steps -= now;
        }
    }

    /// The trapezoid the drive runs for `distance` counts at `VE` `speed` (as the drive
    /// holds it).
    fn trapezoid(&self, distance: f64, speed: Decimal) -> Trapezoid {
        Trapezoid {
            distance,
            speed: units::VELOCITY.held(speed).unwrap_or(0.0) * self.limits.steps_per_rev,
            accel: self.limits.accel_counts_s2,
            decel: self.limits.accel_counts_s2,
        }
    }

    /// `DI`, `VE` (if it changed) and `FP` to `to_counts` at `speed`.
    fn feed(&mut self, to_counts: i64, speed: Decimal, at_ms: u64) -> Result<(), QProgramError> {
        let distance = (to_counts - self.at_counts).abs() as f64;
        let trapezoid = self.trapezoid(distance, speed);
        let counts = i32::try_from(to_counts).map_err(|_| QProgramError::OutOfRange {
            at_ms,
            position_mm: to_counts as f64 / self.config.counts_per_mm,
        })?;
        self.lines.push(Command::Distance {
            counts: Some(counts),
        });
        if self.speed != Some(speed) {
            self.lines.push(Command::Velocity { rev_s: Some(speed) });
            self.speed = Some(speed);
        }
        self.lines.push(Command::FeedToPosition);
        if self.multitasking {
            // With `MT1` an `FP` does not hold the program (HCR p. 183): wait for it.
            self.lines.push(Command::WaitOnMove);
        }
        self.timed.push(Timed {
            start_s: self.now_s,
            from_counts: self.at_counts,
            to_counts,
            trapezoid,
            profile: None,
        });
        self.now_s += trapezoid.duration_s();
        self.at_counts = to_counts;
        Ok(())
    }

    /// The move to `to_counts` ending at `target_ms`, `then_wait` if it is slow;
    /// `ideal_s` is its time from keyframe to keyframe.
    fn feed_by(
        &mut self,
        to_counts: i64,
        target_ms: u64,
        ideal_s: f64,
        then_wait: bool,
    ) -> Result<(), QProgramError> {
        let too_fast = QProgramError::TooFast {
            at_ms: target_ms,
            max_speed_mm_s: self.config.max_speed_mm_s,
            max_accel_mm_s2: self.config.max_accel_mm_s2,
        };
        let target_s = target_ms as f64 / 1000.0;
        let distance = (to_counts - self.at_counts).abs() as f64;
        let duration_s = target_s - self.now_s;
        let speed = solve_speed(distance, duration_s, self.limits.accel_counts_s2)
            .ok_or(too_fast.clone())?;
        // In the drive's steps: at least the smallest `VE`.
        let exact = speed / self.limits.steps_per_rev / units::VELOCITY.step;
        let min = units::VELOCITY.min_steps;
        let up = units::VELOCITY
            .write((exact.ceil() as i64).max(min))
            .ok_or(too_fast)?;
        let down = units::VELOCITY
            .write((exact.floor() as i64).max(min))
            .unwrap_or(up);
        // How far off its time the move ends at `speed`, and whether that is within
        // the window: at most `KEEP_SPEED_S` early, `LATE_S` late.
        let late = |speed: Decimal| self.trapezoid(distance, speed).duration_s() - duration_s;
        let off = |speed: Decimal| {
            let late = late(speed);
            if (-KEEP_SPEED_S..=LATE_S).contains(&late) {
                0.0
            } else {
                late.abs()
            }
        };
        // The step within the window, else the nearer; of two within it, the nearer.
        let key = |speed: Decimal| (off(speed), late(speed).abs());
        let mut closer = if key(down) < key(up) { down } else { up };
        // The speed of the keyframe-to-keyframe move, if it ends this one close enough
        // (when the last move kept an earlier speed and ended a little off, taking
        // that back in this one's speed would make the next need a new one again) …
        let ideal = solve_speed(distance, ideal_s, self.limits.accel_counts_s2).and_then(|speed| {
            let exact = speed / self.limits.steps_per_rev / units::VELOCITY.step;
            units::VELOCITY.write((exact.round() as i64).max(min))
        });
        if let Some(ideal) = ideal.filter(|&ideal| off(ideal) == 0.0) {
            closer = ideal;
        }
        // … and better, the `VE` already set: a line saved.
        if let Some(previous) = self.speed.filter(|&previous| off(previous) == 0.0) {
            closer = previous;
        }
        if then_wait || off(closer) > 0.0 {
            self.feed(to_counts, up, target_ms)?;
            self.keyframes.push(Keyframe {
                time_ms: target_ms,
                position_mm: to_counts as f64 / self.config.counts_per_mm,
            });
            self.wait(target_s - self.now_s);
        } else {
            self.feed(to_counts, closer, target_ms)?;
            self.keyframes.push(Keyframe {
                time_ms: target_ms,
                position_mm: to_counts as f64 / self.config.counts_per_mm,
            });
        }
        Ok(())
    }

    /// The whole program.
    fn write(
        mut self,
        path: &[Edge],
        samples: &Samples,
        candidates: &[usize],
        counts: &[i64],
        track: &Track,
        budget_lines: usize,
    ) -> Result<QProgram, QProgramError> {
        let start_counts = self.at_counts;
        for edge in path {
            let target_ms = samples.times_ms[candidates[edge.to]];
            match edge.step {
                Step::Wait { .. } => self.wait(target_ms as f64 / 1000.0 - self.now_s),
                Step::Move { then_wait, .. } => {
                    self.accelerate(edge.level);
                    let from_ms = samples.times_ms[candidates[edge.from]];
                    let ideal_s = (target_ms - from_ms) as f64 / 1000.0;
                    self.feed_by(counts[edge.to], target_ms, ideal_s, then_wait)?;
                }
            }
        }
        self.finish(samples, track, budget_lines, start_counts)
    }

    /// What follows the moves: the deviation, the loop, the layout and the report.
    fn finish(
        mut self,
        samples: &Samples,
        track: &Track,
        budget_lines: usize,
        start_counts: i64,
    ) -> Result<QProgram, QProgramError> {
        let (max_deviation_mm, at_ms) = self.deviation(samples);
        // A loop goes back past segment 1's `AC` and `DE`: the first move's
        // acceleration is set again before the show repeats.
        if self.config.loop_show
            && let Some(first) = self.first
            && first.accel_counts_s2 != self.limits.accel_counts_s2
        {
            let level = self
                .levels
                .iter()
                .position(|limits| limits.accel_counts_s2 == first.accel_counts_s2);
            if let Some(level) = level {
                self.accelerate(level);
            }
        }
        if self.config.loop_show && self.at_counts != start_counts {
            // Home stretch: back to the start at the speed limit, before `QG`.
            let top =
                self.limits.max_speed_counts_s / self.limits.steps_per_rev / units::VELOCITY.step;
            let top =
                (top.floor() as i64).clamp(units::VELOCITY.min_steps, units::VELOCITY.max_steps);
            let speed = units::VELOCITY
                .write(top)
                .ok_or(QProgramError::OutOfRange {
                    at_ms: track.duration_ms(),
                    position_mm: track.start_mm,
                })?;
            let end_ms = (self.now_s * 1000.0).round() as u64;
            self.feed(start_counts, speed, end_ms)?;
            self.keyframes.push(Keyframe {
                time_ms: (self.now_s * 1000.0).round() as u64,
                position_mm: start_counts as f64 / self.config.counts_per_mm,
            });
        }
        if !self.streamed && self.lines.len() > budget_lines {
            return Err(QProgramError::TooManyLines {
                lines: self.lines.len(),
                limit: budget_lines,
            });
        }
        let segments = if self.streamed {
            // Streamed into the command buffer: one list, no segments, no calls.
            let mut all = self.setup();
            all.extend_from_slice(&self.lines);
            one(all)
        } else {
            self.layout()?
        };
        let lines = segments.iter().map(|(_, commands)| commands.len()).sum();
        let moves = self.keyframes.len();
        Ok(QProgram {
            streamed: self.streamed,
            segments,
            keyframes: self.keyframes,
            report: Reduction {
                track_rows: track.rows.len(),
                moves,
                lines,
                max_deviation_mm,
                at_ms,
            },
        })
    }

    /// The largest |show − program| over the show's grid, and when (ms).
    fn deviation(&self, samples: &Samples) -> (f64, u64) {
        let per_mm = self.config.counts_per_mm;
        let start_counts = self
            .timed
            .first()
            .map_or(self.at_counts, |timed| timed.from_counts);
        let mut next = 0;
        let mut worst = (0.0, 0);
        for (&t_ms, &show_mm) in samples.times_ms.iter().zip(&samples.positions_mm) {
            let t_s = t_ms as f64 / 1000.0;
            while next < self.timed.len() && self.timed[next].start_s <= t_s {
                next += 1;
            }
            let program_counts = match next.checked_sub(1).map(|index| &self.timed[index]) {
                None => start_counts as f64,
                Some(Timed {
                    start_s,
                    profile: Some(profile),
                    ..
                }) => profile.at(t_s - start_s).0,
                Some(timed) => {
                    let sign = if timed.to_counts >= timed.from_counts {
                        1.0
                    } else {
                        -1.0
                    };
                    timed.from_counts as f64 + sign * timed.trapezoid.travelled(t_s - timed.start_s)
                }
            };
            let off = (show_mm - program_counts / per_mm).abs();
            if off > worst.0 {
                worst = (off, t_ms);
            }
        }
        worst
    }

    /// The setup lines of segment 1.
    fn setup(&self) -> Vec<Command> {
        let mut setup = Vec::new();
        if let Some((input, condition)) = self.config.start {
            setup.push(Command::WaitForInput { input, condition });
        }
        setup.push(Command::Multitasking {
            on: Some(self.multitasking),
        });
        if let Some(rev_s2) = accel_decimal(&self.first.unwrap_or(self.limits)) {
            setup.push(Command::Acceleration {
                rev_s2: Some(rev_s2),
            });
            setup.push(Command::Deceleration {
                rev_s2: Some(rev_s2),
            });
        }
        if let Some(rev_s2) = self.jog_accel {
            setup.push(Command::JogAcceleration {
                rev_s2: Some(rev_s2),
            });
            setup.push(Command::JogDeceleration {
                rev_s2: Some(rev_s2),
            });
        }
        setup
    }

    /// The segments: all in segment 1 if they fit, else the moves in 2..=12.
    fn layout(&self) -> Result<Vec<(Segment, Vec<Command>)>, QProgramError> {
        let mut main = self.setup();
        let looping = self.config.loop_show && !self.lines.is_empty();
        let first_line = main.len() + 1;
        let too_many = QProgramError::TooManyLines {
            lines: main.len() + self.lines.len(),
            limit: SEGMENT_LINES + MOVE_LINES,
        };
        let goto = |line: usize| {
            u8::try_from(line)
                .ok()
                .and_then(QLine::new)
                .map(|line| Command::QueueGoto { line })
        };
        if main.len() + self.lines.len() + usize::from(looping) <= SEGMENT_LINES {
            main.extend_from_slice(&self.lines);
            if looping {
                main.push(goto(first_line).ok_or(too_many)?);
            }
            return Ok(one(main));
        }
        let mut segments = Vec::new();
        for (index, chunk) in self.lines.chunks(SEGMENT_LINES - 1).enumerate() {
            let segment = u8::try_from(index + 2)
                .ok()
                .and_then(Segment::new)
                .ok_or(too_many.clone())?;
            let mut commands = chunk.to_vec();
            commands.push(Command::QueueCall { segment: None });
            main.push(Command::QueueCall {
                segment: Some(segment),
            });
            segments.push((segment, commands));
        }
        if looping {
            main.push(goto(first_line).ok_or(too_many.clone())?);
        }
        if main.len() > SEGMENT_LINES {
            return Err(too_many);
        }
        let mut all = one(main);
        all.extend(segments);
        Ok(all)
    }
}

/// `AC` (and `DE`) for an acceleration (a whole number of the drive's steps), rev/s².
fn accel_decimal(limits: &Limits) -> Option<Decimal> {
    let per_rev = limits.accel_counts_s2 / limits.steps_per_rev;
    units::ACCELERATION.write((per_rev / units::ACCELERATION.step).round() as i64)
}

/// Segment 1 alone.
fn one(main: Vec<Command>) -> Vec<(Segment, Vec<Command>)> {
    Segment::new(1)
        .map(|segment| (segment, main))
        .into_iter()
        .collect()
}
