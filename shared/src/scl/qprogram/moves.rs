//! The trapezoid of one move, as a MOONS' drive runs an `FP`: accelerate at `AC`,
//! cruise at `VE`, decelerate at `DE`, from rest to rest; a move too short to reach
//! `VE` is a triangle (it accelerates until it must decelerate). Distances are in
//! counts, speeds in counts/s, accelerations in counts/s², times in seconds.
//!
//! [`solve_speed`] picks the cruise speed that makes a move last a given time;
//! [`Trapezoid::duration_s`] and [`Trapezoid::travelled`] are the drive's own
//! arithmetic, which the compiler runs on the rounded values it writes so that its
//! clock follows the drive's.

/// One move's profile: how far (counts, not negative) at which speed and rates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Trapezoid {
    /// Distance, counts (not negative).
    pub distance: f64,
    /// Cruise speed (`VE`), counts/s, above zero.
    pub speed: f64,
    /// Acceleration (`AC`), counts/s², above zero.
    pub accel: f64,
    /// Deceleration (`DE`), counts/s², above zero.
    pub decel: f64,
}

impl Trapezoid {
    /// The highest speed the move reaches: `speed`, or less for a triangle.
    fn peak(&self) -> f64 {
        let ramps = self.speed * self.speed * (0.5 / self.accel + 0.5 / self.decel);
        if self.distance >= ramps {
            self.speed
        } else {
            (2.0 * self.distance * self.accel * self.decel / (self.accel + self.decel)).sqrt()
        }
    }

    /// How long the move lasts, s.
    pub fn duration_s(&self) -> f64 {
        if self.distance <= 0.0 {
            return 0.0;
        }
        let peak = self.peak();
        let ramps = peak * peak * (0.5 / self.accel + 0.5 / self.decel);
        peak / self.accel + peak / self.decel + (self.distance - ramps).max(0.0) / peak
    }

    /// Counts travelled `t_s` seconds after the start (0 before, `distance` after).
    pub fn travelled(&self, t_s: f64) -> f64 {
        if t_s <= 0.0 || self.distance <= 0.0 {
            return 0.0;
        }
        let peak = self.peak();
        let t_up = peak / self.accel;
        let t_down = peak / self.decel;
        let up = 0.5 * peak * t_up;
        let down = 0.5 * peak * t_down;
        let t_cruise = (self.distance - up - down).max(0.0) / peak;
        if t_s < t_up {
            0.5 * self.accel * t_s * t_s
        } else if t_s < t_up + t_cruise {
            up + peak * (t_s - t_up)
        } else {
            let left = t_up + t_cruise + t_down - t_s;
            if left <= 0.0 {
                self.distance
            } else {
                self.distance - 0.5 * self.decel * left * left
            }
        }
    }
}

/// The cruise speed (counts/s) that moves `distance` counts in exactly `duration_s`
/// with acceleration and deceleration both `accel`: the smaller root of
/// `distance = v (duration − v / accel)`. `None` when the move cannot make its time at
/// that acceleration (`accel · duration² < 4 · distance`: even a triangle is too slow).
pub(crate) fn solve_speed(distance: f64, duration_s: f64, accel: f64) -> Option<f64> {
    if !(distance > 0.0 && duration_s > 0.0 && accel > 0.0) {
        return None;
    }
    let discriminant = accel * accel * duration_s * duration_s - 4.0 * accel * distance;
    if discriminant < 0.0 {
        return None;
    }
    // The smaller root, written without cancellation: v = 2 a D / (a T + √disc).
    Some(2.0 * accel * distance / (accel * duration_s + discriminant.sqrt()))
}
