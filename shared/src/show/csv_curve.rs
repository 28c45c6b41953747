//! The velocities at CSV keyframes: the curve a ball follows between the keyframes a 3D
//! tool exported (`docs/architecture.md` §3).
//!
//! Every gap between two keyframes is one Hermite cubic (a PVT row, split into rows of
//! at most 255 ms on the same cubic), fixed by the two positions and the velocities at
//! both ends. The positions are the file's; this module chooses the velocities, in
//! three steps.
//!
//! 1. **Estimate: the clamped cubic spline.** The velocities are those of the cubic
//!    spline through the keyframes that starts and ends at rest: the one curve through
//!    them whose acceleration is continuous at every keyframe (C²). Nothing is forced
//!    to zero at a turning point, so a sine sampled between its peaks stays a sine. For
//!    a smooth curve at rest at both ends, sampled every `h` seconds, the spline's
//!    positions, velocities and accelerations are the curve's to within terms in `h⁴`,
//!    `h³` and `h²`; in
//!    particular the peak acceleration, which the validation checks, is the curve's
//!    own: on a 3 s sine the spline's peak acceleration is 0.4 % high at 10 keyframes a
//!    second and 1.5 % at 5, where a centred three-point estimate (Catmull-Rom) is
//!    3.9 % and 14 % high. Both ends are at rest because every track starts at rest
//!    (the show format) and a run ends at rest rather than braking past its last
//!    keyframe; a file that does not start or end at rest gets the least abrupt curve
//!    that does. A **hold** — three or more equal keyframes in a row — is at rest too
//!    (velocity 0 at each of its keyframes), so a ball stays still where the file says
//!    so instead of the spline swinging through it; two equal keyframes are not a
//!    hold, since a sine sampled either side of its peak gives them.
//!
//! 2. **Speed and acceleration, only where the keyframes themselves keep them.** The
//!    "straight keyframes" of a gap are the straight line between its keyframes — in
//!    a gap beside a rest (the ends, a hold), the constant acceleration from or to
//!    rest — and their acceleration at a keyframe is the change of slope there (the
//!    second divided difference `2 (d₁ − d₀) / (h₀ + h₁)`; at a rest `2 d / h`).
//!    Only a gap whose straight keyframes keep a limit is held to it:
//!    - acceleration: the cubic's acceleration at each end of a gap is linear in its two
//!      velocities, so an end over the top acceleration is brought to it by the least
//!      change of the velocities (a projection onto the half-plane where it is within);
//!      the gaps are swept repeatedly (projections onto convex sets), which converges
//!      to velocities within every such limit where there are any;
//!    - speed: a gap faster than the top speed has its velocities moved towards its
//!      straight line's (the chord slope, or `2 d` beside a rest) by the least fraction
//!      that brings it within, found by bisection, in a few sweeps.
//!
//!    If this leaves the worst excess over such a limit no smaller than the spline's,
//!    the spline's velocities stay. Where the keyframes themselves break a limit nothing
//!    is bent: the validation reports it (the show needs different keyframes, not a
//!    different curve). For a sampled curve this step acts only in the narrow band where
//!    the curve's peak is over a limit while the samples' straight lines are not (for a
//!    3 s sine at 10 keyframes a second, 0.2 % of speed and 0.4 % of acceleration),
//!    and where the spline's own error at few keyframes a period would refuse a curve
//!    within the limits — both the sampling's own error.
//!
//! 3. **Within 0 … travel, always.** A cubic can pass beyond its keyframes; where it
//!    would go above 0 (the top) or below the travel, the velocities pushing it out are
//!    shrunk towards 0 by the least common factor that keeps it in (bisection).
//!    Precisely, towards the travel (larger positions) the worst case of a gap is its
//!    start velocity if positive and its end velocity if negative, the other one taken
//!    as 0: the position at every instant of the gap increases with the start velocity
//!    and decreases with the end velocity, so a gap within the travel in that worst
//!    case stays within it however much either velocity later shrinks towards 0. Hence
//!    one pass over the gaps, each shrinking only the velocities that push out, leaves
//!    every gap within 0 … travel (towards the top likewise, with the signs turned). This comes last and wins over step 2: a ball never
//!    leaves its travel. Keyframes outside the travel are kept (the validation
//!    refuses them); their gaps are kept within the range they span.
//!
//! The curve passes through every keyframe exactly (positions are never changed).

