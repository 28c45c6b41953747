//! Arming through the real `floatball` binary on its simulated gateway: while the
//! matrix is idle the playlist's first entry is loaded ahead of Start (`armed` in the
//! status, its progress up to 1.0) and nothing moves; Start then needs only the
//! approach; an e-stop or a console line disarms; a new playlist arms its first entry.

use crate::common;

use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::{Process, wave_json};
use common::{Ws, next_message, send_text, status_until};
use floatball_shared::api::{PlayerState, ServerMessage, SimPositions, SimUnit, Status};

/// 2 × 2 balls on the simulated gateway at 19200 baud: a 4 s show (40 rows of
/// 100 ms a ball) takes more than a second to load.
const CONFIG: &str = "[matrix]\nrows = 2\ncols = 2\n\n[[gateway]]\nport = \"sim\"\nbaud = 19200\n";

async fn units(bridge: &Process, token: &str) -> Vec<SimUnit> {
    let reply = bridge
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    let positions: SimPositions = reply.json();
    positions.gateways[0].units.clone()
}

/// Reads statuses until the show is armed completely; every `armed` on the way names
/// `show` with a progress that never goes back. Returns whether a partial progress was
/// seen.
async fn armed(ws: &mut Ws, show: &str, within: Duration) -> bool {
    let deadline = Instant::now() + within;
    let mut last = 0.0;
    let mut partial = false;
    loop {
        assert!(Instant::now() < deadline, "{show} was not armed in time");
        let ServerMessage::Status(status) = next_message(ws).await else {
            continue;
        };
        let Some(armed) = status.armed else {
            continue;
        };
        assert_eq!(
            status.state,
            PlayerState::Idle,
            "armed while {:?}",
            status.state
        );
        if armed.show != show {
            continue;
        }
        assert_eq!(armed.entry, 0);
        assert!(armed.progress >= last, "{} after {last}", armed.progress);
        last = armed.progress;
        partial |= armed.progress > 0.0 && armed.progress < 1.0;
        if armed.progress == 1.0 {
            return partial;
        }
    }
}

/// Reads statuses for `within`; panics if one is armed.
async fn stays_disarmed(ws: &mut Ws, within: Duration) -> Status {
    let deadline = tokio::time::Instant::now() + within;
    let mut last = None;
    while let Ok(message) = tokio::time::timeout_at(deadline, next_message(ws)).await {
        if let ServerMessage::Status(status) = message {
            assert_eq!(status.armed, None, "armed again at once");
            last = Some(status);
        }
    }
    last.unwrap_or_default()
}

