//! The installation's configuration: `<data-dir>/floatball.toml` (every key in
//! `docs/configuration.md`).
//!
//! On first start the file is written with every key at its default and a comment
//! saying what it means ([`DEFAULT_FILE`], kept as `config/default.toml`). The file is
//! read in two steps, as ripgrep does:
//! - `raw`: `toml` parses it into a raw form that keeps where each value sits;
//! - `check`: the one place the installation is checked — straight into the shared
//!   [`Installation`] (units given to gateways by the shared rule,
//!   [`floatball_shared::plan::installation::allocate`]), beside the bridge's own
//!   settings, together a [`Config`]. Every mistake stops the start with the file, the
//!   line, the column and the reason, e.g.
//!   `data/floatball.toml line 12, column 8: baud 300 is out of range (1200 to 921600)`.
//! - `scl`: the MOONS' drives' gateway entries and the `[scl]` table.
//! - `osc`: the `[osc]` table, show control over OSC.
//! - `live`: the `[live]` table, live input and the patch.
//! - `timecode`: the `[timecode]` table, timecode chase.
//!
//! The check goes on past a problem and lists every one ([`Config::parse_all`]), for
//! `floatball check`, for the start, and for `PUT /api/installation`, which writes
//! the file through [`edit`] (comments and untouched keys kept) and checks the result
//! before anything is saved.
//!
//! Two command-line flags override the file without editing it ([`Overrides`]):
//! `--listen` and `--gateway PORT` (repeatable, the n-th flag replaces the n-th
//! gateway's port).

mod check;
pub mod edit;
pub mod live;
pub mod osc;
mod raw;
pub mod scl;
#[cfg(test)]
mod tests;
pub mod timecode;

pub use live::LiveConfig;
pub use osc::{OscConfig, Source};
pub use scl::{
    DEFAULT_SCL_HOST_PORT, DEFAULT_SCL_POLL, DEFAULT_START_INPUT, DEFAULT_STEPS_PER_REV,
    DEFAULT_TOLERANCE_MM, SclConfig, SclGateway, SclPrograms, default_addresses,
};
pub use timecode::{TimecodeConfig, TimecodeSource};

use std::io;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use floatball_shared::plan::Installation;
use floatball_shared::uim2503::ascii::Instruction;

use crate::durable;

/// The configuration file's name inside the data directory.
pub const FILE_NAME: &str = "floatball.toml";

/// Slowest and fastest baud rate accepted.
pub const BAUD_RANGE: std::ops::RangeInclusive<u32> = 1200..=921_600;

/// Baud rate of a real gateway unless configured: the factory setting
/// (`docs/protocol-notes.md` §3, "The gateway's own commands").
pub const DEFAULT_SERIAL_BAUD: u32 = 9600;

/// Baud rate of the simulated gateway unless configured.
pub const DEFAULT_SIM_BAUD: u32 = 115_200;

/// The file written on first start: every key at its default, each explained.
pub const DEFAULT_FILE: &str = include_str!("default.toml");

/// The checked configuration: the installation and the bridge's own settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Address and port to listen on.
    pub listen: SocketAddr,
    /// Extra origins allowed for CORS and the WebSocket, normalised
    /// (`scheme://host[:port]`, lower case, no trailing `/`).
    pub allowed_origins: Vec<String>,
    /// The matrix, its limits and calibration, the gateways and every unit's address,
    /// as the planner, the player and the simulated gateways see them.
    pub installation: Installation,
    /// What goes on every gateway's line for an e-stop: `*0;` (every unit), then the
    /// configured instructions (`[safety] estop`).
    pub estop: Vec<Instruction>,
    /// Show uploads.
    pub uploads: Uploads,
    /// The kind of drive every gateway is, with its own settings: chosen once, here
    /// (the check refuses gateways of different kinds).
    pub family: Family,
    /// Show control over OSC (`[osc]`), when it is on.
    pub osc: Option<OscConfig>,
    /// Live input and the patch (`[live]`; off unless `enabled`).
    pub live: LiveConfig,
    /// Timecode chase (`[timecode]`), when it is on.
    pub timecode: Option<TimecodeConfig>,
}

/// The drive family of an installation, with what only that family needs.
#[derive(Debug, Clone, PartialEq)]
pub enum Family {
    /// UIM2503 gateways (`kind = "uim2503"`, the default) on serial lines.
    Uim2503,
    /// MBOX boxes (`kind = "mbox"`) and their UDP settings.
    Mbox(MboxConfig),
    /// MOONS' drives (`kind = "scl"`) and their settings.
    Scl(SclConfig),
}

impl Config {
    /// The MBOX boxes' settings, when the gateways are MBOX boxes.
    pub fn mbox(&self) -> Option<&MboxConfig> {
        match &self.family {
            Family::Mbox(mbox) => Some(mbox),
            _ => None,
        }
    }

    /// The MOONS' drives' settings, when the gateways are SCL gateway entries.
    pub fn scl(&self) -> Option<&SclConfig> {
        match &self.family {
            Family::Scl(scl) => Some(scl),
            _ => None,
        }
    }
}

/// An installation of MBOX boxes: the host's UDP socket, the frame period and every
/// box (in gateway order, as [`Installation::gateways`] lists them).
#[derive(Debug, Clone, PartialEq)]
pub struct MboxConfig {
    /// The host's UDP port every box is sent from and answers to (`0`: any free port).
    pub host_port: u16,
    /// The time between two motion frames.
    pub frame_period: Duration,
    /// Relative-time frames (`0x1401`) or absolute time codes (`0x1301`).
    pub time: floatball_shared::mbox::TimeMode,
    /// Every box, in gateway order.
    pub boxes: Vec<MboxBox>,
}

