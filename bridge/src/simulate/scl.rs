//! `floatball simulate --kind scl`: simulated MOONS' drives ([`Bus`] of [`Drive`]s, the
//! sans-IO twin in `floatball_shared::scl::twin`) on a real serial device — an RS-485
//! line, every drive addressed by one of [`Address::CHARACTERS`] — or on loopback / LAN
//! UDP as eSCL, one socket a drive on consecutive ports.
//!
//! Either way the drives share one [`Bus`], so the start wire (one drive's output wired
//! to an input of every drive, [`StartWire`]) reaches them all at the instant the
//! output changes. Time is µs since the drives started.
//!
//! On the serial device the line is paced at its baud rate (10 bit times a byte,
//! [`Line`]): a line's bytes are handed to the drives when its last byte would have
//! arrived, and the device is read no faster; answers are written no faster than the
//! line carries them. Over UDP every datagram is answered to its sender, one datagram
//! an answer line.
//!
//! [`SimDrives`] are the bridge's own simulated installation (`kind = "scl"`,
//! `port = "sim"`): every such entry's drives on one bus and one start wire, on
//! loopback UDP, each drive answering on a thread of its own ([`UdpDrives`]), never
//! behind the bridge's async work.

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use floatball_shared::api::SimDrive;
use floatball_shared::line::Line;
use floatball_shared::scl::twin::{Bus, Drive, DriveConfig, StartWire, status};
use floatball_shared::scl::{Address, IoPoint, Segment};

use crate::ports::uim2503::serial::open_port;

/// The most drives on one line: one per address character.
pub const MAX_DRIVES: usize = Address::CHARACTERS.len();
/// The largest datagram a drive takes.
const MAX_DATAGRAM: usize = 2048;

/// The default `--start-wire`: the first drive's output 2 drives input 3 of every
/// drive.
pub const DEFAULT_START_WIRE: &str = "0:2:3";

/// Reads `--start-wire`: `drive:output:input`, e.g. `1:2:3` — drive '1''s output Y2
/// drives input X3 of every drive.
///
/// # Errors
/// Not three parts, an address that is not one, or a point that is not one digit.
pub fn parse_start_wire(text: &str) -> Result<StartWire, String> {
    let parts: Vec<&str> = text.split(':').collect();
    let [from, output, input] = parts[..] else {
        return Err(format!(
            "{text:?}: a start wire is drive:output:input, e.g. 1:2:3"
        ));
    };
    let mut chars = from.chars();
    let from = match (chars.next(), chars.next()) {
        (Some(c), None) => Address::new(c),
        _ => None,
    }
    .ok_or_else(|| {
        format!(
            "{from:?} is not a drive address (one of {})",
            Address::CHARACTERS
        )
    })?;
    let point = |text: &str| {
        text.parse::<u8>()
            .ok()
            .and_then(IoPoint::new)
            .ok_or_else(|| format!("{text:?} is not an I/O point (0 to 9)"))
    };
    Ok(StartWire {
        from,
        output: point(output)?,
        input: point(input)?,
    })
}

/// `count` drives, addressed `0`, `1`, … on a line (`addressed`), or without
/// addresses (eSCL), with `wire`.
///
/// # Errors
/// No drive, or more than [`MAX_DRIVES`].
pub fn bus(count: usize, addressed: bool, wire: StartWire) -> Result<Bus, String> {
    if count == 0 || count > MAX_DRIVES {
        return Err(format!(
            "{count} drives: a line has 1 to {MAX_DRIVES} (one a address character)"
        ));
    }
    let drives = Address::CHARACTERS
        .chars()
        .take(count)
        .map(|c| {
            Drive::new(DriveConfig {
                address: if addressed { Address::new(c) } else { None },
                ..DriveConfig::default()
            })
        })
        .collect();
    let mut bus = Bus::new(drives);
    bus.wire(wire);
    Ok(bus)
}

/// One line a drive: its name (address character) and its position, for the operator
/// and the tests when the simulator stops.
#[must_use]
pub fn positions(bus: &Bus) -> Vec<String> {
    bus.drives()
        .iter()
        .zip(Address::CHARACTERS.chars())
        .map(|(drive, c)| format!("drive {c} position {} counts", drive.position_integer()))
        .collect()
}

