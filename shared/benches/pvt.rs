//! Benchmarks of the PVT evaluator and a unit's table: what the simulator pays per unit
//! and tick, and what the planner pays to predict FIFO water levels.
//!
//! Run with `cargo bench -p floatball-shared --bench pvt`.

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use floatball_shared::motion::Segment;
use floatball_shared::uim2503::pvt::PvtTable;

fn segment(c: &mut Criterion) {
    let row = Segment::new(0.0, 0.0, 1000.0, 8000.0, 0.1);
    let mut group = c.benchmark_group("segment");
    group.throughput(Throughput::Elements(1000));
    group.bench_function("kinematics x1000", |b| {
        b.iter(|| {
            let mut sum = 0.0;
            for i in 0..1000 {
                sum += black_box(&row).kinematics(f64::from(i) * 1e-4).position;
            }
            sum
        });
    });
    group.finish();
}

/// A FIFO run as the player streams it: refill at the watermark, 1 ms simulator ticks.
fn fifo(c: &mut Criterion) {
    const ROWS: u32 = 10_000;
    let mut group = c.benchmark_group("table");
    group.throughput(Throughput::Elements(u64::from(ROWS)));
    group.bench_function("FIFO run of 10000 rows of 20 ms, 1 ms ticks", |b| {
        b.iter(|| {
            let mut table = PvtTable::new(100_000.0);
            table.set_mp(5, 10).ok();
            let mut written = 0u32;
            let write = |table: &mut PvtTable, written: &mut u32| {
                while *written < ROWS && table.water_level() < 250 {
                    let index = (*written % 256) as u8;
                    table.write_position(index, (*written % 1000) as i32);
                    table.write_velocity(index, 0);
                    table.write_time(index, 20).ok();
                    *written += 1;
                }
            };
            write(&mut table, &mut written);
            table.begin(0.0, 0.0).ok();
            let mut now_us = 0;
            while table.is_moving() {
                now_us += 1000;
                let events = table.advance(now_us);
                if events.watermark.is_some() {
                    write(&mut table, &mut written);
                }
                black_box(table.state_at(now_us));
            }
            written
        });
    });
    group.finish();
}

criterion_group!(benches, segment, fifo);
criterion_main!(benches);
