//! Motion frames (`0x1301` absolute time code, `0x1401` relative time): where every
//! axis of a box is to be at the end of the frame, and how long it has to get there.
//!
//! `55 AA | 00 00 | function | channel | receiver | replier | sequence(4) | time(4) |
//! positions(4 × axes) | digital(2) | analog(2 × 2)`: 38 bytes for 3 axes, 50 for 6,
//! 66 for 10.

use std::num::NonZeroU32;

use super::error::{DecodeError, OutputError, PositionsError};
use super::{COMMON_HEADER_LEN, Encode, Function, Header, Route, be_u16, be_u32, encode_header};

/// The bytes before the positions: the common header, sequence and time.
pub const MOTION_HEADER_LEN: usize = COMMON_HEADER_LEN + 8;
/// The bytes after the positions: digital and analog outputs.
pub const OUTPUTS_LEN: usize = 6;
/// How long a box takes over a frame whose time code is 0 (its factory default).
pub const BOX_DEFAULT_FRAME_MS: u32 = 100;

/// How a frame's time field is read (its function code).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeMode {
    /// `0x1301`: the time code is a point on the show's clock (made to match a film);
    /// the frame lasts from the previous frame's time code to this one's.
    Absolute,
    /// `0x1401`: the time field is the frame's duration.
    Relative,
}

impl TimeMode {
    /// The function code of frames in this mode.
    #[must_use]
    pub const fn function(self) -> Function {
        match self {
            Self::Absolute => Function::MotionAbsolute,
            Self::Relative => Function::MotionRelative,
        }
    }
}

/// A frame's time field, in milliseconds: a time code ([`TimeMode::Absolute`]) or a
/// duration ([`TimeMode::Relative`]).
///
/// 0 on the wire is not a time: it tells the box to take its internal default
/// ([`BOX_DEFAULT_FRAME_MS`]) over the frame, in either mode. The document advises
/// against it (its absolute-time vectors use it all the same); it has its own variant,
/// so no computed time can become 0 by accident.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TimeCode {
    /// 0 on the wire: the box's internal frame time.
    BoxDefault,
    /// A time in milliseconds.
    Ms(NonZeroU32),
}

impl TimeCode {
    /// `time_ms`, with 0 read as the document reads it: [`Self::BoxDefault`].
    #[must_use]
    pub const fn from_ms(time_ms: u32) -> Self {
        match NonZeroU32::new(time_ms) {
            Some(ms) => Self::Ms(ms),
            None => Self::BoxDefault,
        }
    }

    /// The value on the wire (0 for [`Self::BoxDefault`]).
    #[must_use]
    pub const fn wire_ms(self) -> u32 {
        match self {
            Self::BoxDefault => 0,
            Self::Ms(ms) => ms.get(),
        }
    }
}

/// How many axes a frame drives (its channel).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AxisCount {
    /// Channel 0: X Y Z.
    Three,
    /// Channel 1: X Y Z U V W.
    Six,
    /// Channel 2: X Y Z U V W A B C D.
    Ten,
}

impl AxisCount {
    /// Every axis count, by channel.
    pub const ALL: [Self; 3] = [Self::Three, Self::Six, Self::Ten];

    /// The channel on the wire.
    #[must_use]
    pub const fn channel(self) -> u16 {
        match self {
            Self::Three => 0,
            Self::Six => 1,
            Self::Ten => 2,
        }
    }

    /// The axis count of a channel, if the document defines it.
    #[must_use]
    pub fn from_channel(channel: u16) -> Option<Self> {
        Self::ALL.into_iter().find(|axes| axes.channel() == channel)
    }

    /// The number of axes.
    #[must_use]
    pub const fn count(self) -> usize {
        match self {
            Self::Three => 3,
            Self::Six => 6,
            Self::Ten => 10,
        }
    }