fn micros(epoch: Instant, at: Instant) -> u64 {
    u64::try_from(at.saturating_duration_since(epoch).as_micros()).unwrap_or(u64::MAX)
}

/// The drives on `port` at `baud` until `stop` is set or the port fails; `ready` is
/// called once the port is open. Returns the bus as it ends (run to the last moment).
///
/// # Errors
/// The port cannot be opened, or reading or writing it fails.
pub fn run_serial(
    port_name: &str,
    baud: u32,
    mut bus: Bus,
    stop: &AtomicBool,
    ready: impl FnOnce(),
) -> Result<Bus, String> {
    let mut port = open_port(port_name, baud)?;
    let line = Line::new(baud);
    let epoch = Instant::now();
    let mut line_free = epoch;
    let mut buffer = [0u8; 64];
    ready();
    while !stop.load(Ordering::Acquire) {
        match port.read(&mut buffer) {
            Ok(0) => {}
            Ok(n) => {
                // The last byte of these arrives `n` byte times after the line is free.
                let arrived =
                    Instant::now().max(line_free) + Duration::from_micros(line.time_us(n));
                std::thread::sleep(arrived.saturating_duration_since(Instant::now()));
                line_free = arrived;
                let answers =
                    bus.receive(buffer.get(..n).unwrap_or_default(), micros(epoch, arrived));
                if !answers.is_empty() {
                    write_all(&mut *port, &answers)?;
                    // The answer holds the line (RS-485 is half duplex).
                    line_free = Instant::now().max(line_free)
                        + Duration::from_micros(line.time_us(answers.len()));
                    std::thread::sleep(line_free.saturating_duration_since(Instant::now()));
                }
            }
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                ) => {}
            Err(err) => return Err(format!("read failed: {err}")),
        }
        bus.advance(micros(epoch, Instant::now()));
    }
    bus.advance(micros(epoch, Instant::now()));
    Ok(bus)
}

fn write_all(port: &mut dyn serialport::SerialPort, bytes: &[u8]) -> Result<(), String> {
    let mut rest = bytes;
    while !rest.is_empty() {
        match port.write(rest) {
            Ok(0) => break,
            Ok(n) => rest = rest.get(n..).unwrap_or_default(),
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
            // Nobody reads the line: the answer is lost, as on a real line.
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => break,
            Err(err) => return Err(format!("write failed: {err}")),
        }
    }
    Ok(())
}

/// The simulated drives of an installation's `port = "sim"` gateway entries: all on
/// one [`Bus`] — one start wire reaches every one of them, as the wire of a real
/// installation runs to every drive — each on its own loopback eSCL socket.
#[derive(Debug)]
pub struct SimDrives {
    drives: UdpDrives,
    /// Each simulated entry: its gateway index and its drives' places on the bus.
    entries: Vec<(usize, std::ops::Range<usize>)>,
}

impl SimDrives {
    /// `entries` (gateway index, drives) on one bus wired by `wire`, each drive
    /// `steps_per_rev` (`EG`), on loopback UDP; the drives' places on the bus follow
    /// the entries' order.
    ///
    /// # Errors
    /// No drive, or a socket that cannot be bound.
    pub fn spawn(
        entries: &[(usize, usize)],
        steps_per_rev: u32,
        wire: StartWire,
    ) -> Result<Self, String> {
        let mut places = Vec::with_capacity(entries.len());
        let mut count = 0;
        for &(gateway, drives) in entries {
            places.push((gateway, count..count + drives));
            count += drives;
        }
        if count == 0 {
            return Err("no simulated MOONS' drive to start".to_owned());
        }
        let config = DriveConfig {
            steps_per_rev,
            ..DriveConfig::default()
        };
        let mut bus = Bus::new((0..count).map(|_| Drive::new(config.clone())).collect());
        bus.wire(wire);
        let drives = UdpDrives::spawn(SocketAddr::from(([127, 0, 0, 1], 0)), bus)?;
        Ok(Self {
            drives,
            entries: places,
        })
    }

    /// The sockets of gateway `gateway`'s drives, in unit order (empty: not simulated).
    #[must_use]
    pub fn sockets(&self, gateway: usize) -> Vec<SocketAddr> {
        self.entries
            .iter()
            .find(|(index, _)| *index == gateway)
            .and_then(|(_, places)| self.drives.sockets().get(places.clone()))
            .map(<[SocketAddr]>::to_vec)
            .unwrap_or_default()
    }

