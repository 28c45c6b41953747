//! Links to the gateways: one per configured gateway, a real serial port or the
//! simulated gateway, behind the same [`Link`] handle.
//!
//! **One owner.** A link's queues belong to its writer thread and to nothing else: the
//! handles hand batches over through a channel and wake the writer; the counters the
//! rest of the bridge reads (bytes queued, bytes written, up or down) are atomics the
//! writer keeps; the link's status (state, bytes/s, error) is written only by the
//! link's own threads and read as snapshots. No lock is shared between a handle and
//! the writer, so no reader can ever hold the writer up.
//!
//! Every link has two write lanes ([`lanes`]): the **priority** lane (the synchronised
//! start, the stop) is always written before the **bulk** lane, and the writer hands
//! the port one instruction at a time, paced to the line's speed ([`pacer`]), so the
//! e-stop waits for at most the one instruction already on the wire. The e-stop is not
//! a message in a queue: the writer reads the [`Latch`]'s generation before every
//! instruction, and when it moved it drops everything queued and writes the stop first
//! (see [`crate::estop`]). While the latch is set only inert instructions (queries,
//! selections, motor off) are written, and batches issued before the e-stop are void.
//!
//! Bytes read back go through the feedback decoder and are broadcast as frames. A lost
//! link is reported in its status, everything queued is dropped (nothing stale is sent
//! later), and the link is retried with backoff while the daemon keeps serving; when it
//! comes back while the e-stop is latched, the stop is its first write.
//!
//! - [`lanes`]: the two lanes and the station re-selection after a priority write;
//! - [`pacer`]: line timing and the bytes/s meter;
//! - [`serial`]: serial ports through the `serialport` crate;
//! - [`sim`]: the simulated gateway behind a virtual line as slow as a real one.

pub mod lanes;
pub mod pacer;
pub mod serial;
pub mod sim;

use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use floatball_shared::api::LinkState;
use floatball_shared::ascii::{Form, parse_script};
use floatball_shared::feedback::Frame;
use floatball_shared::plan::installation::SIM_PORT;
use floatball_shared::sim::GatewayConfig;
use tokio::sync::{Notify, broadcast, watch};

pub use floatball_shared::ascii::Batch;
use lanes::{Popped, Queues};
use pacer::{Pacer, RateMeter};

use crate::estop::Latch;

/// How many bytes the bulk lane holds before [`Link::send`] waits.
pub const BULK_CAPACITY_BYTES: usize = 64 * 1024;

/// How many decoded frames a slow feedback subscriber may fall behind.
const FEEDBACK_CAPACITY: usize = 4096;

/// The stop instructions of the e-stop unless `[safety] estop` says otherwise; a link
/// writes them after `*0;` (every unit), so the default e-stop is `*0;MO=0;`.
pub const DEFAULT_STOP: &str = "MO=0;";

/// What a link connects to.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    /// `sim` for the simulated gateway, otherwise a serial device such as `/dev/ttyUSB0`.
    pub port: String,
    /// The line's speed, baud (8N1: baud / 10 bytes per second).
    pub baud: u32,
    /// The simulated gateway's units (used when `port` is `sim`).
    pub sim: GatewayConfig,
    /// The stop written ahead of everything when the e-stop is pressed.
    pub estop: Batch,
    /// The e-stop latch this link obeys (one for the whole installation).
    pub latch: Arc<Latch>,
}

