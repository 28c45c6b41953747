//! The bridge's WebSocket messages ([`ServerMessage`]) read in two light steps: the
//! `"type"` field first, then the whole text straight into that variant's struct
//! (which skips the `"type"` field as it skips any field it does not know).
//!
//! Serde's own reading of an internally tagged enum buffers every message into a
//! generic tree and then reads each variant's struct from that tree: a second copy of
//! the reading code of every type in the status (about 20 KB of the compressed app).
//! The JSON is the same; [`decode`] gives the same message.

use floatball_shared::api::{Problem, ServerMessage};
use floatball_shared::codes::Params;
use serde::Deserialize;

use crate::json::from_str;

/// The `"type"` field alone.
#[derive(Deserialize)]
struct Tag {
    #[serde(rename = "type")]
    kind: String,
}

/// [`ServerMessage::EstopSent`]'s fields.
#[derive(Deserialize)]
struct EstopSent {
    unreached: Vec<String>,
}

/// [`ServerMessage::Recorded`]'s fields.
#[derive(Deserialize)]
struct Recorded {
    name: String,
    duration_ms: u64,
}

/// [`ServerMessage::Error`]'s fields.
#[derive(Deserialize)]
struct Refused {
    message: String,
    #[serde(default)]
    code: String,
    #[serde(default)]
    params: Params,
    #[serde(default)]
    reason_problem: Option<Box<Problem>>,
    #[serde(default)]
    fix_problems: Vec<Problem>,
}

/// A frame read: a message, or one whose reader comes with the chunk that shows it.
#[derive(Debug, Clone, PartialEq)]
#[allow(
    clippy::large_enum_variant,
    reason = "made once per frame and handed on at once, as the message itself was"
)]
pub enum Decoded {
    /// Read now.
    Message(ServerMessage),
    /// A `schedule` or `timecode` message, read by [`read_show_control`] in the
    /// `showcontrol` chunk ([`crate::lazy::read_show_control`]): shown only where a
    /// schedule or a timecode chase is used, its reading stays out of the first load.
    ShowControl(String),
    /// A `live_positions` message, read by [`read_live_positions`] in the `live`
    /// chunk ([`crate::lazy::read_live_positions`]): asked for only by the Live card
    /// and the Preview's live picture.
    LivePositions(String),
}

/// Reads one WebSocket text frame from the bridge.
///
/// # Errors
/// Not JSON, no `"type"`, a type this app does not know, or a variant's fields that
/// do not read.
pub fn decode(text: &str) -> Result<Decoded, serde_json::Error> {
    let tag: Tag = from_str(text)?;
    if matches!(tag.kind.as_str(), "schedule" | "timecode") {
        return Ok(Decoded::ShowControl(text.to_owned()));
    }
    if tag.kind == "live_positions" {
        return Ok(Decoded::LivePositions(text.to_owned()));
    }
    read(&tag, text).map(Decoded::Message)
}

/// Reads a `schedule` or `timecode` message ([`Decoded::ShowControl`]).
///
/// # Errors
/// Not JSON, another type, or fields that do not read.
pub fn read_show_control(text: &str) -> Result<ServerMessage, serde_json::Error> {
    let tag: Tag = from_str(text)?;
    Ok(match tag.kind.as_str() {
        "schedule" => ServerMessage::Schedule(from_str(text)?),
        "timecode" => ServerMessage::Timecode(from_str(text)?),
        other => {
            return Err(serde::de::Error::custom(format_args!(
                "`{other}` is not a show-control message"
            )));
        }
    })
}

/// [`ServerMessage::LivePositions`]' fields.
#[derive(Deserialize)]
struct LivePositions {
    positions_mm: Vec<i32>,
}

/// Reads a `live_positions` message ([`Decoded::LivePositions`]).
///
/// # Errors
/// Not JSON or fields that do not read.
pub fn read_live_positions(text: &str) -> Result<ServerMessage, serde_json::Error> {
    let read: LivePositions = from_str(text)?;
    Ok(ServerMessage::LivePositions {
        positions_mm: read.positions_mm,
    })
}

