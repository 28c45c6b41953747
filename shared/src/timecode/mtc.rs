//! MIDI timecode (MTC) from a raw MIDI byte stream — what an ALSA rawmidi device such
//! as `/dev/snd/midiC1D0` gives (as `amidi` reads it), or a FIFO or pseudo-terminal
//! fed the same bytes.
//!
//! - Quarter frames, `F1 0nnndddd`: piece `nnn` (0–7) carries a nibble of the time —
//!   0/1 frames low/high, 2/3 seconds, 4/5 minutes, 6/7 hours, piece 7 also the rate
//!   (bits 1–2: 0 24, 1 25, 2 29.97 DF, 3 30). Eight pieces, sent over two frames,
//!   make a time; running forward (pieces 0 → 7) the time they carry is that of the
//!   frame when piece 0 went out, so when piece 7 arrives the timecode is two frames
//!   later: [`MtcDecoder`] adds them. Running backward (7 → 0) the time completes at
//!   piece 0 and is given as carried (the chase stops on a backward timecode anyway).
//! - Full frame, `F0 7F <device> 01 01 hr mn sc fr F7` (`hr` = `0rrhhhhh`): a locate,
//!   sent when the sender jumps or parks.
//!
//! Real-time bytes (`F8`–`FF`) may come between any others, even inside SysEx, and are
//! skipped; every other message is ignored. Nothing here panics on any bytes.

use super::{FrameRate, Timecode};

/// Which way quarter frames run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Direction {
    /// Pieces 0 → 7: the timecode runs forward.
    Forward,
    /// Pieces 7 → 0: the timecode runs backward.
    Backward,
}

/// What the byte stream said.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MtcEvent {
    /// Eight quarter frames made a time (two frames added when forward).
    QuarterFrames {
        /// The time now.
        timecode: Timecode,
        /// Which way the pieces ran.
        direction: Direction,
    },
    /// A full-frame message: the timecode is here now (a locate, or a park).
    FullFrame(Timecode),
}

/// The longest SysEx kept, bytes (a full frame is 10).
const MAX_SYSEX: usize = 16;

/// Reads MTC from MIDI bytes, one at a time ([`MtcDecoder::push`]).
#[derive(Debug, Clone, Default)]
pub struct MtcDecoder {
    /// The nibbles of the pieces, by piece.
    pieces: [u8; 8],
    /// Which pieces arrived in the run so far (bit n = piece n).
    seen: u8,
    /// The last piece, for the direction.
    last_piece: Option<u8>,
    /// Set by an F1 status: the next data byte is a quarter frame.
    quarter_pending: bool,
    /// Inside a SysEx, its bytes so far (after F0).
    sysex: Option<Vec<u8>>,
}

impl MtcDecoder {
    /// A decoder that has seen nothing.
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes one byte; returns a time when it completes one.
    pub fn push(&mut self, byte: u8) -> Option<MtcEvent> {
        if byte >= 0xF8 {
            return None; // Real-time: may come anywhere.
        }
        if byte & 0x80 != 0 {
            // A status byte ends any SysEx (F7 properly, anything else cuts it short).
            let sysex = self.sysex.take();
            self.quarter_pending = byte == 0xF1;
            return match byte {
                0xF0 => {
                    self.sysex = Some(Vec::with_capacity(MAX_SYSEX));
                    None
                }
                0xF7 => sysex.and_then(|body| full_frame(&body)),
                _ => None,
            };
        }
        if let Some(body) = &mut self.sysex {
            if body.len() < MAX_SYSEX {
                body.push(byte);
            }
            return None;
        }
        if std::mem::take(&mut self.quarter_pending) {
            return self.quarter(byte);
        }
        None
    }

    /// Takes every byte of `bytes`; returns the times completed, in order.
    pub fn push_all(&mut self, bytes: &[u8]) -> Vec<MtcEvent> {
        bytes.iter().filter_map(|&byte| self.push(byte)).collect()
    }

