//! What a frame means: ACKs (manual §8), the RTCN notification and error reports.
//!
//! Every multi-byte value is little-endian after restoration (`N = [N0:N1:N2:N3]`). A
//! unit answers a set (`QT[3]=100;`) and a query (`QT[3];`) with the same ACK: the value
//! now in effect. [`Feedback::from_frame`] and [`Feedback::to_frame`] are exact
//! inverses: a frame of a known code with the wrong number of data bytes, or a flag
//! other than 0 or 1, is an error rather than a guess.
//!
//! ```
//! use floatball_shared::uim2503::feedback::{Feedback, Frame, Notification, UnitError, code};
//!
//! // The PVT watermark notice from the unit on station 9 (the manual's `RTN0=44`).
//! let frame = Frame::new(9, code::RTCN, &[44])?;
//! let feedback = Feedback::from_frame(&frame).map_err(|e| e.to_string())?;
//! assert_eq!(feedback, Feedback::Notification(Notification::PVT_WATERMARK));
//!
//! // `QT[3]=0;` refused.
//! let refusal = Feedback::Error(UnitError { error: code::error::DATA, code: code::QT, index: 3 });
//! assert_eq!(refusal.to_frame(9)?.data(), [0x33, 0x27, 3]);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use std::fmt;

use crate::codes::{Code, Coded, Params};
use crate::params;

use super::{Frame, FrameError, Payload, code};

/// The meaning of one feedback frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Feedback {
    /// A unit acknowledges an instruction or answers a query.
    Ack(Ack),
    /// A unit reports an event unasked (RTCN).
    Notification(Notification),
    /// A unit, or the gateway (station 0), refuses an instruction.
    Error(UnitError),
    /// A code Floatball does not know, kept as received.
    Unknown {
        /// The code.
        code: u8,
        /// The data bytes.
        data: Payload,
    },
}

/// A unit's acknowledgement of an instruction: the value now in effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Ack {
    /// `BG` (0x16): `N0…N3`, the start time given (0 for `BG;`).
    Begin {
        /// The start time.
        at_us: u32,
    },
    /// `MP[X]` (0x22): `X, N0 N1`.
    MotionProfile {
        /// The parameter index `X`.
        param: u8,
        /// Its value.
        value: u16,
    },
    /// `PV` (0x23): `N0 N1`, the start row; a query answers the water level (FIFO
    /// mode, up to 256) or the row being executed.
    PvtStart {
        /// The row or water level.
        value: u16,
    },
    /// `QP[X]` (0x25): `X0 X1, N0…N3`.
    PvtPosition {
        /// The row.
        row: u16,
        /// Its position.
        position_counts: i32,
    },
    /// `QV[X]` (0x26): `X0 X1, N0…N3`.
    PvtVelocity {
        /// The row.
        row: u16,
        /// Its velocity.
        velocity_counts_s: i32,
    },
    /// `QT[X]` (0x27): `X0 X1, N0`.
    PvtTime {
        /// The row.
        row: u16,
        /// Its duration.
        duration_ms: u8,
    },
    /// `SN` (0x0C): `N0…N7`, the unit's serial number (the frame's station is its id).
    Serial {
        /// The serial number.
        serial: u64,
    },
    /// `MO` (0x15): `N0`, 0 or 1.
    Motor {
        /// Whether the driver is on.
        on: bool,
    },
    /// `SP` (0x1E): `N0…N3`.
    PtpSpeed {
        /// The point-to-point speed.
        speed_counts_s: i32,
    },
    /// `PA` (0x20): `N0…N3`.
    PtpPosition {
        /// The point-to-point target.
        position_counts: i32,
    },
    /// `SD` (0x1C): `N0…N3`.
    StopDecel {
        /// The stop deceleration.
        decel_counts_s2: u32,
    },
    /// `IE[X]` (0x07): `X, N0 N1`, N 0 or 1.
    InfoEnable {
        /// The notification index `X`.
        index: u8,
        /// Whether it is enabled.
        enabled: bool,
    },
}

/// A real-time change notification (RTCN, code 0x5A): one data byte, its kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Notification {
    /// The kind; see [`code::notification`].
    pub kind: u8,
}

impl Notification {
    /// The PVT water level has fallen to the watermark `MP[5]`.
    pub const PVT_WATERMARK: Self = Self {
        kind: code::notification::PVT_WATERMARK,
    };
}

