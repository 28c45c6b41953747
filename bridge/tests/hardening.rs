//! What a hostile or careless client meets: every refusal is the documented JSON, an
//! oversized WebSocket message is closed with 1009, every response carries the
//! browser-security headers, misleading show names and unbounded uploads are refused,
//! and nothing an interrupted write left behind survives a restart.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode, header};
use common::{Bridge, Reply, encode_path};
use futures_util::{SinkExt, StreamExt};
use tokio_tungstenite::tungstenite::Message;

/// Asserts `reply` is an error answer in the documented form: the status, a JSON
/// content type, and an `{"error": …}` body.
fn assert_json_error(reply: &Reply, status: StatusCode) -> floatball_shared::api::ApiError {
    assert_eq!(
        reply.status,
        status,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    assert_eq!(
        reply.headers[header::CONTENT_TYPE],
        "application/json",
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    let error = reply.error();
    assert!(!error.error.is_empty());
    error
}

/// Asserts the browser-security headers are on `reply`.
fn assert_security_headers(reply: &Reply, what: &str) {
    for (name, value) in floatball_bridge::server::SECURITY_HEADERS {
        assert_eq!(
            reply.headers.get(&name).and_then(|v| v.to_str().ok()),
            Some(value),
            "{name} on {what}"
        );
    }
}

#[tokio::test]
async fn bodies_over_the_limit_are_refused_with_json_413() {
    let bridge = Bridge::start().await;
    let operator = bridge.operator().await;
    let huge = vec![b' '; 2 * 1024 * 1024];
    for (method, path, token) in [
        (Method::POST, "/api/login", None),
        (Method::POST, "/api/password", Some(operator.as_str())),
        (Method::PUT, "/api/playlist", Some(operator.as_str())),
    ] {
        let reply = bridge
            .request(
                method.clone(),
                path,
                token,
                Some(("application/json", huge.clone())),
            )
            .await;
        let error = assert_json_error(&reply, StatusCode::PAYLOAD_TOO_LARGE);
        assert!(
            error.error.contains("at most 1048576 bytes"),
            "{method} {path}: {error:?}"
        );
        assert_security_headers(&reply, path);
    }
}

#[tokio::test]
async fn the_frameworks_refusals_are_json_too() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    // A path segment that is not UTF-8.
    let reply = bridge
        .request(Method::GET, "/api/shows/%FF%FE", Some(&token), None)
        .await;
    assert_json_error(&reply, StatusCode::BAD_REQUEST);
    // Unknown call and method.
    assert_json_error(
        &bridge
            .request(Method::GET, "/api/nothing", None, None)
            .await,
        StatusCode::NOT_FOUND,
    );
    let reply = bridge
        .request(Method::DELETE, "/api/login", None, None)
        .await;
    assert_json_error(&reply, StatusCode::METHOD_NOT_ALLOWED);
    assert!(reply.headers.contains_key(header::ALLOW), "{reply:?}");
    // A plain GET of /ws is not a WebSocket handshake.
    let reply = bridge.request(Method::GET, "/ws?token=x", None, None).await;
    assert!(reply.status.is_client_error(), "{reply:?}");
    assert_json_error(&reply, reply.status);
}

#[tokio::test]
async fn a_websocket_message_over_64_kib_is_closed_with_1009() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let mut ws = bridge.ws(&token).await;
    let big = format!(
        "{{\"type\":\"ping\",\"pad\":\"{}\"}}",
        "x".repeat(floatball_bridge::ws::MAX_MESSAGE_BYTES)
    );
    ws.send(Message::text(big)).await.expect("send");
    let closed = tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            match ws.next().await {
                Some(Ok(Message::Close(frame))) => return frame,
                Some(Ok(_)) => {}
                other => panic!("expected a close frame, got {other:?}"),
            }
        }
    })
    .await
    .expect("closed within 5 s")
    .expect("a close code");
    assert_eq!(u16::from(closed.code), 1009, "{closed:?}");
    assert!(closed.reason.contains("65536"), "{closed:?}");
}

