//! The links to MOONS' drives commanded in SCL ([`SclNet`]): one [`SclLink`] per
//! `kind = "scl"` gateway entry — an RS-485 line ([`serial`]) or a UDP socket to its
//! eSCL drives ([`udp`]) — behind one handle, and the console and programs on them
//! ([`program`]).
//!
//! **One owner.** Each link has one owner thread: it alone writes to the line or the
//! socket, holds the queue of SCL requests awaiting answers, times them out, and keeps
//! the per-drive figures (atomics the status reads). A reader thread (the serial port's,
//! or the socket's receiver) only cuts answers into lines and hands them to the owner
//! through the same channel the requests come by.
//!
//! **Half duplex.** An RS-485 line carries one request at a time: the next goes when
//! the drive addressed answered, or after its timeout (counted as a missed reply, with
//! an error naming the drive). eSCL drives each have their own request in flight. So at
//! most one request line sits in the port's buffer ahead of a stop.
//!
//! **The e-stop waits on nothing.** [`crate::estop::press`] bumps the latch and
//! [`SclNet::wake`] hands every owner a wake-up; before anything else the owner writes
//! `SK` (stop and kill the buffer) to every drive — addressed, back to back, in one
//! write on a line; one datagram a drive over UDP, repeated like MBOX's e-stop — and
//! voids every request queued or in flight that was issued before it (the generation
//! check). Answers that arrive in the next moments (the drives' `%` to `SK`) are not
//! taken for anyone's. While the latch is set only queries and stops are sent. A line
//! that is down when the e-stop is pressed gets `SK` first thing when it is back.
//!
//! **Polling.** Every `poll` (`[scl] poll_ms`) each drive is asked `IP`, `SC` and `AL`
//! when it has nothing else waiting (five times less often while programs are being
//! uploaded); the answers fill [`GatewayStatus::drives`].

pub mod program;
pub mod serial;
pub mod udp;

use std::collections::VecDeque;
use std::sync::atomic::{AtomicBool, AtomicI64, AtomicU32, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayKind, GatewayStatus, LinkState, SclDriveStatus, SclReply};
use floatball_shared::scl::{Address, Answer, Command, Reply, Request};
use tokio::sync::{broadcast, oneshot};

use crate::config::{SclConfig, SclGateway};
use crate::estop::{self, Latch};

/// The longest a drive may take to start answering, on top of the time the bytes
/// take on the line.
pub const ANSWER_TIMEOUT: Duration = Duration::from_millis(100);

/// How long after an e-stop answers are taken for the stop's (not for a request).
const SETTLE: Duration = Duration::from_millis(60);

/// Console answers one slow session may have waiting.
const REPLY_BACKLOG: usize = 64;

/// Bytes an answer line is counted as when its time on the line is estimated.
const ANSWER_BYTES: usize = 16;

/// What the owner thread of a link is told.
#[derive(Debug)]
enum Event {
    /// A request to send.
    Job(Job),
    /// An answer line (without its CR) from the reader; on UDP, from drive `drive`.
    Line {
        connection: u64,
        drive: Option<usize>,
        text: String,
    },
    /// The reader lost the port.
    Lost { connection: u64, reason: String },
    /// Look at the latch now.
    Wake,
}

pub use floatball_shared::scl::drive::{Expect, is_inert};

/// Why a request has no answer.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SclError {
    /// Issued before the last e-stop, or dropped by it.
    #[error("void: the e-stop was pressed")]
    Void,
    /// The e-stop is latched and the request could move a drive.
    #[error("the e-stop is latched: only queries and stops can be sent until Start, Reset or Home")]
    Latched,
    /// The drive did not answer in time.
    #[error("drive {drive} did not answer {request} within {timeout_ms} ms")]
    Timeout {
        /// The drive, as the status names it.
        drive: String,
        /// What was sent.
        request: String,
        /// How long it waited.
        timeout_ms: u64,
    },
    /// The line is down.
    #[error("{0}")]
    Down(String),
    /// No such drive, or the link is gone.
    #[error("{0}")]
    Gone(String),
}

/// A request handed to a link's owner.
#[derive(Debug)]
struct Job {
    drive: usize,
    /// The SCL text without the address (the link adds it on a line).
    text: String,
    /// Whether it may go while the e-stop is latched (a query or a stop).
    inert: bool,
    expect: Expect,
    generation: u64,
    purpose: Purpose,
    /// When its last byte reached the drive (written, and through the line): set when
    /// it is sent.
    delivered: Option<Instant>,
    done: Option<oneshot::Sender<Answered>>,
}

/// A request's answer lines (or why there are none), and when the request reached its
/// drive, if it was sent.
pub type Answered = (Result<Vec<String>, SclError>, Option<Instant>);

