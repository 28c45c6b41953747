//! The MBOX boxes of an installation on one UDP socket ([`MboxNet`]).
//!
//! **One socket, one owner.** The host's socket is bound once (the `[mbox]` host port)
//! and shared by two threads: the **sender** owns the send side, the motion frames
//! waiting to go, the e-stop and release repeats, the poll schedule and the
//! per-box counters it writes (atomics the status reads); the **receiver** matches
//! replies to boxes by their source address and records them (atomics too). Only the
//! configured addresses are ever sent to.
//!
//! **Polling.** Every [`POLL_INTERVAL`] each box is asked for its e-stop register
//! (FN `0x0090`), at most [`POLL_BATCH`] boxes at a time spread over the interval: the
//! answers of a thousand boxes at once would overflow the host socket's receive
//! buffer, and the same last boxes would lose theirs every time. A box that has not answered for [`DOWN_AFTER`] is `down` in the
//! status, with an error saying so; it is polled on, and comes back `up` with its next
//! answer. Every unanswered poll is counted. An answer that disagrees with the latch
//! (a box still stopped after a release, or running while the e-stop is latched) gets
//! the register written again: a lost release or e-stop datagram is made good.
//!
//! **The e-stop waits on nothing.** [`crate::estop::press`] bumps the latch's
//! generation and [`MboxNet::wake`] unparks the sender, which before anything else
//! drops every queued frame, writes FN `0x0090` = 1 to every box, and repeats it
//! [`ESTOP_REPEATS`] times [`ESTOP_REPEAT_INTERVAL`] apart (UDP may lose a datagram).
//! While the latch is set no motion frame is sent; frames issued before the e-stop are
//! void. The first frame after a release (Start, Reset or Home) is preceded by FN
//! `0x0090` = 0 to every box, repeated the same way.
//!
//! **The console.** [`MboxNet::console`] hands a parsed console operation to the same
//! sender thread, for one box or every box; a write issued before an e-stop is void
//! (the e-stop write itself excepted). The receiver relays every read reply that is
//! not a poll answer to [`MboxNet::subscribe_replies`]; a reply shaped like a poll
//! (FN `0x0090`, one register) is relayed only while the box owes a console read of
//! that shape. The bridge's own polls are never relayed.
//!
//! **Live frames are paced at the instant they leave** ([`floatball_shared::mbox::pace`],
//! issue 47): a box runs each frame from where its axes are when it arrives, so a frame
//! that leaves sooner after the one before than the period cuts that one's line short
//! and the ball runs the lag off faster than the top speed, and one that leaves later
//! finds the axes resting. For each live frame the sender asks each box's
//! [`BoxPacer`] — a model of the box fed every frame this sender sent, at the time it
//! sent it — for the line the box is to run from where its axes are now, within the
//! top speed and acceleration (the frame's targets brought in when they would need
//! more), and sends that. Frames that are not live (homing, approaches, shows) go as
//! made and are only followed; an e-stop makes the box's positions unknown to its
//! pacer. Each box's frame is paced at its own send instant.
//!
//! **Send lateness.** Besides the all-time histogram ([`MboxNet::timing`]) the sender
//! keeps the latest a frame left over the last [`RECENT_LATENESS`] or so
//! ([`MboxNet::recent_lateness_us`]): the live status's latency counts it.
//!
//! A box's datagrams name every box as receiver (`0xFFFF`): each is sent to one box's
//! own address and port, so the box need not know its configured address.

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU16, AtomicU32, AtomicU64, Ordering};
use std::sync::mpsc::{Receiver, Sender, channel};
use std::sync::{Arc, OnceLock};
use std::thread::Thread;
use std::time::{Duration, Instant};

use floatball_shared::api::{GatewayKind, GatewayStatus, LinkState, MboxRegisters, MboxReply};
use floatball_shared::mbox::console::{Operation, ReplyLayout, render_reply};
use floatball_shared::mbox::pace::{BoxPacer, Paced};
use floatball_shared::mbox::player::MboxFrame;
use floatball_shared::mbox::register::FN_ESTOP;
use floatball_shared::mbox::{
    AxisPositions, BoxAddress, Datagram, DigitalOutputs, Encode, MotionFrame, ReadBank,
    RegisterRange, RegisterRead, RegisterReply, RegisterWrite, Route, TimeCode, TimeMode,
};
use tokio::sync::broadcast;

use crate::estop::Latch;

