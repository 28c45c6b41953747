//! Every configured gateway's [`Link`] together, as the clients see them.
//!
//! - console lines go to one gateway or to all, on the bulk lane ([`Gateways::send`]);
//! - every link obeys the one e-stop latch and writes the configured stop (pressed
//!   through [`crate::playback::Playback::estop`], the one e-stop path);
//! - every feedback frame of every link is relayed, tagged with its gateway, to one
//!   channel the WebSocket sessions subscribe to ([`Gateways::subscribe_feedback`]).
//!
//! The links' state and bytes/s reach the clients through the status, which the
//! playback task owns and fills from the links' snapshots.
//!
//! **Replaceable.** A new installation (`PUT /api/installation`) is applied without a
//! restart ([`Gateways::reopen`]): the links whose port or baud changed, and the
//! gateways added, are opened anew; the removed ones and the replaced ones close when
//! their last handle goes; the others are kept as they are. Readers take the list as
//! a snapshot ([`Gateways::links`]), never a lock held while they use it.

use std::path::{Path, PathBuf};
use std::sync::{Arc, RwLock};

use floatball_shared::api::FeedbackFrame;
use floatball_shared::plan::installation::SIM_PORT;
use floatball_shared::plan::{DriveKind, Installation};
use floatball_shared::uim2503::ascii::{Batch, EncodeError, Form};
use floatball_shared::uim2503::sim::GatewayConfig;
use tokio::sync::{Notify, broadcast};

use crate::commission::sim_units::SimUnits;
use crate::config::Config;
use crate::estop::Latch;
use crate::ports::uim2503::{FeedbackSource, Link, LinkConfig};

/// How many relayed frames a slow WebSocket client may fall behind before it is told
/// that it missed some.
const FEEDBACK_CAPACITY: usize = 4096;

/// The links to all gateways.
#[derive(Debug)]
pub struct Gateways {
    /// The links now, replaced whole ([`Gateways::reopen`]); the lock is only held to
    /// copy or swap the pointer.
    links: RwLock<Arc<Vec<Link>>>,
    feedback: broadcast::Sender<FeedbackFrame>,
    /// Wakes the links' relays when a WebSocket session subscribes to the feedback
    /// (while nobody does, they do not read their link's frames at all).
    wanted: Arc<Notify>,
    /// The e-stop's bytes, for links opened later.
    estop: Batch,
    /// The one e-stop latch every link obeys.
    latch: Arc<Latch>,
    /// Where simulated units keep their stations ([`crate::commission::sim_units`]).
    data_dir: PathBuf,
    /// How new simulated units leave the factory.
    sim: SimUnits,
}

/// What [`Gateways::reopen`] did.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Reopened {
    /// The gateways (new numbering) whose link is new: port or baud changed, or added.
    pub opened: Vec<usize>,
    /// How many links were closed because their gateway was removed.
    pub removed: usize,
}

impl Gateways {
    /// Opens a link per configured gateway, all obeying `latch`, and starts relaying
    /// their feedback. Must run inside the async runtime. A simulated gateway's units
    /// keep the stations they were given in `data_dir`
    /// ([`crate::commission::sim_units`]); new ones leave the factory as `sim` says.
    ///
    /// # Errors
    /// If the configured e-stop does not encode (the configuration check already
    /// makes sure it does).
    pub fn open(
        config: &Config,
        latch: &Arc<Latch>,
        data_dir: &Path,
        sim: SimUnits,
    ) -> Result<Self, EncodeError> {
        let estop = Batch::encode(&config.estop, Form::Standard)?;
        let installation = &config.installation;
        let (feedback, _) = broadcast::channel(FEEDBACK_CAPACITY);
        let gateways = Self {
            links: RwLock::new(Arc::new(Vec::new())),
            feedback,
            wanted: Arc::new(Notify::new()),
            estop,
            latch: Arc::clone(latch),
            data_dir: data_dir.to_path_buf(),
            sim,
        };
        let links: Vec<Link> = installation
            .gateways
            .iter()
            .enumerate()
            // MBOX boxes are not on a line: they are `crate::ports::mbox`'s.
            .filter(|(_, gateway)| gateway.kind == DriveKind::Uim2503)
            .map(|(index, _)| gateways.open_link(installation, index))
            .collect();
        gateways.swap(links);
        Ok(gateways)
    }

    /// Opens gateway `index`'s link of `installation` and relays its feedback.
    fn open_link(&self, installation: &Installation, index: usize) -> Link {
        let gateway = &installation.gateways[index];
        let mut link = LinkConfig::new(gateway.port.clone(), gateway.baud);
        link.estop = self.estop.clone();
        link.latch = Arc::clone(&self.latch);
        // A simulated gateway has the installation's units and calibration; its units
        // keep the stations they were given.
        link.sim = GatewayConfig {
            stations: self
                .sim
                .stations(&self.data_dir, index, &installation.stations_on(index)),
            seed: index as u64,
            counts_per_mm: installation.counts_per_mm,
            travel_mm: installation.limits.travel_mm,
            max_speed_mm_s: installation.limits.max_speed_mm_s,
            max_accel_mm_s2: installation.limits.max_accel_mm_s2,
            ..GatewayConfig::default()
        };
        let link = Link::open(index, link);
        tokio::spawn(relay_feedback(
            link.index(),
            link.feedback_source(),
            self.feedback.clone(),
            Arc::clone(&self.wanted),
        ));
        link
    }

    /// Replaces the links with `links`.
    fn swap(&self, links: Vec<Link>) {
        self.restore(Arc::new(links));
    }

