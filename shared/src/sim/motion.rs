//! Motion outside the PVT table: point-to-point moves (`SP`, `PA`, `BG`) with a
//! trapezoidal speed profile, braking with a constant deceleration, and where a motion
//! first leaves the travel.
//!
//! Every piece of motion is a [`Segment`]: a phase of constant acceleration is exactly a
//! Hermite cubic whose cubic term is zero, so point-to-point moves and braking are
//! evaluated by the same function as PVT rows.
//!
//! ```
//! use floatball_shared::sim::Trapezoid;
//!
//! // From rest at 0 to 10 000 counts at 20 000 counts/s, accelerating at 100 000
//! // counts/s²: 0.2 s up to speed, 0.3 s cruising, 0.2 s down.
//! let ptp = Trapezoid::new(0.0, 0.0, 10_000.0, 20_000.0, 100_000.0);
//! assert!((ptp.duration_s() - 0.7).abs() < 1e-12);
//! assert!((ptp.kinematics(0.35).velocity - 20_000.0).abs() < 1e-9);
//! assert_eq!(ptp.kinematics(0.7).position, 10_000.0);
//! ```

use crate::pvt::{Kinematics, Segment};

/// Most pieces of a point-to-point move: stop, speed up (or slow down to the speed),
/// cruise, slow down to the target.
const MAX_PIECES: usize = 4;

/// How far past a limit (counts) a motion may reach before it counts as leaving the
/// travel: float noise on a row that ends exactly at 0 is not a limit hit.
const LIMIT_TOLERANCE_COUNTS: f64 = 1e-6;

/// A point-to-point move from any position and velocity to rest at a target, with at
/// most a given speed and a given acceleration (both ways): the UFQ750's `SP=v;PA=p;BG;`.
///
/// The profile: if the ball moves away from the target, or too fast to stop before it,
/// it first stops; then it speeds up to the speed (or, arriving faster, slows down to
/// it), cruises, and slows down to stop exactly at the target. A move too short to reach
/// the speed is a triangle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trapezoid {
    pieces: [Segment; MAX_PIECES],
    count: usize,
    target_counts: f64,
    duration_s: f64,
}

impl Trapezoid {
    /// The move from `position_counts` moving at `velocity_counts_s` to rest at
    /// `target_counts`. `speed_counts_s` and `accel_counts_s2` must be positive and
    /// finite; otherwise there is no move (the ball stays where it is).
    #[must_use]
    pub fn new(
        position_counts: f64,
        velocity_counts_s: f64,
        target_counts: f64,
        speed_counts_s: f64,
        accel_counts_s2: f64,
    ) -> Self {
        let mut ptp = Self {
            pieces: [Segment::new(0.0, 0.0, 0.0, 0.0, 0.0); MAX_PIECES],
            count: 0,
            target_counts,
            duration_s: 0.0,
        };
        let usable = |value: f64| value > 0.0 && value.is_finite();
        if !usable(speed_counts_s) || !usable(accel_counts_s2) {
            ptp.target_counts = position_counts;
            return ptp;
        }
        let (speed, accel) = (speed_counts_s, accel_counts_s2);
        let (mut x, mut v) = (position_counts, velocity_counts_s);
        let away_or_too_fast = |x: f64, v: f64| {
            let d = target_counts - x;
            v * d <= 0.0 || v * v / (2.0 * accel) > d.abs()
        };
        if v != 0.0 && away_or_too_fast(x, v) {
            x = ptp.push(constant_accel(x, v, 0.0, v.abs() / accel));
            v = 0.0;
        }
        let distance = target_counts - x;
        if distance == 0.0 {
            return ptp;
        }
        let direction = distance.signum();
        // Speed towards the target, never negative here.
        let mut toward = v * direction;
        if toward > speed {
            x = ptp.push(constant_accel(
                x,
                v,
                direction * speed,
                (toward - speed) / accel,
            ));
            toward = speed;
        }
        let remaining = (target_counts - x).abs();
        let full_speed_needs = (speed * speed - toward * toward + speed * speed) / (2.0 * accel);
        let peak = if full_speed_needs <= remaining {
            speed
        } else {
            (accel * remaining + toward * toward / 2.0)
                .sqrt()
                .max(toward)
        };
        if peak > toward {
            x = ptp.push(constant_accel(
                x,
                direction * toward,
                direction * peak,
                (peak - toward) / accel,
            ));
        }
        let cruise = (target_counts - x).abs() - peak * peak / (2.0 * accel);
        if cruise > 0.0 {
            x = ptp.push(Segment::new(
                x,
                direction * peak,
                x + direction * cruise,
                direction * peak,
                cruise / peak,
            ));
        }
        ptp.push(Segment::new(
            x,
            direction * peak,
            target_counts,
            0.0,
            peak / accel,
        ));
        ptp
    }

