//! A drive's speed profile: pieces of constant acceleration from any position and
//! velocity, with separate rates for speeding up (`AC`) and slowing down (`DE`) — the
//! one thing [`crate::motion::Trapezoid`] (one rate both ways) does not model.
//!
//! Three shapes: [`Profile::to_rest`] (a move that ends at rest on a target: `FL`,
//! `FP`, and `FS` once its sensor is found), [`Profile::run`] (reach a speed and keep it:
//! `FS` looking for its sensor) and [`Profile::stop`] (slow down to rest: `ST`, `SK`).
//! Times are seconds from the profile's start; positions and velocities are counts and
//! counts/s.

/// One piece of constant acceleration.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    /// When it starts, s from the profile's start.
    start_s: f64,
    /// Its length, s (infinite for a run that never ends).
    duration_s: f64,
    /// Position at its start, counts.
    x0: f64,
    /// Velocity at its start, counts/s.
    v0: f64,
    /// Acceleration, counts/s².
    a: f64,
}

impl Piece {
    fn at(&self, tau_s: f64) -> (f64, f64) {
        (
            self.x0 + self.v0 * tau_s + 0.5 * self.a * tau_s * tau_s,
            self.v0 + self.a * tau_s,
        )
    }

    fn end(&self) -> (f64, f64) {
        self.at(self.duration_s)
    }
}

/// Pieces of constant acceleration, then rest at `end_counts` (or, for a run, the last
/// piece never ends).
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    pieces: Vec<Piece>,
    start_counts: f64,
    /// Where it ends at rest (for a run: `None`).
    end_counts: Option<f64>,
}

/// Whether a rate is usable (positive and finite).
fn usable(value: f64) -> bool {
    value > 0.0 && value.is_finite()
}

impl Profile {
    /// Builds pieces from `(x, v)`, skipping empty ones.
    fn builder(x: f64, v: f64) -> Builder {
        Builder {
            pieces: Vec::new(),
            x,
            v,
            t: 0.0,
        }
    }

    /// From `position_counts` moving at `velocity_counts_s` to rest at `target_counts`,
    /// at most `speed_counts_s`, speeding up at `accel_counts_s2` and slowing down at
    /// `decel_counts_s2`. Moving away from the target, or too fast to stop before it,
    /// it first stops (at `decel`), then comes back. A rate that is not positive and
    /// finite means no move: it stays where it is.
    #[must_use]
    pub fn to_rest(
        position_counts: f64,
        velocity_counts_s: f64,
        target_counts: f64,
        speed_counts_s: f64,
        accel_counts_s2: f64,
        decel_counts_s2: f64,
    ) -> Self {
        let mut b = Self::builder(position_counts, velocity_counts_s);
        let movable = usable(speed_counts_s)
            && usable(accel_counts_s2)
            && usable(decel_counts_s2)
            && target_counts.is_finite();
        if !movable {
            // No move; a moving drive still stops.
            b.brake(decel_counts_s2.max(accel_counts_s2).max(1.0));
            let end = b.x;
            return b.finish(position_counts, Some(end));
        }
        let (a, d) = (accel_counts_s2, decel_counts_s2);
        let distance = target_counts - b.x;
        let toward = distance.signum();
        let u = b.v * toward;
        if b.v != 0.0 && (u < 0.0 || distance == 0.0 || u * u / (2.0 * d) > distance.abs()) {
            b.brake(d);
        }
        let distance = target_counts - b.x;
        if distance != 0.0 {
            let s = distance.signum();
            let big_d = distance.abs();
            let u = (b.v * s).max(0.0);
            let vmax = speed_counts_s;
            if u > vmax {
                // Faster than the speed: slow down to it, cruise, slow down to rest.
                let down = (u * u - vmax * vmax) / (2.0 * d);
                let last = vmax * vmax / (2.0 * d);
                b.push((u - vmax) / d, -s * d);
                b.push((big_d - down - last).max(0.0) / vmax, 0.0);
                b.push(vmax / d, -s * d);
            } else {
                let peak = ((2.0 * a * d * big_d + d * u * u) / (a + d)).sqrt();
                let peak = peak.min(vmax).max(u);
                let up = (peak * peak - u * u) / (2.0 * a);
                let down = peak * peak / (2.0 * d);
                b.push((peak - u) / a, s * a);
                if peak > 0.0 {
                    b.push((big_d - up - down).max(0.0) / peak, 0.0);
                }
                b.push(peak / d, -s * d);
            }
        }
        b.finish(position_counts, Some(target_counts))
    }

    /// From `position_counts` at `velocity_counts_s`, reach `run_counts_s` (signed: the
    /// direction) speeding up at `accel_counts_s2` (or slowing down at
    /// `decel_counts_s2`), then keep it for ever.
    #[must_use]
    pub fn run(
        position_counts: f64,
        velocity_counts_s: f64,
        run_counts_s: f64,
        accel_counts_s2: f64,
        decel_counts_s2: f64,
    ) -> Self {
        let mut b = Self::builder(position_counts, velocity_counts_s);
        let dv = run_counts_s - b.v;
        // Speeding up when the speed grows in the run's direction.
        let rate = if b.v * run_counts_s >= 0.0 && run_counts_s.abs() >= b.v.abs() {
            accel_counts_s2
        } else {
            decel_counts_s2
        };
        if usable(rate) && run_counts_s.is_finite() {
            b.push(dv.abs() / rate, dv.signum() * rate);
            b.push(f64::INFINITY, 0.0);
        } else {
            b.push(f64::INFINITY, 0.0);
        }
        b.finish(position_counts, None)
    }

