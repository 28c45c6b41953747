//! Finding frames in the gateway's byte stream.
//!
//! A byte `0xFy` always starts a frame, wherever it appears, so a valid frame is found
//! whatever came before it. What cannot be a frame is dropped and counted:
//!
//! - bytes outside any frame (*stray*);
//! - a frame cut short by a new header, or by a tail before its station and code
//!   (*truncated*);
//! - a frame with more than 8 data bytes (*overlong*): the rest, up to its tail or the
//!   next header, is dropped with it;
//! - a frame with a byte `0x80`–`0xDF` inside, or a header/tail bit set for a data byte
//!   that is not there (*malformed*).
//!
//! The decoder keeps at most one partial frame (11 bytes) and never allocates.
//!
//! ```
//! use floatball_shared::uim2503::feedback::{DecoderStats, FrameDecoder};
//!
//! let mut decoder = FrameDecoder::new();
//! // Line noise, half a frame, then a whole one split over two reads.
//! assert_eq!(decoder.push(&[0x00, 0x41, 0xF0, 0x05]).count(), 0);
//! let frames: Vec<_> = decoder.push(&[0xF0, 0x05, 0x23, 0x03]).collect();
//! assert!(frames.is_empty());
//! let frames: Vec<_> = decoder.push(&[0x00, 0xE0]).collect();
//! assert_eq!(frames[0].data(), [3, 0]);
//! assert_eq!(
//!     decoder.stats(),
//!     DecoderStats { frames: 1, stray_bytes: 2, truncated_frames: 1, dropped_bytes: 4, ..DecoderStats::default() }
//! );
//! ```

use super::{Frame, MAX_DATA, Payload};

/// What a [`FrameDecoder`] has seen so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DecoderStats {
    /// Frames delivered.
    pub frames: u64,
    /// Bytes outside any frame.
    pub stray_bytes: u64,
    /// Frames cut short by a new header or an early tail.
    pub truncated_frames: u64,
    /// Frames with more than 8 data bytes.
    pub overlong_frames: u64,
    /// Frames with an impossible byte or header/tail bit.
    pub malformed_frames: u64,
    /// Every byte not delivered in a frame: stray bytes and the bytes of dropped frames.
    pub dropped_bytes: u64,
}

/// Where the decoder is in a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Between frames.
    Idle,
    /// After the header.
    Station,
    /// After the station.
    Code,
    /// After the code, reading data bytes.
    Data,
    /// In a frame already dropped, until its tail or the next header.
    Skipping,
}

/// A streaming feedback frame decoder; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct FrameDecoder {
    state: State,
    /// The header's low nibble: bit 7 of D0–D3.
    header_bits: u8,
    station: u8,
    code: u8,
    data: [u8; MAX_DATA],
    len: usize,
    stats: DecoderStats,
}

impl Default for FrameDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameDecoder {
    /// A decoder between frames.
    pub fn new() -> Self {
        Self {
            state: State::Idle,
            header_bits: 0,
            station: 0,
            code: 0,
            data: [0; MAX_DATA],
            len: 0,
            stats: DecoderStats::default(),
        }
    }

    /// Counts so far.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// The bytes of a frame started but not finished.
    pub fn pending(&self) -> usize {
        match self.state {
            State::Idle | State::Skipping => 0,
            State::Station => 1,
            State::Code => 2,
            State::Data => 3 + self.len,
        }
    }

    /// Feeds a chunk of bytes; the iterator yields the frames they complete. Bytes the
    /// iterator has not reached when it is dropped are not read.
    pub fn push<'d, 'b>(&'d mut self, bytes: &'b [u8]) -> Frames<'d, 'b> {
        Frames {
            decoder: self,
            bytes,
        }
    }

