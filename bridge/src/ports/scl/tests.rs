//! The owner's queue on a real pseudo-terminal, the test playing the drives: one
//! request at a time on a line, a timeout that names the drive, and the e-stop that
//! writes `SK` to every drive and voids what was queued.

use std::io::{Read, Write};
use std::sync::Arc;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::*;
use crate::config::{SclConfig, SclGateway, SclPrograms, default_addresses};

/// Three drives `0 1 2` on a pty at 115200 baud; the test holds the master.
fn line(latch: &Arc<Latch>) -> (SclNet, TTYPort) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    master
        .set_timeout(Duration::from_millis(10))
        .expect("timeout");
    let config = SclConfig {
        gateways: vec![SclGateway::Serial {
            port: slave.name().expect("slave name"),
            baud: 115_200,
            addresses: default_addresses(3),
        }],
        start: None,
        trigger: None,
        programs: SclPrograms::Upload,
        steps_per_rev: 20_000,
        tolerance_mm: 10.0,
        // Long: the polls stay out of the way.
        poll: Duration::from_secs(10),
        host_port: 0,
    };
    let net = SclNet::open(&config, latch).expect("open");
    // The slave is the link's now; the first poll round goes out at once.
    drop(slave);
    (net, master)
}

/// Lines the master receives within `wait`, with when.
fn read_lines(master: &mut TTYPort, wait: Duration) -> Vec<(Instant, String)> {
    let until = Instant::now() + wait;
    let mut lines = Vec::new();
    let mut line = Vec::new();
    let mut buffer = [0u8; 256];
    while Instant::now() < until {
        if let Ok(count) = master.read(&mut buffer) {
            for &byte in &buffer[..count] {
                if byte == b'\r' {
                    lines.push((Instant::now(), String::from_utf8_lossy(&line).into_owned()));
                    line.clear();
                } else {
                    line.push(byte);
                }
            }
        }
    }
    lines
}

/// Reads until `count` lines came (or `limit` passed: a failure, not a figure), then
/// `quiet` more, so a line that should not be there yet shows.
fn read_count(master: &mut TTYPort, count: usize, limit: Duration, quiet: Duration) -> Vec<String> {
    let until = Instant::now() + limit;
    let mut lines = Vec::new();
    while lines.len() < count && Instant::now() < until {
        lines.extend(read_lines(master, Duration::from_millis(5)));
    }
    lines.extend(read_lines(master, quiet));
    lines.into_iter().map(|(_, text)| text).collect()
}

