//! Instruction → text, in the fewest characters the gateway accepts.
//!
//! The text is canonical: upper-case mnemonic, no spaces, no leading zeros, `-` only on
//! negative numbers, hexadecimal in whole bytes (`ILx=0A;`). [`Form::Compact`] also
//! drops the `=` (manual §6.1: "the `=` has no meaning and may be omitted").
//!
//! ```
//! use floatball_shared::uim2503::ascii::{Form, Instruction};
//!
//! let row = Instruction::PvtPosition { row: 3, position_counts: Some(-9000) };
//! assert_eq!(row.encode(Form::Standard)?.to_string(), "QP[3]=-9000;");
//! assert_eq!(row.encoded_len(Form::Compact), "QP[3]-9000;".len());
//!
//! let mut wire = Vec::with_capacity(64);
//! let written = row.encode_into(Form::Compact, &mut wire)?;
//! assert_eq!((written, wire.as_slice()), (11, &b"QP[3]-9000;"[..]));
//! # Ok::<(), floatball_shared::uim2503::ascii::EncodeError>(())
//! ```

use std::fmt;

use super::{BAUD, Field, GatewayCommand, STATION};
use super::{Instruction, MAX_LEN, Mnemonic, Number, Parts, QT_MS, RangeError, SN_STATION};

/// How an instruction is written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Form {
    /// With `=` before the operand: `QP[3]=1000;`. What the manual shows.
    #[default]
    Standard,
    /// Without `=`: `QP[3]1000;`, one byte shorter per operand.
    Compact,
}

/// Why an instruction cannot be sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// The text would be longer than the gateway's 20 characters (including `;`).
    #[error(
        "`{text}` is {length} characters including `;`; the gateway accepts at most 20",
        text = InForm(.instruction, *.form)
    )]
    TooLong {
        /// The instruction.
        instruction: Instruction,
        /// The form it was to be written in.
        form: Form,
        /// The length of its text.
        length: usize,
    },
    /// A number outside the documented range of its field (e.g. `QT[0]=0`).
    #[error(transparent)]
    OutOfRange(#[from] RangeError),
    /// A [`Generic`](super::Generic) instruction with a mnemonic that has its own variant.
    #[error(
        "{mnemonic} has its own `Instruction` variant; written as a generic instruction it \
         would skip its range checks"
    )]
    TypedMnemonic {
        /// The mnemonic.
        mnemonic: Mnemonic,
    },
}

/// The text of one instruction, kept on the stack.
#[derive(Clone, Copy, PartialEq, Eq, Hash)]
pub struct Encoded {
    bytes: [u8; MAX_LEN],
    len: usize,
}

impl Encoded {
    /// The text's bytes, ending with `;`.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or_default()
    }

    /// The number of bytes, 3–20.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Always `false`: an instruction has at least `XX;`.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl fmt::Display for Encoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use fmt::Write as _;
        self.as_bytes()
            .iter()
            .try_for_each(|&byte| f.write_char(char::from(byte)))
    }
}

impl fmt::Debug for Encoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Encoded(\"{self}\")")
    }
}

impl Instruction {
    /// Checks the ranges the Rust types do not express, without writing anything.
    ///
    /// # Errors
    /// [`EncodeError::OutOfRange`] or [`EncodeError::TypedMnemonic`].
    pub fn validate(&self) -> Result<(), EncodeError> {
        match *self {
            Self::Select { station } => {
                STATION.narrow::<u8>(Field::Station, station.into())?;
            }
            Self::PvtTime {
                row,
                duration_ms: Some(duration_ms),
            } => {
                QT_MS
                    .narrow::<u8>(Field::Operand(Mnemonic::QT), duration_ms.into())
                    .map_err(|error| RangeError {
                        index: Some(row),
                        ..error
                    })?;
            }
            Self::SetStation { station, .. } => {
                SN_STATION.narrow::<u8>(Field::Index(Mnemonic::SN), station.into())?;
            }
            Self::Gateway(GatewayCommand::SetBaud { baud }) => {
                BAUD.narrow::<u32>(Field::Baud, baud.into())?;
            }
            Self::Generic(generic) if generic.mnemonic.is_typed() => {
                return Err(EncodeError::TypedMnemonic {
                    mnemonic: generic.mnemonic,
                });
            }
            _ => {}
        }
        Ok(())
    }