/// How often each box is asked for its e-stop register.
pub const POLL_INTERVAL: Duration = Duration::from_millis(500);
/// How long before its slot the player hands a motion frame to the sender, which
/// holds it and sends it at its slot: the player's work and the wake-up of its task
/// (a timer of millisecond grain) are then not in the frame's lateness.
pub const FRAME_LEAD: Duration = Duration::from_millis(5);
/// The most boxes polled at once; more are polled in turn over [`POLL_INTERVAL`].
pub const POLL_BATCH: usize = 50;
/// How long a box may leave polls unanswered before it is `down`.
pub const DOWN_AFTER: Duration = Duration::from_millis(1_600);
/// How many times the e-stop (and its release) is sent again after the first (the
/// repeats every datagram stop has, [`crate::estop::REPEATS`]).
pub const ESTOP_REPEATS: u32 = crate::estop::REPEATS;
/// The time between two repeats of the e-stop or its release.
pub const ESTOP_REPEAT_INTERVAL: Duration = crate::estop::REPEAT_INTERVAL;
/// How far back [`MboxNet::recent_lateness_us`] looks: the latest of this window and
/// the one before.
pub const RECENT_LATENESS: Duration = Duration::from_secs(5);

/// One box's counters and last answer: written by the sender and the receiver,
/// read by anyone.
#[derive(Debug)]
struct BoxShared {
    address: SocketAddr,
    /// Datagrams sent to it.
    sent: AtomicU64,
    /// Motion frames sent more than half a period after their slot.
    late_frames: AtomicU64,
    /// Polls it left unanswered.
    missed_replies: AtomicU64,
    /// Poll answers.
    replies: AtomicU64,
    /// µs since the epoch of its last answer + 1 (0: never answered).
    answered_us: AtomicU64,
    /// Its e-stop register as last read (`u16::MAX`: never read).
    estop_register: AtomicU16,
    /// Datagrams a second over the last second, as `f64` bits.
    packets_per_s: AtomicU64,
    /// Console reads shaped like a poll that the box has not answered yet.
    console_polls: AtomicU32,
}

#[derive(Debug)]
struct Shared {
    boxes: Vec<BoxShared>,
    latch: Arc<Latch>,
    sender: OnceLock<Thread>,
    closed: AtomicBool,
    epoch: Instant,
    period: Duration,
    time: TimeMode,
    /// Datagrams from addresses that are not configured, or that are not poll answers.
    unexpected: AtomicU64,
    timing: Timing,
    /// Replies to console reads, for every WebSocket session.
    replies: broadcast::Sender<MboxReply>,
}

/// Width of one bucket of the send-lateness histogram.
const LATENESS_BUCKET_US: u64 = 50;
/// Buckets of the histogram: 0–12.8 ms by 50 µs, the last one for anything later.
const LATENESS_BUCKETS: usize = 257;

/// How late the motion frames left: counters and a histogram the sender writes with
/// relaxed atomic adds (no lock on the send path), read by [`MboxNet::timing`].
#[derive(Debug)]
struct Timing {
    /// Motion frames sent (one per frame period, to every box).
    frames: AtomicU64,
    /// Of them, sent more than half a period after their slot.
    late: AtomicU64,
    /// Per bucket of [`LATENESS_BUCKET_US`]: frames whose first datagram left that late.
    lateness: [AtomicU64; LATENESS_BUCKETS],
    /// The latest a frame's first datagram left, µs after its slot.
    max_lateness_us: AtomicU64,
    /// The longest a frame took from its first datagram to its last, µs.
    max_spread_us: AtomicU64,
    /// The latest a frame's first datagram left over this [`RECENT_LATENESS`] window
    /// and the one before, µs.
    recent_max_lateness_us: AtomicU64,
}

impl Timing {
    fn new() -> Self {
        Self {
            frames: AtomicU64::new(0),
            late: AtomicU64::new(0),
            lateness: std::array::from_fn(|_| AtomicU64::new(0)),
            max_lateness_us: AtomicU64::new(0),
            max_spread_us: AtomicU64::new(0),
            recent_max_lateness_us: AtomicU64::new(0),
        }
    }

    fn record(&self, lateness: Duration, spread: Duration, late: bool) {
        let lateness_us = u64::try_from(lateness.as_micros()).unwrap_or(u64::MAX);
        let spread_us = u64::try_from(spread.as_micros()).unwrap_or(u64::MAX);
        let bucket = usize::try_from(lateness_us / LATENESS_BUCKET_US)
            .unwrap_or(usize::MAX)
            .min(LATENESS_BUCKETS - 1);
        self.lateness[bucket].fetch_add(1, Ordering::Relaxed);
        self.max_lateness_us
            .fetch_max(lateness_us, Ordering::Relaxed);
        self.max_spread_us.fetch_max(spread_us, Ordering::Relaxed);
        self.late.fetch_add(u64::from(late), Ordering::Relaxed);
        self.frames.fetch_add(1, Ordering::Release);
    }

