//! The JSON messages of the HTTP and WebSocket API (`docs/architecture.md` §4): the contract between
//! the bridge and its clients.
//!
//! The bridge serialises these and the web app deserialises them (and the other way
//! round for requests), so every field is defined in exactly one place. `docs/api.md`
//! documents the same contract for people.
//!
//! Every WebSocket text frame is one JSON object with a `"type"` field:
//!
//! ```
//! use floatball_shared::api::{ClientMessage, ServerMessage};
//!
//! let raw: ClientMessage = serde_json::from_str(r#"{"type":"raw","line":"*5;PV;"}"#).unwrap();
//! assert_eq!(raw, ClientMessage::Raw { line: "*5;PV;".into(), gateway: None });
//! let error = ServerMessage::Error {
//!     message: "no such show".into(),
//!     code: "show_not_found".into(),
//!     params: [("name".to_owned(), "波浪".to_owned())].into(),
//!     reason_problem: None,
//!     fix_problems: Vec::new(),
//! };
//! assert_eq!(
//!     serde_json::to_string(&error).unwrap(),
//!     r#"{"type":"error","message":"no such show","code":"show_not_found","params":{"name":"波浪"}}"#
//! );
//! ```

use serde::{Deserialize, Serialize};

use crate::codes::{Code, Coded, Params};

// ----------------------------------------------------------------------------------
// HTTP
// ----------------------------------------------------------------------------------

/// `POST /api/login` request body.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LoginRequest {
    /// The operator password.
    pub password: String,
}

/// `POST /api/login` answer (200).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LoginResponse {
    /// The bearer token for `Authorization: Bearer …` and `/ws?token=…`.
    pub token: String,
    /// The password is still the factory default (`1234`): uploads and control are
    /// refused (403) until it is changed with `POST /api/password`.
    pub must_change_password: bool,
}

/// `POST /api/password` request body.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PasswordChange {
    /// The current password.
    pub old: String,
    /// The new password.
    pub new: String,
}

/// The body of every HTTP error answer:
/// `{"error": "...", "code": "...", "params": {...}, "details": [...], "problems": [...]}`.
///
/// `code` and `params` say what went wrong for the app, which renders them in the
/// operator's language ([`crate::codes`]); `error` and `details` say the same in
/// English for API clients and logs.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ApiError {
    /// What went wrong, in one English sentence an operator can act on.
    pub error: String,
    /// The stable code of the refusal (`snake_case`, [`Code::as_str`]); empty from a
    /// bridge older than the codes.
    #[serde(default)]
    pub code: String,
    /// The code's parameters (`retry_after_s`, `limit_bytes`…).
    #[serde(default, skip_serializing_if = "Params::is_empty")]
    pub params: Params,
    /// Every individual problem (e.g. each validation violation of a show) in English,
    /// if any.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub details: Vec<String>,
    /// The same problems as codes and parameters, in the same order as `details`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<Problem>,
}

impl ApiError {
    /// An error with `code`, its English sentence and no parameters.
    pub fn coded(code: Code, error: impl Into<String>) -> Self {
        Self {
            error: error.into(),
            code: code.as_str().to_owned(),
            params: Params::new(),
            details: Vec::new(),
            problems: Vec::new(),
        }
    }

    /// An error with `code` and `params`, its sentence the code's English template
    /// filled with them ([`crate::codes::english_text`]).
    pub fn from_template(code: Code, params: Params) -> Self {
        let error = crate::codes::english_text(code, &params);
        Self {
            params,
            ..Self::coded(code, error)
        }
    }
}

/// One individual problem of an [`ApiError`] (a validation violation, a CSV problem…):
/// its code and parameters.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Problem {
    /// The stable code ([`Code::as_str`]).
    pub code: String,
    /// The code's parameters.
    #[serde(default, skip_serializing_if = "Params::is_empty")]
    pub params: Params,
}

impl Problem {
    /// The problem of a typed error.
    pub fn of(error: &impl Coded) -> Self {
        Self {
            code: error.code().as_str().to_owned(),
            params: error.params(),
        }
    }
}

/// One show in `GET /api/shows` and the answer to a successful upload (201).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShowSummary {
    /// The show's file name on the controller (any script, at most 100 bytes).
    pub name: String,
    /// Size of the stored native JSON file, bytes.
    pub bytes: u64,
    /// SHA-256 of the stored file, lowercase hex.
    pub sha256: String,
    /// Last modification time, RFC 3339 in UTC (e.g. `2026-11-21T06:30:00Z`).
    pub modified: String,
    /// Number of balls (tracks) in the show.
    pub units: u32,
    /// Length of the show, ms.
    pub duration_ms: u64,
}

/// One entry of the playlist.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PlaylistEntry {
    /// The name of a show stored on the controller.
    pub show: String,
    /// Wait before the entry starts, ms.
    pub delay_ms: u64,
    /// How many times the entry plays in a row (the vendor app's "period"); at least 1.
    pub cycles: u32,
    /// The timecode at which the entry's show starts when the bridge chases timecode
    /// (`HH:MM:SS:FF`, `[timecode]`); absent: it follows the entry before it, or the
    /// playlist's timecode start.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timecode_start: Option<String>,
}

/// `GET` / `PUT /api/playlist`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Playlist {
    /// The entries, played in order by Start.
    pub entries: Vec<PlaylistEntry>,
    /// After the last entry, start again from the first.
    #[serde(rename = "loop")]
    pub loop_playlist: bool,
    /// Delay given to newly added entries, ms.
    pub default_delay_ms: u64,
    /// Cycles given to newly added entries.
    pub default_cycles: u32,
}

impl Default for Playlist {
    fn default() -> Self {
        Self {
            entries: Vec::new(),
            loop_playlist: false,
            default_delay_ms: 0,
            default_cycles: 1,
        }
    }
}

/// Whether a show can run on this installation, and why not (`GET /api/plan/{name}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanReport {
    /// The show's name.
    pub show: String,
    /// The show can run: it is valid and every gateway's line can carry it.
    pub feasible: bool,
    /// Why it cannot run (absent when feasible).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// What would make it run (higher baud, fewer units per gateway, longer rows…).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fixes: Vec<String>,
    /// `reason` as a code and parameters, for the app to say in the operator's
    /// language (absent when feasible, and from a bridge older than the codes). When
    /// its parameters have `more`, that many more problems follow the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reason_problem: Option<Problem>,
    /// `fixes` as codes and parameters, in the same order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fix_problems: Vec<Problem>,
    /// How long the slowest gateway's preload takes before the show can start, ms
    /// (the time Start waits in `loading` unless the show is armed).
    #[serde(default)]
    pub preload_ms: u64,
    /// Advice for a show that runs but could start sooner (a long preload, and the
    /// line speed that shortens it), as codes and parameters; empty when there is none.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub advice: Vec<Problem>,
    /// The figures per gateway.
    pub gateways: Vec<GatewayPlan>,
}

/// One ball's Q program for MOONS' drives (`GET /api/qprogram/{show}?unit=N`): the
/// listing and what the compiler did to the show (`scl::qprogram`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QProgramListing {
    /// The ball: its row-major index (the `u` number of a CSV column).
    pub unit: usize,
    /// The show's name.
    pub show: String,
    /// The listing: a `[segment n: …]` header per segment, then one command a line.
    pub text: String,
    /// Segments used (1–12).
    pub segments: usize,
    /// Lines of every segment together.
    pub lines: usize,
    /// `FP` moves kept.
    pub moves: usize,
    /// The largest |show − program| position, mm.
    pub max_deviation_mm: f64,
    /// When it happens, ms of show time.
    pub at_ms: u64,
}

