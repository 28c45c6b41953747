//! The binary feedback frames the gateway sends the host (manual §6.2–6.3, §8 "ACK";
//! `docs/protocol-notes.md` §2).
//!
//! `[0xFy header] [station] [code] [data 0] … [data n] [0xEy tail]`: 4–12 bytes, at most
//! 8 data bytes. Only the header has high nibble F and only the tail has E; every other
//! byte has bit 7 clear on the wire. The data bytes' bit 7s travel in the header
//! (`1111 D3.7 D2.7 D1.7 D0.7`) and the tail (`1110 D7.7 D6.7 D5.7 D4.7`).
//!
//! - [`Frame`] is one frame with its data restored; [`Frame::encode`] writes it.
//! - [`FrameDecoder`] finds frames in a byte stream of any chunking and recovers from
//!   garbage, counting what it drops ([`DecoderStats`]).
//! - [`Feedback`] says what a frame means (ACKs, the RTCN notification, errors), and
//!   builds the frame back; [`code`] holds every code and value in one place.
//!
//! # Example
//! ```
//! use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame, FrameDecoder};
//!
//! // The manual's example (§6.3): bit 7 of D0, D1, D4, D5, D6 restored.
//! let wire = [0xF3, 0x05, 0x0D, 0x70, 0x71, 0x72, 0x03, 0x14, 0x15, 0x16, 0x17, 0xE7];
//! let mut decoder = FrameDecoder::new();
//! let frames: Vec<Frame> = decoder.push(&wire).collect();
//! assert_eq!((frames[0].station(), frames[0].code()), (5, 13));
//! assert_eq!(frames[0].data(), [0xF0, 0xF1, 0x72, 0x03, 0x94, 0x95, 0x96, 0x17]);
//! assert_eq!(frames[0].encode().as_bytes(), wire);
//!
//! // A unit on station 20 acknowledges `QP[3]=-9000;`.
//! let ack = Ack::PvtPosition { row: 3, position_counts: -9000 };
//! let frame = ack.to_frame(20)?;
//! let decoded: Vec<Frame> = decoder.push(frame.encode().as_bytes()).collect();
//! assert_eq!(Feedback::from_frame(&decoded[0]), Ok(Feedback::Ack(ack)));
//! # Ok::<(), floatball_shared::uim2503::feedback::FrameError>(())
//! ```

pub mod code;
mod decoder;
mod message;

use std::fmt;

pub use decoder::{DecoderStats, FrameDecoder, Frames};
pub use message::{Ack, Feedback, FeedbackError, Notification, UnitError};

/// The most data bytes a frame carries.
pub const MAX_DATA: usize = 8;
/// The longest frame on the wire: header, station, code, 8 data bytes, tail.
pub const MAX_FRAME_LEN: usize = MAX_DATA + 4;

/// The data bytes of a frame (0–8, restored to 8 bits).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Payload {
    bytes: [u8; MAX_DATA],
    len: usize,
}

impl Payload {
    /// Up to [`MAX_DATA`] bytes.
    ///
    /// # Errors
    /// [`FrameError::TooMuchData`] for more than 8 bytes.
    pub fn new(data: &[u8]) -> Result<Self, FrameError> {
        let mut bytes = [0; MAX_DATA];
        bytes
            .get_mut(..data.len())
            .ok_or(FrameError::TooMuchData { len: data.len() })?
            .copy_from_slice(data);
        Ok(Self {
            bytes,
            len: data.len(),
        })
    }

    /// The bytes.
    pub fn as_slice(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or_default()
    }
}

impl fmt::Debug for Payload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02X?}", self.as_slice())
    }
}

/// One feedback frame, its data bytes restored.
///
/// Station and code travel without bit 7, so both are 0–127.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Frame {
    station: u8,
    code: u8,
    data: Payload,
}