    fn quarter(&mut self, data: u8) -> Option<MtcEvent> {
        let piece = (data >> 4) & 0x07;
        let direction = match self.last_piece {
            Some(last) if (last + 1) % 8 == piece => Direction::Forward,
            Some(last) if (piece + 1) % 8 == last => Direction::Backward,
            _ => {
                // A gap or a first piece: start a new run here.
                self.seen = 0;
                if piece == 7 {
                    Direction::Backward
                } else {
                    Direction::Forward
                }
            }
        };
        self.last_piece = Some(piece);
        self.pieces[usize::from(piece)] = data & 0x0F;
        let (first, last) = match direction {
            Direction::Forward => (0, 7),
            Direction::Backward => (7, 0),
        };
        if piece == first {
            self.seen = 0;
        }
        self.seen |= 1 << piece;
        if piece != last || self.seen != 0xFF {
            return None;
        }
        self.seen = 0;
        let p = self.pieces;
        let rate = FrameRate::from_code((p[7] >> 1) & 0x03)?;
        let timecode = Timecode::new(
            ((p[7] & 0x01) << 4) | p[6],
            ((p[5] & 0x03) << 4) | p[4],
            ((p[3] & 0x03) << 4) | p[2],
            ((p[1] & 0x01) << 4) | p[0],
            rate,
        )?;
        let timecode = match direction {
            Direction::Forward => timecode.plus_frames(2),
            Direction::Backward => timecode,
        };
        Some(MtcEvent::QuarterFrames {
            timecode,
            direction,
        })
    }
}

/// A full-frame SysEx body (after F0, before F7): `7F <device> 01 01 hr mn sc fr`.
fn full_frame(body: &[u8]) -> Option<MtcEvent> {
    let &[0x7F, _device, 0x01, 0x01, hr, mn, sc, fr] = body else {
        return None;
    };
    let rate = FrameRate::from_code((hr >> 5) & 0x03)?;
    Timecode::new(hr & 0x1F, mn, sc, fr, rate).map(MtcEvent::FullFrame)
}

/// The eight quarter frames of `timecode` (forward, pieces 0 → 7), as sent over the
/// two frames starting at `timecode` (for tests and the benchmark).
pub fn quarter_frames(timecode: Timecode) -> [u8; 16] {
    let nibbles = [
        timecode.frames & 0x0F,
        timecode.frames >> 4,
        timecode.seconds & 0x0F,
        timecode.seconds >> 4,
        timecode.minutes & 0x0F,
        timecode.minutes >> 4,
        timecode.hours & 0x0F,
        (timecode.hours >> 4) | (timecode.rate.code() << 1),
    ];
    let mut bytes = [0u8; 16];
    for (piece, nibble) in nibbles.iter().enumerate() {
        bytes[2 * piece] = 0xF1;
        bytes[2 * piece + 1] = ((piece as u8) << 4) | nibble;
    }
    bytes
}

