//! Playback: the player (`floatball_shared::plan::player`) driven by the bridge's
//! clock, the links' state and their feedback, its commands carried out on the links.
//!
//! E-stop never waits for this task: [`Playback::estop`] writes the stop on every link's
//! priority lane itself, then tells the player. Status is published on a watch channel
//! whenever it changes (the WebSocket layer limits how often clients hear of it).

use std::sync::Arc;
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayStatus, LinkState, Status};
use floatball_shared::ascii::Batch;
use floatball_shared::plan::Installation;
use floatball_shared::plan::player::{
    Command, Entry, LinkView, Player, PlayerConfig, StartError, TICK_US,
};
use tokio::sync::{mpsc, oneshot, watch};

use crate::link::Link;

enum Request {
    Start {
        entries: Vec<Entry>,
        loop_playlist: bool,
        reply: oneshot::Sender<Result<(), StartError>>,
    },
    Reset {
        entries: Vec<Entry>,
        loop_playlist: bool,
        reply: oneshot::Sender<Result<(), StartError>>,
    },
    Estop,
}

/// A handle to the playback task; cheap to clone.
#[derive(Debug, Clone)]
pub struct Playback {
    requests: mpsc::UnboundedSender<Request>,
    status: watch::Receiver<Status>,
    links: Arc<Vec<Link>>,
    estop: Batch,
}

impl std::fmt::Debug for Request {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Request::Start { .. } => "Start",
            Request::Reset { .. } => "Reset",
            Request::Estop => "Estop",
        })
    }
}

/// Why a request could not be handled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PlaybackError {
    /// The player refused (nothing moved).
    #[error(transparent)]
    Refused(#[from] StartError),
    /// The playback task is gone (the bridge is shutting down).
    #[error("the player is not running")]
    Gone,
}

impl Playback {
    /// Starts the playback task for `installation` on `links` (one per gateway, in
    /// order); `estop` is the stop instruction batch (e.g. `*0;MO=0;`).
    pub fn spawn(installation: Installation, links: Vec<Link>, estop: Batch) -> Self {
        let links = Arc::new(links);
        let player = Player::new(PlayerConfig {
            installation,
            estop: estop.clone(),
        });
        let (requests, inbox) = mpsc::unbounded_channel();
        let (status_tx, status) = watch::channel(Status::default());
        tokio::spawn(run(player, Arc::clone(&links), inbox, status_tx));
        Self {
            requests,
            status,
            links,
            estop,
        }
    }

    /// The status, on every change.
    pub fn status(&self) -> watch::Receiver<Status> {
        self.status.clone()
    }

    /// The links, in gateway order.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// E-stop: the stop goes on every link's priority lane now, ahead of anything
    /// queued (which is dropped); then the player stops. Returns the gateways the stop
    /// could not reach, each with the reason.
    pub fn estop(&self) -> Vec<String> {
        let failures = self
            .links
            .iter()
            .filter_map(|link| {
                link.estop(&self.estop)
                    .err()
                    .map(|error| format!("gateway {}: {error}", link.index()))
            })
            .collect();
        let _ = self.requests.send(Request::Estop);
        failures
    }

    /// Start the playlist.
    ///
    /// # Errors
    /// [`PlaybackError::Refused`] with the player's reason; nothing moved.
    pub async fn start(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<(), PlaybackError> {
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Start {
                entries,
                loop_playlist,
                reply,
            })
            .map_err(|_| PlaybackError::Gone)?;
        answer
            .await
            .map_err(|_| PlaybackError::Gone)?
            .map_err(PlaybackError::from)
    }

    /// Reset: stop now, home, and play the playlist from its first entry.
    ///
    /// # Errors
    /// [`PlaybackError::Refused`]: the matrix is stopped, and stays so.
    pub async fn reset(
        &self,
        entries: Vec<Entry>,
        loop_playlist: bool,
    ) -> Result<(), PlaybackError> {
        for link in self.links.iter() {
            if let Err(err) = link.estop(&self.estop) {
                tracing::error!("reset: stopping gateway {}: {err}", link.index());
            }
        }
        let (reply, answer) = oneshot::channel();
        self.requests
            .send(Request::Reset {
                entries,
                loop_playlist,
                reply,
            })
            .map_err(|_| PlaybackError::Gone)?;
        answer
            .await
            .map_err(|_| PlaybackError::Gone)?
            .map_err(PlaybackError::from)
    }
}

