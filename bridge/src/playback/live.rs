//! Live mode in the playback task (issue 38, `docs/live.md`): the operator's Go live,
//! Leave live, Record and Stop recording as requests to the one task that owns the
//! sequencer, and the live input fed to the sequencer each live period.
//!
//! **Only the operator goes live.** [`Playback::live_mode`] is a request like Start:
//! the task refuses it while the e-stop is latched ([`LiveError::EstopLatched`]:
//! going live never releases the latch; only an operator's Start, Reset or Home
//! does), while a playlist runs, and on a family that does not carry live motion.
//! Accepted, the run's outputs carry the latch's generation now, so nothing of it
//! reaches a unit after a later e-stop. Nothing else — live input, OSC, the
//! schedule, timecode — sends this request.
//!
//! **The feed** ([`Feed`]): before each poll while live mode is on (and just before
//! going live, for the approach's targets) the task reads the latest
//! [`crate::live::LiveInput`] snapshot from its watch — the `Arc` is cloned and the
//! borrow dropped at once — and hands the sequencer each ball's target
//! ([`floatball_shared::live::patch::BallTarget::filter_input`]), speed limit and
//! colour, rebuilt (and handed) only when the snapshot or the loss changed. The input
//! is **lost** when the snapshot says so or its latest packet is older than
//! `hold_after_ms` (the receivers publish only on change: a silent network publishes
//! nothing new). While a change would move the next live step forward (MBOX boxes
//! after a quiet period, [`Sequencer::live_awaits_change`]) the task also wakes on
//! the watch's change ([`Feed::changed`]) and polls at once, so the change's frame
//! goes when the sequencer allows rather than at the next slot.
//!
//! **The positions** ([`Positions`]): while live, every ball's filtered position
//! ([`Sequencer::live_states`]), rounded to whole mm, is published on a watch at most
//! every [`floatball_shared::api::live_positions_period_ms`] (ten a second up to
//! 2,000 balls), `None` once live mode ends; the WebSocket sessions that asked
//! relay it (`crate::ws`). The task builds it after its turn's work: nothing of it is
//! on the e-stop's path.
//!
//! **Recording** is the sequencer's ([`floatball_shared::player::Sequencer::start_recording`]);
//! the show it gives at the stop is stored by the caller (`crate::ws`).

use std::sync::Arc;
use std::time::{Duration, Instant};

use floatball_shared::api::live_positions_period_ms;
use floatball_shared::player::{Drive, LiveInput, RecordStartError, Sequencer, StartError};
use floatball_shared::show::Show;
use tokio::sync::{oneshot, watch};

use super::{Playback, Request};
use crate::estop::Latch;

/// The snapshots of live input, as the receivers publish them.
pub type LiveWatch = watch::Receiver<Arc<crate::live::LiveInput>>;

/// The balls' live positions, whole mm, as the task last published them; `None`
/// while not live.
pub type PositionsWatch = watch::Receiver<Option<Arc<[i32]>>>;

/// The task's publisher of the balls' live positions (see the module's doc).
#[derive(Debug)]
pub(super) struct Positions {
    tx: watch::Sender<Option<Arc<[i32]>>>,
    /// When they were last published (`None`: not since live mode began).
    at: Option<Instant>,
}

impl Positions {
    /// A publisher and its watch.
    pub(super) fn new() -> (Self, PositionsWatch) {
        let (tx, rx) = watch::channel(None);
        (Self { tx, at: None }, rx)
    }

    /// Publishes `sequencer`'s live positions when they are due, or `None` once live
    /// mode has ended.
    pub(super) fn publish<D: Drive>(&mut self, sequencer: &Sequencer<D>) {
        if !sequencer.is_live() {
            self.at = None;
            // Only a change wakes the sessions.
            self.tx.send_if_modified(|now| now.take().is_some());
            return;
        }
        let states = sequencer.live_states();
        let period = Duration::from_millis(live_positions_period_ms(states.len()));
        if states.is_empty() || self.at.is_some_and(|at| at.elapsed() < period) {
            return;
        }
        self.at = Some(Instant::now());
        #[allow(
            clippy::cast_possible_truncation,
            reason = "positions within the travel, a few metres"
        )]
        let positions: Arc<[i32]> = states
            .iter()
            .map(|state| state.position_mm.round() as i32)
            .collect();
        self.tx.send_replace(Some(positions));
    }
}

