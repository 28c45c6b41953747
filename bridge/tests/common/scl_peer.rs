//! MOONS' drives for the SCL link's tests: the drive twin (`floatball_shared::scl::
//! twin`) on the master side of a pseudo-terminal (a [`Bus`] of addressed drives on an
//! RS-485 line, optionally with the start wire) or each on its own loopback UDP socket
//! (eSCL), on the wall clock. Every line they receive is recorded with the time it
//! was on the wire.
//!
//! For the e-stop figures a line can be given a baud rate: a pseudo-terminal carries
//! bytes at once, so the peer times the line as a UART would (each byte 10 bits after
//! the previous one ended; a 4-wire line, the drives answer on their own pair), a
//! line's time on the wire is when its first byte would have been received, and an
//! answer leaves when the request and the answer's own bytes have crossed the line.

use std::io::{Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use floatball_shared::scl::twin::{Bus, Drive, DriveConfig, StartWire};
use floatball_shared::scl::{Address, IoPoint};
use serialport::{SerialPort, TTYPort};

/// What the peer received: a line's text (with its address on a line) and when its
/// first byte was on the wire.
#[derive(Debug, Clone)]
pub struct Received {
    pub at: Instant,
    pub text: String,
    /// The drive (UDP), or `None` on a line.
    pub drive: Option<usize>,
}

/// The twins, what they received, and the stop flag, shared with the threads.
type Shared = (Arc<Mutex<Bus>>, Arc<Mutex<Vec<Received>>>, Arc<AtomicBool>);

/// Twins on a pseudo-terminal or on UDP sockets.
pub struct Peer {
    /// The drives (on UDP each is only ever sent its own datagrams).
    pub bus: Arc<Mutex<Bus>>,
    pub received: Arc<Mutex<Vec<Received>>>,
    pub path: std::path::PathBuf,
    pub sockets: Vec<SocketAddr>,
    /// Drives (by index) that refuse `QL`, as a drive without Q programs does.
    pub refuse_ql: Arc<Mutex<Vec<usize>>>,
    epoch: Instant,
    stop: Arc<AtomicBool>,
}

impl Drop for Peer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

fn micros(epoch: Instant, at: Instant) -> u64 {
    u64::try_from(at.saturating_duration_since(epoch).as_micros()).unwrap_or(u64::MAX)
}

impl Peer {
    fn shared(drives: Vec<Drive>) -> Shared {
        (
            Arc::new(Mutex::new(Bus::new(drives))),
            Arc::new(Mutex::new(Vec::new())),
            Arc::new(AtomicBool::new(false)),
        )
    }

    /// Twins with `addresses` on a line at `dir/name`; `baud` times the line (0: no
    /// timing); `wire`: the first drive's output 2 drives input 3 of every drive.
    pub fn serial(
        dir: &std::path::Path,
        name: &str,
        addresses: &str,
        baud: u32,
        wire: bool,
    ) -> Self {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = slave.name().expect("slave name");
        drop(slave);
        master
            .set_timeout(Duration::from_millis(10))
            .expect("timeout");
        let path = dir.join(name);
        std::os::unix::fs::symlink(slave_path, &path).expect("symlink");
        let addresses: Vec<Address> = addresses.chars().filter_map(Address::new).collect();
        let drives = addresses
            .iter()
            .map(|&address| {
                Drive::new(DriveConfig {
                    address: Some(address),
                    ..DriveConfig::default()
                })
            })
            .collect();
        let (bus, received, stop) = Self::shared(drives);
        if wire {
            bus.lock().unwrap().wire(StartWire {
                from: addresses[0],
                output: IoPoint::new(2).unwrap(),
                input: IoPoint::new(3).unwrap(),
            });
        }
        let refuse_ql = Arc::new(Mutex::new(Vec::new()));
        let epoch = Instant::now();
        // The reader stamps every chunk as it arrives; the drives answer in another
        // thread, so their (timed) answers never delay a stamp.
        let (chunks_tx, chunks) = std::sync::mpsc::channel::<(Instant, Vec<u8>)>();
        let mut writer = master.try_clone().expect("clone the master");
        let reading = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buffer = [0u8; 512];
            while !reading.load(Ordering::Acquire) {
                match master.read(&mut buffer) {
                    Ok(count) => {
                        if chunks_tx
                            .send((Instant::now(), buffer[..count].to_vec()))
                            .is_err()
                        {
                            return;
                        }
                    }
                    Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                    // No slave open yet (EIO): the bridge opens it soon.
                    Err(_) => std::thread::sleep(Duration::from_millis(5)),
                }
            }
        });
        let (b, r, s, q) = (
            Arc::clone(&bus),
            Arc::clone(&received),
            Arc::clone(&stop),
            Arc::clone(&refuse_ql),
        );
        std::thread::spawn(move || {
            let byte_time = if baud == 0 {
                Duration::ZERO
            } else {
                Duration::from_nanos(10_000_000_000 / u64::from(baud))
            };
            // When the emulated UART has received every byte from the host so far.
            let mut line_free = Instant::now();
            let mut line = Vec::new();
            let mut first_at: Option<Instant> = None;
            while !s.load(Ordering::Acquire) {
                let Ok((arrived, chunk)) = chunks.recv_timeout(Duration::from_millis(20)) else {
                    continue;
                };
                for byte in chunk {
                    let start = line_free.max(arrived);
                    line_free = start + byte_time;
                    first_at.get_or_insert(start);
                    if byte != b'\r' {
                        line.push(byte);
                        continue;
                    }
                    let text = String::from_utf8_lossy(&line).into_owned();
                    line.clear();
                    let at = first_at.take().unwrap_or(arrived);
                    r.lock().unwrap().push(Received {
                        at,
                        text: text.clone(),
                        drive: None,
                    });
                    let now_us = micros(epoch, line_free);
                    let answer = {
                        let mut bus = b.lock().unwrap();
                        let refused = text.get(1..).is_some_and(|rest| rest.starts_with("QL"))
                            && text
                                .chars()
                                .next()
                                .and_then(Address::new)
                                .and_then(|address| bus.index_of(address))
                                .is_some_and(|index| q.lock().unwrap().contains(&index));
                        if refused {
                            format!("{}?\r", &text[..1])
                        } else {
                            bus.receive_line(&text, now_us)
                        }
                    };
                    let bytes = answer.into_bytes();
                    let whole = line_free + byte_time * u32::try_from(bytes.len()).unwrap_or(0);
                    std::thread::sleep(whole.saturating_duration_since(Instant::now()));
                    let _ = writer.write_all(&bytes);
                }
            }
        });
        Self {
            bus,
            received,
            path,
            sockets: Vec::new(),
            refuse_ql,
            epoch,
            stop,
        }
    }

    /// `count` eSCL twins, each on a loopback UDP socket.
    pub fn udp(count: usize) -> Self {
        let (bus, received, stop) = Self::shared(
            (0..count)
                .map(|_| Drive::new(DriveConfig::default()))
                .collect(),
        );
        let refuse_ql = Arc::new(Mutex::new(Vec::new()));
        let epoch = Instant::now();
        let mut sockets = Vec::new();
        for index in 0..count {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
            socket
                .set_read_timeout(Some(Duration::from_millis(20)))
                .expect("timeout");
            sockets.push(socket.local_addr().expect("addr"));
            let (b, r, s, q) = (
                Arc::clone(&bus),
                Arc::clone(&received),
                Arc::clone(&stop),
                Arc::clone(&refuse_ql),
            );
            std::thread::spawn(move || {
                let mut buffer = [0u8; 2048];
                while !s.load(Ordering::Acquire) {
                    let Ok((len, from)) = socket.recv_from(&mut buffer) else {
                        continue;
                    };
                    let now = Instant::now();
                    let datagram = &buffer[..len];
                    let text = String::from_utf8_lossy(datagram.get(2..).unwrap_or_default())
                        .trim_end_matches('\r')
                        .to_owned();
                    r.lock().unwrap().push(Received {
                        at: now,
                        text: text.clone(),
                        drive: Some(index),
                    });
                    let answers = if text.starts_with("QL") && q.lock().unwrap().contains(&index) {
                        vec![b"\x00\x07?\r".to_vec()]
                    } else {
                        b.lock()
                            .unwrap()
                            .receive_escl(index, datagram, micros(epoch, now))
                    };
                    for answer in answers {
                        let _ = socket.send_to(&answer, from);
                    }
                }
            });
        }
        Self {
            bus,
            received,
            path: std::path::PathBuf::new(),
            sockets,
            refuse_ql,
            epoch,
            stop,
        }
    }

    /// Everything received since `since`.
    pub fn since(&self, since: Instant) -> Vec<Received> {
        self.received
            .lock()
            .unwrap()
            .iter()
            .filter(|line| line.at >= since)
            .cloned()
            .collect()
    }

    /// Every drive's position now, counts.
    pub fn positions(&self) -> Vec<i64> {
        let mut bus = self.bus.lock().unwrap();
        bus.advance(micros(self.epoch, Instant::now()));
        bus.drives().iter().map(Drive::position_integer).collect()
    }

    /// Runs `with` on drive `index`.
    pub fn with_drive<T>(&self, index: usize, with: impl FnOnce(&mut Drive) -> T) -> T {
        let mut bus = self.bus.lock().unwrap();
        with(&mut bus.drives_mut()[index])
    }
}

