//! The identify move, without I/O: where one ball goes so the installer sees which it
//! is, how fast, and how long it takes to be back.
//!
//! The ball goes down `distance_mm` (by default [`DEFAULT_DISTANCE_MM`]) from where it
//! is, at a safe speed ([`SAFE_SPEED_MM_S`], at most half the matrix's top speed),
//! waits [`PAUSE`] and comes back. A ball too near the end of the travel to go down
//! that far goes as far as the travel allows, or up when it is at the end.

use std::time::Duration;

/// How far the ball goes when the request does not say, mm.
pub const DEFAULT_DISTANCE_MM: f64 = 300.0;

/// The fastest an identify move goes, mm/s.
pub const SAFE_SPEED_MM_S: f64 = 250.0;

/// How long the ball stays down before it comes back.
pub const PAUSE: Duration = Duration::from_millis(500);

/// One identify move in counts and times.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IdentifyMove {
    /// Where the ball is, counts.
    pub from_counts: i32,
    /// Where it goes, counts.
    pub to_counts: i32,
    /// How far that is, mm.
    pub distance_mm: f64,
    /// The point-to-point speed, counts/s (at least 1).
    pub speed_counts_s: i32,
    /// How long one way takes (speeding up, cruising, slowing down).
    pub leg: Duration,
}

impl IdentifyMove {
    /// How long from the start until the ball is back.
    pub fn duration(&self) -> Duration {
        self.leg * 2 + PAUSE
    }
}

/// The matrix's limits the move keeps to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveLimits {
    /// Lowest position, mm below the top.
    pub travel_mm: f64,
    /// Top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration (the units' point-to-point acceleration), mm/s².
    pub max_accel_mm_s2: f64,
    /// Counts per mm.
    pub counts_per_mm: f64,
}

/// Plans the move of a ball at `from_counts` by `distance_mm` within `limits`; `None`
/// when the distance is not a positive number or the calibration is unusable.
pub fn plan(from_counts: i32, distance_mm: f64, limits: &MoveLimits) -> Option<IdentifyMove> {
    let positive = |value: f64| value.is_finite() && value > 0.0;
    if !positive(distance_mm)
        || !positive(limits.counts_per_mm)
        || !positive(limits.max_speed_mm_s)
        || !positive(limits.max_accel_mm_s2)
    {
        return None;
    }
    let from_mm = f64::from(from_counts) / limits.counts_per_mm;
    let travel_mm = limits.travel_mm.max(0.0);
    let down_mm = (from_mm + distance_mm).min(travel_mm);
    let to_mm = if down_mm - from_mm >= distance_mm.min(travel_mm) / 2.0 {
        down_mm
    } else {
        (from_mm - distance_mm).max(0.0)
    };
    let to_counts = (to_mm * limits.counts_per_mm).round();
    if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&to_counts) {
        return None;
    }
    // In range: checked above.
    let to_counts = to_counts as i32;
    let moved_mm = (f64::from(to_counts) - f64::from(from_counts)).abs() / limits.counts_per_mm;
    let speed_mm_s = SAFE_SPEED_MM_S.min(limits.max_speed_mm_s / 2.0);
    let accel = limits.max_accel_mm_s2;
    // A trapezoid, or a triangle when the move is too short to reach the speed.
    let leg_s = if moved_mm >= speed_mm_s * speed_mm_s / accel {
        moved_mm / speed_mm_s + speed_mm_s / accel
    } else {
        2.0 * (moved_mm / accel).sqrt()
    };
    Some(IdentifyMove {
        from_counts,
        to_counts,
        distance_mm: moved_mm,
        speed_counts_s: ((speed_mm_s * limits.counts_per_mm).round() as i32).max(1),
        leg: Duration::from_secs_f64(leg_s),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const LIMITS: MoveLimits = MoveLimits {
        travel_mm: 7500.0,
        max_speed_mm_s: 2000.0,
        max_accel_mm_s2: 4000.0,
        counts_per_mm: 100.0,
    };

    #[test]
    fn a_ball_at_the_top_goes_down_the_distance_at_the_safe_speed() {
        let one = plan(0, DEFAULT_DISTANCE_MM, &LIMITS).unwrap();
        assert_eq!((one.from_counts, one.to_counts), (0, 30_000));
        assert_eq!(one.distance_mm, 300.0);
        assert_eq!(one.speed_counts_s, 25_000);
        // 300 mm at 250 mm/s plus 250/4000 s to speed up and slow down.
        assert_eq!(one.leg.as_millis(), 1262);
        assert_eq!(one.duration().as_millis(), 3025);
    }

    #[test]
    fn the_move_keeps_within_the_travel() {
        // 100 mm above the end: it goes up instead of only 100 mm down.
        let near_end = plan(740_000, 300.0, &LIMITS).unwrap();
        assert_eq!(near_end.to_counts, 710_000);
        // 200 mm above it: down to the end, 200 mm.
        let close = plan(730_000, 300.0, &LIMITS).unwrap();
        assert_eq!(close.to_counts, 750_000);
        // Farther than the travel: the whole travel.
        let far = plan(0, 10_000.0, &LIMITS).unwrap();
        assert_eq!(far.to_counts, 750_000);
        // A slow matrix: half its top speed; a short move never reaches it.
        let slow = MoveLimits {
            max_speed_mm_s: 100.0,
            ..LIMITS
        };
        let short = plan(0, 0.5, &slow).unwrap();
        assert_eq!(short.speed_counts_s, 5_000);
        assert_eq!(
            short.leg,
            Duration::from_secs_f64(2.0 * (0.5f64 / 4000.0).sqrt())
        );
        for bad in [0.0, -3.0, f64::NAN, f64::INFINITY] {
            assert_eq!(plan(0, bad, &LIMITS), None, "{bad}");
        }
    }
}
