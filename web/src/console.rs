//! The engineers' console as plain logic: typed instruction lines checked by the
//! shared parser before anything is sent, and feedback frames decoded into the
//! protocol's notation as they arrive. On an MBOX installation the lines are MBOX
//! console text, checked by `floatball_shared::mbox::console` (the parser the bridge
//! uses), and the boxes' replies to reads join the same log.
//!
//! The decoded notation (`QP[3] = 1000`, `ER …`) is the manual's, the same in both
//! languages; error sentences come from the shared codec (English). Positions in
//! counts (UIM2503 `PA`, `QP`; MOONS' `IP`, `EP`, `SP`) are also given in mm once the
//! installation's calibration is known ([`counts_per_mm`]).

use std::collections::VecDeque;

use std::net::SocketAddr;

use floatball_shared::api::{
    FeedbackFrame, GatewayKind, InstallationInfo, MboxReply, SclReply, Status,
};
use floatball_shared::codes::Coded;
use floatball_shared::mbox::console as mbox_console;
use floatball_shared::mbox::{BoxAddress, Route};
use floatball_shared::scl::{Answer, Reply};
use floatball_shared::uim2503::ascii::parse_script;
use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame, code};

use crate::context::Refusal;
use crate::i18n::Lang;

/// How many feedback lines the console keeps.
pub const FEEDBACK_LINES: usize = 200;

/// What the parser says about the typed text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Check {
    /// Nothing to send.
    Empty,
    /// Every line parses: send these lines (blank and comment-only lines dropped).
    Ready {
        /// The lines to send, one `raw` message each.
        lines: Vec<String>,
        /// The number of instructions in them.
        instructions: usize,
    },
    /// The parser's error, with line and column (shown in the current language).
    Invalid(Refusal),
    /// The parsers are still being fetched ([`Parsers`]): nothing can be sent yet.
    Loading,
    /// The parsers could not be fetched: nothing can be sent until they are.
    Unavailable,
}

/// The console's parsers as the app has them (their code is a chunk of its own,
/// [`crate::lazy::console_parsers`]).
#[derive(Debug, Clone, Copy, Default)]
pub enum Parsers {
    /// Not asked for yet.
    #[default]
    NotLoaded,
    /// Being fetched.
    Loading,
    /// The chunk could not be fetched (a Retry asks again).
    Failed,
    /// Ready to check lines.
    Ready(crate::lazy::ConsoleParsers),
}

impl Parsers {
    /// `text` checked by `family`'s parser, MBOX commands without a box of their own
    /// going to `selected`; [`Check::Loading`] or [`Check::Unavailable`] without the
    /// parsers, unless there is nothing to check.
    pub fn check(self, family: Family, text: &str, selected: Route) -> Check {
        match self {
            _ if text.trim().is_empty() => Check::Empty,
            Parsers::NotLoaded | Parsers::Loading => Check::Loading,
            Parsers::Failed => Check::Unavailable,
            Parsers::Ready(parsers) => match family {
                Family::Mbox => (parsers.mbox)(text, selected),
                Family::Scl => (parsers.scl)(text),
                Family::Uim2503 => (parsers.uim2503)(text),
            },
        }
    }
}

/// Checks the console's text with the shared parser (the same the bridge uses).
pub fn check(text: &str) -> Check {
    check_with(text, parse_script)
}

/// Checks MBOX console text with the shared MBOX parser, commands without a box of
/// their own going to `selected` (see [`mbox_route`]).
pub fn check_mbox(text: &str, selected: Route) -> Check {
    check_with(text, |text| mbox_console::parse(text, selected))
}

/// Checks `text` with `parse`; each line that holds something is sent on its own.
fn check_with<T, E: Coded + std::fmt::Display>(
    text: &str,
    parse: impl Fn(&str) -> Result<Vec<T>, E>,
) -> Check {
    match parse(text) {
        Err(error) => Check::Invalid(Refusal::of(&error)),
        Ok(instructions) if instructions.is_empty() => Check::Empty,
        Ok(instructions) => Check::Ready {
            lines: text
                .lines()
                .filter(|line| !matches!(parse(line), Ok(parsed) if parsed.is_empty()))
                .map(|line| line.trim().to_owned())
                .collect(),
            instructions: instructions.len(),
        },
    }
}