    fn snapshot(&self, boxes: &[BoxShared]) -> MboxTiming {
        let lateness: Vec<u64> = self
            .lateness
            .iter()
            .map(|bucket| bucket.load(Ordering::Relaxed))
            .collect();
        MboxTiming {
            frames_sent: self.frames.load(Ordering::Acquire),
            late_frames: self.late.load(Ordering::Relaxed),
            datagrams_sent: boxes
                .iter()
                .map(|one| one.sent.load(Ordering::Relaxed))
                .sum(),
            lateness_bucket_us: LATENESS_BUCKET_US,
            lateness,
            max_lateness_us: self.max_lateness_us.load(Ordering::Relaxed),
            max_spread_us: self.max_spread_us.load(Ordering::Relaxed),
        }
    }
}

/// How the motion frames left, since the boxes were opened (`GET /api/mbox/timing`).
#[derive(Debug, Clone, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct MboxTiming {
    /// Motion frames sent (each to every box).
    pub frames_sent: u64,
    /// Of them, sent more than half a frame period after their slot.
    pub late_frames: u64,
    /// Datagrams sent to all boxes: motion frames, polls, e-stops and releases.
    pub datagrams_sent: u64,
    /// The width of one bucket of `lateness`.
    pub lateness_bucket_us: u64,
    /// How many frames' first datagram left `i × lateness_bucket_us` µs (up to the
    /// next bucket) after their slot; the last bucket holds anything later.
    pub lateness: Vec<u64>,
    /// The latest a frame's first datagram left after its slot, µs.
    pub max_lateness_us: u64,
    /// The longest a frame took from its first datagram to its last, µs.
    pub max_spread_us: u64,
}

impl MboxTiming {
    /// The lateness (µs, the upper edge of its bucket) that `fraction` (0–1) of the
    /// frames left within, from the frames counted in `self` and not in `before`.
    pub fn lateness_quantile_us(&self, before: &Self, fraction: f64) -> u64 {
        let counts: Vec<u64> = self
            .lateness
            .iter()
            .enumerate()
            .map(|(index, count)| count - before.lateness.get(index).copied().unwrap_or(0))
            .collect();
        let total: u64 = counts.iter().sum();
        let wanted = (fraction * total as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (index, count) in counts.iter().enumerate() {
            seen += count;
            if seen >= wanted {
                return (index as u64 + 1) * self.lateness_bucket_us;
            }
        }
        0
    }
}

impl Shared {
    fn micros(&self) -> u64 {
        u64::try_from(self.epoch.elapsed().as_micros()).unwrap_or(u64::MAX)
    }
}

/// A frame handed to the sender: issued at an e-stop generation, for a slot.
#[derive(Debug)]
struct Outgoing {
    generation: u64,
    slot: Instant,
    frame: MboxFrame,
}

/// A console operation handed to the sender: for one box (all when `None`), issued at
/// an e-stop generation.
#[derive(Debug)]
struct ConsoleOut {
    target: Option<usize>,
    operation: Operation,
    generation: u64,
}

/// Replies to console reads one slow session may have waiting.
const REPLY_BACKLOG: usize = 64;

/// The boxes of an installation; see the [module documentation](self). Cheap to
/// clone; the threads stop when the last handle is dropped.
#[derive(Debug, Clone)]
pub struct MboxNet {
    shared: Arc<Shared>,
    frames: Sender<Outgoing>,
    console: Sender<ConsoleOut>,
    _close: Arc<CloseOnDrop>,
}

#[derive(Debug)]
struct CloseOnDrop(Arc<Shared>);

impl Drop for CloseOnDrop {
    fn drop(&mut self) {
        self.0.closed.store(true, Ordering::Release);
        if let Some(sender) = self.0.sender.get() {
            sender.unpark();
        }
    }
}

impl MboxNet {
    /// Binds the host's UDP socket on `host_port` (0: any free port) and starts the
    /// sender and the receiver for the boxes at `addresses`, obeying `latch`.
    ///
    /// # Errors
    /// The socket cannot be bound, or a thread cannot start.
    pub fn open(
        host_port: u16,
        addresses: &[SocketAddr],
        period: Duration,
        time: TimeMode,
        latch: Arc<Latch>,
    ) -> Result<Self, String> {
        let socket = UdpSocket::bind(("0.0.0.0", host_port))
            .map_err(|err| format!("cannot bind the MBOX host port UDP {host_port}: {err}"))?;
        let receiving = socket
            .try_clone()
            .map_err(|err| format!("cannot share the MBOX socket: {err}"))?;
        receiving
            .set_read_timeout(Some(Duration::from_millis(100)))
            .map_err(|err| format!("cannot set the MBOX socket's timeout: {err}"))?;
        let shared = Arc::new(Shared {
            boxes: addresses
                .iter()
                .map(|&address| BoxShared {
                    address,
                    sent: AtomicU64::new(0),
                    late_frames: AtomicU64::new(0),
                    missed_replies: AtomicU64::new(0),
                    replies: AtomicU64::new(0),
                    answered_us: AtomicU64::new(0),
                    estop_register: AtomicU16::new(u16::MAX),
                    packets_per_s: AtomicU64::new(0),
                    console_polls: AtomicU32::new(0),
                })
                .collect(),
            latch,
            sender: OnceLock::new(),
            closed: AtomicBool::new(false),
            epoch: Instant::now(),
            period,
            time,
            unexpected: AtomicU64::new(0),
            timing: Timing::new(),
            replies: broadcast::channel(REPLY_BACKLOG).0,
        });
        let (frames, inbox) = channel();
        let (console, console_inbox) = channel();
        let sending = Arc::clone(&shared);
        let sender = std::thread::Builder::new()
            .name("mbox-send".to_owned())
            .spawn(move || Outbox::new(&sending, socket).run(&inbox, &console_inbox))
            .map_err(|err| format!("cannot start the MBOX sender: {err}"))?;
        let _ = shared.sender.set(sender.thread().clone());
        let receiver_shared = Arc::clone(&shared);
        std::thread::Builder::new()
            .name("mbox-receive".to_owned())
            .spawn(move || receive(&receiver_shared, &receiving))
            .map_err(|err| format!("cannot start the MBOX receiver: {err}"))?;
        Ok(Self {
            _close: Arc::new(CloseOnDrop(Arc::clone(&shared))),
            shared,
            frames,
            console,
        })
    }

