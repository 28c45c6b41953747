//! Reading SCL text: command lines (a console's input, a Q program listing) and the
//! drive's answers. Everything refused gets a [`ParseError`] with its line and column;
//! nothing panics, whatever the input.
//!
//! Numbers are read in one canonical form only (no `+`, no leading zeros, no `-0`), so
//! whatever is accepted prints back exactly as it was written.

use super::command::{
    Address, Command, Decimal, InputCondition, IoPoint, JumpCondition, Level, MathOp, QLine,
    Register, Request, Segment, StopRate,
};
use super::error::{ParseError, ParseErrorKind};
use super::response::{Answer, QueueUpload, Reply, UploadHeader};

/// Reads a script: one command per line (lines end with CR, LF or CR LF), spaces and
/// tabs around a command ignored, blank lines skipped.
///
/// # Errors
/// The first line that is not a command, with its line and column.
pub fn parse_script(text: &str) -> Result<Vec<Request>, ParseError> {
    let mut requests = Vec::new();
    for (line_number, line) in lines(text) {
        let (column_offset, trimmed) = trim(line);
        if !trimmed.is_empty() {
            requests.push(parse_request(trimmed, line_number, column_offset)?);
        }
    }
    Ok(requests)
}

impl Request {
    /// Reads one command line; a single carriage return at its end (the wire form) and
    /// spaces or tabs around the command are allowed.
    ///
    /// # Errors
    /// What is wrong and where (line 1).
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let (column_offset, trimmed) = trim(text.strip_suffix('\r').unwrap_or(text));
        parse_request(trimmed, 1, column_offset)
    }
}

impl Reply {
    /// Reads one answer from a drive; a single carriage return at its end is allowed.
    ///
    /// # Errors
    /// What is wrong and where (line 1).
    pub fn parse(text: &str) -> Result<Self, ParseError> {
        let text = text.strip_suffix('\r').unwrap_or(text);
        let mut cursor = Cursor::new(text, 1, 0)?;
        let address = cursor.address()?;
        let answer = match cursor.rest() {
            "%" => Answer::Executed,
            "*" => Answer::Buffered,
            rest if rest.starts_with('?') => Answer::Refused {
                code: if rest.len() == 1 {
                    None
                } else {
                    cursor.pos += 1;
                    Some(cursor.number("?", "an error code (0 to 65535)", "0 to 65535")?)
                },
            },
            rest => match rest.split_once('=') {
                Some((name, value))
                    if name.len() >= 2
                        && name.bytes().take(2).all(|b| b.is_ascii_uppercase())
                        && !value.is_empty() =>
                {
                    Answer::Value {
                        name: name.to_owned(),
                        value: value.to_owned(),
                    }
                }
                _ => return Err(cursor.error(ParseErrorKind::BadAnswer)),
            },
        };
        Ok(Self { address, answer })
    }
}

impl QueueUpload {
    /// Reads the header line of an upload (`QU5`, `1QU0`, `QU-1`; a carriage return at
    /// its end allowed): the drive's address, and how many command lines follow.
    ///
    /// # Errors
    /// A line that is not `QU` and a number from −3 to 63, with its column.
    pub fn parse_header(text: &str) -> Result<(Option<Address>, UploadHeader), ParseError> {
        const RANGE: &str = "-3 to 63";
        let text = text.strip_suffix('\r').unwrap_or(text);
        let mut cursor = Cursor::new(text, 1, 0)?;
        let address = cursor.address()?;
        if !cursor.rest().starts_with("QU") {
            return Err(cursor.error(ParseErrorKind::BadAnswer));
        }
        cursor.pos += 2;
        let start = cursor.pos;
        let number: i64 = cursor.number("QU", "the number of lines + 1", RANGE)?;
        let lines = usize::try_from(number)
            .ok()
            .filter(|&n| n <= Self::MAX_LINES + 1);
        let header = match (number, lines) {
            (-3..=0, _) => UploadHeader::Nothing,
            (_, Some(n)) => UploadHeader::Lines(n - 1),
            _ => return Err(cursor.out_of_range(start, "QU", RANGE)),
        };
        Ok((address, header))
    }

