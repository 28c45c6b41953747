//! The e-stop wins every race with Start: Start, then the e-stop after 0 to 100 ms, on
//! a 9600-baud pseudo-terminal through the real `floatball` binary, with a tap on the
//! line that answers as a gateway. After the stop bytes nothing but queries may reach
//! the line, and the matrix must end `stopped` — whether the Start was still being
//! prepared, homing, or approaching when the stop came.
//!
//! `FLOATBALL_RACE_REPS` sets the repetitions of the whole set of offsets (default 2);
//! `cargo xtask stress` runs it many times over.

use crate::common;

use std::time::{Duration, Instant};

use common::process::{Process, Tap};
use common::{Ws, send_text};
use floatball_shared::api::{PlayerState, ServerMessage};
use floatball_shared::uim2503::ascii::parse_script;
use floatball_shared::uim2503::sim::GatewayConfig;
use futures_util::StreamExt;
use tokio_tungstenite::tungstenite::Message;

/// Delays between Start and the e-stop, ms.
const OFFSETS_MS: [u64; 8] = [0, 1, 2, 5, 10, 20, 50, 100];

/// The stop as the default configuration writes it.
const STOP: &[u8] = b"*0;MO=0;";

fn repetitions() -> usize {
    std::env::var("FLOATBALL_RACE_REPS")
        .ok()
        .and_then(|reps| reps.parse().ok())
        .unwrap_or(2)
}

/// Reads messages for `wait`, keeping the last status's state; returns it and
/// whether an `estop_sent` came.
async fn settle(ws: &mut Ws, wait: Duration, last: &mut PlayerState) -> bool {
    let until = tokio::time::Instant::now() + wait;
    let mut acknowledged = false;
    while let Ok(Some(frame)) = tokio::time::timeout_at(until, ws.next()).await {
        let Ok(Message::Text(text)) = frame else {
            continue;
        };
        match serde_json::from_str::<ServerMessage>(text.as_str()).expect("a message") {
            ServerMessage::Status(status) => *last = status.state,
            ServerMessage::EstopSent { .. } => acknowledged = true,
            _ => {}
        }
    }
    acknowledged
}

/// What reached the line after the first stop in `wire`: every instruction there, or
/// `None` when no stop arrived.
fn after_the_stop(wire: &[u8]) -> Option<String> {
    let at = wire.windows(STOP.len()).position(|window| window == STOP)?;
    Some(String::from_utf8_lossy(&wire[at + STOP.len()..]).into_owned())
}

/// The real binary with one gateway on a tapped pseudo-terminal: a `side` × `side`
/// matrix at `baud`, `show` uploaded as the whole playlist, a WebSocket open and the
/// link up.
struct Rig {
    _dir: tempfile::TempDir,
    tap: Tap,
    bridge: Process,
    ws: Ws,
}