/// Who waits for an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Purpose {
    /// The status poll: the answer goes into the drive's figures.
    Poll,
    /// A console line: the answer goes to every session as `scl_reply`.
    Console,
    /// The player (programs, start, home): the answer goes to `done`.
    Player,
}

/// One drive's figures, written by the owner thread, read by anyone.
#[derive(Debug)]
struct DriveShared {
    /// How the status names it: its address character, or its eSCL address.
    name: String,
    /// Its address character on the line (RS-485), for the requests.
    address: Option<Address>,
    position_counts: AtomicI64,
    /// Bit 0: position known; bit 1: status known; bit 2: alarm known.
    known: AtomicU32,
    status_code: AtomicU32,
    alarm_code: AtomicU32,
    missed_replies: AtomicU64,
    /// Segments it saved to its non-volatile memory (`QS` answered `%`) since the
    /// bridge started: each partition lasts about 10,000 writes.
    flash_writes: AtomicU64,
    /// The last refusal or missed answer, if any; held only to copy it in or out.
    error: Mutex<Option<String>>,
}

impl DriveShared {
    /// A drive named `name`, at `address` on a line, nothing known of it yet.
    fn new(name: String, address: Option<Address>) -> Self {
        Self {
            name,
            address,
            position_counts: AtomicI64::new(0),
            known: AtomicU32::new(0),
            status_code: AtomicU32::new(0),
            alarm_code: AtomicU32::new(0),
            missed_replies: AtomicU64::new(0),
            flash_writes: AtomicU64::new(0),
            error: Mutex::new(None),
        }
    }

    fn set_error(&self, error: Option<String>) {
        if let Ok(mut slot) = self.error.lock() {
            *slot = error;
        }
    }

    fn snapshot(&self) -> SclDriveStatus {
        let known = self.known.load(Ordering::Acquire);
        SclDriveStatus {
            address: self.name.clone(),
            position_counts: (known & 1 != 0).then(|| self.position_counts.load(Ordering::Acquire)),
            status_code: (known & 2 != 0)
                .then(|| u16::try_from(self.status_code.load(Ordering::Acquire)).unwrap_or(0)),
            alarm_code: (known & 4 != 0)
                .then(|| u16::try_from(self.alarm_code.load(Ordering::Acquire)).unwrap_or(0)),
            missed_replies: self.missed_replies.load(Ordering::Acquire),
            flash_writes: self.flash_writes.load(Ordering::Acquire),
            error: self.error.lock().ok().and_then(|slot| slot.clone()),
        }
    }
}

/// What a link shares between its owner, its reader and its handles.
#[derive(Debug)]
struct LinkShared {
    index: usize,
    port: String,
    /// Line speed, baud (0: UDP).
    baud: u32,
    drives: Vec<DriveShared>,
    latch: Arc<Latch>,
    poll: Duration,
    up: AtomicBool,
    /// Why the link is down, if it is.
    down_reason: Mutex<Option<String>>,
    closed: AtomicBool,
    /// Program requests queued or in flight: polling slows down.
    program_jobs: AtomicUsize,
    replies: broadcast::Sender<SclReply>,
}

impl LinkShared {
    fn set_up(&self, up: bool, reason: Option<String>) {
        self.up.store(up, Ordering::Release);
        if let Ok(mut slot) = self.down_reason.lock() {
            *slot = reason;
        }
    }

    /// The time `bytes` take on the line (none on UDP).
    fn line_time(&self, bytes: usize) -> Duration {
        if self.baud == 0 {
            return Duration::ZERO;
        }
        // 8N1: ten bits a byte.
        Duration::from_micros(
            u64::try_from(bytes).unwrap_or(u64::MAX) * 10_000_000 / u64::from(self.baud),
        )
    }
}

/// The link to one `kind = "scl"` gateway entry; cheap to clone. The owner thread
/// stops when the last handle is dropped.
#[derive(Debug, Clone)]
pub struct SclLink {
    shared: Arc<LinkShared>,
    events: Sender<Event>,
    _close: Arc<CloseOnDrop>,
}

#[derive(Debug)]
struct CloseOnDrop(Arc<LinkShared>, Sender<Event>);

impl Drop for CloseOnDrop {
    fn drop(&mut self) {
        self.0.closed.store(true, Ordering::Release);
        let _ = self.1.send(Event::Wake);
    }
}

/// How the owner reaches the drives: a serial line or a UDP socket.
trait Transport: Send {
    /// Writes `text` (with its address on a line) and CR to drive `drive`.
    fn send(&mut self, shared: &LinkShared, drive: usize, text: &str) -> std::io::Result<()>;
    /// Writes `SK` to every drive, the first byte as early as it can.
    fn stop_all(&mut self, shared: &LinkShared) -> std::io::Result<()>;
    /// Whether each drive has its own request in flight (eSCL), or the line one.
    fn per_drive(&self) -> bool;
}