/// `floatball simulate --kind scl` as a child process; killed when dropped.
pub struct Simulator {
    child: std::process::Child,
    /// Its eSCL sockets (UDP), in drive order.
    pub sockets: Vec<SocketAddr>,
    _relay: Option<Relay>,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Two pseudo-terminal pairs and a tap between their masters: the simulator opens one
/// slave, the bridge the other (by a symlink); every line the bridge writes is
/// recorded with the time it crossed.
pub struct Relay {
    stop: Arc<AtomicBool>,
}

impl Drop for Relay {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

fn pump(
    mut from: Box<dyn SerialPort>,
    mut to: Box<dyn SerialPort>,
    stop: Arc<AtomicBool>,
    record: Option<Arc<Mutex<Vec<Received>>>>,
) {
    std::thread::spawn(move || {
        let mut buffer = [0u8; 512];
        let mut line = Vec::new();
        let mut first_at = None;
        while !stop.load(Ordering::Acquire) {
            let count = match from.read(&mut buffer) {
                Ok(count) => count,
                Err(err) if err.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(_) => {
                    std::thread::sleep(Duration::from_millis(5));
                    continue;
                }
            };
            let now = Instant::now();
            let _ = to.write_all(&buffer[..count]);
            let Some(record) = &record else { continue };
            for &byte in &buffer[..count] {
                first_at.get_or_insert(now);
                if byte == b'\r' {
                    record.lock().unwrap().push(Received {
                        at: first_at.take().unwrap_or(now),
                        text: String::from_utf8_lossy(&line).into_owned(),
                        drive: None,
                    });
                    line.clear();
                } else {
                    line.push(byte);
                }
            }
        }
    });
}

impl Simulator {
    /// `drives` simulated drives on an RS-485 line at `baud` (addresses `0`, `1`, …;
    /// drive `0`'s output 2 wired to input 3 of every drive), reached by the bridge at
    /// `dir/name`; what the bridge writes is recorded in `received`.
    pub fn serial(
        dir: &std::path::Path,
        name: &str,
        drives: usize,
        baud: u32,
        received: Arc<Mutex<Vec<Received>>>,
    ) -> Self {
        let (mut sim_master, sim_slave) = TTYPort::pair().expect("pty pair");
        let (mut bridge_master, bridge_slave) = TTYPort::pair().expect("pty pair");
        let sim_path = sim_slave.name().expect("slave name");
        let bridge_path = bridge_slave.name().expect("slave name");
        drop(bridge_slave);
        for master in [&mut sim_master, &mut bridge_master] {
            master
                .set_timeout(Duration::from_millis(10))
                .expect("timeout");
        }
        std::os::unix::fs::symlink(bridge_path, dir.join(name)).expect("symlink");
        let child = std::process::Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--kind", "scl", "--port", &sim_path])
            .args(["--baud", &baud.to_string(), "--drives", &drives.to_string()])
            .stdout(std::process::Stdio::null())
            .spawn()
            .expect("start floatball simulate --kind scl");
        // Held until the simulator has the port open: a pty without a slave open
        // cannot be read.
        drop(sim_slave);
        let stop = Arc::new(AtomicBool::new(false));
        let sim_reader = sim_master.try_clone().expect("clone");
        let bridge_reader = bridge_master.try_clone().expect("clone");
        pump(
            bridge_reader,
            Box::new(sim_master),
            Arc::clone(&stop),
            Some(received),
        );
        pump(sim_reader, Box::new(bridge_master), Arc::clone(&stop), None);
        Self {
            child,
            sockets: Vec::new(),
            _relay: Some(Relay { stop }),
        }
    }

