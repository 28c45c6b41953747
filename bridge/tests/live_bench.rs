//! `cargo xtask live-bench`: live input's figures (issue 38). Runs only when
//! `LIVE_BENCH` is set (the xtask sets it): otherwise it says so and passes at once.
//! Nothing about speed is asserted; the figures are printed.
//!
//! Through the real `floatball` binary, Art-Net `ArtDmx` from this bench's own socket
//! to the bridge's Art-Net receiver on a free loopback port (sACN off), live mode
//! switched on over the WebSocket as an operator does:
//! - **packet → first motion out, MBOX**: one 3-axis box that is this bench's own UDP
//!   socket (answering with the shared `MboxTwin`, so the link is up), frames every
//!   20 ms. Ball 0 rests at 500 mm; an `ArtDmx` moves its target 20 mm (alternately
//!   down and up, ~300 ms apart plus a random 0–20 ms so the changes fall anywhere
//!   in the frame period), the send instant is stamped, and the first motion frame
//!   received after it whose position for ball 0 differs from the resting one is the
//!   first motion out carrying the change (decoded with `shared::mbox::Datagram`).
//!   p50/p99/max against one frame period + 2 ms. The balls rest before each change,
//!   so the change comes after a quiet period: the bridge's next frame goes half a
//!   period after the last at the earliest, not at the next slot
//!   (`shared::player::live`, "A change goes at once"). A console's repeat of the current
//!   value every 100 ms keeps the input from being lost;
//! - **packet → first motion out, UIM2503**: 100 units at 115,200 baud — two
//!   gateways of 50 (one line carries at most 81 in live mode), each a pseudo-terminal
//!   this bench reads as a UART would and answers with the shared gateway simulator
//!   (`common::process::Tap`). All 100 balls' targets move 20 mm; the first `QP[i]p;`
//!   on gateway 0's wire after the packet whose value differs from the last one before
//!   it is the first row carrying the change; the time is when the read that completed
//!   it ended. Beside it the line's floor (one row round for 50 units at its longest,
//!   `50 × 33 + 13` bytes, at 115,200 baud) and the row time; the ball moves
//!   the FIFO's rows (`live_fifo_rows`) after its row is written;
//! - **packet → first motion out, MOONS'**: three eSCL drives that are this bench's
//!   UDP sockets (`common::scl_peer::Peer::udp`, the SCL twin answering); the first
//!   jog command (`DI`, `CJ`, `CS` or `SJ`) to drive 0 after the packet;
//! - **CPU**: 10,000 MBOX axes (1,000 simulated 10-axis boxes in the bridge,
//!   `port = "sim"`), the whole-matrix patch (40 universes, 16-bit position), live,
//!   40 universes × 44 packets/s for `LIVE_BENCH_CPU_SECONDS` (20): the bridge
//!   process's utime + stime from `/proc/<pid>/stat` over the run → % of one core
//!   (the in-process box simulation is counted too);
//! - **position error**: a 1 × 3 matrix of simulated MBOX boxes (`port = "sim"`), a
//!   random fader for `LIVE_BENCH_ERROR_SECONDS` (60): every 100 ms a new random
//!   fader speed up to ±1,500 mm/s (the top speed is 1,000 mm/s), the value clamped
//!   into 100–1,900 mm, sent at 44 packets/s. `GET /api/sim/positions` is sampled
//!   every ~10 ms; each sample carries the simulated box's own clock (`time_us`, the
//!   instant its positions are of), so no HTTP delay is in the times.
//!   **Against the bridge's own filtered motion** (exact): the bridge records its
//!   filtered steps through the run (Record over the WebSocket, started with the
//!   balls at rest before the fader moves, so the recording has no lead-in; Stop
//!   recording after it; the show is read back with `GET /api/shows/<name>`), and
//!   each sample of balls 0–2 is compared with the recording at the same time
//!   (`shared::show::Sampler`, the filter's parabolas between steps). **Alignment**:
//!   a recorded step's state is where the boxes are to be a frame period after the
//!   step's slot, and its frame leaves at that slot asking for a period; the first
//!   step's state is the recording's first row's end, so the recording's time 0 is
//!   the slot of its first step (as the box's clock sees it: when that frame
//!   arrived). That slot is on the bridge's clock, which the bench cannot read; it is
//!   bounded on the simulation's clock: after the simulation's time read just before
//!   the record request was sent (the request is taken after it), and at most one
//!   period plus the frame lead (5 ms) and 1 ms after the simulation's time read once
//!   the status said `recording` (the next step's slot). Inside that window the
//!   offset with the least mean square error over the first 250 ms of samples (0.5 ms
//!   steps, then 20 µs) is taken — the fader's speed (up to 1,000 mm/s) makes a wrong
//!   offset cost about 1 mm a millisecond, so the fit is sharp — and printed with the
//!   window. The recording's clock is the filter's: when the bridge is late for a
//!   period it steps once and skips the rest (the filter's time runs slower than the
//!   wall's, never faster), so the recording falls a period behind the box's clock
//!   each time; the offset is therefore followed a quarter of a second at a time, each
//!   fitted within −5…+45 ms of the one before, and how far it moved over the run is
//!   printed (0 when no period was skipped). What remains is
//!   the box's own path (a straight line over each frame against the filter's
//!   parabola, at most `a·dt²/8` = 0.2 mm; a frame re-targeted early starts from
//!   where the axis is), the sender's lateness (each frame leaves within about a
//!   millisecond of its slot), the loopback, and the pulses' rounding.
//!   **Against the bench's own filter** (an upper bound, as before the recording
//!   existed): the filtered input computed here with
//!   `shared::live::filter::MotionFilter` on the values sent (a step every 20 ms,
//!   each taking the latest value sent before it, from rest where ball 0 was), each
//!   sample of ball 0 (put on this bench's clock by the smallest offset seen, the
//!   fastest answer) compared with the filter's output `L` ms earlier (linear between
//!   steps); the steps' phase (0–18 ms, 2 ms apart) and the constant lag `L` (0–150
//!   ms, 5 ms apart) are the ones that give the smallest largest error. It includes
//!   which value each of the bridge's steps took, which this bench cannot see. The
//!   error against the raw input (the value sent, same lag, and at its own best lag)
//!   is printed for context.
//!
//! `LIVE_BENCH_ONLY` (`latency`, `uim2503`, `moons`, `cpu`, `error`) runs one part;
//! `LIVE_BENCH_CHANGES`, `LIVE_BENCH_UIM2503_CHANGES`, `LIVE_BENCH_MOONS_CHANGES`,
//! `LIVE_BENCH_CPU_SECONDS`, `LIVE_BENCH_ERROR_SECONDS` size them.

