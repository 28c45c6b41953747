//! Serial links over real pseudo-terminal pairs: the link opens the slave side by its
//! path, the test plays the gateway on the master side. The gateway answers the link's
//! greeting (`ABC;` → `AA AB AC`, without which the link is not up); the greetings are
//! counted and kept out of the bytes the tests compare.

use std::io::{Read, Write};
use std::os::unix::fs::symlink;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::{
    ANSWER_TIMEOUT, Batch, GREETING_INTERVAL, GREETING_RETRY, Link, LinkConfig, LinkError,
    MISSED_GREETINGS,
};
use floatball_shared::api::LinkState;
use floatball_shared::uim2503::ascii::{Form, parse_script};
use floatball_shared::uim2503::feedback::Frame;
use serialport::{SerialPort, TTYPort};

fn batch(script: &str) -> Batch {
    Batch::encode(&parse_script(script).unwrap(), Form::Standard).unwrap()
}

/// A pty pair whose slave is reachable at `path` (a symlink, as udev's
/// /dev/serial/by-id names are), so a test can swap the device behind it. The master
/// is read from the start ([`spawn_reader`]); dropping the gateway closes it.
struct Gateway {
    master: TTYPort,
    rx: mpsc::Receiver<(Instant, Vec<u8>)>,
    greetings: Arc<AtomicUsize>,
    /// Whether the gateway answers greetings.
    answering: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
}

impl Drop for Gateway {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        // The reader lets go of its handle within one read timeout.
        std::thread::sleep(Duration::from_millis(60));
    }
}

fn pty_at(path: &std::path::Path) -> Gateway {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let slave_path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let _ = std::fs::remove_file(path);
    symlink(slave_path, path).unwrap();
    let greetings = Arc::new(AtomicUsize::new(0));
    let answering = Arc::new(AtomicBool::new(true));
    let stop = Arc::new(AtomicBool::new(false));
    let rx = spawn_reader(
        master.try_clone_native().unwrap(),
        Arc::clone(&greetings),
        Arc::clone(&answering),
        Arc::clone(&stop),
    );
    Gateway {
        master,
        rx,
        greetings,
        answering,
        stop,
    }
}

async fn wait_for_state(link: &Link, state: LinkState) {
    let mut status = link.status();
    tokio::time::timeout(
        Duration::from_secs(10),
        status.wait_for(|status| status.state == state),
    )
    .await
    .unwrap_or_else(|_| panic!("link never became {state:?}: {:?}", link.status().borrow()))
    .unwrap();
}