/// Opens a transport: on success the owner is told of every answer line through
/// `events` (tagged with `connection`).
type Opener = Box<dyn FnMut(u64, Sender<Event>) -> Result<Box<dyn Transport>, String> + Send>;

impl SclLink {
    fn start(shared: LinkShared, opener: Opener) -> Result<Self, String> {
        let shared = Arc::new(shared);
        let (events, inbox) = channel();
        let owner_shared = Arc::clone(&shared);
        let owner_events = events.clone();
        std::thread::Builder::new()
            .name(format!("scl-{}", shared.index))
            .spawn(move || Owner::new(&owner_shared, opener, owner_events).run(&inbox))
            .map_err(|err| format!("cannot start the SCL link's thread: {err}"))?;
        Ok(Self {
            _close: Arc::new(CloseOnDrop(Arc::clone(&shared), events.clone())),
            shared,
            events,
        })
    }

    /// Opens the link to gateway entry `index`, obeying `latch`; its console answers go
    /// to `replies`.
    ///
    /// # Errors
    /// A thread or the UDP socket cannot start.
    fn open(
        index: usize,
        gateway: &SclGateway,
        host_port: u16,
        poll: Duration,
        latch: Arc<Latch>,
        replies: broadcast::Sender<SclReply>,
    ) -> Result<Self, String> {
        let drive = DriveShared::new;
        let (drives, baud, opener): (Vec<DriveShared>, u32, Opener) = match gateway {
            SclGateway::Serial {
                port,
                baud,
                addresses,
            } => (
                addresses
                    .iter()
                    .map(|&address| drive(address.character().to_string(), Some(address)))
                    .collect(),
                *baud,
                serial::opener(port.clone(), *baud),
            ),
            SclGateway::Escl(sockets) => (
                sockets
                    .iter()
                    .map(|&socket| drive(socket.to_string(), None))
                    .collect(),
                0,
                udp::opener(sockets.clone(), host_port),
            ),
            // `crate::state` starts them and hands their sockets over as eSCL.
            SclGateway::Sim { .. } => {
                return Err(format!(
                    "SCL gateway {index}: its simulated drives were not started"
                ));
            }
        };
        Self::start(
            LinkShared {
                index,
                port: gateway.port(),
                baud,
                drives,
                latch,
                poll,
                up: AtomicBool::new(false),
                down_reason: Mutex::new(Some("connecting".to_owned())),
                closed: AtomicBool::new(false),
                program_jobs: AtomicUsize::new(0),
                replies,
            },
            opener,
        )
    }

    /// Its gateway index.
    pub fn index(&self) -> usize {
        self.shared.index
    }

    /// Its serial device, or its eSCL addresses.
    pub fn port(&self) -> &str {
        &self.shared.port
    }

    /// How many drives it has.
    pub fn drives(&self) -> usize {
        self.shared.drives.len()
    }

    /// Whether the line is open (the socket bound).
    pub fn is_up(&self) -> bool {
        self.shared.up.load(Ordering::Acquire)
    }

    /// Drive `drive`'s figures as last polled.
    pub fn drive(&self, drive: usize) -> Option<SclDriveStatus> {
        self.shared.drives.get(drive).map(DriveShared::snapshot)
    }

    /// The index of the drive with address character `address`: on a line, the
    /// configured one; over eSCL, the drives take the characters in listed order.
    pub fn drive_of(&self, address: Address) -> Option<usize> {
        let shared = &self.shared;
        match shared.drives.first().and_then(|drive| drive.address) {
            Some(_) => shared
                .drives
                .iter()
                .position(|drive| drive.address == Some(address)),
            None => Address::CHARACTERS
                .chars()
                .position(|character| character == address.character())
                .filter(|&index| index < shared.drives.len()),
        }
    }

    /// Wakes the owner: it looks at the latch at once (the e-stop path).
    pub fn wake(&self) {
        let _ = self.events.send(Event::Wake);
    }

    /// The link as the status shows it.
    pub fn status(&self) -> GatewayStatus {
        let shared = &self.shared;
        let up = self.is_up();
        let drives: Vec<SclDriveStatus> = shared.drives.iter().map(DriveShared::snapshot).collect();
        let missed = drives.iter().map(|drive| drive.missed_replies).sum();
        GatewayStatus {
            index: 0,
            kind: GatewayKind::Scl,
            port: shared.port.clone(),
            link: if up { LinkState::Up } else { LinkState::Down },
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: if up {
                None
            } else {
                shared.down_reason.lock().ok().and_then(|slot| slot.clone())
            },
            packets_per_s: None,
            late_frames: None,
            missed_replies: Some(missed),
            drives,
            baud: None,
            health: None,
        }
    }