    /// Reads the lines after the `%`: the header, then as many command lines as it
    /// announces, every one after the header's address (if it has one). Lines may end
    /// with a carriage return.
    ///
    /// # Errors
    /// A bad header or command (its line is its index + 1), a command with another
    /// address, or a line count that is not the header's.
    pub fn parse(lines: &[&str]) -> Result<(Option<Address>, Self), ParseError> {
        let Some((header, rest)) = lines.split_first() else {
            return Err(ParseError {
                line: 1,
                column: 1,
                kind: ParseErrorKind::BadAnswer,
            });
        };
        let (address, announced) = Self::parse_header(header)?;
        let upload = match announced {
            UploadHeader::Lines(count) => {
                if rest.len() != count {
                    return Err(ParseError {
                        line: to_u32(lines.len().min(count + 1) + 1),
                        column: 1,
                        kind: ParseErrorKind::UploadLength {
                            announced: count,
                            found: rest.len(),
                        },
                    });
                }
                let mut commands = Vec::with_capacity(count);
                for (index, text) in rest.iter().enumerate() {
                    let line = to_u32(index + 2);
                    let text = text.strip_suffix('\r').unwrap_or(text);
                    let request = parse_request(text, line, 0)?;
                    if request.address != address {
                        return Err(ParseError {
                            line,
                            column: 1,
                            kind: ParseErrorKind::BadAnswer,
                        });
                    }
                    commands.push(request.command);
                }
                Self::Lines(commands)
            }
            UploadHeader::Nothing => {
                if !rest.is_empty() {
                    return Err(ParseError {
                        line: 2,
                        column: 1,
                        kind: ParseErrorKind::UploadLength {
                            announced: 0,
                            found: rest.len(),
                        },
                    });
                }
                // The header was read: its number is one of 0, -1, -2, -3.
                let text = header.strip_suffix('\r').unwrap_or(header);
                match text.rsplit("QU").next() {
                    Some("-1") => Self::ProgramRunning,
                    Some("-2") => Self::UploadInProgress,
                    Some("-3") => Self::PasswordProtected,
                    _ => Self::NoSegment,
                }
            }
        };
        Ok((address, upload))
    }
}

/// The lines of `text` with their numbers from 1; CR LF, CR and LF each end a line.
fn lines(text: &str) -> impl Iterator<Item = (u32, &str)> {
    let mut rest = Some(text);
    let mut number = 0_u32;
    std::iter::from_fn(move || {
        let text = rest?;
        number = number.saturating_add(1);
        match text.find(['\r', '\n']) {
            Some(end) => {
                let skip = if text[end..].starts_with("\r\n") {
                    2
                } else {
                    1
                };
                rest = Some(&text[end + skip..]);
                Some((number, &text[..end]))
            }
            None => {
                rest = None;
                Some((number, text))
            }
        }
    })
}

/// The line without spaces and tabs around it, and how many characters were cut
/// before it.
fn trim(line: &str) -> (u32, &str) {
    let start = line.trim_start_matches([' ', '\t']);
    let offset = line.len() - start.len();
    (to_u32(offset), start.trim_end_matches([' ', '\t']))
}

fn to_u32(value: usize) -> u32 {
    u32::try_from(value).unwrap_or(u32::MAX)
}

/// Reads a line that is not blank.
fn parse_request(line: &str, line_number: u32, column_offset: u32) -> Result<Request, ParseError> {
    let mut cursor = Cursor::new(line, line_number, column_offset)?;
    let address = cursor.address()?;
    let command = cursor.command()?;
    Ok(Request { address, command })
}

/// A position in one line of printable ASCII.
struct Cursor<'a> {
    text: &'a str,
    pos: usize,
    line: u32,
    column_offset: u32,
}

