//! E-stop latency while bulk streams at full line rate, over a real pseudo-terminal
//! and over TCP to a serial device server (`tcp://`).
//!
//! For each baud rate, a link streams PVT rows continuously; at random moments an
//! e-stop is sent and the time until its last byte is read on the far side is measured.
//! The floor is the instruction already on the wire plus the e-stop's own 8 bytes.
//! Over TCP the far side is a listener that drains the socket at the line's rate, as a
//! device server's UART does (a 16-byte FIFO: it takes 16 bytes, then is busy for
//! their line time), so whatever the bridge hands the socket ahead of the line would
//! show as latency.
//! Run with `cargo bench -p floatball-bridge --bench estop`.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::{Batch, Link, LinkConfig};
use floatball_shared::api::LinkState;
use floatball_shared::uim2503::ascii::{Form, parse_script};
use serialport::{SerialPort, TTYPort};

fn batch(script: &str) -> Batch {
    Batch::encode(&parse_script(script).expect("script"), Form::Standard).expect("encode")
}

fn rows(count: u32) -> Batch {
    let mut bulk = batch("*5;");
    for row in 0..count {
        let index = row % 256;
        bulk.extend(&batch(&format!(
            "QP[{index}]=-1234567;QV[{index}]=7654321;QT[{index}]=100;"
        )));
    }
    bulk
}

fn percentile(sorted: &[Duration], p: f64) -> Duration {
    let index = ((sorted.len() - 1) as f64 * p).round() as usize;
    sorted[index]
}

/// The gateway's end of the line.
trait FarEnd {
    /// Reads what has arrived (0 when nothing did).
    fn read_line(&mut self, buffer: &mut [u8]) -> usize;
    /// Writes the gateway's answer.
    fn answer(&mut self, bytes: &[u8]);
    /// The last bytes read, to find a greeting cut across reads.
    fn tail(&mut self) -> &mut Vec<u8>;

    /// Reads what has arrived, answering every greeting (a stalled run on a busy
    /// machine may leave the line idle long enough for the link to greet again).
    fn read(&mut self, buffer: &mut [u8]) -> usize {
        let n = self.read_line(buffer);
        let tail = self.tail();
        tail.extend_from_slice(&buffer[..n]);
        let greeted = tail.windows(4).any(|w| w == b"ABC;");
        let keep = tail.len().saturating_sub(3);
        tail.drain(..keep);
        if greeted {
            self.tail().clear();
            self.answer(&[0xAA, 0xAB, 0xAC]);
        }
        n
    }
}

/// The master side of a pseudo-terminal: the serial case.
struct Pty(TTYPort, Vec<u8>);

impl FarEnd for Pty {
    fn read_line(&mut self, buffer: &mut [u8]) -> usize {
        self.0.read(buffer).unwrap_or(0)
    }

    fn tail(&mut self) -> &mut Vec<u8> {
        &mut self.1
    }

    fn answer(&mut self, bytes: &[u8]) {
        self.0.write_all(bytes).expect("answer");
    }
}

/// A device server's socket drained at the line's rate through a 16-byte FIFO.
struct DeviceServer {
    stream: TcpStream,
    byte_time: Duration,
    uart_free_at: Instant,
    tail: Vec<u8>,
}

/// A UART's transmit FIFO.
const FIFO_BYTES: usize = 16;

/// How late a read may come after the UART went free and still count as streaming.
const STREAMING_GAP: Duration = Duration::from_millis(3);

impl FarEnd for DeviceServer {
    fn tail(&mut self) -> &mut Vec<u8> {
        &mut self.tail
    }

    fn read_line(&mut self, buffer: &mut [u8]) -> usize {
        let now = Instant::now();
        if now < self.uart_free_at {
            std::thread::sleep((self.uart_free_at - now).min(Duration::from_millis(1)));
            return 0;
        }
        let take = buffer.len().min(FIFO_BYTES);
        match self.stream.read(&mut buffer[..take]) {
            Ok(n) => {
                // A UART streaming without a gap keeps its own clock (this thread's
                // oversleeping is not the line's); one that was idle starts now.
                let start = if now <= self.uart_free_at + STREAMING_GAP {
                    self.uart_free_at
                } else {
                    Instant::now()
                };
                self.uart_free_at = start + self.byte_time * n as u32;
                n
            }
            Err(_) => 0,
        }
    }

