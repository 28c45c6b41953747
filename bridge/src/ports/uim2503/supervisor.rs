//! The supervisor of a link whose line is opened, lost and opened again: a serial port
//! ([`super::serial`]) or a serial device server on the network ([`super::net`]).
//!
//! One thread per link opens the line (at its live speed) through a [`Connector`] and
//! hands it to the connector's [`Connector::serve`], which returns when the line is
//! lost: a serial port gets a reader thread and this thread as its writer
//! ([`serve_with_reader`]); a network line is handed to the one network driver
//! ([`super::driver`]) and this thread waits for it back. When the line is lost the
//! supervisor reports why (`Down` with the reason), drops everything queued, waits
//! ([`Backoff`]) and opens it again; a connection that lasted [`STABLE_AFTER`] resets
//! the backoff. Opening is blocking, so these are plain threads rather than async tasks.

use std::io::Write;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use floatball_shared::api::LinkState;
use floatball_shared::uim2503::ascii::GreetingWatch;
use floatball_shared::uim2503::feedback::FrameDecoder;

use super::writer::{LineWrite, run_writer};
use super::{Backoff, Input, Shared};

/// A connection that lasted this long resets the backoff.
pub(super) const STABLE_AFTER: Duration = Duration::from_secs(10);

/// The reader's end of an open line with a reader thread of its own.
pub(super) trait LineRead {
    /// Reads what came in into `buffer`: `Ok(0)` when nothing came within the line's
    /// read timeout, `Err(reason)` when the line is lost.
    fn read_some(&mut self, buffer: &mut [u8]) -> Result<usize, String>;
}

/// How a link's line is opened and served.
pub(super) trait Connector {
    /// An open line.
    type Connection;

    /// Opens the line at `baud`. `lost` is the connection's flag: set when either end
    /// fails, and watched by both. `Err` is the reason, naming the port.
    fn connect(
        &mut self,
        shared: &Arc<Shared>,
        lost: &Arc<AtomicBool>,
        baud: u32,
    ) -> Result<Self::Connection, String>;

    /// Writes to and reads from the open line until it is lost or the link closes;
    /// returns the inbox (for the next connection) and why the line ended.
    fn serve(
        &mut self,
        shared: &Arc<Shared>,
        inbox: Receiver<Input>,
        connection: Self::Connection,
        lost: &Arc<AtomicBool>,
    ) -> (Receiver<Input>, String);
}

/// Starts the supervisor thread of a link.
pub(super) fn spawn<C>(shared: Arc<Shared>, inbox: Receiver<Input>, connector: C)
where
    C: Connector + Send + 'static,
{
    let name = format!("link-{}", shared.index);
    let started = std::thread::Builder::new()
        .name(name)
        .spawn(move || supervise(&shared, inbox, connector));
    if let Err(err) = started {
        tracing::error!("cannot start a thread for a link: {err}");
    }
}

/// The supervisor thread owns the inbox between connections.
fn supervise<C: Connector>(shared: &Arc<Shared>, mut inbox: Receiver<Input>, mut connector: C) {
    shared.register_writer();
    let port_name = shared.config.port.clone();
    let mut backoff = Backoff::new();
    while !shared.is_closed() {
        shared.set_state(LinkState::Connecting, None);
        let baud = shared.baud();
        let lost = Arc::new(AtomicBool::new(false));
        let connection = match connector.connect(shared, &lost, baud) {
            Ok(connection) => connection,
            Err(reason) => {
                tracing::warn!("gateway {port_name}: {reason}; retrying");
                shared.set_state(LinkState::Down, Some(reason));
                shared.sleep(&inbox, backoff.next_delay());
                continue;
            }
        };
        tracing::info!("gateway {port_name}: opened at {baud} baud; greeting the gateway");
        shared.drop_inbox(&inbox);
        let connected_at = Instant::now();
        let (returned, reason) = connector.serve(shared, inbox, connection, &lost);
        inbox = returned;
        if shared.is_closed() {
            break;
        }
        tracing::warn!("gateway {port_name}: link lost ({reason}); retrying");
        shared.set_state(LinkState::Down, Some(reason));
        if connected_at.elapsed() >= STABLE_AFTER {
            backoff.reset();
        }
        shared.sleep(&inbox, backoff.next_delay());
    }
    shared.set_state(LinkState::Down, Some("shut down".to_owned()));
}

/// Serves a line with a reader thread of its own (a serial port): starts the reader,
/// runs the writer on this thread, and joins the reader when the line ends.
pub(super) fn serve_with_reader<L: LineWrite>(
    shared: &Arc<Shared>,
    inbox: &Receiver<Input>,
    mut line: L,
    reader: impl LineRead + Send + 'static,
    lost: &Arc<AtomicBool>,
) -> String {
    let reader_thread = {
        let shared = Arc::clone(shared);
        let lost = Arc::clone(lost);
        std::thread::Builder::new()
            .name(format!("link-{}-read", shared.index))
            .spawn(move || read_loop(&shared, reader, &lost))
    };
    match reader_thread {
        Ok(reader_thread) => {
            let reason = run_writer(shared, inbox, &mut line, lost);
            lost.store(true, Ordering::Release);
            let read_reason = reader_thread.join().ok().flatten();
            drop(line);
            read_reason.unwrap_or(reason)
        }
        Err(err) => format!("cannot start the reader thread: {err}"),
    }
}

/// Reads until the link closes or the line fails; returns the failure, if any.
fn read_loop(shared: &Shared, mut reader: impl LineRead, lost: &AtomicBool) -> Option<String> {
    let mut decoder = FrameDecoder::new();
    let mut watch = GreetingWatch::new();
    let mut buffer = [0u8; 256];
    while !shared.is_closed() && !lost.load(Ordering::Acquire) {
        match reader.read_some(&mut buffer) {
            Ok(0) => {}
            Ok(n) => shared.heard(&mut watch, &mut decoder, &buffer[..n]),
            Err(reason) => {
                lost.store(true, Ordering::Release);
                shared.wake();
                return Some(reason);
            }
        }
    }
    None
}

/// Writes all of `bytes` to `port`. A port that takes nothing for a while (its buffer
/// full: a gateway or adapter that stopped reading) is not an error by itself: the
/// write goes on until the link closes or is lost, and the link counts as stalled
/// meanwhile (its bytes stay queued; the playback watchdog acts on it).
pub(super) fn write_watching(
    port: &mut (impl Write + ?Sized),
    bytes: &[u8],
    shared: &Shared,
    lost: &AtomicBool,
) -> std::io::Result<()> {
    let mut rest = bytes;
    while !rest.is_empty() {
        match port.write(rest) {
            Ok(0) => std::thread::sleep(Duration::from_millis(1)),
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
        if shared.is_closed() || lost.load(Ordering::Acquire) {
            return Err(std::io::Error::other("the line was lost mid-instruction"));
        }
    }
    Ok(())
}

/// A `port` that is none ([`floatball_shared::plan::port::PortError`]): the link stays
/// down and says why (the configuration check refuses such a port before a link is
/// opened).
pub(super) struct Unusable(pub(super) String);

impl Connector for Unusable {
    type Connection = ();

    fn connect(
        &mut self,
        _shared: &Arc<Shared>,
        _lost: &Arc<AtomicBool>,
        _baud: u32,
    ) -> Result<(), String> {
        Err(self.0.clone())
    }

    fn serve(
        &mut self,
        _shared: &Arc<Shared>,
        inbox: Receiver<Input>,
        (): (),
        _lost: &Arc<AtomicBool>,
    ) -> (Receiver<Input>, String) {
        (inbox, self.0.clone())
    }
}
