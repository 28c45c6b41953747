//! The stable error codes of every refusal, validation problem and parse error the
//! bridge and the shared parsers report, and the [`Coded`] trait that gives each typed
//! error its code and parameters.
//!
//! The bridge puts the code (`snake_case`, never renamed once published) and the
//! parameters into [`crate::api::ApiError`], [`crate::api::Problem`] and
//! [`crate::api::ServerMessage::Error`] beside an English sentence for API clients;
//! the app renders the code with its parameters in the operator's language. Each
//! code's English template is written once, in the table below ([`Code::english`],
//! filled by [`english_text`]): the bridge words its errors with it and the app shows
//! it in English; the app keeps only the 中文 templates (`web/src/i18n/codes.rs`).
//! Every code is in [`Code::ALL`], so a test can check that each has a text in every
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

/// `template` with every `{name}` whose `name` is in `params` replaced by its value;
/// any other brace is kept as it is (an unknown placeholder stays visible). The rule
/// of both languages: the app fills its 中文 templates with it too.
#[must_use]
pub fn fill(template: &str, params: &Params) -> String {
    let mut text = String::with_capacity(template.len());
    let mut rest = template;
    while let Some(open) = rest.find('{') {
        text.push_str(&rest[..open]);
        let after = &rest[open + 1..];
        match after.find('}') {
            Some(close) if params.contains_key(&after[..close]) => {
                text.push_str(&params[&after[..close]]);
                rest = &after[close + 1..];
            }
            _ => {
                text.push('{');
                rest = after;
            }
        }
    }
    text.push_str(rest);
    text
}

