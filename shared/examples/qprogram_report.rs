//! The Q program compiler on a 10-minute show, every ball: what it keeps and how far it
//! strays from the show, and how long it takes. Run by `cargo xtask qprogram-report`
//! (release build); prints figures, asserts nothing.
//!
//! `qprogram_report [--rows R] [--cols C] [--minutes M] [--period-s P] [--row-ms MS]
//! [--amplitude-mm A] [--from-rest 1]`: the demo wave (`show::demo`) on R × C balls (default 10 × 10)
//! for M minutes (default 10), one wave every P s (default 4, the standard wave), rows
//! of MS ms (default 200), swinging ±A mm (default 500); with `--from-rest 1` every
//! ball swings the same sine from rest at its top instead (no abrupt start); compiled with the default `QProgramConfig` except the tolerance,
//! which is lifted so that every ball reports its figure instead of being refused.

use std::time::Instant;

use floatball_shared::scl::qprogram::{QProgramConfig, compile};
use floatball_shared::show::TrackRow;
use floatball_shared::show::demo::Wave;

fn main() {
    let mut rows = 10_u32;
    let mut cols = 10_u32;
    let mut minutes = 10.0_f64;
    let mut period_s = 4.0_f64;
    let mut row_ms = 200_u32;
    let mut amplitude_mm = None;
    let mut from_rest = false;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut pairs = args.chunks(2);
    while let Some([flag, value]) = pairs.next() {
        let number: f64 = match value.parse() {
            Ok(number) => number,
            Err(_) => return eprintln!("{flag} needs a number"),
        };
        match flag.as_str() {
            "--rows" => rows = number as u32,
            "--cols" => cols = number as u32,
            "--minutes" => minutes = number,
            "--period-s" => period_s = number,
            "--row-ms" => row_ms = number as u32,
            "--amplitude-mm" => amplitude_mm = Some(number),
            "--from-rest" => from_rest = number != 0.0,
            _ => return eprintln!("unknown option {flag}"),
        }
    }
    let rows_per_ball = (minutes * 60_000.0 / f64::from(row_ms)).round() as usize;
    let standard = Wave::new(rows, cols, rows_per_ball, row_ms);
    let amplitude_mm = amplitude_mm.unwrap_or(standard.amplitude_mm);
    let mut show = Wave {
        period_s,
        amplitude_mm,
        ..standard
    }
    .show();
    if from_rest {
        // Every ball the same sine, starting (and, over whole periods, ending) at rest
        // at the top of its swing: a wave within the limits from its first row.
        let omega = std::f64::consts::TAU / period_s;
        for track in &mut show.tracks {
            track.start_mm = standard.centre_mm - amplitude_mm;
            for (index, row) in track.rows.iter_mut().enumerate() {
                let t_s = (index + 1) as f64 * f64::from(row_ms) / 1000.0;
                *row = TrackRow::new(
                    standard.centre_mm - amplitude_mm * (omega * t_s).cos(),
                    amplitude_mm * omega * (omega * t_s).sin(),
                    row_ms,
                );
            }
        }
    }
    let config = QProgramConfig {
        tolerance_mm: f64::INFINITY,
        ..QProgramConfig::default()
    };
    println!(
        "show: {rows} x {cols} balls, {} PVT rows of {row_ms} ms each ({:.1} min), wave period {period_s} s",
        rows_per_ball,
        show.duration_ms() as f64 / 60_000.0
    );
    println!("ball  rows  moves  lines  segments  max_dev_mm  at_ms    compile_ms");
    let mut total_ms = 0.0;
    let mut slowest_ms: f64 = 0.0;
    let mut worst = (0.0_f64, 0_usize, 0_u64);
    let (mut least_moves, mut most_moves) = (usize::MAX, 0);
    let (mut least_lines, mut most_lines) = (usize::MAX, 0);
    let (mut least_segments, mut most_segments) = (usize::MAX, 0);
    for (ball, track) in show.tracks.iter().enumerate() {
        let started = Instant::now();
        let result = compile(track, &config);
        let ms = started.elapsed().as_secs_f64() * 1000.0;
        total_ms += ms;
        slowest_ms = slowest_ms.max(ms);
        match result {
            Ok(program) => {
                let report = program.report;
                if ball < 5 || ball + 1 == show.tracks.len() {
                    println!(
                        "{ball:>4}  {:>4}  {:>5}  {:>5}  {:>8}  {:>10.1}  {:>7}  {ms:>8.1}",
                        report.track_rows,
                        report.moves,
                        report.lines,
                        program.segments.len(),
                        report.max_deviation_mm,
                        report.at_ms
                    );
                }
                if report.max_deviation_mm > worst.0 {
                    worst = (report.max_deviation_mm, ball, report.at_ms);
                }
                least_moves = least_moves.min(report.moves);
                most_moves = most_moves.max(report.moves);
                least_lines = least_lines.min(report.lines);
                most_lines = most_lines.max(report.lines);
                least_segments = least_segments.min(program.segments.len());
                most_segments = most_segments.max(program.segments.len());
            }
            Err(error) => println!("{ball:>4}  refused: {error}"),
        }
    }
    println!(
        "all {} balls: moves {least_moves}..={most_moves}, lines {least_lines}..={most_lines}, \
         segments {least_segments}..={most_segments}; \
         largest deviation {:.1} mm (ball {}, at {} ms); compile {:.0} ms in all, \
         {:.1} ms a ball on average, {slowest_ms:.1} ms the slowest",
        show.tracks.len(),
        worst.0,
        worst.1,
        worst.2,
        total_ms,
        total_ms / show.tracks.len().max(1) as f64
    );
}
