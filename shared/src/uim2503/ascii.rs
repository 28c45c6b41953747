//! The UIM2503 instruction language: the ASCII text a host sends the gateway (manual §6.1,
//! §8; `docs/protocol-notes.md` §1).
//!
//! An instruction is at most [`MAX_LEN`] (20) characters including its final `;`, ASCII
//! 1–127 only, in one of four shapes: `XX=v;`, `XX;`, `XX[i]=v;`, `XX[i];`. `XX` is a
//! two-letter mnemonic (any case); `XXx` marks a hexadecimal operand with an even number
//! of digits; the `=` may be written as `:` or left out. `*N;` selects the station (0 =
//! every unit) that the following instructions go to.
//!
//! - [`Instruction`] is the typed model: the documented instructions with their ranges,
//!   and [`Generic`] for every other two-letter mnemonic.
//! - [`Instruction::encode`] / [`Instruction::encode_into`] write the shortest valid
//!   text, in [`Form::Standard`] (`QP[3]=1000;`) or [`Form::Compact`] (`QP[3]1000;`), and
//!   refuse what the gateway would not take ([`EncodeError`]);
//!   [`Instruction::encoded_len`] says how long that text is without writing it.
//! - [`parse_script`] reads what engineers type: instructions separated by whitespace,
//!   `#` comments, errors with line and column ([`ParseError`]).
//! - [`Batch`] holds encoded instructions on their way to a gateway, remembering where
//!   each one ends (a link writes one at a time so an e-stop can overtake the rest).
//! - [`InstructionReader`] reads raw bytes the way the gateway does: in any chunking,
//!   one `;`-terminated instruction at a time, from a bounded buffer.
//! - [`gateway`]: the gateway's own three-letter commands, the greeting `ABC;` and the
//!   line speed `BDR=x;` ([`Instruction::Gateway`], not unit instructions), and
//!   [`GreetingWatch`], which finds the greeting's answer `AA AB AC` in what the
//!   gateway sends.
//!
//! # Example
//! ```
//! use floatball_shared::uim2503::ascii::{parse_script, Form, Instruction};
//!
//! let script = "*20;      # the unit on station 20\nPV=3; BG;";
//! let instructions = parse_script(script)?;
//! assert_eq!(
//!     instructions,
//!     [
//!         Instruction::Select { station: 20 },
//!         Instruction::PvtStart { row: Some(3) },
//!         Instruction::Begin { at_us: None },
//!     ]
//! );
//!
//! let mut wire = Vec::new();
//! for instruction in &instructions {
//!     instruction.encode_into(Form::Compact, &mut wire)?;
//! }
//! assert_eq!(wire, b"*20;PV3;BG;");
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod batch;
mod encode;
pub mod gateway;
mod parse;
mod reader;

use std::fmt;

pub use batch::Batch;
pub use encode::{EncodeError, Encoded, Form};
pub use gateway::{GatewayCommand, GreetingWatch};
pub use parse::{Expected, Found, Head, ParseError, ParseErrorKind, parse_script};
pub use reader::{InstructionReader, ReadInstructions};

/// The longest instruction the gateway accepts, in characters, including the final `;`.
pub const MAX_LEN: usize = 20;

/// A two-letter instruction mnemonic such as `QP`, always stored in upper case.
#[derive(Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Mnemonic([u8; 2]);

impl Mnemonic {
    /// `BG`, begin motion.
    pub const BG: Self = Self(*b"BG");
    /// `MP[X]`, PVT motion profile parameters.
    pub const MP: Self = Self(*b"MP");
    /// `PV`, PVT mode and start row.
    pub const PV: Self = Self(*b"PV");
    /// `QP[X]`, PVT row position.
    pub const QP: Self = Self(*b"QP");
    /// `QV[X]`, PVT row velocity.
    pub const QV: Self = Self(*b"QV");
    /// `QT[X]`, PVT row duration.
    pub const QT: Self = Self(*b"QT");
    /// `SN` / `SN[X]`, serial number and station assignment.
    pub const SN: Self = Self(*b"SN");
    /// `MO`, motor driver on/off.
    pub const MO: Self = Self(*b"MO");
    /// `SP`, point-to-point speed.
    pub const SP: Self = Self(*b"SP");
    /// `PA`, point-to-point absolute position.
    pub const PA: Self = Self(*b"PA");
    /// `SD`, stop deceleration.
    pub const SD: Self = Self(*b"SD");
    /// `IE[X]`, information (notification) enable.
    pub const IE: Self = Self(*b"IE");

