//! The MBOX motion controller's UDP protocol (the vendor's Chinese protocol document is
//! the authority; `docs/protocol-notes.md` §7 says what we took from it): every
//! datagram the document defines, typed, with its big-endian encoder and its decoder.
//! No sockets here: bytes in, bytes out.
//!
//! An MBOX drives 3, 6 or 10 axes from UDP datagrams sent to its port [`BOX_PORT`]
//! (from the host's [`HOST_PORT`]). Every datagram starts `55 AA | 00 00 | function(2) |
//! channel(2) | receiver(2) | replier(2)`:
//!
//! - [`MotionFrame`] (`0x1301` absolute time code, `0x1401` relative time): sequence,
//!   time, one position per axis in pulses, 12 digital and 2 analog outputs
//!   ([`motion`]).
//! - [`RegisterRead`] (`0x1101`), its reply [`RegisterReply`] (`0x1102`) and
//!   [`RegisterWrite`] (`0x1201`), with the document's named operations as
//!   constructors: [`RegisterWrite::estop`], [`RegisterWrite::release_estop`],
//!   [`RegisterWrite::reset`], [`RegisterWrite::effects`], [`RegisterWrite::set_ip`]
//!   ([`register`]).
//! - [`Datagram`] is any of them. [`Encode`] writes each; [`Datagram::decode`] refuses
//!   what the document makes invalid with a [`DecodeError`] that says what is wrong,
//!   and whatever it accepts encodes back to the same bytes.
//!
//! - [`console`]: the operator's console language for register operations
//!   (`read FN 0x20 4`, `estop`, `@15.201 ip 192.168.15.210`), parsed to these
//!   datagrams with line and column on every mistake, printed back canonically, and
//!   the boxes' replies as text.
//! - [`twin`]: a simulated box (the digital twin) built on the codec: datagrams and
//!   time in, replies out, axes moving in between.
//!
//! Where the summary and the original differ, and what the document leaves open, is in
//! `docs/protocol-notes.md`, "MBOX (UDP)".
//!
//! # Example
//! ```
//! use floatball_shared::mbox::{
//!     AxisPositions, Datagram, DigitalOutputs, Encode, MotionFrame, RegisterWrite, Route,
//!     TimeCode, TimeMode,
//! };
//!
//! // The document's 3-axis relative vector: 100 ms, every axis at 50 000 pulses.
//! let frame = MotionFrame {
//!     mode: TimeMode::Relative,
//!     route: Route::BROADCAST,
//!     sequence: 1,
//!     time_code: TimeCode::from_ms(100),
//!     positions_pulses: AxisPositions::Three([50_000; 3]),
//!     digital: DigitalOutputs::from_bits(0x1234),
//!     analog: [0x5678, 0xABCD],
//! };
//! let wire = frame.encode();
//! assert_eq!(&wire[..8], [0x55, 0xAA, 0x00, 0x00, 0x14, 0x01, 0x00, 0x00]);
//! assert_eq!(Datagram::decode(&wire), Ok(Datagram::Motion(frame)));
//!
//! // E-stop to every box.
//! let estop = RegisterWrite::estop(Route::BROADCAST).encode();
//! assert_eq!(estop[12..], [0x00, 0x90, 0x00, 0x01, 0x00, 0x01]);
//! ```

pub mod console;
pub mod drive;
mod error;
pub mod motion;
pub mod pace;
pub mod player;
pub mod register;
#[cfg(test)]
mod tests;
pub mod twin;

use std::fmt;
use std::net::Ipv4Addr;

pub use error::{DecodeError, OutputError, PositionsError, RangeError};
pub use motion::{AxisCount, AxisPositions, DigitalOutputs, MotionFrame, TimeCode, TimeMode};
pub use register::{
    Bank, MAX_REGISTERS, ReadBank, RegisterBlock, RegisterRange, RegisterRead, RegisterReply,
    RegisterWrite, Registers, WriteBank,
};

/// The UDP port an MBOX listens on (factory default; configurable on the box).
pub const BOX_PORT: u16 = 7408;
/// The UDP port the host sends from (factory default; configurable on the box).
pub const HOST_PORT: u16 = 8410;
/// An MBOX's factory IP address.
pub const FACTORY_IP: Ipv4Addr = Ipv4Addr::new(192, 168, 15, 201);

/// The verification code every datagram starts with.
pub const MAGIC: u16 = 0x55AA;
/// The pass code after it, always zero.
pub const PASS_CODE: u16 = 0x0000;
/// The bytes every datagram shares: magic, pass code, function, channel, receiver,
/// replier.
pub const COMMON_HEADER_LEN: usize = 12;

