//! Links to the gateways: one per configured gateway, a real serial port, a serial
//! device server on the network (`tcp://`, `rfc2217://`) or the simulated gateway,
//! behind the same [`Link`] handle; [`Link::open`] tells them apart by
//! [`PortAddress::parse`], the one parser of a gateway's `port`.
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
//! **Presence.** An open port is not a gateway: the writer greets the gateway (`ABC;`,
//! `docs/uim2503.md` §2, `docs/protocol-notes.md` §3) as soon as the line opens and again whenever the line has been
//! idle for [`GREETING_INTERVAL`]. The link is `Up` only once the gateway has answered
//! (`AA AB AC`, or any feedback frame); [`MISSED_GREETINGS`] greetings in a row left
//! unanswered for [`ANSWER_TIMEOUT`] each make it `NotAnswering` (writes are refused,
//! but the e-stop is still written), and it greets every [`GREETING_RETRY`] until an
//! answer brings it back `Up`.
//!
//! **Line speed.** [`Link::baud`] is the line's live speed; [`Link::change_baud`] moves
//! the gateway and the line to another one (`BDR=x;`, the gateway's restart, the line
//! switched, greeted at the new speed; back to the old speed if nothing answers).
//!
//! - [`lanes`]: the two lanes and the station re-selection after a priority write;
//! - [`pacer`]: line timing and the bytes/s meter;
//! - [`supervisor`]: open, lose, report, back off, open again — the loop a serial
//!   link and a network link share;
//! - [`serial`]: serial ports through the `serialport` crate;
//! - [`net`]: serial device servers over TCP, raw or RFC 2217;
//! - [`telnet`]: Telnet and RFC 2217 COM-port control, sans IO;
//! - [`sim`]: the simulated gateway behind a virtual line as slow as a real one;
//! - [`writer`]: the writer's turn ([`writer::Drive::step`]) and the thread that runs
//!   it for one serial or simulated link;
//! - [`driver`]: the one thread that reads and writes every network link.

pub mod driver;
pub mod lanes;
pub mod net;
pub mod pacer;
pub mod serial;
pub mod sim;
pub mod supervisor;
pub mod telnet;
pub mod writer;

use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use floatball_shared::api::{BaudChanged, LinkState};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::plan::port::PortAddress;
use floatball_shared::uim2503::ascii::GreetingWatch;
use floatball_shared::uim2503::ascii::gateway::{MAX_BAUD, MIN_BAUD};
use floatball_shared::uim2503::ascii::{Form, parse_script};
use floatball_shared::uim2503::feedback::{Frame, FrameDecoder};
use floatball_shared::uim2503::sim::GatewayConfig;
use tokio::sync::{Notify, broadcast, oneshot, watch};

pub use floatball_shared::uim2503::ascii::Batch;

use crate::estop::Latch;

/// How many bytes the bulk lane holds before [`Link::send`] waits.
pub const BULK_CAPACITY_BYTES: usize = 64 * 1024;

/// How many decoded frames a slow feedback subscriber may fall behind.
const FEEDBACK_CAPACITY: usize = 4096;

/// How long the line must have been idle before the link greets the gateway again.
pub const GREETING_INTERVAL: Duration = Duration::from_secs(2);

/// How long the gateway has to answer a greeting, from when the greeting has crossed
/// the line.
pub const ANSWER_TIMEOUT: Duration = Duration::from_secs(1);

/// How many greetings in a row must go unanswered before the link counts as not
/// answering (one late answer on a busy machine is not a missing gateway).
pub const MISSED_GREETINGS: u32 = 2;

/// How often a link greets a gateway that does not answer (and, during a line-speed
/// change, one that is restarting).
pub const GREETING_RETRY: Duration = Duration::from_millis(250);

/// What a link says while its gateway does not answer.
const NOT_ANSWERING: &str = "the gateway does not answer the greeting (ABC;)";

/// The stop instructions of the e-stop unless `[safety] estop` says otherwise; a link
/// writes them after `*0;` (every unit), so the default e-stop is `*0;MO=0;`.
pub const DEFAULT_STOP: &str = "MO=0;";

