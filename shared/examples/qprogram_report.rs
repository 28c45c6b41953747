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
//!
//! `--stream 1`: every ball streamed instead (`compile_streamed`: the jog every
//! 50 ms, any length), and each stream played on a drive twin the way the bridge
//! feeds it (`PS`, the buffer filled, `CT`, then `BS` and the next lines every
//! 150 ms, never more than the 63 places): the largest distance between the twin's
//! ball and the show, sampled every 10 ms, over the whole show, from the end of its
//! first period to its last second (a demo wave starts at speed and stops dead in
//! its last row, which no drive follows), and past its end; and the line budget (drives per line at 9600 and 115200 baud, and per
//! eSCL gateway entry).

use std::time::Instant;

use floatball_shared::scl::drive::{SclLine, stream_budget};
use floatball_shared::scl::qprogram::{
    QProgram, QProgramConfig, STREAM_STEP_S, compile, compile_streamed,
};
use floatball_shared::scl::twin::{Drive, DriveConfig};
use floatball_shared::show::TrackRow;
use floatball_shared::show::demo::Wave;
use floatball_shared::show::sample::Sampler;

fn main() {
    let mut rows = 10_u32;
    let mut cols = 10_u32;
    let mut minutes = 10.0_f64;
    let mut period_s = 4.0_f64;
    let mut row_ms = 200_u32;
    let mut amplitude_mm = None;
    let mut from_rest = false;
    let mut stream = false;
    let mut from_s = None;
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
            "--stream" => stream = number != 0.0,
            "--from-s" => from_s = Some(number),
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
    if stream {
        // Started by `CT`, not an input.
        let config = QProgramConfig {
            start: None,
            ..config
        };
        return streamed(&show, &config, from_s.unwrap_or(period_s));
    }
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

/// Every ball streamed and played on a twin fed as the bridge feeds it.
fn streamed(show: &floatball_shared::show::Show, config: &QProgramConfig, period_s: f64) {
    for (name, line) in [
        ("RS-485 at 9600 baud", SclLine::Rs485 { baud: 9_600 }),
        ("RS-485 at 115200 baud", SclLine::Rs485 { baud: 115_200 }),
        ("an eSCL gateway entry", SclLine::Escl),
    ] {
        let budget = stream_budget(line, STREAM_STEP_S);
        println!(
            "line budget, {name}: {} drives ({:.0} exchanges/s carried, {:.0} a drive)",
            budget.drives, budget.exchanges_per_s, budget.exchanges_per_s_per_drive
        );
    }
    println!(
        "ball  lines  model_dev_mm at_ms  twin_dev_mm  mid_show_mm  after_end_mm  \
         compile_ms  play_ms"
    );
    let mut sampler = Sampler::new(show);
    let mut show_mm = vec![0.0_f32; show.tracks.len()];
    let (mut worst, mut worst_after, mut most_lines) = (0.0_f64, 0.0_f64, 0);
    let mut worst_overshoot = 0.0_f64;
    let mut worst_after_at = (0, 0);
    for (ball, track) in show.tracks.iter().enumerate() {
        let started = Instant::now();
        let program = match compile_streamed(track, config) {
            Ok(program) => program,
            Err(error) => {
                println!("{ball:>4}  refused: {error}");
                continue;
            }
        };
        let compile_ms = started.elapsed().as_secs_f64() * 1000.0;
        let started = Instant::now();
        let (all, (after, after_at_ms), overshoot) = play(
            &program,
            track.start_mm,
            config,
            |t_ms| {
                sampler.sample(t_ms, &mut show_mm, None);
                f64::from(show_mm[ball])
            },
            period_s,
            show.duration_ms(),
        );
        let play_ms = started.elapsed().as_secs_f64() * 1000.0;
        worst = worst.max(all);
        if after > worst_after {
            worst_after_at = (ball, after_at_ms);
        }
        worst_after = worst_after.max(after);
        worst_overshoot = worst_overshoot.max(overshoot);
        most_lines = most_lines.max(program.lines());
        if ball < 5 || ball + 1 == show.tracks.len() {
            println!(
                "{ball:>4}  {:>5}  {:>5.1} at {:>6}  {:>11.1}  {:>20.1}  {:>12.1}  \
                 {compile_ms:>10.0}  {play_ms:>7.0}",
                program.lines(),
                program.report.max_deviation_mm,
                program.report.at_ms,
                all,
                after,
                overshoot
            );
        }
    }
    println!(
        "all {} balls streamed: at most {most_lines} lines a ball; on the twins the largest \
         deviation {worst:.1} mm, {worst_after:.1} mm from the end of the first period to the last second (ball {}, at {} ms); \
         past the show's end (it stops dead) {worst_overshoot:.1} mm",
        show.tracks.len(),
        worst_after_at.0,
        worst_after_at.1
    );
}

/// Plays `program` on a twin standing at `start_mm`, fed as the bridge feeds it; the
/// largest |twin − show| (mm) over the show, from `period_s` on, and after the end.
fn play(
    program: &QProgram,
    start_mm: f64,
    config: &QProgramConfig,
    mut show_at: impl FnMut(f64) -> f64,
    period_s: f64,
    duration_ms: u64,
) -> (f64, (f64, u64), f64) {
    let mut drive = Drive::new(DriveConfig::default());
    let say = |drive: &mut Drive, line: &str, now_us: u64| {
        let answer = drive.receive_line(line, now_us).unwrap_or_default();
        assert!(!answer.starts_with('?'), "{line}: {answer}");
    };
    say(
        &mut drive,
        &format!("SP{}", (start_mm * config.counts_per_mm).round()),
        0,
    );
    let mut lines = program
        .segments
        .iter()
        .flat_map(|(_, commands)| commands)
        .peekable();
    say(&mut drive, "PS", 0);
    for _ in 0..56 {
        if let Some(line) = lines.next() {
            say(&mut drive, &line.to_string(), 0);
        }
    }
    say(&mut drive, "CT", 0);
    let (mut all, mut after, mut overshoot) = (0.0_f64, 0.0_f64, 0.0_f64);
    let mut after_at_ms = 0;
    let mut next_refill_us = 150_000;
    // The show, and a few seconds more for the last stop and feed.
    for step in 0..=(duration_ms / 10 + 500) {
        let now_us = step * 10_000;
        if now_us >= next_refill_us {
            next_refill_us += 150_000;
            let room = drive.buffer_free().saturating_sub(2);
            for _ in 0..room {
                match lines.next() {
                    Some(line) => say(&mut drive, &line.to_string(), now_us),
                    None => break,
                }
            }
        }
        drive.advance(now_us);
        let t_ms = (now_us as f64 / 1000.0).min(duration_ms as f64);
        let show_mm = show_at(t_ms);
        let off = (drive.position_counts() / config.counts_per_mm - show_mm).abs();
        if std::env::var_os("QPROGRAM_TRACE").is_some() && now_us <= 5_000_000 && step % 5 == 0 {
            eprintln!(
                "trace {t_ms:.0} ms: ball {:.1} mm, show {show_mm:.1} mm, {:.0} mm/s",
                drive.position_counts() / config.counts_per_mm,
                drive.velocity_counts_s() / config.counts_per_mm
            );
        }
        if now_us > duration_ms * 1_000 {
            // Past the show's end: a show that ends at speed is overshot while the
            // drive slows down (no drive stops dead).
            overshoot = overshoot.max(off);
            continue;
        }
        all = all.max(off);
        // From the end of the first period to the show's last second (the demo
        // wave starts at speed and stops dead in its last row: no drive follows
        // either; the whole-show figure includes them).
        if now_us as f64 >= period_s * 1e6 && now_us + 1_000_000 <= duration_ms * 1_000 {
            if off > after {
                after_at_ms = now_us / 1_000;
            }
            after = after.max(off);
        }
    }
    assert!(lines.peek().is_none(), "lines left at the show's end");
    (all, (after, after_at_ms), overshoot)
}