    /// Feeds one byte; yields the frame it completes, if it is a valid tail.
    pub fn push_byte(&mut self, byte: u8) -> Option<Frame> {
        let pending = self.pending() as u64;
        match (self.state, byte) {
            (_, 0xF0..=0xFF) => {
                if pending > 0 {
                    self.drop_frame(|stats| &mut stats.truncated_frames, pending);
                }
                self.header_bits = byte & 0x0F;
                self.len = 0;
                self.state = State::Station;
            }
            (State::Idle, _) => {
                bump(&mut self.stats.stray_bytes, 1);
                bump(&mut self.stats.dropped_bytes, 1);
            }
            (State::Skipping, _) => {
                bump(&mut self.stats.dropped_bytes, 1);
                if byte >> 4 == 0xE {
                    self.state = State::Idle;
                }
            }
            (State::Station | State::Code, 0xE0..=0xEF) => {
                self.drop_frame(|stats| &mut stats.truncated_frames, pending + 1);
                self.state = State::Idle;
            }
            (State::Data, 0xE0..=0xEF) => return self.finish(byte),
            (_, 0x80..=0xDF) => {
                self.drop_frame(|stats| &mut stats.malformed_frames, pending + 1);
                self.state = State::Skipping;
            }
            (State::Station, _) => {
                self.station = byte;
                self.state = State::Code;
            }
            (State::Code, _) => {
                self.code = byte;
                self.state = State::Data;
            }
            (State::Data, _) => match self.data.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => {
                    self.drop_frame(|stats| &mut stats.overlong_frames, pending + 1);
                    self.state = State::Skipping;
                }
            },
        }
        None
    }

    /// Counts a dropped frame of `bytes` bytes under `counter`.
    fn drop_frame(&mut self, counter: fn(&mut DecoderStats) -> &mut u64, bytes: u64) {
        bump(counter(&mut self.stats), 1);
        bump(&mut self.stats.dropped_bytes, bytes);
    }

    /// The tail of a frame in [`State::Data`].
    fn finish(&mut self, tail: u8) -> Option<Frame> {
        let pending = self.pending() as u64;
        self.state = State::Idle;
        let high_bits = u16::from(self.header_bits) | (u16::from(tail & 0x0F) << 4);
        let present = (1_u16 << self.len) - 1;
        if high_bits & !present != 0 {
            self.drop_frame(|stats| &mut stats.malformed_frames, pending + 1);
            return None;
        }
        let mut data = [0; MAX_DATA];
        for (i, (restored, &byte)) in data.iter_mut().zip(&self.data).take(self.len).enumerate() {
            *restored = byte | (((high_bits >> i) & 1) as u8) << 7;
        }
        bump(&mut self.stats.frames, 1);
        Some(Frame {
            station: self.station,
            code: self.code,
            data: Payload {
                bytes: data,
                len: self.len,
            },
        })
    }
}

fn bump(counter: &mut u64, by: u64) {
    *counter = counter.saturating_add(by);
}

/// The frames completed by one chunk: see [`FrameDecoder::push`].
#[derive(Debug)]
#[must_use = "bytes are read only as the iterator is advanced"]
pub struct Frames<'d, 'b> {
    decoder: &'d mut FrameDecoder,
    bytes: &'b [u8],
}

impl Iterator for Frames<'_, '_> {
    type Item = Frame;

