//! Where a motion leaves the travel: the first moment a PVT row, a point-to-point move
//! or braking reaches a limit (the upper limit switch at 0 or the end of the travel),
//! for the simulated unit's limit stops. The motion profiles themselves are in
//! [`crate::motion`].

use crate::motion::Segment;
use crate::motion::Trapezoid;

/// How far past a limit (counts) a motion may reach before it counts as leaving the
/// travel: float noise on a row that ends exactly at 0 is not a limit hit.
const LIMIT_TOLERANCE_COUNTS: f64 = 1e-6;

/// Where a motion leaves the travel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Exit {
    /// When, seconds after the start of the motion.
    pub after_s: f64,
    /// The limit it reaches: 0 (the upper limit switch) or the travel.
    pub position_counts: f64,
}

/// The first moment `segment` leaves `0..=travel_counts`, if it does.
///
/// The segment is split where its velocity is zero; on each part the position is
/// monotone, so the first part that ends outside holds the only crossing, found by
/// bisection to the last bit.
pub(super) fn exit(segment: &Segment, travel_counts: f64) -> Option<Exit> {
    let range = segment.position_range();
    let low = -LIMIT_TOLERANCE_COUNTS;
    let high = travel_counts + LIMIT_TOLERANCE_COUNTS;
    if range.min.value >= low && range.max.value <= high {
        return None;
    }
    let outside = |position: f64| position < low || position > high;
    let limit = |position: f64| if position < low { 0.0 } else { travel_counts };
    if outside(segment.p0) {
        return Some(Exit {
            after_s: 0.0,
            position_counts: limit(segment.p0),
        });
    }
    let mut from = 0.0;
    for to in velocity_roots(segment).into_iter().flatten().chain([1.0]) {
        let end = segment.position_at_fraction(to);
        if outside(end) {
            let limit = limit(end);
            let beyond = |position: f64| {
                if limit == 0.0 {
                    position < 0.0
                } else {
                    position > travel_counts
                }
            };
            // Monotone from inside at `from` to outside at `to`: one crossing between.
            let (mut inside_s, mut beyond_s) = (from, to);
            while beyond_s - inside_s > f64::EPSILON {
                let middle = 0.5 * (inside_s + beyond_s);
                if middle <= inside_s || middle >= beyond_s {
                    break;
                }
                if beyond(segment.position_at_fraction(middle)) {
                    beyond_s = middle;
                } else {
                    inside_s = middle;
                }
            }
            return Some(Exit {
                after_s: beyond_s * segment.duration_s,
                position_counts: limit,
            });
        }
        from = to;
    }
    None
}

/// The fractions strictly inside (0, 1) where the segment's velocity is zero, in order.
fn velocity_roots(segment: &Segment) -> [Option<f64>; 2] {
    // Velocity at fraction s: a s² + b s + c (the derivative of the Hermite basis).
    let k = 6.0 * (segment.p1 - segment.p0) / segment.duration_s;
    let a = -k + 3.0 * segment.v0 + 3.0 * segment.v1;
    let b = k - 4.0 * segment.v0 - 2.0 * segment.v1;
    let c = segment.v0;
    let inside = |s: f64| (s > 0.0 && s < 1.0).then_some(s);
    let (first, second) = if a == 0.0 {
        (if b == 0.0 { None } else { inside(-c / b) }, None)
    } else {
        let discriminant = b * b - 4.0 * a * c;
        if discriminant < 0.0 {
            (None, None)
        } else {
            let q = -0.5 * (b + b.signum() * discriminant.sqrt());
            if q == 0.0 {
                (None, None)
            } else {
                (inside(q / a), inside(c / q))
            }
        }
    };
    match (first, second) {
        (Some(x), Some(y)) if y < x => [Some(y), Some(x)],
        (None, y) => [y, None],
        pair => [pair.0, pair.1],
    }
}

/// The first moment the point-to-point move `ptp` leaves `0..=travel_counts`, if it
/// does.
pub(super) fn move_exit(ptp: &Trapezoid, travel_counts: f64) -> Option<Exit> {
    let mut start_s = 0.0;
    for piece in ptp.pieces() {
        if let Some(exit) = exit(piece, travel_counts) {
            return Some(Exit {
                after_s: start_s + exit.after_s,
                ..exit
            });
        }
        start_s += piece.duration_s;
    }
    None
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::motion::braking;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    #[test]
    fn exits_are_found_where_the_ball_crosses_a_limit() {
        // Braking upward from 2000 counts/s at 1000 counts from the top: 2000 counts.
        let up = braking(1000.0, -2000.0, 1000.0);
        let exit = exit(&up, 10_000.0).unwrap();
        // 1000 = 2000 t - 500 t² → t = 2 - sqrt(2).
        assert!(close(exit.after_s, 2.0 - 2f64.sqrt()), "{exit:?}");
        assert_eq!(exit.position_counts, 0.0);
        // Downward past the travel.
        let down = Segment::new(9000.0, 0.0, 12_000.0, 0.0, 1.0);
        let exit = super::exit(&down, 10_000.0).unwrap();
        assert_eq!(exit.position_counts, 10_000.0);
        assert!(close(down.position(exit.after_s), 10_000.0));
        // A dip between rest points: the first crossing, not the last.
        let dip = Segment::new(100.0, -3000.0, 100.0, 3000.0, 0.2);
        let exit = super::exit(&dip, 10_000.0).unwrap();
        assert!(exit.after_s < 0.1 && close(dip.position(exit.after_s), 0.0));
        // Ending exactly at 0 is no exit, nor is a motion inside.
        assert_eq!(super::exit(&braking(500.0, -1000.0, 1000.0), 1e4), None);
        assert_eq!(
            super::exit(&Segment::new(10.0, 0.0, 20.0, 0.0, 0.1), 1e4),
            None
        );
        // Starting outside leaves at once.
        let outside = Segment::new(-5.0, 0.0, 10.0, 0.0, 0.1);
        assert_eq!(super::exit(&outside, 1e4).map(|e| e.after_s), Some(0.0));
        // A point-to-point move that cannot stop before the top.
        let ptp = Trapezoid::new(100.0, -2000.0, 500.0, 1000.0, 1000.0);
        let exit = move_exit(&ptp, 1e4).unwrap();
        assert!(close(ptp.kinematics(exit.after_s).position, 0.0));
    }

    #[test]
    fn velocity_roots_are_in_order() {
        // Down at the start and at the end, with the same position: it turns twice.
        let s = Segment::new(0.0, 1000.0, 0.0, 1000.0, 1.0);
        let [first, second] = velocity_roots(&s);
        let (first, second) = (first.unwrap(), second.unwrap());
        assert!(first < second);
        for root in [first, second] {
            assert!(s.kinematics_at_fraction(root).velocity.abs() < 1e-9);
        }
        assert_eq!(
            velocity_roots(&Segment::new(0.0, 0.0, 0.0, 0.0, 1.0)),
            [None, None]
        );
    }
}
