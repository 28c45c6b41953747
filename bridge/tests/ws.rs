//! The WebSocket endpoint over real sockets: who may connect, status delivery and its
//! rate, many clients, and answers to every kind of message.

use crate::common;

use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::{Bridge, Ws, next_message, next_reply, send_text};
use floatball_shared::api::{PlayerState, ServerMessage};
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::client::IntoClientRequest;
use tokio_tungstenite::tungstenite::{Error as WsError, Message};

/// Opens `/ws` with `origin` (if any) and returns the HTTP status of a refusal.
async fn refused_status(bridge: &Bridge, query: &str, origin: Option<&str>) -> Option<u16> {
    let mut request = format!("ws://{}/ws{query}", bridge.addr)
        .into_client_request()
        .expect("request");
    if let Some(origin) = origin {
        request
            .headers_mut()
            .insert("origin", origin.parse().expect("header"));
    }
    match tokio_tungstenite::connect_async(request).await {
        Ok(_) => None,
        Err(WsError::Http(response)) => Some(response.status().as_u16()),
        Err(other) => panic!("unexpected error: {other}"),
    }
}

fn expect_error(message: ServerMessage) -> String {
    match message {
        ServerMessage::Error { message, .. } => message,
        other => panic!("expected an error, got {other:?}"),
    }
}

async fn first_status(ws: &mut Ws) {
    let ServerMessage::Status(_) = next_message(ws).await else {
        panic!("the first message is not a status");
    };
}

#[tokio::test]
async fn the_websocket_needs_a_valid_token() {
    let bridge = Bridge::start().await;
    assert_eq!(refused_status(&bridge, "", None).await, Some(401));
    assert_eq!(refused_status(&bridge, "?token=abc", None).await, Some(401));
    let token = bridge.token().await;
    assert_eq!(
        refused_status(&bridge, &format!("?token={token}"), None).await,
        None
    );
}

#[tokio::test]
async fn cross_site_origins_are_refused_before_the_upgrade() {
    let bridge = Bridge::start_with("allowed_origins = [\"http://kiosk.local:3000\"]\n").await;
    let token = bridge.token().await;
    let query = format!("?token={token}");
    let own = format!("http://{}", bridge.addr);
    assert_eq!(
        refused_status(&bridge, &query, Some("http://evil.example")).await,
        Some(403)
    );
    assert_eq!(
        refused_status(&bridge, &query, Some("null")).await,
        Some(403)
    );
    assert_eq!(
        refused_status(&bridge, "", Some("http://evil.example")).await,
        Some(403)
    );
    assert_eq!(refused_status(&bridge, &query, Some(&own)).await, None);
    assert_eq!(
        refused_status(&bridge, &query, Some("http://kiosk.local:3000")).await,
        None
    );
}

#[tokio::test]
async fn status_arrives_on_connect_and_on_change() {
    let bridge = Bridge::start().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    let ServerMessage::Status(status) = next_message(&mut ws).await else {
        panic!("first message is not a status");
    };
    assert_eq!(status.state, PlayerState::Idle);

    // The e-stop is obeyed even before the password change, answered at once, and
    // the status follows.
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let mut acknowledged = false;
    loop {
        match next_message(&mut ws).await {
            ServerMessage::EstopSent { unreached } => {
                assert!(unreached.is_empty(), "{unreached:?}");
                acknowledged = true;
            }
            ServerMessage::Status(status) if status.state == PlayerState::Stopped => break,
            ServerMessage::Status(_) => {}
            other => panic!("unexpected {other:?}"),
        }
    }
    assert!(
        acknowledged,
        "the e-stop is answered before the status changes"
    );
}

#[tokio::test]
async fn status_is_sent_at_most_ten_times_a_second_and_the_latest_wins() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    first_status(&mut ws).await;
    // Homing changes its progress every few milliseconds.
    send_text(&mut ws, r#"{"type":"home"}"#).await;
    let started = Instant::now();
    let mut received = 0;
    // A new state goes out at once, beside the rate.
    let mut states = 0;
    let mut last_state = None;
    let mut homed = false;
    while started.elapsed() < Duration::from_secs(60) {
        match next_message(&mut ws).await {
            ServerMessage::Status(status) => {
                if last_state == Some(status.state) {
                    received += 1;
                } else {
                    states += 1;
                }
                last_state = Some(status.state);
                if status.state == PlayerState::Homing {
                    homed = true;
                }
                if homed && status.state == PlayerState::Idle {
                    break;
                }
            }
            // The units' answers to the homing move.
            ServerMessage::EstopSent { .. } | ServerMessage::Feedback(_) => {}
            other => panic!("unexpected {other:?}"),
        }
    }
    assert!(homed, "the matrix homed");
    let elapsed_s = started.elapsed().as_secs_f64();
    let allowed = (elapsed_s * 10.0).ceil() as usize + 1;
    assert!(
        received <= allowed,
        "{received} statuses without a new state in {elapsed_s:.2} s (at most {allowed})"
    );
    assert!(states >= 2, "every new state is sent: {states}");
    assert!(
        received >= 2,
        "changes are sent while they happen: {received}"
    );
}

