//! The status clock against the units' own (issue 34, item 5), through the real
//! `floatball` binary on each family's simulated matrix: UIM2503 gateways, MBOX boxes,
//! MOONS' drives started by `QX1` and by a trigger's edge.
//!
//! A show moves three balls from rest from its time 0, so the units' time 0 is the
//! instant the simulated units begin to move: `GET /api/sim/positions` is asked over
//! and over while Start runs, and the first answer in which a ball moves again after
//! the approach brackets that instant (between the question before and this answer).
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

mod common;

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

/// The families, each with its configuration.
fn families() -> Vec<(&'static str, String)> {
    let matrix = "[matrix]\nrows = 1\ncols = 3\n[safety]\napproach_speed_mm_s = 1000.0\n";
    vec![
        (
            "UIM2503, 115200 baud",
            format!("{matrix}[[gateway]]\nport = \"sim\"\nbaud = 115200\n"),
        ),
        (
            "MBOX, 20 ms frames",
            format!("{matrix}[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n"),
        ),
        (
            "MOONS', QX1 over eSCL",
            format!(
                "{matrix}[scl]\npoll_ms = 50\ntolerance_mm = 50.0\n\
                 [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"
            ),
        ),
        (
            "MOONS', trigger edge",
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

/// Whether any simulated ball moves.
fn moving(positions: &SimPositions) -> bool {
    positions
        .gateways
        .iter()
        .flat_map(|gateway| &gateway.units)
        .any(|unit| unit.moving)
        || positions.boxes.iter().any(|one| one.moving)
        || positions.drives.iter().any(|drive| drive.moving)
}

/// Plays the show once on `config`'s matrix.
async fn run_once(config: &str) -> Run {
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
    // The positions, asked back to back: (asked, answered, moving).
    let mut looks = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(60);
    while !reader.is_finished() && Instant::now() < deadline {
        let asked = Instant::now();
        let reply = bridge
            .request(
                axum::http::Method::GET,
                "/api/sim/positions",
                Some(&token),
                None,
            )
            .await;
        let answered = Instant::now();
        looks.push((asked, answered, moving(&reply.json())));
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
    // The approach ends before the show: the last status that was not yet `loading`
    // or `playing`, then the balls at rest, then moving again.
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
    let mut at_rest = false;
    let mut units_start = None;
    for (index, &(asked, answered, moving)) in looks.iter().enumerate() {
        if asked < before_show {
            continue;
        }
        if !moving {
            at_rest = true;
        } else if at_rest {
            let since = index.checked_sub(1).map_or(asked, |before| looks[before].0);
            units_start = Some((since, answered));
            break;
        }
    }
    let (since, until) = units_start.expect("the balls began to move after the approach");
    // The units' time 0 is within [since, until]: its middle, ± half the bracket.
    let units_t0 = since + (until - since) / 2;
    let ms = |later: Instant, earlier: Instant| {
        if later >= earlier {
            (later - earlier).as_secs_f64() * 1e3
        } else {
            -(earlier - later).as_secs_f64() * 1e3
        }
    };
    let mut run = Run {
        bracket_ms: ms(until, since),
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
        "family", "p50", "p99", "max |x|", "statuses", "playing after", "bracket", "announced"
    );
    for (name, config) in families() {
        let mut offsets = Vec::new();
        let mut playing_after = Vec::new();
        let mut brackets = Vec::new();
        let mut announced = 0;
        for _ in 0..runs {
            let run = run_once(&config).await;
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
