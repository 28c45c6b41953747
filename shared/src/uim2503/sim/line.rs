//! The simulated gateway's serial port: a line that carries baud / 10 bytes/s each
//! way (8N1), a receive side that overruns, and a transmit queue of bounded size.
//!
//! - **Receiving.** Bytes handed to [`Uart::receive`] at a time `t` are taken to have
//!   arrived back to back, the last one at `t`. The line carries one byte per byte
//!   time; a byte that would have had to share the line with earlier ones came faster
//!   than the line carries and is lost, as in a UART receive overrun, beyond a receive
//!   FIFO of [`RX_FIFO_BYTES`] (slack for the timing of whoever reads a real device).
//!   Lost bytes are counted ([`SimLineStats::overrun_bytes`]). Of a chunk that came too
//!   fast, the *last* bytes are kept: they are the ones the line could have carried
//!   by `t`. [`RxLine`] is that rule on its own, for a reader that wants to read no
//!   faster than the line (`floatball simulate` does).
//! - **Sending.** The gateway's answers wait in a queue of at most [`TX_QUEUE_BYTES`]
//!   bytes and leave at the line's speed. When an instruction makes more answers than
//!   fit (a flood of `*0;SN;`, say, 6 bytes in and 1200 out), the *oldest* whole frames
//!   not yet begun are dropped and counted ([`SimLineStats::dropped_frames`]); a frame on
//!   the wire is always finished, so the host's decoder never sees half a frame. The
//!   newest answers survive, so after any flood an instruction is answered within the
//!   time the line needs for one queue: `TX_QUEUE_BYTES` byte times.
//!
//! - **Speed.** The host's end of the line has a speed of its own
//!   ([`Uart::set_host_baud`]); while it differs from the gateway's, every byte either
//!   way is misread at the far end: what the host sends is lost before the gateway
//!   reads it, what the gateway sends never reaches the host as bytes it could read
//!   (both counted, [`Uart::mismatched_bytes`]). [`Uart::restart`] is the gateway's
//!   power cycle: a line speed stored by `BDR=x;` takes effect then.
//!
//! Time is µs, as for the [`Gateway`]; a byte time need not be whole µs (10.85 µs at
//! 921600 baud), so the line keeps its own clock in µs × baud, where one byte is
//! 10 000 000 units.
//!
//! ```
//! use floatball_shared::uim2503::feedback::FrameDecoder;
//! use floatball_shared::uim2503::sim::{GatewayConfig, TX_QUEUE_BYTES, Uart};
//!
//! let mut uart = Uart::new(GatewayConfig::numbered(100), 115_200)?;
//! // 1000 roll calls at once: 6 kB in, 1.2 MB of answers; most of both are lost.
//! uart.receive(0, &b"*0;SN;".repeat(1000));
//! let mut answers = Vec::new();
//! uart.step(1_000_000, &mut answers);
//! let stats = uart.stats();
//! assert!(stats.overrun_bytes > 5000 && stats.dropped_frames > 0);
//! // A second later, one roll call at the line's speed is answered in full, in the time
//! // the line needs for the queue (12 bytes per serial, 11520 bytes/s).
//! uart.receive(2_000_000, b"*0;SN;");
//! let queue_us = (TX_QUEUE_BYTES as u64 + 12) * 1_000_000 / 11_520;
//! answers.clear();
//! uart.step(2_000_000 + queue_us, &mut answers);
//! assert_eq!(answers.len(), 1200);
//! assert_eq!(FrameDecoder::new().push(&answers).count(), 100);
//! # Ok::<(), floatball_shared::uim2503::sim::ConfigError>(())
//! ```

use std::collections::VecDeque;

use crate::api::{SimGateway, SimLineStats};

use super::{ConfigError, Gateway, GatewayConfig};
use crate::line::BITS_PER_BYTE;

/// Bytes beyond the line's speed the receive side absorbs before it overruns.
pub const RX_FIFO_BYTES: usize = 256;

/// The most answer bytes waiting to be sent; beyond it the oldest frames are dropped.
/// It holds three full roll calls of 100 units (12 bytes each).
pub const TX_QUEUE_BYTES: usize = 4096;

/// One byte on the line in line units (µs × baud): [`BITS_PER_BYTE`] bits (8N1) of
/// 10⁶/baud µs.
const BYTE: i128 = BITS_PER_BYTE as i128 * 1_000_000;

