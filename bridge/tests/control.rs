//! Start / E-stop / Reset through the real server: a show uploaded over HTTP, put in
//! the playlist, started over the WebSocket, played on the simulated matrix; the plan
//! report; an infeasible show refused with its numbers.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use common::{Bridge, send_text, status_until};
use floatball_shared::api::{PlanReport, PlayerState, ServerMessage, SimPositions};

/// A CSV show for a `units`-ball matrix: every ball goes down up to half a metre and back up, in
/// `steps` keyframes 250 ms apart.
fn csv(units: usize, steps: usize) -> String {
    let mut text = String::from("time_ms");
    for unit in 0..units {
        text.push_str(&format!(",u{unit}"));
    }
    text.push('\n');
    for step in 0..steps {
        let half = (steps - 1) as f64 / 2.0;
        let depth_mm = 500.0 * (1.0 - ((step as f64 - half) / half).abs());
        text.push_str(&(step * 250).to_string());
        for unit in 0..units {
            text.push_str(&format!(
                ",{:.1}",
                depth_mm * (0.5 + unit as f64 / (2.0 * units as f64))
            ));
        }
        text.push('\n');
    }
    text
}

const SMALL: &str = "[matrix]\nrows = 2\ncols = 2\n\n[[gateway]]\nport = \"sim\"\nbaud = 115200\n";

