//! One bridge, many UIM2503 gateways of 100 units: the real `floatball` binary plays a
//! ripple show over `tcp://` to `floatball simulate --listen` (a process of its own,
//! one TCP port a gateway, each line at 115200 baud), from the plan report through the
//! approach, the preload, the synchronised start and the streaming to the end, then an
//! e-stop.
//!
//! In the normal test run it is small (3 gateways × 100 units, a 6 s show) and checks
//! that the show plays to its end, that no gateway's FIFO ran dry, that every
//! gateway received its synchronised start and that the e-stop reached every gateway
//! (6 s of rows fit the units' tables; a show streams from 52 s on).
//! `cargo xtask scale-bench [--gateways N] [--seconds S]` runs it at length in a
//! release build (`SCALE_BENCH_GATEWAYS`, `SCALE_BENCH_SECONDS`; 100 × 100 = 10,000
//! balls for 60 s by default) and reads the figures it prints: planning time, preload
//! time, start skew across the gateways, the bridge's CPU while streaming and its peak
//! RSS, the status messages' size and rate, the lowest water level and the underruns.
//! `SCALE_BENCH_LINK=sim` plays to the bridge's in-process simulated gateways instead
//! (no start skew then: the figures of the bridge alone). The bench's WebSocket client
//! turns the feedback relay off, as the app does while its console is closed;
//! `SCALE_BENCH_FEEDBACK=on` keeps it on (every frame of every gateway as JSON, as a
//! console would get).

use crate::common;

use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::Ws;
use common::process::Process;
use common::send_text;
use floatball_shared::api::{PlanReport, PlayerState, ServerMessage, Status};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

const UNITS: usize = 100;
const BAUD: u32 = 115_200;
/// Keyframes of the ripple, ms apart: 100 units' rows at this pace fill about 90 % of
/// a 115200-baud line, and a show longer than 51 s (256 rows, a unit's table) streams.
const KEYFRAME_MS: u64 = 200;

fn from_env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|value| value.parse().ok())
        .filter(|value| *value > 0)
        .unwrap_or(default)
}

/// Whether the gateways are the bridge's own simulated ones (`SCALE_BENCH_LINK=sim`).
fn in_process() -> bool {
    std::env::var("SCALE_BENCH_LINK").is_ok_and(|link| link == "sim")
}

fn config(ports: &[String]) -> String {
    let mut text = format!(
        "[matrix]\nrows = {}\ncols = {UNITS}\n\
         [safety]\napproach_speed_mm_s = 1000.0\n\
         [uploads]\nmax_bytes = 1073741824\n",
        ports.len()
    );
    for port in ports {
        text.push_str(&format!(
            "[[gateway]]\nport = \"{port}\"\nbaud = {BAUD}\nunits = {UNITS}\n"
        ));
    }
    text
}

/// A ripple of `seconds` over `rows` × 100 balls, a keyframe every 200 ms: rings
/// travel out from the middle, ±150 mm around 500 mm, fading in over the first two
/// seconds and out over the last two (every ball at 500 mm at both ends).
fn ripple_csv(rows: usize, seconds: u64) -> Vec<u8> {
    use std::fmt::Write as _;
    let mut csv = format!("# rows={rows} cols={UNITS} pitch_mm=500\ntime_ms");
    for unit in 0..rows * UNITS {
        write!(csv, ",u{unit}").expect("write to a string");
    }
    csv.push('\n');
    let (middle_row, middle_col) = (rows as f64 / 2.0, UNITS as f64 / 2.0);
    let end_ms = seconds * 1000;
    for time_ms in (0..=end_ms).step_by(KEYFRAME_MS as usize) {
        write!(csv, "{time_ms}").expect("write to a string");
        let time_s = time_ms as f64 / 1000.0;
        let fade = (time_s / 2.0)
            .min((end_ms - time_ms) as f64 / 2000.0)
            .clamp(0.0, 1.0);
        for unit in 0..rows * UNITS {
            let (row, col) = ((unit / UNITS) as f64, (unit % UNITS) as f64);
            let distance = (row - middle_row).hypot(col - middle_col);
            let angle = std::f64::consts::TAU * (time_s / 4.0 - distance / 12.0);
            write!(csv, ",{:.1}", 500.0 + 150.0 * fade * angle.sin()).expect("write");
        }
        csv.push('\n');
    }
    csv.into_bytes()
}