/// A datagram's function code (bytes 4–5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Function {
    /// `0x1301`: a motion frame with an absolute time code.
    MotionAbsolute,
    /// `0x1401`: a motion frame with a relative time.
    MotionRelative,
    /// `0x1101`: read registers.
    Read,
    /// `0x1102`: the box's reply to a read.
    ReadReply,
    /// `0x1201`: write registers.
    Write,
}

impl Function {
    /// Every function, in the document's order.
    pub const ALL: [Self; 5] = [
        Self::MotionAbsolute,
        Self::MotionRelative,
        Self::Read,
        Self::ReadReply,
        Self::Write,
    ];

    /// The code on the wire.
    #[must_use]
    pub const fn code(self) -> u16 {
        match self {
            Self::MotionAbsolute => 0x1301,
            Self::MotionRelative => 0x1401,
            Self::Read => 0x1101,
            Self::ReadReply => 0x1102,
            Self::Write => 0x1201,
        }
    }

    /// The function of a code, if the document defines it.
    #[must_use]
    pub fn from_code(code: u16) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|function| function.code() == code)
    }

    /// The channels this function takes, for error messages.
    #[must_use]
    pub const fn channels(self) -> &'static str {
        match self {
            Self::MotionAbsolute | Self::MotionRelative => "0 (3 axes), 1 (6 axes) or 2 (10 axes)",
            Self::Read | Self::ReadReply => "0 (DN parameters) or 1 (FN parameters)",
            Self::Write => "0 (FN, not saved), 1 (FN, saved) or 2 (CX command registers)",
        }
    }
}

impl fmt::Display for Function {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = match self {
            Self::MotionAbsolute => "absolute-time motion frame",
            Self::MotionRelative => "relative-time motion frame",
            Self::Read => "register read",
            Self::ReadReply => "register read reply",
            Self::Write => "register write",
        };
        write!(f, "{name} (0x{:04X})", self.code())
    }
}

/// A box's address in a datagram: the last two octets of its IP address
/// (192.168.15.201 → `0x0FC9`), or one of the special values [`Self::ALL`] and
/// [`Self::NO_REPLY`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct BoxAddress(pub u16);

impl BoxAddress {
    /// `0xFFFF`: every box (as receiver: every box executes; as replier: every box
    /// replies).
    pub const ALL: Self = Self(0xFFFF);
    /// `0x0000` as replier: no box replies. Boxes' replies carry it in both fields.
    pub const NO_REPLY: Self = Self(0x0000);

    /// The box whose IP address ends in `third.fourth`.
    #[must_use]
    pub const fn from_octets(third: u8, fourth: u8) -> Self {
        Self(u16::from_be_bytes([third, fourth]))
    }

    /// The box at `ip` (its last two octets).
    #[must_use]
    pub const fn of_ip(ip: Ipv4Addr) -> Self {
        let [_, _, third, fourth] = ip.octets();
        Self::from_octets(third, fourth)
    }

    /// The last two octets this address stands for.
    #[must_use]
    pub const fn octets(self) -> [u8; 2] {
        self.0.to_be_bytes()
    }
}

/// Who executes a datagram and who replies to it (bytes 8–11).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Route {
    /// The box that executes it, or [`BoxAddress::ALL`].
    pub receiver: BoxAddress,
    /// The box that replies, [`BoxAddress::ALL`] or [`BoxAddress::NO_REPLY`].
    pub replier: BoxAddress,
}

impl Route {
    /// Every box executes and every box replies (`FF FF FF FF`, the document's vectors).
    pub const BROADCAST: Self = Self {
        receiver: BoxAddress::ALL,
        replier: BoxAddress::ALL,
    };
    /// Every box executes, none replies.
    pub const BROADCAST_SILENT: Self = Self {
        receiver: BoxAddress::ALL,
        replier: BoxAddress::NO_REPLY,
    };
    /// The route of a box's reply (`00 00 00 00`, the document's read reply).
    pub const REPLY: Self = Self {
        receiver: BoxAddress::NO_REPLY,
        replier: BoxAddress::NO_REPLY,
    };

    /// `address` executes and replies.
    #[must_use]
    pub const fn to(address: BoxAddress) -> Self {
        Self {
            receiver: address,
            replier: address,
        }
    }

    /// `address` executes and does not reply.
    #[must_use]
    pub const fn silent(address: BoxAddress) -> Self {
        Self {
            receiver: address,
            replier: BoxAddress::NO_REPLY,
        }
    }
}

/// A datagram's bytes: implemented by every datagram type and by [`Datagram`].
pub trait Encode {
    /// Its length on the wire.
    fn encoded_len(&self) -> usize;