/// The slack of the receive FIFO, line units.
const RX_LIMIT: i128 = (RX_FIFO_BYTES as i128 - 1) * BYTE;

/// The gateway reads received bytes in pieces this long, so that the answers one piece
/// makes stay small before they reach the bounded queue.
const RX_PIECE: usize = 32;

/// Counts a number of bytes into a counter.
fn bump(counter: &mut u64, by: usize) {
    *counter = counter.saturating_add(u64::try_from(by).unwrap_or(u64::MAX));
}

/// The receiving half of a line at one baud rate: which bytes could have crossed it;
/// see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct RxLine {
    baud: i128,
    /// When the line has carried every byte taken so far, line units (the "theoretical
    /// arrival time" of the next byte).
    busy_until: i128,
}

impl RxLine {
    /// An idle line at `baud` (at least 1).
    #[must_use]
    pub fn new(baud: u32) -> Self {
        Self {
            baud: i128::from(baud.max(1)),
            // Nothing arrives before the gateway exists.
            busy_until: 0,
        }
    }

    fn at(&self, now_us: u64) -> i128 {
        i128::from(now_us) * self.baud
    }

    /// How many bytes may finish arriving at `now_us` without an overrun.
    #[must_use]
    pub fn room(&self, now_us: u64) -> usize {
        let slack = self.at(now_us) + RX_LIMIT - self.busy_until;
        if slack < 0 {
            return 0;
        }
        usize::try_from(slack / BYTE + 1).unwrap_or(usize::MAX)
    }

    /// When [`room`](Self::room) is next at least one byte, µs (now or earlier if it
    /// already is).
    #[must_use]
    pub fn next_room_us(&self) -> u64 {
        let units = self.busy_until - RX_LIMIT;
        u64::try_from((units + self.baud - 1).div_euclid(self.baud).max(0)).unwrap_or(u64::MAX)
    }

    /// `len` bytes finished arriving back to back at `now_us`: returns how many of them,
    /// counted from the end, the line could have carried. The others overran.
    pub fn accept(&mut self, now_us: u64, len: usize) -> usize {
        let accepted = self.room(now_us).min(len);
        if accepted > 0 {
            let count = i128::try_from(accepted).unwrap_or(i128::MAX / BYTE);
            let first = self.at(now_us) - (count - 1) * BYTE;
            self.busy_until = self.busy_until.max(first) + count * BYTE;
        }
        accepted
    }
}

/// A simulated [`Gateway`] behind its serial port; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Uart {
    gateway: Gateway,
    baud: i128,
    rx: RxLine,
    /// Answer bytes not yet sent.
    tx: VecDeque<u8>,
    /// The lengths of the frames in `tx`, in order (the front one may be partly sent).
    tx_frames: VecDeque<usize>,
    /// The front frame has begun crossing the line.
    front_started: bool,
    /// When the front byte of `tx` will have crossed the line, line units.
    next_byte_end: i128,
    /// When the last byte sent finished crossing, line units.
    idle_from: i128,
    scratch: Vec<u8>,
    stats: SimLineStats,
    /// The speed the host's end of the line runs at, baud.
    host_baud: u32,
    /// Bytes either way lost to a speed mismatch.
    mismatched_bytes: u64,
}

impl Uart {
    /// A gateway built from `config` on a line at `baud` (at least 1), at time 0.
    ///
    /// # Errors
    /// [`ConfigError`] if the configuration cannot be simulated.
    pub fn new(config: GatewayConfig, baud: u32) -> Result<Self, ConfigError> {
        Ok(Self {
            gateway: Gateway::new(config)?,
            baud: i128::from(baud.max(1)),
            rx: RxLine::new(baud),
            tx: VecDeque::with_capacity(TX_QUEUE_BYTES),
            tx_frames: VecDeque::new(),
            front_started: false,
            next_byte_end: 0,
            idle_from: 0,
            scratch: Vec::new(),
            stats: SimLineStats::default(),
            host_baud: baud.max(1),
            mismatched_bytes: 0,
        })
    }

    /// The gateway's line speed, baud.
    #[must_use]
    pub fn baud(&self) -> u32 {
        u32::try_from(self.baud).unwrap_or(u32::MAX)
    }

    /// The host's end of the line now runs at `baud` (at least 1).
    pub fn set_host_baud(&mut self, baud: u32) {
        self.host_baud = baud.max(1);
    }

