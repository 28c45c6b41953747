//! Output tracks: what an MBOX box's 12 digital and 2 analog outputs do during a show
//! (`docs/show-format.md`, "Outputs").
//!
//! Digital outputs hold the last keyframe's bits; an analog channel changes linearly
//! between its keyframes and holds after its last. Before a track's first keyframe,
//! and at and after the show's end, every output is 0.

use serde::{Deserialize, Serialize};

/// The bits of the 12 digital outputs (output `n` is bit `n − 1`); bits 12–15 are
/// reserved.
pub const OUTPUT_BITS: u16 = 0x0FFF;

/// A digital keyframe: from `time_ms` the outputs are `bits`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DigitalKey {
    /// Show time, ms.
    pub time_ms: u64,
    /// Output `n` (1–12) on when bit `n − 1` is set.
    pub bits: u16,
}

/// An analog keyframe: channel `channel` is at `value` at `time_ms`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnalogKey {
    /// Show time, ms.
    pub time_ms: u64,
    /// The channel, 0 or 1.
    pub channel: u8,
    /// The raw output value, 0–65535.
    pub value: u16,
}

/// One MBOX box's outputs over the show.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutputTrack {
    /// The box, 0-based in the installation's gateway order.
    #[serde(rename = "box")]
    pub box_index: usize,
    /// Digital keyframes in strictly increasing time (may be empty).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub digital: Vec<DigitalKey>,
    /// Analog keyframes, each channel's in strictly increasing time (may be empty).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub analog: Vec<AnalogKey>,
}

/// A box's outputs at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct OutputSample {
    /// The digital outputs' bits (reserved bits 0).
    pub digital_bits: u16,
    /// The two analog outputs.
    pub analog: [u16; 2],
}

/// Why output tracks are inconsistent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputProblem {
    /// Two tracks for the same box.
    BoxTwice,
    /// A digital keyframe sets reserved bits (12–15).
    ReservedBits {
        /// The bits given.
        bits: u16,
    },
    /// An analog channel other than 0 or 1.
    Channel {
        /// The channel given.
        channel: u8,
    },
    /// A keyframe not later than the one before (digital, or the same analog channel).
    Order,
    /// A keyframe after the show's end.
    AfterEnd {
        /// The keyframe's time, ms.
        time_ms: u64,
        /// The show's duration, ms.
        duration_ms: u64,
    },
}

impl OutputTrack {
    /// The first problem of this track, with the index of the keyframe (`None` for the
    /// track itself) and whether it is an analog keyframe.
    pub(super) fn problem(
        &self,
        duration_ms: u64,
    ) -> Option<(Option<(bool, usize)>, OutputProblem)> {
        let mut last_digital: Option<u64> = None;
        for (index, key) in self.digital.iter().enumerate() {
            let problem = if key.bits & !OUTPUT_BITS != 0 {
                Some(OutputProblem::ReservedBits { bits: key.bits })
            } else if last_digital.is_some_and(|last| key.time_ms <= last) {
                Some(OutputProblem::Order)
            } else {
                after_end(key.time_ms, duration_ms)
            };
            if let Some(problem) = problem {
                return Some((Some((false, index)), problem));
            }
            last_digital = Some(key.time_ms);
        }
        let mut last_analog: [Option<u64>; 2] = [None; 2];
        for (index, key) in self.analog.iter().enumerate() {
            let Some(last) = last_analog.get_mut(usize::from(key.channel)) else {
                return Some((
                    Some((true, index)),
                    OutputProblem::Channel {
                        channel: key.channel,
                    },
                ));
            };
            let problem = if last.is_some_and(|last| key.time_ms <= last) {
                Some(OutputProblem::Order)
            } else {
                after_end(key.time_ms, duration_ms)
            };
            if let Some(problem) = problem {
                return Some((Some((true, index)), problem));
            }
            *last = Some(key.time_ms);
        }
        None
    }

    /// The outputs at show time `t_ms` (within the show; see the module docs).
    #[must_use]
    pub fn sample(&self, t_ms: u64) -> OutputSample {
        let digital_bits = self
            .digital
            .iter()
            .take_while(|key| key.time_ms <= t_ms)
            .last()
            .map_or(0, |key| key.bits & OUTPUT_BITS);
        let mut analog = [0u16; 2];
        for (channel, out) in analog.iter_mut().enumerate() {
            let keys = self
                .analog
                .iter()
                .filter(|key| usize::from(key.channel) == channel);
            let mut before: Option<&AnalogKey> = None;
            for key in keys {
                if key.time_ms > t_ms {
                    *out = before.map_or(0, |before| ramp(before, key, t_ms));
                    before = None;
                    break;
                }
                before = Some(key);
            }
            if let Some(last) = before {
                *out = last.value;
            }
        }
        OutputSample {
            digital_bits,
            analog,
        }
    }
}

fn after_end(time_ms: u64, duration_ms: u64) -> Option<OutputProblem> {
    (time_ms > duration_ms).then_some(OutputProblem::AfterEnd {
        time_ms,
        duration_ms,
    })
}

/// The value between `from` and `to` at `t_ms` (`from.time_ms ≤ t_ms < to.time_ms`).
fn ramp(from: &AnalogKey, to: &AnalogKey, t_ms: u64) -> u16 {
    let span = to.time_ms.saturating_sub(from.time_ms).max(1) as f64;
    let done = t_ms.saturating_sub(from.time_ms) as f64 / span;
    let value = f64::from(from.value) + (f64::from(to.value) - f64::from(from.value)) * done;
    // Between two u16 values: `as` cannot overflow.
    value.round() as u16
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::demo;

    fn sample(show: &crate::show::Show, t_ms: u64) -> (u16, [u16; 2]) {
        let sample = show.outputs_at(0, t_ms);
        (sample.digital_bits, sample.analog)
    }

    #[test]
    fn digital_holds_analog_ramps_and_all_is_0_outside_the_keyframes() {
        let mut show = demo::wave(1, 1, 10, 100);
        assert_eq!(show.duration_ms(), 1_000);
        show.outputs = vec![OutputTrack {
            box_index: 0,
            digital: vec![
                DigitalKey {
                    time_ms: 100,
                    bits: 1,
                },
                DigitalKey {
                    time_ms: 300,
                    bits: 0x0F00,
                },
            ],
            analog: vec![
                AnalogKey {
                    time_ms: 200,
                    channel: 1,
                    value: 1_000,
                },
                AnalogKey {
                    time_ms: 400,
                    channel: 1,
                    value: 0,
                },
                AnalogKey {
                    time_ms: 0,
                    channel: 0,
                    value: 65_535,
                },
            ],
        }];
        show.check().unwrap();
        assert_eq!(sample(&show, 0), (0, [65_535, 0]));
        assert_eq!(sample(&show, 99), (0, [65_535, 0]));
        assert_eq!(sample(&show, 100), (1, [65_535, 0]));
        assert_eq!(sample(&show, 200), (1, [65_535, 1_000]));
        assert_eq!(sample(&show, 250), (1, [65_535, 750]));
        assert_eq!(sample(&show, 300), (0x0F00, [65_535, 500]));
        assert_eq!(sample(&show, 400), (0x0F00, [65_535, 0]));
        assert_eq!(sample(&show, 999), (0x0F00, [65_535, 0]));
        // The show's end, and boxes without a track: 0.
        assert_eq!(sample(&show, 1_000), (0, [0, 0]));
        assert_eq!(show.outputs_at(1, 300), OutputSample::default());
    }
}
