//! `floatball.toml` as written: what `toml` parses, every value with the place it sits
//! in the file (`Spanned`) so that the checker can name the line and column of a
//! mistake. Every key is optional here; the checker supplies the defaults. Unknown keys
//! are refused by the parser.

use serde::Deserialize;
use toml::Spanned;

/// The whole file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawConfig {
    pub(super) listen: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) allowed_origins: Vec<Spanned<String>>,
    #[serde(default)]
    pub(super) matrix: RawMatrix,
    #[serde(default, rename = "gateway")]
    pub(super) gateways: Vec<Spanned<RawGateway>>,
    #[serde(default)]
    pub(super) safety: RawSafety,
    #[serde(default)]
    pub(super) uploads: RawUploads,
    #[serde(default)]
    pub(super) mbox: RawMbox,
    #[serde(default)]
    pub(super) scl: RawScl,
    #[serde(default)]
    pub(super) osc: RawOsc,
    #[serde(default)]
    pub(super) live: RawLive,
    #[serde(default)]
    pub(super) timecode: RawTimecode,
}

/// `[matrix]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMatrix {
    pub(super) rows: Option<Spanned<u32>>,
    pub(super) cols: Option<Spanned<u32>>,
    pub(super) pitch_mm: Option<Spanned<f64>>,
    pub(super) travel_mm: Option<Spanned<f64>>,
    pub(super) counts_per_mm: Option<Spanned<f64>>,
    pub(super) max_speed_mm_s: Option<Spanned<f64>>,
    pub(super) max_accel_mm_s2: Option<Spanned<f64>>,
    pub(super) home_mm: Option<Spanned<f64>>,
}

/// One `[[gateway]]` table.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawGateway {
    pub(super) kind: Option<Spanned<String>>,
    pub(super) port: Option<Spanned<String>>,
    pub(super) address: Option<Spanned<String>>,
    pub(super) axes: Option<Spanned<u32>>,
    pub(super) pulses_per_mm: Option<Spanned<f64>>,
    pub(super) sign: Option<Spanned<i64>>,
    pub(super) offset_pulses: Option<Spanned<i64>>,
    pub(super) baud: Option<Spanned<u32>>,
    pub(super) first_station: Option<Spanned<u8>>,
    pub(super) units: Option<Spanned<usize>>,
    pub(super) stations: Option<Spanned<Vec<Spanned<u8>>>>,
    pub(super) addresses: Option<Spanned<String>>,
    pub(super) escl: Option<Spanned<Vec<Spanned<String>>>>,
}

impl RawGateway {
    /// The keys only an MBOX box takes, each with where it stands if it is given.
    pub(super) fn mbox_keys(&self) -> [(&'static str, Option<std::ops::Range<usize>>); 5] {
        [
            ("address", self.address.as_ref().map(Spanned::span)),
            ("axes", self.axes.as_ref().map(Spanned::span)),
            (
                "pulses_per_mm",
                self.pulses_per_mm.as_ref().map(Spanned::span),
            ),
            ("sign", self.sign.as_ref().map(Spanned::span)),
            (
                "offset_pulses",
                self.offset_pulses.as_ref().map(Spanned::span),
            ),
        ]
    }
}

/// `[safety]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawSafety {
    pub(super) estop: Option<Spanned<String>>,
    pub(super) approach_speed_mm_s: Option<Spanned<f64>>,
}

/// `[uploads]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawUploads {
    pub(super) max_bytes: Option<Spanned<usize>>,
    pub(super) max_duration: Option<Spanned<String>>,
}

/// `[mbox]`: settings for every MBOX box of the installation.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawMbox {
    pub(super) host_port: Option<Spanned<u16>>,
    pub(super) frame_period_ms: Option<Spanned<u32>>,
    pub(super) time: Option<Spanned<String>>,
}

/// `[scl]`: settings for every MOONS' drive of the installation.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawScl {
    pub(super) start_input: Option<Spanned<u8>>,
    pub(super) start_condition: Option<Spanned<String>>,
    pub(super) trigger: Option<Spanned<String>>,
    pub(super) programs: Option<Spanned<String>>,
    pub(super) steps_per_rev: Option<Spanned<u32>>,
    pub(super) tolerance_mm: Option<Spanned<f64>>,
    pub(super) poll_ms: Option<Spanned<u32>>,
    pub(super) host_port: Option<Spanned<u16>>,
}

/// `[osc]`: show control over OSC (off unless `listen` is given).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawOsc {
    pub(super) listen: Option<Spanned<String>>,
    #[serde(default)]
    pub(super) allow: Vec<Spanned<String>>,
    pub(super) estop: Option<Spanned<bool>>,
    pub(super) motion: Option<Spanned<bool>>,
    pub(super) feedback: Option<Spanned<String>>,
}

/// `[live]`: live input and the patch (`super::live`).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLive {
    pub(super) enabled: Option<Spanned<bool>>,
    pub(super) artnet: Option<Spanned<bool>>,
    pub(super) sacn: Option<Spanned<bool>>,
    pub(super) artnet_listen: Option<Spanned<String>>,
    pub(super) sacn_listen: Option<Spanned<String>>,
    pub(super) sacn_interface: Option<Spanned<String>>,
    pub(super) hold_after_ms: Option<Spanned<u32>>,
    pub(super) profile: Option<Spanned<RawProfile>>,
    pub(super) matrix: Option<Spanned<RawLiveMatrix>>,
    #[serde(default)]
    pub(super) ball: Vec<Spanned<RawLiveBall>>,
}

/// A ball's channels: `{ speed_limit_bits = 8, enable = true, colour = false }`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawProfile {
    pub(super) speed_limit_bits: Option<Spanned<u8>>,
    pub(super) enable: Option<Spanned<bool>>,
    pub(super) colour: Option<Spanned<bool>>,
}

/// `[live] matrix = { universe = 1, address = 1 }`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLiveMatrix {
    pub(super) universe: Option<Spanned<i64>>,
    pub(super) address: Option<Spanned<i64>>,
}

/// One `[[live.ball]]`: a ball patched apart from the matrix.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawLiveBall {
    pub(super) ball: Option<Spanned<usize>>,
    pub(super) universe: Option<Spanned<i64>>,
    pub(super) address: Option<Spanned<i64>>,
    pub(super) profile: Option<Spanned<RawProfile>>,
}

/// `[timecode]`.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawTimecode {
    pub(super) source: Option<Spanned<String>>,
    pub(super) listen: Option<Spanned<String>>,
    pub(super) device: Option<Spanned<String>>,
    pub(super) rate: Option<Spanned<String>>,
    pub(super) start: Option<Spanned<String>>,
    pub(super) loss_ms: Option<Spanned<u64>>,
    pub(super) on_loss: Option<Spanned<String>>,
    pub(super) locate_threshold_ms: Option<Spanned<u64>>,
    pub(super) lead_ms: Option<Spanned<u64>>,
    pub(super) correct_drift: Option<bool>,
}