/// What a link connects to.
#[derive(Debug, Clone)]
pub struct LinkConfig {
    /// `sim` for the simulated gateway, a serial device such as `/dev/ttyUSB0`, or a
    /// serial device server: `tcp://host:port` or `rfc2217://host:port`.
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

/// Why a line-speed change did not happen.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum BaudError {
    /// A speed `BDR=x;` does not take.
    #[error("{baud} baud is not a line speed the gateway takes ({MIN_BAUD}–{MAX_BAUD})")]
    OutOfRange {
        /// The speed asked for.
        baud: u32,
    },
    /// The link cannot write now (down, not answering, shut down, or busy with another
    /// change); nothing was sent.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The e-stop is latched: `BDR=x;` is not inert; nothing was sent.
    #[error("the e-stop is latched: the line speed cannot change until it is released")]
    EstopLatched,
    /// The port refused the new speed; the line is back at the old one.
    #[error("gateway {port}: the port cannot run at {baud} baud: {reason}")]
    Port {
        /// The gateway's port.
        port: String,
        /// The speed asked for.
        baud: u32,
        /// The port's refusal.
        reason: String,
    },
    /// The gateway did not answer at the new speed within the wait; the line is back
    /// at the old speed (where the gateway answers again only if it did not restart).
    #[error(
        "gateway {port} did not answer at {baud} baud within {waited_ms} ms; the line is \
         back at {from_baud} baud"
    )]
    NotAnswering {
        /// The gateway's port.
        port: String,
        /// The speed asked for.
        baud: u32,
        /// The speed the line is back at.
        from_baud: u32,
        /// How long the link waited, ms.
        waited_ms: u64,
    },
}

impl Coded for BaudError {
    fn code(&self) -> Code {
        match self {
            Self::OutOfRange { .. } => Code::BaudOutOfRange,
            Self::Link(_) => Code::GatewayNotConnected,
            Self::EstopLatched => Code::EstopLatched,
            Self::Port { .. } => Code::BaudPortRefused,
            Self::NotAnswering { .. } => Code::BaudNotAnswering,
        }
    }

    fn params(&self) -> Params {
        let mut params = Params::new();
        let mut put = |name: &str, value: String| {
            params.insert(name.into(), value);
        };
        match self {
            Self::OutOfRange { baud } => {
                put("baud", baud.to_string());
                put("min", MIN_BAUD.to_string());
                put("max", MAX_BAUD.to_string());
            }
            Self::Link(LinkError::Down { port, .. } | LinkError::Closed { port }) => {
                put("gateway", port.clone());
            }
            Self::EstopLatched => {}
            Self::Port { port, baud, reason } => {
                put("gateway", port.clone());
                put("baud", baud.to_string());
                put("reason", reason.clone());
            }
            Self::NotAnswering {
                port,
                baud,
                from_baud,
                waited_ms,
            } => {
                put("gateway", port.clone());
                put("baud", baud.to_string());
                put("from_baud", from_baud.to_string());
                put("waited_ms", waited_ms.to_string());
            }
        }
        params
    }
}

/// What the writer answers a line-speed change with.
type BaudReply = oneshot::Sender<Result<BaudChanged, BaudError>>;