    /// Appends its bytes to `out`.
    fn encode_into(&self, out: &mut Vec<u8>);

    /// Its bytes.
    fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.encoded_len());
        self.encode_into(&mut out);
        out
    }
}

/// Any datagram of the protocol.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum Datagram {
    /// `0x1301` or `0x1401`.
    Motion(MotionFrame),
    /// `0x1101`.
    Read(RegisterRead),
    /// `0x1102`.
    ReadReply(RegisterReply),
    /// `0x1201`.
    Write(RegisterWrite),
}

impl Datagram {
    /// Decodes one whole UDP datagram.
    ///
    /// # Errors
    /// A [`DecodeError`] for anything the document makes invalid: too short, wrong magic
    /// or pass code, an unknown function or channel, a length that does not match the
    /// axis or register count, an empty or overflowing register range.
    pub fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let header = Header::decode(bytes)?;
        Ok(match header.function {
            Function::MotionAbsolute | Function::MotionRelative => {
                Self::Motion(MotionFrame::decode_body(&header, bytes)?)
            }
            Function::Read => Self::Read(RegisterRead::decode_body(&header, bytes)?),
            Function::ReadReply => Self::ReadReply(RegisterReply::decode_body(&header, bytes)?),
            Function::Write => Self::Write(RegisterWrite::decode_body(&header, bytes)?),
        })
    }

    /// The datagram's function.
    #[must_use]
    pub fn function(&self) -> Function {
        match self {
            Self::Motion(frame) => frame.mode.function(),
            Self::Read(_) => Function::Read,
            Self::ReadReply(_) => Function::ReadReply,
            Self::Write(_) => Function::Write,
        }
    }
}

impl Encode for Datagram {
    fn encoded_len(&self) -> usize {
        match self {
            Self::Motion(frame) => frame.encoded_len(),
            Self::Read(read) => read.encoded_len(),
            Self::ReadReply(reply) => reply.encoded_len(),
            Self::Write(write) => write.encoded_len(),
        }
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        match self {
            Self::Motion(frame) => frame.encode_into(out),
            Self::Read(read) => read.encode_into(out),
            Self::ReadReply(reply) => reply.encode_into(out),
            Self::Write(write) => write.encode_into(out),
        }
    }
}

/// The fields every datagram starts with, read and checked.
#[derive(Debug, Clone, Copy)]
struct Header {
    function: Function,
    channel: u16,
    route: Route,
}

impl Header {
    fn decode(bytes: &[u8]) -> Result<Self, DecodeError> {
        let at = |offset: usize| be_u16(bytes, offset);
        let truncated = DecodeError::Truncated {
            len: bytes.len(),
            needed: COMMON_HEADER_LEN,
            part: "the common header",
        };
        if let Some(found) = at(0).filter(|&magic| magic != MAGIC) {
            return Err(DecodeError::BadMagic { found });
        }
        if let Some(found) = at(2).filter(|&pass| pass != PASS_CODE) {
            return Err(DecodeError::BadPassCode { found });
        }
        let Some(code) = at(4) else {
            return Err(truncated);
        };
        let function = Function::from_code(code).ok_or(DecodeError::UnknownFunction { code })?;
        let (Some(channel), Some(receiver), Some(replier)) = (at(6), at(8), at(10)) else {
            return Err(truncated);
        };
        Ok(Self {
            function,
            channel,
            route: Route {
                receiver: BoxAddress(receiver),
                replier: BoxAddress(replier),
            },
        })
    }

    fn unknown_channel(&self) -> DecodeError {
        DecodeError::UnknownChannel {
            function: self.function,
            channel: self.channel,
        }
    }
}

/// Writes the common header.
fn encode_header(out: &mut Vec<u8>, function: Function, channel: u16, route: Route) {
    for field in [
        MAGIC,
        PASS_CODE,
        function.code(),
        channel,
        route.receiver.0,
        route.replier.0,
    ] {
        out.extend_from_slice(&field.to_be_bytes());
    }
}

/// The big-endian `u16` at `offset`, if the bytes reach that far.
fn be_u16(bytes: &[u8], offset: usize) -> Option<u16> {
    let pair = bytes.get(offset..offset.checked_add(2)?)?;
    Some(u16::from_be_bytes([*pair.first()?, *pair.get(1)?]))
}

/// The big-endian `u32` at `offset`, if the bytes reach that far.
fn be_u32(bytes: &[u8], offset: usize) -> Option<u32> {
    let high = be_u16(bytes, offset)?;
    let low = be_u16(bytes, offset.checked_add(2)?)?;
    Some(u32::from(high) << 16 | u32::from(low))
}