    fn submit(
        &self,
        drive: usize,
        text: String,
        inert: bool,
        expect: Expect,
        generation: u64,
        purpose: Purpose,
    ) -> oneshot::Receiver<Answered> {
        let (done, answer) = oneshot::channel();
        if purpose == Purpose::Player {
            self.shared.program_jobs.fetch_add(1, Ordering::AcqRel);
        }
        let job = Job {
            drive,
            text,
            inert,
            expect,
            generation,
            purpose,
            delivered: None,
            done: Some(done),
        };
        if let Err(err) = self.events.send(Event::Job(job))
            && let Event::Job(job) = err.0
        {
            finish(
                &self.shared,
                job,
                Err(SclError::Gone("the SCL link is closed".to_owned())),
            );
        }
        answer
    }

    /// Sends `text` (SCL without the address; empty: a lone CR) to drive `drive`,
    /// issued at e-stop `generation`, and waits for its answer lines (addresses
    /// removed).
    ///
    /// # Errors
    /// [`SclError`]: void, latched, no answer in time, the line down.
    pub async fn request(
        &self,
        drive: usize,
        text: String,
        expect: Expect,
        generation: u64,
    ) -> Result<Vec<String>, SclError> {
        self.request_delivered(drive, text, expect, generation)
            .await
            .0
    }

    /// [`SclLink::request`], also saying when the request reached its drive: its
    /// last byte written and through the line (at the line's speed; on UDP, when the
    /// datagram went) — the instant a `QX` or an `SO` acts.
    pub async fn request_delivered(
        &self,
        drive: usize,
        text: String,
        expect: Expect,
        generation: u64,
    ) -> Answered {
        let inert = is_inert_text(&text);
        let answer = self.submit(drive, text, inert, expect, generation, Purpose::Player);
        answer.await.unwrap_or_else(|_| {
            (
                Err(SclError::Gone("the SCL link is closed".to_owned())),
                None,
            )
        })
    }

    /// Hands a console `request` (its address already resolved to `drive`) to the
    /// owner; its answer reaches every session as `scl_reply`.
    pub fn console(&self, drive: usize, request: &Request, generation: u64) {
        let command = Request::new(request.command).to_string();
        drop(self.submit(
            drive,
            command,
            is_inert(&request.command),
            Expect::of(&request.command),
            generation,
            Purpose::Console,
        ));
    }
}

fn is_inert_text(text: &str) -> bool {
    Request::parse(text).is_ok_and(|request| is_inert(&request.command))
}

/// Completes `job` with `result`: to its waiter, the console, or the drive's figures.
fn finish(shared: &LinkShared, mut job: Job, result: Result<Vec<String>, SclError>) {
    if job.purpose == Purpose::Player {
        shared.program_jobs.fetch_sub(1, Ordering::AcqRel);
    }
    let drive = shared.drives.get(job.drive);
    if let (Some(drive), Err(error)) = (drive, &result)
        && matches!(error, SclError::Timeout { .. })
    {
        drive.missed_replies.fetch_add(1, Ordering::AcqRel);
        drive.set_error(Some(error.to_string()));
    }
    if let (Some(drive), Ok(lines)) = (drive, &result)
        && job.text.starts_with("QS")
        && lines
            .first()
            .and_then(|line| Reply::parse(line).ok())
            .is_some_and(|reply| reply.answer == Answer::Executed)
    {
        // A write to the drive's non-volatile memory (from Start or the console).
        let writes = drive.flash_writes.fetch_add(1, Ordering::AcqRel) + 1;
        tracing::info!(
            gateway = shared.index,
            drive = %drive.name,
            request = %job.text,
            flash_writes = writes,
            "a program segment was saved to the drive's memory (about 10,000 writes \
             each segment lasts)"
        );
    }
    match job.purpose {
        Purpose::Poll => {
            if let (Some(drive), Ok(lines)) = (drive, &result) {
                record_poll(drive, lines);
            }
        }
        Purpose::Console => {
            let (text, raw) = match &result {
                Ok(lines) => (describe(lines), lines.join(" ")),
                Err(error) => (error.to_string(), String::new()),
            };
            let _ = shared.replies.send(SclReply {
                gateway: shared.index,
                drive: drive.map(|drive| drive.name.clone()).unwrap_or_default(),
                request: match drive.and_then(|drive| drive.address) {
                    Some(address) => format!("{address}{}", job.text),
                    None => job.text.clone(),
                },
                text,
                raw,
            });
        }
        Purpose::Player => {}
    }
    if let Some(done) = job.done.take() {
        let _ = done.send((result, job.delivered));
    }
}

/// An answer in words: `executed`, `buffered`, `refused (code 5)`, `IP = -1200`, or
/// an upload's lines.
pub fn describe(lines: &[String]) -> String {
    let Some(first) = lines.first() else {
        return "no answer".to_owned();
    };
    if lines.len() > 1 {
        return lines.join(" | ");
    }
    match Reply::parse(first) {
        Ok(reply) => match reply.answer {
            Answer::Executed => "executed".to_owned(),
            Answer::Buffered => "buffered".to_owned(),
            Answer::Refused { code: None } => "refused".to_owned(),
            Answer::Refused { code: Some(code) } => format!("refused (code {code})"),
            Answer::Value { name, value } => format!("{name} = {value}"),
        },
        Err(error) => format!("{first:?} is not an answer: {error}"),
    }
}

