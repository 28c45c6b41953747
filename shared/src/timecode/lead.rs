//! The lead a chase's Start will take, estimated from what the plan knows before any
//! Start was measured ([`super::chase`]): how long every ball takes to approach the
//! cue's first position from where it is (home first when that is unknown), and what
//! the family loads before its common start — a UIM2503 table preloaded through each
//! gateway's line ([`crate::line::Line`]), MBOX boxes' settle frames after each move.
//! Measured leads refine it (the chase keeps the error of the last estimate).

use crate::line::Line;

/// How the balls move between shows (the installation's approach).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Approach and homing speed, mm/s.
    pub speed_mm_s: f64,
    /// Acceleration, mm/s².
    pub accel_mm_s2: f64,
    /// The whole travel, mm: a move from an unknown position may cross it.
    pub travel_mm: f64,
    /// The home position, mm.
    pub home_mm: f64,
}

impl Motion {
    /// A move of `distance_mm` from rest to rest at the speed and acceleration, ms
    /// (a triangle when too short to reach the speed).
    #[must_use]
    pub fn move_ms(&self, distance_mm: f64) -> f64 {
        let speed = self.speed_mm_s.max(1e-9);
        let accel = self.accel_mm_s2.max(1e-9);
        let distance = distance_mm.abs();
        let seconds = if distance < speed * speed / accel {
            2.0 * (distance / accel).sqrt()
        } else {
            distance / speed + speed / accel
        };
        seconds * 1_000.0
    }

    /// Every ball from `from_mm` (`None`: unknown — home first, across the whole
    /// travel) to `to_mm`, ms: the slowest ball's moves.
    #[must_use]
    pub fn approach_ms(&self, from_mm: Option<&[f64]>, to_mm: &[f64]) -> f64 {
        let farthest = |from: &dyn Fn(usize) -> f64| {
            to_mm
                .iter()
                .enumerate()
                .map(|(ball, to)| (to - from(ball)).abs())
                .fold(0.0, f64::max)
        };
        match from_mm {
            Some(from) => self.move_ms(farthest(&|ball| from.get(ball).copied().unwrap_or(0.0))),
            None => self.move_ms(self.travel_mm) + self.move_ms(farthest(&|_| self.home_mm)),
        }
    }
}

/// How long a UIM2503 table load takes before the start: each gateway's preload bytes
/// through its line at `baud`, the slowest gateway's, ms.
#[must_use]
pub fn table_load_ms(gateways: impl IntoIterator<Item = (u32, usize)>) -> f64 {
    gateways
        .into_iter()
        .map(|(baud, bytes)| Line::new(baud).time_us(bytes) as f64 / 1_000.0)
        .fold(0.0, f64::max)
}

/// The bytes of one PVT row as the preload writes it (`QP[r]p;QV[r]v;QT[r]t;`,
/// compact form) at table row `row`.
#[must_use]
pub fn row_bytes(
    row: usize,
    position_counts: i64,
    velocity_counts_s: i64,
    duration_ms: u32,
) -> usize {
    let index = row.to_string().len() + 2;
    let digits = |value: i64| value.to_string().len();
    (2 + index + digits(position_counts) + 1)
        + (2 + index + digits(velocity_counts_s) + 1)
        + (2 + index + digits(i64::from(duration_ms)) + 1)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const MOTION: Motion = Motion {
        speed_mm_s: 1_000.0,
        accel_mm_s2: 4_000.0,
        travel_mm: 3_000.0,
        home_mm: 0.0,
    };

    #[test]
    fn moves_take_their_trapezoid_and_unknown_positions_home_first() {
        // 1000 mm: 1 s at speed and 0.25 s more for the ramps.
        assert!((MOTION.move_ms(1_000.0) - 1_250.0).abs() < 1e-9);
        // 100 mm never reaches the speed: 2 √(100 / 4000) s.
        assert!((MOTION.move_ms(100.0) - 316.227_766).abs() < 1e-3);
        assert_eq!(MOTION.move_ms(0.0), 0.0);
        // The farthest ball sets the time.
        let to = [500.0, 1_500.0];
        assert!((MOTION.approach_ms(Some(&[500.0, 500.0]), &to) - 1_250.0).abs() < 1e-9);
        // Unknown: the whole travel home, then from home.
        let unknown = MOTION.approach_ms(None, &to);
        assert!((unknown - (3_250.0 + 1_750.0)).abs() < 1e-9, "{unknown}");
    }

    #[test]
    fn a_table_load_is_the_slowest_line_s_bytes() {
        // 11520 bytes at 115200 baud: a second; 960 at 9600 baud: a second too.
        assert!((table_load_ms([(115_200, 11_520), (9_600, 480)]) - 1_000.0).abs() < 1.0);
        assert_eq!(
            row_bytes(7, 12_345, -50, 100),
            "QP[7]12345;QV[7]-50;QT[7]100;".len()
        );
    }
}