    /// Hands a console `operation`, issued at e-stop `generation`, to the sender for
    /// box `target` (every box when `None`; a box that is not configured gets nothing).
    pub fn console(&self, target: Option<usize>, operation: Operation, generation: u64) {
        if self
            .console
            .send(ConsoleOut {
                target,
                operation,
                generation,
            })
            .is_ok()
        {
            self.wake();
        }
    }

    /// The boxes' replies to console reads from now on.
    pub fn subscribe_replies(&self) -> broadcast::Receiver<MboxReply> {
        self.shared.replies.subscribe()
    }

    /// Wakes the sender: it looks at the latch at once (the e-stop path).
    pub fn wake(&self) {
        if let Some(sender) = self.shared.sender.get() {
            sender.unpark();
        }
    }

    /// The boxes the e-stop cannot be confirmed to reach now (down), with the reason.
    fn unreachable_boxes(&self) -> Vec<String> {
        (0..self.shared.boxes.len())
            .filter(|&index| self.state(index) == LinkState::Down)
            .map(|index| {
                format!(
                    "MBOX box {index} ({}) does not answer",
                    self.shared.boxes[index].address
                )
            })
            .collect()
    }

    /// Hands `frame`, issued at e-stop `generation`, to the sender for its slot.
    pub fn send(&self, frame: MboxFrame, slot: Instant, generation: u64) {
        if self
            .frames
            .send(Outgoing {
                generation,
                slot,
                frame,
            })
            .is_ok()
        {
            self.wake();
        }
    }

    /// How many boxes.
    pub fn len(&self) -> usize {
        self.shared.boxes.len()
    }

    /// Whether there is no box.
    pub fn is_empty(&self) -> bool {
        self.shared.boxes.is_empty()
    }

    /// Box `index`'s link state: up while it answers polls.
    pub fn state(&self, index: usize) -> LinkState {
        let Some(one) = self.shared.boxes.get(index) else {
            return LinkState::Down;
        };
        let now = self.shared.micros();
        let limit = u64::try_from(DOWN_AFTER.as_micros()).unwrap_or(u64::MAX);
        match one.answered_us.load(Ordering::Acquire) {
            0 if now < limit => LinkState::Connecting,
            0 => LinkState::Down,
            answered if now.saturating_sub(answered - 1) <= limit => LinkState::Up,
            _ => LinkState::Down,
        }
    }

    /// Whether every box answers.
    pub fn all_up(&self) -> bool {
        (0..self.len()).all(|index| self.state(index) == LinkState::Up)
    }

    /// Every box's status, in gateway order.
    pub fn statuses(&self) -> Vec<GatewayStatus> {
        self.shared
            .boxes
            .iter()
            .enumerate()
            .map(|(index, one)| {
                let link = self.state(index);
                GatewayStatus {
                    index,
                    kind: GatewayKind::Mbox,
                    port: one.address.to_string(),
                    link,
                    bytes_per_s: 0.0,
                    lowest_water_level: None,
                    error: (link == LinkState::Down).then(|| {
                        format!(
                            "MBOX box at {} does not answer its register reads; retrying",
                            one.address
                        )
                    }),
                    packets_per_s: Some(f64::from_bits(one.packets_per_s.load(Ordering::Acquire))),
                    late_frames: Some(one.late_frames.load(Ordering::Acquire)),
                    missed_replies: Some(one.missed_replies.load(Ordering::Acquire)),
                    drives: Vec::new(),
                    baud: None,
                    health: None,
                }
            })
            .collect()
    }

