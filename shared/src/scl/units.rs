//! What a MOONS' drive holds of the numbers it is sent (issue 34, item 3): the step
//! each value is held in, the range it takes, and the text that names a held value
//! exactly. The compiler ([`super::qprogram`]) writes only values in range, chooses
//! them in whole steps and times every move from the held value; the drive twin
//! ([`super::twin`]) refuses (`?5`) what is out of range and runs the held value.
//! Sources and what is unconfirmed: `docs/protocol-notes.md` §8 ("Ranges and
//! resolutions").
//!
//! - `VE` is held in whole 0.25 rpm = 1/240 rev/s (HCR p. 287: `VE5` is sent in the
//!   binary form as 1200 units of 0.25 rpm); its smallest value is 0.0042 rev/s, one
//!   such step written with the 4 decimals the reference uses.
//! - `AC` and `DE` are held in whole 10 rpm/s = 1/6 rev/s² (HCR p. 287: `AC100` is 600
//!   units of 10 rpm/s); the smallest is 0.167 rev/s², one step with 3 decimals.
//! - `WT` is held in whole 0.01 s (unconfirmed: no page of the reference was read).
//!
//! The text written for `n` steps is `n × step` rounded **up** to the decimals: it
//! lies within a 40th of a step above the held value, so a drive that rounds to the
//! nearest step and one that truncates both hold exactly `n` steps.

use super::command::Decimal;

/// How a drive holds one kind of value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Resolution {
    /// One step, in the value's unit (rev/s, rev/s², s).
    pub step: f64,
    /// Decimals written.
    pub decimals: u8,
    /// The fewest steps a drive takes.
    pub min_steps: i64,
    /// The most steps the twin takes.
    pub max_steps: i64,
}

/// `VE`, rev/s: steps of 1/240 rev/s (0.25 rpm), from 0.0042 to 100 rev/s (the top is
/// the twin's limit; HCR p. 251 shows `VE200` refused).
pub const VELOCITY: Resolution = Resolution {
    step: 1.0 / 240.0,
    decimals: 4,
    min_steps: 1,
    max_steps: 24_000,
};

/// `AC` and `DE`, rev/s²: steps of 1/6 rev/s² (10 rpm/s), from 0.167 to 5000 rev/s²
/// (the top is the twin's limit).
pub const ACCELERATION: Resolution = Resolution {
    step: 1.0 / 6.0,
    decimals: 3,
    min_steps: 1,
    max_steps: 30_000,
};

/// `WT`, s: steps of 0.01 s, from 0 to 320 s (both unconfirmed).
pub const WAIT: Resolution = Resolution {
    step: 0.01,
    decimals: 2,
    min_steps: 0,
    max_steps: 32_000,
};

impl Resolution {
    /// The steps a drive holds for `value`, or `None` when it refuses it: below the
    /// smallest value as written ([`Self::smallest`]), above the largest, or negative.
    #[must_use]
    pub fn steps(&self, value: Decimal) -> Option<i64> {
        let v = value.to_f64();
        let smallest = self.smallest().map_or(0.0, Decimal::to_f64);
        if value.is_negative() || v < smallest || v > self.max_steps as f64 * self.step + 1e-9 {
            return None;
        }
        Some((v / self.step).round() as i64)
    }

    /// The value a drive holds for `value` (in the value's unit), or `None` when it
    /// refuses it.
    #[must_use]
    pub fn held(&self, value: Decimal) -> Option<f64> {
        self.steps(value).map(|steps| steps as f64 * self.step)
    }

    /// The text for exactly `steps` steps (rounded up to the decimals), or `None` out of
    /// range.
    #[must_use]
    pub fn write(&self, steps: i64) -> Option<Decimal> {
        if !(self.min_steps..=self.max_steps).contains(&steps) {
            return None;
        }
        let scaled = steps as f64 * self.step * 10_f64.powi(i32::from(self.decimals));
        // Up, but an exact value (within float noise) stays.
        Decimal::new((scaled - 1e-6).ceil() as i64, self.decimals)
    }

    /// The smallest value a drive takes, as written.
    #[must_use]
    pub fn smallest(&self) -> Option<Decimal> {
        self.write(self.min_steps)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decimal(mantissa: i64, scale: u8) -> Decimal {
        Decimal::new(mantissa, scale).unwrap()
    }

    #[test]
    fn the_smallest_values_are_the_references() {
        assert_eq!(VELOCITY.smallest(), Some(decimal(42, 4)));
        assert_eq!(ACCELERATION.smallest(), Some(decimal(167, 3)));
        assert_eq!(WAIT.smallest(), Some(decimal(0, 2)));
    }

    #[test]
    fn every_written_value_is_held_as_its_steps() {
        for resolution in [VELOCITY, ACCELERATION, WAIT] {
            for steps in (resolution.min_steps..=resolution.max_steps).step_by(7) {
                let written = resolution.write(steps).unwrap();
                assert_eq!(resolution.steps(written), Some(steps), "{written}");
                // Within a 40th of a step above: a truncating drive holds it too.
                let above = written.to_f64() / resolution.step - steps as f64;
                assert!((-1e-9..0.025).contains(&above), "{written}: {above}");
            }
            assert_eq!(resolution.write(resolution.min_steps - 1), None);
            assert_eq!(resolution.write(resolution.max_steps + 1), None);
        }
    }

    #[test]
    fn a_value_out_of_range_is_not_held() {
        // The creep: VE0.0006 … VE0.0024, below 0.0042.
        for mantissa in [6, 24, 41] {
            assert_eq!(VELOCITY.steps(decimal(mantissa, 4)), None);
        }
        assert_eq!(VELOCITY.steps(decimal(42, 4)), Some(1));
        assert_eq!(VELOCITY.steps(decimal(200, 0)), None);
        assert_eq!(ACCELERATION.steps(decimal(166, 3)), None);
        assert_eq!(ACCELERATION.steps(decimal(25, 1)), Some(15));
        assert_eq!(WAIT.steps(decimal(-1, 2)), None);
        // Between steps: the nearest.
        assert_eq!(VELOCITY.held(decimal(6910, 4)), Some(166.0 / 240.0));
        assert_eq!(WAIT.held(decimal(604, 3)), Some(0.6));
    }
}
