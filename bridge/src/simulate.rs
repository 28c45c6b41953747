//! `floatball simulate`: a simulated gateway on the far end of a real serial device —
//! for tests with a pseudo-terminal pair, and for demonstrations with two serial
//! adapters and a null-modem cable.
//!
//! It answers exactly as the in-process simulated gateway does ([`SimEngine`]): bytes
//! are handed to the gateway as they arrive, and its answers are written no faster than
//! the line's baud rate carries them.
//!
//! The device is read no faster than the line carries bytes (baud / 10 bytes/s, with
//! the receive FIFO's slack, [`RX_FIFO_BYTES`]): what a host writes faster waits in the
//! operating system's buffer and the host's writes block, exactly as writing to a real
//! serial port at that baud rate does. So nothing a host sends is lost here, however
//! fast it writes; the simulated line's overrun (bytes lost, counted) is for callers that
//! hand the engine bytes faster than the line carries them.
//!
//! The answers are bounded by the simulated line ([`TX_QUEUE_BYTES`]: the oldest answers
//! are dropped, and counted, when a flood of queries makes more than the line can
//! carry). If the host does not read the device and its buffer is full, the answers
//! that cannot be written are lost too, as on a real line nobody listens to; they are
//! counted and logged, and the simulator carries on.
//!
//! The gateway answers the greeting `ABC;` with `AA AB AC`. `BDR=x;` is stored (a line
//! says so on standard output) and takes effect at the gateway's power cycle, which is
//! **SIGHUP** here (`kill -HUP <pid>`): the gateway restarts, and if a speed was stored
//! the device is switched to it (another line on standard output). A host still at the
//! old speed is then neither heard nor answered — on a real cable; over a
//! pseudo-terminal, which has no speed, the bytes still pass (a test's cable between two
//! pseudo-terminals can compare the two ends' speeds).
//!
//! The same gateways on TCP sockets (`--listen`, `--gateways`), as if behind serial
//! device servers, are [`tcp`]. MBOX boxes on UDP sockets (`--kind mbox`) are [`mbox`];
//! MOONS' drives on a serial device or on UDP (`--kind scl`) are [`scl`].
//!
//! [`RX_FIFO_BYTES`]: floatball_shared::uim2503::sim::RX_FIFO_BYTES
//! [`TX_QUEUE_BYTES`]: floatball_shared::uim2503::sim::TX_QUEUE_BYTES

pub mod mbox;
pub mod scl;
pub mod tcp;

use std::io::Write as _;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::mpsc::{RecvTimeoutError, Sender, channel};
use std::time::{Duration, Instant};

use floatball_shared::uim2503::sim::{GatewayConfig, RxLine};
use serialport::SerialPort;

use crate::ports::uim2503::serial::open_port;
use crate::ports::uim2503::sim::SimEngine;

/// Bytes the reader leaves of the line's room, so that the engine's clock and the
/// reader's never disagree into an overrun.
const READ_MARGIN: usize = 4;

/// The receiving end of the simulated line on a real device or socket: how many bytes
/// may be taken from it now without outrunning the line (baud / 10 bytes/s, with the
/// receive FIFO's slack, less [`READ_MARGIN`]), and how long until more may.
#[derive(Debug)]
struct LineIntake {
    line: RxLine,
    baud: u32,
    epoch: Instant,
}

impl LineIntake {
    fn new(baud: u32) -> Self {
        Self {
            line: RxLine::new(baud),
            baud,
            epoch: Instant::now(),
        }
    }

    /// The line now runs at `baud` (an idle line from now on, if that is a change).
    fn set_baud(&mut self, baud: u32) {
        if baud != self.baud {
            *self = Self::new(baud);
        }
    }

    fn micros(&self, at: Instant) -> u64 {
        u64::try_from(at.saturating_duration_since(self.epoch).as_micros()).unwrap_or(u64::MAX)
    }

    /// How many bytes may be taken at `now`, at most `limit`.
    fn room(&self, now: Instant, limit: usize) -> usize {
        // The engine keeps its own clock; a few bytes less than the room keeps rounding
        // between the two from ever counting as an overrun.
        self.line
            .room(self.micros(now))
            .saturating_sub(READ_MARGIN)
            .min(limit)
    }

    /// How long from `now` until at least one byte may be taken.
    fn until_room(&self, now: Instant) -> Duration {
        Duration::from_micros(self.line.next_room_us().saturating_sub(self.micros(now)))
    }

    /// `len` bytes were taken at `at`.
    fn accept(&mut self, at: Instant, len: usize) {
        self.line.accept(self.micros(at), len);
    }
}

/// Says (with `prefix`) a line speed the gateway newly stored from `BDR=x;`;
/// `said` is the one said last.
fn say_stored_baud(engine: &SimEngine, said: &mut Option<u32>, prefix: &str) {
    let stored = engine.stored_baud();
    if stored != *said {
        *said = stored;
        if let Some(baud) = stored {
            say(&format!(
                "{prefix}stored BDR={baud}; it takes effect at its restart (SIGHUP)"
            ));
        }
    }
}

/// What to simulate, and where.
#[derive(Debug, Clone)]
pub struct SimulateOptions {
    /// The serial device to answer on.
    pub port: String,
    /// Its baud rate.
    pub baud: u32,
    /// The units behind the gateway.
    pub gateway: GatewayConfig,
}