/// Checks SCL console text for MOONS' drives with the shared SCL parser (the one the
/// bridge uses): one command a line, the drive's address character first (`0IP`).
pub fn check_scl(text: &str) -> Check {
    check_with(text, floatball_shared::scl::parse_script)
}

/// The family of drives the console talks to: what its lines are written in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Family {
    /// UIM2503 gateways: the ASCII instructions (`*5;PV;`).
    #[default]
    Uim2503,
    /// MBOX boxes: the box commands.
    Mbox,
    /// MOONS' drives: SCL lines.
    Scl,
}

impl Family {
    /// The family of the gateways a status details (an installation has one). A
    /// status that summarises many gateways details only those with a problem:
    /// [`Family::of_installation`] knows them all.
    pub fn of(status: &Status) -> Self {
        Self::of_kinds(status.gateways.iter().map(|gateway| gateway.kind))
    }

    /// The family of an installation's gateways.
    pub fn of_installation(installation: &InstallationInfo) -> Self {
        Self::of_kinds(installation.gateways.iter().map(|gateway| gateway.kind))
    }

    /// The family of the console's page: the installation's when it is known, else
    /// that of the gateways the status details.
    pub fn of_either(installation: Option<&InstallationInfo>, status: Option<&Status>) -> Self {
        match (installation, status) {
            (Some(installation), _) if !installation.gateways.is_empty() => {
                Self::of_installation(installation)
            }
            (_, Some(status)) => Self::of(status),
            _ => Self::default(),
        }
    }

    fn of_kinds(kinds: impl Iterator<Item = GatewayKind> + Clone) -> Self {
        let has = |kind| kinds.clone().any(|found| found == kind);
        if has(GatewayKind::Mbox) {
            Self::Mbox
        } else if has(GatewayKind::Scl) {
            Self::Scl
        } else {
            Self::Uim2503
        }
    }
}

/// The route the bridge gives a command without a box of its own: the selected box
/// (the last two octets of its configured IP address), or every box. The box's
/// address comes from the status's details of it (found by its `index`: a status of
/// many gateways details only those with a problem), else from the installation.
pub fn mbox_route(
    status: Option<&Status>,
    installation: Option<&InstallationInfo>,
    gateway: Option<usize>,
) -> Route {
    let address = gateway.and_then(|index| {
        let detailed = status
            .and_then(|status| {
                status
                    .gateways
                    .iter()
                    .find(|gateway| gateway.index == index)
            })
            .map(|gateway| gateway.port.as_str());
        let configured = installation
            .and_then(|installation| installation.gateways.get(index))
            .map(|gateway| gateway.port.as_str());
        [detailed, configured]
            .into_iter()
            .flatten()
            .find_map(|port| port.parse::<SocketAddr>().ok())
    });
    match address {
        Some(SocketAddr::V4(address)) => Route::to(BoxAddress::of_ip(*address.ip())),
        _ => Route::BROADCAST,
    }
}

/// One received frame as the console shows it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FeedbackLine {
    /// A number that grows with every frame (a stable key for the list).
    pub id: u64,
    /// The gateway it came from.
    pub gateway: usize,
    /// The unit's station (none for an MBOX box's reply).
    pub station: Option<u8>,
    /// The meaning, in the protocol's notation.
    pub text: String,
    /// The restored data bytes in hex.
    pub hex: String,
    /// A unit's error report (`ER`) as a code and parameters, shown in the current
    /// language by [`FeedbackLine::text_in`].
    pub unit_error: Option<Refusal>,
}

