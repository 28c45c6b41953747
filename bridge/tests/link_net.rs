//! Network links (`tcp://`, `rfc2217://`) against a `std::net::TcpListener` playing
//! the serial device server with the gateway behind it: it answers the link's greeting
//! (`ABC;` → `AA AB AC`, unless told to stay silent), records every instruction with its arrival time (greetings
//! counted and left out), and in RFC 2217 mode speaks Telnet: it agrees to COM-port
//! control, answers the COM-port commands (code + 100) and keeps the raw bytes so the
//! tests can look at the negotiation.

use std::io::{Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, mpsc};
use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::telnet::{self, DO, IAC, SB, SE, WILL};
use floatball_bridge::ports::uim2503::{Batch, Link, LinkConfig, LinkError};
use floatball_shared::api::LinkState;
use floatball_shared::uim2503::ascii::{Form, parse_script};
use floatball_shared::uim2503::feedback::Frame;
use serialport::{SerialPort, TTYPort};

fn batch(script: &str) -> Batch {
    Batch::encode(&parse_script(script).unwrap(), Form::Standard).unwrap()
}

/// How the fake device server answers RFC 2217 commands.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Raw,
    /// Agrees to everything.
    Rfc2217,
    /// Agrees to COM-port control but keeps its line at this speed.
    Rfc2217FixedBaud(u32),
    /// Agrees to everything while the link sets the line up, then never answers a
    /// SET-BAUDRATE again.
    Rfc2217MuteAfterSetup,
}

/// What the fake device server shares with the test.
struct Server {
    port: u16,
    /// Instruction bytes (the line's data, greetings left out) as they arrived.
    rx: mpsc::Receiver<(Instant, Vec<u8>)>,
    greetings: Arc<AtomicUsize>,
    /// Whether the gateway answers greetings.
    answering: Arc<AtomicBool>,
    /// Connections accepted so far, with when.
    accepted: Arc<Mutex<Vec<Instant>>>,
    /// The current client, to write to and to cut.
    client: Arc<Mutex<Option<TcpStream>>>,
    /// Every byte received, Telnet included.
    raw: Arc<Mutex<Vec<u8>>>,
    /// The remote line's speed as last set over RFC 2217.
    line_baud: Arc<AtomicU32>,
}

impl Server {
    fn start(mode: Mode) -> Self {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let port = listener.local_addr().unwrap().port();
        let (tx, rx) = mpsc::channel();
        let server = Self {
            port,
            rx,
            greetings: Arc::default(),
            answering: Arc::new(AtomicBool::new(true)),
            accepted: Arc::default(),
            client: Arc::default(),
            raw: Arc::default(),
            line_baud: Arc::default(),
        };
        let greetings = Arc::clone(&server.greetings);
        let answering = Arc::clone(&server.answering);
        let accepted = Arc::clone(&server.accepted);
        let client = Arc::clone(&server.client);
        let raw = Arc::clone(&server.raw);
        let line_baud = Arc::clone(&server.line_baud);
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(stream) = stream else { return };
                accepted.lock().unwrap().push(Instant::now());
                *client.lock().unwrap() = Some(stream.try_clone().unwrap());
                let connection = Connection {
                    stream,
                    mode,
                    tx: tx.clone(),
                    greetings: Arc::clone(&greetings),
                    answering: Arc::clone(&answering),
                    raw: Arc::clone(&raw),
                    line_baud: Arc::clone(&line_baud),
                    baud_sets: 0,
                };
                std::thread::spawn(move || connection.serve());
            }
        });
        server
    }

    fn tcp(&self) -> String {
        format!("tcp://127.0.0.1:{}", self.port)
    }

    fn rfc2217(&self) -> String {
        format!("rfc2217://127.0.0.1:{}", self.port)
    }

    /// Writes `bytes` to the link as the gateway's output (escaped in Telnet mode by
    /// the caller).
    fn send(&self, bytes: &[u8]) {
        let mut client = self.client.lock().unwrap();
        client.as_mut().unwrap().write_all(bytes).unwrap();
    }

    /// The device server drops the connection.
    fn cut(&self) {
        if let Some(client) = self.client.lock().unwrap().take() {
            client.shutdown(Shutdown::Both).unwrap();
        }
    }

    fn accepted(&self) -> Vec<Instant> {
        self.accepted.lock().unwrap().clone()
    }
}

