//! The drive's answers: `%` executed, `*` buffered, `?` refused (with its code where
//! the drive gives one), and replies to queries, `XX=value`; each after the drive's
//! address when it has one on a shared line.

use std::fmt;

use super::command::Address;

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
