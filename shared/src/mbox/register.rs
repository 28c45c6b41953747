//! Register datagrams: read (`0x1101`), the box's reply (`0x1102`) and write
//! (`0x1201`), and the document's named operations (e-stop, its release, reset,
//! effects, the box's IP address).
//!
//! `55 AA | 00 00 | function | channel | receiver | replier | start(2) | count(2) |
//! values(2 × count)`; a read carries no values. Every register is 16 bits. Register
//! numbers are hexadecimal in the document's names: FN020 is address `0x0020`, DN1F
//! is `0x001F`.

use std::net::Ipv4Addr;

use super::error::{DecodeError, RangeError};
use super::{COMMON_HEADER_LEN, Encode, Function, Header, Route, be_u16, encode_header};

/// The bytes before the values: the common header, start and count.
pub const REGISTER_HEADER_LEN: usize = COMMON_HEADER_LEN + 4;
/// The most registers one datagram carries: a write or reply of this many fills one
/// IPv4 UDP datagram (65 507 bytes of payload).
pub const MAX_REGISTERS: usize = (65_507 - REGISTER_HEADER_LEN) / 2;

/// FN `0x0090`: emergency stop (1 = stopped, 0 = released).
pub const FN_ESTOP: u16 = 0x0090;
/// FN020–FN023: the box's IP address, one octet a register.
pub const FN_IP: u16 = 0x0020;
/// CX 0: play control (0 = reset).
pub const CX_PLAY_CONTROL: u16 = 0;
/// CX 1: effects (a bit mask; `0xFFFF` all on).
pub const CX_EFFECTS: u16 = 1;

/// The registers a datagram addresses: its channel, read ([`ReadBank`]) or written
/// ([`WriteBank`]).
pub trait Bank: Copy + Eq + Sized + 'static {
    /// The function of the datagrams that carry values of this bank: the read reply
    /// or the write.
    const FUNCTION: Function;
    /// Every bank of this kind.
    const ALL: &[Self];

    /// The channel on the wire.
    fn channel(self) -> u16;

    /// The bank of a channel, if the function takes it.
    fn from_channel(channel: u16) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|bank| bank.channel() == channel)
    }
}

/// The bank of a datagram whose common header is read.
fn bank_of<B: Bank>(header: &Header) -> Result<B, DecodeError> {
    B::from_channel(header.channel).ok_or(header.unknown_channel())
}

/// Which parameters a read asks for, or a reply carries (the channel of `0x1101` and
/// `0x1102`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ReadBank {
    /// Channel 0: DN parameters.
    Dn,
    /// Channel 1: FN parameters.
    Fn,
}

impl Bank for ReadBank {
    const FUNCTION: Function = Function::ReadReply;
    const ALL: &[Self] = &[Self::Dn, Self::Fn];

    fn channel(self) -> u16 {
        match self {
            Self::Dn => 0,
            Self::Fn => 1,
        }
    }
}

/// Which registers a write changes (the channel of `0x1201`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum WriteBank {
    /// Channel 0: FN parameters, changed until the box restarts (not saved).
    FnVolatile,
    /// Channel 1: FN parameters, changed and saved.
    FnSaved,
    /// Channel 2: CX command registers.
    Cx,
}

impl Bank for WriteBank {
    const FUNCTION: Function = Function::Write;
    const ALL: &[Self] = &[Self::FnVolatile, Self::FnSaved, Self::Cx];

    fn channel(self) -> u16 {
        match self {
            Self::FnVolatile => 0,
            Self::FnSaved => 1,
            Self::Cx => 2,
        }
    }
}

/// Consecutive register addresses: at least one, at most [`MAX_REGISTERS`], none past
/// `0xFFFF`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RegisterRange {
    start: u16,
    count: u16,
}