/// One accepted connection, served on its own thread.
struct Connection {
    stream: TcpStream,
    mode: Mode,
    tx: mpsc::Sender<(Instant, Vec<u8>)>,
    greetings: Arc<AtomicUsize>,
    answering: Arc<AtomicBool>,
    raw: Arc<Mutex<Vec<u8>>>,
    line_baud: Arc<AtomicU32>,
    /// SET-BAUDRATE commands received on this connection.
    baud_sets: u32,
}

impl Connection {
    fn serve(mut self) {
        let mut decoder = telnet::Decoder::new();
        let mut buffer = [0u8; 512];
        let mut partial = Vec::new();
        let mut data = Vec::new();
        let mut events = Vec::new();
        loop {
            let n = match self.stream.read(&mut buffer) {
                Ok(0) | Err(_) => return,
                Ok(n) => n,
            };
            let at = Instant::now();
            self.raw.lock().unwrap().extend_from_slice(&buffer[..n]);
            data.clear();
            events.clear();
            if self.mode == Mode::Raw {
                data.extend_from_slice(&buffer[..n]);
            } else {
                decoder.push(&buffer[..n], &mut data, &mut events);
                for event in events.drain(..) {
                    self.answer(event);
                }
            }
            partial.extend_from_slice(&data);
            let whole = partial
                .iter()
                .rposition(|&b| b == b';')
                .map_or(0, |i| i + 1);
            let mut chunk = Vec::new();
            for instruction in partial[..whole].split_inclusive(|&b| b == b';') {
                if instruction == b"ABC;" {
                    self.greetings.fetch_add(1, Ordering::AcqRel);
                    if self.answering.load(Ordering::Acquire) {
                        let _ = self.stream.write_all(&[0xAA, 0xAB, 0xAC]);
                    }
                } else {
                    chunk.extend_from_slice(instruction);
                }
            }
            partial.drain(..whole);
            if !chunk.is_empty() {
                let _ = self.tx.send((at, chunk));
            }
        }
    }

