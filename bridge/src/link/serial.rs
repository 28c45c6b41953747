//! Serial-port links through the `serialport` crate: 8 data bits, no parity, 1 stop bit,
//! no flow control (PROTOCOL §1.2).
//!
//! One supervisor thread per port opens it (at the line's live speed), runs the writer
//! (which greets the gateway and marks the link up once it answers), and after a loss
//! reports it, waits (backoff) and opens it again. A reader thread feeds the bytes it
//! reads to the greeting watch and the feedback decoder and broadcasts every frame. The ports are blocking, so these are
//! plain threads rather than async tasks.

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use floatball_shared::api::LinkState;
use floatball_shared::ascii::GreetingWatch;
use floatball_shared::feedback::FrameDecoder;
use serialport::SerialPort;

use super::{Backoff, Input, LineWrite, Shared, run_writer};

/// How long a read waits for bytes before checking whether to stop.
const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// A connection that lasted this long resets the backoff.
const STABLE_AFTER: Duration = Duration::from_secs(10);

/// Starts the supervisor thread of a serial link.
pub(super) fn spawn(shared: Arc<Shared>, inbox: Receiver<Input>) {
    let name = format!("link-{}", shared.index);
    let started = std::thread::Builder::new()
        .name(name)
        .spawn(move || supervise(&shared, &inbox));
    if let Err(err) = started {
        tracing::error!("cannot start a thread for a serial link: {err}");
    }
}

/// Opens a serial port as the gateway expects it.
///
/// # Errors
/// The port's refusal, with the port's name in the message.
pub fn open_port(port: &str, baud: u32) -> Result<Box<dyn SerialPort>, String> {
    serialport::new(port, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .map_err(|err| format!("cannot open {port}: {err}"))
}

/// The supervisor thread is also the link's writer: it owns the queues.
fn supervise(shared: &Arc<Shared>, inbox: &Receiver<Input>) {
    shared.register_writer();
    let port_name = shared.config.port.clone();
    let mut backoff = Backoff::new();
    while !shared.is_closed() {
        shared.set_state(LinkState::Connecting, None);
        let baud = shared.baud();
        let opened = open_port(&port_name, baud).and_then(|port| {
            let reader = port
                .try_clone()
                .map_err(|err| format!("cannot read from {port_name}: {err}"))?;
            Ok((port, reader))
        });
        let (port, reader) = match opened {
            Ok(pair) => pair,
            Err(reason) => {
                tracing::warn!("gateway {port_name}: {reason}; retrying");
                shared.set_state(LinkState::Down, Some(reason));
                shared.sleep(inbox, backoff.next_delay());
                continue;
            }
        };
        tracing::info!("gateway {port_name}: opened at {baud} baud; greeting the gateway");
        shared.drop_inbox(inbox);
        let connected_at = Instant::now();
        let lost = Arc::new(AtomicBool::new(false));
        let reader_thread = {
            let shared = Arc::clone(shared);
            let lost = Arc::clone(&lost);
            std::thread::Builder::new()
                .name(format!("link-{}-read", shared.index))
                .spawn(move || read_loop(&shared, reader, &lost))
        };
        let reason = match reader_thread {
            Ok(reader_thread) => {
                let mut line = SerialLine {
                    port,
                    shared: Arc::clone(shared),
                    lost: Arc::clone(&lost),
                };
                let reason = run_writer(shared, inbox, &mut line, &lost);
                lost.store(true, Ordering::Release);
                let read_reason = reader_thread.join().ok().flatten();
                read_reason.unwrap_or(reason)
            }
            Err(err) => format!("cannot start the reader thread: {err}"),
        };
        if shared.is_closed() {
            break;
        }
        tracing::warn!("gateway {port_name}: link lost ({reason}); retrying");
        shared.set_state(LinkState::Down, Some(reason));
        if connected_at.elapsed() >= STABLE_AFTER {
            backoff.reset();
        }
        shared.sleep(inbox, backoff.next_delay());
    }
    shared.set_state(LinkState::Down, Some("shut down".to_owned()));
}

/// Reads until the link closes or the port fails; returns the failure, if any.
fn read_loop(shared: &Shared, mut port: Box<dyn SerialPort>, lost: &AtomicBool) -> Option<String> {
    let mut decoder = FrameDecoder::new();
    let mut watch = GreetingWatch::new();
    let mut buffer = [0u8; 256];
    while !shared.is_closed() && !lost.load(Ordering::Acquire) {
        match port.read(&mut buffer) {
            Ok(0) => {}
            Ok(n) => shared.heard(&mut watch, &mut decoder, &buffer[..n]),
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
            Err(err) => {
                lost.store(true, Ordering::Release);
                shared.wake();
                return Some(format!("read failed: {err}"));
            }
        }
    }
    None
}

/// The writer's end of a serial port.
struct SerialLine {
    port: Box<dyn SerialPort>,
    shared: Arc<Shared>,
    lost: Arc<AtomicBool>,
}

impl LineWrite for SerialLine {
    /// Writes the whole instruction. A port that takes nothing for a while (its buffer
    /// full: a gateway or adapter that stopped reading) is not an error by itself: the
    /// write goes on until the link closes or is lost, and the link counts as stalled
    /// meanwhile (its bytes stay queued; the playback watchdog acts on it).
    fn write_instruction(&mut self, instruction: &[u8]) -> std::io::Result<()> {
        let mut rest = instruction;
        while !rest.is_empty() {
            match self.port.write(rest) {
                Ok(0) => std::thread::sleep(std::time::Duration::from_millis(1)),
                Ok(n) => rest = &rest[n..],
                Err(err)
                    if matches!(
                        err.kind(),
                        std::io::ErrorKind::TimedOut
                            | std::io::ErrorKind::WouldBlock
                            | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(err) => return Err(err),
            }
            if self.shared.is_closed() || self.lost.load(Ordering::Acquire) {
                return Err(std::io::Error::other("the line was lost mid-instruction"));
            }
        }
        Ok(())
    }

    /// Sets the port's speed (the reader's clone shares the device's settings).
    fn set_baud(&mut self, baud: u32) -> std::io::Result<()> {
        self.port.set_baud_rate(baud).map_err(std::io::Error::other)
    }

    /// A real gateway is power-cycled by the installer.
    fn restart_gateway(&mut self) -> bool {
        false
    }
}