use crate::common;

use std::net::{SocketAddr, UdpSocket};
use std::sync::atomic::{AtomicBool, AtomicU16, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::http::Method;
use common::process::Process;
use common::send_text;
use floatball_bridge::live::LiveStatus;
use floatball_shared::api::{LivePhase, ServerMessage};
use floatball_shared::live::artnet::{self, PortAddress};
use floatball_shared::live::filter::{BallState, FilterLimits, MotionFilter};
use floatball_shared::mbox::Datagram;
use floatball_shared::mbox::motion::AxisCount;
use floatball_shared::mbox::twin::{MboxTwin, TwinConfig};
use floatball_shared::show::{Sampler, Show};

const TRAVEL_MM: f64 = 2000.0;
const TOP_SPEED_MM_S: f64 = 1000.0;
const ACCEL_MM_S2: f64 = 4000.0;
const PERIOD_MS: u64 = 20;

fn from_env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|value| value.parse().ok())
        .filter(|value| *value > 0)
        .unwrap_or(default)
}

/// A free UDP port on the loopback.
fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|socket| socket.local_addr())
        .expect("a port")
        .port()
}

/// The 16-bit value of a position.
fn value(mm: f64) -> u16 {
    (mm / TRAVEL_MM * 65535.0).round().clamp(0.0, 65535.0) as u16
}

/// Where a 16-bit value puts a ball, mm.
fn mm(value: u16) -> f64 {
    f64::from(value) / 65535.0 * TRAVEL_MM
}

/// The configuration: `rows` × `cols`, `gateways`, live input on Art-Net at `port`.
fn config(rows: u32, cols: u32, gateways: &str, port: u16) -> String {
    format!(
        "[matrix]\nrows = {rows}\ncols = {cols}\ntravel_mm = {TRAVEL_MM:.1}\n\
         max_speed_mm_s = {TOP_SPEED_MM_S:.1}\nmax_accel_mm_s2 = {ACCEL_MM_S2:.1}\n\
         [safety]\napproach_speed_mm_s = {TOP_SPEED_MM_S:.1}\n\
         [mbox]\nhost_port = 0\nframe_period_ms = {PERIOD_MS}\n\
         {gateways}\
         [live]\nenabled = true\nsacn = false\nhold_after_ms = 1000\n\
         artnet_listen = \"127.0.0.1:{port}\"\n"
    )
}

/// `balls` balls at the same 16-bit value, from slot 1 of a universe.
fn slots(balls: usize, value: u16) -> Vec<u8> {
    (0..balls).flat_map(|_| value.to_be_bytes()).collect()
}

/// Sends `ArtDmx` on `universe` to the bridge.
fn send(socket: &UdpSocket, to: SocketAddr, universe: u16, data: &[u8]) {
    let address = PortAddress::of_universe(universe).expect("an Art-Net universe");
    let _ = socket.send_to(&artnet::encode_dmx(0, address, data), to);
}

/// The console's repeat: the current value of balls 0–2 on universe 1 every 100 ms.
struct Repeat {
    value: Arc<AtomicU16>,
    running: Arc<AtomicBool>,
}

impl Repeat {
    fn start(to: SocketAddr, balls: usize, first: u16) -> Self {
        let value = Arc::new(AtomicU16::new(first));
        let running = Arc::new(AtomicBool::new(true));
        let (now, run) = (Arc::clone(&value), Arc::clone(&running));
        std::thread::spawn(move || {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
            while run.load(Ordering::SeqCst) {
                send(&socket, to, 1, &slots(balls, now.load(Ordering::SeqCst)));
                std::thread::sleep(Duration::from_millis(100));
            }
        });
        Self { value, running }
    }
}