/// Reads from the master in a thread, timestamping every chunk, until `stop`. Plays
/// the gateway's part in the greeting: each whole `ABC;` is counted in `greetings`,
/// answered `AA AB AC` while `answering`, and left out of the chunks; everything else
/// is handed on in whole instructions (a partial one waits for its `;`).
fn spawn_reader(
    mut master: TTYPort,
    greetings: Arc<AtomicUsize>,
    answering: Arc<AtomicBool>,
    stop: Arc<AtomicBool>,
) -> mpsc::Receiver<(Instant, Vec<u8>)> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut buffer = [0u8; 512];
        let mut partial = Vec::new();
        while !stop.load(Ordering::Acquire) {
            match master.read(&mut buffer) {
                Ok(0) => {}
                Ok(n) => {
                    let at = Instant::now();
                    partial.extend_from_slice(&buffer[..n]);
                    let whole = partial
                        .iter()
                        .rposition(|&b| b == b';')
                        .map_or(0, |i| i + 1);
                    let mut chunk = Vec::new();
                    for instruction in partial[..whole].split_inclusive(|&b| b == b';') {
                        if instruction == b"ABC;" {
                            greetings.fetch_add(1, Ordering::AcqRel);
                            if answering.load(Ordering::Acquire) {
                                let _ = master.write_all(&[0xAA, 0xAB, 0xAC]);
                            }
                        } else {
                            chunk.extend_from_slice(instruction);
                        }
                    }
                    partial.drain(..whole);
                    if !chunk.is_empty() && tx.send((at, chunk)).is_err() {
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

fn collect(rx: &mpsc::Receiver<(Instant, Vec<u8>)>, until: impl Fn(&[u8]) -> bool) -> Vec<u8> {
    let deadline = Instant::now() + Duration::from_secs(30);
    let mut all = Vec::new();
    while !until(&all) {
        let left = deadline.saturating_duration_since(Instant::now());
        let (_, chunk) = rx.recv_timeout(left).expect("bytes before the deadline");
        all.extend(chunk);
    }
    all
}

#[tokio::test]
async fn a_batch_reaches_the_line_byte_for_byte() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let gateway = pty_at(&path);
    let link = Link::open(0, LinkConfig::new(path.display().to_string(), 115_200));
    wait_for_state(&link, LinkState::Up).await;

    assert!(gateway.greetings.load(Ordering::Acquire) >= 1);
    link.send(batch("*20; PV=3; BG;")).await.unwrap();
    let written = collect(&gateway.rx, |bytes| bytes.len() >= 12);
    assert_eq!(written, b"*20;PV=3;BG;");
}

#[tokio::test]
async fn an_estop_overtakes_queued_bulk_within_one_instruction() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let gateway = pty_at(&path);
    let link = Link::open(0, LinkConfig::new(path.display().to_string(), 9600));
    wait_for_state(&link, LinkState::Up).await;
    let rx = &gateway.rx;

    // 10 kB of rows: more than ten seconds of line time at 9600 baud.
    let mut bulk = batch("*5;");
    let mut row = 0u32;
    while bulk.len() < 10_000 {
        let index = row % 256;
        bulk.extend(&batch(&format!(
            "QP[{index}]=-1234567;QV[{index}]=7654321;QT[{index}]=100;"
        )));
        row += 1;
    }
    let bulk_len = bulk.len();
    link.send(bulk).await.unwrap();
    // Let the line get going, then stop.
    let before = collect(rx, |bytes| bytes.len() >= 200);
    assert_eq!(link.estop(), None);
    let after = collect(rx, |bytes| bytes.windows(8).any(|w| w == b"*0;MO=0;"));
    let mut all = before;
    all.extend(&after);
    let estop_at = all.windows(8).position(|w| w == b"*0;MO=0;").unwrap();
    // Everything before the e-stop is whole instructions of the bulk stream, and at
    // most two beyond what had arrived when it was sent: the one on the wire and the
    // one handed over just before the line became free.
    let in_flight = &all[200.min(estop_at)..estop_at];
    let instructions_in_flight = in_flight.iter().filter(|&&b| b == b';').count();
    assert!(
        instructions_in_flight <= 2,
        "{} instructions went first: {:?}",
        instructions_in_flight,
        String::from_utf8_lossy(in_flight)
    );
    assert_eq!(
        all[..estop_at].last(),
        Some(&b';'),
        "the e-stop never splits an instruction"
    );
    // Nothing of the bulk follows: it was dropped.
    std::thread::sleep(Duration::from_millis(300));
    let mut trailing = Vec::new();
    while let Ok((_, chunk)) = rx.try_recv() {
        trailing.extend(chunk);
    }
    let tail = &all[estop_at + 8..];
    assert!(
        tail.is_empty() && trailing.is_empty(),
        "bulk kept flowing after the e-stop: {:?}",
        String::from_utf8_lossy(&trailing)
    );
    assert!(estop_at < bulk_len / 2);
    assert_eq!(link.queued_bytes(), 0);
}

#[tokio::test]
async fn feedback_in_odd_chunks_with_garbage_arrives_as_frames() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let mut gateway = pty_at(&path);
    let link = Link::open(3, LinkConfig::new(path.display().to_string(), 115_200));
    wait_for_state(&link, LinkState::Up).await;
    let mut feedback = link.feedback();

    // The manual's frame, an ACK of PV=3 from station 20, with garbage around.
    let manual = Frame::new(5, 13, &[0xF0, 0xF1, 0x72, 0x03, 0x94, 0x95, 0x96, 0x17]).unwrap();
    let pv_ack = Frame::new(20, 0x23, &[3, 0]).unwrap();
    let mut wire = vec![0x00, 0x41, 0xE3];
    wire.extend(manual.encode().as_bytes());
    wire.extend([0x7F, 0x12]);
    wire.extend(pv_ack.encode().as_bytes());
    assert_eq!(
        &wire[3..15],
        [
            0xF3, 0x05, 0x0D, 0x70, 0x71, 0x72, 0x03, 0x14, 0x15, 0x16, 0x17, 0xE7
        ]
    );
    for chunk in wire.chunks(5) {
        gateway.master.write_all(chunk).unwrap();
        gateway.master.flush().unwrap();
        tokio::time::sleep(Duration::from_millis(15)).await;
    }
    let first = tokio::time::timeout(Duration::from_secs(5), feedback.recv())
        .await
        .unwrap()
        .unwrap();
    let second = tokio::time::timeout(Duration::from_secs(5), feedback.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(first, manual);
    assert_eq!(second, pv_ack);
}

#[tokio::test]
async fn a_lost_line_is_reported_and_recovered() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let gateway = pty_at(&path);
    let link = Link::open(0, LinkConfig::new(path.display().to_string(), 115_200));
    wait_for_state(&link, LinkState::Up).await;

    // The far side goes away (the adapter is unplugged).
    drop(gateway);
    wait_for_state(&link, LinkState::Down).await;
    let error = link.send(batch("*5;PV;")).await.unwrap_err();
    assert!(matches!(error, LinkError::Down { .. }), "{error}");
    assert!(link.status().borrow().error.is_some());

    // It comes back (plugged in again): the link reconnects by itself.
    let gateway = pty_at(&path);
    wait_for_state(&link, LinkState::Up).await;
    link.send(batch("*5;PV;")).await.unwrap();
    assert_eq!(collect(&gateway.rx, |bytes| bytes.len() >= 6), b"*5;PV;");
}

#[tokio::test]
async fn a_missing_port_is_down_with_the_reason() {
    let link = Link::open(0, LinkConfig::new("/dev/floatball-no-such-port", 9600));
    wait_for_state(&link, LinkState::Down).await;
    let status = link.status().borrow().clone();
    let error = status.error.unwrap();
    assert!(error.contains("/dev/floatball-no-such-port"), "{error}");
}

#[tokio::test]
async fn while_the_estop_is_latched_only_queries_pass_and_older_batches_are_void() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let gateway = pty_at(&path);
    let link = Link::open(0, LinkConfig::new(path.display().to_string(), 115_200));
    wait_for_state(&link, LinkState::Up).await;
    let rx = &gateway.rx;

    let issued_before = link.latch().generation();
    assert_eq!(link.estop(), None);
    // A batch issued before the e-stop is void, whenever it arrives.
    link.send_issued(batch("*5;PV=0;BG;"), issued_before)
        .await
        .unwrap();
    // Issued after it, while latched: only what cannot move a ball goes.
    link.send(batch("*5;MO=1;PA=100;PA;BG;SN;")).await.unwrap();
    let wire = collect(rx, |bytes| bytes.ends_with(b"SN;"));
    assert_eq!(String::from_utf8_lossy(&wire), "*0;MO=0;*5;PA;SN;");
    assert!(link.dropped_instructions() >= 2);

    // Released by a request issued after the e-stop: motion goes again.
    assert!(link.latch().release(link.latch().generation()));
    link.send(batch("*5;MO=1;")).await.unwrap();
    let wire = collect(rx, |bytes| bytes.ends_with(b"MO=1;"));
    assert_eq!(String::from_utf8_lossy(&wire), "*5;MO=1;");
}

