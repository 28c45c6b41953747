//! Live mode as a plain type: while the matrix plays the show being previewed, the
//! preview shows the machine's show time.
//!
//! The bridge reports `show_time_ms` in its status at most ten times a second
//! (`docs/architecture.md` §4); between two reports the time runs on from the last one by the local
//! clock, so the animation stays smooth. A report a little behind what is already on
//! screen (the messages' own delay varies) holds the picture rather than jumping back;
//! if reports stop coming, the time stops a second after the last.

use floatball_shared::api::{PlayerState, Status};

/// How far past the last report the time runs on by itself, ms.
const RUN_ON_MS: f64 = 1000.0;
/// A report at most this far behind the picture holds it instead of going back, ms.
const HOLD_MS: f64 = 250.0;

/// Whether `status` says the matrix plays the show named `name`.
pub fn plays(status: &Status, name: &str) -> bool {
    status.state == PlayerState::Playing && status.show.as_deref() == Some(name)
}

/// The machine's time at the last report, and when (local clock, ms) it came.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Report {
    show_ms: f64,
    at_ms: f64,
}

/// The machine's show time between reports.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LiveClock {
    report: Option<Report>,
    shown_ms: Option<f64>,
}

impl LiveClock {
    /// Takes in a status (or its absence, when disconnected) that came at `now_ms` for
    /// the preview of the show named `name`.
    pub fn report(&mut self, status: Option<&Status>, name: Option<&str>, now_ms: f64) {
        match (status, name) {
            (Some(status), Some(name)) if plays(status, name) => {
                self.report = Some(Report {
                    show_ms: status.show_time_ms as f64,
                    at_ms: now_ms,
                });
            }
            _ => *self = Self::default(),
        }
    }

    /// Whether the machine plays the show, as of the last report.
    pub fn playing(&self) -> bool {
        self.report.is_some()
    }

    /// The show time to draw at `now_ms`, or `None` when the machine is not playing
    /// this show.
    pub fn time_at(&mut self, now_ms: f64) -> Option<f64> {
        let report = self.report?;
        let estimate = report.show_ms + (now_ms - report.at_ms).clamp(0.0, RUN_ON_MS);
        let shown = match self.shown_ms {
            Some(shown) if shown > estimate && shown - estimate <= HOLD_MS => shown,
            _ => estimate,
        };
        self.shown_ms = Some(shown);
        Some(shown)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    /// A status of the matrix in `state` at `show_time_ms` into `show`.
    pub(crate) fn status(state: PlayerState, show: &str, show_time_ms: u64) -> Status {
        Status {
            state,
            entry: Some(0),
            show: Some(show.into()),
            show_time_ms,
            show_starts_in_ms: None,
            show_duration_ms: 60_000,
            cycle: 1,
            progress: 0.0,
            gateways: Vec::new(),
            last_error: None,
            armed: None,
            gateway_summary: Default::default(),
            live: None,
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn follows_only_the_same_show_while_it_plays() {
        let playing = status(PlayerState::Playing, "ripple", 1000);
        assert!(plays(&playing, "ripple"));
        assert!(!plays(&playing, "other"));
        assert!(!plays(&status(PlayerState::Loading, "ripple", 0), "ripple"));

        let mut clock = LiveClock::default();
        assert_eq!(clock.time_at(0.0), None);
        clock.report(Some(&playing), Some("other"), 0.0);
        assert!(!clock.playing());
        clock.report(Some(&playing), Some("ripple"), 0.0);
        assert!(clock.playing());
        assert_eq!(clock.time_at(0.0), Some(1000.0));
        clock.report(None, Some("ripple"), 10.0);
        assert_eq!(clock.time_at(20.0), None, "disconnected");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn runs_on_between_reports_and_stops_a_second_after_the_last() {
        let mut clock = LiveClock::default();
        clock.report(
            Some(&status(PlayerState::Playing, "s", 5000)),
            Some("s"),
            100.0,
        );
        assert_eq!(clock.time_at(150.0), Some(5050.0));
        assert_eq!(clock.time_at(1100.0), Some(6000.0));
        assert_eq!(clock.time_at(9000.0), Some(6000.0), "no report for long");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_late_report_holds_the_picture_and_a_real_jump_is_followed() {
        let mut clock = LiveClock::default();
        let playing = |ms| status(PlayerState::Playing, "s", ms);
        clock.report(Some(&playing(1000)), Some("s"), 0.0);
        assert_eq!(clock.time_at(120.0), Some(1120.0));
        // This report says 1080 at 120 ms: a little behind; the picture holds.
        clock.report(Some(&playing(1080)), Some("s"), 120.0);
        assert_eq!(clock.time_at(130.0), Some(1120.0));
        assert_eq!(clock.time_at(170.0), Some(1130.0));
        // The next cycle starts over at 0: followed at once.
        clock.report(Some(&playing(0)), Some("s"), 200.0);
        assert_eq!(clock.time_at(200.0), Some(0.0));
    }
}
