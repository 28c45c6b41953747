//! The MOONS' (SCL) part of `floatball.toml`: a `kind = "scl"` gateway entry — an
//! RS-485 line (`port`, `baud`, `addresses`) or eSCL drives on UDP (`escl`) — and the
//! `[scl]` table (start input and trigger, programs uploaded or stored, steps per
//! revolution, tolerance, poll period), checked with line and column like the rest; and
//! the Q program compiler's settings an installation gives ([`qprogram_config`]), the
//! one place that builds them for the player, the API and the verdict.

use std::net::SocketAddr;
use std::ops::Range;
use std::time::Duration;

use floatball_shared::plan::Installation;
use floatball_shared::plan::installation::{MAX_SCL_DRIVES, SIM_PORT};
use floatball_shared::scl::qprogram::QProgramConfig;
use floatball_shared::scl::{Address, InputCondition, IoPoint, escl};
use toml::Spanned;

use super::check::{Checker, located};
use super::raw::{RawGateway, RawScl};
use super::{ConfigError, DEFAULT_SERIAL_BAUD};

/// The status poll period unless configured.
pub const DEFAULT_SCL_POLL: Duration = Duration::from_millis(200);

pub use floatball_shared::scl::qprogram::{
    DEFAULT_START_INPUT, DEFAULT_STEPS_PER_REV, DEFAULT_TOLERANCE_MM,
};

/// The host's UDP port for eSCL unless configured: the drives' own port. An eSCL drive
/// answers only the address and port of the first host that spoke to it until it is
/// powered down, so the bridge sends from the same port every time it starts.
pub const DEFAULT_SCL_HOST_PORT: u16 = escl::UDP_PORT;

// ---- the Q program compiler's settings ----

/// What an installation may set beyond its calibration and limits; `None` keeps the
/// compiler's default ([`QProgramConfig::default`]).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct QProgramOverrides {
    /// The common start input (`Some(None)`: no `WI`, the program starts at once).
    pub start: Option<Option<(IoPoint, InputCondition)>>,
    /// The largest deviation accepted, mm.
    pub tolerance_mm: Option<f64>,
    /// Counts per motor revolution (`EG`).
    pub steps_per_rev: Option<u32>,
    /// Run the show again and again.
    pub loop_show: Option<bool>,
}

/// The compiler's settings for `installation`: its calibration (`counts_per_mm`) and
/// limits (top speed and acceleration), then `overrides`, then the defaults.
#[must_use]
pub fn qprogram_config(
    installation: &Installation,
    overrides: &QProgramOverrides,
) -> QProgramConfig {
    let defaults = QProgramConfig::default();
    QProgramConfig {
        counts_per_mm: installation.counts_per_mm,
        steps_per_rev: overrides.steps_per_rev.unwrap_or(defaults.steps_per_rev),
        start: overrides.start.unwrap_or(defaults.start),
        loop_show: overrides.loop_show.unwrap_or(defaults.loop_show),
        tolerance_mm: overrides.tolerance_mm.unwrap_or(defaults.tolerance_mm),
        max_speed_mm_s: installation.limits.max_speed_mm_s,
        max_accel_mm_s2: installation.limits.max_accel_mm_s2,
    }
}

/// The overrides a configuration sets: its `[scl]` table (start input only with a
/// trigger, tolerance, steps per revolution) when the gateways are MOONS' drives;
/// otherwise every setting is the compiler's default.
#[must_use]
pub fn overrides(config: &super::Config) -> QProgramOverrides {
    config
        .scl()
        .map_or_else(QProgramOverrides::default, scl_overrides)
}

/// The overrides of an SCL installation's `[scl]` table (the player's too).
#[must_use]
pub fn scl_overrides(scl: &SclConfig) -> QProgramOverrides {
    QProgramOverrides {
        start: Some(scl.start),
        tolerance_mm: Some(scl.tolerance_mm),
        steps_per_rev: Some(scl.steps_per_rev),
        loop_show: Some(false),
    }
}