    /// The axes' names in order (1 = X … 10 = D).
    #[must_use]
    pub const fn names(self) -> &'static str {
        match self {
            Self::Three => "XYZ",
            Self::Six => "XYZUVW",
            Self::Ten => "XYZUVWABCD",
        }
    }

    /// The length of a motion frame with this many axes.
    #[must_use]
    pub const fn frame_len(self) -> usize {
        MOTION_HEADER_LEN + 4 * self.count() + OUTPUTS_LEN
    }
}

/// Every axis's target position, in pulses (factory setting: 10 000 pulses a motor
/// revolution). The document gives only positive positions; negative ones travel as
/// two's complement.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AxisPositions {
    /// Channel 0: X Y Z.
    Three([i32; 3]),
    /// Channel 1: X Y Z U V W.
    Six([i32; 6]),
    /// Channel 2: X Y Z U V W A B C D.
    Ten([i32; 10]),
}

impl AxisPositions {
    /// The positions of `pulses.len()` axes (3, 6 or 10).
    ///
    /// # Errors
    /// [`PositionsError`] for any other number of axes.
    pub fn from_slice(pulses: &[i32]) -> Result<Self, PositionsError> {
        let wrong = PositionsError { axes: pulses.len() };
        Ok(match pulses.len() {
            3 => Self::Three(pulses.try_into().map_err(|_| wrong)?),
            6 => Self::Six(pulses.try_into().map_err(|_| wrong)?),
            10 => Self::Ten(pulses.try_into().map_err(|_| wrong)?),
            _ => return Err(wrong),
        })
    }

    /// Every axis at `pulses`.
    #[must_use]
    pub const fn uniform(axes: AxisCount, pulses: i32) -> Self {
        match axes {
            AxisCount::Three => Self::Three([pulses; 3]),
            AxisCount::Six => Self::Six([pulses; 6]),
            AxisCount::Ten => Self::Ten([pulses; 10]),
        }
    }

    /// How many axes.
    #[must_use]
    pub const fn axes(&self) -> AxisCount {
        match self {
            Self::Three(_) => AxisCount::Three,
            Self::Six(_) => AxisCount::Six,
            Self::Ten(_) => AxisCount::Ten,
        }
    }

    /// The positions, axis 1 first.
    #[must_use]
    pub fn as_slice(&self) -> &[i32] {
        match self {
            Self::Three(pulses) => pulses,
            Self::Six(pulses) => pulses,
            Self::Ten(pulses) => pulses,
        }
    }

    fn decode(axes: AxisCount, bytes: &[u8]) -> Option<Self> {
        fn read<const N: usize>(bytes: &[u8]) -> Option<[i32; N]> {
            let mut pulses = [0; N];
            for (axis, slot) in pulses.iter_mut().enumerate() {
                *slot = be_u32(bytes, MOTION_HEADER_LEN + 4 * axis)?.cast_signed();
            }
            Some(pulses)
        }
        Some(match axes {
            AxisCount::Three => Self::Three(read(bytes)?),
            AxisCount::Six => Self::Six(read(bytes)?),
            AxisCount::Ten => Self::Ten(read(bytes)?),
        })
    }
}

/// The 12 digital outputs ("effects"), bit 0 = output 1 … bit 11 = output 12.
///
/// Bits 12–15 are reserved. They are kept as received, because the document's own
/// vectors send `0x1234` (bit 12 set); [`Self::with_output`] never sets them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct DigitalOutputs(u16);

impl DigitalOutputs {
    /// The number of outputs.
    pub const COUNT: u8 = 12;
    /// The bits of the outputs; the rest are reserved.
    pub const OUTPUT_BITS: u16 = 0x0FFF;
    /// Every output off.
    pub const NONE: Self = Self(0);
    /// Every output on.
    pub const ALL: Self = Self(Self::OUTPUT_BITS);

    /// The 16 bits on the wire, reserved bits included.
    #[must_use]
    pub const fn from_bits(bits: u16) -> Self {
        Self(bits)
    }

    /// The 16 bits on the wire.
    #[must_use]
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// The reserved bits 12–15 (0 in everything Floatball builds).
    #[must_use]
    pub const fn reserved_bits(self) -> u16 {
        self.0 & !Self::OUTPUT_BITS
    }

