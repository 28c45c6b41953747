//! CSV import against the curves it samples: analytic curves (sines of several periods
//! and amplitudes, a smooth step, a damped spring) sampled at 25, 10 and 5 keyframes a
//! second as a 3D tool exports them (positions to 0.001 mm), imported as CSV, and
//! compared with the analytic curve. Run by `cargo xtask csv-report`; prints figures,
//! asserts nothing.
//!
//! Per curve and rate: the largest position error (mm, the imported curve against the
//! analytic one every ms), the peak speed and acceleration of the imported curve
//! against the analytic ones and the difference in %, whether the analytic curve is
//! within the default limits (7500 mm, 2000 mm/s, 4000 mm/s²) and whether the CSV is
//! accepted by the upload's validation ([`import`] with the installation's limits).
//! The last two columns are the same figures for the conversion before issue 34
//! (velocity 0 at every turning point, the monotone Fritsch–Carlson rule), rebuilt
//! here for comparison.

use std::f64::consts::PI;
use std::fmt::Write as _;

use floatball_shared::motion::Segment;
use floatball_shared::show::{Layout, Limits, Show, ShowFormat, UploadLimits, import};

/// An analytic curve: position, velocity, acceleration (mm, mm/s, mm/s²) at t (s).
struct Curve {
    name: String,
    duration_s: f64,
    at: Box<dyn Fn(f64) -> (f64, f64, f64)>,
}

/// `centre − amplitude · cos(2π t / period)`: from rest at the top of its swing, for
/// `periods` whole periods (so it ends at rest).
fn sine(period_s: f64, amplitude_mm: f64, centre_mm: f64, periods: f64) -> Curve {
    let w = 2.0 * PI / period_s;
    Curve {
        name: format!("sine {period_s} s, {amplitude_mm} mm"),
        duration_s: period_s * periods,
        at: Box::new(move |t| {
            let (s, c) = (w * t).sin_cos();
            (
                centre_mm - amplitude_mm * c,
                amplitude_mm * w * s,
                amplitude_mm * w * w * c,
            )
        }),
    }
}

/// A smootherstep (`6x⁵ − 15x⁴ + 10x³`) from `from_mm` to `to_mm` over `step_s`,
/// with a hold of `hold_s` before and after.
fn smooth_step(from_mm: f64, to_mm: f64, step_s: f64, hold_s: f64) -> Curve {
    let span = to_mm - from_mm;
    Curve {
        name: format!("smooth step {from_mm}→{to_mm} mm in {step_s} s"),
        duration_s: step_s + 2.0 * hold_s,
        at: Box::new(move |t| {
            let x = ((t - hold_s) / step_s).clamp(0.0, 1.0);
            let inside = t > hold_s && t < hold_s + step_s;
            let p = from_mm + span * x * x * x * (10.0 - 15.0 * x + 6.0 * x * x);
            if !inside {
                return (p, 0.0, 0.0);
            }
            let v = span * 30.0 * x * x * (1.0 - x) * (1.0 - x) / step_s;
            let a = span * 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x) / (step_s * step_s);
            (p, v, a)
        }),
    }
}

/// A damped spring from rest, `amplitude_mm` off `centre_mm`:
/// `c + A e^(−ζt) (cos ωt + ζ/ω sin ωt)`, for `periods` periods (ends at rest).
fn damped(period_s: f64, amplitude_mm: f64, centre_mm: f64, zeta: f64, periods: f64) -> Curve {
    let w = 2.0 * PI / period_s;
    let k = amplitude_mm * (w + zeta * zeta / w);
    Curve {
        name: format!("damped bounce {period_s} s, {amplitude_mm} mm"),
        duration_s: period_s * periods,
        at: Box::new(move |t| {
            let (s, c) = (w * t).sin_cos();
            let e = (-zeta * t).exp();
            (
                centre_mm + amplitude_mm * e * (c + zeta / w * s),
                -k * e * s,
                -k * e * (w * c - zeta * s),
            )
        }),
    }
}

fn curves() -> Vec<Curve> {
    vec![
        sine(3.0, 880.0, 1500.0, 3.0),
        sine(3.0, 940.0, 1500.0, 3.0),
        Curve {
            name: "raised cosine 2.9 s, 0…1500 mm".into(),
            ..sine(2.9, 750.0, 750.0, 2.0)
        },
        sine(1.0, 100.0, 3000.0, 6.0),
        sine(1.5, 220.0, 3000.0, 4.0),
        sine(2.0, 420.0, 3000.0, 3.0),
        sine(6.0, 1850.0, 3700.0, 1.0),
        sine(6.0, 1950.0, 3700.0, 1.0),
        sine(4.0, 1000.0, 7500.0 - 1000.0, 2.0),
        smooth_step(500.0, 3500.0, 3.0, 0.5),
        smooth_step(500.0, 5000.0, 3.0, 0.5),
        damped(1.2, 120.0, 2000.0, 0.8, 5.0),
    ]
}

/// The keyframes of `curve` at `rate` a second: (ms, mm to 0.001).
fn keyframes(curve: &Curve, rate: u32) -> Vec<(u64, f64)> {
    let count = (curve.duration_s * f64::from(rate)).round() as u64;
    (0..=count)
        .map(|k| {
            let t = k as f64 / f64::from(rate);
            let p = (curve.at)(t).0;
            ((t * 1000.0).round() as u64, (p * 1000.0).round() / 1000.0)
        })
        .collect()
}

fn csv(keyframes: &[(u64, f64)]) -> String {
    let mut text = String::from("time_ms,u0\n");
    for (t, p) in keyframes {
        let _ = writeln!(text, "{t},{p:.3}");
    }
    text
}

