//! `cargo xtask timecode-bench [--seconds N]`: the timecode chase's figures. Runs only
//! when `TIMECODE_BENCH_SECONDS` is set (the xtask sets it; default 300): otherwise it
//! says so and passes at once. Nothing about speed is asserted.
//!
//! Through the real `floatball` binary on each family's simulated matrix (1 × 3 balls:
//! UIM2503 at 115200 baud, MBOX, MOONS' with `tolerance_mm = 100` — a wave of 300
//! one-second periods is more than a drive's 12 segments of 62 lines follow within
//! 50 mm; the figures are about time), Art-Net timecode at 25 fps from this bench
//! (the shared encoder) on the loopback, the playlist's timecode start 10:00:00:00:
//! - **chasing error**: a wave of N seconds chased from its cue; every chase status
//!   while `chasing` gives the offset of the show's time from the timecode (the
//!   status's show time, extrapolated to the instant the chase looks, against the
//!   timecode then): p50, p99 and max of its size, with the drift over the show;
//! - **lead**: the lead the chase measured at the cue (from the Start it issued to the
//!   show's clock at the cue's time: approach and preload), and how far from the
//!   timecode the show started (the first offset);
//! - **locate**: on a 10 × 10 matrix of UIM2503 units (ten gateways of ten at 115200
//!   baud), the time from a jump of the timecode to the chase `chasing` again at the
//!   new point (stop, home, approach, play), for the first locate (its lead estimated)
//!   and the second (measured).
//!
//! `TIMECODE_BENCH_FAMILY` (`UIM2503`, `MBOX`, `MOONS'`) runs the chase of one family
//! only (then the locate); `TIMECODE_BENCH_LOCATE_ONLY` the locate only;
//! `TIMECODE_BENCH_NO_LOCATE` the chases only. `TIMECODE_BENCH_FAST_PPM` runs the
//! sender's clock that much fast (the drift to correct); `TIMECODE_BENCH_UNCORRECTED`
//! sets `correct_drift = false` (the drift as it was). The sender sends each frame
//! as it begins.

use crate::common;

use std::net::UdpSocket;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use common::native_show;
use common::process::{Process, links_up};
use common::{Ws, next_message};
use floatball_shared::api::{PlayerState, ServerMessage, Status};
use floatball_shared::timecode::chase::{ChaseState, TimecodeStatus};
use floatball_shared::timecode::{FrameRate, Timecode, artnet};

const CUE_MS: u64 = 10 * 3_600_000;

/// A wave of `depth_mm` below 300 mm (a run-up into it stays inside the travel), a
/// period a second, each column 0.1 s after the one before, rows of 100 ms.
fn wave(rows: u32, cols: u32, duration_ms: u64, depth_mm: f64) -> Vec<u8> {
    use std::f64::consts::{PI, TAU};
    let steps = (duration_ms / 100).max(2);
    let units = (0..rows * cols)
        .map(|unit| {
            let delay_s = f64::from(unit % cols) * 0.1;
            let active_s = (duration_ms as f64 / 1000.0 - 1.0 - delay_s)
                .floor()
                .max(0.0);
            let track: Vec<serde_json::Value> = (1..=steps)
                .map(|step| {
                    let local_s = step as f64 / 10.0 - delay_s;
                    if local_s <= 0.0 || local_s >= active_s {
                        return serde_json::json!([300.0, 0.0, 100]);
                    }
                    let angle = local_s * TAU;
                    serde_json::json!([
                        300.0 + depth_mm * (1.0 - angle.cos()) / 2.0,
                        depth_mm * PI * angle.sin(),
                        100
                    ])
                })
                .collect();
            serde_json::json!({ "start_mm": 300.0, "rows": track })
        })
        .collect();
    native_show("bench", rows, cols, units)
}

/// Art-Net timecode at 25 fps to `to`, from a thread; can jump.
struct Sender {
    base_ms: Arc<AtomicU64>,
    epoch: Instant,
    running: Arc<AtomicBool>,
}

impl Sender {
    fn start(to: std::net::SocketAddr, from_ms: u64) -> Self {
        let epoch = Instant::now();
        let base_ms = Arc::new(AtomicU64::new(from_ms));
        let running = Arc::new(AtomicBool::new(true));
        let (base, run) = (Arc::clone(&base_ms), Arc::clone(&running));
        let fast_ppm = fast_ppm();
        std::thread::spawn(move || {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
            // Its own clock, `fast_ppm` faster than the machine's; each frame sent as
            // it begins, as a timecode source does.
            let now_ms = || {
                base.load(Ordering::SeqCst)
                    + epoch.elapsed().as_micros() as u64 * (1_000_000 + fast_ppm) / 1_000_000_000
            };
            while run.load(Ordering::SeqCst) {
                let now = now_ms();
                let next = (now / 40 + 1) * 40;
                let wait_us = (next - now) * 1_000_000_000 / (1_000_000 + fast_ppm);
                std::thread::sleep(Duration::from_micros(wait_us));
                let _ = socket.send_to(
                    &artnet::encode(Timecode::from_ms(now_ms(), FrameRate::Ebu25)),
                    to,
                );
            }
        });
        Self {
            base_ms,
            epoch,
            running,
        }
    }