/// Where an MBOX box is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MboxTarget {
    /// A simulated box in the bridge, on a loopback UDP socket (`port = "sim"`).
    Sim,
    /// A box at this UDP address and port.
    Address(SocketAddr),
}

/// One `kind = "mbox"` gateway.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MboxBox {
    /// Where it is.
    pub target: MboxTarget,
    /// 3, 6 or 10 axes.
    pub axes: floatball_shared::mbox::AxisCount,
    /// Millimetres to pulses.
    pub calibration: floatball_shared::mbox::player::BoxCalibration,
}

/// The host's UDP port unless configured (the box's factory setting).
pub const DEFAULT_MBOX_HOST_PORT: u16 = floatball_shared::mbox::HOST_PORT;

/// The frame period unless configured.
pub const DEFAULT_MBOX_PERIOD: Duration = Duration::from_millis(20);

/// Upload settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Uploads {
    /// Largest show file accepted, bytes: the upload, and the show as stored.
    pub max_bytes: usize,
    /// Longest show accepted.
    pub max_duration: Duration,
}

/// `max_duration` unless configured: 30 minutes.
pub const DEFAULT_MAX_DURATION: Duration = Duration::from_secs(30 * 60);

/// The shortest and longest `max_duration` accepted: 1 second to 24 hours (the latest
/// keyframe a CSV may have).
pub const MAX_DURATION_RANGE: std::ops::RangeInclusive<Duration> =
    Duration::from_secs(1)..=Duration::from_secs(24 * 60 * 60);

/// What the command line overrides.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Overrides {
    /// Replaces `listen`.
    pub listen: Option<SocketAddr>,
    /// Replaces the ports of the first gateways, in order.
    pub gateway_ports: Vec<String>,
}

/// Why the configuration cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// The file exists but cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// The defaults cannot be written on first start.
    #[error("cannot write the default configuration to {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: io::Error,
    },
    /// A value is wrong at a known place in the file.
    #[error("{} line {line}, column {column}: {reason}", path.display())]
    At {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column, in characters.
        column: usize,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// Something is wrong with the file as a whole, or with a command-line override.
    #[error("{}: {reason}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong and what is allowed.
        reason: String,
    },
    /// More than one problem: each of them, one a line.
    #[error("{}", list(.0))]
    Many(Vec<ConfigError>),
}

/// Problems one a line.
fn list(problems: &[ConfigError]) -> String {
    let lines: Vec<String> = problems.iter().map(ToString::to_string).collect();
    lines.join("\n")
}

impl ConfigError {
    /// What is wrong, without the file and the place (for an API answer, where the
    /// file is not the client's).
    pub fn reason(&self) -> String {
        match self {
            Self::Read { source, .. } | Self::Write { source, .. } => source.to_string(),
            Self::At { reason, .. } | Self::File { reason, .. } => reason.clone(),
            Self::Many(problems) => list(problems),
        }
    }

    /// Every problem: this one, or each of [`ConfigError::Many`].
    pub fn problems(&self) -> Vec<&ConfigError> {
        match self {
            Self::Many(problems) => problems.iter().collect(),
            one => vec![one],
        }
    }
}

impl Config {
    /// Reads `<data_dir>/floatball.toml`, writing the defaults first if it does not
    /// exist, and applies the command-line `overrides`.
    ///
    /// # Errors
    /// [`ConfigError`] naming the file, and the line and column where known.
    pub fn load_or_create(data_dir: &Path, overrides: &Overrides) -> Result<Self, ConfigError> {
        let path = data_dir.join(FILE_NAME);
        let text = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(source) if source.kind() == io::ErrorKind::NotFound => {
                durable::write_atomic(data_dir, FILE_NAME, DEFAULT_FILE.as_bytes()).map_err(
                    |source| ConfigError::Write {
                        path: path.clone(),
                        source,
                    },
                )?;
                tracing::info!("wrote the default configuration to {}", path.display());
                DEFAULT_FILE.to_owned()
            }
            Err(source) => return Err(ConfigError::Read { path, source }),
        };
        Self::parse(&path, &text, overrides)
    }

    /// Parses and checks the text of a configuration file; `path` names it in errors.
    ///
    /// # Errors
    /// [`ConfigError::At`] or [`ConfigError::File`] for a single problem,
    /// [`ConfigError::Many`] listing every problem when there are more.
    pub fn parse(path: &Path, text: &str, overrides: &Overrides) -> Result<Self, ConfigError> {
        Self::parse_all(path, text, overrides).map_err(|mut problems| {
            if problems.len() == 1
                && let Some(one) = problems.pop()
            {
                one
            } else {
                ConfigError::Many(problems)
            }
        })
    }

    /// Parses and checks the text of a configuration file, listing every problem (a
    /// file TOML cannot parse has one: where parsing stopped).
    ///
    /// # Errors
    /// Every problem found, in the order of the file's sections (never empty).
    pub fn parse_all(
        path: &Path,
        text: &str,
        overrides: &Overrides,
    ) -> Result<Self, Vec<ConfigError>> {
        let checker = check::Checker::new(path, text);
        let raw: raw::RawConfig = toml::from_str(text).map_err(|error| {
            vec![match error.span() {
                Some(span) => checker.at(&span, error.message().trim_end().to_owned()),
                None => checker.file(error.message().trim_end().to_owned()),
            }]
        })?;
        checker.check(raw, overrides)
    }
}
