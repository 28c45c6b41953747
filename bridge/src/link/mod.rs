//! Links to the gateways: one per configured gateway, a real serial port or the
//! simulated gateway, behind the same [`Link`] handle.
//!
//! Every link has two write lanes ([`lanes`]): the **priority** lane (e-stop) is always
//! written before the **bulk** lane, and the writer hands the port one instruction at a
//! time, paced to the line's speed ([`pacer`]), so an e-stop waits for at most the one
//! instruction already on the wire. Bytes read back go through the feedback decoder and
//! are broadcast as frames. A lost link is reported in its status, everything queued is
//! dropped (nothing stale is sent later), and the link is retried with backoff while
//! the daemon keeps serving.
//!
//! - [`lanes`]: the two lanes and the station re-selection after a priority write;
//! - [`pacer`]: line timing and the bytes/s meter;
//! - [`serial`]: serial ports through the `serialport` crate;
//! - [`sim`]: the simulated gateway behind a virtual line as slow as a real one.

pub mod lanes;
pub mod pacer;
pub mod serial;
pub mod sim;

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use floatball_shared::api::LinkState;
use floatball_shared::feedback::Frame;
use floatball_shared::sim::GatewayConfig;
use tokio::sync::{broadcast, watch};

pub use floatball_shared::ascii::Batch;
use lanes::Lanes;
use pacer::{Pacer, RateMeter};

/// The `port` value that selects the simulated gateway.
pub const SIM_PORT: &str = "sim";

/// How many bytes the bulk lane holds before [`Link::send`] waits.
pub const BULK_CAPACITY_BYTES: usize = 64 * 1024;

/// How many decoded frames a slow feedback subscriber may fall behind.
const FEEDBACK_CAPACITY: usize = 4096;

/// What a link connects to.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkConfig {
    /// `sim` for the simulated gateway, otherwise a serial device such as `/dev/ttyUSB0`.
    pub port: String,
    /// The line's speed, baud (8N1: baud / 10 bytes per second).
    pub baud: u32,
    /// The simulated gateway's units (used when `port` is `sim`).
    pub sim: GatewayConfig,
}

impl LinkConfig {
    /// A link to `port` at `baud`; a simulated gateway gets the default 100 units.
    pub fn new(port: impl Into<String>, baud: u32) -> Self {
        Self {
            port: port.into(),
            baud,
            sim: GatewayConfig::default(),
        }
    }
}

/// A link's state as shown to operators.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkStatus {
    /// Up, connecting or down.
    pub state: LinkState,
    /// Bytes written per second over the last second.
    pub bytes_per_s: f64,
    /// Why the link is down (or the last reason it went down).
    pub error: Option<String>,
}

/// Why a write was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LinkError {
    /// The link is not connected right now; nothing was queued.
    #[error("gateway {port} is not connected{}", reason.as_deref().map(|r| format!(": {r}")).unwrap_or_default())]
    Down {
        /// The gateway's port.
        port: String,
        /// Why, if known.
        reason: Option<String>,
    },
    /// The link was shut down.
    #[error("gateway {port} is shut down")]
    Closed {
        /// The gateway's port.
        port: String,
    },
}

/// What the link's threads and handles share.
#[derive(Debug)]
struct Shared {
    index: usize,
    config: LinkConfig,
    lanes: Lanes,
    feedback: broadcast::Sender<Frame>,
    status: watch::Sender<LinkStatus>,
    closed: AtomicBool,
}

impl Shared {
    fn is_closed(&self) -> bool {
        self.closed.load(Ordering::Acquire)
    }

    fn close(&self) {
        self.closed.store(true, Ordering::Release);
        self.lanes.wake_writer();
        self.lanes.wake_senders();
    }

    fn set_state(&self, state: LinkState, error: Option<String>) {
        self.status.send_if_modified(|status| {
            let changed = status.state != state || (error.is_some() && status.error != error);
            status.state = state;
            if error.is_some() {
                status.error = error;
            }
            if state != LinkState::Up {
                status.bytes_per_s = 0.0;
            }
            changed
        });
        if state != LinkState::Up {
            // Nothing stale may reach the line when it comes back.
            self.lanes.lock().clear_all();
        }
        self.lanes.wake_senders();
    }

    fn publish_rate(&self, bytes_per_s: f64) {
        self.status
            .send_modify(|status| status.bytes_per_s = bytes_per_s);
    }

    fn down_error(&self) -> LinkError {
        LinkError::Down {
            port: self.config.port.clone(),
            reason: self.status.borrow().error.clone(),
        }
    }