    /// The mnemonics that have their own [`Instruction`] variant; [`Generic`] may not
    /// use them.
    pub const TYPED: [Self; 12] = [
        Self::BG,
        Self::MP,
        Self::PV,
        Self::QP,
        Self::QV,
        Self::QT,
        Self::SN,
        Self::MO,
        Self::SP,
        Self::PA,
        Self::SD,
        Self::IE,
    ];

    /// A mnemonic from two ASCII letters in any case.
    ///
    /// # Errors
    /// [`InvalidMnemonic`] if either byte is not an ASCII letter (this is where the
    /// "ASCII 1–127 only" rule is enforced for generic instructions).
    pub fn new(letters: [u8; 2]) -> Result<Self, InvalidMnemonic> {
        match letters.into_iter().find(|byte| !byte.is_ascii_alphabetic()) {
            Some(byte) => Err(InvalidMnemonic { byte }),
            None => Ok(Self::from_letters(letters[0], letters[1])),
        }
    }

    /// Two bytes already known to be ASCII letters.
    fn from_letters(first: u8, second: u8) -> Self {
        Self([first.to_ascii_uppercase(), second.to_ascii_uppercase()])
    }

    /// The two upper-case letters.
    pub fn letters(self) -> [u8; 2] {
        self.0
    }

    /// Whether this mnemonic has its own [`Instruction`] variant.
    pub fn is_typed(self) -> bool {
        Self::TYPED.contains(&self)
    }
}

impl fmt::Display for Mnemonic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use fmt::Write as _;
        f.write_char(char::from(self.0[0]))?;
        f.write_char(char::from(self.0[1]))
    }
}

impl fmt::Debug for Mnemonic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Mnemonic(\"{self}\")")
    }
}

/// A byte that cannot be part of a mnemonic.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error(
    "byte {byte:#04x} is not an ASCII letter: a mnemonic is two letters A–Z, and the gateway \
     accepts ASCII 1–127 only"
)]
pub struct InvalidMnemonic {
    /// The offending byte.
    pub byte: u8,
}

/// The parameter an `MP[X]` instruction reads or writes (manual §7.2, §8.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MpParam {
    /// `MP[0]=1`: clear every QP/QV/QT row at once.
    Clear,
    /// `MP[1]`: the first row of the sequence (single and loop modes).
    FirstRow,
    /// `MP[2]`: the last row of the sequence (single and loop modes); must exceed `MP[1]`.
    LastRow,
    /// `MP[3]`: the mode, 0 FIFO, 1 single sequence, 3 loop (2 is reserved).
    Mode,
    /// `MP[4]`: reserved.
    Reserved,
    /// `MP[5]`: the watermark (1–254 pending rows, 0 = off) that triggers the RTCN notice.
    Watermark,
    /// `MP[6]`: (query) the row the next write goes to.
    NextWriteRow,
}

impl MpParam {
    /// The index `X` of `MP[X]`.
    pub fn index(self) -> u8 {
        match self {
            Self::Clear => 0,
            Self::FirstRow => 1,
            Self::LastRow => 2,
            Self::Mode => 3,
            Self::Reserved => 4,
            Self::Watermark => 5,
            Self::NextWriteRow => 6,
        }
    }

    /// The parameter at index `X`, if `X` is 0–6.
    pub fn from_index(index: u8) -> Option<Self> {
        Some(match index {
            0 => Self::Clear,
            1 => Self::FirstRow,
            2 => Self::LastRow,
            3 => Self::Mode,
            4 => Self::Reserved,
            5 => Self::Watermark,
            6 => Self::NextWriteRow,
            _ => return None,
        })
    }
}