/// The installation as the app needs it (`GET /api/installation`), and as the settings
/// and commissioning pages send it back changed (`PUT /api/installation`): the matrix,
/// its limits and calibration, and every gateway with its stations.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InstallationInfo {
    /// Rows of balls, as seen from below.
    pub rows: u32,
    /// Columns of balls.
    pub cols: u32,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
    /// Lowest position a ball may reach, mm below the top.
    pub travel_mm: f64,
    /// Top speed of a ball, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration of a ball, mm/s².
    pub max_accel_mm_s2: f64,
    /// Where balls go when homing, mm below the top.
    pub home_mm: f64,
    /// Speed of the move to a show's first position, mm/s.
    pub approach_speed_mm_s: f64,
    /// Counts per mm of ball travel of the UIM2503 units and MOONS' drives (`[matrix]
    /// counts_per_mm`); an MBOX box's pulses are its own (`pulses_per_mm`, an offset
    /// and a sign) and are not converted.
    pub counts_per_mm: f64,
    /// Every gateway, in configuration order; the first takes the first units
    /// (row-major), and so on.
    pub gateways: Vec<InstallationGateway>,
}

impl InstallationInfo {
    /// The units of the matrix, rows × cols.
    #[must_use]
    pub fn unit_count(&self) -> usize {
        self.rows as usize * self.cols as usize
    }

    /// The first cell (row-major index) of gateway `gateway`: the cells before it
    /// belong to the gateways before it.
    #[must_use]
    pub fn first_cell(&self, gateway: usize) -> usize {
        self.gateways
            .iter()
            .take(gateway)
            .map(|one| one.stations.len())
            .sum()
    }

    /// The limits a show must keep on this installation (its travel, top speed and
    /// acceleration, and its grid).
    #[must_use]
    pub fn limits(&self) -> crate::show::Limits {
        crate::show::Limits {
            travel_mm: self.travel_mm,
            max_speed_mm_s: self.max_speed_mm_s,
            max_accel_mm_s2: self.max_accel_mm_s2,
            rows: self.rows,
            cols: self.cols,
        }
    }

    /// The installation this describes, as the planner takes it: what the app needs
    /// to plan a show in the browser (the bandwidth verdict of a show it has just
    /// made) exactly as the bridge would. The inverse of the bridge's own
    /// description; the stop deceleration is the top acceleration, as the bridge's
    /// configuration sets it, and a gateway without a line speed (UDP) has 0.
    #[must_use]
    pub fn installation(&self) -> crate::plan::Installation {
        use crate::plan::{DriveKind, GatewaySpec, Installation, UnitAddress};
        let units = self
            .gateways
            .iter()
            .enumerate()
            .flat_map(|(gateway, one)| {
                one.stations
                    .iter()
                    .map(move |&station| UnitAddress { gateway, station })
            })
            .collect();
        let gateways = self
            .gateways
            .iter()
            .map(|one| GatewaySpec {
                port: one.port.clone(),
                baud: one.baud.unwrap_or(0),
                kind: match one.kind {
                    GatewayKind::Uim2503 => DriveKind::Uim2503,
                    GatewayKind::Mbox => DriveKind::Mbox,
                    GatewayKind::Scl => DriveKind::Scl,
                },
            })
            .collect();
        Installation {
            limits: self.limits(),
            pitch_mm: self.pitch_mm,
            counts_per_mm: self.counts_per_mm,
            gateways,
            units,
            approach_speed_mm_s: self.approach_speed_mm_s,
            home_mm: self.home_mm,
            stop_decel_mm_s2: self.max_accel_mm_s2,
        }
    }
}

/// One gateway in [`InstallationInfo`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct InstallationGateway {
    /// Its drive family; `uim2503` when absent.
    #[serde(default, skip_serializing_if = "GatewayKind::is_uim2503")]
    pub kind: GatewayKind,
    /// Its port: `sim`, a serial device, or an MBOX box's / eSCL drive's address.
    #[serde(default)]
    pub port: String,
    /// The line's speed, baud (serial lines; absent for UDP).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baud: Option<u32>,
    /// The stations of its balls, in unit order (its cells, row-major): UIM2503
    /// stations, MBOX axes, the places of MOONS' drives on the entry.
    pub stations: Vec<u8>,
}

// ----------------------------------------------------------------------------------
// Commissioning (`/api/gateways/{gateway}/…`, UIM2503 gateways)
// ----------------------------------------------------------------------------------

/// `POST /api/gateways/{gateway}/rollcall`, and the answer to an assignment: every unit
/// that answered on the gateway, and what is wrong with the bus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RollCall {
    /// The gateway (0-based, as configured).
    pub gateway: usize,
    /// Every unit that answered, by serial number, ascending.
    pub units: Vec<FoundUnit>,
    /// Stations more than one unit answered on (factory-fresh units: all on 5).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub duplicated: Vec<u8>,
    /// Configured stations nobody answered on.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missing: Vec<u8>,
    /// Stations that answered but are not configured on this gateway.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unexpected: Vec<u8>,
    /// How long the roll call took, ms.
    pub took_ms: u64,
}

/// One unit in a [`RollCall`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FoundUnit {
    /// Its serial number (`SN`).
    pub serial: u64,
    /// The station it answers on.
    pub station: u8,
    /// Where it is, mm below the top; absent when its station is shared (the answers
    /// cannot be told apart) or it did not answer the question.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_mm: Option<f64>,
    /// How long before the end of the roll call it last answered, ms.
    pub last_answer_age_ms: u64,
    /// The last error it reported, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fault: Option<UnitFault>,
    /// The cell (row-major index into the matrix) the installation gives its station
    /// on this gateway; absent when the station is not configured or is shared.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cell: Option<usize>,
}

/// `POST /api/gateways/{gateway}/assign`: give units their stations by serial number
/// (`*0;SN[X]=s/n;`, manual §6.0); answered with a new [`RollCall`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AssignRequest {
    /// Each unit's new station.
    pub assignments: Vec<Assignment>,
}

/// One unit's new station in an [`AssignRequest`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Assignment {
    /// The unit's serial number.
    pub serial: u64,
    /// Its new station, 1–127.
    pub station: u8,
}

/// `POST /api/gateways/{gateway}/identify`: move one ball down and back so the
/// installer sees which it is; the others stay still.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IdentifyRequest {
    /// The station of the ball to move.
    pub station: u8,
    /// How far down it moves, mm; the bridge's default when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub distance_mm: Option<f64>,
}

/// The answer to an [`IdentifyRequest`]: the move has started.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Identifying {
    /// The station that moves.
    pub station: u8,
    /// How far down it goes, mm.
    pub distance_mm: f64,
    /// When it will be back where it was, ms from now.
    pub duration_ms: u64,
}

/// `POST /api/gateways/{gateway}/baud`: the guided line-speed change (`BDR`, then the
/// gateway's restart, then a greeting at the new speed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct BaudRequest {
    /// The new speed, one of the gateway's rates (9600 to 115200).
    pub baud: u32,
}

