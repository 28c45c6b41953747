//! Live input within the limits at the ball (issue 47), through the real `floatball`
//! binary on each family's simulated matrix — 1 × 3 balls, travel 1000 mm, 500 mm/s,
//! 2000 mm/s², as the issue's outside check had it — fed `ArtDmx` from this test's
//! own socket on a free loopback port (sACN off), live mode switched on over the
//! WebSocket as an operator does.
//!
//! A fader is snapped to the bottom (the whole travel) and back to the top (0), twice,
//! each held until every ball rests. `GET /api/sim/positions` is sampled every ~10 ms
//! all along. Checked:
//! - no sample of any ball is ever past either end of the travel, to the count;
//! - each time, every ball comes to rest exactly on the end's count (0, or 100,000
//!   counts or pulses);
//! - live mode is still following at the end: no fault (a UIM2503 unit stopped at its
//!   upper limit switch by a row that dipped past 0 ended it in error);
//! - on UIM2503 units and MBOX boxes, whose simulations stamp their positions with
//!   their own clock, no ball moves faster than the top speed between two samples
//!   (MOONS' drives' simulation has no clock: their speed and acceleration are
//!   checked every millisecond in the sans-IO rig, `shared/src/scl/drive/tests/live.rs`).
//!
//! Acceleration at the ball is not asserted here: the samples' spacing and the
//! motion's corners (an MBOX box runs straight lines) make a second difference a
//! figure, not a bound — the sans-IO tests of each family check it exactly. Each
//! family's peak speed and acceleration at the ball are printed as a share of the
//! limits (`--nocapture`); `cargo xtask live-bench` runs this with more cycles
//! (`LIVE_LIMITS_CYCLES`) for the figures.

use crate::common;

use std::net::UdpSocket;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU16, Ordering};
use std::time::{Duration, Instant};

use common::process::{Process, links_up};
use common::send_text;
use floatball_shared::api::{LivePhase, SimPositions};
use floatball_shared::live::artnet::{self, PortAddress};

const TRAVEL_MM: f64 = 1000.0;
const TOP_SPEED_MM_S: f64 = 500.0;
const TOP_ACCEL_MM_S2: f64 = 2000.0;
/// Counts (or pulses) a mm, the default calibration.
const COUNTS_PER_MM: f64 = 100.0;

/// A free UDP port on the loopback.
fn free_port() -> u16 {
    UdpSocket::bind("127.0.0.1:0")
        .and_then(|socket| socket.local_addr())
        .expect("a free port")
        .port()
}

/// The configuration: the 1 × 3 matrix of `gateway`, live input on `artnet_port`.
fn config(gateway: &str, artnet_port: u16) -> String {
    format!(
        "[matrix]\nrows = 1\ncols = 3\ntravel_mm = {TRAVEL_MM:.1}\n\
         max_speed_mm_s = {TOP_SPEED_MM_S:.1}\nmax_accel_mm_s2 = {TOP_ACCEL_MM_S2:.1}\n\
         [safety]\napproach_speed_mm_s = {TOP_SPEED_MM_S:.1}\n\
         {gateway}\
         [live]\nenabled = true\nsacn = false\nhold_after_ms = 1000\n\
         artnet_listen = \"127.0.0.1:{artnet_port}\"\n"
    )
}