    /// The server's side of RFC 2217.
    fn answer(&mut self, event: telnet::Event) {
        let reply = match event {
            telnet::Event::Will(telnet::COM_PORT_OPTION) => vec![IAC, DO, 44],
            telnet::Event::Will(option) => vec![IAC, telnet::DONT, option],
            telnet::Event::Do(option) => vec![IAC, telnet::WONT, option],
            telnet::Event::Sub(44, payload) => {
                let (&command, value) = payload.split_first().unwrap();
                let mut value = value.to_vec();
                if command == telnet::SET_BAUDRATE {
                    self.baud_sets += 1;
                    if self.mode == Mode::Rfc2217MuteAfterSetup && self.baud_sets > 1 {
                        return;
                    }
                    if let Mode::Rfc2217FixedBaud(fixed) = self.mode {
                        value = fixed.to_be_bytes().to_vec();
                    }
                    let baud = u32::from_be_bytes(value.as_slice().try_into().unwrap());
                    self.line_baud.store(baud, Ordering::Release);
                }
                let mut reply = vec![IAC, SB, 44, command + 100];
                telnet::escape(&value, &mut reply);
                reply.extend([IAC, SE]);
                reply
            }
            _ => return,
        };
        let _ = self.stream.write_all(&reply);
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

fn collect(rx: &mpsc::Receiver<(Instant, Vec<u8>)>, len: usize) -> Vec<(Instant, Vec<u8>)> {
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut all = Vec::new();
    let mut total = 0;
    while total < len {
        let left = deadline.saturating_duration_since(Instant::now());
        let (at, chunk) = rx.recv_timeout(left).expect("bytes before the deadline");
        total += chunk.len();
        all.push((at, chunk));
    }
    all
}

fn bytes(chunks: &[(Instant, Vec<u8>)]) -> Vec<u8> {
    chunks.iter().flat_map(|(_, chunk)| chunk.clone()).collect()
}

/// A pty pair as a local serial gateway: the link opens the slave, a thread reads
/// the master, answers greetings and records the rest.
fn pty_gateway(greetings: Arc<AtomicUsize>) -> (String, mpsc::Receiver<Vec<u8>>, TTYPort) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    master.set_timeout(Duration::from_millis(20)).unwrap();
    let mut reading = master.try_clone_native().unwrap();
    let (tx, rx) = mpsc::channel::<Vec<u8>>();
    std::thread::spawn(move || {
        let mut buffer = [0u8; 512];
        let mut partial = Vec::new();
        loop {
            match reading.read(&mut buffer) {
                Ok(n) => {
                    partial.extend_from_slice(&buffer[..n]);
                    let whole = partial
                        .iter()
                        .rposition(|&b| b == b';')
                        .map_or(0, |i| i + 1);
                    let mut chunk = Vec::new();
                    for instruction in partial[..whole].split_inclusive(|&b| b == b';') {
                        if instruction == b"ABC;" {
                            greetings.fetch_add(1, Ordering::AcqRel);
                            let _ = reading.write_all(&[0xAA, 0xAB, 0xAC]);
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
                // No slave open yet (EIO): the link opens it in a moment.
                Err(_) => std::thread::sleep(Duration::from_millis(5)),
            }
        }
    });
    drop(slave);
    (path, rx, master)
}

/// The batches of a short show's worth of traffic: selections, queue rows, a start.
fn traffic() -> Vec<Batch> {
    let mut batches = vec![batch("*0;MO=1;"), batch("*20; PV=3; BG;")];
    for station in 1..=4 {
        let mut rows = format!("*{station};");
        for index in 0..6 {
            rows.push_str(&format!(
                "QP[{index}]=-{}; QV[{index}]=7654321; QT[{index}]=100;",
                1000 * station + index
            ));
        }
        batches.push(batch(&rows));
    }
    batches.push(batch("*0;BG;"));
    batches
}

#[tokio::test]
async fn a_tcp_link_writes_what_a_serial_link_writes() {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 115_200));
    let greetings = Arc::new(AtomicUsize::new(0));
    let (pty, pty_rx, _master) = pty_gateway(Arc::clone(&greetings));
    let serial = Link::open(1, LinkConfig::new(pty, 115_200));
    wait_for_state(&link, LinkState::Up).await;
    wait_for_state(&serial, LinkState::Up).await;
    assert!(server.greetings.load(Ordering::Acquire) >= 1);
    assert!(greetings.load(Ordering::Acquire) >= 1);

    let mut expected = 0;
    for batch in traffic() {
        expected += batch.len();
        link.send(batch.clone()).await.unwrap();
        serial.send(batch).await.unwrap();
    }
    let over_tcp = bytes(&collect(&server.rx, expected));
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut over_serial = Vec::new();
    while over_serial.len() < expected {
        let left = deadline.saturating_duration_since(Instant::now());
        over_serial.extend(pty_rx.recv_timeout(left).expect("serial bytes"));
    }
    assert_eq!(
        String::from_utf8_lossy(&over_tcp),
        String::from_utf8_lossy(&over_serial)
    );
    assert_eq!(over_tcp.len(), expected);
    // Beyond the traffic, each link wrote only whole greetings (`ABC;`, one more on
    // either side whenever its line was idle for 2 s).
    for written in [link.written_bytes(), serial.written_bytes()] {
        let extra = written - expected as u64;
        assert!(
            extra >= 4 && extra.is_multiple_of(4),
            "{written} bytes for {expected}"
        );
    }
}

/// Rows of `instructions` pairs of `QP`/`QV` (15 and 13 bytes) for unit 5.
fn rows(instructions: usize) -> Batch {
    let mut rows = String::from("*5;");
    for _ in 0..instructions {
        rows.push_str("QP[7]=-1234567;QV[7]=765432;");
    }
    batch(&rows)
}

/// Sends `rows` through a `tcp://` link at `baud` and returns the most bytes the device
/// server held ahead of what its line could have carried, and whether the whole took
/// about as long as the line needs.
async fn bytes_ahead_of_the_line(baud: u32, rows: Batch) -> i64 {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), baud));
    wait_for_state(&link, LinkState::Up).await;
    let total = rows.len();
    link.send(rows).await.unwrap();
    let chunks = collect(&server.rx, total);
    let byte_time = Duration::from_secs_f64(10.0 / f64::from(baud));
    let start = chunks[0].0;
    let mut received = 0usize;
    let mut worst_ahead = 0i64;
    for (at, chunk) in &chunks {
        received += chunk.len();
        // Bytes the remote line could have sent by `at`, counting from the first.
        let line_bytes = (at.duration_since(start).as_secs_f64() / byte_time.as_secs_f64()) as i64;
        worst_ahead = worst_ahead.max(received as i64 - chunks[0].1.len() as i64 - line_bytes);
    }
    // And the whole took about as long as the line needs.
    let took = chunks.last().unwrap().0.duration_since(start);
    let line_time = byte_time * u32::try_from(total - chunks[0].1.len()).unwrap();
    assert!(
        took + Duration::from_millis(60) >= line_time,
        "{took:?} < {line_time:?}"
    );
    worst_ahead
}

