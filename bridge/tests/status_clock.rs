//! The status clock against the units' own (issue 34, item 5), through the real
//! `floatball` binary on each family's simulated matrix: UIM2503 gateways, MBOX boxes,
//! MOONS' drives started by `QX1` and by a trigger's edge.
//!
//! `GET /api/sim/positions` is asked over and over while Start runs. The show moves
//! three balls from rest along one cubic (100 → 600 mm), so where UIM2503 units and
//! MBOX boxes follow the show exactly, a ball's position says the units' show time at
//! each answer, and the units' time 0 is the median of each answer's instant less that
//! time (its uncertainty: half the time one answer takes). MOONS' drives run the
//! compiled program, not the cubic: there the units' time 0 is bracketed by the last
//! answer in which no drive moves after the approach and the first in which one does.
//! Every `playing` status the WebSocket brings says the show's time 0 is its arrival
//! less its `show_time_ms`; the offset is that instant less the units' time 0
//! (positive: the status runs behind the units). Also: how long after the balls began
//! the state `playing` arrived, and whether the start was announced
//! (`show_starts_in_ms`).
//!
//! In the normal test run each family plays once and the figures are printed; nothing
//! about time is asserted (the machine's load would decide it). `cargo xtask
//! status-clock [--runs N]` runs it in a release build (`STATUS_CLOCK_RUNS`) and prints
//! p50 / p99 / max per family over every status of every run.

use crate::common;

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use common::process::{Process, links_up};
use common::{native_show, send_text};
use floatball_shared::api::{PlayerState, ServerMessage, SimPositions};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

/// The show's length, ms.
const SHOW_MS: u64 = 1_200;

/// Three balls from 100 mm at rest to 600 mm at rest in [`SHOW_MS`] (a cubic: 0.4 mm
/// in the first 20 ms, 40 counts; peak 2,083 mm/s², within the default limits).
fn show() -> Vec<u8> {
    // Rows of 200 ms with the cubic's own velocities: the curve is the cubic itself.
    const ROW_MS: u64 = 200;
    let seconds = SHOW_MS as f64 / 1e3;
    let rows: Vec<_> = (1..=SHOW_MS / ROW_MS)
        .map(|row| {
            let s = (row * ROW_MS) as f64 / SHOW_MS as f64;
            let position_mm = 100.0 + 500.0 * (3.0 * s * s - 2.0 * s * s * s);
            let velocity_mm_s = 500.0 * (6.0 * s - 6.0 * s * s) / seconds;
            serde_json::json!([position_mm, velocity_mm_s, ROW_MS])
        })
        .collect();
    let units = (0..3)
        .map(|_| serde_json::json!({ "start_mm": 100.0, "rows": rows }))
        .collect();
    native_show("ramp", 1, 3, units)
}

/// Where the show's balls are at `s` of its length (0 to 1), mm.
fn show_mm(s: f64) -> f64 {
    100.0 + 500.0 * (3.0 * s * s - 2.0 * s * s * s)
}

/// The share of the show at which its balls are at `position_mm` (the cubic is
/// monotonic: bisection).
fn show_share(position_mm: f64) -> f64 {
    let (mut low, mut high) = (0.0_f64, 1.0_f64);
    for _ in 0..60 {
        let middle = (low + high) / 2.0;
        if show_mm(middle) < position_mm {
            low = middle;
        } else {
            high = middle;
        }
    }
    (low + high) / 2.0
}

/// How the units' time 0 is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Clock {
    /// From the positions along the show's cubic.
    Curve,
    /// From the first answer in which a ball moves after the approach.
    Onset,
}

/// The families, each with how its time 0 is found and its configuration.
fn families() -> Vec<(&'static str, Clock, String)> {
    let matrix = "[matrix]\nrows = 1\ncols = 3\n[safety]\napproach_speed_mm_s = 1000.0\n";
    vec![
        (
            "UIM2503, 115200 baud",
            Clock::Curve,
            format!("{matrix}[[gateway]]\nport = \"sim\"\nbaud = 115200\n"),
        ),
        (
            "MBOX, 20 ms frames",
            Clock::Curve,
            format!("{matrix}[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n"),
        ),
        (
            "MOONS', QX1 over eSCL",
            Clock::Onset,
            format!(
                "{matrix}[scl]\npoll_ms = 50\ntolerance_mm = 50.0\n\
                 [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"
            ),
        ),
        (
            "MOONS', trigger edge",
            Clock::Onset,
            format!(
                "{matrix}[scl]\npoll_ms = 50\ntolerance_mm = 50.0\ntrigger = \"0:2\"\n\
                 [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"
            ),
        ),
    ]
}

