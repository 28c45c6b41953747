//! Motion: one PVT row as a cubic Hermite segment ([`segment`]: the single evaluation
//! every family, the preview, validation and the simulators share), and motion
//! profiles: point-to-point moves (`SP`, `PA`, `BG`) with a trapezoidal speed
//! profile, and braking with a constant deceleration — the model of how a unit moves
//! outside its PVT table.
//!
//! The planner's player uses [`Trapezoid`] to know how long an approach or a homing
//! move takes; the simulator ([`crate::uim2503::sim`]) moves its balls by the same profiles.
//!
//! Every piece of motion is a [`Segment`]: a phase of constant acceleration is exactly a
//! Hermite cubic whose cubic term is zero, so point-to-point moves and braking are
//! evaluated by the same function as PVT rows.
//!
//! ```
//! use floatball_shared::motion::Trapezoid;
//!
//! // From rest at 0 to 10 000 counts at 20 000 counts/s, accelerating at 100 000
//! // counts/s²: 0.2 s up to speed, 0.3 s cruising, 0.2 s down.
//! let ptp = Trapezoid::new(0.0, 0.0, 10_000.0, 20_000.0, 100_000.0);
//! assert!((ptp.duration_s() - 0.7).abs() < 1e-12);
//! assert!((ptp.kinematics(0.35).velocity - 20_000.0).abs() < 1e-9);
//! assert_eq!(ptp.kinematics(0.7).position, 10_000.0);
//! ```

pub mod segment;

pub use segment::{Extremum, Kinematics, PositionRange, Segment, hermite_position};

/// Most pieces of a point-to-point move: stop, speed up (or slow down to the speed),
/// cruise, slow down to the target.
const MAX_PIECES: usize = 4;

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
}

/// A phase of constant acceleration from `v0` to `v1` over `duration_s`, as a segment.
fn constant_accel(p0: f64, v0: f64, v1: f64, duration_s: f64) -> Segment {
    Segment::new(p0, v0, p0 + (v0 + v1) / 2.0 * duration_s, v1, duration_s)
}

/// Braking from `velocity_counts_s` to rest at `decel_counts_s2` (positive, finite):
/// what a unit does when a PVT run ends moving (`SD`) or on a stop.
#[must_use]
pub fn braking(position_counts: f64, velocity_counts_s: f64, decel_counts_s2: f64) -> Segment {
    constant_accel(
        position_counts,
        velocity_counts_s,
        0.0,
        velocity_counts_s.abs() / decel_counts_s2,
    )
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
}