/// One instruction to the gateway. `None` operands are queries (`PV;`, `QP[3];`): the
/// unit answers with the current value.
///
/// Ranges the Rust types cannot express (station 0–127, `QT` 10–255 ms) are checked by
/// the encoder and the parsers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Instruction {
    /// `*N;`: send the following instructions to station `N` (1–127), or to every unit
    /// when `N` is 0 (global broadcast).
    Select {
        /// The station, 0 = global.
        station: u8,
    },
    /// `BG;` / `BG=N;`: activate the parameters set last and begin motion, at once or
    /// when the unit's system time reaches `N` µs.
    Begin {
        /// The unit's system time to start at.
        at_us: Option<u32>,
    },
    /// `MP[X];` / `MP[X]=N;`: PVT motion profile parameter, `N` 0–255.
    MotionProfile {
        /// Which parameter.
        param: MpParam,
        /// Its new value.
        value: Option<u8>,
    },
    /// `PV;` / `PV=N;`: enter PVT mode; the next `BG` starts at row `N`. The query
    /// answers the water level (FIFO mode) or the row being executed.
    PvtStart {
        /// The row to start at.
        row: Option<u8>,
    },
    /// `QP[X];` / `QP[X]=N;`: the position of PVT row `X`.
    PvtPosition {
        /// The row, 0–255.
        row: u8,
        /// The position at the end of the row.
        position_counts: Option<i32>,
    },
    /// `QV[X];` / `QV[X]=N;`: the velocity of PVT row `X`.
    PvtVelocity {
        /// The row, 0–255.
        row: u8,
        /// The velocity at the end of the row.
        velocity_counts_s: Option<i32>,
    },
    /// `QT[X];` / `QT[X]=N;`: the duration of PVT row `X`, 10–255 ms, never 0. Writing
    /// it raises the water level by one.
    PvtTime {
        /// The row, 0–255.
        row: u8,
        /// The row's duration, 10–255.
        duration_ms: Option<u8>,
    },
    /// `SN;`: ask for the serial number (after `*0;`, every unit answers).
    QuerySerial,
    /// `SN[X]=s/n;`: give the unit whose serial number is `serial` the station `X`.
    SetStation {
        /// The new station, 0–127.
        station: u8,
        /// The serial number of the unit to renumber.
        serial: u64,
    },
    /// `MO;` / `MO=0;` / `MO=1;`: motor driver on or off (off also ends PVT motion).
    Motor {
        /// Whether the driver is on.
        on: Option<bool>,
    },
    /// `SP;` / `SP=v;`: the speed of point-to-point moves.
    PtpSpeed {
        /// The speed.
        speed_counts_s: Option<i32>,
    },
    /// `PA;` / `PA=p;`: the absolute target of the next point-to-point move (then `BG;`).
    PtpPosition {
        /// The target position.
        position_counts: Option<i32>,
    },
    /// `SD;` / `SD=d;`: the deceleration used when motion stops (also at the end of a
    /// PVT run with non-zero velocity).
    StopDecel {
        /// The deceleration.
        decel_counts_s2: Option<u32>,
    },
    /// `IE[X];` / `IE[X]=0;` / `IE[X]=1;`: enable notification `X` (`IE[5]`: the PVT
    /// watermark RTCN).
    InfoEnable {
        /// The notification, 0–255.
        index: u8,
        /// Whether it is enabled.
        enabled: Option<bool>,
    },
    /// Any other two-letter instruction, passed through as written.
    Generic(Generic),
    /// A command for the gateway itself (`ABC;`, `BDR=x;`), not for a unit.
    Gateway(GatewayCommand),
}

/// An instruction without a typed variant: a mnemonic, an optional index and an optional
/// operand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Generic {
    /// The mnemonic; not one of [`Mnemonic::TYPED`].
    pub mnemonic: Mnemonic,
    /// The index of `XX[i]`, 0–255.
    pub index: Option<u8>,
    /// The operand of `XX=v`.
    pub operand: Option<Operand>,
}

/// The operand of a [`Generic`] instruction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Operand {
    /// A decimal number, `XX=-12;`.
    Decimal(i64),
    /// A hexadecimal number, `XXx=0A0B;`, written with the fewest whole bytes.
    Hex(u64),
}