/// One run's figures.
#[derive(Debug, Default)]
struct Run {
    /// Each `playing` status's time 0 less the units', ms.
    offsets_ms: Vec<f64>,
    /// The first `playing` status's arrival less the units' time 0, ms.
    playing_after_ms: f64,
    /// The bracket on the units' time 0: question before to answer, ms.
    bracket_ms: f64,
    /// A `loading` status announced the start.
    announced: bool,
}

/// Whether any simulated ball moves, and the first ball's position, mm (100 counts
/// or pulses a mm).
fn look(positions: &SimPositions) -> (bool, f64) {
    let moving = positions
        .gateways
        .iter()
        .flat_map(|gateway| &gateway.units)
        .any(|unit| unit.moving)
        || positions.boxes.iter().any(|one| one.moving)
        || positions.drives.iter().any(|drive| drive.moving);
    let counts = positions
        .gateways
        .first()
        .and_then(|gateway| gateway.units.first())
        .map(|unit| unit.position_counts)
        .or_else(|| {
            positions
                .boxes
                .first()
                .and_then(|one| one.positions_pulses.first())
                .map(|&pulses| f64::from(pulses).abs())
        })
        .or_else(|| positions.drives.first().map(|drive| drive.position_counts))
        .unwrap_or(0.0);
    (moving, counts / 100.0)
}