    /// Appends a piece; returns where it ends.
    fn push(&mut self, piece: Segment) -> f64 {
        if let Some(slot) = self.pieces.get_mut(self.count) {
            *slot = piece;
            self.count += 1;
            self.duration_s += piece.duration_s;
        }
        piece.p1
    }

    /// The pieces of the move, in order; each is a phase of constant acceleration.
    #[must_use]
    pub fn pieces(&self) -> &[Segment] {
        self.pieces.get(..self.count).unwrap_or_default()
    }

    /// Where the move ends, counts.
    #[must_use]
    pub fn target_counts(&self) -> f64 {
        self.target_counts
    }

    /// How long the move takes, seconds (0 when there is nothing to do).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The highest speed the move reaches, counts/s.
    #[must_use]
    pub fn peak_speed_counts_s(&self) -> f64 {
        self.pieces()
            .iter()
            .map(|piece| piece.peak_speed().value)
            .fold(0.0, f64::max)
    }

    /// Position, velocity and acceleration `tau_s` seconds after the move began; at
    /// rest on the target from [`duration_s`](Self::duration_s) on.
    #[must_use]
    pub fn kinematics(&self, tau_s: f64) -> Kinematics {
        let mut start_s = 0.0;
        for piece in self.pieces() {
            if tau_s < start_s + piece.duration_s {
                return piece.kinematics((tau_s - start_s).max(0.0));
            }
            start_s += piece.duration_s;
        }
        Kinematics {
            position: self.target_counts,
            velocity: 0.0,
            acceleration: 0.0,
        }
    }

    /// The first moment the move leaves `0..=travel_counts`, if it does.
    pub(super) fn exit(&self, travel_counts: f64) -> Option<Exit> {
        let mut start_s = 0.0;
        for piece in self.pieces() {
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
}

/// A phase of constant acceleration from `v0` to `v1` over `duration_s`, as a segment.
fn constant_accel(p0: f64, v0: f64, v1: f64, duration_s: f64) -> Segment {
    Segment::new(p0, v0, p0 + (v0 + v1) / 2.0 * duration_s, v1, duration_s)
}

/// Braking from `velocity_counts_s` to rest at `decel_counts_s2` (positive, finite).
pub(super) fn braking(
    position_counts: f64,
    velocity_counts_s: f64,
    decel_counts_s2: f64,
) -> Segment {
    constant_accel(
        position_counts,
        velocity_counts_s,
        0.0,
        velocity_counts_s.abs() / decel_counts_s2,
    )
}

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

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const A: f64 = 100_000.0;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-9 * (1.0 + a.abs().max(b.abs()))
    }