    /// The length in bytes of the text [`encode`](Self::encode) writes in `form`,
    /// computed without writing it (and without checking that it may be sent).
    pub fn encoded_len(&self, form: Form) -> usize {
        match self.parts() {
            Parts::Select { station } => 2 + decimal_len(station.into()),
            Parts::Command { index, operand, .. } => {
                let index_len = index.map_or(0, |index| 2 + decimal_len(index.into()));
                let operand_len = operand.map_or(0, |operand| {
                    let equals = usize::from(form == Form::Standard);
                    equals
                        + match operand {
                            Number::Signed(value) => {
                                usize::from(value < 0) + decimal_len(value.unsigned_abs())
                            }
                            Number::Unsigned(value) => decimal_len(value),
                            Number::Hex(value) => 1 + 2 * hex_bytes(value),
                        }
                });
                3 + index_len + operand_len
            }
            Parts::Gateway { operand, .. } => {
                4 + operand.map_or(0, |baud| {
                    usize::from(form == Form::Standard) + decimal_len(baud.into())
                })
            }
        }
    }

    /// The instruction's text in `form`.
    ///
    /// # Errors
    /// [`EncodeError`] if a value is out of range or the text would exceed 20
    /// characters.
    pub fn encode(&self, form: Form) -> Result<Encoded, EncodeError> {
        self.check(form)?;
        let mut encoded = Encoded {
            bytes: [0; MAX_LEN],
            len: 0,
        };
        self.write(form, &mut encoded);
        Ok(encoded)
    }

    /// Appends the instruction's text in `form` to `out` and returns its length; on an
    /// error `out` is left as it was. Allocates only if `out` must grow.
    ///
    /// # Errors
    /// As [`encode`](Self::encode).
    pub fn encode_into(&self, form: Form, out: &mut Vec<u8>) -> Result<usize, EncodeError> {
        let length = self.check(form)?;
        out.reserve(length);
        self.write(form, out);
        Ok(length)
    }

    /// Validates and returns the length of the text in `form`.
    fn check(&self, form: Form) -> Result<usize, EncodeError> {
        self.validate()?;
        let length = self.encoded_len(form);
        if length > MAX_LEN {
            return Err(EncodeError::TooLong {
                instruction: *self,
                form,
                length,
            });
        }
        Ok(length)
    }

    /// Writes the text in `form`, unchecked.
    fn write(&self, form: Form, sink: &mut impl Sink) {
        match self.parts() {
            Parts::Select { station } => {
                sink.put(b'*');
                put_decimal(sink, station.into());
            }
            Parts::Command {
                mnemonic,
                index,
                operand,
            } => {
                sink.put_all(&mnemonic.letters());
                if let Some(Number::Hex(_)) = operand {
                    sink.put(b'x');
                }
                if let Some(index) = index {
                    sink.put(b'[');
                    put_decimal(sink, index.into());
                    sink.put(b']');
                }
                if let Some(operand) = operand {
                    if form == Form::Standard {
                        sink.put(b'=');
                    }
                    match operand {
                        Number::Signed(value) => {
                            if value < 0 {
                                sink.put(b'-');
                            }
                            put_decimal(sink, value.unsigned_abs());
                        }
                        Number::Unsigned(value) => put_decimal(sink, value),
                        Number::Hex(value) => put_hex(sink, value),
                    }
                }
            }
            Parts::Gateway { letters, operand } => {
                sink.put_all(&letters);
                if let Some(value) = operand {
                    if form == Form::Standard {
                        sink.put(b'=');
                    }
                    put_decimal(sink, value.into());
                }
            }
        }
        sink.put(b';');
    }
}

