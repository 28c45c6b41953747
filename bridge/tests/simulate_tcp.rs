//! `floatball simulate --kind uim2503 --listen`: simulated gateways on TCP sockets; the
//! test is the client (a device server's user) on each.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant, SystemTime};

use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame, FrameDecoder};

struct Simulator {
    child: Child,
    lines: Receiver<String>,
    sockets: Vec<SocketAddr>,
}

impl Drop for Simulator {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Simulator {
    fn start(gateways: usize, baud: u32, extra: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .args(["simulate", "--listen", "127.0.0.1:0", "--baud"])
            .arg(baud.to_string())
            .args(["--gateways", &gateways.to_string()])
            .args(extra)
            .stdout(Stdio::piped())
            .spawn()
            .expect("start floatball simulate");
        let lines = read_lines(child.stdout.take().unwrap());
        let mut simulator = Self {
            child,
            lines,
            sockets: Vec::new(),
        };
        for index in 0..gateways {
            let line = simulator.line();
            let prefix = format!("floatball simulating gateway {index} with ");
            assert!(line.starts_with(&prefix), "{line}");
            let socket = line.rsplit(' ').next().unwrap().parse().expect(&line);
            simulator.sockets.push(socket);
        }
        simulator
    }

    fn line(&self) -> String {
        self.lines
            .recv_timeout(Duration::from_secs(10))
            .expect("floatball simulate printed a line")
    }

    fn connect(&self, index: usize) -> TcpStream {
        let stream = TcpStream::connect(self.sockets[index]).expect("connect");
        stream
            .set_read_timeout(Some(Duration::from_millis(20)))
            .unwrap();
        stream
    }

    /// The next `count` start lines: (gateway, unix ns the simulated line took it).
    fn starts(&self, count: usize) -> Vec<(usize, u128)> {
        self.start_lines(count)
            .into_iter()
            .map(|(gateway, _, read_ns)| (gateway, read_ns))
            .collect()
    }

    /// The next `count` start lines: (gateway, unix ns it arrived at the socket, unix
    /// ns the simulated line took it).
    fn start_lines(&self, count: usize) -> Vec<(usize, u128, u128)> {
        (0..count)
            .map(|_| {
                let line = self.line();
                let (gateway, rest) = line
                    .strip_prefix("gateway ")
                    .and_then(|rest| rest.split_once(": start received at "))
                    .unwrap_or_else(|| panic!("not a start line: {line}"));
                let (arrived, read) = rest
                    .strip_suffix(" ns")
                    .and_then(|rest| rest.split_once(" ns, read at "))
                    .expect(&line);
                (
                    gateway.parse().expect(&line),
                    arrived.parse().expect(&line),
                    read.parse().expect(&line),
                )
            })
            .collect()
    }
}

fn read_lines(stdout: ChildStdout) -> Receiver<String> {
    let (lines, receive) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            let Ok(line) = line else { return };
            if lines.send(line).is_err() {
                return;
            }
        }
    });
    receive
}

fn unix_ns() -> u128 {
    SystemTime::now()
        .duration_since(SystemTime::UNIX_EPOCH)
        .unwrap()
        .as_nanos()
}

fn frames_until(stream: &mut TcpStream, count: usize) -> Vec<Frame> {
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
        match stream.read(&mut buffer) {
            Ok(0) => panic!("the gateway closed the connection"),
            Ok(n) => frames.extend(decoder.push(&buffer[..n])),
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(err) => panic!("read failed: {err}"),
        }
    }
    frames
}

#[test]
fn each_gateway_answers_on_its_own_socket_and_says_when_a_start_arrived() {
    let simulator = Simulator::start(3, 115_200, &["--units", "3"]);
    assert_eq!(simulator.sockets.len(), 3);
    let mut clients: Vec<TcpStream> = (0..3).map(|index| simulator.connect(index)).collect();
    for client in &mut clients {
        // Split mid-instruction, as a device server may deliver it.
        client.write_all(b"*3;QT[7]").unwrap();
        std::thread::sleep(Duration::from_millis(10));
        client.write_all(b"=100;").unwrap();
    }
    for client in &mut clients {
        let frames = frames_until(client, 1);
        assert_eq!(frames[0].station(), 3);
        assert_eq!(
            Feedback::from_frame(&frames[0]),
            Ok(Feedback::Ack(Ack::PvtTime {
                row: 7,
                duration_ms: 100
            }))
        );
    }
    let before = unix_ns();
    for client in &mut clients {
        client.write_all(b"*1;MO=1;*0;B").unwrap();
    }
    std::thread::sleep(Duration::from_millis(20));
    for client in &mut clients {
        client.write_all(b"G;").unwrap();
    }
    let mut starts = simulator.starts(3);
    let after = unix_ns();
    starts.sort_unstable();
    assert_eq!(
        starts
            .iter()
            .map(|&(gateway, _)| gateway)
            .collect::<Vec<_>>(),
        [0, 1, 2]
    );
    for (gateway, at_ns) in starts {
        // The start's last byte was sent 20 ms after the rest.
        assert!(
            at_ns >= before + 20_000_000 && at_ns <= after,
            "gateway {gateway}: {at_ns} not in {before}..{after}"
        );
    }
}