impl Drop for Repeat {
    fn drop(&mut self) {
        self.running.store(false, Ordering::SeqCst);
    }
}

/// Goes live and waits until following (homing and the approach included).
async fn go_live(bridge: &Process, within: Duration) -> (common::Ws, String, u32) {
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"live","on":true}"#).await;
    let status = common::status_until(&mut ws, within, |status| {
        status.live.as_ref().map(|live| live.phase) == Some(LivePhase::Following)
    })
    .await;
    let live = status.live.as_deref().expect("live");
    println!(
        "  following: period {} ms, latency (the bridge's estimate) {} ms",
        live.period_ms, live.latency_ms
    );
    let period_ms = live.period_ms;
    (ws, token, period_ms)
}

/// p50, p99, max of `values` (sorted here).
fn percentiles(values: &mut [f64]) -> (f64, f64, f64) {
    values.sort_by(f64::total_cmp);
    let at = |q: f64| values[((values.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99), values[values.len() - 1])
}

/// One MBOX box that is this bench's socket: every motion frame stamped on arrival
/// (ball 0's pulses), every datagram answered by the twin.
struct FakeBox {
    address: SocketAddr,
    frames: Arc<Mutex<Vec<(Instant, i32)>>>,
    running: Arc<AtomicBool>,
}

impl FakeBox {
    fn start() -> Self {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
        socket
            .set_read_timeout(Some(Duration::from_millis(50)))
            .expect("a timeout");
        let address = socket.local_addr().expect("an address");
        let frames = Arc::new(Mutex::new(Vec::new()));
        let running = Arc::new(AtomicBool::new(true));
        let (seen, run) = (Arc::clone(&frames), Arc::clone(&running));
        std::thread::spawn(move || {
            let epoch = Instant::now();
            let mut twin = MboxTwin::new(TwinConfig::new(
                std::net::Ipv4Addr::LOCALHOST,
                AxisCount::Three,
            ));
            let mut buffer = [0u8; 2048];
            while run.load(Ordering::SeqCst) {
                let Ok((len, from)) = socket.recv_from(&mut buffer) else {
                    continue;
                };
                let at = Instant::now();
                let bytes = &buffer[..len];
                if let Ok(Datagram::Motion(frame)) = Datagram::decode(bytes) {
                    let pulses = frame.positions_pulses.as_slice()[0];
                    seen.lock().expect("frames").push((at, pulses));
                }
                let now_us = u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX);
                if let Some(reply) = twin.receive(now_us, bytes) {
                    let _ = socket.send_to(&reply, from);
                }
            }
        });
        Self {
            address,
            frames,
            running,
        }
    }

    /// Ball 0's pulses in the latest frame and how many frames came.
    fn latest(&self) -> Option<(Instant, i32)> {
        self.frames.lock().expect("frames").last().copied()
    }

    /// The first frame after `since` whose ball 0 is not at `resting`.
    fn first_change(&self, since: Instant, resting: i32) -> Option<Instant> {
        self.frames
            .lock()
            .expect("frames")
            .iter()
            .find(|(at, pulses)| *at > since && *pulses != resting)
            .map(|(at, _)| *at)
    }
}

impl Drop for FakeBox {
    fn drop(&mut self) {
        self.running.store(false, Ordering::SeqCst);
    }
}

/// A tiny deterministic generator (xorshift), [0, 1).
struct Random(u64);

impl Random {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Until ball 0's frames rest (the same pulses for 5 frames); its pulses.
fn resting(fake: &FakeBox) -> i32 {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        std::thread::sleep(Duration::from_millis(2 * PERIOD_MS));
        let frames = fake.frames.lock().expect("frames");
        let last: Vec<i32> = frames.iter().rev().take(5).map(|(_, p)| *p).collect();
        if last.len() == 5 && last.iter().all(|p| *p == last[0]) {
            return last[0];
        }
        drop(frames);
        assert!(Instant::now() < deadline, "ball 0 never rested");
    }
}

async fn mbox_latency(changes: u64) {
    println!("MBOX: packet → first motion frame out (one box that is this bench's socket)");
    let fake = FakeBox::start();
    let port = free_port();
    let to = SocketAddr::from(([127, 0, 0, 1], port));
    let bridge = Process::start(&config(
        1,
        3,
        &format!(
            "[[gateway]]\nkind = \"mbox\"\naddress = \"{}\"\naxes = 3\n",
            fake.address
        ),
        port,
    ));
    let low = value(500.0);
    let high = value(520.0);
    let repeat = Repeat::start(to, 3, low);
    let (_ws, _token, _) = go_live(&bridge, Duration::from_secs(30)).await;
    let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
    let mut random = Random(0x9e37_79b9_7f4a_7c15);
    let mut latencies_ms = Vec::new();
    let mut missed = 0;
    for change in 0..changes {
        let rest = resting(&fake);
        std::thread::sleep(Duration::from_micros((random.next() * 20_000.0) as u64));
        let target = if change % 2 == 0 { high } else { low };
        let sent = Instant::now();
        send(&socket, to, 1, &slots(3, target));
        repeat.value.store(target, Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(300));
        match fake.first_change(sent, rest) {
            Some(at) => latencies_ms.push((at - sent).as_secs_f64() * 1000.0),
            None => missed += 1,
        }
    }
    let (p50, p99, max) = percentiles(&mut latencies_ms);
    println!(
        "  {} changes ({missed} without a frame within 300 ms): p50 {p50:.1} ms, p99 {p99:.1} ms, \
         max {max:.1} ms; goal ≤ one frame period + 2 ms = {} ms",
        latencies_ms.len(),
        PERIOD_MS + 2
    );
    if let Some((_, pulses)) = fake.latest() {
        println!("  (ball 0's last frame: {pulses} pulses)");
    }
    drop(repeat);
}