#[tokio::test]
async fn every_response_carries_the_security_headers() {
    let bridge = Bridge::start().await;
    let csp = floatball_bridge::server::CONTENT_SECURITY_POLICY;
    for needed in [
        "default-src 'self'",
        "script-src 'self' 'wasm-unsafe-eval'",
        "style-src 'self' 'unsafe-inline'",
        "img-src 'self' data: blob:",
        "frame-ancestors 'none'",
    ] {
        assert!(csp.contains(needed), "{needed} in {csp}");
    }
    assert!(!csp.contains("script-src 'self' 'unsafe-inline'"), "{csp}");

    let login = bridge.login("1234").await;
    let cases = [
        (
            "the app",
            bridge.request(Method::GET, "/", None, None).await,
        ),
        (
            "an app route",
            bridge.request(Method::GET, "/shows/x", None, None).await,
        ),
        ("a login", login),
        (
            "a refused API call",
            bridge.request(Method::GET, "/api/shows", None, None).await,
        ),
        (
            "an unknown API call",
            bridge.request(Method::GET, "/api/nope", None, None).await,
        ),
        (
            "a refused WebSocket",
            bridge.request(Method::GET, "/ws", None, None).await,
        ),
        (
            "a WebSocket from another site",
            bridge
                .request_from(
                    "127.0.0.1".parse().expect("ip"),
                    Method::GET,
                    "/ws?token=x",
                    None,
                    None,
                    &[
                        ("origin", "http://evil.example"),
                        ("connection", "upgrade"),
                        ("upgrade", "websocket"),
                        ("sec-websocket-version", "13"),
                        ("sec-websocket-key", "dGhlIHNhbXBsZSBub25jZQ=="),
                    ],
                )
                .await,
        ),
    ];
    for (what, reply) in &cases {
        assert_security_headers(reply, what);
    }
    assert_eq!(cases[5].1.status.as_u16() / 100, 4);
    assert_eq!(cases[6].1.status, StatusCode::FORBIDDEN);
}

