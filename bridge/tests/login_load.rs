//! Login traffic: many logins at once each get a correct answer, and the bridge's
//! memory stays bounded (each argon2id check needs 19 MiB; only a few run at once, in
//! work areas that are reused).

use crate::common;

use std::net::{IpAddr, SocketAddr};
use std::process::Stdio;
use std::time::Duration;

use axum::http::{Method, StatusCode, header};
use common::Bridge;
use tokio::io::{AsyncBufReadExt, AsyncReadExt, AsyncWriteExt, BufReader};

/// Logins fired at once.
const LOGINS: usize = 100;

/// Client addresses they come from (127.0.0.1 …): 5 logins each, within the limit of
/// five wrong passwords per address and minute.
const ADDRESSES: usize = 20;

/// The most resident memory the bridge may hold after the burst, bytes.
const MAX_RSS_BYTES: u64 = 100 * 1024 * 1024;

/// The `i`-th login: its client address and whether it gives the right password
/// (two of every five do).
fn login_plan(i: usize) -> (IpAddr, bool) {
    let address = IpAddr::from([127, 0, 0, u8::try_from(1 + i % ADDRESSES).expect("small")]);
    (address, (i / ADDRESSES) % 5 < 2)
}

/// Checks one answer: 200 with a token for the right password, 401 for a wrong one, or
/// 503 with `Retry-After` and a JSON error when the bridge was too busy to check.
fn assert_correct(right: bool, status: u16, retry_after: Option<&str>, body: &[u8]) {
    let text = String::from_utf8_lossy(body);
    match status {
        200 => {
            assert!(right, "a wrong password was accepted: {text}");
            let json: serde_json::Value = serde_json::from_slice(body).expect("JSON");
            assert_eq!(json["token"].as_str().map(str::len), Some(64), "{text}");
        }
        401 => {
            assert!(!right, "the right password was refused: {text}");
            let json: serde_json::Value = serde_json::from_slice(body).expect("JSON");
            assert_eq!(json["error"], "Wrong password", "{text}");
        }
        503 => {
            let seconds: u64 = retry_after
                .expect("503 has Retry-After")
                .parse()
                .expect("seconds");
            assert!(seconds >= 1, "{seconds}");
            let json: serde_json::Value = serde_json::from_slice(body).expect("JSON");
            assert!(
                json["error"].as_str().is_some_and(|e| e.contains("busy")),
                "{text}"
            );
        }
        other => panic!("unexpected answer {other}: {text}"),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_hundred_concurrent_logins_each_get_a_correct_answer() {
    let bridge = Bridge::start().await;
    let logins = (0..LOGINS).map(|i| {
        let (from, right) = login_plan(i);
        let password = if right { "1234" } else { "wrong!" };
        let bridge = &bridge;
        async move {
            let body =
                serde_json::to_vec(&serde_json::json!({ "password": password })).expect("json");
            let reply = bridge
                .request_from(
                    from,
                    Method::POST,
                    "/api/login",
                    None,
                    Some(("application/json", body)),
                    &[],
                )
                .await;
            (right, reply)
        }
    });
    let replies = futures_util::future::join_all(logins).await;
    let mut counts = [0usize; 3];
    for (right, reply) in &replies {
        let retry_after = reply
            .headers
            .get(header::RETRY_AFTER)
            .and_then(|value| value.to_str().ok());
        assert_correct(*right, reply.status.as_u16(), retry_after, &reply.body);
        match reply.status {
            StatusCode::OK => counts[0] += 1,
            StatusCode::UNAUTHORIZED => counts[1] += 1,
            _ => counts[2] += 1,
        }
    }
    eprintln!("200: {}, 401: {}, 503: {}", counts[0], counts[1], counts[2]);
    assert!(counts[0] + counts[1] > 0, "some logins were checked");
}

#[tokio::test]
async fn a_login_waiting_too_long_for_a_check_gets_503_with_retry_after() {
    let bridge = Bridge::start().await;
    // Every check is taken (as by slow logins) for longer than a login waits.
    let held: Vec<_> = (0..floatball_bridge::auth::CHECK_PERMITS)
        .map(|_| bridge.state.password().try_admit().expect("free"))
        .collect();
    let started = std::time::Instant::now();
    let reply = bridge.login("1234").await;
    assert!(started.elapsed() >= floatball_bridge::auth::CHECK_QUEUE_WAIT);
    assert_eq!(reply.status, StatusCode::SERVICE_UNAVAILABLE);
    assert_eq!(reply.headers[header::CONTENT_TYPE], "application/json");
    assert_correct(
        true,
        503,
        reply.headers[header::RETRY_AFTER].to_str().ok(),
        &reply.body,
    );
    drop(held);
    // A refused wait is not a wrong password: the address is not held back.
    for _ in 0..5 {
        assert_eq!(bridge.login("1234").await.status, StatusCode::OK);
    }
}

/// A line of `/proc/<pid>/status` in bytes (`VmRSS`, `VmHWM`).
fn proc_status_bytes(pid: u32, key: &str) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).expect("proc status");
    let line = status
        .lines()
        .find_map(|line| line.strip_prefix(key)?.strip_prefix(':'))
        .unwrap_or_else(|| panic!("no {key} in {status}"));
    let kib: u64 = line
        .trim()
        .strip_suffix("kB")
        .expect("kB")
        .trim()
        .parse()
        .expect("number");
    kib * 1024
}