impl LinkConfig {
    /// A link to `port` at `baud` with a latch of its own and the default stop
    /// (`*0;MO=0;`); a simulated gateway gets the default 100 units.
    pub fn new(port: impl Into<String>, baud: u32) -> Self {
        let estop = parse_script(&format!("*0;{DEFAULT_STOP}"))
            .ok()
            .and_then(|stop| Batch::encode(&stop, Form::Standard).ok())
            .unwrap_or_default();
        Self {
            port: port.into(),
            baud,
            sim: GatewayConfig::default(),
            estop,
            latch: Arc::new(Latch::new()),
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

/// What a handle hands the writer.
#[derive(Debug)]
enum Input {
    /// Instructions for the bulk lane, issued at an e-stop generation.
    Bulk { generation: u64, batch: Batch },
    /// Instructions for the priority lane, issued at an e-stop generation.
    Priority { generation: u64, batch: Batch },
}

fn state_code(state: LinkState) -> u8 {
    match state {
        LinkState::Connecting => 0,
        LinkState::Up => 1,
        LinkState::Down => 2,
        LinkState::NotAnswering => 3,
    }
}

/// What the link's threads and handles share: configuration, atomics, channels. The
/// queues are not here: they live in the writer.
#[derive(Debug)]
struct Shared {
    index: usize,
    config: LinkConfig,
    inbox: Sender<Input>,
    /// The thread that writes (and, for a serial link, supervises): woken by handles.
    writer: OnceLock<Thread>,
    /// Bulk bytes handed over and neither written nor dropped yet.
    queued_bytes: AtomicUsize,
    /// Bytes written to the line since the link was opened.
    written_bytes: AtomicU64,
    /// Instructions dropped because they were void or refused while latched.
    dropped_instructions: AtomicU64,
    /// [`LinkState`] as a number, for lock-free checks.
    state: AtomicU8,
    /// Wakes senders waiting for room on the bulk lane.
    room: Notify,
    feedback: broadcast::Sender<Frame>,
    /// Written only by the link's own threads.
    status: watch::Sender<LinkStatus>,
    closed: AtomicBool,
}

impl Shared {
    fn is_closed(&self) -> bool {
        self.closed.load(Ordering::Acquire)
    }

    fn close(&self) {
        self.closed.store(true, Ordering::Release);
        self.wake();
        self.room.notify_waiters();
    }

    /// Wakes the writer thread (a no-op before it started: it looks at everything
    /// when it does).
    fn wake(&self) {
        if let Some(writer) = self.writer.get() {
            writer.unpark();
        }
    }

    /// Called by the writer thread once, when it starts.
    fn register_writer(&self) {
        let _ = self.writer.set(std::thread::current());
    }

    fn is_up(&self) -> bool {
        self.state.load(Ordering::Acquire) == state_code(LinkState::Up)
    }

    /// Changes the state; only the link's own threads call this.
    fn set_state(&self, state: LinkState, error: Option<String>) {
        self.state.store(state_code(state), Ordering::Release);
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
        self.room.notify_waiters();
    }

    fn publish_rate(&self, bytes_per_s: f64) {
        self.status
            .send_modify(|status| status.bytes_per_s = bytes_per_s);
    }

    /// Counts `bytes` of bulk as no longer queued.
    fn unqueue(&self, bytes: usize) {
        if bytes == 0 {
            return;
        }
        let _ = self
            .queued_bytes
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |queued| {
                Some(queued.saturating_sub(bytes))
            });
        self.room.notify_waiters();
    }

    /// Whether the link can take writes now: not shut down, and up.
    fn writable(&self) -> Result<(), LinkError> {
        if self.is_closed() {
            return Err(LinkError::Closed {
                port: self.config.port.clone(),
            });
        }
        if !self.is_up() {
            return Err(LinkError::Down {
                port: self.config.port.clone(),
                reason: self.status.borrow().error.clone(),
            });
        }
        Ok(())
    }

    /// Hands `input` to the writer and wakes it.
    fn hand_over(&self, input: Input) -> Result<(), LinkError> {
        let bulk_bytes = match &input {
            Input::Bulk { batch, .. } => batch.len(),
            Input::Priority { .. } => 0,
        };
        self.queued_bytes.fetch_add(bulk_bytes, Ordering::AcqRel);
        if self.inbox.send(input).is_err() {
            self.unqueue(bulk_bytes);
            return Err(LinkError::Closed {
                port: self.config.port.clone(),
            });
        }
        self.wake();
        Ok(())
    }

    /// Drops everything handed over and not taken yet (before a connection starts:
    /// nothing stale reaches a line that comes back).
    fn drop_inbox(&self, inbox: &Receiver<Input>) {
        while let Ok(input) = inbox.try_recv() {
            if let Input::Bulk { batch, .. } = input {
                self.unqueue(batch.len());
            }
        }
    }

    /// Sleeps for `duration` unless the link is closed first; drops what is handed
    /// over meanwhile (the link is down).
    fn sleep(&self, inbox: &Receiver<Input>, duration: Duration) {
        let deadline = Instant::now() + duration;
        while !self.is_closed() {
            self.drop_inbox(inbox);
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                break;
            }
            std::thread::park_timeout(left);
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
        let (inbox, taken) = channel();
        let shared = Arc::new(Shared {
            index,
            config,
            inbox,
            writer: OnceLock::new(),
            queued_bytes: AtomicUsize::new(0),
            written_bytes: AtomicU64::new(0),
            dropped_instructions: AtomicU64::new(0),
            state: AtomicU8::new(state_code(LinkState::Connecting)),
            room: Notify::new(),
            feedback: broadcast::channel(FEEDBACK_CAPACITY).0,
            status,
            closed: AtomicBool::new(false),
        });
        let sim = if shared.config.port == SIM_PORT {
            sim::spawn(Arc::clone(&shared), shared.config.sim.clone(), taken)
        } else {
            serial::spawn(Arc::clone(&shared), taken);
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

    /// The e-stop latch this link obeys.
    pub fn latch(&self) -> &Arc<Latch> {
        &self.shared.config.latch
    }

    /// Queues `batch` on the bulk lane as a request issued now, waiting while the lane
    /// is full. The batch's instructions are written in order, after anything queued
    /// before.
    ///
    /// # Errors
    /// [`LinkError::Down`] while the link is not connected (nothing is queued), and
    /// [`LinkError::Closed`] after shutdown.
    pub async fn send(&self, batch: Batch) -> Result<(), LinkError> {
        let generation = self.latch().generation();
        self.send_issued(batch, generation).await
    }

    /// As [`Link::send`], for a request issued at e-stop `generation` (void if the
    /// e-stop was pressed since).
    ///
    /// # Errors
    /// As [`Link::send`].
    pub async fn send_issued(&self, batch: Batch, generation: u64) -> Result<(), LinkError> {
        if batch.is_empty() {
            return Ok(());
        }
        let shared = &self.shared;
        loop {
            let room = shared.room.notified();
            tokio::pin!(room);
            room.as_mut().enable();
            shared.writable()?;
            let queued = shared.queued_bytes.load(Ordering::Acquire);
            if queued == 0 || queued + batch.len() <= BULK_CAPACITY_BYTES {
                return shared.hand_over(Input::Bulk { generation, batch });
            }
            room.await;
        }
    }

    /// Queues `batch` on the bulk lane at once, whatever is queued already: for a
    /// caller that keeps the queue shallow itself (the player refills only when the
    /// queue has drained) and must not wait. `generation` is the e-stop generation the
    /// batch was issued at.
    ///
    /// # Errors
    /// As [`Link::send`].
    pub fn enqueue(&self, batch: &Batch, generation: u64) -> Result<(), LinkError> {
        self.shared.writable()?;
        self.shared.hand_over(Input::Bulk {
            generation,
            batch: batch.clone(),
        })
    }

    /// Queues `batch` on the priority lane: it is written before anything on the bulk
    /// lane, after at most the one instruction already on the wire.
    ///
    /// # Errors
    /// [`LinkError::Down`] / [`LinkError::Closed`] when it cannot be written.
    pub fn send_priority(&self, batch: &Batch, generation: u64) -> Result<(), LinkError> {
        self.shared.writable()?;
        self.shared.hand_over(Input::Priority {
            generation,
            batch: batch.clone(),
        })
    }

    /// The e-stop for this link alone (its latch, pressed): see [`crate::estop::press`].
    /// Returns why the stop cannot reach the gateway now, if it cannot.
    pub fn estop(&self) -> Option<String> {
        crate::estop::press(self.latch(), std::slice::from_ref(self))
            .into_iter()
            .next()
    }

    /// Wakes the writer: it looks at the latch and its inbox at once.
    pub fn wake(&self) {
        self.shared.wake();
    }

    /// Whether the link is up (lock-free).
    pub fn is_up(&self) -> bool {
        self.shared.is_up()
    }

    /// Bulk bytes handed to the link and not written (or dropped) yet; an instruction
    /// being written counts until the port took it.
    pub fn queued_bytes(&self) -> usize {
        self.shared.queued_bytes.load(Ordering::Acquire)
    }

    /// Bytes written to the line since the link was opened.
    pub fn written_bytes(&self) -> u64 {
        self.shared.written_bytes.load(Ordering::Acquire)
    }

    /// Instructions dropped because the e-stop voided them or refused them.
    pub fn dropped_instructions(&self) -> u64 {
        self.shared.dropped_instructions.load(Ordering::Acquire)
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

    /// The link's status now, copied out.
    pub fn snapshot(&self) -> LinkStatus {
        self.shared.status.borrow().clone()
    }
}

/// Writes one instruction to a line (a serial port, the simulator's input).
trait LineWrite {
    /// Hands `instruction` to the line.
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()>;
}

/// How often an idle writer wakes up to update the bytes/s figure.
const IDLE_TICK: Duration = Duration::from_millis(250);

/// Whether one instruction's bytes may be written while the e-stop is latched.
fn is_inert(instruction: &[u8]) -> bool {
    std::str::from_utf8(instruction)
        .ok()
        .and_then(|text| parse_script(text).ok())
        .is_some_and(|parsed| {
            parsed
                .iter()
                .all(floatball_shared::ascii::Instruction::is_inert)
        })
}

/// The writer's own state: the queues, and the e-stop generation it last acted on.
struct Writer<'a> {
    shared: &'a Shared,
    queues: Queues,
    seen_generation: u64,
}

impl Writer<'_> {
    /// Acts on a new e-stop generation: everything queued is void, the stop goes first.
    fn observe_latch(&mut self) {
        let generation = self.shared.config.latch.generation();
        if generation == self.seen_generation {
            return;
        }
        self.seen_generation = generation;
        self.stop();
    }

    fn stop(&mut self) {
        let dropped = self.queues.clear_bulk();
        self.queues.clear_priority();
        self.shared.unqueue(dropped);
        self.queues.push_priority(&self.shared.config.estop);
    }

    /// Takes one handed-over input into the queues, dropping it if it is void.
    fn accept(&mut self, input: Input) {
        let (generation, batch, bulk) = match input {
            Input::Bulk { generation, batch } => (generation, batch, true),
            Input::Priority { generation, batch } => (generation, batch, false),
        };
        if generation > self.seen_generation {
            // Issued after an e-stop this writer has not acted on yet: act first.
            self.observe_latch();
        }
        let count = batch.instruction_count() as u64;
        let void = generation < self.seen_generation;
        if void {
            self.shared
                .dropped_instructions
                .fetch_add(count, Ordering::Relaxed);
            if bulk {
                self.shared.unqueue(batch.len());
            }
            return;
        }
        let latched = self.shared.config.latch.is_latched();
        let keep = |instruction: &[u8]| !latched || is_inert(instruction);
        let refused = if bulk {
            self.queues.push_bulk_filtered(&batch, keep)
        } else {
            self.queues.push_priority_filtered(&batch, keep)
        };
        if refused > 0 {
            tracing::warn!(
                "gateway {}: {refused} bytes of motion refused while the e-stop is latched",
                self.shared.config.port
            );
            self.shared
                .dropped_instructions
                .fetch_add(1, Ordering::Relaxed);
            if bulk {
                self.shared.unqueue(refused);
            }
        }
    }
}

/// Writes queued instructions to `line` until the link is closed, `lost` is set, or a
/// write fails; returns why it stopped. The calling thread must have registered as the
/// link's writer. Whatever is still queued when it returns is dropped.
fn run_writer(
    shared: &Shared,
    inbox: &Receiver<Input>,
    line: &mut impl LineWrite,
    lost: &AtomicBool,
) -> String {
    let now = Instant::now();
    let mut pacer = Pacer::new(shared.config.baud, now);
    let mut meter = RateMeter::new(now);
    let mut instruction = Vec::with_capacity(floatball_shared::ascii::MAX_LEN);
    let mut writer = Writer {
        shared,
        queues: Queues::default(),
        seen_generation: shared.config.latch.generation(),
    };
    if shared.config.latch.is_latched() {
        // Back while the e-stop is in force: the units behind this gateway may not
        // have heard it.
        writer.stop();
    }
    let reason = loop {
        if shared.is_closed() {
            break "shut down".to_owned();
        }
        if lost.load(Ordering::Acquire) {
            break "the line was lost".to_owned();
        }
        writer.observe_latch();
        while let Ok(input) = inbox.try_recv() {
            writer.accept(input);
        }
        let now = Instant::now();
        if let Some(rate) = meter.roll(now) {
            shared.publish_rate(rate);
        }
        let wait = if writer.queues.has_work() {
            pacer.wait_before_next(now)
        } else {
            IDLE_TICK
        };
        if !wait.is_zero() {
            std::thread::park_timeout(wait.min(IDLE_TICK));
            continue;
        }
        let Some(popped) = writer.queues.pop_into(&mut instruction) else {
            continue;
        };
        if let Err(err) = line.write_instruction(&instruction) {
            if popped == Popped::Bulk {
                shared.unqueue(instruction.len());
            }
            break format!("write failed: {err}");
        }
        let now = Instant::now();
        pacer.wrote(now, instruction.len());
        meter.add(now, instruction.len());
        shared
            .written_bytes
            .fetch_add(instruction.len() as u64, Ordering::AcqRel);
        if popped == Popped::Bulk {
            shared.unqueue(instruction.len());
        }
    };
    let left = writer.queues.clear_bulk();
    shared.unqueue(left);
    shared.drop_inbox(inbox);
    reason
}

/// Retry delays after a lost or failed connection: 250 ms doubling up to 5 s.
#[derive(Debug, Clone)]
pub(crate) struct Backoff {
    next: Duration,
}

impl Backoff {
    const FIRST: Duration = Duration::from_millis(250);
    const MAX: Duration = Duration::from_secs(5);

    pub(crate) fn new() -> Self {
        Self { next: Self::FIRST }
    }

    pub(crate) fn reset(&mut self) {
        self.next = Self::FIRST;
    }

    pub(crate) fn next_delay(&mut self) -> Duration {
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
    fn only_inert_instruction_bytes_pass_the_latch() {
        for inert in [&b"*0;"[..], b"PA;", b"MO=0;", b"SN;", b"QP[3];"] {
            assert!(is_inert(inert), "{}", String::from_utf8_lossy(inert));
        }
        for active in [
            &b"MO1;"[..],
            b"PA0;",
            b"BG;",
            b"QP[16]162878;",
            b"SP25000;",
            b"\xff;",
        ] {
            assert!(!is_inert(active), "{}", String::from_utf8_lossy(active));
        }
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