/// The answer to a [`BaudRequest`] that succeeded: the gateway answered at the new
/// speed and the configuration says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct BaudChanged {
    /// The speed before.
    pub from_baud: u32,
    /// The speed now.
    pub baud: u32,
    /// How long the gateway took to answer at the new speed, ms.
    pub took_ms: u64,
}

/// The bandwidth figures of one gateway in a [`PlanReport`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GatewayPlan {
    /// The configured port (`sim` for a simulated gateway).
    pub port: String,
    /// The link's speed, baud.
    pub baud: u32,
    /// Units of the show on this gateway.
    pub units: u32,
    /// Mean bytes on the wire per PVT row.
    pub bytes_per_row: f64,
    /// Bytes sent before the synchronised start.
    pub preload_bytes: u64,
    /// Time to send the preload at this baud, ms.
    pub preload_ms: u64,
    /// Streaming rate the show needs while it plays, bytes/s.
    pub needed_bytes_per_s: f64,
    /// Rate the line carries (baud / 10), bytes/s.
    pub available_bytes_per_s: f64,
    /// The lowest FIFO water level any unit reaches (simulated), rows; absent when no
    /// unit streams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lowest_water_level: Option<u16>,
}

/// `GET /api/sim/positions`: the simulated units' true state, for tests and the app.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimPositions {
    /// Every simulated gateway, in configuration order.
    pub gateways: Vec<SimGateway>,
    /// Every simulated MBOX box in the bridge (`port = "sim"`), in configuration
    /// order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub boxes: Vec<SimBox>,
    /// Every simulated MOONS' drive in the bridge (`kind = "scl"`, `port = "sim"`),
    /// in gateway and unit order.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub drives: Vec<SimDrive>,
}

/// One simulated MOONS' drive in [`SimPositions`], at the simulated drives' clock.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimDrive {
    /// Index of its gateway entry in the configuration.
    pub gateway: usize,
    /// Its place on that entry (0 = the first unit).
    pub unit: usize,
    /// Its address character (eSCL drives take them in order: `'0'` the first).
    pub address: char,
    /// Position, counts.
    pub position_counts: f64,
    /// The motor moves.
    pub moving: bool,
    /// A program runs or buffered commands wait to run.
    pub executing: bool,
    /// The program waits for an input (`WI`): not started by the common start.
    pub waiting_input: bool,
    /// How many of the 12 Q segments hold a program.
    pub segments_stored: usize,
    /// Lines in its queue (a program of one segment runs from there, never stored).
    #[serde(default)]
    pub queue_lines: usize,
    /// How many moves it ended since it was switched on.
    pub moves_ended: usize,
    /// The alarm code (`AL`); 0 = none.
    pub alarm_code: u16,
    /// The motor is enabled (`ME`; `MD` disables it).
    #[serde(default)]
    pub motor_enabled: bool,
    /// Writes to its segments' non-volatile memory (`QS`) since it was switched on.
    #[serde(default)]
    pub flash_writes: u32,
}

/// One simulated gateway in [`SimPositions`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimGateway {
    /// Index of the gateway in the configuration.
    pub gateway: usize,
    /// The simulator's clock, µs since it started.
    pub time_us: u64,
    /// Every unit on this gateway's bus.
    pub units: Vec<SimUnit>,
    /// Its serial line: bytes taken, sent and dropped.
    #[serde(default)]
    pub line: SimLineStats,
}

/// A simulated gateway's serial line in [`SimGateway`]: what crossed it, and what was
/// dropped because it came faster than the line carries or than the gateway could send
/// (see `docs/protocol-notes.md`, "The simulator's serial line").
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimLineStats {
    /// Bytes from the host the gateway read.
    pub received_bytes: u64,
    /// Bytes from the host that arrived faster than the line carries them and were
    /// lost, as in a UART receive overrun.
    pub overrun_bytes: u64,
    /// Answer bytes that crossed the line to the host.
    pub sent_bytes: u64,
    /// Answer frames dropped unsent because the transmit queue was full.
    pub dropped_frames: u64,
    /// The bytes of those frames.
    pub dropped_bytes: u64,
}

/// One simulated unit, at the simulated gateway's time: what
/// [`crate::uim2503::sim::Gateway::units`] returns and `GET /api/sim/positions` serves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SimUnit {
    /// Its station number (CAN id).
    pub station: u8,
    /// Its serial number.
    pub serial: u64,
    /// Position, counts below the top (0 = upper limit).
    pub position_counts: f64,
    /// Velocity, counts/s (positive = down).
    pub velocity_counts_s: f64,
    /// The motor is enabled (`MO=1`).
    pub motor_on: bool,
    /// The ball is moving (point-to-point or PVT).
    pub moving: bool,
    /// Point-to-point moves begun since the unit's power-on: counts a move however
    /// short (an identify of 1 mm is over in a fraction of a second).
    #[serde(default)]
    pub ptp_moves: u64,
}

/// One simulated MBOX box (`floatball_shared::mbox::twin`), at the twin's time: where
/// its axes are, its registers that matter to a show, and what it received.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimBox {
    /// Its address: the last two octets of its IP address (`0x0FC9` = x.x.15.201).
    pub address: u16,
    /// Its IP address as the saved FN020–FN023 registers give it.
    pub ip: String,
    /// The twin's clock, µs since it started.
    pub time_us: u64,
    /// Every axis's position now, pulses, axis 1 (X) first.
    pub positions_pulses: Vec<i32>,
    /// Every axis's target (the last frame's position, or where it stopped).
    pub targets_pulses: Vec<i32>,
    /// Some axis has not reached its target yet.
    pub moving: bool,
    /// The e-stop is engaged (FN `0x0090` = 1): motion frames are ignored.
    pub estop: bool,
    /// CX 0, play control (0 = reset).
    pub play_control: u16,
    /// CX 1, the effects mask.
    pub effects_mask: u16,
    /// The last motion frame's 16 digital-output bits.
    pub digital: u16,
    /// The last motion frame's two analog outputs, raw.
    pub analog: [u16; 2],
    /// What the box received.
    pub counters: SimBoxCounters,
}

/// What a simulated MBOX received, in [`SimBox`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimBoxCounters {
    /// Datagrams received, whatever they were.
    pub datagrams: u64,
    /// Valid datagrams addressed to another box.
    pub not_for_this_box: u64,
    /// Motion frames carried out.
    pub motion_frames: u64,
    /// Motion frames ignored because the e-stop was engaged.
    pub ignored_estop: u64,
    /// Motion frames ignored because they drive another number of axes than the box has.
    pub wrong_axes: u64,
    /// Register reads answered or not (the replier decides).
    pub register_reads: u64,
    /// Register writes carried out.
    pub register_writes: u64,
    /// Read replies (`0x1102`) sent.
    pub replies: u64,
    /// Datagrams only a box sends (`0x1102`), received by a box.
    pub unexpected: u64,
    /// Numbered motion frames that skipped sequence numbers (each jump counts once).
    pub sequence_gaps: u64,
    /// The sequence numbers skipped by those jumps, in all.
    pub sequence_skipped: u64,
    /// Numbered motion frames whose sequence was not above the last one (repeats and
    /// frames from the past).
    pub sequence_repeats: u64,
    /// Absolute motion frames whose time code was not after the last one (a repeat or
    /// a rewind: the document gives such a frame no time, the twin its default).
    #[serde(default)]
    pub time_code_faults: u64,
    /// Datagrams the decoder refused, by reason.
    pub malformed: SimMalformed,
}

