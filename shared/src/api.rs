//! The JSON messages of the HTTP and WebSocket API (DESIGN §4).
//!
//! The bridge serialises these and the web app deserialises them (and the other way
//! round for [`ClientMessage`]), so the wire contract lives in exactly one place.
//! Every WebSocket text frame is one JSON object with a `"type"` field.

use serde::{Deserialize, Serialize};

/// A message from a client (the web app, a test) to the bridge over `/ws`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ClientMessage {
    /// Play the playlist from its first entry.
    Start,
    /// Stop every ball at once (sent ahead of anything queued).
    Estop,
    /// Stop, return every ball home and restart from the first entry.
    Reset,
    /// A console line of instructions, checked by the codec before it is sent.
    Raw {
        /// The instruction text, e.g. `*5;PV;`.
        line: String,
    },
    /// Liveness check; the bridge answers [`ServerMessage::Pong`].
    Ping,
}

/// A message from the bridge to a client over `/ws`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ServerMessage {
    /// The state of the matrix, sent on connect, on every change and at most ten
    /// times a second.
    Status(Status),
    /// The answer to a [`ClientMessage::Ping`].
    Pong,
    /// A request was refused; the connection stays open.
    Error {
        /// What was wrong, in words an operator can act on.
        message: String,
    },
}

/// What the player is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlayerState {
    /// Nothing is playing.
    #[default]
    Idle,
    /// Balls are moving to the first position of a show.
    Approaching,
    /// Rows are being preloaded into the units.
    Loading,
    /// A show is running.
    Playing,
    /// Stopped by an e-stop; Start homes first.
    Stopped,
    /// Balls are returning to position 0.
    Homing,
    /// Something went wrong; see [`Status::last_error`].
    Error,
}

/// The state of one gateway's serial link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkState {
    /// The link is open and bytes flow.
    Up,
    /// The link is being opened (or reopened after a loss).
    Connecting,
    /// The link is lost; the bridge retries with backoff.
    Down,
}

/// One gateway as shown in the status.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GatewayStatus {
    /// The configured port (`sim` for the simulated gateway).
    pub port: String,
    /// Whether the link is up.
    pub link: LinkState,
}

/// The `status` message.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Status {
    /// What the player is doing.
    pub state: PlayerState,
    /// Every configured gateway and its link.
    pub gateways: Vec<GatewayStatus>,
    /// The last error, if any, in words an operator can act on.
    pub last_error: Option<String>,
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn client_messages_use_the_documented_json() {
        let raw: ClientMessage =
            serde_json::from_str(r#"{"type":"raw","line":"*5;PV;"}"#).expect("valid raw");
        assert_eq!(
            raw,
            ClientMessage::Raw {
                line: "*5;PV;".into()
            }
        );
        let estop: ClientMessage = serde_json::from_str(r#"{"type":"estop"}"#).expect("estop");
        assert_eq!(estop, ClientMessage::Estop);
    }

    #[test]
    fn status_serialises_with_a_type_tag() {
        let json = serde_json::to_value(ServerMessage::Status(Status::default())).expect("json");
        assert_eq!(json["type"], "status");
        assert_eq!(json["state"], "idle");
    }

    #[test]
    fn unknown_types_are_refused() {
        assert!(serde_json::from_str::<ClientMessage>(r#"{"type":"dance"}"#).is_err());
    }
}