impl<'a> Cursor<'a> {
    /// A cursor at the start of `text`, refused if it holds anything but printable
    /// ASCII (so that byte positions are columns).
    fn new(text: &'a str, line: u32, column_offset: u32) -> Result<Self, ParseError> {
        let cursor = Self {
            text,
            pos: 0,
            line,
            column_offset,
        };
        if let Some((at, found)) = text
            .char_indices()
            .find(|&(_, c)| !(' '..='~').contains(&c))
        {
            return Err(cursor.error_at(at, ParseErrorKind::NotAscii { found }));
        }
        Ok(cursor)
    }

    fn error_at(&self, pos: usize, kind: ParseErrorKind) -> ParseError {
        ParseError {
            line: self.line,
            column: self
                .column_offset
                .saturating_add(to_u32(pos))
                .saturating_add(1),
            kind,
        }
    }

    fn error(&self, kind: ParseErrorKind) -> ParseError {
        self.error_at(self.pos, kind)
    }

    fn rest(&self) -> &'a str {
        &self.text[self.pos..]
    }

    fn peek(&self) -> Option<char> {
        self.rest().chars().next()
    }

    /// The address character, if the line starts with one (anything but a capital
    /// letter must be an address).
    fn address(&mut self) -> Result<Option<Address>, ParseError> {
        match self.peek() {
            Some(c) if !c.is_ascii_uppercase() && !matches!(c, '%' | '*' | '?') => {
                let address = Address::new(c)
                    .ok_or_else(|| self.error(ParseErrorKind::BadAddress { found: c }))?;
                self.pos += 1;
                Ok(Some(address))
            }
            _ => Ok(None),
        }
    }

    /// The mnemonic and its parameter, to the end of the line.
    fn command(&mut self) -> Result<Command, ParseError> {
        let rest = self.rest();
        if rest.is_empty() {
            return Err(self.error(ParseErrorKind::MissingMnemonic));
        }
        let mnemonic = rest.get(..2).unwrap_or(rest);
        let known = Command::MNEMONICS
            .iter()
            .copied()
            .find(|&m| m == mnemonic)
            .ok_or_else(|| {
                let end = rest
                    .find(|c: char| !c.is_ascii_alphabetic())
                    .unwrap_or(rest.len())
                    .max(mnemonic.len());
                self.error(ParseErrorKind::UnknownMnemonic {
                    mnemonic: rest[..end].to_owned(),
                })
            })?;
        self.pos += 2;
        let command = self.parameter(known)?;
        if !self.rest().is_empty() {
            return Err(self.error(ParseErrorKind::Trailing {
                mnemonic: known,
                found: self.rest().to_owned(),
            }));
        }
        Ok(command)
    }

    /// The parameter of `mnemonic`.
    fn parameter(&mut self, mnemonic: &'static str) -> Result<Command, ParseError> {
        let query = self.rest().is_empty();
        Ok(match mnemonic {
            "FL" => Command::FeedToLength,
            "FP" => Command::FeedToPosition,
            // Struct fields are read in the order written: the point, then its letter.
            "FS" => Command::FeedToSensor {
                input: self.io_point(mnemonic)?,
                condition: self.input_condition(mnemonic)?,
            },
            "WI" => Command::WaitForInput {
                input: self.io_point(mnemonic)?,
                condition: self.input_condition(mnemonic)?,
            },
            "DI" => Command::Distance {
                counts: self.optional(|c| c.signed(mnemonic))?,
            },
            "SP" => Command::SetPosition {
                counts: self.optional(|c| c.signed(mnemonic))?,
            },
            "EP" => Command::EncoderPosition {
                counts: self.optional(|c| c.signed(mnemonic))?,
            },
            "VE" => Command::Velocity {
                rev_s: self.optional(|c| c.non_negative_decimal(mnemonic, "a speed in rev/s"))?,
            },
            "AC" => Command::Acceleration {
                rev_s2: self
                    .optional(|c| c.non_negative_decimal(mnemonic, "an acceleration in rev/s²"))?,
            },
            "DE" => Command::Deceleration {
                rev_s2: self
                    .optional(|c| c.non_negative_decimal(mnemonic, "a deceleration in rev/s²"))?,
            },
            "JS" => Command::JogSpeed {
                rev_s: self.optional(|c| c.non_negative_decimal(mnemonic, "a speed in rev/s"))?,
            },
            "JA" => Command::JogAcceleration {
                rev_s2: self
                    .optional(|c| c.non_negative_decimal(mnemonic, "an acceleration in rev/s²"))?,
            },
            "JL" => Command::JogDeceleration {
                rev_s2: self
                    .optional(|c| c.non_negative_decimal(mnemonic, "a deceleration in rev/s²"))?,
            },
            "CJ" => Command::CommenceJogging,
            "SJ" => Command::StopJogging,
            "CS" => {
                if query {
                    return Err(self.missing(mnemonic, "a speed in rev/s"));
                }
                Command::ChangeSpeed {
                    rev_s: self.decimal(
                        mnemonic,
                        "a speed in rev/s (signed: the direction)",
                        "-133.3333 to 133.3333",
                    )?,
                }
            }
            "EG" => Command::ElectronicGearing {
                steps_per_rev: self
                    .optional(|c| c.number(mnemonic, "steps per revolution", "0 to 4294967295"))?,
            },
            "WT" => {
                if query {
                    return Err(self.missing(mnemonic, "a time in seconds"));
                }
                Command::WaitTime {
                    s: self.non_negative_decimal(mnemonic, "a time in seconds")?,
                }
            }
            "QG" => Command::QueueGoto {
                line: self.q_line(mnemonic)?,
            },
            "QR" => Command::QueueRepeat {
                count_register: self.register(mnemonic)?,
                line: self.q_line(mnemonic)?,
            },
            "QJ" => Command::QueueJump {
                condition: self.letter(
                    mnemonic,
                    "a condition (T, F, P, G, L, E, U or Z)",
                    JumpCondition::from_letter,
                )?,
                line: self.q_line(mnemonic)?,
            },
            "QC" => Command::QueueCall {
                segment: self.optional(|c| c.segment(mnemonic))?,
            },
            "QL" => Command::QueueLoad {
                segment: self.optional(|c| c.segment(mnemonic))?,
            },
            "QS" => Command::QueueSave {
                segment: self.segment(mnemonic)?,
            },
            "QX" => Command::QueueExecute {
                segment: self.segment(mnemonic)?,
            },
            "QE" => Command::QueueExecuteLoaded,
            "QU" => Command::QueueUpload {
                segment: self.upload_segment(mnemonic)?,
            },
            "TI" => Command::TestInput {
                input: self.io_point(mnemonic)?,
                level: self.level(mnemonic)?,
            },
            "SO" => Command::SetOutput {
                output: self.io_point(mnemonic)?,
                level: self.level(mnemonic)?,
            },
            "TR" => Command::TestRegister {
                register: self.register(mnemonic)?,
                value: self.signed(mnemonic)?,
            },
            "RL" => Command::RegisterLoadImmediate {
                register: self.register(mnemonic)?,
                value: self.optional(|c| c.signed(mnemonic))?,
            },
            "SM" => Command::StopMove {
                rate: self.letter(
                    mnemonic,
                    "D (at DE or JL) or M (at AM)",
                    StopRate::from_letter,
                )?,
            },
            "WM" => Command::WaitOnMove,
            "BS" => Command::BufferStatus,
            "PS" => Command::Pause,
            "CT" => Command::Continue,
            "RX" => Command::RegisterLoad {
                register: self.register(mnemonic)?,
                value: self.signed(mnemonic)?,
            },
            "CR" => Command::CompareRegisters {
                first: self.register(mnemonic)?,
                second: self.register(mnemonic)?,
            },
            "RM" => Command::RegisterMove {
                destination: self.register(mnemonic)?,
                source: self.register(mnemonic)?,
            },
            "MT" => Command::Multitasking {
                on: self.optional(|c| {
                    c.letter(mnemonic, "1 (on) or 0 (off)", |b| match b {
                        '1' => Some(true),
                        '0' => Some(false),
                        _ => None,
                    })
                })?,
            },
            "SK" => Command::StopKill,
            "ST" => Command::Stop,
            "ME" => Command::MotorEnable,
            "MD" => Command::MotorDisable,
            "IP" => Command::ImmediatePosition,
            "SC" => Command::StatusCode,
            "AL" => Command::AlarmCode,
            "AR" => Command::AlarmReset,
            math => {
                let op = math
                    .chars()
                    .nth(1)
                    .and_then(MathOp::from_symbol)
                    .ok_or_else(|| {
                        self.error_at(
                            self.pos - 2,
                            ParseErrorKind::UnknownMnemonic {
                                mnemonic: math.to_owned(),
                            },
                        )
                    })?;
                Command::RegisterMath {
                    op,
                    first: self.register(math)?,
                    second: self.register(math)?,
                }
            }
        })
    }

    fn missing(&self, mnemonic: &'static str, expected: &'static str) -> ParseError {
        self.error(ParseErrorKind::MissingParameter { mnemonic, expected })
    }

    /// `None` at the end of the line (the query form), else what `read` reads.
    fn optional<T>(
        &mut self,
        read: impl FnOnce(&mut Self) -> Result<T, ParseError>,
    ) -> Result<Option<T>, ParseError> {
        if self.rest().is_empty() {
            Ok(None)
        } else {
            read(self).map(Some)
        }
    }

    /// One character mapped by `of`.
    fn letter<T>(
        &mut self,
        mnemonic: &'static str,
        expected: &'static str,
        of: impl FnOnce(char) -> Option<T>,
    ) -> Result<T, ParseError> {
        let c = self
            .peek()
            .ok_or_else(|| self.missing(mnemonic, expected))?;
        let value = of(c).ok_or_else(|| {
            self.error(ParseErrorKind::BadParameter {
                mnemonic,
                expected,
                found: c.to_string(),
            })
        })?;
        self.pos += 1;
        Ok(value)
    }

    fn register(&mut self, mnemonic: &'static str) -> Result<Register, ParseError> {
        self.letter(mnemonic, "a register ('0' to 'z')", Register::new)
    }

    fn io_point(&mut self, mnemonic: &'static str) -> Result<IoPoint, ParseError> {
        self.letter(mnemonic, "an I/O point (one digit)", |c| {
            c.to_digit(10)
                .and_then(|d| u8::try_from(d).ok())
                .and_then(IoPoint::new)
        })
    }

    fn input_condition(&mut self, mnemonic: &'static str) -> Result<InputCondition, ParseError> {
        self.letter(
            mnemonic,
            "a condition (H, L, R or F)",
            InputCondition::from_letter,
        )
    }

    fn level(&mut self, mnemonic: &'static str) -> Result<Level, ParseError> {
        self.letter(mnemonic, "a level (H or L)", Level::from_letter)
    }

    fn q_line(&mut self, mnemonic: &'static str) -> Result<QLine, ParseError> {
        let start = self.pos;
        let value: u8 = self.number(mnemonic, "a line number", QLine::RANGE)?;
        QLine::new(value).ok_or_else(|| self.out_of_range(start, mnemonic, QLine::RANGE))
    }

    fn segment(&mut self, mnemonic: &'static str) -> Result<Segment, ParseError> {
        let start = self.pos;
        let value: u8 = self.number(mnemonic, "a segment number", Segment::RANGE)?;
        Segment::new(value).ok_or_else(|| self.out_of_range(start, mnemonic, Segment::RANGE))
    }

    /// `QU`'s parameter: `0` (the queue, `None`) or a segment.
    fn upload_segment(&mut self, mnemonic: &'static str) -> Result<Option<Segment>, ParseError> {
        const RANGE: &str = "0 (the queue) or 1 to 12";
        let start = self.pos;
        let value: u8 = self.number(mnemonic, "a segment number or 0", RANGE)?;
        if value == 0 {
            return Ok(None);
        }
        Segment::new(value)
            .map(Some)
            .ok_or_else(|| self.out_of_range(start, mnemonic, RANGE))
    }

    fn out_of_range(
        &self,
        start: usize,
        mnemonic: &'static str,
        range: &'static str,
    ) -> ParseError {
        self.error_at(
            start,
            ParseErrorKind::OutOfRange {
                mnemonic,
                range,
                found: self.text[start..self.pos].to_owned(),
            },
        )
    }

    /// A signed 32-bit integer, to the end of the line.
    fn signed(&mut self, mnemonic: &'static str) -> Result<i32, ParseError> {
        self.number(mnemonic, "a whole number", "-2147483648 to 2147483647")
    }

    /// A canonical integer, to the end of the line, converted to `T`.
    fn number<T: TryFrom<i64>>(
        &mut self,
        mnemonic: &'static str,
        expected: &'static str,
        range: &'static str,
    ) -> Result<T, ParseError> {
        let start = self.pos;
        let decimal = self.decimal(mnemonic, expected, range)?;
        if decimal.scale() != 0 {
            return Err(self.bad(start, mnemonic, expected));
        }
        T::try_from(decimal.mantissa()).map_err(|_| self.out_of_range(start, mnemonic, range))
    }

    /// A canonical decimal number, to the end of the line.
    fn decimal(
        &mut self,
        mnemonic: &'static str,
        expected: &'static str,
        range: &'static str,
    ) -> Result<Decimal, ParseError> {
        let start = self.pos;
        if self.rest().is_empty() {
            return Err(self.missing(mnemonic, expected));
        }
        let parsed = parse_decimal(self.rest());
        self.pos = self.text.len();
        parsed.map_err(|error| match error {
            DecimalError::Malformed => self.bad(start, mnemonic, expected),
            DecimalError::TooLarge => self.out_of_range(start, mnemonic, range),
        })
    }

    fn non_negative_decimal(
        &mut self,
        mnemonic: &'static str,
        expected: &'static str,
    ) -> Result<Decimal, ParseError> {
        let start = self.pos;
        let value = self.decimal(mnemonic, expected, "not negative")?;
        if value.is_negative() {
            return Err(self.out_of_range(start, mnemonic, "not negative"));
        }
        Ok(value)
    }

    fn bad(&self, start: usize, mnemonic: &'static str, expected: &'static str) -> ParseError {
        self.error_at(
            start,
            ParseErrorKind::BadParameter {
                mnemonic,
                expected,
                found: self.text[start..].to_owned(),
            },
        )
    }
}

