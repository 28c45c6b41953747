//! Golden wire test of MOONS' drives: through the real `floatball` binary, three drives
//! (addresses `1`, `2`, `3`) on an RS-485 line on a pseudo-terminal, played by the
//! drive twin (`common::scl_peer`), which records every line the bridge writes. One
//! bridge start-up carries out the operator's actions
//!
//! 1. Start (the first): approach, compile and load (a program of one segment into
//!    the queue — `QL`, its lines, `QE`; a longer one compared with `QU` and saved with
//!    `QL` … `QS` only where it differs, then read back), the start, play to the end;
//! 2. Start again, and the e-stop while the show plays;
//! 3. Home, until idle;
//! 4. Start after the e-stop (and the Home), played to the end,
//!
//! and the golden file (`tests/golden/scl_qx1.txt` without a trigger: `QE` or `QX1`
//! starts every drive; `tests/golden/scl_trigger.txt` with `trigger = "1:2"`: the
//! trigger output set high, drives 2 and 3 started, then drive 1, whose program's line
//! 1 is the edge) holds, per action and per drive, in order, every line that drive
//! was sent, byte for byte without its CR (a line begins with the drive's address
//! character).
//!
//! **Left out: the queries `IP`, `SC` and `AL`, and only those.** The link polls every
//! drive with `IP`, `SC` and `AL` every `poll_ms` whenever it has nothing else queued
//! for it; the player's waits ask `IP` until each drive stands where it was sent
//! (`wait_positions`: approach and Home) and `SC` until no program runs
//! (`wait_ended`). How many of them go, and where they fall between the other lines,
//! depends on real time (the twin moves in real time, the polls are timed), so they
//! cannot be pinned. Every other line is: motion set-up (`VE AC DE DI FP`), the
//! uploads, the start, `SK`. Wall-clock times are not recorded either; the order is.
//!
//! The partition into actions is causal, not timed: on a half-duplex line the bridge
//! sends a request only after the previous one was answered, and the twin records a
//! line before it answers, so every line of an action is recorded before the status
//! that ends the action (Idle, Playing, Stopped) reaches the test, and the next
//! action's lines are written only after the test has marked where it begins.
//!
//! Outside the golden, on the whole record (queries included): after the e-stop, the
//! first line that is not a query is `SK`, to every drive back to back, and nothing but
//! queries follows until Home; Home stops every drive the same way (`SK` back to back)
//! before it moves them.
//!
//! **Start homes first when the positions are unknown** — the first Start after
//! start-up and every Start after an e-stop — as on every other family (the show
//! sequencer, `floatball_shared::player`): the home moves (`VE AC DE DI0 FP` to every
//! drive) come before the approach in "Start (the first)" and "Start after the
//! e-stop". That was the one change the move onto the sequencer made to these
//! goldens (before it, a Start on MOONS' drives never homed); a Start after Home goes
//! straight to the approach.
//!
//! **Every run's first move begins with `ME`** (motor enable) to each drive — Start,
//! Start again, Home, Start after Home, Start after the e-stop: the schedule disables
//! the drives at a window's end (`MD`), and a disabled drive refuses to move (alarm
//! `8000` No Move). That was the one change issue 37's motors-off made to these
//! goldens (one `ME` line per drive per action that moves).
//!
//! Regenerate with `FLOATBALL_BLESS=1 cargo test -p floatball-bridge --test
//! integration -- scl_golden::` and read the diff.

use crate::common;

use std::time::Duration;

use common::golden::assert_golden;
use common::process::{Process, links_up};
use common::scl_peer::{Peer, drop_end_mm, drop_show, serial_config};
use common::{Ws, next_reply, send_text, until};
use floatball_shared::api::{PlayerState, ServerMessage};

/// The drives' addresses on the line, in unit order.
const ADDRESSES: &str = "123";

/// The queries left out of the golden (see the module's doc).
const QUERIES: [&str; 3] = ["IP", "SC", "AL"];

