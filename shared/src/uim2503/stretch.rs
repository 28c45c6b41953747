//! The clock trim of a streamed UIM2503 show (a timecode chase, `docs/show-control.md`):
//! how much the units' show clock is stretched, as a function of the show's nominal
//! time, and what that makes of each row's time field (`QT`) not yet sent.
//!
//! A [`Stretch`] is `C(T)`, ms, piecewise linear in the nominal show time `T`: a row
//! from `T₀` to `T₁` is written `round(C(T₁)) − round(C(T₀))` ms longer (shorter when
//! negative). The units then reach nominal time `T` at `start + T + C(T)`: the show
//! plays `C(T)` later than planned. Every unit's row ending at the same nominal time
//! ends at the same instant whatever its rows' lengths (within the rounding, 1 ms), so
//! the units stay together. `C`'s slope is at most `1 / the longest row` (ms per ms),
//! so **no row gains or loses more than 1 ms**. Steering ([`Stretch::steer`]) changes
//! `C` only from a nominal time on (the end of the rows already sent, which on a
//! streaming gateway is about a table ahead of the units): from there it heads for
//! the target at the steepest slope allowed, then follows the clocks' drift, so rows
//! sent now are right when they play.

/// One piece of `C`: from `from_ms` on, `base_ms + slope × (T − from_ms)`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Piece {
    from_ms: f64,
    base_ms: f64,
    slope: f64,
}

/// The stretch `C(T)` of a show's clock; see the [module documentation](self).
#[derive(Debug, Clone, PartialEq)]
pub struct Stretch {
    pieces: Vec<Piece>,
    max_slope: f64,
}

impl Stretch {
    /// No stretch yet, for a show whose longest row lasts `longest_row_ms`.
    #[must_use]
    pub fn new(longest_row_ms: u64) -> Self {
        Self {
            pieces: Vec::new(),
            max_slope: 1.0 / longest_row_ms.max(1) as f64,
        }
    }

    /// `C(t_ms)`, ms.
    #[must_use]
    pub fn at(&self, t_ms: f64) -> f64 {
        self.pieces
            .iter()
            .rev()
            .find(|piece| piece.from_ms <= t_ms)
            .map_or(0.0, |piece| {
                piece.base_ms + piece.slope * (t_ms - piece.from_ms)
            })
    }

    /// From nominal time `from_ms` on (nothing sent ends after it), `C` heads for the
    /// line that is `target_ms` at `from_ms` and rises `drift` ms a ms (the clocks'
    /// drift, so the rows sent now are right when they play) as steeply as allowed,
    /// then follows it (no steeper than allowed either).
    pub fn steer(&mut self, from_ms: f64, target_ms: f64, drift: f64) {
        let base_ms = self.at(from_ms);
        self.pieces.retain(|piece| piece.from_ms < from_ms);
        let drift = drift.clamp(-self.max_slope, self.max_slope);
        let gap_ms = target_ms - base_ms;
        let slope = self.max_slope.copysign(gap_ms);
        // Where C at `slope` meets the line.
        let meet_ms = if gap_ms.abs() < 1e-9 {
            0.0
        } else if (slope - drift).abs() < 1e-12 {
            f64::INFINITY
        } else {
            gap_ms / (slope - drift)
        };
        if meet_ms > 0.0 {
            self.pieces.push(Piece {
                from_ms,
                base_ms,
                slope,
            });
        }
        if meet_ms.is_finite() {
            self.pieces.push(Piece {
                from_ms: from_ms + meet_ms,
                base_ms: base_ms + slope * meet_ms,
                slope: drift,
            });
        }
    }

    /// How many ms the row from `start_ms` lasting `duration_ms` (nominal) gains: −1,
    /// 0 or +1.
    #[must_use]
    pub fn row_ms(&self, start_ms: u64, duration_ms: u64) -> i32 {
        let c = |t_ms: u64| self.at(t_ms as f64).round();
        let gain = c(start_ms + duration_ms) - c(start_ms);
        gain.clamp(-1.0, 1.0) as i32
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn no_row_gains_or_loses_more_than_a_millisecond_and_the_gains_add_up() {
        // Rows of 100 and 40 ms (two units), a target 25 ms later, then 30 ms earlier.
        let mut stretch = Stretch::new(100);
        assert_eq!(stretch.row_ms(0, 100), 0, "no stretch yet");
        stretch.steer(1_000.0, 25.0, 0.0);
        // Steepest slope 1 ms per 100 ms: 25 ms are reached 2.5 s after 1 s.
        assert_eq!(stretch.at(1_000.0), 0.0);
        assert!((stretch.at(2_250.0) - 12.5).abs() < 1e-9);
        assert_eq!(stretch.at(3_500.0), 25.0);
        assert_eq!(stretch.at(60_000.0), 25.0);
        for duration_ms in [100, 40] {
            let mut total = 0;
            let mut start_ms = 0;
            while start_ms < 10_000 {
                let gain = stretch.row_ms(start_ms, duration_ms);
                assert!(gain.abs() <= 1, "{gain} at {start_ms}");
                total += gain;
                start_ms += duration_ms;
            }
            assert_eq!(total, 25, "rows of {duration_ms} ms");
        }
        // Steered back from 5 s: rows before are as they were sent.
        stretch.steer(5_000.0, -5.0, 0.0);
        assert_eq!(stretch.at(4_000.0), 25.0);
        assert_eq!(stretch.at(8_000.0), -5.0);
        let mut total = 0;
        for start_ms in (0..20_000).step_by(100) {
            let gain = stretch.row_ms(start_ms, 100);
            assert!(gain.abs() <= 1);
            total += gain;
        }
        assert_eq!(total, -5);
        // Rows of the longest length gain at most one ms even at the steepest slope.
        let mut stretch = Stretch::new(255);
        stretch.steer(0.0, 1_000.0, 0.0);
        assert!(
            (0..400_000)
                .step_by(255)
                .all(|t| stretch.row_ms(t, 255) <= 1)
        );
        // With a drift: up to the line at the steepest slope, then along it.
        let mut stretch = Stretch::new(100);
        stretch.steer(0.0, 10.0, -0.005);
        // 10 − 0.005 t = 0.01 t at t = 10 / 0.015.
        let meet = 10.0 / 0.015;
        assert!((stretch.at(meet) - 0.01 * meet).abs() < 1e-9);
        assert!((stretch.at(meet + 1_000.0) - (0.01 * meet - 5.0)).abs() < 1e-9);
        // A drift steeper than allowed is followed as steeply as allowed.
        let mut stretch = Stretch::new(100);
        stretch.steer(0.0, 0.0, 0.02);
        assert!((stretch.at(1_000.0) - 10.0).abs() < 1e-9);
    }
}
