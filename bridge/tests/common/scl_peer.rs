//! Scripted MOONS' drives for the SCL link's tests, until the drive twin
//! (`floatball simulate --kind scl`) lands: a few drives on the master side of a
//! pseudo-terminal (an RS-485 line, addressed) or each on its own loopback UDP socket
//! (eSCL). They keep what the bridge needs to see — the position (`DI` + `FP` moves at
//! once), the stored segments (`QW`, read back by `QU`), a program "running" for
//! [`RUN_TIME`] after `QX` with its last `FP` as the end position, outputs — and
//! record every line they receive with the time it was on the wire.
//!
//! For the e-stop figures a line can be given a baud rate: a pseudo-terminal carries
//! bytes at once, so the peer times the line as a UART would (each byte 10 bits after
//! the previous one ended), and a line's time on the wire is when its first byte
//! would have been received.

use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use floatball_shared::scl::{Command, Request, escl};
use serialport::{SerialPort, TTYPort};

/// How long a started program "runs".
pub const RUN_TIME: Duration = Duration::from_millis(300);

/// One scripted drive.
#[derive(Debug, Default, Clone)]
pub struct Drive {
    pub position_counts: i64,
    pub distance_counts: i64,
    pub segments: HashMap<u8, Vec<Command>>,
    pub writing: Option<u8>,
    pub running_until: Option<Instant>,
    pub outputs: HashMap<u8, char>,
    /// Refuse `QW` as a real drive does.
    pub refuse_qw: bool,
}

impl Drive {
    /// The last `DI` before an `FP` in segment `segment` and the segments it calls.
    fn end_of(&self, segment: u8, depth: u8) -> Option<i64> {
        let mut distance = None;
        let mut end = None;
        for command in self.segments.get(&segment)? {
            match command {
                Command::Distance {
                    counts: Some(counts),
                } => distance = Some(i64::from(*counts)),
                Command::FeedToPosition => end = distance.or(end),
                Command::QueueCall {
                    segment: Some(called),
                } if depth < 12 => {
                    if let Some(position) = self.end_of(called.get(), depth + 1) {
                        end = Some(position);
                    }
                }
                _ => {}
            }
        }
        end
    }

    /// The answer lines to `text` (no address, no CR).
    pub fn answer(&mut self, text: &str, now: Instant) -> Vec<String> {
        if self.running_until.is_some_and(|until| now >= until) {
            self.running_until = None;
        }
        if let Some(segment) = self.writing {
            if text.is_empty() {
                self.writing = None;
                return vec!["%".into()];
            }
            return match Request::parse(text) {
                Ok(request) => {
                    self.segments
                        .entry(segment)
                        .or_default()
                        .push(request.command);
                    vec!["*".into()]
                }
                Err(_) => vec!["?".into()],
            };
        }
        let Ok(request) = Request::parse(text) else {
            return vec!["?".into()];
        };
        match request.command {
            Command::ImmediatePosition => vec![format!("IP={}", self.position_counts)],
            Command::StatusCode => {
                let running = self.running_until.is_some();
                vec![format!("SC={:04X}", if running { 0x4001 } else { 0x0001 })]
            }
            Command::AlarmCode => vec!["AL=0000".into()],
            Command::Distance {
                counts: Some(counts),
            } => {
                self.distance_counts = i64::from(counts);
                vec!["%".into()]
            }
            Command::FeedToPosition => {
                self.position_counts = self.distance_counts;
                vec!["%".into()]
            }
            Command::QueueWrite { segment } => {
                if self.refuse_qw {
                    return vec!["?".into()];
                }
                self.segments.insert(segment.get(), Vec::new());
                self.writing = Some(segment.get());
                vec!["%".into()]
            }
            Command::QueueUpload {
                segment: Some(segment),
            } => {
                let lines = self
                    .segments
                    .get(&segment.get())
                    .cloned()
                    .unwrap_or_default();
                let mut answer = vec!["%".to_owned(), format!("QU{}", lines.len() + 1)];
                answer.extend(lines.iter().map(ToString::to_string));
                answer
            }
            Command::QueueExecute { segment } => {
                if let Some(end) = self.end_of(segment.get(), 0) {
                    self.position_counts = end;
                }
                self.running_until = Some(now + RUN_TIME);
                vec!["%".into()]
            }
            Command::SetOutput { output, level } => {
                self.outputs.insert(output.get(), level.letter());
                vec!["%".into()]
            }
            Command::StopKill => {
                self.running_until = None;
                vec!["%".into()]
            }
            _ => vec!["%".into()],
        }
    }
}

/// What the peer received: a line's text (with its address on a line) and when its
/// first byte was on the wire.
#[derive(Debug, Clone)]
pub struct Received {
    pub at: Instant,
    pub text: String,
    /// The drive (UDP), or `None` on a line.
    pub drive: Option<usize>,
}

