//! The drive's answers: `%` executed, `*` buffered, `?` refused (with its code where
//! the drive gives one), and replies to queries, `XX=value`; each after the drive's
//! address when it has one on a shared line; and the lines that follow the `%` of a
//! `QU` (queue upload), [`QueueUpload`].

use std::fmt;

use super::command::{Address, Command, QLine};

/// One answer from a drive.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Answer {
    /// `%`: an immediate command was executed.
    Executed,
    /// `*`: a buffered command was put in the command buffer.
    Buffered,
    /// `?`: the command was refused; `code` is the number after the `?` (`?5`: a
    /// parameter out of range), when the drive sends one.
    Refused {
        /// The error code, if any.
        code: Option<u16>,
    },
    /// `XX=value`: the reply to a query (`IP=-1200`, `SC=0009`, `VE=20.0`).
    Value {
        /// What was asked, as the drive names it (`IP`, `SC`, `RLA`, …).
        name: String,
        /// The value, as sent (decimal, or hexadecimal for codes such as `SC` and `AL`).
        value: String,
    },
}

impl Answer {
    /// The value read as a decimal integer (`IP=-1200` → −1200), if it is one.
    #[must_use]
    pub fn value_i64(&self) -> Option<i64> {
        match self {
            Self::Value { value, .. } => value.parse().ok(),
            _ => None,
        }
    }

    /// The value read as a 16-bit hexadecimal word (`SC=0009`, `AL=0002`), if it is one.
    #[must_use]
    pub fn value_hex_u16(&self) -> Option<u16> {
        match self {
            Self::Value { value, .. } => u16::from_str_radix(value, 16).ok(),
            _ => None,
        }
    }
}

impl fmt::Display for Answer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Executed => f.write_str("%"),
            Self::Buffered => f.write_str("*"),
            Self::Refused { code: None } => f.write_str("?"),
            Self::Refused { code: Some(code) } => write!(f, "?{code}"),
            Self::Value { name, value } => write!(f, "{name}={value}"),
        }
    }
}

/// An answer as received: the drive's address (on a shared RS-485 line), then the
/// answer. Its text is `Display`; [`Reply::to_wire`] adds the carriage return.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Reply {
    /// The drive that answers, if it puts its address first.
    pub address: Option<Address>,
    /// The answer.
    pub answer: Answer,
}

impl Reply {
    /// The bytes on a serial line: the text and a carriage return.
    #[must_use]
    pub fn to_wire(&self) -> Vec<u8> {
        super::wire(self)
    }
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(address) = self.address {
            write!(f, "{address}")?;
        }
        write!(f, "{}", self.answer)
    }
}

/// What a drive sends after the `%` of a `QU` (HCR p. 172): a header line `QU##`, where
/// `##` is the number of lines + 1, then each line of the segment (or the queue); or a
/// header alone that says why there is nothing (`QU0`, `QU-1`, `QU-2`, `QU-3`). On a
/// shared RS-485 line an addressed drive puts its address before every line (the
/// header and each command; Floatball's choice, the reference is silent).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum QueueUpload {
    /// `QU{n + 1}`, then the `n` lines (the queue may hold none: `QU1`).
    Lines(Vec<Command>),
    /// `QU0`: no segment at that location.
    NoSegment,
    /// `QU-1`: a program is running; the drive cannot upload now.
    ProgramRunning,
    /// `QU-2`: an upload is already in process.
    UploadInProgress,
    /// `QU-3`: the segment is password protected.
    PasswordProtected,
}

/// What the header line of a [`QueueUpload`] announces.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UploadHeader {
    /// This many command lines follow (0 to 62).
    Lines(usize),
    /// Nothing follows: the upload is one of the refusals (`QU0`, `QU-1`, …).
    Nothing,
}

impl QueueUpload {
    /// The number after `QU` in the header line.
    #[must_use]
    pub fn header_number(&self) -> i64 {
        match self {
            Self::Lines(lines) => i64::try_from(lines.len()).map_or(i64::MAX, |n| n + 1),
            Self::NoSegment => 0,
            Self::ProgramRunning => -1,
            Self::UploadInProgress => -2,
            Self::PasswordProtected => -3,
        }
    }

    /// The text lines, without carriage returns and addresses: the header, then each
    /// command.
    #[must_use]
    pub fn lines(&self) -> Vec<String> {
        let mut lines = vec![format!("QU{}", self.header_number())];
        if let Self::Lines(commands) = self {
            lines.extend(commands.iter().map(ToString::to_string));
        }
        lines
    }

    /// The bytes after the `%`: each line, after `address` when there is one, ended by
    /// a carriage return.
    #[must_use]
    pub fn to_wire(&self, address: Option<Address>) -> Vec<u8> {
        let mut wire = Vec::new();
        for line in self.lines() {
            if let Some(address) = address {
                wire.extend_from_slice(address.to_string().as_bytes());
            }
            wire.extend_from_slice(line.as_bytes());
            wire.push(super::CR);
        }
        wire
    }

    /// The most command lines a segment holds.
    pub const MAX_LINES: usize = QLine::MAX as usize;
}