async fn until_up(net: &SclNet) {
    for _ in 0..200 {
        if net.links()[0].is_up() {
            return;
        }
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    panic!("the line never came up");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_drive_times_out_with_its_name_and_counts_a_missed_reply() {
    let latch = Arc::new(Latch::new());
    let (net, mut master) = line(&latch);
    until_up(&net).await;
    let link = net.links()[0].clone();
    let asked = Instant::now();
    let answer = link
        .request(1, "IP".to_owned(), Expect::One, latch.generation())
        .await;
    let Err(SclError::Timeout {
        drive,
        request,
        timeout_ms,
    }) = answer
    else {
        panic!("a timeout: {answer:?}");
    };
    assert_eq!(
        (drive.as_str(), request.as_str()),
        ("\"1\" on SCL gateway 0", "IP")
    );
    assert!(asked.elapsed() >= Duration::from_millis(timeout_ms));
    let status = link.drive(1).expect("drive 1");
    assert!(status.missed_replies >= 1);
    assert!(
        status
            .error
            .expect("an error")
            .contains("did not answer IP")
    );
    // The polls went one at a time too: every line the link wrote was a whole request.
    let lines = read_lines(&mut master, Duration::from_millis(50));
    assert!(lines.iter().all(|(_, text)| text.len() >= 3), "{lines:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_line_carries_one_request_at_a_time_and_the_estop_goes_first() {
    let latch = Arc::new(Latch::new());
    let (net, mut master) = line(&latch);
    until_up(&net).await;
    // Let the first poll round time out (nobody answers) so the line is quiet.
    let link = net.links()[0].clone();
    tokio::time::sleep(Duration::from_millis(1200)).await;
    let _ = read_lines(&mut master, Duration::from_millis(20));
    let generation = latch.generation();
    // The drives' side, on a thread of its own while the requests wait.
    let script = tokio::task::spawn_blocking({
        let (latch, net) = (Arc::clone(&latch), net.clone());
        move || {
            // Only the first is on the line until it is answered (the quiet read
            // would show a second).
            let limit = Duration::from_secs(5);
            let quiet = Duration::from_millis(40);
            let first = read_count(&mut master, 1, limit, quiet);
            master.write_all(b"0%\r").expect("answer");
            let second = read_count(&mut master, 1, limit, quiet);
            // The e-stop while 1DI200 waits for its answer and 2DI300 is queued.
            crate::estop::press(&latch, &[]);
            net.wake();
            let stops = read_count(&mut master, 3, limit, quiet);
            (first, second, stops)
        }
    });
    // Queued in this order (join! polls them in order).
    let answers = tokio::join!(
        link.request(0, "DI100".to_owned(), Expect::One, generation),
        link.request(1, "DI200".to_owned(), Expect::One, generation),
        link.request(2, "DI300".to_owned(), Expect::One, generation),
    );
    let (first, second, stops) = script.await.expect("the drives' side");
    assert_eq!(first, ["0DI100"]);
    assert_eq!(second, ["1DI200"]);
    // SK to every drive, back to back, and both requests left are void (how soon
    // after the press is `cargo xtask scl-bench`'s figure, not a test's bound).
    assert_eq!(stops, ["0SK", "1SK", "2SK"]);
    assert_eq!(answers.0, Ok(vec!["%".to_owned()]));
    assert_eq!(answers.1, Err(SclError::Void));
    assert_eq!(answers.2, Err(SclError::Void));
    // Latched: a move is refused, a query goes.
    let refused = link
        .request(0, "FP".to_owned(), Expect::One, latch.generation())
        .await;
    assert_eq!(refused, Err(SclError::Latched));
    // Issued before the e-stop: void.
    let stale = link
        .request(0, "IP".to_owned(), Expect::One, generation)
        .await;
    assert_eq!(stale, Err(SclError::Void));
}

/// A transport that takes every request and answers nothing (the test answers).
struct Quiet;

impl Transport for Quiet {
    fn send(&mut self, _: &LinkShared, _: usize, _: &str) -> std::io::Result<()> {
        Ok(())
    }

    fn stop_all(&mut self, _: &LinkShared) -> std::io::Result<()> {
        Ok(())
    }

    fn per_drive(&self) -> bool {
        false
    }
}

/// Issue 47: an owner that wakes after a request's deadline (a loaded host) while the
/// answer already waits in its inbox takes the answer — it came in time — instead of
/// counting the request as missed ("drive … did not answer WT0.05 within 100 ms"
/// put a bridge in error under load).
#[test]
fn an_answer_queued_before_the_owner_looks_is_not_a_timeout() {
    let latch = Arc::new(Latch::new());
    let shared = LinkShared {
        index: 0,
        port: "test".to_owned(),
        baud: 115_200,
        drives: vec![DriveShared::new("0".to_owned(), Address::new('0'))],
        latch: Arc::clone(&latch),
        poll: Duration::from_secs(3600),
        up: AtomicBool::new(false),
        down_reason: Mutex::new(None),
        closed: AtomicBool::new(false),
        program_jobs: AtomicUsize::new(0),
        replies: broadcast::channel(4).0,
    };
    let (events, inbox) = channel();
    let opener: Opener = Box::new(|_, _| Ok(Box::new(Quiet) as Box<dyn Transport>));
    let mut owner = Owner::new(&shared, opener, events.clone());
    owner.connect();
    // The first poll is due at once: out of the way first, answered by nobody.
    owner.next_poll = Instant::now() + Duration::from_secs(3600);
    let (done, mut answered) = oneshot::channel();
    owner.enqueue(Job {
        drive: 0,
        text: "WT0.05".to_owned(),
        inert: false,
        expect: Expect::One,
        generation: latch.generation(),
        purpose: Purpose::Player,
        delivered: None,
        done: Some(done),
    });
    shared.program_jobs.fetch_add(1, Ordering::AcqRel);
    owner.dispatch();
    let deadline = owner
        .in_flight
        .first()
        .and_then(Option::as_ref)
        .map(|flight| flight.deadline)
        .expect("in flight");
    // The drive answers in time; the reader queues it for the owner…
    events
        .send(Event::Line {
            connection: owner.connection,
            drive: None,
            text: "0%".to_owned(),
        })
        .expect("queued");
    // …which only looks after the deadline.
    std::thread::sleep(
        deadline.saturating_duration_since(Instant::now()) + Duration::from_millis(5),
    );
    // The turn's wait ends with the next poll (soon), not an hour from now.
    owner.next_poll = Instant::now() + Duration::from_millis(20);
    assert!(owner.turn(&inbox));
    let (result, _) = answered.try_recv().expect("answered at once");
    assert_eq!(result, Ok(vec!["%".to_owned()]));
    assert_eq!(shared.drives[0].missed_replies.load(Ordering::Acquire), 0);
}