    /// How the motion frames left so far.
    pub fn timing(&self) -> MboxTiming {
        self.shared.timing.snapshot(&self.shared.boxes)
    }

    /// The latest a motion frame's first datagram left after its slot lately (over the
    /// last [`RECENT_LATENESS`] to twice that), µs; 0 before any frame.
    pub fn recent_lateness_us(&self) -> u64 {
        self.shared
            .timing
            .recent_max_lateness_us
            .load(Ordering::Relaxed)
    }

    /// Box `index`'s configured address and port.
    pub fn address(&self, index: usize) -> Option<SocketAddr> {
        self.shared.boxes.get(index).map(|one| one.address)
    }

    /// Datagrams sent to box `index` so far.
    pub fn sent(&self, index: usize) -> u64 {
        self.shared
            .boxes
            .get(index)
            .map_or(0, |one| one.sent.load(Ordering::Acquire))
    }
}

/// The bytes of FN `0x0090` = `value` (1 e-stop, 0 release), as written to every box.
fn estop_datagram(value: u16) -> Vec<u8> {
    let write = if value == 0 {
        RegisterWrite::release_estop(Route::BROADCAST_SILENT)
    } else {
        RegisterWrite::estop(Route::BROADCAST_SILENT)
    };
    write.encode()
}

/// Turns the player's frames into the motion datagrams the sender puts on the wire:
/// the time code of the configured [`TimeMode`], and each box's own sequence number
/// (1 for its first frame, counting on and wrapping past 0 to 1).
///
/// **Time codes.** A frame takes `time_ms` (a move's frames the time left, show and
/// settle frames the period, a live frame what its box's pacer made of it — four
/// periods, or less near the travel's ends and at rest). Relative: the time code is that time. Absolute: the box
/// takes a frame's time code minus the previous frame's (the document: 「指令的执行时间
/// 是当前指令里的绝对时间减去上一条指令里的绝对时间」), so each box's time code counts
/// on from the last one it was sent by exactly the frame's time, from 0 when the
/// bridge starts: the first frame's code is its own time (what a box whose last code
/// is 0 takes). Frames never sent (dropped by an e-stop) do not count. Past `u32::MAX`
/// ms (49.7 days of frames and moves) the code starts over from the frame's time,
/// which a box takes as a rewind (its default time for that one frame).
#[derive(Debug)]
struct FrameEncoder {
    time: TimeMode,
    /// Per box: the sequence number of the last frame it was sent.
    sequence: Vec<u32>,
    /// Per box: the absolute time code of the last frame it was sent, ms (0: none).
    absolute_ms: Vec<u32>,
}

impl FrameEncoder {
    fn new(time: TimeMode, boxes: usize) -> Self {
        Self {
            time,
            sequence: vec![0; boxes],
            absolute_ms: vec![0; boxes],
        }
    }

    /// Box `index`'s time code of a frame of `time_ms`, counted on when absolute: its
    /// time (relative), or box `index`'s last time code plus its time (absolute; never
    /// 0).
    fn time_code(&mut self, time_ms: u32, index: usize) -> Option<TimeCode> {
        let time_ms = time_ms.max(1);
        match self.time {
            TimeMode::Relative => Some(TimeCode::from_ms(time_ms)),
            TimeMode::Absolute => {
                let last_ms = self.absolute_ms.get_mut(index)?;
                *last_ms = last_ms.checked_add(time_ms).unwrap_or(time_ms);
                Some(TimeCode::from_ms(*last_ms))
            }
        }
    }

    /// Box `index`'s datagram of `frame`, counted in the box's sequence (and its
    /// absolute time code); `None` (and not counted) when the frame has no valid axis
    /// count for it or the box is not configured.
    fn datagram(&mut self, frame: &MboxFrame, index: usize) -> Option<Vec<u8>> {
        let paced = Paced {
            positions_pulses: frame.positions_pulses.get(index)?.clone(),
            time_ms: frame.time_ms,
        };
        self.paced_datagram(frame, index, &paced)
    }

