//! Why a datagram, a register range or a set of outputs is refused.

use thiserror::Error;

use super::Function;
use super::register::MAX_REGISTERS;

/// Why [`Datagram::decode`](super::Datagram::decode) refuses a datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Error)]
pub enum DecodeError {
    /// The datagram ends before a field every datagram of its kind has.
    #[error(
        "truncated MBOX datagram: {len} bytes, but {part} needs {needed}; a sender cut it short, or this is not MBOX traffic"
    )]
    Truncated {
        /// The datagram's length.
        len: usize,
        /// The length the missing part needs.
        needed: usize,
        /// What is missing.
        part: &'static str,
    },
    /// The first two bytes are not the verification code `55 AA`.
    #[error(
        "not an MBOX datagram: it starts with 0x{found:04X}, not the verification code 0x55AA; check what else sends to this port"
    )]
    BadMagic {
        /// The first two bytes.
        found: u16,
    },
    /// Bytes 2–3 are not the pass code `00 00`.
    #[error(
        "MBOX datagram with pass code 0x{found:04X}: the protocol's pass code is always 0x0000"
    )]
    BadPassCode {
        /// Bytes 2–3.
        found: u16,
    },
    /// A function code the document does not define.
    #[error(
        "unknown MBOX function code 0x{code:04X}: the document defines 0x1301 and 0x1401 (motion), 0x1101 (read), 0x1102 (read reply) and 0x1201 (write)"
    )]
    UnknownFunction {
        /// Bytes 4–5.
        code: u16,
    },
    /// A channel the function does not take.
    #[error("{function} with channel 0x{channel:04X}: it takes channel {}", function.channels())]
    UnknownChannel {
        /// The function.
        function: Function,
        /// Bytes 6–7.
        channel: u16,
    },
    /// A motion frame whose length does not match its channel's number of axes.
    #[error(
        "{axes}-axis motion frame (channel {channel}) of {len} bytes: it must be exactly {expected} (20 + 4 per axis + 6); the datagram was cut short or the channel does not match the positions sent"
    )]
    MotionLength {
        /// The number of axes the channel says.
        axes: usize,
        /// The channel.
        channel: u16,
        /// The datagram's length.
        len: usize,
        /// The length of a frame with that many axes.
        expected: usize,
    },
    /// A register datagram whose length does not match its register count.
    #[error(
        "{function} for {count} registers is {len} bytes: it must be exactly {expected} (16, and 2 per value carried); the datagram was cut short or the count does not match the values sent"
    )]
    RegisterLength {
        /// The function.
        function: Function,
        /// The register count (bytes 14–15).
        count: u16,
        /// The datagram's length.
        len: usize,
        /// The length the count implies.
        expected: usize,
    },
    /// A register datagram whose start and count name no valid range.
    #[error("{function}: {source}")]
    Registers {
        /// The function.
        function: Function,
        /// What is wrong with the range.
        #[source]
        source: RangeError,
    },
}

/// Why a register range or block is refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Error)]
pub enum RangeError {
    /// No registers at all.
    #[error("no registers: a read or write covers at least one")]
    Empty,
    /// More registers than one UDP datagram carries.
    #[error(
        "{count} registers do not fit one UDP datagram: at most {MAX_REGISTERS}; split the range"
    )]
    TooMany {
        /// How many were asked for.
        count: usize,
    },
    /// A range that runs past the last address.
    #[error("{count} registers from 0x{start:04X} run past the last address 0xFFFF")]
    PastEnd {
        /// The first address.
        start: u16,
        /// How many registers.
        count: usize,
    },
}

/// A number of positions that is no MBOX channel's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Error)]
#[error("{axes} positions: an MBOX motion frame carries 3, 6 or 10 axes")]
pub struct PositionsError {
    /// How many positions were given.
    pub axes: usize,
}

/// A digital output number outside 1–12.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Error)]
#[error("digital output {output} does not exist: an MBOX has outputs 1 to 12")]
pub struct OutputError {
    /// The number given.
    pub output: u8,
}