use super::DEFAULT_TRAVEL_MM;
use super::validate::{DEFAULT_MAX_ACCEL_MM_S2, DEFAULT_MAX_SPEED_MM_S, Limits};
use crate::motion::Segment;

/// What the curve through CSV keyframes is kept within (module docs, steps 2 and 3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveLimits {
    /// Lowest position, mm below the top.
    pub travel_mm: f64,
    /// Top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration, mm/s².
    pub max_accel_mm_s2: f64,
}

impl CurveLimits {
    /// The default installation's: a UFQ750's travel, speed and acceleration. Used when
    /// the installation is not known (the web app's preview of a file).
    pub const DEFAULT: Self = Self {
        travel_mm: DEFAULT_TRAVEL_MM,
        max_speed_mm_s: DEFAULT_MAX_SPEED_MM_S,
        max_accel_mm_s2: DEFAULT_MAX_ACCEL_MM_S2,
    };
}

impl Default for CurveLimits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl From<&Limits> for CurveLimits {
    fn from(limits: &Limits) -> Self {
        Self {
            travel_mm: limits.travel_mm,
            max_speed_mm_s: limits.max_speed_mm_s,
            max_accel_mm_s2: limits.max_accel_mm_s2,
        }
    }
}

/// Sweeps over the gaps for the acceleration of step 2, at most.
const ACCEL_SWEEPS: usize = 64;

/// Sweeps over the gaps (forwards and backwards) for the speed of step 2, at most.
const SPEED_SWEEPS: usize = 4;

/// Bisection steps: the fraction to within 2⁻⁴⁰.
const BISECTIONS: usize = 40;

/// Slack before a limit counts as broken (mm/s, mm/s²): the validation's rounding.
const SLACK: f64 = 1e-6;

/// The velocities (mm/s) at the keyframes `positions_mm` at whole-ms `times_ms`
/// (strictly increasing), written into `velocities_mm_s` (same length), by the three
/// steps of the [module](self) docs. `scratch` is working space, reused across balls.
pub(super) fn keyframe_velocities(
    times_ms: &[u64],
    positions_mm: &[f64],
    limits: CurveLimits,
    velocities_mm_s: &mut [f64],
    scratch: &mut Vec<f64>,
) {
    velocities_mm_s.fill(0.0);
    let n = times_ms
        .len()
        .min(positions_mm.len())
        .min(velocities_mm_s.len());
    if n < 3 {
        return;
    }
    let gaps = Gaps {
        times_ms: &times_ms[..n],
        positions_mm: &positions_mm[..n],
    };
    let velocities = &mut velocities_mm_s[..n];
    spline(&gaps, velocities, scratch);
    limit_speed_and_accel(&gaps, limits, velocities, scratch);
    keep_within_travel(&gaps, limits, velocities);
}

/// The keyframes, as gaps.
struct Gaps<'a> {
    times_ms: &'a [u64],
    positions_mm: &'a [f64],
}