/// Reads a message of every other type.
fn read(tag: &Tag, text: &str) -> Result<ServerMessage, serde_json::Error> {
    Ok(match tag.kind.as_str() {
        "status" => ServerMessage::Status(from_str(text)?),
        "feedback" => ServerMessage::Feedback(from_str(text)?),
        "pong" => ServerMessage::Pong,
        "estop_sent" => ServerMessage::EstopSent {
            unreached: from_str::<EstopSent>(text)?.unreached,
        },
        "mbox_reply" => ServerMessage::MboxReply(from_str(text)?),
        "scl_reply" => ServerMessage::SclReply(from_str(text)?),
        "recorded" => {
            let recorded: Recorded = from_str(text)?;
            ServerMessage::Recorded {
                name: recorded.name,
                duration_ms: recorded.duration_ms,
            }
        }
        "error" => {
            let refused: Refused = from_str(text)?;
            ServerMessage::Error {
                message: refused.message,
                code: refused.code,
                params: refused.params,
                reason_problem: refused.reason_problem,
                fix_problems: refused.fix_problems,
            }
        }
        other => {
            return Err(serde::de::Error::custom(format_args!(
                "unknown message type `{other}`"
            )));
        }
    })
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use floatball_shared::api::{
        ArmedShow, FeedbackFrame, GatewayKind, GatewayStatus, LinkState, PlayerState, SclReply,
        Status, UnitFault, UnitHealth,
    };

    use super::*;

    /// Every variant the bridge sends, as serde writes it, reads back the same.
    #[wasm_bindgen_test(unsupported = test)]
    fn every_message_reads_back_as_serde_wrote_it() {
        let status = Status {
            state: PlayerState::Idle,
            entry: Some(0),
            show: Some("wave".into()),
            show_time_ms: 0,
            show_starts_in_ms: None,
            show_duration_ms: 8000,
            cycle: 0,
            progress: 0.0,
            gateways: vec![GatewayStatus {
                index: 0,
                kind: GatewayKind::Uim2503,
                port: "sim".into(),
                link: LinkState::NotAnswering,
                bytes_per_s: 12.5,
                lowest_water_level: Some(3),
                error: None,
                packets_per_s: None,
                late_frames: None,
                missed_replies: None,
                drives: Vec::new(),
                baud: Some(9600),
                health: Some(UnitHealth {
                    expected: 100,
                    answering: 98,
                    missing: vec![4, 9],
                    faults: vec![UnitFault {
                        station: 3,
                        error: 0x37,
                        code: 0x27,
                        index: 2,
                    }],
                    ..UnitHealth::default()
                }),
            }],
            last_error: Some("x".into()),
            armed: Some(ArmedShow {
                entry: 0,
                show: "wave".into(),
                progress: 0.5,
            }),
            gateway_summary: floatball_shared::api::GatewaySummary {
                total: 100,
                up: 99,
                bytes_per_s: 1100.5,
                lowest_water_level: Some(3),
                lowest_water_gateway: Some(41),
                problems: vec![0],
                complete: false,
            },
            live: Some(Box::new(floatball_shared::api::LiveStatus {
                phase: floatball_shared::api::LivePhase::Holding,
                input_lost: true,
                period_ms: 20,
                latency_ms: 40,
                recording: true,
                recorded_ms: 1200,
            })),
        };
        let mut params = Params::new();
        params.insert("name".into(), "波浪".into());
        let messages = [
            ServerMessage::Status(status),
            ServerMessage::Feedback(FeedbackFrame {
                gateway: 0,
                station: 5,
                code: 35,
                data: vec![3, 0],
            }),
            ServerMessage::Pong,
            ServerMessage::EstopSent {
                unreached: vec!["sim: down".into()],
            },
            ServerMessage::SclReply(SclReply {
                gateway: 0,
                drive: "2".into(),
                request: "2IP".into(),
                text: "IP = 1200".into(),
                raw: "IP=1200".into(),
            }),
            ServerMessage::Schedule(floatball_shared::api::ScheduleStatus {
                enabled: true,
                time_zone: "Asia/Shanghai".into(),
                window: None,
                next_start: Some("2026-11-30 10:00".into()),
                last: Some(floatball_shared::api::ScheduleOutcome {
                    at: "2026-11-29 22:00".into(),
                    done: true,
                    code: "schedule_ended".into(),
                    params: Params::new(),
                    message: "The window ended".into(),
                }),
            }),
            ServerMessage::Timecode(floatball_shared::timecode::chase::TimecodeStatus {
                source: "artnet".into(),
                state: floatball_shared::timecode::chase::ChaseState::Chasing,
                timecode: Some("10:00:01:05".into()),
                rate: Some(floatball_shared::timecode::FrameRate::Df2997),
                running: true,
                entry: Some(1),
                offset_ms: Some(-12),
                lead_ms: 1800,
                locate_lead_ms: 4200,
                lead_measured: true,
                drift_ms: Some(1),
                drift_over_ms: 60_000,
                locates: 1,
                refused: None,
            }),
            ServerMessage::Recorded {
                name: "take 1".into(),
                duration_ms: 12_340,
            },
            ServerMessage::LivePositions {
                positions_mm: vec![0, 512, 3_999],
            },
            ServerMessage::Error {
                message: "no such show".into(),
                code: "show_not_found".into(),
                params,
                reason_problem: Some(Box::new(Problem {
                    code: "x".into(),
                    params: Params::new(),
                })),
                fix_problems: Vec::new(),
            },
        ];
        for message in messages {
            let text = serde_json::to_string(&message).expect("json");
            let read = match decode(&text).expect(&text) {
                Decoded::Message(read) => read,
                // Read later, in the show-control chunk.
                Decoded::ShowControl(later) => {
                    assert!(matches!(
                        message,
                        ServerMessage::Schedule(_) | ServerMessage::Timecode(_)
                    ));
                    read_show_control(&later).expect(&later)
                }
                // Read later, in the Live card's chunk.
                Decoded::LivePositions(later) => {
                    assert!(matches!(message, ServerMessage::LivePositions { .. }));
                    read_live_positions(&later).expect(&later)
                }
            };
            assert_eq!(read, message);
        }
        let mbox = r#"{"type":"mbox_reply","gateway":1,"text":"FN0090 = 1","registers":{"bank":"FN","start":144,"values":[1]}}"#;
        assert!(matches!(
            decode(mbox),
            Ok(Decoded::Message(ServerMessage::MboxReply(_)))
        ));
        let old = decode(r#"{"type":"error","message":"no"}"#).expect("an older bridge");
        assert!(
            matches!(old, Decoded::Message(ServerMessage::Error { code, .. }) if code.is_empty())
        );
        assert!(read_show_control(r#"{"type":"pong"}"#).is_err());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn unknown_or_broken_messages_are_errors() {
        for text in [
            r#"{"type":"dance"}"#,
            r#"{"state":"idle"}"#,
            r#"{"type":"status"}"#,
            "not json",
        ] {
            assert!(decode(text).is_err(), "{text}");
        }
    }
}
