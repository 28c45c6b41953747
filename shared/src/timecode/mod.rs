//! Timecode (issue 37, item 3; `docs/show-control.md`): SMPTE/EBU time as Art-Net's
//! OpTimeCode and MIDI timecode carry it, and the chase that keeps a playlist in step
//! with it. Sans-IO: bytes come in as buffers and every time is a parameter.
//!
//! - [`FrameRate`] and [`Timecode`]: the four rates (24, 25, 29.97 drop-frame, 30)
//!   and the conversion between a timecode and milliseconds since 00:00:00:00,
//!   drop-frame correct (29.97 DF counts 30 frames a second but skips frame numbers
//!   0 and 1 at the start of every minute except each tenth, so its timecode keeps to
//!   the wall clock within 3.6 ms an hour).
//! - [`artnet`]: Art-Net 4's OpTimeCode (UDP 6454): decode, and encode for tests and
//!   the benchmark; any other Art-Net packet is told apart by its OpCode, so one
//!   socket can later take OpDmx too.
//! - [`mtc`]: MIDI timecode from a raw MIDI byte stream: quarter frames assembled into
//!   a time (eight of them, two frames' worth, with the direction), full-frame SysEx.
//! - [`chase`]: the state machine that turns timecode samples (with their arrival
//!   time) and the player's status into Start, Locate and Stop actions.
//! - [`lead`]: the lead of a Start estimated from the plan (approach, table load)
//!   before one was measured.

pub mod artnet;
pub mod chase;
pub mod lead;
pub mod mtc;

use std::fmt;

use serde::{Deserialize, Serialize};

/// Milliseconds in a day: timecode runs from 00:00:00:00 to 23:59:59:FF.
pub const DAY_MS: u64 = 24 * 60 * 60 * 1000;

/// A timecode frame rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum FrameRate {
    /// 24 fps (film).
    #[serde(rename = "24")]
    Film24,
    /// 25 fps (EBU).
    #[serde(rename = "25")]
    Ebu25,
    /// 29.97 fps drop-frame (30 frame numbers a second, some skipped).
    #[serde(rename = "29.97df")]
    Df2997,
    /// 30 fps (SMPTE non-drop).
    #[serde(rename = "30")]
    Smpte30,
}

impl FrameRate {
    /// Every rate, in Art-Net's order (its `Type` field 0–3).
    pub const ALL: [Self; 4] = [Self::Film24, Self::Ebu25, Self::Df2997, Self::Smpte30];

    /// Frame numbers a second (30 for 29.97 DF).
    pub fn frames_per_second(self) -> u32 {
        match self {
            Self::Film24 => 24,
            Self::Ebu25 => 25,
            Self::Df2997 | Self::Smpte30 => 30,
        }
    }

    /// Whether the rate drops frame numbers (29.97 DF).
    pub fn drop_frame(self) -> bool {
        self == Self::Df2997
    }

    /// One frame's length, µs (33 366.7 for 29.97).
    pub fn frame_us(self) -> f64 {
        match self {
            Self::Df2997 => 1_001_000.0 / 30.0,
            other => 1_000_000.0 / f64::from(other.frames_per_second()),
        }
    }

    /// The rate's name as configured and shown: `24`, `25`, `29.97df`, `30`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Film24 => "24",
            Self::Ebu25 => "25",
            Self::Df2997 => "29.97df",
            Self::Smpte30 => "30",
        }
    }

    /// Reads a rate's [name](Self::name) (`29.97` and `df` also name drop-frame).
    pub fn parse(text: &str) -> Option<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "24" => Some(Self::Film24),
            "25" => Some(Self::Ebu25),
            "29.97df" | "29.97" | "df" | "2997" => Some(Self::Df2997),
            "30" => Some(Self::Smpte30),
            _ => None,
        }
    }

    /// The rate of Art-Net's `Type` and MTC's rate bits (0 film, 1 EBU, 2 DF, 3 SMPTE).
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(usize::from(code)).copied()
    }

    /// The code [`FrameRate::from_code`] reads.
    pub fn code(self) -> u8 {
        match self {
            Self::Film24 => 0,
            Self::Ebu25 => 1,
            Self::Df2997 => 2,
            Self::Smpte30 => 3,
        }
    }
}

impl fmt::Display for FrameRate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A timecode: hours, minutes, seconds, frames at a rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timecode {
    /// 0–23.
    pub hours: u8,
    /// 0–59.
    pub minutes: u8,
    /// 0–59.
    pub seconds: u8,
    /// 0 to the rate's frames a second less one.
    pub frames: u8,
    /// The rate.
    pub rate: FrameRate,
}

