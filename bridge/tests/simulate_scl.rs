//! `floatball simulate --kind scl`: simulated MOONS' drives on one end of a real
//! pseudo-terminal pair (an RS-485 line, addressed drives) and on loopback UDP (eSCL,
//! one socket a drive); the test is the host.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, UdpSocket};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::time::{Duration, Instant};

use floatball_shared::scl::{QueueUpload, UploadHeader};
use serialport::{SerialPort, TTYPort};

/// The running simulator; killed when dropped.
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
    fn start(args: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--kind", "scl"])
            .args(args)
            .stdout(Stdio::piped())
            .spawn()
            .expect("start floatball simulate --kind scl");
        let stdout = BufReader::new(child.stdout.take().expect("stdout"));
        Self { child, stdout }
    }

    fn line(&mut self) -> String {
        let mut line = String::new();
        self.stdout.read_line(&mut line).expect("a line");
        line
    }

    /// Stops it with SIGTERM; returns the lines it prints as it ends.
    fn stop(mut self) -> Vec<String> {
        let status = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status()
            .expect("kill");
        assert!(status.success());
        let mut rest = String::new();
        self.stdout
            .read_to_string(&mut rest)
            .expect("the positions");
        assert!(self.child.wait().expect("exit").success());
        rest.lines().map(str::to_owned).collect()
    }
}

/// Reads `lines` CR-ended lines from the pty.
fn read_lines(master: &mut TTYPort, lines: usize) -> Vec<String> {
    let mut text = String::new();
    let mut buffer = [0u8; 256];
    let deadline = Instant::now() + Duration::from_secs(10);
    while text.matches('\r').count() < lines {
        assert!(Instant::now() < deadline, "only {text:?} arrived");
        match master.read(&mut buffer) {
            Ok(n) => text.push_str(std::str::from_utf8(&buffer[..n]).unwrap()),
            Err(err) if err.kind() == std::io::ErrorKind::TimedOut => {}
            Err(err) => panic!("read failed: {err}"),
        }
    }
    text.split_inclusive('\r').map(str::to_owned).collect()
}

fn ask(master: &mut TTYPort, line: &str, answers: usize) -> Vec<String> {
    master.write_all(format!("{line}\r").as_bytes()).unwrap();
    read_lines(master, answers)
}

#[test]
fn drives_on_an_rs485_line_answer_when_addressed_and_store_and_run_programs() {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut simulator = Simulator::start(&["--port", &path, "--baud", "115200", "--drives", "3"]);
    let banner = simulator.line();
    assert!(
        banner.contains(&path) && banner.contains("3 MOONS' drives"),
        "{banner}"
    );
    // A download as the HCR defines it: QL, the lines (each buffered), QS1 saves them
    // (p. 216, 218).
    assert_eq!(ask(&mut master, "1QL", 1), ["1%\r"]);
    for line in ["1WI3F", "1VE20", "1DI8000", "1FL"] {
        assert_eq!(ask(&mut master, line, 1), ["1*\r"], "{line}");
    }
    assert_eq!(ask(&mut master, "1QS1", 1), ["1%\r"]);
    // Read back with QU: %, QU5, then the four lines.
    let upload = ask(&mut master, "1QU1", 6);
    assert_eq!(upload[0], "1%\r");
    let lines: Vec<&str> = upload[1..].iter().map(String::as_str).collect();
    assert_eq!(
        QueueUpload::parse_header(lines[0]),
        Ok((
            floatball_shared::scl::Address::new('1'),
            UploadHeader::Lines(4)
        ))
    );
    let (_, program) = QueueUpload::parse(&lines).unwrap();
    assert_eq!(program.lines()[1..], ["WI3F", "VE20", "DI8000", "FL"]);
    // Another address is not answered; drive 2 moves on its own.
    master.write_all(b"5IP\r").unwrap();
    assert_eq!(ask(&mut master, "2DI-1000", 1), ["2*\r"]);
    assert_eq!(ask(&mut master, "2FL", 1), ["2*\r"]);
    // Drive 1 runs its program, which waits for the start wire (drive 0's Y2 → X3).
    assert_eq!(ask(&mut master, "1QX1", 1), ["1*\r"]);
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(ask(&mut master, "1IP", 1), ["1IP=0\r"]);
    assert_eq!(ask(&mut master, "0SO2L", 1), ["0*\r"]);
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(ask(&mut master, "1IP", 1), ["1IP=8000\r"]);
    assert_eq!(ask(&mut master, "2IP", 1), ["2IP=-1000\r"]);
    assert_eq!(ask(&mut master, "1SC", 1), ["1SC=0009\r"]);
    let positions = simulator.stop();
    assert_eq!(
        positions,
        [
            "drive 0 position 0 counts",
            "drive 1 position 8000 counts",
            "drive 2 position -1000 counts"
        ]
    );
}

