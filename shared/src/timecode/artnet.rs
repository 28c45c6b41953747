//! Art-Net 4's OpTimeCode (Artistic Licence, "ArtTimeCode"), received on UDP 6454.
//!
//! Every Art-Net packet starts with the 8 bytes `Art-Net\0` and a 16-bit OpCode,
//! low byte first. ArtTimeCode (OpCode 0x9700) then has ProtVer (high byte first,
//! 14 or more), two fillers (the second is the stream id in Art-Net 4), and Frames,
//! Seconds, Minutes, Hours and Type (0 film 24, 1 EBU 25, 2 DF 29.97, 3 SMPTE 30):
//! 19 bytes. [`decode`] tells an OpTimeCode from any other Art-Net packet by its
//! OpCode ([`Packet::Other`]), so a receiver on port 6454 can hand OpDmx to another
//! reader later.

use super::{FrameRate, Timecode};

/// The ID every Art-Net packet starts with.
pub const ID: &[u8; 8] = b"Art-Net\0";
/// OpTimeCode.
pub const OP_TIME_CODE: u16 = 0x9700;
/// OpDmx (ArtDmx), for a later DMX input on the same socket.
pub const OP_DMX: u16 = 0x5000;
/// The lowest protocol version receivers accept.
pub const MIN_PROT_VER: u16 = 14;
/// An ArtTimeCode's length, bytes.
pub const TIME_CODE_LEN: usize = 19;
/// Art-Net's UDP port.
pub const PORT: u16 = 6454;

/// A decoded Art-Net packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packet {
    /// An ArtTimeCode.
    TimeCode {
        /// The time.
        timecode: Timecode,
        /// The stream (Art-Net 4's second filler; 0 is the master).
        stream: u8,
    },
    /// Any other Art-Net packet, by its OpCode (not read further here).
    Other {
        /// The OpCode.
        opcode: u16,
    },
}

/// Why bytes are not an Art-Net packet this module reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArtNetError {
    /// Not Art-Net: no `Art-Net\0` ID, or shorter than the header.
    NotArtNet,
    /// An OpTimeCode shorter than 19 bytes or with a ProtVer below 14.
    BadTimeCode,
    /// An OpTimeCode whose fields are out of range for its type.
    OutOfRange,
}

impl std::fmt::Display for ArtNetError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::NotArtNet => "not an Art-Net packet",
            Self::BadTimeCode => "an ArtTimeCode too short or of a protocol version below 14",
            Self::OutOfRange => "an ArtTimeCode with a time out of range for its frame rate",
        })
    }
}

/// Reads one datagram.
///
/// # Errors
/// [`ArtNetError`]: not Art-Net, or a malformed ArtTimeCode.
pub fn decode(bytes: &[u8]) -> Result<Packet, ArtNetError> {
    let (Some(id), Some(&[low, high])) = (bytes.get(..8), bytes.get(8..10)) else {
        return Err(ArtNetError::NotArtNet);
    };
    if id != ID {
        return Err(ArtNetError::NotArtNet);
    }
    let opcode = u16::from_le_bytes([low, high]);
    if opcode != OP_TIME_CODE {
        return Ok(Packet::Other { opcode });
    }
    let Some(
        &[
            ver_high,
            ver_low,
            _filler,
            stream,
            frames,
            seconds,
            minutes,
            hours,
            kind,
        ],
    ) = bytes.get(10..TIME_CODE_LEN)
    else {
        return Err(ArtNetError::BadTimeCode);
    };
    if u16::from_be_bytes([ver_high, ver_low]) < MIN_PROT_VER {
        return Err(ArtNetError::BadTimeCode);
    }
    let rate = FrameRate::from_code(kind).ok_or(ArtNetError::OutOfRange)?;
    let timecode =
        Timecode::new(hours, minutes, seconds, frames, rate).ok_or(ArtNetError::OutOfRange)?;
    Ok(Packet::TimeCode { timecode, stream })
}

/// An ArtTimeCode of `timecode` on stream 0 (for tests and the benchmark).
pub fn encode(timecode: Timecode) -> [u8; TIME_CODE_LEN] {
    let mut bytes = [0u8; TIME_CODE_LEN];
    bytes[..8].copy_from_slice(ID);
    bytes[8..10].copy_from_slice(&OP_TIME_CODE.to_le_bytes());
    bytes[10..12].copy_from_slice(&MIN_PROT_VER.to_be_bytes());
    bytes[14] = timecode.frames;
    bytes[15] = timecode.seconds;
    bytes[16] = timecode.minutes;
    bytes[17] = timecode.hours;
    bytes[18] = timecode.rate.code();
    bytes
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ola_s_timecode_packets_decode() {
        // As olad's Art-Net plugin sent `ola_timecode 01:02:03:04` (SMPTE) and
        // `ola_timecode -f EBU 00:00:10:05`, captured on 127.0.0.1:6454.
        let smpte = hex("4172742d4e6574000097000e00000403020103");
        let ebu = hex("4172742d4e6574000097000e0000050a000001");
        assert_eq!(
            decode(&smpte),
            Ok(Packet::TimeCode {
                timecode: Timecode::new(1, 2, 3, 4, FrameRate::Smpte30).unwrap(),
                stream: 0
            })
        );
        let Ok(Packet::TimeCode { timecode, .. }) = decode(&ebu) else {
            panic!("{:?}", decode(&ebu));
        };
        assert_eq!(timecode.to_string(), "00:00:10:05");
        assert_eq!(timecode.rate, FrameRate::Ebu25);
        assert_eq!(encode(timecode).as_slice(), ebu.as_slice());
    }

    #[test]
    fn other_packets_are_told_apart_and_bad_ones_refused() {
        let mut dmx = vec![0u8; 530];
        dmx[..8].copy_from_slice(ID);
        dmx[8..10].copy_from_slice(&OP_DMX.to_le_bytes());
        assert_eq!(decode(&dmx), Ok(Packet::Other { opcode: OP_DMX }));
        assert_eq!(decode(b"Art-Net"), Err(ArtNetError::NotArtNet));
        assert_eq!(decode(b"OSC-Net\0\x00\x97"), Err(ArtNetError::NotArtNet));
        let good = encode(Timecode::new(0, 0, 1, 2, FrameRate::Film24).unwrap());
        assert_eq!(decode(&good[..18]), Err(ArtNetError::BadTimeCode));
        let mut old = good;
        old[11] = 13;
        assert_eq!(decode(&old), Err(ArtNetError::BadTimeCode));
        let mut frames = good;
        frames[14] = 24;
        assert_eq!(decode(&frames), Err(ArtNetError::OutOfRange));
        let mut kind = good;
        kind[18] = 4;
        assert_eq!(decode(&kind), Err(ArtNetError::OutOfRange));
        // No bytes panic the decoder.
        for length in 0..=TIME_CODE_LEN {
            for fill in [0u8, 0xff] {
                let mut bytes = good.to_vec();
                bytes.truncate(length);
                bytes.iter_mut().skip(12).for_each(|byte| *byte = fill);
                let _ = decode(&bytes);
            }
        }
    }

    fn hex(text: &str) -> Vec<u8> {
        (0..text.len())
            .step_by(2)
            .map(|at| u8::from_str_radix(&text[at..at + 2], 16).unwrap())
            .collect()
    }
}