async fn put_playlist(bridge: &Process, token: &str, show: &str) {
    let playlist = serde_json::json!({
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
            Some(("application/json", playlist.to_string().into_bytes())),
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_idle_matrix_is_armed_without_moving_and_start_skips_the_load() {
    let bridge = Process::start(CONFIG);
    let token = bridge
        .prepare_show("wave", &wave_json("wave", 2, 2, 4000, 40.0), false)
        .await;
    let before = units(&bridge, &token).await;
    let mut ws = bridge.ws(&token).await;
    let partial = armed(&mut ws, "wave", Duration::from_secs(15)).await;
    assert!(partial, "the progress was shown on the way to 1.0");
    let after = units(&bridge, &token).await;
    assert_eq!(after, before, "nothing moved and no motor was switched on");

    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let playing = status_until(&mut ws, Duration::from_secs(20), |status| {
        assert_eq!(status.armed, None, "a running show is not armed");
        status.state == PlayerState::Playing
    })
    .await;
    assert_eq!(playing.show.as_deref(), Some("wave"));
    assert!(
        bridge.log().lines().all(|line| !line.contains("ERROR")),
        "{}",
        bridge.log()
    );
    // The show plays to its end; idle again, it is armed again.
    status_until(&mut ws, Duration::from_secs(15), |status| {
        status.state == PlayerState::Idle
    })
    .await;
    armed(&mut ws, "wave", Duration::from_secs(10)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_start_after_arming_has_no_loading_phase() {
    let bridge = Process::start(CONFIG);
    let token = bridge
        .prepare_show("wave", &wave_json("wave", 2, 2, 4000, 40.0), false)
        .await;
    // The plan says how long the load takes at Start when nothing is armed.
    let plan = bridge
        .request(Method::GET, "/api/plan/wave", Some(&token), None)
        .await;
    let plan: floatball_shared::api::PlanReport = plan.json();
    assert!(plan.preload_ms > 1000, "{}", plan.preload_ms);
    let mut ws = bridge.ws(&token).await;
    armed(&mut ws, "wave", Duration::from_secs(15)).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    // Loading may show for the arm-and-confirm round trip, never with rows to load.
    let mut loading: Option<Instant> = None;
    let mut loading_for = Duration::ZERO;
    loop {
        let ServerMessage::Status(status) = next_message(&mut ws).await else {
            continue;
        };
        match status.state {
            PlayerState::Loading => {
                assert_eq!(status.progress, 1.0, "rows were loaded at Start");
                loading.get_or_insert_with(Instant::now);
            }
            PlayerState::Playing => {
                if let Some(since) = loading {
                    loading_for = since.elapsed();
                }
                break;
            }
            PlayerState::Homing | PlayerState::Approaching | PlayerState::Idle => {}
            other => panic!("{other:?}: {:?}", status.last_error),
        }
    }
    assert!(
        loading_for * 4 < Duration::from_millis(plan.preload_ms),
        "loading took {loading_for:?} of a {} ms preload",
        plan.preload_ms
    );

    // An e-stop while it plays: the next Start homes first (the balls' positions are
    // unknown), as on every drive family.
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    status_until(&mut ws, Duration::from_secs(2), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (states, _) = common::until(&mut ws, Duration::from_secs(30), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    let moves: Vec<PlayerState> = states
        .into_iter()
        .filter(|state| !matches!(state, PlayerState::Stopped | PlayerState::Idle))
        .collect();
    // (This show starts at the home position: no approach follows.)
    assert_eq!(moves.first(), Some(&PlayerState::Homing), "{moves:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_estop_or_a_console_line_disarms_and_a_new_playlist_arms_its_first_entry() {
    let bridge = Process::start(CONFIG);
    let token = bridge
        .prepare_show("wave", &wave_json("wave", 2, 2, 4000, 40.0), false)
        .await;
    let other = bridge
        .upload(
            &token,
            "other",
            "application/json",
            &wave_json("other", 2, 2, 3000, 30.0),
        )
        .await;
    assert_eq!(other.status, StatusCode::CREATED);
    let mut ws = bridge.ws(&token).await;
    armed(&mut ws, "wave", Duration::from_secs(15)).await;

    // An e-stop disarms, and nothing is armed while the matrix is stopped.
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let stopped = status_until(&mut ws, Duration::from_secs(2), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    assert_eq!(stopped.armed, None);
    let still = stays_disarmed(&mut ws, Duration::from_secs(4)).await;
    assert_eq!(still.state, PlayerState::Stopped);

    // Home: idle again, armed again.
    send_text(&mut ws, r#"{"type":"home"}"#).await;
    armed(&mut ws, "wave", Duration::from_secs(20)).await;

    // A console line (a query, even) disarms; arming waits for the quiet time.
    send_text(&mut ws, r#"{"type":"raw","line":"*1;PA;"}"#).await;
    status_until(&mut ws, Duration::from_secs(2), |status| {
        status.armed.is_none()
    })
    .await;
    stays_disarmed(&mut ws, Duration::from_secs(2)).await;
    armed(&mut ws, "wave", Duration::from_secs(15)).await;

    // A new playlist: its first entry is armed.
    put_playlist(&bridge, &token, "other").await;
    status_until(&mut ws, Duration::from_secs(2), |status| {
        status.armed.is_none()
    })
    .await;
    armed(&mut ws, "other", Duration::from_secs(15)).await;
}
