//! UIM2503 gateways as a family under the sequencer ([`super::sequenced`]): the
//! gateways' drive ([`Uim2503Drive`]) queues instruction batches for each line, the
//! links ([`crate::ports::uim2503::Link`]) write them — the synchronised start on the priority
//! lane at its instant — and every unit's feedback comes back to the drive.
//!
//! **A stalled link is a fault.** While a playlist runs, a link that has bytes queued
//! and writes nothing for [`stall_limit`] stops the show on every gateway and sets the
//! state `error`, naming the gateway ([`Watchdog`]).

use std::sync::Arc;
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayKind, GatewayStatus, LinkState};
use floatball_shared::player::{LinkView, Sequencer};
use floatball_shared::uim2503::feedback::Frame;
use floatball_shared::uim2503::player::{Command, PlayerConfig, Uim2503Drive};
use tokio::sync::mpsc;

use super::sequenced::Family;
use super::{Reconfigure, ReconfigureError};
use crate::commission::health::HealthView;
use crate::estop::StopPort;
use crate::ports::uim2503::Link;

/// A unit's feedback frame, with its gateway.
pub type Feedback = (usize, Frame);

/// The gateways of an installation on their links, as a family.
#[derive(Debug)]
pub struct Uim2503Family {
    /// The links, in gateway order.
    pub links: Arc<Vec<Link>>,
    /// The units' health of each link (same order), for the status.
    pub health: Vec<HealthView>,
    /// The stalled-link watchdog.
    pub watchdog: Watchdog,
}

impl Uim2503Family {
    /// The family on `links` with each link's unit `health`.
    pub fn new(links: Arc<Vec<Link>>, health: Vec<HealthView>) -> Self {
        Self {
            watchdog: Watchdog::new(&links),
            links,
            health,
        }
    }
}

impl Family for Uim2503Family {
    type Drive = Uim2503Drive;
    type Input = Feedback;

    /// A poll looks at every gateway, and a hundred of them send thousands of frames a
    /// second.
    const POLL_PERIOD: Duration = Duration::from_millis(2);

    fn attach(&mut self, inputs: &mpsc::UnboundedSender<Feedback>) {
        for (gateway, link) in self.links.iter().enumerate() {
            relay(gateway, link, inputs.clone());
        }
    }

    fn views(&self) -> Vec<LinkView> {
        link_views(&self.links)
    }

    fn statuses(&self, drive: &Uim2503Drive) -> Vec<GatewayStatus> {
        let lowest = drive.lowest_water_levels();
        self.links
            .iter()
            .enumerate()
            .map(|(gateway, link)| {
                let link_status = link.snapshot();
                GatewayStatus {
                    index: gateway,
                    kind: GatewayKind::Uim2503,
                    port: link.port().to_owned(),
                    link: link_status.state,
                    bytes_per_s: link_status.bytes_per_s,
                    lowest_water_level: lowest.get(gateway).copied().flatten(),
                    error: match link_status.state {
                        LinkState::Up => None,
                        _ => link_status.error,
                    },
                    packets_per_s: None,
                    late_frames: None,
                    missed_replies: None,
                    drives: Vec::new(),
                    baud: Some(link.baud()),
                    health: self
                        .health
                        .get(gateway)
                        .and_then(|view| view.borrow().clone()),
                }
            })
            .collect()
    }

    fn lost(&mut self, running: bool) -> Option<String> {
        // A link that went down is the drive's own fault (it sees the links' state
        // at each poll); a link that is up but writes nothing is the watchdog's.
        self.watchdog.check(&self.links, running)
    }

    fn ports(&self) -> Vec<&dyn StopPort> {
        self.links.iter().map(|link| link as _).collect()
    }

    fn before_poll(&self, drive: &mut Uim2503Drive) {
        drive.set_links(&link_views(&self.links));
    }

    fn carry_out(
        &mut self,
        drive: &mut Uim2503Drive,
        epoch: Instant,
        generation: u64,
        _inputs: &mpsc::UnboundedSender<Feedback>,
    ) {
        for command in drive.take_commands() {
            let (gateway, result) = match command {
                Command::Bulk { gateway, batch } => (
                    gateway,
                    self.links
                        .get(gateway)
                        .map(|link| link.enqueue(&batch, generation)),
                ),
                Command::Priority {
                    gateway,
                    batch,
                    at_us,
                } => {
                    let at = epoch + Duration::from_micros(at_us);
                    (
                        gateway,
                        self.links
                            .get(gateway)
                            .map(|link| link.send_priority_at(&batch, generation, Some(at))),
                    )
                }
                // The sequencer's own stop goes out through the task (`take_estop`).
                Command::Estop => continue,
            };
            match result {
                Some(Ok(())) => {}
                Some(Err(err)) => tracing::warn!("player: {err}"),
                None => tracing::error!("player: there is no gateway {gateway}"),
            }
        }
    }

