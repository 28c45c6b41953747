//! Text → instructions, with errors an operator can act on.
//!
//! The grammar (manual §6.1): `*N;`, or a two-letter mnemonic in any case, an `x` for a
//! hexadecimal operand, an optional `[index]`, an optional operand after `=`, `:` or
//! nothing, and a final `;`. Spaces and line breaks may sit between these parts (the
//! manual writes `QV[3]= 0;` and `MP [1] = 12;`) but not inside a mnemonic or a number.
//! In a script, `#` starts a comment that runs to the end of the line, and may hold any
//! text; everywhere else only ASCII 1–127 is accepted.
//!
//! ```
//! use floatball_shared::uim2503::ascii::{parse_script, Instruction};
//!
//! let error = parse_script("*20;\nQP[3]=1000 QV[3]=0;").unwrap_err();
//! assert_eq!((error.line, error.column), (2, 12));
//! assert_eq!(
//!     error.to_string(),
//!     "line 2, column 12: expected `;` after the operand of QP[3], found `Q`"
//! );
//!
//! let instructions = parse_script("qp[3]: -9000;  # case and `:` do not matter")?;
//! assert_eq!(instructions, [Instruction::PvtPosition { row: 3, position_counts: Some(-9000) }]);
//! # Ok::<(), floatball_shared::uim2503::ascii::ParseError>(())
//! ```

use std::fmt;

use crate::codes::{Code, Coded, Params};
use crate::params;

use super::{
    BAUD, BYTE, FLAG, Field, Form, GatewayCommand, Generic, I32, I64, INDEX, Instruction, MAX_LEN,
    MP_PARAM, Mnemonic, MpParam, Operand, QT_MS, Range, RangeError, SN_STATION, STATION, U32, U64,
    takes_index,
};

/// Parses a command script: any number of instructions separated by optional whitespace
/// and line breaks, with `#` comments. Stops at the first error.
///
/// Every instruction returned can be encoded in [`Form::Standard`] (and so in
/// [`Form::Compact`]): one whose standard text would exceed 20 characters is an error
/// here, at its line and column.
///
/// # Errors
/// [`ParseError`] with the line and column (both from 1, columns in characters) of the
/// first thing that is wrong, and what was expected there.
pub fn parse_script(text: &str) -> Result<Vec<Instruction>, ParseError> {
    let mut cursor = Cursor::new(text.as_bytes(), Mode::Script);
    let mut instructions = Vec::new();
    loop {
        cursor.skip_trivia();
        if cursor.peek().is_none() {
            return Ok(instructions);
        }
        instructions.push(cursor.instruction()?);
    }
}

/// Parses one instruction as the gateway receives it: `bytes` runs up to and including
/// its first `;`. No comments; the length rule is the caller's (it counts raw bytes).
pub(super) fn parse_received(bytes: &[u8]) -> Result<Instruction, ParseError> {
    let mut cursor = Cursor::new(bytes, Mode::Received);
    cursor.skip_trivia();
    cursor.instruction()
}

/// What is wrong with a script, and where.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("line {line}, column {column}: {kind}")]
pub struct ParseError {
    /// The line, from 1.
    pub line: u32,
    /// The column in characters, from 1.
    pub column: u32,
    /// What is wrong.
    pub kind: ParseErrorKind,
}

/// What is wrong with an instruction's text.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ParseErrorKind {
    /// A character outside ASCII 1–127 (outside a comment); the gateway accepts no other.
    NotAscii {
        /// The character.
        found: Found,
    },
    /// `{` or `}`, which the manual forbids.
    Brace {
        /// The brace.
        found: char,
    },
    /// Something other than what the grammar allows here.
    Unexpected {
        /// What the grammar allows.
        expected: Expected,
        /// What is there instead.
        found: Found,
    },
    /// A hexadecimal operand with an odd number of digits (`001`, `10A`).
    OddHexDigits {
        /// The instruction so far.
        head: Head,
        /// The number of digits.
        digits: usize,
    },
    /// A number with more digits than any field can hold.
    NumberTooLarge {
        /// Where the number is.
        field: Field,
    },
    /// A number outside the documented range of its field.
    OutOfRange(RangeError),
    /// `[index]` on an instruction that takes none (`PV[1]=3;`).
    UnexpectedIndex {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
    /// An instruction that needs `[index]`, written without one (`QP=5;`).
    MissingIndex {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
    /// An operand on an instruction that takes one only with an index (`SN=5;`).
    OperandWithoutIndex {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
    /// `XXx` without its hexadecimal operand, or `SN[X];` without the serial number.
    MissingOperand {
        /// The instruction so far.
        head: Head,
    },
    /// The instruction's text would exceed 20 characters even in its shortest standard
    /// form.
    TooLong {
        /// Its length, including `;`.
        length: usize,
    },
}

impl fmt::Display for ParseErrorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::NotAscii { found } => {
                write!(
                    f,
                    "{found} is outside ASCII 1–127, the only characters the gateway accepts"
                )?;
                match found {
                    Found::Char(c @ '\u{FF01}'..='\u{FF5E}') => {
                        let ascii = char::from_u32(u32::from(c) - 0xFEE0).unwrap_or(c);
                        write!(f, " (it is a full-width character: type `{ascii}` instead)")
                    }
                    _ => Ok(()),
                }
            }
            Self::Brace { found } => {
                write!(f, "`{found}` is forbidden in instructions (manual §6.1)")
            }
            Self::Unexpected { expected, found } => {
                write!(f, "expected {expected}, found {found}")?;
                if found == Found::End {
                    f.write_str(
                        "; every instruction must end with `;` (without it the gateway waits \
                         and executes nothing)",
                    )?;
                }
                Ok(())
            }
            Self::OddHexDigits { head, digits } => write!(
                f,
                "the hexadecimal operand of {head} has {digits} digits; it needs an even \
                 number (`0A`, not `A`)"
            ),
            Self::NumberTooLarge { field } => write!(f, "{field} is too large"),
            Self::OutOfRange(error) => error.fmt(f),
            Self::UnexpectedIndex { mnemonic } => write!(f, "{mnemonic} takes no index"),
            Self::MissingIndex { mnemonic } => {
                write!(f, "{mnemonic} needs an index: `{mnemonic}[X]`")
            }
            Self::OperandWithoutIndex { mnemonic } => write!(
                f,
                "{mnemonic} takes an operand only with an index: `{mnemonic}[X]=…;`"
            ),
            Self::MissingOperand { head } if head.hex => write!(
                f,
                "{head} needs a hexadecimal operand (an even number of digits)"
            ),
            Self::MissingOperand { head } => write!(
                f,
                "{head} needs the serial number of the unit to renumber: `{head}=s/n;`"
            ),
            Self::TooLong { length } => write!(
                f,
                "this instruction is {length} characters including `;`; the gateway accepts \
                 at most 20"
            ),
        }
    }
}

