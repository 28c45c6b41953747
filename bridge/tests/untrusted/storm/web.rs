//! The WebSocket and HTTP fuzzers of the storm.
//!
//! **WebSocket** ([`ws_fuzz`]): a session of its own (the operator's token), sent text
//! frames — malformed JSON, unknown types, fields of the wrong type, Start and Reset at
//! an entry the playlist lacks or a time at or past its show's end, nesting past
//! serde's limit, messages near and over the 64 KiB limit — binary frames and pings,
//! now and then a close frame or a connection with a wrong token. Its replies are read
//! as they come (the bridge closes a session whose replies pile up). Each text frame is
//! classified as the bridge reads it (`serde_json` into `ClientMessage`): a Start or
//! Reset the playlist can play (entry 1, a time before the show's end), Home, the
//! e-stop, a console line (`raw`) and `live` are valid commands and skipped; a ping,
//! the feedback switches, `record` and `record_stop` (refused: live mode is off) are
//! sent. A frame over the size limit is refused whatever it holds: sent.
//!
//! **HTTP** ([`http_fuzz`]): random and known paths, methods and bodies, with the
//! operator's token, a wrong one or none, and raw bytes on TCP that are not HTTP or
//! are broken HTTP. With the token, a request that could change something is never
//! valid: its body is not JSON (a byte `0xFF` first, or a JSON body cut before its
//! end), a show is deleted only by a name that is not stored, and `logout` and the
//! roll call (which take no body) are never sent. Without a valid token anything goes.
//! Every request that could change something and was answered 2xx is recorded: the
//! test fails on it.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::http::{Method, Request, header};
use floatball_shared::api::ClientMessage;
use futures_util::{SinkExt, StreamExt};
use http_body_util::{BodyExt, Full};
use hyper_util::client::legacy::Client;
use hyper_util::client::legacy::connect::HttpConnector;
use hyper_util::rt::TokioExecutor;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::tungstenite::protocol::CloseFrame;
use tokio_tungstenite::tungstenite::protocol::frame::coding::CloseCode;

use super::{Class, Draw, Playable, Rng, Tally, mutate};
use crate::common::Remote;

/// Whether a text frame is a valid command the bridge would carry out.
fn ws_is_command(text: &str, playable: Playable) -> bool {
    match serde_json::from_str::<ClientMessage>(text) {
        Ok(ClientMessage::Start(from) | ClientMessage::Reset(from)) => playable.plays(from),
        Ok(
            ClientMessage::Estop
            | ClientMessage::Home
            | ClientMessage::Raw { .. }
            | ClientMessage::Live { .. },
        ) => true,
        Ok(
            ClientMessage::Ping
            | ClientMessage::Feedback { .. }
            | ClientMessage::Record { .. }
            | ClientMessage::RecordStop
            | ClientMessage::LivePositions { .. },
        )
        | Err(_) => false,
    }
}

/// Valid messages, for mutations.
const WS_CORPUS: [&str; 9] = [
    r#"{"type":"start"}"#,
    r#"{"type":"start","entry":1,"time_ms":500}"#,
    r#"{"type":"reset","entry":1}"#,
    r#"{"type":"home"}"#,
    r#"{"type":"estop"}"#,
    r#"{"type":"ping"}"#,
    r#"{"type":"raw","line":"*0;MO=1;"}"#,
    r#"{"type":"live","on":true}"#,
    r#"{"type":"feedback","relay":false}"#,
];

/// Harmless, well-formed messages.
const WS_INPUTS: [&str; 5] = [
    r#"{"type":"ping"}"#,
    r#"{"type":"feedback","relay":false}"#,
    r#"{"type":"live_positions","on":true}"#,
    r#"{"type":"record","name":"storm"}"#,
    r#"{"type":"record_stop"}"#,
];

/// One frame for the WebSocket fuzzer.
enum WsFrame {
    Text(String),
    /// Over the size limit: refused whatever it holds.
    Oversize(String),
    Binary(Vec<u8>),
    Ping(Vec<u8>),
    Close(u16),
}

