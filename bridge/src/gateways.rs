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

use std::path::Path;
use std::sync::Arc;

use floatball_shared::api::FeedbackFrame;
use floatball_shared::ascii::{Batch, EncodeError, Form};
use floatball_shared::plan::DriveKind;
use floatball_shared::sim::GatewayConfig;
use tokio::sync::broadcast;

use crate::commission::sim_units::SimUnits;
use crate::config::Config;
use crate::estop::Latch;
use crate::link::{Link, LinkConfig};

/// How many relayed frames a slow WebSocket client may fall behind before it is told
/// that it missed some.
const FEEDBACK_CAPACITY: usize = 4096;

/// The links to all gateways.
#[derive(Debug)]
pub struct Gateways {
    links: Vec<Link>,
    feedback: broadcast::Sender<FeedbackFrame>,
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
        let links: Vec<Link> = installation
            .gateways
            .iter()
            .enumerate()
            // MBOX boxes are not on a line: they are `crate::mbox`'s.
            .filter(|(_, gateway)| gateway.kind == DriveKind::Uim2503)
            .map(|(index, gateway)| {
                let mut link = LinkConfig::new(gateway.port.clone(), gateway.baud);
                link.estop = estop.clone();
                link.latch = Arc::clone(latch);
                // A simulated gateway has the installation's units and calibration.
                link.sim = GatewayConfig {
                    stations: sim.stations(data_dir, index, &installation.stations_on(index)),
                    seed: index as u64,
                    counts_per_mm: installation.counts_per_mm,
                    travel_mm: installation.limits.travel_mm,
                    max_speed_mm_s: installation.limits.max_speed_mm_s,
                    max_accel_mm_s2: installation.limits.max_accel_mm_s2,
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
        }
        Ok(Self { links, feedback })
    }

    /// The links, in configuration order.
    pub fn links(&self) -> &[Link] {
        &self.links
    }

    /// Every feedback frame from every gateway from now on.
    pub fn subscribe_feedback(&self) -> broadcast::Receiver<FeedbackFrame> {
        self.feedback.subscribe()
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