/// What the grammar allows at the place of an [`ParseErrorKind::Unexpected`] error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expected {
    /// The start of an instruction: `*` or a letter.
    Instruction,
    /// The second letter of a mnemonic, right after the first.
    SecondLetter {
        /// The first letter.
        first: char,
    },
    /// The station number after `*`.
    Station,
    /// The index after `[`.
    Index {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
    /// `]` after the index.
    CloseBracket {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
    /// The digits of the operand.
    Operand {
        /// The instruction so far.
        head: Head,
    },
    /// `=`, an operand or `;` after the mnemonic or index.
    OperandOrSemicolon {
        /// The instruction so far.
        head: Head,
    },
    /// `;` after `*N`.
    SemicolonAfterStation {
        /// The station.
        station: u8,
    },
    /// `;` after the operand.
    SemicolonAfterOperand {
        /// The instruction so far.
        head: Head,
    },
    /// The line speed after `BDR=`.
    Baud,
    /// `;` after a gateway command.
    SemicolonAfterGateway {
        /// The command.
        command: GatewayCommand,
    },
}

impl fmt::Display for Expected {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Instruction => f.write_str("an instruction (`*N;` or a two-letter mnemonic)"),
            Self::SecondLetter { first } => write!(
                f,
                "a second letter right after `{first}` (a mnemonic is two letters)"
            ),
            Self::Station => f.write_str("a station number after `*`"),
            Self::Index { mnemonic } => write!(f, "an index after `{mnemonic}[`"),
            Self::CloseBracket { mnemonic } => write!(f, "`]` after the index of {mnemonic}"),
            Self::Operand { head } if head.hex => {
                write!(f, "the hexadecimal digits of the operand of {head}")
            }
            Self::Operand { head } => write!(f, "the digits of the operand of {head}"),
            Self::OperandOrSemicolon { head } => write!(f, "`=`, an operand or `;` after {head}"),
            Self::SemicolonAfterStation { station } => write!(f, "`;` after `*{station}`"),
            Self::SemicolonAfterOperand { head } => {
                write!(f, "`;` after the operand of {head}")
            }
            Self::Baud => f.write_str("the line speed after `BDR=` (9600–115200 baud)"),
            Self::SemicolonAfterGateway { command } => {
                let letters = command.letters().map(char::from);
                write!(f, "`;` after {}", letters.iter().collect::<String>())
            }
        }
    }
}

/// What the parser found where it expected something else.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Found {
    /// A character.
    Char(char),
    /// A byte that is not UTF-8 (only in bytes from [`InstructionReader`](super::InstructionReader)).
    Byte(u8),
    /// The end of the text.
    End,
}

impl fmt::Display for Found {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Char('\n') => f.write_str("a line break"),
            Self::Char('\r') => f.write_str("a carriage return"),
            Self::Char('\t') => f.write_str("a tab"),
            Self::Char(' ') => f.write_str("a space"),
            Self::Char(c) if c.is_ascii_control() => {
                write!(f, "the control character U+{:04X}", u32::from(c))
            }
            Self::Char(c) if c.is_ascii() => write!(f, "`{c}`"),
            Self::Char(c) => write!(f, "`{c}` (U+{:04X})", u32::from(c)),
            Self::Byte(byte) => write!(f, "the byte {byte:#04X} (not UTF-8)"),
            Self::End => f.write_str("the end of the input"),
        }
    }
}

/// The part of an instruction read before an error: mnemonic, `x`, index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Head {
    /// The mnemonic.
    pub mnemonic: Mnemonic,
    /// Whether an `x` follows it (hexadecimal operand).
    pub hex: bool,
    /// The index, if one has been read.
    pub index: Option<u8>,
}

impl fmt::Display for Head {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.mnemonic)?;
        if self.hex {
            f.write_str("x")?;
        }
        if let Some(index) = self.index {
            write!(f, "[{index}]")?;
        }
        Ok(())
    }
}

/// Where the text comes from.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    /// A script: comments, and the 20-character rule applied to the encoded text.
    Script,
    /// Bytes received by a gateway: no comments; the reader applies the length rule.
    Received,
}

/// A place in the text.
#[derive(Clone, Copy)]
struct Mark {
    line: u32,
    column: u32,
}

impl Mark {
    fn error(self, kind: ParseErrorKind) -> ParseError {
        ParseError {
            line: self.line,
            column: self.column,
            kind,
        }
    }
}

/// A run of digits.
struct Digits {
    /// The value, `None` if it overflows a `u64`.
    value: Option<u64>,
    /// How many digits.
    count: usize,
}

/// An instruction read but not yet checked against its mnemonic's rules.
struct Parsed {
    start: Mark,
    head: Head,
    /// Where the index is (`start` if there is none).
    index_at: Mark,
    operand: Option<(Mark, i128)>,
    /// Where the `;` is.
    end: Mark,
}

struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    line: u32,
    column: u32,
    mode: Mode,
}

