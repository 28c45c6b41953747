//! Planner figures: bytes on the wire per row against the naive form
//! `*N;QP[X]=…;QV[X]=…;QT[X]=…;` for a 100-unit wave, and how long planning and the
//! bandwidth report take. Run with `cargo bench -p floatball-shared --bench plan`.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, criterion_group, criterion_main};
use floatball_shared::plan::Installation;
use floatball_shared::plan::report::report_for;
use floatball_shared::show::Show;
use floatball_shared::show::demo::Wave;
use floatball_shared::uim2503::plan::{Plan, PlanOptions};
use floatball_shared::uim2503::schedule::ROUND_ROWS;
use floatball_shared::uim2503::stream;

/// A wave across 10 × 10 balls, 600 rows of 250 ms each (150 s).
fn wave() -> Show {
    Wave {
        amplitude_mm: 1500.0,
        period_s: 8.0,
        ..Wave::new(10, 10, 600, 250)
    }
    .show()
}

fn installation() -> Installation {
    Installation::demo(10, 10, &[115_200]).expect("installation")
}

fn figures() {
    let show = wave();
    let installation = installation();
    let started = Instant::now();
    let plan = Plan::new(&show, &installation, PlanOptions::default()).expect("plan");
    let planned = started.elapsed();
    let run = &plan.gateways[0];
    let rows = run.units.len() * plan.units[0].rows.len();
    let mut ours = 0usize;
    let mut row = 0;
    while row < 600 {
        ours += stream::rows(&plan, run, row, (row + ROUND_ROWS).min(600)).len();
        row += ROUND_ROWS;
    }
    let naive = stream::naive_bytes(&plan, run);
    let report = report_for(&plan, &installation);
    let gateway = &report.gateways[0];
    println!(
        "wave of 100 units × 600 rows: {:.2} bytes per row vs {:.2} naive = {:.3}× (goal ≤ 0.75×); \
         planning took {planned:?}; at 115200 baud it needs {:.0} of {:.0} B/s, preloads {} rows per ball \
         ({} bytes, {:.1} s), lowest water level {:?}, feasible: {}",
        ours as f64 / rows as f64,
        naive as f64 / rows as f64,
        ours as f64 / naive as f64,
        gateway.needed_bytes_per_s,
        gateway.available_bytes_per_s,
        run.preload_rows,
        gateway.preload_bytes,
        gateway.preload_ms as f64 / 1000.0,
        gateway.lowest_water_level,
        report.feasible,
    );
}

fn benches(c: &mut Criterion) {
    figures();
    let show = wave();
    let installation = installation();
    c.bench_function("plan a 100-unit, 600-row show", |b| {
        b.iter(|| Plan::new(black_box(&show), &installation, PlanOptions::default()))
    });
    let plan = Plan::new(&show, &installation, PlanOptions::default()).expect("plan");
    c.bench_function("bandwidth report for it", |b| {
        b.iter(|| report_for(black_box(&plan), &installation))
    });
    c.bench_function("encode one 16-row round for 100 units", |b| {
        b.iter(|| stream::rows(&plan, &plan.gateways[0], black_box(256), 272))
    });
}

criterion_group! {
    name = plan;
    config = Criterion::default().sample_size(10);
    targets = benches
}
criterion_main!(plan);
