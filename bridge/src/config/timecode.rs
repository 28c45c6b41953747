//! The `[timecode]` table of `floatball.toml`: timecode chase (`crate::timecode`),
//! off unless `source` is given — `artnet` (OpTimeCode on the UDP address `listen`,
//! default `0.0.0.0:6454`) or `mtc` (MIDI timecode read from the raw MIDI `device`);
//! the frame rate the timecode starts are written at (`rate`), the whole playlist's
//! timecode start (`start`), the loss time and what a loss does (`loss_ms`,
//! `on_loss`), the locate threshold and the first lead (`locate_threshold_ms`,
//! `lead_ms`) — checked with line and column like the rest
//! (docs/show-control.md, docs/configuration.md).

use std::net::SocketAddr;
use std::path::PathBuf;

use floatball_shared::timecode::chase::{ChaseConfig, OnLoss};
use floatball_shared::timecode::{FrameRate, Timecode, artnet};

use super::ConfigError;
use super::check::Checker;
use super::raw::RawTimecode;

/// Default loss time, ms.
pub const DEFAULT_LOSS_MS: u64 = 2_000;
/// Default locate threshold, ms.
pub const DEFAULT_LOCATE_THRESHOLD_MS: u64 = 500;
/// Default first lead, ms (replaced by the lead measured at the first start).
pub const DEFAULT_LEAD_MS: u64 = 2_000;

/// Where the timecode comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TimecodeSource {
    /// Art-Net OpTimeCode on this UDP address.
    ArtNet(SocketAddr),
    /// MIDI timecode read from this raw MIDI device (or FIFO, or pseudo-terminal).
    Mtc(PathBuf),
}

impl TimecodeSource {
    /// `artnet` or `mtc`.
    pub fn name(&self) -> &'static str {
        match self {
            Self::ArtNet(_) => "artnet",
            Self::Mtc(_) => "mtc",
        }
    }
}

impl std::fmt::Display for TimecodeSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::ArtNet(listen) => write!(f, "Art-Net timecode on udp {listen}"),
            Self::Mtc(device) => write!(f, "MIDI timecode from {}", device.display()),
        }
    }
}

/// Timecode chase, when `[timecode] source` is given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TimecodeConfig {
    /// Where the timecode comes from.
    pub source: TimecodeSource,
    /// The rate timecode starts are written at (and the timecode is expected at).
    pub rate: FrameRate,
    /// The whole playlist's timecode start, ms since 00:00:00:00.
    pub start_ms: Option<u64>,
    /// The chase's settings.
    pub chase: ChaseConfig,
    /// While chasing, the units' clock is trimmed to the timecode's (where the
    /// family allows: `docs/show-control.md`).
    pub correct_drift: bool,
}

impl TimecodeConfig {
    /// A timecode start `HH:MM:SS:FF` at the configured rate, ms.
    pub fn start_of(&self, text: &str) -> Option<u64> {
        Timecode::parse(text, self.rate).map(Timecode::to_ms)
    }
}

impl Checker<'_> {
    /// `[timecode]`: `None` when the chase is off (no `source`).
    pub(super) fn timecode(
        &self,
        raw: &RawTimecode,
    ) -> Result<Option<TimecodeConfig>, ConfigError> {
        let Some(source) = &raw.source else {
            return Ok(None);
        };
        let source = match source.get_ref().trim() {
            "artnet" => {
                let listen = match &raw.listen {
                    None => SocketAddr::from(([0, 0, 0, 0], artnet::PORT)),
                    Some(listen) => listen.get_ref().trim().parse().map_err(|_| {
                        self.at(
                            &listen.span(),
                            format!(
                                "[timecode] listen = {:?} is not an address and UDP port \
                                 such as \"0.0.0.0:6454\"",
                                listen.get_ref()
                            ),
                        )
                    })?,
                };
                TimecodeSource::ArtNet(listen)
            }
            "mtc" => {
                let Some(device) = &raw.device else {
                    return Err(self.at(
                        &source.span(),
                        "[timecode] source = \"mtc\" needs device, the raw MIDI device \
                         such as \"/dev/snd/midiC1D0\""
                            .to_owned(),
                    ));
                };
                TimecodeSource::Mtc(PathBuf::from(device.get_ref()))
            }
            other => {
                return Err(self.at(
                    &source.span(),
                    format!("[timecode] source = {other:?} must be \"artnet\" or \"mtc\""),
                ));
            }
        };
        let rate = match &raw.rate {
            None => FrameRate::Ebu25,
            Some(rate) => FrameRate::parse(rate.get_ref()).ok_or_else(|| {
                self.at(
                    &rate.span(),
                    format!(
                        "[timecode] rate = {:?} must be \"24\", \"25\", \"29.97df\" or \"30\"",
                        rate.get_ref()
                    ),
                )
            })?,
        };
        let start_ms = raw
            .start
            .as_ref()
            .map(|start| {
                Timecode::parse(start.get_ref(), rate)
                    .map(Timecode::to_ms)
                    .ok_or_else(|| {
                        self.at(
                            &start.span(),
                            format!(
                                "[timecode] start = {:?} is not a timecode such as \
                                 \"10:00:00:00\" at {rate} fps",
                                start.get_ref()
                            ),
                        )
                    })
            })
            .transpose()?;
        let on_loss = match &raw.on_loss {
            None => OnLoss::Hold,
            Some(on_loss) => match on_loss.get_ref().trim() {
                "hold" => OnLoss::Hold,
                "stop" => OnLoss::Stop,
                other => {
                    return Err(self.at(
                        &on_loss.span(),
                        format!("[timecode] on_loss = {other:?} must be \"hold\" or \"stop\""),
                    ));
                }
            },
        };
        let ms = |value: &Option<toml::Spanned<u64>>, key: &str, default: u64, min: u64| {
            let Some(value) = value else {
                return Ok(default);
            };
            let ms = *value.get_ref();
            if (min..=600_000).contains(&ms) {
                Ok(ms)
            } else {
                Err(self.at(
                    &value.span(),
                    format!("[timecode] {key} = {ms} must be from {min} to 600000 ms"),
                ))
            }
        };
        Ok(Some(TimecodeConfig {
            source,
            rate,
            start_ms,
            chase: ChaseConfig {
                loss_ms: ms(&raw.loss_ms, "loss_ms", DEFAULT_LOSS_MS, 100)?,
                on_loss,
                locate_threshold_ms: ms(
                    &raw.locate_threshold_ms,
                    "locate_threshold_ms",
                    DEFAULT_LOCATE_THRESHOLD_MS,
                    40,
                )?,
                lead_ms: ms(&raw.lead_ms, "lead_ms", DEFAULT_LEAD_MS, 0)?,
            },
            correct_drift: raw.correct_drift.unwrap_or(true),
        }))
    }
}
