//! One PVT row as a cubic Hermite segment: the single evaluation function that the
//! simulator, the planner, validation and the preview all use, so that every part of
//! Floatball moves a ball identically.
//!
//! A row X means "from the current position and velocity, be at `QP[X]` with velocity
//! `QV[X]` after `QT[X]` ms" (manual §7.2). The motion between is the cubic whose
//! position and velocity match at both ends. Units are the caller's: counts and
//! counts/s on the unit side, mm and mm/s in show files; time is always in seconds here.
//!
//! Evaluation uses the Hermite basis, not expanded polynomial coefficients, so both
//! ends are exact: at the start the segment returns `p0`/`v0` bit for bit, at the end
//! `p1`/`v1`.
//!
//! ```
//! use floatball_shared::motion::Segment;
//!
//! // The first row of the manual's example table: from rest at 0 to 1000 counts,
//! // arriving at 8000 counts/s after 100 ms.
//! let row = Segment::new(0.0, 0.0, 1000.0, 8000.0, 0.100);
//! assert_eq!(row.position(0.100), 1000.0);
//! assert_eq!(row.kinematics(0.100).velocity, 8000.0);
//! assert!(row.peak_speed().value >= 8000.0);
//! ```

use std::ops::{Add, Mul, Sub};

/// Position, velocity and acceleration at one instant, in the caller's units
/// (e.g. counts, counts/s, counts/s²).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Kinematics {
    /// Position.
    pub position: f64,
    /// Velocity (position units per second).
    pub velocity: f64,
    /// Acceleration (position units per second squared).
    pub acceleration: f64,
}

/// An extreme value over a segment and when it occurs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Extremum {
    /// The value (for a peak speed or acceleration: its absolute value).
    pub value: f64,
    /// Time from the start of the segment, in seconds.
    pub at_s: f64,
}

/// The lowest and the highest position a segment passes through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionRange {
    /// The smallest position value.
    pub min: Extremum,
    /// The largest position value.
    pub max: Extremum,
}

/// Position on the unit Hermite cubic at fraction `s` of the segment (0 = start,
/// 1 = end): `p0`, `p1` are the end positions, `m0`, `m1` the end velocities multiplied
/// by the segment's duration.
///
/// This is the one function that turns a PVT row into a position: in `f64` for the
/// evaluator (and so the simulator and planner), in `f32` for the preview's
/// [`Sampler`](crate::show::Sampler). At `s = 0` it returns `p0` and at `s = 1` exactly
/// `p1`; outside `0..=1` it extrapolates the cubic.
#[inline]
#[must_use]
pub fn hermite_position<F>(p0: F, m0: F, p1: F, m1: F, s: F) -> F
where
    F: Copy + Add<Output = F> + Sub<Output = F> + Mul<Output = F> + From<u8>,
{
    let (one, two, three) = (F::from(1), F::from(2), F::from(3));
    let s2 = s * s;
    let s3 = s2 * s;
    let h00 = two * s3 - three * s2 + one;
    let h01 = three * s2 - two * s3;
    let h10 = s3 - two * s2 + s;
    let h11 = s3 - s2;
    h00 * p0 + h01 * p1 + (h10 * m0 + h11 * m1)
}

/// One PVT row: from `p0` moving at `v0`, reach `p1` moving at `v1` after `duration_s`.
///
/// Velocities are in position units per second. The duration must be positive and
/// finite for the results to be meaningful (a PVT row lasts 10–255 ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Segment {
    /// Position at the start.
    pub p0: f64,
    /// Velocity at the start (position units per second).
    pub v0: f64,
    /// Position at the end.
    pub p1: f64,
    /// Velocity at the end (position units per second).
    pub v1: f64,
    /// Duration in seconds.
    pub duration_s: f64,
}

impl Segment {
    /// A segment from (`p0`, `v0`) to (`p1`, `v1`) over `duration_s` seconds.
    #[must_use]
    pub const fn new(p0: f64, v0: f64, p1: f64, v1: f64, duration_s: f64) -> Self {
        Self {
            p0,
            v0,
            p1,
            v1,
            duration_s,
        }
    }

    /// Position at fraction `s` of the segment (0 = start, 1 = end).
    #[inline]
    #[must_use]
    pub fn position_at_fraction(&self, s: f64) -> f64 {
        let t = self.duration_s;
        hermite_position(self.p0, self.v0 * t, self.p1, self.v1 * t, s)
    }