impl<'a> Cursor<'a> {
    fn new(bytes: &'a [u8], mode: Mode) -> Self {
        Self {
            bytes,
            pos: 0,
            line: 1,
            column: 1,
            mode,
        }
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn mark(&self) -> Mark {
        Mark {
            line: self.line,
            column: self.column,
        }
    }

    /// Moves past one byte; columns count characters, not UTF-8 continuation bytes.
    fn bump(&mut self) {
        if let Some(byte) = self.peek() {
            self.pos += 1;
            if byte == b'\n' {
                self.line = self.line.saturating_add(1);
                self.column = 1;
            } else if byte & 0xC0 != 0x80 {
                self.column = self.column.saturating_add(1);
            }
        }
    }

    /// Skips whitespace and, in scripts, comments.
    fn skip_trivia(&mut self) {
        while let Some(byte) = self.peek() {
            match byte {
                b' ' | b'\t' | b'\r' | b'\n' => self.bump(),
                b'#' if self.mode == Mode::Script => {
                    while self.peek().is_some_and(|byte| byte != b'\n') {
                        self.bump();
                    }
                }
                _ => break,
            }
        }
    }

    fn found(&self) -> Found {
        let rest = self.bytes.get(self.pos..).unwrap_or_default();
        match rest.utf8_chunks().next() {
            None => Found::End,
            Some(chunk) => match chunk.valid().chars().next() {
                Some(c) => Found::Char(c),
                None => Found::Byte(chunk.invalid().first().copied().unwrap_or_default()),
            },
        }
    }

    /// The error for finding something other than `expected` here.
    fn unexpected(&self, expected: Expected) -> ParseError {
        let kind = match self.found() {
            found @ Found::Byte(_) => ParseErrorKind::NotAscii { found },
            Found::Char(c) if c == '\0' || !c.is_ascii() => ParseErrorKind::NotAscii {
                found: Found::Char(c),
            },
            Found::Char(c @ ('{' | '}')) => ParseErrorKind::Brace { found: c },
            found => ParseErrorKind::Unexpected { expected, found },
        };
        self.mark().error(kind)
    }

    fn expect_semicolon(&mut self, expected: Expected) -> Result<(), ParseError> {
        if self.peek() == Some(b';') {
            self.bump();
            Ok(())
        } else {
            Err(self.unexpected(expected))
        }
    }

    /// Reads a run of digits in `radix`, if there is one.
    fn digits(&mut self, radix: u32) -> Option<Digits> {
        let mut value = Some(0_u64);
        let mut count = 0;
        while let Some(digit) = self
            .peek()
            .and_then(|byte| char::from(byte).to_digit(radix))
        {
            value = value
                .and_then(|value| value.checked_mul(radix.into()))
                .and_then(|value| value.checked_add(digit.into()));
            count += 1;
            self.bump();
        }
        (count > 0).then_some(Digits { value, count })
    }

    /// Reads one instruction; trivia before it has been skipped and it is not at the end.
    fn instruction(&mut self) -> Result<Instruction, ParseError> {
        let start = self.mark();
        let instruction = match self.peek() {
            Some(b'*') => self.select()?,
            Some(_) if self.gateway_letters().is_some() => self.gateway()?,
            Some(byte) if byte.is_ascii_alphabetic() => build(self.command(start)?)?,
            _ => return Err(self.unexpected(Expected::Instruction)),
        };
        if self.mode == Mode::Script {
            let length = instruction.encoded_len(Form::Standard);
            if length > MAX_LEN {
                return Err(start.error(ParseErrorKind::TooLong { length }));
            }
        }
        Ok(instruction)
    }

    /// The gateway command whose three letters (any case) start here, if one does.
    fn gateway_letters(&self) -> Option<[u8; 3]> {
        let letters: [u8; 3] = self.bytes.get(self.pos..self.pos + 3)?.try_into().ok()?;
        let upper = letters.map(|byte| byte.to_ascii_uppercase());
        (upper == *b"ABC" || upper == *b"BDR").then_some(upper)
    }

    /// `ABC;` or `BDR[=]x;`.
    fn gateway(&mut self) -> Result<Instruction, ParseError> {
        let letters = self.gateway_letters().unwrap_or_default();
        for _ in letters {
            self.bump();
        }
        self.skip_trivia();
        let command = if letters == *b"ABC" {
            GatewayCommand::Greet
        } else {
            if matches!(self.peek(), Some(b'=' | b':')) {
                self.bump();
                self.skip_trivia();
            }
            let at = self.mark();
            let digits = self
                .digits(10)
                .ok_or_else(|| self.unexpected(Expected::Baud))?;
            let too_large = at.error(ParseErrorKind::NumberTooLarge { field: Field::Baud });
            let value = digits.value.ok_or(too_large)?;
            let baud = BAUD
                .narrow(Field::Baud, value.into())
                .map_err(|error| at.error(ParseErrorKind::OutOfRange(error)))?;
            self.skip_trivia();
            GatewayCommand::SetBaud { baud }
        };
        self.expect_semicolon(Expected::SemicolonAfterGateway { command })?;
        Ok(Instruction::Gateway(command))
    }

    /// `*N;`
    fn select(&mut self) -> Result<Instruction, ParseError> {
        self.bump();
        self.skip_trivia();
        let at = self.mark();
        let digits = self
            .digits(10)
            .ok_or_else(|| self.unexpected(Expected::Station))?;
        let value = digits
            .value
            .ok_or(at.error(ParseErrorKind::NumberTooLarge {
                field: Field::Station,
            }))?;
        let station = STATION
            .narrow(Field::Station, value.into())
            .map_err(|error| at.error(ParseErrorKind::OutOfRange(error)))?;
        self.skip_trivia();
        self.expect_semicolon(Expected::SemicolonAfterStation { station })?;
        Ok(Instruction::Select { station })
    }

    /// `XX[x][[i]][=v];`, read but not yet checked against the mnemonic's rules.
    fn command(&mut self, start: Mark) -> Result<Parsed, ParseError> {
        let first = self.peek().unwrap_or_default();
        self.bump();
        let Some(second) = self.peek().filter(u8::is_ascii_alphabetic) else {
            return Err(self.unexpected(Expected::SecondLetter {
                first: char::from(first.to_ascii_uppercase()),
            }));
        };
        self.bump();
        let mnemonic = Mnemonic::from_letters(first, second);
        let hex = matches!(self.peek(), Some(b'x' | b'X'));
        if hex {
            self.bump();
        }
        let mut head = Head {
            mnemonic,
            hex,
            index: None,
        };
        let mut index_at = start;
        self.skip_trivia();
        if self.peek() == Some(b'[') {
            if !takes_index(mnemonic) {
                return Err(self
                    .mark()
                    .error(ParseErrorKind::UnexpectedIndex { mnemonic }));
            }
            self.bump();
            self.skip_trivia();
            index_at = self.mark();
            let field = Field::Index(mnemonic);
            let digits = self
                .digits(10)
                .ok_or_else(|| self.unexpected(Expected::Index { mnemonic }))?;
            let value = digits
                .value
                .ok_or(index_at.error(ParseErrorKind::NumberTooLarge { field }))?;
            head.index = Some(
                INDEX
                    .narrow(field, value.into())
                    .map_err(|error| index_at.error(ParseErrorKind::OutOfRange(error)))?,
            );
            self.skip_trivia();
            if self.peek() != Some(b']') {
                return Err(self.unexpected(Expected::CloseBracket { mnemonic }));
            }
            self.bump();
            self.skip_trivia();
        }
        let operand = match self.peek() {
            Some(b'=' | b':') => {
                self.bump();
                self.skip_trivia();
                Some(self.operand(head)?)
            }
            Some(b';') => None,
            Some(byte) if starts_operand(byte, hex) => Some(self.operand(head)?),
            _ => return Err(self.unexpected(Expected::OperandOrSemicolon { head })),
        };
        self.skip_trivia();
        let end = self.mark();
        self.expect_semicolon(Expected::SemicolonAfterOperand { head })?;
        Ok(Parsed {
            start,
            head,
            index_at,
            operand,
            end,
        })
    }

    /// The operand's digits (with their sign) and where they start.
    fn operand(&mut self, head: Head) -> Result<(Mark, i128), ParseError> {
        let at = self.mark();
        let too_large = at.error(ParseErrorKind::NumberTooLarge {
            field: Field::Operand(head.mnemonic),
        });
        if head.hex {
            let digits = self
                .digits(16)
                .ok_or_else(|| self.unexpected(Expected::Operand { head }))?;
            if digits.count % 2 == 1 {
                return Err(at.error(ParseErrorKind::OddHexDigits {
                    head,
                    digits: digits.count,
                }));
            }
            Ok((at, digits.value.ok_or(too_large)?.into()))
        } else {
            let negative = self.peek() == Some(b'-');
            if negative {
                self.bump();
            }
            let digits = self
                .digits(10)
                .ok_or_else(|| self.unexpected(Expected::Operand { head }))?;
            let magnitude = i128::from(digits.value.ok_or(too_large)?);
            Ok((at, if negative { -magnitude } else { magnitude }))
        }
    }
}

/// Whether `byte` can start an operand written without `=`.
fn starts_operand(byte: u8, hex: bool) -> bool {
    if hex {
        byte.is_ascii_hexdigit()
    } else {
        byte.is_ascii_digit() || byte == b'-'
    }
}

/// The operand of the instruction with `index`, checked against `range`, as a `T`.
fn value<T: TryFrom<i128>>(
    operand: Option<(Mark, i128)>,
    range: Range,
    field: Field,
    index: Option<u8>,
) -> Result<Option<T>, ParseError> {
    operand
        .map(|(at, value)| {
            range.narrow(field, value).map_err(|error| {
                at.error(ParseErrorKind::OutOfRange(RangeError { index, ..error }))
            })
        })
        .transpose()
}

/// Checks a parsed instruction against its mnemonic's rules and types it.
fn build(parsed: Parsed) -> Result<Instruction, ParseError> {
    let Parsed {
        start,
        head,
        index_at,
        operand,
        end,
    } = parsed;
    let mnemonic = head.mnemonic;
    let field = Field::Operand(mnemonic);
    if head.hex && operand.is_none() {
        return Err(end.error(ParseErrorKind::MissingOperand { head }));
    }
    let row = || {
        head.index
            .ok_or(start.error(ParseErrorKind::MissingIndex { mnemonic }))
    };
    Ok(match mnemonic {
        Mnemonic::BG => Instruction::Begin {
            at_us: value(operand, U32, field, head.index)?,
        },
        Mnemonic::MP => {
            let index = row()?;
            let param = MpParam::from_index(index).ok_or_else(|| {
                index_at.error(ParseErrorKind::OutOfRange(
                    MP_PARAM.error(Field::Index(mnemonic), index.into()),
                ))
            })?;
            Instruction::MotionProfile {
                param,
                value: value(operand, BYTE, field, head.index)?,
            }
        }
        Mnemonic::PV => Instruction::PvtStart {
            row: value(operand, BYTE, field, head.index)?,
        },
        Mnemonic::QP => Instruction::PvtPosition {
            row: row()?,
            position_counts: value(operand, I32, field, head.index)?,
        },
        Mnemonic::QV => Instruction::PvtVelocity {
            row: row()?,
            velocity_counts_s: value(operand, I32, field, head.index)?,
        },
        Mnemonic::QT => Instruction::PvtTime {
            row: row()?,
            duration_ms: value(operand, QT_MS, field, head.index)?,
        },
        Mnemonic::SN => match (head.index, operand) {
            (None, None) => Instruction::QuerySerial,
            (Some(station), Some((at, serial))) => Instruction::SetStation {
                station: SN_STATION
                    .narrow(Field::Index(mnemonic), station.into())
                    .map_err(|error| index_at.error(ParseErrorKind::OutOfRange(error)))?,
                serial: U64.narrow(field, serial).map_err(|error| {
                    at.error(ParseErrorKind::OutOfRange(RangeError {
                        index: Some(station),
                        ..error
                    }))
                })?,
            },
            (Some(_), None) => return Err(end.error(ParseErrorKind::MissingOperand { head })),
            (None, Some((at, _))) => {
                return Err(at.error(ParseErrorKind::OperandWithoutIndex { mnemonic }));
            }
        },
        Mnemonic::MO => Instruction::Motor {
            on: value::<u8>(operand, FLAG, field, head.index)?.map(|on| on == 1),
        },
        Mnemonic::SP => Instruction::PtpSpeed {
            speed_counts_s: value(operand, I32, field, head.index)?,
        },
        Mnemonic::PA => Instruction::PtpPosition {
            position_counts: value(operand, I32, field, head.index)?,
        },
        Mnemonic::SD => Instruction::StopDecel {
            decel_counts_s2: value(operand, U32, field, head.index)?,
        },
        Mnemonic::IE => Instruction::InfoEnable {
            index: row()?,
            enabled: value::<u8>(operand, FLAG, field, head.index)?.map(|enabled| enabled == 1),
        },
        _ => Instruction::Generic(Generic {
            mnemonic,
            index: head.index,
            operand: if head.hex {
                value(operand, U64, field, head.index)?.map(Operand::Hex)
            } else {
                value(operand, I64, field, head.index)?.map(Operand::Decimal)
            },
        }),
    })
}

impl Coded for ParseError {
    fn code(&self) -> Code {
        self.kind.code()
    }