    /// Checks continuity between pieces and the bounds of speed and acceleration.
    fn check(ptp: &Trapezoid, speed: f64) {
        let mut previous: Option<Segment> = None;
        for piece in ptp.pieces() {
            if let Some(previous) = previous {
                assert!(close(previous.p1, piece.p0), "{ptp:?}");
                assert!(close(previous.v1, piece.v0), "{ptp:?}");
            }
            assert!(piece.duration_s > 0.0);
            assert!(
                piece.peak_acceleration().value <= A * (1.0 + 1e-9),
                "{piece:?}"
            );
            previous = Some(*piece);
        }
        assert!(ptp.peak_speed_counts_s() <= speed.max(ptp.pieces()[0].v0.abs()) + 1e-6);
        let end = ptp.kinematics(ptp.duration_s());
        assert_eq!((end.position, end.velocity), (ptp.target_counts(), 0.0));
        if let Some(last) = ptp.pieces().last() {
            assert_eq!((last.p1, last.v1), (ptp.target_counts(), 0.0));
        }
    }

    #[test]
    fn a_long_move_is_a_trapezoid() {
        let ptp = Trapezoid::new(1000.0, 0.0, 11_000.0, 20_000.0, A);
        check(&ptp, 20_000.0);
        assert_eq!(ptp.pieces().len(), 3);
        assert!(close(ptp.duration_s(), 0.7));
        assert!(close(ptp.peak_speed_counts_s(), 20_000.0));
        // Up to speed after 0.2 s and 2000 counts, down from 0.5 s.
        assert!(close(ptp.kinematics(0.2).position, 3000.0));
        assert!(close(ptp.kinematics(0.1).acceleration, A));
        assert!(close(ptp.kinematics(0.6).acceleration, -A));
        assert!(close(ptp.kinematics(0.6).velocity, 10_000.0));
    }

    #[test]
    fn a_short_move_is_a_triangle() {
        // 1000 counts at 100000 counts/s²: peak sqrt(1e8) = 10000 counts/s at 0.1 s.
        let ptp = Trapezoid::new(5000.0, 0.0, 4000.0, 50_000.0, A);
        check(&ptp, 50_000.0);
        assert_eq!(ptp.pieces().len(), 2);
        assert!(close(ptp.duration_s(), 0.2));
        assert!(close(ptp.peak_speed_counts_s(), 10_000.0));
        assert!(close(ptp.kinematics(0.1).velocity, -10_000.0));
    }

    #[test]
    fn moving_away_it_stops_first_and_arriving_fast_it_slows_to_the_speed() {
        let away = Trapezoid::new(0.0, -10_000.0, 10_000.0, 20_000.0, A);
        check(&away, 20_000.0);
        assert_eq!(away.pieces().len(), 4);
        assert!(close(away.pieces()[0].p1, -500.0));
        let fast = Trapezoid::new(0.0, 40_000.0, 100_000.0, 20_000.0, A);
        check(&fast, 40_000.0);
        assert_eq!(fast.pieces()[0].v1, 20_000.0);
        let overshoot = Trapezoid::new(0.0, 40_000.0, 1000.0, 20_000.0, A);
        check(&overshoot, 40_000.0);
        assert!(
            close(overshoot.pieces()[0].p1, 8000.0),
            "stops past, comes back"
        );
        assert!(overshoot.kinematics(0.5).velocity < 0.0);
    }

    #[test]
    fn nothing_to_do_is_no_move() {
        let still = Trapezoid::new(300.0, 0.0, 300.0, 1000.0, A);
        assert_eq!((still.pieces().len(), still.duration_s()), (0, 0.0));
        assert_eq!(still.kinematics(1.0).position, 300.0);
        // Arriving at 10000 counts/s with just the room to stop: one steady deceleration
        // (slowing to the speed, then to rest).
        let stopping_on_target = Trapezoid::new(0.0, 10_000.0, 500.0, 1000.0, A);
        check(&stopping_on_target, 10_000.0);
        assert!(close(stopping_on_target.duration_s(), 0.1));
        for piece in stopping_on_target.pieces() {
            assert!(close(piece.kinematics(0.0).acceleration, -A));
        }
        let unusable = Trapezoid::new(300.0, 50.0, 900.0, 0.0, A);
        assert_eq!(unusable.target_counts(), 300.0);
        assert_eq!(unusable.duration_s(), 0.0);
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
        let exit = ptp.exit(1e4).unwrap();
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