impl RegisterRange {
    /// `count` registers from `start`.
    ///
    /// # Errors
    /// [`RangeError`] for no registers, more than [`MAX_REGISTERS`], or a range that
    /// runs past `0xFFFF`.
    pub fn new(start: u16, count: usize) -> Result<Self, RangeError> {
        if count == 0 {
            return Err(RangeError::Empty);
        }
        if count > MAX_REGISTERS {
            return Err(RangeError::TooMany { count });
        }
        if usize::from(start) + count - 1 > usize::from(u16::MAX) {
            return Err(RangeError::PastEnd { start, count });
        }
        let count = u16::try_from(count).map_err(|_| RangeError::TooMany { count })?;
        Ok(Self { start, count })
    }

    /// The first address.
    #[must_use]
    pub const fn start(self) -> u16 {
        self.start
    }

    /// How many registers.
    #[must_use]
    pub const fn count(self) -> u16 {
        self.count
    }

    fn encode_into(self, out: &mut Vec<u8>) {
        out.extend_from_slice(&self.start.to_be_bytes());
        out.extend_from_slice(&self.count.to_be_bytes());
    }

    /// The start and count of a register datagram whose common header is read, and the
    /// datagram's expected length when it carries `values`.
    fn decode(header: &Header, bytes: &[u8], values: bool) -> Result<Self, DecodeError> {
        let (Some(start), Some(count)) = (
            be_u16(bytes, COMMON_HEADER_LEN),
            be_u16(bytes, COMMON_HEADER_LEN + 2),
        ) else {
            return Err(DecodeError::Truncated {
                len: bytes.len(),
                needed: REGISTER_HEADER_LEN,
                part: "a register datagram's start and count",
            });
        };
        let range =
            Self::new(start, usize::from(count)).map_err(|source| DecodeError::Registers {
                function: header.function,
                source,
            })?;
        let expected = REGISTER_HEADER_LEN + if values { 2 * usize::from(count) } else { 0 };
        if bytes.len() != expected {
            return Err(DecodeError::RegisterLength {
                function: header.function,
                count,
                len: bytes.len(),
                expected,
            });
        }
        Ok(range)
    }
}

/// Values of consecutive registers, the first at `start`.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct RegisterBlock {
    start: u16,
    values: Vec<u16>,
}

impl RegisterBlock {
    /// `values` from address `start` on.
    ///
    /// # Errors
    /// [`RangeError`] for no values, more than [`MAX_REGISTERS`], or a block that runs
    /// past address `0xFFFF`.
    pub fn new(start: u16, values: Vec<u16>) -> Result<Self, RangeError> {
        RegisterRange::new(start, values.len())?;
        Ok(Self { start, values })
    }

    /// The first address.
    #[must_use]
    pub const fn start(&self) -> u16 {
        self.start
    }

    /// The values, the first at [`Self::start`].
    #[must_use]
    pub fn values(&self) -> &[u16] {
        &self.values
    }

    /// The value at `address`, if the block holds it.
    #[must_use]
    pub fn get(&self, address: u16) -> Option<u16> {
        let index = address.checked_sub(self.start)?;
        self.values.get(usize::from(index)).copied()
    }

    /// One register: always valid.
    fn one(start: u16, value: u16) -> Self {
        Self {
            start,
            values: vec![value],
        }
    }

    fn encoded_len(&self) -> usize {
        REGISTER_HEADER_LEN + 2 * self.values.len()
    }

    fn encode_into(&self, out: &mut Vec<u8>, function: Function, channel: u16, route: Route) {
        out.reserve(self.encoded_len());
        encode_header(out, function, channel, route);
        out.extend_from_slice(&self.start.to_be_bytes());
        // Valid blocks hold at most MAX_REGISTERS values.
        let count = u16::try_from(self.values.len()).unwrap_or(u16::MAX);
        out.extend_from_slice(&count.to_be_bytes());
        for value in &self.values {
            out.extend_from_slice(&value.to_be_bytes());
        }
    }

    fn decode(header: &Header, bytes: &[u8]) -> Result<Self, DecodeError> {
        let range = RegisterRange::decode(header, bytes, true)?;
        let values = (0..usize::from(range.count))
            .map(|index| be_u16(bytes, REGISTER_HEADER_LEN + 2 * index))
            .collect::<Option<Vec<u16>>>()
            .ok_or(DecodeError::Truncated {
                len: bytes.len(),
                needed: REGISTER_HEADER_LEN + 2 * usize::from(range.count),
                part: "the register values",
            })?;
        Ok(Self {
            start: range.start,
            values,
        })
    }
}