/// Stores a poll's answer in the drive's figures.
fn record_poll(drive: &DriveShared, lines: &[String]) {
    let Some(reply) = lines.first().and_then(|line| Reply::parse(line).ok()) else {
        return;
    };
    if let Answer::Value { name, .. } = &reply.answer {
        match name.as_str() {
            "IP" => {
                if let Some(counts) = reply.answer.value_i64() {
                    drive.position_counts.store(counts, Ordering::Release);
                    drive.known.fetch_or(1, Ordering::AcqRel);
                }
            }
            "SC" => {
                if let Some(code) = reply.answer.value_hex_u16() {
                    drive.status_code.store(u32::from(code), Ordering::Release);
                    drive.known.fetch_or(2, Ordering::AcqRel);
                }
            }
            "AL" => {
                if let Some(code) = reply.answer.value_hex_u16() {
                    drive.alarm_code.store(u32::from(code), Ordering::Release);
                    drive.known.fetch_or(4, Ordering::AcqRel);
                }
            }
            _ => {}
        }
        drive.set_error(None);
    }
}

/// A request on the wire, waiting for its answer.
#[derive(Debug)]
struct InFlight {
    job: Job,
    deadline: Instant,
    timeout: Duration,
    lines: Vec<String>,
}

impl InFlight {
    /// Whether the answer is whole.
    fn complete(&self) -> bool {
        match self.job.expect {
            Expect::One => !self.lines.is_empty(),
            Expect::Global => true,
            Expect::Upload => match self.lines.as_slice() {
                [] => false,
                [first, rest @ ..] => {
                    if first.starts_with('?') {
                        return true;
                    }
                    match rest
                        .first()
                        .map(|header| floatball_shared::scl::QueueUpload::parse_header(header))
                    {
                        None => false,
                        Some(Ok((_, floatball_shared::scl::UploadHeader::Lines(count)))) => {
                            rest.len() > count
                        }
                        Some(_) => true,
                    }
                }
            },
        }
    }
}

/// The owner thread's state.
struct Owner<'a> {
    shared: &'a LinkShared,
    opener: Opener,
    events: Sender<Event>,
    transport: Option<Box<dyn Transport>>,
    connection: u64,
    retry_at: Instant,
    backoff: crate::ports::uim2503::Backoff,
    seen_generation: u64,
    /// A stop is owed to a line that was down when the e-stop was pressed.
    stop_owed: bool,
    /// Per channel (one on a line, one a drive on UDP): requests waiting.
    queues: Vec<VecDeque<Job>>,
    in_flight: Vec<Option<InFlight>>,
    /// Answers before this are the stop's.
    settle_until: Instant,
    /// Stop datagrams still to repeat (UDP) and when.
    repeats: estop::Repeats,
    next_poll: Instant,
    /// Answer lines that matched no request.
    unexpected: u64,
}

impl<'a> Owner<'a> {
    fn new(shared: &'a LinkShared, opener: Opener, events: Sender<Event>) -> Self {
        let now = Instant::now();
        Self {
            shared,
            opener,
            events,
            transport: None,
            connection: 0,
            retry_at: now,
            backoff: crate::ports::uim2503::Backoff::new(),
            seen_generation: shared.latch.generation(),
            stop_owed: false,
            queues: Vec::new(),
            in_flight: Vec::new(),
            settle_until: now,
            repeats: estop::Repeats::default(),
            next_poll: now,
            unexpected: 0,
        }
    }

    fn channel_of(&self, drive: usize) -> usize {
        match &self.transport {
            Some(transport) if transport.per_drive() => drive,
            _ => 0,
        }
    }

    fn connect(&mut self) {
        if self.transport.is_some() || Instant::now() < self.retry_at {
            return;
        }
        self.connection += 1;
        match (self.opener)(self.connection, self.events.clone()) {
            Ok(transport) => {
                let channels = if transport.per_drive() {
                    self.shared.drives.len()
                } else {
                    1
                };
                self.transport = Some(transport);
                self.queues = (0..channels).map(|_| VecDeque::new()).collect();
                self.in_flight = (0..channels).map(|_| None).collect();
                self.backoff.reset();
                self.shared.set_up(true, None);
                tracing::info!(
                    "SCL gateway {} ({}): open",
                    self.shared.index,
                    self.shared.port
                );
                if self.stop_owed || self.shared.latch.is_latched() {
                    self.stop_owed = false;
                    self.write_stop();
                }
            }
            Err(reason) => {
                tracing::warn!("SCL gateway {}: {reason}; retrying", self.shared.index);
                self.shared.set_up(false, Some(reason));
                self.retry_at = Instant::now() + self.backoff.next_delay();
            }
        }
    }

