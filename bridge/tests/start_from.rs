//! "Play from anywhere" (issue 37, item 1) through the real `floatball` binary on each
//! family's simulated matrix: UIM2503 gateways, MBOX boxes, MOONS' drives.
//!
//! The show moves three balls from rest at 1000 mm down to 1400, 1500 and 1600 mm
//! in its first second (one cubic each: up to 720 mm/s), holds them there for two
//! seconds, and brings them back in the last. A Start at entry 1, 500 ms — in the
//! middle of the fall — must play on from there: once the status's show time is in
//! the hold (after the cut's run-up, its join with the show), every simulated ball is
//! within 2 mm of where the show has it at that time. The hold makes the check
//! independent of when the positions are read: a status before and one after the
//! reading both say the show is in the hold (and, on UIM2503, a Reset to the same
//! time homes and plays the cut again). At the first `playing` status (the
//! cut starts at the show's time 50 ms, its run-up of 450 ms joining the show at
//! 500 ms) the status counts the full show's time from 50 ms, and every ball is
//! within 5 mm of its run-up (the cut's position then). Printed: the largest
//! distances there, from the show and from the cut, and in the hold. Also: an entry the playlist lacks and a time past the
//! show's end are refused with their codes.

use crate::common;

use std::time::Duration;

use common::process::{Process, links_up};
use common::{Ws, native_show, next_message, send_text};
use floatball_shared::api::{PlayerState, ServerMessage, SimPositions, Status};
use floatball_shared::show::validate::DEFAULT_MAX_ACCEL_MM_S2;
use floatball_shared::show::{Sampler, Show};

/// When the fall ends and the hold begins, and when the hold ends, ms.
const HOLD_MS: (u64, u64) = (1_000, 3_000);

/// The time the tests start from, ms: the middle of the fall.
const FROM_MS: u64 = 500;

/// The show: three balls fall from 1000 mm to 1400, 1500, 1600 mm in one second
/// (rows of 100 ms with the cubic's own velocities), hold for two, rise in one.
fn show() -> Vec<u8> {
    const ROW_MS: u64 = 100;
    let units = (0..3)
        .map(|ball| {
            let depth_mm = 400.0 + 100.0 * f64::from(ball);
            let cubic = |s: f64| 3.0 * s * s - 2.0 * s * s * s;
            let slope = |s: f64| 6.0 * s - 6.0 * s * s;
            let mut rows = Vec::new();
            for row in 1..=10u64 {
                let s = (row * ROW_MS) as f64 / 1_000.0;
                rows.push(serde_json::json!([
                    1_000.0 + depth_mm * cubic(s),
                    depth_mm * slope(s),
                    ROW_MS
                ]));
            }
            for _ in 0..8 {
                rows.push(serde_json::json!([1_000.0 + depth_mm, 0.0, 250]));
            }
            for row in 1..=10u64 {
                let s = (row * ROW_MS) as f64 / 1_000.0;
                rows.push(serde_json::json!([
                    1_000.0 + depth_mm * (1.0 - cubic(s)),
                    -depth_mm * slope(s),
                    ROW_MS
                ]));
            }
            serde_json::json!({ "start_mm": 1_000.0, "rows": rows })
        })
        .collect();
    native_show("fall", 1, 3, units)
}

/// Each simulated ball's position, mm (100 counts or pulses a mm).
fn balls_mm(positions: &SimPositions) -> Vec<f64> {
    let counts: Vec<f64> = if let Some(gateway) = positions.gateways.first() {
        gateway
            .units
            .iter()
            .map(|unit| unit.position_counts)
            .collect()
    } else if let Some(one) = positions.boxes.first() {
        one.positions_pulses
            .iter()
            .map(|&pulses| f64::from(pulses).abs())
            .collect()
    } else {
        positions
            .drives
            .iter()
            .map(|drive| drive.position_counts)
            .collect()
    };
    counts.iter().map(|counts| counts / 100.0).collect()
}

/// The largest distance of the balls from where the show has them at `t_ms`, mm.
fn error_mm(sampler: &mut Sampler, t_ms: u64, balls_mm: &[f64]) -> f64 {
    let mut expected = vec![0.0f32; 3];
    sampler.sample(t_ms as f64, &mut expected, None);
    assert_eq!(balls_mm.len(), 3, "{balls_mm:?}");
    expected
        .iter()
        .zip(balls_mm)
        .map(|(&show, ball)| (f64::from(show) - ball).abs())
        .fold(0.0, f64::max)
}

/// The next status, skipping other messages.
async fn next_status(ws: &mut Ws) -> Status {
    loop {
        if let ServerMessage::Status(status) = next_message(ws).await {
            return status;
        }
    }
}

/// The next error, skipping statuses.
async fn next_error(ws: &mut Ws) -> (String, String) {
    loop {
        if let ServerMessage::Error { code, message, .. } = next_message(ws).await {
            return (code.to_string(), message);
        }
    }
}

