//! The weekly schedule (issue 37, item 2) through the real `floatball` binary on each
//! family's simulated matrix (UIM2503 gateways, MBOX boxes, MOONS' drives), with the
//! scheduler's clock set by the test (`--test-clock-at`, `POST /api/test/clock`):
//! no test waits for minutes to pass.
//!
//! Each family: a schedule open 10:00–12:00 (UTC) every day, looping the playlist;
//! the clock set into the window starts the show (status `playing`, outcome
//! `schedule_started_loop`); set past the window's end, the balls go home (every
//! simulated ball at 0 mm) and, on UIM2503, every unit's motor is off; with the
//! e-stop latched, the next day's window starts nothing and the outcome says why
//! (`schedule_estop_latched`), the matrix stays stopped. On UIM2503 also: a schedule
//! with problems is refused with their codes; a loop's playlist that ends by itself
//! is started again; and a bridge restarted in the middle of a window (the clock
//! set there from its start) resumes the window's program.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use common::process::{Process, links_up};
use common::{PASSWORD, Ws, native_show, next_message, send_text};
use floatball_shared::api::{PlayerState, ScheduleStatus, ServerMessage, SimPositions, Status};

/// The show: three balls held at 150 mm for 2 s (rows of 250 ms).
fn show() -> Vec<u8> {
    let units = (0..3)
        .map(|_| {
            let rows: Vec<serde_json::Value> = (0..8)
                .map(|_| serde_json::json!([150.0, 0.0, 250]))
                .collect();
            serde_json::json!({ "start_mm": 150.0, "rows": rows })
        })
        .collect();
    native_show("hold", 1, 3, units)
}

/// Open 10:00–12:00 every day, looping, in UTC.
fn schedule() -> serde_json::Value {
    let day =
        serde_json::json!([{ "start": "10:00", "end": "12:00", "program": { "kind": "loop" } }]);
    serde_json::json!({
        "enabled": true,
        "time_zone": "UTC",
        "week": {
            "monday": day, "tuesday": day, "wednesday": day, "thursday": day,
            "friday": day, "saturday": day, "sunday": day,
        },
    })
}

async fn put_json(
    bridge: &Process,
    token: &str,
    path: &str,
    body: &serde_json::Value,
) -> common::Reply {
    bridge
        .request(
            Method::PUT,
            path,
            Some(token),
            Some(("application/json", body.to_string().into_bytes())),
        )
        .await
}

/// Sets the scheduler's clock.
async fn set_clock(bridge: &Process, token: &str, now: &str) {
    let reply = bridge
        .request(
            Method::POST,
            "/api/test/clock",
            Some(token),
            Some((
                "application/json",
                serde_json::json!({ "now": now }).to_string().into_bytes(),
            )),
        )
        .await;
    assert_eq!(reply.status, StatusCode::NO_CONTENT, "{:?}", reply.body);
}

/// What the WebSocket said last: the status and the scheduler's state.
#[derive(Debug, Default)]
struct Latest {
    status: Status,
    schedule: ScheduleStatus,
}

/// Reads messages until the latest status and schedule state satisfy `what`, within
/// 30 s.
async fn until(ws: &mut Ws, latest: &mut Latest, family: &str, what: impl Fn(&Latest) -> bool) {
    let found = tokio::time::timeout(Duration::from_secs(30), async {
        while !what(latest) {
            match next_message(ws).await {
                ServerMessage::Status(status) => latest.status = status,
                ServerMessage::Schedule(schedule) => latest.schedule = schedule,
                _ => {}
            }
        }
    })
    .await;
    assert!(
        found.is_ok(),
        "{family}: not within 30 s; the latest: {latest:?}"
    );
}

fn last_code(schedule: &ScheduleStatus) -> &str {
    schedule.last.as_ref().map_or("", |last| last.code.as_str())
}

/// Each simulated ball's position, mm (100 counts or pulses a mm), and whether its
/// motor is on where the simulator says.
fn balls(positions: &SimPositions) -> Vec<(f64, Option<bool>)> {
    if let Some(gateway) = positions.gateways.first() {
        gateway
            .units
            .iter()
            .map(|unit| (unit.position_counts / 100.0, Some(unit.motor_on)))
            .collect()
    } else if let Some(one) = positions.boxes.first() {
        one.positions_pulses
            .iter()
            .map(|&pulses| (f64::from(pulses).abs() / 100.0, None))
            .collect()
    } else {
        positions
            .drives
            .iter()
            .map(|drive| (drive.position_counts / 100.0, Some(drive.motor_enabled)))
            .collect()
    }
}