/// Why a frame cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// More than 8 data bytes.
    #[error("a feedback frame carries at most 8 data bytes, not {len}")]
    TooMuchData {
        /// The number of bytes given.
        len: usize,
    },
    /// A station above 127, which the wire cannot carry.
    #[error("station {station} does not fit in a feedback frame (0–127)")]
    Station {
        /// The station given.
        station: u8,
    },
    /// A code above 127, which the wire cannot carry.
    #[error("code {code:#04x} does not fit in a feedback frame (0x00–0x7f)")]
    Code {
        /// The code given.
        code: u8,
    },
}

impl Frame {
    /// A frame from `station` with `code` and up to 8 data bytes.
    ///
    /// # Errors
    /// [`FrameError`] if the station or code exceed 127 or there are more than 8 data
    /// bytes.
    pub fn new(station: u8, code: u8, data: &[u8]) -> Result<Self, FrameError> {
        Self::from_payload(station, code, Payload::new(data)?)
    }

    fn from_payload(station: u8, code: u8, data: Payload) -> Result<Self, FrameError> {
        if station > 0x7F {
            return Err(FrameError::Station { station });
        }
        if code > 0x7F {
            return Err(FrameError::Code { code });
        }
        Ok(Self {
            station,
            code,
            data,
        })
    }

    /// The station (CAN id) of the unit that sent the frame.
    pub fn station(&self) -> u8 {
        self.station
    }

    /// The frame's code: which instruction it answers, or what it reports.
    pub fn code(&self) -> u8 {
        self.code
    }

    /// The data bytes, restored to 8 bits.
    pub fn data(&self) -> &[u8] {
        self.data.as_slice()
    }

    /// The frame's length on the wire, 4–12 bytes.
    pub fn encoded_len(&self) -> usize {
        self.data.len + 4
    }

    /// The frame as the gateway sends it.
    pub fn encode(&self) -> EncodedFrame {
        let data = self.data();
        let high_bits = data
            .iter()
            .enumerate()
            .fold(0_u8, |bits, (i, byte)| bits | ((byte >> 7) << i));
        let mut bytes = [0; MAX_FRAME_LEN];
        bytes[0] = 0xF0 | (high_bits & 0x0F);
        bytes[1] = self.station;
        bytes[2] = self.code;
        for (slot, byte) in bytes[3..].iter_mut().zip(data) {
            *slot = byte & 0x7F;
        }
        bytes[3 + data.len()] = 0xE0 | (high_bits >> 4);
        EncodedFrame {
            bytes,
            len: self.encoded_len(),
        }
    }

    /// Appends the frame as the gateway sends it to `out` and returns its length.
    pub fn encode_into(&self, out: &mut Vec<u8>) -> usize {
        let encoded = self.encode();
        out.extend_from_slice(encoded.as_bytes());
        encoded.len
    }
}

/// A frame's bytes on the wire, kept on the stack.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EncodedFrame {
    bytes: [u8; MAX_FRAME_LEN],
    len: usize,
}

