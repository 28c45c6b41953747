//! A line-speed change waits up to a minute for the installer's power cycle without
//! holding the catalogue lock: through the real `floatball` binary and a tapped
//! pseudo-terminal gateway that stays silent after `BDR`, a playlist edit made while
//! the change waits answers at once.

mod common;

use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::{Process, Tap, links_up};
use common::send_text;
use floatball_shared::sim::GatewayConfig;

#[tokio::test]
async fn a_playlist_edit_during_a_pending_line_speed_change_answers_at_once() {
    let dir = tempfile::tempdir().expect("temp dir");
    let tap = Tap::new(dir.path(), "gateway0", 9600, GatewayConfig::numbered(4));
    let bridge = Process::start(&format!(
        "[matrix]\nrows = 2\ncols = 2\n[[gateway]]\nport = \"{}\"\nbaud = 9600\n",
        tap.path.display()
    ));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    assert!(links_up(&mut ws).await, "the link comes up");

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
        let playlist = serde_json::json!({
            "entries": [],
            "loop": false,
            "default_delay_ms": 0,
            "default_cycles": 1,
        });
        let started = Instant::now();
        let reply = bridge
            .request(
                Method::PUT,
                "/api/playlist",
                Some(&token),
                Some(("application/json", playlist.to_string().into_bytes())),
            )
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