/// Datagrams a simulated MBOX refused, by the decoder's reason
/// (`floatball_shared::mbox::DecodeError`), in [`SimBoxCounters`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct SimMalformed {
    /// Shorter than a field their kind has.
    pub truncated: u64,
    /// Not starting `55 AA`.
    pub bad_magic: u64,
    /// A pass code other than `00 00`.
    pub bad_pass_code: u64,
    /// A function code the document does not define.
    pub unknown_function: u64,
    /// A channel the function does not take.
    pub unknown_channel: u64,
    /// A motion frame whose length does not match its axes.
    pub motion_length: u64,
    /// A register datagram whose length does not match its count.
    pub register_length: u64,
    /// An empty or overflowing register range.
    pub registers: u64,
}

impl SimMalformed {
    /// Every refused datagram.
    #[must_use]
    pub const fn total(&self) -> u64 {
        self.truncated
            + self.bad_magic
            + self.bad_pass_code
            + self.unknown_function
            + self.unknown_channel
            + self.motion_length
            + self.register_length
            + self.registers
    }
}

// ----------------------------------------------------------------------------------
// Live input: the patch (`/api/live/patch`)
// ----------------------------------------------------------------------------------

/// The patch as the app needs it (`GET /api/live/patch`, and the answer to
/// `PUT /api/live/patch`, whose body is the [`crate::live::patch::Patch`] alone): the
/// grid it is for, the `[live]` settings read from `floatball.toml`, every ball's
/// universe, address and profile, and the universes in use.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LivePatch {
    /// Rows of balls.
    pub rows: u32,
    /// Columns of balls.
    pub cols: u32,
    /// `[live] enabled`: whether live input is switched on in the file (the receivers
    /// come in a later step).
    pub enabled: bool,
    /// `[live] hold_after_ms`: input lost this long → the balls hold.
    pub hold_after_ms: u32,
    /// `[live] artnet`: Art-Net is received.
    pub artnet: bool,
    /// `[live] sacn`: sACN (E1.31) is received.
    pub sacn: bool,
    /// Every ball's universe, address and profile, row-major.
    pub patch: crate::live::patch::Patch,
    /// The universes the patch uses, in order.
    pub universes: Vec<u16>,
}

// ----------------------------------------------------------------------------------
// WebSocket
// ----------------------------------------------------------------------------------

/// Where a Start or Reset begins ("play from anywhere"): both absent, the playlist's
/// first entry from its start.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct StartFrom {
    /// The entry, **1-based** as the app numbers them; absent: the first.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entry: Option<usize>,
    /// The time inside the entry's show, ms; absent or 0: its start (after its
    /// delay). Every ball approaches where the show needs it, then the show plays on
    /// from there (`docs/api.md`, "Start from a time").
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time_ms: Option<u64>,
}

/// A message from a client (the web app, a test) to the bridge over `/ws`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ClientMessage {
    /// Play the playlist from its first entry, or from where [`StartFrom`] says
    /// (`{"type": "start"}`, `{"type": "start", "entry": 2, "time_ms": 30000}`).
    Start(StartFrom),
    /// Stop every ball at once (sent ahead of anything queued).
    Estop,
    /// Stop, return every ball home and restart from the first entry, or from where
    /// [`StartFrom`] says.
    Reset(StartFrom),
    /// Stop, return every ball home and stay idle there.
    Home,
    /// A console line of instructions, checked by the codec before it is sent.
    Raw {
        /// The instruction text, e.g. `*5;PV;`.
        line: String,
        /// Which gateway to send it to (index in the configuration); all when absent.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        gateway: Option<usize>,
    },
    /// Liveness check; the bridge answers [`ServerMessage::Pong`].
    Ping,
    /// Whether this client wants every gateway's [`ServerMessage::Feedback`] frames
    /// (on when a session opens). With a hundred gateways streaming they are thousands
    /// a second: the app asks for them only while its console is open.
    Feedback {
        /// `true`: relay them; `false`: none from now on.
        relay: bool,
    },
    /// Go live (`{"type": "live", "on": true}`): the balls approach the live input
    /// and follow it (homing first when their positions are unknown); `on: false`
    /// leaves live mode (the balls brake to rest, then the matrix is idle). An
    /// operator's request only: refused while the E-stop is latched (going live does
    /// not release it), while a playlist runs, and while `[live]` is off.
    Live {
        /// `true`: go live; `false`: leave live mode.
        on: bool,
    },
    /// Record the live motion from now on as a show named `name`
    /// (`{"type": "record", "name": "take 1"}`): refused unless the balls follow live
    /// input, and when a show of that name is stored already.
    Record {
        /// The show's name in the store.
        name: String,
    },
    /// Stop recording (`{"type": "record_stop"}`): the show is written to the store
    /// (braked to rest) and the bridge answers [`ServerMessage::Recorded`].
    RecordStop,
    /// Whether this client wants the balls' live positions
    /// ([`ServerMessage::LivePositions`]; off when a session opens): the app asks for
    /// them only while it shows the Preview or the Live card
    /// (`{"type": "live_positions", "on": true}`).
    LivePositions {
        /// `true`: send them while live; `false`: none from now on.
        on: bool,
    },
}

impl ClientMessage {
    /// Start from the playlist's first entry.
    #[must_use]
    pub fn start() -> Self {
        Self::Start(StartFrom::default())
    }

    /// Reset, then play from the playlist's first entry.
    #[must_use]
    pub fn reset() -> Self {
        Self::Reset(StartFrom::default())
    }
}

/// The most ball positions a second one client is sent in
/// [`ServerMessage::LivePositions`]: ten messages a second up to 2,000 balls, fewer
/// above (10,000 balls: two a second, about 50 KB each).
pub const LIVE_POSITIONS_PER_S: u32 = 20_000;

/// How often the live positions of `balls` balls are published, ms
/// ([`LIVE_POSITIONS_PER_S`]; never more often than every 100 ms).
#[must_use]
pub fn live_positions_period_ms(balls: usize) -> u64 {
    let balls = u64::try_from(balls).unwrap_or(u64::MAX);
    (balls.saturating_mul(1000) / u64::from(LIVE_POSITIONS_PER_S)).max(100)
}

