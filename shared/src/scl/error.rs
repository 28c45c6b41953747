//! Why a command line, an answer or an eSCL datagram is refused.

use thiserror::Error;

use crate::codes::{Code, Coded, Params};
use crate::params;

/// Why a line of SCL text is refused, and where: 1-based line and column (in
/// characters) of the first character that is wrong.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Error)]
#[error("line {line}, column {column}: {kind}")]
pub struct ParseError {
    /// The line, from 1.
    pub line: u32,
    /// The column, from 1, in characters; one past the end when something is missing.
    pub column: u32,
    /// What is wrong there.
    pub kind: ParseErrorKind,
}

/// What is wrong in a refused line.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Error)]
pub enum ParseErrorKind {
    /// A character SCL does not use: not printable ASCII.
    #[error("{found:?} is not printable ASCII; SCL is plain ASCII text")]
    NotAscii {
        /// The character.
        found: char,
    },
    /// The line ends where a command's mnemonic should start.
    #[error("expected a command (two capital letters, such as FL or DI) after the address")]
    MissingMnemonic,
    /// A mnemonic this codec does not know.
    #[error(
        "unknown command {mnemonic:?}; mnemonics are upper case (FL, FP, FS, DI, VE, AC, DE, …)"
    )]
    UnknownMnemonic {
        /// The characters read as the mnemonic.
        mnemonic: String,
    },
    /// A character that cannot be an RS-485 address before a command or an answer.
    #[error(
        "{found:?} cannot be an RS-485 address: an address is a digit or one of \" # $ & ' ( ) + , - . / : ; < = >"
    )]
    BadAddress {
        /// The character.
        found: char,
    },
    /// The command needs a parameter here and the line ends.
    #[error("{mnemonic} needs {expected} here")]
    MissingParameter {
        /// The command.
        mnemonic: &'static str,
        /// What it needs, in words.
        expected: &'static str,
    },
    /// A parameter that does not fit the command.
    #[error("{mnemonic}: expected {expected}, found {found:?}")]
    BadParameter {
        /// The command.
        mnemonic: &'static str,
        /// What it takes, in words.
        expected: &'static str,
        /// The offending text.
        found: String,
    },
    /// A number out of the parameter's range.
    #[error("{mnemonic}: {found} is out of range ({range})")]
    OutOfRange {
        /// The command.
        mnemonic: &'static str,
        /// The range it takes, in words.
        range: &'static str,
        /// The offending text.
        found: String,
    },
    /// Characters after a complete command.
    #[error("unexpected {found:?} after a complete {mnemonic} command")]
    Trailing {
        /// The command.
        mnemonic: &'static str,
        /// The rest of the line.
        found: String,
    },
    /// A queue upload whose number of lines is not the one its header announces.
    #[error("queue upload: the header announces {announced} lines, {found} follow")]
    UploadLength {
        /// The lines announced (the header's number − 1).
        announced: usize,
        /// The lines found.
        found: usize,
    },
    /// An answer that is none of `%`, `*`, `?code` or `XX=value`.
    #[error("not a drive answer: expected %, *, ? (with its code) or a reply such as IP=1000")]
    BadAnswer,
}

/// Why an eSCL datagram is refused.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Error)]
pub enum EsclError {
    /// Shorter than the two-byte header and the carriage return.
    #[error(
        "eSCL datagram of {len} bytes: it needs the 2-byte header, the SCL text and a carriage return"
    )]
    Truncated {
        /// The datagram's length.
        len: usize,
    },
    /// The first two bytes are not `00 07`.
    #[error("not eSCL: the datagram starts {found:02X?}, not the header [00, 07]")]
    BadHeader {
        /// The first two bytes.
        found: [u8; 2],
    },
    /// The SCL text does not end with a carriage return, holds another one, or has
    /// spaces around the command.
    #[error(
        "eSCL datagram whose SCL text is not exactly one command ended by a carriage return (no spaces around it)"
    )]
    NotOneLine,
    /// The SCL text is refused.
    #[error("eSCL datagram: {0}")]
    Text(#[from] ParseError),
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
            Self::NotAscii { .. } => Code::SclNotAscii,
            Self::MissingMnemonic => Code::SclMissingMnemonic,
            Self::UnknownMnemonic { .. } => Code::SclUnknownMnemonic,
            Self::BadAddress { .. } => Code::SclBadAddress,
            Self::MissingParameter { .. } => Code::SclMissingParameter,
            Self::BadParameter { .. } => Code::SclBadParameter,
            Self::OutOfRange { .. } => Code::SclOutOfRange,
            Self::Trailing { .. } => Code::SclTrailing,
            Self::UploadLength { .. } => Code::SclUploadLength,
            Self::BadAnswer => Code::SclBadAnswer,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::NotAscii { found } | Self::BadAddress { found } => {
                params! {"found" => found.escape_debug()}
            }
            Self::MissingMnemonic | Self::BadAnswer => Params::new(),
            Self::UnknownMnemonic { mnemonic } => params! {"mnemonic" => mnemonic},
            Self::MissingParameter { mnemonic, expected } => {
                params! {"mnemonic" => mnemonic, "expected" => expected}
            }
            Self::BadParameter {
                mnemonic,
                expected,
                found,
            } => params! {"mnemonic" => mnemonic, "expected" => expected, "found" => found},
            Self::OutOfRange {
                mnemonic,
                range,
                found,
            } => params! {"mnemonic" => mnemonic, "range" => range, "found" => found},
            Self::Trailing { mnemonic, found } => {
                params! {"mnemonic" => mnemonic, "found" => found}
            }
            Self::UploadLength { announced, found } => {
                params! {"announced" => announced, "found" => found}
            }
        }
    }
}
