//! Start-up with a library of shows: the real `floatball` binary on a data directory
//! full of shows, timed from the process's start to its first HTTP answer, to the
//! WebSocket's `estop_sent`, and to the complete show list (issue 36).
//!
//! In the normal test run it is small: four shows stored without the show index
//! (`show-index.json`, as after an upgrade or a lost index), and it checks that the
//! e-stop is acknowledged at once, that the list, once complete, is exactly the
//! shows' summaries as stored, that the index is written, and that the next start
//! answers the same list from it.
//!
//! `cargo xtask startup-bench [--library-mb N] [--runs R]` runs it at length in a
//! release build (`STARTUP_BENCH_MB`, default 1024; `STARTUP_BENCH_RUNS`, default 5):
//! a library of about N MB of generated shows (10 × 10 balls, 2 to 4.5 minutes each,
//! about 2.8 MB: wave, ripple, rain, plane, breathe and noise from `floatball
//! generate`, stored by the store itself), kept between runs under the target
//! directory (`tmp/startup-bench/`). Each run starts the bridge, times it, then kills
//! it with SIGKILL (a power cut). It prints the medians with the index kept (a normal
//! restart) and with the index removed before each start (it is rebuilt in the
//! background). Nothing about speed is asserted.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::{Remote, Ws, send_text};
use floatball_bridge::store::{ShowName, ShowStore};
use floatball_shared::api::{ServerMessage, ShowSummary};
use floatball_shared::show::Show;
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

/// The show index's file in the data directory.
const INDEX: &str = "show-index.json";

/// The response header of a show list that is not complete yet.
const LIBRARY_HEADER: &str = "floatball-library";

fn from_env(name: &str) -> Option<u64> {
    std::env::var(name)
        .ok()
        .and_then(|value| value.parse().ok())
        .filter(|value| *value > 0)
}

/// A started bridge: its process and address.
struct Started {
    child: Child,
    remote: Remote,
}