#[tokio::test]
async fn the_device_server_never_gets_more_than_one_instruction_ahead_of_the_line() {
    // About 1.5 s of line time at 9600 baud (960 bytes/s), in instructions of at most
    // 15 bytes.
    let instruction = b"QP[7]=-1234567;".len() as i64;
    let worst_ahead = bytes_ahead_of_the_line(9600, rows(50)).await;
    assert!(
        worst_ahead <= 2 * instruction,
        "the device server got {worst_ahead} bytes ahead of the line"
    );
}

#[tokio::test]
async fn on_a_fast_line_the_device_server_holds_a_few_milliseconds_at_most() {
    // About 1 s of line time at 115,200 baud. The network driver writes up to 10 ms of
    // line time at once (115 bytes), 2 ms ahead of the line being free (23 bytes): the
    // device server holds at most that, and the instruction that did not fit whole.
    let worst_ahead = bytes_ahead_of_the_line(115_200, rows(400)).await;
    let limit = 115 + 23 + 15;
    assert!(
        worst_ahead <= limit,
        "the device server got {worst_ahead} bytes ahead of the line (at most {limit})"
    );
}

/// When the last byte of `needle` arrived at the device server, among `chunks`.
fn arrival_of(chunks: &[(Instant, Vec<u8>)], needle: &[u8]) -> Option<Instant> {
    let all = bytes(chunks);
    let end = find(&all, needle)? + needle.len();
    let mut seen = 0;
    chunks.iter().find_map(|(at, chunk)| {
        seen += chunk.len();
        (seen >= end).then_some(*at)
    })
}

#[tokio::test]
async fn a_start_handed_ahead_goes_out_at_its_instant_on_every_link() {
    let servers = [Server::start(Mode::Raw), Server::start(Mode::Raw)];
    let links: Vec<Link> = servers
        .iter()
        .enumerate()
        .map(|(index, server)| Link::open(index, LinkConfig::new(server.tcp(), 9600)))
        .collect();
    for link in &links {
        wait_for_state(link, LinkState::Up).await;
    }
    // Both lines busy with about 0.6 s of rows, then the start for 150 ms from now.
    let busy = rows(20);
    let generation = links[0].latch().generation();
    for link in &links {
        link.send(busy.clone()).await.unwrap();
    }
    let begin = batch("*0;BG;");
    let at = Instant::now() + Duration::from_millis(150);
    for link in &links {
        link.send_priority_at(&begin, generation, Some(at)).unwrap();
    }
    let total = busy.len() + begin.len() + "*5;".len();
    let mut starts = Vec::new();
    for server in &servers {
        let chunks = collect(&server.rx, total);
        let all = bytes(&chunks);
        // Rows before and after the start, the unit selected again after it.
        let start_at = find(&all, b"*0;BG;").expect("the start was written");
        assert!(start_at > 0, "rows went out before the start's instant");
        assert!(
            find(&all[start_at..], b"*0;BG;*5;").is_some(),
            "{}",
            all.escape_ascii()
        );
        let arrived = arrival_of(&chunks, b"*0;BG;").unwrap();
        // Not before its instant, and within a few of its own bytes' line time after.
        assert!(arrived >= at, "the start arrived {:?} early", at - arrived);
        // (Generous: a loaded machine delays this test's reading thread, not the line.)
        assert!(
            arrived - at <= Duration::from_millis(150),
            "the start arrived {:?} late",
            arrived - at
        );
        starts.push(arrived);
    }
    let skew = starts[0].max(starts[1]) - starts[0].min(starts[1]);
    assert!(skew <= Duration::from_millis(60), "skew {skew:?}");
}

