//! A serial line's timing: how long bytes take at a baud rate. The one place the 8N1
//! rule is written — a UART sends a byte in [`BITS_PER_BYTE`] bit times (8 data bits,
//! one start bit, one stop bit), so a line carries baud / 10 bytes per second.
//!
//! Used by the planner's schedule and report, by the player's timing, by the simulated
//! gateway's line and by the bridge's pacer.
//!
//! ```
//! use floatball_shared::line::Line;
//!
//! let line = Line::new(9600);
//! assert_eq!(line.bytes_per_s(), 960.0);
//! assert_eq!(line.time_us(20), 20_834); // 20 bytes, rounded up to whole µs
//! ```

use core::time::Duration;

/// Bit times per byte on the wire (8N1: 8 data bits, 1 start, 1 stop).
pub const BITS_PER_BYTE: u32 = 10;

/// A serial line at one baud rate (8N1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line {
    baud: u32,
}

impl Line {
    /// A line at `baud`. Timings treat a baud of 0 as 1 (a line that barely moves),
    /// never as a division by zero.
    pub fn new(baud: u32) -> Self {
        Self { baud }
    }

    /// The baud rate it was made with.
    pub fn baud(self) -> u32 {
        self.baud
    }

    /// The baud rate timings divide by: at least 1.
    fn divisor(self) -> u32 {
        self.baud.max(1)
    }

    /// Bytes the line carries per second: baud / [`BITS_PER_BYTE`].
    pub fn bytes_per_s(self) -> f64 {
        f64::from(self.baud) / f64::from(BITS_PER_BYTE)
    }

    /// How long `bytes` take on the line, µs, rounded up.
    pub fn time_us(self, bytes: usize) -> u64 {
        (bytes as u64 * u64::from(BITS_PER_BYTE) * 1_000_000).div_ceil(u64::from(self.divisor()))
    }

    /// How long one byte takes on the line, ms (not rounded).
    pub fn byte_ms(self) -> f64 {
        f64::from(BITS_PER_BYTE) * 1000.0 / f64::from(self.divisor())
    }

    /// How long one byte takes on the line.
    pub fn byte_time(self) -> Duration {
        Duration::from_secs_f64(f64::from(BITS_PER_BYTE) / f64::from(self.divisor()))
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn a_byte_is_ten_bit_times() {
        let line = Line::new(9600);
        assert_eq!(line.time_us(1), 1042); // 1041.67 µs, rounded up
        assert_eq!(line.time_us(960), 1_000_000);
        assert_eq!(line.bytes_per_s(), 960.0);
        assert!((line.byte_ms() - 10.0 / 9.6).abs() < 1e-12);
        assert_eq!(line.byte_time(), Duration::from_secs_f64(10.0 / 9600.0));
        assert_eq!(Line::new(115_200).byte_time().as_nanos(), 86_806);
        assert_eq!(Line::new(115_200).time_us(11_520), 1_000_000);
    }

    #[test]
    fn a_zero_baud_line_is_slow_not_a_division_by_zero() {
        let line = Line::new(0);
        assert_eq!(line.baud(), 0);
        assert_eq!(line.bytes_per_s(), 0.0);
        assert_eq!(line.time_us(1), 10_000_000);
        assert_eq!(line.byte_time(), Duration::from_secs(10));
    }
}