/// The English sentence of `code` with `params`: [`Code::english`] filled by [`fill`].
/// Where the error happened (a `line` and `column`, a ball and a time) is not part of
/// it: the app puts that before the sentence.
#[must_use]
pub fn english_text(code: Code, params: &Params) -> String {
    fill(code.english(), params)
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
    ($($(#[doc = $doc:literal])* $name:ident = $code:literal [$($param:literal),*] => $english:literal;)*) => {
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

            /// The English template of this code: its sentence with `{name}` standing
            /// for a parameter, filled by [`english_text`]. The one English text of the
            /// code: the bridge's error sentences and the app's English come from it.
            #[must_use]
            pub const fn english(self) -> &'static str {
                match self {
                    $(Code::$name => $english,)*
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
    NotFound = "not_found" []
        => "There is no such API call";
    /// The API call does not take that method.
    MethodNotAllowed = "method_not_allowed" []
        => "This API call does not take that method";
    /// The request body is larger than the call accepts.
    BodyTooLarge = "body_too_large" ["limit_bytes"]
        => "The request is too large: at most {limit_bytes} bytes";
    /// The request's Content-Type is not one the call accepts.
    UnsupportedMediaType = "unsupported_media_type" []
        => "The request's Content-Type is not accepted";
    /// The request body is not the JSON the call expects.
    BadJson = "bad_json" ["what", "reason"]
        => "The body is not a valid {what}: {reason}";
    /// The framework refused the request for another reason (`status`).
    RequestRefused = "request_refused" ["status"]
        => "The controller refused the request (HTTP {status})";
    /// Something failed inside the bridge (logged there).
    Internal = "internal" ["what"]
        => "The controller failed inside: {what}";
    // ---- sessions ----
    /// The call needs a login (no token sent).
    LoginRequired = "login_required" []
        => "Log in first";
    /// The token is unknown or expired.
    SessionExpired = "session_expired" []
        => "Your login has expired; please log in again";
    /// The password is wrong.
    WrongPassword = "wrong_password" []
        => "Wrong password";
    /// Too many wrong passwords from this address; wait `retry_after_s` seconds.
    TooManyAttempts = "too_many_attempts" ["retry_after_s"]
        => "Too many failed logins; try again in {retry_after_s} s";
    /// The bridge is busy checking other passwords; wait `retry_after_s` seconds.
    LoginBusy = "login_busy" ["retry_after_s"]
        => "The controller is busy checking other passwords; try again in {retry_after_s} s";
    /// The factory password must be changed first.
    MustChangePassword = "must_change_password" []
        => "Change the factory password first";
    /// The current password given for a change is wrong.
    WrongCurrentPassword = "wrong_current_password" []
        => "The current password is wrong";
    /// The new password is shorter than `min` characters.
    PasswordTooShort = "password_too_short" ["min"]
        => "The new password is too short: at least {min} characters";
    /// The new password is longer than `max_bytes`.
    PasswordTooLong = "password_too_long" ["max_bytes"]
        => "The new password is too long: at most {max_bytes} bytes";
    /// The new password may not be the factory password (`default`).
    PasswordIsDefault = "password_is_default" ["default"]
        => "The new password must not be the factory password {default}";
    /// The page's origin may not open the WebSocket.
    OriginNotAllowed = "origin_not_allowed" []
        => "This page's origin may not connect to the controller (allowed_origins in floatball.toml)";
    // ---- shows and uploads ----
    /// The show name is not allowed (`reason` in English).
    BadShowName = "bad_show_name" ["reason"]
        => "The file name is not allowed: {reason}";
    /// There is no show of that name.
    ShowNotFound = "show_not_found" ["name"]
        => "The controller has no file \"{name}\"";
    /// A stored show no longer reads as a show (`reason` in English).
    ShowUnreadable = "show_unreadable" ["name", "reason"]
        => "The file \"{name}\" on the controller cannot be read: {reason}";
    /// The show is in the playlist and cannot be deleted.
    ShowInPlaylist = "show_in_playlist" ["name"]
        => "\"{name}\" is in the playlist; remove it from the playlist first";
    /// The upload was not received whole.
    UploadIncomplete = "upload_incomplete" []
        => "The upload was not received whole; try again";
    /// The file is not UTF-8 text (first bad byte).
    NotUtf8 = "not_utf8" ["byte"]
        => "The file is not UTF-8 text (byte {byte})";
    /// The native show file cannot be read (its problem follows in `problems`).
    ShowFileUnreadable = "show_file_unreadable" []
        => "The show file cannot be read";
    /// The CSV keyframes cannot be imported (the problem follows in `problems`).
    CsvUnreadable = "csv_unreadable" []
        => "The CSV keyframes cannot be imported";
    /// The show has no motion.
    ShowEmpty = "show_empty" []
        => "The show is empty: it has no motion";
    /// The show is longer than `[uploads] max_duration`.
    ShowTooLong = "show_too_long" ["limit_ms"]
        => "The show is longer than the limit of {limit_ms} ms";
    /// The show as stored is larger than `[uploads] max_bytes`.
    ShowTooLarge = "show_too_large" ["limit_bytes"]
        => "The show is larger than the limit of {limit_bytes} bytes";
    /// The show does not fit the installation (`count` problems follow).
    ShowUnfit = "show_unfit" ["count"]
        => "The show does not fit this installation: {count} problems";
    /// An output track names a box the installation lacks.
    OutputBox = "output_box" ["box", "boxes"]
        => "The show has outputs for box {box} but the installation has {boxes} boxes";
    /// Only the first problems are listed; `count` more follow.
    MoreProblems = "more_problems" ["count"]
        => "… and {count} more problems";
    /// A CSV show needs two keyframes, the last after 0 ms.
    CsvNeedsMotion = "csv_needs_motion" []
        => "A CSV show needs at least two keyframes, the last after 0 ms";
    /// Every ball's `rows` is empty.
    JsonNeedsMotion = "json_needs_motion" []
        => "Every ball's \"rows\" is empty";
    /// The show lasts `duration_ms`.
    ShowLasts = "show_lasts" ["duration_ms"]
        => "The show lasts {duration_ms} ms";
    /// As stored, the show takes `bytes`.
    ShowTakes = "show_takes" ["bytes"]
        => "As stored the show takes {bytes} bytes";
    // ---- validation (each violation; `unit` and `time_ms` say where, when known) ----
    /// Above the top (position below 0 mm).
    AboveTop = "above_top" ["position_mm"]
        => "position {position_mm} mm is above the top (0 mm); the ball would hit the upper limit switch";
    /// Below the travel.
    BelowTravel = "below_travel" ["position_mm", "travel_mm"]
        => "position {position_mm} mm is below the lowest point (travel {travel_mm} mm)";
    /// Too fast.
    TooFast = "too_fast" ["speed_mm_s", "limit_mm_s"]
        => "speed {speed_mm_s} mm/s exceeds the limit of {limit_mm_s} mm/s";
    /// Accelerating or braking too hard.
    TooHardAcceleration = "too_hard_acceleration" ["accel_mm_s2", "limit_mm_s2"]
        => "acceleration {accel_mm_s2} mm/s² exceeds the limit of {limit_mm_s2} mm/s²";
    /// A row outside 10–255 ms.
    RowDuration = "row_duration" ["row", "duration_ms", "min_ms", "max_ms"]
        => "row {row} of the track lasts {duration_ms} ms; a row must last {min_ms} to {max_ms} ms";
    /// A track shorter than the show.
    TrackDuration = "track_duration" ["duration_s", "show_duration_s"]
        => "the track lasts {duration_s} s but the show lasts {show_duration_s} s; every ball's track must last as long as the show";
    /// The track ends moving.
    EndsMoving = "ends_moving" ["velocity_mm_s"]
        => "the track ends moving at {velocity_mm_s} mm/s; it must end at rest (velocity 0)";
    /// Made for another grid.
    WrongLayout = "wrong_layout" ["show_rows", "show_cols", "rows", "cols"]
        => "the show is made for {show_rows} rows × {show_cols} columns but the installation has {rows} rows × {cols} columns";
    // ---- native show files ----
    /// Not valid JSON or a field wrong (`message` is serde's, in English).
    ShowInvalid = "show_invalid" ["message"]
        => "the show file is not valid: {message}";
    /// Not a Floatball show file.
    ShowWrongFormat = "show_wrong_format" ["found"]
        => "this is not a Floatball show file (\"format\" is \"{found}\")";
    /// A newer format version.
    ShowUnsupportedVersion = "show_unsupported_version" ["found", "version"]
        => "the show file is format version {found}, but this Floatball reads version {version}; update Floatball";
    /// A layout without balls or pitch.
    ShowEmptyLayout = "show_empty_layout" []
        => "the layout needs at least one row and one column and a positive pitch_mm";
    /// Tracks differ from rows × cols.
    ShowTrackCount = "show_track_count" ["tracks", "rows", "cols"]
        => "the show has {tracks} tracks but its layout is {rows} × {cols}";
    /// A position or velocity is not finite.
    ShowNotFinite = "show_not_finite" ["track"]
        => "track {track}: a position or velocity is not a finite number";
    /// An output track that cannot be played (`detail` in English).
    ShowOutput = "show_output" ["box", "detail"]
        => "the outputs of box {box} cannot be played: {detail}";
    /// Colour keyframes out of order.
    ShowColourOrder = "show_colour_order" ["track", "index"]
        => "track {track}: colour keyframe {index} is not later than the one before";
    // ---- CSV keyframes (each with `line` and `column`) ----
    /// Nothing but blank lines.
    CsvEmpty = "csv_empty" []
        => "the file is empty; it must start with a header line \"time_ms,u0,u1,…\"";
    /// No header after the layout line.
    CsvNoHeader = "csv_no_header" []
        => "the header line \"time_ms,u0,u1,…\" is missing after the layout line";
    /// A `#` line not first.
    CsvMisplacedComment = "csv_misplaced_comment" []
        => "a line starting with # is only allowed first, as the layout \"# rows=R cols=C pitch_mm=P\"";
    /// A word on the layout line not understood.
    CsvLayoutWord = "csv_layout_word" ["text"]
        => "\"{text}\" is not understood; the layout line reads \"# rows=R cols=C pitch_mm=P\"";
    /// A bad value on the layout line.
    CsvLayoutValue = "csv_layout_value" ["key", "text"]
        => "{key} has an invalid value \"{text}\"";
    /// A key missing from the layout line.
    CsvLayoutMissing = "csv_layout_missing" ["key"]
        => "the layout line has no {key}=…";
    /// A wrong header column name.
    CsvHeaderName = "csv_header_name" ["found", "expected"]
        => "the header column is \"{found}\" but must be \"{expected}\"";
    /// The header names no balls.
    CsvNoUnits = "csv_no_units" []
        => "the header names no balls; it must be \"time_ms,u0,u1,…\"";
    /// Ball columns differ from the layout's balls.
    CsvLayoutMismatch = "csv_layout_mismatch" ["units", "rows", "cols"]
        => "the file has {units} ball columns but the layout is {rows} rows × {cols} columns";
    /// A line with the wrong number of fields.
    CsvFieldCount = "csv_field_count" ["found", "expected"]
        => "this line has {found} fields but the header has {expected}";
    /// A field that is not a number.
    CsvNotANumber = "csv_not_a_number" ["text"]
        => "\"{text}\" is not a number";
    /// No keyframes after the header.
    CsvNoKeyframes = "csv_no_keyframes" []
        => "there are no keyframes after the header";
    /// The first keyframe is not at 0.
    CsvFirstTimeNotZero = "csv_first_time_not_zero" ["time_ms"]
        => "the first keyframe is at {time_ms} ms; it must be at 0";
    /// A time not after the previous one.
    CsvTimeNotIncreasing = "csv_time_not_increasing" ["time_ms", "previous_ms", "previous_line"]
        => "time {time_ms} ms is not after {previous_ms} ms on line {previous_line}";
    /// Keyframes closer than 10 ms.
    CsvGapTooShort = "csv_gap_too_short" ["gap_ms", "previous_line", "min_ms"]
        => "this keyframe is only {gap_ms} ms after the one on line {previous_line}; keyframes must be at least {min_ms} ms apart";
    /// A time beyond 24 hours.
    CsvTooLate = "csv_too_late" ["time_ms"]
        => "time {time_ms} ms is later than the longest show accepted (24 hours)";
    /// A keyframe later than the longest show allowed.
    CsvTooLong = "csv_too_long" ["time_ms", "max_ms"]
        => "time {time_ms} ms is later than the longest show accepted here ({max_ms} ms)";
    /// Too many rows in all.
    CsvTooManyRows = "csv_too_many_rows" ["rows", "max_rows"]
        => "the show would have {rows} rows in all, more than {max_rows}; use fewer balls or a shorter show";
    /// Converted, the show would be over the size limit.
    CsvConvertedTooLarge = "csv_converted_too_large" ["bytes", "max_bytes"]
        => "converted the show would take {bytes} bytes, more than the limit of {max_bytes} bytes";
    // ---- Start, Reset, Home ----
    /// The playlist is empty.
    PlaylistEmpty = "playlist_empty" []
        => "The playlist is empty: add a show first";
    /// A playlist entry's show cannot be read.
    EntryUnreadable = "entry_unreadable" ["entry", "show", "reason"]
        => "Playlist entry {entry} (\"{show}\") cannot be read: {reason}";
    /// A show cannot be planned or does not fit (`reason` in English; coded in the
    /// error's `reason_problem`).
    EntryInvalid = "entry_invalid" ["entry", "show", "reason"]
        => "Entry {entry} (\"{show}\") cannot run: {reason}";
    /// A show the lines cannot carry (`reason` and `fixes` in English; coded in the
    /// error's `reason_problem` and `fix_problems`).
    EntryInfeasible = "entry_infeasible" ["entry", "show", "reason", "fixes"]
        => "Entry {entry} (\"{show}\") cannot run: {reason}. To make it run: {fixes}";
    /// A gateway is not connected.
    GatewayNotConnected = "gateway_not_connected" ["gateway"]
        => "Gateway {gateway} is not connected";
    /// The matrix is already running a playlist.
    PlayerBusy = "player_busy" []
        => "The matrix is already running a playlist; press E-stop or Reset first";
    /// A start at an entry the playlist lacks.
    StartNoSuchEntry = "start_no_such_entry" ["entry", "entries"]
        => "There is no entry {entry}: the playlist has {entries} entries";
    /// A start at a time at or after the end of the entry's show.
    StartPastTheEnd = "start_past_the_end" ["entry", "time_ms", "duration_ms"]
        => "Entry {entry} cannot start at {time_ms} ms: its show ends at {duration_ms} ms";
    /// A start from a time on drives that play their stored programs.
    StartNoCut = "start_no_cut" ["entry"]
        => "Entry {entry} cannot start from a time: the drives play the programs stored on them; start it from its beginning, or let the bridge upload programs";
    /// Live mode on a drive family that does not carry it (yet).
    LiveUnsupported = "live_unsupported" ["family"]
        => "Live mode is not available on {family}";
    /// Live mode on a UIM2503 line too slow for a row of its units.
    LiveLineTooSlow = "live_line_too_slow" ["gateway", "units", "row_ms", "max_ms"]
        => "Live mode: gateway {gateway}'s line needs {row_ms} ms for a row of its {units} units, more than the {max_ms} ms a row may last";
    /// A recording asked for while the balls do not follow live input.
    RecordNotLive = "record_not_live" []
        => "Recording needs live mode with the balls following the input";
    /// A recording whose step is no row duration.
    RecordStep = "record_step" ["dt_ms", "min_ms", "max_ms"]
        => "A live period of {dt_ms} ms cannot be recorded: rows last {min_ms}-{max_ms} ms";
    /// Live mode asked for while the E-stop is latched: only an operator's Start,
    /// Reset or Home releases it, going live does not.
    LiveEstopLatched = "live_estop_latched" []
        => "Live mode cannot start while the E-stop is latched: press Start, Reset or Home first (going live does not release the E-stop)";
    /// Live mode asked for while live input is off (`[live] enabled = false`).
    LiveOff = "live_off" []
        => "Live input is off: set enabled = true in the [live] section of the configuration";
    /// A recording named as a show already in the store.
    RecordNameTaken = "record_name_taken" ["name"]
        => "A show named \"{name}\" exists already: choose another name for the recording";
    /// Stop recording while no recording is under way (or an E-stop dropped it).
    RecordNothing = "record_nothing" []
        => "No recording is under way (an E-stop drops one)";
    /// The E-stop was pressed after the request; the matrix stays stopped.
    Superseded = "superseded" []
        => "The E-stop was pressed after this request; the matrix stays stopped";
    /// The player is not running (the bridge is shutting down).
    PlayerGone = "player_gone" []
        => "The player is not running (the controller is shutting down)";
    // ---- the WebSocket and the console ----
    /// A frame that is not a valid message (`reason` is serde's, in English).
    BadMessage = "bad_message" ["reason"]
        => "The controller did not understand the message: {reason}";
    /// A binary frame.
    BinaryFrame = "binary_frame" []
        => "Only text frames holding JSON messages are understood";
    /// The client reads too slowly: feedback frames were dropped.
    FeedbackDropped = "feedback_dropped" ["count"]
        => "{count} feedback frames were dropped: this device reads too slowly";
    /// Console lines and control need the factory password changed first.
    MustChangePasswordFirst = "must_change_password_first" []
        => "Change the factory password (1234) before controlling the matrix or sending instructions";
    /// No gateway with that number.
    NoSuchGateway = "no_such_gateway" ["gateway", "last"]
        => "There is no gateway {gateway}; gateways are numbered 0 to {last}";
    /// The console line holds no instruction or command.
    EmptyLine = "empty_line" []
        => "The line holds no instruction";
    /// The e-stop is latched: only queries may be sent.
    EstopLatched = "estop_latched" []
        => "The E-stop is latched: only queries can be sent until Start, Reset or Home; this line was not sent";
    /// Too many console lines wait for the gateway.
    ConsoleBusy = "console_busy" []
        => "Too many console lines are waiting for the gateway; this one was not sent";
    /// A console line holds `BDR=x;`: a gateway's line speed changes only through the
    /// guided change (Commissioning → line speed), which keeps the link in step.
    ConsoleLineSpeed = "console_line_speed" ["baud"]
        => "The console cannot set the line speed (BDR={baud}): change it in Commissioning → Line speed, which keeps the bridge in step with the gateway; this line was not sent";
    /// The console line could not be sent (`reason` in English).
    LineNotSent = "line_not_sent" ["reason"]
        => "The line was not sent: {reason}";
    /// The E-stop could not reach these gateways now (`estop_sent` with `unreached`;
    /// they get it first thing when they come back).
    EstopUnreached = "estop_unreached" ["gateways"]
        => "The E-stop did not reach: {gateways} (it is sent first thing when they come back)";
    /// No drive with that address on the gateway.
    NoSuchDrive = "no_such_drive" ["drive", "gateway"]
        => "There is no drive {drive} on gateway {gateway}";
    /// A line without a drive address on a gateway with several drives.
    DriveAddressNeeded = "drive_address_needed" ["request", "gateway", "drives"]
        => "{request}: put the drive's address first (gateway {gateway} has {drives} drives)";
    // ---- UIM2503 instructions (each with `line` and `column`) ----
    /// A character outside ASCII 1–127.
    AsciiNotAscii = "ascii_not_ascii" ["found"]
        => "{found} is outside ASCII 1–127, the only characters the gateway accepts";
    /// `{` or `}`.
    AsciiBrace = "ascii_brace" ["found"]
        => "`{found}` is forbidden in instructions (manual §6.1)";
    /// Something the grammar does not allow here.
    AsciiUnexpected = "ascii_unexpected" ["expected", "found"]
        => "expected {expected}, found {found}";
    /// A hexadecimal operand with an odd number of digits.
    AsciiOddHexDigits = "ascii_odd_hex_digits" ["instruction", "digits"]
        => "the hexadecimal operand of {instruction} has {digits} digits; it needs an even number (`0A`, not `A`)";
    /// A number too large for any field.
    AsciiNumberTooLarge = "ascii_number_too_large" ["field"]
        => "{field} is too large";
    /// A number outside its field's range.
    AsciiOutOfRange = "ascii_out_of_range" ["field", "value", "min", "max"]
        => "{field} must be {min}–{max}, found {value}";
    /// An index on an instruction that takes none.
    AsciiUnexpectedIndex = "ascii_unexpected_index" ["mnemonic"]
        => "{mnemonic} takes no index";
    /// An instruction that needs an index.
    AsciiMissingIndex = "ascii_missing_index" ["mnemonic"]
        => "{mnemonic} needs an index: `{mnemonic}[X]`";
    /// An operand without an index.
    AsciiOperandWithoutIndex = "ascii_operand_without_index" ["mnemonic"]
        => "{mnemonic} takes an operand only with an index: `{mnemonic}[X]=…;`";
    /// A missing operand.
    AsciiMissingOperand = "ascii_missing_operand" ["instruction"]
        => "{instruction} needs an operand";
    /// More than 20 characters.
    AsciiTooLong = "ascii_too_long" ["length", "max"]
        => "this instruction is {length} characters including `;`; the gateway accepts at most {max}";
    /// An instruction that cannot be encoded (`reason` in English).
    AsciiNotEncodable = "ascii_not_encodable" ["reason"]
        => "The instruction cannot be sent: {reason}";
    // ---- SCL command lines (each with `line` and `column`) ----
    /// Not printable ASCII.
    SclNotAscii = "scl_not_ascii" ["found"]
        => "{found} is not printable ASCII; SCL is plain ASCII text";
    /// No command after the address.
    SclMissingMnemonic = "scl_missing_mnemonic" []
        => "expected a command (two capital letters, such as FL or DI) after the address";
    /// An unknown command.
    SclUnknownMnemonic = "scl_unknown_mnemonic" ["mnemonic"]
        => "unknown command {mnemonic}; mnemonics are upper case (FL, FP, FS, DI, VE, AC, DE, …)";
    /// A character that cannot be an RS-485 address.
    SclBadAddress = "scl_bad_address" ["found"]
        => "{found} cannot be an RS-485 address: an address is a digit or one of \" # $ & ' ( ) + , - . / : ; < = >";
    /// A parameter missing (`expected` in English).
    SclMissingParameter = "scl_missing_parameter" ["mnemonic", "expected"]
        => "{mnemonic} needs {expected} here";
    /// A parameter that does not fit (`expected` in English).
    SclBadParameter = "scl_bad_parameter" ["mnemonic", "expected", "found"]
        => "{mnemonic}: expected {expected}, found \"{found}\"";
    /// A number out of range (`range` in English).
    SclOutOfRange = "scl_out_of_range" ["mnemonic", "range", "found"]
        => "{mnemonic}: {found} is out of range ({range})";
    /// Characters after a complete command.
    SclTrailing = "scl_trailing" ["mnemonic", "found"]
        => "unexpected \"{found}\" after a complete {mnemonic} command";
    /// A queue upload of the wrong length.
    SclUploadLength = "scl_upload_length" ["announced", "found"]
        => "queue upload: the header announces {announced} lines, {found} follow";
    /// Not a drive answer.
    SclBadAnswer = "scl_bad_answer" []
        => "not a drive answer: expected %, *, ? (with its code) or a reply such as IP=1000";
    // ---- MBOX console (each with `line` and `column`) ----
    /// A word that is no command.
    MboxUnknownCommand = "mbox_unknown_command" ["found"]
        => "unknown command `{found}`: the console knows read, write, save, estop, release, reset, effects and ip";
    /// A box and no command.
    MboxMissingCommand = "mbox_missing_command" ["target"]
        => "expected a command after `{target}`: read, write, save, estop, release, reset, effects or ip";
    /// The command needs more (`operand` in English).
    MboxMissing = "mbox_missing" ["command", "operand"]
        => "`{command}` needs {operand} here";
    /// Not a register bank.
    MboxNotABank = "mbox_not_a_bank" ["found"]
        => "expected a register bank FN, DN or CX, found `{found}`";
    /// A bank the command cannot use (`reason` in English).
    MboxWrongBank = "mbox_wrong_bank" ["command", "bank", "reason"]
        => "`{command}` does not take {bank}: {reason}";
    /// Not a number.
    MboxNotANumber = "mbox_not_a_number" ["operand", "found"]
        => "expected {operand} as a number (decimal or 0x hex), found `{found}`";
    /// A number out of range.
    MboxOutOfRange = "mbox_out_of_range" ["operand", "found"]
        => "{operand} `{found}` is out of range";
    /// A read of no register.
    MboxZeroCount = "mbox_zero_count" []
        => "count 0: read at least one register";
    /// A register range that is refused (`reason` in English).
    MboxRange = "mbox_range" ["reason"]
        => "the register range is refused: {reason}";
    /// Something after a complete command.
    MboxTrailing = "mbox_trailing" ["command", "found"]
        => "unexpected `{found}`: `{command}` is complete without it (commands are separated by a new line or `;`)";
    /// Not an IP address.
    MboxNotAnIp = "mbox_not_an_ip" ["found"]
        => "expected an IP address such as 192.168.15.210, found `{found}`";
    /// A target that names no box.
    MboxBadTarget = "mbox_bad_target" ["found"]
        => "expected a box after `@`: all, a last octet such as 201, two octets such as 15.201 or an IP address; found `{found}`";
    /// A last octet and no single selected box.
    MboxNoSubnet = "mbox_no_subnet" ["octet"]
        => "`@{octet}` gives the last octet only, and the selected box is not one box: give two octets, such as @15.{octet}";
    // ---- unit errors (`ER`, feedback code 0x0F), with `error` (hex) and, when the
    // unit names it, `instruction` and `index` ----
    /// 0x32: the gateway could not read the instruction.
    UnitSyntax = "unit_syntax" ["error"]
        => "the gateway could not read the instruction (error {error})";
    /// 0x33: a value out of range or inconsistent.
    UnitData = "unit_data" ["error"]
        => "value out of range or inconsistent (error {error})";
    /// 0x34: an index out of range.
    UnitIndex = "unit_index" ["error"]
        => "index out of range (error {error})";
    /// 0x3D: not allowed while the motor moves.
    UnitWhileMoving = "unit_while_moving" ["error"]
        => "not allowed while the motor moves (error {error})";
    /// 0x3E: the motor driver is off.
    UnitMotorOff = "unit_motor_off" ["error"]
        => "the motor driver is off (error {error})";
    /// 0x40: the unit cannot follow the PVT row.
    UnitOverload = "unit_overload" ["error"]
        => "the unit cannot follow the PVT row (speed or acceleration) (error {error})";
    /// 0x41: the ball reached the end of its travel.
    UnitLimit = "unit_limit" ["error"]
        => "the ball reached the end of its travel (error {error})";
    /// An error number Floatball does not know.
    UnitUnknown = "unit_unknown" ["error"]
        => "unknown error (error {error})";
    // ---- the playlist ----
    /// The playlist's entries cannot change while a show plays or balls move.
    PlaylistLocked = "playlist_locked" []
        => "The playlist's entries cannot change while a show plays or balls move";
    /// A playlist that cannot be stored (`problems` say why).
    PlaylistInvalid = "playlist_invalid" []
        => "The playlist is not valid";
    /// More entries than allowed.
    PlaylistTooManyEntries = "playlist_too_many_entries" ["entries", "max"]
        => "the playlist has {entries} entries; at most {max} are allowed";
    /// A playlist entry names no stored show.
    PlaylistUnknownShow = "playlist_unknown_show" ["entry", "show"]
        => "entry {entry}: there is no show named \"{show}\"";
    /// An entry's cycles out of range.
    EntryCycles = "entry_cycles" ["entry", "cycles", "max"]
        => "entry {entry}: cycles is {cycles}; it must be from 1 to {max}";
    /// An entry's delay out of range.
    EntryDelay = "entry_delay" ["entry", "delay_ms", "max_ms"]
        => "entry {entry}: delay_ms is {delay_ms}; it must be at most {max_ms} (one day)";
    /// The default cycles out of range.
    DefaultCycles = "default_cycles" ["cycles", "max"]
        => "default_cycles is {cycles}; it must be from 1 to {max}";
    /// The default delay out of range.
    DefaultDelay = "default_delay" ["delay_ms", "max_ms"]
        => "default_delay_ms is {delay_ms}; it must be at most {max_ms} (one day)";
    /// An entry's timecode start is not a timecode.
    EntryTimecode = "entry_timecode" ["entry", "timecode"]
        => "entry {entry}: timecode_start \"{timecode}\" is not a timecode such as 10:00:00:00 (HH:MM:SS:FF)";
    // ---- engineering calls ----
    /// A query parameter that is wrong (`reason` in English).
    BadQuery = "bad_query" ["reason"]
        => "Bad query: {reason}";
    /// The show has no such ball.
    NoSuchUnit = "no_such_unit" ["name", "unit", "units"]
        => "The show \"{name}\" has {units} balls: no unit {unit} (the first is 0)";
    /// The Q program compiler refused the show (`reason` in English).
    QprogramRefused = "qprogram_refused" ["reason"]
        => "The Q program cannot be compiled: {reason}";
    /// The installation has no MBOX boxes.
    NoMboxBoxes = "no_mbox_boxes" []
        => "This installation has no MBOX boxes";
    // ---- plan verdicts (`GET /api/plan/{name}`, shown beside Start) ----
    /// A gateway's line cannot keep its units fed; their buffers run dry `dry_at_s`
    /// into the show.
    LineStarved = "line_starved" ["gateway", "baud", "units", "show", "needed_bytes_per_s", "available_bytes_per_s", "dry_at_s", "preload_rows"]
        => "gateway {gateway} ({baud} baud) cannot keep its {units} units fed: \"{show}\" streams {needed_bytes_per_s} B/s while the line carries {available_bytes_per_s} B/s, so the units' row buffers run dry {dry_at_s} s into the show even with a full {preload_rows}-row preload";
    /// [`Code::LineStarved`] when the simulation does not say when.
    LineStarvedDuring = "line_starved_during" ["gateway", "baud", "units", "show", "needed_bytes_per_s", "available_bytes_per_s", "preload_rows"]
        => "gateway {gateway} ({baud} baud) cannot keep its {units} units fed: \"{show}\" streams {needed_bytes_per_s} B/s while the line carries {available_bytes_per_s} B/s, so the units' row buffers run dry during the show even with a full {preload_rows}-row preload";
    /// The show has more or fewer balls than the installation.
    BallCount = "ball_count" ["show_balls", "units"]
        => "the show has {show_balls} balls but the installation has {units}";
    /// A position or speed does not fit the units' 32-bit counters (`unit` says which).
    OutOfCounts = "out_of_counts" ["value_mm", "counts_per_mm"]
        => "{value_mm} mm does not fit in counts at {counts_per_mm} counts/mm";
    /// The installation lists more or fewer units than its matrix has.
    UnitCount = "unit_count" ["listed", "expected"]
        => "the installation lists {listed} units for a matrix of {expected}";
    /// Fix: a faster line is enough.
    FixFasterLine = "fix_faster_line" ["baud"]
        => "raise the line to {baud} baud (Commissioning → Line speed)";
    /// Fix: no baud rate is enough on its own.
    FixNoBaudEnough = "fix_no_baud_enough" ["max_baud"]
        => "no baud rate up to {max_baud} is enough on its own";
    /// Fix: fewer units on each gateway.
    FixFewerUnits = "fix_fewer_units" ["units_per_gateway", "baud", "gateways", "units"]
        => "put at most {units_per_gateway} of these units on each gateway at {baud} baud ({gateways} gateways for these {units})";
    /// Fix: longer rows.
    FixLongerRows = "fix_longer_rows" ["row_ms", "mean_row_ms"]
        => "use rows of at least {row_ms} ms (this show's rows last {mean_row_ms} ms on average)";
    /// Fix: few enough rows to load the show before it starts.
    FixFewerRows = "fix_fewer_rows" ["rows"]
        => "or shorten the show to at most {rows} rows per ball so it loads completely before it starts";
    /// Fix: a larger `[scl] tolerance_mm`, or gentler moves.
    FixTolerance = "fix_tolerance" ["tolerance_mm", "deviation_mm"]
        => "raise [scl] tolerance_mm to {tolerance_mm} mm or more (the largest deviation of any ball is {deviation_mm} mm), or give the show fewer, gentler moves";
    // ---- Q programs of MOONS' drives (each with `unit`, and `time_s` when known) ----
    /// The program that fits is further off the show than the tolerance.
    QprogramTooFar = "qprogram_too_far" ["deviation_mm", "tolerance_mm"]
        => "the program would be {deviation_mm} mm off the show, more than the tolerance of {tolerance_mm} mm (the show has too many moves for a drive's 12 segments of 62 lines, or moves that a rest-to-rest move cannot follow closely)";
    /// No rest-to-rest move within the limits reaches the position in time.
    QprogramTooFast = "qprogram_too_fast" ["max_speed_mm_s", "max_accel_mm_s2"]
        => "the ball cannot be at its position: a move from rest to rest would need more than {max_speed_mm_s} mm/s or {max_accel_mm_s2} mm/s²";
    /// A position out of the drive's range.
    QprogramOutOfRange = "qprogram_out_of_range" ["position_mm"]
        => "the position {position_mm} mm is out of the drive's range";
    /// More lines than a drive holds.
    QprogramTooManyLines = "qprogram_too_many_lines" ["lines", "limit"]
        => "the program needs {lines} lines, more than a drive's {limit}";
    /// A `[scl]` setting that cannot be used (`must` in English).
    QprogramSetting = "qprogram_setting" ["field", "must"]
        => "the Q program setting {field} must be {must}";
    // ---- install ----
    /// `PUT /api/installation` refused: `problems` problems, each in `problems[]`.
    InstallationInvalid = "installation_invalid" ["problems"]
        => "The installation has {problems} problem(s) and was not saved";
    /// One problem of a new installation, as `floatball check` words it (`reason` in
    /// English).
    InstallationProblem = "installation_problem" ["reason"]
        => "Installation: {reason}";
    /// A new installation or line speed is applied only while the player is idle.
    InstallationBusy = "installation_busy" ["state"]
        => "The matrix is {state}: the installation and line speeds change only while it is idle";
    /// The gateways of MBOX boxes and MOONS' drives change only in `floatball.toml`
    /// and at a restart.
    InstallationNotLive = "installation_not_live" []
        => "The gateways of MBOX boxes and MOONS' drives change only in floatball.toml, at a restart";
    /// `floatball.toml` could not be read or written (`reason` in English).
    InstallationNotSaved = "installation_not_saved" ["reason"]
        => "floatball.toml could not be saved: {reason}";
    /// A line speed a gateway does not take (`allowed`: the speeds it takes).
    BaudNotAllowed = "baud_not_allowed" ["baud", "allowed"]
        => "The gateway does not take {baud} baud; it takes {allowed}";
    // ---- line: the gateway's line speed (`POST /api/gateways/{g}/baud`) ----
    /// A line speed `BDR=x;` does not take.
    BaudOutOfRange = "baud_out_of_range" ["baud", "min", "max"]
        => "{baud} baud is not a line speed the gateway takes ({min}–{max})";
    /// The gateway did not answer at the new speed in time; the line is back at the old.
    BaudNotAnswering = "baud_not_answering" ["gateway", "baud", "from_baud", "waited_ms"]
        => "Gateway {gateway} did not answer at {baud} baud within {waited_ms} ms; the line is back at {from_baud} baud";
    /// The serial port refused the new speed (`reason` in English).
    BaudPortRefused = "baud_port_refused" ["gateway", "baud", "reason"]
        => "The port of gateway {gateway} cannot run at {baud} baud: {reason}";
    // ---- arm ----
    /// Advice: a gateway's preload is long at its rate; a faster rate shortens it
    /// (seconds rounded up; `preload_min` with one decimal).
    PreloadLong = "preload_long" ["gateway", "baud", "preload_bytes", "preload_s", "preload_min", "faster_baud", "faster_preload_s"]
        => "gateway {gateway} preloads {preload_bytes} bytes in {preload_s} s ({preload_min} min) at {baud} baud before the show can start; at {faster_baud} baud it takes {faster_preload_s} s (change the line speed to {faster_baud} in Commissioning → Line speed)";
    /// Advice: a gateway's preload is long even at the fastest rate.
    PreloadLongFastest = "preload_long_fastest" ["gateway", "baud", "preload_bytes", "preload_s", "preload_min"]
        => "gateway {gateway} preloads {preload_bytes} bytes in {preload_s} s ({preload_min} min) at {baud} baud before the show can start, even at the fastest rate; as the playlist's first entry it is loaded while the matrix is idle";
    // ---- commission ----
    /// The gateway is not a UIM2503: its drives have no stations to commission.
    CommissionNotUim2503 = "commission_not_uim2503" ["gateway"]
        => "Gateway {gateway} is not a UIM2503 gateway; only UFQ750 units are commissioned";
    /// Commissioning waits until the matrix is idle (`state`: what it is doing, or
    /// `starting` while a Start is being prepared).
    CommissionNotIdle = "commission_not_idle" ["state"]
        => "The matrix is {state}: commissioning waits until it is idle";
    /// Another commissioning call is using the gateway.
    CommissionInProgress = "commission_in_progress" ["gateway"]
        => "Another commissioning call is using gateway {gateway}; try again when it is done";
    /// A station outside 1–127.
    CommissionBadStation = "commission_bad_station" ["station"]
        => "Station {station} is not a unit's station; stations are 1–127";
    /// An identify distance that is not a positive number of mm.
    CommissionBadDistance = "commission_bad_distance" ["distance_mm"]
        => "The identify distance must be a positive number of mm, found {distance_mm}";
    /// No unit answers on the station.
    CommissionStationSilent = "commission_station_silent" ["gateway", "station"]
        => "No unit answers on station {station} of gateway {gateway}";
    /// Several units answer on the station: all of them would move.
    CommissionStationShared = "commission_station_shared" ["gateway", "station", "units"]
        => "{units} units answer on station {station} of gateway {gateway}; give them their own stations first";
    /// An assignment request that assigns no unit.
    CommissionNoAssignments = "commission_no_assignments" []
        => "The request assigns no unit";
    /// The same serial twice in one assignment request.
    CommissionSerialTwice = "commission_serial_twice" ["serial"]
        => "Serial {serial} is assigned twice";
    /// The same station for two units in one assignment request.
    CommissionStationTwice = "commission_station_twice" ["station"]
        => "Station {station} is given to two units";
    /// A serial too long for the gateway's 20 characters.
    CommissionSerialTooLong = "commission_serial_too_long" ["serial", "max"]
        => "Serial {serial} is too long: `SN[X]=s/n;` holds at most {max} characters";
    // ---- live input: the patch ----
    /// The patch has another number of balls than the installation.
    PatchBallCount = "patch_ball_count" ["patched", "balls"]
        => "The patch has {patched} balls; the installation has {balls}";
    /// A ball's universe outside 1–63999.
    PatchUniverse = "patch_universe" ["ball", "universe", "max"]
        => "Ball {ball}: universe {universe} is outside 1–{max}";
    /// A ball's start address outside 1–512.
    PatchAddress = "patch_address" ["ball", "address"]
        => "Ball {ball}: address {address} is outside 1–512";
    /// A ball's channels pass slot 512.
    PatchFootprint = "patch_footprint" ["ball", "address", "footprint"]
        => "Ball {ball}: {footprint} channels from address {address} pass slot 512";
    /// Two balls share slots.
    PatchOverlap = "patch_overlap" ["ball", "other", "universe", "address"]
        => "Ball {ball} and ball {other} share slots in universe {universe} from address {address}";
    /// A speed-limit channel of neither 8 nor 16 bits.
    PatchSpeedBits = "patch_speed_bits" ["ball", "bits"]
        => "Ball {ball}: a speed limit of {bits} bits; 8 or 16 expected";
    // ---- the schedule (issue 37, item 2) ----
    /// A schedule that cannot be stored (`problems` say why).
    ScheduleInvalid = "schedule_invalid" []
        => "The schedule is not valid";
    /// The schedule's time zone is not known.
    ScheduleUnknownTimeZone = "schedule_unknown_time_zone" ["zone"]
        => "unknown time zone \"{zone}\": give an IANA name such as Europe/Zurich, Asia/Shanghai or UTC";
    /// A window whose end is not after its start (a window never crosses midnight).
    ScheduleEndNotAfterStart = "schedule_end_not_after_start" ["day", "window", "start", "end"]
        => "{day}, window {window}: it ends at {end}, not after its start {start}";
    /// Two windows of a day overlap.
    ScheduleWindowsOverlap = "schedule_windows_overlap" ["day", "first", "second"]
        => "{day}: windows {first} and {second} overlap";
    /// An every-N program's N out of range.
    ScheduleEveryOutOfRange = "schedule_every_out_of_range" ["day", "window", "minutes", "min", "max"]
        => "{day}, window {window}: every {minutes} minutes is out of range ({min}–{max})";
    /// Too many windows on a day.
    ScheduleTooManyWindows = "schedule_too_many_windows" ["day", "windows", "max"]
        => "{day} has {windows} windows; at most {max} are allowed";
    /// Too many exceptions.
    ScheduleTooManyExceptions = "schedule_too_many_exceptions" ["exceptions", "max"]
        => "the schedule has {exceptions} exceptions; at most {max} are allowed";
    /// Two exceptions for one date.
    ScheduleExceptionTwice = "schedule_exception_twice" ["date"]
        => "{date} has two exceptions";
    /// The scheduler started a loop program.
    ScheduleStartedLoop = "schedule_started_loop" []
        => "Started the playlist, over and over until the window ends";
    /// The scheduler started an every-N program's slot.
    ScheduleStartedEvery = "schedule_started_every" ["minutes"]
        => "Started the playlist once (every {minutes} minutes)";
    /// The scheduler did not start: the matrix was not idle.
    ScheduleNotIdle = "schedule_not_idle" ["state"]
        => "Did not start: the matrix is {state}, not idle";
    /// The scheduler did not start: the matrix is in error.
    ScheduleInError = "schedule_in_error" ["error"]
        => "Did not start: the matrix is in error ({error}); only an operator clears it";
    /// The scheduler did not start: the e-stop is latched.
    ScheduleEstopLatched = "schedule_estop_latched" []
        => "Did not start: the e-stop is latched; only an operator in the app releases it";
    /// The scheduler did not start: a link is not up.
    ScheduleLinkDown = "schedule_link_down" ["gateway", "link"]
        => "Did not start: the link of gateway {gateway} is {link}";
    /// The scheduler did not start: units are missing.
    ScheduleUnitsMissing = "schedule_units_missing" ["gateway", "stations"]
        => "Did not start: units missing on gateway {gateway} (stations {stations})";
    /// The scheduler did not start: the player refused the Start.
    ScheduleStartRefused = "schedule_start_refused" ["reason"]
        => "Did not start: {reason}";
    /// A window ended: home, then motors off.
    ScheduleEnded = "schedule_ended" []
        => "The window ended: the balls went home and the motors are off";
    /// A window ended on a family the bridge cannot switch the motors off on.
    ScheduleEndedMotorsOn = "schedule_ended_motors_on" []
        => "The window ended: the balls went home (the motors stay on: this family has no motors-off the bridge can send)";
    /// A window's end could not home: the e-stop is latched.
    ScheduleEndLatched = "schedule_end_latched" []
        => "The window ended, but the balls did not go home: the e-stop is latched";
    /// A window's end could not home for another reason.
    ScheduleEndRefused = "schedule_end_refused" ["reason"]
        => "The window ended, but the balls did not go home: {reason}";
    /// `PUT /api/live/patch` refused: `problems` problems, each in `problems[]`.
    PatchInvalid = "patch_invalid" ["problems"]
        => "The patch has {problems} problem(s) and was not saved";
    /// The patch changes only while the player is idle (`state`: what it is doing).
    PatchBusy = "patch_busy" ["state"]
        => "The matrix is {state}: the patch changes only while it is idle";
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
    fn every_code_has_an_english_template_naming_only_its_parameters() {
        for &code in Code::ALL {
            let english = code.english();
            assert!(!english.trim().is_empty(), "{code} has no English text");
            for name in code.params() {
                assert!(
                    english.contains(&format!("{{{name}}}")),
                    "{code}: English lacks {{{name}}}"
                );
            }
            for name in placeholders(english) {
                assert!(
                    code.params().contains(&name),
                    "{code}: unknown parameter {{{name}}}"
                );
            }
        }
    }

    /// The names of a template's `{name}` placeholders.
    fn placeholders(template: &str) -> Vec<&str> {
        let mut names = Vec::new();
        let mut rest = template;
        while let Some(open) = rest.find('{') {
            let after = &rest[open + 1..];
            let close = after.find('}').unwrap_or(after.len());
            names.push(&after[..close]);
            rest = &after[close.min(after.len())..];
        }
        names
    }

    #[test]
    fn english_texts_fill_their_parameters_and_leave_others_visible() {
        let params = params! {"min" => 4};
        assert_eq!(
            english_text(Code::PasswordTooShort, &params),
            "The new password is too short: at least 4 characters"
        );
        assert_eq!(english_text(Code::WrongPassword, &params), "Wrong password");
        // A parameter that is missing stays visible as its placeholder.
        assert_eq!(
            english_text(Code::PasswordTooShort, &Params::new()),
            "The new password is too short: at least {min} characters"
        );
        // Stray braces are kept; a value is not filled again.
        let params = params! {"a" => "{b}", "b" => "x"};
        assert_eq!(fill("{a} {b} {c} { } {", &params), "{b} x {c} { } {");
        assert_eq!(fill("}{a}}", &params), "}{b}}");
    }

    #[test]
    fn the_docs_list_every_code_with_its_english_text() {
        let docs = include_str!("../../docs/errors.md");
        for &code in Code::ALL {
            assert!(
                docs.contains(&format!("| `{code}` |")),
                "docs/errors.md does not list {code}"
            );
            assert!(
                docs.contains(&format!("| `{code}` | {} |", code.english())),
                "docs/errors.md does not show the English text of {code}"
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
            Box::new(crate::uim2503::ascii::parse_script("PV[1]=3;").expect_err("index")),
            Box::new(crate::scl::parse_script("1ZZ").expect_err("unknown")),
            Box::new(
                crate::mbox::console::parse("dance", crate::mbox::Route::BROADCAST)
                    .expect_err("unknown"),
            ),
            Box::new(crate::uim2503::feedback::UnitError {
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