/// A request to read registers (`0x1101`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct RegisterRead {
    /// DN or FN parameters.
    pub bank: ReadBank,
    /// Who answers.
    pub route: Route,
    /// Which registers.
    pub range: RegisterRange,
}

impl RegisterRead {
    pub(super) fn decode_body(header: &Header, bytes: &[u8]) -> Result<Self, DecodeError> {
        Ok(Self {
            bank: bank_of(header)?,
            route: header.route,
            range: RegisterRange::decode(header, bytes, false)?,
        })
    }
}

impl Encode for RegisterRead {
    /// 16 bytes.
    fn encoded_len(&self) -> usize {
        REGISTER_HEADER_LEN
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        encode_header(out, Function::Read, self.bank.channel(), self.route);
        self.range.encode_into(out);
    }
}

/// Values of consecutive registers in a bank: a box's answer to a read
/// ([`RegisterReply`], `0x1102`) or a write ([`RegisterWrite`], `0x1201`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct Registers<B> {
    /// Which registers: DN or FN for a reply; FN (saved or not) or CX for a write.
    pub bank: B,
    /// Who executes it and who replies ([`Route::REPLY`] in the box's replies).
    pub route: Route,
    /// The registers and their values.
    pub block: RegisterBlock,
}

/// A box's answer to a read (`0x1102`): the values of the registers asked for.
pub type RegisterReply = Registers<ReadBank>;

/// A write of consecutive registers (`0x1201`).
pub type RegisterWrite = Registers<WriteBank>;

impl<B: Bank> Registers<B> {
    pub(super) fn decode_body(header: &Header, bytes: &[u8]) -> Result<Self, DecodeError> {
        Ok(Self {
            bank: bank_of(header)?,
            route: header.route,
            block: RegisterBlock::decode(header, bytes)?,
        })
    }
}

impl<B: Bank> Encode for Registers<B> {
    /// 16 bytes and 2 a register.
    fn encoded_len(&self) -> usize {
        self.block.encoded_len()
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        let channel = self.bank.channel();
        self.block
            .encode_into(out, B::FUNCTION, channel, self.route);
    }
}

impl RegisterWrite {
    /// Emergency stop: FN `0x0090` = 1, not saved.
    #[must_use]
    pub fn estop(route: Route) -> Self {
        Self::one(WriteBank::FnVolatile, route, FN_ESTOP, 1)
    }

    /// Whether it is the emergency stop ([`RegisterWrite::estop`]) to its route.
    #[must_use]
    pub fn is_estop(&self) -> bool {
        *self == Self::estop(self.route)
    }

    /// Release of the emergency stop: FN `0x0090` = 0, not saved.
    #[must_use]
    pub fn release_estop(route: Route) -> Self {
        Self::one(WriteBank::FnVolatile, route, FN_ESTOP, 0)
    }

    /// Reset: CX 0 (play control) = 0.
    #[must_use]
    pub fn reset(route: Route) -> Self {
        Self::one(WriteBank::Cx, route, CX_PLAY_CONTROL, 0)
    }

    /// Effects: CX 1 = `mask` (`0xFFFF`: all on).
    #[must_use]
    pub fn effects(route: Route, mask: u16) -> Self {
        Self::one(WriteBank::Cx, route, CX_EFFECTS, mask)
    }

    /// A new IP address for the box: FN020–FN023 = its four octets, saved (as in the
    /// document's example). The box answers at the new address from then on.
    #[must_use]
    pub fn set_ip(route: Route, ip: Ipv4Addr) -> Self {
        Self {
            bank: WriteBank::FnSaved,
            route,
            block: RegisterBlock {
                start: FN_IP,
                values: ip.octets().map(u16::from).to_vec(),
            },
        }
    }

    fn one(bank: WriteBank, route: Route, address: u16, value: u16) -> Self {
        Self {
            bank,
            route,
            block: RegisterBlock::one(address, value),
        }
    }
}
