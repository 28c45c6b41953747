//! Timecode chase (issue 37, item 3; `docs/show-control.md`): the playlist kept in
//! step with Art-Net or MIDI timecode, off unless `[timecode] source` is given
//! ([`crate::config::TimecodeConfig`]).
//!
//! One task owns the chase ([`floatball_shared::timecode::chase::Chase`], sans-IO):
//! it takes the timecode from its receiver ([`receive`]: Art-Net on a UDP socket, MTC
//! from a raw MIDI device on a thread), the player's status from its watch, and asks
//! the chase every [`POLL`] what to do. The chase's actions are issued ONLY through
//! [`control::issue_unless_latched`] — a Start as `Control::Start` at an entry and a
//! time, a locate as `Control::Locate` (the show under way ends without an e-stop,
//! the balls go from where they are to the new point and play on from there), a stop
//! on loss as `Control::Home` — so the chase is refused while an e-stop
//! is latched and can never release one. A refusal is logged (once, until the show
//! plays) and the chase tries again a second later, backing off (doubling, up to
//! 30 s) while the same action is refused again (`Chase::refused`).
//!
//! Before a cue is due the chase asks for its lead, which [`lead::estimate_ms`]
//! estimates from the plan (approach and load); measured leads correct it.
//!
//! The cues (where each entry sits on the timecode) are read from the stored playlist
//! — each entry's `timecode_start`, or the layout from `[timecode] start` — and
//! read again every [`CUES_EVERY`], so a playlist edited meanwhile is chased as
//! stored.
//!
//! While chasing, and unless `[timecode] correct_drift = false`, the chase hands the
//! player its clock trim every [`TRIM_EVERY`] (`Playback::trim_clock`: the instant
//! the timecode puts the show's time 0 at): MBOX frames then follow the timecode
//! exactly, UIM2503 rows not yet sent absorb at most ±1 ms each, MOONS' drives cannot
//! be trimmed (only relocated).
//!
//! The chase's status ([`TimecodeStatus`]: the timecode, the offset of the show from
//! it, the state, the leads, the drift) is published to the app clients
//! ([`AppState::publish_timecode`], sent as `ServerMessage::Timecode`) at most
//! [`PUBLISH_PER_S`] times a second.

pub mod lead;
pub mod receive;

use std::sync::Arc;
use std::time::Duration;

use floatball_shared::api::{PlayerState, StartFrom, Status};
use floatball_shared::timecode::chase::cues as lay_out;
use floatball_shared::timecode::chase::{Action, Chase, CueEntry, PlayerView, TimecodeStatus};
use tokio::net::UdpSocket;
use tokio::sync::mpsc;
use tokio::time::Instant;

use crate::config::{TimecodeConfig, TimecodeSource};
use crate::control::{self, Control};
use crate::state::AppState;
use receive::Sample;

/// How often the chase is asked what to do.
pub const POLL: Duration = Duration::from_millis(10);

/// How often the cues are read again from the stored playlist.
pub const CUES_EVERY: Duration = Duration::from_secs(1);

/// How often the chase hands its clock trim to the player while chasing
/// (`[timecode] correct_drift`).
pub const TRIM_EVERY: Duration = Duration::from_millis(50);

/// Most status publications a second.
pub const PUBLISH_PER_S: u32 = 10;

/// The samples waiting for the chase task, at most.
const SAMPLES_QUEUED: usize = 64;

/// Binds the Art-Net socket when `config` takes Art-Net (before the bridge starts,
/// so that a port in use stops the start with its reason).
///
/// # Errors
/// The address cannot be bound.
pub fn bind(config: &TimecodeConfig) -> std::io::Result<Option<UdpSocket>> {
    match &config.source {
        TimecodeSource::ArtNet(listen) => receive::bind_artnet(*listen).map(Some),
        TimecodeSource::Mtc(_) => Ok(None),
    }
}