impl FeedbackLine {
    /// The meaning in `lang`: a unit's error report translated, with the instruction
    /// and index it names; any other frame in the protocol's notation.
    pub fn text_in(&self, lang: Lang) -> String {
        let Some(error) = &self.unit_error else {
            return self.text.clone();
        };
        let mut text = format!("ER: {}", error.text(lang));
        if let (Some(instruction), Some(index)) =
            (error.params.get("instruction"), error.params.get("index"))
        {
            text.push_str(&match lang {
                Lang::Zh => format!("（{instruction}，下标 {index}）"),
                Lang::En => format!(" ({instruction}, index {index})"),
            });
        }
        text
    }
}

/// The most recent feedback frames, newest first, and the installation that gives
/// their positions in mm.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FeedbackLog {
    lines: VecDeque<FeedbackLine>,
    next_id: u64,
    installation: Option<InstallationInfo>,
}

impl FeedbackLine {
    /// Where it came from: `gw0 #5` (gateway and station), `gw1` (an MBOX box).
    pub fn source(&self) -> String {
        match self.station {
            Some(station) => format!("gw{} #{station}", self.gateway),
            None => format!("gw{}", self.gateway),
        }
    }
}

impl FeedbackLog {
    /// Decodes `frame` and puts it first, dropping the oldest beyond
    /// [`FEEDBACK_LINES`]; a position also in mm when the installation is known
    /// ([`describe_scaled`]).
    pub fn push(&mut self, frame: &FeedbackFrame) {
        let hex = frame.data.iter().map(|byte| format!("{byte:02X}"));
        let scale = counts_per_mm(
            self.installation.as_ref(),
            frame.gateway,
            Some(frame.station),
        );
        let decoded = decode(frame);
        let text = describe_decoded(frame.code, &decoded, scale);
        self.push_line(frame.gateway, Some(frame.station), text, hex);
        if let (Ok(Feedback::Error(error)), Some(line)) = (decoded, self.lines.front_mut()) {
            line.unit_error = Some(Refusal::of(&error));
        }
    }

    /// Takes the installation's calibration and stations: from now on positions in
    /// counts are also given in mm ([`counts_per_mm`]).
    pub fn set_installation(&mut self, installation: InstallationInfo) {
        self.installation = Some(installation);
    }

    /// The installation, once known.
    pub fn installation(&self) -> Option<&InstallationInfo> {
        self.installation.as_ref()
    }

    /// Puts an MBOX box's reply to a console read first, its registers in hex.
    pub fn push_mbox(&mut self, reply: &MboxReply) {
        let hex = reply
            .registers
            .values
            .iter()
            .map(|value| format!("{value:04X}"));
        self.push_line(reply.gateway, None, reply.text.clone(), hex);
    }

    /// A MOONS' drive's answer to an SCL console line: the line sent and the answer
    /// decoded, under its gateway; a position answer (`IP`, `EP`, `SP`, in counts)
    /// also in mm when the installation is known: `1IP → IP = 200000 (400.0 mm)`.
    pub fn push_scl(&mut self, reply: &SclReply) {
        let scale = counts_per_mm(self.installation.as_ref(), reply.gateway, None);
        let position = Reply::parse(&reply.raw)
            .ok()
            .filter(|answer| {
                matches!(&answer.answer, Answer::Value { name, .. } if SCL_POSITIONS.contains(&name.as_str()))
            })
            .and_then(|answer| answer.answer.value_i64());
        let mut text = format!("{} → {}", reply.request, reply.text);
        if let Some(counts) = position {
            text.push_str(&in_mm(counts, scale));
        }
        self.push_line(
            reply.gateway,
            None,
            text,
            std::iter::once(reply.raw.clone()),
        );
    }

    fn push_line(
        &mut self,
        gateway: usize,
        station: Option<u8>,
        text: String,
        hex: impl Iterator<Item = String>,
    ) {
        let line = FeedbackLine {
            id: self.next_id,
            gateway,
            station,
            text,
            hex: hex.collect::<Vec<_>>().join(" "),
            unit_error: None,
        };
        self.next_id += 1;
        self.lines.push_front(line);
        self.lines.truncate(FEEDBACK_LINES);
    }