/// Ball `ball`'s start position, mm: 1, 2, 3 (away from home, 0, and from one another).
fn start_mm(ball: usize) -> f64 {
    1.0 + ball as f64
}

/// Ball `ball`'s end position, mm: 5, 10, 15.
fn end_mm(ball: usize) -> f64 {
    drop_end_mm(ball)
}

/// Three balls that each go down to 20 mm and come up to their end position, in 1 s.
fn show() -> Vec<u8> {
    drop_show(start_mm)
}

fn config(peer: &Peer, scl: &str) -> String {
    serial_config(peer, scl)
}

/// The SCL command of a line as written on the line: without its address character.
fn command(line: &str) -> &str {
    line.get(1..).unwrap_or_default()
}

fn is_query(line: &str) -> bool {
    QUERIES.contains(&command(line))
}

/// Where each operator action begins in the twin's record.
struct Marks {
    peer: Peer,
    marks: Vec<(&'static str, usize)>,
}

impl Marks {
    /// Marks that what the twin receives from now on belongs to `action`.
    fn mark(&mut self, action: &'static str) {
        let at = self.peer.received.lock().unwrap().len();
        self.marks.push((action, at));
    }

    /// Waits until every drive got `command` since the last mark: an e-stop's stop
    /// lines are on the wire before the next action's mark. The status says
    /// `stopped` as the e-stop is taken, and on a loaded machine a drive's `SK` can
    /// reach the line after that (the next action's section then held it once).
    async fn until_every_drive_got(&self, command: &str) {
        let since = self.marks.last().map_or(0, |(_, at)| *at);
        let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
        loop {
            let lines = self.lines();
            let missing: Vec<char> = ADDRESSES
                .chars()
                .filter(|address| {
                    !lines[since.min(lines.len())..]
                        .iter()
                        .any(|line| *line == format!("{address}{command}"))
                })
                .collect();
            if missing.is_empty() {
                return;
            }
            assert!(
                tokio::time::Instant::now() < deadline,
                "drives {missing:?} got no {command} within 5 s"
            );
            tokio::time::sleep(Duration::from_millis(10)).await;
        }
    }

    /// Every line received, in order.
    fn lines(&self) -> Vec<String> {
        self.peer
            .received
            .lock()
            .unwrap()
            .iter()
            .map(|line| line.text.clone())
            .collect()
    }

    /// The lines of `action`.
    fn section(&self, lines: &[String], action: &str) -> Vec<String> {
        let index = self
            .marks
            .iter()
            .position(|(name, _)| *name == action)
            .expect("a marked action");
        let from = self.marks[index].1;
        let to = self.marks.get(index + 1).map_or(lines.len(), |(_, at)| *at);
        lines[from..to].to_vec()
    }