#[tokio::test]
async fn an_estop_voids_a_start_waiting_for_its_instant() {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 9600));
    wait_for_state(&link, LinkState::Up).await;
    let generation = link.latch().generation();
    let at = Instant::now() + Duration::from_millis(200);
    link.send_priority_at(&batch("*0;BG;"), generation, Some(at))
        .unwrap();
    assert_eq!(link.estop(), None);
    assert_eq!(bytes(&collect(&server.rx, 8)), b"*0;MO=0;");
    std::thread::sleep(Duration::from_millis(400));
    let late: Vec<u8> = server.rx.try_iter().flat_map(|(_, chunk)| chunk).collect();
    assert!(late.is_empty(), "after the stop: {}", late.escape_ascii());
}

#[tokio::test]
async fn a_dropped_connection_is_reported_queued_bytes_dropped_and_the_link_reconnects() {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 9600));
    wait_for_state(&link, LinkState::Up).await;

    // Ten seconds of line time queued; the server cuts the connection once some of it
    // has arrived.
    let mut rows = String::from("*5;");
    for _ in 0..350 {
        rows.push_str("QP[7]=-1234567;QV[7]=765432;");
    }
    link.send(batch(&rows)).await.unwrap();
    collect(&server.rx, 100);
    assert!(link.queued_bytes() > 5000);
    let mut status = link.status();
    server.cut();
    let cut_at = Instant::now();
    let down = tokio::time::timeout(
        Duration::from_secs(5),
        status.wait_for(|status| status.state == LinkState::Down),
    )
    .await
    .expect("the link goes down")
    .unwrap()
    .clone();
    let reason = down.error.unwrap();
    assert!(
        reason.contains(&format!("127.0.0.1:{}", server.port)),
        "{reason}"
    );
    assert_eq!(link.queued_bytes(), 0, "everything queued is dropped");
    let error = link.send(batch("*5;PV;")).await.unwrap_err();
    assert!(matches!(error, LinkError::Down { .. }), "{error}");

    // Back after the first backoff, greeted and answered: up again, nothing stale.
    wait_for_state(&link, LinkState::Up).await;
    let accepted = server.accepted();
    assert_eq!(accepted.len(), 2);
    assert!(
        accepted[1].duration_since(cut_at) >= Duration::from_millis(200),
        "reconnected after {:?}",
        accepted[1].duration_since(cut_at)
    );
    std::thread::sleep(Duration::from_millis(300));
    // What was in the old socket when it was cut may have come through; nothing but the
    // greeting is written on the new connection.
    let stale: Vec<u8> = server
        .rx
        .try_iter()
        .filter(|(at, _)| *at >= accepted[1])
        .flat_map(|(_, chunk)| chunk)
        .collect();
    assert!(
        stale.is_empty(),
        "stale bytes: {:?}",
        String::from_utf8_lossy(&stale)
    );
    assert!(server.greetings.load(Ordering::Acquire) >= 2);
    link.send(batch("*5;PV;")).await.unwrap();
    assert_eq!(bytes(&collect(&server.rx, 6)), b"*5;PV;");
}

#[tokio::test]
async fn nobody_listening_is_down_naming_host_and_port() {
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let link = Link::open(0, LinkConfig::new(format!("tcp://127.0.0.1:{port}"), 9600));
    wait_for_state(&link, LinkState::Down).await;
    let error = link.snapshot().error.unwrap();
    assert!(
        error.contains(&format!("cannot connect to 127.0.0.1:{port}")),
        "{error}"
    );
}