/// The drives, what they received, and the stop flag, shared with the threads.
type Shared = (
    Arc<Mutex<Vec<Drive>>>,
    Arc<Mutex<Vec<Received>>>,
    Arc<AtomicBool>,
);

/// Drives on a pseudo-terminal or on UDP sockets.
pub struct Peer {
    pub drives: Arc<Mutex<Vec<Drive>>>,
    pub received: Arc<Mutex<Vec<Received>>>,
    pub path: std::path::PathBuf,
    pub sockets: Vec<SocketAddr>,
    stop: Arc<AtomicBool>,
}

impl Drop for Peer {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
    }
}

impl Peer {
    fn shared(count: usize) -> Shared {
        (
            Arc::new(Mutex::new(vec![Drive::default(); count])),
            Arc::new(Mutex::new(Vec::new())),
            Arc::new(AtomicBool::new(false)),
        )
    }

    /// Drives with `addresses` on a line at `dir/name`; `baud` times the line (0: no
    /// timing).
    pub fn serial(dir: &std::path::Path, name: &str, addresses: &str, baud: u32) -> Self {
        let (mut master, slave) = TTYPort::pair().expect("pty pair");
        let slave_path = slave.name().expect("slave name");
        drop(slave);
        master
            .set_timeout(Duration::from_millis(10))
            .expect("timeout");
        let path = dir.join(name);
        std::os::unix::fs::symlink(slave_path, &path).expect("symlink");
        let addresses: Vec<char> = addresses.chars().collect();
        let (drives, received, stop) = Self::shared(addresses.len());
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
        let (d, r, s) = (
            Arc::clone(&drives),
            Arc::clone(&received),
            Arc::clone(&stop),
        );
        std::thread::spawn(move || {
            let byte_time = if baud == 0 {
                Duration::ZERO
            } else {
                Duration::from_nanos(10_000_000_000 / u64::from(baud))
            };
            // When the emulated UART has received every byte from the host so far (a
            // 4-wire line: the drives answer on their own pair).
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
                    let mut chars = text.chars();
                    let Some(address) = chars.next() else {
                        continue;
                    };
                    let Some(index) = addresses.iter().position(|a| *a == address) else {
                        continue;
                    };
                    let answers = d.lock().unwrap()[index].answer(chars.as_str(), Instant::now());
                    let mut bytes = Vec::new();
                    for answer in answers {
                        bytes.extend(format!("{address}{answer}\r").into_bytes());
                    }
                    // The answer is whole once the request is in and its own bytes
                    // have crossed the line.
                    let whole = line_free + byte_time * u32::try_from(bytes.len()).unwrap_or(0);
                    std::thread::sleep(whole.saturating_duration_since(Instant::now()));
                    let _ = writer.write_all(&bytes);
                }
            }
        });
        Self {
            drives,
            received,
            path,
            sockets: Vec::new(),
            stop,
        }
    }

    /// `count` eSCL drives, each on a loopback UDP socket.
    pub fn udp(count: usize) -> Self {
        let (drives, received, stop) = Self::shared(count);
        let mut sockets = Vec::new();
        for index in 0..count {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("bind");
            socket
                .set_read_timeout(Some(Duration::from_millis(20)))
                .expect("timeout");
            sockets.push(socket.local_addr().expect("addr"));
            let (d, r, s) = (
                Arc::clone(&drives),
                Arc::clone(&received),
                Arc::clone(&stop),
            );
            std::thread::spawn(move || {
                let mut buffer = [0u8; 2048];
                while !s.load(Ordering::Acquire) {
                    let Ok((len, from)) = socket.recv_from(&mut buffer) else {
                        continue;
                    };
                    let now = Instant::now();
                    let Some(body) = buffer[..len].strip_prefix(&escl::HEADER) else {
                        continue;
                    };
                    let text = String::from_utf8_lossy(body.strip_suffix(b"\r").unwrap_or(body))
                        .into_owned();
                    r.lock().unwrap().push(Received {
                        at: now,
                        text: text.clone(),
                        drive: Some(index),
                    });
                    let answers = d.lock().unwrap()[index].answer(&text, now);
                    let mut datagram = escl::HEADER.to_vec();
                    for answer in answers {
                        datagram.extend(answer.into_bytes());
                        datagram.push(b'\r');
                    }
                    let _ = socket.send_to(&datagram, from);
                }
            });
        }
        Self {
            drives,
            received,
            path: std::path::PathBuf::new(),
            sockets,
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

    /// Drive `index`'s state.
    pub fn drive(&self, index: usize) -> Drive {
        self.drives.lock().unwrap()[index].clone()
    }
}