/// A message from the bridge to a client over `/ws`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ServerMessage {
    /// The state of the matrix, sent on connect, on every change and at most ten
    /// times a second.
    Status(Status),
    /// One decoded feedback frame from a gateway.
    Feedback(FeedbackFrame),
    /// The answer to a [`ClientMessage::Ping`].
    Pong,
    /// The answer to a [`ClientMessage::Estop`]: the stop was handed to every link's
    /// writer (it is on the wire after at most the instruction already there).
    EstopSent {
        /// The gateways the stop could not reach now (not connected), each with the
        /// reason; they get it first thing when they come back.
        unreached: Vec<String>,
    },
    /// An MBOX box's answer to a register read sent from the console (the bridge's
    /// own polls are not relayed); sent to every client.
    MboxReply(MboxReply),
    /// A MOONS' drive's answer to a console line (SCL installations).
    SclReply(SclReply),
    /// The scheduler's state: sent on connect and whenever it changes
    /// ([`ScheduleStatus`]).
    Schedule(ScheduleStatus),
    /// A request was refused; the connection stays open.
    Error {
        /// What was wrong, in English words an operator can act on.
        message: String,
        /// The stable code ([`crate::codes::Code::as_str`]); empty from a bridge older
        /// than the codes.
        #[serde(default)]
        code: String,
        /// The code's parameters.
        #[serde(default, skip_serializing_if = "Params::is_empty")]
        params: Params,
        /// The `reason` parameter (English) as a coded problem, when the bridge has
        /// it typed (a refused Start: why the entry cannot run). Boxed: most errors
        /// have none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        reason_problem: Option<Box<Problem>>,
        /// The `fixes` parameter (English, joined by `; `) as coded problems, one per
        /// fix in the same order.
        #[serde(default, skip_serializing_if = "Vec::is_empty")]
        fix_problems: Vec<Problem>,
    },
    /// The timecode chase (`[timecode]`): the timecode, the offset between show time
    /// and timecode, the chase's state, the lead and the drift; sent on connect when
    /// the chase is on and on every change, at most ten times a second.
    Timecode(crate::timecode::chase::TimecodeStatus),
    /// Every ball's filtered live position, whole mm from the top, in ball order (row
    /// by row): sent to the clients that asked ([`ClientMessage::LivePositions`])
    /// while the matrix is live, ten times a second (less often on a large matrix:
    /// at most [`LIVE_POSITIONS_PER_S`] positions a second); once empty when live mode
    /// ends. Empty too before the approach has positions.
    LivePositions {
        /// Each ball's position, mm (rounded to whole mm).
        positions_mm: Vec<i32>,
    },
    /// The answer to [`ClientMessage::RecordStop`]: the recording is stored as the
    /// show `name` (it lists, previews and plays as any other).
    Recorded {
        /// The show's name in the store.
        name: String,
        /// Its duration, ms.
        duration_ms: u64,
    },
}

impl ServerMessage {
    /// A [`ServerMessage::Error`] with `code`, its English `message` and `params`.
    pub fn error(code: Code, message: impl Into<String>, params: Params) -> Self {
        Self::Error {
            message: message.into(),
            code: code.as_str().to_owned(),
            params,
            reason_problem: None,
            fix_problems: Vec::new(),
        }
    }

    /// A [`ServerMessage::Error`] with `code` and `params`, its `message` the code's
    /// English template filled with them ([`crate::codes::english_text`]).
    pub fn from_template(code: Code, params: Params) -> Self {
        Self::error(code, crate::codes::english_text(code, &params), params)
    }

    /// This message with the coded forms of its `reason` and `fixes` parameters (an
    /// error only; any other message is returned as it is).
    #[must_use]
    pub fn with_problems(mut self, reason: Option<Problem>, fixes: Vec<Problem>) -> Self {
        if let Self::Error {
            reason_problem,
            fix_problems,
            ..
        } = &mut self
        {
            *reason_problem = reason.map(Box::new);
            *fix_problems = fixes;
        }
        self
    }
}

/// An MBOX box's reply to a console read, in [`ServerMessage::MboxReply`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MboxReply {
    /// Index of the box's gateway entry in the configuration.
    pub gateway: usize,
    /// The reply as the console prints it: `FN0020..FN0023 = 192 168 15 201`.
    pub text: String,
    /// The registers it carries.
    pub registers: MboxRegisters,
}

/// A MOONS' drive's answer to an SCL console line, in [`ServerMessage::SclReply`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct SclReply {
    /// Index of the drive's gateway entry in the configuration.
    pub gateway: usize,
    /// The drive: its RS-485 address character, or its eSCL address and port.
    pub drive: String,
    /// The line as sent (`1IP`).
    pub request: String,
    /// The answer decoded: `executed`, `buffered`, `refused (code 5)`, `IP = -1200`,
    /// or why there is none (`no answer within 200 ms`).
    pub text: String,
    /// The answer as received, without its carriage return (`1IP=-1200`); empty when
    /// none came.
    pub raw: String,
}

/// A block of consecutive MBOX registers, in [`MboxReply`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct MboxRegisters {
    /// The bank: `FN` or `DN`.
    pub bank: String,
    /// The first register's address (FN020 is 32).
    pub start: u16,
    /// One value a register from `start` on.
    pub values: Vec<u16>,
}

/// A decoded feedback frame, as relayed to clients (bit 7 of the data restored).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct FeedbackFrame {
    /// Index of the gateway in the configuration.
    pub gateway: usize,
    /// The unit's station number.
    pub station: u8,
    /// The frame's code (the instruction's code for an ACK).
    pub code: u8,
    /// The restored data bytes (at most 8).
    pub data: Vec<u8>,
}

/// What the player is doing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PlayerState {
    /// Nothing is playing.
    #[default]
    Idle,
    /// Waiting for a playlist entry's delay to pass.
    Waiting,
    /// Balls are moving to the first position of a show.
    Approaching,
    /// Rows are being preloaded into the units.
    Loading,
    /// A show is running.
    Playing,
    /// Stopped by an e-stop; Start homes first.
    Stopped,
    /// Balls are returning to position 0.
    Homing,
    /// Something went wrong; see [`Status::last_error`].
    Error,
}

impl PlayerState {
    /// The state's name in the API (`playing`), the same in every language.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Idle => "idle",
            Self::Waiting => "waiting",
            Self::Approaching => "approaching",
            Self::Loading => "loading",
            Self::Playing => "playing",
            Self::Stopped => "stopped",
            Self::Homing => "homing",
            Self::Error => "error",
        }
    }
}

/// The state of one gateway's serial link.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LinkState {
    /// The link is open and bytes flow.
    Up,
    /// The link is being opened (or reopened after a loss).
    Connecting,
    /// The link is lost; the bridge retries with backoff.
    Down,
    /// The port is open but the gateway does not answer its greeting (`ABC;`, PROTOCOL
    /// §1.2): unpowered, another line speed, a wrong cable, or it stopped answering.
    /// Only the e-stop and the greeting are written; the bridge keeps greeting.
    NotAnswering,
}

/// Which drive family a gateway entry is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GatewayKind {
    /// A UIM2503 gateway on a serial line (the default).
    #[default]
    Uim2503,
    /// An MBOX motion controller over UDP.
    Mbox,
    /// MOONS' drives commanded in SCL: an RS-485 line, or eSCL drives over UDP.
    Scl,
}

impl GatewayKind {
    /// Whether it is the default, [`Self::Uim2503`] (left out of the JSON).
    #[must_use]
    pub fn is_uim2503(&self) -> bool {
        *self == Self::Uim2503
    }
}