async fn a_window_starts_and_ends_the_show(family: &str, config: &str, uim2503: bool) {
    let bridge = Process::start_with_args(config, &["--test-clock-at", "2026-11-30T09:00:00Z"]);
    let token = bridge.prepare_show("hold", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    assert!(links_up(&mut ws).await, "{family}: {}", bridge.log());
    let mut latest = Latest::default();
    if uim2503 {
        // Not stored: every problem coded.
        let mut bad = schedule();
        bad["time_zone"] = "Mars/Olympus".into();
        bad["week"]["monday"] = serde_json::json!([
            { "start": "10:00", "end": "12:00", "program": { "kind": "loop" } },
            { "start": "11:00", "end": "11:30", "program": { "kind": "every", "minutes": 0 } },
            { "start": "13:00", "end": "12:00", "program": { "kind": "loop" } },
        ]);
        let reply = put_json(&bridge, &token, "/api/schedule", &bad).await;
        assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
        let error = reply.error();
        assert_eq!(error.code, "schedule_invalid");
        let codes: Vec<&str> = error.problems.iter().map(|p| p.code.as_str()).collect();
        assert_eq!(
            codes,
            [
                "schedule_unknown_time_zone",
                "schedule_every_out_of_range",
                "schedule_end_not_after_start",
                "schedule_windows_overlap",
            ],
            "{error:?}"
        );
        // Not a schedule at all: a time that is not HH:MM.
        bad["week"]["monday"] =
            serde_json::json!([{ "start": "10", "end": "12:00", "program": { "kind": "loop" } }]);
        let reply = put_json(&bridge, &token, "/api/schedule", &bad).await;
        assert_eq!(reply.status, StatusCode::BAD_REQUEST);
    }
    let reply = put_json(&bridge, &token, "/api/schedule", &schedule()).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    until(&mut ws, &mut latest, family, |l| l.schedule.enabled).await;
    let waiting = &latest.schedule;
    assert_eq!(
        waiting.next_start.as_deref(),
        Some("2026-11-30 10:00"),
        "{waiting:?}"
    );
    assert_eq!(waiting.window, None);

    // Into the window: the show starts.
    set_clock(&bridge, &token, "2026-11-30T10:00:30Z").await;
    until(&mut ws, &mut latest, family, |l| {
        l.status.state == PlayerState::Playing && last_code(&l.schedule) == "schedule_started_loop"
    })
    .await;
    let started = &latest.schedule;
    assert_eq!(
        started.last.as_ref().map(|l| l.at.as_str()),
        Some("2026-11-30 10:00:30")
    );
    assert!(started.window.is_some(), "{started:?}");
    assert_eq!(started.next_start.as_deref(), Some("2026-12-01 10:00"));
    if uim2503 {
        // The playlist (2 s, not looping) ends by itself: the loop starts it again.
        until(&mut ws, &mut latest, family, |l| {
            l.status.state == PlayerState::Idle
        })
        .await;
        until(&mut ws, &mut latest, family, |l| {
            l.status.state == PlayerState::Playing
        })
        .await;
    }
    let playing = balls(&bridge.sim_positions(&token).await);
    assert!(
        playing.iter().all(|(mm, _)| *mm > 100.0),
        "{family}: the balls are not where the show has them: {playing:?}"
    );

    // Past the window's end: home, motors off.
    set_clock(&bridge, &token, "2026-11-30T12:00:00Z").await;
    until(&mut ws, &mut latest, family, |l| {
        last_code(&l.schedule).starts_with("schedule_end")
    })
    .await;
    let ended = &latest.schedule;
    // MBOX boxes have no motors-off; UIM2503 units get MO=0, MOONS' drives MD.
    let expected = if family == "MBOX" {
        "schedule_ended_motors_on"
    } else {
        "schedule_ended"
    };
    assert_eq!(
        last_code(ended),
        expected,
        "{family}: {ended:?}\n{}",
        bridge.log()
    );
    let home = balls(&bridge.sim_positions(&token).await);
    assert!(
        home.iter().all(|(mm, _)| mm.abs() < 1.0),
        "{family}: not home: {home:?}"
    );
    if family != "MBOX" {
        // The motor-off goes out on the line after the homing: wait for it to arrive.
        let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
        loop {
            let motors = balls(&bridge.sim_positions(&token).await);
            if motors.iter().all(|(_, on)| *on == Some(false)) {
                break;
            }
            assert!(
                tokio::time::Instant::now() < deadline,
                "{family}: motors on: {motors:?}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }
    if family == "MOONS'" {
        // Disabled drives move again: a Start sends ME before its first move.
        send_text(&mut ws, r#"{"type":"start"}"#).await;
        until(&mut ws, &mut latest, family, |l| {
            l.status.state == PlayerState::Playing
        })
        .await;
        let drives = bridge.sim_positions(&token).await.drives;
        assert!(
            drives
                .iter()
                .all(|drive| drive.motor_enabled && drive.alarm_code == 0),
            "{drives:?}"
        );
    }

    // The e-stop latched: the next window starts nothing, and says why.
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    until(&mut ws, &mut latest, family, |l| {
        l.status.state == PlayerState::Stopped
    })
    .await;
    set_clock(&bridge, &token, "2026-12-01T10:00:00Z").await;
    until(&mut ws, &mut latest, family, |l| {
        last_code(&l.schedule) == "schedule_estop_latched"
    })
    .await;
    let last = latest.schedule.last.clone().expect("an outcome");
    assert!(!last.done);
    assert_eq!(last.at, "2026-12-01 10:00");
    // Tried again meanwhile (every 2 s), still refused: the matrix stays stopped.
    if uim2503 {
        tokio::time::sleep(Duration::from_millis(2_500)).await;
    }
    let status = bridge
        .request(Method::GET, "/api/schedule/status", Some(&token), None)
        .await
        .json::<ScheduleStatus>();
    assert_eq!(last_code(&status), "schedule_estop_latched", "{status:?}");
    // A status as it is now (a new connection is sent one at once; the old one hears
    // of a change only, and a stopped matrix may not change for a while).
    let mut fresh = Latest::default();
    let mut now = bridge.ws(&token).await;
    until(&mut now, &mut fresh, family, |l| {
        l.status.gateway_summary.total > 0
    })
    .await;
    drop(now);
    assert_eq!(fresh.status.state, PlayerState::Stopped, "{family}");

    if uim2503 {
        // `floatball check` says the schedule is on and when it starts next (by the
        // system's clock: a window opens every day).
        let check = std::process::Command::new(env!("CARGO_BIN_EXE_floatball"))
            .arg("check")
            .arg("--data-dir")
            .arg(bridge.data.path())
            .output()
            .expect("floatball check");
        let said = String::from_utf8_lossy(&check.stdout);
        assert!(said.contains("schedule: on, next start 20"), "{said}");
        assert!(said.contains(" 10:00 (UTC)"), "{said}");
        // A restart in the middle of a window resumes its program.
        drop(ws);
        let bridge = bridge.restart(&["--test-clock-at", "2026-12-02T11:00:00Z"]);
        let reply = bridge.login(PASSWORD).await;
        assert_eq!(reply.status, StatusCode::OK);
        let token = reply.json::<floatball_shared::api::LoginResponse>().token;
        let mut ws = bridge.ws(&token).await;
        let mut latest = Latest::default();
        until(&mut ws, &mut latest, family, |l| {
            l.status.state == PlayerState::Playing
        })
        .await;
        let resumed = bridge
            .request(Method::GET, "/api/schedule/status", Some(&token), None)
            .await
            .json::<ScheduleStatus>();
        assert_eq!(last_code(&resumed), "schedule_started_loop", "{resumed:?}");
        assert_eq!(
            resumed.last.map(|l| l.at).as_deref(),
            Some("2026-12-02 11:00")
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_window_starts_and_ends_the_show_on_every_family() {
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
    for (family, config, uim2503) in families {
        let started = std::time::Instant::now();
        a_window_starts_and_ends_the_show(family, &config, uim2503).await;
        println!("{family}: {:.1} s", started.elapsed().as_secs_f64());
    }
}