/// Plays the show once on `config`'s matrix.
async fn run_once(clock: Clock, config: &str) -> Run {
    let bridge = Process::start(config);
    let token = bridge.prepare_show("ramp", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    // Every status with its arrival, read by a task of its own.
    let statuses = Arc::new(Mutex::new(Vec::new()));
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let reader = {
        let statuses = Arc::clone(&statuses);
        tokio::spawn(async move {
            while let Some(Ok(frame)) = ws.next().await {
                let arrived = Instant::now();
                let Message::Text(text) = frame else { continue };
                if let Ok(ServerMessage::Status(status)) = serde_json::from_str(text.as_str()) {
                    let done = status.state == PlayerState::Idle && status.progress >= 1.0;
                    let failed = matches!(status.state, PlayerState::Error | PlayerState::Stopped);
                    statuses.lock().unwrap().push((arrived, status));
                    if done || failed {
                        return;
                    }
                }
            }
        })
    };
    // The positions, asked back to back: (asked, answered, moving, first ball mm).
    let mut looks = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !reader.is_finished() && Instant::now() < deadline {
        let asked = Instant::now();
        let (moving, position_mm) = look(&bridge.sim_positions(&token).await);
        looks.push((asked, Instant::now(), moving, position_mm));
    }
    reader.await.expect("the status reader");
    let statuses = statuses.lock().unwrap().clone();
    let states: Vec<_> = statuses.iter().map(|(_, status)| status.state).collect();
    assert!(
        states.contains(&PlayerState::Playing),
        "{states:?}\n{}",
        bridge.log()
    );
    let last = statuses.last().map(|(_, status)| status.clone()).unwrap();
    assert_eq!(last.state, PlayerState::Idle, "{last:?}\n{}", bridge.log());
    let (units_t0, uncertainty) = match clock {
        Clock::Curve => from_curve(&looks),
        Clock::Onset => from_onset(&looks, &statuses),
    };
    let ms = |later: Instant, earlier: Instant| {
        if later >= earlier {
            (later - earlier).as_secs_f64() * 1e3
        } else {
            -(earlier - later).as_secs_f64() * 1e3
        }
    };
    let mut run = Run {
        bracket_ms: uncertainty.as_secs_f64() * 1e3,
        ..Run::default()
    };
    for (arrived, status) in &statuses {
        match status.state {
            PlayerState::Loading if status.show_starts_in_ms.is_some() => run.announced = true,
            PlayerState::Playing if status.show_time_ms < SHOW_MS => {
                let status_t0 = *arrived - Duration::from_millis(status.show_time_ms);
                if run.offsets_ms.is_empty() {
                    run.playing_after_ms = ms(*arrived, units_t0);
                }
                run.offsets_ms.push(ms(status_t0, units_t0));
            }
            _ => {}
        }
    }
    assert!(
        !run.offsets_ms.is_empty(),
        "a playing status within the show"
    );
    run
}

/// An answer: asked, answered, some ball moving, the first ball's position (mm).
type Look = (Instant, Instant, bool, f64);

/// The units' time 0 from the answers along the show's cubic, and its uncertainty:
/// the median of each answer's middle less the show time its position says.
fn from_curve(looks: &[Look]) -> (Instant, Duration) {
    let show = Duration::from_millis(SHOW_MS);
    let mut starts: Vec<(Instant, Duration)> = looks
        .iter()
        .filter(|(_, _, _, mm)| *mm > show_mm(0.02) && *mm < show_mm(0.98))
        .map(|&(asked, answered, _, mm)| {
            let middle = asked + (answered - asked) / 2;
            (
                middle - show.mul_f64(show_share(mm)),
                (answered - asked) / 2,
            )
        })
        .collect();
    assert!(
        starts.len() >= 5,
        "only {} answers along the show",
        starts.len()
    );
    starts.sort();
    starts[starts.len() / 2]
}

/// The units' time 0 from the first answer in which a ball moves after the approach
/// (the last status before `loading` or `playing`), and half its bracket.
fn from_onset(
    looks: &[Look],
    statuses: &[(Instant, floatball_shared::api::Status)],
) -> (Instant, Duration) {
    let before_show = statuses
        .iter()
        .rev()
        .find(|(_, status)| {
            !matches!(
                status.state,
                PlayerState::Loading | PlayerState::Playing | PlayerState::Idle
            )
        })
        .map(|(at, _)| *at)
        .expect("an approach before the show");
    let mut at_rest = None;
    for &(asked, answered, moving, _) in looks {
        if asked < before_show {
            continue;
        }
        if !moving {
            at_rest = Some(asked);
        } else if let Some(since) = at_rest {
            return (since + (answered - since) / 2, (answered - since) / 2);
        }
    }
    panic!("the balls did not begin to move after the approach");
}

/// The `q` quantile of sorted `values`.
fn quantile(values: &[f64], q: f64) -> f64 {
    let index = ((values.len() - 1) as f64 * q).round() as usize;
    values[index]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_status_clock_follows_the_units_on_every_family() {
    let runs: usize = std::env::var("STATUS_CLOCK_RUNS")
        .ok()
        .and_then(|runs| runs.parse().ok())
        .unwrap_or(1);
    println!(
        "status clock − units' clock, ms (positive: the status behind), {runs} run(s) a family:"
    );
    println!(
        "{:<24} {:>8} {:>8} {:>8} {:>8} {:>14} {:>10} {:>9}",
        "family", "p50", "p99", "max |x|", "statuses", "playing after", "± t0", "announced"
    );
    for (name, clock, config) in families() {
        let mut offsets = Vec::new();
        let mut playing_after = Vec::new();
        let mut brackets = Vec::new();
        let mut announced = 0;
        for _ in 0..runs {
            let run = run_once(clock, &config).await;
            offsets.extend(run.offsets_ms);
            playing_after.push(run.playing_after_ms);
            brackets.push(run.bracket_ms);
            announced += usize::from(run.announced);
        }
        offsets.sort_by(f64::total_cmp);
        playing_after.sort_by(f64::total_cmp);
        brackets.sort_by(f64::total_cmp);
        let worst = offsets
            .iter()
            .map(|offset| offset.abs())
            .fold(0.0, f64::max);
        println!(
            "{name:<24} {:>8.1} {:>8.1} {:>8.1} {:>8} {:>11.1} ms {:>7.1} ms {:>6}/{runs}",
            quantile(&offsets, 0.5),
            quantile(&offsets, 0.99),
            worst,
            offsets.len(),
            quantile(&playing_after, 0.5),
            quantile(&brackets, 0.5),
            announced,
        );
    }
}