/// The user and system CPU time of process `pid` so far.
fn cpu_time(pid: u32) -> Duration {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).expect("/proc/<pid>/stat");
    // The fields after the command's closing parenthesis: state is the 3rd field, utime
    // and stime the 14th and 15th.
    let fields: Vec<&str> = stat
        .rsplit_once(')')
        .map(|(_, rest)| rest.split_whitespace().collect())
        .unwrap_or_default();
    let ticks: u64 =
        fields[11].parse::<u64>().expect("utime") + fields[12].parse::<u64>().expect("stime");
    // Linux reports them in USER_HZ, 100 a second on every architecture it runs on.
    Duration::from_millis(ticks * 10)
}

/// A size from `/proc/<pid>/status` (`VmHWM`: the peak resident set; `VmRSS`: now),
/// bytes.
fn memory_bytes(pid: u32, field: &str) -> u64 {
    let status =
        std::fs::read_to_string(format!("/proc/{pid}/status")).expect("/proc/<pid>/status");
    status
        .lines()
        .find_map(|line| line.strip_prefix(field)?.strip_prefix(':'))
        .and_then(|value| {
            value
                .trim()
                .trim_end_matches("kB")
                .trim()
                .parse::<u64>()
                .ok()
        })
        .unwrap_or_else(|| panic!("{field} in /proc/{pid}/status"))
        * 1024
}

/// `floatball simulate --listen`: `gateways` simulated UIM2503 gateways of 100 units,
/// each on its own TCP port; every synchronised start it received, gateway by gateway,
/// with the time (unix ns) its last byte arrived.
/// Per gateway, every start it received: (arrived at its socket, read), Unix ns.
type Starts = Vec<Vec<(u64, u64)>>;

struct Simulator {
    child: Child,
    ports: Vec<u16>,
    starts_ns: Arc<Mutex<Starts>>,
}

impl Simulator {
    /// Starts `floatball simulate` at a lower scheduling priority (`nice -n 10`): it
    /// stands in for a hundred gateways that are devices of their own, so it takes the
    /// CPU the bridge leaves rather than preempting it on a machine of two cores.
    fn start(gateways: usize) -> Self {
        let mut child = Command::new("nice")
            .args(["-n", "10", env!("CARGO_BIN_EXE_floatball")])
            .args(["simulate", "--kind", "uim2503", "--listen", "127.0.0.1:0"])
            .args(["--gateways", &gateways.to_string()])
            .args(["--baud", &BAUD.to_string(), "--units", &UNITS.to_string()])
            .env("RUST_LOG", "warn")
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start floatball simulate");
        let mut lines = BufReader::new(child.stdout.take().expect("stdout")).lines();
        let mut ports = vec![0; gateways];
        let mut listening = 0;
        while listening < gateways {
            let line = lines
                .next()
                .expect("the simulator said where it listens")
                .expect("stdout line");
            if let Some((gateway, port)) = listening_port(&line) {
                ports[gateway] = port;
                listening += 1;
            }
        }
        let starts_ns = Arc::new(Mutex::new(vec![Vec::new(); gateways]));
        let seen = Arc::clone(&starts_ns);
        std::thread::spawn(move || {
            for line in lines.map_while(Result::ok) {
                if let Some((gateway, at_ns)) = start_received(&line)
                    && let Some(starts) = seen.lock().expect("starts").get_mut(gateway)
                {
                    starts.push(at_ns);
                }
            }
        });
        Self {
            child,
            ports,
            starts_ns,
        }
    }

    fn pid(&self) -> u32 {
        self.child.id()
    }