    fn lose(&mut self, reason: String) {
        tracing::warn!(
            "SCL gateway {} ({}): {reason}",
            self.shared.index,
            self.shared.port
        );
        self.transport = None;
        self.shared.set_up(false, Some(reason.clone()));
        self.retry_at = Instant::now() + self.backoff.next_delay();
        self.drop_all(&|| SclError::Down(reason.clone()));
    }

    /// Completes every queued and in-flight request with `error`.
    fn drop_all(&mut self, error: &dyn Fn() -> SclError) {
        for flight in self.in_flight.iter_mut() {
            if let Some(flight) = flight.take() {
                finish(self.shared, flight.job, Err(error()));
            }
        }
        for queue in &mut self.queues {
            for job in queue.drain(..) {
                finish(self.shared, job, Err(error()));
            }
        }
    }

    /// Writes `SK` to every drive now.
    fn write_stop(&mut self) {
        let Some(transport) = self.transport.as_mut() else {
            self.stop_owed = true;
            return;
        };
        if let Err(err) = transport.stop_all(self.shared) {
            self.stop_owed = true;
            self.lose(format!("the stop could not be written: {err}"));
            return;
        }
        let answers = self
            .shared
            .line_time(ANSWER_BYTES * self.shared.drives.len());
        self.settle_until = Instant::now() + SETTLE + answers;
        if !transport.per_drive() {
            return;
        }
        self.repeats.start(Instant::now());
        self.settle_until += estop::REPEAT_INTERVAL * estop::REPEATS;
    }

    /// Acts on a new e-stop generation: the stop goes out before anything else.
    fn observe_latch(&mut self, inbox: &Receiver<Event>) {
        let generation = self.shared.latch.generation();
        if generation == self.seen_generation {
            return;
        }
        self.seen_generation = generation;
        self.write_stop();
        // Requests that came in meanwhile are as old as the ones queued.
        let mut later = Vec::new();
        while let Ok(event) = inbox.try_recv() {
            later.push(event);
        }
        self.drop_all(&|| SclError::Void);
        for event in later {
            self.handle(event);
        }
    }

    fn handle(&mut self, event: Event) {
        match event {
            Event::Job(job) => self.enqueue(job),
            Event::Line {
                connection,
                drive,
                text,
            } if connection == self.connection => self.answer(drive, text),
            Event::Lost { connection, reason } if connection == self.connection => {
                self.lose(reason);
            }
            Event::Line { .. } | Event::Lost { .. } | Event::Wake => {}
        }
    }

    fn enqueue(&mut self, job: Job) {
        if job.drive >= self.shared.drives.len() {
            let error = SclError::Gone(format!(
                "there is no drive {} on SCL gateway {}",
                job.drive, self.shared.index
            ));
            finish(self.shared, job, Err(error));
            return;
        }
        if job.generation != self.seen_generation {
            finish(self.shared, job, Err(SclError::Void));
            return;
        }
        if self.shared.latch.is_latched() && !job.inert {
            finish(self.shared, job, Err(SclError::Latched));
            return;
        }
        if self.transport.is_none() {
            let reason = self
                .shared
                .down_reason
                .lock()
                .ok()
                .and_then(|slot| slot.clone())
                .unwrap_or_else(|| "the line is down".to_owned());
            finish(
                self.shared,
                job,
                Err(SclError::Down(format!(
                    "SCL gateway {} ({}) is not connected: {reason}",
                    self.shared.index, self.shared.port
                ))),
            );
            return;
        }
        let channel = self.channel_of(job.drive);
        if let Some(queue) = self.queues.get_mut(channel) {
            queue.push_back(job);
        }
    }

    /// Takes an answer line for the request in flight it belongs to.
    fn answer(&mut self, from: Option<usize>, text: String) {
        if Instant::now() < self.settle_until {
            return;
        }
        // On a line the drive names itself by its address character.
        let (drive, text) = match from {
            Some(drive) => (Some(drive), text),
            None => {
                let mut characters = text.chars();
                match characters
                    .next()
                    .and_then(Address::new)
                    .and_then(|address| {
                        self.shared
                            .drives
                            .iter()
                            .position(|drive| drive.address == Some(address))
                    }) {
                    Some(drive) => (Some(drive), characters.as_str().to_owned()),
                    None => (None, text),
                }
            }
        };
        let channel = match drive {
            Some(drive) => self.channel_of(drive),
            None => 0,
        };
        match self.in_flight.get_mut(channel) {
            Some(Some(flight)) if drive.is_none_or(|drive| drive == flight.job.drive) => {
                flight.lines.push(text);
                if flight.complete()
                    && let Some(flight) = self.in_flight.get_mut(channel).and_then(Option::take)
                {
                    finish(self.shared, flight.job, Ok(flight.lines));
                }
            }
            _ => {
                self.unexpected += 1;
                tracing::debug!(
                    "SCL gateway {}: an answer for no request: {text:?}",
                    self.shared.index
                );
            }
        }
    }

