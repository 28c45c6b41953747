//! The MBOX sender under load: the real `floatball` binary streaming a show to many
//! 10-axis twins (`floatball simulate --kind mbox`, a process of their own) on
//! loopback at a 20 ms frame period.
//!
//! In the normal test run it is short (20 boxes, 2 s of play) and checks that every
//! frame was sent and that every box received every frame — nothing lost, no timing
//! asserted. `cargo xtask mbox-bench [--boxes N] [--seconds S]` runs it at length in
//! a release build (`MBOX_BENCH_BOXES`, `MBOX_BENCH_SECONDS`) and reads the figures
//! it prints: the bridge's CPU use, frames per second, how late the frames left
//! (p50/p99/max, from `GET /api/mbox/timing`) and the late frames.

use crate::common;

use std::time::{Duration, Instant};

use common::mbox_sim::Simulator;
use common::process::{Process, links_up};
use common::{send_text, until};
use floatball_bridge::ports::mbox::MboxTiming;
use floatball_shared::api::PlayerState;

const PERIOD_MS: u64 = 20;
const AXES: usize = 10;

fn from_env(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|value| value.parse().ok())
        .filter(|value| *value > 0)
        .unwrap_or(default)
}

fn config(sockets: &[std::net::SocketAddr]) -> String {
    let mut text = format!(
        "[matrix]\nrows = {}\ncols = {AXES}\n\
         [safety]\napproach_speed_mm_s = 1000.0\n\
         [uploads]\nmax_bytes = 1073741824\n\
         [mbox]\nhost_port = 0\nframe_period_ms = {PERIOD_MS}\n",
        sockets.len()
    );
    for socket in sockets {
        text.push_str(&format!(
            "[[gateway]]\nkind = \"mbox\"\naddress = \"{socket}\"\naxes = {AXES}\n"
        ));
    }
    text
}

/// A gentle wave of `seconds` over `boxes` × 10 balls, a keyframe a second: every ball
/// swings ±50 mm around 100 mm.
fn wave_csv(boxes: usize, seconds: u64) -> Vec<u8> {
    use std::fmt::Write as _;
    let units = boxes * AXES;
    let mut csv = format!("# rows={boxes} cols={AXES} pitch_mm=500\ntime_ms");
    for unit in 0..units {
        write!(csv, ",u{unit}").expect("write to a string");
    }
    csv.push('\n');
    for second in 0..=seconds {
        write!(csv, "{}", second * 1000).expect("write to a string");
        for unit in 0..units {
            let phase = (unit % AXES) as f64 * 0.6;
            let angle = std::f64::consts::TAU * second as f64 / 4.0 + phase;
            let swing = if second == 0 || second == seconds {
                0.0
            } else {
                50.0 * angle.sin()
            };
            write!(csv, ",{:.0}", 100.0 + swing).expect("write to a string");
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

async fn timing(bridge: &Process, token: &str) -> MboxTiming {
    let reply = bridge
        .request(
            axum::http::Method::GET,
            "/api/mbox/timing",
            Some(token),
            None,
        )
        .await;
    assert_eq!(reply.status, axum::http::StatusCode::OK, "{:?}", reply.body);
    reply.json()
}

/// Streams a show to `boxes` twins and measures `seconds` of play; returns the frames
/// sent over the whole run and those the twins received, box by box.
async fn bench(boxes: usize, seconds: u64) -> (u64, Vec<u64>) {
    let started = Instant::now();
    let (simulator, sockets) = Simulator::start(AXES as u8, boxes, 0);
    let bridge = Process::start(&config(&sockets));
    let token = bridge
        .prepare_upload("wave", "text/csv", &wave_csv(boxes, seconds + 2), false)
        .await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    println!(
        "mbox-bench: {boxes} boxes × {AXES} axes up after {:.1} s",
        started.elapsed().as_secs_f64()
    );
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (_, playing) = until(&mut ws, Duration::from_secs(120), |status| {
        matches!(status.state, PlayerState::Playing | PlayerState::Error)
    })
    .await;
    assert_eq!(
        playing.state,
        PlayerState::Playing,
        "{:?}",
        playing.last_error
    );
    drop(ws);
    // Let the first frames of the show go out, then measure.
    tokio::time::sleep(Duration::from_millis(500)).await;
    let before = timing(&bridge, &token).await;
    let (bridge_cpu, twins_cpu) = (cpu_time(bridge.pid()), cpu_time(simulator.pid()));
    let window = Instant::now();
    tokio::time::sleep(Duration::from_secs(seconds)).await;
    let after = timing(&bridge, &token).await;
    let elapsed = window.elapsed().as_secs_f64();
    let bridge_cpu = (cpu_time(bridge.pid()) - bridge_cpu).as_secs_f64();
    let twins_cpu = (cpu_time(simulator.pid()) - twins_cpu).as_secs_f64();
    let frames = after.frames_sent - before.frames_sent;
    let datagrams = after.datagrams_sent - before.datagrams_sent;
    println!(
        "mbox-bench: {boxes} boxes ({} axes), {PERIOD_MS} ms period, {elapsed:.1} s measured while playing\n\
         mbox-bench:   frames sent {frames} = {:.2}/s (expected {:.2}/s), datagrams {:.0}/s\n\
         mbox-bench:   send lateness of a frame's first datagram vs its slot: p50 ≤ {} µs, p99 ≤ {} µs, max {} µs (whole run)\n\
         mbox-bench:   longest frame, first to last datagram: {} µs (whole run)\n\
         mbox-bench:   late frames (> half a period): {}\n\
         mbox-bench:   CPU: bridge {:.1} % of one core, twins' process {:.1} %",
        boxes * AXES,
        frames as f64 / elapsed,
        1000.0 / PERIOD_MS as f64,
        datagrams as f64 / elapsed,
        after.lateness_quantile_us(&before, 0.5),
        after.lateness_quantile_us(&before, 0.99),
        after.max_lateness_us,
        after.max_spread_us,
        after.late_frames - before.late_frames,
        100.0 * bridge_cpu / elapsed,
        100.0 * twins_cpu / elapsed,
    );
    // The show plays to its end, then every box tells what it received.
    let mut ws = bridge.ws(&token).await;
    until(&mut ws, Duration::from_secs(60), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let sent = timing(&bridge, &token).await.frames_sent;
    let received: Vec<u64> = simulator
        .stop()
        .iter()
        .map(|one| one.counters.motion_frames)
        .collect();
    let lost: u64 = received
        .iter()
        .map(|count| sent.saturating_sub(*count))
        .sum();
    println!(
        "mbox-bench:   whole run: {sent} frames sent to each box, {lost} of {} datagrams lost on the way",
        sent * boxes as u64
    );
    (sent, received)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_frame_reaches_every_box() {
    let boxes = from_env("MBOX_BENCH_BOXES", 20) as usize;
    let seconds = from_env("MBOX_BENCH_SECONDS", 2);
    let (sent, received) = bench(boxes, seconds).await;
    assert!(sent > seconds * 1000 / PERIOD_MS, "{sent} frames");
    // The length of a run (`cargo xtask mbox-bench`) reports what it lost instead.
    if std::env::var_os("MBOX_BENCH_BOXES").is_none() {
        assert!(received.iter().all(|count| *count == sent), "{received:?}");
    }
}
