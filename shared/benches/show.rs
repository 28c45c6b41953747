//! Benchmarks of the show module: sampling for the preview (goal: at least 200 M
//! ball-samples/s natively), CSV import (goal: 100 balls × 6,000 frames within 0.5 s)
//! and rendering a generated show (issue 19: the Create page regenerates its preview
//! on every change; goal in the browser: 10 × 10 within 16 ms, 100 × 100 within
//! 100 ms).
//!
//! Run with `cargo bench -p floatball-shared --bench show`.

use std::f64::consts::TAU;
use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use floatball_shared::show::demo::Wave;
use floatball_shared::show::{ColourKey, Layout, Sampler, Show, import_csv};

/// A travelling wave over a `rows` × `cols` matrix: 100 ms rows for `seconds`, red to
/// blue.
fn wave(rows: u32, cols: u32, seconds: u32) -> Show {
    let mut show = Wave {
        amplitude_mm: 2000.0,
        col_phase: TAU / 97.0,
        row_phase: f64::from(cols) * TAU / 97.0,
        tenths: false,
        ..Wave::new(rows, cols, seconds as usize * 10, 100)
    }
    .show();
    for track in &mut show.tracks {
        track.colours = vec![
            ColourKey {
                time_ms: 0,
                rgb: [255, 0, 0],
            },
            ColourKey {
                time_ms: u64::from(seconds) * 1000,
                rgb: [0, 0, 255],
            },
        ];
    }
    show
}

fn sample(c: &mut Criterion) {
    const SECONDS: u32 = 20;
    let show = wave(100, 100, SECONDS);
    let units = show.tracks.len();
    let mut group = c.benchmark_group("sample");
    group.throughput(Throughput::Elements(units as u64));

    // A preview playing at 60 frames a second, looping over the show.
    let mut sampler = Sampler::new(&show);
    let mut positions_mm = vec![0.0f32; units];
    let mut colours = vec![[0u8; 3]; units];
    let mut frame = 0u32;
    let frames = SECONDS * 60;
    group.bench_function("10000 balls, 60 fps", |b| {
        b.iter(|| {
            frame = (frame + 1) % frames;
            let t_ms = f64::from(frame) * 1000.0 / 60.0;
            sampler.sample(black_box(t_ms), &mut positions_mm, None);
        });
    });
    group.bench_function("10000 balls with colours, 60 fps", |b| {
        b.iter(|| {
            frame = (frame + 1) % frames;
            let t_ms = f64::from(frame) * 1000.0 / 60.0;
            sampler.sample(black_box(t_ms), &mut positions_mm, Some(&mut colours));
        });
    });
    // A paused preview redrawing the same frame: evaluation only, no cursor moves.
    group.bench_function("10000 balls, paused", |b| {
        b.iter(|| {
            sampler.sample(black_box(1234.0), &mut positions_mm, None);
        });
    });
    // Scrubbing: every call jumps somewhere else.
    let mut seed = 12345u64;
    group.bench_function("10000 balls, random seeks", |b| {
        b.iter(|| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            let t_ms = (seed >> 11) as f64 / (1u64 << 53) as f64 * f64::from(SECONDS) * 1000.0;
            sampler.sample(black_box(t_ms), &mut positions_mm, None);
        });
    });
    group.finish();
}

fn csv(c: &mut Criterion) {
    const UNITS: usize = 100;
    const FRAMES: usize = 6000;
    let header: Vec<_> = (0..UNITS).map(|u| format!("u{u}")).collect();
    let mut text = format!(
        "# rows=10 cols=10 pitch_mm=500\ntime_ms,{}\n",
        header.join(",")
    );
    for frame in 0..FRAMES {
        // 30 fps as 3D tools export it.
        let t_ms = frame as f64 * 1000.0 / 30.0;
        text.push_str(&format!("{t_ms:.3}"));
        for unit in 0..UNITS {
            let phase = TAU * (frame as f64 / 120.0 + unit as f64 / 17.0);
            text.push_str(&format!(",{:.2}", 3000.0 + 2500.0 * phase.sin()));
        }
        text.push('\n');
    }
    let installation = Layout {
        rows: 10,
        cols: 10,
        pitch_mm: 500.0,
    };
    let mut group = c.benchmark_group("csv");
    group.sample_size(10);
    group.throughput(Throughput::Bytes(text.len() as u64));
    group.bench_function("import 100 balls x 6000 frames", |b| {
        b.iter_batched(
            || (),
            |()| import_csv("bench", black_box(&text), installation),
            BatchSize::SmallInput,
        );
    });
    group.finish();
}

/// Rendering a 60 s recipe of the default wave, as the Create page does on every change
/// of a parameter.
fn render(c: &mut Criterion) {
    use floatball_shared::create::{self, Grid, Params, Recipe};
    use floatball_shared::show::Limits;
    let mut group = c.benchmark_group("create");
    group.sample_size(10);
    for side in [10u32, 100] {
        let grid = Grid::new(side, side, 500.0, 7500.0);
        let limits = Limits::for_layout(side, side);
        let recipe = Recipe::single("bench", "wave", Params::new(), 60.0);
        group.throughput(Throughput::Elements(u64::from(side * side)));
        group.bench_function(format!("render {side}x{side} 60 s wave"), |b| {
            b.iter(|| create::render(black_box(&recipe), &grid, &limits));
        });
    }
    group.finish();
}

criterion_group!(benches, sample, csv, render);
criterion_main!(benches);