    /// Sleeps for `duration` unless the link is closed first.
    fn sleep(&self, duration: Duration) {
        let deadline = Instant::now() + duration;
        let mut queues = self.lanes.lock();
        while !self.is_closed() {
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            queues = self.lanes.wait(queues, left);
        }
    }
}

/// Shuts the link down when the last handle is dropped.
#[derive(Debug)]
struct CloseOnDrop(Arc<Shared>);

impl Drop for CloseOnDrop {
    fn drop(&mut self) {
        self.0.close();
    }
}

/// A handle to one gateway's link. Cheap to clone; the link shuts down when the last
/// handle is dropped.
#[derive(Debug, Clone)]
pub struct Link {
    shared: Arc<Shared>,
    sim: Option<sim::SimView>,
    _close: Arc<CloseOnDrop>,
}

impl Link {
    /// Starts the link for gateway number `index` (its place in the configuration).
    /// It connects, and reconnects after a loss, by itself.
    pub fn open(index: usize, config: LinkConfig) -> Self {
        let (status, _) = watch::channel(LinkStatus {
            state: LinkState::Connecting,
            bytes_per_s: 0.0,
            error: None,
        });
        let shared = Arc::new(Shared {
            index,
            config,
            lanes: Lanes::new(BULK_CAPACITY_BYTES),
            feedback: broadcast::channel(FEEDBACK_CAPACITY).0,
            status,
            closed: AtomicBool::new(false),
        });
        let sim = if shared.config.port == SIM_PORT {
            sim::spawn(Arc::clone(&shared), shared.config.sim.clone())
        } else {
            serial::spawn(Arc::clone(&shared));
            None
        };
        Self {
            _close: Arc::new(CloseOnDrop(Arc::clone(&shared))),
            sim,
            shared,
        }
    }

    /// The gateway's place in the configuration.
    pub fn index(&self) -> usize {
        self.shared.index
    }

    /// The configured port (`sim` or a device path).
    pub fn port(&self) -> &str {
        &self.shared.config.port
    }

    /// The line's speed, baud.
    pub fn baud(&self) -> u32 {
        self.shared.config.baud
    }

    /// Queues `batch` on the bulk lane, waiting while the lane is full. The batch's
    /// instructions are written in order, after anything queued before.
    ///
    /// # Errors
    /// [`LinkError::Down`] while the link is not connected (nothing is queued), and
    /// [`LinkError::Closed`] after shutdown.
    pub async fn send(&self, batch: Batch) -> Result<(), LinkError> {
        if batch.is_empty() {
            return Ok(());
        }
        let lanes = &self.shared.lanes;
        loop {
            let room = lanes.room();
            tokio::pin!(room);
            room.as_mut().enable();
            {
                let mut queues = lanes.lock();
                if self.shared.is_closed() {
                    return Err(LinkError::Closed {
                        port: self.port().to_owned(),
                    });
                }
                if self.shared.status.borrow().state != LinkState::Up {
                    return Err(self.shared.down_error());
                }
                let queued = queues.bulk_bytes();
                if queued == 0 || queued + batch.len() <= lanes.capacity_bytes {
                    queues.push_bulk(&batch);
                    drop(queues);
                    lanes.wake_writer();
                    return Ok(());
                }
            }
            room.await;
        }
    }

    /// Queues `batch` on the bulk lane at once, whatever is queued already: for a
    /// caller that keeps the queue shallow itself (the player refills only when the
    /// queue has drained) and must not wait.
    ///
    /// # Errors
    /// As [`Link::send`].
    pub fn enqueue(&self, batch: &Batch) -> Result<(), LinkError> {
        let lanes = &self.shared.lanes;
        let mut queues = lanes.lock();
        if self.shared.is_closed() {
            return Err(LinkError::Closed {
                port: self.port().to_owned(),
            });
        }
        if self.shared.status.borrow().state != LinkState::Up {
            return Err(self.shared.down_error());
        }
        queues.push_bulk(batch);
        drop(queues);
        lanes.wake_writer();
        Ok(())
    }

    /// Queues `batch` on the priority lane: it is written before anything on the bulk
    /// lane, after at most the one instruction already on the wire.
    ///
    /// # Errors
    /// [`LinkError::Down`] / [`LinkError::Closed`] when it cannot be written.
    pub fn send_priority(&self, batch: &Batch) -> Result<(), LinkError> {
        let lanes = &self.shared.lanes;
        let mut queues = lanes.lock();
        if self.shared.is_closed() {
            return Err(LinkError::Closed {
                port: self.port().to_owned(),
            });
        }
        if self.shared.status.borrow().state != LinkState::Up {
            return Err(self.shared.down_error());
        }
        queues.push_priority(batch);
        drop(queues);
        lanes.wake_writer();
        Ok(())
    }