impl Instruction {
    /// Whether the instruction is safe to send while the e-stop is latched: it cannot
    /// switch a motor on, move a ball, load or arm motion rows, or start anything. These
    /// are queries (no value), station selections `*N;`, the serial-number roll call,
    /// and switching the motor driver off. `BG;` has no value but starts motion, so it is
    /// not inert; neither is any untyped instruction (its meaning is not known here).
    pub fn is_inert(&self) -> bool {
        match *self {
            Self::Select { .. } | Self::QuerySerial => true,
            Self::Begin { .. } | Self::SetStation { .. } | Self::Generic(_) => false,
            Self::Motor { on } => on != Some(true),
            Self::MotionProfile { value, .. } => value.is_none(),
            Self::PvtStart { row } => row.is_none(),
            Self::PvtPosition {
                position_counts, ..
            } => position_counts.is_none(),
            Self::PvtVelocity {
                velocity_counts_s, ..
            } => velocity_counts_s.is_none(),
            Self::PvtTime { duration_ms, .. } => duration_ms.is_none(),
            Self::PtpSpeed { speed_counts_s } => speed_counts_s.is_none(),
            Self::PtpPosition { position_counts } => position_counts.is_none(),
            Self::StopDecel { decel_counts_s2 } => decel_counts_s2.is_none(),
            Self::InfoEnable { enabled, .. } => enabled.is_none(),
            Self::Gateway(command) => command.is_inert(),
        }
    }

    /// The two-letter mnemonic, or `None` for [`Instruction::Select`] and the gateway's
    /// three-letter [`Instruction::Gateway`] commands.
    pub fn mnemonic(&self) -> Option<Mnemonic> {
        match self.parts() {
            Parts::Select { .. } | Parts::Gateway { .. } => None,
            Parts::Command { mnemonic, .. } => Some(mnemonic),
        }
    }

    /// The instruction taken apart into what the text is made of.
    fn parts(&self) -> Parts {
        use Number::{Hex, Signed, Unsigned};
        let command = |mnemonic, index, operand| Parts::Command {
            mnemonic,
            index,
            operand,
        };
        match *self {
            Self::Select { station } => Parts::Select { station },
            Self::Begin { at_us } => command(Mnemonic::BG, None, at_us.map(|v| Unsigned(v.into()))),
            Self::MotionProfile { param, value } => command(
                Mnemonic::MP,
                Some(param.index()),
                value.map(|v| Unsigned(v.into())),
            ),
            Self::PvtStart { row } => command(Mnemonic::PV, None, row.map(|v| Unsigned(v.into()))),
            Self::PvtPosition {
                row,
                position_counts,
            } => command(
                Mnemonic::QP,
                Some(row),
                position_counts.map(|v| Signed(v.into())),
            ),
            Self::PvtVelocity {
                row,
                velocity_counts_s,
            } => command(
                Mnemonic::QV,
                Some(row),
                velocity_counts_s.map(|v| Signed(v.into())),
            ),
            Self::PvtTime { row, duration_ms } => command(
                Mnemonic::QT,
                Some(row),
                duration_ms.map(|v| Unsigned(v.into())),
            ),
            Self::QuerySerial => command(Mnemonic::SN, None, None),
            Self::SetStation { station, serial } => {
                command(Mnemonic::SN, Some(station), Some(Unsigned(serial)))
            }
            Self::Motor { on } => command(Mnemonic::MO, None, on.map(|v| Unsigned(v.into()))),
            Self::PtpSpeed { speed_counts_s } => {
                command(Mnemonic::SP, None, speed_counts_s.map(|v| Signed(v.into())))
            }
            Self::PtpPosition { position_counts } => command(
                Mnemonic::PA,
                None,
                position_counts.map(|v| Signed(v.into())),
            ),
            Self::StopDecel { decel_counts_s2 } => command(
                Mnemonic::SD,
                None,
                decel_counts_s2.map(|v| Unsigned(v.into())),
            ),
            Self::InfoEnable { index, enabled } => command(
                Mnemonic::IE,
                Some(index),
                enabled.map(|v| Unsigned(v.into())),
            ),
            Self::Generic(Generic {
                mnemonic,
                index,
                operand,
            }) => command(
                mnemonic,
                index,
                operand.map(|operand| match operand {
                    Operand::Decimal(v) => Signed(v),
                    Operand::Hex(v) => Hex(v),
                }),
            ),
            Self::Gateway(command) => Parts::Gateway {
                letters: command.letters(),
                operand: match command {
                    GatewayCommand::Greet => None,
                    GatewayCommand::SetBaud { baud } => Some(baud),
                },
            },
        }
    }
}

