//! Many gateways in the live status: with more than `GATEWAY_DETAIL_LIMIT` gateways the
//! WebSocket's status details only those with a problem and counts them all in its
//! `gateway_summary`, and `GET /api/status/gateways` lists every one in installation
//! order. A status of 100 gateways that are all up stays under 2 KB.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use common::Bridge;
use floatball_shared::api::{GatewayStatus, LinkState, ServerMessage, Status};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

/// A configuration of `gateways` gateways of `units` units each (one row a gateway),
/// each `port = "sim"` except those at `broken` (a serial port that is not there).
fn config(gateways: usize, units: usize, broken: &[usize]) -> String {
    let mut text = format!("[matrix]\nrows = {gateways}\ncols = {units}\n");
    for index in 0..gateways {
        let port = if broken.contains(&index) {
            format!("/dev/floatball-no-such-port-{index}")
        } else {
            "sim".to_owned()
        };
        text.push_str(&format!(
            "[[gateway]]\nport = \"{port}\"\nunits = {units}\n"
        ));
    }
    text
}

/// The next status over the WebSocket that satisfies `wanted`, with its size on the
/// wire (bytes of the JSON text frame), within 10 s.
async fn status_frame(ws: &mut common::Ws, wanted: impl Fn(&Status) -> bool) -> (Status, usize) {
    tokio::time::timeout(Duration::from_secs(10), async {
        loop {
            let frame = ws.next().await.expect("open").expect("frame");
            let Message::Text(text) = frame else { continue };
            if let Ok(ServerMessage::Status(status)) = serde_json::from_str(text.as_str())
                && wanted(&status)
            {
                return (status, text.len());
            }
        }
    })
    .await
    .expect("no such status within 10 s")
}

/// How many of `all` are up.
fn up(all: &[GatewayStatus]) -> usize {
    all.iter()
        .filter(|gateway| gateway.link == LinkState::Up)
        .count()
}

/// `GET /api/status/gateways` until its answer satisfies `wanted` (the list is
/// published beside the status, at most four times a second), within 5 s.
async fn list_until(
    bridge: &Bridge,
    token: &str,
    wanted: impl Fn(&[GatewayStatus]) -> bool,
) -> Vec<GatewayStatus> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    loop {
        let reply = bridge
            .request(Method::GET, "/api/status/gateways", Some(token), None)
            .await;
        assert_eq!(reply.status, StatusCode::OK);
        let all: Vec<GatewayStatus> = reply.json();
        if wanted(&all) {
            return all;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the list never matched: {all:?}"
        );
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test]
async fn twenty_gateways_are_summarised_and_listed_in_full_on_request() {
    let bridge = Bridge::start_with(&config(20, 3, &[7])).await;
    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    let (status, _) = status_frame(&mut ws, |status| status.gateway_summary.up == 19).await;
    let summary = &status.gateway_summary;
    assert!(!summary.complete, "{summary:?}");
    assert_eq!((summary.total, summary.up), (20, 19));
    assert_eq!(summary.problems, vec![7]);
    assert_eq!(
        status
            .gateways
            .iter()
            .map(|gateway| gateway.index)
            .collect::<Vec<_>>(),
        vec![7],
        "only the gateway with a problem is detailed"
    );
    let broken = &status.gateways[0];
    assert_ne!(broken.link, LinkState::Up);
    assert!(broken.port.contains("no-such-port-7"), "{broken:?}");

    let all = list_until(&bridge, &token, |all| up(all) == 19).await;
    assert_eq!(all.len(), 20);
    assert_eq!(
        all.iter().map(|gateway| gateway.index).collect::<Vec<_>>(),
        (0..20).collect::<Vec<_>>()
    );
    assert_eq!(
        all.iter()
            .filter(|gateway| gateway.link == LinkState::Up)
            .count(),
        19
    );
    assert!(all.iter().filter(|g| g.index != 7).all(|g| g.port == "sim"));
    assert!(all[7].error.is_some(), "{:?}", all[7]);

    // Only for a logged-in client.
    let reply = bridge
        .request(Method::GET, "/api/status/gateways", None, None)
        .await;
    assert_eq!(reply.status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn a_status_of_a_hundred_gateways_that_are_all_up_is_small() {
    let bridge = Bridge::start_with(&config(100, 1, &[])).await;
    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    let (status, bytes) = status_frame(&mut ws, |status| status.gateway_summary.up == 100).await;
    println!("a status of 100 gateways, all up: {bytes} bytes");
    assert!(status.gateways.is_empty(), "{:?}", status.gateways);
    assert_eq!(status.gateway_summary.total, 100);
    assert!(bytes < 2048, "{bytes} bytes");

    let all = list_until(&bridge, &token, |all| up(all) == 100).await;
    assert_eq!(all.len(), 100);
    println!(
        "GET /api/status/gateways with 100 gateways: {} bytes",
        serde_json::to_string(&all).expect("json").len()
    );
}