    /// The links now, in configuration order: a snapshot, which a new installation
    /// replaces ([`Gateways::reopen`]) but never changes.
    pub fn links(&self) -> Arc<Vec<Link>> {
        match self.links.read() {
            Ok(links) => Arc::clone(&links),
            Err(poisoned) => Arc::clone(&poisoned.into_inner()),
        }
    }

    /// Puts `links` back (they are still open: the player held them) after a new
    /// installation was refused; the links [`Gateways::reopen`] opened close.
    pub fn restore(&self, links: Arc<Vec<Link>>) {
        match self.links.write() {
            Ok(mut now) => *now = links,
            Err(poisoned) => *poisoned.into_inner() = links,
        }
    }

    /// Applies a new UIM2503 `installation` in place of `before` (the player is idle;
    /// the caller makes sure): a link whose gateway keeps its port and baud is kept;
    /// the others close (when their last handle goes) and the new or changed ones
    /// open. A simulated gateway kept keeps its units where they are (their stations
    /// are theirs, as a real unit's are in its flash); one whose number of units
    /// changes restarts with the new units. Returns the links now and what changed.
    pub fn reopen(
        &self,
        before: &Installation,
        installation: &Installation,
    ) -> (Arc<Vec<Link>>, Reopened) {
        let old = self.links();
        let mut reopened = Reopened {
            removed: old.len().saturating_sub(installation.gateways.len()),
            ..Reopened::default()
        };
        // A changed serial link's port is free once its last handle goes (the
        // player's, when it takes the new links); the new link retries it until then.
        let kept: Vec<Option<Link>> = installation
            .gateways
            .iter()
            .enumerate()
            .map(|(index, gateway)| {
                let units = installation.stations_on(index).len();
                old.get(index)
                    .filter(|link| {
                        link.port() == gateway.port
                            && link.baud() == gateway.baud
                            && (gateway.port != SIM_PORT
                                || before.stations_on(index).len() == units)
                    })
                    .cloned()
            })
            .collect();
        drop(old);
        let links: Vec<Link> = kept
            .into_iter()
            .enumerate()
            .map(|(index, link)| {
                link.unwrap_or_else(|| {
                    reopened.opened.push(index);
                    self.open_link(installation, index)
                })
            })
            .collect();
        self.swap(links);
        (self.links(), reopened)
    }

    /// Every feedback frame from every gateway from now on.
    pub fn subscribe_feedback(&self) -> broadcast::Receiver<FeedbackFrame> {
        let frames = self.feedback.subscribe();
        self.wanted.notify_waiters();
        frames
    }

    /// Queues `batch` on the bulk lane of `gateway`, or of every gateway when `None`,
    /// waiting while a lane is full; `generation` is the e-stop generation the line was
    /// issued at (void if the e-stop was pressed since).
    ///
    /// # Errors
    /// No such gateway, or each gateway that refused, with the reason.
    pub async fn send(
        &self,
        gateway: Option<usize>,
        batch: Batch,
        generation: u64,
    ) -> Result<(), String> {
        let links = self.links();
        let targets: Vec<&Link> = match gateway {
            Some(index) => vec![links.get(index).ok_or_else(|| {
                format!(
                    "there is no gateway {index}; gateways are numbered 0 to {}",
                    links.len().saturating_sub(1)
                )
            })?],
            None => links.iter().collect(),
        };
        let mut failures = Vec::new();
        for link in targets {
            if let Err(error) = link.send_issued(batch.clone(), generation).await {
                failures.push(format!("gateway {}: {error}", link.index()));
            }
        }
        if failures.is_empty() {
            Ok(())
        } else {
            Err(failures.join("; "))
        }
    }
}

/// How often a relay with nobody listening looks whether its link is gone.
const RELAY_IDLE_CHECK: std::time::Duration = std::time::Duration::from_secs(1);

/// Forwards one link's frames, tagged with its gateway index, until the link is gone.
/// While no WebSocket session listens (most of the time: the app asks for frames only
/// on its console) it does not read its link's frames at all — a hundred gateways send
/// thousands a second — and waits for `wanted`.
async fn relay_feedback(
    gateway: usize,
    source: FeedbackSource,
    relay: broadcast::Sender<FeedbackFrame>,
    wanted: Arc<Notify>,
) {
    let mut frames: Option<broadcast::Receiver<floatball_shared::uim2503::feedback::Frame>> = None;
    loop {
        if relay.receiver_count() == 0 {
            frames = None;
            let subscribed = wanted.notified();
            tokio::pin!(subscribed);
            subscribed.as_mut().enable();
            if relay.receiver_count() == 0 {
                let _ = tokio::time::timeout(RELAY_IDLE_CHECK, subscribed).await;
                if !source.is_open() {
                    return;
                }
                continue;
            }
        }
        let receiver = match frames.as_mut() {
            Some(receiver) => receiver,
            None => match source.subscribe() {
                Some(receiver) => frames.insert(receiver),
                None => return,
            },
        };
        match receiver.recv().await {
            // The last listener left since: back to waiting (the check above).
            Ok(_) if relay.receiver_count() == 0 => {}
            Ok(frame) => {
                let _ = relay.send(FeedbackFrame {
                    gateway,
                    station: frame.station(),
                    code: frame.code(),
                    data: frame.data().to_vec(),
                });
            }
            Err(broadcast::error::RecvError::Lagged(missed)) => {
                tracing::warn!("gateway {gateway}: {missed} feedback frames were not relayed");
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
    }
}