    fn starts_ns(&self) -> Starts {
        self.starts_ns.lock().expect("starts").clone()
    }
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// `floatball simulating gateway G with U units at B baud on tcp 127.0.0.1:PORT`:
/// (G, PORT).
fn listening_port(line: &str) -> Option<(usize, u16)> {
    let rest = line.strip_prefix("floatball simulating gateway ")?;
    let gateway = rest.split_whitespace().next()?.parse().ok()?;
    let socket = rest.rsplit_once(" on tcp ")?.1;
    let port = socket.trim().rsplit_once(':')?.1.parse().ok()?;
    Some((gateway, port))
}

/// `gateway G: start received at UNIX_NS ns, read at READ_NS ns`: (G, (UNIX_NS, READ_NS)).
fn start_received(line: &str) -> Option<(usize, (u64, u64))> {
    let rest = line.strip_prefix("gateway ")?;
    let (gateway, rest) = rest.split_once(": start received at ")?;
    let (at_ns, read_ns) = rest.strip_suffix(" ns")?.split_once(" ns, read at ")?;
    Some((
        gateway.parse().ok()?,
        (at_ns.trim().parse().ok()?, read_ns.trim().parse().ok()?),
    ))
}

/// Every status seen: when, how large, what.
struct Seen {
    at: Instant,
    bytes: usize,
    status: Status,
}

/// What came over the WebSocket.
#[derive(Default)]
struct Log {
    statuses: Vec<Seen>,
    /// Messages other than statuses (feedback frames: every gateway acknowledges every
    /// instruction, and every client is sent every frame), and their bytes.
    others: usize,
    other_bytes: usize,
}

/// Reads statuses into `log` until `wanted` holds for one; panics after `limit`.
async fn watch(
    ws: &mut Ws,
    log: &mut Log,
    limit: Duration,
    wanted: impl Fn(&Status) -> bool,
) -> Status {
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        let frame = tokio::time::timeout_at(deadline, ws.next())
            .await
            .unwrap_or_else(|_| {
                let last = log.statuses.last().map(|seen| &seen.status);
                panic!("no such status within {limit:?}; the last: {last:?}")
            })
            .expect("open")
            .expect("frame");
        let Message::Text(text) = frame else {
            continue;
        };
        if !text.as_str().starts_with(r#"{"type":"status""#) {
            log.others += 1;
            log.other_bytes += text.len();
            continue;
        }
        if let Ok(ServerMessage::Status(status)) = serde_json::from_str(text.as_str()) {
            let found = wanted(&status);
            log.statuses.push(Seen {
                at: Instant::now(),
                bytes: text.len(),
                status,
            });
            if found {
                return log.statuses.last().expect("just pushed").status.clone();
            }
        }
    }
}

fn quantile(sorted: &[f64], q: f64) -> f64 {
    let index = ((sorted.len() as f64 * q).ceil() as usize).clamp(1, sorted.len()) - 1;
    sorted[index]
}

/// What a run found.
struct Outcome {
    /// The synchronised starts each gateway received (empty in process).
    starts: Vec<usize>,
    lowest_water_level: Option<u16>,
    underruns: usize,
    reached_end: bool,
    estop_everywhere: bool,
}

