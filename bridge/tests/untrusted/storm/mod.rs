//! The parts of the fuzz storm (`tests/untrusted.rs`): its settings, the seeded
//! generator and the byte mutations every reader shares, the tally of what each reader
//! sent, the threads that pace datagrams (and MIDI bytes) into the bridge, and the real
//! `floatball` process the storm is aimed at.
//!
//! - [`inputs`]: what each UDP reader (and the MTC byte stream) is sent — random bytes,
//!   mutations of valid packets, structure-aware hostile packets — and how each
//!   candidate is classified before it is sent (a valid, allowed command is skipped and
//!   counted, never sent).
//! - [`tap`]: a UIM2503 gateway on a pseudo-terminal, answered by the simulator, with
//!   noise injected into the bridge's feedback direction between the gateway's frames.
//! - [`web`]: the WebSocket and HTTP fuzzers.
//!
//! Nothing here decides whether the bridge passed: `tests/untrusted.rs` watches it.

pub mod inputs;
pub mod tap;
pub mod web;

use std::collections::VecDeque;
use std::fmt::Write as _;
use std::io::{BufRead, BufReader};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use floatball_shared::uim2503::sim::noise::SplitMix;
use tempfile::TempDir;

use crate::common::Remote;

/// The storm's length per family, seconds, unless `FLOATBALL_STORM_SECONDS` says.
pub const DEFAULT_SECONDS: f64 = 3.0;

/// Datagrams a second into the UDP readers of one family in all, unless
/// `FLOATBALL_STORM_RATE` says (shared evenly among them).
pub const DEFAULT_RATE_PER_S: f64 = 1_200.0;

/// The seed unless `FLOATBALL_STORM_SEED` says: the same storm every run.
pub const DEFAULT_SEED: u64 = 52;

/// How long the storm lasts and how hard it blows.
#[derive(Debug, Clone, Copy)]
pub struct Settings {
    /// Seconds of storm per family.
    pub seconds: f64,
    /// Datagrams a second into the UDP readers of one family in all.
    pub rate_per_s: f64,
    /// The seed every generator is derived from.
    pub seed: u64,
}

impl Settings {
    /// The short version unless `FLOATBALL_STORM_SECONDS`, `FLOATBALL_STORM_RATE` or
    /// `FLOATBALL_STORM_SEED` say otherwise (`cargo xtask fuzz` sets them).
    ///
    /// # Panics
    /// A variable that is set but is not a number.
    pub fn from_env() -> Self {
        fn var<T: std::str::FromStr>(name: &str) -> Option<T> {
            let text = std::env::var(name).ok()?;
            let value = text.trim().replace('_', "");
            Some(
                value
                    .parse()
                    .unwrap_or_else(|_| panic!("{name}={text:?} is not a number")),
            )
        }
        let seconds: f64 = var("FLOATBALL_STORM_SECONDS").unwrap_or(DEFAULT_SECONDS);
        let rate_per_s: f64 = var("FLOATBALL_STORM_RATE").unwrap_or(DEFAULT_RATE_PER_S);
        assert!(
            seconds > 0.0 && rate_per_s > 0.0,
            "FLOATBALL_STORM_SECONDS and FLOATBALL_STORM_RATE must be above 0"
        );
        Self {
            seconds,
            rate_per_s,
            seed: var("FLOATBALL_STORM_SEED").unwrap_or(DEFAULT_SEED),
        }
    }

    /// The storm's length.
    pub fn duration(&self) -> Duration {
        Duration::from_secs_f64(self.seconds)
    }
}

/// The seeded generator with the choices every reader makes.
#[derive(Debug, Clone)]
pub struct Rng(SplitMix);

