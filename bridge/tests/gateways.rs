//! The WebSocket against gateways on pseudo-terminal pairs: the exact bytes a console
//! line puts on the line, feedback bytes in odd chunks with garbage arriving as
//! `feedback` messages, the e-stop on every gateway, and link states in the status.
//! The test's gateways answer the bridge's greeting (`ABC;` → `AA AB AC`, without which
//! a link is not up) and keep the greetings out of the bytes the tests compare.

use crate::common;

use std::io::{Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use common::{Bridge, Ws, next_message, send_text};
use floatball_shared::api::{FeedbackFrame, LinkState, ServerMessage};
use floatball_shared::uim2503::feedback::Frame;
use serialport::{SerialPort, TTYPort};
use tokio::sync::mpsc;

/// A gateway played by the test on the master side of a pty pair. The bridge opens
/// the slave through a symlink (as udev's /dev/serial/by-id names are), so a test can
/// take the device away without another test's pty taking its number. What the bridge
/// writes is read from the start ([`spawn_reader`]); dropping it closes the master.
struct Gateway {
    master: TTYPort,
    path: std::path::PathBuf,
    rx: mpsc::UnboundedReceiver<Vec<u8>>,
    stop: Arc<AtomicBool>,
}

impl Drop for Gateway {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        // The reader lets go of its handle within one read timeout.
        std::thread::sleep(Duration::from_millis(60));
    }
}

fn pty(dir: &std::path::Path, name: &str) -> Gateway {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let slave_path = slave.name().expect("slave name");
    drop(slave);
    master
        .set_timeout(Duration::from_millis(20))
        .expect("timeout");
    let path = dir.join(name);
    std::os::unix::fs::symlink(slave_path, &path).expect("symlink");
    let stop = Arc::new(AtomicBool::new(false));
    let reader = master.try_clone_native().expect("clone the master");
    let rx = spawn_reader(reader, Arc::clone(&stop));
    Gateway {
        master,
        path,
        rx,
        stop,
    }
}