#[test]
fn the_app_page_has_no_inline_script() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../static");
    let page = std::fs::read_to_string(root.join("index.html")).expect("index.html");
    let scripts: Vec<&str> = page.split("<script").skip(1).collect();
    assert!(!scripts.is_empty(), "the page loads the app");
    for script in scripts {
        let tag = &script[..script.find('>').expect("tag end")];
        let body = &script[script.find('>').expect("tag end") + 1..];
        assert!(tag.contains("src="), "inline script: <script{tag}>");
        assert!(
            body.trim_start().starts_with("</script>"),
            "a script with src has no body"
        );
    }
    assert!(!page.contains(" style="), "no style attributes in the page");
    let boot = std::fs::read_to_string(root.join("boot.js")).expect("boot.js");
    // The built page (static/pkg/index.html, see xtask/src/app.rs) names the app's
    // hashed js in a modulepreload link; boot.js imports what that link names.
    assert!(boot.contains(r#"link[rel="modulepreload"]"#), "{boot}");
    assert!(boot.contains("import(link.href)"), "{boot}");
    assert!(page.contains(r#"<link rel="stylesheet" href="/style.css">"#));
}

#[tokio::test]
async fn misleading_show_names_are_refused() {
    let bridge = Bridge::start().await;
    let operator = bridge.operator().await;
    let show = common::show_json("x", 10, 10, 20.0);
    for name in [
        "invoice\u{202E}fdp.exe",
        "wave\u{2066}1\u{2069}",
        "a\u{200B}b",
        "\u{FEFF}rain",
        "snow\u{200F}",
        "x\u{061C}y",
    ] {
        let reply = bridge
            .upload(&operator, &encode_path(name), "application/json", &show)
            .await;
        let error = assert_json_error(&reply, StatusCode::BAD_REQUEST);
        assert!(error.error.contains("U+"), "{name:?}: {error:?}");
    }
    let reply = bridge
        .upload(&operator, &encode_path("波浪 1"), "application/json", &show)
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "{reply:?}");
}

#[tokio::test]
async fn a_restart_removes_every_unfinished_write() {
    let bridge = Bridge::start().await;
    let operator = bridge.operator().await;
    let data = bridge.data_dir().to_owned();
    // What `kill -9` in the middle of each kind of durable write leaves behind.
    let leftovers = [
        data.join(".playlist.json.0123456789abcdef.tmp"),
        data.join(".password.fedcba9876543210.tmp"),
        data.join(".sessions.json.00112233aabbccdd.tmp"),
        data.join(".floatball.toml.0a0b0c0d0e0f0102.tmp"),
        data.join("shows")
            .join(".77617665.json.1122334455667788.tmp"),
    ];
    for leftover in &leftovers {
        std::fs::write(leftover, b"{\"half").expect("write");
    }
    // Not ours: kept.
    std::fs::write(data.join("notes.tmp"), b"mine").expect("write");
    std::fs::write(data.join(".notes.tmp"), b"mine").expect("write");

    let bridge = bridge.restart().await;
    for leftover in &leftovers {
        assert!(!leftover.exists(), "{} is left", leftover.display());
    }
    assert!(data.join("notes.tmp").exists() && data.join(".notes.tmp").exists());
    // The session and the password survived.
    let reply = bridge
        .request(Method::GET, "/api/playlist", Some(&operator), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{reply:?}");
}

/// A CSV for the default 10 × 10 installation: every ball at `depth_mm` at each of
/// `times_ms`.
fn keyframes_csv(times_ms: &[u64], depth_mm: f64) -> String {
    let mut text = String::from("time_ms");
    for unit in 0..100 {
        text.push_str(&format!(",u{unit}"));
    }
    text.push('\n');
    for (index, time_ms) in times_ms.iter().enumerate() {
        text.push_str(&time_ms.to_string());
        let depth = if index % 2 == 0 { 0.0 } else { depth_mm };
        for _ in 0..100 {
            text.push_str(&format!(",{depth}"));
        }
        text.push('\n');
    }
    text
}

#[tokio::test]
async fn a_small_csv_cannot_become_a_huge_or_endless_show() {
    let bridge = Bridge::start().await;
    let operator = bridge.operator().await;
    // Two keyframes 7 hours apart: 1.4 kB that would be a 176 MB show.
    let seven_hours = keyframes_csv(&[0, 7 * 3600 * 1000], 20.0);
    assert!(seven_hours.len() < 1500, "{}", seven_hours.len());
    let reply = bridge
        .upload(&operator, "far", "text/csv", seven_hours.as_bytes())
        .await;
    let error = assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        error.error.contains("30m") && error.error.contains("max_duration"),
        "{error:?}"
    );

    // Within the duration, but over max_bytes once converted: 413 naming the limit.
    let bridge = Bridge::start_with("[uploads]\nmax_bytes = 65536\n").await;
    let operator = bridge.operator().await;
    let ten_minutes = keyframes_csv(&[0, 10 * 60 * 1000], 20.0);
    let reply = bridge
        .upload(&operator, "big", "text/csv", ten_minutes.as_bytes())
        .await;
    let error = assert_json_error(&reply, StatusCode::PAYLOAD_TOO_LARGE);
    assert!(
        error.error.contains("65536 bytes") && error.error.contains("max_bytes"),
        "{error:?}"
    );
    // Nothing was stored.
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&operator), None)
        .await;
    assert_eq!(&list.body[..], b"[]");
}