/// An error report (code 0x0F): `E, C, X`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct UnitError {
    /// What went wrong; see [`code::error`].
    pub error: u8,
    /// The code of the instruction refused (0 if the gateway could not read it).
    pub code: u8,
    /// The index of the instruction refused (0 if it has none).
    pub index: u8,
}

impl fmt::Display for UnitError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} (error {:#04x}",
            code::error::describe(self.error),
            self.error
        )?;
        if self.code != 0 {
            write!(f, ", {}, index {}", Label(self.code), self.index)?;
        }
        f.write_str(")")
    }
}

/// A frame that does not have the layout its code calls for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FeedbackError {
    /// The wrong number of data bytes for the code.
    #[error("{} carries {expected} data bytes, found {found}", Label(*.code))]
    Length {
        /// The frame's code.
        code: u8,
        /// The number its layout has.
        expected: usize,
        /// The number in the frame.
        found: usize,
    },
    /// A flag (`MO`, `IE`) other than 0 or 1.
    #[error("{} carries {value} where 0 or 1 is expected", Label(*.code))]
    Flag {
        /// The frame's code.
        code: u8,
        /// The value in the frame.
        value: u16,
    },
}

/// A code shown with its name: `QT (0x27)`.
struct Label(u8);

impl fmt::Display for Label {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match code::name(self.0) {
            Some(name) => write!(f, "{name} ({:#04x})", self.0),
            None => write!(f, "code {:#04x}", self.0),
        }
    }
}

impl Feedback {
    /// What `frame` means.
    ///
    /// # Errors
    /// [`FeedbackError`] if a known code comes with the wrong layout.
    pub fn from_frame(frame: &Frame) -> Result<Self, FeedbackError> {
        let code = frame.code();
        let data = frame.data();
        let ack = |ack| Ok(Self::Ack(ack));
        match code {
            code::BG => ack(Ack::Begin {
                at_us: u32::from_le_bytes(exact(code, data)?),
            }),
            code::MP => {
                let [param, n0, n1] = exact(code, data)?;
                ack(Ack::MotionProfile {
                    param,
                    value: u16::from_le_bytes([n0, n1]),
                })
            }
            code::PV => ack(Ack::PvtStart {
                value: u16::from_le_bytes(exact(code, data)?),
            }),
            code::QP | code::QV => {
                let [x0, x1, n0, n1, n2, n3] = exact(code, data)?;
                let row = u16::from_le_bytes([x0, x1]);
                let value = i32::from_le_bytes([n0, n1, n2, n3]);
                ack(if code == code::QP {
                    Ack::PvtPosition {
                        row,
                        position_counts: value,
                    }
                } else {
                    Ack::PvtVelocity {
                        row,
                        velocity_counts_s: value,
                    }
                })
            }
            code::QT => {
                let [x0, x1, duration_ms] = exact(code, data)?;
                ack(Ack::PvtTime {
                    row: u16::from_le_bytes([x0, x1]),
                    duration_ms,
                })
            }
            code::SN => ack(Ack::Serial {
                serial: u64::from_le_bytes(exact(code, data)?),
            }),
            code::MO => {
                let [on] = exact(code, data)?;
                ack(Ack::Motor {
                    on: flag(code, on.into())?,
                })
            }
            code::SP => ack(Ack::PtpSpeed {
                speed_counts_s: i32::from_le_bytes(exact(code, data)?),
            }),
            code::PA => ack(Ack::PtpPosition {
                position_counts: i32::from_le_bytes(exact(code, data)?),
            }),
            code::SD => ack(Ack::StopDecel {
                decel_counts_s2: u32::from_le_bytes(exact(code, data)?),
            }),
            code::IE => {
                let [index, n0, n1] = exact(code, data)?;
                ack(Ack::InfoEnable {
                    index,
                    enabled: flag(code, u16::from_le_bytes([n0, n1]))?,
                })
            }
            code::RTCN => {
                let [kind] = exact(code, data)?;
                Ok(Self::Notification(Notification { kind }))
            }
            code::ER => {
                let [error, code, index] = exact(code, data)?;
                Ok(Self::Error(UnitError { error, code, index }))
            }
            code => Ok(Self::Unknown {
                code,
                data: frame.data,
            }),
        }
    }

