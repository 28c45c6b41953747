//! Reading the bridge's `status` message for the Control page: the state's stable
//! key (for `data-state` and styling), the show time, the progress bar (homing shows
//! its own, never the previous show's time) and each gateway's line (the buffer's
//! level in words, only while a show streams).

use floatball_shared::api::{GatewayKind, GatewayStatus, LinkState, PlayerState, Status};

use crate::files::format_duration_ms;
use crate::i18n::{Lang, Text};

/// One gateway's line in the status: a UIM2503 gateway's port, link, bytes/s and,
/// while a show `streaming`, how many rows its units had buffered ahead at the least
/// (the lowest FIFO water level); an MBOX box's address, link, packets/s, late frames
/// and missed replies; then the error, if any.
pub fn gateway_text(lang: Lang, gateway: &GatewayStatus, streaming: bool) -> String {
    let mut text = format!("{}: {}", gateway.port, lang.link_state(gateway.link));
    match gateway.kind {
        GatewayKind::Uim2503 => {
            text.push_str(&format!(" · {:.0} B/s", gateway.bytes_per_s));
            if let Some(level) = gateway.lowest_water_level.filter(|_| streaming) {
                text.push_str(&format!(
                    " · {} {level} {}",
                    lang.t(Text::BufferAtLeast),
                    lang.t(Text::BufferRows)
                ));
            }
        }
        GatewayKind::Mbox => {
            let packets = gateway.packets_per_s.unwrap_or_default();
            text.push_str(&format!(" · {packets:.0} {}", lang.t(Text::PacketsPerS)));
            for (label, count) in [
                (Text::LateFrames, gateway.late_frames),
                (Text::MissedReplies, gateway.missed_replies),
            ] {
                let count = count.unwrap_or_default();
                text.push_str(&format!(" · {} {count}", lang.t(label)));
            }
        }
        // MOONS' drives: how many, how many report an alarm and the polls they
        // missed (each drive's answers are on the Console page).
        GatewayKind::Scl => {
            let alarms = gateway
                .drives
                .iter()
                .filter(|drive| drive.alarm_code.is_some_and(|code| code != 0))
                .count();
            let missed: u64 = gateway
                .drives
                .iter()
                .map(|drive| drive.missed_replies)
                .sum();
            text.push_str(&format!(
                " · SCL × {} · {} {alarms} · {} {missed}",
                gateway.drives.len(),
                lang.t(Text::Alarms),
                lang.t(Text::MissedReplies)
            ));
        }
    }
    if let Some(error) = &gateway.error {
        text.push_str(&format!(" · {error}"));
    }
    text
}

/// The state's name in the API (`playing`), the same in every language.
pub fn state_key(state: PlayerState) -> &'static str {
    state.as_str()
}

/// A gateway's drive family as the installation page names it.
pub fn kind_key(kind: GatewayKind) -> &'static str {
    match kind {
        GatewayKind::Uim2503 => "UIM2503",
        GatewayKind::Mbox => "MBOX",
        GatewayKind::Scl => "SCL",
    }
}

/// A link's state as the page's `data-link` and CSS class say it (the API's name:
/// `up`, `connecting`, `down`, `not_answering`).
pub fn link_key(link: LinkState) -> &'static str {
    match link {
        LinkState::Up => "up",
        LinkState::Connecting => "connecting",
        LinkState::Down => "down",
        LinkState::NotAnswering => "not_answering",
    }
}

/// Whether the progress bar means something in this state (loading, playback, or
/// homing: its own progress).
pub fn shows_progress(state: PlayerState) -> bool {
    matches!(
        state,
        PlayerState::Loading | PlayerState::Playing | PlayerState::Homing
    )
}

/// Whether rows stream to the units in this state (the buffer's level means
/// something): loading and playback.
pub fn streams(state: PlayerState) -> bool {
    matches!(state, PlayerState::Loading | PlayerState::Playing)
}

/// `Homing… 42 %` while the balls home (their own progress), else `None`.
pub fn homing_text(lang: Lang, status: &Status) -> Option<String> {
    (status.state == PlayerState::Homing).then(|| {
        let percent = (progress(status) * 100.0).round();
        format!("{} {percent:.0} %", lang.t(Text::Homing))
    })
}

