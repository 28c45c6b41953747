//! `floatball simulate --kind uim2503 --listen ADDR [--gateways N]`: simulated UIM2503
//! gateways answering on TCP, each as if behind a serial device server in raw TCP mode
//! — for quick tests of `tcp://` gateways and for the scale benchmark (100 of them in
//! one process).
//!
//! Gateway `i` (from 0) listens on `ADDR`'s port + `i`; with port 0 each listens on a
//! free port of the system's choosing. Each serves one client at a time: a new
//! connection replaces the old one (which is closed), as a device server's port does.
//! The gateway itself does not notice connections come and go: its units keep their
//! state, exactly as a gateway behind a device server does.
//!
//! Each gateway is the same [`SimEngine`] behind the same line model as on a pty
//! ([`super::run`]): the socket is read no faster than the line carries bytes (baud / 10
//! bytes/s, with the receive FIFO's slack), so what a client sends faster waits in the
//! socket's buffers and its writes block, as they would at a device server feeding a
//! real line; the answers are written as they cross the line. Answers nobody can take
//! (no client, or one that does not read) are lost, as on a real line. `--units`,
//! `--baud`, `--factory-fresh`, `--counts-per-mm` apply to every gateway; gateway `i`'s
//! units take their serial numbers from seed `--seed` + `i`, so no two gateways have
//! units with the same serial numbers. SIGHUP power-cycles every gateway (a line speed
//! stored by `BDR=x;` takes effect; there is no device to switch, so both ends of the
//! simulated line follow the gateway).
//!
//! One thread a gateway (it reads, steps its engine and writes), plus one a gateway
//! blocked in `accept`: a gateway's thread wakes when bytes arrive or its engine has
//! something to do, so the arrival times are those of the socket, not of a poll.
//! Measured (release build, two cores shared with the load): 100 gateways of 100 units,
//! each client writing one instruction at a time at 115 200 baud for 10 s, take every
//! byte at line rate with about 65 % of one core (a third of it the engines' next-event
//! search over their units, a fifth the kernel's thread switches); a start written to
//! all 100 sockets over 1.8 ms is printed as arriving 0.06 to 1.9 ms after the first
//! write.
//!
//! # Standard output
//!
//! Every line is one of these (tests and the scale benchmark parse them; `{i}` is the
//! gateway's index from 0, `{socket}` its listening address as `ip:port`):
//!
//! - once each gateway listens, before any client can be served:
//!   `floatball simulating gateway {i} with {units} units at {baud} baud on tcp {socket}`
//!   (the socket is the last word);
//! - **per synchronised start `*0;BG;` received**, at once:
//!   `gateway {i}: start received at {unix_ns} ns, read at {read_ns} ns` — wall-clock
//!   times ([`SystemTime`], nanoseconds since the Unix epoch, decimal): `{unix_ns}` when
//!   the segment holding the start's last byte arrived at the gateway's socket (the
//!   kernel's receive timestamp, `SO_TIMESTAMPNS`; the read time where the system gives
//!   none), `{read_ns}` when this process took it from the socket onto the simulated
//!   line (later by its own thread's scheduling);
//! - `gateway {i}: stored BDR={baud}; it takes effect at its restart (SIGHUP)`;
//! - `gateway {i}: restarted; the line runs at {baud} baud`.

use std::io::{ErrorKind, IoSliceMut, Write as _};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::os::fd::AsRawFd;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use floatball_shared::uim2503::sim::GatewayConfig;
use nix::sys::socket::{ControlMessageOwned, MsgFlags, recvmsg, setsockopt, sockopt};
use nix::sys::time::TimeSpec;

use super::{LineIntake, say, say_stored_baud};
use crate::ports::uim2503::sim::SimEngine;

/// The synchronised start every gateway receives at once.
pub const START: &[u8] = b"*0;BG;";

/// The longest a gateway's thread waits without looking at the stop flag and the power
/// cycles.
const MAX_WAIT: Duration = Duration::from_millis(50);

/// The shortest read timeout (a zero one would mean "none").
const MIN_WAIT: Duration = Duration::from_micros(100);

/// How long an answer may wait for a client that does not read before it is dropped.
const WRITE_TIMEOUT: Duration = Duration::from_millis(20);

