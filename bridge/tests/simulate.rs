//! `floatball simulate` on one end of a real pseudo-terminal pair; the test is the host
//! on the other end.

use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame, FrameDecoder};
use floatball_shared::uim2503::sim::TX_QUEUE_BYTES;
use floatball_shared::uim2503::sim::noise::LineNoise;
use serialport::{SerialPort, TTYPort};

struct Simulator(Child);

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(extra: &[&str]) -> (TTYPort, Simulator) {
    start_at("115200", extra)
}

fn start_at(baud: &str, extra: &[&str]) -> (TTYPort, Simulator) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args(["simulate", "--port", &path, "--baud", baud])
        .args(extra)
        .stdout(Stdio::piped())
        .spawn()
        .expect("start floatball simulate");
    // It says what it does once the port is open.
    let mut line = String::new();
    let mut stdout = child.stdout.take().unwrap();
    let mut byte = [0u8; 1];
    while !line.ends_with('\n') {
        stdout
            .read_exact(&mut byte)
            .expect("floatball simulate printed its banner");
        line.push(char::from(byte[0]));
    }
    assert!(line.contains(&path), "{line}");
    (master, Simulator(child))
}

fn frames_until(master: &mut TTYPort, count: usize) -> Vec<Frame> {
    let mut decoder = FrameDecoder::new();
    let mut frames = Vec::new();
    let mut buffer = [0u8; 256];
    let deadline = Instant::now() + Duration::from_secs(10);
    while frames.len() < count {
        assert!(
            Instant::now() < deadline,
            "only {} frames arrived",
            frames.len()
        );
        match master.read(&mut buffer) {
            Ok(n) => frames.extend(decoder.push(&buffer[..n])),
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) => panic!("read failed: {err}"),
        }
    }
    frames
}

#[test]
fn a_round_trip_through_a_pty_gets_the_manuals_answers() {
    let (mut master, _simulator) = start(&["--units", "3"]);
    // Split mid-instruction, as a serial line may deliver it.
    master.write_all(b"*2;MO=1;PV").unwrap();
    master.flush().unwrap();
    std::thread::sleep(Duration::from_millis(30));
    master.write_all(b"=0;*3;QT[7]=100;").unwrap();
    let frames = frames_until(&mut master, 3);
    let answers: Vec<(u8, Result<Feedback, _>)> = frames
        .iter()
        .map(|frame| (frame.station(), Feedback::from_frame(frame)))
        .collect();
    assert_eq!(answers[0].0, 2);
    assert_eq!(
        answers[1],
        (2, Ok(Feedback::Ack(Ack::PvtStart { value: 0 })))
    );
    assert_eq!(
        answers[2],
        (
            3,
            Ok(Feedback::Ack(Ack::PvtTime {
                row: 7,
                duration_ms: 100
            }))
        )
    );
}

#[test]
fn factory_fresh_units_are_discovered_through_the_pty() {
    let (mut master, _simulator) = start(&["--units", "8", "--factory-fresh"]);
    master.write_all(b"*0;SN;").unwrap();
    let frames = frames_until(&mut master, 8);
    let mut serials: Vec<u64> = frames
        .iter()
        .map(|frame| match Feedback::from_frame(frame) {
            Ok(Feedback::Ack(Ack::Serial { serial })) => {
                assert_eq!(frame.station(), 5);
                serial
            }
            other => panic!("expected a serial number, got {other:?}"),
        })
        .collect();
    serials.sort_unstable();
    serials.dedup();
    assert_eq!(serials.len(), 8);
}

/// Writes all of `bytes`, waiting while the simulator reads at the line's speed.
fn write_slowly(port: &mut TTYPort, bytes: &[u8]) {
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut rest = bytes;
    while !rest.is_empty() {
        assert!(Instant::now() < deadline, "the simulator stopped reading");
        match port.write(rest) {
            Ok(n) => rest = &rest[n..],
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) if err.kind() == std::io::ErrorKind::Interrupted => {}
            Err(err) => panic!("write failed: {err}"),
        }
    }
}

