//! How many drives one line can stream a show to ([`stream_budget`]): a jogged show
//! sends two buffered lines a step (the `J` register and the `WT`; HCR p. 64, 274)
//! and a `BS` to each drive every [`super::STREAM_REFILL_US`] (p. 53), one exchange
//! at a time on a line (half duplex) — and on an eSCL gateway entry too, whose
//! requests the bridge sends one after the other.

use super::live::{ESCL_EXCHANGE_US, SclLine, TURNAROUND_US};
use crate::line::Line;

/// A jogged step's two lines and their answers, bytes on average: `1RXJ-123` and
/// `1WT0.05` with their CRs, `1*` and its CR each.
const STEP_LINE_BYTES: usize = 12;

/// `1BS` and `1BS=12`, with their CRs, bytes.
const BS_BYTES: usize = 11;

/// The share of a line the streams may take (the status polls and the answers' gaps
/// take the rest).
const LINE_SHARE: f64 = crate::uim2503::schedule::LINE_UTILISATION;

/// What a line carries of streamed shows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamBudget {
    /// Exchanges (a line and its answer) one drive needs a second.
    pub exchanges_per_s_per_drive: f64,
    /// Exchanges the line carries a second (at its share).
    pub exchanges_per_s: f64,
    /// Drives it can stream to at once.
    pub drives: usize,
}

/// The budget of `line` for shows jogged every `step_s` (the stream's step:
/// [`crate::scl::qprogram`]'s shortest, 50 ms).
#[must_use]
pub fn stream_budget(line: SclLine, step_s: f64) -> StreamBudget {
    let refill_s = super::STREAM_REFILL_US as f64 / 1e6;
    let per_drive = 2.0 / step_s.max(1e-3) + 1.0 / refill_s;
    // The time of one exchange, µs: the bytes at the line's speed and the turn-round.
    let exchange_us = match line {
        SclLine::Rs485 { baud } => {
            let line = Line::new(baud);
            let mean_bytes = (STEP_LINE_BYTES as f64 * 2.0 / step_s.max(1e-3)
                + BS_BYTES as f64 / refill_s)
                / per_drive;
            mean_bytes * line.byte_ms() * 1_000.0 + TURNAROUND_US as f64
        }
        SclLine::Escl => ESCL_EXCHANGE_US as f64,
    };
    let exchanges_per_s = 1e6 / exchange_us * LINE_SHARE;
    StreamBudget {
        exchanges_per_s_per_drive: per_drive,
        exchanges_per_s,
        drives: (exchanges_per_s / per_drive).floor() as usize,
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn a_slow_line_streams_to_one_drive_a_fast_one_to_many() {
        let at = |baud| stream_budget(SclLine::Rs485 { baud }, 0.05).drives;
        // 9600 baud: 960 bytes/s carry one drive's 47 exchanges of ~12 bytes.
        assert_eq!(at(9_600), 1);
        assert!((10..=25).contains(&at(115_200)), "{}", at(115_200));
        assert!(stream_budget(SclLine::Escl, 0.05).drives >= at(115_200));
        // Longer steps, more drives.
        assert!(stream_budget(SclLine::Rs485 { baud: 9_600 }, 0.2).drives >= 2);
    }
}