    /// The frame that carries this feedback from `station`.
    ///
    /// # Errors
    /// [`FrameError`] if `station`, or an unknown code, exceeds 127.
    pub fn to_frame(&self, station: u8) -> Result<Frame, FrameError> {
        let (code, data) = match *self {
            Self::Ack(ack) => return ack.to_frame(station),
            Self::Notification(Notification { kind }) => (code::RTCN, Payload::new(&[kind])?),
            Self::Error(UnitError { error, code, index }) => {
                (code::ER, Payload::new(&[error, code, index])?)
            }
            Self::Unknown { code, data } => (code, data),
        };
        Frame::from_payload(station, code, data)
    }

    /// The frame code this feedback travels with.
    pub fn code(&self) -> u8 {
        match self {
            Self::Ack(ack) => ack.code(),
            Self::Notification(_) => code::RTCN,
            Self::Error(_) => code::ER,
            Self::Unknown { code, .. } => *code,
        }
    }
}

impl Ack {
    /// The frame code of this ACK.
    pub fn code(&self) -> u8 {
        match self {
            Self::Begin { .. } => code::BG,
            Self::MotionProfile { .. } => code::MP,
            Self::PvtStart { .. } => code::PV,
            Self::PvtPosition { .. } => code::QP,
            Self::PvtVelocity { .. } => code::QV,
            Self::PvtTime { .. } => code::QT,
            Self::Serial { .. } => code::SN,
            Self::Motor { .. } => code::MO,
            Self::PtpSpeed { .. } => code::SP,
            Self::PtpPosition { .. } => code::PA,
            Self::StopDecel { .. } => code::SD,
            Self::InfoEnable { .. } => code::IE,
        }
    }

    /// The frame that carries this ACK from `station`.
    ///
    /// # Errors
    /// [`FrameError::Station`] if `station` exceeds 127.
    pub fn to_frame(&self, station: u8) -> Result<Frame, FrameError> {
        let code = self.code();
        match *self {
            Self::Begin { at_us } => Frame::new(station, code, &at_us.to_le_bytes()),
            Self::MotionProfile { param, value } => {
                let [n0, n1] = value.to_le_bytes();
                Frame::new(station, code, &[param, n0, n1])
            }
            Self::PvtStart { value } => Frame::new(station, code, &value.to_le_bytes()),
            Self::PvtPosition {
                row,
                position_counts: value,
            }
            | Self::PvtVelocity {
                row,
                velocity_counts_s: value,
            } => {
                let [x0, x1] = row.to_le_bytes();
                let [n0, n1, n2, n3] = value.to_le_bytes();
                Frame::new(station, code, &[x0, x1, n0, n1, n2, n3])
            }
            Self::PvtTime { row, duration_ms } => {
                let [x0, x1] = row.to_le_bytes();
                Frame::new(station, code, &[x0, x1, duration_ms])
            }
            Self::Serial { serial } => Frame::new(station, code, &serial.to_le_bytes()),
            Self::Motor { on } => Frame::new(station, code, &[on.into()]),
            Self::PtpSpeed {
                speed_counts_s: value,
            }
            | Self::PtpPosition {
                position_counts: value,
            } => Frame::new(station, code, &value.to_le_bytes()),
            Self::StopDecel { decel_counts_s2 } => {
                Frame::new(station, code, &decel_counts_s2.to_le_bytes())
            }
            Self::InfoEnable { index, enabled } => {
                Frame::new(station, code, &[index, enabled.into(), 0])
            }
        }
    }
}

/// The data as exactly `N` bytes.
fn exact<const N: usize>(code: u8, data: &[u8]) -> Result<[u8; N], FeedbackError> {
    <[u8; N]>::try_from(data).map_err(|_| FeedbackError::Length {
        code,
        expected: N,
        found: data.len(),
    })
}

fn flag(code: u8, value: u16) -> Result<bool, FeedbackError> {
    match value {
        0 => Ok(false),
        1 => Ok(true),
        _ => Err(FeedbackError::Flag { code, value }),
    }
}

impl Coded for UnitError {
    fn code(&self) -> Code {
        match self.error {
            code::error::SYNTAX => Code::UnitSyntax,
            code::error::DATA => Code::UnitData,
            code::error::INDEX => Code::UnitIndex,
            code::error::WHILE_MOVING => Code::UnitWhileMoving,
            code::error::MOTOR_OFF => Code::UnitMotorOff,
            code::error::OVERLOAD => Code::UnitOverload,
            code::error::LIMIT => Code::UnitLimit,
            _ => Code::UnitUnknown,
        }
    }

