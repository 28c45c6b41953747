//! The real `floatball` binary driving MBOX boxes on loopback UDP: `floatball simulate
//! --kind mbox` processes (whose final state is printed when they stop, and whose
//! registers the test reads over UDP), and `port = "sim"` boxes in the bridge.

mod common;

use std::io::{BufRead, BufReader, Read};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use common::process::{Process, links_up};
use common::{Ws, send_text};
use floatball_shared::api::{PlayerState, ServerMessage, SimBox, SimPositions, Status};
use floatball_shared::mbox::register::FN_ESTOP;
use floatball_shared::mbox::{
    Datagram, Encode, ReadBank, RegisterRange, RegisterRead, Route, WriteBank,
};
use futures_util::StreamExt;

const PULSES_PER_MM: f64 = 10.0;
const OFFSET_PULSES: i32 = 1_000;

/// `floatball simulate --kind mbox` boxes; killed when dropped.
struct Simulator {
    child: Child,
    stdout: BufReader<ChildStdout>,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Simulator {
    /// `boxes` 3-axis boxes on free ports, losing `drop_percent` of datagrams.
    fn start(boxes: usize, drop_percent: u8) -> (Self, Vec<SocketAddr>) {
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--kind", "mbox", "--listen", "127.0.0.1:0"])
            .args(["--axes", "3", "--boxes", &boxes.to_string()])
            .args(["--drop-percent", &drop_percent.to_string(), "--seed", "7"])
            .stdout(Stdio::piped())
            .spawn()
            .expect("start floatball simulate --kind mbox");
        let mut stdout = BufReader::new(child.stdout.take().unwrap());
        let sockets = (0..boxes)
            .map(|_| {
                let mut line = String::new();
                stdout.read_line(&mut line).expect("a banner line a box");
                line.split_whitespace().last().unwrap().parse().unwrap()
            })
            .collect();
        (Self { child, stdout }, sockets)
    }

    /// Stops the boxes (SIGTERM); returns each one's final state.
    fn stop(mut self) -> Vec<SimBox> {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let mut rest = String::new();
        self.stdout.read_to_string(&mut rest).unwrap();
        assert!(self.child.wait().unwrap().success());
        rest.lines()
            .map(|line| serde_json::from_str(line).unwrap())
            .collect()
    }
}

/// The e-stop register of the box at `to`, read over UDP (retried: the box may lose
/// datagrams).
fn estop_register(to: SocketAddr) -> u16 {
    let host = UdpSocket::bind("127.0.0.1:0").unwrap();
    host.set_read_timeout(Some(Duration::from_millis(200)))
        .unwrap();
    let read = RegisterRead {
        bank: ReadBank::Fn,
        route: Route::BROADCAST,
        range: RegisterRange::new(FN_ESTOP, 1).unwrap(),
    }
    .encode();
    let mut buffer = [0u8; 512];
    for _ in 0..20 {
        host.send_to(&read, to).unwrap();
        if let Ok((len, _)) = host.recv_from(&mut buffer)
            && let Ok(Datagram::ReadReply(reply)) = Datagram::decode(&buffer[..len])
        {
            return reply.block.get(FN_ESTOP).unwrap();
        }
    }
    panic!("the box at {to} does not answer");
}

/// A 2 × 3 show: ball `u` goes smoothly from 0 to `20 + 10·u` mm in 2 s and rests
/// there for 0.4 s.
fn show() -> Vec<u8> {
    let units: Vec<serde_json::Value> = (0..6)
        .map(|unit| {
            let depth = 20.0 + 10.0 * f64::from(unit);
            let mut rows: Vec<serde_json::Value> = (1..=20)
                .map(|step| {
                    let phase = std::f64::consts::PI * f64::from(step) / 20.0;
                    let position = depth * (1.0 - phase.cos()) / 2.0;
                    let velocity = depth * std::f64::consts::PI / 4.0 * phase.sin();
                    serde_json::json!([position, velocity, 100])
                })
                .collect();
            rows.push(serde_json::json!([depth, 0.0, 200]));
            rows.push(serde_json::json!([depth, 0.0, 200]));
            serde_json::json!({ "start_mm": 0.0, "rows": rows })
        })
        .collect();
    common::native_show("ramp", 2, 3, units)
}

fn last_pulses() -> Vec<i32> {
    (0..6)
        .map(|unit| {
            let depth = 20.0 + 10.0 * f64::from(unit);
            OFFSET_PULSES - (depth * PULSES_PER_MM).round() as i32
        })
        .collect()
}

fn config(gateways: &[String]) -> String {
    let mut text = String::from(
        "[matrix]\nrows = 2\ncols = 3\ntravel_mm = 500.0\n\
         [safety]\napproach_speed_mm_s = 1000.0\n\
         [mbox]\nhost_port = 0\nframe_period_ms = 20\n",
    );
    for gateway in gateways {
        text.push_str(&format!(
            "[[gateway]]\nkind = \"mbox\"\n{gateway}\naxes = 3\npulses_per_mm = {PULSES_PER_MM}\n\
             sign = -1\noffset_pulses = {OFFSET_PULSES}\n"
        ));
    }
    text
}

/// Reads statuses until `wanted` holds, within `limit`; returns every state seen
/// on the way and the matching status.
async fn until(
    ws: &mut Ws,
    limit: Duration,
    wanted: impl Fn(&Status) -> bool,
) -> (Vec<PlayerState>, Status) {
    let deadline = tokio::time::Instant::now() + limit;
    let mut states = Vec::new();
    loop {
        let frame = tokio::time::timeout_at(deadline, ws.next())
            .await
            .unwrap_or_else(|_| panic!("no such status within {limit:?}; seen {states:?}"))
            .expect("open")
            .expect("frame");
        let tokio_tungstenite::tungstenite::Message::Text(text) = frame else {
            continue;
        };
        match serde_json::from_str(text.as_str()) {
            Ok(ServerMessage::Status(status)) => {
                if states.last() != Some(&status.state) {
                    states.push(status.state);
                }
                if wanted(&status) {
                    return (states, status);
                }
            }
            Ok(ServerMessage::Error { message }) => panic!("error: {message}"),
            _ => {}
        }
    }
}

async fn operator_ws(bridge: &Process) -> (Ws, String) {
    let token = bridge.prepare_show("ramp", &show(), false).await;
    let mut ws = bridge.ws(&token).await;
    assert!(links_up(&mut ws).await, "{}", bridge.log());
    (ws, token)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn mbox_boxes_play_stop_and_reset_like_a_matrix() {
    let (simulator, sockets) = Simulator::start(2, 0);
    let gateways: Vec<String> = sockets
        .iter()
        .map(|socket| format!("address = \"{socket}\""))
        .collect();
    let bridge = Process::start(&config(&gateways));
    let (mut ws, _token) = operator_ws(&bridge).await;

    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (states, _) = until(&mut ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    let played: Vec<PlayerState> = states
        .into_iter()
        .filter(|state| *state != PlayerState::Idle)
        .collect();
    assert_eq!(
        played,
        [
            PlayerState::Homing,
            PlayerState::Approaching,
            PlayerState::Playing
        ]
    );

    // Again, and an e-stop while it plays: every box's e-stop register reads 1.
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing && status.show_time_ms > 500
    })
    .await;
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let (_, stopped) = until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    assert!(
        stopped
            .gateways
            .iter()
            .all(|gateway| gateway.port.contains("127.0.0.1"))
    );
    for &socket in &sockets {
        assert_eq!(estop_register(socket), 1, "box at {socket}");
    }

    // Reset: released, homed, and the playlist played to its end.
    send_text(&mut ws, r#"{"type":"reset"}"#).await;
    let (states, idle) = until(&mut ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    assert!(states.contains(&PlayerState::Homing), "{states:?}");
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    for &socket in &sockets {
        assert_eq!(estop_register(socket), 0, "box at {socket}");
    }
    for gateway in &idle.gateways {
        assert!(gateway.packets_per_s.is_some() && gateway.late_frames.is_some());
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let boxes = simulator.stop();
    let reached: Vec<i32> = boxes
        .iter()
        .flat_map(|one| one.positions_pulses.clone())
        .collect();
    assert_eq!(reached, last_pulses());
    // Released; and no motion frame reached a box while its e-stop held.
    assert!(
        boxes
            .iter()
            .all(|one| !one.estop && one.counters.ignored_estop == 0)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lossy_network_still_ends_at_the_last_positions_and_counts_missed_replies() {
    let (simulator, sockets) = Simulator::start(2, 5);
    let gateways: Vec<String> = sockets
        .iter()
        .map(|socket| format!("address = \"{socket}\""))
        .collect();
    let bridge = Process::start(&config(&gateways));
    let (mut ws, _token) = operator_ws(&bridge).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (states, idle) = until(&mut ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    // Polls go on every 500 ms: wait for a few more, some of which are lost.
    let (_, later) = until(&mut ws, Duration::from_secs(30), |status| {
        status
            .gateways
            .iter()
            .map(|gateway| gateway.missed_replies.unwrap_or(0))
            .sum::<u64>()
            > 0
    })
    .await;
    println!("missed replies: {:?}", later.gateways);
    drop(idle);
    let boxes = simulator.stop();
    let reached: Vec<i32> = boxes
        .iter()
        .flat_map(|one| one.positions_pulses.clone())
        .collect();
    assert_eq!(reached, last_pulses());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn simulated_boxes_in_the_bridge_play_the_show() {
    let bridge = Process::start(&config(&[
        "port = \"sim\"".to_owned(),
        "port = \"sim\"".to_owned(),
    ]));
    let (mut ws, token) = operator_ws(&bridge).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    let (states, _) = until(&mut ws, Duration::from_secs(20), |status| {
        status.state == PlayerState::Idle && status.progress >= 1.0
    })
    .await;
    assert!(states.contains(&PlayerState::Playing), "{states:?}");
    tokio::time::sleep(Duration::from_millis(200)).await;
    let reply = bridge
        .request(
            axum::http::Method::GET,
            "/api/sim/positions",
            Some(&token),
            None,
        )
        .await;
    let positions: SimPositions = reply.json();
    assert!(positions.gateways.is_empty());
    let reached: Vec<i32> = positions
        .boxes
        .iter()
        .flat_map(|one| one.positions_pulses.clone())
        .collect();
    assert_eq!(reached, last_pulses());
}

/// WebSocket `estop` → the first e-stop datagram at a box: printed, not asserted (the
/// goal is ≤ 2 ms; a loaded test machine may be slower).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn estop_latency_is_measured() {
    let box_socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    box_socket
        .set_read_timeout(Some(Duration::from_secs(2)))
        .unwrap();
    let address = box_socket.local_addr().unwrap();
    let bridge = Process::start(&config(&[
        format!("address = \"{address}\""),
        "port = \"sim\"".to_owned(),
    ]));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    let mut figures = Vec::new();
    let mut buffer = [0u8; 512];
    for _ in 0..20 {
        // Let the repeats of the last e-stop pass, and drain what came.
        tokio::time::sleep(Duration::from_millis(60)).await;
        box_socket.set_nonblocking(true).unwrap();
        while box_socket.recv_from(&mut buffer).is_ok() {}
        box_socket.set_nonblocking(false).unwrap();
        let sent = Instant::now();
        send_text(&mut ws, r#"{"type":"estop"}"#).await;
        loop {
            let (len, _) = box_socket.recv_from(&mut buffer).expect("the e-stop");
            if let Ok(Datagram::Write(write)) = Datagram::decode(&buffer[..len])
                && write.bank == WriteBank::FnVolatile
                && write.block.get(FN_ESTOP) == Some(1)
            {
                figures.push(sent.elapsed());
                break;
            }
        }
    }
    figures.sort();
    println!(
        "e-stop latency, WebSocket message to the first datagram at the box, 20 presses: \
         median {:?}, max {:?}",
        figures[figures.len() / 2],
        figures[figures.len() - 1]
    );
}