    /// Sends the next request of every idle channel.
    fn dispatch(&mut self) {
        let now = Instant::now();
        if now < self.settle_until {
            return;
        }
        for channel in 0..self.queues.len() {
            if self.in_flight.get(channel).is_some_and(Option::is_some) {
                continue;
            }
            let Some(job) = self.queues.get_mut(channel).and_then(VecDeque::pop_front) else {
                continue;
            };
            if job.generation != self.seen_generation {
                finish(self.shared, job, Err(SclError::Void));
                continue;
            }
            if self.shared.latch.is_latched() && !job.inert {
                finish(self.shared, job, Err(SclError::Latched));
                continue;
            }
            let Some(transport) = self.transport.as_mut() else {
                return;
            };
            let global = job.expect == Expect::Global;
            if global && transport.per_drive() {
                // eSCL has no line every drive hears: one datagram a drive.
                finish(
                    self.shared,
                    job,
                    Err(SclError::Gone(
                        "a line without an address needs an RS-485 line".to_owned(),
                    )),
                );
                continue;
            }
            // A global line goes without an address (no drive has the index `MAX`):
            // every drive on the line takes it, none answers (HCR p. 305).
            let to = if global { usize::MAX } else { job.drive };
            if let Err(err) = transport.send(self.shared, to, &job.text) {
                finish(self.shared, job, Err(SclError::Down(err.to_string())));
                self.lose(format!("write failed: {err}"));
                return;
            }
            let mut job = job;
            // The address, the text and the CR through the line.
            let address = self
                .shared
                .drives
                .get(job.drive)
                .is_some_and(|drive| drive.address.is_some());
            job.delivered = Some(
                Instant::now()
                    + self
                        .shared
                        .line_time(job.text.len() + 1 + usize::from(address)),
            );
            if global {
                // Nobody answers: done when it is through the line.
                let mut done = job;
                done.delivered = Some(Instant::now() + self.shared.line_time(done.text.len() + 1));
                finish(self.shared, done, Ok(Vec::new()));
                continue;
            }
            let answer_bytes = match job.expect {
                Expect::One => ANSWER_BYTES,
                Expect::Upload => ANSWER_BYTES * 64,
                Expect::Global => 0,
            };
            let timeout =
                ANSWER_TIMEOUT + self.shared.line_time(job.text.len() + 2 + answer_bytes) * 2;
            if let Some(slot) = self.in_flight.get_mut(channel) {
                *slot = Some(InFlight {
                    job,
                    deadline: Instant::now() + timeout,
                    timeout,
                    lines: Vec::new(),
                });
            }
        }
    }

    /// Times out the requests whose answer is late.
    fn expire(&mut self) {
        let now = Instant::now();
        for channel in 0..self.in_flight.len() {
            let late = self
                .in_flight
                .get(channel)
                .and_then(Option::as_ref)
                .is_some_and(|flight| now >= flight.deadline);
            if !late {
                continue;
            }
            if let Some(flight) = self.in_flight.get_mut(channel).and_then(Option::take) {
                let drive = self
                    .shared
                    .drives
                    .get(flight.job.drive)
                    .map(|drive| drive.name.clone())
                    .unwrap_or_default();
                let error = SclError::Timeout {
                    drive: format!("{drive:?} on SCL gateway {}", self.shared.index),
                    request: flight.job.text.clone(),
                    timeout_ms: u64::try_from(flight.timeout.as_millis()).unwrap_or(u64::MAX),
                };
                finish(self.shared, flight.job, Err(error));
            }
        }
    }

    /// Queues `IP`, `SC` and `AL` for every drive with nothing waiting.
    fn poll(&mut self) {
        let now = Instant::now();
        if now < self.next_poll || self.transport.is_none() {
            return;
        }
        let slow = self.shared.program_jobs.load(Ordering::Acquire) > 0;
        self.next_poll = now
            + if slow {
                self.shared.poll * 5
            } else {
                self.shared.poll
            };
        for drive in 0..self.shared.drives.len() {
            let channel = self.channel_of(drive);
            let busy = self.queues.get(channel).is_some_and(|queue| {
                queue
                    .iter()
                    .any(|job| job.drive == drive && job.purpose == Purpose::Poll)
            });
            if busy {
                continue;
            }
            for command in [
                Command::ImmediatePosition,
                Command::StatusCode,
                Command::AlarmCode,
            ] {
                let job = Job {
                    drive,
                    text: command.to_string(),
                    inert: true,
                    expect: Expect::One,
                    generation: self.seen_generation,
                    purpose: Purpose::Poll,
                    delivered: None,
                    done: None,
                };
                if let Some(queue) = self.queues.get_mut(channel) {
                    queue.push_back(job);
                }
            }
        }
    }

