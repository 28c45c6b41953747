//! The SCL e-stop's latency: WebSocket message → first byte of the first `SK` on the
//! wire, through the real `floatball` binary, on an RS-485 line of 8 drives at 9600
//! and 115200 baud and to 8 eSCL drives over loopback UDP, with the drives polled
//! every 20 ms (the line is busy).
//!
//! A pseudo-terminal carries bytes at once, so the twins' peer times the line as a
//! UART would (`common::scl_peer`: ten bits a byte, one byte after the other; the
//! answers are delayed by their own time on the line): a stop that waits behind a
//! request already written waits as long as on a real line.
//!
//! In the normal test run it is short (3 presses a line) and checks that every press
//! put `SK` on the wire for every drive — no timing asserted. `cargo xtask scl-bench
//! [--presses N]` runs it at length in a release build (`SCL_BENCH_PRESSES`) and reads
//! the figures it prints: the median and the maximum latency of each line.

use crate::common;

use std::time::{Duration, Instant};

use common::process::{Process, links_up};
use common::scl_peer::Peer;
use common::{next_reply, send_text};
use floatball_shared::api::ServerMessage;

const DRIVES: &str = "12345678";

fn config(gateway: &str) -> String {
    format!(
        "[matrix]\nrows = 1\ncols = {}\n[scl]\npoll_ms = 20\nhost_port = 0\n[[gateway]]\nkind = \"scl\"\n{gateway}\n",
        DRIVES.len()
    )
}

/// Presses the e-stop `presses` times; returns every latency, sorted.
async fn measure(bridge: &Process, peer: &Peer, presses: usize) -> Vec<Duration> {
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    let mut latencies = Vec::with_capacity(presses);
    for press in 0..presses {
        // Let the polls fill the line again, at a different phase each time.
        tokio::time::sleep(Duration::from_millis(300 + (press as u64 * 7) % 40)).await;
        let pressed = Instant::now();
        send_text(&mut ws, r#"{"type":"estop"}"#).await;
        assert!(matches!(
            next_reply(&mut ws).await,
            ServerMessage::EstopSent { .. }
        ));
        let deadline = Instant::now() + Duration::from_secs(2);
        let stops = loop {
            let stops: Vec<_> = peer
                .since(pressed)
                .into_iter()
                .filter(|line| line.text.ends_with("SK"))
                .collect();
            // A drive: its socket over UDP, its address (`3SK`) on a line; the UDP
            // stop's repeats count once.
            let reached: std::collections::BTreeSet<String> = stops
                .iter()
                .map(|line| {
                    line.drive
                        .map_or_else(|| line.text.clone(), |d| d.to_string())
                })
                .collect();
            if reached.len() == DRIVES.len() {
                break stops;
            }
            assert!(
                Instant::now() < deadline,
                "press {press}: SK reached {reached:?}, not all {} drives, within 2 s",
                DRIVES.len()
            );
            tokio::time::sleep(Duration::from_millis(2)).await;
        };
        latencies.push(stops[0].at - pressed);
    }
    latencies.sort();
    latencies
}

fn report(name: &str, latencies: &[Duration]) {
    let median = latencies[latencies.len() / 2];
    let max = latencies[latencies.len() - 1];
    println!(
        "{name}: {} presses, WebSocket → first SK byte: median {:.2} ms, max {:.2} ms",
        latencies.len(),
        median.as_secs_f64() * 1000.0,
        max.as_secs_f64() * 1000.0
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_estop_reaches_every_drive_and_its_latency_is_printed() {
    let presses: usize = std::env::var("SCL_BENCH_PRESSES")
        .ok()
        .and_then(|value| value.parse().ok())
        .unwrap_or(3);
    for baud in [9600, 115_200] {
        let dir = tempfile::tempdir().unwrap();
        let peer = Peer::serial(dir.path(), "rs485", DRIVES, baud, false);
        let bridge = Process::start(&config(&format!(
            "port = \"{}\"\nbaud = {baud}\naddresses = \"{DRIVES}\"",
            peer.path.display()
        )));
        let latencies = measure(&bridge, &peer, presses).await;
        report(&format!("RS-485 at {baud} baud, 8 drives"), &latencies);
    }
    let peer = Peer::udp(DRIVES.len());
    let list: Vec<String> = peer.sockets.iter().map(|s| format!("\"{s}\"")).collect();
    let bridge = Process::start(&config(&format!("escl = [{}]", list.join(", "))));
    let latencies = measure(&bridge, &peer, presses).await;
    report("eSCL over loopback UDP, 8 drives", &latencies);
}