async fn playlist(bridge: &Bridge, token: &str, show: &str) {
    let body = serde_json::json!({
        "entries": [{ "show": show, "delay_ms": 0, "cycles": 1 }],
        "loop": false,
        "default_delay_ms": 0,
        "default_cycles": 1,
    });
    let reply = bridge
        .request(
            Method::PUT,
            "/api/playlist",
            Some(token),
            Some(("application/json", serde_json::to_vec(&body).unwrap())),
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
}

async fn positions(bridge: &Bridge, token: &str) -> SimPositions {
    let reply = bridge
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    reply.json()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_uploaded_show_plays_from_the_websocket_and_an_estop_stops_it() {
    let bridge = Bridge::start_with(SMALL).await;
    let token = bridge.operator().await;
    let upload = bridge
        .upload(&token, "down-and-up", "text/csv", csv(4, 25).as_bytes())
        .await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);

    let plan = bridge
        .request(Method::GET, "/api/plan/down-and-up", Some(&token), None)
        .await;
    assert_eq!(plan.status, StatusCode::OK);
    let plan: PlanReport = plan.json();
    assert!(plan.feasible, "{:?}", plan.reason);
    assert_eq!(plan.gateways[0].units, 4);

    playlist(&bridge, &token, "down-and-up").await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let playing = status_until(&mut ws, Duration::from_secs(30), |s| {
        s.state == PlayerState::Playing
    })
    .await;
    assert_eq!(playing.show.as_deref(), Some("down-and-up"));
    assert_eq!(playing.entry, Some(0));

    tokio::time::sleep(Duration::from_millis(1500)).await;
    let moving = positions(&bridge, &token).await;
    let units = &moving.gateways[0].units;
    assert_eq!(units.len(), 4);
    assert!(
        units
            .iter()
            .all(|unit| unit.moving && unit.position_counts > 0.0),
        "{units:?}"
    );

    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    status_until(&mut ws, Duration::from_secs(2), |s| {
        s.state == PlayerState::Stopped
    })
    .await;
    // `stopped` is said once the stop is written; the units take it as it arrives
    // over their line, a moment later.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(1);
    loop {
        let stopped = positions(&bridge, &token).await;
        let units = &stopped.gateways[0].units;
        if units.iter().all(|unit| !unit.moving && !unit.motor_on) {
            break;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "still moving 1 s after the e-stop: {units:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn start_needs_the_password_changed_and_a_playlist() {
    let bridge = Bridge::start_with(SMALL).await;
    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let reply = common::next_reply(&mut ws).await;
    assert!(
        matches!(&reply, ServerMessage::Error { message, .. } if message.contains("factory password")),
        "{reply:?}"
    );
    let token = {
        let reply = bridge
            .change_password(&token, "1234", common::PASSWORD)
            .await;
        assert_eq!(reply.status, StatusCode::NO_CONTENT);
        let login = bridge.login(common::PASSWORD).await;
        login.json::<floatball_shared::api::LoginResponse>().token
    };
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let reply = common::next_reply(&mut ws).await;
    assert!(
        matches!(&reply, ServerMessage::Error { message, code, .. }
            if message.contains("playlist is empty") && code == "playlist_empty"),
        "{reply:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_infeasible_show_is_refused_with_numbers() {
    // The default 10 × 10 matrix on one gateway at the factory's 9600 baud.
    let bridge = Bridge::start_with("[[gateway]]\nport = \"sim\"\nbaud = 9600\n").await;
    let token = bridge.operator().await;
    let upload = bridge
        .upload(&token, "long", "text/csv", csv(100, 301).as_bytes())
        .await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
    let plan: PlanReport = bridge
        .request(Method::GET, "/api/plan/long", Some(&token), None)
        .await
        .json();
    assert!(!plan.feasible);
    assert!(
        plan.reason
            .as_deref()
            .unwrap_or_default()
            .contains("960 B/s"),
        "{plan:?}"
    );

    playlist(&bridge, &token, "long").await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let reply = common::next_reply(&mut ws).await;
    let ServerMessage::Error {
        message,
        code,
        params,
        reason_problem,
        fix_problems,
    } = reply
    else {
        panic!("expected a refusal, got {reply:?}");
    };
    assert!(
        message.contains("cannot run") && message.contains("B/s"),
        "{message}"
    );
    assert!(message.contains("To make it run"), "{message}");
    // The same as codes for the app, the English params kept for API clients.
    assert_eq!(code, "entry_infeasible");
    assert_eq!(
        (params["entry"].as_str(), params["show"].as_str()),
        ("1", "long")
    );
    assert!(params["reason"].contains("960 B/s"), "{params:?}");
    let reason = reason_problem.expect("the reason as a coded problem");
    assert!(reason.code.starts_with("line_starved"), "{reason:?}");
    assert_eq!(
        (
            reason.params["baud"].as_str(),
            reason.params["available_bytes_per_s"].as_str()
        ),
        ("9600", "960")
    );
    // One coded fix per English one, in the same order.
    let fixes: Vec<&str> = fix_problems.iter().map(|fix| fix.code.as_str()).collect();
    assert_eq!(
        fixes,
        ["fix_faster_line", "fix_fewer_units", "fix_fewer_rows"],
        "{params:?}"
    );
    assert_eq!(fix_problems[0].params["baud"], "19200");
    assert!(params["fixes"].starts_with("raise the line to 19200 baud"));
    // Nothing moved.
    let still = positions(&bridge, &token).await;
    assert!(still.gateways[0].units.iter().all(|unit| !unit.moving));
}

#[tokio::test]
async fn plan_and_positions_need_a_session_and_a_known_show() {
    let bridge = Bridge::start_with(SMALL).await;
    let anonymous = bridge
        .request(Method::GET, "/api/sim/positions", None, None)
        .await;
    assert_eq!(anonymous.status, StatusCode::UNAUTHORIZED);
    let token = bridge.token().await;
    let missing = bridge
        .request(Method::GET, "/api/plan/nothing", Some(&token), None)
        .await;
    assert_eq!(missing.status, StatusCode::NOT_FOUND);
    let sim = positions(&bridge, &token).await;
    assert_eq!(sim.gateways.len(), 1);
    assert_eq!(sim.gateways[0].units.len(), 4);
}

#[tokio::test]
async fn the_example_show_in_the_docs_runs_on_the_default_matrix() {
    let example = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../docs/examples/ripple-10x10.csv"
    ))
    .expect("docs/examples/ripple-10x10.csv");
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let upload = bridge.upload(&token, "ripple", "text/csv", &example).await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
    let plan: PlanReport = bridge
        .request(Method::GET, "/api/plan/ripple", Some(&token), None)
        .await
        .json();
    assert!(plan.feasible, "{plan:?}");
    assert_eq!(plan.gateways[0].units, 100);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_playlist_is_locked_while_a_start_is_planned() {
    // Planning takes a while and the status still says idle all that time: a Start
    // that has read the playlist locks it until the player took or refused it.
    let bridge = Bridge::start_with(SMALL).await;
    let token = bridge.operator().await;
    for name in ["first", "second"] {
        let upload = bridge
            .upload(&token, name, "text/csv", csv(4, 25).as_bytes())
            .await;
        assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
    }
    playlist(&bridge, &token, "first").await;
    let changed = serde_json::json!({
        "entries": [{ "show": "second", "delay_ms": 0, "cycles": 1 }],
        "loop": false,
        "default_delay_ms": 0,
        "default_cycles": 1,
    });
    let put = || {
        bridge.request(
            Method::PUT,
            "/api/playlist",
            Some(&token),
            Some(("application/json", serde_json::to_vec(&changed).unwrap())),
        )
    };

    let pending = bridge.state.start_pending().await;
    let refused = put().await;
    assert_eq!(refused.status, StatusCode::CONFLICT, "{:?}", refused.body);
    assert_eq!(refused.error().code, "playlist_locked");
    assert!(
        refused.error().error.contains("starting"),
        "{:?}",
        refused.body
    );

    drop(pending);
    let taken = put().await;
    assert_eq!(taken.status, StatusCode::OK, "{:?}", taken.body);
}