#[tokio::test]
async fn a_raw_tcp_link_refuses_a_line_speed_change_before_sending_bdr() {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 9600));
    wait_for_state(&link, LinkState::Up).await;
    let error = link
        .change_baud(115_200, Duration::from_secs(1))
        .await
        .unwrap_err();
    assert!(error.to_string().contains("rfc2217://"), "{error}");
    std::thread::sleep(Duration::from_millis(100));
    assert!(server.rx.try_recv().is_err(), "nothing was sent");
    assert_eq!(link.baud(), 9600);
}

#[tokio::test]
async fn feedback_over_tcp_arrives_as_frames() {
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 115_200));
    wait_for_state(&link, LinkState::Up).await;
    let mut feedback = link.feedback();
    let frame = Frame::new(20, 0x23, &[3, 0]).unwrap();
    server.send(frame.encode().as_bytes());
    let got = tokio::time::timeout(Duration::from_secs(5), feedback.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(got, frame);
}

/// Where `needle` first occurs in `haystack`.
fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack
        .windows(needle.len())
        .position(|window| window == needle)
}

#[tokio::test]
async fn an_rfc2217_link_sets_the_remote_line_and_writes_the_same_bytes() {
    let server = Server::start(Mode::Rfc2217);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 19_200));
    wait_for_state(&link, LinkState::Up).await;
    assert_eq!(server.line_baud.load(Ordering::Acquire), 19_200);

    let raw = server.raw.lock().unwrap().clone();
    // WILL COM-PORT-OPTION, then the line: 19200 baud, 8 bits, no parity, one stop
    // bit, no flow control — each as RFC 2217 spells it — and only then the greeting.
    let offer = find(&raw, &[IAC, WILL, 44]).expect("WILL COM-PORT-OPTION");
    let mut at = offer;
    for command in [
        &[IAC, SB, 44, 1, 0, 0, 0x4B, 0x00, IAC, SE][..],
        &[IAC, SB, 44, 2, 8, IAC, SE],
        &[IAC, SB, 44, 3, 1, IAC, SE],
        &[IAC, SB, 44, 4, 1, IAC, SE],
        &[IAC, SB, 44, 5, 1, IAC, SE],
        b"ABC;",
    ] {
        let found = find(&raw[at..], command)
            .unwrap_or_else(|| panic!("{command:?} after byte {at} of {raw:?}"));
        at += found + command.len();
    }

    // The instructions are the line's bytes, as over raw TCP.
    let mut expected = 0;
    for batch in traffic() {
        expected += batch.len();
        link.send(batch).await.unwrap();
    }
    let written = bytes(&collect(&server.rx, expected));
    let plain: Vec<u8> = traffic()
        .iter()
        .flat_map(|b| b.as_bytes().to_vec())
        .collect();
    assert_eq!(written, plain);
}

#[tokio::test]
async fn a_line_speed_change_is_sent_to_the_rfc2217_server() {
    let server = Server::start(Mode::Rfc2217);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 9600));
    wait_for_state(&link, LinkState::Up).await;
    let changed = link
        .change_baud(57_600, Duration::from_secs(3))
        .await
        .unwrap();
    assert_eq!((changed.from_baud, changed.baud), (9600, 57_600));
    assert_eq!(link.baud(), 57_600);
    assert_eq!(server.line_baud.load(Ordering::Acquire), 57_600);
    let raw = server.raw.lock().unwrap().clone();
    let bdr = find(&raw, b"BDR=57600;").expect("BDR sent to the gateway");
    let set = find(&raw, &[IAC, SB, 44, 1, 0, 0, 0xE1, 0x00, IAC, SE]).expect("SET-BAUDRATE");
    assert!(bdr < set, "the gateway is told before the line moves");
    assert_eq!(bytes(&collect(&server.rx, 10)), b"BDR=57600;");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_estop_during_a_remote_speed_change_does_not_wait_for_the_server() {
    let server = Server::start(Mode::Rfc2217MuteAfterSetup);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 9600));
    wait_for_state(&link, LinkState::Up).await;
    let changing = {
        let link = link.clone();
        tokio::spawn(async move { link.change_baud(57_600, Duration::from_secs(3)).await })
    };
    assert_eq!(bytes(&collect(&server.rx, 10)), b"BDR=57600;");
    // The link now waits (up to 3 s) for the server to answer SET-BAUDRATE.
    tokio::time::sleep(Duration::from_millis(150)).await;
    let pressed = Instant::now();
    // The link is `Connecting` while its speed changes: the stop goes all the same.
    let _ = link.estop();
    let stop = collect(&server.rx, 8);
    assert_eq!(bytes(&stop), b"*0;MO=0;");
    let waited = stop.last().unwrap().0 - pressed;
    assert!(
        waited < Duration::from_millis(500),
        "the stop waited {waited:?} for the server's answer"
    );
    assert!(changing.await.unwrap().is_err());
}