    /// Position, velocity and acceleration at fraction `s` of the segment.
    #[must_use]
    pub fn kinematics_at_fraction(&self, s: f64) -> Kinematics {
        let t = self.duration_s;
        let dp = self.p1 - self.p0;
        let s2 = s * s;
        // d/ds of the basis, divided by the duration: velocity. Written so that the
        // end velocities come out exactly (the p-term vanishes at s = 0 and s = 1).
        let velocity = 6.0 * (s - s2) * dp / t
            + (3.0 * s2 - 4.0 * s + 1.0) * self.v0
            + (3.0 * s2 - 2.0 * s) * self.v1;
        let acceleration =
            ((6.0 - 12.0 * s) * dp / t + (6.0 * s - 4.0) * self.v0 + (6.0 * s - 2.0) * self.v1) / t;
        Kinematics {
            position: self.position_at_fraction(s),
            velocity,
            acceleration,
        }
    }

    /// Position `tau_s` seconds after the start of the segment.
    #[inline]
    #[must_use]
    pub fn position(&self, tau_s: f64) -> f64 {
        self.position_at_fraction(tau_s / self.duration_s)
    }

    /// Position, velocity and acceleration `tau_s` seconds after the start.
    #[must_use]
    pub fn kinematics(&self, tau_s: f64) -> Kinematics {
        self.kinematics_at_fraction(tau_s / self.duration_s)
    }

    /// The largest absolute velocity over the segment (analytic: the velocity is a
    /// quadratic, so the peak is at an end or where the acceleration is zero).
    #[must_use]
    pub fn peak_speed(&self) -> Extremum {
        let mut best = self.speed_extremum(0.0);
        let end = self.speed_extremum(1.0);
        if end.value > best.value {
            best = end;
        }
        // The acceleration is linear in s: a(s) = a0 + (a1 - a0) s.
        let a0 = self.kinematics_at_fraction(0.0).acceleration;
        let a1 = self.kinematics_at_fraction(1.0).acceleration;
        if a0 != a1 {
            let s = a0 / (a0 - a1);
            if s > 0.0 && s < 1.0 {
                let inner = self.speed_extremum(s);
                if inner.value > best.value {
                    best = inner;
                }
            }
        }
        best
    }

    /// The largest absolute acceleration over the segment (analytic: the acceleration
    /// is linear in time, so the peak is at one end).
    #[must_use]
    pub fn peak_acceleration(&self) -> Extremum {
        let a0 = self.kinematics_at_fraction(0.0).acceleration.abs();
        let a1 = self.kinematics_at_fraction(1.0).acceleration.abs();
        if a1 > a0 {
            Extremum {
                value: a1,
                at_s: self.duration_s,
            }
        } else {
            Extremum {
                value: a0,
                at_s: 0.0,
            }
        }
    }

    /// The lowest and highest positions over the segment (analytic: at an end or where
    /// the velocity crosses zero).
    #[must_use]
    pub fn position_range(&self) -> PositionRange {
        let start = Extremum {
            value: self.p0,
            at_s: 0.0,
        };
        let end = Extremum {
            value: self.p1,
            at_s: self.duration_s,
        };
        let (mut min, mut max) = if self.p1 < self.p0 {
            (end, start)
        } else {
            (start, end)
        };
        for s in self.velocity_roots().into_iter().flatten() {
            let candidate = Extremum {
                value: self.position_at_fraction(s),
                at_s: s * self.duration_s,
            };
            if candidate.value < min.value {
                min = candidate;
            }
            if candidate.value > max.value {
                max = candidate;
            }
        }
        PositionRange { min, max }
    }

    fn speed_extremum(&self, s: f64) -> Extremum {
        let velocity = if s == 0.0 {
            self.v0
        } else if s == 1.0 {
            self.v1
        } else {
            self.kinematics_at_fraction(s).velocity
        };
        Extremum {
            value: velocity.abs(),
            at_s: s * self.duration_s,
        }
    }

