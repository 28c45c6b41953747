//! Shows a drive cannot store: **streamed**. A drive holds 12 segments of 62 lines
//! (HCR p. 213–217); a 10-minute smooth show jogged every 50 ms needs thousands. The
//! same buffered commands a stored program would hold (the jog of [`super::jog`] at
//! its shortest step, [`super::jog::MIN_STEP_S`]) go instead, as the show plays, into
//! the drive's command buffer of 63 places (HCR p. 53, `BS`), which the bridge keeps
//! topped up; every drive is paused first (`PS`, HCR p. 206), its buffer filled, and
//! the show starts when it continues (`CT`, p. 72) — or, with a trigger, at the edge
//! its first line waits for.
//!
//! [`compile_for_drive`] chooses: a stored program when it fits within the tolerance,
//! else (or [`Streaming::Always`]) the stream.

use super::jog::{self, MIN_STEP_S};
use super::reduce::Limits;
use super::{
    QProgram, QProgramConfig, QProgramError, Writer, check, keyframes, to_counts, within_tolerance,
};
use crate::scl::units;
use crate::show::Track;

/// The step of a streamed jog, s: the shortest a stored program may have.
pub const STREAM_STEP_S: f64 = MIN_STEP_S;

/// When a ball's show is streamed rather than stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Streaming {
    /// Never: the programs are stored (loaded by hand with Q Programmer).
    Never,
    /// When no stored program comes within the tolerance (or fits at all).
    WhenNeeded,
    /// Always (`programs = "stream"`).
    Always,
}

/// A track jogged at the shortest step, as one list of buffered commands of any
/// length (segment 1 holds them all; [`QProgram::streamed`] is set). Its report is
/// measured as a stored program's is.
///
/// # Errors
/// As [`super::compile`]: a bad configuration or position, a move too fast for the
/// limits, or a deviation over the tolerance.
pub fn compile_streamed(track: &Track, config: &QProgramConfig) -> Result<QProgram, QProgramError> {
    check(config)?;
    // The buffer runs the show once: the playlist repeats it, not a `QG`.
    let config = QProgramConfig {
        loop_show: false,
        ..*config
    };
    let samples = keyframes::sample(track);
    let candidates = keyframes::candidates(&samples);
    let counts = candidates
        .iter()
        .map(|&k| to_counts(samples.positions_mm[k], samples.times_ms[k], &config))
        .collect::<Result<Vec<_>, _>>()?;
    let start_counts = counts.first().copied().unwrap_or(0);
    // Moves from rest to rest (a stretch too short to jog, the exact feed after each
    // jog) at the top acceleration, in whole steps as a drive holds it.
    let steps_per_rev = f64::from(config.steps_per_rev);
    let accel_rev_s2 = config.max_accel_mm_s2 * config.counts_per_mm / steps_per_rev;
    let accel_steps = ((accel_rev_s2 / units::ACCELERATION.step + 1e-9).floor() as i64)
        .clamp(units::ACCELERATION.min_steps, units::ACCELERATION.max_steps);
    let levels = [Limits {
        accel_counts_s2: accel_steps as f64 * units::ACCELERATION.step * steps_per_rev,
        max_speed_counts_s: config.max_speed_mm_s * config.counts_per_mm,
        steps_per_rev,
        counts_per_mm: config.counts_per_mm,
    }];
    let mut writer = Writer::new(&config, &levels, start_counts);
    writer.streamed = true;
    let program = match jog::accel(&samples, &config) {
        Some(accel) => {
            let plan = jog::Plan {
                accel,
                step_s: MIN_STEP_S,
            };
            writer.write_jog(&plan, (&samples, &candidates, &counts), track, usize::MAX)?
        }
        None => {
            return Err(QProgramError::InvalidConfig {
                field: "max_accel_mm_s2",
                must: "at least one step of a drive's acceleration",
            });
        }
    };
    within_tolerance(program, &config)
}

/// A ball's program for a drive: stored when it fits within the tolerance, else
/// streamed, as `streaming` allows.
///
/// # Errors
/// Why neither a stored nor (where allowed) a streamed program follows the show
/// within the tolerance: the stream's reason when it was tried.
pub fn compile_for_drive(
    track: &Track,
    config: &QProgramConfig,
    streaming: Streaming,
) -> Result<QProgram, QProgramError> {
    match streaming {
        Streaming::Never => super::compile(track, config),
        Streaming::Always => compile_streamed(track, config),
        Streaming::WhenNeeded => match super::compile(track, config) {
            Err(QProgramError::TooFar { .. } | QProgramError::TooManyLines { .. }) => {
                compile_streamed(track, config)
            }
            other => other,
        },
    }
}