/// Answers on `options.port` until `stop` is set or the port fails; `ready` is called
/// once the port is open. Setting `power_cycle` restarts the gateway (it is cleared
/// when done): a line speed stored by `BDR=x;` then takes effect.
///
/// # Errors
/// The port cannot be opened, or reading or writing it fails.
pub fn run(
    options: &SimulateOptions,
    stop: &Arc<AtomicBool>,
    power_cycle: &AtomicBool,
    ready: impl FnOnce(),
) -> Result<(), String> {
    let mut port = open_port(&options.port, options.baud)?;
    let reader = port
        .try_clone()
        .map_err(|err| format!("cannot read from {}: {err}", options.port))?;
    let mut engine = SimEngine::new(options.gateway.clone(), options.baud)?;
    let (arrivals, arrived) = channel::<Result<(Instant, Vec<u8>), String>>();
    let reader_stop = Arc::clone(stop);
    let baud = Arc::new(AtomicU32::new(options.baud));
    let reader_baud = Arc::clone(&baud);
    std::thread::Builder::new()
        .name("simulate-read".to_owned())
        .spawn(move || read_at_line_speed(reader, &reader_baud, &reader_stop, &arrivals))
        .map_err(|err| format!("cannot start the reader thread: {err}"))?;
    ready();
    let mut answers = Vec::new();
    let mut unwritten: u64 = 0;
    let mut stored = None;
    while !stop.load(Ordering::Acquire) {
        if power_cycle.swap(false, Ordering::AcqRel) {
            engine.restart(Instant::now());
            let now_baud = engine.baud();
            if now_baud != baud.load(Ordering::Acquire) {
                port.set_baud_rate(now_baud).map_err(|err| {
                    format!("cannot set {} to {now_baud} baud: {err}", options.port)
                })?;
                // This end of the line follows the gateway; the far end is the host's.
                engine.set_host_baud(now_baud);
                baud.store(now_baud, Ordering::Release);
            }
            say(&format!(
                "the gateway restarted; the line runs at {now_baud} baud"
            ));
        }
        let now = Instant::now();
        let wait = engine
            .next_wakeup(now)
            .saturating_duration_since(now)
            .min(Duration::from_millis(50));
        match arrived.recv_timeout(wait) {
            Ok(Ok((at, bytes))) => {
                engine.receive(at, &bytes);
                say_stored_baud(&engine, &mut stored, "the gateway ");
            }
            Ok(Err(reason)) => return Err(reason),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => return Err("the reader stopped".to_owned()),
        }
        answers.clear();
        engine.step(Instant::now(), &mut answers);
        let lost = write_or_drop(&mut *port, &answers)?;
        if lost > 0 {
            unwritten += lost as u64;
            let line = engine.view().line();
            tracing::warn!(
                "the host is not reading {}: {lost} answer bytes lost ({unwritten} so far; \
                 {} dropped from the full answer queue, {} overrun)",
                options.port,
                line.dropped_bytes,
                line.overrun_bytes
            );
        }
    }
    Ok(())
}

/// One line on standard output, at once (tests wait for it).
fn say(line: &str) {
    let mut stdout = std::io::stdout().lock();
    let _ = writeln!(stdout, "{line}");
    let _ = stdout.flush();
}

/// The reader thread: reads `port` no faster than a line at `baud` carries bytes (a
/// speed that changes when the gateway restarts at another one), and hands what it
/// read, with the time, to the engine.
fn read_at_line_speed(
    mut port: Box<dyn SerialPort>,
    baud: &AtomicU32,
    stop: &AtomicBool,
    arrivals: &Sender<Result<(Instant, Vec<u8>), String>>,
) {
    let mut line = LineIntake::new(baud.load(Ordering::Acquire));
    let mut buffer = [0u8; 1024];
    while !stop.load(Ordering::Acquire) {
        line.set_baud(baud.load(Ordering::Acquire));
        let now = Instant::now();
        let room = line.room(now, buffer.len());
        if room == 0 {
            let wait = line
                .until_room(now)
                .clamp(Duration::from_micros(100), Duration::from_millis(50));
            std::thread::sleep(wait);
            continue;
        }
        let result = match port.read(&mut buffer[..room]) {
            Ok(0) => continue,
            Ok(n) => {
                let at = Instant::now();
                line.accept(at, n);
                Ok((at, buffer[..n].to_vec()))
            }
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => continue,
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(err) => Err(format!("read failed: {err}")),
        };
        let failed = result.is_err();
        if arrivals.send(result).is_err() || failed {
            return;
        }
    }
}

/// Writes `bytes`; what the device cannot take within its timeout (the host is not
/// reading) is dropped. Returns the number of bytes dropped.
///
/// # Errors
/// The port failed.
fn write_or_drop(port: &mut dyn SerialPort, bytes: &[u8]) -> Result<usize, String> {
    let mut rest = bytes;
    while !rest.is_empty() {
        match port.write(rest) {
            Ok(0) => break,
            Ok(n) => rest = &rest[n..],
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => break,
            Err(err) => return Err(format!("write failed: {err}")),
        }
    }
    Ok(rest.len())
}