/// Every `QP[i]p;` on `wire` from `from` on: (the offset its `;` ends at, p).
fn qp_values(wire: &[u8], from: usize) -> Vec<(usize, i64)> {
    let mut found = Vec::new();
    let mut at = from;
    while let Some(start) = wire[at..].windows(3).position(|w| w == b"QP[") {
        let mut i = at + start + 3;
        while i < wire.len() && wire[i] != b']' {
            i += 1;
        }
        let number_from = i + 1;
        let mut end = number_from;
        while end < wire.len() && wire[end] != b';' {
            end += 1;
        }
        if end >= wire.len() {
            break;
        }
        if let Some(value) = std::str::from_utf8(&wire[number_from..end])
            .ok()
            .and_then(|text| text.parse().ok())
        {
            found.push((end + 1, value));
        }
        at = end;
    }
    found
}

async fn uim2503_latency(changes: u64) {
    const UNITS: u32 = 50;
    const BAUD: u32 = 115_200;
    println!(
        "UIM2503: packet → first row byte out carrying the change, 100 units at {BAUD} baud \
         (two gateways of {UNITS}, each on a pseudo-terminal this bench reads, answering as \
         a gateway with the shared simulator)"
    );
    let dir = tempfile::tempdir().expect("a dir");
    let taps: Vec<common::process::Tap> = (0..2)
        .map(|gateway| {
            common::process::Tap::new(
                dir.path(),
                &format!("gateway{gateway}"),
                BAUD,
                floatball_shared::uim2503::sim::GatewayConfig::numbered(UNITS as u8),
            )
        })
        .collect();
    let port = free_port();
    let to = SocketAddr::from(([127, 0, 0, 1], port));
    let gateways: String = taps
        .iter()
        .map(|tap| {
            format!(
                "[[gateway]]\nport = \"{}\"\nbaud = {BAUD}\n",
                tap.path.display()
            )
        })
        .collect();
    let bridge = Process::start(&config(10, 10, &gateways, port));
    let low = value(500.0);
    let high = value(520.0);
    let repeat = Repeat::start(to, 100, low);
    let (_ws, _token, period_ms) = go_live(&bridge, Duration::from_secs(90)).await;
    tokio::time::sleep(Duration::from_secs(2)).await;
    let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
    let mut random = Random(0x1234_5678_9abc_def1);
    let mut latencies_ms = Vec::new();
    let mut missed = 0;
    for change in 0..changes {
        std::thread::sleep(Duration::from_micros(
            (random.next() * f64::from(period_ms) * 1000.0) as u64,
        ));
        let tap = &taps[0];
        let (wire_before, _) = tap.wire_timed();
        let resting = qp_values(&wire_before, wire_before.len().saturating_sub(4000))
            .last()
            .map(|(_, value)| *value);
        let target = if change % 2 == 0 { high } else { low };
        let sent = Instant::now();
        send(&socket, to, 1, &slots(100, target));
        repeat.value.store(target, Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(700));
        let (wire, arrivals) = tap.wire_timed();
        let first = qp_values(&wire, wire_before.len())
            .into_iter()
            .find(|(_, value)| Some(*value) != resting);
        let at = first.and_then(|(end, _)| {
            arrivals
                .iter()
                .find(|(_, length)| *length >= end)
                .map(|(at, _)| *at)
        });
        match at {
            Some(at) if resting.is_some() => {
                latencies_ms.push((at.saturating_duration_since(sent)).as_secs_f64() * 1000.0);
            }
            _ => missed += 1,
        }
    }
    drop(repeat);
    let (p50, p99, max) = percentiles(&mut latencies_ms);
    let row_bytes = UNITS * 33 + 13;
    println!(
        "  {} changes ({missed} not seen within 700 ms): p50 {p50:.1} ms, p99 {p99:.1} ms, \
         max {max:.1} ms to the read that completed the first QP carrying the change \
         (as the line paces it); the row time (period) {period_ms} ms; the line's floor: one \
         row round for {UNITS} units is at most {row_bytes} bytes = {:.0} ms at {BAUD} baud \
         ({:.0} ms for 100 units on one line, which live mode refuses above 81 units); the \
         ball moves {} rows later (the FIFO)",
        latencies_ms.len(),
        f64::from(row_bytes) * 10.0 / f64::from(BAUD) * 1000.0,
        f64::from(100 * 33 + 13) * 10.0 / f64::from(BAUD) * 1000.0,
        floatball_shared::uim2503::player::live::live_fifo_rows(
            u8::try_from(period_ms).unwrap_or(u8::MAX)
        )
    );
}