#[tokio::test]
async fn a_hundred_clients_each_get_every_status() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let mut clients = Vec::new();
    for _ in 0..100 {
        let mut ws = bridge.ws(&token).await;
        first_status(&mut ws).await;
        clients.push(ws);
    }
    send_text(&mut clients[0], r#"{"type":"estop"}"#).await;
    let received = futures_util::future::join_all(clients.iter_mut().map(|ws| async move {
        loop {
            match next_message(ws).await {
                ServerMessage::Status(status) if status.state == PlayerState::Stopped => {
                    return status.state;
                }
                ServerMessage::Status(_) | ServerMessage::EstopSent { .. } => {}
                other => panic!("expected a status, got {other:?}"),
            }
        }
    }))
    .await;
    assert!(received.iter().all(|state| *state == PlayerState::Stopped));
    assert_eq!(received.len(), 100);
}

#[tokio::test]
async fn bad_messages_get_an_error_and_the_connection_stays() {
    let bridge = Bridge::start().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    first_status(&mut ws).await;

    send_text(&mut ws, "{not json").await;
    assert!(expect_error(next_reply(&mut ws).await).contains("did not understand the message"));
    send_text(&mut ws, r#"{"type":"dance"}"#).await;
    assert!(expect_error(next_reply(&mut ws).await).contains("dance"));
    futures_util::SinkExt::send(&mut ws, Message::binary(vec![1, 2, 3]))
        .await
        .expect("send");
    assert!(expect_error(next_reply(&mut ws).await).contains("text frames"));

    send_text(&mut ws, r#"{"type":"ping"}"#).await;
    assert_eq!(next_reply(&mut ws).await, ServerMessage::Pong);
}

#[tokio::test]
async fn console_lines_and_control_need_a_changed_password() {
    let bridge = Bridge::start().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    first_status(&mut ws).await;
    for message in [
        r#"{"type":"raw","line":"*5;PV;"}"#,
        r#"{"type":"start"}"#,
        r#"{"type":"reset"}"#,
    ] {
        send_text(&mut ws, message).await;
        let error = expect_error(next_reply(&mut ws).await);
        assert!(error.contains("factory password"), "{message}: {error}");
    }
}

#[tokio::test]
async fn invalid_console_lines_are_refused_with_the_parsers_message() {
    let bridge = Bridge::start().await;
    let mut ws = bridge.ws(&bridge.operator().await).await;
    first_status(&mut ws).await;
    send_text(
        &mut ws,
        r#"{"type":"raw","line":"*20;QP[3]=1000 QV[3]=0;"}"#,
    )
    .await;
    let reply = next_reply(&mut ws).await;
    let ServerMessage::Error { code, params, .. } = &reply else {
        panic!("expected an error, got {reply:?}");
    };
    assert_eq!(code, "ascii_unexpected");
    assert_eq!(
        (params["line"].as_str(), params["column"].as_str()),
        ("1", "16")
    );
    let error = expect_error(reply);
    assert_eq!(
        error,
        "the line is not valid: line 1, column 16: expected `;` after the operand of QP[3], \
         found `Q`"
    );
    send_text(&mut ws, r#"{"type":"raw","line":"QT[0]=0;"}"#).await;
    let error = expect_error(next_reply(&mut ws).await);
    assert!(
        error.starts_with("the line is not valid: line 1, column "),
        "{error}"
    );
    send_text(&mut ws, r#"{"type":"raw","line":"  # only a comment"}"#).await;
    assert!(expect_error(next_reply(&mut ws).await).contains("no instruction"));
}

#[tokio::test]
async fn an_expired_or_ended_token_ends_the_session() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    first_status(&mut ws).await;
    bridge.clock.advance(Duration::from_secs(12 * 3600));
    send_text(&mut ws, r#"{"type":"ping"}"#).await;
    assert!(expect_error(next_reply(&mut ws).await).contains("log in again"));
    let closed = tokio::time::timeout(Duration::from_secs(5), ws.next())
        .await
        .expect("closed within 5 s");
    assert!(
        matches!(closed, Some(Ok(Message::Close(_))) | None),
        "{closed:?}"
    );

    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    first_status(&mut ws).await;
    let logout = bridge
        .request(Method::POST, "/api/logout", Some(&token), None)
        .await;
    assert_eq!(logout.status, StatusCode::NO_CONTENT);
    assert!(expect_error(next_reply(&mut ws).await).contains("log in again"));
}

#[tokio::test]
async fn stopping_the_bridge_closes_open_websockets() {
    let bridge = Bridge::start().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    first_status(&mut ws).await;
    // `restart` stops the server and waits (at most 5 s) for it to finish.
    let _bridge = bridge.restart().await;
    loop {
        let frame = tokio::time::timeout(Duration::from_secs(5), ws.next())
            .await
            .expect("closed within 5 s");
        match frame {
            Some(Ok(Message::Close(Some(close)))) => {
                assert_eq!(u16::from(close.code), 1001);
                break;
            }
            Some(Ok(Message::Text(_))) => {}
            other => panic!("expected a close frame, got {other:?}"),
        }
    }
}