impl Gaps<'_> {
    /// Keyframes.
    fn len(&self) -> usize {
        self.times_ms.len()
    }

    /// Gap `i`'s duration, s.
    fn h(&self, i: usize) -> f64 {
        (self.times_ms[i + 1] - self.times_ms[i]) as f64 / 1000.0
    }

    /// Gap `i`'s chord slope, mm/s.
    fn slope(&self, i: usize) -> f64 {
        (self.positions_mm[i + 1] - self.positions_mm[i]) / self.h(i)
    }

    /// Gap `i`'s cubic with end velocities `v0`, `v1`.
    fn segment(&self, i: usize, v0: f64, v1: f64) -> Segment {
        Segment::new(
            self.positions_mm[i],
            v0,
            self.positions_mm[i + 1],
            v1,
            self.h(i),
        )
    }

    /// Whether the ball is at rest at keyframe `k`: the first, the last, and every
    /// keyframe of a hold — three or more equal keyframes in a row. (Two equal
    /// keyframes are not a hold: a sine sampled either side of its peak gives them.)
    fn at_rest(&self, k: usize) -> bool {
        let p = self.positions_mm;
        let last = self.len() - 1;
        let equal = |a: usize, b: usize| p[a] == p[b];
        k == 0
            || k >= last
            || (equal(k - 1, k) && equal(k, k + 1))
            || (k >= 2 && equal(k - 2, k - 1) && equal(k - 1, k))
            || (k + 2 <= last && equal(k, k + 1) && equal(k + 1, k + 2))
    }

    /// The straight keyframes' acceleration at keyframe `k`: the change of slope
    /// there; at a keyframe at rest, the larger of stopping from the slope before and
    /// starting to the slope after (`2 d / h`).
    fn keyframe_accel(&self, k: usize) -> f64 {
        let last = self.len() - 1;
        if self.at_rest(k) {
            let stop = if k > 0 {
                (2.0 * self.slope(k - 1) / self.h(k - 1)).abs()
            } else {
                0.0
            };
            let start = if k < last {
                (2.0 * self.slope(k) / self.h(k)).abs()
            } else {
                0.0
            };
            stop.max(start)
        } else {
            2.0 * (self.slope(k) - self.slope(k - 1)) / (self.h(k - 1) + self.h(k))
        }
    }
}

/// Step 1: the clamped cubic spline's velocities (0 at both ends and through every
/// hold), by the tridiagonal (Thomas) solve of the C² conditions at the other
/// keyframes: `v₋/h₀ + 2 (1/h₀ + 1/h₁) v + v₊/h₁ = 3 (d₀/h₀ + d₁/h₁)`. The system is
/// strictly diagonally dominant, so the solve is stable; a keyframe at rest splits it
/// into independent pieces.
fn spline(gaps: &Gaps<'_>, velocities: &mut [f64], scratch: &mut Vec<f64>) {
    let n = gaps.len();
    scratch.clear();
    scratch.resize(n, 0.0);
    // Forward: velocities[i] holds the reduced right-hand side, scratch[i] the
    // reduced super-diagonal.
    let mut previous = (0.0, 0.0);
    for i in 0..n {
        if gaps.at_rest(i) {
            velocities[i] = 0.0;
            scratch[i] = 0.0;
            previous = (0.0, 0.0);
            continue;
        }
        let (h0, h1) = (gaps.h(i - 1), gaps.h(i));
        let (sub, sup) = (1.0 / h0, 1.0 / h1);
        let diagonal = 2.0 * (sub + sup);
        let rhs = 3.0 * (gaps.slope(i - 1) * sub + gaps.slope(i) * sup);
        let (c_prev, r_prev) = previous;
        let pivot = diagonal - sub * c_prev;
        let c = if gaps.at_rest(i + 1) {
            0.0
        } else {
            sup / pivot
        };
        let r = (rhs - sub * r_prev) / pivot;
        scratch[i] = c;
        velocities[i] = r;
        previous = (c, r);
    }
    for i in (1..n - 1).rev() {
        velocities[i] -= scratch[i] * velocities[i + 1];
    }
}

/// Step 2 (module docs). Kept only if it leaves the worst excess over a limit it
/// applies to smaller than the spline's; else the spline's velocities stay.
fn limit_speed_and_accel(
    gaps: &Gaps<'_>,
    limits: CurveLimits,
    velocities: &mut [f64],
    scratch: &mut Vec<f64>,
) {
    let before = worst_excess(gaps, limits, velocities);
    if before <= 0.0 {
        return;
    }
    scratch.clear();
    scratch.extend_from_slice(velocities);
    let gap_count = gaps.len() - 1;
    for sweep in 0..ACCEL_SWEEPS {
        let mut changed = false;
        for step in 0..gap_count {
            let i = if sweep % 2 == 0 {
                step
            } else {
                gap_count - 1 - step
            };
            changed |= limit_accel(gaps, limits, velocities, i);
        }
        if !changed {
            break;
        }
    }
    for sweep in 0..2 * SPEED_SWEEPS {
        let mut changed = false;
        for step in 0..gap_count {
            let i = if sweep % 2 == 0 {
                step
            } else {
                gap_count - 1 - step
            };
            changed |= limit_speed(gaps, limits, velocities, i);
        }
        if !changed {
            break;
        }
    }
    if worst_excess(gaps, limits, velocities) >= before {
        velocities.copy_from_slice(scratch);
    }
}