/// What a handle hands the writer.
#[derive(Debug)]
enum Input {
    /// Instructions for the bulk lane, issued at an e-stop generation.
    Bulk { generation: u64, batch: Batch },
    /// Instructions for the priority lane, issued at an e-stop generation, written not
    /// before `not_before` (the synchronised start: every line free for it then).
    Priority {
        generation: u64,
        batch: Batch,
        not_before: Option<Instant>,
    },
    /// Move the gateway and the line to `baud`, waiting up to `restart_wait` for the
    /// gateway to answer at it.
    ChangeBaud {
        baud: u32,
        restart_wait: Duration,
        reply: BaudReply,
    },
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
    /// The thread that writes (and, for a serial or network link, supervises): woken
    /// by handles.
    writer: OnceLock<Thread>,
    /// The network driver's thread, for a network link: it writes while the line is
    /// open, so handles wake it too.
    driver: OnceLock<Thread>,
    /// Bulk bytes handed over and neither written nor dropped yet.
    queued_bytes: AtomicUsize,
    /// Bytes written to the line since the link was opened.
    written_bytes: AtomicU64,
    /// Instructions dropped because they were void or refused while latched.
    dropped_instructions: AtomicU64,
    /// [`LinkState`] as a number, for lock-free checks.
    state: AtomicU8,
    /// The line's speed now, baud.
    baud: AtomicU32,
    /// Greeting answers read from the gateway so far.
    greetings_answered: AtomicU64,
    /// Feedback frames read from the gateway so far.
    frames_read: AtomicU64,
    /// The writer waits for an answer to a greeting (the readers wake it on a frame).
    awaiting_answer: AtomicBool,
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
        if let Some(driver) = self.driver.get() {
            driver.unpark();
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

    /// The speed the line runs at now, baud.
    fn baud(&self) -> u32 {
        self.baud.load(Ordering::Acquire)
    }

    /// What a reader does with the bytes it read from the gateway: finds greeting
    /// answers and frames, broadcasts the frames, and wakes a writer waiting for an
    /// answer.
    fn heard(&self, watch: &mut GreetingWatch, decoder: &mut FrameDecoder, bytes: &[u8]) {
        let answers = watch.push(bytes);
        let mut frames = 0;
        for frame in decoder.push(bytes) {
            frames += 1;
            // No subscriber is fine: nobody is listening right now.
            let _ = self.feedback.send(frame);
        }
        if answers > 0 {
            self.greetings_answered
                .fetch_add(answers as u64, Ordering::AcqRel);
        }
        if frames > 0 {
            self.frames_read.fetch_add(frames, Ordering::AcqRel);
        }
        if (answers > 0 || frames > 0) && self.awaiting_answer.load(Ordering::Acquire) {
            self.wake();
        }
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

    /// Hands `input` to the writer and wakes it — unless it is bulk for a link with
    /// bulk still queued: that writer is busy and takes it on its next turn anyway (a
    /// refill does not cost the writer a wake-up).
    fn hand_over(&self, input: Input) -> Result<(), LinkError> {
        let bulk_bytes = match &input {
            Input::Bulk { batch, .. } => Some(batch.len()),
            Input::Priority { .. } | Input::ChangeBaud { .. } => None,
        };
        let queued_before = self
            .queued_bytes
            .fetch_add(bulk_bytes.unwrap_or(0), Ordering::AcqRel);
        if self.inbox.send(input).is_err() {
            self.unqueue(bulk_bytes.unwrap_or(0));
            return Err(LinkError::Closed {
                port: self.config.port.clone(),
            });
        }
        if bulk_bytes.is_none() || queued_before == 0 {
            self.wake();
        }
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

/// Subscribes to a link's feedback frames on demand, without keeping the link open
/// ([`Link::feedback_source`]).
#[derive(Debug, Clone)]
pub struct FeedbackSource {
    shared: std::sync::Weak<Shared>,
}

impl FeedbackSource {
    /// Every frame decoded from now on; `None` once the link is shut down.
    pub fn subscribe(&self) -> Option<broadcast::Receiver<Frame>> {
        let shared = self.shared.upgrade()?;
        (!shared.is_closed()).then(|| shared.feedback.subscribe())
    }

    /// Whether the link is still open.
    pub fn is_open(&self) -> bool {
        self.shared
            .upgrade()
            .is_some_and(|shared| !shared.is_closed())
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
        let baud = config.baud;
        let shared = Arc::new(Shared {
            index,
            config,
            inbox,
            writer: OnceLock::new(),
            driver: OnceLock::new(),
            queued_bytes: AtomicUsize::new(0),
            written_bytes: AtomicU64::new(0),
            dropped_instructions: AtomicU64::new(0),
            state: AtomicU8::new(state_code(LinkState::Connecting)),
            baud: AtomicU32::new(baud),
            greetings_answered: AtomicU64::new(0),
            frames_read: AtomicU64::new(0),
            awaiting_answer: AtomicBool::new(false),
            room: Notify::new(),
            feedback: broadcast::channel(FEEDBACK_CAPACITY).0,
            status,
            closed: AtomicBool::new(false),
        });
        let sim = match PortAddress::parse(&shared.config.port) {
            Ok(PortAddress::Sim) => {
                sim::spawn(Arc::clone(&shared), shared.config.sim.clone(), taken)
            }
            Ok(PortAddress::Serial(device)) => {
                supervisor::spawn(
                    Arc::clone(&shared),
                    taken,
                    serial::SerialConnector { device },
                );
                None
            }
            Ok(PortAddress::Tcp(address)) => {
                let connector = net::NetConnector::new(address, net::Mode::Raw);
                supervisor::spawn(Arc::clone(&shared), taken, connector);
                None
            }
            Ok(PortAddress::Rfc2217(address)) => {
                let connector = net::NetConnector::new(address, net::Mode::Rfc2217);
                supervisor::spawn(Arc::clone(&shared), taken, connector);
                None
            }
            Err(err) => {
                // The configuration check refuses such a port; a link opened anyway
                // stays down and says why.
                supervisor::spawn(
                    Arc::clone(&shared),
                    taken,
                    supervisor::Unusable(err.to_string()),
                );
                None
            }
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

    /// The configured port (`sim`, a device path, `tcp://…` or `rfc2217://…`).
    pub fn port(&self) -> &str {
        &self.shared.config.port
    }

    /// The line's speed now, baud: the configured one until [`Link::change_baud`]
    /// moved it.
    pub fn baud(&self) -> u32 {
        self.shared.baud()
    }

    /// Moves the gateway and the line to `baud`: writes `BDR=x;` (after what is queued),
    /// restarts the gateway if it is the in-process simulator (a real one is
    /// power-cycled by the installer meanwhile), switches the line to `baud`, and greets
    /// the gateway every [`GREETING_RETRY`] until it answers or `restart_wait` has
    /// passed. The link is `Connecting` meanwhile (writes are refused; the e-stop still
    /// goes, at whatever speed the line runs at). On failure the line goes back to the
    /// old speed and greets the gateway there.
    ///
    /// # Errors
    /// [`BaudError::OutOfRange`] for a speed `BDR` does not take,
    /// [`BaudError::EstopLatched`] while the e-stop is latched, [`BaudError::Link`] when
    /// the link is not up (nothing is sent), [`BaudError::Port`] when the port refuses
    /// the speed (a raw `tcp://` device server always: its speed is set on the server),
    /// [`BaudError::NotAnswering`] when nothing answers at the new speed in
    /// time.
    pub async fn change_baud(
        &self,
        baud: u32,
        restart_wait: Duration,
    ) -> Result<BaudChanged, BaudError> {
        if !(MIN_BAUD..=MAX_BAUD).contains(&baud) {
            return Err(BaudError::OutOfRange { baud });
        }
        if self.latch().is_latched() {
            return Err(BaudError::EstopLatched);
        }
        if let Ok(PortAddress::Tcp(_)) = PortAddress::parse(self.port()) {
            // Refused before `BDR` goes out: the gateway would move and the line not.
            return Err(BaudError::Port {
                port: self.port().to_owned(),
                baud,
                reason: net::RAW_BAUD.to_owned(),
            });
        }
        self.shared.writable()?;
        let (reply, answer) = oneshot::channel();
        self.shared.hand_over(Input::ChangeBaud {
            baud,
            restart_wait,
            reply,
        })?;
        answer.await.map_err(|_| {
            BaudError::Link(LinkError::Down {
                port: self.port().to_owned(),
                reason: self.shared.status.borrow().error.clone(),
            })
        })?
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
        self.send_priority_at(batch, generation, None)
    }

    /// As [`Link::send_priority`], written not before `not_before` — the synchronised
    /// start, handed to every link ahead of its instant: meanwhile a link writes only
    /// what will have left the line by then, and at the instant the batch goes first.
    /// An e-stop pressed meanwhile voids it.
    ///
    /// # Errors
    /// As [`Link::send_priority`].
    pub fn send_priority_at(
        &self,
        batch: &Batch,
        generation: u64,
        not_before: Option<Instant>,
    ) -> Result<(), LinkError> {
        self.shared.writable()?;
        self.shared.hand_over(Input::Priority {
            generation,
            batch: batch.clone(),
            not_before,
        })
    }

    /// The e-stop for this link alone (its latch, pressed): see [`crate::estop::press`].
    /// Returns why the stop cannot reach the gateway now, if it cannot.
    pub fn estop(&self) -> Option<String> {
        crate::estop::press(self.latch(), &[self])
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

    /// A way to subscribe to the feedback later that does not keep the link open.
    pub fn feedback_source(&self) -> FeedbackSource {
        FeedbackSource {
            shared: Arc::downgrade(&self.shared),
        }
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

impl crate::estop::StopPort for Link {
    fn wake(&self) {
        Link::wake(self);
    }

    fn unreachable(&self) -> Vec<String> {
        if self.is_up() {
            Vec::new()
        } else {
            vec![format!(
                "gateway {} ({}) is not connected",
                self.index(),
                self.port()
            )]
        }
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
            assert!(
                writer::is_inert(inert),
                "{}",
                String::from_utf8_lossy(inert)
            );
        }
        for active in [
            &b"MO1;"[..],
            b"PA0;",
            b"BG;",
            b"QP[16]162878;",
            b"SP25000;",
            b"\xff;",
        ] {
            assert!(
                !writer::is_inert(active),
                "{}",
                String::from_utf8_lossy(active)
            );
        }
    }

    #[test]
    fn baud_errors_are_coded_with_their_figures() {
        let error = BaudError::NotAnswering {
            port: "/dev/ttyUSB0".into(),
            baud: 115_200,
            from_baud: 9600,
            waited_ms: 30_000,
        };
        assert_eq!(error.code(), Code::BaudNotAnswering);
        let params = error.params();
        assert_eq!(params.get("from_baud").map(String::as_str), Some("9600"));
        assert_eq!(params.get("waited_ms").map(String::as_str), Some("30000"));
        let error = BaudError::OutOfRange { baud: 4800 };
        assert_eq!(error.code(), Code::BaudOutOfRange);
        assert_eq!(error.params().get("min").map(String::as_str), Some("9600"));
        assert_eq!(
            error.to_string(),
            "4800 baud is not a line speed the gateway takes (9600–115200)"
        );
        let error = BaudError::from(LinkError::Closed { port: "sim".into() });
        assert_eq!(error.code(), Code::GatewayNotConnected);
        assert_eq!(
            error.params().get("gateway").map(String::as_str),
            Some("sim")
        );
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