#[tokio::test]
async fn max_duration_is_configurable_and_applies_to_json_too() {
    let bridge = Bridge::start_with("[uploads]\nmax_duration = \"1s\"\n").await;
    let operator = bridge.operator().await;
    let csv = keyframes_csv(&[0, 500, 1000], 20.0);
    let reply = bridge
        .upload(&operator, "one-second", "text/csv", csv.as_bytes())
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "{reply:?}");
    let csv = keyframes_csv(&[0, 500, 1000, 1500], 20.0);
    let reply = bridge
        .upload(&operator, "longer", "text/csv", csv.as_bytes())
        .await;
    let error = assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(error.error.contains("1s"), "{error:?}");
    assert!(
        error.details.iter().any(|detail| detail.contains("line 5")),
        "{error:?}"
    );

    // A native show of 2 × 250 ms × 3 = 1.5 s.
    let units: Vec<serde_json::Value> = (0..100)
        .map(|_| serde_json::json!({ "start_mm": 0.0, "rows": [[20.0, 0.0, 250], [0.0, 0.0, 250], [20.0, 0.0, 250], [0.0, 0.0, 250], [20.0, 0.0, 250], [0.0, 0.0, 250]] }))
        .collect();
    let json = serde_json::json!({
        "format": "floatball-show", "version": 1, "name": "x",
        "layout": { "rows": 10, "cols": 10, "pitch_mm": 500.0 },
        "units": units,
    })
    .to_string();
    let reply = bridge
        .upload(&operator, "native", "application/json", json.as_bytes())
        .await;
    let error = assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(error.error.contains("max_duration"), "{error:?}");
    assert!(
        error
            .details
            .iter()
            .any(|detail| detail.contains("1s 500ms")),
        "{error:?}"
    );
}

#[tokio::test]
async fn empty_shows_are_refused() {
    let bridge = Bridge::start().await;
    let operator = bridge.operator().await;
    let one_keyframe = keyframes_csv(&[0], 0.0);
    let reply = bridge
        .upload(&operator, "still", "text/csv", one_keyframe.as_bytes())
        .await;
    let error = assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(error.error.contains("empty"), "{error:?}");

    let no_rows = common::show_json("x", 10, 10, 20.0);
    let mut value: serde_json::Value = serde_json::from_slice(&no_rows).expect("json");
    for unit in value["units"].as_array_mut().expect("units") {
        unit["rows"] = serde_json::json!([]);
    }
    let reply = bridge
        .upload(
            &operator,
            "nothing",
            "application/json",
            value.to_string().as_bytes(),
        )
        .await;
    let error = assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(error.error.contains("empty"), "{error:?}");

    let header_only = keyframes_csv(&[], 0.0);
    let reply = bridge
        .upload(&operator, "header", "text/csv", header_only.as_bytes())
        .await;
    assert_json_error(&reply, StatusCode::UNPROCESSABLE_ENTITY);
}

/// Sends `bytes` on a new raw TCP connection to `bridge` and reads until the bridge
/// closes it (or `within` passes: then `None`). A reset after the answer keeps what
/// was read.
async fn raw_exchange(
    bridge: &common::process::Process,
    bytes: &[u8],
    within: Duration,
) -> Option<Vec<u8>> {
    use tokio::io::{AsyncReadExt, AsyncWriteExt};
    let mut stream = tokio::net::TcpStream::connect(bridge.addr)
        .await
        .expect("connect");
    stream.write_all(bytes).await.expect("write");
    let mut answer = Vec::new();
    let mut buffer = [0u8; 4096];
    tokio::time::timeout(within, async {
        loop {
            match stream.read(&mut buffer).await {
                Ok(0) | Err(_) => return,
                Ok(read) => answer.extend_from_slice(&buffer[..read]),
            }
        }
    })
    .await
    .ok()?;
    Some(answer)
}

/// Hyper's own answer to a request it cannot read, as docs/api.md describes it: the
/// status line, `connection: close`, `content-length: 0` and `date`, nothing else,
/// and the connection closed.
fn assert_hypers_answer(answer: &[u8], status_line: &str) {
    let text = String::from_utf8_lossy(answer);
    let (head, body) = text
        .split_once("\r\n\r\n")
        .unwrap_or_else(|| panic!("{text:?}"));
    assert!(body.is_empty(), "{text:?}");
    let mut lines = head.lines();
    assert_eq!(lines.next(), Some(status_line), "{text:?}");
    let mut names: Vec<String> = lines
        .map(|line| {
            line.split_once(':')
                .map(|(name, _)| name.to_ascii_lowercase())
                .unwrap_or_default()
        })
        .collect();
    names.sort();
    assert_eq!(names, ["connection", "content-length", "date"], "{text:?}");
    let head = head.to_ascii_lowercase();
    assert!(head.contains("\r\nconnection: close\r\n"), "{text:?}");
    assert!(head.contains("\r\ncontent-length: 0\r\n"), "{text:?}");
}