/// The reproduction: 400 kB of line noise (binary chunks and instruction
/// fragments: selections, rows, moves, renumbering, floods of queries) written as fast
/// as the pseudo-terminal takes it, then `;` and a roll call. The simulator reads at
/// the line's speed (the writes block), keeps its answer queue bounded, and answers the
/// roll call from all 100 units in the time the line needs.
#[test]
fn line_noise_at_full_speed_does_not_mute_the_roll_call() {
    const BAUD: u32 = 921_600;
    let (mut master, _simulator) = start_at(&BAUD.to_string(), &["--units", "100"]);
    let mut noise = Vec::new();
    LineNoise::new(2503).fill(&mut noise, 400_000);
    let mut writer = master.try_clone_native().expect("clone the pty");
    writer.set_timeout(Duration::from_millis(200)).unwrap();
    let started = Instant::now();
    let sending = std::thread::spawn(move || {
        write_slowly(&mut writer, &noise);
        writer
    });
    // Read everything meanwhile, as a host would.
    let mut decoder = FrameDecoder::new();
    let mut buffer = [0u8; 4096];
    let mut noise_answers = 0;
    while !sending.is_finished() {
        match master.read(&mut buffer) {
            Ok(n) => noise_answers += decoder.push(&buffer[..n]).count(),
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) => panic!("read failed: {err}"),
        }
    }
    let mut writer = sending.join().expect("the writer");
    let writing = started.elapsed();
    // At most baud / 10 bytes/s went in (with a little slack for the read timing).
    assert!(
        writing.as_secs_f64() > 400_000.0 * 10.0 / f64::from(BAUD) * 0.8,
        "400 kB written in {writing:?}: faster than the line"
    );
    assert!(
        noise_answers > 1000,
        "the noise was answered: {noise_answers}"
    );

    let rolled_at = Instant::now();
    writer.write_all(b";;;*0;MO=0;*0;SN;").unwrap();
    // Everything until the line is quiet for 300 ms.
    let mut frames: Vec<(Instant, Frame)> = Vec::new();
    let mut quiet_since = Instant::now();
    while quiet_since.elapsed() < Duration::from_millis(300) {
        assert!(rolled_at.elapsed() < Duration::from_secs(10), "never quiet");
        match master.read(&mut buffer) {
            Ok(n) => {
                let now = Instant::now();
                frames.extend(decoder.push(&buffer[..n]).map(|frame| (now, frame)));
                quiet_since = now;
            }
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) => panic!("read failed: {err}"),
        }
    }
    // The roll call's answers are the last 100 frames: one serial number from each unit.
    assert!(
        frames.len() >= 100,
        "only {} frames after the roll call",
        frames.len()
    );
    let last = &frames[frames.len() - 100..];
    let mut serials: Vec<u64> = last
        .iter()
        .map(|(_, frame)| match Feedback::from_frame(frame) {
            Ok(Feedback::Ack(Ack::Serial { serial })) => serial,
            other => panic!("expected a serial number, got {other:?}"),
        })
        .collect();
    serials.sort_unstable();
    serials.dedup();
    assert_eq!(serials.len(), 100);
    // In the time the line needs: what the operating system still held of the noise
    // (its pseudo-terminal buffer, at most some 70 kB), a full answer queue and the
    // roll call, at 92160 bytes/s — well under 1.5 s. Before the fix the answers to the
    // noise queued without bound and the roll call waited behind all of them.
    let answered = last[99].0.duration_since(rolled_at);
    let line_needs = Duration::from_secs_f64(
        (70_000.0 + TX_QUEUE_BYTES as f64 + 1200.0) * 10.0 / f64::from(BAUD),
    );
    assert!(
        answered < line_needs + Duration::from_millis(500),
        "answered after {answered:?}"
    );
}