    /// The e-stop: drops every queued bulk instruction (nothing queued may start a
    /// motion afterwards) and writes `batch` ahead of everything.
    ///
    /// # Errors
    /// As [`Link::send_priority`].
    pub fn estop(&self, batch: &Batch) -> Result<(), LinkError> {
        self.clear_bulk();
        self.send_priority(batch)
    }

    /// Drops every queued bulk instruction; returns how many bytes were dropped.
    pub fn clear_bulk(&self) -> usize {
        let dropped = self.shared.lanes.lock().clear_bulk();
        self.shared.lanes.wake_senders();
        dropped
    }

    /// Bytes waiting on the bulk lane.
    pub fn queued_bytes(&self) -> usize {
        self.shared.lanes.lock().bulk_bytes()
    }

    /// Every feedback frame decoded from now on.
    pub fn feedback(&self) -> broadcast::Receiver<Frame> {
        self.shared.feedback.subscribe()
    }

    /// The simulated gateway behind this link, if it is one.
    pub fn sim_view(&self) -> Option<&sim::SimView> {
        self.sim.as_ref()
    }

    /// The link's status, updated on every change.
    pub fn status(&self) -> watch::Receiver<LinkStatus> {
        self.shared.status.subscribe()
    }
}

/// Writes one instruction to a line (a serial port, the simulator's input).
trait LineWrite {
    /// Hands `instruction` to the line.
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()>;
}

/// How often an idle writer wakes up to update the bytes/s figure.
const IDLE_TICK: Duration = Duration::from_millis(250);

/// Writes queued instructions to `line` until the link is closed, `lost` is set, or a
/// write fails; returns why it stopped.
fn run_writer(shared: &Shared, line: &mut impl LineWrite, lost: &AtomicBool) -> String {
    let lanes = &shared.lanes;
    let now = Instant::now();
    let mut pacer = Pacer::new(shared.config.baud, now);
    let mut meter = RateMeter::new(now);
    let mut instruction = Vec::with_capacity(floatball_shared::ascii::MAX_LEN);
    loop {
        let mut queues = lanes.lock();
        let from_bulk = loop {
            if shared.is_closed() {
                return "shut down".to_owned();
            }
            if lost.load(Ordering::Acquire) {
                return "the line was lost".to_owned();
            }
            let now = Instant::now();
            if let Some(rate) = meter.roll(now) {
                shared.publish_rate(rate);
            }
            let wait = if queues.has_work() {
                pacer.wait_before_next(now)
            } else {
                IDLE_TICK
            };
            if wait.is_zero()
                && let Some(from_bulk) = queues.pop_into(&mut instruction)
            {
                break from_bulk;
            }
            queues = lanes.wait(queues, wait.min(IDLE_TICK));
        };
        drop(queues);
        if from_bulk {
            lanes.wake_senders();
        }
        if let Err(err) = line.write_instruction(&instruction) {
            return format!("write failed: {err}");
        }
        let now = Instant::now();
        pacer.wrote(now, instruction.len());
        meter.add(now, instruction.len());
    }
}

/// Retry delays after a lost or failed connection: 250 ms doubling up to 5 s.
#[derive(Debug, Clone)]
struct Backoff {
    next: Duration,
}

impl Backoff {
    const FIRST: Duration = Duration::from_millis(250);
    const MAX: Duration = Duration::from_secs(5);

    fn new() -> Self {
        Self { next: Self::FIRST }
    }

    fn reset(&mut self) {
        self.next = Self::FIRST;
    }

    fn next_delay(&mut self) -> Duration {
        let delay = self.next;
        self.next = (self.next * 2).min(Self::MAX);
        delay
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backoff_doubles_up_to_five_seconds() {
        let mut backoff = Backoff::new();
        let delays: Vec<u128> = (0..7).map(|_| backoff.next_delay().as_millis()).collect();
        assert_eq!(delays, [250, 500, 1000, 2000, 4000, 5000, 5000]);
        backoff.reset();
        assert_eq!(backoff.next_delay(), Backoff::FIRST);
    }

    #[test]
    fn down_errors_name_the_port_and_reason() {
        let error = LinkError::Down {
            port: "/dev/ttyUSB0".into(),
            reason: Some("No such file or directory".into()),
        };
        assert_eq!(
            error.to_string(),
            "gateway /dev/ttyUSB0 is not connected: No such file or directory"
        );
    }
}
