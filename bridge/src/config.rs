//! The installation's configuration: `<data-dir>/floatball.toml` (DESIGN §2).
//!
//! On first start the file is written with every key at its default and a comment
//! saying what it means ([`DEFAULT_FILE`]). The file is read in two steps, as ripgrep
//! does: first parsed by `toml` into a raw form that keeps where each value sits, then
//! checked into the typed [`Config`]. Every mistake stops the start with the file, the
//! line, the column and the reason, e.g.
//! `data/floatball.toml line 12, column 8: baud 300 is out of range (1200 to 921600)`.
//!
//! Two command-line flags override the file without editing it ([`Overrides`]):
//! `--listen` and `--gateway PORT` (repeatable, the n-th flag replaces the n-th
//! gateway's port).

use std::collections::HashSet;
use std::io;
use std::net::SocketAddr;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::time::Duration;

use floatball_shared::ascii::{Form, Instruction, parse_script};
use floatball_shared::plan::{GatewaySpec, Installation, UnitAddress};
use floatball_shared::show::{Layout, Limits};
use serde::Deserialize;
use toml::Spanned;

use crate::durable;

/// The configuration file's name inside the data directory.
pub const FILE_NAME: &str = "floatball.toml";

/// The port name of the simulated gateway.
pub const SIM_PORT: &str = "sim";

/// Most units one UIM2503 gateway serves (PROTOCOL §1.1).
pub const MAX_UNITS_PER_GATEWAY: usize = 100;

/// Slowest and fastest baud rate accepted.
pub const BAUD_RANGE: std::ops::RangeInclusive<u32> = 1200..=921_600;

/// Baud rate of a real gateway unless configured: the factory setting (PROTOCOL §1.2).
pub const DEFAULT_SERIAL_BAUD: u32 = 9600;

/// Baud rate of the simulated gateway unless configured.
pub const DEFAULT_SIM_BAUD: u32 = 115_200;

/// The file written on first start: every key at its default, each explained.
pub const DEFAULT_FILE: &str = r#"# Floatball installation settings. Written with the defaults on first start;
# edit and restart `floatball` to apply. Every key may be left out: the value shown is
# then used.

# Address and port the bridge listens on (the --listen flag overrides it).
listen = "0.0.0.0:8080"

# Extra origins (scheme://host[:port]) allowed to call the API and open the WebSocket,
# for an app served from another host. The bridge's own origin is always allowed.
allowed_origins = []

[matrix]
# Rows and columns of balls, as seen from below. Units are numbered row-major.
rows = 10
cols = 10
# Distance between neighbouring balls, mm.
pitch_mm = 500.0
# Lowest position a ball may reach, mm below the top (the UFQ750 travels 7.5 m).
travel_mm = 7500.0
# Calibration: motor counts per mm of ball travel.
counts_per_mm = 100.0
# Top speed of a ball, mm/s, and top acceleration, mm/s². Shows beyond them are refused.
max_speed_mm_s = 2000.0
max_accel_mm_s2 = 4000.0
# Home position, mm below the top (0 = at the upper limit).
home_mm = 0.0

# One [[gateway]] table per UIM2503 gateway (at most 100 units each). Units map to
# gateways row-major: the first gateway takes the first units, and so on.
[[gateway]]
# "sim" for the built-in simulated gateway, or a serial device such as "/dev/ttyUSB0"
# (the --gateway flag overrides it).
port = "sim"
# Line speed. Default: 115200 for "sim", 9600 (the factory setting) for a real port.
# baud = 9600
# Station number of this gateway's first unit; the next units count up from it.
first_station = 1
# How many units this gateway serves. Default: the matrix's units shared evenly
# among the gateways that leave it out.
# units = 100
# Or list the station of each unit in order instead of first_station and units:
# stations = [1, 2, 3]

[safety]
# The instruction(s) that stop every ball at once. Always sent as a global broadcast
# ("*0;" first) on every gateway, ahead of anything queued.
estop = "MO=0;"
# Speed of the move to a show's first position, mm/s.
approach_speed_mm_s = 250.0

[uploads]
# Largest show file accepted, bytes (32 MiB): the upload, and the show as stored (a CSV
# becomes one row per 255 ms or less of every ball, which can be much larger).
max_bytes = 33554432
# Longest show accepted, such as "30m", "1h 15m" or "90s" (1 second to 24 hours).
max_duration = "30m"
"#;

