//! Codec throughput: instruction encoding and parsing, feedback frame decoding.
//!
//! The workload is what a show streams: 256 PVT rows (`QP`/`QV`/`QT`) for each of 10
//! stations, with their `*N;` selections, and the ACK frames that answer them.
//! Run with `cargo bench -p floatball-shared --bench codec`.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use floatball_shared::uim2503::ascii::{Form, Instruction, InstructionReader, parse_script};
use floatball_shared::uim2503::feedback::{Ack, Frame, FrameDecoder};

/// The instructions of a 10-station, 256-row PVT upload.
fn pvt_stream() -> Vec<Instruction> {
    let mut instructions = Vec::new();
    for station in 1..=10_u8 {
        instructions.push(Instruction::Select { station });
        for row in 0..=255_u8 {
            let position_counts = i32::from(row) * 1_000 - 120_000 + i32::from(station);
            instructions.push(Instruction::PvtPosition {
                row,
                position_counts: Some(position_counts),
            });
            instructions.push(Instruction::PvtVelocity {
                row,
                velocity_counts_s: Some(-9_000 + i32::from(row) * 70),
            });
            instructions.push(Instruction::PvtTime {
                row,
                duration_ms: Some(100),
            });
        }
    }
    instructions
}

/// The ACK frames that answer [`pvt_stream`], on the wire.
fn ack_wire(instructions: &[Instruction]) -> Vec<u8> {
    let mut wire = Vec::new();
    for instruction in instructions {
        let ack = match *instruction {
            Instruction::PvtPosition {
                row,
                position_counts,
            } => Ack::PvtPosition {
                row: row.into(),
                position_counts: position_counts.unwrap_or_default(),
            },
            Instruction::PvtVelocity {
                row,
                velocity_counts_s,
            } => Ack::PvtVelocity {
                row: row.into(),
                velocity_counts_s: velocity_counts_s.unwrap_or_default(),
            },
            Instruction::PvtTime { row, duration_ms } => Ack::PvtTime {
                row: row.into(),
                duration_ms: duration_ms.unwrap_or_default(),
            },
            _ => continue,
        };
        ack.to_frame(20).unwrap().encode_into(&mut wire);
    }
    wire
}

/// Deterministic noise: bytes of every class, so the decoder drops and resyncs a lot.
fn noise(len: usize) -> Vec<u8> {
    let mut state = 0x2545_F491_4F6C_DD1D_u64;
    (0..len)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        })
        .collect()
}

fn encode(c: &mut Criterion) {
    let instructions = pvt_stream();
    let mut group = c.benchmark_group("encode");
    group.throughput(Throughput::Elements(instructions.len() as u64));
    for (name, form) in [("standard", Form::Standard), ("compact", Form::Compact)] {
        let mut out = Vec::with_capacity(64 * 1024);
        group.bench_function(name, |b| {
            b.iter(|| {
                out.clear();
                for instruction in black_box(&instructions) {
                    instruction.encode_into(form, &mut out).unwrap();
                }
                black_box(out.len())
            });
        });
    }
    group.bench_function("encoded_len", |b| {
        b.iter(|| {
            black_box(&instructions)
                .iter()
                .map(|instruction| instruction.encoded_len(Form::Compact))
                .sum::<usize>()
        });
    });
    group.finish();
}

fn parse(c: &mut Criterion) {
    let instructions = pvt_stream();
    let mut script = String::new();
    let mut compact = Vec::new();
    for instruction in &instructions {
        script.push_str(&instruction.to_string());
        script.push('\n');
        instruction
            .encode_into(Form::Compact, &mut compact)
            .unwrap();
    }
    assert_eq!(parse_script(&script).unwrap(), instructions);

    let mut group = c.benchmark_group("parse");
    group.throughput(Throughput::Bytes(script.len() as u64));
    group.bench_function("script", |b| {
        b.iter(|| parse_script(black_box(&script)).unwrap().len());
    });
    group.throughput(Throughput::Bytes(compact.len() as u64));
    group.bench_function("reader", |b| {
        b.iter(|| {
            let mut reader = InstructionReader::new();
            reader
                .push(black_box(&compact))
                .filter(Result::is_ok)
                .count()
        });
    });
    group.finish();
}

fn decode(c: &mut Criterion) {
    let instructions = pvt_stream();
    let frames = ack_wire(&instructions);
    let garbage = noise(64 * 1024);

    let mut group = c.benchmark_group("decode");
    group.throughput(Throughput::Bytes(frames.len() as u64));
    group.bench_function("frames", |b| {
        b.iter(|| FrameDecoder::new().push(black_box(&frames)).count());
    });
    group.throughput(Throughput::Bytes(garbage.len() as u64));
    group.bench_function("noise", |b| {
        b.iter(|| FrameDecoder::new().push(black_box(&garbage)).count());
    });
    let decoded: Vec<Frame> = FrameDecoder::new().push(&frames).collect();
    group.throughput(Throughput::Elements(decoded.len() as u64));
    let mut out = Vec::with_capacity(frames.len());
    group.bench_function("encode_frames", |b| {
        b.iter(|| {
            out.clear();
            for frame in black_box(&decoded) {
                frame.encode_into(&mut out);
            }
            black_box(out.len())
        });
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    targets = encode, parse, decode
}
criterion_main!(benches);
