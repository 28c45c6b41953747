//! A line-speed change waits up to a minute for the installer's power cycle without
//! holding the catalogue lock: through the real `floatball` binary and a tapped
//! pseudo-terminal gateway that stays silent after `BDR`, a playlist edit made while
//! the change waits answers at once.

use crate::common;

use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::tapped_bridge;

#[tokio::test]
async fn a_playlist_edit_during_a_pending_line_speed_change_answers_at_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (tap, bridge, token, _ws) = tapped_bridge(dir.path()).await;

    // The gateway takes BDR and then hangs: the change waits for a power cycle that
    // does not come.
    let change = bridge.request(
        Method::POST,
        "/api/gateways/0/baud",
        Some(&token),
        Some(("application/json", br#"{"baud":38400}"#.to_vec())),
    );
    let edit = async {
        let deadline = Instant::now() + Duration::from_secs(10);
        while !tap.wire().windows(4).any(|window| window == b"BDR=") {
            assert!(Instant::now() < deadline, "BDR reached the line");
            tokio::time::sleep(Duration::from_millis(1)).await;
        }
        tap.set_answering(false);
        tokio::time::sleep(Duration::from_millis(200)).await;
        let started = Instant::now();
        let reply = bridge
            .put_playlist(&token, serde_json::json!([]), false)
            .await;
        (reply, started.elapsed())
    };
    let (reply, took) = tokio::select! {
        done = change => panic!("the line-speed change ended before the edit: {done:?}"),
        edited = edit => edited,
    };
    assert_eq!(reply.status, StatusCode::OK, "{reply:?}");
    assert!(
        took < Duration::from_millis(500),
        "the playlist edit took {took:?} during the line-speed change"
    );
}