/// Why text is not a canonical decimal.
enum DecimalError {
    /// Not `-?(0|[1-9][0-9]*)(.[0-9]{1,9})?`, or `-0`.
    Malformed,
    /// Beyond 64 bits.
    TooLarge,
}

/// Reads `-?(0|[1-9][0-9]*)(\.[0-9]{1,9})?`, refusing `-0` (and `-0.0`, …), so that
/// every value has one text.
fn parse_decimal(text: &str) -> Result<Decimal, DecimalError> {
    let (negative, unsigned) = match text.strip_prefix('-') {
        Some(rest) => (true, rest),
        None => (false, text),
    };
    let (whole, fraction) = match unsigned.split_once('.') {
        Some((whole, fraction)) => (whole, Some(fraction)),
        None => (unsigned, None),
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    if !digits(whole) || (whole.len() > 1 && whole.starts_with('0')) {
        return Err(DecimalError::Malformed);
    }
    let fraction = fraction.unwrap_or("");
    if (unsigned.contains('.') && !digits(fraction))
        || fraction.len() > usize::from(Decimal::MAX_SCALE)
    {
        return Err(DecimalError::Malformed);
    }
    let mut mantissa: i64 = 0;
    for byte in whole.bytes().chain(fraction.bytes()) {
        mantissa = mantissa
            .checked_mul(10)
            .and_then(|m| m.checked_add(i64::from(byte - b'0')))
            .ok_or(DecimalError::TooLarge)?;
    }
    if negative {
        if mantissa == 0 {
            return Err(DecimalError::Malformed);
        }
        mantissa = -mantissa;
    }
    let scale = u8::try_from(fraction.len()).map_err(|_| DecimalError::Malformed)?;
    Decimal::new(mantissa, scale).ok_or(DecimalError::Malformed)
}