    /// Whether the host's and the gateway's ends of the line run at the same speed.
    #[must_use]
    pub fn speeds_match(&self) -> bool {
        i128::from(self.host_baud) == self.baud
    }

    /// Bytes either way lost because the two ends' speeds differ.
    #[must_use]
    pub fn mismatched_bytes(&self) -> u64 {
        self.mismatched_bytes
    }

    /// The gateway's power cycle at `now_us` (see [`Gateway::restart`]): answers not
    /// sent yet are lost, and the line runs at the speed `BDR=x;` stored, if any.
    pub fn restart(&mut self, now_us: u64) {
        let now_us = now_us.max(self.gateway.now_us());
        self.gateway.advance(now_us);
        if let Some(baud) = self.gateway.restart() {
            self.baud = i128::from(baud.max(1));
            self.rx = RxLine::new(baud);
        }
        self.tx.clear();
        self.tx_frames.clear();
        self.front_started = false;
        let now = i128::from(now_us) * self.baud;
        self.next_byte_end = now;
        self.idle_from = now;
    }

    /// The gateway.
    #[must_use]
    pub fn gateway(&self) -> &Gateway {
        &self.gateway
    }

    /// The gateway, to inject faults or let time pass for a view. Its answers still go
    /// through the queue.
    pub fn gateway_mut(&mut self) -> &mut Gateway {
        &mut self.gateway
    }

    /// What crossed the line so far, and what was lost.
    #[must_use]
    pub fn stats(&self) -> SimLineStats {
        self.stats
    }

    /// Answer bytes waiting to be sent (never more than [`TX_QUEUE_BYTES`] plus the
    /// frame on the wire).
    #[must_use]
    pub fn queued_bytes(&self) -> usize {
        self.tx.len()
    }

    /// How many bytes may finish arriving at `now_us` without an overrun (see
    /// [`RxLine::room`]).
    #[must_use]
    pub fn room(&self, now_us: u64) -> usize {
        self.rx.room(now_us)
    }

    /// [`Gateway::positions`] with the line's counts.
    #[must_use]
    pub fn positions(&self, gateway: usize) -> SimGateway {
        SimGateway {
            line: self.stats,
            ..self.gateway.positions(gateway)
        }
    }