    /// `drives` simulated eSCL drives on loopback UDP.
    pub fn udp(drives: usize) -> Self {
        use std::io::BufRead;
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--kind", "scl", "--listen", "127.0.0.1:0"])
            .args(["--drives", &drives.to_string()])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .expect("start floatball simulate --kind scl");
        let mut stdout = std::io::BufReader::new(child.stdout.take().expect("stdout"));
        let sockets = (0..drives)
            .map(|_| {
                let mut line = String::new();
                stdout.read_line(&mut line).expect("a line a drive");
                line.split_whitespace()
                    .last()
                    .and_then(|socket| socket.parse().ok())
                    .unwrap_or_else(|| panic!("no socket in {line:?}"))
            })
            .collect();
        std::thread::spawn(move || for _ in stdout.lines() {});
        Self {
            child,
            sockets,
            _relay: None,
        }
    }
}

/// Ball `ball`'s end position in [`drop_show`], mm: 5 × (ball + 1).
pub fn drop_end_mm(ball: usize) -> f64 {
    5.0 * (ball as f64 + 1.0)
}

/// "drop" on a row of three balls: each starts at `start_mm(ball)`, goes down to 20 mm
/// and comes up to [`drop_end_mm`], in 1 s.
pub fn drop_show(start_mm: impl Fn(usize) -> f64) -> Vec<u8> {
    let units = (0..3)
        .map(|ball| {
            serde_json::json!({
                "start_mm": start_mm(ball),
                "rows": [[10.0, 0.0, 250], [20.0, 0.0, 250], [10.0, 0.0, 250], [drop_end_mm(ball), 0.0, 250]],
            })
        })
        .collect();
    super::native_show("drop", 1, 3, units)
}

/// A row of three balls on MOONS' drives, the `[scl]` table holding `scl`, its gateway
/// entry `gateway`.
pub fn config(gateway: &str, scl: &str) -> String {
    format!(
        "[matrix]\nrows = 1\ncols = 3\n[safety]\napproach_speed_mm_s = 1000.0\n\
         [scl]\npoll_ms = 50\ntolerance_mm = 20.0\nhost_port = 0\n{scl}\n[[gateway]]\nkind = \"scl\"\n{gateway}\n"
    )
}

/// [`config`] with the drives `1`, `2`, `3` on `peer`'s RS-485 line at 115200 baud.
pub fn serial_config(peer: &Peer, scl: &str) -> String {
    config(
        &format!(
            "port = \"{}\"\nbaud = 115200\naddresses = \"123\"",
            peer.path.display()
        ),
        scl,
    )
}