/// Issue 36 (6): what a scanner gets for a malformed request line or oversized
/// headers, through the real binary on raw sockets — hyper's own answer, as
/// documented, and the connection closed at once; a request within the limit is the
/// router's as usual.
#[tokio::test]
async fn unreadable_requests_get_the_documented_answer_and_the_connection_closes() {
    let bridge = common::process::Process::start("");
    let within = Duration::from_secs(5);

    for malformed in [
        &b"GARBAGE\r\n\r\n"[..],
        b"GET / HTTP/9.9\r\nHost: x\r\n\r\n",
        b"GET / HTTP/1.1\r\nHost: x\r\nNo colon here\r\n\r\n",
        b"GET /\x01 HTTP/1.1\r\nHost: x\r\n\r\n",
    ] {
        let answer = raw_exchange(&bridge, malformed, within)
            .await
            .unwrap_or_else(|| panic!("{malformed:?}: the connection stayed open"));
        assert_hypers_answer(&answer, "HTTP/1.1 400 Bad Request");
    }

    let limit = floatball_bridge::server::MAX_HEADER_BYTES;
    let oversized = format!(
        "GET / HTTP/1.1\r\nHost: x\r\nX-Padding: {}\r\n\r\n",
        "a".repeat(limit)
    );
    let answer = raw_exchange(&bridge, oversized.as_bytes(), within)
        .await
        .expect("the connection stayed open");
    assert_hypers_answer(&answer, "HTTP/1.1 431 Request Header Fields Too Large");
    // A URI as long is refused the same way (it counts with the headers).
    let long_uri = format!("GET /{} HTTP/1.1\r\nHost: x\r\n\r\n", "a".repeat(limit));
    let answer = raw_exchange(&bridge, long_uri.as_bytes(), within)
        .await
        .expect("the connection stayed open");
    assert_hypers_answer(&answer, "HTTP/1.1 431 Request Header Fields Too Large");

    // More than 100 headers, however short.
    let many: String = (0..101).map(|n| format!("X-{n}: a\r\n")).collect();
    let answer = raw_exchange(
        &bridge,
        format!("GET / HTTP/1.1\r\nHost: x\r\n{many}\r\n").as_bytes(),
        within,
    )
    .await
    .expect("the connection stayed open");
    assert_hypers_answer(&answer, "HTTP/1.1 431 Request Header Fields Too Large");

    // Just within the limit: the router answers, with its headers.
    let within_limit = format!(
        "GET /api/nothing-here HTTP/1.1\r\nHost: x\r\nConnection: close\r\nX-Padding: {}\r\n\r\n",
        "a".repeat(limit / 2)
    );
    let answer = raw_exchange(&bridge, within_limit.as_bytes(), within)
        .await
        .expect("closed after the answer");
    let text = String::from_utf8_lossy(&answer).to_ascii_lowercase();
    assert!(text.starts_with("http/1.1 404 not found\r\n"), "{text}");
    assert!(text.contains("content-type: application/json"), "{text}");
    assert!(text.contains("x-content-type-options: nosniff"), "{text}");
}