/// Frame numbers in ten drop-frame minutes (17 982: 10 × 1800 less 9 × 2).
const DF_TEN_MINUTES: u64 = 17_982;
/// Frame numbers in one dropped drop-frame minute (1798).
const DF_MINUTE: u64 = 1_798;

impl Timecode {
    /// A timecode, if every field is in range for `rate` (in 29.97 DF frames 0 and 1
    /// do not exist at the start of a minute that is not a tenth).
    pub fn new(hours: u8, minutes: u8, seconds: u8, frames: u8, rate: FrameRate) -> Option<Self> {
        let valid = hours < 24
            && minutes < 60
            && seconds < 60
            && u32::from(frames) < rate.frames_per_second()
            && !(rate.drop_frame() && seconds == 0 && frames < 2 && !minutes.is_multiple_of(10));
        valid.then_some(Self {
            hours,
            minutes,
            seconds,
            frames,
            rate,
        })
    }

    /// The frame count since 00:00:00:00 (drop-frame numbers skipped).
    pub fn frame_count(self) -> u64 {
        let fps = u64::from(self.rate.frames_per_second());
        let minutes = u64::from(self.hours) * 60 + u64::from(self.minutes);
        let nominal = (minutes * 60 + u64::from(self.seconds)) * fps + u64::from(self.frames);
        if self.rate.drop_frame() {
            nominal - 2 * (minutes - minutes / 10)
        } else {
            nominal
        }
    }

    /// The timecode `count` frames after 00:00:00:00 (wrapping at a day).
    pub fn from_frame_count(count: u64, rate: FrameRate) -> Self {
        let fps = u64::from(rate.frames_per_second());
        let per_day = if rate.drop_frame() {
            DF_TEN_MINUTES * 6 * 24
        } else {
            fps * 86_400
        };
        let mut count = count % per_day;
        if rate.drop_frame() {
            let tens = count / DF_TEN_MINUTES;
            let rest = count % DF_TEN_MINUTES;
            count += 18 * tens;
            if rest > 1 {
                count += 2 * ((rest - 2) / DF_MINUTE);
            }
        }
        let field = |value: u64| u8::try_from(value).unwrap_or(u8::MAX);
        Self {
            hours: field(count / (fps * 3600)),
            minutes: field(count / (fps * 60) % 60),
            seconds: field(count / fps % 60),
            frames: field(count % fps),
            rate,
        }
    }

    /// Milliseconds since 00:00:00:00 at this frame's start (real time: a 29.97
    /// frame lasts 1001/30 ms), rounded to the nearest.
    pub fn to_ms(self) -> u64 {
        let count = self.frame_count();
        match self.rate {
            FrameRate::Df2997 => (count * 1001 + 15) / 30,
            rate => {
                let fps = u64::from(rate.frames_per_second());
                (count * 1000 + fps / 2) / fps
            }
        }
    }

    /// The frame that is showing `ms` after 00:00:00:00 at `rate`.
    pub fn from_ms(ms: u64, rate: FrameRate) -> Self {
        let count = match rate {
            FrameRate::Df2997 => (ms * 30 + 500) / 1001,
            rate => (ms * u64::from(rate.frames_per_second()) + 500) / 1000,
        };
        Self::from_frame_count(count, rate)
    }

    /// The timecode `frames` frames later (wrapping at a day).
    pub fn plus_frames(self, frames: u64) -> Self {
        Self::from_frame_count(self.frame_count() + frames, self.rate)
    }

    /// Reads `HH:MM:SS:FF` (`;` before the frames also allowed, as drop-frame is
    /// written) at `rate`.
    pub fn parse(text: &str, rate: FrameRate) -> Option<Self> {
        let fields: Vec<&str> = text.trim().split([':', ';', '.']).collect();
        let [hours, minutes, seconds, frames] = fields.as_slice() else {
            return None;
        };
        let number = |field: &str| {
            (!field.is_empty() && field.len() <= 2 && field.bytes().all(|b| b.is_ascii_digit()))
                .then(|| field.parse::<u8>().ok())
                .flatten()
        };
        Self::new(
            number(hours)?,
            number(minutes)?,
            number(seconds)?,
            number(frames)?,
            rate,
        )
    }
}

impl fmt::Display for Timecode {
    /// `HH:MM:SS:FF`, `HH:MM:SS;FF` for drop-frame.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let separator = if self.rate.drop_frame() { ';' } else { ':' };
        write!(
            f,
            "{:02}:{:02}:{:02}{separator}{:02}",
            self.hours, self.minutes, self.seconds, self.frames
        )
    }
}