    /// Box `index`'s datagram of `frame` with the targets and time of `paced` (what
    /// its pacer made of the frame), counted as [`Self::datagram`] counts.
    fn paced_datagram(
        &mut self,
        frame: &MboxFrame,
        index: usize,
        paced: &Paced,
    ) -> Option<Vec<u8>> {
        let positions_pulses = AxisPositions::from_slice(&paced.positions_pulses).ok()?;
        let time_code = self.time_code(paced.time_ms, index)?;
        let sequence = self.sequence.get_mut(index)?;
        *sequence = sequence.wrapping_add(1).max(1);
        let output = frame.outputs.get(index).copied().unwrap_or_default();
        let datagram = MotionFrame {
            mode: self.time,
            route: Route::BROADCAST_SILENT,
            sequence: *sequence,
            time_code,
            positions_pulses,
            digital: DigitalOutputs::from_bits(output.digital_bits),
            analog: output.analog,
        };
        Some(datagram.encode())
    }
}

/// The sender thread's own state.
struct Outbox<'a> {
    shared: &'a Shared,
    socket: UdpSocket,
    seen_generation: u64,
    /// The register value being repeated (1 e-stop, 0 release), how often still, when.
    repeats: crate::estop::Repeats<u16>,
    /// A release must go before the next motion frame.
    needs_release: bool,
    next_poll: Instant,
    /// The first box of the next batch of polls.
    poll_cursor: usize,
    /// Motion frames handed over ahead of their slot, in slot order.
    pending: std::collections::VecDeque<Outgoing>,
    /// Per box: a poll is unanswered (replies count when it was sent).
    polled: Vec<Option<u64>>,
    encoder: FrameEncoder,
    /// Per box: its model for pacing live frames.
    pacers: Vec<BoxPacer>,
    /// The [`RECENT_LATENESS`] window now, the latest a frame left in it and in the
    /// one before, µs.
    lateness_window: (u64, u64, u64),
    meter_since: Instant,
    meter_sent: Vec<u64>,
}

impl<'a> Outbox<'a> {
    fn new(shared: &'a Shared, socket: UdpSocket) -> Self {
        let now = Instant::now();
        let boxes = shared.boxes.len();
        Self {
            shared,
            socket,
            seen_generation: shared.latch.generation(),
            repeats: crate::estop::Repeats::default(),
            needs_release: true,
            next_poll: now,
            poll_cursor: 0,
            pending: std::collections::VecDeque::new(),
            polled: vec![None; boxes],
            encoder: FrameEncoder::new(shared.time, boxes),
            pacers: vec![BoxPacer::new(); boxes],
            lateness_window: (0, 0, 0),
            meter_since: now,
            meter_sent: vec![0; boxes],
        }
    }

    fn send_to(&self, index: usize, datagram: &[u8]) {
        let Some(one) = self.shared.boxes.get(index) else {
            return;
        };
        match self.socket.send_to(datagram, one.address) {
            Ok(_) => {
                one.sent.fetch_add(1, Ordering::AcqRel);
            }
            Err(err) => tracing::debug!("MBOX box {index} ({}): send failed: {err}", one.address),
        }
    }

    /// Writes FN `0x0090` = `value` to every box.
    fn write_estop(&self, value: u16) {
        let bytes = estop_datagram(value);
        for index in 0..self.shared.boxes.len() {
            self.send_to(index, &bytes);
        }
    }

    /// Acts on a new e-stop generation: the stop goes out before anything else.
    fn observe_latch(&mut self, inbox: &Receiver<Outgoing>) {
        let generation = self.shared.latch.generation();
        if generation == self.seen_generation {
            return;
        }
        self.seen_generation = generation;
        self.write_estop(1);
        self.repeats.start_with(1, Instant::now());
        self.needs_release = true;
        while inbox.try_recv().is_ok() {}
        self.pending.clear();
        // Every axis stops where it is: the pacers no longer know where.
        for pacer in &mut self.pacers {
            pacer.forget();
        }
    }

    fn frame(&mut self, outgoing: Outgoing) {
        if outgoing.generation != self.seen_generation || self.shared.latch.is_latched() {
            return;
        }
        if self.needs_release {
            self.needs_release = false;
            self.write_estop(0);
            self.repeats.start_with(0, Instant::now());
        }
        let started = Instant::now();
        let slot_us = self.micros_at(outgoing.slot);
        for index in 0..outgoing.frame.positions_pulses.len() {
            if let Some(datagram) = self.pace(&outgoing.frame, slot_us, index) {
                self.send_to(index, &datagram);
            }
        }
        let finished = Instant::now();
        let late = finished.saturating_duration_since(outgoing.slot) > self.shared.period / 2;
        let lateness = started.saturating_duration_since(outgoing.slot);
        self.shared
            .timing
            .record(lateness, finished.saturating_duration_since(started), late);
        self.recent_lateness(started, lateness);
        if late {
            for one in &self.shared.boxes {
                one.late_frames.fetch_add(1, Ordering::AcqRel);
            }
        }
    }

