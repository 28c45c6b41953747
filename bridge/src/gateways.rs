//! Every configured gateway's [`Link`] together, as the clients see them.
//!
//! - console lines go to one gateway or to all, on the bulk lane ([`Gateways::send`]);
//! - the e-stop goes to every gateway at once on the priority lane, as a global
//!   broadcast, dropping queued bulk ([`Gateways::estop`]);
//! - every feedback frame of every link is relayed, tagged with its gateway, to one
//!   channel the WebSocket sessions subscribe to ([`Gateways::subscribe_feedback`]);
//! - every link's state and bytes/s are written into the shared [`Status`].

use std::sync::Arc;

use floatball_shared::api::{FeedbackFrame, GatewayStatus, LinkState, Status};
use floatball_shared::ascii::{Batch, EncodeError, Form};
use floatball_shared::sim::GatewayConfig;
use tokio::sync::{broadcast, watch};

use crate::config::Config;
use crate::link::{Link, LinkConfig, LinkStatus};

/// How many relayed frames a slow WebSocket client may fall behind before it is told
/// that it missed some.
const FEEDBACK_CAPACITY: usize = 4096;

/// The links to all gateways.
#[derive(Debug)]
pub struct Gateways {
    links: Vec<Link>,
    estop: Batch,
    feedback: broadcast::Sender<FeedbackFrame>,
}

impl Gateways {
    /// Opens a link per configured gateway and starts relaying its feedback and its
    /// state into `status`. Must run inside the async runtime.
    ///
    /// # Errors
    /// If the configured e-stop does not encode (the configuration check already
    /// makes sure it does).
    pub fn open(config: &Config, status: &Arc<watch::Sender<Status>>) -> Result<Self, EncodeError> {
        let estop = Batch::encode(&config.safety.estop, Form::Standard)?;
        let (feedback, _) = broadcast::channel(FEEDBACK_CAPACITY);
        status.send_modify(|status| {
            status.gateways = config
                .gateways
                .iter()
                .map(|gateway| GatewayStatus {
                    port: gateway.port.clone(),
                    link: LinkState::Connecting,
                    bytes_per_s: 0.0,
                    lowest_water_level: None,
                    error: None,
                })
                .collect();
        });
        let links: Vec<Link> = config
            .gateways
            .iter()
            .enumerate()
            .map(|(index, gateway)| {
                let mut link = LinkConfig::new(gateway.port.clone(), gateway.baud);
                // A simulated gateway has the installation's units and calibration.
                link.sim = GatewayConfig {
                    stations: gateway.stations.clone(),
                    seed: index as u64,
                    counts_per_mm: config.matrix.counts_per_mm,
                    travel_mm: config.matrix.travel_mm,
                    max_speed_mm_s: config.matrix.max_speed_mm_s,
                    max_accel_mm_s2: config.matrix.max_accel_mm_s2,
                    ..GatewayConfig::default()
                };
                Link::open(index, link)
            })
            .collect();
        for link in &links {
            tokio::spawn(relay_feedback(
                link.index(),
                link.feedback(),
                feedback.clone(),
            ));
            tokio::spawn(relay_status(
                link.index(),
                link.status(),
                Arc::clone(status),
            ));
        }
        Ok(Self {
            links,
            estop,
            feedback,
        })
    }

    /// The e-stop batch: `*0;` followed by the configured stop.
    pub fn estop_batch(&self) -> &Batch {
        &self.estop
    }

    /// The links, in configuration order.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// Every feedback frame from every gateway from now on.
    pub fn subscribe_feedback(&self) -> broadcast::Receiver<FeedbackFrame> {
        self.feedback.subscribe()
    }

    /// Sends the e-stop (`*0;` + the configured instructions) on every gateway's
    /// priority lane, dropping whatever bulk was queued. Returns the gateways it could
    /// not reach, each with the reason.
    pub fn estop(&self) -> Vec<String> {
        self.links
            .iter()
            .filter_map(|link| {
                link.estop(&self.estop)
                    .err()
                    .map(|error| format!("gateway {}: {error}", link.index()))
            })
            .collect()
    }

    /// Queues `batch` on the bulk lane of `gateway`, or of every gateway when `None`,
    /// waiting while a lane is full.
    ///
    /// # Errors
    /// No such gateway, or each gateway that refused, with the reason.
    pub async fn send(&self, gateway: Option<usize>, batch: Batch) -> Result<(), String> {
        let targets: Vec<&Link> = match gateway {
            Some(index) => vec![self.links.get(index).ok_or_else(|| {
                format!(
                    "there is no gateway {index}; gateways are numbered 0 to {}",
                    self.links.len().saturating_sub(1)
                )
            })?],
            None => self.links.iter().collect(),
        };
        let mut failures = Vec::new();
        for link in targets {
            if let Err(error) = link.send(batch.clone()).await {
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

/// Forwards one link's frames, tagged with its gateway index, until the link is gone.
async fn relay_feedback(
    gateway: usize,
    mut frames: broadcast::Receiver<floatball_shared::feedback::Frame>,
    relay: broadcast::Sender<FeedbackFrame>,
) {
    loop {
        match frames.recv().await {
            Ok(frame) => {
                // No subscriber is not an error: frames are only for who listens.
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

/// Copies one link's state into the status until the link is gone.
async fn relay_status(
    gateway: usize,
    mut link: watch::Receiver<LinkStatus>,
    status: Arc<watch::Sender<Status>>,
) {
    loop {
        let current = link.borrow_and_update().clone();
        status.send_if_modified(|status| {
            let Some(shown) = status.gateways.get_mut(gateway) else {
                return false;
            };
            let before = shown.clone();
            shown.link = current.state;
            shown.bytes_per_s = current.bytes_per_s;
            shown.error = match current.state {
                LinkState::Up => None,
                LinkState::Connecting | LinkState::Down => current.error,
            };
            *shown != before
        });
        if link.changed().await.is_err() {
            return;
        }
    }
}