/// Largest error (mm), peak speed and peak acceleration of `segments` (with start
/// times in ms) against `curve`, every ms.
fn measure(curve: &Curve, segments: &[(u64, Segment)]) -> (f64, f64, f64) {
    let mut error: f64 = 0.0;
    let (mut speed, mut accel): (f64, f64) = (0.0, 0.0);
    for &(start_ms, segment) in segments {
        speed = speed.max(segment.peak_speed().value);
        accel = accel.max(segment.peak_acceleration().value);
        let ms = (segment.duration_s * 1000.0).round() as u64;
        for i in 0..=ms {
            let t = (start_ms + i) as f64 / 1000.0;
            let p = segment.position(i as f64 / 1000.0);
            error = error.max((p - (curve.at)(t).0).abs());
        }
    }
    (error, speed, accel)
}

/// The analytic peaks (speed, acceleration) and range, every 0.1 ms.
fn analytic(curve: &Curve) -> (f64, f64, f64, f64) {
    let steps = (curve.duration_s * 10_000.0).round() as u64;
    let (mut speed, mut accel, mut low, mut high): (f64, f64, f64, f64) =
        (0.0, 0.0, f64::MAX, f64::MIN);
    for i in 0..=steps {
        let (p, v, a) = (curve.at)(i as f64 / 10_000.0);
        speed = speed.max(v.abs());
        accel = accel.max(a.abs());
        low = low.min(p);
        high = high.max(p);
    }
    (speed, accel, low, high)
}

/// The conversion before issue 34: monotone (Fritsch–Carlson) velocities, 0 at the ends
/// and at every turning point. One segment per gap (splitting does not change it).
fn monotone_segments(keyframes: &[(u64, f64)]) -> Vec<(u64, Segment)> {
    let n = keyframes.len();
    let mut v = vec![0.0; n];
    for i in 1..n.saturating_sub(1) {
        let h0 = (keyframes[i].0 - keyframes[i - 1].0) as f64 / 1000.0;
        let h1 = (keyframes[i + 1].0 - keyframes[i].0) as f64 / 1000.0;
        let d0 = (keyframes[i].1 - keyframes[i - 1].1) / h0;
        let d1 = (keyframes[i + 1].1 - keyframes[i].1) / h1;
        if d0 * d1 > 0.0 {
            let w0 = 2.0 * h1 + h0;
            let w1 = h1 + 2.0 * h0;
            v[i] = (w0 + w1) / (w0 / d0 + w1 / d1);
        }
    }
    (1..n)
        .map(|i| {
            let h = (keyframes[i].0 - keyframes[i - 1].0) as f64 / 1000.0;
            (
                keyframes[i - 1].0,
                Segment::new(keyframes[i - 1].1, v[i - 1], keyframes[i].1, v[i], h),
            )
        })
        .collect()
}

fn main() {
    let layout = Layout {
        rows: 1,
        cols: 1,
        pitch_mm: 500.0,
    };
    let motion = Limits::for_layout(1, 1);
    let upload = UploadLimits {
        motion,
        max_duration_ms: 30 * 60 * 1000,
        max_json_bytes: 32 << 20,
        mbox_boxes: None,
    };
    println!(
        "limits: travel {} mm, speed {} mm/s, acceleration {} mm/s²; positions exported to 0.001 mm",
        motion.travel_mm, motion.max_speed_mm_s, motion.max_accel_mm_s2
    );
    println!();
    println!(
        "| curve | kf/s | max error mm | peak speed CSV / analytic mm/s | peak accel CSV / analytic mm/s² | accel diff | analytic within limits | CSV accepted | before #34: max error mm, peak accel, accepted |"
    );
    println!("|---|---:|---:|---:|---:|---:|:---:|:---:|---|");
    for curve in curves() {
        let (speed, accel, low, high) = analytic(&curve);
        let tol = 1e-3;
        let within = speed <= motion.max_speed_mm_s + tol
            && accel <= motion.max_accel_mm_s2 + tol
            && low >= -tol
            && high <= motion.travel_mm + tol;
        for rate in [25, 10, 5] {
            let keys = keyframes(&curve, rate);
            let text = csv(&keys);
            let show: Show = match import("r", text.as_bytes(), ShowFormat::Csv, Some(layout), None)
            {
                Ok(show) => show,
                Err(refused) => {
                    println!("| {} | {rate} | not read: {refused} |", curve.name);
                    continue;
                }
            };
            let accepted = import(
                "r",
                text.as_bytes(),
                ShowFormat::Csv,
                Some(layout),
                Some(&upload),
            )
            .is_ok();
            let segments: Vec<_> = show.tracks[0].segments().collect();
            let (error, csv_speed, csv_accel) = measure(&curve, &segments);
            let old = monotone_segments(&keys);
            let (old_error, old_speed, old_accel) = measure(&curve, &old);
            let old_range = old.iter().all(|(_, s)| {
                let r = s.position_range();
                r.min.value >= -tol && r.max.value <= motion.travel_mm + tol
            });
            let old_accepted = old_speed <= motion.max_speed_mm_s + tol
                && old_accel <= motion.max_accel_mm_s2 + tol
                && old_range;
            let yes = |b: bool| if b { "yes" } else { "no" };
            println!(
                "| {} | {rate} | {error:.3} | {csv_speed:.0} / {speed:.0} | {csv_accel:.0} / {accel:.0} | {:+.2} % | {} | {} | {old_error:.2}, {old_accel:.0}, {} |",
                curve.name,
                (csv_accel / accel - 1.0) * 100.0,
                yes(within),
                yes(accepted),
                yes(old_accepted),
            );
        }
    }
}