/// The straight keyframes of gap `i` (module docs, step 2): their end velocities,
/// their speed and their largest acceleration; `None` for a gap at rest at both
/// ends, where there is nothing to choose.
fn straight(gaps: &Gaps<'_>, i: usize) -> Option<(f64, f64, f64, f64)> {
    let d = gaps.slope(i);
    let (target0, target1, speed) = match (gaps.at_rest(i), gaps.at_rest(i + 1)) {
        (true, true) => return None,
        (true, false) => (0.0, 2.0 * d, 2.0 * d.abs()),
        (false, true) => (2.0 * d, 0.0, 2.0 * d.abs()),
        (false, false) => (d, d, d.abs()),
    };
    let accel = gaps
        .keyframe_accel(i)
        .abs()
        .max(gaps.keyframe_accel(i + 1).abs());
    Some((target0, target1, speed, accel))
}

/// The largest relative excess over the top speed or acceleration, among the gaps
/// whose straight keyframes keep that limit (≤ 0: none).
fn worst_excess(gaps: &Gaps<'_>, limits: CurveLimits, velocities: &[f64]) -> f64 {
    let mut worst: f64 = 0.0;
    for i in 0..gaps.len() - 1 {
        let Some((_, _, speed, accel)) = straight(gaps, i) else {
            continue;
        };
        let segment = gaps.segment(i, velocities[i], velocities[i + 1]);
        if speed <= limits.max_speed_mm_s {
            worst = worst.max(segment.peak_speed().value / limits.max_speed_mm_s - 1.0);
        }
        if accel <= limits.max_accel_mm_s2 {
            worst = worst.max(segment.peak_acceleration().value / limits.max_accel_mm_s2 - 1.0);
        }
    }
    worst
}

/// The acceleration part of step 2 for gap `i`, if its straight keyframes keep the
/// top acceleration: each end's acceleration is linear in the two velocities, so a
/// too large one is brought to the limit by the least change of the velocities that
/// may change (not a rest at either end of the show): a projection onto the half-plane
/// where it is within. Sweeping the gaps repeatedly (projections onto convex sets)
/// converges to velocities within every such limit when there are any. Whether the
/// velocities changed.
fn limit_accel(gaps: &Gaps<'_>, limits: CurveLimits, velocities: &mut [f64], i: usize) -> bool {
    let Some((_, _, _, accel)) = straight(gaps, i) else {
        return false;
    };
    if accel > limits.max_accel_mm_s2 {
        return false;
    }
    let (h, d) = (gaps.h(i), gaps.slope(i));
    let free0 = if gaps.at_rest(i) { 0.0 } else { 1.0 };
    let free1 = if gaps.at_rest(i + 1) { 0.0 } else { 1.0 };
    let mut changed = false;
    // a_start = (6d − 4v₀ − 2v₁)/h, a_end = (2v₀ + 4v₁ − 6d)/h: (offset, ∂/∂v₀, ∂/∂v₁).
    for (offset, g0, g1) in [
        (6.0 * d / h, -4.0 / h, -2.0 / h),
        (-6.0 * d / h, 2.0 / h, 4.0 / h),
    ] {
        let (g0, g1) = (g0 * free0, g1 * free1);
        let norm = g0 * g0 + g1 * g1;
        let value = offset + g0 * velocities[i] + g1 * velocities[i + 1];
        let excess = value.abs() - limits.max_accel_mm_s2;
        if excess > SLACK && norm > 0.0 {
            // Slightly past the limit, so that the sweeps settle.
            let step = value.signum() * (excess + SLACK) / norm;
            velocities[i] -= step * g0;
            velocities[i + 1] -= step * g1;
            changed = true;
        }
    }
    changed
}