    /// From `position_counts` at `velocity_counts_s`, slow down to rest at
    /// `decel_counts_s2`.
    #[must_use]
    pub fn stop(position_counts: f64, velocity_counts_s: f64, decel_counts_s2: f64) -> Self {
        let mut b = Self::builder(position_counts, velocity_counts_s);
        b.brake(if usable(decel_counts_s2) {
            decel_counts_s2
        } else {
            f64::MAX
        });
        let end = b.x;
        b.finish(position_counts, Some(end))
    }

    /// How long it lasts, s (infinite for a run).
    #[must_use]
    pub fn duration_s(&self) -> f64 {
        if self.end_counts.is_none() {
            return f64::INFINITY;
        }
        self.pieces.last().map_or(0.0, |p| p.start_s + p.duration_s)
    }

    /// Where it ends at rest, if it ends.
    #[must_use]
    pub fn end_counts(&self) -> Option<f64> {
        self.end_counts
    }

    /// Position (counts) and velocity (counts/s) `tau_s` after its start; after its end
    /// exactly its end, at rest.
    #[must_use]
    pub fn at(&self, tau_s: f64) -> (f64, f64) {
        if tau_s >= self.duration_s()
            && let Some(end) = self.end_counts
        {
            return (end, 0.0);
        }
        match self
            .pieces
            .iter()
            .rev()
            .find(|p| p.start_s <= tau_s.max(0.0))
        {
            Some(piece) => piece.at(tau_s.max(0.0) - piece.start_s),
            None => (self.start_counts, 0.0),
        }
    }
}

/// Appends pieces, following the position and velocity.
struct Builder {
    pieces: Vec<Piece>,
    x: f64,
    v: f64,
    t: f64,
}

impl Builder {
    fn push(&mut self, duration_s: f64, a: f64) {
        if duration_s.is_nan() || duration_s <= 0.0 {
            return;
        }
        let piece = Piece {
            start_s: self.t,
            duration_s,
            x0: self.x,
            v0: self.v,
            a,
        };
        self.pieces.push(piece);
        if duration_s.is_finite() {
            (self.x, self.v) = piece.end();
            self.t += duration_s;
        }
    }

    /// Slows down to rest at `decel`.
    fn brake(&mut self, decel: f64) {
        if self.v != 0.0 {
            let v = self.v;
            self.push(v.abs() / decel, -v.signum() * decel);
            self.v = 0.0;
        }
    }

    fn finish(self, start_counts: f64, end_counts: Option<f64>) -> Profile {
        Profile {
            pieces: self.pieces,
            start_counts,
            end_counts,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-6 * (1.0 + b.abs())
    }

    #[test]
    fn a_rest_to_rest_move_speeds_up_at_ac_cruises_and_slows_down_at_de() {
        // 0 → 10 000 counts at 2 000 counts/s, AC 1 000 counts/s², DE 4 000 counts/s²:
        // 2 s up (2 000 counts), 0.5 s down (500 counts), 3.75 s cruising.
        let p = Profile::to_rest(0.0, 0.0, 10_000.0, 2_000.0, 1_000.0, 4_000.0);
        assert!(close(p.duration_s(), 6.25), "{}", p.duration_s());
        assert!(close(p.at(1.0).0, 500.0));
        assert!(close(p.at(2.0).1, 2_000.0));
        assert!(close(p.at(5.75).0, 9_500.0));
        assert_eq!(p.at(6.25), (10_000.0, 0.0));
        assert_eq!(p.at(100.0), (10_000.0, 0.0));
        // Backwards, and a triangle: 0 → −1 000 at AC = DE = 1 000: 1 s each way.
        let p = Profile::to_rest(0.0, 0.0, -1_000.0, 5_000.0, 1_000.0, 1_000.0);
        assert!(close(p.duration_s(), 2.0));
        assert!(close(p.at(1.0).1, -1_000.0));
    }

    #[test]
    fn a_move_from_speed_keeps_it_then_stops_and_one_too_fast_comes_back() {
        // At 1 000 counts/s, 1 000 counts to go, DE 1 000: 0.5 s cruising, 1 s down.
        let p = Profile::to_rest(0.0, 1_000.0, 1_000.0, 1_000.0, 1_000.0, 1_000.0);
        assert!(close(p.duration_s(), 1.5));
        assert!(close(p.at(0.5).0, 500.0));
        // At 1 000 counts/s with 100 to go: stops 500 further, comes back.
        let p = Profile::to_rest(0.0, 1_000.0, 100.0, 1_000.0, 1_000.0, 1_000.0);
        assert!(close(p.at(1.0).0, 500.0));
        assert_eq!(p.at(p.duration_s()), (100.0, 0.0));
        // Faster than the speed: slows to it first.
        let p = Profile::to_rest(0.0, 2_000.0, 10_000.0, 1_000.0, 1_000.0, 1_000.0);
        assert!(close(p.at(1.0).1, 1_000.0));
    }

    #[test]
    fn a_run_keeps_its_speed_and_a_stop_brakes_at_de() {
        let p = Profile::run(0.0, 0.0, -2_000.0, 1_000.0, 4_000.0);
        assert_eq!(p.duration_s(), f64::INFINITY);
        assert!(close(p.at(2.0).1, -2_000.0));
        assert!(close(p.at(3.0).0, -2_000.0 - 2_000.0));
        let p = Profile::stop(0.0, 2_000.0, 4_000.0);
        assert!(close(p.duration_s(), 0.5));
        assert_eq!(p.at(1.0), (500.0, 0.0));
        let p = Profile::to_rest(7.0, 0.0, 7.0, 1.0, 1.0, 1.0);
        assert_eq!(p.duration_s(), 0.0);
        assert_eq!(p.at(0.0), (7.0, 0.0));
    }
}
