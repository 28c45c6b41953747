//! The WebSocket endpoint over a real socket: the server on port 0, a real
//! tokio-tungstenite client.

use std::time::Duration;

use floatball_bridge::server;
use floatball_bridge::state::AppState;
use floatball_shared::api::{PlayerState, ServerMessage};
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

async fn start() -> (
    std::net::SocketAddr,
    tokio::sync::oneshot::Sender<()>,
    AppState,
) {
    let static_dir = tempfile::tempdir().expect("temp dir").keep();
    std::fs::write(
        static_dir.join("index.html"),
        "<!doctype html><title>t</title>",
    )
    .unwrap();
    let state = AppState::new(static_dir);
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
    let serving = state.clone();
    tokio::spawn(async move {
        server::run(listener, serving, async {
            let _ = stopped.await;
        })
        .await
        .unwrap();
    });
    (addr, stop, state)
}

async fn next_message(
    ws: &mut tokio_tungstenite::WebSocketStream<
        tokio_tungstenite::MaybeTlsStream<tokio::net::TcpStream>,
    >,
) -> ServerMessage {
    loop {
        let frame = tokio::time::timeout(Duration::from_secs(5), ws.next())
            .await
            .expect("a message within 5 s")
            .expect("stream open")
            .expect("valid frame");
        if let Message::Text(text) = frame {
            return serde_json::from_str(text.as_str()).expect("a ServerMessage");
        }
    }
}

#[tokio::test]
async fn status_arrives_on_connect_and_on_change() {
    let (addr, _stop, state) = start().await;
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .expect("connect");
    let ServerMessage::Status(status) = next_message(&mut ws).await else {
        panic!("first message is not a status");
    };
    assert_eq!(status.state, PlayerState::Idle);

    state.update_status(|status| status.state = PlayerState::Playing);
    let ServerMessage::Status(status) = next_message(&mut ws).await else {
        panic!("expected a status after the change");
    };
    assert_eq!(status.state, PlayerState::Playing);
}

#[tokio::test]
async fn ping_is_answered_and_bad_json_gets_an_error_without_closing() {
    let (addr, _stop, _state) = start().await;
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws"))
        .await
        .expect("connect");
    next_message(&mut ws).await;

    ws.send(Message::text("{not json")).await.unwrap();
    let ServerMessage::Error { message } = next_message(&mut ws).await else {
        panic!("malformed JSON must be answered with an error");
    };
    assert!(message.contains("not a valid message"), "{message}");

    ws.send(Message::text(r#"{"type":"ping"}"#)).await.unwrap();
    assert_eq!(next_message(&mut ws).await, ServerMessage::Pong);
}

#[tokio::test]
async fn the_app_is_served_and_unknown_paths_fall_back_to_index() {
    let (addr, _stop, _state) = start().await;
    for path in ["/", "/control"] {
        let mut stream = tokio::net::TcpStream::connect(addr).await.unwrap();
        use tokio::io::{AsyncReadExt, AsyncWriteExt};
        stream
            .write_all(
                format!("GET {path} HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n").as_bytes(),
            )
            .await
            .unwrap();
        let mut response = String::new();
        stream.read_to_string(&mut response).await.unwrap();
        assert!(response.starts_with("HTTP/1.1 200"), "{path}: {response}");
        assert!(response.contains("<title>t</title>"), "{path}: {response}");
    }
}