#[tokio::test]
async fn the_link_is_up_only_once_greeted_and_not_answering_while_the_gateway_is_silent() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("gateway0");
    let gateway = pty_at(&path);
    gateway.answering.store(false, Ordering::Release);
    let link = Link::open(0, LinkConfig::new(path.display().to_string(), 115_200));
    // The port opens at once, but nothing answers the greeting.
    wait_for_state(&link, LinkState::NotAnswering).await;
    assert!(gateway.greetings.load(Ordering::Acquire) >= 1);
    let error = link.send(batch("*5;PV;")).await.unwrap_err();
    assert!(matches!(error, LinkError::Down { .. }), "{error}");
    assert_eq!(
        link.status().borrow().error.as_deref(),
        Some("the gateway does not answer the greeting (ABC;)")
    );

    // The gateway answers: up. Then it falls silent: after the next idle greeting the
    // link is not answering, and an e-stop is still written.
    gateway.answering.store(true, Ordering::Release);
    wait_for_state(&link, LinkState::Up).await;
    gateway.answering.store(false, Ordering::Release);
    let silent_from = Instant::now();
    wait_for_state(&link, LinkState::NotAnswering).await;
    let noticed = silent_from.elapsed();
    assert!(
        noticed
            <= GREETING_INTERVAL
                + (ANSWER_TIMEOUT + GREETING_RETRY) * MISSED_GREETINGS
                + Duration::from_millis(500),
        "noticed after {noticed:?}"
    );
    assert!(link.estop().is_some(), "the e-stop says the link is not up");
    let wire = collect(&gateway.rx, |bytes| bytes.ends_with(b"*0;MO=0;"));
    assert_eq!(wire, b"*0;MO=0;");

    // Answering again: up again, by itself.
    gateway.answering.store(true, Ordering::Release);
    wait_for_state(&link, LinkState::Up).await;
}
