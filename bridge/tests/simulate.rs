//! `floatball simulate` on one end of a real pseudo-terminal pair; the test is the host
//! on the other end.

use std::io::{Read, Write};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use floatball_shared::feedback::{Ack, Feedback, Frame, FrameDecoder};
use serialport::{SerialPort, TTYPort};

struct Simulator(Child);

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn start(extra: &[&str]) -> (TTYPort, Simulator) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args(["simulate", "--port", &path, "--baud", "115200"])
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