/// One gateway as shown in the status.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GatewayStatus {
    /// Its place in the installation (0-based, the order of `[[gateway]]` entries).
    #[serde(default)]
    pub index: usize,
    /// Its drive family; `uim2503` when absent.
    #[serde(default, skip_serializing_if = "GatewayKind::is_uim2503")]
    pub kind: GatewayKind,
    /// The configured port (`sim` for the simulated gateway); an MBOX box's address
    /// and port.
    pub port: String,
    /// Whether the link is up.
    pub link: LinkState,
    /// Bytes written to the line per second, averaged over the last second.
    pub bytes_per_s: f64,
    /// The lowest FIFO water level of the units on this gateway during the current
    /// show, rows; absent when nothing streams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lowest_water_level: Option<u16>,
    /// Why the link is down, if it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// MBOX boxes: datagrams sent to the box per second, over the last second.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub packets_per_s: Option<f64>,
    /// MBOX boxes: motion frames sent more than half a frame period after their slot.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub late_frames: Option<u64>,
    /// MBOX boxes: register reads (polls) the box left unanswered: lost datagrams,
    /// either way, or a box that is down.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub missed_replies: Option<u64>,
    /// SCL gateways: every drive on the line (or every eSCL drive of the entry), in
    /// unit order, as the last status poll found it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub drives: Vec<SclDriveStatus>,
    /// Serial lines (UIM2503, SCL on RS-485): the line's speed now, baud.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baud: Option<u32>,
    /// UIM2503 gateways: how many of the configured units answer, and their faults;
    /// absent until the bridge has asked (a roll call, or its idle checks).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub health: Option<UnitHealth>,
}

/// The units of one UIM2503 gateway as the bridge last heard them
/// ([`GatewayStatus::health`]).
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct UnitHealth {
    /// Stations the installation gives this gateway.
    pub expected: u32,
    /// Of those, how many answered when last asked (or sent anything since).
    pub answering: u32,
    /// Configured stations that did not answer when last asked, ascending.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub missing: Vec<u8>,
    /// Stations that answered but are not configured on this gateway, ascending.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unexpected: Vec<u8>,
    /// Stations more than one unit answers on (a bus fault: factory-fresh units all
    /// answer on station 5), ascending.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub duplicated: Vec<u8>,
    /// The last error each unit reported (one entry per station, the newest), by
    /// station.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub faults: Vec<UnitFault>,
}

/// The last error a unit reported: an `ER` frame (`docs/protocol-notes.md` §2), as
/// [`crate::uim2503::feedback::UnitError`] decodes it; the app says it in words through its
/// code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct UnitFault {
    /// The unit's station.
    pub station: u8,
    /// The error number (0x32–0x41, [`crate::uim2503::feedback::UnitError::error`]).
    pub error: u8,
    /// The code of the instruction it refused.
    pub code: u8,
    /// The instruction's index, if it has one (else 0).
    pub index: u8,
}

impl UnitFault {
    /// The fault of the unit on `station` that sent `error`.
    #[must_use]
    pub fn of(station: u8, error: &crate::uim2503::feedback::UnitError) -> Self {
        Self {
            station,
            error: error.error,
            code: error.code,
            index: error.index,
        }
    }
}

/// A show loaded into the units while the matrix is idle ([`Status::armed`]): Start
/// then needs only the approach.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ArmedShow {
    /// The playlist entry (0-based) it was loaded for.
    pub entry: usize,
    /// The show's name.
    pub show: String,
    /// How much of its preload has reached the units, 0.0 to 1.0 (1.0: armed).
    pub progress: f64,
}

/// One MOONS' drive as the bridge's status poll (`IP`, `SC`, `AL`) last found it, in
/// [`GatewayStatus::drives`].
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct SclDriveStatus {
    /// Its RS-485 address character, or its eSCL address and port.
    pub address: String,
    /// Its immediate (commanded) position, counts (`IP`); absent until it answered.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position_counts: Option<i64>,
    /// Its status code word (`SC`, bit 4 = a program is executing); absent until read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub status_code: Option<u16>,
    /// Its alarm code word (`AL`, 0 = no alarm); absent until read.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alarm_code: Option<u16>,
    /// Requests it left unanswered within the timeout.
    pub missed_replies: u64,
    /// Program segments it saved to its non-volatile memory (`QS`) since the bridge
    /// started: each segment's memory lasts about 10,000 writes, so a repeated Start
    /// of the same show writes none.
    #[serde(default)]
    pub flash_writes: u64,
    /// Its last refusal or missed answer, in words, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The `status` message.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Status {
    /// What the player is doing.
    pub state: PlayerState,
    /// Index of the playlist entry being played, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub entry: Option<usize>,
    /// Name of the show being played, if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub show: Option<String>,
    /// Time into the show, ms: the units' own show time at the instant the status was
    /// made (0 until they start).
    pub show_time_ms: u64,
    /// While `loading` a show whose common start is already given: the units start
    /// this many ms after the status was made (the state turns `playing` then).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub show_starts_in_ms: Option<u64>,
    /// Length of the show, ms (0 when none).
    pub show_duration_ms: u64,
    /// Which cycle of the entry is playing (1-based; 0 when none).
    pub cycle: u32,
    /// Progress of the current phase (loading or playback), 0.0 to 1.0.
    pub progress: f64,
    /// Every configured gateway and its link.
    pub gateways: Vec<GatewayStatus>,
    /// The last error, if any, in words an operator can act on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last_error: Option<String>,
    /// While idle: the first playlist entry's show being loaded or loaded ahead of
    /// Start (nothing moves); absent when nothing is armed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub armed: Option<ArmedShow>,
    /// Every gateway counted: how many are up, the lowest water level, which have a
    /// problem. With more than [`GATEWAY_DETAIL_LIMIT`] gateways `gateways` lists only
    /// those with a problem (`GET /api/status/gateways` gives every one).
    #[serde(default)]
    pub gateway_summary: GatewaySummary,
    /// While live mode is on (issue 38): its phase, whether the input is lost, the
    /// period and the latency the drive family gives, the recording; absent otherwise
    /// (old clients ignore it). The state is `homing`, `loading` (the drive prepares)
    /// or `approaching` on the way in,
    /// `playing` while the balls follow, hold or brake to leave.
    /// (Boxed: a status stays small in every message.)
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub live: Option<Box<LiveStatus>>,
}

/// Where live mode stands ([`Status::live`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LivePhase {
    /// The positions were unknown: the balls home first.
    Homing,
    /// The drive prepares live motion (UIM2503 units: their FIFO and its first rows).
    Preparing,
    /// The balls move to the first live positions at the approach speed.
    Approaching,
    /// The balls follow the input through the motion filter.
    Following,
    /// The input is lost: the balls decelerate within the limits and stay.
    Holding,
    /// The operator left live mode: the balls brake to rest, then the matrix is idle.
    Leaving,
}

impl LivePhase {
    /// The phase's name in the API (`following`).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Homing => "homing",
            Self::Preparing => "preparing",
            Self::Approaching => "approaching",
            Self::Following => "following",
            Self::Holding => "holding",
            Self::Leaving => "leaving",
        }
    }
}

/// Live mode in the status.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LiveStatus {
    /// Its phase.
    pub phase: LivePhase,
    /// The input is lost (longer than the configured time): the balls hold.
    #[serde(default)]
    pub input_lost: bool,
    /// The drive's live period: one filter step and one output per period, ms.
    pub period_ms: u32,
    /// From an input to the balls following it, at most, ms: the drive family's
    /// (a period and the frame's move for MBOX boxes, the FIFO's depth for UIM2503
    /// units, the line's round for MOONS' drives).
    pub latency_ms: u32,
    /// The filtered motion is being recorded.
    #[serde(default)]
    pub recording: bool,
    /// How much is recorded so far, ms.
    #[serde(default)]
    pub recorded_ms: u64,
}