#[tokio::test]
async fn a_refused_line_speed_is_down_with_the_reason() {
    let server = Server::start(Mode::Rfc2217FixedBaud(9600));
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 115_200));
    wait_for_state(&link, LinkState::Down).await;
    let error = link.snapshot().error.unwrap();
    assert!(
        error.contains(&format!("127.0.0.1:{}", server.port))
            && error.contains("115200")
            && error.contains("9600"),
        "{error}"
    );
    assert_eq!(server.greetings.load(Ordering::Acquire), 0);
}

#[tokio::test]
async fn a_raw_server_on_an_rfc2217_link_is_told_apart() {
    // A raw TCP server never answers the Telnet offer.
    let server = Server::start(Mode::Raw);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 9600));
    wait_for_state(&link, LinkState::Down).await;
    let error = link.snapshot().error.unwrap();
    assert!(
        error.contains(&format!("tcp://127.0.0.1:{}", server.port)),
        "{error}"
    );
}

#[tokio::test]
async fn feedback_holding_0xff_is_undoubled_and_telnet_commands_inside_it_skipped() {
    let server = Server::start(Mode::Rfc2217);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 115_200));
    wait_for_state(&link, LinkState::Up).await;
    let mut feedback = link.feedback();
    // Every data byte with its high bit set: the header is 0xFF.
    let frame = Frame::new(7, 0x5A, &[0xFF; 8]).unwrap();
    let plain = frame.encode().as_bytes().to_vec();
    assert_eq!(plain[0], 0xFF);
    let mut wire = Vec::new();
    telnet::escape(&plain[..3], &mut wire);
    // A NOP and a server notification between two bytes of the frame.
    wire.extend([IAC, 241, IAC, SB, 44, 107, 0x30, IAC, SE]);
    telnet::escape(&plain[3..], &mut wire);
    assert_eq!(&wire[..2], [IAC, IAC]);
    for chunk in wire.chunks(3) {
        server.send(chunk);
        std::thread::sleep(Duration::from_millis(5));
    }
    let got = tokio::time::timeout(Duration::from_secs(5), feedback.recv())
        .await
        .unwrap()
        .unwrap();
    assert_eq!(got, frame);
}

#[tokio::test]
async fn an_estop_over_rfc2217_goes_first_after_a_reconnect_while_latched() {
    let server = Server::start(Mode::Rfc2217);
    let link = Link::open(0, LinkConfig::new(server.rfc2217(), 115_200));
    wait_for_state(&link, LinkState::Up).await;
    server.cut();
    wait_for_state(&link, LinkState::Down).await;
    // Pressed while the connection is down: it cannot be written now…
    assert!(link.estop().is_some());
    // …and is the first instruction on the next connection.
    wait_for_state(&link, LinkState::Up).await;
    assert_eq!(bytes(&collect(&server.rx, 8)), b"*0;MO=0;");
}

#[tokio::test]
async fn a_connected_but_silent_gateway_is_not_answering_and_comes_back() {
    let server = Server::start(Mode::Raw);
    server.answering.store(false, Ordering::Release);
    let link = Link::open(0, LinkConfig::new(server.tcp(), 115_200));
    wait_for_state(&link, LinkState::NotAnswering).await;
    let error = link.send(batch("*5;PV;")).await.unwrap_err();
    assert!(matches!(error, LinkError::Down { .. }), "{error}");
    // The connection stays; the gateway is powered on: the next greeting is answered.
    server.answering.store(true, Ordering::Release);
    wait_for_state(&link, LinkState::Up).await;
    assert_eq!(server.accepted().len(), 1);
}