/// What an instruction's text is made of.
enum Parts {
    /// `*N;`
    Select { station: u8 },
    /// `XX[x][[i]][=v];`
    Command {
        mnemonic: Mnemonic,
        index: Option<u8>,
        operand: Option<Number>,
    },
    /// `XXX[=v];`, a command for the gateway itself.
    Gateway {
        letters: [u8; 3],
        operand: Option<u32>,
    },
}

/// An operand as written.
#[derive(Clone, Copy)]
enum Number {
    /// Decimal, may be negative.
    Signed(i64),
    /// Decimal, never negative.
    Unsigned(u64),
    /// Hexadecimal (the mnemonic gets an `x`).
    Hex(u64),
}

/// The part of an instruction a range applies to, for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// The `N` of `*N;`.
    Station,
    /// The index `i` of `XX[i]`.
    Index(Mnemonic),
    /// The operand `v` of `XX=v`.
    Operand(Mnemonic),
    /// The line speed `x` of the gateway's `BDR=x;`.
    Baud,
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Station => f.write_str("the station of `*N;`"),
            Self::Index(Mnemonic::SN) => f.write_str("the new station of SN[X]"),
            Self::Index(mnemonic) => write!(f, "the index of {mnemonic}[X]"),
            Self::Operand(mnemonic) => {
                let (shape, unit) = match mnemonic {
                    Mnemonic::BG => ("", " (µs)"),
                    Mnemonic::QT => ("[X]", " (ms)"),
                    Mnemonic::SN => ("[X]", " (the serial number)"),
                    Mnemonic::MP | Mnemonic::QP | Mnemonic::QV | Mnemonic::IE => ("[X]", ""),
                    _ => ("", ""),
                };
                write!(f, "the operand of {mnemonic}{shape}{unit}")
            }
            Self::Baud => f.write_str("the line speed of BDR (baud)"),
        }
    }
}

/// A number outside the documented range of its field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{field} must be {min}–{max}, found {value}")]
pub struct RangeError {
    /// Which part of the instruction.
    pub field: Field,
    /// The value given.
    pub value: i128,
    /// The smallest value allowed.
    pub min: i128,
    /// The largest value allowed.
    pub max: i128,
    /// For an operand, the index of its instruction (`QT[3]=0` → `Some(3)`), so that a
    /// unit can say which row or parameter it refused; `None` for an instruction
    /// without an index and for the other fields.
    pub index: Option<u8>,
}

/// A documented range; the parsers and the encoder take every limit from the constants
/// below.
#[derive(Clone, Copy)]
struct Range {
    min: i128,
    max: i128,
}

impl Range {
    const fn new(min: i128, max: i128) -> Self {
        Self { min, max }
    }

    /// `value` as a `T`, if it lies in the range.
    fn narrow<T: TryFrom<i128>>(self, field: Field, value: i128) -> Result<T, RangeError> {
        if value < self.min || value > self.max {
            return Err(self.error(field, value));
        }
        T::try_from(value).map_err(|_| self.error(field, value))
    }

    /// The error for `value`, outside this range.
    fn error(self, field: Field, value: i128) -> RangeError {
        RangeError {
            field,
            value,
            min: self.min,
            max: self.max,
            index: None,
        }
    }
}