/// What to simulate, and where.
#[derive(Debug, Clone)]
pub struct ListenOptions {
    /// The first gateway's socket; gateway `i` listens on its port + `i` (port 0: each
    /// on a free port).
    pub listen: SocketAddr,
    /// How many gateways.
    pub gateways: u16,
    /// Their line speed.
    pub baud: u32,
    /// The units behind each gateway (gateway `i` seeds its serial numbers with
    /// `seed` + `i`).
    pub gateway: GatewayConfig,
}

/// The gateways' sockets, bound and listening, not yet served ([`Bound::serve`]).
#[derive(Debug)]
pub struct Bound {
    listeners: Vec<TcpListener>,
    options: ListenOptions,
}

/// Binds every gateway's socket.
///
/// # Errors
/// A port is taken or out of range, or the units' configuration is refused.
pub fn bind(options: ListenOptions) -> Result<Bound, String> {
    let first = options.listen.port();
    if first != 0 && u32::from(first) + u32::from(options.gateways) - 1 > u32::from(u16::MAX) {
        return Err(format!(
            "{} gateways from port {first} would go past port {}",
            options.gateways,
            u16::MAX
        ));
    }
    // The configuration is checked once, before anything listens.
    SimEngine::new(options.gateway.clone(), options.baud)?;
    let mut listeners = Vec::with_capacity(usize::from(options.gateways));
    for index in 0..options.gateways {
        let mut socket = options.listen;
        if first != 0 {
            socket.set_port(first + index);
        }
        let listener =
            TcpListener::bind(socket).map_err(|err| format!("cannot listen on {socket}: {err}"))?;
        listeners.push(listener);
    }
    Ok(Bound { listeners, options })
}

impl Bound {
    /// Each gateway's listening socket, in order.
    ///
    /// # Errors
    /// The system cannot say which port a socket got.
    pub fn sockets(&self) -> Result<Vec<SocketAddr>, String> {
        self.listeners
            .iter()
            .map(|listener| {
                listener
                    .local_addr()
                    .map_err(|err| format!("cannot read a listening address: {err}"))
            })
            .collect()
    }

    /// Serves every gateway on its own thread until `stop` is set; each time
    /// `power_cycles` changes, every gateway restarts.
    ///
    /// # Errors
    /// A thread cannot be started.
    pub fn serve(
        self,
        stop: &Arc<AtomicBool>,
        power_cycles: &Arc<AtomicU64>,
    ) -> Result<Vec<JoinHandle<()>>, String> {
        let mut threads = Vec::with_capacity(self.listeners.len());
        for (index, listener) in self.listeners.into_iter().enumerate() {
            let mut config = self.options.gateway.clone();
            config.seed = config
                .seed
                .wrapping_add(u64::try_from(index).unwrap_or(u64::MAX));
            let engine = SimEngine::new(config, self.options.baud)?;
            let incoming = Arc::new(Incoming::default());
            let mut gateway = Gateway {
                index,
                engine,
                intake: LineIntake::new(self.options.baud),
                client: None,
                incoming: Arc::clone(&incoming),
                start_matched: 0,
                stored: None,
                power_seen: power_cycles.load(Ordering::Acquire),
                read_timeout: None,
            };
            let stop_gateway = Arc::clone(stop);
            let power_cycles = Arc::clone(power_cycles);
            let thread = std::thread::Builder::new()
                .name(format!("simulate-gw{index}"))
                .spawn(move || gateway.run(&stop_gateway, &power_cycles))
                .map_err(|err| format!("cannot start gateway {index}'s thread: {err}"))?;
            let gateway_thread = thread.thread().clone();
            std::thread::Builder::new()
                .name(format!("simulate-gw{index}-accept"))
                .spawn(move || accept(index, &listener, &incoming, &gateway_thread))
                .map_err(|err| format!("cannot start gateway {index}'s acceptor: {err}"))?;
            threads.push(thread);
        }
        Ok(threads)
    }
}

/// A connection waiting to be taken by its gateway's thread.
#[derive(Debug, Default)]
struct Incoming {
    fresh: AtomicBool,
    stream: Mutex<Option<TcpStream>>,
}

/// The acceptor: hands each new connection to the gateway's thread (which replaces its
/// client with it) and wakes that thread.
fn accept(
    index: usize,
    listener: &TcpListener,
    incoming: &Incoming,
    gateway: &std::thread::Thread,
) {
    loop {
        match listener.accept() {
            Ok((stream, peer)) => {
                tracing::info!("simulated gateway {index}: {peer} connected");
                if let Ok(mut slot) = incoming.stream.lock() {
                    *slot = Some(stream);
                }
                incoming.fresh.store(true, Ordering::Release);
                gateway.unpark();
            }
            Err(err) => {
                tracing::warn!("simulated gateway {index} cannot accept a connection: {err}");
                std::thread::sleep(MAX_WAIT);
            }
        }
    }
}