/// With more gateways than this, a status lists in full only the gateways with a
/// problem; [`Status::gateway_summary`] still counts every one.
pub const GATEWAY_DETAIL_LIMIT: usize = 16;

/// Every gateway of the installation in a few numbers, so that a status stays small
/// with a hundred gateways.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct GatewaySummary {
    /// Gateways in the installation.
    pub total: u32,
    /// Of those, how many links are up.
    pub up: u32,
    /// Bytes written per second, all gateways together.
    pub bytes_per_s: f64,
    /// The lowest FIFO water level of any unit on any gateway during the current show,
    /// rows; absent when nothing streams.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lowest_water_level: Option<u16>,
    /// The gateway (index) with that lowest level.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lowest_water_gateway: Option<usize>,
    /// The gateways (indices, ascending) with a problem ([`GatewayStatus::has_problem`]).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<usize>,
    /// Whether [`Status::gateways`] lists every gateway (`false`: only `problems`).
    pub complete: bool,
}

impl GatewayStatus {
    /// Whether an operator should look at this gateway: its link is not up, it has an
    /// error, or (UIM2503) units are missing, unexpected, shared or in fault, or (SCL)
    /// a drive reports a problem.
    #[must_use]
    pub fn has_problem(&self) -> bool {
        let health = self.health.as_ref().is_some_and(|health| {
            !health.missing.is_empty()
                || !health.unexpected.is_empty()
                || !health.duplicated.is_empty()
                || !health.faults.is_empty()
        });
        self.link != LinkState::Up
            || self.error.is_some()
            || health
            || self.drives.iter().any(|drive| drive.error.is_some())
    }
}