    /// The lines, newest first.
    pub fn lines(&self) -> impl Iterator<Item = &FeedbackLine> {
        self.lines.iter()
    }

    /// Forgets every line.
    pub fn clear(&mut self) {
        self.lines.clear();
    }

    /// How many lines there are.
    pub fn len(&self) -> usize {
        self.lines.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.lines.is_empty()
    }
}

/// The answers of MOONS' drives that are positions in counts.
const SCL_POSITIONS: [&str; 3] = ["IP", "EP", "SP"];

/// The calibration that turns positions in counts from `station` on `gateway` into
/// mm: the installation's `counts_per_mm` for one of a UIM2503 gateway's stations
/// and for MOONS' drives; none for an MBOX box (its pulses have an offset and a sign
/// of their own, and its replies are registers), an unknown gateway or station, or
/// before the installation is known.
pub fn counts_per_mm(
    installation: Option<&InstallationInfo>,
    gateway: usize,
    station: Option<u8>,
) -> Option<f64> {
    let installation = installation?;
    let entry = installation.gateways.get(gateway)?;
    let known = match entry.kind {
        GatewayKind::Uim2503 => station.is_some_and(|station| entry.stations.contains(&station)),
        GatewayKind::Scl => true,
        GatewayKind::Mbox => false,
    };
    let scale = installation.counts_per_mm;
    (known && scale.is_finite() && scale > 0.0).then_some(scale)
}

/// ` (400.0 mm)` for `counts` at `counts_per_mm`; nothing when that is unknown.
fn in_mm(counts: i64, counts_per_mm: Option<f64>) -> String {
    counts_per_mm
        .map(|scale| format!(" ({:.1} mm)", counts as f64 / scale))
        .unwrap_or_default()
}

/// A frame's meaning in the protocol's notation: `PV = 3`, `QP[3] = 1000`,
/// `ER: value out of range … (error 0x33, QT (0x27), index 3)`.
pub fn describe(frame: &FeedbackFrame) -> String {
    describe_scaled(frame, None)
}

/// [`describe`], with a position (`PA`, `QP`, in counts) also in mm when
/// `counts_per_mm` is known: `PA = 200000 (400.0 mm)`.
pub fn describe_scaled(frame: &FeedbackFrame, counts_per_mm: Option<f64>) -> String {
    describe_decoded(frame.code, &decode(frame), counts_per_mm)
}

/// A frame's [`Feedback`], or why it has none.
fn decode(frame: &FeedbackFrame) -> Result<Feedback, String> {
    Frame::new(frame.station, frame.code, &frame.data)
        .map_err(|err| err.to_string())
        .and_then(|frame| Feedback::from_frame(&frame).map_err(|err| err.to_string()))
}

/// [`describe_scaled`] of a frame with function code `code`, already decoded.
fn describe_decoded(
    code: u8,
    decoded: &Result<Feedback, String>,
    counts_per_mm: Option<f64>,
) -> String {
    match *decoded {
        Err(ref error) => format!("? code {code:#04x}: {error}"),
        Ok(Feedback::Ack(ack)) => {
            let position = match ack {
                Ack::PtpPosition { position_counts }
                | Ack::PvtPosition {
                    position_counts, ..
                } => Some(i64::from(position_counts)),
                _ => None,
            };
            let text = describe_ack(ack);
            match position {
                Some(counts) => text + &in_mm(counts, counts_per_mm),
                None => text,
            }
        }
        Ok(Feedback::Notification(notice)) => {
            if notice.kind == code::notification::PVT_WATERMARK {
                format!("RTCN {} (PVT watermark)", notice.kind)
            } else {
                format!("RTCN {}", notice.kind)
            }
        }
        Ok(Feedback::Error(error)) => format!("ER: {error}"),
        Ok(Feedback::Unknown { code, .. }) => format!("code {code:#04x}"),
    }
}