async fn bench(gateways: usize, seconds: u64) -> Outcome {
    let began = Instant::now();
    let simulator = (!in_process()).then(|| Simulator::start(gateways));
    let ports: Vec<String> = match &simulator {
        Some(simulator) => simulator
            .ports
            .iter()
            .map(|port| format!("tcp://127.0.0.1:{port}"))
            .collect(),
        None => vec!["sim".to_owned(); gateways],
    };
    let bridge = Process::start(&config(&ports));
    let csv = ripple_csv(gateways, seconds);
    let uploading = Instant::now();
    let token = bridge
        .prepare_upload("ripple", "text/csv", &csv, false)
        .await;
    let upload_s = uploading.elapsed().as_secs_f64();
    let planning = Instant::now();
    let reply = bridge
        .request(Method::GET, "/api/plan/ripple", Some(&token), None)
        .await;
    let planning_s = planning.elapsed().as_secs_f64();
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let plan: PlanReport = reply.json();
    assert!(plan.feasible, "{plan:?}");
    let busiest = plan
        .gateways
        .iter()
        .max_by(|a, b| a.needed_bytes_per_s.total_cmp(&b.needed_bytes_per_s))
        .expect("a gateway");
    let mut ws = bridge.ws(&token).await;
    let relay = std::env::var("SCALE_BENCH_FEEDBACK").is_ok_and(|value| value == "on");
    send_text(
        &mut ws,
        &format!(r#"{{"type":"feedback","relay":{relay}}}"#),
    )
    .await;
    let mut log = Log::default();
    watch(&mut ws, &mut log, Duration::from_secs(30), |status| {
        status.gateway_summary.total as usize == gateways
            && status.gateway_summary.up as usize == gateways
    })
    .await;
    println!(
        "scale-bench: {gateways} gateways × {UNITS} units ({} balls) over {}, {seconds} s ripple: \
         {:.1} MB CSV uploaded in {upload_s:.2} s, links up after {:.1} s",
        gateways * UNITS,
        if in_process() { "sim" } else { "tcp://" },
        csv.len() as f64 / 1e6,
        began.elapsed().as_secs_f64(),
    );
    // The bridge arms the first entry once the playlist is quiet: wait for it so that
    // the preload is measured whole, whether it happens before Start or after.
    let arming = Instant::now();
    let armed = watch(&mut ws, &mut log, Duration::from_secs(120), |status| {
        status
            .armed
            .as_ref()
            .is_some_and(|armed| armed.progress >= 1.0)
    })
    .await;
    let armed_s = arming.elapsed().as_secs_f64();
    let preload_from = log
        .statuses
        .iter()
        .find(|seen| seen.status.armed.is_some())
        .map_or(arming, |seen| seen.at);
    let preload_s = log
        .statuses
        .last()
        .expect("seen")
        .at
        .duration_since(preload_from)
        .as_secs_f64();
    assert!(armed.armed.is_some());
    let starting = Instant::now();
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let playing = watch(&mut ws, &mut log, Duration::from_secs(120), |status| {
        matches!(status.state, PlayerState::Playing | PlayerState::Error)
    })
    .await;
    assert_eq!(
        playing.state,
        PlayerState::Playing,
        "{:?}\n{}",
        playing.last_error,
        bridge.log()
    );
    let start_s = starting.elapsed().as_secs_f64();
    // Measure while streaming.
    let streaming_from = (log.statuses.len(), log.others, log.other_bytes);
    let (cpu_before, window) = (cpu_time(bridge.pid()), Instant::now());
    let simulator_cpu = simulator
        .as_ref()
        .map(|simulator| cpu_time(simulator.pid()));
    let done = watch(
        &mut ws,
        &mut log,
        Duration::from_secs(seconds + 60),
        |status| status.state != PlayerState::Playing,
    )
    .await;
    let elapsed_s = window.elapsed().as_secs_f64();
    let streaming_rss_mb = memory_bytes(bridge.pid(), "VmRSS") as f64 / 1e6;
    let bridge_cpu = (cpu_time(bridge.pid()) - cpu_before).as_secs_f64();
    let simulator_cpu = simulator
        .as_ref()
        .zip(simulator_cpu)
        .map(|(simulator, before)| (cpu_time(simulator.pid()) - before).as_secs_f64());
    let reached_end = done.state == PlayerState::Idle && done.last_error.is_none();
    let streaming = &log.statuses[streaming_from.0..];
    let (others, other_bytes) = (
        log.others - streaming_from.1,
        log.other_bytes - streaming_from.2,
    );
    let status_bytes: Vec<usize> = streaming.iter().map(|seen| seen.bytes).collect();
    let lowest_water_level = log
        .statuses
        .iter()
        .filter(|seen| seen.status.state == PlayerState::Playing)
        .filter_map(|seen| seen.status.gateway_summary.lowest_water_level)
        .min();
    // A FIFO modelled empty when a refill landed (the player's model, lowered by the
    // units' watermark notices).
    let underruns = usize::from(lowest_water_level == Some(0));
    // The e-stop, then every gateway must have been told.
    let pressing = Instant::now();
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let stopped = watch(&mut ws, &mut log, Duration::from_secs(10), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    let estop_ms = pressing.elapsed().as_secs_f64() * 1000.0;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let log = bridge.log();
    let estop_everywhere = !log.contains("did not reach") && stopped.last_error.is_none();
    let rss_mb = memory_bytes(bridge.pid(), "VmHWM") as f64 / 1e6;
    drop(ws);
    let starts_ns = simulator
        .as_ref()
        .map(Simulator::starts_ns)
        .unwrap_or_default();
    println!(
        "scale-bench:   planning (GET /api/plan): {planning_s:.2} s; preload (armed ahead of Start): \
         {preload_s:.2} s ({armed_s:.1} s from upload to armed; planned {} ms); Start → playing {start_s:.2} s\n\
         scale-bench:   the busiest line: {:.0} of {:.0} B/s, {:.1} B a unit-row, lowest water level on paper {}",
        plan.preload_ms,
        busiest.needed_bytes_per_s,
        busiest.available_bytes_per_s,
        busiest.bytes_per_row,
        busiest.lowest_water_level.map_or(
            "- (no streaming: every row preloaded)".to_owned(),
            |level| format!("{level} rows")
        ),
    );
    if let Some(first) = starts_ns
        .iter()
        .map(|starts| starts.first().copied())
        .collect::<Option<Vec<(u64, u64)>>>()
        .filter(|first| !first.is_empty())
    {
        let skew = |times_ns: Vec<u64>| {
            let earliest = times_ns.iter().min().copied().unwrap_or_default();
            let mut offsets_ms: Vec<f64> = times_ns
                .iter()
                .map(|at_ns| (at_ns - earliest) as f64 / 1e6)
                .collect();
            offsets_ms.sort_by(f64::total_cmp);
            format!(
                "p50 {:.2} ms, p99 {:.2} ms, spread (max) {:.2} ms",
                quantile(&offsets_ms, 0.5),
                quantile(&offsets_ms, 0.99),
                offsets_ms.last().copied().unwrap_or_default(),
            )
        };
        println!(
            "scale-bench:   start skew over {} gateways (last byte of *0;BG; at each simulated \
             gateway's socket, after the first gateway's): {}",
            first.len(),
            skew(first.iter().map(|(at_ns, _)| *at_ns).collect()),
        );
        println!(
            "scale-bench:   (the same, as the simulator's threads read it: {})",
            skew(first.iter().map(|(_, read_ns)| *read_ns).collect()),
        );
    } else if !starts_ns.is_empty() {
        println!(
            "scale-bench:   start skew: not every gateway received a start: {:?}",
            starts_ns.iter().map(Vec::len).collect::<Vec<_>>()
        );
    }
    println!(
        "scale-bench:   bridge CPU while streaming: {:.1} % of one core over {elapsed_s:.1} s{}; peak RSS (VmHWM) {rss_mb:.1} MB, \
         {streaming_rss_mb:.1} MB at the show's end (VmRSS)",
        100.0 * bridge_cpu / elapsed_s,
        simulator_cpu.map_or(String::new(), |cpu| format!(
            " (the simulator: {:.1} %)",
            100.0 * cpu / elapsed_s
        )),
    );
    println!(
        "scale-bench:   status over WebSocket while streaming: {} messages = {:.1}/s, {:.0} B average, {} B largest",
        status_bytes.len(),
        status_bytes.len() as f64 / elapsed_s,
        status_bytes.iter().sum::<usize>() as f64 / status_bytes.len().max(1) as f64,
        status_bytes.iter().max().copied().unwrap_or_default(),
    );
    println!(
        "scale-bench:   other messages over WebSocket while streaming (feedback frames, relay {}): {:.0}/s, {:.0} kB/s",
        if relay { "on" } else { "off, as the app" },
        others as f64 / elapsed_s,
        other_bytes as f64 / elapsed_s / 1000.0,
    );
    println!(
        "scale-bench:   lowest water level {} rows; underruns {underruns}; show {}; e-stop answered in {estop_ms:.0} ms, {}",
        lowest_water_level.map_or("-".to_owned(), |level| level.to_string()),
        if reached_end {
            "played to its end"
        } else {
            "did NOT play to its end"
        },
        if estop_everywhere {
            "sent to every gateway"
        } else {
            "NOT sent to every gateway"
        },
    );
    if !reached_end {
        println!("{:?}\n{log}", done.last_error);
    }
    Outcome {
        starts: starts_ns.iter().map(Vec::len).collect(),
        lowest_water_level,
        underruns,
        reached_end,
        estop_everywhere,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_ripple_plays_to_its_end_on_every_gateway() {
    let gateways = from_env("SCALE_BENCH_GATEWAYS", 3) as usize;
    let seconds = from_env("SCALE_BENCH_SECONDS", 6);
    let outcome = bench(gateways, seconds).await;
    assert!(outcome.reached_end);
    assert_eq!(outcome.underruns, 0, "{:?}", outcome.lowest_water_level);
    assert!(outcome.estop_everywhere);
    if !in_process() {
        assert_eq!(outcome.starts, vec![1; gateways]);
    }
}

#[test]
fn the_simulators_lines_are_read() {
    assert_eq!(
        listening_port(
            "floatball simulating gateway 7 with 100 units at 115200 baud on tcp 127.0.0.1:40007"
        ),
        Some((7, 40007))
    );
    assert_eq!(
        start_received(
            "gateway 2: start received at 1764000000123456789 ns, read at 1764000000123556789 ns"
        ),
        Some((2, (1_764_000_000_123_456_789, 1_764_000_000_123_556_789)))
    );
    assert_eq!(
        start_received("gateway 2: stored BDR=9600; it takes effect at its restart (SIGHUP)"),
        None
    );
}
