//! The bridge's own simulated MOONS' drives (`kind = "scl"`, `port = "sim"`) through
//! the real `floatball` binary: two gateway entries of three drives each, on one start
//! wire, on loopback eSCL. Start uploads every drive's Q program and fires the common
//! start, the show plays to its end, `GET /api/sim/positions` shows every drive's
//! stored program and end position, and the e-stop stops them all. The verdict
//! (`GET /api/plan`) compiles the programs as Start does.

use crate::common;

use std::time::Duration;

use common::process::{Process, links_up};
use common::{Ws, native_show, send_text, until};
use floatball_shared::api::{PlanReport, PlayerState, SimDrive};

/// Ball `ball`'s end position, mm.
fn end_mm(ball: usize) -> f64 {
    5.0 * (ball as f64 + 1.0)
}

/// Six balls that each go down 20 mm and come up to their end position, in 1 s; the
/// last one instead goes past its end and creeps back 0.3 mm in 0.5 s (60 counts/s,
/// slower than the smallest `VE` a drive takes: the twins refuse `VE0.0030`, which
/// the compiler wrote before it kept to a drive's ranges, issue 34 item 3).
fn show() -> Vec<u8> {
    let units = (0..6)
        .map(|ball| {
            let rows = if ball == 5 {
                serde_json::json!([
                    [10.0, 0.0, 250],
                    [end_mm(ball) + 0.3, 0.0, 250],
                    [end_mm(ball) + 0.15, 0.0, 250],
                    [end_mm(ball), 0.0, 250]
                ])
            } else {
                serde_json::json!([
                    [10.0, 0.0, 250],
                    [20.0, 0.0, 250],
                    [10.0, 0.0, 250],
                    [end_mm(ball), 0.0, 250]
                ])
            };
            serde_json::json!({"start_mm": 0.0, "rows": rows})
        })
        .collect();
    native_show("drop", 2, 3, units)
}

fn config(scl: &str) -> String {
    let sim = "[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n";
    format!(
        "[matrix]\nrows = 2\ncols = 3\n[safety]\napproach_speed_mm_s = 1000.0\n\
         [scl]\npoll_ms = 50\n{scl}\n{sim}{sim}"
    )
}