/// One simulated gateway on its socket.
struct Gateway {
    index: usize,
    engine: SimEngine,
    /// The receiving half of the line: how many bytes may be taken from the socket.
    intake: LineIntake,
    client: Option<TcpStream>,
    incoming: Arc<Incoming>,
    /// How many bytes of [`START`] the last bytes received match.
    start_matched: usize,
    /// The line speed the gateway stored, last said.
    stored: Option<u32>,
    /// The power cycles seen.
    power_seen: u64,
    /// The client's read timeout as last set.
    read_timeout: Option<Duration>,
}

impl Gateway {
    fn run(&mut self, stop: &AtomicBool, power_cycles: &AtomicU64) {
        let mut buffer = [0u8; 1024];
        let mut answers = Vec::new();
        while !stop.load(Ordering::Acquire) {
            let cycles = power_cycles.load(Ordering::Acquire);
            if cycles != self.power_seen {
                self.power_seen = cycles;
                self.restart();
            }
            if self.incoming.fresh.swap(false, Ordering::AcqRel) {
                let stream = self
                    .incoming
                    .stream
                    .lock()
                    .ok()
                    .and_then(|mut slot| slot.take());
                if let Some(stream) = stream {
                    self.connect(stream);
                }
            }
            let now = Instant::now();
            let wait = self
                .engine
                .next_wakeup(now)
                .saturating_duration_since(now)
                .min(MAX_WAIT);
            self.receive(&mut buffer, now, wait);
            answers.clear();
            self.engine.step(Instant::now(), &mut answers);
            self.answer(&answers);
        }
    }

    /// Takes what the line carries from the client, waiting up to `wait` for it.
    fn receive(&mut self, buffer: &mut [u8], now: Instant, wait: Duration) {
        let Some(client) = self.client.as_mut() else {
            std::thread::park_timeout(wait);
            return;
        };
        let room = self.intake.room(now, buffer.len());
        if room == 0 {
            let until_room = self.intake.until_room(now);
            std::thread::sleep(until_room.clamp(MIN_WAIT, wait.max(MIN_WAIT)));
            return;
        }
        let timeout = Some(wait.max(MIN_WAIT));
        if self.read_timeout != timeout {
            if let Err(err) = client.set_read_timeout(timeout) {
                self.drop_client(&format!("cannot set its read timeout: {err}"));
                return;
            }
            self.read_timeout = timeout;
        }
        match read_stamped(client, &mut buffer[..room]) {
            Ok((0, _)) => self.drop_client("it closed the connection"),
            Ok((n, arrived)) => {
                let at = Instant::now();
                let wall = SystemTime::now();
                self.intake.accept(at, n);
                let bytes = &buffer[..n];
                self.engine.receive(at, bytes);
                self.look_for_starts(bytes, arrived.unwrap_or(wall), wall);
                say_stored_baud(
                    &self.engine,
                    &mut self.stored,
                    &format!("gateway {}: ", self.index),
                );
            }
            Err(err)
                if matches!(
                    err.kind(),
                    ErrorKind::WouldBlock | ErrorKind::TimedOut | ErrorKind::Interrupted
                ) => {}
            Err(err) => self.drop_client(&format!("reading failed: {err}")),
        }
    }

    /// Writes the answers that crossed the line to the client, if any; what it does not
    /// take in time is lost.
    fn answer(&mut self, answers: &[u8]) {
        if answers.is_empty() {
            return;
        }
        let Some(client) = self.client.as_mut() else {
            return;
        };
        let mut rest = answers;
        while !rest.is_empty() {
            match client.write(rest) {
                Ok(0) => break,
                Ok(n) => rest = &rest[n..],
                Err(err) if err.kind() == ErrorKind::Interrupted => {}
                Err(err) if matches!(err.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    tracing::warn!(
                        "simulated gateway {}: the client is not reading; {} answer bytes lost",
                        self.index,
                        rest.len()
                    );
                    break;
                }
                Err(err) => {
                    self.drop_client(&format!("writing failed: {err}"));
                    break;
                }
            }
        }
    }