    /// Bytes from the host finished arriving at `now_us` (time first passes up to then):
    /// those the line could have carried are read by the gateway, the others overrun.
    /// Times earlier than the gateway's count as its time (time never goes back).
    pub fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        let now_us = now_us.max(self.gateway.now_us());
        if !self.speeds_match() {
            bump(&mut self.mismatched_bytes, bytes.len());
            self.gateway.advance(now_us);
            self.collect();
            return;
        }
        let accepted = self.rx.accept(now_us, bytes.len());
        let lost = bytes.len() - accepted;
        bump(&mut self.stats.overrun_bytes, lost);
        bump(&mut self.stats.received_bytes, accepted);
        self.gateway.advance(now_us);
        self.collect();
        for piece in bytes[lost..].chunks(RX_PIECE) {
            self.gateway.receive(now_us, piece);
            self.collect();
        }
    }

    /// Lets time pass up to `now_us` and appends to `out` the answer bytes that have
    /// crossed the line by then.
    pub fn step(&mut self, now_us: u64, out: &mut Vec<u8>) {
        let now_us = now_us.max(self.gateway.now_us());
        self.gateway.advance(now_us);
        self.collect();
        let now = i128::from(now_us) * self.baud;
        while self.next_byte_end <= now {
            let Some(byte) = self.tx.pop_front() else {
                break;
            };
            if self.speeds_match() {
                out.push(byte);
            } else {
                bump(&mut self.mismatched_bytes, 1);
            }
            bump(&mut self.stats.sent_bytes, 1);
            self.front_started = true;
            if let Some(front) = self.tx_frames.front_mut() {
                *front = front.saturating_sub(1);
                if *front == 0 {
                    self.tx_frames.pop_front();
                    self.front_started = false;
                }
            }
            self.idle_from = self.next_byte_end;
            self.next_byte_end += BYTE;
        }
    }

    /// When [`step`](Self::step) next has something to do: an answer byte has crossed,
    /// or the gateway has an event; µs. `None` while the line and the gateway are idle.
    #[must_use]
    pub fn next_event_us(&self) -> Option<u64> {
        let line = (!self.tx.is_empty()).then(|| {
            let us = (self.next_byte_end + self.baud - 1).div_euclid(self.baud);
            u64::try_from(us.max(0)).unwrap_or(u64::MAX)
        });
        match (line, self.gateway.next_event_us()) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    /// Moves the gateway's new answers into the queue, dropping the oldest frames not
    /// yet begun if they do not fit.
    fn collect(&mut self) {
        self.scratch.clear();
        if self.gateway.poll_output(&mut self.scratch) == 0 {
            return;
        }
        if self.tx.is_empty() {
            // An idle line starts sending now.
            let now = i128::from(self.gateway.now_us()) * self.baud;
            self.next_byte_end = self.idle_from.max(now) + BYTE;
            self.tx_frames.clear();
            self.front_started = false;
        }
        for &byte in &self.scratch {
            // A header starts a frame; anything else (a garbled byte) belongs to the
            // frame before it.
            match self.tx_frames.back_mut() {
                Some(last) if byte < 0xF0 => *last += 1,
                _ => self.tx_frames.push_back(1),
            }
            self.tx.push_back(byte);
        }
        while self.tx.len() > TX_QUEUE_BYTES {
            let victim = usize::from(self.front_started);
            let Some(len) = self.tx_frames.remove(victim) else {
                break;
            };
            let from = if self.front_started {
                self.tx_frames.front().copied().unwrap_or_default()
            } else {
                0
            };
            self.tx.drain(from..from + len);
            bump(&mut self.stats.dropped_frames, 1);
            bump(&mut self.stats.dropped_bytes, len);
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::uim2503::feedback::{Ack, Feedback, FrameDecoder};

    /// µs per byte at 115200 baud, rounded up.
    const BYTE_US_115200: u64 = 87;

    fn serials(bytes: &[u8]) -> usize {
        FrameDecoder::new()
            .push(bytes)
            .filter(|frame| {
                matches!(
                    Feedback::from_frame(frame),
                    Ok(Feedback::Ack(Ack::Serial { .. }))
                )
            })
            .count()
    }

    #[test]
    fn bytes_at_the_lines_speed_are_all_read() {
        let mut uart = Uart::new(GatewayConfig::numbered(3), 115_200).unwrap();
        let text = b"*1;MO=1;*2;MO=1;*3;MO=1;".repeat(40);
        // One byte every byte time, delivered in chunks of 7 at the last one's time.
        for (i, chunk) in text.chunks(7).enumerate() {
            let end_us = (i as u64 * 7 + chunk.len() as u64) * 1_000_000 / 11_520;
            uart.receive(end_us, chunk);
        }
        let stats = uart.stats();
        assert_eq!(stats.overrun_bytes, 0);
        assert_eq!(stats.received_bytes, text.len() as u64);
    }

    #[test]
    fn a_burst_beyond_the_fifo_keeps_its_last_bytes() {
        let mut line = RxLine::new(115_200);
        assert_eq!(
            line.accept(1_000_000, 10_000),
            10_000,
            "after an idle second"
        );
        // The last of them arrived just now: the FIFO has room for the rest.
        assert_eq!(line.room(1_000_000), RX_FIFO_BYTES - 1);
        assert_eq!(line.accept(1_000_000, 1000), RX_FIFO_BYTES - 1);
        assert_eq!(line.room(1_000_000), 0);
        assert_eq!(line.next_room_us(), 1_000_000 + 1_000_000 / 11_520 + 1);
        assert_eq!(line.room(line.next_room_us()), 1);

        let mut uart = Uart::new(GatewayConfig::numbered(2), 115_200).unwrap();
        let mut burst = b"*1;MO=1;".repeat(100);
        burst.extend_from_slice(b";*0;SN;");
        uart.receive(0, &burst);
        let stats = uart.stats();
        assert_eq!(
            (stats.received_bytes, stats.overrun_bytes),
            (
                RX_FIFO_BYTES as u64,
                burst.len() as u64 - RX_FIFO_BYTES as u64
            )
        );
        let mut out = Vec::new();
        uart.step(1_000_000, &mut out);
        assert_eq!(serials(&out), 2, "the roll call at the end was read");
    }

    #[test]
    fn the_queue_keeps_the_newest_answers_and_counts_the_rest() {
        let mut uart = Uart::new(GatewayConfig::numbered(100), 115_200).unwrap();
        // Ten roll calls at the line's speed: 12000 bytes of answers for a 4096-byte
        // queue.
        for i in 0..10 {
            uart.receive(i * 6 * BYTE_US_115200, b"*0;SN;");
        }
        assert!(uart.queued_bytes() <= TX_QUEUE_BYTES + 12);
        let mut out = Vec::new();
        uart.step(10_000_000, &mut out);
        let stats = uart.stats();
        assert_eq!(stats.sent_bytes, out.len() as u64);
        assert_eq!(stats.sent_bytes + stats.dropped_bytes, 12_000);
        assert_eq!(stats.dropped_bytes, stats.dropped_frames * 12);
        // Whole frames only: everything sent decodes.
        let mut decoder = FrameDecoder::new();
        assert_eq!(decoder.push(&out).count() * 12, out.len());
        // The last roll call is complete, at the end.
        assert_eq!(serials(&out[out.len() - 1200..]), 100);
        assert_eq!(uart.next_event_us(), None);
    }

    #[test]
    fn answers_leave_at_the_lines_speed() {
        let mut uart = Uart::new(GatewayConfig::numbered(1), 115_200).unwrap();
        uart.receive(1000, b"*1;MO=1;");
        // 5 bytes: the last has crossed 434.03 µs after 1000 µs.
        assert_eq!(uart.next_event_us(), Some(1087));
        let mut out = Vec::new();
        uart.step(1434, &mut out);
        assert_eq!(out.len(), 4);
        uart.step(1435, &mut out);
        assert_eq!(out.len(), 5);
        assert_eq!(uart.next_event_us(), None);
        assert_eq!(uart.positions(0).line.sent_bytes, 5);
    }

    #[test]
    fn the_greeting_is_answered_and_a_stored_speed_waits_for_the_restart() {
        use crate::uim2503::ascii::gateway::GREETING_ANSWER;

        let mut uart = Uart::new(GatewayConfig::numbered(2), 9600).unwrap();
        uart.receive(10_000, b"ABC;");
        let mut out = Vec::new();
        uart.step(20_000, &mut out);
        assert_eq!(out, GREETING_ANSWER);

        // BDR is stored and answered by nothing; the line keeps its speed.
        uart.receive(30_000, b"BDR=115200;ABC;");
        assert_eq!(uart.gateway().stored_baud(), Some(115_200));
        out.clear();
        uart.step(40_000, &mut out);
        assert_eq!(out, GREETING_ANSWER);
        assert_eq!(uart.baud(), 9600);

        // After the power cycle the gateway runs at 115200: a host still at 9600 is
        // neither heard nor answered.
        uart.restart(50_000);
        assert_eq!(uart.baud(), 115_200);
        assert!(!uart.speeds_match());
        uart.receive(60_000, b"ABC;*1;PV;");
        out.clear();
        uart.step(100_000, &mut out);
        assert!(out.is_empty(), "{out:02X?}");
        assert_eq!(uart.mismatched_bytes(), 10);
        assert_eq!(uart.stats().received_bytes, 15 + 4);

        // The host follows: greeted, answered, and the units answer too.
        uart.set_host_baud(115_200);
        uart.receive(110_000, b"ABC;*1;PV;");
        out.clear();
        uart.step(120_000, &mut out);
        assert_eq!(out.get(..3), Some(&GREETING_ANSWER[..]));
        assert_eq!(FrameDecoder::new().push(&out[3..]).count(), 1);

        // The speed stays stored across later restarts.
        uart.restart(130_000);
        assert_eq!(uart.baud(), 115_200);
    }

    #[test]
    fn answers_at_a_mismatched_speed_are_lost_and_a_restart_drops_the_queue() {
        let mut uart = Uart::new(GatewayConfig::numbered(100), 9600).unwrap();
        uart.receive(10_000, b"*0;SN;");
        // The host changes speed while the roll call is being answered.
        let mut out = Vec::new();
        uart.step(100_000, &mut out);
        let before = out.len();
        assert!(before > 0 && before < 1200);
        uart.set_host_baud(19_200);
        uart.step(2_000_000, &mut out);
        assert_eq!(out.len(), before, "nothing readable arrives");
        assert_eq!(uart.mismatched_bytes(), 1200 - before as u64);

        uart.set_host_baud(9600);
        uart.receive(3_000_000, b"*0;SN;");
        uart.step(3_100_000, &mut out);
        uart.restart(3_100_000);
        assert_eq!(uart.queued_bytes(), 0);
        assert_eq!(uart.next_event_us(), None);
        // Without a stored speed the restart keeps the line's speed.
        assert_eq!(uart.baud(), 9600);
    }
}