    fn apply(sequencer: &mut Sequencer<Uim2503Drive>, now_us: u64, (gateway, frame): Feedback) {
        Uim2503Drive::handle_feedback(sequencer, now_us, gateway, &frame);
    }

    fn reconfigure(
        &mut self,
        change: &Reconfigure,
        inputs: &mpsc::UnboundedSender<Feedback>,
    ) -> Result<Uim2503Drive, ReconfigureError> {
        self.links = Arc::clone(&change.links);
        self.health.clone_from(&change.health);
        for &gateway in &change.opened {
            if let Some(link) = self.links.get(gateway) {
                relay(gateway, link, inputs.clone());
            }
        }
        self.watchdog = Watchdog::new(&self.links);
        Ok(Uim2503Drive::new(PlayerConfig {
            installation: change.installation.clone(),
        }))
    }
}

/// Each link's state and queued bytes, in gateway order.
pub fn link_views(links: &[Link]) -> Vec<LinkView> {
    links
        .iter()
        .map(|link| LinkView {
            up: link.is_up(),
            queued_bytes: link.queued_bytes(),
        })
        .collect()
}

/// Relays `link`'s feedback into the task's inputs, tagged with `gateway`, until the
/// link or the task is gone.
fn relay(gateway: usize, link: &Link, inputs: mpsc::UnboundedSender<Feedback>) {
    let mut feedback = link.feedback();
    tokio::spawn(async move {
        loop {
            match feedback.recv().await {
                Ok(frame) => {
                    if inputs.send((gateway, frame)).is_err() {
                        return;
                    }
                }
                Err(tokio::sync::broadcast::error::RecvError::Lagged(missed)) => {
                    tracing::warn!("player missed {missed} feedback frames of gateway {gateway}");
                }
                Err(tokio::sync::broadcast::error::RecvError::Closed) => return,
            }
        }
    });
}

/// How long a link may hold queued bytes without writing any while a show runs
/// before it counts as stalled: ten of the longest instructions on its line, and never
/// less than half a second (threads are not scheduled to the millisecond).
pub fn stall_limit(baud: u32) -> Duration {
    (floatball_shared::line::Line::new(baud).byte_time()
        * 10
        * floatball_shared::uim2503::ascii::MAX_LEN as u32)
        .max(Duration::from_millis(500))
}

/// Progress of one link as the watchdog last saw it.
#[derive(Debug, Clone, Copy)]
struct Progress {
    written_bytes: u64,
    since: Instant,
}

/// The link watchdog: a link with bytes queued that writes nothing for its
/// [`stall_limit`] while a show runs.
#[derive(Debug)]
pub struct Watchdog {
    progress: Vec<Progress>,
}

impl Watchdog {
    /// A watchdog over `links`, counting from now.
    pub fn new(links: &[Link]) -> Self {
        let now = Instant::now();
        Self {
            progress: links
                .iter()
                .map(|link| Progress {
                    written_bytes: link.written_bytes(),
                    since: now,
                })
                .collect(),
        }
    }

    /// The first stalled link's description, if one is stalled.
    fn check(&mut self, links: &[Link], running: bool) -> Option<String> {
        let now = Instant::now();
        let mut stalled = None;
        for (progress, link) in self.progress.iter_mut().zip(links) {
            let written_bytes = link.written_bytes();
            let queued = link.queued_bytes();
            if !running || queued == 0 || written_bytes != progress.written_bytes {
                *progress = Progress {
                    written_bytes,
                    since: now,
                };
                continue;
            }
            let silent = now.saturating_duration_since(progress.since);
            if stalled.is_none() && silent >= stall_limit(link.baud()) {
                stalled = Some(format!(
                    "gateway {} ({}) stalled: {queued} bytes queued and nothing written for {} ms; the show was stopped on every gateway",
                    link.index(),
                    link.port(),
                    silent.as_millis()
                ));
            }
        }
        stalled
    }
}