    /// The kind's parameters, and where: `line` and `column`.
    fn params(&self) -> Params {
        crate::codes::located(&self.kind, self.line, self.column)
    }
}

impl Coded for ParseErrorKind {
    fn code(&self) -> Code {
        match self {
            Self::NotAscii { .. } => Code::AsciiNotAscii,
            Self::Brace { .. } => Code::AsciiBrace,
            Self::Unexpected { .. } => Code::AsciiUnexpected,
            Self::OddHexDigits { .. } => Code::AsciiOddHexDigits,
            Self::NumberTooLarge { .. } => Code::AsciiNumberTooLarge,
            Self::OutOfRange(_) => Code::AsciiOutOfRange,
            Self::UnexpectedIndex { .. } => Code::AsciiUnexpectedIndex,
            Self::MissingIndex { .. } => Code::AsciiMissingIndex,
            Self::OperandWithoutIndex { .. } => Code::AsciiOperandWithoutIndex,
            Self::MissingOperand { .. } => Code::AsciiMissingOperand,
            Self::TooLong { .. } => Code::AsciiTooLong,
        }
    }

    fn params(&self) -> Params {
        match *self {
            Self::NotAscii { found } => params! {"found" => found},
            Self::Brace { found } => params! {"found" => found},
            Self::Unexpected { expected, found } => {
                params! {"expected" => expected, "found" => found}
            }
            Self::OddHexDigits { head, digits } => {
                params! {"instruction" => head, "digits" => digits}
            }
            Self::NumberTooLarge { field } => params! {"field" => field},
            Self::OutOfRange(error) => params! {
                "field" => error.field,
                "value" => error.value,
                "min" => error.min,
                "max" => error.max,
            },
            Self::UnexpectedIndex { mnemonic }
            | Self::MissingIndex { mnemonic }
            | Self::OperandWithoutIndex { mnemonic } => params! {"mnemonic" => mnemonic},
            Self::MissingOperand { head } => params! {"instruction" => head},
            Self::TooLong { length } => params! {"length" => length, "max" => 20},
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::InstructionReader;
    use super::*;

    /// Parses `source`, checks the standard re-encoding against `canonical`, and checks
    /// that the canonical text parses to the same instructions.
    fn round_trip(source: &str, canonical: &str) -> Vec<Instruction> {
        let instructions = parse_script(source)
            .unwrap_or_else(|error| panic!("{source:?} does not parse: {error}"));
        let mut encoded = Vec::new();
        for instruction in &instructions {
            instruction
                .encode_into(Form::Standard, &mut encoded)
                .unwrap_or_else(|error| panic!("{instruction:?}: {error}"));
        }
        assert_eq!(String::from_utf8_lossy(&encoded), canonical, "{source:?}");
        assert_eq!(parse_script(canonical), Ok(instructions.clone()));
        instructions
    }

    /// Every example instruction of manual §7.4 (PVT worked sequences), with the
    /// manual's full-width `；` written as `;` and its `……` left out.
    #[test]
    fn manual_section_7_4_examples() {
        let single = "MO=1;\nMP[3]=1;\nMP[1]=3;\nMP[2]=100;\n\
            QP[3]=1000;QV[3]=0;QT[3]=100;\n\
            QP[4]=4000;QV[4]=500;QT[4]=100;\n\
            QP[100]=8000;QV[100]=0;QT[100]=100;\n\
            SP=1000;PA=4000;BG;\nPV=4;BG;";
        let single_canonical = single.replace('\n', "");
        let instructions = round_trip(single, &single_canonical);
        assert_eq!(instructions.len(), 18);
        assert_eq!(instructions[0], Instruction::Motor { on: Some(true) });
        assert_eq!(
            instructions[1],
            Instruction::MotionProfile {
                param: MpParam::Mode,
                value: Some(1)
            }
        );
        assert_eq!(
            instructions[12],
            Instruction::PvtTime {
                row: 100,
                duration_ms: Some(100)
            }
        );
        assert_eq!(
            instructions[13..],
            [
                Instruction::PtpSpeed {
                    speed_counts_s: Some(1000)
                },
                Instruction::PtpPosition {
                    position_counts: Some(4000)
                },
                Instruction::Begin { at_us: None },
                Instruction::PvtStart { row: Some(4) },
                Instruction::Begin { at_us: None },
            ]
        );

        round_trip(
            "MO=1;\nMP[3]=3;\nMP[1]=3;\nMP[2]=100;\n\
             QP[3]=1000;QV[3]= 0;QT[3]=100;\n\
             QP[4]=4000;QV[4]=500;QT[4]=100;\n\
             QP[100]=1000;QV[100]=0;QT[100]=100;\n\
             SP=1000;PA=1000;BG;\nPV=3;BG;",
            "MO=1;MP[3]=3;MP[1]=3;MP[2]=100;QP[3]=1000;QV[3]=0;QT[3]=100;\
             QP[4]=4000;QV[4]=500;QT[4]=100;QP[100]=1000;QV[100]=0;QT[100]=100;\
             SP=1000;PA=1000;BG;PV=3;BG;",
        );

        let fifo = round_trip(
            "MO=1;\nMP[3]=0;\nMP[5]=5;\nMP[0]=1;\n\
             QP[0]=1000;QV[0]= 0;QT[0]=100;\n\
             QP[1]=4000;QV[1]=500;QT[1]=100;\n\
             QP[10]=1000;QV[10]=7000;QT[10]=100;\n\
             PA=1000;BG;\nPV=0;BG;\n\
             QP[11]=1000;QV[11]= 0;QT[11]=100;\n\
             QP[12]=4000;QV[12]=500;QT[12]=100;\n\
             QP[255]=1000;QV[255]=7000;QT[255]=100;\n\
             QP[0]=1000;QV[0]= 0;QT[0]=100;\n\
             QP[1]=4000;QV[1]=500;QT[1]=100;\n\
             QP[249]=1000;QV[249]=7000;QT[249]=100;",
            "MO=1;MP[3]=0;MP[5]=5;MP[0]=1;\
             QP[0]=1000;QV[0]=0;QT[0]=100;QP[1]=4000;QV[1]=500;QT[1]=100;\
             QP[10]=1000;QV[10]=7000;QT[10]=100;PA=1000;BG;PV=0;BG;\
             QP[11]=1000;QV[11]=0;QT[11]=100;QP[12]=4000;QV[12]=500;QT[12]=100;\
             QP[255]=1000;QV[255]=7000;QT[255]=100;\
             QP[0]=1000;QV[0]=0;QT[0]=100;QP[1]=4000;QV[1]=500;QT[1]=100;\
             QP[249]=1000;QV[249]=7000;QT[249]=100;",
        );
        assert_eq!(
            fifo[2],
            Instruction::MotionProfile {
                param: MpParam::Watermark,
                value: Some(5)
            }
        );
        assert_eq!(
            fifo[3],
            Instruction::MotionProfile {
                param: MpParam::Clear,
                value: Some(1)
            }
        );
    }

    /// Every example instruction of manual §8 (instruction reference) and §6 (syntax),
    /// placeholders (`N`, `s/n`) given values.
    #[test]
    fn manual_sections_6_and_8_examples() {
        // §8.1 BG
        let bg = round_trip("*20;PV=3;BG;", "*20;PV=3;BG;");
        assert_eq!(bg[0], Instruction::Select { station: 20 });
        let ptp = round_trip("*20;SP=20;PA=500;BG=12345;", "*20;SP=20;PA=500;BG=12345;");
        assert_eq!(ptp[3], Instruction::Begin { at_us: Some(12345) });
        round_trip("BG;BG = 4294967295;", "BG;BG=4294967295;");
        // §8.2 MP: the syntax, the description (note `MP [1]`) and the example.
        round_trip("MP[6]; MP[5] = 254;", "MP[6];MP[5]=254;");
        let descriptions = round_trip(
            "MP[0] = 1;\nMP [1] = 12;\nMP [2] = 25;\nMP[3] = 0;\nMP[3] = 1;\nMP[3] = 2;\n\
             MP[3] = 3;\nMP[5] = 1;\nMP[6];",
            "MP[0]=1;MP[1]=12;MP[2]=25;MP[3]=0;MP[3]=1;MP[3]=2;MP[3]=3;MP[5]=1;MP[6];",
        );
        assert_eq!(
            descriptions[8],
            Instruction::MotionProfile {
                param: MpParam::NextWriteRow,
                value: None
            }
        );
        round_trip(
            "*10;\nMP[3]=1;\nMP[1]=0;\nMP[2]=100;\nMP[5]=5;\n\
             QP[0]= 50;QV[0]=20;QT[0]=200;\n\
             QP[1]=100;QV[1]=30;QT[1]=150;\n\
             QP[2]=220;QV[2]=10;QT[2]=200;\n\
             QP[100]=2000;QV[100]=40;QT[100]=200;\n\
             PV=10;\nBG;",
            "*10;MP[3]=1;MP[1]=0;MP[2]=100;MP[5]=5;QP[0]=50;QV[0]=20;QT[0]=200;\
             QP[1]=100;QV[1]=30;QT[1]=150;QP[2]=220;QV[2]=10;QT[2]=200;\
             QP[100]=2000;QV[100]=40;QT[100]=200;PV=10;BG;",
        );
        // §8.3 PV, §8.4 QP/QV/QT (queries, and the negative velocity of the §7.1 table).
        round_trip("PV;PV = 255;", "PV;PV=255;");
        let queries = round_trip(
            "QP[7]; QV[7]; QT[7];QV[3]=-9000;",
            "QP[7];QV[7];QT[7];QV[3]=-9000;",
        );
        assert_eq!(
            queries[3],
            Instruction::PvtVelocity {
                row: 3,
                velocity_counts_s: Some(-9000)
            }
        );
        // §8.5 SN and §6.0 `SN[ID]=XXXX`, §8.5 notes `*0; SN;`.
        let sn = round_trip(
            "SN;SN[12] = 305419896;*0; SN;",
            "SN;SN[12]=305419896;*0;SN;",
        );
        assert_eq!(
            sn[1],
            Instruction::SetStation {
                station: 12,
                serial: 305_419_896
            }
        );
        // §6.1: `=` may be left out (`SP5000;`) or replaced by `:`; hexadecimal `ILx`.
        round_trip("SP5000;SP:5000;sp=5000;", "SP=5000;SP=5000;SP=5000;");
        round_trip(
            "ILx=00;ILx=01;ILx=0A;ilX0a;",
            "ILx=00;ILx=01;ILx=0A;ILx=0A;",
        );
        // A typed mnemonic written in hexadecimal is the same instruction.
        assert_eq!(
            round_trip("QPx[3]=03E8;", "QP[3]=1000;"),
            [Instruction::PvtPosition {
                row: 3,
                position_counts: Some(1000)
            }]
        );
    }

    #[test]
    fn whitespace_comments_and_empty_scripts() {
        assert_eq!(parse_script(""), Ok(vec![]));
        assert_eq!(parse_script("  \n# only a comment\n\t"), Ok(vec![]));
        round_trip(
            "# 单序列方式 (single sequence)\r\nMO=1;   # enable\r\n\
             QP[ 3 ] =\n 1000 ;# split over lines\nIE[5]:1;",
            "MO=1;QP[3]=1000;IE[5]=1;",
        );
        // Text longer than 20 characters is fine as long as the encoded text is not.
        round_trip("QP[3]     =     -2147483648   ;", "QP[3]=-2147483648;");
    }

    #[test]
    fn every_error_has_a_place_and_says_what_was_wrong() {
        let end = "; every instruction must end with `;` (without it the gateway waits and \
                   executes nothing)";
        let cases: &[(&str, u32, u32, &str)] = &[
            // NotAscii
            (
                "PV=3；",
                1,
                5,
                "`；` (U+FF1B) is outside ASCII 1–127, the only characters the \
                gateway accepts (it is a full-width character: type `;` instead)",
            ),
            (
                "\n  é",
                2,
                3,
                "`é` (U+00E9) is outside ASCII 1–127, the only characters the \
                gateway accepts",
            ),
            (
                "PV\0;",
                1,
                3,
                "the control character U+0000 is outside ASCII 1–127, the only \
                characters the gateway accepts",
            ),
            // Brace
            (
                "QP[3]={5};",
                1,
                7,
                "`{` is forbidden in instructions (manual §6.1)",
            ),
            ("}", 1, 1, "`}` is forbidden in instructions (manual §6.1)"),
            // Unexpected, one per Expected
            (
                ";",
                1,
                1,
                "expected an instruction (`*N;` or a two-letter mnemonic), found `;`",
            ),
            (
                "BG;1",
                1,
                4,
                "expected an instruction (`*N;` or a two-letter mnemonic), found `1`",
            ),
            (
                "Q P[3];",
                1,
                2,
                "expected a second letter right after `Q` (a mnemonic is two \
                letters), found a space",
            ),
            ("*;", 1, 2, "expected a station number after `*`, found `;`"),
            (
                "*-1;",
                1,
                2,
                "expected a station number after `*`, found `-`",
            ),
            ("QP[];", 1, 4, "expected an index after `QP[`, found `]`"),
            (
                "QP[3=5;",
                1,
                5,
                "expected `]` after the index of QP, found `=`",
            ),
            (
                "QP[3]=;",
                1,
                7,
                "expected the digits of the operand of QP[3], found `;`",
            ),
            (
                "QV[3]=- 9000;",
                1,
                8,
                "expected the digits of the operand of QV[3], found a \
                space",
            ),
            (
                "ILx=-0A;",
                1,
                5,
                "expected the hexadecimal digits of the operand of ILx, found \
                `-`",
            ),
            (
                "PVz;",
                1,
                3,
                "expected `=`, an operand or `;` after PV, found `z`",
            ),
            (
                "MP[3]\t=1\n;\nPV\n\tQ;",
                4,
                2,
                "expected `=`, an operand or `;` after PV, \
                found `Q`",
            ),
            ("*20 PV;", 1, 5, "expected `;` after `*20`, found `P`"),
            (
                "*20;\nQP[3]=1000 QV[3]=0;",
                2,
                12,
                "expected `;` after the operand of QP[3], \
                found `Q`",
            ),
            (
                "BG;#x\nQP[3]=10A;",
                2,
                9,
                "expected `;` after the operand of QP[3], found `A`",
            ),
            (
                "PV=3;\nPV=3 # no semicolon\nBG;",
                3,
                1,
                "expected `;` after the operand of PV, \
                found `B`",
            ),
            // Missing final `;`
            (
                "PV=3",
                1,
                5,
                "expected `;` after the operand of PV, found the end of the input",
            ),
            (
                "BG",
                1,
                3,
                "expected `=`, an operand or `;` after BG, found the end of the input",
            ),
            (
                "*5",
                1,
                3,
                "expected `;` after `*5`, found the end of the input",
            ),
            (
                "QP[3",
                1,
                5,
                "expected `]` after the index of QP, found the end of the input",
            ),
            (
                "Q",
                1,
                2,
                "expected a second letter right after `Q` (a mnemonic is two letters), \
                found the end of the input",
            ),
            // OddHexDigits
            (
                "ILx=001;",
                1,
                5,
                "the hexadecimal operand of ILx has 3 digits; it needs an even \
                number (`0A`, not `A`)",
            ),
            (
                "ILx[1]10A;",
                1,
                7,
                "the hexadecimal operand of ILx[1] has 3 digits; it needs an \
                even number (`0A`, not `A`)",
            ),
            // NumberTooLarge
            (
                "*99999999999999999999;",
                1,
                2,
                "the station of `*N;` is too large",
            ),
            (
                "QP[99999999999999999999]=1;",
                1,
                4,
                "the index of QP[X] is too large",
            ),
            (
                "QP[3]=-99999999999999999999;",
                1,
                7,
                "the operand of QP[X] is too large",
            ),
            (
                "ILx=0102030405060708090A;",
                1,
                5,
                "the operand of IL is too large",
            ),
            // OutOfRange
            (
                "*128;",
                1,
                2,
                "the station of `*N;` must be 0–127, found 128",
            ),
            (
                "QT[3]=0;",
                1,
                7,
                "the operand of QT[X] (ms) must be 10–255, found 0",
            ),
            (
                "QT[3]=256;",
                1,
                7,
                "the operand of QT[X] (ms) must be 10–255, found 256",
            ),
            ("MP[7]=1;", 1, 4, "the index of MP[X] must be 0–6, found 7"),
            (
                "MP[1]=256;",
                1,
                7,
                "the operand of MP[X] must be 0–255, found 256",
            ),
            (
                "QP[256]=1;",
                1,
                4,
                "the index of QP[X] must be 0–255, found 256",
            ),
            (
                "QP[1]=2147483648;",
                1,
                7,
                "the operand of QP[X] must be -2147483648–2147483647, \
                found 2147483648",
            ),
            (
                "QV[1]=-2147483649;",
                1,
                7,
                "the operand of QV[X] must be -2147483648–2147483647, \
                found -2147483649",
            ),
            ("PV=-1;", 1, 4, "the operand of PV must be 0–255, found -1"),
            ("MO=2;", 1, 4, "the operand of MO must be 0–1, found 2"),
            (
                "IE[5]=3;",
                1,
                7,
                "the operand of IE[X] must be 0–1, found 3",
            ),
            (
                "SN[128]=5;",
                1,
                4,
                "the new station of SN[X] must be 0–127, found 128",
            ),
            (
                "BG=4294967296;",
                1,
                4,
                "the operand of BG (µs) must be 0–4294967295, found \
                4294967296",
            ),
            (
                "SD=-1;",
                1,
                4,
                "the operand of SD must be 0–4294967295, found -1",
            ),
            (
                "SP=3000000000;",
                1,
                4,
                "the operand of SP must be -2147483648–2147483647, found \
                3000000000",
            ),
            (
                "PA=-3000000000;",
                1,
                4,
                "the operand of PA must be -2147483648–2147483647, found \
                -3000000000",
            ),
            (
                "SNx[1]=-1;",
                1,
                8,
                "expected the hexadecimal digits of the operand of SNx[1], \
                found `-`",
            ),
            (
                "AB=9223372036854775808;",
                1,
                4,
                "the operand of AB must be \
                -9223372036854775808–9223372036854775807, found 9223372036854775808",
            ),
            // UnexpectedIndex, MissingIndex, OperandWithoutIndex, MissingOperand
            ("PV[1]=3;", 1, 3, "PV takes no index"),
            ("BG [1];", 1, 4, "BG takes no index"),
            ("QP=5;", 1, 1, "QP needs an index: `QP[X]`"),
            ("  IE;", 1, 3, "IE needs an index: `IE[X]`"),
            ("MP=1;", 1, 1, "MP needs an index: `MP[X]`"),
            (
                "SN=5;",
                1,
                4,
                "SN takes an operand only with an index: `SN[X]=…;`",
            ),
            (
                "SN[5];",
                1,
                6,
                "SN[5] needs the serial number of the unit to renumber: \
                `SN[5]=s/n;`",
            ),
            (
                "ILx;",
                1,
                4,
                "ILx needs a hexadecimal operand (an even number of digits)",
            ),
            (
                "QPx[2] ;",
                1,
                8,
                "QPx[2] needs a hexadecimal operand (an even number of digits)",
            ),
            // TooLong
            (
                "BG;\n SN[100]=99999999999999;",
                2,
                2,
                "this instruction is 23 characters \
                including `;`; the gateway accepts at most 20",
            ),
            (
                "ABx[255]=0102030405060708;",
                1,
                1,
                "this instruction is 26 characters including \
                `;`; the gateway accepts at most 20",
            ),
        ];
        for &(source, line, column, message) in cases {
            let error = parse_script(source).expect_err(source);
            assert_eq!(
                (error.line, error.column),
                (line, column),
                "{source:?}: {error}"
            );
            let text = error.kind.to_string();
            let expected = if matches!(
                error.kind,
                ParseErrorKind::Unexpected {
                    found: Found::End,
                    ..
                }
            ) {
                format!("{message}{end}")
            } else {
                message.to_owned()
            };
            assert_eq!(text, expected, "{source:?}");
            assert_eq!(
                error.to_string(),
                format!("line {line}, column {column}: {expected}")
            );
        }
    }

    #[test]
    fn a_comment_is_not_an_instruction_and_ends_at_the_line_break() {
        assert_eq!(parse_script("# PV=3;"), Ok(vec![]));
        assert_eq!(
            parse_script("#"),
            Ok(vec![]),
            "a script of only `#` is an empty comment"
        );
    }

    #[test]
    fn the_reader_reads_what_the_gateway_would() {
        let mut reader = InstructionReader::new();
        let read: Vec<_> = reader
            .push(b"\r\n*5;QP[3]=1000;  qv[3]:-9000;QT[3]100;\nPV=\xFF;BG;")
            .collect();
        assert_eq!(
            read[..4],
            [
                Ok(Instruction::Select { station: 5 }),
                Ok(Instruction::PvtPosition {
                    row: 3,
                    position_counts: Some(1000)
                }),
                Ok(Instruction::PvtVelocity {
                    row: 3,
                    velocity_counts_s: Some(-9000)
                }),
                Ok(Instruction::PvtTime {
                    row: 3,
                    duration_ms: Some(100)
                }),
            ]
        );
        let error = read[4].expect_err("0xFF is not ASCII");
        assert_eq!((error.line, error.column), (1, 4));
        assert_eq!(
            error.kind,
            ParseErrorKind::NotAscii {
                found: Found::Byte(0xFF)
            }
        );
        assert_eq!(
            error.to_string(),
            "line 1, column 4: the byte 0xFF (not UTF-8) is outside ASCII 1–127, the only \
             characters the gateway accepts"
        );
        assert_eq!(read[5], Ok(Instruction::Begin { at_us: None }));
        assert_eq!(read.len(), 6);
        assert_eq!(reader.pending(), 0);
    }

    #[test]
    fn the_reader_counts_raw_bytes_and_recovers_at_the_next_semicolon() {
        let mut reader = InstructionReader::default();
        // 20 bytes including `;` pass, even with spaces; 21 do not.
        let twenty = b"QP[3] = 1000       ;";
        assert_eq!(twenty.len(), 20);
        assert!(matches!(reader.push(twenty).next(), Some(Ok(_))));
        let long = b"QP[3] = 1000        ;BG;";
        let read: Vec<_> = reader.push(long).collect();
        assert_eq!(
            read,
            [
                Err(ParseError {
                    line: 1,
                    column: 1,
                    kind: ParseErrorKind::TooLong { length: 21 }
                }),
                Ok(Instruction::Begin { at_us: None }),
            ]
        );
        // A long run without `;` is held as a count, not in memory, and yields nothing.
        assert_eq!(reader.push(&[b'A'; 10_000]).count(), 0);
        assert_eq!(reader.pending(), 10_000);
        let read: Vec<_> = reader.push(b";PV;").collect();
        assert!(matches!(
            read[0],
            Err(ParseError {
                kind: ParseErrorKind::TooLong { length: 10_001 },
                ..
            })
        ));
        assert_eq!(read[1], Ok(Instruction::PvtStart { row: None }));
        // Script features are not gateway features; errors are per instruction.
        let read: Vec<_> = reader.push(b"# PV;\n;*1;").collect();
        assert_eq!(read.len(), 3);
        assert!(matches!(
            read[0],
            Err(ParseError {
                column: 1,
                kind: ParseErrorKind::Unexpected {
                    expected: Expected::Instruction,
                    found: Found::Char('#')
                },
                ..
            })
        ));
        assert!(matches!(
            read[1],
            Err(ParseError {
                kind: ParseErrorKind::Unexpected {
                    found: Found::Char(';'),
                    ..
                },
                ..
            })
        ));
        assert_eq!(read[2], Ok(Instruction::Select { station: 1 }));
    }

    /// A refused operand names its instruction's index, so a unit can say which row or
    /// parameter it refused (`QT[3]=0;` → ER `[0x33, 0x27, 3]`).
    #[test]
    fn an_operand_out_of_range_carries_its_index() {
        let index_of = |text: &[u8]| match InstructionReader::new().push(text).next() {
            Some(Err(ParseError {
                kind: ParseErrorKind::OutOfRange(error),
                ..
            })) => Some((error.field, error.index)),
            _ => None,
        };
        let operand = |mnemonic| Field::Operand(mnemonic);
        assert_eq!(
            index_of(b"QT[3]=0;"),
            Some((operand(Mnemonic::QT), Some(3)))
        );
        assert_eq!(
            index_of(b"qt [ 200 ] 256;"),
            Some((operand(Mnemonic::QT), Some(200)))
        );
        assert_eq!(
            index_of(b"MP[1]=256;"),
            Some((operand(Mnemonic::MP), Some(1)))
        );
        assert_eq!(
            index_of(b"IE[5]=2;"),
            Some((operand(Mnemonic::IE), Some(5)))
        );
        assert_eq!(index_of(b"PV=256;"), Some((operand(Mnemonic::PV), None)));
        assert_eq!(
            index_of(b"MP[7]=1;"),
            Some((Field::Index(Mnemonic::MP), None)),
            "an index out of range is the value itself"
        );
        assert_eq!(index_of(b"*128;"), Some((Field::Station, None)));
    }

    #[test]
    fn the_reader_reads_byte_by_byte() {
        let mut reader = InstructionReader::new();
        let mut read = Vec::new();
        for &byte in b"SN[7]=305419896;MO" {
            read.extend(reader.push_byte(byte));
        }
        assert_eq!(
            read,
            [Ok(Instruction::SetStation {
                station: 7,
                serial: 305_419_896
            })]
        );
        assert_eq!(reader.pending(), 2);
    }
}