/// Whether `text` is a timecode `HH:MM:SS:FF` at some rate (frames below 30): the
/// playlist's check, before the rate is known.
pub fn timecode_text_valid(text: &str) -> bool {
    Timecode::parse(text, FrameRate::Smpte30).is_some()
        || Timecode::parse(text, FrameRate::Df2997).is_some()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn non_drop_rates_convert_both_ways() {
        let tc = Timecode::new(1, 2, 3, 4, FrameRate::Ebu25).unwrap();
        assert_eq!(tc.to_ms(), ((3600 + 120 + 3) * 1000) + 160);
        assert_eq!(Timecode::from_ms(tc.to_ms(), FrameRate::Ebu25), tc);
        assert_eq!(tc.to_string(), "01:02:03:04");
        let film = Timecode::new(0, 0, 1, 12, FrameRate::Film24).unwrap();
        assert_eq!(film.to_ms(), 1_500);
        let smpte = Timecode::new(23, 59, 59, 29, FrameRate::Smpte30).unwrap();
        assert_eq!(smpte.to_ms(), DAY_MS - 33);
        assert_eq!(Timecode::new(0, 0, 0, 25, FrameRate::Ebu25), None);
        assert_eq!(Timecode::new(24, 0, 0, 0, FrameRate::Ebu25), None);
    }

    #[test]
    fn drop_frame_skips_two_numbers_a_minute_but_every_tenth() {
        let rate = FrameRate::Df2997;
        // 00:00:59;29 is followed by 00:01:00;02.
        let before = Timecode::new(0, 0, 59, 29, rate).unwrap();
        assert_eq!(before.plus_frames(1).to_string(), "00:01:00;02");
        assert_eq!(Timecode::new(0, 1, 0, 0, rate), None);
        // 00:09:59;29 is followed by 00:10:00;00 (every tenth minute keeps its frames).
        let ninth = Timecode::new(0, 9, 59, 29, rate).unwrap();
        assert_eq!(ninth.plus_frames(1).to_string(), "00:10:00;00");
        // Ten minutes of drop-frame are 17 982 frames of 1001/30 ms: 599.4 s.
        let ten = Timecode::new(0, 10, 0, 0, rate).unwrap();
        assert_eq!(ten.frame_count(), 17_982);
        assert_eq!(ten.to_ms(), 599_999);
        // One hour of drop-frame timecode is one hour of wall time less 3.6 ms.
        let hour = Timecode::new(1, 0, 0, 0, rate).unwrap();
        assert_eq!(hour.frame_count(), 107_892);
        assert!(
            (hour.to_ms() as i64 - 3_600_000).abs() <= 4,
            "{}",
            hour.to_ms()
        );
        // Every frame of a day survives count → timecode → count.
        for count in (0..DF_TEN_MINUTES * 6 * 24).step_by(7) {
            let tc = Timecode::from_frame_count(count, rate);
            assert!(Timecode::new(tc.hours, tc.minutes, tc.seconds, tc.frames, rate).is_some());
            assert_eq!(tc.frame_count(), count, "{tc}");
        }
        // ms → frame → ms lands on the frame showing at that time.
        for ms in [0, 33, 34, 60_000, 600_000, 3_599_996, 45_296_789] {
            let tc = Timecode::from_ms(ms, rate);
            assert!(
                tc.to_ms().abs_diff(ms) <= 17,
                "{ms} → {tc} → {}",
                tc.to_ms()
            );
        }
    }

    #[test]
    fn timecodes_and_rates_are_read_from_text() {
        let rate = FrameRate::Ebu25;
        assert_eq!(
            Timecode::parse("10:00:00:00", rate),
            Timecode::new(10, 0, 0, 0, rate)
        );
        assert_eq!(
            Timecode::parse("00:01:00;02", FrameRate::Df2997).map(|tc| tc.frame_count()),
            Some(1_800)
        );
        for wrong in [
            "",
            "1:2:3",
            "00:00:00:25",
            "aa:00:00:00",
            "00:00:00:000",
            "+1:00:00:00",
        ] {
            assert_eq!(Timecode::parse(wrong, rate), None, "{wrong}");
        }
        assert!(timecode_text_valid("01:00:00:29"));
        assert!(!timecode_text_valid("01:00:00:30"));
        for rate in FrameRate::ALL {
            assert_eq!(FrameRate::parse(rate.name()), Some(rate));
            assert_eq!(FrameRate::from_code(rate.code()), Some(rate));
        }
        assert_eq!(FrameRate::parse("29"), None);
    }
}