    /// Every drive as it is now, in gateway and unit order.
    #[must_use]
    pub fn snapshots(&self) -> Vec<SimDrive> {
        self.drives.with_bus(|bus| {
            self.entries
                .iter()
                .flat_map(|(gateway, places)| {
                    places.clone().enumerate().filter_map(move |(unit, place)| {
                        let drive = bus.drives().get(place)?;
                        Some(SimDrive {
                            gateway: *gateway,
                            unit,
                            address: Address::CHARACTERS.chars().nth(unit).unwrap_or('?'),
                            position_counts: drive.position_counts(),
                            moving: drive.is_moving(),
                            executing: drive.is_executing(),
                            waiting_input: drive.status_code() & status::WAITING_INPUT != 0,
                            segments_stored: (Segment::MIN..=Segment::MAX)
                                .filter_map(Segment::new)
                                .filter(|&segment| drive.segment(segment).is_some())
                                .count(),
                            queue_lines: drive.queue().len(),
                            moves_ended: drive.move_ends().len(),
                            alarm_code: drive.alarm_code(),
                            motor_enabled: drive.is_enabled(),
                            flash_writes: drive.flash_writes_total(),
                        })
                    })
                })
                .collect()
        })
    }
}

/// How often a drive's thread looks whether it is to stop (its socket's read
/// timeout).
const STOP_POLL: Duration = Duration::from_millis(50);

/// Drives answering eSCL on UDP sockets until [`Self::stop`] (or until dropped).
///
/// Each drive answers on a thread of its own, not on the bridge's async runtime: a
/// real drive answers whatever the bridge is busy with, and the bridge's link gives
/// it [`crate::ports::scl::ANSWER_TIMEOUT`] — a simulated drive queued behind busy
/// tasks on the runtime's few workers could miss that window under load.
#[derive(Debug)]
pub struct UdpDrives {
    sockets: Vec<SocketAddr>,
    bus: Arc<Mutex<Bus>>,
    epoch: Instant,
    stop: Arc<AtomicBool>,
    threads: Vec<std::thread::JoinHandle<()>>,
}

impl UdpDrives {
    /// Binds one socket a drive of `bus` (drive `i` on `listen`'s port + `i`; port 0:
    /// each on a free port) and starts answering, each drive on its own thread.
    ///
    /// # Errors
    /// A port past 65535, or a socket or thread that cannot be had.
    pub fn spawn(listen: SocketAddr, bus: Bus) -> Result<Self, String> {
        let count = bus.drives().len();
        let bus = Arc::new(Mutex::new(bus));
        let epoch = Instant::now();
        let stop = Arc::new(AtomicBool::new(false));
        let mut sockets = Vec::with_capacity(count);
        let mut bound = Vec::with_capacity(count);
        for index in 0..count {
            let mut at = listen;
            if at.port() != 0 {
                let offset = u16::try_from(index).map_err(|_| "too many drives".to_owned())?;
                at.set_port(at.port().checked_add(offset).ok_or_else(|| {
                    format!("{count} drives from port {} run past 65535", listen.port())
                })?);
            }
            let socket = std::net::UdpSocket::bind(at)
                .and_then(|socket| {
                    socket.set_read_timeout(Some(STOP_POLL))?;
                    Ok(socket)
                })
                .map_err(|err| format!("cannot listen on UDP {at}: {err}"))?;
            sockets.push(
                socket
                    .local_addr()
                    .map_err(|err| format!("cannot read the address of UDP {at}: {err}"))?,
            );
            bound.push(socket);
        }
        let mut running = Self {
            sockets,
            bus,
            epoch,
            stop,
            threads: Vec::with_capacity(count),
        };
        for (index, socket) in bound.into_iter().enumerate() {
            let (bus, stop) = (Arc::clone(&running.bus), Arc::clone(&running.stop));
            let thread = std::thread::Builder::new()
                .name(format!("sim-scl-drive-{index}"))
                .spawn(move || answer(&socket, index, &bus, epoch, &stop))
                .map_err(|err| format!("cannot start simulated MOONS' drive {index}: {err}"))?;
            running.threads.push(thread);
        }
        Ok(running)
    }

