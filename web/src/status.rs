//! Reading the bridge's `status` message for the Control page: the state's stable
//! key (for `data-state` and styling), the show time and the progress bar.

use floatball_shared::api::{PlayerState, Status};

use crate::files::format_duration_ms;

/// The state's name in the API (`playing`), the same in every language.
pub fn state_key(state: PlayerState) -> &'static str {
    match state {
        PlayerState::Idle => "idle",
        PlayerState::Waiting => "waiting",
        PlayerState::Approaching => "approaching",
        PlayerState::Loading => "loading",
        PlayerState::Playing => "playing",
        PlayerState::Stopped => "stopped",
        PlayerState::Homing => "homing",
        PlayerState::Error => "error",
    }
}

/// Whether the progress bar means something in this state (loading or playback).
pub fn shows_progress(state: PlayerState) -> bool {
    matches!(state, PlayerState::Loading | PlayerState::Playing)
}

/// The progress of the current phase, clamped to 0.0–1.0 (0 for nonsense).
pub fn progress(status: &Status) -> f64 {
    if status.progress.is_finite() {
        status.progress.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// `show time / length`, e.g. `0:12.5 / 1:00.0`; empty when no show runs.
pub fn time_text(status: &Status) -> String {
    if status.show.is_none() {
        return String::new();
    }
    format!(
        "{} / {}",
        format_duration_ms(status.show_time_ms),
        format_duration_ms(status.show_duration_ms)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_keys_match_the_api() {
        for state in [
            PlayerState::Idle,
            PlayerState::Waiting,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Stopped,
            PlayerState::Homing,
            PlayerState::Error,
        ] {
            let json = serde_json::to_value(state).unwrap();
            assert_eq!(json, state_key(state));
        }
        assert!(shows_progress(PlayerState::Loading));
        assert!(!shows_progress(PlayerState::Stopped));
    }

    #[test]
    fn time_and_progress() {
        let mut status = Status {
            show_time_ms: 12_500,
            show_duration_ms: 60_000,
            progress: 1.7,
            ..Status::default()
        };
        assert_eq!(time_text(&status), "");
        status.show = Some("wave".into());
        assert_eq!(time_text(&status), "0:12.5 / 1:00.0");
        assert_eq!(progress(&status), 1.0);
        status.progress = f64::NAN;
        assert_eq!(progress(&status), 0.0);
    }
}
