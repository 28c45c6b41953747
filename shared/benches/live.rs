//! Live input's motion filter: the largest position error of the filter against its
//! unfiltered input over a 60 s random-fader run at 50 steps/s (printed first), and
//! what one step costs per ball (criterion).
//!
//! Run with `cargo bench -p floatball-shared --bench live`.
//!
//! The faders: a DMX console's fader (16-bit, quantised as the patch reads it) moving
//! from level to level in ramps of 0.3–5 s, as a hand does, sometimes much faster than
//! a ball may move; and the same kind of run with every ramp slow enough for the
//! balls (at most half the top speed). The error is |filtered − input| at each step;
//! the filter tracks a target it must be able to stop on, so even within the limits it
//! runs behind a moving fader by about its braking distance.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use floatball_shared::live::filter::{BallState, FilterLimits, MotionFilter};
use floatball_shared::uim2503::sim::noise::SplitMix;

/// The default limits at a 20 ms step (7.5 m of travel, 2 m/s, 4 m/s²).
const LIMITS: FilterLimits = FilterLimits::default_at(20);

/// 60 s at 50 steps/s.
const STEPS: usize = 3000;

fn unit(rng: &mut SplitMix) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// A fader's positions, mm, one per step: ramps from level to level; `max_speed_mm_s`
/// caps the ramps' speed (infinite: any ramp of 0.3–5 s).
fn fader(seed: u64, max_speed_mm_s: f64) -> Vec<f64> {
    let mut rng = SplitMix::new(seed);
    let dt = f64::from(LIMITS.dt_ms) / 1000.0;
    let mut positions = Vec::with_capacity(STEPS);
    let mut at = unit(&mut rng) * LIMITS.travel_mm;
    while positions.len() < STEPS {
        let to = unit(&mut rng) * LIMITS.travel_mm;
        let mut seconds = 0.3 + 4.7 * unit(&mut rng);
        seconds = seconds.max((to - at).abs() / max_speed_mm_s);
        let steps = (seconds / dt).ceil() as usize;
        for step in 1..=steps {
            let value = at + (to - at) * step as f64 / steps as f64;
            // As the patch reads a 16-bit position.
            let dmx = (value / LIMITS.travel_mm * 65535.0).round();
            positions.push(dmx / 65535.0 * LIMITS.travel_mm);
        }
        // A pause at the level.
        for _ in 0..(unit(&mut rng) * 100.0) as usize {
            positions.push(*positions.last().unwrap_or(&to));
        }
        at = to;
    }
    positions.truncate(STEPS);
    positions
}

/// Largest and RMS error of the filter over `input`, mm.
fn errors(filter: &MotionFilter, input: &[f64]) -> (f64, f64) {
    let mut state = BallState::at_rest(input[0]);
    let (mut largest, mut squares) = (0.0f64, 0.0);
    for &target in input {
        filter.step(&mut state, Some(target), None);
        let error = (state.position_mm - target).abs();
        largest = largest.max(error);
        squares += error * error;
    }
    (largest, (squares / input.len() as f64).sqrt())
}

fn figures() {
    let filter = MotionFilter::new(LIMITS).expect("limits");
    println!(
        "live filter: v_max {} mm/s, a_max {} mm/s², travel {} mm, {} ms steps, 60 s runs, 100 seeds",
        LIMITS.max_speed_mm_s, LIMITS.max_accel_mm_s2, LIMITS.travel_mm, LIMITS.dt_ms
    );
    for (name, cap) in [
        ("random fader (ramps of 0.3-5 s)", f64::INFINITY),
        (
            "fader within the limits (<= v_max/2)",
            LIMITS.max_speed_mm_s / 2.0,
        ),
    ] {
        let (mut largest, mut rms) = (0.0f64, 0.0f64);
        for seed in 0..100 {
            let (l, r) = errors(&filter, &fader(seed, cap));
            largest = largest.max(l);
            rms = rms.max(r);
        }
        println!("  {name}: largest error {largest:.1} mm, worst run's RMS {rms:.1} mm");
    }
    // Cost per ball-step, 10,000 balls.
    let mut states: Vec<BallState> = (0..10_000)
        .map(|ball| BallState::at_rest(f64::from(ball % 7500)))
        .collect();
    let input = fader(7, f64::INFINITY);
    let started = Instant::now();
    for target in &input[..500] {
        for state in &mut states {
            filter.step(state, Some(*target), None);
        }
    }
    let per_step_us = started.elapsed().as_secs_f64() * 1e6 / (500.0 * 10_000.0);
    println!("  cost: {per_step_us:.3} µs per ball-step (10,000 balls × 500 steps)");
}

fn step(c: &mut Criterion) {
    figures();
    let filter = MotionFilter::new(LIMITS).expect("limits");
    let input = fader(3, f64::INFINITY);
    let mut group = c.benchmark_group("live filter");
    group.throughput(Throughput::Elements(10_000));
    group.bench_function("step of 10000 balls", |b| {
        let mut states: Vec<BallState> = (0..10_000)
            .map(|ball| BallState::at_rest(f64::from(ball % 7500)))
            .collect();
        let mut at = 0;
        b.iter(|| {
            at = (at + 1) % input.len();
            for (ball, state) in states.iter_mut().enumerate() {
                let target = input[(at + ball) % input.len()];
                filter.step(state, Some(black_box(target)), None);
            }
        });
    });
    group.finish();
}

criterion_group!(benches, step);
criterion_main!(benches);