impl Rng {
    /// The generator of reader `stream` in a storm of `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut mixed = SplitMix::new(seed ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        // Spread nearby seeds apart before use.
        let _ = mixed.next_u64();
        Self(mixed)
    }

    pub fn u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// A number below `bound` (at least 1).
    pub fn below(&mut self, bound: u64) -> u64 {
        self.0.below(bound)
    }

    /// An index below `len` (at least 1).
    pub fn index(&mut self, len: usize) -> usize {
        usize::try_from(self.0.below(len as u64)).unwrap_or(0)
    }

    /// True `per_mille` times in a thousand.
    pub fn chance(&mut self, per_mille: u64) -> bool {
        self.0.below(1000) < per_mille
    }

    pub fn byte(&mut self) -> u8 {
        self.0.next_u64().to_le_bytes()[0]
    }

    /// One of `items`.
    pub fn pick<'a, T>(&mut self, items: &'a [T]) -> &'a T {
        &items[self.index(items.len())]
    }

    /// `len` random bytes.
    pub fn bytes(&mut self, len: usize) -> Vec<u8> {
        let mut out = Vec::with_capacity(len + 8);
        while out.len() < len {
            out.extend_from_slice(&self.0.next_u64().to_le_bytes());
        }
        out.truncate(len);
        out
    }

    /// A datagram's length for random bytes: mostly short, sometimes up to a frame,
    /// rarely far over every limit.
    pub fn datagram_len(&mut self) -> usize {
        match self.below(200) {
            0 => 1_500 + self.index(60_000),
            1..=19 => self.index(1_500),
            _ => self.index(96),
        }
    }
}

/// Values that often sit on an edge: for overwritten bytes and size fields.
const INTERESTING_BYTES: [u8; 12] = [
    0x00, 0x01, 0x7F, 0x80, 0xFF, 0xFE, b',', b'/', b'#', b'\0', 0xF0, 0xF7,
];

/// Mutates a copy of `base` one to four times: a bit flipped, a byte overwritten with
/// an edge value, cut short, extended, a byte inserted or deleted, a 32-bit big-endian
/// size field (at a multiple of 4) replaced by a lie, a piece repeated.
pub fn mutate(rng: &mut Rng, base: &[u8]) -> Vec<u8> {
    let mut bytes = base.to_vec();
    for _ in 0..=rng.below(4) {
        let len = bytes.len();
        match rng.below(8) {
            0 if len > 0 => {
                let at = rng.index(len);
                bytes[at] ^= 1 << rng.below(8);
            }
            1 if len > 0 => {
                let at = rng.index(len);
                bytes[at] = *rng.pick(&INTERESTING_BYTES);
            }
            2 if len > 0 => bytes.truncate(rng.index(len)),
            3 => {
                let extra = 1 + rng.index(32);
                bytes.extend(rng.bytes(extra));
            }
            4 => {
                let at = rng.index(len + 1);
                let byte = rng.byte();
                bytes.insert(at, byte);
            }
            5 if len > 0 => {
                bytes.remove(rng.index(len));
            }
            6 if len >= 4 => {
                let at = rng.index(len / 4) * 4;
                let lie: u32 = match rng.below(8) {
                    0 => 0,
                    1 => 1,
                    2 => 3,
                    3 => 0x7FFF_FFFF,
                    4 => u32::MAX,
                    5 => u32::try_from(len).unwrap_or(u32::MAX).wrapping_add(4),
                    6 => u32::try_from(len).unwrap_or(0).wrapping_sub(5),
                    _ => u32::try_from(rng.below(2_000)).unwrap_or(0),
                };
                bytes[at..at + 4].copy_from_slice(&lie.to_be_bytes());
            }
            7 if len > 1 => {
                let from = rng.index(len);
                let to = (from + 1 + rng.index(16)).min(len);
                let piece = bytes[from..to].to_vec();
                let at = rng.index(len + 1);
                bytes.splice(at..at, piece);
            }
            _ => bytes.push(rng.byte()),
        }
    }
    bytes
}

/// What the playlist can play: a Start or Reset within it is valid.
#[derive(Debug, Clone, Copy)]
pub struct Playable {
    /// Entries in the playlist.
    pub entries: usize,
    /// The length of each entry's show, ms (one show here).
    pub show_ms: u64,
}

impl Playable {
    /// Whether a Start or Reset from `from` would play.
    pub fn plays(self, from: floatball_shared::api::StartFrom) -> bool {
        let entry = from.entry.unwrap_or(1);
        (1..=self.entries).contains(&entry) && from.time_ms.unwrap_or(0) < self.show_ms
    }
}

/// What kind of input a candidate is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Random bytes.
    Random,
    /// A valid packet mutated.
    Mutated,
    /// Structure-aware: invalid by construction (or from a sender not allowed).
    Crafted,
    /// Well formed, accepted, and no command: DMX while live mode is off, an `ArtPoll`,
    /// an OSC button's release, a WebSocket ping.
    Input,
}

impl Class {
    const ALL: [Self; 4] = [Self::Random, Self::Mutated, Self::Crafted, Self::Input];

    fn index(self) -> usize {
        match self {
            Self::Random => 0,
            Self::Mutated => 1,
            Self::Crafted => 2,
            Self::Input => 3,
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Random => "random",
            Self::Mutated => "mutated",
            Self::Crafted => "crafted",
            Self::Input => "input",
        }
    }
}