/// Runs the chase for `state` as `config` says, its Art-Net `socket` bound already
/// ([`bind`]), what is not timecode on it handed to `live` (live input sharing the
/// socket, [`crate::live`]); ends when the bridge stops. Must run inside the async
/// runtime.
pub fn spawn(
    state: AppState,
    config: TimecodeConfig,
    socket: Option<Arc<UdpSocket>>,
    live: Option<crate::live::Feed>,
) {
    let (samples, received) = mpsc::channel(SAMPLES_QUEUED);
    match (&config.source, socket) {
        (TimecodeSource::ArtNet(_), Some(socket)) => {
            tokio::spawn(receive::artnet(socket, samples, live, state.stopping()));
        }
        (TimecodeSource::Mtc(device), _) => receive::spawn_mtc(device.clone(), samples),
        (TimecodeSource::ArtNet(listen), None) => {
            tracing::error!("timecode: no Art-Net socket on {listen}: the chase is off");
            return;
        }
    }
    tokio::spawn(chase(state, config, received));
}

/// The cues of the stored playlist: each entry's own timecode start or the layout
/// from the playlist's; an entry whose show is not stored ends the layout there.
pub fn cues(
    state: &AppState,
    config: &TimecodeConfig,
) -> Vec<floatball_shared::timecode::chase::Cue> {
    let playlist = state.playlist().get();
    let shows = state.shows().list();
    let entries: Vec<CueEntry> = playlist
        .entries
        .iter()
        .map(|entry| CueEntry {
            start_ms: entry
                .timecode_start
                .as_deref()
                .and_then(|start| config.start_of(start)),
            delay_ms: entry.delay_ms,
            duration_ms: shows
                .iter()
                .find(|show| show.name == entry.show)
                .map_or(0, |show| show.duration_ms),
            cycles: entry.cycles,
        })
        .collect();
    lay_out(&entries, config.start_ms)
}

/// The player as the chase sees it.
fn view(status: &Status) -> PlayerView {
    match (status.state, status.entry) {
        (PlayerState::Playing, Some(entry)) => PlayerView::Playing {
            entry,
            show_time_ms: status.show_time_ms,
        },
        (PlayerState::Idle | PlayerState::Stopped | PlayerState::Error, _) => PlayerView::Idle,
        _ => PlayerView::Busy,
    }
}