    /// `error` (`0x32`), and when the unit names the instruction it refused,
    /// `instruction` (`QT (0x27)`) and `index`.
    fn params(&self) -> Params {
        let mut params = params! {"error" => format!("{:#04x}", self.error)};
        if self.code != 0 {
            params.insert("instruction".into(), Label(self.code).to_string());
            params.insert("index".into(), self.index.to_string());
        }
        params
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::super::FrameDecoder;
    use super::*;

    fn decode(wire: &[u8]) -> Frame {
        let frames: Vec<Frame> = FrameDecoder::new().push(wire).collect();
        assert_eq!(frames.len(), 1, "{wire:02X?}");
        frames[0]
    }

    /// Every layout, from station 20, against bytes worked out independently.
    #[test]
    fn every_layout_on_the_wire() {
        let cases: [(Feedback, &[u8]); 16] = [
            (
                Feedback::Ack(Ack::Begin {
                    at_us: 3_000_000_000,
                }),
                &[0xFC, 0x14, 0x16, 0x00, 0x5E, 0x50, 0x32, 0xE0],
            ),
            (
                Feedback::Ack(Ack::MotionProfile {
                    param: 5,
                    value: 254,
                }),
                &[0xF2, 0x14, 0x22, 0x05, 0x7E, 0x00, 0xE0],
            ),
            (
                Feedback::Ack(Ack::PvtStart { value: 256 }),
                &[0xF0, 0x14, 0x23, 0x00, 0x01, 0xE0],
            ),
            (
                Feedback::Ack(Ack::PvtPosition {
                    row: 3,
                    position_counts: -9000,
                }),
                &[0xFC, 0x14, 0x25, 0x03, 0x00, 0x58, 0x5C, 0x7F, 0x7F, 0xE3],
            ),
            (
                Feedback::Ack(Ack::PvtVelocity {
                    row: 255,
                    velocity_counts_s: 8000,
                }),
                &[0xF1, 0x14, 0x26, 0x7F, 0x00, 0x40, 0x1F, 0x00, 0x00, 0xE0],
            ),
            (
                Feedback::Ack(Ack::PvtTime {
                    row: 200,
                    duration_ms: 150,
                }),
                &[0xF5, 0x14, 0x27, 0x48, 0x00, 0x16, 0xE0],
            ),
            (
                Feedback::Ack(Ack::Serial {
                    serial: 0x0123_4567_89AB_CDEF,
                }),
                &[
                    0xFF, 0x14, 0x0C, 0x6F, 0x4D, 0x2B, 0x09, 0x67, 0x45, 0x23, 0x01, 0xE0,
                ],
            ),
            (
                Feedback::Ack(Ack::Motor { on: true }),
                &[0xF0, 0x14, 0x15, 0x01, 0xE0],
            ),
            (
                Feedback::Ack(Ack::PtpSpeed {
                    speed_counts_s: -5000,
                }),
                &[0xFE, 0x14, 0x1E, 0x78, 0x6C, 0x7F, 0x7F, 0xE0],
            ),
            (
                Feedback::Ack(Ack::PtpPosition {
                    position_counts: 1000,
                }),
                &[0xF1, 0x14, 0x20, 0x68, 0x03, 0x00, 0x00, 0xE0],
            ),
            (
                Feedback::Ack(Ack::StopDecel {
                    decel_counts_s2: u32::MAX,
                }),
                &[0xFF, 0x14, 0x1C, 0x7F, 0x7F, 0x7F, 0x7F, 0xE0],
            ),
            (
                Feedback::Ack(Ack::InfoEnable {
                    index: 5,
                    enabled: true,
                }),
                &[0xF0, 0x14, 0x07, 0x05, 0x01, 0x00, 0xE0],
            ),
            (
                Feedback::Notification(Notification::PVT_WATERMARK),
                &[0xF0, 0x14, 0x5A, 0x2C, 0xE0],
            ),
            (
                Feedback::Error(UnitError {
                    error: code::error::DATA,
                    code: code::QT,
                    index: 3,
                }),
                &[0xF0, 0x14, 0x0F, 0x33, 0x27, 0x03, 0xE0],
            ),
            (
                Feedback::Unknown {
                    code: 0x11,
                    data: Payload::new(&[0x80, 0x01]).unwrap(),
                },
                &[0xF1, 0x14, 0x11, 0x00, 0x01, 0xE0],
            ),
            (
                Feedback::Unknown {
                    code: 0x7F,
                    data: Payload::default(),
                },
                &[0xF0, 0x14, 0x7F, 0xE0],
            ),
        ];
        for (feedback, wire) in cases {
            let frame = feedback.to_frame(20).unwrap();
            assert_eq!(frame.code(), feedback.code());
            assert_eq!(frame.encode().as_bytes(), wire, "{feedback:?}");
            assert_eq!(Feedback::from_frame(&decode(wire)), Ok(feedback));
            if let Feedback::Ack(ack) = feedback {
                assert_eq!(ack.to_frame(20), Ok(frame));
            }
        }
    }

    #[test]
    fn wrong_layouts_are_errors() {
        let length = |code, expected, found, message: &str| {
            let frame = Frame::new(5, code, &[0; 8][..found]).unwrap();
            let error = FeedbackError::Length {
                code,
                expected,
                found,
            };
            assert_eq!(Feedback::from_frame(&frame), Err(error));
            assert_eq!(error.to_string(), message);
        };
        length(code::BG, 4, 0, "BG (0x16) carries 4 data bytes, found 0");
        length(code::MP, 3, 2, "MP (0x22) carries 3 data bytes, found 2");
        length(code::PV, 2, 3, "PV (0x23) carries 2 data bytes, found 3");
        length(code::QP, 6, 4, "QP (0x25) carries 6 data bytes, found 4");
        length(code::QV, 6, 7, "QV (0x26) carries 6 data bytes, found 7");
        length(code::QT, 3, 6, "QT (0x27) carries 3 data bytes, found 6");
        length(code::SN, 8, 4, "SN (0x0c) carries 8 data bytes, found 4");
        length(code::MO, 1, 0, "MO (0x15) carries 1 data bytes, found 0");
        length(code::SP, 4, 2, "SP (0x1e) carries 4 data bytes, found 2");
        length(code::PA, 4, 8, "PA (0x20) carries 4 data bytes, found 8");
        length(code::SD, 4, 1, "SD (0x1c) carries 4 data bytes, found 1");
        length(code::IE, 3, 1, "IE (0x07) carries 3 data bytes, found 1");
        length(
            code::RTCN,
            1,
            2,
            "RTCN (0x5a) carries 1 data bytes, found 2",
        );
        length(code::ER, 3, 0, "ER (0x0f) carries 3 data bytes, found 0");

        let flags = [
            (
                Frame::new(5, code::MO, &[2]),
                2,
                "MO (0x15) carries 2 where 0 or 1 is expected",
            ),
            (
                Frame::new(5, code::IE, &[5, 0, 1]),
                256,
                "IE (0x07) carries 256 where 0 or 1 is expected",
            ),
        ];
        for (frame, value, message) in flags {
            let frame = frame.unwrap();
            let error = FeedbackError::Flag {
                code: frame.code(),
                value,
            };
            assert_eq!(Feedback::from_frame(&frame), Err(error));
            assert_eq!(error.to_string(), message);
        }
    }

    #[test]
    fn frames_need_a_seven_bit_station_and_code() {
        assert_eq!(
            Ack::Motor { on: false }.to_frame(128),
            Err(FrameError::Station { station: 128 })
        );
        assert_eq!(
            Feedback::Notification(Notification::PVT_WATERMARK).to_frame(200),
            Err(FrameError::Station { station: 200 })
        );
        let unknown = Feedback::Unknown {
            code: 0x80,
            data: Payload::default(),
        };
        assert_eq!(unknown.to_frame(5), Err(FrameError::Code { code: 0x80 }));
    }

    #[test]
    fn unit_errors_read_well() {
        let cases = [
            (
                UnitError {
                    error: code::error::DATA,
                    code: code::QT,
                    index: 3,
                },
                "value out of range or inconsistent (error 0x33, QT (0x27), index 3)",
            ),
            (
                UnitError {
                    error: code::error::WHILE_MOVING,
                    code: code::PV,
                    index: 0,
                },
                "not allowed while the motor moves (error 0x3d, PV (0x23), index 0)",
            ),
            (
                UnitError {
                    error: code::error::SYNTAX,
                    code: 0,
                    index: 0,
                },
                "the gateway could not read the instruction (error 0x32)",
            ),
            (
                UnitError {
                    error: 0x70,
                    code: 0x44,
                    index: 1,
                },
                "unknown error (error 0x70, code 0x44, index 1)",
            ),
        ];
        for (error, message) in cases {
            assert_eq!(error.to_string(), message);
        }
    }
}