/// One candidate from a reader's generator.
#[derive(Debug, Clone)]
pub struct Draw {
    pub bytes: Vec<u8>,
    pub class: Class,
    /// What it is, for the figures and a failure's message.
    pub label: &'static str,
}

impl Draw {
    pub fn new(class: Class, label: &'static str, bytes: Vec<u8>) -> Self {
        Self {
            bytes,
            class,
            label,
        }
    }
}

/// A reader's input: candidates, and the classifier that says which are valid,
/// allowed commands (never sent).
pub trait Generator: Send {
    /// The next candidate.
    fn draw(&mut self, rng: &mut Rng) -> Draw;

    /// Whether `draw` is a valid, allowed command, which the storm must not send. A
    /// stream's generator (MTC) takes what it admits into its copy of the bridge's
    /// decoder.
    fn is_command(&mut self, draw: &Draw) -> bool;

    /// Whether a crafted candidate the classifier calls a command is still sent: it is
    /// invalid by construction (the bridge's own decoder, used as the classifier,
    /// misreads it). Streams classify everything in context: `false`.
    fn crafted_overrides(&self) -> bool {
        true
    }
}

/// The most recent inputs a reader sent, kept for a failure's message.
const RECENT: usize = 12;

/// What one reader sent.
#[derive(Debug)]
pub struct Tally {
    pub reader: &'static str,
    sent: [AtomicU64; 4],
    bytes: AtomicU64,
    /// Candidates that were valid, allowed commands: not sent.
    skipped: AtomicU64,
    /// Crafted inputs the classifier (the bridge's own decoder) read as a command,
    /// sent all the same: they are invalid by construction.
    misread: AtomicU64,
    /// Sends that failed (a full buffer, a refused port, a closed connection).
    errors: AtomicU64,
    recent: Mutex<VecDeque<(Instant, &'static str, Vec<u8>)>>,
    labels: Mutex<Vec<(&'static str, u64)>>,
}

impl Tally {
    pub fn new(reader: &'static str) -> Arc<Self> {
        Arc::new(Self {
            reader,
            sent: Default::default(),
            bytes: AtomicU64::new(0),
            skipped: AtomicU64::new(0),
            misread: AtomicU64::new(0),
            errors: AtomicU64::new(0),
            recent: Mutex::new(VecDeque::with_capacity(RECENT)),
            labels: Mutex::new(Vec::new()),
        })
    }

    /// Counts `draw` as sent.
    pub fn sent(&self, draw: &Draw) {
        self.sent[draw.class.index()].fetch_add(1, Ordering::Relaxed);
        self.bytes
            .fetch_add(draw.bytes.len() as u64, Ordering::Relaxed);
        let mut recent = self.recent.lock().unwrap_or_else(|e| e.into_inner());
        if recent.len() == RECENT {
            recent.pop_front();
        }
        let kept = draw.bytes.get(..96).unwrap_or(&draw.bytes).to_vec();
        recent.push_back((Instant::now(), draw.label, kept));
        drop(recent);
        if draw.class == Class::Crafted {
            let mut labels = self.labels.lock().unwrap_or_else(|e| e.into_inner());
            match labels.iter_mut().find(|(label, _)| *label == draw.label) {
                Some((_, count)) => *count += 1,
                None => labels.push((draw.label, 1)),
            }
        }
    }

    pub fn skipped(&self) {
        self.skipped.fetch_add(1, Ordering::Relaxed);
    }

    pub fn misread(&self) {
        self.misread.fetch_add(1, Ordering::Relaxed);
    }

    pub fn error(&self) {
        self.errors.fetch_add(1, Ordering::Relaxed);
    }

    /// Everything sent.
    pub fn total(&self) -> u64 {
        self.sent
            .iter()
            .map(|count| count.load(Ordering::Relaxed))
            .sum()
    }

    pub fn skipped_count(&self) -> u64 {
        self.skipped.load(Ordering::Relaxed)
    }

    pub fn misread_count(&self) -> u64 {
        self.misread.load(Ordering::Relaxed)
    }

    /// How many crafted cases of distinct kinds were sent.
    pub fn crafted_kinds(&self) -> usize {
        self.labels.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    /// One line of figures over `seconds`.
    pub fn figures(&self, seconds: f64) -> String {
        let total = self.total();
        let mut line = format!(
            "{:<26} {:>7} sent ({:>5.0}/s)",
            self.reader,
            total,
            total as f64 / seconds.max(1e-3)
        );
        for class in Class::ALL {
            let _ = write!(
                line,
                " {} {}",
                class.name(),
                self.sent[class.index()].load(Ordering::Relaxed)
            );
        }
        let _ = write!(
            line,
            "; {} KB; skipped as valid {}; crafted kinds {}",
            self.bytes.load(Ordering::Relaxed) / 1024,
            self.skipped_count(),
            self.crafted_kinds()
        );
        let _ = write!(
            line,
            "; crafted read as commands by the classifier {}",
            self.misread_count()
        );
        let errors = self.errors.load(Ordering::Relaxed);
        if errors > 0 {
            let _ = write!(line, "; send errors {errors}");
        }
        line
    }

    /// The inputs sent last, newest last, with how long before `at` each went.
    pub fn recent(&self, at: Instant) -> String {
        let recent = self.recent.lock().unwrap_or_else(|e| e.into_inner());
        let mut text = String::new();
        for (sent, label, bytes) in recent.iter() {
            let before_ms = at.saturating_duration_since(*sent).as_secs_f64() * 1e3;
            let _ = writeln!(
                text,
                "    {:>8.1} ms before: {label}: {}",
                before_ms,
                hex(bytes)
            );
        }
        text
    }
}

/// `bytes` in hex.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().fold(String::new(), |mut text, byte| {
        let _ = write!(text, "{byte:02x}");
        text
    })
}