/// Shows the instruction in [`Form::Standard`], without checking its ranges or length.
impl fmt::Display for Instruction {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        InForm(self, Form::Standard).fmt(f)
    }
}

/// An instruction shown in a given form.
struct InForm<'a>(&'a Instruction, Form);

impl fmt::Display for InForm<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut sink = FmtSink { f, result: Ok(()) };
        self.0.write(self.1, &mut sink);
        sink.result
    }
}

/// Where the encoder writes bytes.
trait Sink {
    fn put(&mut self, byte: u8);

    fn put_all(&mut self, bytes: &[u8]) {
        bytes.iter().for_each(|&byte| self.put(byte));
    }
}

impl Sink for Vec<u8> {
    fn put(&mut self, byte: u8) {
        self.push(byte);
    }
}

/// Writes into the fixed buffer; [`Instruction::check`] has made sure it fits.
impl Sink for Encoded {
    fn put(&mut self, byte: u8) {
        if let Some(slot) = self.bytes.get_mut(self.len) {
            *slot = byte;
            self.len += 1;
        }
    }
}

struct FmtSink<'a, 'b> {
    f: &'a mut fmt::Formatter<'b>,
    result: fmt::Result,
}

impl Sink for FmtSink<'_, '_> {
    fn put(&mut self, byte: u8) {
        use fmt::Write as _;
        if self.result.is_ok() {
            self.result = self.f.write_char(char::from(byte));
        }
    }
}

/// The number of decimal digits of `value`.
fn decimal_len(value: u64) -> usize {
    value.checked_ilog10().map_or(1, |log| log as usize + 1)
}

/// The number of whole bytes `value` needs in hexadecimal (at least one: `00`).
fn hex_bytes(value: u64) -> usize {
    (value.checked_ilog2().map_or(0, |log| log as usize) / 8) + 1
}

fn put_decimal(sink: &mut impl Sink, value: u64) {
    let mut digits = [0_u8; 20];
    let mut start = digits.len();
    let mut rest = value;
    loop {
        start -= 1;
        if let Some(digit) = digits.get_mut(start) {
            *digit = b'0' + (rest % 10) as u8;
        }
        rest /= 10;
        if rest == 0 {
            break;
        }
    }
    sink.put_all(digits.get(start..).unwrap_or_default());
}

