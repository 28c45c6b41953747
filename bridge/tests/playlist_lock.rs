//! The playlist is locked while the matrix runs, through the real `floatball` binary on
//! a simulated gateway: while a show plays, a `PUT /api/playlist` that changes the
//! entries is refused with 409 `playlist_locked` and nothing is stored, one that only
//! changes loop or the defaults is taken; after an E-stop the entries may change
//! again. Home then brings every ball home with a status of its own (no show, no
//! stale time) and the matrix stays idle.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use common::process::{Process, wave_json};
use common::{Remote, send_text, status_until};
use floatball_shared::api::{PlayerState, Playlist, SimPositions};

const SMALL: &str = "[matrix]\nrows = 2\ncols = 2\n\n[[gateway]]\nport = \"sim\"\nbaud = 115200\n\n\
                     [safety]\napproach_speed_mm_s = 2000.0\n";

async fn get_playlist(bridge: &Remote, token: &str) -> Playlist {
    let reply = bridge
        .request(Method::GET, "/api/playlist", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    reply.json()
}

async fn put_playlist(bridge: &Remote, token: &str, playlist: &Playlist) -> common::Reply {
    bridge
        .request(
            Method::PUT,
            "/api/playlist",
            Some(token),
            Some(("application/json", serde_json::to_vec(playlist).unwrap())),
        )
        .await
}

async fn positions(bridge: &Remote, token: &str) -> SimPositions {
    let reply = bridge
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    reply.json()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_entries_are_locked_while_a_show_plays_and_home_stays_idle() {
    let bridge = Process::start(SMALL);
    let token = bridge
        .prepare_show("wave", &wave_json("wave", 2, 2, 20_000, 150.0), false)
        .await;
    let mut ws = bridge.ws(&token).await;
    // A Start before the simulated gateway's link is up is refused (not connected).
    assert!(
        common::process::links_up(&mut ws).await,
        "the link comes up"
    );
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    status_until(&mut ws, Duration::from_secs(20), |s| {
        s.state == PlayerState::Playing
    })
    .await;

    let stored = get_playlist(&bridge, &token).await;
    let mut added = stored.clone();
    added.entries.push(added.entries[0].clone());
    let mut cycles = stored.clone();
    cycles.entries[0].cycles = 5;
    let mut emptied = stored.clone();
    emptied.entries.clear();
    for edit in [&added, &cycles, &emptied] {
        let reply = put_playlist(&bridge, &token, edit).await;
        assert_eq!(reply.status, StatusCode::CONFLICT, "{:?}", reply.body);
        let error = reply.error();
        assert!(error.error.contains("cannot change"), "{error:?}");
        assert_eq!(error.code, "playlist_locked", "{error:?}");
    }
    assert_eq!(
        get_playlist(&bridge, &token).await,
        stored,
        "nothing stored"
    );

    // Loop and the defaults are not what plays now: they may change.
    let mut settings = stored.clone();
    settings.loop_playlist = true;
    settings.default_cycles = 2;
    let reply = put_playlist(&bridge, &token, &settings).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);

    // Stopped, the entries may change again.
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    status_until(&mut ws, Duration::from_secs(2), |s| {
        s.state == PlayerState::Stopped
    })
    .await;
    let reply = put_playlist(&bridge, &token, &cycles).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);

    // Home: its own progress, no show and no stale time, then idle at home.
    send_text(&mut ws, r#"{"type":"home"}"#).await;
    let homing = status_until(&mut ws, Duration::from_secs(5), |s| {
        s.state == PlayerState::Homing
    })
    .await;
    assert_eq!(
        (homing.entry, homing.show.as_deref(), homing.show_time_ms),
        (None, None, 0),
        "{homing:?}"
    );
    assert_eq!(homing.show_duration_ms, 0, "{homing:?}");
    status_until(&mut ws, Duration::from_secs(20), |s| {
        s.state == PlayerState::Idle
    })
    .await;
    let home = positions(&bridge, &token).await;
    assert!(
        home.gateways[0]
            .units
            .iter()
            .all(|unit| !unit.moving && unit.position_counts.abs() < 1.0),
        "{home:?}"
    );
    let left_idle = tokio::time::timeout(
        Duration::from_secs(1),
        status_until(&mut ws, Duration::from_secs(5), |s| {
            s.state != PlayerState::Idle
        }),
    )
    .await;
    assert!(left_idle.is_err(), "Home stays idle: {left_idle:?}");
}
