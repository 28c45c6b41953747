//! Pacing writes to the line's real speed.
//!
//! A byte's time on the wire is [`Line::byte_time`] (8N1, the rule written once in
//! [`floatball_shared::line`]). The writer hands the next instruction to the port only shortly before the
//! line is free ([`LEAD`]): the line stays busy, and the port's buffer never holds
//! more than the instruction being sent — so an e-stop waits for at most that one.
//! The same pacing makes the simulated gateway's line exactly as slow as a real one.

use std::time::{Duration, Instant};

use floatball_shared::line::Line;

/// How long before the line is free the next instruction is handed over, at least.
pub const LEAD: Duration = Duration::from_micros(300);

/// When the line will be free, given what was written.
#[derive(Debug, Clone)]
pub struct Pacer {
    byte_time: Duration,
    lead: Duration,
    line_free_at: Instant,
}

impl Pacer {
    /// A pacer for a line at `baud`, idle at `now`.
    pub fn new(baud: u32, now: Instant) -> Self {
        let byte_time = Line::new(baud).byte_time();
        Self {
            byte_time,
            lead: LEAD.max(byte_time * 2),
            line_free_at: now,
        }
    }

    /// How many bytes the line carries in `duration` (whole bytes, rounded down).
    pub fn bytes_in(&self, duration: Duration) -> usize {
        usize::try_from(duration.as_nanos() / self.byte_time.as_nanos().max(1))
            .unwrap_or(usize::MAX)
    }

    /// When the line would be free if `len` more bytes were handed over at `now`.
    pub fn free_after(&self, now: Instant, len: usize) -> Instant {
        let len = u32::try_from(len).unwrap_or(u32::MAX);
        self.line_free_at.max(now) + self.byte_time * len
    }

    /// How long to wait at `now` before handing over the next instruction.
    pub fn wait_before_next(&self, now: Instant) -> Duration {
        self.line_free_at
            .checked_sub(self.lead)
            .map_or(Duration::ZERO, |start| start.saturating_duration_since(now))
    }

    /// Records `len` bytes handed to the port at `now`; returns when they will have
    /// left the line.
    pub fn wrote(&mut self, now: Instant, len: usize) -> Instant {
        let start = self.line_free_at.max(now);
        let len = u32::try_from(len).unwrap_or(u32::MAX);
        self.line_free_at = start + self.byte_time * len;
        self.line_free_at
    }
}

/// Bytes per second over the last window of about a second.
#[derive(Debug, Clone)]
pub struct RateMeter {
    window_start: Instant,
    bytes: u64,
    rate_bytes_per_s: f64,
}

/// The length of a [`RateMeter`] window.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);

impl RateMeter {
    /// A meter starting at `now` with a rate of 0.
    pub fn new(now: Instant) -> Self {
        Self {
            window_start: now,
            bytes: 0,
            rate_bytes_per_s: 0.0,
        }
    }

    /// Counts `len` bytes written at `now`.
    pub fn add(&mut self, now: Instant, len: usize) {
        self.roll(now);
        self.bytes += len as u64;
    }

    /// The rate of the last complete window, rolling over at `now` if a window ended.
    /// Returns `Some(rate)` when it changed.
    pub fn roll(&mut self, now: Instant) -> Option<f64> {
        let elapsed = now.saturating_duration_since(self.window_start);
        if elapsed < RATE_WINDOW {
            return None;
        }
        let rate = self.bytes as f64 / elapsed.as_secs_f64();
        self.window_start = now;
        self.bytes = 0;
        let changed = (rate - self.rate_bytes_per_s).abs() > f64::EPSILON;
        self.rate_bytes_per_s = rate;
        changed.then_some(rate)
    }

    /// The last published rate, bytes/s.
    pub fn rate_bytes_per_s(&self) -> f64 {
        self.rate_bytes_per_s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_next_write_waits_until_shortly_before_the_line_is_free() {
        let start = Instant::now();
        let mut pacer = Pacer::new(9600, start);
        assert_eq!(pacer.wait_before_next(start), Duration::ZERO);
        // 20 bytes at 9600 baud: 20.83 ms on the wire.
        let free = pacer.wrote(start, 20);
        assert_eq!(free - start, Line::new(9600).byte_time() * 20);
        let wait = pacer.wait_before_next(start);
        let lead = Line::new(9600).byte_time() * 2;
        assert_eq!(wait, Line::new(9600).byte_time() * 20 - lead);
        // Writing again right away queues behind the first instruction.
        let free_again = pacer.wrote(start + wait, 10);
        assert_eq!(free_again - free, Line::new(9600).byte_time() * 10);
    }

    #[test]
    fn bytes_in_a_duration_follow_the_baud() {
        let start = Instant::now();
        assert_eq!(
            Pacer::new(115_200, start).bytes_in(Duration::from_millis(3)),
            34
        );
        assert_eq!(
            Pacer::new(9600, start).bytes_in(Duration::from_millis(3)),
            2
        );
    }

    #[test]
    fn an_idle_line_starts_from_now() {
        let start = Instant::now();
        let mut pacer = Pacer::new(115_200, start);
        pacer.wrote(start, 10);
        let later = start + Duration::from_secs(1);
        assert_eq!(
            pacer.wrote(later, 10) - later,
            Line::new(115_200).byte_time() * 10
        );
    }

    #[test]
    fn rate_is_measured_per_window() {
        let start = Instant::now();
        let mut meter = RateMeter::new(start);
        meter.add(start, 500);
        meter.add(start + Duration::from_millis(500), 460);
        assert_eq!(meter.roll(start + Duration::from_millis(900)), None);
        let rate = meter.roll(start + Duration::from_secs(1)).unwrap();
        assert!((rate - 960.0).abs() < 1e-9);
        assert_eq!(meter.roll(start + Duration::from_secs(2)), Some(0.0));
    }
}
