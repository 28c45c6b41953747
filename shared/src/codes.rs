//! The stable error codes of every refusal, validation problem and parse error the
//! bridge and the shared parsers report, and the [`Coded`] trait that gives each typed
//! error its code and parameters.
//!
//! The bridge puts the code (`snake_case`, never renamed once published) and the
//! parameters into [`crate::api::ApiError`], [`crate::api::Problem`] and
//! [`crate::api::ServerMessage::Error`] beside an English sentence for API clients;
//! the app renders the code with its parameters in the operator's language. Every
//! code is in [`Code::ALL`], so a test can check that each has a text in every
//! language (`web/src/i18n.rs`), and the table in `docs/errors.md` lists them.

use std::collections::BTreeMap;

/// The parameters of a coded error: names (`unit`, `time_ms`, `limit`…) to values,
/// as text.
pub type Params = BTreeMap<String, String>;

/// A typed error that has a stable code and parameters.
pub trait Coded {
    /// Its stable code.
    fn code(&self) -> Code;
    /// Its parameters (the names [`Code::params`] lists, and optional others).
    fn params(&self) -> Params;
}

/// The parameters of `kind` and where in the text it was found, `line` and `column`
/// (1-based): the parse errors of the three console languages.
pub fn located(kind: &impl Coded, line: u32, column: u32) -> Params {
    let mut params = kind.params();
    params.insert("line".into(), line.to_string());
    params.insert("column".into(), column.to_string());
    params
}

/// Builds [`Params`] from `name => value` pairs (values through `to_string`).
#[macro_export]
macro_rules! params {
    ($($name:literal => $value:expr),* $(,)?) => {{
        #[allow(unused_mut)]
        let mut params = $crate::codes::Params::new();
        $(params.insert($name.to_owned(), ($value).to_string());)*
        params
    }};
}

macro_rules! codes {
    ($($(#[doc = $doc:literal])* $name:ident = $code:literal [$($param:literal),*];)*) => {
        /// A stable error code. Its text is [`Code::as_str`]; [`Code::params`] names the
        /// parameters every error of that code carries.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub enum Code {
            $($(#[doc = $doc])* $name,)*
        }

        impl Code {
            /// Every code, for the tests that check translations and docs.
            pub const ALL: &'static [Code] = &[$(Code::$name),*];

            /// The code as it appears in the JSON (`snake_case`).
            #[must_use]
            pub const fn as_str(self) -> &'static str {
                match self {
                    $(Code::$name => $code,)*
                }
            }

            /// The parameters every error with this code carries.
            #[must_use]
            pub const fn params(self) -> &'static [&'static str] {
                match self {
                    $(Code::$name => &[$($param),*],)*
                }
            }
        }
    };
}

impl Code {
    /// The code whose text is `code`, if it is one of [`Code::ALL`].
    #[must_use]
    pub fn parse(code: &str) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|known| known.as_str() == code)
    }
}