async fn operator(bridge: &Process) -> (Ws, String) {
    let token = bridge.prepare_show("drop", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    (ws, token)
}

async fn drives(bridge: &Process, token: &str) -> Vec<SimDrive> {
    bridge.sim_positions(token).await.drives
}

/// Start plays the show to its end; every drive stored its program, was started
/// (none waits at `WI`) and ends where its ball's track ends.
async fn plays_to_the_end(
    bridge: &Process,
    ws: &mut Ws,
    token: &str,
    streamed: bool,
) -> floatball_shared::api::Status {
    send_text(ws, r#"{"type":"start"}"#).await;
    let (states, last) = until(ws, Duration::from_secs(15), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    let drives = drives(bridge, token).await;
    assert_eq!(drives.len(), 6, "{drives:?}");
    for (ball, drive) in drives.iter().enumerate() {
        assert_eq!(
            (drive.gateway, drive.unit),
            (ball / 3, ball % 3),
            "{drive:?}"
        );
        // A program ran: stored, or (one segment) from the queue; a streamed show
        // leaves neither (and writes nothing to memory).
        if streamed {
            assert_eq!(
                (drive.segments_stored, drive.queue_lines, drive.flash_writes),
                (0, 0, 0),
                "{drive:?}"
            );
        } else {
            assert!(
                drive.segments_stored >= 1 || drive.queue_lines >= 1,
                "{drive:?}"
            );
        }
        assert!(!drive.waiting_input && !drive.executing, "{drive:?}");
        assert!(drive.moves_ended > 0, "{drive:?}");
        assert_eq!(drive.alarm_code, 0, "{drive:?}");
        // 100 counts/mm.
        assert!(
            (drive.position_counts - end_mm(ball) * 100.0).abs() < 1.0,
            "ball {ball}: {drive:?}"
        );
    }
    last
}

/// Start again, then the e-stop while the programs run: every drive stops.
async fn estop_stops_every_drive(bridge: &Process, ws: &mut Ws, token: &str) {
    send_text(ws, r#"{"type":"start"}"#).await;
    until(ws, Duration::from_secs(15), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    send_text(ws, r#"{"type":"estop"}"#).await;
    let (_, stopped) = until(ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    assert_eq!(stopped.last_error, None);
    tokio::time::sleep(Duration::from_millis(300)).await;
    for drive in drives(bridge, token).await {
        assert!(!drive.executing && !drive.moving, "{drive:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_drives_on_one_start_wire_play_and_stop() {
    // The trigger drive's output is wired to input 3 of every drive on both entries.
    let bridge = Process::start(&config("trigger = \"0:2\"\ntolerance_mm = 20.0"));
    let (mut ws, token) = operator(&bridge).await;
    // The download for Q Programmer is what Start sends: the trigger drive's ball
    // fires the edge from its own line 1; the others wait for it.
    let first_line = |unit: usize| {
        let bridge = &bridge;
        let token = token.clone();
        async move {
            let path = format!("/api/qprogram/drop?unit={unit}");
            let reply = bridge
                .request(axum::http::Method::GET, &path, Some(&token), None)
                .await;
            let listing: floatball_shared::api::QProgramListing = reply.json();
            listing.text.lines().nth(1).unwrap_or_default().to_owned()
        }
    };
    assert_eq!(first_line(0).await, "SO2L");
    assert_eq!(first_line(1).await, "WI3F");
    assert_eq!(first_line(3).await, "WI3F");
    plays_to_the_end(&bridge, &mut ws, &token, false).await;
    // One-segment programs run from the queue: nothing written to memory; a
    // longer one is stored once, and a second Start writes nothing more.
    let written: Vec<u32> = drives(&bridge, &token)
        .await
        .iter()
        .map(|drive| drive.flash_writes)
        .collect();
    let status = plays_to_the_end(&bridge, &mut ws, &token, false).await;
    let again: Vec<u32> = drives(&bridge, &token)
        .await
        .iter()
        .map(|drive| drive.flash_writes)
        .collect();
    assert_eq!(written, again, "a repeated Start wrote to a drive's memory");
    // The status counts the same writes, drive by drive.
    let counted: Vec<u32> = status
        .gateways
        .iter()
        .flat_map(|gateway| &gateway.drives)
        .map(|drive| u32::try_from(drive.flash_writes).unwrap())
        .collect();
    assert_eq!(counted, again);
    estop_stops_every_drive(&bridge, &mut ws, &token).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_drives_stream_the_show_into_their_command_buffers() {
    // `programs = "stream"`: every drive paused, its buffer filled, the rest sent as
    // the show plays; the trigger ball's first line fires the common start.
    let bridge = Process::start(&config(
        "trigger = \"0:2\"\ntolerance_mm = 20.0\nprograms = \"stream\"",
    ));
    let (mut ws, token) = operator(&bridge).await;
    plays_to_the_end(&bridge, &mut ws, &token, true).await;
    estop_stops_every_drive(&bridge, &mut ws, &token).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_drives_without_a_trigger_are_started_each_by_qx() {
    let bridge = Process::start(&config("tolerance_mm = 20.0"));
    let (mut ws, token) = operator(&bridge).await;
    plays_to_the_end(&bridge, &mut ws, &token, false).await;
}

async fn plan(bridge: &Process, token: &str) -> PlanReport {
    bridge
        .request(axum::http::Method::GET, "/api/plan/drop", Some(token), None)
        .await
        .json()
}

/// The verdict before Start compiles every ball's program: a show Start would refuse
/// (here: over a tolerance no rest-to-rest move meets) is not feasible, with the ball,
/// the figure and the tolerance that would take it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_verdict_refuses_a_show_over_the_tolerance() {
    let bridge = Process::start(&config("tolerance_mm = 0.001"));
    let (_, token) = operator(&bridge).await;
    let report = plan(&bridge, &token).await;
    assert!(!report.feasible, "{report:?}");
    let reason = report.reason.clone().unwrap_or_default();
    assert!(
        reason.starts_with("ball u0: the program would be")
            && reason.contains("tolerance of 0.001 mm"),
        "{report:?}"
    );
    assert!(
        report.fixes[0].starts_with("raise [scl] tolerance_mm to"),
        "{report:?}"
    );
    // The same verdict as codes, for the app to say in the operator's language.
    let coded = report.reason_problem.as_ref().expect("a coded reason");
    assert_eq!(coded.code, "qprogram_too_far", "{report:?}");
    assert_eq!(coded.params["unit"], "u0");
    assert_eq!(coded.params["tolerance_mm"], "0.001");
    assert_eq!(report.fix_problems[0].code, "fix_tolerance", "{report:?}");
    assert!(
        report.fixes[0].contains(&format!(
            "to {} mm or more",
            report.fix_problems[0].params["tolerance_mm"]
        )),
        "{report:?}"
    );

    let bridge = Process::start(&config("tolerance_mm = 20.0"));
    let (_, token) = operator(&bridge).await;
    let report = plan(&bridge, &token).await;
    assert!(report.feasible, "{report:?}");
}
