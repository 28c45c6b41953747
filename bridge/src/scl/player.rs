//! The player of an SCL installation: a playlist run as Q programs on the drives.
//!
//! **Which way shows play, and why.** Start plays each show from **Q programs stored
//! on the drives**, not by streaming moves: a drive runs its program on its own clock
//! and the bridge's only timing-critical act is the common start, so neither a busy
//! RS-485 line at 9600 baud (27 drives share ~960 bytes/s: one `FP` each per ~0.15 s
//! at best) nor a lost datagram can bend the show; the drives play it as compiled,
//! and the compiler's report says how far that is from the show.
//!
//! For every entry (after its delay) and cycle:
//! 1. **approach**: every drive to its track's start position (`VE AC DE DI FP` at
//!    the installation's approach speed), then wait until every `IP` is there;
//! 2. **load** (first cycle, `programs = "upload"`): compile each ball's track
//!    ([`floatball_shared::scl::qprogram::compile`], every core at once), write every segment (`QW`) and
//!    read it back (`QU`); with `programs = "stored"` the drives' own programs run;
//! 3. **start**: `QX1` to every drive, then the trigger output low and high again
//!    after 100 ms when a trigger is configured ([`super::program::fire`]);
//! 4. **play** until the show's duration has passed and no drive runs its program.
//!
//! Home moves every drive to the installation's home position; Reset homes, then
//! plays. The task running this reports each phase to the playback task
//! ([`Progress`]), which alone owns the status; an e-stop voids every request of the
//! run (the generation), and the playback task ends the run.

use std::sync::Arc;
use std::time::{Duration, Instant};

use floatball_shared::plan::Installation;
use floatball_shared::plan::player::Entry;
use floatball_shared::scl::qprogram::QProgram;
use tokio::sync::mpsc;

use super::SclNet;
use super::program::{
    compile_every_ball, drives_of, fire, move_all, qprogram_config, upload, wait_ended,
    wait_positions,
};
use crate::config::{SclConfig, SclPrograms};

/// Where a run is, for the status.
#[derive(Debug, Clone, PartialEq)]
pub enum Progress {
    /// Every drive is on its way home.
    Homing,
    /// Waiting for an entry's delay.
    Waiting {
        /// The entry (0-based).
        entry: usize,
        /// Its show.
        show: String,
    },
    /// Every drive is on its way to the show's first position.
    Approaching {
        /// The entry (0-based).
        entry: usize,
        /// Its show.
        show: String,
        /// The cycle (1-based).
        cycle: u32,
    },
    /// Programs are being written: `done` of `drives`.
    Loading {
        /// The entry (0-based).
        entry: usize,
        /// Drives whose programs are written.
        done: usize,
        /// Drives.
        drives: usize,
    },
    /// The show runs since `started`.
    Playing {
        /// The entry (0-based).
        entry: usize,
        /// Its show.
        show: String,
        /// The cycle (1-based).
        cycle: u32,
        /// When the start was fired.
        started: Instant,
        /// The show's length.
        duration_ms: u64,
    },
    /// The playlist ended (or Home arrived): idle.
    Done,
    /// The run failed; the drives were stopped.
    Failed(String),
}

/// What one run does.
#[derive(Debug, Clone)]
pub struct Run {
    /// The playlist (empty: Home).
    pub entries: Vec<Entry>,
    /// Play it again from the start when it ends.
    pub loop_playlist: bool,
    /// Home first.
    pub home_first: bool,
}

/// The show's positions in counts at time 0 of every track.
fn start_counts(installation: &Installation, entry: &Entry) -> Vec<i32> {
    entry
        .show
        .tracks
        .iter()
        .map(|track| counts(installation, track.start_mm))
        .collect()
}

fn counts(installation: &Installation, position_mm: f64) -> i32 {
    let counts = (position_mm * installation.counts_per_mm).round();
    counts.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32
}

/// How long a move across the whole travel may take at the approach speed, and some.
fn travel_limit(installation: &Installation) -> Duration {
    let speed = installation.approach_speed_mm_s.max(1.0);
    Duration::from_secs_f64(installation.limits.travel_mm / speed + 5.0)
}