    /// These outputs with output `output` (1–12) switched `on` or off.
    ///
    /// # Errors
    /// [`OutputError`] for an output outside 1–12.
    pub fn with_output(self, output: u8, on: bool) -> Result<Self, OutputError> {
        let bit = Self::bit(output).ok_or(OutputError { output })?;
        Ok(Self(if on { self.0 | bit } else { self.0 & !bit }))
    }

    /// Whether output `output` (1–12) is on; `false` for any other number.
    #[must_use]
    pub fn is_on(self, output: u8) -> bool {
        Self::bit(output).is_some_and(|bit| self.0 & bit != 0)
    }

    fn bit(output: u8) -> Option<u16> {
        (1..=Self::COUNT)
            .contains(&output)
            .then(|| 1 << (output - 1))
    }
}

/// One motion frame: every axis of the receiving box moves to its position over the
/// frame's time.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct MotionFrame {
    /// Absolute time code or relative time (the function code).
    pub mode: TimeMode,
    /// Who executes the frame and who replies.
    pub route: Route,
    /// The frame's number, for checking only; may be 0.
    pub sequence: u32,
    /// The time code or duration.
    pub time_code: TimeCode,
    /// The axes' targets (their number is the channel).
    pub positions_pulses: AxisPositions,
    /// The 12 digital outputs.
    pub digital: DigitalOutputs,
    /// The two analog outputs, raw (their scale is the box's manual's).
    pub analog: [u16; 2],
}

impl Encode for MotionFrame {
    /// 38, 50 or 66 bytes.
    fn encoded_len(&self) -> usize {
        self.positions_pulses.axes().frame_len()
    }

    fn encode_into(&self, out: &mut Vec<u8>) {
        let axes = self.positions_pulses.axes();
        out.reserve(axes.frame_len());
        encode_header(out, self.mode.function(), axes.channel(), self.route);
        out.extend_from_slice(&self.sequence.to_be_bytes());
        out.extend_from_slice(&self.time_code.wire_ms().to_be_bytes());
        for pulses in self.positions_pulses.as_slice() {
            out.extend_from_slice(&pulses.to_be_bytes());
        }
        for field in [self.digital.bits(), self.analog[0], self.analog[1]] {
            out.extend_from_slice(&field.to_be_bytes());
        }
    }
}

impl MotionFrame {
    /// The rest of a motion frame whose common header is read.
    pub(super) fn decode_body(header: &Header, bytes: &[u8]) -> Result<Self, DecodeError> {
        let mode = match header.function {
            Function::MotionAbsolute => TimeMode::Absolute,
            _ => TimeMode::Relative,
        };
        let axes = AxisCount::from_channel(header.channel).ok_or(header.unknown_channel())?;
        let wrong_length = DecodeError::MotionLength {
            axes: axes.count(),
            channel: header.channel,
            len: bytes.len(),
            expected: axes.frame_len(),
        };
        if bytes.len() != axes.frame_len() {
            return Err(wrong_length);
        }
        let outputs = MOTION_HEADER_LEN + 4 * axes.count();
        let fields = (
            be_u32(bytes, COMMON_HEADER_LEN),
            be_u32(bytes, COMMON_HEADER_LEN + 4),
            AxisPositions::decode(axes, bytes),
            be_u16(bytes, outputs),
            be_u16(bytes, outputs + 2),
            be_u16(bytes, outputs + 4),
        );
        let (
            Some(sequence),
            Some(time_ms),
            Some(positions_pulses),
            Some(digital),
            Some(a0),
            Some(a1),
        ) = fields
        else {
            return Err(wrong_length);
        };
        Ok(Self {
            mode,
            route: header.route,
            sequence,
            time_code: TimeCode::from_ms(time_ms),
            positions_pulses,
            digital: DigitalOutputs::from_bits(digital),
            analog: [a0, a1],
        })
    }
}
