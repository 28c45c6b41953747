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
//! `PROTOCOL.md` §1.2) as soon as the line opens and again whenever the line has been
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
//! - [`sim`]: the simulated gateway behind a virtual line as slow as a real one.

pub mod lanes;
pub mod net;
pub mod pacer;
pub mod serial;
pub mod sim;
pub mod supervisor;
pub mod telnet;

use std::sync::atomic::{AtomicBool, AtomicU8, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use floatball_shared::api::{BaudChanged, LinkState};
use floatball_shared::ascii::GreetingWatch;
use floatball_shared::ascii::gateway::{GREETING, MAX_BAUD, MIN_BAUD};
use floatball_shared::ascii::{Form, GatewayCommand, Instruction, parse_script};
use floatball_shared::codes::{Code, Coded, Params};
use floatball_shared::feedback::{Frame, FrameDecoder};
use floatball_shared::plan::port::PortAddress;
use floatball_shared::sim::GatewayConfig;
use tokio::sync::{Notify, broadcast, oneshot, watch};

pub use floatball_shared::ascii::Batch;
use lanes::{Popped, Queues};
use pacer::{Pacer, RateMeter};

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
    /// Instructions for the priority lane, issued at an e-stop generation.
    Priority { generation: u64, batch: Batch },
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

    /// Hands `input` to the writer and wakes it.
    fn hand_over(&self, input: Input) -> Result<(), LinkError> {
        let bulk_bytes = match &input {
            Input::Bulk { batch, .. } => batch.len(),
            Input::Priority { .. } | Input::ChangeBaud { .. } => 0,
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
        let baud = config.baud;
        let shared = Arc::new(Shared {
            index,
            config,
            inbox,
            writer: OnceLock::new(),
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

    /// Switches the line (this end of it) to `baud`.
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()>;

    /// Restarts the gateway, if this line can (the in-process simulator); `false` when
    /// someone else has to (a real gateway is power-cycled by the installer).
    fn restart_gateway(&mut self) -> bool;
}

/// How often an idle writer wakes up to update the bytes/s figure.
const IDLE_TICK: Duration = Duration::from_millis(250);

/// The greeting the writer is waiting to see answered.
struct Greeting {
    /// Answers and frames read before it was sent.
    answers_before: u64,
    frames_before: u64,
    /// When it counts as unanswered.
    deadline: Instant,
}

/// The writer's greetings: when the next is due, the one awaiting its answer, and how
/// many in a row went unanswered.
struct Greeter {
    next_at: Instant,
    pending: Option<Greeting>,
    missed: u32,
}

/// What became of a greeting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Answer {
    /// The gateway answered (the greeting, or with any frame).
    Answered,
    /// [`MISSED_GREETINGS`] deadlines passed in a row.
    Unanswered,
}

impl Greeter {
    /// Greets at once.
    fn now(now: Instant) -> Self {
        Self {
            next_at: now,
            pending: None,
            missed: 0,
        }
    }

    /// Whether a greeting is due at `now` on a line with nothing else to write.
    fn due(&self, now: Instant) -> bool {
        self.pending.is_none() && now >= self.next_at
    }

    /// A greeting went out at `now`; the line is free again after `line_busy`.
    fn sent(&mut self, shared: &Shared, now: Instant, line_busy: Duration) {
        self.pending = Some(Greeting {
            answers_before: shared.greetings_answered.load(Ordering::Acquire),
            frames_before: shared.frames_read.load(Ordering::Acquire),
            deadline: now + line_busy + ANSWER_TIMEOUT,
        });
        shared.awaiting_answer.store(true, Ordering::Release);
    }

    /// Something other than a greeting was written at `now`: the line is not idle.
    fn wrote(&mut self, now: Instant) {
        if self.pending.is_none() {
            self.next_at = self.next_at.max(now + GREETING_INTERVAL);
        }
    }

    /// Whether the pending greeting has been answered or has timed out by `now`.
    fn check(&mut self, shared: &Shared, now: Instant) -> Option<Answer> {
        let pending = self.pending.as_ref()?;
        let answered = shared.greetings_answered.load(Ordering::Acquire) > pending.answers_before
            || shared.frames_read.load(Ordering::Acquire) > pending.frames_before;
        let answer = if answered {
            self.next_at = now + GREETING_INTERVAL;
            self.missed = 0;
            Some(Answer::Answered)
        } else if now >= pending.deadline {
            self.next_at = now + GREETING_RETRY;
            self.missed = self.missed.saturating_add(1);
            (self.missed >= MISSED_GREETINGS).then_some(Answer::Unanswered)
        } else {
            return None;
        };
        self.pending = None;
        shared.awaiting_answer.store(false, Ordering::Release);
        answer
    }

    /// How long the writer may sleep before the greeter needs it.
    fn wait(&self, now: Instant) -> Duration {
        match &self.pending {
            Some(pending) => pending.deadline.saturating_duration_since(now),
            None => self.next_at.saturating_duration_since(now),
        }
    }
}

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
    /// A line-speed change asked for and not carried out yet.
    baud_change: Option<(u32, Duration, BaudReply)>,
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

    /// Takes one handed-over input into the queues, dropping it if it is void; a
    /// line-speed change is kept for the writer to carry out once the queues are empty.
    fn accept(&mut self, input: Input) {
        let (generation, batch, bulk) = match input {
            Input::Bulk { generation, batch } => (generation, batch, true),
            Input::Priority { generation, batch } => (generation, batch, false),
            Input::ChangeBaud {
                baud,
                restart_wait,
                reply,
            } => {
                if self.baud_change.is_some() {
                    let _ = reply.send(Err(BaudError::Link(LinkError::Down {
                        port: self.shared.config.port.clone(),
                        reason: Some("another line-speed change is under way".to_owned()),
                    })));
                } else {
                    self.baud_change = Some((baud, restart_wait, reply));
                }
                return;
            }
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
/// write fails; returns why it stopped. Greets the gateway at once and whenever the line
/// is idle, and keeps the link's state (`Connecting` until the first answer, `Up`,
/// `NotAnswering`) by the answers. The calling thread must have registered as the
/// link's writer. Whatever is still queued when it returns is dropped.
fn run_writer(
    shared: &Shared,
    inbox: &Receiver<Input>,
    line: &mut impl LineWrite,
    lost: &AtomicBool,
) -> String {
    let now = Instant::now();
    let mut pacer = Pacer::new(shared.baud(), now);
    let mut meter = RateMeter::new(now);
    let mut instruction = Vec::with_capacity(floatball_shared::ascii::MAX_LEN);
    let mut writer = Writer {
        shared,
        queues: Queues::default(),
        seen_generation: shared.config.latch.generation(),
        baud_change: None,
    };
    let mut greeter = Greeter::now(now);
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
        match greeter.check(shared, now) {
            Some(Answer::Answered) => shared.set_state(LinkState::Up, None),
            Some(Answer::Unanswered) => {
                shared.set_state(LinkState::NotAnswering, Some(NOT_ANSWERING.to_owned()));
            }
            None => {}
        }
        let has_work = writer.queues.has_work();
        if !has_work && greeter.pending.is_none() && writer.baud_change.is_some() {
            if let Some((baud, restart_wait, reply)) = writer.baud_change.take() {
                let mut change = Change {
                    writer: &mut writer,
                    line: &mut *line,
                    pacer: &mut pacer,
                    lost,
                    buffer: &mut instruction,
                };
                match change.run(baud, restart_wait) {
                    Ok(result) => {
                        let _ = reply.send(result);
                    }
                    Err(err) => break format!("write failed: {err}"),
                }
                greeter = Greeter {
                    next_at: Instant::now() + GREETING_INTERVAL,
                    pending: None,
                    missed: 0,
                };
            }
            continue;
        }
        let line_wait = pacer.wait_before_next(now);
        if !has_work && greeter.due(now) && line_wait.is_zero() {
            if let Err(err) = line.write_instruction(GREETING) {
                break format!("write failed: {err}");
            }
            let free_at = pacer.wrote(now, GREETING.len());
            meter.add(now, GREETING.len());
            shared
                .written_bytes
                .fetch_add(GREETING.len() as u64, Ordering::AcqRel);
            greeter.sent(shared, now, free_at.saturating_duration_since(now));
            continue;
        }
        let wait = if has_work {
            line_wait
        } else {
            IDLE_TICK.min(greeter.wait(now)).max(line_wait)
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
        greeter.wrote(now);
        shared
            .written_bytes
            .fetch_add(instruction.len() as u64, Ordering::AcqRel);
        if popped == Popped::Bulk {
            shared.unqueue(instruction.len());
        }
    };
    shared.awaiting_answer.store(false, Ordering::Release);
    let left = writer.queues.clear_bulk();
    shared.unqueue(left);
    shared.drop_inbox(inbox);
    if let Some((_, _, reply)) = writer.baud_change.take() {
        let _ = reply.send(Err(BaudError::Link(LinkError::Down {
            port: shared.config.port.clone(),
            reason: Some(reason.clone()),
        })));
    }
    reason
}

/// A line-speed change, carried out by the writer thread (it owns the line).
struct Change<'w, 'a, L> {
    writer: &'w mut Writer<'a>,
    line: &'w mut L,
    pacer: &'w mut Pacer,
    lost: &'w AtomicBool,
    buffer: &'w mut Vec<u8>,
}

impl<L: LineWrite> Change<'_, '_, L> {
    /// `BDR=x;`, the restart, the switch, the greetings; on failure back to the old
    /// speed. `Err` only when the line failed.
    fn run(
        &mut self,
        baud: u32,
        restart_wait: Duration,
    ) -> std::io::Result<Result<BaudChanged, BaudError>> {
        let shared = self.writer.shared;
        let port = shared.config.port.clone();
        let from_baud = shared.baud();
        let started = Instant::now();
        // An e-stop pressed since the change was asked for: `BDR` is not inert, and
        // nothing but inert instructions goes out while the latch is set.
        self.writer.observe_latch();
        if shared.config.latch.is_latched() {
            return Ok(Err(BaudError::EstopLatched));
        }
        shared.set_state(
            LinkState::Connecting,
            Some(format!(
                "changing the line speed from {from_baud} to {baud} baud"
            )),
        );
        let mut bdr = Vec::new();
        let command = Instruction::Gateway(GatewayCommand::SetBaud { baud });
        if let Err(err) = command.encode_into(Form::Standard, &mut bdr) {
            shared.set_state(LinkState::Up, None);
            return Ok(Err(BaudError::Port {
                port,
                baud,
                reason: err.to_string(),
            }));
        }
        self.write(&bdr)?;
        // Until the gateway has read all of it.
        let crossed = self.pacer.wrote(Instant::now(), 0) + ANSWER_MARGIN;
        self.idle_until(crossed)?;
        let restarted_here = self.line.restart_gateway();
        if let Err(err) = self.switch(baud) {
            self.switch(from_baud)?;
            self.greet_until(Instant::now() + ANSWER_TIMEOUT * 2)?;
            return Ok(Err(BaudError::Port {
                port,
                baud,
                reason: err.to_string(),
            }));
        }
        tracing::info!(
            "gateway {port}: BDR={baud} sent; {}; greeting at {baud} baud",
            if restarted_here {
                "the simulated gateway restarted"
            } else {
                "waiting for the gateway's power cycle"
            }
        );
        if self.greet_until(started + restart_wait)? {
            let took_ms = u64::try_from(started.elapsed().as_millis()).unwrap_or(u64::MAX);
            return Ok(Ok(BaudChanged {
                from_baud,
                baud,
                took_ms,
            }));
        }
        let waited_ms = u64::try_from(started.elapsed().as_millis()).unwrap_or(u64::MAX);
        tracing::warn!(
            "gateway {port}: no answer at {baud} baud within {waited_ms} ms; back to \
             {from_baud} baud"
        );
        self.switch(from_baud)?;
        self.greet_until(Instant::now() + ANSWER_TIMEOUT * 2)?;
        Ok(Err(BaudError::NotAnswering {
            port,
            baud,
            from_baud,
            waited_ms,
        }))
    }

    /// Switches this end of the line to `baud`.
    fn switch(&mut self, baud: u32) -> std::io::Result<()> {
        self.line.set_baud(baud)?;
        self.writer.shared.baud.store(baud, Ordering::Release);
        *self.pacer = Pacer::new(baud, Instant::now());
        Ok(())
    }

    /// Writes `bytes` when the pacer allows.
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<()> {
        let wait = self.pacer.wait_before_next(Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        self.check_line()?;
        self.line.write_instruction(bytes)?;
        self.pacer.wrote(Instant::now(), bytes.len());
        self.writer
            .shared
            .written_bytes
            .fetch_add(bytes.len() as u64, Ordering::AcqRel);
        Ok(())
    }

    fn check_line(&self) -> std::io::Result<()> {
        if self.writer.shared.is_closed() || self.lost.load(Ordering::Acquire) {
            return Err(std::io::Error::other("the line was lost"));
        }
        Ok(())
    }

    /// Waits until `until`, writing the e-stop if it is pressed meanwhile.
    fn idle_until(&mut self, until: Instant) -> std::io::Result<()> {
        loop {
            self.check_line()?;
            self.writer.observe_latch();
            // Only the stop can be queued here: the inbox is not read during a change.
            while self.writer.queues.pop_into(self.buffer).is_some() {
                let instruction = std::mem::take(self.buffer);
                self.write(&instruction)?;
                *self.buffer = instruction;
            }
            let now = Instant::now();
            if now >= until {
                return Ok(());
            }
            std::thread::park_timeout((until - now).min(Duration::from_millis(20)));
        }
    }

    /// Greets every [`GREETING_RETRY`] until the gateway answers (`true`, and the link is
    /// `Up`) or `deadline` passes (`false`, and the link is `NotAnswering`).
    fn greet_until(&mut self, deadline: Instant) -> std::io::Result<bool> {
        let shared = self.writer.shared;
        let answers_before = shared.greetings_answered.load(Ordering::Acquire);
        shared.awaiting_answer.store(true, Ordering::Release);
        let answered = loop {
            self.write(GREETING)?;
            let retry_at = Instant::now() + GREETING_RETRY;
            while Instant::now() < retry_at.min(deadline) {
                if shared.greetings_answered.load(Ordering::Acquire) > answers_before {
                    break;
                }
                self.idle_until((Instant::now() + Duration::from_millis(5)).min(retry_at))?;
            }
            if shared.greetings_answered.load(Ordering::Acquire) > answers_before {
                break true;
            }
            if Instant::now() >= deadline {
                break false;
            }
        };
        shared.awaiting_answer.store(false, Ordering::Release);
        if answered {
            shared.set_state(LinkState::Up, None);
            if shared.config.latch.is_latched() {
                // A stop written while the two ends' speeds differed was lost: the
                // gateway hears it again now that they agree.
                self.writer.stop();
                self.idle_until(Instant::now())?;
            }
        } else {
            shared.set_state(LinkState::NotAnswering, Some(NOT_ANSWERING.to_owned()));
        }
        Ok(answered)
    }
}

/// Time left for the gateway to take in `BDR=x;` after its last byte crossed the line.
const ANSWER_MARGIN: Duration = Duration::from_millis(20);

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