fn describe_ack(ack: Ack) -> String {
    match ack {
        Ack::Begin { at_us } => format!("BG = {at_us}"),
        Ack::MotionProfile { param, value } => format!("MP[{param}] = {value}"),
        Ack::PvtStart { value } => format!("PV = {value}"),
        Ack::PvtPosition {
            row,
            position_counts,
        } => format!("QP[{row}] = {position_counts}"),
        Ack::PvtVelocity {
            row,
            velocity_counts_s,
        } => format!("QV[{row}] = {velocity_counts_s}"),
        Ack::PvtTime { row, duration_ms } => format!("QT[{row}] = {duration_ms}"),
        Ack::Serial { serial } => format!("SN = {serial}"),
        Ack::Motor { on } => format!("MO = {}", u8::from(on)),
        Ack::PtpSpeed { speed_counts_s } => format!("SP = {speed_counts_s}"),
        Ack::PtpPosition { position_counts } => format!("PA = {position_counts}"),
        Ack::StopDecel { decel_counts_s2 } => format!("SD = {decel_counts_s2}"),
        Ack::InfoEnable { index, enabled } => format!("IE[{index}] = {}", u8::from(enabled)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wasm_bindgen_test::wasm_bindgen_test;

    fn frame(station: u8, code: u8, data: &[u8]) -> FeedbackFrame {
        FeedbackFrame {
            gateway: 0,
            station,
            code,
            data: data.to_vec(),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn lines_wait_for_the_parsers_and_each_family_gets_its_own() {
        let text = "*5;PV;";
        let to = Route::BROADCAST;
        for family in [Family::Uim2503, Family::Mbox, Family::Scl] {
            for parsers in [Parsers::NotLoaded, Parsers::Loading, Parsers::Failed] {
                assert_eq!(parsers.check(family, " \n", to), Check::Empty);
            }
            assert_eq!(Parsers::Loading.check(family, text, to), Check::Loading);
            assert_eq!(Parsers::NotLoaded.check(family, text, to), Check::Loading);
            assert_eq!(Parsers::Failed.check(family, text, to), Check::Unavailable);
        }
        let ready = Parsers::Ready(crate::lazy::ConsoleParsers {
            uim2503: check,
            mbox: check_mbox,
            scl: check_scl,
        });
        assert_eq!(ready.check(Family::Uim2503, text, to), check(text));
        assert!(matches!(
            ready.check(Family::Uim2503, text, to),
            Check::Ready {
                instructions: 2,
                ..
            }
        ));
        let mbox = "read FN 0x20 4";
        assert_eq!(ready.check(Family::Mbox, mbox, to), check_mbox(mbox, to));
        assert!(matches!(
            ready.check(Family::Mbox, mbox, to),
            Check::Ready { .. }
        ));
        assert_eq!(ready.check(Family::Scl, "0IP", to), check_scl("0IP"));
        assert!(matches!(
            ready.check(Family::Scl, "0IP", to),
            Check::Ready { .. }
        ));
        // Each family's text is refused by the others' parsers.
        assert!(matches!(
            ready.check(Family::Scl, text, to),
            Check::Invalid(_)
        ));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn valid_text_is_ready_line_by_line() {
        assert_eq!(check("  \n # only a comment\n"), Check::Empty);
        assert_eq!(
            check("*5;PV;\n\n# query\n*0; MO=0;"),
            Check::Ready {
                lines: vec!["*5;PV;".into(), "*0; MO=0;".into()],
                instructions: 4
            }
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_parser_error_is_shown_with_its_place() {
        let Check::Invalid(error) = check("*5;\nQT[3]=0;") else {
            panic!("QT=0 must be refused");
        };
        assert!(error.message.starts_with("line 2, column"), "{error:?}");
        assert_eq!(error.code, "ascii_out_of_range");
        assert!(error.text(Lang::Zh).starts_with("第 2 行第"), "{error:?}");
        let Check::Invalid(error) = check("PV") else {
            panic!("missing ;");
        };
        assert!(error.message.contains("`;`"), "{error:?}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_gateways_own_commands_are_lines_like_any_other() {
        assert_eq!(
            check("ABC;\nbdr=115200;"),
            Check::Ready {
                lines: vec!["ABC;".into(), "bdr=115200;".into()],
                instructions: 2
            }
        );
        let Check::Invalid(error) = check("BDR=4800;") else {
            panic!("4800 baud is below what BDR takes");
        };
        assert_eq!(error.code, "ascii_out_of_range");
        assert!(error.message.contains("9600–115200"), "{error:?}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn mbox_text_is_checked_with_the_mbox_parser_and_the_selected_box() {
        let every = Route::BROADCAST;
        assert_eq!(check_mbox(" # nothing\n", every), Check::Empty);
        assert_eq!(
            check_mbox("read FN 0x20 4\n\n@all/none estop; release", every),
            Check::Ready {
                lines: vec!["read FN 0x20 4".into(), "@all/none estop; release".into()],
                instructions: 3
            }
        );
        let Check::Invalid(error) = check_mbox("reset\nread FX 0x20 4", every) else {
            panic!("FX must be refused");
        };
        assert!(error.message.starts_with("line 2, column 6"), "{error:?}");
        assert_eq!(error.code, "mbox_not_a_bank");
        // `@201` needs a selected box's subnet.
        assert!(matches!(check_mbox("@201 reset", every), Check::Invalid(_)));
        let status = Status {
            gateways: vec![floatball_shared::api::GatewayStatus {
                index: 0,
                baud: None,
                health: None,
                kind: GatewayKind::Mbox,
                port: "192.168.15.201:7408".into(),
                link: floatball_shared::api::LinkState::Up,
                bytes_per_s: 0.0,
                lowest_water_level: None,
                error: None,
                packets_per_s: Some(50.0),
                late_frames: Some(0),
                missed_replies: Some(0),
                drives: Vec::new(),
            }],
            ..Status::default()
        };
        assert_eq!(Family::of(&status), Family::Mbox);
        assert_ne!(Family::of(&Status::default()), Family::Mbox);
        let selected = mbox_route(Some(&status), None, Some(0));
        assert_eq!(selected, Route::to(BoxAddress::from_octets(15, 201)));
        assert_eq!(mbox_route(Some(&status), None, None), every);
        // A status of many boxes details only those with a problem: box 1 is found by
        // its index, box 2 in the installation.
        let mut many = status.clone();
        many.gateways[0].index = 1;
        many.gateways[0].port = "192.168.15.202:7408".into();
        let installation = InstallationInfo {
            rows: 1,
            cols: 3,
            pitch_mm: 500.0,
            travel_mm: 7500.0,
            max_speed_mm_s: 2000.0,
            max_accel_mm_s2: 4000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 250.0,
            counts_per_mm: 100.0,
            gateways: (201..204)
                .map(|octet| floatball_shared::api::InstallationGateway {
                    kind: GatewayKind::Mbox,
                    port: format!("192.168.15.{octet}:7408"),
                    baud: None,
                    stations: vec![1],
                })
                .collect(),
        };
        assert_eq!(
            mbox_route(Some(&many), Some(&installation), Some(1)),
            Route::to(BoxAddress::from_octets(15, 202))
        );
        assert_eq!(
            mbox_route(Some(&many), Some(&installation), Some(2)),
            Route::to(BoxAddress::from_octets(15, 203))
        );
        assert_eq!(mbox_route(Some(&many), None, Some(2)), every);
        // The family: the installation's, whatever the status details.
        assert_eq!(
            Family::of_either(Some(&installation), Some(&Status::default())),
            Family::Mbox
        );
        assert_eq!(Family::of_either(None, Some(&many)), Family::Mbox);
        assert_eq!(Family::of_either(None, None), Family::Uim2503);
        assert!(matches!(
            check_mbox("@202 reset", selected),
            Check::Ready { .. }
        ));
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn scl_text_is_checked_with_the_scl_parser() {
        assert_eq!(check_scl("  \n"), Check::Empty);
        assert_eq!(
            check_scl("0IP\n\n1VE2.5\n1FL"),
            Check::Ready {
                lines: vec!["0IP".into(), "1VE2.5".into(), "1FL".into()],
                instructions: 3,
            }
        );
        let Check::Invalid(error) = check_scl("0IP\n1XX5") else {
            panic!("an unknown mnemonic passed");
        };
        assert!(error.message.contains("line 2"), "{error:?}");
        // UIM2503 text is not SCL, and SCL is not UIM2503 text.
        assert!(matches!(check_scl("*5;PV;"), Check::Invalid(_)));
        let scl = Status {
            gateways: vec![floatball_shared::api::GatewayStatus {
                index: 0,
                baud: None,
                health: None,
                kind: GatewayKind::Scl,
                port: "/dev/ttyUSB0".into(),
                link: floatball_shared::api::LinkState::Up,
                bytes_per_s: 0.0,
                lowest_water_level: None,
                error: None,
                packets_per_s: None,
                late_frames: None,
                missed_replies: None,
                drives: Vec::new(),
            }],
            ..Status::default()
        };
        assert_eq!(Family::of(&scl), Family::Scl);
        assert_eq!(Family::of(&Status::default()), Family::Uim2503);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn mbox_replies_join_the_log() {
        let mut log = FeedbackLog::default();
        log.push_mbox(&MboxReply {
            gateway: 1,
            text: "FN0090 = 1".into(),
            registers: floatball_shared::api::MboxRegisters {
                bank: "FN".into(),
                start: 0x90,
                values: vec![1, 0xC0],
            },
        });
        let line = log.lines().next().unwrap();
        assert_eq!(
            (line.source(), line.text.as_str(), line.hex.as_str()),
            ("gw1".into(), "FN0090 = 1", "0001 00C0")
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn frames_are_decoded_in_the_manuals_notation() {
        assert_eq!(describe(&frame(5, code::PV, &[3, 0])), "PV = 3");
        assert_eq!(
            describe(&frame(5, code::QP, &[3, 0, 0xE8, 3, 0, 0])),
            "QP[3] = 1000"
        );
        assert_eq!(describe(&frame(5, code::MO, &[1])), "MO = 1");
        assert_eq!(
            describe(&frame(9, code::RTCN, &[44])),
            "RTCN 44 (PVT watermark)"
        );
        let error = describe(&frame(9, code::ER, &[0x33, code::QT, 3]));
        assert!(error.starts_with("ER: value out of range"), "{error}");
        let mut log = FeedbackLog::default();
        log.push(&frame(9, code::ER, &[0x32, 0, 0]));
        let line = log.lines().next().expect("a line");
        assert_eq!(
            line.text_in(Lang::Zh),
            "ER: 网关无法读取这条指令（错误 0x32）"
        );
        assert_eq!(
            line.text_in(Lang::En),
            "ER: the gateway could not read the instruction (error 0x32)"
        );
        log.push(&frame(9, code::ER, &[0x33, code::QT, 3]));
        let line = log.lines().next().expect("a line");
        assert_eq!(
            line.text_in(Lang::Zh),
            "ER: 数值超出范围或不一致（错误 0x33）（QT (0x27)，下标 3）"
        );
        log.push(&frame(9, code::PV, &[3, 0]));
        assert_eq!(
            log.lines().next().expect("a line").text_in(Lang::Zh),
            "PV = 3"
        );
        assert_eq!(describe(&frame(5, 0x70, &[])), "code 0x70");
        let bad = describe(&frame(5, code::PV, &[3]));
        assert!(bad.starts_with("? code 0x23"), "{bad}");
        let bad = describe(&frame(200, code::PV, &[3, 0]));
        assert!(bad.contains("station 200"), "{bad}");
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn positions_are_also_in_mm_on_known_stations() {
        let installation = InstallationInfo {
            rows: 2,
            cols: 3,
            pitch_mm: 500.0,
            travel_mm: 7500.0,
            max_speed_mm_s: 2000.0,
            max_accel_mm_s2: 4000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 250.0,
            counts_per_mm: 500.0,
            gateways: vec![
                floatball_shared::api::InstallationGateway {
                    kind: GatewayKind::Uim2503,
                    port: "sim".into(),
                    baud: None,
                    stations: vec![5, 6],
                },
                floatball_shared::api::InstallationGateway {
                    kind: GatewayKind::Mbox,
                    port: "sim".into(),
                    baud: None,
                    stations: vec![1, 2, 3],
                },
                floatball_shared::api::InstallationGateway {
                    kind: GatewayKind::Scl,
                    port: "sim".into(),
                    baud: None,
                    stations: vec![1],
                },
            ],
        };
        let known = Some(&installation);
        assert_eq!(counts_per_mm(known, 0, Some(5)), Some(500.0));
        // A station that is none of the installation's balls, an MBOX box, a gateway
        // the installation does not have, or no installation yet: counts only.
        assert_eq!(counts_per_mm(known, 0, Some(9)), None);
        assert_eq!(counts_per_mm(known, 1, Some(1)), None);
        assert_eq!(counts_per_mm(known, 7, Some(5)), None);
        assert_eq!(counts_per_mm(None, 0, Some(5)), None);
        assert_eq!(counts_per_mm(known, 2, None), Some(500.0));

        let pa = frame(5, code::PA, &200_000_i32.to_le_bytes());
        assert_eq!(describe_scaled(&pa, Some(500.0)), "PA = 200000 (400.0 mm)");
        assert_eq!(describe_scaled(&pa, None), "PA = 200000");
        let qp = frame(5, code::QP, &[3, 0, 0x30, 0xF8, 0xFF, 0xFF]);
        assert_eq!(describe_scaled(&qp, Some(500.0)), "QP[3] = -2000 (-4.0 mm)");
        // Not a position: no mm.
        assert_eq!(
            describe_scaled(&frame(5, code::PV, &[3, 0]), Some(500.0)),
            "PV = 3"
        );

        let mut log = FeedbackLog::default();
        log.push(&pa);
        log.set_installation(installation.clone());
        log.push(&pa);
        let texts: Vec<_> = log.lines().map(|line| line.text.clone()).collect();
        assert_eq!(texts, ["PA = 200000 (400.0 mm)", "PA = 200000"]);

        let mut log = FeedbackLog::default();
        let reply = |request: &str, text: &str, raw: &str| SclReply {
            gateway: 2,
            drive: "1".into(),
            request: request.into(),
            text: text.into(),
            raw: raw.into(),
        };
        log.push_scl(&reply("1EP", "EP = 1000", "1EP=1000"));
        log.set_installation(installation);
        log.push_scl(&reply("1IP", "IP = -1200", "1IP=-1200"));
        log.push_scl(&reply("1VE", "VE = 20.0", "1VE=20.0"));
        let texts: Vec<_> = log.lines().map(|line| line.text.clone()).collect();
        assert_eq!(
            texts,
            [
                "1VE → VE = 20.0",
                "1IP → IP = -1200 (-2.4 mm)",
                "1EP → EP = 1000"
            ]
        );
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn the_log_keeps_the_newest_frames_first() {
        let mut log = FeedbackLog::default();
        assert!(log.is_empty());
        for value in 0..(FEEDBACK_LINES as u8 + 5) {
            log.push(&frame(5, code::PV, &[value, 0]));
        }
        assert_eq!(log.len(), FEEDBACK_LINES);
        let newest = log.lines().next().unwrap();
        assert_eq!(newest.text, format!("PV = {}", FEEDBACK_LINES + 4));
        assert_eq!(newest.hex, format!("{:02X} 00", FEEDBACK_LINES + 4));
        assert_eq!(newest.id, FEEDBACK_LINES as u64 + 4);
        log.clear();
        assert!(log.is_empty());
    }
}