/// The chase task: owns the chase until the bridge stops.
async fn chase(
    state: AppState,
    config: TimecodeConfig,
    mut samples: mpsc::Receiver<(Sample, Instant)>,
) {
    let epoch = Instant::now();
    let ms = |at: Instant| u64::try_from(at.duration_since(epoch).as_millis()).unwrap_or(u64::MAX);
    let mut chase = Chase::new(config.chase, config.source.name(), cues(&state, &config));
    let mut status = state.subscribe_status();
    let mut stopping = state.stopping();
    let mut poll = tokio::time::interval(POLL);
    poll.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let (results, mut outcomes) = mpsc::channel::<Option<String>>(8);
    let mut cues_read = Instant::now();
    let mut published = Instant::now() - Duration::from_secs(1);
    let mut last_refusal: Option<String> = None;
    let mut warned_rate = false;
    let mut trimmed = Instant::now();
    let (estimates_tx, mut estimates) = mpsc::channel::<((usize, u64), Option<(u64, u64)>)>(4);
    let mut estimating = None;
    chase.player(view(&status.borrow_and_update()), 0);
    state.publish_timecode(chase.status(0));
    loop {
        tokio::select! {
            _ = stopping.changed() => return,
            sample = samples.recv() => {
                let Some((sample, at)) = sample else { return };
                let (Sample::Running(timecode) | Sample::Parked(timecode)) = sample;
                if timecode.rate != config.rate && !warned_rate {
                    warned_rate = true;
                    tracing::warn!(
                        "timecode: {} fps arrives, [timecode] rate says {} (chased all the same)",
                        timecode.rate, config.rate
                    );
                }
                match sample {
                    Sample::Running(timecode) => chase.timecode(timecode, ms(at)),
                    Sample::Parked(timecode) => chase.locate_to(timecode, ms(at)),
                }
            }
            changed = status.changed() => {
                if changed.is_err() {
                    return;
                }
                let seen = view(&status.borrow_and_update());
                if matches!(seen, PlayerView::Playing { .. }) {
                    // Played: the next refusal is logged even if it is the last one's.
                    last_refusal = None;
                }
                chase.player(seen, ms(Instant::now()));
            }
            Some(((entry, time_ms), estimate)) = estimates.recv() => {
                estimating = None;
                if let Some((lead_ms, locate_ms)) = estimate {
                    tracing::info!(
                        "timecode: entry {}'s lead estimated at {lead_ms} ms (a locate's {locate_ms} ms)",
                        entry + 1
                    );
                }
                let configured = (config.chase.lead_ms, config.chase.lead_ms);
                let (lead_ms, locate_ms) = estimate.unwrap_or(configured);
                chase.set_lead_estimate(entry, time_ms, lead_ms, locate_ms);
            }
            outcome = outcomes.recv() => {
                if let Some(Some(why)) = outcome {
                    note_refusal(&mut chase, &mut last_refusal, why, ms(Instant::now()));
                }
            }
            _ = poll.tick() => {
                let now = Instant::now();
                if now.duration_since(cues_read) >= CUES_EVERY {
                    cues_read = now;
                    let fresh = cues(&state, &config);
                    if fresh != chase.cues() {
                        chase.set_cues(fresh);
                    }
                }
                if let Some(wanted) = chase.lead_wanted(ms(now))
                    && estimating != Some(wanted)
                {
                    // Reads the show (on a blocking thread): once a cue, and again after
                    // a jump.
                    estimating = Some(wanted);
                    chase.estimating(ms(now));
                    let (state, estimates) = (state.clone(), estimates_tx.clone());
                    tokio::task::spawn_blocking(move || {
                        let (entry, time_ms) = wanted;
                        let _ = estimates.try_send((wanted, lead::estimate_ms(&state, entry, time_ms)));
                    });
                }
                if let Some(action) = chase.poll(ms(now)) {
                    issue(&state, &mut chase, &mut last_refusal, action, &results, ms(now));
                }
                if config.correct_drift && now.duration_since(trimmed) >= TRIM_EVERY {
                    trimmed = now;
                    // (The show's time 0 may lie before the chase began: a show
                    // located into.)
                    if let Some((entry, start_ms)) = chase.trim(ms(now))
                        && let Some(show_start) = if start_ms >= 0 {
                            epoch.into_std().checked_add(Duration::from_millis(start_ms.unsigned_abs()))
                        } else {
                            epoch.into_std().checked_sub(Duration::from_millis(start_ms.unsigned_abs()))
                        }
                    {
                        state.playback().trim_clock(entry, show_start);
                    }
                }
                if now.duration_since(published) >= Duration::from_secs(1) / PUBLISH_PER_S {
                    published = now;
                    state.publish_timecode(chase.status(ms(now)));
                }
            }
        }
    }
}

/// Issues `action` through [`control::issue_unless_latched`]; its outcome comes back
/// on `results` (`Some(why)` when refused).
fn issue(
    state: &AppState,
    chase: &mut Chase,
    last_refusal: &mut Option<String>,
    action: Action,
    results: &mpsc::Sender<Option<String>>,
    now_ms: u64,
) {
    let control = match action {
        Action::Start { entry, time_ms } => Control::Start(StartFrom {
            entry: Some(entry + 1),
            time_ms: Some(time_ms),
        }),
        Action::Locate { entry, time_ms } => Control::Locate(StartFrom {
            entry: Some(entry + 1),
            time_ms: Some(time_ms),
        }),
        Action::Stop => Control::Home,
    };
    match control::issue_unless_latched(state, control) {
        Err(not_issued) => note_refusal(chase, last_refusal, not_issued.to_string(), now_ms),
        Ok(run) => {
            tracing::info!("timecode: {action:?}");
            let results = results.clone();
            tokio::spawn(async move {
                let outcome = run.await.err().map(control::reason);
                let _ = results.send(outcome).await;
            });
        }
    }
}

/// Tells the chase its action was refused; logs the reason when it is not the last
/// one's (a refusal repeated every retry is logged once until the show plays).
fn note_refusal(chase: &mut Chase, last: &mut Option<String>, why: String, now_ms: u64) {
    if last.as_deref() != Some(why.as_str()) {
        tracing::warn!("timecode: refused: {why}");
    }
    *last = Some(why.clone());
    chase.refused(why, now_ms);
}

/// The chase's status now (for tests that read it without a WebSocket).
pub fn snapshot(state: &AppState) -> Option<TimecodeStatus> {
    state.subscribe_timecode().borrow().clone()
}
