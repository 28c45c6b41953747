//! MOONS' drives through the real `floatball` binary: an RS-485 line of three drives
//! on a pseudo-terminal and three eSCL drives on loopback UDP, played by the drive
//! twin (`common::scl_peer`): console lines and their decoded answers, the status
//! polls, the e-stop (`SK` to every drive before anything else), Start playing a show
//! from uploaded Q programs to its end, and a drive that refuses `QL`.

use crate::common;

use std::time::{Duration, Instant};

use common::process::{Process, links_up};
use common::scl_peer::{Peer, Simulator, config, drop_end_mm, drop_show, serial_config};
use common::{Ws, next_reply, send_text, until};
use floatball_shared::api::{PlayerState, ServerMessage, Status};
use floatball_shared::scl::{IoPoint, Level, Segment};

fn end_mm(ball: usize) -> f64 {
    drop_end_mm(ball)
}

fn show() -> Vec<u8> {
    drop_show(|_| 0.0)
}

fn udp_config(peer: &Peer, scl: &str) -> String {
    let list: Vec<String> = peer.sockets.iter().map(|s| format!("\"{s}\"")).collect();
    config(&format!("escl = [{}]", list.join(", ")), scl)
}

async fn operator(bridge: &Process) -> Ws {
    let token = bridge.prepare_show("drop", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    ws
}

/// Presses the e-stop while the drives are polled, and returns what reached them
/// from just before the press.
/// The last status seen while waiting for the e-stop's answer comes with them (the
/// status that shows the stop may come before the answer: see [`stopped`]).
async fn press(ws: &mut Ws, peer: &Peer) -> (Vec<common::scl_peer::Received>, Option<Status>) {
    tokio::time::sleep(Duration::from_millis(150)).await;
    let pressed = Instant::now();
    send_text(ws, r#"{"type":"estop"}"#).await;
    let mut seen = None;
    loop {
        match common::next_message(ws).await {
            ServerMessage::Status(status) => seen = Some(status),
            ServerMessage::EstopSent { .. } => break,
            other => panic!("expected the e-stop's answer, got {other:?}"),
        }
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    (peer.since(pressed), seen)
}

/// The status that shows the matrix stopped after [`press`]: the last one it saw, if
/// that shows it (a stopped matrix's status may not change again for a while), or
/// the next that does.
async fn stopped(ws: &mut Ws, seen: Option<Status>) -> Status {
    match seen {
        Some(status) if status.state == PlayerState::Stopped => status,
        _ => {
            until(ws, Duration::from_secs(5), |status| {
                status.state == PlayerState::Stopped
            })
            .await
            .1
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_rs485_line_answers_the_console_and_stops_every_drive_first() {
    let dir = tempfile::tempdir().unwrap();
    let peer = Peer::serial(dir.path(), "rs485", "123", 0, false);
    let bridge = Process::start(&serial_config(&peer, ""));
    let mut ws = operator(&bridge).await;
    send_text(&mut ws, r#"{"type":"raw","line":"2SP1200"}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    // A buffered command: the drive answers `*`.
    assert_eq!((reply.text.as_str(), reply.raw.as_str()), ("buffered", "*"));

    // The polls put every drive's position and codes in the status.
    let (_, status) = until(&mut ws, Duration::from_secs(5), |status| {
        status.gateways[0].drives.len() == 3
            && status.gateways[0].drives[1].position_counts == Some(1200)
            && status.gateways[0].drives[2].alarm_code == Some(0)
    })
    .await;
    assert_eq!(status.gateways[0].drives[0].address, "1");

    send_text(&mut ws, r#"{"type":"raw","line":"2IP","gateway":0}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    assert_eq!(
        (
            reply.drive.as_str(),
            reply.request.as_str(),
            reply.text.as_str()
        ),
        ("2", "2IP", "IP = 1200")
    );
    assert_eq!(reply.raw, "IP=1200");
    send_text(&mut ws, r#"{"type":"raw","line":"3DI5000\n3FP"}"#).await;
    for _ in 0..2 {
        let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
            panic!("an scl_reply");
        };
        assert!(
            ["executed", "buffered"].contains(&reply.text.as_str()),
            "{reply:?}"
        );
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(peer.positions()[2], 5000);
    // A refusal names its line and column; nothing is sent.
    send_text(&mut ws, r#"{"type":"raw","line":"2IP\n2XX"}"#).await;
    let ServerMessage::Error { message, .. } = next_reply(&mut ws).await else {
        panic!("an error");
    };
    assert!(message.contains("line 2, column 2"), "{message}");
    send_text(&mut ws, r#"{"type":"raw","line":"IP"}"#).await;
    let ServerMessage::Error { message, .. } = next_reply(&mut ws).await else {
        panic!("an error");
    };
    assert!(
        message.contains("put the drive's address first"),
        "{message}"
    );

    // The e-stop: SK to every drive, back to back, before any other request.
    let (lines, _) = press(&mut ws, &peer).await;
    let texts: Vec<&str> = lines.iter().map(|line| line.text.as_str()).collect();
    let first = texts
        .iter()
        .position(|text| text.ends_with("SK"))
        .expect("a stop");
    assert_eq!(&texts[first..first + 3], ["1SK", "2SK", "3SK"], "{texts:?}");
    // While latched, a move is refused at the console; a query still goes.
    send_text(&mut ws, r#"{"type":"raw","line":"1FP"}"#).await;
    let ServerMessage::Error { message, .. } = next_reply(&mut ws).await else {
        panic!("an error");
    };
    assert!(message.contains("latched"), "{message}");
    send_text(&mut ws, r#"{"type":"raw","line":"1SC"}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    assert!(reply.text.starts_with("SC = "), "{reply:?}");
}

/// Starts the playlist and reads statuses until it has played to its end.
async fn play_to_end(ws: &mut Ws) -> Vec<PlayerState> {
    send_text(ws, r#"{"type":"start"}"#).await;
    let (states, _) = until(ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    states
}

fn assert_played(states: &[PlayerState], peer: &Peer) {
    // (Approaching and Loading take a few ms here: the status may not show them.)
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    // 100 counts/mm: where the show ends.
    let ends: Vec<i64> = (0..3).map(|ball| (end_mm(ball) * 100.0) as i64).collect();
    assert_eq!(peer.positions(), ends);
    for ball in 0..3 {
        assert!(peer.with_drive(ball, |drive| {
            drive.segment(Segment::new(1).unwrap()).is_some() || !drive.queue().is_empty()
        }));
    }
}

/// The first line of drive `ball`'s program: stored in segment 1, or (a program of
/// one segment, never stored) in the queue.
fn first_line(peer: &Peer, ball: usize) -> String {
    peer.with_drive(ball, |drive| {
        drive
            .segment(Segment::new(1).unwrap())
            .unwrap_or(drive.queue())[0]
            .to_string()
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn start_uploads_programs_fires_the_trigger_and_plays_to_the_end() {
    let dir = tempfile::tempdir().unwrap();
    let peer = Peer::serial(dir.path(), "rs485", "123", 0, true);
    let bridge = Process::start(&serial_config(&peer, "trigger = \"1:2\""));
    let mut ws = operator(&bridge).await;
    let states = play_to_end(&mut ws).await;
    assert_played(&states, &peer);
    // The other programs wait for the start input (3, falling edge); the trigger
    // drive's ball fires it from its own line 1, started last, after the bridge set
    // the wire high while no program ran on it.
    assert_eq!(first_line(&peer, 0), "SO2L");
    assert_eq!(first_line(&peer, 1), "WI3F");
    let output = IoPoint::new(2).unwrap();
    assert_eq!(peer.with_drive(0, |drive| drive.output(output)), Level::Low);
    let wire: Vec<String> = peer
        .received
        .lock()
        .unwrap()
        .iter()
        .map(|line| line.text.clone())
        .collect();
    let high = wire.iter().position(|line| line == "1SO2H").expect("high");
    let line_1 = wire
        .iter()
        .position(|line| line == "1SO2L")
        .expect("line 1");
    let last_start = wire
        .iter()
        .rposition(|line| line == "1QE" || line == "1QX1");
    assert!(high < line_1 && line_1 < last_start.expect("started"));
    for other in ["2QE", "2QX1", "3QE", "3QX1"] {
        if let Some(at) = wire.iter().position(|line| line == other) {
            assert!(at < last_start.unwrap(), "{other} after drive 1's start");
        }
    }

    // Again, and the e-stop during the program: SK to every drive, back to back.
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    let (lines, seen) = press(&mut ws, &peer).await;
    let texts: Vec<&str> = lines.iter().map(|line| line.text.as_str()).collect();
    let first = texts
        .iter()
        .position(|text| text.ends_with("SK"))
        .expect("a stop");
    assert_eq!(&texts[first..first + 3], ["1SK", "2SK", "3SK"], "{texts:?}");
    let stopped = stopped(&mut ws, seen).await;
    assert_eq!(stopped.last_error, None);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn escl_drives_play_to_the_end_and_each_gets_the_stop() {
    let peer = Peer::udp(3);
    let bridge = Process::start(&udp_config(&peer, ""));
    let mut ws = operator(&bridge).await;
    let states = play_to_end(&mut ws).await;
    assert_played(&states, &peer);
    // No trigger: QX1 to every drive, and no WI in the program.
    assert_ne!(first_line(&peer, 0), "WI3F");

    // eSCL drives take the address characters in listed order: "0" is the first.
    send_text(&mut ws, r#"{"type":"raw","line":"1IP","gateway":0}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    assert_eq!(reply.text, "IP = 1000");
    assert_eq!(reply.drive, peer.sockets[1].to_string());
    // The twin refuses what the Host Command Reference refuses, through the console
    // (whose parser already refuses `QW`, no MOONS' command): `CS` while not jogging
    // cannot be carried out (`?7`, HCR p. 71, 304), a 63rd line of the queue is full
    // (`?6`), and an immediate command while `QL` loads is carried out, not stored.
    for (line, text) in [
        ("1CS1", "refused (code 7)"),
        ("1QL", "executed"),
        ("1IP", "IP = 1000"),
    ] {
        let message = format!(r#"{{"type":"raw","line":"{line}","gateway":0}}"#);
        send_text(&mut ws, &message).await;
        let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
            panic!("an scl_reply");
        };
        assert_eq!(reply.text, text, "{line}");
    }
    for _ in 0..62 {
        send_text(&mut ws, r#"{"type":"raw","line":"1WT0.01","gateway":0}"#).await;
        let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
            panic!("an scl_reply");
        };
        assert_eq!(reply.text, "buffered");
    }
    send_text(&mut ws, r#"{"type":"raw","line":"1WT0.01","gateway":0}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    assert_eq!(reply.text, "refused (code 6)");
    assert!(peer.with_drive(1, |drive| drive.queue().len() == 62 && drive.is_loading()));
    // `SK` ends the load (the e-stop below presses it anyway).
    send_text(&mut ws, r#"{"type":"raw","line":"1SK","gateway":0}"#).await;
    let _ = next_reply(&mut ws).await;

    let (lines, seen) = press(&mut ws, &peer).await;
    for drive in 0..3 {
        let stops = lines
            .iter()
            .filter(|line| line.drive == Some(drive) && line.text == "SK")
            .count();
        // The stop and its three repeats.
        assert_eq!(stops, 4, "drive {drive}: {lines:?}");
    }
    let stopped = stopped(&mut ws, seen).await;
    assert_eq!(stopped.gateways[0].drives.len(), 3);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_drive_that_refuses_ql_is_named_with_what_to_do() {
    let peer = Peer::udp(3);
    peer.refuse_ql.lock().unwrap().push(1);
    let bridge = Process::start(&udp_config(&peer, ""));
    let mut ws = operator(&bridge).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (_, failed) = until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Error
    })
    .await;
    let error = failed.last_error.unwrap_or_default();
    assert!(error.contains("refused QL"), "{error}");
    assert!(error.contains("Q Programmer"), "{error}");
    assert!(error.contains("programs = \"stored\""), "{error}");
}

/// The polled positions of every drive, in unit order.
fn polled(status: &floatball_shared::api::Status) -> Vec<Option<i64>> {
    status.gateways[0]
        .drives
        .iter()
        .map(|drive| drive.position_counts)
        .collect()
}

/// Plays the show on drives the real simulator runs, and reads their positions from
/// the bridge's status.
async fn play_on_simulated_drives(ws: &mut Ws) {
    let ends: Vec<Option<i64>> = (0..3)
        .map(|ball| Some((end_mm(ball) * 100.0) as i64))
        .collect();
    send_text(ws, r#"{"type":"start"}"#).await;
    let (states, _) = until(ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0 && polled(status) == ends
    })
    .await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_simulator_on_a_line_plays_the_show_and_takes_the_stop_first() {
    let dir = tempfile::tempdir().unwrap();
    let wire = std::sync::Arc::new(std::sync::Mutex::new(Vec::new()));
    let _drives = Simulator::serial(
        dir.path(),
        "rs485",
        3,
        115_200,
        std::sync::Arc::clone(&wire),
    );
    let path = dir.path().join("rs485");
    let bridge = Process::start(&config(
        &format!("port = \"{}\"\nbaud = 115200", path.display()),
        "trigger = \"0:2\"",
    ));
    let mut ws = operator(&bridge).await;
    play_on_simulated_drives(&mut ws).await;

    // Again, and the e-stop while the programs run.
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    tokio::time::sleep(Duration::from_millis(100)).await;
    let pressed = Instant::now();
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let (_, stopped) = until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    assert_eq!(stopped.last_error, None);
    // The status may say stopped before the simulated drives' reader has taken the
    // stops off the line (on a loaded machine): the wire is read until it holds
    // three since the press, at most 5 s.
    let since_pressed = || -> Vec<String> {
        wire.lock()
            .unwrap()
            .iter()
            .filter(|line| line.at >= pressed)
            .map(|line| line.text.clone())
            .collect()
    };
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut lines = since_pressed();
    while lines.iter().filter(|line| line.ends_with("SK")).count() < 3 && Instant::now() < deadline
    {
        tokio::time::sleep(Duration::from_millis(20)).await;
        lines = since_pressed();
    }
    let first = lines
        .iter()
        .position(|line| line.ends_with("SK"))
        .unwrap_or_else(|| panic!("a stop: {lines:?}"));
    assert_eq!(&lines[first..first + 3], ["0SK", "1SK", "2SK"], "{lines:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_simulator_over_escl_plays_the_show_and_stops() {
    let drives = Simulator::udp(3);
    let list: Vec<String> = drives.sockets.iter().map(|s| format!("\"{s}\"")).collect();
    let bridge = Process::start(&config(&format!("escl = [{}]", list.join(", ")), ""));
    let mut ws = operator(&bridge).await;
    play_on_simulated_drives(&mut ws).await;
    send_text(&mut ws, r#"{"type":"raw","line":"2IP"}"#).await;
    let ServerMessage::SclReply(reply) = next_reply(&mut ws).await else {
        panic!("an scl_reply");
    };
    assert_eq!(reply.text, "IP = 1500");
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    // Home: every drive back to the top (0 mm), then idle.
    send_text(&mut ws, r#"{"type":"home"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Idle && polled(status) == [Some(0); 3]
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stored_programs_are_started_without_an_upload() {
    use floatball_bridge::config::{Config, Overrides};
    let peer = Peer::udp(3);
    let text = udp_config(&peer, "programs = \"stored\"");
    // The programs an installer loaded with Q Programmer: the app's downloads.
    let config = Config::parse(
        std::path::Path::new("floatball.toml"),
        &text,
        &Overrides::default(),
    )
    .expect("valid");
    let scl = config.scl().expect("scl");
    let compiler =
        floatball_bridge::ports::scl::program::qprogram_config(&config.installation, scl);
    let show = floatball_shared::show::Show::from_json(std::str::from_utf8(&show()).unwrap())
        .expect("show");
    for (ball, track) in show.tracks.iter().enumerate() {
        let program = floatball_shared::scl::qprogram::compile(track, &compiler).expect("fits");
        peer.with_drive(ball, |drive| {
            // As Q Programmer stores them: `QL`, the lines, `QS n` (HCR p. 216, 218).
            for (segment, lines) in &program.segments {
                drive.receive_line("QL", 0);
                for line in lines {
                    drive.receive_line(&line.to_string(), 0);
                }
                drive.receive_line(&format!("QS{segment}"), 0);
            }
        });
    }
    let bridge = Process::start(&text);
    let mut ws = operator(&bridge).await;
    let started = Instant::now();
    let states = play_to_end(&mut ws).await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    let ends: Vec<i64> = (0..3).map(|ball| (end_mm(ball) * 100.0) as i64).collect();
    assert_eq!(peer.positions(), ends);
    let sent = peer.since(started);
    assert!(
        sent.iter()
            .all(|line| !line.text.starts_with("QL") && !line.text.starts_with("QS")),
        "{sent:?}"
    );
    assert!(sent.iter().any(|line| line.text == "QX1"), "{sent:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn streamed_drives_on_a_line_start_on_one_ct_without_an_address() {
    // `programs = "stream"` on an RS-485 line: every drive paused and primed (`PS`,
    // its first lines), then one `CT` without an address continues them all at once
    // (HCR p. 72, 305); nothing is loaded into a queue or memory.
    let dir = tempfile::tempdir().unwrap();
    let peer = Peer::serial(dir.path(), "rs485", "123", 0, true);
    let bridge = Process::start(&serial_config(&peer, "programs = \"stream\""));
    let mut ws = operator(&bridge).await;
    let started = Instant::now();
    let states = play_to_end(&mut ws).await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    let ends: Vec<i64> = (0..3).map(|ball| (end_mm(ball) * 100.0) as i64).collect();
    assert_eq!(peer.positions(), ends);
    let sent: Vec<String> = peer
        .since(started)
        .into_iter()
        .map(|line| line.text)
        .collect();
    assert_eq!(
        sent.iter().filter(|line| *line == "CT").count(),
        1,
        "{sent:?}"
    );
    for address in ["1", "2", "3"] {
        assert!(sent.contains(&format!("{address}PS")), "{sent:?}");
        assert!(!sent.contains(&format!("{address}CT")), "{sent:?}");
        assert!(
            !sent
                .iter()
                .any(|line| line.starts_with(&format!("{address}Q"))),
            "{sent:?}"
        );
    }
    let ct = sent.iter().position(|line| line == "CT").unwrap();
    let last_ps = sent.iter().rposition(|line| line.ends_with("PS")).unwrap();
    assert!(last_ps < ct);
}