async fn moons_latency(changes: u64) {
    println!(
        "MOONS': packet → first jog command (DI/CJ/CS/SJ) out to drive 0, three eSCL drives \
         that are this bench's UDP sockets answering with the shared SCL twin"
    );
    let peer = common::scl_peer::Peer::udp(3);
    let list: Vec<String> = peer.sockets.iter().map(|s| format!("\"{s}\"")).collect();
    let port = free_port();
    let to = SocketAddr::from(([127, 0, 0, 1], port));
    let bridge = Process::start(&config(
        1,
        3,
        &format!(
            "[scl]\nhost_port = 0\n[[gateway]]\nkind = \"scl\"\nescl = [{}]\n",
            list.join(", ")
        ),
        port,
    ));
    let low = value(500.0);
    let high = value(520.0);
    let repeat = Repeat::start(to, 3, low);
    let (_ws, _token, period_ms) = go_live(&bridge, Duration::from_secs(60)).await;
    tokio::time::sleep(Duration::from_secs(1)).await;
    let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
    let mut random = Random(0x0f1e_2d3c_4b5a_6978);
    let mut latencies_ms = Vec::new();
    let mut missed = 0;
    let jog = |text: &str| ["DI", "CJ", "CS", "SJ"].iter().any(|c| text.starts_with(c));
    for change in 0..changes {
        std::thread::sleep(Duration::from_micros(
            (random.next() * f64::from(period_ms) * 1000.0) as u64,
        ));
        let target = if change % 2 == 0 { high } else { low };
        let sent = Instant::now();
        send(&socket, to, 1, &slots(3, target));
        repeat.value.store(target, Ordering::SeqCst);
        std::thread::sleep(Duration::from_millis(500));
        let first = peer
            .since(sent)
            .into_iter()
            .find(|line| line.drive == Some(0) && jog(&line.text));
        match first {
            Some(line) => latencies_ms.push((line.at - sent).as_secs_f64() * 1000.0),
            None => missed += 1,
        }
    }
    drop(repeat);
    let (p50, p99, max) = percentiles(&mut latencies_ms);
    println!(
        "  {} changes ({missed} without a jog command within 500 ms): p50 {p50:.1} ms, p99 \
         {p99:.1} ms, max {max:.1} ms; the period {period_ms} ms",
        latencies_ms.len()
    );
}

/// utime + stime of `pid`, clock ticks.
fn cpu_ticks(pid: u32) -> u64 {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).expect("/proc/pid/stat");
    // The fields after the command (which may hold spaces) in parentheses.
    let rest = &stat[stat.rfind(')').expect("the command's end") + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    // utime and stime are fields 14 and 15 of stat; `rest` starts at field 3.
    fields[11].parse::<u64>().expect("utime") + fields[12].parse::<u64>().expect("stime")
}