impl std::fmt::Display for Code {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

codes! {
    // ---- HTTP in general ----
    /// No API call at that path.
    NotFound = "not_found" [];
    /// The API call does not take that method.
    MethodNotAllowed = "method_not_allowed" [];
    /// The request body is larger than the call accepts.
    BodyTooLarge = "body_too_large" ["limit_bytes"];
    /// The request's Content-Type is not one the call accepts.
    UnsupportedMediaType = "unsupported_media_type" [];
    /// The request body is not the JSON the call expects.
    BadJson = "bad_json" ["what", "reason"];
    /// The framework refused the request for another reason (`status`).
    RequestRefused = "request_refused" ["status"];
    /// Something failed inside the bridge (logged there).
    Internal = "internal" ["what"];
    // ---- sessions ----
    /// The call needs a login (no token sent).
    LoginRequired = "login_required" [];
    /// The token is unknown or expired.
    SessionExpired = "session_expired" [];
    /// The password is wrong.
    WrongPassword = "wrong_password" [];
    /// Too many wrong passwords from this address; wait `retry_after_s` seconds.
    TooManyAttempts = "too_many_attempts" ["retry_after_s"];
    /// The bridge is busy checking other passwords; wait `retry_after_s` seconds.
    LoginBusy = "login_busy" ["retry_after_s"];
    /// The factory password must be changed first.
    MustChangePassword = "must_change_password" [];
    /// The current password given for a change is wrong.
    WrongCurrentPassword = "wrong_current_password" [];
    /// The new password is shorter than `min` characters.
    PasswordTooShort = "password_too_short" ["min"];
    /// The new password is longer than `max_bytes`.
    PasswordTooLong = "password_too_long" ["max_bytes"];
    /// The new password may not be the factory password (`default`).
    PasswordIsDefault = "password_is_default" ["default"];
    /// The page's origin may not open the WebSocket.
    OriginNotAllowed = "origin_not_allowed" [];
    // ---- shows and uploads ----
    /// The show name is not allowed (`reason` in English).
    BadShowName = "bad_show_name" ["reason"];
    /// There is no show of that name.
    ShowNotFound = "show_not_found" ["name"];
    /// A stored show no longer reads as a show (`reason` in English).
    ShowUnreadable = "show_unreadable" ["name", "reason"];
    /// The show is in the playlist and cannot be deleted.
    ShowInPlaylist = "show_in_playlist" ["name"];
    /// The upload was not received whole.
    UploadIncomplete = "upload_incomplete" [];
    /// The file is not UTF-8 text (first bad byte).
    NotUtf8 = "not_utf8" ["byte"];
    /// The native show file cannot be read (its problem follows in `problems`).
    ShowFileUnreadable = "show_file_unreadable" [];
    /// The CSV keyframes cannot be imported (the problem follows in `problems`).
    CsvUnreadable = "csv_unreadable" [];
    /// The show has no motion.
    ShowEmpty = "show_empty" [];
    /// The show is longer than `[uploads] max_duration`.
    ShowTooLong = "show_too_long" ["limit_ms"];
    /// The show as stored is larger than `[uploads] max_bytes`.
    ShowTooLarge = "show_too_large" ["limit_bytes"];
    /// The show does not fit the installation (`count` problems follow).
    ShowUnfit = "show_unfit" ["count"];
    /// An output track names a box the installation lacks.
    OutputBox = "output_box" ["box", "boxes"];
    /// Only the first problems are listed; `count` more follow.
    MoreProblems = "more_problems" ["count"];
    /// A CSV show needs two keyframes, the last after 0 ms.
    CsvNeedsMotion = "csv_needs_motion" [];
    /// Every ball's `rows` is empty.
    JsonNeedsMotion = "json_needs_motion" [];
    /// The show lasts `duration_ms`.
    ShowLasts = "show_lasts" ["duration_ms"];
    /// As stored, the show takes `bytes`.
    ShowTakes = "show_takes" ["bytes"];
    // ---- validation (each violation; `unit` and `time_ms` say where, when known) ----
    /// Above the top (position below 0 mm).
    AboveTop = "above_top" ["position_mm"];
    /// Below the travel.
    BelowTravel = "below_travel" ["position_mm", "travel_mm"];
    /// Too fast.
    TooFast = "too_fast" ["speed_mm_s", "limit_mm_s"];
    /// Accelerating or braking too hard.
    TooHardAcceleration = "too_hard_acceleration" ["accel_mm_s2", "limit_mm_s2"];
    /// A row outside 10–255 ms.
    RowDuration = "row_duration" ["row", "duration_ms", "min_ms", "max_ms"];
    /// A track shorter than the show.
    TrackDuration = "track_duration" ["duration_s", "show_duration_s"];
    /// The track ends moving.
    EndsMoving = "ends_moving" ["velocity_mm_s"];
    /// Made for another grid.
    WrongLayout = "wrong_layout" ["show_rows", "show_cols", "rows", "cols"];
    // ---- native show files ----
    /// Not valid JSON or a field wrong (`message` is serde's, in English).
    ShowInvalid = "show_invalid" ["message"];
    /// Not a Floatball show file.
    ShowWrongFormat = "show_wrong_format" ["found"];
    /// A newer format version.
    ShowUnsupportedVersion = "show_unsupported_version" ["found", "version"];
    /// A layout without balls or pitch.
    ShowEmptyLayout = "show_empty_layout" [];
    /// Tracks differ from rows × cols.
    ShowTrackCount = "show_track_count" ["tracks", "rows", "cols"];
    /// A position or velocity is not finite.
    ShowNotFinite = "show_not_finite" ["track"];
    /// An output track that cannot be played (`detail` in English).
    ShowOutput = "show_output" ["box", "detail"];
    /// Colour keyframes out of order.
    ShowColourOrder = "show_colour_order" ["track", "index"];
    // ---- CSV keyframes (each with `line` and `column`) ----
    /// Nothing but blank lines.
    CsvEmpty = "csv_empty" [];
    /// No header after the layout line.
    CsvNoHeader = "csv_no_header" [];
    /// A `#` line not first.
    CsvMisplacedComment = "csv_misplaced_comment" [];
    /// A word on the layout line not understood.
    CsvLayoutWord = "csv_layout_word" ["text"];
    /// A bad value on the layout line.
    CsvLayoutValue = "csv_layout_value" ["key", "text"];
    /// A key missing from the layout line.
    CsvLayoutMissing = "csv_layout_missing" ["key"];
    /// A wrong header column name.
    CsvHeaderName = "csv_header_name" ["found", "expected"];
    /// The header names no balls.
    CsvNoUnits = "csv_no_units" [];
    /// Ball columns differ from the layout's balls.
    CsvLayoutMismatch = "csv_layout_mismatch" ["units", "rows", "cols"];
    /// A line with the wrong number of fields.
    CsvFieldCount = "csv_field_count" ["found", "expected"];
    /// A field that is not a number.
    CsvNotANumber = "csv_not_a_number" ["text"];
    /// No keyframes after the header.
    CsvNoKeyframes = "csv_no_keyframes" [];
    /// The first keyframe is not at 0.
    CsvFirstTimeNotZero = "csv_first_time_not_zero" ["time_ms"];
    /// A time not after the previous one.
    CsvTimeNotIncreasing = "csv_time_not_increasing" ["time_ms", "previous_ms", "previous_line"];
    /// Keyframes closer than 10 ms.
    CsvGapTooShort = "csv_gap_too_short" ["gap_ms", "previous_line", "min_ms"];
    /// A time beyond 24 hours.
    CsvTooLate = "csv_too_late" ["time_ms"];
    /// A keyframe later than the longest show allowed.
    CsvTooLong = "csv_too_long" ["time_ms", "max_ms"];
    /// Too many rows in all.
    CsvTooManyRows = "csv_too_many_rows" ["rows", "max_rows"];
    /// Converted, the show would be over the size limit.
    CsvConvertedTooLarge = "csv_converted_too_large" ["bytes", "max_bytes"];
    // ---- Start, Reset, Home ----
    /// The playlist is empty.
    PlaylistEmpty = "playlist_empty" [];
    /// A playlist entry's show cannot be read.
    EntryUnreadable = "entry_unreadable" ["entry", "show", "reason"];
    /// A show cannot be planned or does not fit (`reason` in English; coded in the
    /// error's `reason_problem`).
    EntryInvalid = "entry_invalid" ["entry", "show", "reason"];
    /// A show the lines cannot carry (`reason` and `fixes` in English; coded in the
    /// error's `reason_problem` and `fix_problems`).
    EntryInfeasible = "entry_infeasible" ["entry", "show", "reason", "fixes"];
    /// A gateway is not connected.
    GatewayNotConnected = "gateway_not_connected" ["gateway"];
    /// The matrix is already running a playlist.
    PlayerBusy = "player_busy" [];
    /// The E-stop was pressed after the request; the matrix stays stopped.
    Superseded = "superseded" [];
    /// The player is not running (the bridge is shutting down).
    PlayerGone = "player_gone" [];
    // ---- the WebSocket and the console ----
    /// A frame that is not a valid message (`reason` is serde's, in English).
    BadMessage = "bad_message" ["reason"];
    /// A binary frame.
    BinaryFrame = "binary_frame" [];
    /// The client reads too slowly: feedback frames were dropped.
    FeedbackDropped = "feedback_dropped" ["count"];
    /// Console lines and control need the factory password changed first.
    MustChangePasswordFirst = "must_change_password_first" [];
    /// No gateway with that number.
    NoSuchGateway = "no_such_gateway" ["gateway", "last"];
    /// The console line holds no instruction or command.
    EmptyLine = "empty_line" [];
    /// The e-stop is latched: only queries may be sent.
    EstopLatched = "estop_latched" [];
    /// Too many console lines wait for the gateway.
    ConsoleBusy = "console_busy" [];
    /// A console line holds `BDR=x;`: a gateway's line speed changes only through the
    /// guided change (Commissioning → line speed), which keeps the link in step.
    ConsoleLineSpeed = "console_line_speed" ["baud"];
    /// The console line could not be sent (`reason` in English).
    LineNotSent = "line_not_sent" ["reason"];
    /// The E-stop could not reach these gateways now (`estop_sent` with `unreached`;
    /// they get it first thing when they come back).
    EstopUnreached = "estop_unreached" ["gateways"];
    /// No drive with that address on the gateway.
    NoSuchDrive = "no_such_drive" ["drive", "gateway"];
    /// A line without a drive address on a gateway with several drives.
    DriveAddressNeeded = "drive_address_needed" ["request", "gateway", "drives"];
    // ---- UIM2503 instructions (each with `line` and `column`) ----
    /// A character outside ASCII 1–127.
    AsciiNotAscii = "ascii_not_ascii" ["found"];
    /// `{` or `}`.
    AsciiBrace = "ascii_brace" ["found"];
    /// Something the grammar does not allow here.
    AsciiUnexpected = "ascii_unexpected" ["expected", "found"];
    /// A hexadecimal operand with an odd number of digits.
    AsciiOddHexDigits = "ascii_odd_hex_digits" ["instruction", "digits"];
    /// A number too large for any field.
    AsciiNumberTooLarge = "ascii_number_too_large" ["field"];
    /// A number outside its field's range.
    AsciiOutOfRange = "ascii_out_of_range" ["field", "value", "min", "max"];
    /// An index on an instruction that takes none.
    AsciiUnexpectedIndex = "ascii_unexpected_index" ["mnemonic"];
    /// An instruction that needs an index.
    AsciiMissingIndex = "ascii_missing_index" ["mnemonic"];
    /// An operand without an index.
    AsciiOperandWithoutIndex = "ascii_operand_without_index" ["mnemonic"];
    /// A missing operand.
    AsciiMissingOperand = "ascii_missing_operand" ["instruction"];
    /// More than 20 characters.
    AsciiTooLong = "ascii_too_long" ["length", "max"];
    /// An instruction that cannot be encoded (`reason` in English).
    AsciiNotEncodable = "ascii_not_encodable" ["reason"];
    // ---- SCL command lines (each with `line` and `column`) ----
    /// Not printable ASCII.
    SclNotAscii = "scl_not_ascii" ["found"];
    /// No command after the address.
    SclMissingMnemonic = "scl_missing_mnemonic" [];
    /// An unknown command.
    SclUnknownMnemonic = "scl_unknown_mnemonic" ["mnemonic"];
    /// A character that cannot be an RS-485 address.
    SclBadAddress = "scl_bad_address" ["found"];
    /// A parameter missing (`expected` in English).
    SclMissingParameter = "scl_missing_parameter" ["mnemonic", "expected"];
    /// A parameter that does not fit (`expected` in English).
    SclBadParameter = "scl_bad_parameter" ["mnemonic", "expected", "found"];
    /// A number out of range (`range` in English).
    SclOutOfRange = "scl_out_of_range" ["mnemonic", "range", "found"];
    /// Characters after a complete command.
    SclTrailing = "scl_trailing" ["mnemonic", "found"];
    /// A queue upload of the wrong length.
    SclUploadLength = "scl_upload_length" ["announced", "found"];
    /// Not a drive answer.
    SclBadAnswer = "scl_bad_answer" [];
    // ---- MBOX console (each with `line` and `column`) ----
    /// A word that is no command.
    MboxUnknownCommand = "mbox_unknown_command" ["found"];
    /// A box and no command.
    MboxMissingCommand = "mbox_missing_command" ["target"];
    /// The command needs more (`operand` in English).
    MboxMissing = "mbox_missing" ["command", "operand"];
    /// Not a register bank.
    MboxNotABank = "mbox_not_a_bank" ["found"];
    /// A bank the command cannot use (`reason` in English).
    MboxWrongBank = "mbox_wrong_bank" ["command", "bank", "reason"];
    /// Not a number.
    MboxNotANumber = "mbox_not_a_number" ["operand", "found"];
    /// A number out of range.
    MboxOutOfRange = "mbox_out_of_range" ["operand", "found"];
    /// A read of no register.
    MboxZeroCount = "mbox_zero_count" [];
    /// A register range that is refused (`reason` in English).
    MboxRange = "mbox_range" ["reason"];
    /// Something after a complete command.
    MboxTrailing = "mbox_trailing" ["command", "found"];
    /// Not an IP address.
    MboxNotAnIp = "mbox_not_an_ip" ["found"];
    /// A target that names no box.
    MboxBadTarget = "mbox_bad_target" ["found"];
    /// A last octet and no single selected box.
    MboxNoSubnet = "mbox_no_subnet" ["octet"];
    // ---- unit errors (`ER`, feedback code 0x0F), with `error` (hex) and, when the
    // unit names it, `instruction` and `index` ----
    /// 0x32: the gateway could not read the instruction.
    UnitSyntax = "unit_syntax" ["error"];
    /// 0x33: a value out of range or inconsistent.
    UnitData = "unit_data" ["error"];
    /// 0x34: an index out of range.
    UnitIndex = "unit_index" ["error"];
    /// 0x3D: not allowed while the motor moves.
    UnitWhileMoving = "unit_while_moving" ["error"];
    /// 0x3E: the motor driver is off.
    UnitMotorOff = "unit_motor_off" ["error"];
    /// 0x40: the unit cannot follow the PVT row.
    UnitOverload = "unit_overload" ["error"];
    /// 0x41: the ball reached the end of its travel.
    UnitLimit = "unit_limit" ["error"];
    /// An error number Floatball does not know.
    UnitUnknown = "unit_unknown" ["error"];
    // ---- the playlist ----
    /// The playlist's entries cannot change while a show plays or balls move.
    PlaylistLocked = "playlist_locked" [];
    /// A playlist that cannot be stored (`problems` say why).
    PlaylistInvalid = "playlist_invalid" [];
    /// More entries than allowed.
    PlaylistTooManyEntries = "playlist_too_many_entries" ["entries", "max"];
    /// A playlist entry names no stored show.
    PlaylistUnknownShow = "playlist_unknown_show" ["entry", "show"];
    /// An entry's cycles out of range.
    EntryCycles = "entry_cycles" ["entry", "cycles", "max"];
    /// An entry's delay out of range.
    EntryDelay = "entry_delay" ["entry", "delay_ms", "max_ms"];
    /// The default cycles out of range.
    DefaultCycles = "default_cycles" ["cycles", "max"];
    /// The default delay out of range.
    DefaultDelay = "default_delay" ["delay_ms", "max_ms"];
    // ---- engineering calls ----
    /// A query parameter that is wrong (`reason` in English).
    BadQuery = "bad_query" ["reason"];
    /// The show has no such ball.
    NoSuchUnit = "no_such_unit" ["name", "unit", "units"];
    /// The Q program compiler refused the show (`reason` in English).
    QprogramRefused = "qprogram_refused" ["reason"];
    /// The installation has no MBOX boxes.
    NoMboxBoxes = "no_mbox_boxes" [];
    // ---- plan verdicts (`GET /api/plan/{name}`, shown beside Start) ----
    /// A gateway's line cannot keep its units fed; their buffers run dry `dry_at_s`
    /// into the show.
    LineStarved = "line_starved" ["gateway", "baud", "units", "show", "needed_bytes_per_s", "available_bytes_per_s", "dry_at_s", "preload_rows"];
    /// [`Code::LineStarved`] when the simulation does not say when.
    LineStarvedDuring = "line_starved_during" ["gateway", "baud", "units", "show", "needed_bytes_per_s", "available_bytes_per_s", "preload_rows"];
    /// The show has more or fewer balls than the installation.
    BallCount = "ball_count" ["show_balls", "units"];
    /// A position or speed does not fit the units' 32-bit counters (`unit` says which).
    OutOfCounts = "out_of_counts" ["value_mm", "counts_per_mm"];
    /// The installation lists more or fewer units than its matrix has.
    UnitCount = "unit_count" ["listed", "expected"];
    /// Fix: a faster line is enough.
    FixFasterLine = "fix_faster_line" ["baud"];
    /// Fix: no baud rate is enough on its own.
    FixNoBaudEnough = "fix_no_baud_enough" ["max_baud"];
    /// Fix: fewer units on each gateway.
    FixFewerUnits = "fix_fewer_units" ["units_per_gateway", "baud", "gateways", "units"];
    /// Fix: longer rows.
    FixLongerRows = "fix_longer_rows" ["row_ms", "mean_row_ms"];
    /// Fix: few enough rows to load the show before it starts.
    FixFewerRows = "fix_fewer_rows" ["rows"];
    /// Fix: a larger `[scl] tolerance_mm`, or gentler moves.
    FixTolerance = "fix_tolerance" ["tolerance_mm", "deviation_mm"];
    // ---- Q programs of MOONS' drives (each with `unit`, and `time_s` when known) ----
    /// The program that fits is further off the show than the tolerance.
    QprogramTooFar = "qprogram_too_far" ["deviation_mm", "tolerance_mm"];
    /// No rest-to-rest move within the limits reaches the position in time.
    QprogramTooFast = "qprogram_too_fast" ["max_speed_mm_s", "max_accel_mm_s2"];
    /// A position out of the drive's range.
    QprogramOutOfRange = "qprogram_out_of_range" ["position_mm"];
    /// More lines than a drive holds.
    QprogramTooManyLines = "qprogram_too_many_lines" ["lines", "limit"];
    /// A `[scl]` setting that cannot be used (`must` in English).
    QprogramSetting = "qprogram_setting" ["field", "must"];
    // ---- install ----
    /// `PUT /api/installation` refused: `problems` problems, each in `problems[]`.
    InstallationInvalid = "installation_invalid" ["problems"];
    /// One problem of a new installation, as `floatball check` words it (`reason` in
    /// English).
    InstallationProblem = "installation_problem" ["reason"];
    /// A new installation or line speed is applied only while the player is idle.
    InstallationBusy = "installation_busy" ["state"];
    /// The gateways of MBOX boxes and MOONS' drives change only in `floatball.toml`
    /// and at a restart.
    InstallationNotLive = "installation_not_live" [];
    /// `floatball.toml` could not be read or written (`reason` in English).
    InstallationNotSaved = "installation_not_saved" ["reason"];
    /// A line speed a gateway does not take (`allowed`: the speeds it takes).
    BaudNotAllowed = "baud_not_allowed" ["baud", "allowed"];
    // ---- line: the gateway's line speed (`POST /api/gateways/{g}/baud`) ----
    /// A line speed `BDR=x;` does not take.
    BaudOutOfRange = "baud_out_of_range" ["baud", "min", "max"];
    /// The gateway did not answer at the new speed in time; the line is back at the old.
    BaudNotAnswering = "baud_not_answering" ["gateway", "baud", "from_baud", "waited_ms"];
    /// The serial port refused the new speed (`reason` in English).
    BaudPortRefused = "baud_port_refused" ["gateway", "baud", "reason"];
    // ---- arm ----
    /// Advice: a gateway's preload is long at its rate; a faster rate shortens it
    /// (seconds rounded up; `preload_min` with one decimal).
    PreloadLong = "preload_long" ["gateway", "baud", "preload_bytes", "preload_s", "preload_min", "faster_baud", "faster_preload_s"];
    /// Advice: a gateway's preload is long even at the fastest rate.
    PreloadLongFastest = "preload_long_fastest" ["gateway", "baud", "preload_bytes", "preload_s", "preload_min"];
    // ---- commission ----
    /// The gateway is not a UIM2503: its drives have no stations to commission.
    CommissionNotUim2503 = "commission_not_uim2503" ["gateway"];
    /// Commissioning waits until the matrix is idle (`state`: what it is doing, or
    /// `starting` while a Start is being prepared).
    CommissionNotIdle = "commission_not_idle" ["state"];
    /// Another commissioning call is using the gateway.
    CommissionInProgress = "commission_in_progress" ["gateway"];
    /// A station outside 1–127.
    CommissionBadStation = "commission_bad_station" ["station"];
    /// An identify distance that is not a positive number of mm.
    CommissionBadDistance = "commission_bad_distance" ["distance_mm"];
    /// No unit answers on the station.
    CommissionStationSilent = "commission_station_silent" ["gateway", "station"];
    /// Several units answer on the station: all of them would move.
    CommissionStationShared = "commission_station_shared" ["gateway", "station", "units"];
    /// An assignment request that assigns no unit.
    CommissionNoAssignments = "commission_no_assignments" [];
    /// The same serial twice in one assignment request.
    CommissionSerialTwice = "commission_serial_twice" ["serial"];
    /// The same station for two units in one assignment request.
    CommissionStationTwice = "commission_station_twice" ["station"];
    /// A serial too long for the gateway's 20 characters.
    CommissionSerialTooLong = "commission_serial_too_long" ["serial", "max"];
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn codes_are_unique_snake_case_and_parse_back() {
        let mut seen = std::collections::BTreeSet::new();
        for &code in Code::ALL {
            let text = code.as_str();
            assert!(seen.insert(text), "{text} twice");
            assert!(
                !text.is_empty()
                    && text
                        .chars()
                        .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_'),
                "{text} is not snake_case"
            );
            assert_eq!(Code::parse(text), Some(code));
        }
        assert_eq!(Code::parse("no_such_code"), None);
    }

    #[test]
    fn the_docs_list_every_code() {
        let docs = include_str!("../../docs/errors.md");
        for &code in Code::ALL {
            assert!(
                docs.contains(&format!("| `{code}` |")),
                "docs/errors.md does not list {code}"
            );
        }
    }

    #[test]
    fn typed_errors_carry_every_parameter_their_code_names() {
        use crate::show::{self, ShowFormat};
        let csv = "time_ms,u0\n0,0\n50,x\n";
        let refused =
            show::import("s", csv.as_bytes(), ShowFormat::Csv, None, None).expect_err("bad csv");
        let problems = refused.problems();
        assert_eq!(problems.len(), refused.details().len());
        assert_eq!(problems[0].code, "csv_not_a_number");
        assert_eq!(problems[0].params["text"], "x");
        assert_eq!(problems[0].params["line"], "3");
        let errors: Vec<Box<dyn Coded>> = vec![
            Box::new(refused),
            Box::new(crate::ascii::parse_script("PV[1]=3;").expect_err("index")),
            Box::new(crate::scl::parse_script("1ZZ").expect_err("unknown")),
            Box::new(
                crate::mbox::console::parse("dance", crate::mbox::Route::BROADCAST)
                    .expect_err("unknown"),
            ),
            Box::new(crate::feedback::UnitError {
                error: 0x32,
                code: 0,
                index: 0,
            }),
        ];
        for error in errors {
            let params = error.params();
            for name in error.code().params() {
                assert!(params.contains_key(*name), "{} lacks {name}", error.code());
            }
        }
    }
}
