//! Benchmarks of the simulated gateway as the bridge drives it: 100 units (a full
//! gateway) playing 20 ms PVT rows, advanced in 1 ms steps.
//!
//! Run with `cargo bench -p floatball-shared --bench sim`. Every iteration simulates one
//! second (1000 steps), so the time per step is the reported time / 1000.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use floatball_shared::uim2503::feedback::{Feedback, FrameDecoder, Notification};
use floatball_shared::uim2503::sim::{Gateway, GatewayConfig};

const UNITS: u8 = 100;
const ROW_MS: u64 = 20;
const STEPS: u64 = 1000;

/// Row `k` of a ball bobbing 400 mm (at 100 counts/mm) every 2 s, from rest at the top:
/// at most 62 800 counts/s and 197 000 counts/s², inside the default limits.
fn row(k: u64) -> (i64, i64) {
    let omega = PI; // rad/s
    let amplitude = 20_000.0;
    let t = (k + 1) as f64 * ROW_MS as f64 / 1000.0;
    (
        (amplitude * (1.0 - (omega * t).cos())).round() as i64,
        (amplitude * omega * (omega * t).sin()).round() as i64,
    )
}

/// Appends rows `from..to` (row index k mod 256) for the selected station.
fn rows(text: &mut String, from: u64, to: u64) {
    for k in from..to {
        let (p, v) = row(k);
        let index = k % 256;
        let _ = write!(
            text,
            "QP[{index}]={p};QV[{index}]={v};QT[{index}]={ROW_MS};"
        );
    }
}

/// 100 units looping 100 rows (2 s), all started by one `*0;BG;`.
fn looping() -> Gateway {
    let mut gateway = Gateway::new(GatewayConfig::numbered(UNITS)).unwrap();
    let mut text = String::from("*0;MO=1;MP[3]=3;MP[1]=0;MP[2]=99;");
    rows(&mut text, 0, 100);
    text.push_str("PV=0;BG;");
    gateway.receive(0, text.as_bytes());
    gateway
}

/// A host that streams FIFO rows to 100 units: 200 rows ahead, 200 more at each
/// watermark notice (`MP[5]=20`).
struct Streaming {
    gateway: Gateway,
    decoder: FrameDecoder,
    written: Vec<u64>,
    output: Vec<u8>,
    text: String,
    now_us: u64,
}

impl Streaming {
    fn new() -> Self {
        let mut gateway = Gateway::new(GatewayConfig::numbered(UNITS)).unwrap();
        let mut text = String::from("*0;MO=1;MP[3]=0;MP[5]=20;MP[0]=1;");
        rows(&mut text, 0, 200);
        text.push_str("PV=0;BG;");
        gateway.receive(0, text.as_bytes());
        Self {
            gateway,
            decoder: FrameDecoder::new(),
            written: vec![200; usize::from(UNITS)],
            output: Vec::new(),
            text: String::new(),
            now_us: 0,
        }
    }

    /// One second in 1 ms steps, refilling every unit that asks.
    fn second(&mut self) {
        for _ in 0..STEPS {
            self.now_us += 1000;
            self.gateway.advance(self.now_us);
            self.output.clear();
            if self.gateway.poll_output(&mut self.output) == 0 {
                continue;
            }
            self.text.clear();
            let mut last_station = 0;
            for frame in self.decoder.push(&self.output) {
                let station = frame.station();
                let notice = Feedback::from_frame(&frame)
                    == Ok(Feedback::Notification(Notification::PVT_WATERMARK));
                // Three notices per watermark: refill once.
                if notice && station != last_station {
                    last_station = station;
                    let written = &mut self.written[usize::from(station) - 1];
                    let _ = write!(self.text, "*{station};");
                    rows(&mut self.text, *written, *written + 200);
                    *written += 200;
                }
            }
            self.gateway.receive(self.now_us, self.text.as_bytes());
        }
    }
}

fn advance(c: &mut Criterion) {
    let mut group = c.benchmark_group("sim, 100 units, 20 ms rows");
    group.throughput(Throughput::Elements(STEPS));
    let mut gateway = looping();
    let mut now_us = 0;
    group.bench_function("advance 1 ms x1000 (loop mode)", |b| {
        b.iter(|| {
            for _ in 0..STEPS {
                now_us += 1000;
                gateway.advance(black_box(now_us));
            }
        });
    });
    let mut streaming = Streaming::new();
    group.bench_function("advance 1 ms x1000, FIFO refilled at the watermark", |b| {
        b.iter(|| streaming.second());
    });
    assert!(
        streaming
            .gateway
            .units()
            .all(|unit| unit.moving && unit.motor_on),
        "every ball still streaming"
    );
    group.finish();

    let mut group = c.benchmark_group("sim, 100 units");
    group.throughput(Throughput::Elements(u64::from(UNITS)));
    let mut gateway = looping();
    gateway.advance(10_500);
    group.bench_function("read every unit's position, mid-row", |b| {
        b.iter(|| {
            black_box(&gateway)
                .units()
                .map(|unit| unit.position_counts)
                .sum::<f64>()
        });
    });
    group.finish();
}

criterion_group!(benches, advance);
criterion_main!(benches);