/// Issue 36 (6): slowloris connections (a header line every second, never the end of
/// the head), idle connections and a keep-alive connection left idle are all closed,
/// without an answer, [`HEADER_READ_TIMEOUT`] after their request began — and
/// meanwhile the e-stop works, on a WebSocket opened before them and on one opened
/// while they hang.
///
/// [`HEADER_READ_TIMEOUT`]: floatball_bridge::server::HEADER_READ_TIMEOUT
#[tokio::test]
async fn slow_and_idle_connections_are_closed_and_the_estop_still_works() {
    use floatball_shared::api::{PlayerState, ServerMessage};
    use std::time::Instant;
    use tokio::io::{AsyncReadExt, AsyncWriteExt};

    const SLOW: usize = 40;
    const IDLE: usize = 40;
    let timeout = floatball_bridge::server::HEADER_READ_TIMEOUT;
    let bridge = common::process::Process::start("");
    let token = bridge.operator().await;
    let mut before = bridge.ws(&token).await;

    // Each connection: when it began, and when the bridge closed it (and whether it
    // sent anything).
    let began = Instant::now();
    let mut hanging = Vec::new();
    for slow in 0..SLOW + IDLE {
        let mut stream = tokio::net::TcpStream::connect(bridge.addr)
            .await
            .expect("connect");
        hanging.push(tokio::spawn(async move {
            let mut buffer = [0u8; 1024];
            let mut sent = 0usize;
            if slow < SLOW {
                stream
                    .write_all(b"GET / HTTP/1.1\r\nHost: x\r\n")
                    .await
                    .expect("write");
            }
            loop {
                tokio::select! {
                    read = stream.read(&mut buffer) => {
                        return (Instant::now(), read.unwrap_or(0));
                    }
                    () = tokio::time::sleep(Duration::from_secs(1)), if slow < SLOW => {
                        sent += 1;
                        if stream.write_all(format!("X-Slow-{sent}: a\r\n").as_bytes()).await.is_err() {
                            return (Instant::now(), 0);
                        }
                    }
                }
            }
        }));
    }
    // A keep-alive connection: one request answered, then nothing.
    let mut kept = tokio::net::TcpStream::connect(bridge.addr)
        .await
        .expect("connect");
    kept.write_all(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n")
        .await
        .expect("write");
    let mut buffer = vec![0u8; 65_536];
    // The whole answer, however the bridge's writes and the network cut it.
    let mut answer = Vec::new();
    let answered = loop {
        let read = kept.read(&mut buffer).await.expect("the answer");
        assert!(
            read > 0,
            "closed after {:?}",
            String::from_utf8_lossy(&answer)
        );
        answer.extend_from_slice(&buffer[..read]);
        let text = String::from_utf8_lossy(&answer).into_owned();
        if let Some(head_end) = text.find("\r\n\r\n") {
            let length = text[..head_end]
                .lines()
                .find_map(|line| {
                    let (name, value) = line.split_once(':')?;
                    name.eq_ignore_ascii_case("content-length")
                        .then(|| value.trim().parse::<usize>().ok())
                        .flatten()
                })
                .expect("a content-length");
            if answer.len() >= head_end + 4 + length {
                break text;
            }
        }
    };
    assert!(answered.starts_with("HTTP/1.1 200 OK"), "{answered:?}");
    let kept_answered = Instant::now();

    // While they hang: a new WebSocket, and the e-stop on the one opened before.
    let mut during = bridge.ws(&token).await;
    assert!(matches!(
        common::next_message(&mut during).await,
        ServerMessage::Status(_)
    ));
    common::send_text(&mut before, r#"{"type":"estop"}"#).await;
    common::status_until(&mut during, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    assert!(
        began.elapsed() < timeout,
        "the e-stop took until the hanging connections' end"
    );

    // Every hanging connection is closed, without an answer, after the timeout.
    for (index, connection) in hanging.into_iter().enumerate() {
        let (closed, bytes) = tokio::time::timeout(timeout + Duration::from_secs(5), connection)
            .await
            .unwrap_or_else(|_| panic!("connection {index} is still open"))
            .expect("the connection's task");
        assert_eq!(bytes, 0, "connection {index} got an answer");
        let after = closed.duration_since(began);
        assert!(
            after >= timeout - Duration::from_millis(500)
                && after < timeout + Duration::from_secs(3),
            "connection {index} closed after {after:?}"
        );
    }
    let read = tokio::time::timeout(Duration::from_secs(5), kept.read(&mut buffer))
        .await
        .expect("the idle keep-alive connection is still open")
        .unwrap_or(0);
    assert_eq!(read, 0, "{:?}", String::from_utf8_lossy(&buffer[..read]));
    assert!(kept_answered.elapsed() >= timeout - Duration::from_millis(500));
}