fn ws_crafted(rng: &mut Rng, playable: Playable) -> (&'static str, WsFrame) {
    let end_ms = playable.show_ms;
    let text = |label: &'static str, text: String| (label, WsFrame::Text(text));
    match rng.below(14) {
        0 => {
            let broken = *rng.pick(&[
                "{",
                r#"{"type":"#,
                "[]",
                "null",
                r#""start""#,
                r#"{"type":"start""#,
                r#"{"type":"start"}}"#,
                r#"{"type":"start",}"#,
                "{'type':'start'}",
                r#"{"type":"start"} trailing"#,
                "",
                " ",
            ]);
            text("malformed JSON", broken.to_owned())
        }
        1 => {
            let kind = *rng.pick(&["jump", "START", "start ", "Start", "estop ", "", "stop"]);
            text("unknown type", format!(r#"{{"type":"{kind}"}}"#))
        }
        2 => text("type not a string", r#"{"type":5}"#.to_owned()),
        3 => {
            let entry = *rng.pick(&["\"1\"", "-1", "1.5", "1e99", "true", "[1]", "{}"]);
            text(
                "start with an entry of the wrong type",
                format!(r#"{{"type":"start","entry":{entry}}}"#),
            )
        }
        4 => {
            let time = *rng.pick(&["-5", "1.5", "\"0\"", "1e30", "18446744073709551616"]);
            text(
                "start with a time of the wrong type",
                format!(r#"{{"type":"start","entry":1,"time_ms":{time}}}"#),
            )
        }
        5 => {
            let kind = *rng.pick(&["start", "reset"]);
            let entry = *rng.pick(&[0usize, 2, 3, 99_999]);
            text(
                "start or reset at an entry the playlist lacks",
                format!(r#"{{"type":"{kind}","entry":{entry}}}"#),
            )
        }
        6 => {
            let kind = *rng.pick(&["start", "reset"]);
            let time = *rng.pick(&[end_ms, end_ms + 1, 9_995, 3_600_000, u64::MAX]);
            text(
                "start or reset at or past the show's end",
                format!(r#"{{"type":"{kind}","entry":1,"time_ms":{time}}}"#),
            )
        }
        7 => text(
            "start at entry 2 from 0.5 s",
            r#"{"type":"start","entry":2,"time_ms":500}"#.to_owned(),
        ),
        8 => {
            let depth = 1_000 + rng.index(9_000);
            text(
                "arrays nested past serde's limit",
                format!("{}{}", "[".repeat(depth), "]".repeat(depth)),
            )
        }
        9 => {
            let pad = 60_000 + rng.index(5_000);
            text(
                "a ping padded to near the size limit",
                format!(r#"{{"type":"ping","pad":"{}"}}"#, "x".repeat(pad)),
            )
        }
        10 => (
            "a start over the 64 KiB limit",
            WsFrame::Oversize(format!(r#"{{"type":"start"}}{}"#, " ".repeat(70_000))),
        ),
        11 => (
            "a binary frame",
            WsFrame::Binary({
                let len = rng.index(2_000);
                rng.bytes(len)
            }),
        ),
        12 => (
            "a WebSocket ping frame",
            WsFrame::Ping({
                let len = rng.index(125);
                rng.bytes(len)
            }),
        ),
        _ => {
            let code = *rng.pick(&[1000u16, 1002, 1008, 3000, 4999]);
            ("a close frame", WsFrame::Close(code))
        }
    }
}

/// Random text: characters of any kind, control characters and quotes included.
fn random_text(rng: &mut Rng) -> String {
    let len = rng.index(200);
    (0..len)
        .map(|_| match rng.below(4) {
            0 => char::from(rng.byte() & 0x7F),
            1 => *rng.pick(&['{', '}', '"', ':', ',', '[', ']', '\\']),
            2 => char::from_u32(u32::try_from(rng.below(0x11_0000)).unwrap_or(0x41))
                .unwrap_or('\u{FFFD}'),
            _ => char::from(b'a' + rng.byte() % 26),
        })
        .collect()
}

/// What the WebSocket fuzzer saw.
#[derive(Debug, Default)]
pub struct WsCounts {
    pub connections: AtomicU64,
    pub refused_connections: AtomicU64,
    pub replies: AtomicU64,
}

/// Sends the WebSocket storm, `per_s` frames a second, until `stop`.
#[allow(clippy::too_many_arguments)]
pub async fn ws_fuzz(
    remote: Remote,
    token: String,
    per_s: f64,
    playable: Playable,
    mut rng: Rng,
    tally: Arc<Tally>,
    counts: Arc<WsCounts>,
    stop: Arc<AtomicBool>,
) {
    let period = Duration::from_secs_f64(1.0 / per_s);
    let mut next = tokio::time::Instant::now();
    while !stop.load(Ordering::Acquire) {
        // Now and then a connection with a wrong token: refused before the upgrade.
        if rng.chance(20) {
            let url = format!("ws://{}/ws?token=storm{}", remote.addr, rng.u64());
            let refused = tokio::time::timeout(
                Duration::from_secs(5),
                tokio_tungstenite::connect_async(url),
            )
            .await;
            if matches!(refused, Ok(Err(_))) {
                counts.refused_connections.fetch_add(1, Ordering::Relaxed);
            }
        }
        let url = format!("ws://{}/ws?token={token}", remote.addr);
        let Ok(Ok((ws, _))) = tokio::time::timeout(
            Duration::from_secs(5),
            tokio_tungstenite::connect_async(url),
        )
        .await
        else {
            tally.error();
            tokio::time::sleep(Duration::from_millis(50)).await;
            continue;
        };
        counts.connections.fetch_add(1, Ordering::Relaxed);
        let (mut sink, mut stream) = ws.split();
        let replies = Arc::clone(&counts);
        let drain = tokio::spawn(async move {
            while let Some(Ok(_)) = stream.next().await {
                replies.replies.fetch_add(1, Ordering::Relaxed);
            }
        });
        while !stop.load(Ordering::Acquire) && !drain.is_finished() {
            tokio::time::sleep_until(next).await;
            next += period;
            let (class, label, frame) = match rng.below(10) {
                0..=1 => (
                    Class::Random,
                    "random text",
                    WsFrame::Text(random_text(&mut rng)),
                ),
                2..=4 => {
                    let base = rng.pick(&WS_CORPUS).as_bytes().to_vec();
                    let mutated = mutate(&mut rng, &base);
                    (
                        Class::Mutated,
                        "a valid message mutated",
                        WsFrame::Text(String::from_utf8_lossy(&mutated).into_owned()),
                    )
                }
                5..=8 => {
                    let (label, frame) = ws_crafted(&mut rng, playable);
                    (Class::Crafted, label, frame)
                }
                _ => {
                    let text = rng.pick(&WS_INPUTS).to_string();
                    (Class::Input, "a harmless message", WsFrame::Text(text))
                }
            };
            if let Some(only) = super::only()
                && !(class == Class::Crafted && label.contains(only))
            {
                continue;
            }
            let (message, bytes, closing) = match frame {
                WsFrame::Text(text) => {
                    if ws_is_command(&text, playable) {
                        tally.skipped();
                        continue;
                    }
                    let bytes = text.as_bytes().to_vec();
                    (Message::text(text), bytes, false)
                }
                WsFrame::Oversize(text) => {
                    let bytes = text.as_bytes().to_vec();
                    (Message::text(text), bytes, true)
                }
                WsFrame::Binary(bytes) => (Message::binary(bytes.clone()), bytes, false),
                WsFrame::Ping(bytes) => (Message::Ping(bytes.clone().into()), bytes, false),
                WsFrame::Close(code) => (
                    Message::Close(Some(CloseFrame {
                        code: CloseCode::from(code),
                        reason: "storm".into(),
                    })),
                    code.to_be_bytes().to_vec(),
                    true,
                ),
            };
            let draw = Draw::new(class, label, bytes);
            match tokio::time::timeout(Duration::from_secs(5), sink.send(message)).await {
                Ok(Ok(())) => tally.sent(&draw),
                _ => {
                    tally.error();
                    break;
                }
            }
            if closing {
                break;
            }
        }
        let _ = tokio::time::timeout(Duration::from_secs(1), sink.close()).await;
        let _ = tokio::time::timeout(Duration::from_secs(2), drain).await;
    }
}

/// What the HTTP fuzzer saw.
#[derive(Debug, Default)]
pub struct HttpCounts {
    /// Answers by class: 2xx, 3xx, 4xx, 5xx, none (timed out or refused).
    pub answers: [AtomicU64; 5],
    /// Requests that could change something, with the token, answered 2xx.
    pub accepted: Mutex<Vec<String>>,
    /// The slowest answer to a request (not to raw bytes on TCP, which may rightly
    /// go unanswered until the read gives up), µs.
    pub slowest_us: AtomicU64,
    /// The first requests answered 5xx: what was sent and the answer.
    pub server_errors: Mutex<Vec<String>>,
    /// Requests (not raw bytes) left unanswered for 5 s: the test fails on them.
    pub unanswered: Mutex<Vec<String>>,
}

impl HttpCounts {
    fn answered(&self, status: Option<u16>, took: Option<Duration>) {
        let index = match status {
            Some(200..=299) => 0,
            Some(300..=399) => 1,
            Some(400..=499) => 2,
            Some(_) => 3,
            None => 4,
        };
        self.answers[index].fetch_add(1, Ordering::Relaxed);
        if let Some(took) = took {
            let took_us = u64::try_from(took.as_micros()).unwrap_or(u64::MAX);
            self.slowest_us.fetch_max(took_us, Ordering::Relaxed);
        }
    }

    /// `2xx a, 3xx b, …`.
    pub fn summary(&self) -> String {
        let [ok, moved, client, server, none] = &self.answers;
        format!(
            "2xx {}, 3xx {}, 4xx {}, 5xx {}, none {}; slowest {:.0} ms",
            ok.load(Ordering::Relaxed),
            moved.load(Ordering::Relaxed),
            client.load(Ordering::Relaxed),
            server.load(Ordering::Relaxed),
            none.load(Ordering::Relaxed),
            self.slowest_us.load(Ordering::Relaxed) as f64 / 1e3
        )
    }
}

/// Paths the API has (and some it does not), `{name}` a show's name.
const PATHS: [&str; 30] = [
    "/api/login",
    "/api/logout",
    "/api/password",
    "/api/shows",
    "/api/shows/wave",
    "/api/shows/{name}",
    "/api/playlist",
    "/api/installation",
    "/api/gateways/0/baud",
    "/api/plan/wave",
    "/api/sim/positions",
    "/api/mbox/timing",
    "/api/qprogram/wave",
    "/api/gateways/0/rollcall",
    "/api/gateways/0/assign",
    "/api/gateways/0/identify",
    "/api/status/gateways",
    "/api/schedule",
    "/api/schedule/status",
    "/api/test/clock",
    "/api/live/patch",
    "/api/live/status",
    "/ws",
    "/",
    "/api/",
    "/api/../../etc/passwd",
    "/%2e%2e/%2e%2e/password",
    "/api/shows/%00",
    "/api/shows/..%2f..%2fpassword",
    "/api/gateways/99999999999999999999/baud",
];

/// Valid request bodies, for bodies cut short (with the token) or sent whole
/// (without a valid one).
const BODIES: [&str; 5] = [
    concat!(
        r#"{"entries":[{"show":"wave","delay_ms":0,"cycles":1}],"#,
        r#""loop":true,"default_delay_ms":0,"default_cycles":1}"#
    ),
    r#"{"old":"ball-operator","new":"storm-storm"}"#,
    r#"{"enabled":true,"time_zone":"UTC","week":{},"exceptions":[]}"#,
    r#"{"baud":9600}"#,
    r#"{"password":"1234"}"#,
];

/// Whether a request may change something (and so must never be valid with the token).
fn may_change(method: &Method) -> bool {
    !matches!(*method, Method::GET | Method::HEAD | Method::OPTIONS)
}

/// A body that is not valid for any call: `0xFF` first (not UTF-8, so neither JSON nor
/// CSV), or a valid JSON body cut before its end.
fn invalid_body(rng: &mut Rng) -> Vec<u8> {
    if rng.chance(500) {
        let mut body = vec![0xFF];
        let len = rng.index(2_000);
        body.extend(rng.bytes(len));
        body
    } else {
        let valid = rng.pick(&BODIES).as_bytes();
        valid[..1 + rng.index(valid.len() - 2)].to_vec()
    }
}

/// One HTTP request of the storm: what it is and whether it carries the token.
struct HttpCase {
    method: Method,
    path: String,
    token: Option<String>,
    content_type: Option<&'static str>,
    body: Vec<u8>,
    origin: bool,
}

fn http_case(rng: &mut Rng, token: &str) -> HttpCase {
    let method = match rng.below(10) {
        0..=2 => Method::GET,
        3 => Method::POST,
        4 => Method::PUT,
        5 => Method::DELETE,
        6 => Method::PATCH,
        7 => Method::OPTIONS,
        8 => Method::HEAD,
        _ => {
            let name = *rng.pick(&["FROB", "PROPFIND", "TRACE"]);
            Method::from_bytes(name.as_bytes()).unwrap_or(Method::GET)
        }
    };
    let mut path = if rng.chance(150) {
        let len = rng.index(8_000);
        let mut path = String::from("/");
        path.extend((0..len).map(|_| char::from(b'a' + rng.byte() % 26)));
        path
    } else {
        rng.pick(&PATHS).to_string()
    };
    path = path.replace("{name}", &format!("storm-{}", rng.below(1_000)));
    if rng.chance(100) {
        path.push_str("?token=x&x=%ff%fe");
    }
    let token = match rng.below(3) {
        0 => Some(token.to_owned()),
        1 => Some(format!("storm{}", rng.u64())),
        _ => None,
    };
    let content_type = *rng.pick(&[
        Some("application/json"),
        Some("text/csv"),
        Some("application/octet-stream"),
        Some("text/plain"),
        None,
        Some("application/json; charset=utf-16"),
        Some("x/y; z"),
    ]);
    let body = if rng.chance(300) {
        Vec::new()
    } else if rng.chance(500) {
        let len = rng.index(4_000);
        rng.bytes(len)
    } else {
        rng.pick(&BODIES).as_bytes().to_vec()
    };
    HttpCase {
        method,
        path,
        token,
        content_type,
        body,
        origin: rng.chance(100),
    }
}

/// Makes `case` invalid when it carries the operator's `token` and may change
/// something: an invalid body, a show name that is not stored, never `logout` or the
/// roll call.
fn disarm(case: &mut HttpCase, token: &str, rng: &mut Rng) {
    if case.token.as_deref() != Some(token) || !may_change(&case.method) {
        return;
    }
    // The route, without the query the case may have.
    let route = case.path.split('?').next().unwrap_or_default().to_owned();
    if route == "/api/logout" || route.ends_with("/rollcall") {
        case.path = "/api/storm/nothing".to_owned();
    }
    if route == "/api/shows/wave" && case.method == Method::DELETE {
        case.path = "/api/shows/storm-not-stored".to_owned();
    }
    case.body = invalid_body(rng);
}

/// Raw bytes on a TCP connection to the bridge's HTTP port: not HTTP, or broken HTTP.
fn raw_request(rng: &mut Rng, token: &str) -> (&'static str, Vec<u8>) {
    match rng.below(9) {
        0 => {
            let len = rng.index(2_000);
            ("random bytes on TCP", rng.bytes(len))
        }
        1 => (
            "a negative Content-Length",
            b"GET / HTTP/1.1\r\nHost: x\r\nContent-Length: -1\r\n\r\n".to_vec(),
        ),
        2 => (
            "a broken chunked body",
            b"POST /api/login HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\nzz\r\n"
                .to_vec(),
        ),
        3 => {
            let mut bytes = b"GET / HTTP/1.1\r\nHost: x\r\nX-Storm: ".to_vec();
            bytes.extend(std::iter::repeat_n(b'a', 100_000));
            bytes.extend_from_slice(b"\r\n\r\n");
            ("a 100 KB header", bytes)
        }
        4 => (
            "a playlist cut short, with the token",
            format!(
                "PUT /api/playlist HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer {token}\r\n\
                 Content-Type: application/json\r\nContent-Length: 100\r\n\r\n{{\"entries\":"
            )
            .into_bytes(),
        ),
        5 => ("HTTP/0.9", b"GET /\r\n".to_vec()),
        6 => ("HTTP/9.9", b"GET / HTTP/9.9\r\nHost: x\r\n\r\n".to_vec()),
        7 => {
            let mut bytes = b"GET /".to_vec();
            bytes.extend(std::iter::repeat_n(b'a', 10_000));
            bytes.extend_from_slice(b" HTTP/1.1\r\nHost: x\r\n\r\n");
            ("a 10 KB request line", bytes)
        }
        _ => (
            "a request, then garbage pipelined",
            b"GET /api/live/status HTTP/1.1\r\nHost: x\r\n\r\n\x00\x01\x02GARBAGE\r\n\r\n".to_vec(),
        ),
    }
}

/// Sends the HTTP storm, `per_s` requests a second, until `stop`.
pub async fn http_fuzz(
    remote: Remote,
    token: String,
    per_s: f64,
    mut rng: Rng,
    tally: Arc<Tally>,
    counts: Arc<HttpCounts>,
    stop: Arc<AtomicBool>,
) {
    let client: Client<_, Full<Bytes>> =
        Client::builder(TokioExecutor::new()).build(HttpConnector::new());
    let period = Duration::from_secs_f64(1.0 / per_s);
    let mut next = tokio::time::Instant::now();
    let mut raw = tokio::task::JoinSet::new();
    while !stop.load(Ordering::Acquire) {
        tokio::time::sleep_until(next).await;
        next += period;
        while raw.try_join_next().is_some() {}
        let started = Instant::now();
        if rng.chance(200) {
            let (label, bytes) = raw_request(&mut rng, &token);
            if super::only().is_some_and(|only| !label.contains(only)) {
                continue;
            }
            // On a task of its own: an answer may rightly never come (a body cut short
            // is waited for), and the read gives up after 2 s.
            tally.sent(&Draw::new(Class::Crafted, label, bytes.clone()));
            let counts = Arc::clone(&counts);
            raw.spawn(async move {
                let answered = tokio::time::timeout(Duration::from_secs(5), async {
                    let mut stream = tokio::net::TcpStream::connect(remote.addr).await.ok()?;
                    stream.write_all(&bytes).await.ok()?;
                    let mut answer = vec![0u8; 256];
                    let read =
                        tokio::time::timeout(Duration::from_secs(2), stream.read(&mut answer))
                            .await
                            .ok()?
                            .ok()?;
                    let head = String::from_utf8_lossy(answer.get(..read).unwrap_or_default())
                        .into_owned();
                    head.split(' ')
                        .nth(1)
                        .and_then(|code| code.parse::<u16>().ok())
                })
                .await
                .ok()
                .flatten();
                counts.answered(answered, None);
            });
            continue;
        }
        let mut case = http_case(&mut rng, &token);
        disarm(&mut case, &token, &mut rng);
        let mut request = Request::builder()
            .method(case.method.clone())
            .uri(format!("http://{}{}", remote.addr, case.path));
        if let Some(token) = &case.token {
            request = request.header(header::AUTHORIZATION, format!("Bearer {token}"));
        }
        if let Some(content_type) = case.content_type {
            request = request.header(header::CONTENT_TYPE, content_type);
        }
        if case.origin {
            request = request.header(header::ORIGIN, "http://evil.example");
        }
        let Ok(request) = request.body(Full::new(Bytes::from(case.body.clone()))) else {
            // A path the URI parser refuses: not sent.
            tally.error();
            continue;
        };
        let with_token = case.token.as_deref() == Some(token.as_str());
        let label = if with_token {
            "a request with the token"
        } else {
            "a request without a valid token"
        };
        if super::only().is_some_and(|only| !label.contains(only)) {
            continue;
        }
        let class = if with_token && !may_change(&case.method) {
            Class::Input
        } else {
            Class::Crafted
        };
        let mut sent = case.method.as_str().as_bytes().to_vec();
        sent.push(b' ');
        sent.extend_from_slice(case.path.as_bytes());
        sent.push(b' ');
        sent.extend_from_slice(&case.body);
        let answered = tokio::time::timeout(Duration::from_secs(5), async {
            let response = client.request(request).await.ok()?;
            let status = response.status();
            let _ = response.into_body().collect().await;
            Some(status)
        })
        .await
        .ok()
        .flatten();
        counts.answered(
            answered.map(|status| status.as_u16()),
            Some(started.elapsed()),
        );
        if answered.is_none() {
            counts
                .unanswered
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(format!(
                    "{} {}{} ({} bytes)",
                    case.method,
                    case.path.get(..120).unwrap_or(&case.path),
                    if with_token { " with the token" } else { "" },
                    case.body.len()
                ));
        }
        if let Some(status) = answered
            && status.is_server_error()
        {
            let mut errors = counts
                .server_errors
                .lock()
                .unwrap_or_else(|e| e.into_inner());
            if errors.len() < 10 {
                errors.push(format!(
                    "{} {}… ({} characters){} ({} bytes of {:?}: {}) answered {status}",
                    case.method,
                    case.path.get(..40).unwrap_or(&case.path),
                    case.path.len(),
                    if with_token { " with the token" } else { "" },
                    case.body.len(),
                    case.content_type,
                    super::hex(case.body.get(..48).unwrap_or(&case.body))
                ));
            }
        }
        tally.sent(&Draw::new(class, label, sent));
        if let Some(status) = answered
            && with_token
            && may_change(&case.method)
            && status.is_success()
        {
            counts
                .accepted
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push(format!(
                    "{} {} ({} bytes: {}) answered {status}",
                    case.method,
                    case.path,
                    case.body.len(),
                    super::hex(case.body.get(..64).unwrap_or(&case.body))
                ));
        }
    }
    // Those still waiting for an answer that may never come are let go.
    raw.abort_all();
}