async fn cpu(seconds: u64) {
    println!(
        "CPU: 10,000 MBOX axes (1,000 simulated boxes in the bridge), 40 universes × 44 packets/s"
    );
    let port = free_port();
    let to = SocketAddr::from(([127, 0, 0, 1], port));
    let gateways = "[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 10\n".repeat(1000);
    let bridge = Process::start(&config(100, 100, &gateways, port));
    let running = Arc::new(AtomicBool::new(true));
    let run = Arc::clone(&running);
    let sender = std::thread::spawn(move || {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
        let started = Instant::now();
        let mut packets = 0u64;
        let mut tick = 0u64;
        while run.load(Ordering::SeqCst) {
            let t_s = started.elapsed().as_secs_f64();
            for universe in 1..=40u16 {
                // A slow wave per universe: every ball moves, within the limits.
                let mm = 1000.0 + 300.0 * (t_s * 0.5 + f64::from(universe) * 0.1).sin();
                let balls = if universe == 40 { 16 } else { 256 };
                send(&socket, to, universe, &slots(balls, value(mm)));
                packets += 1;
            }
            tick += 1;
            let next = Duration::from_secs_f64(tick as f64 / 44.0);
            if let Some(wait) = next.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        (packets, started.elapsed())
    });
    let (_ws, token, _) = go_live(&bridge, Duration::from_secs(120)).await;
    let counters = || async {
        let reply = bridge
            .request(Method::GET, "/api/live/status", Some(&token), None)
            .await;
        let status: LiveStatus = reply.json();
        status.counters
    };
    let taken_before = counters().await;
    let ticks_per_s = 100.0; // USER_HZ on Linux
    let before = (cpu_ticks(bridge.pid()), Instant::now());
    tokio::time::sleep(Duration::from_secs(seconds)).await;
    let after = (cpu_ticks(bridge.pid()), Instant::now());
    running.store(false, Ordering::SeqCst);
    let (packets, sent_for) = sender.join().expect("the sender");
    let taken_after = counters().await;
    println!(
        "  the receivers over the run: {} Art-Net packets, {} accepted, {} dropped (queue full)",
        taken_after.artnet_packets - taken_before.artnet_packets,
        taken_after.accepted - taken_before.accepted,
        taken_after.dropped - taken_before.dropped
    );
    let cpu_s = (after.0 - before.0) as f64 / ticks_per_s;
    let wall_s = (after.1 - before.1).as_secs_f64();
    println!(
        "  {:.0} packets/s sent; the bridge used {cpu_s:.2} s of CPU in {wall_s:.1} s: \
         {:.1} % of one core (goal ≤ 50 %)",
        packets as f64 / sent_for.as_secs_f64(),
        cpu_s / wall_s * 100.0
    );
}

async fn position_error(seconds: u64) {
    println!("position error: a random fader on 1 × 3 simulated MBOX balls for {seconds} s");
    let port = free_port();
    let to = SocketAddr::from(([127, 0, 0, 1], port));
    let bridge = Process::start(&config(
        1,
        3,
        "[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n",
        port,
    ));
    let start_mm = 1000.0;
    let inputs: Arc<Mutex<Vec<(Instant, f64)>>> = Arc::new(Mutex::new(Vec::new()));
    let repeat = Repeat::start(to, 3, value(start_mm));
    let (mut ws, token, _) = go_live(&bridge, Duration::from_secs(30)).await;
    // At rest on the first value.
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let positions = bridge.sim_positions(&token).await;
        let pulses = positions.boxes[0].positions_pulses[0];
        if (f64::from(pulses).abs() / 100.0 - mm(value(start_mm))).abs() < 0.5 {
            break;
        }
        assert!(Instant::now() < deadline, "ball 0 never reached the input");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    drop(repeat);
    // The bridge records its filtered motion from here, the balls at rest: the
    // recording's time 0 is the slot of its first step, between the simulation's
    // clock just before the request and one period and the frame lead after it was
    // taken (see the module's doc).
    let take = "live bench error";
    let before_us = bridge.sim_positions(&token).await.boxes[0].time_us;
    send_text(
        &mut ws,
        &serde_json::json!({"type": "record", "name": take}).to_string(),
    )
    .await;
    common::status_until(&mut ws, Duration::from_secs(5), |status| {
        status.live.as_deref().is_some_and(|live| live.recording)
    })
    .await;
    let after_us = bridge.sim_positions(&token).await.boxes[0].time_us;
    let running = Arc::new(AtomicBool::new(true));
    let (run, sent) = (Arc::clone(&running), Arc::clone(&inputs));
    let fader = std::thread::spawn(move || {
        let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
        let mut random = Random(0x2545_f491_4f6c_dd1d);
        let started = Instant::now();
        let (mut at_mm, mut speed_mm_s) = (start_mm, 0.0);
        let mut last = started;
        let mut tick = 0u64;
        while run.load(Ordering::SeqCst) {
            let now = Instant::now();
            at_mm = (at_mm + speed_mm_s * (now - last).as_secs_f64()).clamp(100.0, 1900.0);
            last = now;
            if tick.is_multiple_of(4) {
                speed_mm_s = (random.next() * 2.0 - 1.0) * 1500.0;
            }
            let v = value(at_mm);
            let stamp = Instant::now();
            send(&socket, to, 1, &slots(3, v));
            sent.lock().expect("inputs").push((stamp, mm(v)));
            tick += 1;
            let next = Duration::from_secs_f64(tick as f64 / 44.0);
            if let Some(wait) = next.checked_sub(started.elapsed()) {
                std::thread::sleep(wait);
            }
        }
    });
    let started = Instant::now();
    let first_mm = mm(value(start_mm));
    // (when the answer came, the simulation's clock, ball 0 mm)
    let mut answers: Vec<(Instant, u64, f64)> = Vec::new();
    // (the simulation's clock, balls 0–2 mm)
    let mut balls: Vec<(u64, [f64; 3])> = Vec::new();
    while started.elapsed() < Duration::from_secs(seconds) {
        let positions = bridge.sim_positions(&token).await;
        let one = &positions.boxes[0];
        let mm = |axis: usize| f64::from(one.positions_pulses[axis]).abs() / 100.0;
        answers.push((Instant::now(), one.time_us, mm(0)));
        balls.push((one.time_us, [mm(0), mm(1), mm(2)]));
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    // Each sample on the simulation's clock, put on this bench's by the smallest
    // offset seen (the answer that came back fastest): no HTTP delay in the times.
    let clock_origin = answers[0].0;
    let offset_us = answers
        .iter()
        .map(|(at, sim_us, _)| (*at - clock_origin).as_micros() as i128 - i128::from(*sim_us))
        .min()
        .expect("samples");
    let samples: Vec<(Instant, f64)> = answers
        .iter()
        .filter_map(|(_, sim_us, ball)| {
            let us = i128::from(*sim_us) + offset_us;
            u64::try_from(us)
                .ok()
                .map(|us| (clock_origin + Duration::from_micros(us), *ball))
        })
        .collect();
    running.store(false, Ordering::SeqCst);
    fader.join().expect("the fader");
    let inputs = inputs.lock().expect("inputs").clone();
    send_text(&mut ws, r#"{"type":"record_stop"}"#).await;
    let recorded_ms = loop {
        match common::next_message(&mut ws).await {
            ServerMessage::Recorded { duration_ms, .. } => break duration_ms,
            ServerMessage::Error { message, .. } => panic!("the recording: {message}"),
            _ => {}
        }
    };
    let reply = bridge
        .request(
            Method::GET,
            &format!("/api/shows/{}", common::encode_path(take)),
            Some(&token),
            None,
        )
        .await;
    let show = Show::from_json(std::str::from_utf8(&reply.body).expect("utf-8"))
        .expect("the recorded show");
    compare_recorded(&show, recorded_ms, &balls, (before_us, after_us));

    let by_answer: Vec<(Instant, f64)> = answers.iter().map(|(at, _, ball)| (*at, *ball)).collect();
    compare(
        &inputs,
        &samples,
        first_mm,
        "timed by the simulation's clock",
    );
    compare(
        &inputs,
        &by_answer,
        first_mm,
        "timed by the answer's arrival",
    );
}

/// Prints |simulated ball − the bridge's own filtered motion| (the recording `show`)
/// over `samples` of balls 0–2 (the simulation's clock), the recording's time 0 put
/// on that clock within `request_us` (the simulation's clock before the record
/// request and after it was taken) plus one period and the frame lead: the offset
/// there with the least mean square error (see the module's doc).
fn compare_recorded(
    show: &Show,
    recorded_ms: u64,
    samples: &[(u64, [f64; 3])],
    request_us: (u64, u64),
) {
    let mut sampler = Sampler::new(show);
    let end_ms = sampler.duration_ms() as f64;
    // |sim − recording| of every sample of `chunk` inside the recording, its time 0 at
    // `zero_us`.
    let mut errors = |chunk: &[(u64, [f64; 3])], zero_us: f64| -> Vec<f64> {
        let mut at = [0.0f32; 3];
        let mut errors = Vec::with_capacity(chunk.len() * 3);
        for (sim_us, ball) in chunk {
            let t_ms = (*sim_us as f64 - zero_us) / 1000.0;
            if !(0.0..=end_ms).contains(&t_ms) {
                continue;
            }
            sampler.sample(t_ms, &mut at, None);
            for (sim, filtered) in ball.iter().zip(at) {
                errors.push((sim - f64::from(filtered)).abs());
            }
        }
        errors
    };
    let mean_square =
        |errors: &[f64]| errors.iter().map(|e| e * e).sum::<f64>() / errors.len().max(1) as f64;
    // The offset in `from..=to` with the least mean square error over `chunk`: 0.5 ms
    // steps, then 20 µs steps around the best.
    type Errors<'a> = dyn FnMut(&[(u64, [f64; 3])], f64) -> Vec<f64> + 'a;
    let fit = |errors: &mut Errors<'_>, chunk: &[(u64, [f64; 3])], from: f64, to: f64| -> f64 {
        let mut search = |from: f64, to: f64, step: f64| {
            let mut best = (from, f64::INFINITY);
            let mut zero = from;
            while zero <= to {
                let score = mean_square(&errors(chunk, zero));
                if score < best.1 {
                    best = (zero, score);
                }
                zero += step;
            }
            best.0
        };
        let coarse = search(from, to, 500.0);
        search(coarse - 500.0, coarse + 500.0, 20.0)
    };
    let lead_us = 5_000.0;
    let (from_us, to_us) = (
        request_us.0 as f64,
        request_us.1 as f64 + (PERIOD_MS * 1000) as f64 + lead_us + 1_000.0,
    );
    // A quarter of a second at a time: the first inside the window the record request
    // bounds, each next within −5…+45 ms of the one before (the recording's clock falls behind by a
    // period whenever the bridge skipped a late one).
    const WINDOW_US: u64 = 250_000;
    let first_us = samples.first().map_or(0, |(us, _)| *us);
    let mut zero_us = None;
    let (mut first_zero_us, mut found) = (0.0, Vec::new());
    for chunk in
        samples.chunk_by(|a, b| (a.0 - first_us) / WINDOW_US == (b.0 - first_us) / WINDOW_US)
    {
        let zero = match zero_us {
            None => {
                let zero = fit(&mut errors, chunk, from_us, to_us);
                first_zero_us = zero;
                zero
            }
            Some(last) => fit(&mut errors, chunk, last - 5_000.0, last + 45_000.0),
        };
        found.extend(errors(chunk, zero));
        zero_us = Some(zero);
    }
    let last_zero_us = zero_us.unwrap_or(first_zero_us);
    let count = found.len();
    let (p50, p99, max) = percentiles(&mut found);
    println!(
        "  against the bridge's own filtered motion (its recording, {recorded_ms} ms; time 0 \
         on the simulation's clock {:.2} ms after the record request was sent (window \
         {:.1} ms), {:.1} ms later by the last quarter second: periods the bridge skipped): {count} \
         ball samples: p50 {p50:.2} mm, p99 {p99:.2} mm, max {max:.2} mm",
        (first_zero_us - from_us) / 1000.0,
        (to_us - from_us) / 1000.0,
        (last_zero_us - first_zero_us) / 1000.0
    );
}

/// Prints the largest error of `samples` of ball 0 against the filtered input and the
/// raw input (see the module's doc).
fn compare(inputs: &[(Instant, f64)], samples: &[(Instant, f64)], first_mm: f64, what: &str) {
    // The filter offline, every 20 ms from the first input, on the latest value sent.
    let filter = MotionFilter::new(FilterLimits {
        travel_mm: TRAVEL_MM,
        max_speed_mm_s: TOP_SPEED_MM_S,
        max_accel_mm_s2: ACCEL_MM_S2,
        dt_ms: PERIOD_MS as u32,
    })
    .expect("a filter");
    let origin = inputs[0].0;
    let step_s = PERIOD_MS as f64 / 1000.0;
    let end_s = (samples.last().expect("samples").0 - origin).as_secs_f64();
    // The filter's steps at `phase_s` + k × 20 ms from the first packet: the
    // positions at those instants.
    let run = |phase_s: f64| -> Vec<f64> {
        let mut state = BallState::at_rest(first_mm);
        let mut filtered = vec![first_mm];
        let mut next_input = 0;
        let mut target = first_mm;
        let mut t_s = phase_s;
        while t_s < end_s + 0.5 {
            while next_input < inputs.len() && (inputs[next_input].0 - origin).as_secs_f64() <= t_s
            {
                target = inputs[next_input].1;
                next_input += 1;
            }
            filter.step(&mut state, Some(target), None);
            filtered.push(state.position_mm);
            t_s += step_s;
        }
        filtered
    };
    let interpolate = |filtered: &[f64], phase_s: f64, t_s: f64| -> f64 {
        if t_s <= phase_s {
            return first_mm;
        }
        let index = (t_s - phase_s) / step_s;
        let below = index.floor() as usize;
        let fraction = index - index.floor();
        let a = filtered[below.min(filtered.len() - 1)];
        let b = filtered[(below + 1).min(filtered.len() - 1)];
        a + (b - a) * fraction
    };
    let raw_at = |t_s: f64| -> f64 {
        let index = inputs.partition_point(|(at, _)| (*at - origin).as_secs_f64() <= t_s);
        if index == 0 {
            first_mm
        } else {
            inputs[index - 1].1
        }
    };
    // Samples from the fader's first packet on.
    let times: Vec<(f64, f64)> = samples
        .iter()
        .filter(|(at, _)| *at > origin)
        .map(|(at, ball)| ((*at - origin).as_secs_f64(), *ball))
        .collect();
    let worst = |lag_s: f64, of: &dyn Fn(f64) -> f64| -> f64 {
        times
            .iter()
            .map(|(t, ball)| (ball - of(t - lag_s)).abs())
            .fold(0.0, f64::max)
    };
    // The phase of the filter's steps (0–18 ms, 2 ms apart) and the lag (0–150 ms,
    // 5 ms apart) that give the smallest largest error.
    let (phase_ms, lag_ms, error_mm, filtered) = (0..10)
        .map(|phase| {
            let phase_s = f64::from(phase) * 0.002;
            let filtered = run(phase_s);
            let (lag_ms, error_mm) = (0..=30)
                .map(|step| {
                    let lag_ms = f64::from(step) * 5.0;
                    let at = |t_s: f64| interpolate(&filtered, phase_s, t_s);
                    (lag_ms, worst(lag_ms / 1000.0, &at))
                })
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .expect("lags");
            (phase_s * 1000.0, lag_ms, error_mm, filtered)
        })
        .min_by(|a, b| a.2.total_cmp(&b.2))
        .expect("phases");
    let filtered_at = |t_s: f64| interpolate(&filtered, phase_ms / 1000.0, t_s);
    let mut errors: Vec<f64> = times
        .iter()
        .map(|(t, ball)| (ball - filtered_at(t - lag_ms / 1000.0)).abs())
        .collect();
    let (p50, p99, _) = percentiles(&mut errors);
    let raw_mm = worst(lag_ms / 1000.0, &raw_at);
    let raw_at_best = (0..=30)
        .map(|step| worst(f64::from(step) * 0.005, &raw_at))
        .fold(f64::INFINITY, f64::min);
    println!(
        "  {what}: {} samples of ball 0, {} packets: against the filtered input (steps at \
         {phase_ms:.0} ms + k × 20 ms, lagged {lag_ms:.0} ms): max {error_mm:.1} mm (p50 {p50:.2} mm, p99 {p99:.1} mm); against the raw input: max \
         {raw_mm:.1} mm at that lag ({raw_at_best:.1} mm at its own best lag)",
        times.len(),
        inputs.len()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn live_bench() {
    if std::env::var_os("LIVE_BENCH").is_none() {
        eprintln!("SKIPPED: set LIVE_BENCH=1 (cargo xtask live-bench does)");
        return;
    }
    let only = std::env::var("LIVE_BENCH_ONLY").unwrap_or_default();
    if only.is_empty() || only == "latency" {
        mbox_latency(from_env("LIVE_BENCH_CHANGES", 200)).await;
    }
    if only.is_empty() || only == "uim2503" {
        uim2503_latency(from_env("LIVE_BENCH_UIM2503_CHANGES", 100)).await;
    }
    if only.is_empty() || only == "moons" {
        moons_latency(from_env("LIVE_BENCH_MOONS_CHANGES", 100)).await;
    }
    if only.is_empty() || only == "cpu" {
        cpu(from_env("LIVE_BENCH_CPU_SECONDS", 20)).await;
    }
    if only.is_empty() || only == "error" {
        position_error(from_env("LIVE_BENCH_ERROR_SECONDS", 60)).await;
    }
}