    fn answer(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).expect("answer");
    }
}

/// Which far end a measurement uses.
#[derive(Clone, Copy)]
enum Via {
    Pty,
    Tcp,
}

fn measure(runtime: &tokio::runtime::Runtime, via: Via, baud: u32, samples: usize) {
    let byte_time = floatball_shared::line::Line::new(baud).byte_time();
    let (link, mut master): (Link, Box<dyn FarEnd>) = match via {
        Via::Pty => {
            let (mut master, slave) = TTYPort::pair().expect("pty pair");
            let path = slave.name().expect("slave name");
            drop(slave);
            master
                .set_timeout(Duration::from_millis(5))
                .expect("timeout");
            (
                Link::open(0, LinkConfig::new(path, baud)),
                Box::new(Pty(master, Vec::new())),
            )
        }
        Via::Tcp => {
            let listener = TcpListener::bind("127.0.0.1:0").expect("listener");
            let port = listener.local_addr().expect("address").port();
            let link = Link::open(0, LinkConfig::new(format!("tcp://127.0.0.1:{port}"), baud));
            let (stream, _) = listener.accept().expect("the link connects");
            stream
                .set_read_timeout(Some(Duration::from_millis(1)))
                .expect("timeout");
            let server = DeviceServer {
                stream,
                byte_time,
                uart_free_at: Instant::now(),
                tail: Vec::new(),
            };
            (link, Box::new(server))
        }
    };
    // The gateway's part of the greeting: the link is up once it is answered.
    let mut buffer = [0u8; 4096];
    runtime.block_on(async {
        let mut status = link.status();
        while status.borrow_and_update().state != LinkState::Up {
            let _ = master.read(&mut buffer);
            let _ = tokio::time::timeout(Duration::from_millis(5), status.changed()).await;
        }
    });
    let mut latencies = Vec::with_capacity(samples);
    let mut seed = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..samples {
        // The last sample's e-stop is still latched: a new request releases it.
        link.latch().release(link.latch().generation());
        runtime.block_on(link.send(rows(200))).expect("queue bulk");
        // Let the line stream for a pseudo-random 20..120 instruction times.
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        let warmup = byte_time * 20 * (20 + (seed % 100) as u32);
        let until = Instant::now() + warmup;
        while Instant::now() < until {
            let _ = master.read(&mut buffer);
        }
        let sent = Instant::now();
        assert_eq!(link.estop(), None, "the link is up");
        let mut seen = Vec::new();
        loop {
            let n = master.read(&mut buffer);
            seen.extend_from_slice(&buffer[..n]);
            if seen.windows(8).any(|w| w == b"*0;MO=0;") {
                break;
            }
        }
        latencies.push(sent.elapsed());
        // Drain what is left so the next sample starts from an idle line.
        let quiet = Instant::now() + Duration::from_millis(50);
        while Instant::now() < quiet {
            let _ = master.read(&mut buffer);
        }
    }
    latencies.sort();
    let instruction = byte_time * 20;
    println!(
        "e-stop latency {:<6} at {baud:>6} baud over {samples} samples: min {:?}, median {:?}, p99 {:?}, max {:?} \
         (one 20-byte instruction takes {:?}; the e-stop itself {:?})",
        match via {
            Via::Pty => "pty",
            Via::Tcp => "tcp://",
        },
        latencies[0],
        percentile(&latencies, 0.5),
        percentile(&latencies, 0.99),
        latencies[latencies.len() - 1],
        instruction,
        byte_time * 8,
    );
}

fn main() {
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .expect("runtime");
    if std::env::args().any(|arg| arg == "--test") {
        // `cargo test --benches` runs this as a smoke test: a few samples only.
        measure(&runtime, Via::Pty, 115_200, 3);
        measure(&runtime, Via::Tcp, 115_200, 3);
        return;
    }
    for via in [Via::Pty, Via::Tcp] {
        measure(&runtime, via, 9600, 100);
        measure(&runtime, via, 115_200, 200);
    }
}