/// `*N;`: 0 (global) or a station 1–127.
const STATION: Range = Range::new(0, 127);
/// Any index `[i]`.
const INDEX: Range = Range::new(0, 255);
/// `MP[X]`: X = 0–6.
const MP_PARAM: Range = Range::new(0, 6);
/// `MP[X]=N` and `PV=N`: N = 0–255.
const BYTE: Range = Range::new(0, 255);
/// `QT[X]=N`: 10–255 ms, never 0.
const QT_MS: Range = Range::new(10, 255);
/// `SN[X]=s/n`: X = 0–127.
const SN_STATION: Range = Range::new(0, 127);
/// `MO=N`, `IE[X]=N`: 0 or 1.
const FLAG: Range = Range::new(0, 1);
/// `QP`, `QV`, `SP`, `PA`: a signed 32-bit number.
const I32: Range = Range::new(i32::MIN as i128, i32::MAX as i128);
/// `BG=N`, `SD=N`: an unsigned 32-bit number.
const U32: Range = Range::new(0, u32::MAX as i128);
/// A generic decimal operand.
const I64: Range = Range::new(i64::MIN as i128, i64::MAX as i128);
/// `SN[X]=s/n` and any hexadecimal operand.
const U64: Range = Range::new(0, u64::MAX as i128);
/// `BDR=x`: 9600–115200 baud (`docs/uim2503.md` §2, `docs/protocol-notes.md` §3).
const BAUD: Range = Range::new(gateway::MIN_BAUD as i128, gateway::MAX_BAUD as i128);