/// `POST /api/login` over a fresh connection from `from`: the status, `Retry-After`
/// and the body.
async fn raw_login(to: SocketAddr, from: IpAddr, password: &str) -> (u16, Option<String>, Vec<u8>) {
    let socket = tokio::net::TcpSocket::new_v4().expect("socket");
    socket.bind(SocketAddr::new(from, 0)).expect("bind");
    let mut stream = socket.connect(to).await.expect("connect");
    let body = serde_json::json!({ "password": password }).to_string();
    let request = format!(
        "POST /api/login HTTP/1.1\r\nHost: {to}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    stream.write_all(request.as_bytes()).await.expect("send");
    let mut answer = Vec::new();
    stream.read_to_end(&mut answer).await.expect("answer");
    let split = answer
        .windows(4)
        .position(|window| window == b"\r\n\r\n")
        .expect("head and body");
    let head = String::from_utf8_lossy(&answer[..split]).into_owned();
    let status: u16 = head
        .split_whitespace()
        .nth(1)
        .and_then(|code| code.parse().ok())
        .expect("status");
    let retry_after = head.lines().find_map(|line| {
        let (name, value) = line.split_once(':')?;
        name.eq_ignore_ascii_case("retry-after")
            .then(|| value.trim().to_owned())
    });
    (status, retry_after, answer[split + 4..].to_vec())
}

/// The real daemon answers 100 logins at once and afterwards holds at most 100 MB
/// (before the checks were limited it reached 791 MB for 40 wrong and 1.37 GB for 40
/// right logins, and kept it).
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_daemon_stays_under_100_mb_after_a_hundred_concurrent_logins() {
    let data = tempfile::tempdir().expect("temp dir");
    let static_dir = data.path().join("static");
    std::fs::create_dir_all(&static_dir).expect("static");
    std::fs::write(static_dir.join("index.html"), "<!doctype html>").expect("index");
    let mut daemon = tokio::process::Command::new(env!("CARGO_BIN_EXE_floatball"))
        .arg("--listen")
        .arg("127.0.0.1:0")
        .arg("--data-dir")
        .arg(data.path().join("data"))
        .arg("--static-dir")
        .arg(&static_dir)
        .env("RUST_LOG", "error")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .kill_on_drop(true)
        .spawn()
        .expect("start floatball");
    let pid = daemon.id().expect("pid");
    let stdout = daemon.stdout.take().expect("stdout");
    let mut banner = String::new();
    tokio::time::timeout(
        Duration::from_secs(30),
        BufReader::new(stdout).read_line(&mut banner),
    )
    .await
    .expect("the daemon starts within 30 s")
    .expect("read the banner");
    let addr: SocketAddr = banner
        .trim()
        .rsplit("http://")
        .next()
        .and_then(|addr| addr.parse().ok())
        .unwrap_or_else(|| panic!("no address in {banner:?}"));
    let before = proc_status_bytes(pid, "VmRSS");

    let logins = (0..LOGINS).map(|i| {
        let (from, right) = login_plan(i);
        async move {
            let password = if right { "1234" } else { "wrong!" };
            (right, raw_login(addr, from, password).await)
        }
    });
    let replies = tokio::time::timeout(
        Duration::from_secs(120),
        futures_util::future::join_all(logins),
    )
    .await
    .expect("every login is answered within 2 minutes");
    for (right, (status, retry_after, body)) in &replies {
        assert_correct(*right, *status, retry_after.as_deref(), body);
    }
    let answered = replies
        .iter()
        .filter(|(_, (status, _, _))| *status != 503)
        .count();

    let after = proc_status_bytes(pid, "VmRSS");
    let peak = proc_status_bytes(pid, "VmHWM");
    eprintln!(
        "floatball RSS: {:.1} MB before, {:.1} MB after {LOGINS} concurrent logins \
         ({answered} checked, the rest 503), peak {:.1} MB",
        before as f64 / 1e6,
        after as f64 / 1e6,
        peak as f64 / 1e6
    );
    assert!(
        after <= MAX_RSS_BYTES,
        "RSS after the burst is {after} bytes, over {MAX_RSS_BYTES}"
    );
}