    /// The fractions strictly inside (0, 1) where the velocity is zero.
    fn velocity_roots(&self) -> [Option<f64>; 2] {
        // v(s) = a s² + b s + c
        let k = 6.0 * (self.p1 - self.p0) / self.duration_s;
        let a = -k + 3.0 * self.v0 + 3.0 * self.v1;
        let b = k - 4.0 * self.v0 - 2.0 * self.v1;
        let c = self.v0;
        let inside = |s: f64| (s > 0.0 && s < 1.0).then_some(s);
        if a == 0.0 {
            return if b == 0.0 {
                [None, None]
            } else {
                [inside(-c / b), None]
            };
        }
        let discriminant = b * b - 4.0 * a * c;
        if discriminant < 0.0 {
            return [None, None];
        }
        // The numerically stable pair of roots.
        let q = -0.5 * (b + b.signum() * discriminant.sqrt());
        if q == 0.0 {
            return [inside(0.0), None];
        }
        [inside(q / a), inside(c / q)]
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    /// The manual's example table (§7.1): (P, V, T ms).
    const MANUAL_TABLE: [(f64, f64, f64); 5] = [
        (1000.0, 8000.0, 100.0),
        (2000.0, 9000.0, 110.0),
        (3000.0, 9500.0, 90.0),
        (2000.0, -9000.0, 110.0),
        (1000.0, -8000.0, 100.0),
    ];

    fn manual_segments() -> Vec<Segment> {
        let (mut p, mut v) = (0.0, 0.0);
        MANUAL_TABLE
            .iter()
            .map(|&(p1, v1, t_ms)| {
                let segment = Segment::new(p, v, p1, v1, t_ms / 1000.0);
                (p, v) = (p1, v1);
                segment
            })
            .collect()
    }

    #[test]
    fn manual_table_ends_are_exact() {
        for (segment, &(p1, v1, t_ms)) in manual_segments().iter().zip(&MANUAL_TABLE) {
            let start = segment.kinematics(0.0);
            assert_eq!(start.position, segment.p0);
            assert_eq!(start.velocity, segment.v0);
            let end = segment.kinematics(t_ms / 1000.0);
            assert_eq!(end.position, p1);
            assert_eq!(end.velocity, v1);
            assert_eq!(segment.position(t_ms / 1000.0), p1);
        }
    }

    #[test]
    fn manual_table_is_c1_across_rows() {
        let segments = manual_segments();
        for pair in segments.windows(2) {
            let end = pair[0].kinematics_at_fraction(1.0);
            let start = pair[1].kinematics_at_fraction(0.0);
            assert_eq!(end.position, start.position);
            assert_eq!(end.velocity, start.velocity);
            // Just either side of the joint the curve is continuous too.
            let eps = 1e-9;
            let before = pair[0].kinematics(pair[0].duration_s - eps);
            let after = pair[1].kinematics(eps);
            assert!((before.position - after.position).abs() < 1e-3);
            assert!((before.velocity - after.velocity).abs() < 1.0);
        }
    }

    #[test]
    fn manual_first_row_matches_the_closed_form() {
        // From rest at 0 to 1000 at 8000/s in 0.1 s: p(s) = (3s² - 2s³)·1000 + (s³ - s²)·800.
        let row = manual_segments()[0];
        let s: f64 = 0.5;
        let expected = (3.0 * s * s - 2.0 * s * s * s) * 1000.0 + (s * s * s - s * s) * 800.0;
        assert!((row.position_at_fraction(s) - expected).abs() < 1e-9);
        // a(0) = 6·1000/0.01 - 2·8000/0.1 = 600000 - 160000.
        assert!((row.kinematics(0.0).acceleration - 440_000.0).abs() < 1e-6);
        // a(T) = -600000 + 4·8000/0.1 = -280000.
        assert!((row.kinematics(0.1).acceleration + 280_000.0).abs() < 1e-6);
        let peak = row.peak_acceleration();
        assert!((peak.value - 440_000.0).abs() < 1e-6);
        assert_eq!(peak.at_s, 0.0);
    }

    #[test]
    fn acceleration_is_the_derivative_of_velocity() {
        for segment in manual_segments() {
            for i in 1..10 {
                let tau = segment.duration_s * f64::from(i) / 10.0;
                let h = 1e-7;
                let numeric = (segment.kinematics(tau + h).velocity
                    - segment.kinematics(tau - h).velocity)
                    / (2.0 * h);
                let analytic = segment.kinematics(tau).acceleration;
                assert!(
                    (numeric - analytic).abs() < 1e-3 * analytic.abs().max(1.0),
                    "{numeric} vs {analytic}"
                );
                let numeric_v = (segment.position(tau + h) - segment.position(tau - h)) / (2.0 * h);
                let analytic_v = segment.kinematics(tau).velocity;
                assert!((numeric_v - analytic_v).abs() < 1e-3 * analytic_v.abs().max(1.0));
            }
        }
    }

    /// Brute-force maxima over a fine grid, for comparison with the analytic ones.
    fn sampled(segment: &Segment, f: impl Fn(Kinematics) -> f64) -> (f64, f64) {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for i in 0..=10_000 {
            let value = f(segment.kinematics_at_fraction(f64::from(i) / 10_000.0));
            lo = lo.min(value);
            hi = hi.max(value);
        }
        (lo, hi)
    }

    #[test]
    fn analytic_peaks_match_a_fine_grid() {
        let mut segments = manual_segments();
        segments.push(Segment::new(0.0, 0.0, 0.0, 0.0, 0.1));
        segments.push(Segment::new(100.0, -5000.0, 100.0, 5000.0, 0.2));
        segments.push(Segment::new(0.0, 3000.0, 0.0, 3000.0, 0.25));
        segments.push(Segment::new(50.0, 0.0, 10.0, 0.0, 0.01));
        for segment in &segments {
            let (_, speed) = sampled(segment, |k| k.velocity.abs());
            let peak = segment.peak_speed();
            assert!(peak.value >= speed - 1e-9, "{segment:?}");
            assert!(peak.value <= speed + 1e-3 * speed.max(1.0), "{segment:?}");
            let at = segment.kinematics(peak.at_s).velocity.abs();
            assert!((at - peak.value).abs() < 1e-6 * peak.value.max(1.0));

            let (_, accel) = sampled(segment, |k| k.acceleration.abs());
            assert!((segment.peak_acceleration().value - accel).abs() < 1e-6 * accel.max(1.0));

            let (lo, hi) = sampled(segment, |k| k.position);
            let range = segment.position_range();
            assert!(range.min.value <= lo + 1e-9 && range.min.value >= lo - 1e-3);
            assert!(range.max.value >= hi - 1e-9 && range.max.value <= hi + 1e-3);
            assert!((segment.position(range.min.at_s) - range.min.value).abs() < 1e-9);
        }
    }

    #[test]
    fn a_reversing_row_overshoots_and_the_range_sees_it() {
        // Arrive at 100 moving down at 5000/s, leave towards 100 moving up: dips below.
        let segment = Segment::new(100.0, -5000.0, 100.0, 5000.0, 0.2);
        let range = segment.position_range();
        assert!(range.min.value < 0.0);
        assert!(range.min.at_s > 0.0 && range.min.at_s < 0.2);
        assert_eq!(range.max.value, 100.0);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn row() -> impl Strategy<Value = Segment> {
        (
            -1e7..1e7f64,
            -1e5..1e5f64,
            -1e7..1e7f64,
            -1e5..1e5f64,
            10u8..=255,
        )
            .prop_map(|(p0, v0, p1, v1, ms)| Segment::new(p0, v0, p1, v1, f64::from(ms) / 1000.0))
    }

    proptest! {
        #[test]
        fn ends_are_exact(segment in row()) {
            let start = segment.kinematics(0.0);
            prop_assert_eq!(start.position, segment.p0);
            prop_assert_eq!(start.velocity, segment.v0);
            let end = segment.kinematics(segment.duration_s);
            prop_assert_eq!(end.position, segment.p1);
            prop_assert_eq!(end.velocity, segment.v1);
        }

        #[test]
        fn peaks_bound_every_sample(segment in row(), s in 0.0..=1.0f64) {
            let k = segment.kinematics_at_fraction(s);
            let slack = 1e-9;
            prop_assert!(k.velocity.abs() <= segment.peak_speed().value * (1.0 + slack) + slack);
            prop_assert!(
                k.acceleration.abs() <= segment.peak_acceleration().value * (1.0 + slack) + slack
            );
            let range = segment.position_range();
            let scale = segment.p0.abs().max(segment.p1.abs()).max(1.0) * slack;
            prop_assert!(k.position >= range.min.value - scale);
            prop_assert!(k.position <= range.max.value + scale);
        }
    }
}