    fn jump(&self, to_ms: u64) {
        let elapsed =
            self.epoch.elapsed().as_micros() as u64 * (1_000_000 + fast_ppm()) / 1_000_000_000;
        self.base_ms.store(to_ms - elapsed, Ordering::SeqCst);
    }
}

impl Drop for Sender {
    fn drop(&mut self) {
        self.running.store(false, Ordering::SeqCst);
    }
}

/// How much faster the sender's clock runs than the machine's, ppm
/// (`TIMECODE_BENCH_FAST_PPM`, default 0).
fn fast_ppm() -> u64 {
    std::env::var("TIMECODE_BENCH_FAST_PPM")
        .ok()
        .and_then(|ppm| ppm.parse().ok())
        .unwrap_or(0)
}

/// Whether the chase corrects the drift (`TIMECODE_BENCH_UNCORRECTED` unset).
fn correct_drift() -> bool {
    std::env::var_os("TIMECODE_BENCH_UNCORRECTED").is_none()
}

/// A bridge chasing Art-Net timecode on a free port, its show uploaded.
async fn bridge(matrix_and_gateways: &str, show: &[u8]) -> (Process, Ws, std::net::SocketAddr) {
    let port = UdpSocket::bind("127.0.0.1:0")
        .and_then(|socket| socket.local_addr())
        .expect("a port")
        .port();
    let config = format!(
        "{matrix_and_gateways}[timecode]\nsource = \"artnet\"\nlisten = \"127.0.0.1:{port}\"\n\
         rate = \"25\"\nstart = \"10:00:00:00\"\nloss_ms = 1000\nlocate_threshold_ms = 150\n\
         lead_ms = 2000\ncorrect_drift = {}\n",
        correct_drift()
    );
    let bridge = Process::start(&config);
    let token = bridge.prepare_show("bench", show, false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    (bridge, ws, ([127, 0, 0, 1], port).into())
}

/// The next status or chase message.
async fn next(ws: &mut Ws, status: &mut Option<Status>, chase: &mut Option<TimecodeStatus>) {
    match next_message(ws).await {
        ServerMessage::Status(latest) => *status = Some(latest),
        ServerMessage::Timecode(latest) => *chase = Some(latest),
        _ => {}
    }
}

fn percentile(sorted: &[i64], p: f64) -> i64 {
    if sorted.is_empty() {
        return 0;
    }
    let index = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[index.min(sorted.len() - 1)]
}

/// One family's chase of a `seconds` long wave: prints its figures.
async fn chasing_error(family: &str, gateways: &str, seconds: u64) {
    if std::env::var("TIMECODE_BENCH_FAMILY").is_ok_and(|only| only != family) {
        return;
    }
    let matrix = "[matrix]\nrows = 1\ncols = 3\n[safety]\napproach_speed_mm_s = 2000.0\n";
    let show = wave(1, 3, seconds * 1_000, 100.0);
    let (bridge, mut ws, to) = bridge(&format!("{matrix}{gateways}"), &show).await;
    let _sender = Sender::start(to, CUE_MS - 3_000);
    let (mut status, mut chase) = (None, None);
    let mut offsets = Vec::new();
    let mut first = None;
    let mut last_chase = None;
    let deadline = Instant::now() + Duration::from_secs(seconds + 60);
    let mut played = false;
    let began = Instant::now();
    while Instant::now() < deadline {
        if !played && began.elapsed() > Duration::from_secs(60) {
            println!(
                "{family}: did not play within 60 s: {:?}\n{}",
                last_chase
                    .as_ref()
                    .and_then(|chase: &TimecodeStatus| chase.refused.clone()),
                bridge.log()
            );
            return;
        }
        next(&mut ws, &mut status, &mut chase).await;
        let playing = status
            .as_ref()
            .is_some_and(|status| status.state == PlayerState::Playing);
        played |= playing;
        if played
            && !playing
            && status
                .as_ref()
                .is_some_and(|s| s.state == PlayerState::Idle)
        {
            break;
        }
        if let Some(now) = chase.take() {
            if now.state == ChaseState::Chasing
                && let Some(offset) = now.offset_ms
            {
                first.get_or_insert((now.lead_ms, offset));
                offsets.push(offset.abs());
            }
            last_chase = Some(now);
        }
    }
    offsets.sort_unstable();
    let last = last_chase.unwrap_or_default();
    let (lead, first_offset) = first.unwrap_or_default();
    println!(
        "{family}: chasing {seconds} s (timecode {} ppm fast, drift {}corrected): \
         |show − timecode| p50 {} ms, p99 {} ms, max {} ms over {} chase statuses; locates {}; \
         drift {:?} ms over {} s; lead at the cue {lead} ms, first offset {first_offset:+} ms",
        fast_ppm(),
        if correct_drift() { "" } else { "un" },
        percentile(&offsets, 0.5),
        percentile(&offsets, 0.99),
        offsets.last().copied().unwrap_or_default(),
        offsets.len(),
        last.locates,
        last.drift_ms,
        last.drift_over_ms / 1_000,
    );
    drop(bridge);
}

/// The 10 × 10 locate figure.
async fn locate_time() {
    let mut config =
        String::from("[matrix]\nrows = 10\ncols = 10\n[safety]\napproach_speed_mm_s = 2000.0\n");
    for _ in 0..10 {
        config.push_str("[[gateway]]\nport = \"sim\"\nbaud = 115200\nunits = 10\n");
    }
    let show = wave(10, 10, 120_000, 100.0);
    let (bridge, mut ws, to) = bridge(&config, &show).await;
    let sender = Sender::start(to, CUE_MS - 3_000);
    let (mut status, mut chase) = (None, None);
    let mut seen: Option<TimecodeStatus> = None;
    let deadline = Instant::now() + Duration::from_secs(120);
    // In step first.
    while !seen
        .as_ref()
        .is_some_and(|chase| chase.state == ChaseState::Chasing)
    {
        assert!(Instant::now() < deadline, "{seen:?}\n{}", bridge.log());
        next(&mut ws, &mut status, &mut chase).await;
        if let Some(now) = chase.take() {
            seen = Some(now);
        }
    }
    for (round, to_s) in [(1, 40u64), (2, 80)] {
        let locates = seen.as_ref().map_or(0, |chase| chase.locates);
        sender.jump(CUE_MS + to_s * 1_000);
        let jumped = Instant::now();
        loop {
            assert!(Instant::now() < deadline, "{seen:?}\n{}", bridge.log());
            next(&mut ws, &mut status, &mut chase).await;
            if let Some(now) = chase.take() {
                seen = Some(now);
            }
            let chasing = seen
                .as_ref()
                .is_some_and(|chase| chase.locates > locates && chase.state == ChaseState::Chasing);
            let at_new_point = status.as_ref().is_some_and(|status| {
                status.state == PlayerState::Playing && status.show_time_ms >= to_s * 1_000
            });
            if chasing && at_new_point {
                break;
            }
        }
        let shown = seen.clone().unwrap_or_default();
        println!(
            "UIM2503 10 × 10 at 115200 baud: locate {round} to {to_s} s: playing again in \
             step {:?} after the jump (locates {}, locate lead {} ms, offset {:?} ms)",
            jumped.elapsed(),
            shown.locates,
            shown.locate_lead_ms,
            shown.offset_ms
        );
        // Let it settle before the next.
        let settle = Instant::now() + Duration::from_secs(3);
        while Instant::now() < settle {
            next(&mut ws, &mut status, &mut chase).await;
            if let Some(now) = chase.take() {
                seen = Some(now);
            }
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn timecode_figures() {
    let Some(seconds) = std::env::var("TIMECODE_BENCH_SECONDS")
        .ok()
        .and_then(|seconds| seconds.parse::<u64>().ok())
    else {
        eprintln!("timecode bench: TIMECODE_BENCH_SECONDS is not set (cargo xtask timecode-bench)");
        return;
    };
    if std::env::var_os("TIMECODE_BENCH_LOCATE_ONLY").is_some() {
        locate_time().await;
        return;
    }
    chasing_error(
        "UIM2503",
        "[[gateway]]\nport = \"sim\"\nbaud = 115200\n",
        seconds,
    )
    .await;
    chasing_error(
        "MBOX",
        "[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n",
        seconds,
    )
    .await;
    chasing_error(
        "MOONS'",
        "[scl]\npoll_ms = 50\ntolerance_mm = 100.0\n\
         [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n",
        seconds,
    )
    .await;
    if std::env::var_os("TIMECODE_BENCH_NO_LOCATE").is_none() {
        locate_time().await;
    }
}