/// The checked configuration of the installation.
#[derive(Debug, Clone, PartialEq)]
pub struct Config {
    /// Address and port to listen on.
    pub listen: SocketAddr,
    /// Extra origins allowed for CORS and the WebSocket, normalised
    /// (`scheme://host[:port]`, lower case, no trailing `/`).
    pub allowed_origins: Vec<String>,
    /// The ball matrix.
    pub matrix: Matrix,
    /// The gateways, in order; at least one.
    pub gateways: Vec<Gateway>,
    /// E-stop and approach.
    pub safety: Safety,
    /// Show uploads.
    pub uploads: Uploads,
}

/// The ball matrix and its calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrix {
    /// Rows of balls.
    pub rows: u32,
    /// Balls per row.
    pub cols: u32,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
    /// Lowest position, mm below the top.
    pub travel_mm: f64,
    /// Motor counts per mm of travel.
    pub counts_per_mm: f64,
    /// Top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration, mm/s².
    pub max_accel_mm_s2: f64,
    /// Home position, mm below the top.
    pub home_mm: f64,
}

/// One gateway and the units behind it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gateway {
    /// `sim` or a serial device path.
    pub port: String,
    /// Line speed, baud.
    pub baud: u32,
    /// The station of each unit on this gateway, in row-major unit order.
    pub stations: Vec<u8>,
}

impl Gateway {
    /// Whether this is the built-in simulated gateway.
    pub fn is_sim(&self) -> bool {
        self.port == SIM_PORT
    }
}

/// Safety settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Safety {
    /// What goes on every gateway's line for an e-stop: `*0;` (every unit), then the
    /// configured instructions.
    pub estop: Vec<Instruction>,
    /// Speed of the move to a show's first position, mm/s.
    pub approach_speed_mm_s: f64,
}

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
    /// [`ConfigError::At`] or [`ConfigError::File`] for the first problem found.
    pub fn parse(path: &Path, text: &str, overrides: &Overrides) -> Result<Self, ConfigError> {
        let checker = Checker { path, text };
        let raw: RawConfig = toml::from_str(text).map_err(|error| match error.span() {
            Some(span) => checker.at(&span, error.message().trim_end().to_owned()),
            None => checker.file(error.message().trim_end().to_owned()),
        })?;
        checker.check(raw, overrides)
    }

    /// The installation's grid, for CSV import.
    pub fn layout(&self) -> Layout {
        Layout {
            rows: self.matrix.rows,
            cols: self.matrix.cols,
            pitch_mm: self.matrix.pitch_mm,
        }
    }

    /// The installation as the planner and the player see it: limits, calibration,
    /// lines, and every unit's address (row-major, gateway by gateway in order).
    pub fn installation(&self) -> Installation {
        let units = self
            .gateways
            .iter()
            .enumerate()
            .flat_map(|(gateway, spec)| {
                spec.stations
                    .iter()
                    .map(move |&station| UnitAddress { gateway, station })
            })
            .collect();
        Installation {
            limits: self.limits(),
            pitch_mm: self.matrix.pitch_mm,
            counts_per_mm: self.matrix.counts_per_mm,
            gateways: self
                .gateways
                .iter()
                .map(|gateway| GatewaySpec {
                    port: gateway.port.clone(),
                    baud: gateway.baud,
                    kind: floatball_shared::plan::DriveKind::Uim2503,
                })
                .collect(),
            units,
            approach_speed_mm_s: self.safety.approach_speed_mm_s,
            home_mm: self.matrix.home_mm,
            stop_decel_mm_s2: self.matrix.max_accel_mm_s2,
        }
    }

    /// The limits shows are validated against.
    pub fn limits(&self) -> Limits {
        Limits {
            travel_mm: self.matrix.travel_mm,
            max_speed_mm_s: self.matrix.max_speed_mm_s,
            max_accel_mm_s2: self.matrix.max_accel_mm_s2,
            rows: self.matrix.rows,
            cols: self.matrix.cols,
        }
    }
}