/// The speed part of step 2 for gap `i`, if its straight keyframes keep the top speed:
/// the velocities moved towards the straight line's by the least fraction that keeps
/// the cubic within it. Whether the velocities changed.
fn limit_speed(gaps: &Gaps<'_>, limits: CurveLimits, velocities: &mut [f64], i: usize) -> bool {
    let Some((target0, target1, speed, _)) = straight(gaps, i) else {
        return false;
    };
    if speed > limits.max_speed_mm_s {
        return false;
    }
    let (v0, v1) = (velocities[i], velocities[i + 1]);
    let blend = |k: f64| (target0 + k * (v0 - target0), target1 + k * (v1 - target1));
    let within = |k: f64| {
        let (a, b) = blend(k);
        gaps.segment(i, a, b).peak_speed().value <= limits.max_speed_mm_s + SLACK
    };
    if within(1.0) {
        return false;
    }
    let (a, b) = blend(largest_within(within));
    velocities[i] = a;
    velocities[i + 1] = b;
    true
}

/// Step 3 (module docs): one pass, each gap shrinking only the velocities that push it
/// past the top or the travel.
fn keep_within_travel(gaps: &Gaps<'_>, limits: CurveLimits, velocities: &mut [f64]) {
    for i in 0..gaps.len() - 1 {
        let (p0, p1) = (gaps.positions_mm[i], gaps.positions_mm[i + 1]);
        let top = p0.min(p1).min(0.0);
        let bottom = p0.max(p1).max(limits.travel_mm);
        // Towards the travel (larger positions): a positive start velocity, a negative
        // end velocity.
        let (v0, v1) = (velocities[i], velocities[i + 1]);
        let (a, b) = (v0.max(0.0), v1.min(0.0));
        let k =
            largest_within(|k| gaps.segment(i, k * a, k * b).position_range().max.value <= bottom);
        if k < 1.0 {
            if v0 > 0.0 {
                velocities[i] = k * v0;
            }
            if v1 < 0.0 {
                velocities[i + 1] = k * v1;
            }
        }
        // Towards the top (smaller positions): a negative start velocity, a positive
        // end velocity.
        let (v0, v1) = (velocities[i], velocities[i + 1]);
        let (a, b) = (v0.min(0.0), v1.max(0.0));
        let k = largest_within(|k| gaps.segment(i, k * a, k * b).position_range().min.value >= top);
        if k < 1.0 {
            if v0 < 0.0 {
                velocities[i] = k * v0;
            }
            if v1 > 0.0 {
                velocities[i + 1] = k * v1;
            }
        }
    }
}