/// An installation of MOONS' drives: every gateway entry's drives and the `[scl]`
/// settings.
#[derive(Debug, Clone, PartialEq)]
pub struct SclConfig {
    /// Every `kind = "scl"` gateway entry, in gateway order.
    pub gateways: Vec<SclGateway>,
    /// The input every compiled program waits on before it moves, and the condition
    /// (`WI{input}{condition}`): only when a [`SclConfig::trigger`] is configured —
    /// without one the drives are started by `QX1` and wait for nothing.
    pub start: Option<(IoPoint, InputCondition)>,
    /// The drive (on the first gateway entry) and its output wired to every drive's
    /// start input; `None`: each drive is started by `QX1`.
    pub trigger: Option<(Address, IoPoint)>,
    /// Whether Start uploads the compiled programs or only starts the stored ones.
    pub programs: SclPrograms,
    /// The drives' steps per revolution (`EG`): rev/s ↔ counts/s.
    pub steps_per_rev: u32,
    /// The largest deviation from the show a reduced program may have, mm.
    pub tolerance_mm: f64,
    /// How often each drive is asked for `IP`, `SC` and `AL` while nothing else is
    /// waiting (less often while programs are uploaded).
    pub poll: Duration,
    /// The host's UDP port for the first eSCL gateway entry (the n-th entry's is this
    /// + n); `0`: any free port (tests).
    pub host_port: u16,
}

/// Where Start finds the drives' Q programs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SclPrograms {
    /// Compiled from the show at every Start: a program of one segment loaded into
    /// the drive's queue (`QL`, its lines, `QE`: never its memory); a longer one
    /// saved to its segments (`QL`, `QS`) only where `QU` shows they differ.
    Upload,
    /// Already on the drives (loaded with Q Programmer); Start only starts them.
    Stored,
    /// Every ball's show streamed into its drive's command buffer as it plays (`PS`,
    /// the buffer filled, `CT`, then `BS` and the next lines), whatever its length.
    Stream,
}

impl SclPrograms {
    /// Whether Start compiles the programs (uploaded or streamed).
    pub fn compiled(self) -> bool {
        matches!(self, Self::Upload | Self::Stream)
    }

    /// When a ball's show is streamed: `upload` streams the shows no stored
    /// program follows within the tolerance; `stream` all of them.
    pub fn streaming(self) -> floatball_shared::scl::qprogram::Streaming {
        use floatball_shared::scl::qprogram::Streaming;
        match self {
            Self::Upload => Streaming::WhenNeeded,
            Self::Stream => Streaming::Always,
            Self::Stored => Streaming::Never,
        }
    }
}

impl SclConfig {
    /// The trigger drive's place on the first gateway entry (its index there), if a
    /// trigger is set and its drive is listed: the drive plays that unit when the
    /// unit is on entry 0 at that place.
    pub fn trigger_drive(&self) -> Option<usize> {
        let (address, _) = self.trigger?;
        match self.gateways.first()? {
            SclGateway::Serial { addresses, .. } => {
                addresses.iter().position(|&listed| listed == address)
            }
            // eSCL and simulated drives take the address characters in order.
            gateway => Address::CHARACTERS
                .chars()
                .position(|character| character == address.character())
                .filter(|&index| index < gateway.drives()),
        }
    }
}

/// One `kind = "scl"` gateway entry.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SclGateway {
    /// An RS-485 line: the serial device, its speed and every drive's address
    /// character, in unit order.
    Serial {
        /// The serial device.
        port: String,
        /// Its speed, baud.
        baud: u32,
        /// The drives' address characters, in unit order.
        addresses: Vec<Address>,
    },
    /// eSCL drives, one per unit, each at its UDP address and port.
    Escl(Vec<SocketAddr>),
    /// `port = "sim"`: simulated drives the bridge starts on loopback UDP (eSCL), one
    /// per unit, all on one start wire (see `crate::state`).
    Sim {
        /// How many drives (units).
        drives: usize,
    },
}

impl SclGateway {
    /// How many drives (units) it has.
    pub fn drives(&self) -> usize {
        match self {
            Self::Serial { addresses, .. } => addresses.len(),
            Self::Escl(addresses) => addresses.len(),
            Self::Sim { drives } => *drives,
        }
    }

    /// How the status names it: the serial device, or the first eSCL address.
    pub fn port(&self) -> String {
        match self {
            Self::Serial { port, .. } => port.clone(),
            Self::Escl(addresses) => addresses
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(" "),
            Self::Sim { .. } => SIM_PORT.to_owned(),
        }
    }
}