    /// A new client replaces the old one.
    fn connect(&mut self, stream: TcpStream) {
        if let Err(err) = stream
            .set_nodelay(true)
            .and_then(|()| stream.set_write_timeout(Some(WRITE_TIMEOUT)))
        {
            tracing::warn!("simulated gateway {}: {err}", self.index);
        }
        if let Err(err) = setsockopt(stream.as_raw_fd(), sockopt::ReceiveTimestampns, &true) {
            tracing::warn!(
                "simulated gateway {}: no receive timestamps ({err}); a start's arrival \
                 is the time it is read",
                self.index
            );
        }
        if self.client.replace(stream).is_some() {
            tracing::info!(
                "simulated gateway {}: a new client replaced the old one",
                self.index
            );
        }
        self.read_timeout = None;
    }

    fn drop_client(&mut self, reason: &str) {
        tracing::info!("simulated gateway {}: client gone: {reason}", self.index);
        self.client = None;
    }

    /// Says, for every synchronised start completed by `bytes`, when it arrived at the
    /// socket (`arrived`) and when it was read from it (`read`).
    fn look_for_starts(&mut self, bytes: &[u8], arrived: SystemTime, read: SystemTime) {
        let unix_ns = |at: SystemTime| {
            at.duration_since(SystemTime::UNIX_EPOCH)
                .map_or(0, |since| since.as_nanos())
        };
        for &byte in bytes {
            self.start_matched = next_match(self.start_matched, byte);
            if self.start_matched == START.len() {
                self.start_matched = 0;
                say(&format!(
                    "gateway {}: start received at {} ns, read at {} ns",
                    self.index,
                    unix_ns(arrived),
                    unix_ns(read)
                ));
            }
        }
    }

    /// The power cycle: a stored line speed takes effect on both ends of the line.
    fn restart(&mut self) {
        self.engine.restart(Instant::now());
        let baud = self.engine.baud();
        if baud != self.intake.baud {
            self.engine.set_host_baud(baud);
            self.intake.set_baud(baud);
        }
        say(&format!(
            "gateway {}: restarted; the line runs at {baud} baud",
            self.index
        ));
    }
}

/// Reads from `client` into `buffer`: how many bytes, and when the last of them
/// arrived at the socket (the kernel's receive timestamp, if it gave one).
fn read_stamped(
    client: &TcpStream,
    buffer: &mut [u8],
) -> std::io::Result<(usize, Option<SystemTime>)> {
    let mut iov = [IoSliceMut::new(buffer)];
    let mut space = nix::cmsg_space!(TimeSpec);
    let message = recvmsg::<()>(
        client.as_raw_fd(),
        &mut iov,
        Some(&mut space),
        MsgFlags::empty(),
    )
    .map_err(|errno| std::io::Error::from_raw_os_error(errno as i32))?;
    let arrived = message.cmsgs().find_map(|cmsg| match cmsg {
        ControlMessageOwned::ScmTimestampns(at) => {
            let since = Duration::new(
                u64::try_from(at.tv_sec()).ok()?,
                u32::try_from(at.tv_nsec()).ok()?,
            );
            SystemTime::UNIX_EPOCH.checked_add(since)
        }
        _ => None,
    });
    Ok((message.bytes, arrived))
}

/// How many bytes of [`START`] match after `byte`, when `matched` did before it. No
/// proper prefix of [`START`] is also its suffix, so a mismatch only ever restarts the
/// match.
fn next_match(matched: usize, byte: u8) -> usize {
    if START.get(matched) == Some(&byte) {
        matched + 1
    } else if START.first() == Some(&byte) {
        1
    } else {
        0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn starts_in(chunks: &[&[u8]]) -> usize {
        let mut matched = 0;
        let mut found = 0;
        for chunk in chunks {
            for &byte in *chunk {
                matched = next_match(matched, byte);
                if matched == START.len() {
                    matched = 0;
                    found += 1;
                }
            }
        }
        found
    }

    #[test]
    fn a_start_is_found_across_reads_and_among_other_instructions() {
        assert_eq!(starts_in(&[b"*0;BG;"]), 1);
        assert_eq!(starts_in(&[b"*0;MO1;*0", b";B", b"G;*1;PA5;"]), 1);
        assert_eq!(starts_in(&[b"**0;BG;*0;BG;"]), 2);
        // Another station's begin, or a near miss, is not the synchronised start.
        assert_eq!(starts_in(&[b"*10;BG;*1;BG;*0;BG=1;*0;B*0;BG"]), 0);
    }
}