fn link_views(links: &[Link]) -> Vec<LinkView> {
    links
        .iter()
        .map(|link| LinkView {
            up: link.status().borrow().state == LinkState::Up,
            queued_bytes: link.queued_bytes(),
        })
        .collect()
}

fn status_of(player: &Player, links: &[Link]) -> Status {
    let mut status = player.status();
    let lowest = player.lowest_water_levels();
    status.gateways = links
        .iter()
        .enumerate()
        .map(|(gateway, link)| {
            let link_status = link.status().borrow().clone();
            GatewayStatus {
                port: link.port().to_owned(),
                link: link_status.state,
                bytes_per_s: link_status.bytes_per_s,
                lowest_water_level: lowest.get(gateway).copied().flatten(),
                error: link_status.error,
            }
        })
        .collect();
    status
}

fn carry_out(links: &[Link], commands: Vec<Command>) {
    for command in commands {
        let (gateway, result) = match command {
            Command::Bulk { gateway, batch } => {
                (gateway, links.get(gateway).map(|link| link.enqueue(&batch)))
            }
            Command::Priority { gateway, batch } => (
                gateway,
                links.get(gateway).map(|link| link.send_priority(&batch)),
            ),
            // The handle already wrote the stop; the player only says so again.
            Command::Estop { gateway, .. } => (gateway, Some(Ok(()))),
        };
        match result {
            Some(Ok(())) => {}
            Some(Err(err)) => tracing::warn!("player: {err}"),
            None => tracing::error!("player: there is no gateway {gateway}"),
        }
    }
}

async fn run(
    mut player: Player,
    links: Arc<Vec<Link>>,
    mut inbox: mpsc::UnboundedReceiver<Request>,
    status: watch::Sender<Status>,
) {
    let epoch = Instant::now();
    let now_us = || u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX);
    // Every link's feedback into one queue, tagged with the gateway.
    let (frames_tx, mut frames) = mpsc::unbounded_channel();
    for (gateway, link) in links.iter().enumerate() {
        let mut feedback = link.feedback();
        let frames_tx = frames_tx.clone();
        tokio::spawn(async move {
            loop {
                match feedback.recv().await {
                    Ok(frame) => {
                        if frames_tx.send((gateway, frame)).is_err() {
                            return;
                        }
                    }
                    Err(tokio::sync::broadcast::error::RecvError::Lagged(missed)) => {
                        tracing::warn!(
                            "player missed {missed} feedback frames of gateway {gateway}"
                        );
                    }
                    Err(tokio::sync::broadcast::error::RecvError::Closed) => return,
                }
            }
        });
    }
    drop(frames_tx);
    loop {
        let now = now_us();
        // Idle, it still looks at the links ten times a second for the status.
        let wake_us = player.next_wakeup_us(now).unwrap_or(now + 100_000);
        let sleep = tokio::time::sleep(Duration::from_micros(
            wake_us.saturating_sub(now).clamp(1_000, TICK_US * 25),
        ));
        tokio::select! {
            request = inbox.recv() => {
                let Some(request) = request else { return };
                let now = now_us();
                let views = link_views(&links);
                match request {
                    Request::Start { entries, loop_playlist, reply } => {
                        let _ = reply.send(player.start(now, entries, loop_playlist, &views));
                    }
                    Request::Reset { entries, loop_playlist, reply } => {
                        let _ = reply.send(player.reset(now, entries, loop_playlist, &views));
                    }
                    Request::Estop => player.estop(),
                }
            }
            Some((gateway, frame)) = frames.recv() => {
                player.handle_feedback(now_us(), gateway, &frame);
            }
            () = sleep => {}
        }
        player.poll(now_us(), &link_views(&links));
        carry_out(&links, player.take_commands());
        let current = status_of(&player, &links);
        status.send_if_modified(|published| {
            let changed = *published != current;
            if changed {
                *published = current;
            }
            changed
        });
    }
}