// ----------------------------------------------------------------------------------
// The file as written
// ----------------------------------------------------------------------------------

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    listen: Option<Spanned<String>>,
    #[serde(default)]
    allowed_origins: Vec<Spanned<String>>,
    #[serde(default)]
    matrix: RawMatrix,
    #[serde(default, rename = "gateway")]
    gateways: Vec<Spanned<RawGateway>>,
    #[serde(default)]
    safety: RawSafety,
    #[serde(default)]
    uploads: RawUploads,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMatrix {
    rows: Option<Spanned<u32>>,
    cols: Option<Spanned<u32>>,
    pitch_mm: Option<Spanned<f64>>,
    travel_mm: Option<Spanned<f64>>,
    counts_per_mm: Option<Spanned<f64>>,
    max_speed_mm_s: Option<Spanned<f64>>,
    max_accel_mm_s2: Option<Spanned<f64>>,
    home_mm: Option<Spanned<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawGateway {
    port: Spanned<String>,
    baud: Option<Spanned<u32>>,
    first_station: Option<Spanned<u8>>,
    units: Option<Spanned<usize>>,
    stations: Option<Spanned<Vec<Spanned<u8>>>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSafety {
    estop: Option<Spanned<String>>,
    approach_speed_mm_s: Option<Spanned<f64>>,
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawUploads {
    max_bytes: Option<Spanned<usize>>,
    max_duration: Option<Spanned<String>>,
}

// ----------------------------------------------------------------------------------
// Checking
// ----------------------------------------------------------------------------------

/// Turns the raw file into a [`Config`], naming the place of every problem.
struct Checker<'a> {
    path: &'a Path,
    text: &'a str,
}

/// A value and where it came from (`None`: the default).
type Located<T> = (T, Option<Range<usize>>);

fn located<T: Clone>(value: Option<&Spanned<T>>, default: T) -> Located<T> {
    match value {
        Some(spanned) => (spanned.get_ref().clone(), Some(spanned.span())),
        None => (default, None),
    }
}

impl Checker<'_> {
    fn at(&self, span: &Range<usize>, reason: String) -> ConfigError {
        let before = self.text.get(..span.start).unwrap_or(self.text);
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |newline| newline + 1);
        let column = before
            .get(line_start..)
            .map_or(0, |text| text.chars().count())
            + 1;
        ConfigError::At {
            path: self.path.to_owned(),
            line,
            column,
            reason,
        }
    }

    fn file(&self, reason: String) -> ConfigError {
        ConfigError::File {
            path: self.path.to_owned(),
            reason,
        }
    }

    /// An error at `span`, or for the whole file when the value is a default (a default
    /// can only be wrong together with another value, which the reason names).
    fn wrong(&self, span: Option<&Range<usize>>, reason: String) -> ConfigError {
        match span {
            Some(span) => self.at(span, reason),
            None => self.file(reason),
        }
    }

    fn positive(
        &self,
        (value, span): Located<f64>,
        key: &str,
        max: f64,
    ) -> Result<f64, ConfigError> {
        if value.is_finite() && value > 0.0 && value <= max {
            Ok(value)
        } else {
            Err(self.wrong(
                span.as_ref(),
                format!("{key} = {value} must be a number above 0 and at most {max}"),
            ))
        }
    }

    fn check(&self, raw: RawConfig, overrides: &Overrides) -> Result<Config, ConfigError> {
        let listen = match overrides.listen {
            Some(listen) => listen,
            None => {
                let (text, span) = located(raw.listen.as_ref(), "0.0.0.0:8080".to_owned());
                text.parse().map_err(|_| {
                    self.wrong(
                        span.as_ref(),
                        format!(
                            "listen = {text:?} is not an address and port such as \"0.0.0.0:8080\""
                        ),
                    )
                })?
            }
        };
        let allowed_origins = raw
            .allowed_origins
            .iter()
            .map(|origin| {
                normalise_origin(origin.get_ref()).ok_or_else(|| {
                    self.at(
                        &origin.span(),
                        format!(
                            "{:?} is not an origin such as \"http://192.168.1.20:8080\" \
                             (scheme://host[:port], no path)",
                            origin.get_ref()
                        ),
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let matrix = self.matrix(&raw.matrix)?;
        let gateways = self.gateways(&raw.gateways, &matrix, overrides)?;
        let safety = self.safety(&raw.safety, &matrix)?;
        let (max_bytes, span) = located(raw.uploads.max_bytes.as_ref(), 32 * 1024 * 1024);
        if !(1024..=1024 * 1024 * 1024).contains(&max_bytes) {
            return Err(self.wrong(
                span.as_ref(),
                format!("max_bytes = {max_bytes} must be from 1024 (1 KiB) to 1073741824 (1 GiB)"),
            ));
        }
        let max_duration = match &raw.uploads.max_duration {
            None => DEFAULT_MAX_DURATION,
            Some(text) => humantime::parse_duration(text.get_ref().trim())
                .ok()
                .filter(|duration| MAX_DURATION_RANGE.contains(duration))
                .ok_or_else(|| {
                    self.at(
                        &text.span(),
                        format!(
                            "max_duration = {:?} must be a duration such as \"30m\" or \
                             \"1h 15m\", from 1 second to 24 hours",
                            text.get_ref()
                        ),
                    )
                })?,
        };
        Ok(Config {
            listen,
            allowed_origins,
            matrix,
            gateways,
            safety,
            uploads: Uploads {
                max_bytes,
                max_duration,
            },
        })
    }

    fn matrix(&self, raw: &RawMatrix) -> Result<Matrix, ConfigError> {
        let size = |value: Option<&Spanned<u32>>, key: &str| {
            let (count, span) = located(value, 10);
            if (1..=1000).contains(&count) {
                Ok(count)
            } else {
                Err(self.wrong(
                    span.as_ref(),
                    format!("{key} = {count} must be from 1 to 1000"),
                ))
            }
        };
        let rows = size(raw.rows.as_ref(), "rows")?;
        let cols = size(raw.cols.as_ref(), "cols")?;
        let pitch_mm =
            self.positive(located(raw.pitch_mm.as_ref(), 500.0), "pitch_mm", 100_000.0)?;
        let travel_mm = self.positive(
            located(raw.travel_mm.as_ref(), 7500.0),
            "travel_mm",
            100_000.0,
        )?;
        let counts_per_mm = self.positive(
            located(raw.counts_per_mm.as_ref(), 100.0),
            "counts_per_mm",
            100_000.0,
        )?;
        let max_speed_mm_s = self.positive(
            located(raw.max_speed_mm_s.as_ref(), 2000.0),
            "max_speed_mm_s",
            100_000.0,
        )?;
        let max_accel_mm_s2 = self.positive(
            located(raw.max_accel_mm_s2.as_ref(), 4000.0),
            "max_accel_mm_s2",
            1_000_000.0,
        )?;
        let (home_mm, span) = located(raw.home_mm.as_ref(), 0.0);
        if !(home_mm.is_finite() && (0.0..=travel_mm).contains(&home_mm)) {
            return Err(self.wrong(
                span.as_ref(),
                format!("home_mm = {home_mm} must be from 0 to travel_mm ({travel_mm})"),
            ));
        }
        // Positions in counts travel as i32 on the wire (QP, PA).
        if travel_mm * counts_per_mm > f64::from(i32::MAX) {
            let span = raw.counts_per_mm.as_ref().map(Spanned::span);
            return Err(self.wrong(
                span.as_ref(),
                format!(
                    "travel_mm × counts_per_mm = {} counts does not fit in a position (at most {})",
                    travel_mm * counts_per_mm,
                    i32::MAX
                ),
            ));
        }
        Ok(Matrix {
            rows,
            cols,
            pitch_mm,
            travel_mm,
            counts_per_mm,
            max_speed_mm_s,
            max_accel_mm_s2,
            home_mm,
        })
    }

    fn gateways(
        &self,
        raw: &[Spanned<RawGateway>],
        matrix: &Matrix,
        overrides: &Overrides,
    ) -> Result<Vec<Gateway>, ConfigError> {
        let default_gateway = [Spanned::new(
            0..0,
            RawGateway {
                port: Spanned::new(0..0, SIM_PORT.to_owned()),
                baud: None,
                first_station: None,
                units: None,
                stations: None,
            },
        )];
        // Without a [[gateway]] table there is no place in the file to point at.
        let implicit = raw.is_empty();
        let raw = if implicit { &default_gateway[..] } else { raw };
        if overrides.gateway_ports.len() > raw.len() {
            return Err(self.file(format!(
                "{} --gateway flags given but the file configures {} [[gateway]] table(s); \
                 add [[gateway]] tables for the others",
                overrides.gateway_ports.len(),
                raw.len()
            )));
        }
        // How many units each gateway serves: explicit counts first, then the rest
        // shared evenly (the first gateways take one more when it does not divide).
        let explicit: Vec<Option<usize>> = raw
            .iter()
            .map(|gateway| {
                let gateway = gateway.get_ref();
                match (&gateway.stations, &gateway.units) {
                    (Some(stations), _) => Some(stations.get_ref().len()),
                    (None, Some(units)) => Some(*units.get_ref()),
                    (None, None) => None,
                }
            })
            .collect();
        let total = matrix.rows as usize * matrix.cols as usize;
        let explicit_sum: usize = explicit.iter().flatten().sum();
        let sharing = explicit.iter().filter(|units| units.is_none()).count();
        let rest = total.saturating_sub(explicit_sum);
        let mut shared_index = 0;
        let mut gateways = Vec::with_capacity(raw.len());
        for (index, spanned) in raw.iter().enumerate() {
            let gateway = spanned.get_ref();
            let table_span = spanned.span();
            let (port, port_span) = match overrides.gateway_ports.get(index) {
                Some(port) => (port.clone(), None),
                None => (gateway.port.get_ref().clone(), Some(gateway.port.span())),
            };
            if port.is_empty() || port.chars().any(char::is_control) {
                return Err(self.wrong(
                    port_span.as_ref(),
                    format!(
                        "gateway {}: port {port:?} must be \"sim\" or a device path such as \
                         \"/dev/ttyUSB0\"",
                        index + 1
                    ),
                ));
            }
            let default_baud = if port == SIM_PORT {
                DEFAULT_SIM_BAUD
            } else {
                DEFAULT_SERIAL_BAUD
            };
            let (baud, baud_span) = located(gateway.baud.as_ref(), default_baud);
            if !BAUD_RANGE.contains(&baud) {
                return Err(self.wrong(
                    baud_span.as_ref(),
                    format!(
                        "baud {baud} is out of range ({} to {})",
                        BAUD_RANGE.start(),
                        BAUD_RANGE.end()
                    ),
                ));
            }
            let units = explicit[index].unwrap_or_else(|| {
                let share =
                    rest / sharing.max(1) + usize::from(shared_index < rest % sharing.max(1));
                shared_index += 1;
                share
            });
            let units_span = gateway
                .stations
                .as_ref()
                .map(Spanned::span)
                .or_else(|| gateway.units.as_ref().map(Spanned::span))
                .unwrap_or_else(|| table_span.clone());
            let units_span = (!implicit).then_some(units_span);
            if units > MAX_UNITS_PER_GATEWAY {
                return Err(self.wrong(
                    units_span.as_ref(),
                    format!(
                        "gateway {} would serve {units} units; a gateway serves at most \
                         {MAX_UNITS_PER_GATEWAY}: add a [[gateway]]",
                        index + 1
                    ),
                ));
            }
            let stations = match &gateway.stations {
                Some(stations) => self.station_list(stations, index)?,
                None => {
                    let (first, first_span) = located(gateway.first_station.as_ref(), 1);
                    let last = usize::from(first) + units.saturating_sub(1);
                    if first == 0 || last > 127 {
                        return Err(self.wrong(
                            first_span.as_ref().or(units_span.as_ref()),
                            format!(
                                "gateway {}: stations {first} to {last} must lie within 1 to 127",
                                index + 1
                            ),
                        ));
                    }
                    (first..).take(units).collect()
                }
            };
            gateways.push(Gateway {
                port,
                baud,
                stations,
            });
        }
        let held: usize = gateways.iter().map(|gateway| gateway.stations.len()).sum();
        if held != total {
            return Err(self.file(format!(
                "the matrix has {} × {} = {total} units but the gateways serve {held}; \
                 adjust the gateways' units or stations (each gateway serves at most \
                 {MAX_UNITS_PER_GATEWAY})",
                matrix.rows, matrix.cols
            )));
        }
        Ok(gateways)
    }

    fn station_list(
        &self,
        stations: &Spanned<Vec<Spanned<u8>>>,
        index: usize,
    ) -> Result<Vec<u8>, ConfigError> {
        let mut seen = HashSet::new();
        for station in stations.get_ref() {
            let number = *station.get_ref();
            if !(1..=127).contains(&number) {
                return Err(self.at(
                    &station.span(),
                    format!(
                        "gateway {}: station {number} must be from 1 to 127",
                        index + 1
                    ),
                ));
            }
            if !seen.insert(number) {
                return Err(self.at(
                    &station.span(),
                    format!(
                        "gateway {}: station {number} is listed twice; two units with one \
                         station number break the bus",
                        index + 1
                    ),
                ));
            }
        }
        Ok(stations
            .get_ref()
            .iter()
            .map(|station| *station.get_ref())
            .collect())
    }

    fn safety(&self, raw: &RawSafety, matrix: &Matrix) -> Result<Safety, ConfigError> {
        let (text, span) = located(raw.estop.as_ref(), "MO=0;".to_owned());
        let estop = parse_script(&text)
            .map_err(|error| self.wrong(span.as_ref(), format!("estop = {text:?}: {error}")))?;
        if estop.is_empty() {
            return Err(self.wrong(
                span.as_ref(),
                "estop is empty; it must hold the stop instruction, e.g. \"MO=0;\"".to_owned(),
            ));
        }
        if estop
            .iter()
            .any(|instruction| matches!(instruction, Instruction::Select { .. }))
        {
            return Err(self.wrong(
                span.as_ref(),
                format!(
                    "estop = {text:?} selects a station; leave it out: the e-stop always goes \
                     to every unit (\"*0;\")"
                ),
            ));
        }
        let estop: Vec<Instruction> = [Instruction::Select { station: 0 }]
            .into_iter()
            .chain(estop)
            .collect();
        // The parser only returns instructions that encode; checked again all the same.
        for instruction in &estop {
            instruction
                .encode(Form::Standard)
                .map_err(|error| self.wrong(span.as_ref(), format!("estop: {error}")))?;
        }
        let approach_speed_mm_s = self.positive(
            located(raw.approach_speed_mm_s.as_ref(), 250.0),
            "approach_speed_mm_s",
            matrix.max_speed_mm_s,
        )?;
        Ok(Safety {
            estop,
            approach_speed_mm_s,
        })
    }
}

/// `scheme://host[:port]` in lower case without a trailing `/`, or `None` if `text` is
/// not an origin.
pub fn normalise_origin(text: &str) -> Option<String> {
    let lower = text.trim().trim_end_matches('/').to_ascii_lowercase();
    let rest = lower
        .strip_prefix("http://")
        .or_else(|| lower.strip_prefix("https://"))?;
    let valid = !rest.is_empty()
        && rest
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | ':' | '[' | ']' | '_'));
    valid.then_some(lower)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Config, ConfigError> {
        Config::parse(
            Path::new("data/floatball.toml"),
            text,
            &Overrides::default(),
        )
    }

    fn estop_bytes(config: &Config) -> Vec<u8> {
        let mut bytes = Vec::new();
        for instruction in &config.safety.estop {
            instruction
                .encode_into(Form::Standard, &mut bytes)
                .expect("encodes");
        }
        bytes
    }

    #[test]
    fn the_default_file_gives_the_defaults() {
        let config = parse(DEFAULT_FILE).expect("defaults parse");
        assert_eq!(config, parse("").expect("empty file"));
        assert_eq!(config.listen, "0.0.0.0:8080".parse().expect("addr"));
        assert_eq!(config.matrix.rows * config.matrix.cols, 100);
        assert_eq!(config.gateways.len(), 1);
        assert_eq!(config.gateways[0].port, "sim");
        assert_eq!(config.gateways[0].baud, DEFAULT_SIM_BAUD);
        assert_eq!(config.gateways[0].stations, (1..=100).collect::<Vec<u8>>());
        assert_eq!(estop_bytes(&config), b"*0;MO=0;");
        assert_eq!(config.uploads.max_bytes, 32 * 1024 * 1024);
        assert_eq!(config.uploads.max_duration, Duration::from_secs(30 * 60));
        assert_eq!(config.limits(), Limits::for_layout(10, 10));
    }

    #[test]
    fn syntax_errors_name_the_file_line_and_column() {
        let error = parse("[matrix]\nrows = 10\ncols = ten\n").expect_err("bad value");
        let message = error.to_string();
        assert!(
            message.starts_with("data/floatball.toml line 3, column 8: "),
            "{message}"
        );
    }

    #[test]
    fn unknown_keys_are_refused_with_their_line() {
        let message = parse("[matrix]\nrows = 10\ncolumns = 3\n")
            .expect_err("unknown key")
            .to_string();
        assert!(message.contains("line 3, column 1"), "{message}");
        assert!(message.contains("columns"), "{message}");
    }

    #[test]
    fn a_baud_out_of_range_names_its_line() {
        let text = "[[gateway]]\nport = \"/dev/ttyUSB0\"\nbaud = 300\n";
        let message = parse(text).expect_err("baud").to_string();
        assert_eq!(
            message,
            "data/floatball.toml line 3, column 8: baud 300 is out of range (1200 to 921600)"
        );
    }

    #[test]
    fn a_real_port_defaults_to_9600_baud_and_sim_to_115200() {
        let config = parse("[[gateway]]\nport = \"/dev/ttyUSB0\"\n").expect("config");
        assert_eq!(config.gateways[0].baud, 9600);
        let overridden = Config::parse(
            Path::new("f"),
            "[[gateway]]\nport = \"/dev/ttyUSB0\"\n",
            &Overrides {
                listen: Some("127.0.0.1:0".parse().expect("addr")),
                gateway_ports: vec!["sim".into()],
            },
        )
        .expect("config");
        assert_eq!(overridden.gateways[0].port, "sim");
        assert_eq!(overridden.gateways[0].baud, 115_200);
        assert_eq!(overridden.listen.port(), 0);
    }

    #[test]
    fn more_gateway_flags_than_gateways_are_refused() {
        let error = Config::parse(
            Path::new("f"),
            "",
            &Overrides {
                listen: None,
                gateway_ports: vec!["sim".into(), "sim".into()],
            },
        )
        .expect_err("two flags, one gateway");
        assert!(error.to_string().contains("2 --gateway flags"), "{error}");
    }

    #[test]
    fn units_are_shared_among_gateways_row_major() {
        let text = "[matrix]\nrows = 15\ncols = 10\n\
                    [[gateway]]\nport = \"sim\"\n\
                    [[gateway]]\nport = \"sim\"\nfirst_station = 10\n";
        let config = parse(text).expect("config");
        assert_eq!(config.gateways[0].stations, (1..=75).collect::<Vec<u8>>());
        assert_eq!(config.gateways[1].stations, (10..=84).collect::<Vec<u8>>());
    }

    /// Every unit's (gateway, station), row-major.
    fn addresses(text: &str) -> Vec<(usize, u8)> {
        parse(text)
            .expect("config")
            .installation()
            .units
            .iter()
            .map(|address| (address.gateway, address.station))
            .collect()
    }

    #[test]
    fn unit_addresses_stay_as_they_were() {
        // The default file: one gateway, stations 1 to 100.
        let default: Vec<(usize, u8)> = (1..=100).map(|station| (0, station)).collect();
        assert_eq!(addresses(DEFAULT_FILE), default);
        // Ten units shared by three gateways: 4, 3, 3, each from its first station.
        let text = "[matrix]\nrows = 2\ncols = 5\n\
                    [[gateway]]\nport = \"sim\"\n\
                    [[gateway]]\nport = \"sim\"\n\
                    [[gateway]]\nport = \"sim\"\nfirst_station = 20\n";
        assert_eq!(
            addresses(text),
            [
                (0, 1),
                (0, 2),
                (0, 3),
                (0, 4),
                (1, 1),
                (1, 2),
                (1, 3),
                (2, 20),
                (2, 21),
                (2, 22)
            ]
        );
        // Counts and lists first, the rest shared among the others.
        let text = "[matrix]\nrows = 2\ncols = 5\n\
                    [[gateway]]\nport = \"sim\"\nfirst_station = 5\nunits = 3\n\
                    [[gateway]]\nport = \"sim\"\n\
                    [[gateway]]\nport = \"sim\"\nstations = [9, 7]\nfirst_station = 40\n\
                    [[gateway]]\nport = \"sim\"\nfirst_station = 50\n";
        assert_eq!(
            addresses(text),
            [
                (0, 5),
                (0, 6),
                (0, 7),
                (1, 1),
                (1, 2),
                (1, 3),
                (2, 9),
                (2, 7),
                (3, 50),
                (3, 51)
            ]
        );
        // A gateway left with nothing to share serves no unit.
        let text = "[matrix]\nrows = 1\ncols = 2\n\
                    [[gateway]]\nport = \"sim\"\nunits = 2\n\
                    [[gateway]]\nport = \"sim\"\n";
        assert_eq!(addresses(text), [(0, 1), (0, 2)]);
        // 150 units on two gateways: 75 each, the second from station 10.
        let text = "[matrix]\nrows = 15\ncols = 10\n\
                    [[gateway]]\nport = \"sim\"\n\
                    [[gateway]]\nport = \"sim\"\nfirst_station = 10\n";
        let two: Vec<(usize, u8)> = (1..=75)
            .map(|station| (0, station))
            .chain((10..=84).map(|station| (1, station)))
            .collect();
        assert_eq!(addresses(text), two);
    }

    #[test]
    fn the_gateways_must_serve_every_unit_exactly() {
        let text = "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nport = \"sim\"\nunits = 2\n";
        assert_eq!(
            parse(text).expect_err("2 of 3").to_string(),
            "data/floatball.toml: the matrix has 1 × 3 = 3 units but the gateways serve 2; \
             adjust the gateways' units or stations (each gateway serves at most 100)"
        );
    }

    #[test]
    fn too_many_units_for_the_gateways_is_refused() {
        let message = parse("[matrix]\nrows = 11\ncols = 10\n")
            .expect_err("110 units on one gateway")
            .to_string();
        assert!(
            message.starts_with("data/floatball.toml: gateway 1"),
            "{message}"
        );
        assert!(message.contains("110 units"), "{message}");
        assert!(message.contains("at most 100"), "{message}");
        let text = "[matrix]\nrows = 11\ncols = 10\n[[gateway]]\nport = \"sim\"\n";
        let message = parse(text).expect_err("110 units").to_string();
        assert!(
            message.starts_with("data/floatball.toml line 4, column 1: gateway 1"),
            "{message}"
        );
    }

    #[test]
    fn explicit_stations_must_be_unique_and_in_range() {
        let duplicate =
            "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nport = \"sim\"\nstations = [5, 6, 5]\n";
        let message = parse(duplicate).expect_err("duplicate").to_string();
        assert_eq!(
            message,
            "data/floatball.toml line 6, column 19: gateway 1: station 5 is listed twice; two \
             units with one station number break the bus"
        );
        let range =
            "[matrix]\nrows = 1\ncols = 2\n[[gateway]]\nport = \"sim\"\nstations = [0, 6]\n";
        assert!(
            parse(range)
                .expect_err("station 0")
                .to_string()
                .contains("line 6, column 13")
        );
        let stations =
            "[matrix]\nrows = 1\ncols = 2\n[[gateway]]\nport = \"sim\"\nstations = [9, 7]\n";
        assert_eq!(
            parse(stations).expect("config").gateways[0].stations,
            [9, 7]
        );
    }

    #[test]
    fn stations_past_127_are_refused() {
        let text = "[[gateway]]\nport = \"sim\"\nfirst_station = 100\n";
        let message = parse(text).expect_err("100..199").to_string();
        assert!(message.contains("line 3"), "{message}");
        assert!(message.contains("stations 100 to 199"), "{message}");
    }

    #[test]
    fn the_estop_is_checked_by_the_codec() {
        let message = parse("[safety]\nestop = \"MO=0\"\n")
            .expect_err("no ;")
            .to_string();
        assert!(
            message.starts_with("data/floatball.toml line 2, column 9: estop"),
            "{message}"
        );
        assert!(message.contains("`;`"), "{message}");
        let select = parse("[safety]\nestop = \"*5;MO=0;\"\n").expect_err("selects");
        assert!(select.to_string().contains("selects a station"), "{select}");
        let two = parse("[safety]\nestop = \"mo=0; SD=1000;\"\n").expect("two instructions");
        assert_eq!(estop_bytes(&two), b"*0;MO=0;SD=1000;");
    }

    #[test]
    fn numbers_are_checked() {
        for (text, key) in [
            ("[matrix]\npitch_mm = -1.0\n", "pitch_mm"),
            ("[matrix]\nrows = 0\n", "rows"),
            ("[matrix]\nhome_mm = 8000.0\n", "home_mm"),
            ("[uploads]\nmax_bytes = 10\n", "max_bytes"),
            ("[uploads]\nmax_duration = \"25h\"\n", "max_duration"),
            (
                "[uploads]\nmax_duration = \"half an hour\"\n",
                "max_duration",
            ),
            ("[uploads]\nmax_duration = \"0s\"\n", "max_duration"),
            (
                "[safety]\napproach_speed_mm_s = 5000.0\n",
                "approach_speed_mm_s",
            ),
            ("listen = \"everywhere\"\n", "listen"),
            ("allowed_origins = [\"example.com\"]\n", "origin"),
        ] {
            let message = parse(text).expect_err(key).to_string();
            assert!(message.contains(key), "{text}: {message}");
            assert!(message.contains("line "), "{text}: {message}");
        }
    }

    #[test]
    fn max_duration_reads_human_durations() {
        let config = parse("[uploads]\nmax_duration = \"1h 15m\"\n").expect("duration");
        assert_eq!(config.uploads.max_duration, Duration::from_secs(75 * 60));
    }

    #[test]
    fn every_key_of_the_default_file_is_documented() {
        let docs = include_str!("../../docs/configuration.md");
        let keys: Vec<&str> = DEFAULT_FILE
            .lines()
            .map(|line| line.trim_start_matches("# "))
            .filter_map(|line| line.split_once(" = ").map(|(key, _)| key))
            .filter(|key| key.chars().all(|c| c.is_ascii_lowercase() || c == '_'))
            .collect();
        assert!(keys.len() >= 17, "{keys:?}");
        for key in keys {
            assert!(
                docs.contains(&format!("| `{key}` |")),
                "{key} is not documented"
            );
        }
        for table in ["[matrix]", "[[gateway]]", "[safety]", "[uploads]"] {
            assert!(
                DEFAULT_FILE.contains(table) && docs.contains(table),
                "{table}"
            );
        }
    }

    #[test]
    fn origins_are_normalised() {
        assert_eq!(
            normalise_origin("HTTP://Tablet.local:8080/").as_deref(),
            Some("http://tablet.local:8080")
        );
        assert_eq!(normalise_origin("http://a/b"), None);
        assert_eq!(normalise_origin("ftp://a"), None);
    }
}