impl EncodedFrame {
    /// The bytes, header to tail.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn the_manuals_vector_encodes_back_to_its_bytes() {
        let frame = Frame::new(5, 13, &[0xF0, 0xF1, 0x72, 0x03, 0x94, 0x95, 0x96, 0x17]).unwrap();
        assert_eq!(
            frame.encode().as_bytes(),
            [
                0xF3, 0x05, 0x0D, 0x70, 0x71, 0x72, 0x03, 0x14, 0x15, 0x16, 0x17, 0xE7
            ]
        );
        assert_eq!(frame.encoded_len(), 12);
    }

    #[test]
    fn frames_of_every_length_encode() {
        let cases: [(&[u8], &[u8]); 4] = [
            (&[], &[0xF0, 0x07, 0x5A, 0xE0]),
            (&[0x80], &[0xF1, 0x07, 0x5A, 0x00, 0xE0]),
            (
                &[0, 0, 0, 0, 0xFF],
                &[0xF0, 0x07, 0x5A, 0, 0, 0, 0, 0x7F, 0xE1],
            ),
            (
                &[0xFF; 8],
                &[
                    0xFF, 0x07, 0x5A, 0x7F, 0x7F, 0x7F, 0x7F, 0x7F, 0x7F, 0x7F, 0x7F, 0xEF,
                ],
            ),
        ];
        for (data, wire) in cases {
            let frame = Frame::new(7, 0x5A, data).unwrap();
            assert_eq!(frame.data(), data);
            assert_eq!(frame.encode().as_bytes(), wire);
            let mut out = vec![0xAA];
            assert_eq!(frame.encode_into(&mut out), wire.len());
            assert_eq!(&out[1..], wire);
        }
    }

    #[test]
    fn frames_refuse_what_the_wire_cannot_carry() {
        let cases = [
            (
                Frame::new(5, 0x16, &[0; 9]),
                FrameError::TooMuchData { len: 9 },
                "a feedback frame carries at most 8 data bytes, not 9",
            ),
            (
                Frame::new(128, 0x16, &[]),
                FrameError::Station { station: 128 },
                "station 128 does not fit in a feedback frame (0–127)",
            ),
            (
                Frame::new(5, 0x96, &[]),
                FrameError::Code { code: 0x96 },
                "code 0x96 does not fit in a feedback frame (0x00–0x7f)",
            ),
        ];
        for (result, error, message) in cases {
            assert_eq!(result, Err(error));
            assert_eq!(error.to_string(), message);
        }
    }

    #[test]
    fn payload_debug_is_hex() {
        let payload = Payload::new(&[0x0A, 0xFF]).unwrap();
        assert_eq!(format!("{payload:?}"), "[0A, FF]");
        assert_eq!(Payload::default().as_slice(), [0; 0]);
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn frame() -> impl Strategy<Value = Frame> {
        (
            0..=0x7F_u8,
            0..=0x7F_u8,
            proptest::collection::vec(any::<u8>(), 0..=MAX_DATA),
        )
            .prop_filter_map("valid frame", |(station, code, data)| {
                Frame::new(station, code, &data).ok()
            })
    }

    fn ack() -> impl Strategy<Value = Ack> {
        prop_oneof![
            any::<u32>().prop_map(|at_us| Ack::Begin { at_us }),
            any::<(u8, u16)>().prop_map(|(param, value)| Ack::MotionProfile { param, value }),
            any::<u16>().prop_map(|value| Ack::PvtStart { value }),
            any::<(u16, i32)>().prop_map(|(row, position_counts)| Ack::PvtPosition {
                row,
                position_counts
            }),
            any::<(u16, i32)>().prop_map(|(row, velocity_counts_s)| Ack::PvtVelocity {
                row,
                velocity_counts_s
            }),
            any::<(u16, u8)>().prop_map(|(row, duration_ms)| Ack::PvtTime { row, duration_ms }),
            any::<u64>().prop_map(|serial| Ack::Serial { serial }),
            any::<bool>().prop_map(|on| Ack::Motor { on }),
            any::<i32>().prop_map(|speed_counts_s| Ack::PtpSpeed { speed_counts_s }),
            any::<i32>().prop_map(|position_counts| Ack::PtpPosition { position_counts }),
            any::<u32>().prop_map(|decel_counts_s2| Ack::StopDecel { decel_counts_s2 }),
            any::<(u8, bool)>().prop_map(|(index, enabled)| Ack::InfoEnable { index, enabled }),
        ]
    }

    fn feedback() -> impl Strategy<Value = Feedback> {
        let unknown = (
            (0..=0x7F_u8).prop_filter("a known code", |&c| code::name(c).is_none()),
            proptest::collection::vec(any::<u8>(), 0..=MAX_DATA),
        )
            .prop_filter_map("payload", |(code, data)| {
                Some(Feedback::Unknown {
                    code,
                    data: Payload::new(&data).ok()?,
                })
            });
        prop_oneof![
            ack().prop_map(Feedback::Ack),
            any::<u8>().prop_map(|kind| Feedback::Notification(Notification { kind })),
            any::<(u8, u8, u8)>().prop_map(|(error, code, index)| Feedback::Error(UnitError {
                error,
                code,
                index
            })),
            unknown,
        ]
    }

    /// Splits `bytes` at `cuts` and feeds the pieces to `decoder`.
    fn feed_in_chunks(
        decoder: &mut FrameDecoder,
        bytes: &[u8],
        cuts: &[prop::sample::Index],
    ) -> Vec<Frame> {
        let mut cuts: Vec<usize> = cuts.iter().map(|cut| cut.index(bytes.len() + 1)).collect();
        cuts.sort_unstable();
        let mut frames = Vec::new();
        let mut from = 0;
        for cut in cuts.into_iter().chain([bytes.len()]) {
            frames.extend(decoder.push(&bytes[from..cut]));
            from = cut;
        }
        frames
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2048))]

        /// decode(encode(frame)) == frame, and the wire keeps its shape.
        #[test]
        fn decode_of_encode_is_identity(frame in frame()) {
            let encoded = frame.encode();
            let wire = encoded.as_bytes();
            prop_assert_eq!(wire.len(), frame.encoded_len());
            prop_assert_eq!(wire[0] >> 4, 0xF);
            prop_assert_eq!(wire[wire.len() - 1] >> 4, 0xE);
            prop_assert!(wire[1..wire.len() - 1].iter().all(|&b| b < 0x80));
            let mut decoder = FrameDecoder::new();
            prop_assert_eq!(decoder.push(wire).collect::<Vec<_>>(), vec![frame]);
            prop_assert_eq!(decoder.stats().dropped_bytes, 0);
        }

        /// Any chunking of a stream of frames yields the same frames.
        #[test]
        fn chunking_does_not_matter(
            frames in proptest::collection::vec(frame(), 0..20),
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..20),
        ) {
            let mut wire = Vec::new();
            for frame in &frames {
                frame.encode_into(&mut wire);
            }
            let mut decoder = FrameDecoder::new();
            prop_assert_eq!(feed_in_chunks(&mut decoder, &wire, &cuts), frames);
            prop_assert_eq!(decoder.pending(), 0);
        }

        /// Whatever garbage comes first, every valid frame after it is recovered.
        #[test]
        fn every_frame_after_garbage_is_recovered(
            garbage in proptest::collection::vec(any::<u8>(), 0..64),
            frames in proptest::collection::vec(frame(), 1..8),
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..8),
        ) {
            let mut wire = garbage;
            for frame in &frames {
                frame.encode_into(&mut wire);
            }
            let mut decoder = FrameDecoder::new();
            let decoded = feed_in_chunks(&mut decoder, &wire, &cuts);
            prop_assert!(decoded.len() >= frames.len());
            prop_assert_eq!(&decoded[decoded.len() - frames.len()..], frames.as_slice());
        }

        /// On any bytes the decoder never panics, holds at most one partial frame, and
        /// accounts for every byte: delivered, dropped, or pending.
        #[test]
        fn every_byte_is_accounted_for(
            bytes in proptest::collection::vec(
                prop_oneof![any::<u8>(), 0xE0..=0xFF_u8, 0..0x10_u8],
                0..400,
            ),
        ) {
            let mut decoder = FrameDecoder::new();
            let mut delivered = 0;
            for &byte in &bytes {
                if let Some(frame) = decoder.push_byte(byte) {
                    delivered += frame.encoded_len();
                }
                prop_assert!(decoder.pending() < MAX_FRAME_LEN);
            }
            let stats = decoder.stats();
            prop_assert_eq!(
                delivered as u64 + stats.dropped_bytes + decoder.pending() as u64,
                bytes.len() as u64
            );
            prop_assert!(stats.stray_bytes <= stats.dropped_bytes);
        }

        /// from_frame and to_frame are exact inverses, both ways.
        #[test]
        fn feedback_round_trips(feedback in feedback(), station in 0..=0x7F_u8) {
            let frame = feedback.to_frame(station);
            prop_assert!(frame.is_ok());
            if let Ok(frame) = frame {
                prop_assert_eq!(frame.code(), feedback.code());
                prop_assert_eq!(Feedback::from_frame(&frame), Ok(feedback));
            }
        }

        #[test]
        fn every_frame_that_decodes_encodes_back(frame in frame()) {
            if let Ok(feedback) = Feedback::from_frame(&frame) {
                prop_assert_eq!(feedback.to_frame(frame.station()), Ok(frame));
            }
        }
    }
}
