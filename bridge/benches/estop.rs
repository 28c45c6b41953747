//! E-stop latency while bulk streams at full line rate, over a real pseudo-terminal.
//!
//! For each baud rate, a link streams PVT rows continuously; at random moments an
//! e-stop is sent and the time until its last byte is read on the far side is measured.
//! The floor is the instruction already on the wire plus the e-stop's own 8 bytes.
//! Run with `cargo bench -p floatball-bridge --bench estop`.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use floatball_bridge::link::{Batch, Link, LinkConfig};
use floatball_shared::api::LinkState;
use floatball_shared::ascii::{Form, parse_script};
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

fn measure(runtime: &tokio::runtime::Runtime, baud: u32, samples: usize) {
    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    let path = slave.name().expect("slave name");
    drop(slave);
    master
        .set_timeout(Duration::from_millis(5))
        .expect("timeout");
    let link = Link::open(0, LinkConfig::new(path, baud));
    // The gateway's part of the greeting: the link is up once it is answered (the
    // samples follow each other too closely for the idle greeting to come again).
    let mut greeting = Vec::new();
    let mut buffer = [0u8; 4096];
    while !greeting.windows(4).any(|w| w == b"ABC;") {
        if let Ok(n) = master.read(&mut buffer) {
            greeting.extend_from_slice(&buffer[..n]);
        }
    }
    master
        .write_all(&[0xAA, 0xAB, 0xAC])
        .expect("answer the greeting");
    runtime.block_on(async {
        let mut status = link.status();
        status
            .wait_for(|s| s.state == LinkState::Up)
            .await
            .expect("link up");
    });
    let byte_time = floatball_shared::line::Line::new(baud).byte_time();
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
            if let Ok(n) = master.read(&mut buffer) {
                seen.extend_from_slice(&buffer[..n]);
                if seen.windows(8).any(|w| w == b"*0;MO=0;") {
                    break;
                }
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
        "e-stop latency at {baud:>6} baud over {samples} samples: min {:?}, median {:?}, p99 {:?}, max {:?} \
         (one 20-byte instruction takes {:?}; the e-stop itself {:?})",
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
        measure(&runtime, 115_200, 3);
        return;
    }
    measure(&runtime, 9600, 100);
    measure(&runtime, 115_200, 200);
}