/// Starts `config`'s matrix at entry 1, [`FROM_MS`]; returns the largest distance
/// from the show at the first `playing` status and in the hold, mm.
async fn start_from_the_middle(family: &str, config: &str, refusals: bool) -> ((f64, f64), f64) {
    let bridge = Process::start(config);
    let file = show();
    let token = bridge.prepare_show("fall", &file, false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    if refusals {
        send_text(&mut ws, r#"{"type":"start","entry":2,"time_ms":100}"#).await;
        let (code, message) = next_error(&mut ws).await;
        assert_eq!(code, "start_no_such_entry", "{message}");
        assert_eq!(message, "there is no entry 2: the playlist has 1 entries");
        send_text(&mut ws, r#"{"type":"start","time_ms":4000}"#).await;
        let (code, message) = next_error(&mut ws).await;
        assert_eq!(code, "start_past_the_end", "{message}");
    }
    let show = Show::from_json(std::str::from_utf8(&file).unwrap()).unwrap();
    let mut sampler = Sampler::new(&show);
    // The cut the bridge plays: run-ups at half the default top acceleration.
    let cut = show
        .from_time(FROM_MS, DEFAULT_MAX_ACCEL_MM_S2 / 2.0)
        .unwrap();
    assert!(cut.start_ms > 0 && cut.joins_ms == FROM_MS, "{cut:?}");
    assert!(cut.joins_ms < HOLD_MS.0);
    let mut cut_sampler = Sampler::new(&cut.show);
    send_text(
        &mut ws,
        &format!(r#"{{"type":"start","entry":1,"time_ms":{FROM_MS}}}"#),
    )
    .await;
    let mut at_first = None;
    let hold = loop {
        let status = tokio::time::timeout(Duration::from_secs(60), next_status(&mut ws))
            .await
            .unwrap_or_else(|_| panic!("{family}: no status\n{}", bridge.log()));
        assert!(
            !matches!(status.state, PlayerState::Error | PlayerState::Stopped),
            "{family}: {status:?}\n{}",
            bridge.log()
        );
        if status.state != PlayerState::Playing {
            continue;
        }
        assert_eq!(status.entry, Some(0));
        assert_eq!(status.show_duration_ms, 4_000);
        if at_first.is_none() {
            // The first `playing` status: the show's clock is the full show's.
            assert!(
                (cut.start_ms..=cut.start_ms + 200).contains(&status.show_time_ms),
                "{family}: {status:?}"
            );
            let balls = balls_mm(&bridge.sim_positions(&token).await);
            // The balls set off on their run-ups (from rest, at most 2 m/s²: 2.5 mm in
            // the first 50 ms), not where the show has them then.
            let off_cut = error_mm(&mut cut_sampler, status.show_time_ms - cut.start_ms, &balls);
            assert!(
                off_cut <= 5.0,
                "{family}: {off_cut} mm from the cut: {balls:?}"
            );
            at_first = Some((error_mm(&mut sampler, status.show_time_ms, &balls), off_cut));
        }
        if status.show_time_ms > HOLD_MS.0 + 100 && status.show_time_ms < HOLD_MS.1 - 500 {
            let balls = balls_mm(&bridge.sim_positions(&token).await);
            let after = next_status(&mut ws).await;
            assert!(
                after.state == PlayerState::Playing && after.show_time_ms < HOLD_MS.1,
                "{family}: the reading was not in the hold: {after:?}"
            );
            break error_mm(&mut sampler, status.show_time_ms, &balls);
        }
    };
    let (first, off_cut) = at_first.unwrap_or_default();
    println!(
        "{family}: from {FROM_MS} ms: largest distance at the first playing status from \
         the show {first:.1} mm, from the cut's run-up {off_cut:.2} mm; in the hold from \
         the show {hold:.3} mm"
    );
    assert!(hold <= 2.0, "{family}: {hold} mm off\n{}", bridge.log());
    if refusals {
        // Reset takes the same: it stops, homes, and plays the cut again.
        send_text(&mut ws, r#"{"type":"reset","entry":1,"time_ms":500}"#).await;
        let mut homed = false;
        loop {
            let status = tokio::time::timeout(Duration::from_secs(60), next_status(&mut ws))
                .await
                .unwrap_or_else(|_| panic!("{family}: no status after Reset\n{}", bridge.log()));
            homed |= status.state == PlayerState::Homing;
            if homed && status.state == PlayerState::Playing {
                assert!(
                    (cut.start_ms..=cut.start_ms + 200).contains(&status.show_time_ms),
                    "{family}: {status:?}"
                );
                break;
            }
        }
    }
    ((first, off_cut), hold)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_start_from_a_time_plays_on_from_there_on_every_family() {
    let matrix = "[matrix]\nrows = 1\ncols = 3\n[safety]\napproach_speed_mm_s = 2000.0\n";
    let families = [
        (
            "UIM2503",
            format!("{matrix}[[gateway]]\nport = \"sim\"\nbaud = 115200\n"),
            true,
        ),
        (
            "MBOX",
            format!("{matrix}[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n"),
            false,
        ),
        (
            "MOONS'",
            format!(
                "{matrix}[scl]\npoll_ms = 50\ntolerance_mm = 50.0\n\
                 [[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"
            ),
            false,
        ),
    ];
    for (family, config, refusals) in families {
        start_from_the_middle(family, &config, refusals).await;
    }
}