/// Reads everything the bridge writes to a gateway, in a thread, until `stop`. Answers
/// each whole `ABC;` (the greeting) with `AA AB AC` and leaves it out; hands on the
/// rest in whole instructions.
fn spawn_reader(mut master: TTYPort, stop: Arc<AtomicBool>) -> mpsc::UnboundedReceiver<Vec<u8>> {
    let (tx, rx) = mpsc::unbounded_channel();
    std::thread::spawn(move || {
        let mut buffer = [0u8; 512];
        let mut partial = Vec::new();
        while !stop.load(Ordering::Acquire) {
            match master.read(&mut buffer) {
                Ok(0) => {}
                Ok(n) => {
                    partial.extend_from_slice(&buffer[..n]);
                    let whole = partial
                        .iter()
                        .rposition(|&b| b == b';')
                        .map_or(0, |i| i + 1);
                    let mut chunk = Vec::new();
                    for instruction in partial[..whole].split_inclusive(|&b| b == b';') {
                        if instruction == b"ABC;" {
                            let _ = master.write_all(&[0xAA, 0xAB, 0xAC]);
                        } else {
                            chunk.extend_from_slice(instruction);
                        }
                    }
                    partial.drain(..whole);
                    if !chunk.is_empty() && tx.send(chunk).is_err() {
                        return;
                    }
                }
                Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
    });
    rx
}

/// Collects bytes until `len` have arrived, then waits a little to catch any extra.
async fn read_exactly(rx: &mut mpsc::UnboundedReceiver<Vec<u8>>, len: usize) -> Vec<u8> {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(10);
    let mut all = Vec::new();
    while all.len() < len {
        match tokio::time::timeout_at(deadline, rx.recv()).await {
            Ok(Some(chunk)) => all.extend(chunk),
            _ => panic!("only {:?} arrived", String::from_utf8_lossy(&all)),
        }
    }
    while let Ok(Some(chunk)) = tokio::time::timeout(Duration::from_millis(200), rx.recv()).await {
        all.extend(chunk);
    }
    all
}

async fn nothing_arrives(rx: &mut mpsc::UnboundedReceiver<Vec<u8>>) {
    if let Ok(Some(chunk)) = tokio::time::timeout(Duration::from_millis(300), rx.recv()).await {
        panic!("unexpected bytes {:?}", String::from_utf8_lossy(&chunk));
    }
}

/// A bridge with a 1 × 2 matrix on two gateways, one unit each, on pty pairs; the
/// gateways' symlinks live in the returned directory.
async fn bridge_with_two_gateways() -> (Bridge, Vec<Gateway>, tempfile::TempDir) {
    let dir = tempfile::tempdir().expect("temp dir");
    let gateways = [pty(dir.path(), "gateway0"), pty(dir.path(), "gateway1")];
    let config = format!(
        "[matrix]\nrows = 1\ncols = 2\n\
         [[gateway]]\nport = \"{}\"\nbaud = 115200\nfirst_station = 5\n\
         [[gateway]]\nport = \"{}\"\nbaud = 115200\nfirst_station = 5\n",
        gateways[0].path.display(),
        gateways[1].path.display()
    );
    let bridge = Bridge::start_with(&config).await;
    (bridge, gateways.into(), dir)
}

/// Reads statuses until every gateway's link is up.
async fn wait_until_links_are_up(ws: &mut Ws) {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(Instant::now() < deadline, "the links did not come up");
        if let ServerMessage::Status(status) = next_message(ws).await
            && !status.gateways.is_empty()
            && status
                .gateways
                .iter()
                .all(|gateway| gateway.link == LinkState::Up)
        {
            return;
        }
    }
}

/// The next `feedback` message, skipping statuses.
async fn next_feedback(ws: &mut Ws) -> FeedbackFrame {
    loop {
        match next_message(ws).await {
            ServerMessage::Feedback(frame) => return frame,
            ServerMessage::Status(_) => {}
            other => panic!("expected feedback, got {other:?}"),
        }
    }
}

/// The next `error` message, skipping statuses.
async fn next_error(ws: &mut Ws) -> String {
    loop {
        match next_message(ws).await {
            ServerMessage::Error { message, .. } => return message,
            ServerMessage::Status(_) => {}
            other => panic!("expected an error, got {other:?}"),
        }
    }
}

#[tokio::test]
async fn a_console_line_puts_exactly_its_instructions_on_the_chosen_lines() {
    let (bridge, mut gateways, _links) = bridge_with_two_gateways().await;
    let mut ws = bridge.ws(&bridge.operator().await).await;
    wait_until_links_are_up(&mut ws).await;
    let mut readers: Vec<_> = gateways.iter_mut().map(|gateway| &mut gateway.rx).collect();

    send_text(
        &mut ws,
        r#"{"type":"raw","line":"*5; pv=3;  # start at row 3\nBG;","gateway":1}"#,
    )
    .await;
    assert_eq!(read_exactly(readers[1], 11).await, b"*5;PV=3;BG;");
    nothing_arrives(readers[0]).await;

    send_text(&mut ws, r#"{"type":"raw","line":"*0;MP[3]:1;QT[7]=10;"}"#).await;
    for reader in &mut readers {
        assert_eq!(read_exactly(reader, 20).await, b"*0;MP[3]=1;QT[7]=10;");
    }

    send_text(&mut ws, r#"{"type":"raw","line":"QT[7]=0;"}"#).await;
    let message = next_error(&mut ws).await;
    assert!(
        message.starts_with("the line is not valid: line 1, column "),
        "{message}"
    );
    send_text(&mut ws, r#"{"type":"raw","line":"PV;","gateway":2}"#).await;
    assert!(next_error(&mut ws).await.contains("no gateway 2"));
    for reader in &mut readers {
        nothing_arrives(reader).await;
    }
}

#[tokio::test]
async fn feedback_bytes_in_odd_chunks_with_garbage_arrive_as_feedback_messages() {
    let (bridge, mut gateways, _links) = bridge_with_two_gateways().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    wait_until_links_are_up(&mut ws).await;

    // Garbage, the manual's test vector, a stray tail, a frame cut short by a new
    // header, then a frame built by the encoder.
    let mut bytes = vec![0x00, 0x41, 0x7f];
    bytes.extend([
        0xF3, 0x05, 0x0D, 0x70, 0x71, 0x72, 0x03, 0x14, 0x15, 0x16, 0x17, 0xE7,
    ]);
    bytes.extend([0xE2, 0x13, 0xF0, 0x07]);
    let ack = Frame::new(20, 0x23, &[3, 0]).expect("frame");
    bytes.extend(ack.encode().as_bytes());
    let mut rest = &bytes[..];
    for size in [1, 4, 2, 7, 3, 1, 5].into_iter().cycle() {
        if rest.is_empty() {
            break;
        }
        let (chunk, after) = rest.split_at(size.min(rest.len()));
        gateways[1].master.write_all(chunk).expect("write");
        gateways[1].master.flush().expect("flush");
        rest = after;
        tokio::time::sleep(Duration::from_millis(7)).await;
    }

    assert_eq!(
        next_feedback(&mut ws).await,
        FeedbackFrame {
            gateway: 1,
            station: 5,
            code: 13,
            data: vec![0xF0, 0xF1, 0x72, 0x03, 0x94, 0x95, 0x96, 0x17],
        }
    );
    assert_eq!(
        next_feedback(&mut ws).await,
        FeedbackFrame {
            gateway: 1,
            station: 20,
            code: 0x23,
            data: vec![3, 0],
        }
    );

    // The other gateway's frames carry its own index.
    gateways[0]
        .master
        .write_all(Frame::new(6, 0x16, &[]).expect("frame").encode().as_bytes())
        .expect("write");
    let frame = next_feedback(&mut ws).await;
    assert_eq!((frame.gateway, frame.station, frame.code), (0, 6, 0x16));
}

#[tokio::test]
async fn estop_broadcasts_the_stop_on_every_gateway() {
    let (bridge, mut gateways, _links) = bridge_with_two_gateways().await;
    // E-stop works even before the initial password is changed.
    let mut ws = bridge.ws(&bridge.token().await).await;
    wait_until_links_are_up(&mut ws).await;
    let mut readers: Vec<_> = gateways.iter_mut().map(|gateway| &mut gateway.rx).collect();
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    for reader in &mut readers {
        assert_eq!(read_exactly(reader, 8).await, b"*0;MO=0;");
    }
    loop {
        match next_message(&mut ws).await {
            ServerMessage::EstopSent { unreached } => {
                assert!(unreached.is_empty(), "{unreached:?}");
                break;
            }
            ServerMessage::Status(_) => {}
            other => panic!("the e-stop reached every gateway; got {other:?}"),
        }
    }
    // Latched: a console line that would move is refused, a query still goes.
    let mut ws = bridge.ws(&bridge.operator().await).await;
    send_text(&mut ws, r#"{"type":"raw","line":"*5;MO=1;","gateway":0}"#).await;
    let message = next_error(&mut ws).await;
    assert!(message.contains("latched"), "{message}");
    send_text(&mut ws, r#"{"type":"raw","line":"*5;PV;","gateway":0}"#).await;
    assert_eq!(read_exactly(readers[0], 6).await, b"*5;PV;");
}

#[tokio::test]
async fn a_lost_gateway_shows_in_the_status_and_the_estop_reports_it() {
    let (bridge, mut gateways, links) = bridge_with_two_gateways().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    wait_until_links_are_up(&mut ws).await;
    std::fs::remove_file(links.path().join("gateway1")).expect("remove the device");
    drop(gateways.remove(1));
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        assert!(Instant::now() < deadline, "the loss was not reported");
        if let ServerMessage::Status(status) = next_message(&mut ws).await
            && status.gateways[1].link != LinkState::Up
        {
            assert_eq!(status.gateways[0].link, LinkState::Up);
            break;
        }
    }
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    let unreached = loop {
        match next_message(&mut ws).await {
            ServerMessage::EstopSent { unreached } => break unreached,
            ServerMessage::Status(_) => {}
            other => panic!("expected the e-stop's answer, got {other:?}"),
        }
    };
    let message = unreached.join("; ");
    assert!(message.contains("gateway 1"), "{message}");
    assert!(!message.contains("gateway 0"), "{message}");
}

#[tokio::test]
async fn the_simulated_gateway_answers_a_console_line_with_feedback() {
    let bridge = Bridge::start_with(
        "[matrix]\nrows = 1\ncols = 2\n[[gateway]]\nport = \"sim\"\nfirst_station = 7\n",
    )
    .await;
    let mut ws = bridge.ws(&bridge.operator().await).await;
    wait_until_links_are_up(&mut ws).await;
    send_text(&mut ws, r#"{"type":"raw","line":"*8;PV;"}"#).await;
    let frame = next_feedback(&mut ws).await;
    assert_eq!((frame.gateway, frame.station, frame.code), (0, 8, 0x23));
}

/// Every message until a `pong`, in order.
async fn until_pong(ws: &mut Ws) -> Vec<ServerMessage> {
    send_text(ws, r#"{"type":"ping"}"#).await;
    let mut heard = Vec::new();
    loop {
        match next_message(ws).await {
            ServerMessage::Pong => return heard,
            other => heard.push(other),
        }
    }
}

#[tokio::test]
async fn a_client_that_turns_the_feedback_relay_off_gets_no_frames_until_it_turns_it_on() {
    let (bridge, mut gateways, _links) = bridge_with_two_gateways().await;
    let mut ws = bridge.ws(&bridge.token().await).await;
    wait_until_links_are_up(&mut ws).await;
    let mut quiet = bridge.ws(&bridge.token().await).await;
    wait_until_links_are_up(&mut quiet).await;
    send_text(&mut quiet, r#"{"type":"feedback","relay":false}"#).await;
    // The ping is read after the relay message: once it is answered, the relay is off.
    until_pong(&mut quiet).await;

    let frame = |station| Frame::new(station, 0x16, &[]).expect("frame");
    gateways[0]
        .master
        .write_all(frame(6).encode().as_bytes())
        .expect("write");
    // The other client still gets it: the relay is per client.
    assert_eq!(next_feedback(&mut ws).await.station, 6);
    let heard = until_pong(&mut quiet).await;
    assert!(
        !heard
            .iter()
            .any(|message| matches!(message, ServerMessage::Feedback(_))),
        "a frame reached a client that turned the relay off: {heard:?}"
    );

    send_text(&mut quiet, r#"{"type":"feedback","relay":true}"#).await;
    until_pong(&mut quiet).await;
    gateways[0]
        .master
        .write_all(frame(7).encode().as_bytes())
        .expect("write");
    assert_eq!(next_feedback(&mut quiet).await.station, 7);
}