    fn next(&mut self) -> Option<Frame> {
        while let Some((&byte, rest)) = self.bytes.split_first() {
            self.bytes = rest;
            if let Some(frame) = self.decoder.push_byte(byte) {
                return Some(frame);
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const MANUAL: [u8; 12] = [
        0xF3, 0x05, 0x0D, 0x70, 0x71, 0x72, 0x03, 0x14, 0x15, 0x16, 0x17, 0xE7,
    ];
    const MANUAL_DATA: [u8; 8] = [0xF0, 0xF1, 0x72, 0x03, 0x94, 0x95, 0x96, 0x17];

    #[test]
    fn the_manuals_vector_decodes_in_one_chunk_and_byte_by_byte() {
        let mut decoder = FrameDecoder::new();
        let frames: Vec<Frame> = decoder.push(&MANUAL).collect();
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].station(), 5);
        assert_eq!(frames[0].code(), 13);
        assert_eq!(frames[0].data(), MANUAL_DATA);

        let mut frames = Vec::new();
        for &byte in &MANUAL {
            frames.extend(decoder.push_byte(byte));
        }
        assert_eq!(frames, [Frame::new(5, 13, &MANUAL_DATA).unwrap()]);
        assert_eq!(
            decoder.stats(),
            DecoderStats {
                frames: 2,
                ..DecoderStats::default()
            }
        );
    }

    #[test]
    fn pending_counts_the_partial_frame() {
        let mut decoder = FrameDecoder::default();
        for (i, &byte) in MANUAL[..11].iter().enumerate() {
            assert_eq!(decoder.push_byte(byte), None);
            assert_eq!(decoder.pending(), i + 1);
        }
        assert!(decoder.push_byte(MANUAL[11]).is_some());
        assert_eq!(decoder.pending(), 0);
    }

    /// Each kind of damage, followed by the manual's frame: the frame is recovered and
    /// the damage counted.
    #[test]
    fn recovers_from_every_kind_of_damage_and_counts_it() {
        let stats = |stray, truncated, overlong, malformed, dropped| DecoderStats {
            frames: 1,
            stray_bytes: stray,
            truncated_frames: truncated,
            overlong_frames: overlong,
            malformed_frames: malformed,
            dropped_bytes: dropped,
        };
        let cases: [(&str, &[u8], DecoderStats); 11] = [
            ("nothing", &[], stats(0, 0, 0, 0, 0)),
            (
                "stray bytes",
                &[0x00, 0x7F, 0xE0, 0x80, 0xDF],
                stats(5, 0, 0, 0, 5),
            ),
            ("a lone header", &[0xF0], stats(0, 1, 0, 0, 1)),
            ("a header and station", &[0xF2, 0x05], stats(0, 1, 0, 0, 2)),
            (
                "a frame cut in its data",
                &[0xF0, 0x05, 0x25, 1, 2, 3],
                stats(0, 1, 0, 0, 6),
            ),
            (
                "a tail before the code",
                &[0xF0, 0x05, 0xE0],
                stats(0, 1, 0, 0, 3),
            ),
            (
                "nine data bytes, up to the tail",
                &[0xF0, 5, 0x25, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 0xE0, 0x00],
                stats(1, 0, 1, 0, 15),
            ),
            (
                "nine data bytes, up to a header",
                &[0xF0, 5, 0x25, 1, 2, 3, 4, 5, 6, 7, 8, 9],
                stats(0, 0, 1, 0, 12),
            ),
            (
                "a byte 0x80-0xDF inside",
                &[0xF0, 5, 0x25, 1, 0xC5, 2, 0xE0],
                stats(0, 0, 0, 1, 7),
            ),
            (
                "a header bit for a missing byte",
                &[0xF4, 5, 0x25, 1, 2, 0xE0],
                stats(0, 0, 0, 1, 6),
            ),
            (
                "a tail bit for a missing byte",
                &[0xF0, 5, 0x25, 1, 2, 3, 4, 0xE2],
                stats(0, 0, 0, 1, 8),
            ),
        ];
        for (what, damage, expected) in cases {
            let mut decoder = FrameDecoder::new();
            let mut wire = damage.to_vec();
            wire.extend_from_slice(&MANUAL);
            let frames: Vec<Frame> = decoder.push(&wire).collect();
            assert_eq!(frames, [Frame::new(5, 13, &MANUAL_DATA).unwrap()], "{what}");
            assert_eq!(decoder.stats(), expected, "{what}");
        }
    }

    #[test]
    fn frames_without_data_and_with_eight_bytes_are_valid() {
        let mut decoder = FrameDecoder::new();
        let frames: Vec<Frame> = decoder
            .push(&[
                0xF0, 0x05, 0x0C, 0xE0, 0xFF, 0x7F, 0x7F, 1, 2, 3, 4, 5, 6, 7, 8, 0xEF,
            ])
            .collect();
        assert_eq!(
            frames,
            [
                Frame::new(5, 0x0C, &[]).unwrap(),
                Frame::new(
                    0x7F,
                    0x7F,
                    &[0x81, 0x82, 0x83, 0x84, 0x85, 0x86, 0x87, 0x88]
                )
                .unwrap(),
            ]
        );
        assert_eq!(decoder.stats().dropped_bytes, 0);
    }

    #[test]
    fn a_dropped_iterator_leaves_the_rest_unread() {
        let mut decoder = FrameDecoder::new();
        let mut wire = MANUAL.to_vec();
        wire.extend_from_slice(&MANUAL);
        assert!(decoder.push(&wire).next().is_some());
        assert_eq!(decoder.stats().frames, 1);
        assert_eq!(decoder.pending(), 0);
    }
}