fn put_hex(sink: &mut impl Sink, value: u64) {
    const DIGITS: &[u8; 16] = b"0123456789ABCDEF";
    for nibble in (0..2 * hex_bytes(value)).rev() {
        sink.put(DIGITS[((value >> (4 * nibble)) & 0xF) as usize]);
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::{Generic, MpParam, Operand};
    use super::*;

    fn generic(letters: &[u8; 2], index: Option<u8>, operand: Option<Operand>) -> Instruction {
        Instruction::Generic(Generic {
            mnemonic: Mnemonic::new(*letters).unwrap(),
            index,
            operand,
        })
    }

    #[test]
    fn writes_the_shortest_text_in_both_forms() {
        use Instruction::*;
        let cases = [
            (Select { station: 0 }, "*0;", "*0;"),
            (Select { station: 127 }, "*127;", "*127;"),
            (Begin { at_us: None }, "BG;", "BG;"),
            (Begin { at_us: Some(12345) }, "BG=12345;", "BG12345;"),
            (
                Begin {
                    at_us: Some(u32::MAX),
                },
                "BG=4294967295;",
                "BG4294967295;",
            ),
            (
                MotionProfile {
                    param: MpParam::Mode,
                    value: Some(1),
                },
                "MP[3]=1;",
                "MP[3]1;",
            ),
            (
                MotionProfile {
                    param: MpParam::NextWriteRow,
                    value: None,
                },
                "MP[6];",
                "MP[6];",
            ),
            (PvtStart { row: Some(0) }, "PV=0;", "PV0;"),
            (PvtStart { row: None }, "PV;", "PV;"),
            (
                PvtPosition {
                    row: 255,
                    position_counts: Some(i32::MIN),
                },
                "QP[255]=-2147483648;",
                "QP[255]-2147483648;",
            ),
            (
                PvtVelocity {
                    row: 3,
                    velocity_counts_s: Some(-9000),
                },
                "QV[3]=-9000;",
                "QV[3]-9000;",
            ),
            (
                PvtTime {
                    row: 100,
                    duration_ms: Some(100),
                },
                "QT[100]=100;",
                "QT[100]100;",
            ),
            (
                PvtTime {
                    row: 7,
                    duration_ms: None,
                },
                "QT[7];",
                "QT[7];",
            ),
            (QuerySerial, "SN;", "SN;"),
            (
                SetStation {
                    station: 127,
                    serial: 4_294_967_295,
                },
                "SN[127]=4294967295;",
                "SN[127]4294967295;",
            ),
            (Motor { on: Some(true) }, "MO=1;", "MO1;"),
            (Motor { on: Some(false) }, "MO=0;", "MO0;"),
            (
                PtpSpeed {
                    speed_counts_s: Some(5000),
                },
                "SP=5000;",
                "SP5000;",
            ),
            (
                PtpPosition {
                    position_counts: Some(-1),
                },
                "PA=-1;",
                "PA-1;",
            ),
            (
                StopDecel {
                    decel_counts_s2: Some(0),
                },
                "SD=0;",
                "SD0;",
            ),
            (
                InfoEnable {
                    index: 5,
                    enabled: Some(true),
                },
                "IE[5]=1;",
                "IE[5]1;",
            ),
            (
                generic(b"IL", None, Some(Operand::Hex(0))),
                "ILx=00;",
                "ILx00;",
            ),
            (
                generic(b"IL", Some(2), Some(Operand::Hex(0x0A0B))),
                "ILx[2]=0A0B;",
                "ILx[2]0A0B;",
            ),
            (
                generic(b"AB", None, Some(Operand::Hex(0x00FF_FFFF_FFFF_FFFF))),
                "ABx=FFFFFFFFFFFFFF;",
                "ABxFFFFFFFFFFFFFF;",
            ),
            (
                generic(b"AC", None, Some(Operand::Decimal(-7))),
                "AC=-7;",
                "AC-7;",
            ),
            (generic(b"ST", None, None), "ST;", "ST;"),
            (generic(b"DV", Some(4), None), "DV[4];", "DV[4];"),
        ];
        for (instruction, standard, compact) in cases {
            for (form, text) in [(Form::Standard, standard), (Form::Compact, compact)] {
                let encoded = instruction.encode(form).unwrap();
                assert_eq!(encoded.to_string(), text, "{instruction:?}");
                assert_eq!(encoded.as_bytes(), text.as_bytes());
                assert_eq!(encoded.len(), text.len());
                assert!(!encoded.is_empty());
                assert_eq!(instruction.encoded_len(form), text.len(), "{instruction:?}");
                let mut out = b"*1;".to_vec();
                assert_eq!(instruction.encode_into(form, &mut out), Ok(text.len()));
                assert_eq!(&out[3..], text.as_bytes());
            }
            assert_eq!(instruction.to_string(), standard);
        }
    }

    #[test]
    fn refuses_what_the_gateway_would_not_take() {
        use Instruction::*;
        let range = |field, value, min, max, index| {
            EncodeError::OutOfRange(RangeError {
                field,
                value,
                min,
                max,
                index,
            })
        };
        let too_long = |instruction, form, length| EncodeError::TooLong {
            instruction,
            form,
            length,
        };
        let serial = SetStation {
            station: 100,
            serial: u64::MAX,
        };
        let hex = generic(b"AB", Some(200), Some(Operand::Hex(u64::MAX)));
        let decimal = generic(b"AB", Some(1), Some(Operand::Decimal(i64::MIN)));
        let cases = [
            (
                Select { station: 128 },
                Form::Standard,
                range(Field::Station, 128, 0, 127, None),
                "the station of `*N;` must be 0–127, found 128",
            ),
            (
                PvtTime {
                    row: 0,
                    duration_ms: Some(0),
                },
                Form::Compact,
                range(Field::Operand(Mnemonic::QT), 0, 10, 255, Some(0)),
                "the operand of QT[X] (ms) must be 10–255, found 0",
            ),
            (
                PvtTime {
                    row: 7,
                    duration_ms: Some(9),
                },
                Form::Standard,
                range(Field::Operand(Mnemonic::QT), 9, 10, 255, Some(7)),
                "the operand of QT[X] (ms) must be 10–255, found 9",
            ),
            (
                SetStation {
                    station: 128,
                    serial: 1,
                },
                Form::Standard,
                range(Field::Index(Mnemonic::SN), 128, 0, 127, None),
                "the new station of SN[X] must be 0–127, found 128",
            ),
            (
                generic(b"qp", Some(1), Some(Operand::Decimal(5))),
                Form::Standard,
                EncodeError::TypedMnemonic {
                    mnemonic: Mnemonic::QP,
                },
                "QP has its own `Instruction` variant; written as a generic instruction it would \
                 skip its range checks",
            ),
            (
                serial,
                Form::Standard,
                too_long(serial, Form::Standard, 29),
                "`SN[100]=18446744073709551615;` is 29 characters including `;`; the gateway \
                 accepts at most 20",
            ),
            (
                serial,
                Form::Compact,
                too_long(serial, Form::Compact, 28),
                "`SN[100]18446744073709551615;` is 28 characters including `;`; the gateway \
                 accepts at most 20",
            ),
            (
                hex,
                Form::Compact,
                too_long(hex, Form::Compact, 25),
                "`ABx[200]FFFFFFFFFFFFFFFF;` is 25 characters including `;`; the gateway \
                 accepts at most 20",
            ),
            (
                decimal,
                Form::Standard,
                too_long(decimal, Form::Standard, 27),
                "`AB[1]=-9223372036854775808;` is 27 characters including `;`; the gateway \
                 accepts at most 20",
            ),
        ];
        for (instruction, form, error, message) in cases {
            assert_eq!(instruction.encode(form), Err(error), "{instruction:?}");
            let mut out = vec![b'X'];
            assert_eq!(instruction.encode_into(form, &mut out), Err(error));
            assert_eq!(out, b"X", "nothing is written on an error");
            assert_eq!(error.to_string(), message);
        }
    }

    #[test]
    fn twenty_characters_pass_and_twenty_one_do_not() {
        let fits = Instruction::SetStation {
            station: 12,
            serial: 999_999_999_999,
        };
        assert_eq!(fits.encode(Form::Standard).map(|e| e.len()), Ok(20));
        let over = Instruction::SetStation {
            station: 120,
            serial: 999_999_999_999,
        };
        assert_eq!(over.encode(Form::Compact).map(|e| e.len()), Ok(20));
        assert!(matches!(
            over.encode(Form::Standard),
            Err(EncodeError::TooLong { length: 21, .. })
        ));
    }

    #[test]
    fn digit_counts() {
        for (value, len) in [(0, 1), (9, 1), (10, 2), (99, 2), (100, 3), (u64::MAX, 20)] {
            assert_eq!(decimal_len(value), len, "{value}");
        }
        for (value, bytes) in [(0, 1), (0xFF, 1), (0x100, 2), (0xFFFF, 2), (u64::MAX, 8)] {
            assert_eq!(hex_bytes(value), bytes, "{value:#x}");
        }
    }
}
