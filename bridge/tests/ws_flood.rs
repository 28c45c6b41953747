//! A client that sends faster than the bridge can answer, through the real `floatball`
//! binary: each message is answered, or the connection closes with 1008 and the reason
//! (docs/api.md, "Replies and floods"); an e-stop in the middle of a flood is still
//! pressed and acknowledged.

use crate::common;

use std::time::Duration;

use common::process::Process;
use common::{Ws, next_message, send_text};
use floatball_bridge::ws::{FLOODED, REPLY_LIMIT};
use floatball_shared::api::{PlayerState, ServerMessage};
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::protocol::frame::coding::CloseCode;

const PING: &str = r#"{"type":"ping"}"#;
const ESTOP: &str = r#"{"type":"estop"}"#;
/// Refused with an `error`: no such type.
const NONSENSE: &str = r#"{"type":"nonsense"}"#;

/// What came back from a flood.
#[derive(Debug, Default)]
struct Answers {
    pongs: usize,
    estop_sent: usize,
    refusals: usize,
    /// The close frame's code and reason, if the bridge closed.
    closed: Option<(CloseCode, String)>,
}

/// Sends `messages` as fast as the socket takes them while reading on another task,
/// until `pongs` pongs and `estops` acknowledgements came, the connection closed, or
/// nothing came for 5 s; fails when that takes over 60 s.
async fn flood(ws: Ws, messages: Vec<&'static str>, pongs: usize, estops: usize) -> Answers {
    tokio::time::timeout(
        Duration::from_secs(60),
        flood_within(ws, messages, pongs, estops),
    )
    .await
    .expect("the flood is answered or closed within 60 s")
}

async fn flood_within(ws: Ws, messages: Vec<&'static str>, pongs: usize, estops: usize) -> Answers {
    let (mut sink, mut stream) = ws.split();
    let sender = tokio::spawn(async move {
        for message in messages {
            if sink.feed(Message::text(message)).await.is_err() {
                return;
            }
        }
        let _ = sink.flush().await;
        // Kept open until the reading is done.
        std::future::pending::<()>().await;
    });
    let mut answers = Answers::default();
    while answers.pongs < pongs || answers.estop_sent < estops {
        let Ok(Some(frame)) = tokio::time::timeout(Duration::from_secs(5), stream.next()).await
        else {
            break;
        };
        match frame.expect("a valid frame") {
            Message::Text(text) => {
                match serde_json::from_str::<ServerMessage>(text.as_str()).expect("a message") {
                    ServerMessage::Pong => answers.pongs += 1,
                    ServerMessage::EstopSent { .. } => answers.estop_sent += 1,
                    ServerMessage::Error { .. } => answers.refusals += 1,
                    ServerMessage::Status(_) | ServerMessage::Feedback(_) => {}
                    other => panic!("unexpected {other:?}"),
                }
            }
            Message::Close(frame) => {
                let frame = frame.expect("a close frame with a code");
                answers.closed = Some((frame.code, frame.reason.to_string()));
                break;
            }
            _ => {}
        }
    }
    sender.abort();
    answers
}

async fn open(bridge: &Process) -> Ws {
    let mut ws = bridge.ws(&bridge.token().await).await;
    send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    let ServerMessage::Status(_) = next_message(&mut ws).await else {
        panic!("the first message is not a status");
    };
    ws
}

/// Whether the matrix is stopped, as a new session sees it.
async fn assert_stopped(bridge: &Process) {
    let mut fresh = bridge.ws(&bridge.token().await).await;
    common::status_until(&mut fresh, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
}

#[tokio::test]
async fn a_burst_of_a_thousand_pings_gets_a_thousand_pongs() {
    let bridge = Process::start("");
    let ws = open(&bridge).await;
    let answers = flood(ws, vec![PING; 1000], 1000, 0).await;
    assert_eq!(answers.pongs, 1000, "{answers:?}");
    assert!(answers.closed.is_none(), "{answers:?}");
}

#[tokio::test]
async fn an_estop_in_a_ping_flood_is_pressed_acknowledged_and_every_ping_answered() {
    let bridge = Process::start("");
    let ws = open(&bridge).await;
    // Waiting pongs are a count: a flood of pings never overflows.
    let half = 4 * REPLY_LIMIT;
    let mut messages = vec![PING; half];
    messages.push(ESTOP);
    messages.extend(vec![PING; half]);
    let answers = flood(ws, messages, 2 * half, 1).await;
    assert_eq!(answers.estop_sent, 1, "{answers:?}");
    assert_eq!(answers.pongs, 2 * half, "{answers:?}");
    assert!(answers.closed.is_none(), "{answers:?}");
    assert_stopped(&bridge).await;
}

#[tokio::test]
async fn a_flood_of_refusals_is_answered_or_closed_with_1008_and_its_reason() {
    let bridge = Process::start("");
    let ws = open(&bridge).await;
    let refused = 8 * REPLY_LIMIT;
    // The e-stop comes before the limit can be reached; the last ping follows every
    // refusal.
    let mut messages = vec![NONSENSE; 10];
    messages.push(ESTOP);
    messages.extend(vec![NONSENSE; refused]);
    messages.push(PING);
    let answers = flood(ws, messages, 1, 1).await;
    assert_eq!(answers.estop_sent, 1, "{answers:?}");
    match &answers.closed {
        None => assert_eq!(answers.refusals, refused + 10, "{answers:?}"),
        Some((code, reason)) => {
            assert_eq!(*code, CloseCode::Policy, "{answers:?}");
            assert_eq!(reason, FLOODED);
            assert_eq!(answers.pongs, 0, "{answers:?}");
        }
    }
    assert_stopped(&bridge).await;
}