/// The full-frame SysEx of `timecode`, to every device (7F).
pub fn full_frame_message(timecode: Timecode) -> [u8; 10] {
    [
        0xF0,
        0x7F,
        0x7F,
        0x01,
        0x01,
        (timecode.rate.code() << 5) | timecode.hours,
        timecode.minutes,
        timecode.seconds,
        timecode.frames,
        0xF7,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eight_quarter_frames_make_a_time_two_frames_on() {
        let mut decoder = MtcDecoder::new();
        // 01:23:45:10 at 25 fps, pieces 0 → 7, written out by hand.
        let bytes = [
            0xF1, 0x0A, 0xF1, 0x10, 0xF1, 0x2D, 0xF1, 0x32, 0xF1, 0x47, 0xF1, 0x51, 0xF1, 0x61,
            0xF1, 0x72,
        ];
        let events = decoder.push_all(&bytes);
        let rate = FrameRate::Ebu25;
        assert_eq!(
            events,
            vec![MtcEvent::QuarterFrames {
                timecode: Timecode::new(1, 23, 45, 12, rate).unwrap(),
                direction: Direction::Forward
            }]
        );
        assert_eq!(
            bytes,
            quarter_frames(Timecode::new(1, 23, 45, 10, rate).unwrap())
        );
        // The next run, two frames on, with a clock byte and active sensing between.
        let next = quarter_frames(Timecode::new(1, 23, 45, 12, rate).unwrap());
        let mut stream = Vec::new();
        for pair in next.chunks(2) {
            stream.extend_from_slice(&[pair[0], 0xF8, pair[1], 0xFE]);
        }
        let events = decoder.push_all(&stream);
        assert_eq!(events.len(), 1, "{events:?}");
        let MtcEvent::QuarterFrames { timecode, .. } = events[0] else {
            panic!("{events:?}");
        };
        assert_eq!(timecode.to_string(), "01:23:45:14");
    }

    #[test]
    fn a_run_started_mid_way_waits_for_piece_0_and_drop_frame_wraps() {
        let rate = FrameRate::Df2997;
        let tc = Timecode::new(0, 0, 59, 28, rate).unwrap();
        let bytes = quarter_frames(tc);
        let mut decoder = MtcDecoder::new();
        // From piece 3 on: no time until a whole run.
        assert_eq!(decoder.push_all(&bytes[6..]), vec![]);
        let events = decoder.push_all(&bytes);
        let [MtcEvent::QuarterFrames { timecode, .. }] = events.as_slice() else {
            panic!("{events:?}");
        };
        assert_eq!(timecode.to_string(), "00:01:00;02");
    }

    #[test]
    fn backward_pieces_are_told_and_full_frames_read() {
        let rate = FrameRate::Smpte30;
        let tc = Timecode::new(10, 0, 0, 5, rate).unwrap();
        let forward = quarter_frames(tc);
        let mut backward = Vec::new();
        for pair in forward.chunks(2).rev() {
            backward.extend_from_slice(pair);
        }
        let events = MtcDecoder::new().push_all(&backward);
        assert_eq!(
            events,
            vec![MtcEvent::QuarterFrames {
                timecode: tc,
                direction: Direction::Backward
            }]
        );
        let full = full_frame_message(Timecode::new(2, 3, 4, 5, FrameRate::Film24).unwrap());
        assert_eq!(full, [0xF0, 0x7F, 0x7F, 0x01, 0x01, 0x02, 3, 4, 5, 0xF7]);
        let mut decoder = MtcDecoder::new();
        // A note, a clock inside the SysEx, then the full frame.
        let mut stream = vec![0x90, 0x40, 0x7F];
        stream.extend_from_slice(&full[..4]);
        stream.push(0xF8);
        stream.extend_from_slice(&full[4..]);
        assert_eq!(
            decoder.push_all(&stream),
            vec![MtcEvent::FullFrame(
                Timecode::new(2, 3, 4, 5, FrameRate::Film24).unwrap()
            )]
        );
        // A 29.97 DF full frame: hr = 0x40 | hours.
        assert_eq!(
            decoder.push_all(&[0xF0, 0x7F, 0x01, 0x01, 0x01, 0x41, 0, 0, 0, 0xF7]),
            vec![MtcEvent::FullFrame(
                Timecode::new(1, 0, 0, 0, FrameRate::Df2997).unwrap()
            )]
        );
        // Other SysEx, one cut short, and out-of-range times give nothing.
        assert_eq!(
            decoder.push_all(&[0xF0, 0x7E, 0x7F, 0x06, 0x01, 0xF7]),
            vec![]
        );
        assert_eq!(decoder.push_all(&[0xF0, 0x7F, 0x7F, 0x01, 0x90]), vec![]);
        assert_eq!(
            decoder.push_all(&[0xF0, 0x7F, 0x7F, 0x01, 0x01, 0x20, 0, 0, 25, 0xF7]),
            vec![]
        );
    }

    #[test]
    fn no_bytes_panic_the_decoder() {
        let mut decoder = MtcDecoder::new();
        let mut seed = 0x1234_5678u32;
        for _ in 0..100_000 {
            seed = seed.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            let _ = decoder.push((seed >> 16) as u8);
        }
    }
}