async fn rig(side: u32, baud: u32, name: &str, show: &[u8]) -> Rig {
    let dir = tempfile::tempdir().expect("temp dir");
    let units = u8::try_from(side * side).expect("at most 127 units");
    let tap = Tap::new(dir.path(), "gateway0", baud, GatewayConfig::numbered(units));
    let bridge = Process::start(&format!(
        "[matrix]\nrows = {side}\ncols = {side}\n\
         [[gateway]]\nport = \"{}\"\nbaud = {baud}\n\
         [safety]\napproach_speed_mm_s = 2000.0\n",
        tap.path.display()
    ));
    let token = bridge.prepare_show(name, show, false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(
        common::process::links_up(&mut ws).await,
        "the gateway did not come up; log:\n{}",
        bridge.log()
    );
    Rig {
        _dir: dir,
        tap,
        bridge,
        ws,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_estop_right_after_start_wins_at_every_offset() {
    let Rig {
        tap,
        bridge,
        mut ws,
        ..
    } = rig(2, 9600, "race", &common::show_json("race", 2, 2, 20.0)).await;
    let mut state = PlayerState::Idle;
    let started = Instant::now();
    let mut runs = 0;
    for repetition in 0..repetitions() {
        for offset_ms in OFFSETS_MS {
            let mark = tap.len();
            send_text(&mut ws, r#"{"type":"start"}"#).await;
            tokio::time::sleep(Duration::from_millis(offset_ms)).await;
            send_text(&mut ws, r#"{"type":"estop"}"#).await;
            // The stop takes 8.3 ms at 9600 baud after at most one 20.8 ms instruction.
            let acknowledged = settle(&mut ws, Duration::from_millis(600), &mut state).await;
            let wire = tap.wire();
            let wire = &wire[mark..];
            let context = format!(
                "repetition {repetition}, e-stop {offset_ms} ms after Start; wire {:?}; log:\n{}",
                String::from_utf8_lossy(wire),
                bridge.log()
            );
            assert!(acknowledged, "no estop_sent: {context}");
            let tail = after_the_stop(wire).unwrap_or_else(|| panic!("no stop: {context}"));
            let instructions =
                parse_script(&tail).unwrap_or_else(|error| panic!("{error}: {context}"));
            assert!(
                instructions
                    .iter()
                    .all(|instruction| instruction.is_inert()),
                "something that moves followed the stop: {context}"
            );
            assert_eq!(state, PlayerState::Stopped, "{context}");
            if repetition == 0 {
                println!(
                    "e-stop {offset_ms:>3} ms after Start: {:?}",
                    String::from_utf8_lossy(wire)
                );
            }
            runs += 1;
        }
    }
    println!(
        "{runs} Start/e-stop races at 9600 baud, offsets {OFFSETS_MS:?} ms: all stopped, nothing but queries after the stop ({:.1} s)",
        started.elapsed().as_secs_f64()
    );
}

/// A gateway that stops reading mid-show: the line backs up, the link writes nothing
/// while bytes wait, and the watchdog stops the show and names the gateway.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stalled_line_stops_the_show_and_names_the_gateway() {
    let show = common::process::wave_json("long", 10, 10, 60_000, 40.0);
    let Rig {
        tap,
        bridge,
        mut ws,
        ..
    } = rig(10, 921_600, "long", &show).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut state = PlayerState::Idle;
    while state != PlayerState::Playing {
        assert!(
            Instant::now() < deadline,
            "never played; log:\n{}",
            bridge.log()
        );
        settle(&mut ws, Duration::from_millis(100), &mut state).await;
    }
    tap.set_answering(false);
    let deadline = Instant::now() + Duration::from_secs(30);
    let error = loop {
        assert!(
            Instant::now() < deadline,
            "the stall was not noticed ({state:?}); log:\n{}",
            bridge.log()
        );
        match common::next_message(&mut ws).await {
            ServerMessage::Status(status) if status.state == PlayerState::Error => {
                break status.last_error.unwrap_or_default();
            }
            ServerMessage::Status(status) => state = status.state,
            _ => {}
        }
    };
    assert!(
        error.contains("gateway 0") && error.contains("stalled"),
        "{error}"
    );
    assert!(bridge.log().contains("stalled"), "the stall is logged");
}

/// An e-stop while a long show preloads its rows: no stale row follows the stop (the
/// player may have a batch on its way between the link dropping its queue and the
/// player hearing of the stop).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_estop_during_the_preload_leaves_no_stale_rows() {
    let show = common::process::wave_json("long", 2, 2, 30_000, 40.0);
    let Rig {
        tap,
        bridge,
        mut ws,
        ..
    } = rig(2, 9600, "long", &show).await;
    for (repetition, wait_ms) in [0u64, 150, 400]
        .into_iter()
        .cycle()
        .take(repetitions() * 3)
        .enumerate()
    {
        let mark = tap.len();
        send_text(&mut ws, r#"{"type":"start"}"#).await;
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut state = PlayerState::Stopped;
        while state != PlayerState::Loading {
            assert!(
                Instant::now() < deadline,
                "never loaded; log:\n{}",
                bridge.log()
            );
            settle(&mut ws, Duration::from_millis(20), &mut state).await;
        }
        tokio::time::sleep(Duration::from_millis(wait_ms)).await;
        send_text(&mut ws, r#"{"type":"estop"}"#).await;
        let acknowledged = settle(&mut ws, Duration::from_millis(600), &mut state).await;
        let wire = tap.wire();
        let wire = &wire[mark..];
        let context = format!("repetition {repetition}, e-stop {wait_ms} ms into the preload");
        assert!(acknowledged, "no estop_sent: {context}");
        assert!(
            wait_ms == 0 || wire.windows(3).any(|window| window == b"QP["),
            "the preload had begun: {context}"
        );
        let tail = after_the_stop(wire).unwrap_or_else(|| panic!("no stop: {context}"));
        let instructions = parse_script(&tail).unwrap_or_else(|error| panic!("{error}: {context}"));
        assert!(
            instructions
                .iter()
                .all(|instruction| instruction.is_inert()),
            "rows or motion followed the stop ({context}): {tail:?}"
        );
        assert_eq!(state, PlayerState::Stopped, "{context}");
    }
}