/// Compiles every ball's track of `entry`, on a blocking thread.
async fn compile_all(
    installation: &Installation,
    scl: &SclConfig,
    entry_index: usize,
    entry: &Entry,
) -> Result<Vec<QProgram>, String> {
    let config = qprogram_config(installation, scl);
    let show = entry.show.clone();
    tokio::task::spawn_blocking(move || {
        compile_every_ball(&show, &config)
            .into_iter()
            .enumerate()
            .map(|(ball, program)| {
                program.map_err(|error| {
                    format!(
                        "entry {} (\"{}\"), ball u{}: {error}",
                        entry_index + 1,
                        show.name,
                        ball
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()
    })
    .await
    .map_err(|_| "the compiler stopped".to_owned())?
}

/// Homes every drive.
async fn home(
    net: &SclNet,
    installation: &Installation,
    scl: &SclConfig,
    generation: u64,
    progress: &mpsc::UnboundedSender<Progress>,
) -> Result<(), String> {
    let _ = progress.send(Progress::Homing);
    let home = vec![counts(installation, installation.home_mm); installation.units.len()];
    move_all(
        net,
        installation,
        scl,
        &home,
        installation.approach_speed_mm_s,
        generation,
    )
    .await?;
    wait_positions(
        net,
        installation,
        &home,
        travel_limit(installation),
        generation,
    )
    .await
}

/// Carries out `run` at e-stop `generation`, reporting to `progress`; ends with
/// [`Progress::Done`] or [`Progress::Failed`].
pub async fn run(
    net: SclNet,
    installation: Arc<Installation>,
    scl: Arc<SclConfig>,
    run: Run,
    generation: u64,
    progress: mpsc::UnboundedSender<Progress>,
) {
    let result = play(&net, &installation, &scl, &run, generation, &progress).await;
    let _ = progress.send(match result {
        Ok(()) => Progress::Done,
        Err(reason) => Progress::Failed(reason),
    });
}

async fn play(
    net: &SclNet,
    installation: &Installation,
    scl: &SclConfig,
    run: &Run,
    generation: u64,
    progress: &mpsc::UnboundedSender<Progress>,
) -> Result<(), String> {
    if run.home_first || run.entries.is_empty() {
        home(net, installation, scl, generation, progress).await?;
    }
    let drives = drives_of(installation);
    loop {
        for (index, entry) in run.entries.iter().enumerate() {
            let show = entry.show.name.clone();
            if entry.delay_ms > 0 {
                let _ = progress.send(Progress::Waiting {
                    entry: index,
                    show: show.clone(),
                });
                tokio::time::sleep(Duration::from_millis(entry.delay_ms)).await;
            }
            let programs = match scl.programs {
                SclPrograms::Upload => Some(compile_all(installation, scl, index, entry).await?),
                SclPrograms::Stored => None,
            };
            let start = start_counts(installation, entry);
            for cycle in 1..=entry.cycles.max(1) {
                let _ = progress.send(Progress::Approaching {
                    entry: index,
                    show: show.clone(),
                    cycle,
                });
                move_all(
                    net,
                    installation,
                    scl,
                    &start,
                    installation.approach_speed_mm_s,
                    generation,
                )
                .await?;
                wait_positions(
                    net,
                    installation,
                    &start,
                    travel_limit(installation),
                    generation,
                )
                .await?;
                if let Some(programs) = programs.as_ref().filter(|_| cycle == 1) {
                    for (done, (drive, program)) in drives.iter().zip(programs).enumerate() {
                        let _ = progress.send(Progress::Loading {
                            entry: index,
                            done,
                            drives: drives.len(),
                        });
                        upload(net, *drive, &program.segments, generation).await?;
                    }
                }
                let started = fire(net, installation, scl, generation).await?;
                let duration_ms = entry.show.duration_ms();
                let _ = progress.send(Progress::Playing {
                    entry: index,
                    show: show.clone(),
                    cycle,
                    started,
                    duration_ms,
                });
                tokio::time::sleep_until((started + Duration::from_millis(duration_ms)).into())
                    .await;
                let limit = Instant::now() + Duration::from_secs(10);
                wait_ended(net, installation, limit, generation).await?;
            }
        }
        if !run.loop_playlist || run.entries.is_empty() {
            return Ok(());
        }
    }
}