/// The largest `k` in 0 … 1 for which `within(k)` holds, given that it holds at 0:
/// 1 if it holds there, else by bisection (the bracket's end where it holds).
fn largest_within(within: impl Fn(f64) -> bool) -> f64 {
    if within(1.0) {
        return 1.0;
    }
    let (mut good, mut bad) = (0.0, 1.0);
    for _ in 0..BISECTIONS {
        let middle = 0.5 * (good + bad);
        if within(middle) {
            good = middle;
        } else {
            bad = middle;
        }
    }
    good
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    fn velocities(times_ms: &[u64], positions_mm: &[f64], limits: CurveLimits) -> Vec<f64> {
        let mut out = vec![0.0; times_ms.len()];
        keyframe_velocities(times_ms, positions_mm, limits, &mut out, &mut Vec::new());
        out
    }

    #[test]
    fn a_quadratic_and_a_line_keep_their_velocities() {
        // A constant acceleration from rest is a C² curve: the spline is exact.
        let times: Vec<u64> = (0..=10).map(|i| i * 100).collect();
        let positions: Vec<f64> = times
            .iter()
            .map(|&t| 0.5 * 1000.0 * (t as f64 / 1000.0).powi(2))
            .collect();
        let v = velocities(&times, &positions, CurveLimits::DEFAULT);
        // Interior keyframes near the start follow a·t closely (the rest at the end
        // disturbs only the last few, decaying by 2 − √3 per keyframe).
        for (i, &t) in times.iter().enumerate().take(5).skip(1) {
            assert!((v[i] - t as f64).abs() < 1.0, "{i}: {}", v[i]);
        }
        assert_eq!((v[0], v[10]), (0.0, 0.0));
    }

    #[test]
    fn turning_points_are_not_flattened() {
        // A cosine sampled so that its peak falls between keyframes.
        let times: Vec<u64> = (0..=40).map(|i| i * 100).collect();
        let omega = 2.0 * std::f64::consts::PI / 2.9;
        let p = |t: f64| 2000.0 - 500.0 * (omega * t).cos();
        let positions: Vec<f64> = times.iter().map(|&t| p(t as f64 / 1000.0)).collect();
        let v = velocities(&times, &positions, CurveLimits::DEFAULT);
        for i in 5..35 {
            let t = times[i] as f64 / 1000.0;
            let exact = 500.0 * omega * (omega * t).sin();
            assert!((v[i] - exact).abs() < 0.5, "{i}: {} vs {exact}", v[i]);
        }
    }

    #[test]
    fn a_hold_stays_still_and_two_equal_keyframes_are_a_peak() {
        // Down, hold over three gaps, back up: at rest through the hold.
        let times = [0, 200, 400, 600, 800, 1000];
        let v = velocities(
            &times,
            &[0.0, 20.0, 20.0, 20.0, 20.0, 0.0],
            CurveLimits::DEFAULT,
        );
        assert_eq!(v, [0.0; 6]);
        // A peak between two samples: both keep their velocity.
        let v = velocities(
            &times,
            &[0.0, 10.0, 20.0, 20.0, 10.0, 0.0],
            CurveLimits::DEFAULT,
        );
        assert!(v[2] > 0.0 && v[3] < 0.0, "{v:?}");
    }

    #[test]
    fn near_the_top_the_curve_is_kept_in() {
        // A valley touching the top between keyframes: the spline would pass 0.
        let times = [0, 100, 200, 300, 400];
        let positions = [300.0, 40.0, 0.5, 40.0, 300.0];
        let limits = CurveLimits::DEFAULT;
        let v = velocities(&times, &positions, limits);
        for i in 0..4 {
            let segment = Segment::new(positions[i], v[i], positions[i + 1], v[i + 1], 0.1);
            let range = segment.position_range();
            assert!(range.min.value >= 0.0, "{i}: {range:?}");
            assert!(range.max.value <= limits.travel_mm);
        }
    }

    #[test]
    fn speed_is_limited_only_where_the_chords_are_within() {
        let times: Vec<u64> = (0..=30).map(|i| i * 100).collect();
        let omega = 2.0 * std::f64::consts::PI / 3.0;
        // Peak speed 0.1 % over 2000 mm/s; the chords are under it.
        let amplitude = 2002.0 / omega;
        let positions: Vec<f64> = times
            .iter()
            .map(|&t| 3000.0 - amplitude * (omega * t as f64 / 1000.0).cos())
            .collect();
        let limits = CurveLimits {
            max_accel_mm_s2: 1e9,
            ..CurveLimits::DEFAULT
        };
        let v = velocities(&times, &positions, limits);
        for i in 0..30 {
            let segment = Segment::new(positions[i], v[i], positions[i + 1], v[i + 1], 0.1);
            assert!(segment.peak_speed().value <= 2000.0 + 1e-3, "{i}");
        }
        // Keyframes too fast themselves are left as they are.
        let fast = [0.0, 300.0, 700.0, 1000.0];
        let v = velocities(&[0, 100, 200, 300], &fast, limits);
        let unlimited = velocities(
            &[0, 100, 200, 300],
            &fast,
            CurveLimits {
                max_speed_mm_s: 1e9,
                ..limits
            },
        );
        assert_eq!(v, unlimited);
    }
}