    /// When the owner must look again, at the latest.
    fn next_deadline(&self) -> Instant {
        let mut wake = self.next_poll;
        if self.transport.is_none() {
            wake = wake.min(self.retry_at);
        }
        if let Some(at) = self.repeats.next() {
            wake = wake.min(at);
        }
        for flight in self.in_flight.iter().flatten() {
            wake = wake.min(flight.deadline);
        }
        if self.queues.iter().any(|queue| !queue.is_empty()) {
            wake = wake.min(self.settle_until);
        }
        wake
    }

    /// Handles every event already in `inbox` (answers, requests), the latch first.
    fn take_queued(&mut self, inbox: &Receiver<Event>) {
        while let Ok(event) = inbox.try_recv() {
            self.observe_latch(inbox);
            self.handle(event);
        }
    }

    fn run(mut self, inbox: &Receiver<Event>) {
        while !self.shared.closed.load(Ordering::Acquire) {
            if !self.turn(inbox) {
                return;
            }
        }
    }

    /// One turn of the owner: the line, the latch, the stops to repeat, what is
    /// queued, the requests timed out, the poll, the next request; then waits for an
    /// event or the next deadline. `false` when every handle is gone.
    fn turn(&mut self, inbox: &Receiver<Event>) -> bool {
        self.connect();
        self.observe_latch(inbox);
        if self.repeats.due(Instant::now())
            && let Some(transport) = self.transport.as_mut()
            && let Err(err) = transport.stop_all(self.shared)
        {
            tracing::debug!(
                "SCL gateway {}: a repeated stop failed: {err}",
                self.shared.index
            );
        }
        // Answers already queued are taken before any request is timed out: an owner
        // that wakes late (a loaded host) must not count an answer that came in time
        // as missed.
        self.take_queued(inbox);
        self.expire();
        self.poll();
        self.dispatch();
        let wait = self
            .next_deadline()
            .saturating_duration_since(Instant::now());
        match inbox.recv_timeout(wait) {
            Ok(event) => {
                // The latch first: an e-stop overtakes whatever came with it.
                self.observe_latch(inbox);
                self.handle(event);
                self.take_queued(inbox);
                true
            }
            Err(RecvTimeoutError::Timeout) => true,
            Err(RecvTimeoutError::Disconnected) => false,
        }
    }
}

/// Every `kind = "scl"` gateway entry's link, and the console answers.
#[derive(Debug, Clone)]
pub struct SclNet {
    links: Vec<SclLink>,
    replies: broadcast::Sender<SclReply>,
}

impl SclNet {
    /// Opens a link per gateway entry of `config`, all obeying `latch`.
    ///
    /// # Errors
    /// A thread or a socket cannot start.
    pub fn open(config: &SclConfig, latch: &Arc<Latch>) -> Result<Self, String> {
        let replies = broadcast::channel(REPLY_BACKLOG).0;
        let links = config
            .gateways
            .iter()
            .enumerate()
            .map(|(index, gateway)| {
                // Each eSCL entry sends from its own port, the same at every start.
                let host_port = match config.host_port {
                    0 => 0,
                    port => port.saturating_add(u16::try_from(index).unwrap_or(u16::MAX)),
                };
                SclLink::open(
                    index,
                    gateway,
                    host_port,
                    config.poll,
                    Arc::clone(latch),
                    replies.clone(),
                )
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Self { links, replies })
    }

    /// The links, in gateway order.
    pub fn links(&self) -> &[SclLink] {
        &self.links
    }

    /// Wakes every owner: each writes `SK` to its drives before anything else.
    pub fn wake(&self) {
        for link in &self.links {
            link.wake();
        }
    }

    /// The gateways the stop cannot reach now (line down), with the reason.
    pub fn unreachable(&self) -> Vec<String> {
        self.links
            .iter()
            .filter(|link| !link.is_up())
            .map(|link| {
                format!(
                    "SCL gateway {} ({}) is not connected",
                    link.index(),
                    link.port()
                )
            })
            .collect()
    }

    /// Every gateway entry as the status shows it.
    pub fn statuses(&self) -> Vec<GatewayStatus> {
        self.links
            .iter()
            .enumerate()
            .map(|(index, link)| GatewayStatus {
                index,
                ..link.status()
            })
            .collect()
    }

    /// The drives' answers to console lines from now on.
    pub fn subscribe_replies(&self) -> broadcast::Receiver<SclReply> {
        self.replies.subscribe()
    }
}

#[cfg(test)]
mod tests;

impl crate::estop::StopPort for SclNet {
    /// Wakes every link's owner: it writes `SK` to every drive before anything else.
    fn wake(&self) {
        SclNet::wake(self);
    }

    fn unreachable(&self) -> Vec<String> {
        SclNet::unreachable(self)
    }
}