    /// `at` as µs since the boxes were opened.
    fn micros_at(&self, at: Instant) -> u64 {
        u64::try_from(at.saturating_duration_since(self.shared.epoch).as_micros())
            .unwrap_or(u64::MAX)
    }

    /// Box `index`'s datagram of `frame` (of slot `slot_us`) as it leaves now: paced by
    /// the box's pacer when the frame is live, else as made (and followed by the
    /// pacer).
    fn pace(&mut self, frame: &MboxFrame, slot_us: u64, index: usize) -> Option<Vec<u8>> {
        let made = frame.positions_pulses.get(index)?;
        let send_us = self.shared.micros();
        let pacer = self.pacers.get_mut(index)?;
        match frame.pace.as_ref().and_then(|limits| limits.get(index)) {
            Some(limits) => {
                let paced = pacer.pace(limits, slot_us, send_us, frame.time_ms, made);
                self.encoder.paced_datagram(frame, index, &paced)
            }
            None => {
                pacer.observe(slot_us, send_us, frame.time_ms, made);
                self.encoder.datagram(frame, index)
            }
        }
    }

    /// Counts a frame that left `lateness` after its slot, at `at`, in the recent
    /// latest.
    fn recent_lateness(&mut self, at: Instant, lateness: Duration) {
        let window = self
            .micros_at(at)
            .checked_div(u64::try_from(RECENT_LATENESS.as_micros()).unwrap_or(1))
            .unwrap_or(0);
        let lateness_us = u64::try_from(lateness.as_micros()).unwrap_or(u64::MAX);
        let (now, latest, before) = &mut self.lateness_window;
        if window != *now {
            *before = if window == *now + 1 { *latest } else { 0 };
            *latest = 0;
            *now = window;
        }
        *latest = (*latest).max(lateness_us);
        self.shared
            .timing
            .recent_max_lateness_us
            .store((*latest).max(*before), Ordering::Relaxed);
    }

    /// The time between two batches of polls: every box once in [`POLL_INTERVAL`].
    fn poll_step(&self) -> Duration {
        let batches = self.shared.boxes.len().div_ceil(POLL_BATCH).max(1);
        POLL_INTERVAL / u32::try_from(batches).unwrap_or(u32::MAX)
    }

    /// Sends a console operation; a write issued before the last e-stop, or arriving
    /// while the e-stop is latched (the session's check may have raced the press), is
    /// void — the e-stop write itself excepted.
    fn console(&self, out: ConsoleOut) {
        let is_poll = match &out.operation {
            Operation::Read(read) => is_poll_shaped(
                read.bank,
                read.range.start(),
                usize::from(read.range.count()),
            ),
            Operation::Write(write) => {
                if (out.generation != self.seen_generation || self.shared.latch.is_latched())
                    && !write.is_estop()
                {
                    return;
                }
                false
            }
        };
        let bytes = Datagram::from(out.operation).encode();
        for index in 0..self.shared.boxes.len() {
            if out.target.is_some_and(|target| target != index) {
                continue;
            }
            if is_poll {
                self.shared.boxes[index]
                    .console_polls
                    .fetch_add(1, Ordering::AcqRel);
            }
            self.send_to(index, &bytes);
        }
    }

    /// Polls the e-stop register of the next [`POLL_BATCH`] boxes; counts the polls
    /// they left unanswered; writes the register again where the answer disagrees
    /// with the latch.
    fn poll(&mut self) {
        let read = RegisterRead {
            bank: ReadBank::Fn,
            route: Route {
                receiver: BoxAddress::ALL,
                replier: BoxAddress::ALL,
            },
            range: match RegisterRange::new(FN_ESTOP, 1) {
                Ok(range) => range,
                Err(_) => return,
            },
        }
        .encode();
        let latched = self.shared.latch.is_latched();
        let boxes = self.shared.boxes.len();
        let batch = self.poll_cursor.min(boxes)..(self.poll_cursor + POLL_BATCH).min(boxes);
        self.poll_cursor = if batch.end >= boxes { 0 } else { batch.end };
        for index in batch {
            let one = &self.shared.boxes[index];
            let replies = one.replies.load(Ordering::Acquire);
            if let Some(sent_at) = self.polled[index]
                && replies == sent_at
            {
                one.missed_replies.fetch_add(1, Ordering::AcqRel);
            }
            let register = one.estop_register.load(Ordering::Acquire);
            let wanted = if latched {
                Some(1)
            } else if self.needs_release {
                None
            } else {
                Some(0)
            };
            if let Some(wanted) = wanted
                && register != u16::MAX
                && register != wanted
            {
                let write = if wanted == 0 {
                    RegisterWrite::release_estop(Route::BROADCAST_SILENT)
                } else {
                    RegisterWrite::estop(Route::BROADCAST_SILENT)
                };
                self.send_to(index, &write.encode());
            }
            self.polled[index] = Some(replies);
            self.send_to(index, &read);
        }
    }