#[test]
fn the_socket_is_read_no_faster_than_the_line_carries_bytes() {
    // 100 starts of 6 bytes at 9600 baud (960 bytes/s): the receive FIFO's 256 bytes
    // go at once, the rest at line speed.
    let simulator = Simulator::start(1, 9600, &["--units", "2"]);
    let mut client = simulator.connect(0);
    client.write_all(&b"*0;BG;".repeat(100)).unwrap();
    let starts = simulator.start_lines(100);
    let spread_s = (starts[99].2 - starts[0].2) as f64 / 1e9;
    let line_s = (600.0 - 256.0) / 960.0;
    assert!(
        spread_s > line_s * 0.9 && spread_s < line_s + 1.0,
        "100 starts were read over {spread_s} s; the line carries them in {line_s} s"
    );
    // They all arrived at the socket at once (one write), long before the last was read.
    let arrived_s = (starts[99].1 - starts[0].1) as f64 / 1e9;
    assert!(arrived_s < 0.05, "100 starts arrived over {arrived_s} s");
    assert!(starts.iter().all(|&(_, arrived, read)| arrived <= read));
}

#[test]
fn a_new_client_replaces_the_old_one_and_the_gateway_keeps_its_units() {
    let simulator = Simulator::start(1, 115_200, &["--units", "4", "--factory-fresh"]);
    let mut old = simulator.connect(0);
    old.write_all(b"*0;SN;").unwrap();
    let frames = frames_until(&mut old, 4);
    let mut serials: Vec<u64> = frames
        .iter()
        .map(|frame| match Feedback::from_frame(frame) {
            Ok(Feedback::Ack(Ack::Serial { serial })) => serial,
            other => panic!("expected a serial number, got {other:?}"),
        })
        .collect();
    serials.sort_unstable();
    let mut new = simulator.connect(0);
    // The old connection is closed by the gateway.
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut buffer = [0u8; 64];
    loop {
        assert!(Instant::now() < deadline, "the old client was not dropped");
        match old.read(&mut buffer) {
            Ok(0) => break,
            Ok(_) => {}
            Err(err)
                if matches!(
                    err.kind(),
                    std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
                ) => {}
            Err(_) => break,
        }
    }
    new.write_all(b"*0;SN;").unwrap();
    let frames = frames_until(&mut new, 4);
    let mut again: Vec<u64> = frames
        .iter()
        .map(|frame| match Feedback::from_frame(frame) {
            Ok(Feedback::Ack(Ack::Serial { serial })) => serial,
            other => panic!("expected a serial number, got {other:?}"),
        })
        .collect();
    again.sort_unstable();
    assert_eq!(serials, again, "the same units answer the new client");
}

#[test]
fn sighup_power_cycles_every_gateway_into_its_stored_speed() {
    let simulator = Simulator::start(2, 115_200, &["--units", "2"]);
    let mut client = simulator.connect(1);
    client.write_all(b"BDR=9600;").unwrap();
    assert_eq!(
        simulator.line(),
        "gateway 1: stored BDR=9600; it takes effect at its restart (SIGHUP)"
    );
    let status = Command::new("kill")
        .args(["-HUP", &simulator.child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let mut restarts = vec![simulator.line(), simulator.line()];
    restarts.sort();
    assert_eq!(
        restarts,
        [
            "gateway 0: restarted; the line runs at 115200 baud",
            "gateway 1: restarted; the line runs at 9600 baud",
        ]
    );
    // Gateway 1 now reads at 9600 baud: 256 bytes at once, then 960 bytes/s.
    client.write_all(&b"*0;BG;".repeat(100)).unwrap();
    let starts = simulator.starts(100);
    assert!(starts.iter().all(|&(gateway, _)| gateway == 1));
    let spread_s = (starts[99].1 - starts[0].1) as f64 / 1e9;
    assert!(spread_s > 0.3, "{spread_s} s");
}

#[test]
fn a_serial_device_and_tcp_do_not_mix() {
    for (args, said) in [
        (
            &["--port", "/dev/null", "--listen", "127.0.0.1:0"][..],
            "not both",
        ),
        (
            &["--port", "/dev/null", "--gateways", "2"][..],
            "--gateways is for --listen",
        ),
        (&[][..], "needs --port (a serial device) or --listen (TCP)"),
    ] {
        let output = Command::new(env!("CARGO_BIN_EXE_floatball"))
            .arg("simulate")
            .args(args)
            .output()
            .expect("run floatball simulate");
        assert!(!output.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(said), "{args:?}: {stderr}");
    }
}