/// A `kind = "scl"` entry before the units are known: its drives' count when the
/// entry fixes it (`addresses`, `escl`).
#[derive(Debug, Clone)]
pub(super) struct SclEntry {
    pub(super) gateway: SclGateway,
    /// Addresses were listed (not the default characters).
    pub(super) listed: bool,
}

impl Checker<'_> {
    /// A `kind = "scl"` gateway entry: an RS-485 line or eSCL drives; `override_port`
    /// (`--gateway`) replaces the serial device.
    pub(super) fn scl_gateway(
        &self,
        number: usize,
        gateway: &RawGateway,
        table: &Range<usize>,
        override_port: Option<&String>,
    ) -> Result<SclEntry, ConfigError> {
        let stations = [
            (
                "first_station",
                gateway.first_station.as_ref().map(Spanned::span),
            ),
            ("stations", gateway.stations.as_ref().map(Spanned::span)),
        ];
        for (key, value) in gateway.mbox_keys().into_iter().chain(stations) {
            if let Some(span) = value {
                return Err(self.at(
                    &span,
                    format!(
                        "gateway {number}: {key} is not for MOONS' drives (kind = \"scl\"); give \
                         port and addresses, or escl"
                    ),
                ));
            }
        }
        let units = gateway.units.as_ref();
        if let Some(list) = &gateway.escl {
            if override_port.is_some() || gateway.port.is_some() || gateway.baud.is_some() {
                let span = gateway
                    .port
                    .as_ref()
                    .map(Spanned::span)
                    .or_else(|| gateway.baud.as_ref().map(Spanned::span))
                    .unwrap_or_else(|| list.span());
                return Err(self.at(
                    &span,
                    format!(
                        "gateway {number}: give MOONS' drives either port (an RS-485 line) or \
                         escl (drives on UDP), not both"
                    ),
                ));
            }
            if let Some(span) = gateway.addresses.as_ref().map(Spanned::span) {
                return Err(self.at(
                    &span,
                    format!(
                        "gateway {number}: addresses are for an RS-485 line; an eSCL drive is \
                         named by its IP address"
                    ),
                ));
            }
            if list.get_ref().is_empty() || list.get_ref().len() > MAX_SCL_DRIVES {
                return Err(self.at(
                    &list.span(),
                    format!(
                        "gateway {number}: escl lists {} drives; give 1 to {MAX_SCL_DRIVES} \
                         (add a [[gateway]] for more)",
                        list.get_ref().len()
                    ),
                ));
            }
            let mut addresses: Vec<SocketAddr> = Vec::with_capacity(list.get_ref().len());
            for item in list.get_ref() {
                let text = item.get_ref().trim();
                let address = text
                    .parse::<SocketAddr>()
                    .ok()
                    .or_else(|| {
                        text.parse::<std::net::IpAddr>()
                            .ok()
                            .map(|ip| SocketAddr::new(ip, escl::UDP_PORT))
                    })
                    .ok_or_else(|| {
                        self.at(
                            &item.span(),
                            format!(
                                "gateway {number}: {text:?} is not a drive's IP address such as \
                                 \"192.168.0.11\" or \"192.168.0.11:{}\"",
                                escl::UDP_PORT
                            ),
                        )
                    })?;
                if addresses.contains(&address) {
                    return Err(self.at(
                        &item.span(),
                        format!("gateway {number}: {address} is listed twice"),
                    ));
                }
                addresses.push(address);
            }
            self.scl_units_agree(number, units, addresses.len())?;
            return Ok(SclEntry {
                gateway: SclGateway::Escl(addresses),
                listed: true,
            });
        }
        let (port, port_span) = match (override_port, &gateway.port) {
            (Some(port), _) => (port.clone(), None),
            (None, Some(port)) => (port.get_ref().clone(), Some(port.span())),
            (None, None) => {
                return Err(self.at(
                    table,
                    format!(
                        "gateway {number}: MOONS' drives need port = \"/dev/ttyUSB0\" (an RS-485 \
                         line) or escl = [\"192.168.0.11\", …] (drives on UDP)"
                    ),
                ));
            }
        };
        if port == SIM_PORT {
            for (key, value) in [
                ("baud", gateway.baud.as_ref().map(Spanned::span)),
                ("addresses", gateway.addresses.as_ref().map(Spanned::span)),
            ] {
                if let Some(span) = value {
                    return Err(self.at(
                        &span,
                        format!(
                            "gateway {number}: {key} is not for simulated drives (port = \
                             \"sim\"); give units"
                        ),
                    ));
                }
            }
            // The count comes from the units, once they are allocated.
            return Ok(SclEntry {
                gateway: SclGateway::Sim { drives: 0 },
                listed: false,
            });
        }
        if port.is_empty() || port.chars().any(char::is_control) {
            return Err(self.wrong(
                port_span.as_ref(),
                format!(
                    "gateway {number}: port {port:?} must be a serial device such as \
                     \"/dev/ttyUSB0\", or \"sim\" (simulated drives)"
                ),
            ));
        }
        let baud = self.baud(gateway.baud.as_ref(), DEFAULT_SERIAL_BAUD)?;
        let mut addresses = Vec::new();
        let listed = gateway.addresses.is_some();
        if let Some(text) = &gateway.addresses {
            // The string's first character sits one past the opening quote.
            let start = text.span().start + 1;
            for (offset, character) in text.get_ref().char_indices() {
                let at = start + offset..start + offset + character.len_utf8();
                let address = Address::new(character).ok_or_else(|| {
                    self.at(
                        &at,
                        format!(
                            "gateway {number}: {character:?} is not a drive address; the \
                             address characters are {}",
                            Address::CHARACTERS
                        ),
                    )
                })?;
                if addresses.contains(&address) {
                    return Err(self.at(
                        &at,
                        format!("gateway {number}: address {character:?} is given twice"),
                    ));
                }
                addresses.push(address);
            }
            if addresses.is_empty() {
                return Err(self.at(
                    &text.span(),
                    format!(
                        "gateway {number}: addresses is empty; give one character per drive \
                         such as \"123\""
                    ),
                ));
            }
            self.scl_units_agree(number, units, addresses.len())?;
        }
        Ok(SclEntry {
            gateway: SclGateway::Serial {
                port,
                baud,
                addresses,
            },
            listed,
        })
    }

    /// `units`, when given beside a list of drives, must count them.
    fn scl_units_agree(
        &self,
        number: usize,
        units: Option<&Spanned<usize>>,
        drives: usize,
    ) -> Result<(), ConfigError> {
        match units {
            Some(units) if *units.get_ref() != drives => Err(self.at(
                &units.span(),
                format!(
                    "gateway {number}: units = {} but {drives} drives are listed; leave units \
                     out",
                    units.get_ref()
                ),
            )),
            _ => Ok(()),
        }
    }

    /// `[scl]`, for an installation of MOONS' drives on `gateways` (each with its
    /// drives' addresses filled in).
    pub(super) fn scl(
        &self,
        raw: &RawScl,
        gateways: Vec<SclGateway>,
    ) -> Result<SclConfig, ConfigError> {
        let (input, input_span) = located(raw.start_input.as_ref(), DEFAULT_START_INPUT);
        let input = IoPoint::new(input).ok_or_else(|| {
            self.wrong(
                input_span.as_ref(),
                format!("start_input = {input} must be an input from 0 to 9"),
            )
        })?;
        let condition = match &raw.start_condition {
            None => InputCondition::Falling,
            Some(text) => {
                let mut letters = text.get_ref().chars();
                match (letters.next(), letters.next()) {
                    (Some(letter), None) => InputCondition::from_letter(letter),
                    _ => None,
                }
                .ok_or_else(|| {
                    self.at(
                        &text.span(),
                        format!(
                            "start_condition = {:?} must be \"H\" (high), \"L\" (low), \"R\" \
                             (rising edge) or \"F\" (falling edge)",
                            text.get_ref()
                        ),
                    )
                })?
            }
        };
        let trigger = match &raw.trigger {
            None => None,
            Some(text) => Some(self.scl_trigger(text, gateways.first())?),
        };
        let programs = match &raw.programs {
            None => SclPrograms::Upload,
            Some(text) => match text.get_ref().as_str() {
                "upload" => SclPrograms::Upload,
                "stored" => SclPrograms::Stored,
                "stream" => SclPrograms::Stream,
                other => {
                    return Err(self.at(
                        &text.span(),
                        format!(
                            "programs = {other:?} must be \"upload\" (Start writes the compiled \
                             programs, streaming the shows too long to store), \"stream\" \
                             (Start streams every show) or \"stored\" (loaded with Q \
                             Programmer)"
                        ),
                    ));
                }
            },
        };
        let (steps_per_rev, steps_span) =
            located(raw.steps_per_rev.as_ref(), DEFAULT_STEPS_PER_REV);
        if !(200..=51_200).contains(&steps_per_rev) {
            return Err(self.wrong(
                steps_span.as_ref(),
                format!("steps_per_rev = {steps_per_rev} must be from 200 to 51200"),
            ));
        }
        let (tolerance_mm, tolerance_span) =
            located(raw.tolerance_mm.as_ref(), DEFAULT_TOLERANCE_MM);
        if !(tolerance_mm.is_finite() && tolerance_mm > 0.0 && tolerance_mm <= 1000.0) {
            return Err(self.wrong(
                tolerance_span.as_ref(),
                format!("tolerance_mm = {tolerance_mm} must be a number above 0 and at most 1000"),
            ));
        }
        let (poll_ms, poll_span) = located(
            raw.poll_ms.as_ref(),
            u32::try_from(DEFAULT_SCL_POLL.as_millis()).unwrap_or(200),
        );
        if !(20..=10_000).contains(&poll_ms) {
            return Err(self.wrong(
                poll_span.as_ref(),
                format!("poll_ms = {poll_ms} must be from 20 to 10000"),
            ));
        }
        let host_port = raw
            .host_port
            .as_ref()
            .map_or(DEFAULT_SCL_HOST_PORT, |port| *port.get_ref());
        Ok(SclConfig {
            host_port,
            gateways,
            start: trigger.map(|_| (input, condition)),
            trigger,
            programs,
            steps_per_rev,
            tolerance_mm,
            poll: Duration::from_millis(u64::from(poll_ms)),
        })
    }

    /// `trigger = "1:2"`: a drive of the first gateway entry (its address character)
    /// and its output.
    fn scl_trigger(
        &self,
        text: &Spanned<String>,
        first: Option<&SclGateway>,
    ) -> Result<(Address, IoPoint), ConfigError> {
        let shape = || {
            self.at(
                &text.span(),
                format!(
                    "trigger = {:?} must be a drive's address character and one of its \
                     outputs, such as \"1:2\" (drive 1, output 2)",
                    text.get_ref()
                ),
            )
        };
        let mut characters = text.get_ref().chars();
        let (Some(address), Some(':'), Some(output), None) = (
            characters.next(),
            characters.next(),
            characters.next(),
            characters.next(),
        ) else {
            return Err(shape());
        };
        let address = Address::new(address).ok_or_else(shape)?;
        let output = output
            .to_digit(10)
            .and_then(|digit| IoPoint::new(u8::try_from(digit).ok()?))
            .ok_or_else(shape)?;
        let known = match first {
            Some(SclGateway::Serial { addresses, .. }) => addresses.contains(&address),
            // eSCL and simulated drives take the address characters in their order.
            Some(gateway @ (SclGateway::Escl(_) | SclGateway::Sim { .. })) => Address::CHARACTERS
                .chars()
                .take(gateway.drives())
                .any(|character| character == address.character()),
            None => false,
        };
        if !known {
            return Err(self.at(
                &text.span(),
                format!(
                    "trigger = {:?}: there is no drive {:?} on the first gateway entry",
                    text.get_ref(),
                    address.character()
                ),
            ));
        }
        Ok((address, output))
    }
}

/// The addresses a line's drives get when none are listed: the first `drives`
/// characters of [`Address::CHARACTERS`], in order.
pub fn default_addresses(drives: usize) -> Vec<Address> {
    Address::CHARACTERS
        .chars()
        .take(drives)
        .filter_map(Address::new)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_settings_come_from_the_installation_then_the_overrides() {
        let installation = Installation::demo(1, 1, &[9600]).unwrap();
        let config = qprogram_config(&installation, &QProgramOverrides::default());
        assert_eq!(config.counts_per_mm, installation.counts_per_mm);
        assert_eq!(config.max_speed_mm_s, installation.limits.max_speed_mm_s);
        assert_eq!(config.start, QProgramConfig::default().start);
        let config = qprogram_config(
            &installation,
            &QProgramOverrides {
                start: Some(None),
                tolerance_mm: Some(2.5),
                ..QProgramOverrides::default()
            },
        );
        assert_eq!((config.start, config.tolerance_mm), (None, 2.5));
    }
}