impl Drop for Started {
    fn drop(&mut self) {
        // SIGKILL: as a power cut.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `floatball` on `data`; returns once it says where it listens.
fn start(data: &Path) -> Started {
    let static_dir = common::static_dir(data);
    let log = std::fs::File::options()
        .create(true)
        .append(true)
        .open(data.join("floatball.log"))
        .expect("log");
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .arg("--data-dir")
        .arg(data)
        .arg("--static-dir")
        .arg(&static_dir)
        .args(["--listen", "127.0.0.1:0"])
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(log)
        .spawn()
        .expect("start floatball");
    let stdout = child.stdout.take().expect("stdout");
    let addr = common::process::listening_address(stdout);
    Started {
        child,
        remote: Remote { addr },
    }
}

/// The show list if it is complete (no `Floatball-Library: indexing`).
async fn complete_list(remote: &Remote, token: &str) -> Option<Vec<ShowSummary>> {
    let reply = remote
        .request(Method::GET, "/api/shows", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let partial = reply.headers.contains_key(LIBRARY_HEADER);
    (!partial).then(|| reply.json())
}

/// Presses the e-stop on a new WebSocket and waits for `estop_sent`.
async fn estop(remote: &Remote, token: &str) {
    let mut ws: Ws = remote.ws(token).await;
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    tokio::time::timeout(Duration::from_secs(30), async {
        while let Some(frame) = ws.next().await {
            if let Ok(Message::Text(text)) = frame
                && let Ok(ServerMessage::EstopSent { .. }) = serde_json::from_str(text.as_str())
            {
                return;
            }
        }
        panic!("the WebSocket closed before estop_sent");
    })
    .await
    .expect("estop_sent within 30 s");
}

/// One start's times from the process's start, and the list it ended with.
struct Times {
    listening: Duration,
    first_answer: Duration,
    estop: Duration,
    list: Duration,
    shows: Vec<ShowSummary>,
}

/// Starts the bridge on `data` and times it; it is killed when this returns.
async fn time_start(data: &Path, token: &str) -> Times {
    let began = Instant::now();
    let started = start(data);
    let listening = began.elapsed();
    let remote = started.remote;
    let first = remote
        .request(Method::GET, "/api/playlist", Some(token), None)
        .await;
    assert_eq!(first.status, StatusCode::OK, "{:?}", first.body);
    let first_answer = began.elapsed();
    estop(&remote, token).await;
    let estop = began.elapsed();
    let shows = loop {
        if let Some(shows) = complete_list(&remote, token).await {
            break shows;
        }
        assert!(
            began.elapsed() < Duration::from_secs(600),
            "the list is complete within 10 minutes"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    };
    let list = began.elapsed();
    drop(started);
    Times {
        listening,
        first_answer,
        estop,
        list,
        shows,
    }
}

/// Logs in once on `data` (changing the initial password) and returns the token; the
/// bridge keeps it across restarts.
async fn operator_token(data: &Path) -> String {
    let started = start(data);
    let token = started.remote.operator().await;
    // Wait for the first complete list, so the index (if any) is written.
    while complete_list(&started.remote, &token).await.is_none() {
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    token
}

/// The base shows of the bench's library: (pattern, seconds).
const PATTERNS: [(&str, u32); 6] = [
    ("wave", 120),
    ("ripple", 150),
    ("rain", 180),
    ("plane", 210),
    ("breathe", 240),
    ("noise", 270),
];

/// Generates the base shows with `floatball generate` into `dir`.
fn base_shows(dir: &Path) -> Vec<(String, Show)> {
    PATTERNS
        .iter()
        .map(|(pattern, seconds)| {
            let out = dir.join(format!("{pattern}.json"));
            let output = Command::new(env!("CARGO_BIN_EXE_floatball"))
                .arg("generate")
                .arg(pattern)
                .args(["--duration-s", &seconds.to_string()])
                .arg("--out")
                .arg(&out)
                .output()
                .expect("run floatball generate");
            assert!(output.status.success(), "{output:?}");
            let text = std::fs::read_to_string(&out).expect("generated show");
            std::fs::remove_file(&out).expect("remove");
            (
                (*pattern).to_owned(),
                Show::from_json(&text).expect("a show"),
            )
        })
        .collect()
}

/// A data directory with a library of at least `mb` MB of shows, generated once and
/// kept in `cache` (a file `complete` says it is whole); returns it and its token.
async fn library(cache: &Path, mb: u64) -> (PathBuf, String) {
    let data = cache.join(format!("library-{mb}mb"));
    let complete = data.join("complete");
    let token_file = data.join("token");
    if complete.is_file() {
        println!(
            "startup-bench: the {mb} MB library is kept in {}",
            data.display()
        );
    } else {
        let _ = std::fs::remove_dir_all(&data);
        std::fs::create_dir_all(&data).expect("library dir");
        println!(
            "startup-bench: generating a {mb} MB library in {} (once)",
            data.display()
        );
        let bases = base_shows(&data);
        let store = ShowStore::open(&data).expect("store");
        let mut total = 0u64;
        let mut count = 0usize;
        while total < mb * 1024 * 1024 {
            let (pattern, show) = &bases[count % bases.len()];
            let name = ShowName::parse(&format!("show {count:04} {pattern}")).expect("name");
            let mut show = show.clone();
            name.as_str().clone_into(&mut show.name);
            let (summary, _) = store.put(&name, &show).expect("store a show");
            total += summary.bytes;
            count += 1;
        }
        drop(store);
        println!(
            "startup-bench: {count} shows, {:.0} MB",
            total as f64 / 1_048_576.0
        );
        let token = operator_token(&data).await;
        std::fs::write(&token_file, &token).expect("token");
        std::fs::write(&complete, b"").expect("complete");
    }
    let token = std::fs::read_to_string(&token_file).expect("token");
    (data, token)
}

fn median(mut values: Vec<Duration>) -> Duration {
    values.sort();
    values[values.len() / 2]
}

fn seconds(duration: Duration) -> String {
    format!("{:.3} s", duration.as_secs_f64())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn start_up_with_a_library() {
    match from_env("STARTUP_BENCH_MB") {
        Some(mb) => bench(mb, from_env("STARTUP_BENCH_RUNS").unwrap_or(5)).await,
        None => small().await,
    }
}

/// The bench: medians of `runs` starts with the index kept and removed.
async fn bench(mb: u64, runs: u64) {
    let cache = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("startup-bench");
    let (data, token) = library(&cache, mb).await;
    let shows: u64 = std::fs::read_dir(data.join("shows"))
        .expect("shows")
        .filter_map(Result::ok)
        .map(|entry| entry.metadata().map(|meta| meta.len()).unwrap_or(0))
        .sum();
    let reference = time_start(&data, &token).await.shows;
    println!(
        "startup-bench: {} shows, {:.0} MB; {runs} runs each, killed with SIGKILL after each",
        reference.len(),
        shows as f64 / 1_048_576.0
    );
    for (what, remove_index) in [("index kept", false), ("index removed", true)] {
        let mut all = Vec::new();
        for _ in 0..runs {
            if remove_index {
                let _ = std::fs::remove_file(data.join(INDEX));
            }
            let times = time_start(&data, &token).await;
            assert_eq!(
                times.shows, reference,
                "the list is the same at every start"
            );
            all.push(times);
        }
        let pick = |of: fn(&Times) -> Duration| median(all.iter().map(of).collect());
        println!(
            "startup-bench: {what}: median listening {}, first HTTP answer {}, \
             WebSocket estop_sent {}, show list complete {}",
            seconds(pick(|times| times.listening)),
            seconds(pick(|times| times.first_answer)),
            seconds(pick(|times| times.estop)),
            seconds(pick(|times| times.list)),
        );
    }
}

/// The normal test run: four shows without an index.
async fn small() {
    let data = tempfile::tempdir().expect("temp dir");
    let mut stored = Vec::new();
    {
        let store = ShowStore::open(data.path()).expect("store");
        for (index, name) in ["波浪", "rain", "a b", "z"].into_iter().enumerate() {
            let rows = u32::try_from(index).expect("small") + 1;
            let bytes = common::show_json(name, rows, 2, 30.0);
            let show = Show::from_json(std::str::from_utf8(&bytes).expect("utf-8")).expect("show");
            let name = ShowName::parse(name).expect("name");
            stored.push(store.put(&name, &show).expect("put").0);
        }
    }
    stored.sort_by(|a, b| a.name.cmp(&b.name));
    let index = data.path().join(INDEX);
    assert!(index.is_file(), "the store writes the index with each show");
    std::fs::remove_file(&index).expect("remove the index");

    let token = operator_token(data.path()).await;
    std::fs::remove_file(&index).expect("the index is written again by the first start");
    let times = time_start(data.path(), &token).await;
    assert_eq!(
        times.shows, stored,
        "the rebuilt list is the shows as stored"
    );
    assert!(
        times.estop < Duration::from_secs(5),
        "estop_sent {:?} after the start",
        times.estop
    );
    assert!(index.is_file(), "the index is written once rebuilt");
    // The next start answers the same list from the index.
    let again = time_start(data.path(), &token).await;
    assert_eq!(again.shows, stored);
}