/// The progress of the current phase, clamped to 0.0–1.0 (0 for nonsense).
pub fn progress(status: &Status) -> f64 {
    if status.progress.is_finite() {
        status.progress.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// `show time / length`, e.g. `0:12.5 / 1:00.0`; empty when no show runs (also
/// while homing, whatever an older bridge still sends).
pub fn time_text(status: &Status) -> String {
    if status.show.is_none() || status.state == PlayerState::Homing {
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
        assert!(shows_progress(PlayerState::Homing));
        assert!(!shows_progress(PlayerState::Stopped));
        assert!(streams(PlayerState::Playing) && streams(PlayerState::Loading));
        assert!(!streams(PlayerState::Homing) && !streams(PlayerState::Idle));
    }

    #[test]
    fn gateway_lines_by_kind() {
        let uim = GatewayStatus {
            index: 0,
            baud: None,
            health: None,
            kind: GatewayKind::Uim2503,
            port: "/dev/ttyUSB0".into(),
            link: floatball_shared::api::LinkState::Up,
            bytes_per_s: 1234.4,
            lowest_water_level: Some(12),
            error: None,
            packets_per_s: None,
            late_frames: None,
            missed_replies: None,
            drives: Vec::new(),
        };
        assert_eq!(
            gateway_text(Lang::En, &uim, true),
            "/dev/ttyUSB0: up · 1234 B/s · buffered ahead: at least 12 rows"
        );
        assert!(gateway_text(Lang::Zh, &uim, true).contains("控制器缓冲至少 12 行"));
        assert_eq!(
            gateway_text(Lang::En, &uim, false),
            "/dev/ttyUSB0: up · 1234 B/s",
            "the buffer only while a show streams"
        );
        let mbox = GatewayStatus {
            index: 0,
            baud: None,
            health: None,
            kind: GatewayKind::Mbox,
            port: "192.168.15.201:7408".into(),
            link: floatball_shared::api::LinkState::Down,
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: Some("no answer".into()),
            packets_per_s: Some(52.0),
            late_frames: Some(1),
            missed_replies: Some(3),
            drives: Vec::new(),
        };
        assert_eq!(
            gateway_text(Lang::En, &mbox, true),
            format!(
                "192.168.15.201:7408: {} · 52 packets/s · late frames 1 · missed replies 3 · no answer",
                Lang::En.link_state(floatball_shared::api::LinkState::Down)
            )
        );
        assert!(gateway_text(Lang::Zh, &mbox, true).contains("迟发帧 1 · 未应答 3"));
        let drive = |alarm_code, missed_replies| floatball_shared::api::SclDriveStatus {
            address: "1".into(),
            position_counts: Some(0),
            status_code: Some(1),
            alarm_code: Some(alarm_code),
            missed_replies,
            error: None,
        };
        let scl = GatewayStatus {
            index: 0,
            baud: None,
            health: None,
            kind: GatewayKind::Scl,
            port: "/dev/ttyUSB0".into(),
            link: floatball_shared::api::LinkState::Up,
            missed_replies: Some(2),
            drives: vec![drive(0, 0), drive(2, 2)],
            ..mbox
        };
        assert_eq!(
            gateway_text(Lang::En, &scl, true),
            format!(
                "/dev/ttyUSB0: {} · SCL × 2 · alarms 1 · missed replies 2 · no answer",
                Lang::En.link_state(floatball_shared::api::LinkState::Up)
            )
        );
        assert!(gateway_text(Lang::Zh, &scl, true).contains("报警 1 · 未应答 2"));
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
        assert_eq!(homing_text(Lang::En, &status), None);

        // Homing: its own progress, never a show's time (even from an older bridge
        // that still names the last show).
        status.state = PlayerState::Homing;
        status.progress = 0.416;
        assert_eq!(time_text(&status), "");
        assert_eq!(
            homing_text(Lang::En, &status).as_deref(),
            Some("Homing… 42 %")
        );
        assert_eq!(
            homing_text(Lang::Zh, &status).as_deref(),
            Some("回原点中… 42 %")
        );
    }
}