    /// The golden text: per action, per drive, every line but the queries.
    fn golden(&self, lines: &[String], title: &str) -> String {
        let mut out = format!(
            "# {title}\n\
             # Every line the bridge wrote to each drive (RS-485, addresses {ADDRESSES}), in order,\n\
             # per operator action, without its CR.\n\
             # Left out: the queries {} (status polls, waits for positions and for the end).\n\
             # Regenerate: FLOATBALL_BLESS=1 cargo test -p floatball-bridge --test integration -- \
             scl_golden::\n",
            QUERIES.join(" ")
        );
        for (action, _) in &self.marks {
            out.push_str(&format!("\n== {action} ==\n"));
            let section = self.section(lines, action);
            for address in ADDRESSES.chars() {
                out.push_str(&format!("-- drive {address} --\n"));
                let mine: Vec<&String> = section
                    .iter()
                    .filter(|line| line.starts_with(address) && !is_query(line))
                    .collect();
                if mine.is_empty() {
                    out.push_str("(nothing)\n");
                }
                for line in mine {
                    out.push_str(&line.escape_debug().to_string());
                    out.push('\n');
                }
            }
        }
        out
    }
}

/// Starts the playlist and reads statuses until it has played to its end.
async fn play_to_end(ws: &mut Ws) {
    send_text(ws, r#"{"type":"start"}"#).await;
    let (states, _) = until(ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
}

/// Checks that the first line other than a query in `section` is `SK`, to every
/// drive back to back; returns what follows the stops.
///
/// (Queries may come first: the test marks the section before the press reaches the
/// bridge, and the polls go on meanwhile. How soon the stop follows the press is
/// `scl_bench`'s to measure.)
fn stops_first(section: &[String], what: &str) -> Vec<String> {
    let stops: Vec<String> = ADDRESSES.chars().map(|a| format!("{a}SK")).collect();
    let first = section
        .iter()
        .position(|line| !is_query(line))
        .unwrap_or_else(|| panic!("{what}: no SK in {section:?}"));
    assert_eq!(
        section.get(first..first + stops.len()),
        Some(&stops[..]),
        "{what}: not SK to every drive first: {section:?}"
    );
    section[first + stops.len()..].to_vec()
}

/// The scenario on a fresh bridge, with `scl` in its `[scl]` section; returns the
/// golden text.
async fn scenario(scl: &str, title: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let peer = Peer::serial(dir.path(), "rs485", ADDRESSES, 0, !scl.is_empty());
    let bridge = Process::start(&config(&peer, scl));
    let mut marks = Marks {
        peer,
        marks: Vec::new(),
    };
    marks.mark("bridge start-up (before any action)");
    let token = bridge.prepare_show("drop", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());

    marks.mark("Start (the first)");
    play_to_end(&mut ws).await;
    let ends: Vec<i64> = (0..3).map(|ball| (end_mm(ball) * 100.0) as i64).collect();
    assert_eq!(marks.peer.positions(), ends);

    marks.mark("Start (again)");
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    tokio::time::sleep(Duration::from_millis(150)).await;

    marks.mark("E-stop (while the show plays)");
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    assert!(matches!(
        next_reply(&mut ws).await,
        ServerMessage::EstopSent { .. }
    ));
    until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    marks.until_every_drive_got("SK").await;
    // Some polls while stopped.
    tokio::time::sleep(Duration::from_millis(200)).await;

    marks.mark("Home (until idle)");
    send_text(&mut ws, r#"{"type":"home"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Idle
    })
    .await;
    assert_eq!(marks.peer.positions(), [0, 0, 0]);

    // Homed: the positions are known, Start goes straight to the approach.
    marks.mark("Start after Home (played to the end)");
    play_to_end(&mut ws).await;
    assert_eq!(marks.peer.positions(), ends);

    marks.mark("Start and E-stop again");
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    tokio::time::sleep(Duration::from_millis(150)).await;
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    marks.until_every_drive_got("SK").await;

    // After an e-stop the positions are unknown: Start homes first.
    marks.mark("Start after the e-stop (homes first, played to the end)");
    play_to_end(&mut ws).await;
    assert_eq!(marks.peer.positions(), ends);
    // The last polls come in.
    tokio::time::sleep(Duration::from_millis(100)).await;

    let lines = marks.lines();
    for line in &lines {
        assert!(
            line.starts_with(|c| ADDRESSES.contains(c)),
            "a line to no drive: {line:?}"
        );
    }
    let after = stops_first(
        &marks.section(&lines, "E-stop (while the show plays)"),
        "the e-stop",
    );
    assert!(
        after.iter().all(|line| is_query(line)),
        "more than queries after the e-stop, before Home: {after:?}"
    );
    stops_first(&marks.section(&lines, "Home (until idle)"), "Home");
    marks.golden(&lines, title)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_wire_of_start_estop_home_start_without_a_trigger() {
    let golden = scenario(
        "",
        "MOONS' drives, no trigger: QE (queue) or QX1 (stored) starts every drive",
    )
    .await;
    assert_golden("scl_qx1.txt", &golden);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_wire_of_start_estop_home_start_with_a_trigger() {
    let golden = scenario(
        "trigger = \"1:2\"",
        "MOONS' drives, trigger = \"1:2\": drive 1's output 2 starts every drive",
    )
    .await;
    assert_golden("scl_trigger.txt", &golden);
}