/// A console's fader for balls 0–2 (16-bit position each, universe 1 from address
/// 1), repeated every 20 ms from this test's socket until dropped.
struct Fader {
    value: Arc<AtomicU16>,
    stop: Arc<AtomicBool>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Fader {
    fn start(port: u16, value: u16) -> Self {
        let shared = Arc::new(AtomicU16::new(value));
        let stop = Arc::new(AtomicBool::new(false));
        let (now, stopping) = (Arc::clone(&shared), Arc::clone(&stop));
        let thread = std::thread::spawn(move || {
            let socket = UdpSocket::bind("127.0.0.1:0").expect("a socket");
            let address = PortAddress::of_universe(1).expect("universe 1");
            let mut sequence = 0u8;
            while !stopping.load(Ordering::Acquire) {
                let [coarse, fine] = now.load(Ordering::Acquire).to_be_bytes();
                let data = [coarse, fine, coarse, fine, coarse, fine];
                sequence = sequence.wrapping_add(1).max(1);
                let packet = artnet::encode_dmx(sequence, address, &data);
                let _ = socket.send_to(&packet, ("127.0.0.1", port));
                std::thread::sleep(Duration::from_millis(20));
            }
        });
        Self {
            value: shared,
            stop,
            thread: Some(thread),
        }
    }

    fn set(&self, value: u16) {
        self.value.store(value, Ordering::Release);
    }
}

impl Drop for Fader {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}

/// One sample: every ball's position, counts (or pulses, as a distance from the top),
/// and the simulation's clock when it has one, µs.
struct Sample {
    counts: Vec<f64>,
    time_us: Option<u64>,
}

async fn sample(bridge: &Process, token: &str) -> Sample {
    let positions: SimPositions = bridge.sim_positions(token).await;
    if let Some(gateway) = positions.gateways.first() {
        Sample {
            counts: gateway
                .units
                .iter()
                .map(|unit| unit.position_counts)
                .collect(),
            time_us: Some(gateway.time_us),
        }
    } else if let Some(one) = positions.boxes.first() {
        Sample {
            counts: one
                .positions_pulses
                .iter()
                .map(|&pulses| f64::from(pulses).abs())
                .collect(),
            time_us: Some(one.time_us),
        }
    } else {
        Sample {
            counts: positions
                .drives
                .iter()
                .map(|drive| drive.position_counts)
                .collect(),
            time_us: None,
        }
    }
}

/// What the samples of one family showed.
#[derive(Debug, Default)]
struct Seen {
    lowest_counts: f64,
    highest_counts: f64,
    /// Between two samples, on the simulation's clock (none without one).
    fastest_mm_s: f64,
    /// From three samples (the change of the speeds between them over the time between
    /// their middles), on the simulation's clock (none without one).
    hardest_mm_s2: f64,
    samples: usize,
    /// The last two samples' times, s, and the speed between them, mm/s, per ball.
    speeds: Option<(f64, Vec<f64>)>,
}

impl Seen {
    /// Takes `now`, the sample after `before`.
    fn take(&mut self, before: Option<&Sample>, now: &Sample) {
        self.samples += 1;
        for &counts in &now.counts {
            self.lowest_counts = self.lowest_counts.min(counts);
            self.highest_counts = self.highest_counts.max(counts);
        }
        let Some(before) = before else {
            return;
        };
        let (Some(from_us), Some(to_us)) = (before.time_us, now.time_us) else {
            return;
        };
        if to_us <= from_us {
            return;
        }
        let dt_s = (to_us - from_us) as f64 / 1e6;
        let middle_s = (from_us + to_us) as f64 / 2e6;
        let speeds: Vec<f64> = before
            .counts
            .iter()
            .zip(&now.counts)
            .map(|(was, is)| (is - was) / COUNTS_PER_MM / dt_s)
            .collect();
        for speed in &speeds {
            self.fastest_mm_s = self.fastest_mm_s.max(speed.abs());
        }
        if let Some((last_middle_s, last)) = &self.speeds
            && middle_s > *last_middle_s
        {
            for (was, is) in last.iter().zip(&speeds) {
                let accel = (is - was).abs() / (middle_s - last_middle_s);
                self.hardest_mm_s2 = self.hardest_mm_s2.max(accel);
            }
        }
        self.speeds = Some((middle_s, speeds));
    }
}

/// Samples until every ball rests on `end_counts` (the same count in three samples
/// 50 ms apart), at most 15 s; every sample goes into `seen`.
async fn until_at_rest(
    family: &str,
    bridge: &Process,
    token: &str,
    end_counts: f64,
    seen: &mut Seen,
    last: &mut Option<Sample>,
) {
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut still = 0;
    loop {
        let now = sample(bridge, token).await;
        seen.take(last.as_ref(), &now);
        let resting = now.counts.iter().all(|&counts| counts == end_counts);
        still = if resting { still + 1 } else { 0 };
        *last = Some(now);
        if still >= 3 {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "{family}: the balls did not come to rest on {end_counts} counts: {:?}\n{}",
            last.as_ref().map(|sample| sample.counts.clone()),
            bridge.log()
        );
        tokio::time::sleep(Duration::from_millis(if resting { 50 } else { 10 })).await;
    }
}

/// How many times the fader goes to the bottom and back: `LIVE_LIMITS_CYCLES`
/// (`cargo xtask live-bench` sets it), 2 unless told.
fn cycles() -> u32 {
    std::env::var("LIVE_LIMITS_CYCLES")
        .ok()
        .and_then(|cycles| cycles.parse().ok())
        .unwrap_or(2)
}

async fn snaps_to_both_ends(family: &str, gateway: &str) {
    let port = free_port();
    let bridge = Process::start(&config(gateway, port));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{family}: {}", bridge.log());
    let fader = Fader::start(port, 0);
    send_text(&mut ws, r#"{"type":"live","on":true}"#).await;
    common::status_until(&mut ws, Duration::from_secs(30), |status| {
        status.live.as_ref().map(|live| live.phase) == Some(LivePhase::Following)
    })
    .await;
    let mut seen = Seen {
        lowest_counts: f64::MAX,
        highest_counts: f64::MIN,
        ..Seen::default()
    };
    let mut last = None;
    let bottom_counts = TRAVEL_MM * COUNTS_PER_MM;
    until_at_rest(family, &bridge, &token, 0.0, &mut seen, &mut last).await;
    for _ in 0..cycles() {
        fader.set(u16::MAX);
        until_at_rest(family, &bridge, &token, bottom_counts, &mut seen, &mut last).await;
        fader.set(0);
        until_at_rest(family, &bridge, &token, 0.0, &mut seen, &mut last).await;
    }
    // A new connection gets the status now.
    let mut fresh = bridge.ws(&token).await;
    let status = common::status_until(&mut fresh, Duration::from_secs(5), |_| true).await;
    assert_eq!(
        status.live.as_ref().map(|live| live.phase),
        Some(LivePhase::Following),
        "{family}: live mode ended: {status:?}\n{}",
        bridge.log()
    );
    if seen.fastest_mm_s > 0.0 {
        println!(
            "{family}: {} samples ~10 ms apart, from {:.0} to {:.0} counts (0 to {:.0}); at \
             the ball, on the simulation's clock: peak speed {:.1} mm/s ({:.1} % of \
             {TOP_SPEED_MM_S}), peak acceleration {:.0} mm/s² ({:.0} % of {TOP_ACCEL_MM_S2})",
            seen.samples,
            seen.lowest_counts,
            seen.highest_counts,
            TRAVEL_MM * COUNTS_PER_MM,
            seen.fastest_mm_s,
            100.0 * seen.fastest_mm_s / TOP_SPEED_MM_S,
            seen.hardest_mm_s2,
            100.0 * seen.hardest_mm_s2 / TOP_ACCEL_MM_S2,
        );
    } else {
        println!(
            "{family}: {} samples, from {:.0} to {:.0} counts (0 to {:.0}); speed and \
             acceleration not measured here: the simulated drives carry no clock (the \
             sans-IO rig checks them every millisecond)",
            seen.samples,
            seen.lowest_counts,
            seen.highest_counts,
            TRAVEL_MM * COUNTS_PER_MM,
        );
    }
    assert!(
        seen.lowest_counts >= 0.0 && seen.highest_counts <= bottom_counts,
        "{family}: a ball went past an end: from {} to {} counts",
        seen.lowest_counts,
        seen.highest_counts
    );
    assert!(
        seen.fastest_mm_s <= TOP_SPEED_MM_S * (1.0 + 1e-6),
        "{family}: {} mm/s between two samples",
        seen.fastest_mm_s
    );
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn uim2503_faders_at_either_end_reach_it_exactly_and_never_pass_it() {
    snaps_to_both_ends("UIM2503", "[[gateway]]\nport = \"sim\"\nbaud = 115200\n").await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mbox_faders_at_either_end_reach_it_exactly_and_never_pass_it() {
    snaps_to_both_ends(
        "MBOX",
        "[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n",
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn moons_faders_at_either_end_reach_it_exactly_and_never_pass_it() {
    snaps_to_both_ends(
        "MOONS'",
        "[scl]\npoll_ms = 50\n[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n",
    )
    .await;
}