/// `FLOATBALL_STORM_ONLY`: when set, every reader sends only its crafted inputs whose
/// label holds this text (to replay one case: `FLOATBALL_STORM_ONLY="issue 52"`).
pub fn only() -> Option<&'static str> {
    static ONLY: std::sync::OnceLock<Option<String>> = std::sync::OnceLock::new();
    ONLY.get_or_init(|| std::env::var("FLOATBALL_STORM_ONLY").ok())
        .as_deref()
}

/// Draws from `generator` until it gives a candidate to send: valid, allowed commands
/// are counted in `tally` and drawn again. `None` when `FLOATBALL_STORM_ONLY` leaves
/// this reader nothing to send.
pub fn next_to_send(generator: &mut dyn Generator, rng: &mut Rng, tally: &Tally) -> Option<Draw> {
    for _ in 0..10_000 {
        let draw = generator.draw(rng);
        if let Some(only) = only()
            && !(draw.class == Class::Crafted && draw.label.contains(only))
        {
            continue;
        }
        if !generator.is_command(&draw) {
            return Some(draw);
        }
        if draw.class == Class::Crafted && generator.crafted_overrides() {
            tally.misread();
            return Some(draw);
        }
        tally.skipped();
    }
    None
}

/// Paces `per_s` sends a second until `stop`: calls `send` for each one due, until it
/// says there is nothing more to send.
fn paced(per_s: f64, stop: &AtomicBool, mut send: impl FnMut() -> bool) {
    let started = Instant::now();
    let mut due = 0u64;
    while !stop.load(Ordering::Acquire) {
        let at = started + Duration::from_secs_f64(due as f64 / per_s);
        let now = Instant::now();
        if at > now {
            std::thread::sleep((at - now).min(Duration::from_millis(20)));
            continue;
        }
        if !send() {
            return;
        }
        due += 1;
    }
}

/// A thread sending `generator`'s datagrams from `from` (`"127.0.0.1:0"`) to each of
/// `to` in turn, `per_s` a second, until `stop`.
pub fn udp_feeder(
    from: &str,
    to: Vec<SocketAddr>,
    per_s: f64,
    mut generator: Box<dyn Generator>,
    mut rng: Rng,
    tally: Arc<Tally>,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    let socket = UdpSocket::bind(from).unwrap_or_else(|error| panic!("bind {from}: {error}"));
    std::thread::Builder::new()
        .name(format!("storm {}", tally.reader))
        .spawn(move || {
            let mut turn = 0usize;
            paced(per_s, &stop, || {
                let Some(draw) = next_to_send(generator.as_mut(), &mut rng, &tally) else {
                    return false;
                };
                let target = to[turn % to.len()];
                turn += 1;
                match socket.send_to(&draw.bytes, target) {
                    Ok(_) => tally.sent(&draw),
                    // A datagram over 65507 bytes, or ICMP from an earlier one: counted.
                    Err(_) => tally.error(),
                }
                true
            });
        })
        .expect("a storm thread")
}