/// Counts `all` (every gateway, in installation order) into a [`GatewaySummary`] and
/// keeps the details a status carries: every gateway up to [`GATEWAY_DETAIL_LIMIT`],
/// beyond that only those with a problem.
#[must_use]
pub fn summarise_gateways(all: Vec<GatewayStatus>) -> (Vec<GatewayStatus>, GatewaySummary) {
    let mut summary = GatewaySummary {
        total: u32::try_from(all.len()).unwrap_or(u32::MAX),
        complete: all.len() <= GATEWAY_DETAIL_LIMIT,
        ..GatewaySummary::default()
    };
    for gateway in &all {
        if gateway.link == LinkState::Up {
            summary.up += 1;
        }
        summary.bytes_per_s += gateway.bytes_per_s;
        if let Some(level) = gateway.lowest_water_level
            && summary
                .lowest_water_level
                .is_none_or(|lowest| level < lowest)
        {
            summary.lowest_water_level = Some(level);
            summary.lowest_water_gateway = Some(gateway.index);
        }
        if gateway.has_problem() {
            summary.problems.push(gateway.index);
        }
    }
    let details = if summary.complete {
        all
    } else {
        all.into_iter().filter(GatewayStatus::has_problem).collect()
    };
    (details, summary)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn live_positions_are_ten_a_second_up_to_2000_balls_then_fewer() {
        assert_eq!(live_positions_period_ms(0), 100);
        assert_eq!(live_positions_period_ms(2_000), 100);
        assert_eq!(live_positions_period_ms(10_000), 500);
        let message = ServerMessage::LivePositions {
            positions_mm: vec![0, 512],
        };
        assert_eq!(
            serde_json::to_string(&message).expect("json"),
            r#"{"type":"live_positions","positions_mm":[0,512]}"#
        );
        let wish: ClientMessage =
            serde_json::from_str(r#"{"type":"live_positions","on":true}"#).expect("valid");
        assert_eq!(wish, ClientMessage::LivePositions { on: true });
    }

    #[test]
    fn client_messages_use_the_documented_json() {
        let raw: ClientMessage =
            serde_json::from_str(r#"{"type":"raw","line":"*5;PV;"}"#).expect("valid raw");
        assert_eq!(
            raw,
            ClientMessage::Raw {
                line: "*5;PV;".into(),
                gateway: None
            }
        );
        let estop: ClientMessage = serde_json::from_str(r#"{"type":"estop"}"#).expect("estop");
        assert_eq!(estop, ClientMessage::Estop);
    }

    #[test]
    fn start_and_reset_may_name_an_entry_and_a_time() {
        let read = |text: &str| serde_json::from_str::<ClientMessage>(text).expect(text);
        assert_eq!(read(r#"{"type":"start"}"#), ClientMessage::start());
        assert_eq!(read(r#"{"type":"reset"}"#), ClientMessage::reset());
        let from = StartFrom {
            entry: Some(2),
            time_ms: Some(30_000),
        };
        assert_eq!(
            read(r#"{"type":"start","entry":2,"time_ms":30000}"#),
            ClientMessage::Start(from)
        );
        assert_eq!(
            read(r#"{"type":"reset","time_ms":500}"#),
            ClientMessage::Reset(StartFrom {
                entry: None,
                time_ms: Some(500)
            })
        );
        assert_eq!(
            serde_json::to_string(&ClientMessage::start()).unwrap(),
            r#"{"type":"start"}"#
        );
        assert_eq!(
            serde_json::to_string(&ClientMessage::Start(from)).unwrap(),
            r#"{"type":"start","entry":2,"time_ms":30000}"#
        );
        assert!(serde_json::from_str::<ClientMessage>(r#"{"type":"start","entry":-1}"#).is_err());
    }

    fn gateway(index: usize, link: LinkState, level: Option<u16>) -> GatewayStatus {
        GatewayStatus {
            index,
            kind: GatewayKind::Uim2503,
            port: format!("tcp://10.0.0.{index}:4001"),
            link,
            bytes_per_s: 100.0,
            lowest_water_level: level,
            error: None,
            packets_per_s: None,
            late_frames: None,
            missed_replies: None,
            drives: Vec::new(),
            baud: Some(115_200),
            health: None,
        }
    }

    #[test]
    fn a_few_gateways_are_all_detailed() {
        let all: Vec<_> = (0..3)
            .map(|i| gateway(i, LinkState::Up, Some(200 - i as u16)))
            .collect();
        let (details, summary) = summarise_gateways(all.clone());
        assert_eq!(details, all);
        assert!(summary.complete);
        assert_eq!((summary.total, summary.up), (3, 3));
        assert_eq!(summary.lowest_water_level, Some(198));
        assert_eq!(summary.lowest_water_gateway, Some(2));
        assert!(summary.problems.is_empty());
        assert!((summary.bytes_per_s - 300.0).abs() < 1e-9);
    }

    #[test]
    fn a_hundred_gateways_detail_only_their_problems() {
        let mut all: Vec<_> = (0..100)
            .map(|i| gateway(i, LinkState::Up, Some(180)))
            .collect();
        all[7].link = LinkState::Down;
        all[42].health = Some(UnitHealth {
            expected: 100,
            answering: 99,
            missing: vec![12],
            ..UnitHealth::default()
        });
        all[63].lowest_water_level = Some(3);
        let (details, summary) = summarise_gateways(all);
        assert!(!summary.complete);
        assert_eq!((summary.total, summary.up), (100, 99));
        assert_eq!(summary.problems, vec![7, 42]);
        assert_eq!(
            details.iter().map(|g| g.index).collect::<Vec<_>>(),
            vec![7, 42]
        );
        assert_eq!(summary.lowest_water_level, Some(3));
        assert_eq!(summary.lowest_water_gateway, Some(63));
        let json = serde_json::to_string(&Status {
            gateways: details,
            gateway_summary: summary,
            ..Status::default()
        })
        .expect("json");
        assert!(json.len() < 1500, "{} bytes: {json}", json.len());
    }

    #[test]
    fn status_serialises_with_a_type_tag() {
        let json = serde_json::to_value(ServerMessage::Status(Status::default())).expect("json");
        assert_eq!(json["type"], "status");
        assert_eq!(json["state"], "idle");
        assert!(json.get("last_error").is_none());
    }

    #[test]
    fn feedback_has_the_documented_fields() {
        let message = ServerMessage::Feedback(FeedbackFrame {
            gateway: 0,
            station: 5,
            code: 0x23,
            data: vec![3, 0],
        });
        let json = serde_json::to_string(&message).expect("json");
        assert_eq!(
            json,
            r#"{"type":"feedback","gateway":0,"station":5,"code":35,"data":[3,0]}"#
        );
    }

    #[test]
    fn playlist_uses_loop_as_the_field_name() {
        let playlist: Playlist = serde_json::from_str(
            r#"{"entries":[{"show":"波浪","delay_ms":500,"cycles":2}],"loop":true,
                "default_delay_ms":0,"default_cycles":1}"#,
        )
        .expect("playlist");
        assert!(playlist.loop_playlist);
        assert_eq!(playlist.entries[0].show, "波浪");
        let json = serde_json::to_value(&playlist).expect("json");
        assert_eq!(json["loop"], true);
    }

    #[test]
    fn api_errors_omit_empty_details() {
        let json =
            serde_json::to_string(&ApiError::coded(Code::NotFound, "no such call")).expect("json");
        assert_eq!(json, r#"{"error":"no such call","code":"not_found"}"#);
    }

    #[test]
    fn api_errors_from_older_bridges_still_parse() {
        let old: ApiError =
            serde_json::from_str(r#"{"error":"bad name","details":["x"]}"#).expect("old");
        assert_eq!(old.code, "");
        assert!(old.params.is_empty() && old.problems.is_empty());
        let message: ServerMessage =
            serde_json::from_str(r#"{"type":"error","message":"no"}"#).expect("old message");
        assert!(matches!(message, ServerMessage::Error { code, .. } if code.is_empty()));
    }

    #[test]
    fn api_errors_carry_params_and_problems() {
        let mut error = ApiError::coded(Code::TooManyAttempts, "wait");
        error.params.insert("retry_after_s".into(), "53".into());
        error.problems.push(Problem {
            code: "wrong_password".into(),
            params: Params::new(),
        });
        let json = serde_json::to_string(&error).expect("json");
        assert_eq!(
            json,
            r#"{"error":"wait","code":"too_many_attempts","params":{"retry_after_s":"53"},"problems":[{"code":"wrong_password"}]}"#
        );
        assert_eq!(
            serde_json::from_str::<ApiError>(&json).expect("back"),
            error
        );
    }

    #[test]
    fn mbox_replies_and_kinds_use_the_documented_json() {
        let message = ServerMessage::MboxReply(MboxReply {
            gateway: 1,
            text: "FN0090 = 1".into(),
            registers: MboxRegisters {
                bank: "FN".into(),
                start: 0x90,
                values: vec![1],
            },
        });
        assert_eq!(
            serde_json::to_string(&message).expect("json"),
            r#"{"type":"mbox_reply","gateway":1,"text":"FN0090 = 1","registers":{"bank":"FN","start":144,"values":[1]}}"#
        );
        let uim: GatewayStatus =
            serde_json::from_str(r#"{"port":"sim","link":"up","bytes_per_s":0.0}"#).expect("uim");
        assert_eq!(uim.kind, GatewayKind::Uim2503);
        assert!(
            serde_json::to_value(&uim)
                .expect("json")
                .get("kind")
                .is_none()
        );
        let mbox = GatewayStatus {
            index: 0,
            baud: None,
            health: None,
            kind: GatewayKind::Mbox,
            ..uim
        };
        assert_eq!(serde_json::to_value(&mbox).expect("json")["kind"], "mbox");
    }

    #[test]
    fn scl_replies_and_drives_use_the_documented_json() {
        let message = ServerMessage::SclReply(SclReply {
            gateway: 0,
            drive: "2".into(),
            request: "2IP".into(),
            text: "IP = 1200".into(),
            raw: "IP=1200".into(),
        });
        assert_eq!(
            serde_json::to_string(&message).expect("json"),
            r#"{"type":"scl_reply","gateway":0,"drive":"2","request":"2IP","text":"IP = 1200","raw":"IP=1200"}"#
        );
        let status = GatewayStatus {
            index: 0,
            kind: GatewayKind::Scl,
            port: "/dev/ttyUSB0".into(),
            link: LinkState::Up,
            bytes_per_s: 0.0,
            lowest_water_level: None,
            error: None,
            packets_per_s: None,
            late_frames: None,
            missed_replies: Some(1),
            drives: vec![SclDriveStatus {
                address: "1".into(),
                position_counts: Some(-1200),
                status_code: Some(0x4001),
                alarm_code: Some(0),
                missed_replies: 1,
                flash_writes: 3,
                error: None,
            }],
            baud: Some(9600),
            health: None,
        };
        let json = serde_json::to_value(&status).expect("json");
        assert_eq!(json["kind"], "scl");
        assert_eq!(
            json["drives"][0],
            serde_json::json!({"address": "1", "position_counts": -1200, "status_code": 16385, "alarm_code": 0, "missed_replies": 1, "flash_writes": 3})
        );
        let back: GatewayStatus = serde_json::from_value(json).expect("back");
        assert_eq!(back, status);
    }

    #[test]
    fn unknown_types_are_refused() {
        assert!(serde_json::from_str::<ClientMessage>(r#"{"type":"dance"}"#).is_err());
    }
}

/// What the bridge's scheduler is doing (`docs/show-control.md`, "Schedule"): in
/// [`ServerMessage::Schedule`] and `GET /api/schedule/status`. Times are the
/// installation's local time, `YYYY-MM-DD HH:MM`.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ScheduleStatus {
    /// Whether the schedule is followed.
    pub enabled: bool,
    /// Its time zone.
    pub time_zone: String,
    /// The window open now, `HH:MM–HH:MM` style (`start` and `end` as local times).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub window: Option<ScheduleWindowNow>,
    /// The next start (a window's, or an every-N slot's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub next_start: Option<String>,
    /// What the scheduler did last.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub last: Option<ScheduleOutcome>,
}

/// The window the scheduler is in ([`ScheduleStatus::window`]).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScheduleWindowNow {
    /// When it opened (local).
    pub start: String,
    /// When it closes (local).
    pub end: String,
    /// What plays.
    pub program: crate::schedule::Program,
}

/// One thing the scheduler did, or did not do and why ([`ScheduleStatus::last`]): a
/// code ([`crate::codes::Code`], `schedule_…`) and its parameters, as the app words
/// it, and the English sentence.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ScheduleOutcome {
    /// When (local).
    pub at: String,
    /// Whether it was done (a start or an end), `false` when it was not.
    pub done: bool,
    /// The code.
    pub code: String,
    /// Its parameters.
    #[serde(default, skip_serializing_if = "Params::is_empty")]
    pub params: Params,
    /// The same in English.
    pub message: String,
}
