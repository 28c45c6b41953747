//! Reading the bridge's `status` message for the Control page: the state's stable
//! key (for `data-state` and styling), the show time, the progress bar (homing shows
//! its own, never the previous show's time) and each gateway's line (the buffer's
//! level in words, only while a show streams).
//!
//! With many gateways the status counts them in its `gateway_summary` and details only
//! those with a problem ([`summarised`]): the page then says how many are up, the
//! lowest buffer and where ([`lowest_text`]), and each gateway with a problem in words
//! ([`problem_text`], at most [`PROBLEMS_LISTED`]); the full list comes from
//! `GET /api/status/gateways` on request. Gateway ports come from the details or,
//! for the others, the installation ([`gateway_port`]).

use floatball_shared::api::{
    GatewayKind, GatewayStatus, InstallationInfo, LinkState, PlayerState, Status,
};

use crate::files::format_duration_ms;
use crate::i18n::{Lang, Text};
use crate::installation::health_warnings;

/// How many gateways with a problem the summary lists by name; the others are
/// counted ([`Lang::more_gateways`]) and are all in the full list.
pub const PROBLEMS_LISTED: usize = 8;

/// Whether `status` counts its gateways in a summary and details only those with a
/// problem (more than `GATEWAY_DETAIL_LIMIT` gateways). A bridge that sends no
/// summary (`total` 0) details every gateway.
pub fn summarised(status: &Status) -> bool {
    !status.gateway_summary.complete && status.gateway_summary.total > 0
}

/// The port of gateway `index`: from the status's details when it has them, else
/// from the installation; `None` when neither knows it.
pub fn gateway_port(
    status: &Status,
    installation: Option<&InstallationInfo>,
    index: usize,
) -> Option<String> {
    status
        .gateways
        .iter()
        .find(|gateway| gateway.index == index)
        .map(|gateway| gateway.port.clone())
        .or_else(|| Some(installation?.gateways.get(index)?.port.clone()))
}

/// A gateway with a problem in words: its port, link and error while its link is not
/// up or has an error; else what is wrong with its units (UIM2503: who does not
/// answer, shares a station or reported an error); then each MOONS' drive's error.
pub fn problem_text(lang: Lang, gateway: &GatewayStatus) -> String {
    let link_fine = gateway.link == LinkState::Up && gateway.error.is_none();
    let units = health_warnings(std::slice::from_ref(gateway))
        .pop()
        .filter(|_| link_fine);
    let mut text = match units {
        Some(warning) => lang.health_warning(&warning),
        None => format!("{}: {}", gateway.port, lang.link_state(gateway.link)),
    };
    if let Some(error) = gateway.error.as_ref().filter(|_| !link_fine) {
        text.push_str(&format!(" · {error}"));
    }
    for drive in &gateway.drives {
        if let Some(error) = &drive.error {
            text.push_str(&format!(" · {}: {error}", drive.address));
        }
    }
    text
}

/// The lowest buffer of any unit while a show streams, and on which gateway
/// (`at least 38 rows · gateway 63 (tcp://…)`); `None` otherwise.
pub fn lowest_text(
    lang: Lang,
    status: &Status,
    installation: Option<&InstallationInfo>,
) -> Option<String> {
    let summary = &status.gateway_summary;
    let level = summary
        .lowest_water_level
        .filter(|_| streams(status.state))?;
    let gateway = summary.lowest_water_gateway?;
    let port = gateway_port(status, installation, gateway);
    Some(lang.lowest_buffer(level, gateway, port.as_deref()))
}

impl Lang {
    /// How many gateways' links are up: `97 of 100 gateways`.
    pub fn gateways_up(self, up: u32, total: u32) -> String {
        match self {
            Lang::Zh => format!("{up} / {total} 个网关"),
            Lang::En => format!("{up} of {total} gateways"),
        }
    }

    /// The lowest buffer and its gateway: `at least 38 rows · gateway 63 (sim)`.
    pub fn lowest_buffer(self, level: u16, gateway: usize, port: Option<&str>) -> String {
        match (self, port) {
            (Lang::Zh, Some(port)) => format!("至少 {level} 行 · 网关 {gateway}（{port}）"),
            (Lang::Zh, None) => format!("至少 {level} 行 · 网关 {gateway}"),
            (Lang::En, Some(port)) => format!("at least {level} rows · gateway {gateway} ({port})"),
            (Lang::En, None) => format!("at least {level} rows · gateway {gateway}"),
        }
    }

    /// The gateways with a problem beyond those listed: `… and 5 more`.
    pub fn more_gateways(self, more: usize) -> String {
        match self {
            Lang::Zh => format!("……另有 {more} 个，见全部网关列表"),
            Lang::En => format!("… and {more} more: see the full list"),
        }
    }