/// A thread writing `generator`'s chunks into the FIFO at `path` (MIDI bytes), `per_s`
/// a second, until `stop`; it opens the FIFO once (blocking until the bridge reads it)
/// and keeps it open, so the bridge's decoder sees one unbroken stream.
pub fn fifo_feeder(
    path: std::path::PathBuf,
    per_s: f64,
    mut generator: Box<dyn Generator>,
    mut rng: Rng,
    tally: Arc<Tally>,
    stop: Arc<AtomicBool>,
) -> std::thread::JoinHandle<()> {
    use std::io::Write as _;
    std::thread::Builder::new()
        .name(format!("storm {}", tally.reader))
        .spawn(move || {
            // Opening for writing blocks until the reader has it open.
            let mut fifo = match std::fs::OpenOptions::new().write(true).open(&path) {
                Ok(fifo) => fifo,
                Err(_) => {
                    tally.error();
                    return;
                }
            };
            paced(per_s, &stop, || {
                let Some(draw) = next_to_send(generator.as_mut(), &mut rng, &tally) else {
                    return false;
                };
                match fifo.write_all(&draw.bytes) {
                    Ok(()) => tally.sent(&draw),
                    Err(_) => tally.error(),
                }
                true
            });
        })
        .expect("a storm thread")
}

/// A free UDP port on the loopback (bound and let go: another program could take it
/// meanwhile, as in the other tests).
pub fn free_udp_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|socket| socket.local_addr())
        .expect("a free UDP port")
        .port()
}

/// A running `floatball` on a temporary data directory; killed when dropped. As
/// `common::process::Process`, but its binary may be another build's:
/// `FLOATBALL_STORM_BIN` names one (to check that the oracle catches a bug in a
/// build from before its fix), else the one Cargo built for this test.
pub struct StormBridge {
    child: Child,
    remote: Remote,
    pub data: TempDir,
}

impl StormBridge {
    /// Starts it with `config` as its floatball.toml on a free loopback port; returns
    /// once it listens. Its log goes to `floatball.log` in the data directory.
    pub fn start(config: &str) -> Self {
        let data = tempfile::tempdir().expect("temp dir");
        std::fs::write(data.path().join("floatball.toml"), config).expect("write config");
        let static_dir = crate::common::static_dir(data.path());
        let log = std::fs::File::options()
            .create(true)
            .append(true)
            .open(data.path().join("floatball.log"))
            .expect("log");
        let binary = std::env::var_os("FLOATBALL_STORM_BIN")
            .unwrap_or_else(|| env!("CARGO_BIN_EXE_floatball").into());
        let mut child = Command::new(&binary)
            .arg("--data-dir")
            .arg(data.path())
            .arg("--static-dir")
            .arg(&static_dir)
            .args(["--listen", "127.0.0.1:0"])
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(log)
            .spawn()
            .unwrap_or_else(|error| panic!("start {}: {error}", binary.to_string_lossy()));
        let stdout = child.stdout.take().expect("stdout");
        let mut lines = BufReader::new(stdout).lines();
        let addr = loop {
            let Some(Ok(line)) = lines.next() else {
                let _ = child.kill();
                let _ = child.wait();
                panic!(
                    "floatball ended before it listened:\n{}",
                    std::fs::read_to_string(data.path().join("floatball.log")).unwrap_or_default()
                );
            };
            if let Some(url) = line.strip_prefix("floatball listening on http://") {
                break url.trim().parse().expect("address");
            }
        };
        std::thread::spawn(move || for _ in lines {});
        Self {
            child,
            remote: Remote { addr },
            data,
        }
    }

    /// The log so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(self.data.path().join("floatball.log")).unwrap_or_default()
    }

    /// The last `lines` lines of the log.
    pub fn log_tail(&self, lines: usize) -> String {
        let log = self.log();
        let all: Vec<&str> = log.lines().collect();
        all[all.len().saturating_sub(lines)..].join("\n")
    }

    /// Whether the process still runs.
    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    pub fn remote(&self) -> Remote {
        self.remote
    }
}

impl std::ops::Deref for StormBridge {
    type Target = Remote;

    fn deref(&self) -> &Remote {
        &self.remote
    }
}

impl Drop for StormBridge {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Sets `stop` when dropped: every storm thread ends with the test, on a panic too.
pub struct StopOnDrop(pub Arc<AtomicBool>);

impl Drop for StopOnDrop {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Release);
    }
}