/// Whether the mnemonic may be written with an index (`None` of these take one).
fn takes_index(mnemonic: Mnemonic) -> bool {
    !matches!(
        mnemonic,
        Mnemonic::BG | Mnemonic::PV | Mnemonic::MO | Mnemonic::SP | Mnemonic::PA | Mnemonic::SD
    )
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn only_queries_selections_and_motor_off_are_inert() {
        let inert = "*0; *5; SN; PA; PV; QP[3]; QV[3]; QT[3]; MP[1]; SP; SD; IE[5]; MO; MO=0;";
        for instruction in parse_script(inert).unwrap() {
            assert!(instruction.is_inert(), "{instruction:?}");
        }
        let active = "BG; BG=1000; MO=1; PA=0; PA0; SP=25000; PV=0; QP[16]=162878; \
                      QV[16]=-34110; QT[16]=100; MP[1]=1; SD=1000; IE[5]=1; SN[3]=12345; \
                      ST; JV=100;";
        for instruction in parse_script(active).unwrap() {
            assert!(!instruction.is_inert(), "{instruction:?}");
        }
    }

    #[test]
    fn mnemonic_new_normalises_case_and_refuses_non_letters() {
        assert_eq!(Mnemonic::new(*b"qp"), Ok(Mnemonic::QP));
        assert_eq!(
            Mnemonic::new(*b"Il").map(|m| m.to_string()),
            Ok("IL".into())
        );
        for letters in [*b"Q1", *b" P", [b'Q', 0xC4], [0, b'A'], *b"Q;"] {
            let byte = letters.into_iter().find(|b| !b.is_ascii_alphabetic());
            assert_eq!(
                Mnemonic::new(letters).map_err(|e| e.byte),
                Err(byte.unwrap_or_default()),
                "{letters:?}"
            );
        }
        let message = Mnemonic::new([b'Q', 0xC4]).unwrap_err().to_string();
        assert!(
            message.contains("0xc4") && message.contains("ASCII 1–127"),
            "{message}"
        );
    }

    #[test]
    fn typed_mnemonics_are_recognised() {
        for mnemonic in Mnemonic::TYPED {
            assert!(mnemonic.is_typed());
        }
        assert!(!Mnemonic::new(*b"IL").unwrap().is_typed());
        assert_eq!(format!("{:?}", Mnemonic::QT), "Mnemonic(\"QT\")");
    }

    #[test]
    fn mp_param_index_round_trips() {
        for index in 0..=6 {
            assert_eq!(MpParam::from_index(index).map(MpParam::index), Some(index));
        }
        assert_eq!(MpParam::from_index(7), None);
    }

    #[test]
    fn instruction_mnemonic() {
        assert_eq!(Instruction::Select { station: 3 }.mnemonic(), None);
        assert_eq!(Instruction::QuerySerial.mnemonic(), Some(Mnemonic::SN));
        let generic = Generic {
            mnemonic: Mnemonic::new(*b"IL").unwrap(),
            index: None,
            operand: None,
        };
        assert_eq!(
            Instruction::Generic(generic).mnemonic(),
            Some(generic.mnemonic)
        );
    }

    #[test]
    fn range_error_names_the_field_and_the_limits() {
        let cases = [
            (
                Field::Station,
                STATION,
                200,
                "the station of `*N;` must be 0–127, found 200",
            ),
            (
                Field::Operand(Mnemonic::QT),
                QT_MS,
                0,
                "the operand of QT[X] (ms) must be 10–255, found 0",
            ),
            (
                Field::Index(Mnemonic::MP),
                MP_PARAM,
                7,
                "the index of MP[X] must be 0–6, found 7",
            ),
            (
                Field::Index(Mnemonic::SN),
                SN_STATION,
                128,
                "the new station of SN[X] must be 0–127, found 128",
            ),
            (
                Field::Operand(Mnemonic::BG),
                U32,
                -1,
                "the operand of BG (µs) must be 0–4294967295, found -1",
            ),
        ];
        for (field, range, value, message) in cases {
            let error = range.narrow::<u32>(field, value).unwrap_err();
            assert_eq!(error.to_string(), message);
        }
        assert_eq!(I32.narrow::<i32>(Field::Station, -5), Ok(-5));
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn small_or_any_i32() -> impl Strategy<Value = i32> {
        prop_oneof![-10_000..10_000, any::<i32>()]
    }

    fn small_or_any_u64() -> impl Strategy<Value = u64> {
        prop_oneof![0..100_000_u64, 0..=u64::from(u32::MAX), any::<u64>()]
    }

    fn generic() -> impl Strategy<Value = Generic> {
        let mnemonic = (b'A'..=b'Z', b'A'..=b'Z').prop_filter_map("typed mnemonic", |(a, b)| {
            Mnemonic::new([a, b]).ok().filter(|m| !m.is_typed())
        });
        let operand = prop_oneof![
            prop_oneof![-10_000..10_000_i64, any::<i64>()].prop_map(Operand::Decimal),
            small_or_any_u64().prop_map(Operand::Hex),
        ];
        (mnemonic, any::<Option<u8>>(), proptest::option::of(operand)).prop_map(
            |(mnemonic, index, operand)| Generic {
                mnemonic,
                index,
                operand,
            },
        )
    }

    /// Every instruction the types and documented ranges allow.
    pub(crate) fn instruction() -> impl Strategy<Value = Instruction> {
        use Instruction::*;
        let param = (0..=6_u8).prop_filter_map("MP index", MpParam::from_index);
        prop_oneof![
            (0..=127_u8).prop_map(|station| Select { station }),
            any::<Option<u32>>().prop_map(|at_us| Begin { at_us }),
            (param, any::<Option<u8>>()).prop_map(|(param, value)| MotionProfile { param, value }),
            any::<Option<u8>>().prop_map(|row| PvtStart { row }),
            (any::<u8>(), proptest::option::of(small_or_any_i32())).prop_map(
                |(row, position_counts)| PvtPosition {
                    row,
                    position_counts
                }
            ),
            (any::<u8>(), proptest::option::of(small_or_any_i32())).prop_map(
                |(row, velocity_counts_s)| PvtVelocity {
                    row,
                    velocity_counts_s
                }
            ),
            (any::<u8>(), proptest::option::of(10..=255_u8))
                .prop_map(|(row, duration_ms)| PvtTime { row, duration_ms }),
            Just(QuerySerial),
            (0..=127_u8, small_or_any_u64())
                .prop_map(|(station, serial)| SetStation { station, serial }),
            any::<Option<bool>>().prop_map(|on| Motor { on }),
            proptest::option::of(small_or_any_i32())
                .prop_map(|speed_counts_s| PtpSpeed { speed_counts_s }),
            proptest::option::of(small_or_any_i32())
                .prop_map(|position_counts| PtpPosition { position_counts }),
            any::<Option<u32>>().prop_map(|decel_counts_s2| StopDecel { decel_counts_s2 }),
            (any::<u8>(), any::<Option<bool>>())
                .prop_map(|(index, enabled)| InfoEnable { index, enabled }),
            generic().prop_map(Generic),
            Just(Gateway(GatewayCommand::Greet)),
            (gateway::MIN_BAUD..=gateway::MAX_BAUD)
                .prop_map(|baud| Gateway(GatewayCommand::SetBaud { baud })),
        ]
    }

    fn form() -> impl Strategy<Value = Form> {
        prop_oneof![Just(Form::Standard), Just(Form::Compact)]
    }

    fn read_all(bytes: &[u8]) -> Vec<Result<Instruction, ParseError>> {
        InstructionReader::new().push(bytes).collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// parse(encode(x)) == x, in both forms, through both parsers; the length is
        /// known before encoding, and only the 20-character rule refuses a valid value.
        #[test]
        fn parse_of_encode_is_identity(instruction in instruction(), form in form()) {
            let length = instruction.encoded_len(form);
            match instruction.encode(form) {
                Ok(encoded) => {
                    prop_assert_eq!(encoded.len(), length);
                    prop_assert!(length <= MAX_LEN);
                    prop_assert!(encoded.as_bytes().iter().all(|b| (1..=127).contains(b)));
                    prop_assert_eq!(read_all(encoded.as_bytes()), vec![Ok(instruction)]);
                    if instruction.encoded_len(Form::Standard) <= MAX_LEN {
                        let text = encoded.to_string();
                        prop_assert_eq!(parse_script(&text), Ok(vec![instruction]));
                    }
                }
                Err(EncodeError::TooLong { length: too_long, .. }) => {
                    prop_assert_eq!(too_long, length);
                    prop_assert!(length > MAX_LEN);
                }
                Err(error) => prop_assert!(false, "valid {:?} refused: {}", instruction, error),
            }
        }

        /// Case, `:` for `=` and spaces between the parts do not change the instruction.
        #[test]
        fn scripts_forgive_case_separators_and_spacing(instruction in instruction()) {
            if let Ok(encoded) = instruction.encode(Form::Standard) {
                let text = encoded
                    .to_string()
                    .to_lowercase()
                    .replace('=', " :\t")
                    .replace('[', " [ ")
                    .replace(']', "\n] ")
                    .replace(';', " ; # comment\n");
                prop_assert_eq!(parse_script(&text), Ok(vec![instruction]));
            }
        }

        /// The reader gives the same instructions however the bytes are chunked.
        #[test]
        fn reader_chunking_does_not_matter(
            instructions in proptest::collection::vec(instruction(), 0..20),
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..10),
        ) {
            let mut wire = Vec::new();
            let mut sent = Vec::new();
            for instruction in instructions {
                if instruction.encode_into(Form::Compact, &mut wire).is_ok() {
                    sent.push(Ok(instruction));
                }
            }
            let mut cuts: Vec<usize> = cuts.iter().map(|cut| cut.index(wire.len() + 1)).collect();
            cuts.sort_unstable();
            let mut reader = InstructionReader::new();
            let mut read = Vec::new();
            let mut from = 0;
            for cut in cuts.into_iter().chain([wire.len()]) {
                read.extend(reader.push(&wire[from..cut]));
                from = cut;
            }
            prop_assert_eq!(read, sent);
            prop_assert_eq!(reader.pending(), 0);
        }

        /// No text makes the script parser panic.
        #[test]
        fn parse_script_never_panics(text in any::<String>()) {
            let _ = parse_script(&text);
        }

        /// Nor text made of the grammar's own characters, which reaches every state.
        #[test]
        fn parse_script_never_panics_on_near_misses(
            text in "[*A-Za-z0-9xX\\[\\]=:;#{} \n\t-]{0,40}",
        ) {
            if let Err(error) = parse_script(&text) {
                prop_assert!(error.line >= 1 && error.column >= 1);
                prop_assert!(!error.to_string().is_empty());
            }
        }

        /// No bytes make the reader panic, and its memory stays bounded.
        #[test]
        fn reader_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..200)) {
            let mut reader = InstructionReader::new();
            let results = reader.push(&bytes).count();
            prop_assert_eq!(results, bytes.iter().filter(|&&b| b == b';').count());
        }
    }
}