#[test]
fn the_line_is_paced_at_its_baud_rate() {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut simulator = Simulator::start(&["--port", &path, "--baud", "9600", "--drives", "1"]);
    simulator.line();
    // 60 queries of 4 bytes ("0IP" CR) and their 6-byte answers ("0IP=0" CR): 600
    // bytes, 0.625 s at 960 bytes/s (a half-duplex line carries one way at a time).
    let started = Instant::now();
    for _ in 0..60 {
        assert_eq!(ask(&mut master, "0IP", 1), ["0IP=0\r"]);
    }
    let elapsed = started.elapsed();
    assert!(elapsed > Duration::from_millis(600), "{elapsed:?}");
    assert!(elapsed < Duration::from_secs(5), "{elapsed:?}");
    drop(simulator);
}

/// Sends one eSCL datagram and reads `answers` datagrams back.
fn escl(socket: &UdpSocket, to: SocketAddr, text: &str, answers: usize) -> Vec<String> {
    let mut datagram = vec![0, 7];
    datagram.extend_from_slice(text.as_bytes());
    datagram.push(b'\r');
    socket.send_to(&datagram, to).unwrap();
    let mut buffer = [0u8; 512];
    (0..answers)
        .map(|_| {
            let (n, from) = socket.recv_from(&mut buffer).expect("an answer");
            assert_eq!(from, to);
            assert_eq!(&buffer[..2], [0, 7]);
            String::from_utf8(buffer[2..n].to_vec()).unwrap()
        })
        .collect()
}

#[test]
fn drives_on_udp_answer_escl_and_share_the_start_wire() {
    let mut simulator = Simulator::start(&["--listen", "127.0.0.1:0", "--drives", "2"]);
    let sockets: Vec<SocketAddr> = (0..2)
        .map(|_| {
            let line = simulator.line();
            assert!(line.contains("eSCL"), "{line}");
            line.split_whitespace().last().unwrap().parse().unwrap()
        })
        .collect();
    let host = UdpSocket::bind("127.0.0.1:0").unwrap();
    host.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
    let drive_1 = sockets[1];
    assert_eq!(escl(&host, drive_1, "QL", 1), ["%\r"]);
    assert_eq!(escl(&host, drive_1, "WI3F", 1), ["*\r"]);
    assert_eq!(escl(&host, drive_1, "DI2500", 1), ["*\r"]);
    assert_eq!(escl(&host, drive_1, "FP", 1), ["*\r"]);
    assert_eq!(escl(&host, drive_1, "QS2", 1), ["%\r"]);
    assert_eq!(
        escl(&host, drive_1, "QU2", 5),
        ["%\r", "QU4\r", "WI3F\r", "DI2500\r", "FP\r"]
    );
    assert_eq!(escl(&host, drive_1, "QX2", 1), ["*\r"]);
    // Drive 0's Y2 is wired to every drive's X3.
    assert_eq!(escl(&host, sockets[0], "SO2L", 1), ["*\r"]);
    std::thread::sleep(Duration::from_millis(200));
    assert_eq!(escl(&host, drive_1, "IP", 1), ["IP=2500\r"]);
    assert_eq!(escl(&host, drive_1, "VE200", 1), ["?5\r"]);
    let positions = simulator.stop();
    assert_eq!(
        positions,
        ["drive 0 position 0 counts", "drive 1 position 2500 counts"]
    );
}