    /// The button that opens the full list: `Show all 100 gateways`.
    pub fn show_all_gateways(self, total: u32) -> String {
        match self {
            Lang::Zh => format!("显示全部 {total} 个网关"),
            Lang::En => format!("Show all {total} gateways"),
        }
    }
}

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

/// `Starting in 0.1 s` while `loading` a show whose start is given for an instant
/// (`show_starts_in_ms`), else `None`.
pub fn starting_text(lang: Lang, status: &Status) -> Option<String> {
    status
        .show_starts_in_ms
        .filter(|_| status.state == PlayerState::Loading)
        .map(|ms| lang.starting_in(ms))
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
    use wasm_bindgen_test::wasm_bindgen_test;

    #[wasm_bindgen_test(unsupported = test)]
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

    #[wasm_bindgen_test(unsupported = test)]
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
            flash_writes: 0,
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

    fn gateway(index: usize, link: LinkState) -> GatewayStatus {
        GatewayStatus {
            index,
            kind: GatewayKind::Uim2503,
            port: format!("tcp://10.0.0.{index}:4001"),
            link,
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: (link != LinkState::Up).then(|| "connection refused".into()),
            packets_per_s: None,
            late_frames: None,
            missed_replies: None,
            drives: Vec::new(),
            baud: None,
            health: None,
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_summarised_status_names_its_problems_and_the_lowest_buffer() {
        let mut unwell = gateway(42, LinkState::Up);
        unwell.health = Some(floatball_shared::api::UnitHealth {
            expected: 100,
            answering: 99,
            missing: vec![17],
            ..Default::default()
        });
        let mut status = Status {
            state: PlayerState::Playing,
            gateways: vec![gateway(7, LinkState::Down), unwell],
            ..Status::default()
        };
        assert!(
            !summarised(&status),
            "no summary: every gateway is detailed"
        );
        status.gateway_summary = floatball_shared::api::GatewaySummary {
            total: 100,
            up: 99,
            bytes_per_s: 0.0,
            lowest_water_level: Some(38),
            lowest_water_gateway: Some(63),
            problems: vec![7, 42],
            complete: false,
        };
        assert!(summarised(&status));
        assert_eq!(
            problem_text(Lang::En, &status.gateways[0]),
            "tcp://10.0.0.7:4001: down · connection refused"
        );
        assert_eq!(
            problem_text(Lang::En, &status.gateways[1]),
            "tcp://10.0.0.42:4001: 99 of 100 units answer; missing stations 17"
        );
        assert!(problem_text(Lang::Zh, &status.gateways[1]).contains("缺失站号 17"));
        // Gateway 63 is not detailed: its port comes from the installation.
        assert_eq!(
            lowest_text(Lang::En, &status, None).as_deref(),
            Some("at least 38 rows · gateway 63")
        );
        let installation = InstallationInfo {
            gateways: (0..100)
                .map(|index| floatball_shared::api::InstallationGateway {
                    kind: GatewayKind::Uim2503,
                    port: format!("tcp://10.0.1.{index}:4001"),
                    baud: None,
                    stations: vec![1],
                })
                .collect(),
            rows: 10,
            cols: 10,
            pitch_mm: 500.0,
            travel_mm: 7500.0,
            max_speed_mm_s: 2000.0,
            max_accel_mm_s2: 4000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 250.0,
            counts_per_mm: 100.0,
        };
        assert_eq!(
            lowest_text(Lang::Zh, &status, Some(&installation)).as_deref(),
            Some("至少 38 行 · 网关 63（tcp://10.0.1.63:4001）")
        );
        assert_eq!(
            gateway_port(&status, Some(&installation), 7).as_deref(),
            Some("tcp://10.0.0.7:4001"),
            "the details first"
        );
        status.state = PlayerState::Idle;
        assert_eq!(
            lowest_text(Lang::En, &status, None),
            None,
            "only while streaming"
        );
        assert_eq!(Lang::En.gateways_up(99, 100), "99 of 100 gateways");
        assert_eq!(Lang::Zh.gateways_up(99, 100), "99 / 100 个网关");
        assert_eq!(Lang::En.show_all_gateways(100), "Show all 100 gateways");
        assert!(Lang::Zh.more_gateways(5).contains('5'));
    }

    #[wasm_bindgen_test(unsupported = test)]
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
        assert_eq!(starting_text(Lang::En, &status), None);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn a_given_start_counts_down_while_loading() {
        let mut status = Status {
            state: PlayerState::Loading,
            show: Some("wave".into()),
            show_starts_in_ms: Some(80),
            ..Status::default()
        };
        assert_eq!(
            starting_text(Lang::En, &status).as_deref(),
            Some("Starting in 0.1 s")
        );
        assert_eq!(
            starting_text(Lang::Zh, &status).as_deref(),
            Some("0.1 秒后开始")
        );
        status.state = PlayerState::Playing;
        assert_eq!(starting_text(Lang::En, &status), None);
    }
}