    /// Each drive's socket, in order.
    #[must_use]
    pub fn sockets(&self) -> &[SocketAddr] {
        &self.sockets
    }

    /// `read` on the bus run to now.
    pub fn with_bus<R>(&self, read: impl FnOnce(&Bus) -> R) -> R {
        let mut bus = self.bus.lock().unwrap_or_else(PoisonError::into_inner);
        bus.advance(micros(self.epoch, Instant::now()));
        read(&bus)
    }

    /// Stops every drive; returns the bus run to now.
    pub async fn stop(mut self) -> Bus {
        self.stop.store(true, Ordering::Release);
        let threads = std::mem::take(&mut self.threads);
        let joined = tokio::task::spawn_blocking(move || {
            threads
                .into_iter()
                .filter_map(|thread| thread.join().err())
                .count()
        })
        .await;
        if !matches!(joined, Ok(0)) {
            tracing::error!("a simulated MOONS' drive stopped unexpectedly");
        }
        let mut bus = self
            .bus
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        bus.advance(micros(self.epoch, Instant::now()));
        bus
    }
}

impl Drop for UdpDrives {
    /// The drives stop answering (their threads see it within [`STOP_POLL`] and
    /// close their sockets).
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

/// One drive's socket, on its own thread: each datagram goes to the drive, each
/// answer line back to the sender, until `stop`.
fn answer(
    socket: &std::net::UdpSocket,
    index: usize,
    bus: &Mutex<Bus>,
    epoch: Instant,
    stop: &AtomicBool,
) {
    let mut buffer = vec![0u8; MAX_DATAGRAM];
    while !stop.load(Ordering::Acquire) {
        match socket.recv_from(&mut buffer) {
            Ok((len, sender)) => {
                let datagram = buffer.get(..len).unwrap_or_default();
                let answers = bus
                    .lock()
                    .unwrap_or_else(PoisonError::into_inner)
                    .receive_escl(index, datagram, micros(epoch, Instant::now()));
                for answer in answers {
                    if let Err(err) = socket.send_to(&answer, sender) {
                        tracing::warn!(
                            "simulated MOONS' drive {index}: cannot answer {sender}: {err}"
                        );
                    }
                }
            }
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::Interrupted
                ) => {}
            Err(err) => tracing::debug!("simulated MOONS' drive {index}: receive failed: {err}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use floatball_shared::scl::{Command, Request};

    /// A simulated drive answers `IP` while the async runtime it was started from is
    /// busy (its one worker blocked): under load the bridge's own tasks must not keep
    /// a drive from answering within the link's window.
    #[tokio::test(flavor = "multi_thread", worker_threads = 1)]
    async fn a_drive_answers_while_the_runtime_is_busy() {
        let wire = parse_start_wire(DEFAULT_START_WIRE).expect("a wire");
        let drives = UdpDrives::spawn(
            SocketAddr::from(([127, 0, 0, 1], 0)),
            bus(1, false, wire).expect("a bus"),
        )
        .expect("the drives");
        let to = drives.sockets()[0];
        // The runtime's only worker busy for 3 s (as a long synchronous stretch of
        // work would keep it).
        let busy = Arc::new(AtomicBool::new(true));
        let (started, began) = std::sync::mpsc::channel();
        let blocker = {
            let busy = Arc::clone(&busy);
            tokio::spawn(async move {
                let _ = started.send(());
                std::thread::sleep(Duration::from_secs(3));
                busy.store(false, Ordering::SeqCst);
            })
        };
        began.recv().expect("the worker is busy");
        let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("a socket");
        socket
            .set_read_timeout(Some(Duration::from_secs(10)))
            .expect("a timeout");
        socket
            .send_to(&Request::new(Command::ImmediatePosition).to_escl(), to)
            .expect("sent");
        let mut buffer = [0u8; 64];
        let length = socket.recv(&mut buffer).expect("an answer");
        let answered_while_busy = busy.load(Ordering::SeqCst);
        let answer = String::from_utf8_lossy(&buffer[..length]).into_owned();
        assert!(answer.contains("IP="), "{answer:?}");
        assert!(
            answered_while_busy,
            "the drive answered only once the runtime was free again"
        );
        blocker.await.expect("the blocker");
        let bus = drives.stop().await;
        assert_eq!(bus.drives().len(), 1);
    }
}