/// Why live mode or a recording was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LiveError {
    /// The e-stop is latched: going live does not release it.
    #[error("live mode cannot start while the E-stop is latched: press Start, Reset or Home first")]
    EstopLatched,
    /// The player refused (a playlist runs, the family carries no live motion…).
    #[error(transparent)]
    Refused(#[from] StartError),
    /// The recording could not start.
    #[error(transparent)]
    Record(#[from] RecordStartError),
    /// The playback task is gone (the bridge is shutting down).
    #[error("the player is not running")]
    Gone,
}

/// A live request to the task.
#[derive(Debug)]
pub(super) enum LiveRequest {
    /// The receivers' snapshots, read from now on.
    Feed(LiveWatch),
    /// Go live (`on`) or leave live mode.
    Live {
        on: bool,
        reply: oneshot::Sender<Result<(), LiveError>>,
    },
    /// Start recording as `name`.
    Record {
        name: String,
        reply: oneshot::Sender<Result<(), LiveError>>,
    },
    /// Stop recording: the show, if one was under way.
    RecordStop {
        reply: oneshot::Sender<Option<Show>>,
    },
}

impl Playback {
    /// The balls' live positions, whole mm, ten times a second while live (less often
    /// on a large matrix); `None` while not live.
    pub fn live_positions(&self) -> PositionsWatch {
        self.live_positions.clone()
    }

    /// Hands the playback task the receivers' snapshots of live input (once, as the
    /// bridge starts).
    pub fn attach_live(&self, input: LiveWatch) {
        let _ = self.requests.send(Request::Live(LiveRequest::Feed(input)));
    }

    /// The operator's Go live (`on`) or Leave live.
    ///
    /// # Errors
    /// [`LiveError`]: nothing changed.
    pub async fn live_mode(&self, on: bool) -> Result<(), LiveError> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Live(LiveRequest::Live { on, reply }))
            .map_err(|_| LiveError::Gone)?;
        answer.await.map_err(|_| LiveError::Gone)?
    }

    /// Starts recording the live motion as `name`.
    ///
    /// # Errors
    /// [`LiveError::Record`]: the balls do not follow live input.
    pub async fn record(&self, name: String) -> Result<(), LiveError> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Live(LiveRequest::Record { name, reply }))
            .map_err(|_| LiveError::Gone)?;
        answer.await.map_err(|_| LiveError::Gone)?
    }

    /// Stops recording: the show recorded (braked to rest), or `None` when none was
    /// under way (or an e-stop dropped it).
    pub async fn record_stop(&self) -> Option<Show> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Live(LiveRequest::RecordStop { reply }))
            .ok()?;
        answer.await.ok().flatten()
    }
}

/// The task's side of live input: the receivers' watch and the vectors last built
/// from it.
#[derive(Debug, Default)]
pub(super) struct Feed {
    input: Option<LiveWatch>,
    /// The generation of the snapshot the vectors were built from.
    built: Option<u64>,
    /// The snapshot's generation and the loss last handed to the sequencer: the
    /// sequencer keeps the input, so the same is not handed again (a poll comes with
    /// every batch of answers; copying every ball's input each time is wasted).
    fed: Option<(u64, bool)>,
    targets_mm: Vec<Option<f64>>,
    speed_limits_mm_s: Vec<Option<f64>>,
    colours: Vec<Option<[u8; 3]>>,
}

impl Feed {
    /// Hands `sequencer` the latest live input (see the module's doc).
    pub(super) fn feed<D: Drive>(&mut self, sequencer: &mut Sequencer<D>) {
        let Some(input) = &mut self.input else {
            self.fed = None;
            sequencer.set_live_input(LiveInput {
                lost: true,
                ..LiveInput::default()
            });
            return;
        };
        // The borrow ends here: nothing is held while the vectors are built. Marked
        // seen: [`Feed::changed`] wakes on the next one.
        let snapshot = Arc::clone(&input.borrow_and_update());
        if self.built != Some(snapshot.generation) {
            self.built = Some(snapshot.generation);
            self.targets_mm.clear();
            self.speed_limits_mm_s.clear();
            self.colours.clear();
            for target in snapshot.targets.iter() {
                self.targets_mm
                    .push(target.as_ref().and_then(|t| t.filter_input()));
                self.speed_limits_mm_s
                    .push(target.as_ref().and_then(|t| t.speed_limit_mm_s));
                self.colours.push(target.as_ref().and_then(|t| t.rgb));
            }
        }
        let hold_after = Duration::from_millis(u64::from(snapshot.hold_after_ms));
        let lost = snapshot.lost
            || !snapshot.running
            || snapshot
                .received_at
                .is_none_or(|at| at.elapsed() > hold_after);
        if self.fed == Some((snapshot.generation, lost)) {
            return;
        }
        self.fed = Some((snapshot.generation, lost));
        sequencer.set_live_input(LiveInput {
            targets_mm: &self.targets_mm,
            speed_limits_mm_s: &self.speed_limits_mm_s,
            colours: &self.colours,
            lost,
        });
    }

    /// Resolves when the receivers publish a snapshot not fed yet (never without
    /// their watch, or once they are gone). The task waits on it while a change would
    /// move the next live step forward ([`Sequencer::live_awaits_change`]).
    pub(super) async fn changed(&mut self) {
        let gone = match self.input.as_mut() {
            Some(input) => input.changed().await.is_err(),
            None => true,
        };
        if gone {
            std::future::pending::<()>().await;
        }
    }

    /// Carries out `request` at `now_us`; returns the generation live mode's outputs
    /// carry when it went live.
    pub(super) fn handle<D: Drive>(
        &mut self,
        sequencer: &mut Sequencer<D>,
        latch: &Latch,
        request: LiveRequest,
        now_us: u64,
    ) -> Option<u64> {
        match request {
            LiveRequest::Feed(input) => {
                self.input = Some(input);
                self.built = None;
                self.fed = None;
                None
            }
            LiveRequest::Live { on: false, reply } => {
                sequencer.leave_live(now_us);
                let _ = reply.send(Ok(()));
                None
            }
            LiveRequest::Live { on: true, reply } => {
                let generation = latch.generation();
                let (result, went) = if latch.is_latched() {
                    (Err(LiveError::EstopLatched), None)
                } else if sequencer.is_live() {
                    // Live already: nothing changes.
                    (Ok(()), None)
                } else {
                    // Handed anew: going live takes the input kept for the approach.
                    self.fed = None;
                    self.feed(sequencer);
                    let result = sequencer.go_live(now_us).map_err(LiveError::from);
                    let went = result.is_ok().then_some(generation);
                    (result, went)
                };
                let _ = reply.send(result);
                went
            }
            LiveRequest::Record { name, reply } => {
                let _ = reply.send(sequencer.start_recording(name).map_err(LiveError::from));
                None
            }
            LiveRequest::RecordStop { reply } => {
                let _ = reply.send(sequencer.stop_recording());
                None
            }
        }
    }
}
