//! The WebSocket endpoint `/ws`: sends `status` on connect and on every change, and
//! answers client messages.

use axum::extract::State;
use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::response::Response;
use floatball_shared::api::{ClientMessage, ServerMessage};

use crate::state::AppState;

/// Upgrades an HTTP request to the `/ws` WebSocket.
pub async fn upgrade(ws: WebSocketUpgrade, State(state): State<AppState>) -> Response {
    ws.on_upgrade(move |socket| session(socket, state))
}

/// One client's session: the current status at once, then every change, until the
/// client goes away.
async fn session(mut socket: WebSocket, state: AppState) {
    let mut status = state.subscribe_status();
    let first = ServerMessage::Status(status.borrow_and_update().clone());
    if send(&mut socket, &first).await.is_err() {
        return;
    }
    loop {
        tokio::select! {
            changed = status.changed() => {
                if changed.is_err() {
                    return;
                }
                let message = ServerMessage::Status(status.borrow_and_update().clone());
                if send(&mut socket, &message).await.is_err() {
                    return;
                }
            }
            incoming = socket.recv() => {
                let Some(Ok(incoming)) = incoming else { return };
                let reply = match incoming {
                    Message::Text(text) => answer(text.as_str()),
                    Message::Close(_) => return,
                    _ => continue,
                };
                if send(&mut socket, &reply).await.is_err() {
                    return;
                }
            }
        }
    }
}

/// The reply to one text frame from a client.
fn answer(text: &str) -> ServerMessage {
    match serde_json::from_str::<ClientMessage>(text) {
        Ok(ClientMessage::Ping) => ServerMessage::Pong,
        Ok(other) => ServerMessage::Error {
            message: format!("{other:?} is not supported by this bridge yet"),
        },
        Err(err) => ServerMessage::Error {
            message: format!("not a valid message: {err}"),
        },
    }
}

async fn send(socket: &mut WebSocket, message: &ServerMessage) -> Result<(), axum::Error> {
    let text = serde_json::to_string(message).map_err(axum::Error::new)?;
    socket.send(Message::Text(text.into())).await
}