    fn meter(&mut self, now: Instant) {
        let elapsed = now.saturating_duration_since(self.meter_since);
        if elapsed < Duration::from_secs(1) {
            return;
        }
        for (one, last) in self.shared.boxes.iter().zip(&mut self.meter_sent) {
            let sent = one.sent.load(Ordering::Acquire);
            let rate = (sent - *last) as f64 / elapsed.as_secs_f64();
            one.packets_per_s.store(rate.to_bits(), Ordering::Release);
            *last = sent;
        }
        self.meter_since = now;
    }

    fn run(mut self, inbox: &Receiver<Outgoing>, console: &Receiver<ConsoleOut>) {
        while !self.shared.closed.load(Ordering::Acquire) {
            self.observe_latch(inbox);
            while let Ok(outgoing) = inbox.try_recv() {
                self.pending.push_back(outgoing);
            }
            while self
                .pending
                .front()
                .is_some_and(|outgoing| outgoing.slot <= Instant::now())
            {
                self.observe_latch(inbox);
                if let Some(outgoing) = self.pending.pop_front() {
                    self.frame(outgoing);
                }
            }
            while let Ok(out) = console.try_recv() {
                self.observe_latch(inbox);
                self.console(out);
            }
            let now = Instant::now();
            if let Some(value) = self.repeats.due_value(now) {
                self.write_estop(value);
            }
            if now >= self.next_poll {
                self.poll();
                self.next_poll = now + self.poll_step();
            }
            self.meter(now);
            let mut wake = self.next_poll;
            if let Some(at) = self.repeats.next() {
                wake = wake.min(at);
            }
            if let Some(outgoing) = self.pending.front() {
                wake = wake.min(outgoing.slot);
            }
            std::thread::park_timeout(wake.saturating_duration_since(Instant::now()));
        }
    }
}

/// Whether a read has the shape of the bridge's poll: FN `0x0090`, one register.
fn is_poll_shaped(bank: ReadBank, start: u16, count: usize) -> bool {
    bank == ReadBank::Fn && start == FN_ESTOP && count == 1
}

/// Relays `reply` from box `index` to the console when it answers a console read.
fn relay(shared: &Shared, index: usize, one: &BoxShared, reply: &RegisterReply) {
    let values = reply.block.values();
    if is_poll_shaped(reply.bank, reply.block.start(), values.len())
        && one
            .console_polls
            .fetch_update(Ordering::AcqRel, Ordering::Acquire, |owed| {
                owed.checked_sub(1)
            })
            .is_err()
    {
        return;
    }
    // No session listening is not a failure.
    let _ = shared.replies.send(MboxReply {
        gateway: index,
        text: render_reply(reply, ReplyLayout::Line),
        registers: MboxRegisters {
            bank: match reply.bank {
                ReadBank::Fn => "FN",
                ReadBank::Dn => "DN",
            }
            .to_owned(),
            start: reply.block.start(),
            values: values.to_vec(),
        },
    });
}

/// The receiver thread: matches answers to boxes by source address.
fn receive(shared: &Shared, socket: &UdpSocket) {
    let mut buffer = vec![0u8; 2048];
    while !shared.closed.load(Ordering::Acquire) {
        let (len, from) = match socket.recv_from(&mut buffer) {
            Ok(received) => received,
            // Timeouts, and ICMP "port unreachable" from a box that is not there.
            Err(_) => continue,
        };
        let Some((index, one)) = shared
            .boxes
            .iter()
            .enumerate()
            .find(|(_, one)| one.address == from)
        else {
            shared.unexpected.fetch_add(1, Ordering::Relaxed);
            continue;
        };
        match Datagram::decode(buffer.get(..len).unwrap_or_default()) {
            Ok(Datagram::ReadReply(reply)) => {
                relay(shared, index, one, &reply);
                if reply.bank == ReadBank::Fn {
                    if let Some(value) = reply.block.get(FN_ESTOP) {
                        one.estop_register.store(value, Ordering::Release);
                    }
                    one.answered_us
                        .store(shared.micros().saturating_add(1), Ordering::Release);
                    one.replies.fetch_add(1, Ordering::AcqRel);
                }
            }
            _ => {
                shared.unexpected.fetch_add(1, Ordering::Relaxed);
            }
        }
    }
}

impl crate::estop::StopPort for MboxNet {
    /// Wakes the sender: it writes the boxes' e-stop register before any frame.
    fn wake(&self) {
        MboxNet::wake(self);
    }

    fn unreachable(&self) -> Vec<String> {
        self.unreachable_boxes()
    }
}

#[cfg(test)]
#[path = "mbox_tests.rs"]
mod tests;
