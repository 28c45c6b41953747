//! The one place the installation is checked: the raw file (`super::raw`) becomes a
//! [`Config`] — the shared [`Installation`] and the bridge's own settings — with the
//! defaults filled in, and every problem named by the file, line and column of the
//! value at fault (or by the file alone when the value is a default).

use std::cell::RefCell;
use std::ops::Range;
use std::path::Path;

use floatball_shared::mbox::player::BoxCalibration;
use floatball_shared::mbox::{AxisCount, TimeMode};
use floatball_shared::plan::installation::{
    AllocationError, DEFAULT_PITCH_MM, DriveKind, GatewaySpec, Installation, MAX_UNITS_PER_GATEWAY,
    SIM_PORT, Stations, UnitAddress, allocate,
};
use floatball_shared::plan::port::PortAddress;
use floatball_shared::show::Limits;
use floatball_shared::uim2503::ascii::{Form, Instruction, parse_script};
use std::time::Duration;
use toml::Spanned;

use super::raw::{RawConfig, RawGateway, RawMatrix, RawMbox, RawSafety};
use super::scl::{SclEntry, SclGateway, default_addresses};
use super::{
    BAUD_RANGE, Config, ConfigError, DEFAULT_MAX_DURATION, DEFAULT_MBOX_HOST_PORT,
    DEFAULT_MBOX_PERIOD, DEFAULT_SERIAL_BAUD, DEFAULT_SIM_BAUD, Family, MAX_DURATION_RANGE,
    MboxBox, MboxConfig, MboxTarget, Overrides, Uploads,
};
use crate::origin::normalise_origin;

/// Turns the raw file into a [`Config`], naming the place of every problem.
pub(super) struct Checker<'a> {
    /// The file, as errors name it.
    pub(super) path: &'a Path,
    /// Its text, to turn byte spans into lines and columns.
    pub(super) text: &'a str,
    /// Every problem found so far: the check goes on past a problem (with the default
    /// in place of the wrong value) so that all of them are listed at once.
    pub(super) problems: RefCell<Vec<ConfigError>>,
}

/// The gateways' lines, every unit's address, the MBOX boxes and the MOONS' drives'
/// gateway entries (each empty for the other kinds).
type CheckedGateways = (
    Vec<GatewaySpec>,
    Vec<UnitAddress>,
    Vec<MboxBox>,
    Vec<SclGateway>,
);

/// A value and where it came from (`None`: the default).
type Located<T> = (T, Option<Range<usize>>);

pub(super) fn located<T: Clone>(value: Option<&Spanned<T>>, default: T) -> Located<T> {
    match value {
        Some(spanned) => (spanned.get_ref().clone(), Some(spanned.span())),
        None => (default, None),
    }
}

impl Checker<'_> {
    /// A checker of `text`, the file at `path`, with no problem found yet.
    pub(super) fn new<'a>(path: &'a Path, text: &'a str) -> Checker<'a> {
        Checker {
            path,
            text,
            problems: RefCell::new(Vec::new()),
        }
    }

    /// The value of `result`, or `None` with its problem noted.
    pub(super) fn keep<T>(&self, result: Result<T, ConfigError>) -> Option<T> {
        match result {
            Ok(value) => Some(value),
            Err(problem) => {
                self.problems.borrow_mut().push(problem);
                None
            }
        }
    }

    /// Notes a problem and goes on.
    pub(super) fn note(&self, problem: ConfigError) {
        self.problems.borrow_mut().push(problem);
    }

    /// An error at `span` of the file.
    pub(super) fn at(&self, span: &Range<usize>, reason: String) -> ConfigError {
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

    /// An error about the file as a whole.
    pub(super) fn file(&self, reason: String) -> ConfigError {
        ConfigError::File {
            path: self.path.to_owned(),
            reason,
        }
    }

    /// An error at `span`, or for the whole file when the value is a default (a default
    /// can only be wrong together with another value, which the reason names).
    pub(super) fn wrong(&self, span: Option<&Range<usize>>, reason: String) -> ConfigError {
        match span {
            Some(span) => self.at(span, reason),
            None => self.file(reason),
        }
    }

    /// A gateway's line speed: `value`, or `default` when it is left out, within
    /// [`BAUD_RANGE`].
    pub(super) fn baud(
        &self,
        value: Option<&Spanned<u32>>,
        default: u32,
    ) -> Result<u32, ConfigError> {
        let (baud, span) = located(value, default);
        if BAUD_RANGE.contains(&baud) {
            return Ok(baud);
        }
        Err(self.wrong(
            span.as_ref(),
            format!(
                "baud {baud} is out of range ({} to {})",
                BAUD_RANGE.start(),
                BAUD_RANGE.end()
            ),
        ))
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

    /// Checks the whole file and applies the command-line `overrides`; every problem
    /// is listed, in the order of the file's sections.
    pub(super) fn check(
        &self,
        raw: RawConfig,
        overrides: &Overrides,
    ) -> Result<Config, Vec<ConfigError>> {
        let config = self.check_all(raw, overrides);
        let problems = self.problems.take();
        match config {
            Some(config) if problems.is_empty() => Ok(config),
            _ => Err(problems),
        }
    }

    /// [`Checker::check`]'s work: `None` when a part could not be checked (its problem
    /// is noted).
    fn check_all(&self, raw: RawConfig, overrides: &Overrides) -> Option<Config> {
        let listen = match overrides.listen {
            Some(listen) => Some(listen),
            None => {
                let (text, span) = located(raw.listen.as_ref(), "0.0.0.0:8080".to_owned());
                self.keep(text.parse().map_err(|_| {
                    self.wrong(
                        span.as_ref(),
                        format!(
                            "listen = {text:?} is not an address and port such as \"0.0.0.0:8080\""
                        ),
                    )
                }))
            }
        };
        let allowed_origins: Vec<String> = raw
            .allowed_origins
            .iter()
            .filter_map(|origin| {
                self.keep(normalise_origin(origin.get_ref()).ok_or_else(|| {
                    self.at(
                        &origin.span(),
                        format!(
                            "{:?} is not an origin such as \"http://192.168.1.20:8080\" \
                             (scheme://host[:port], no path)",
                            origin.get_ref()
                        ),
                    )
                }))
            })
            .collect();
        let matrix = self.matrix(&raw.matrix);
        let gateways = self.gateways(&raw.gateways, &matrix, overrides);
        let (estop, approach_speed_mm_s) =
            self.keep(self.safety(&raw.safety, &matrix.limits)).unzip();
        let (max_bytes, span) = located(raw.uploads.max_bytes.as_ref(), 32 * 1024 * 1024);
        if !(1024..=1024 * 1024 * 1024).contains(&max_bytes) {
            self.note(self.wrong(
                span.as_ref(),
                format!("max_bytes = {max_bytes} must be from 1024 (1 KiB) to 1073741824 (1 GiB)"),
            ));
        }
        let max_duration = match &raw.uploads.max_duration {
            None => Some(DEFAULT_MAX_DURATION),
            Some(text) => self.keep(
                humantime::parse_duration(text.get_ref().trim())
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
                    }),
            ),
        };
        let osc = self.keep(self.osc(&raw.osc));
        let balls = matrix.limits.rows as usize * matrix.limits.cols as usize;
        let live = self.keep(self.live(&raw.live, balls));
        let timecode = self.keep(self.timecode(&raw.timecode));
        let (gateways, units, boxes, drives) = gateways?;
        // Every gateway is of the first one's kind (`gateway` refuses another).
        let family = if !boxes.is_empty() {
            Family::Mbox(self.keep(self.mbox(&raw.mbox, boxes))?)
        } else if !drives.is_empty() {
            Family::Scl(self.keep(self.scl(&raw.scl, drives))?)
        } else {
            Family::Uim2503
        };
        let installation = Installation {
            limits: matrix.limits,
            pitch_mm: matrix.pitch_mm,
            counts_per_mm: matrix.counts_per_mm,
            gateways,
            units,
            approach_speed_mm_s: approach_speed_mm_s?,
            home_mm: matrix.home_mm,
            stop_decel_mm_s2: matrix.limits.max_accel_mm_s2,
        };
        Some(Config {
            listen: listen?,
            allowed_origins,
            installation,
            estop: estop?,
            uploads: Uploads {
                max_bytes,
                max_duration: max_duration?,
            },
            family,
            osc: osc?,
            live: live?,
            timecode: timecode?,
        })
    }

    /// `[mbox]`, for an installation of MBOX `boxes`.
    fn mbox(&self, raw: &RawMbox, boxes: Vec<MboxBox>) -> Result<MboxConfig, ConfigError> {
        let host_port = raw
            .host_port
            .as_ref()
            .map_or(DEFAULT_MBOX_HOST_PORT, |port| *port.get_ref());
        let (period_ms, span) = located(
            raw.frame_period_ms.as_ref(),
            u32::try_from(DEFAULT_MBOX_PERIOD.as_millis()).unwrap_or(20),
        );
        if !(5..=1000).contains(&period_ms) {
            return Err(self.wrong(
                span.as_ref(),
                format!("frame_period_ms = {period_ms} must be from 5 to 1000"),
            ));
        }
        let time = match raw.time.as_ref() {
            None => TimeMode::Relative,
            Some(text) => match text.get_ref().as_str() {
                "relative" => TimeMode::Relative,
                "absolute" => TimeMode::Absolute,
                other => {
                    return Err(self.at(
                        &text.span(),
                        format!("time = {other:?} must be \"relative\" or \"absolute\""),
                    ));
                }
            },
        };
        Ok(MboxConfig {
            host_port,
            frame_period: Duration::from_millis(u64::from(period_ms)),
            time,
            boxes,
        })
    }

    /// An MBOX gateway's box: where it is, its axes and calibration.
    fn mbox_box(
        &self,
        number: usize,
        gateway: &RawGateway,
        table: &Range<usize>,
        override_port: Option<&String>,
        counts_per_mm: f64,
    ) -> Result<MboxBox, ConfigError> {
        if let Some(baud) = &gateway.baud {
            return Err(self.at(
                &baud.span(),
                format!("gateway {number}: baud is for serial gateways; an MBOX box is on UDP"),
            ));
        }
        let (text, span) = match (override_port, &gateway.address, &gateway.port) {
            (Some(port), _, _) => (port.clone(), None),
            (None, Some(address), None) => (address.get_ref().clone(), Some(address.span())),
            (None, None, Some(port)) => (port.get_ref().clone(), Some(port.span())),
            (None, Some(_), Some(port)) => {
                return Err(self.at(
                    &port.span(),
                    format!(
                        "gateway {number}: give an MBOX box either address = \"IP:port\" or \
                         port = \"sim\", not both"
                    ),
                ));
            }
            (None, None, None) => {
                return Err(self.at(
                    table,
                    format!(
                        "gateway {number}: an MBOX box needs address = \"192.168.15.201:7408\" \
                         (its IP address and UDP port) or port = \"sim\" (a simulated box)"
                    ),
                ));
            }
        };
        let target = if text == SIM_PORT {
            MboxTarget::Sim
        } else {
            MboxTarget::Address(text.parse().map_err(|_| {
                self.wrong(
                    span.as_ref(),
                    format!(
                        "gateway {number}: {text:?} is not an MBOX box's address and UDP port \
                         such as \"192.168.15.201:7408\", nor \"sim\""
                    ),
                )
            })?)
        };
        let (axes_count, axes_span) = located(gateway.axes.as_ref(), 10);
        let axes = AxisCount::ALL
            .into_iter()
            .find(|axes| axes.count() as u32 == axes_count)
            .ok_or_else(|| {
                self.wrong(
                    axes_span.as_ref(),
                    format!("gateway {number}: axes = {axes_count} must be 3, 6 or 10"),
                )
            })?;
        let pulses_per_mm = self.positive(
            located(gateway.pulses_per_mm.as_ref(), counts_per_mm),
            "pulses_per_mm",
            100_000.0,
        )?;
        let (sign, sign_span) = located(gateway.sign.as_ref(), 1);
        if sign != 1 && sign != -1 {
            return Err(self.wrong(
                sign_span.as_ref(),
                format!("gateway {number}: sign = {sign} must be 1 or -1"),
            ));
        }
        let (offset, offset_span) = located(gateway.offset_pulses.as_ref(), 0);
        let offset_pulses = i32::try_from(offset).map_err(|_| {
            self.wrong(
                offset_span.as_ref(),
                format!("gateway {number}: offset_pulses = {offset} does not fit a position"),
            )
        })?;
        Ok(MboxBox {
            target,
            axes,
            calibration: BoxCalibration {
                axes: axes.count(),
                pulses_per_mm,
                sign: if sign < 0 { -1 } else { 1 },
                offset_pulses,
            },
        })
    }

    /// `[matrix]`; a wrong value is noted and its default used in its place.
    fn matrix(&self, raw: &RawMatrix) -> Matrix {
        let size = |value: Option<&Spanned<u32>>, key: &str| {
            let (count, span) = located(value, 10);
            if (1..=1000).contains(&count) {
                count
            } else {
                self.note(self.wrong(
                    span.as_ref(),
                    format!("{key} = {count} must be from 1 to 1000"),
                ));
                10
            }
        };
        let problems = self.problems.borrow().len();
        let rows = size(raw.rows.as_ref(), "rows");
        let cols = size(raw.cols.as_ref(), "cols");
        let sized = self.problems.borrow().len() == problems;
        let positive = |value: Option<&Spanned<f64>>, default: f64, key: &str, max: f64| {
            self.keep(self.positive(located(value, default), key, max))
                .unwrap_or(default)
        };
        let pitch_mm = positive(
            raw.pitch_mm.as_ref(),
            DEFAULT_PITCH_MM,
            "pitch_mm",
            100_000.0,
        );
        let travel_mm = positive(raw.travel_mm.as_ref(), 7500.0, "travel_mm", 100_000.0);
        let counts_per_mm = positive(
            raw.counts_per_mm.as_ref(),
            100.0,
            "counts_per_mm",
            100_000.0,
        );
        let max_speed_mm_s = positive(
            raw.max_speed_mm_s.as_ref(),
            2000.0,
            "max_speed_mm_s",
            100_000.0,
        );
        let max_accel_mm_s2 = positive(
            raw.max_accel_mm_s2.as_ref(),
            4000.0,
            "max_accel_mm_s2",
            1_000_000.0,
        );
        let (mut home_mm, span) = located(raw.home_mm.as_ref(), 0.0);
        if !(home_mm.is_finite() && (0.0..=travel_mm).contains(&home_mm)) {
            self.note(self.wrong(
                span.as_ref(),
                format!("home_mm = {home_mm} must be from 0 to travel_mm ({travel_mm})"),
            ));
            home_mm = 0.0;
        }
        // Positions in counts travel as i32 on the wire (QP, PA).
        if travel_mm * counts_per_mm > f64::from(i32::MAX) {
            let span = raw.counts_per_mm.as_ref().map(Spanned::span);
            self.note(self.wrong(
                span.as_ref(),
                format!(
                    "travel_mm × counts_per_mm = {} counts does not fit in a position (at most {})",
                    travel_mm * counts_per_mm,
                    i32::MAX
                ),
            ));
        }
        Matrix {
            limits: Limits {
                travel_mm,
                max_speed_mm_s,
                max_accel_mm_s2,
                rows,
                cols,
            },
            pitch_mm,
            counts_per_mm,
            home_mm,
            sized,
        }
    }

    /// The `[[gateway]]` tables: each gateway's line and kind, and every unit's address
    /// by the shared rule.
    fn gateways(
        &self,
        raw: &[Spanned<RawGateway>],
        matrix: &Matrix,
        overrides: &Overrides,
    ) -> Option<CheckedGateways> {
        let limits = &matrix.limits;
        let default_gateway = [Spanned::new(
            0..0,
            RawGateway {
                kind: None,
                port: Some(Spanned::new(0..0, SIM_PORT.to_owned())),
                address: None,
                axes: None,
                pulses_per_mm: None,
                sign: None,
                offset_pulses: None,
                baud: None,
                first_station: None,
                units: None,
                stations: None,
                addresses: None,
                escl: None,
            },
        )];
        // Without a [[gateway]] table there is no place in the file to point at.
        let implicit = raw.is_empty();
        let raw = if implicit { &default_gateway[..] } else { raw };
        if overrides.gateway_ports.len() > raw.len() {
            self.note(self.file(format!(
                "{} --gateway flags given but the file configures {} [[gateway]] table(s); \
                 add [[gateway]] tables for the others",
                overrides.gateway_ports.len(),
                raw.len()
            )));
            return None;
        }
        let mut specs: Vec<GatewaySpec> = Vec::with_capacity(raw.len());
        let mut wanted = Vec::with_capacity(raw.len());
        let mut boxes = Vec::new();
        let mut lines: Vec<SclEntry> = Vec::new();
        let mut complete = true;
        for (index, spanned) in raw.iter().enumerate() {
            let first_kind = specs.first().map(|spec| spec.kind);
            let Some(one) = self.keep(self.gateway(
                index,
                spanned,
                overrides.gateway_ports.get(index),
                first_kind,
                matrix.counts_per_mm,
            )) else {
                complete = false;
                continue;
            };
            wanted.push((one.spec.kind, one.stations));
            specs.push(one.spec);
            boxes.extend(one.mbox);
            lines.extend(one.scl);
        }
        if !complete || !matrix.sized {
            // The units cannot be given to gateways that are not all known, nor
            // counted in a matrix of unknown size.
            return None;
        }
        let units = self.keep(
            allocate(limits.rows as usize * limits.cols as usize, &wanted)
                .map_err(|error| self.allocation(error, raw, implicit, limits)),
        )?;
        // An MBOX unit's station is its axis: within the box's axes.
        let mut axes_fit = true;
        for (gateway, found) in boxes.iter().enumerate() {
            let axes = found.axes.count();
            if let Some(axis) = units
                .iter()
                .filter(|unit| unit.gateway == gateway)
                .map(|unit| unit.station)
                .find(|&station| usize::from(station) > axes)
            {
                let table = &raw[gateway];
                let span = table
                    .get_ref()
                    .stations
                    .as_ref()
                    .map(Spanned::span)
                    .or_else(|| table.get_ref().units.as_ref().map(Spanned::span))
                    .unwrap_or_else(|| table.span());
                axes_fit = false;
                self.note(self.at(
                    &span,
                    format!(
                        "gateway {}: axis {axis} is beyond the box's {axes} axes; give it at \
                         most {axes} units (or add a box)",
                        gateway + 1
                    ),
                ));
            }
        }
        if !axes_fit {
            return None;
        }
        // A line whose addresses were not listed: the first characters, one a unit;
        // simulated drives: one a unit.
        let drives = lines
            .into_iter()
            .enumerate()
            .map(|(gateway, entry)| match entry.gateway {
                SclGateway::Serial {
                    port,
                    baud,
                    addresses,
                } if !entry.listed => SclGateway::Serial {
                    port,
                    baud,
                    addresses: if addresses.is_empty() {
                        default_addresses(
                            units.iter().filter(|unit| unit.gateway == gateway).count(),
                        )
                    } else {
                        addresses
                    },
                },
                SclGateway::Sim { .. } => SclGateway::Sim {
                    drives: units.iter().filter(|unit| unit.gateway == gateway).count(),
                },
                other => other,
            })
            .collect();
        Some((specs, units, boxes, drives))
    }

    /// One `[[gateway]]` table (the `index`-th): its line, kind and stations, and its
    /// MBOX box or SCL entry. `first_kind` is the first gateway's kind, which every
    /// other must share.
    fn gateway(
        &self,
        index: usize,
        spanned: &Spanned<RawGateway>,
        override_port: Option<&String>,
        first_kind: Option<DriveKind>,
        counts_per_mm: f64,
    ) -> Result<OneGateway, ConfigError> {
        let gateway = spanned.get_ref();
        let kind = match &gateway.kind {
            None => DriveKind::default(),
            Some(name) => DriveKind::from_name(name.get_ref()).ok_or_else(|| {
                let known: Vec<String> = DriveKind::ALL
                    .iter()
                    .map(|kind| format!("{:?}", kind.name()))
                    .collect();
                self.at(
                    &name.span(),
                    format!(
                        "gateway {}: kind {:?} is not a known kind of drive; the known \
                         kinds are {}",
                        index + 1,
                        name.get_ref(),
                        known.join(", ")
                    ),
                )
            })?,
        };
        if let (Some(first), Some(name)) = (first_kind, &gateway.kind)
            && kind != first
        {
            return Err(self.at(
                &name.span(),
                format!(
                    "gateway {}: kind {:?} after {:?} gateways: an installation is all \
                     UIM2503 gateways, all MBOX boxes or all MOONS' (SCL) drives",
                    index + 1,
                    kind.name(),
                    first.name()
                ),
            ));
        }
        let stations = match &gateway.stations {
            Some(list) => Stations::Listed(list.get_ref().iter().map(|s| *s.get_ref()).collect()),
            None => Stations::Consecutive {
                first: located(gateway.first_station.as_ref(), 1).0,
                units: gateway.units.as_ref().map(|units| *units.get_ref()),
            },
        };
        if kind == DriveKind::Scl {
            let found = self.scl_gateway(index + 1, gateway, &spanned.span(), override_port)?;
            let (port, baud) = match &found.gateway {
                SclGateway::Serial { port, baud, .. } => (port.clone(), *baud),
                SclGateway::Escl(_) | SclGateway::Sim { .. } => (found.gateway.port(), 0),
            };
            let units = if found.listed {
                Some(found.gateway.drives())
            } else {
                gateway.units.as_ref().map(|units| *units.get_ref())
            };
            return Ok(OneGateway {
                spec: GatewaySpec { port, baud, kind },
                stations: Stations::Consecutive { first: 1, units },
                mbox: None,
                scl: Some(found),
            });
        }
        if let Some(span) = gateway
            .addresses
            .as_ref()
            .map(Spanned::span)
            .or_else(|| gateway.escl.as_ref().map(Spanned::span))
        {
            return Err(self.at(
                &span,
                format!(
                    "gateway {}: addresses and escl are for MOONS' drives (kind = \"scl\")",
                    index + 1
                ),
            ));
        }
        if kind == DriveKind::Mbox {
            let found = self.mbox_box(
                index + 1,
                gateway,
                &spanned.span(),
                override_port,
                counts_per_mm,
            )?;
            let port = match found.target {
                MboxTarget::Sim => SIM_PORT.to_owned(),
                MboxTarget::Address(address) => address.to_string(),
            };
            return Ok(OneGateway {
                spec: GatewaySpec {
                    port,
                    baud: 0,
                    kind,
                },
                stations,
                mbox: Some(found),
                scl: None,
            });
        }
        let (port, port_span) = match (override_port, &gateway.port) {
            (Some(port), _) => (port.clone(), None),
            (None, Some(port)) => (port.get_ref().clone(), Some(port.span())),
            (None, None) => {
                return Err(self.at(
                    &spanned.span(),
                    format!(
                        "gateway {}: port is missing: \"sim\", a device path such as \
                         \"/dev/ttyUSB0\", or a serial device server: \"tcp://host:port\" \
                         (raw TCP) or \"rfc2217://host:port\" (RFC 2217)",
                        index + 1
                    ),
                ));
            }
        };
        for (key, value) in gateway.mbox_keys() {
            if let Some(span) = value {
                return Err(self.at(
                    &span,
                    format!(
                        "gateway {}: {key} is for MBOX boxes (kind = \"mbox\")",
                        index + 1
                    ),
                ));
            }
        }

        if port.is_empty() || port.chars().any(char::is_control) {
            return Err(self.wrong(
                port_span.as_ref(),
                format!(
                    "gateway {}: port {port:?} must be \"sim\", a device path such as \
                     \"/dev/ttyUSB0\", or a serial device server: \"tcp://host:port\" \
                     (raw TCP) or \"rfc2217://host:port\" (RFC 2217)",
                    index + 1
                ),
            ));
        }
        // The one parser of a port: what passes here is what the link opens.
        if let Err(err) = PortAddress::parse(&port) {
            return Err(self.wrong(
                port_span.as_ref(),
                format!("gateway {}: port {err}", index + 1),
            ));
        }
        let default_baud = if port == SIM_PORT {
            DEFAULT_SIM_BAUD
        } else {
            DEFAULT_SERIAL_BAUD
        };
        let baud = self.baud(gateway.baud.as_ref(), default_baud)?;
        Ok(OneGateway {
            spec: GatewaySpec { port, baud, kind },
            stations,
            mbox: None,
            scl: None,
        })
    }

    /// Where an allocation problem sits in the file, in the file's words.
    fn allocation(
        &self,
        error: AllocationError,
        raw: &[Spanned<RawGateway>],
        implicit: bool,
        limits: &Limits,
    ) -> ConfigError {
        // The gateway's units: its station list, its count, or its table.
        let units_span = |gateway: usize| {
            let spanned = raw.get(gateway)?;
            let table = spanned.get_ref();
            let span = table
                .stations
                .as_ref()
                .map(Spanned::span)
                .or_else(|| table.units.as_ref().map(Spanned::span))
                .unwrap_or_else(|| spanned.span());
            (!implicit).then_some(span)
        };
        let listed_span = |gateway: usize, index: usize| {
            raw.get(gateway)?
                .get_ref()
                .stations
                .as_ref()?
                .get_ref()
                .get(index)
                .map(Spanned::span)
        };
        match error {
            AllocationError::TooManyUnits { gateway, .. } => self.wrong(
                units_span(gateway).as_ref(),
                format!("{error}: add a [[gateway]]"),
            ),
            AllocationError::StationsOutOfRange { gateway, .. } => {
                let first_span = raw
                    .get(gateway)
                    .and_then(|table| table.get_ref().first_station.as_ref())
                    .map(Spanned::span);
                self.wrong(
                    first_span.or_else(|| units_span(gateway)).as_ref(),
                    error.to_string(),
                )
            }
            AllocationError::StationOutOfRange { gateway, index, .. }
            | AllocationError::DuplicateStation { gateway, index, .. } => {
                self.wrong(listed_span(gateway, index).as_ref(), error.to_string())
            }
            AllocationError::UnitCount { units, served } => self.file(format!(
                "the matrix has {} × {} = {units} units but the gateways serve {served}; \
                 adjust the gateways' units or stations (each gateway serves at most \
                 {MAX_UNITS_PER_GATEWAY})",
                limits.rows, limits.cols
            )),
            AllocationError::NoGateway => self.file(error.to_string()),
        }
    }

    /// `[safety]`: the e-stop's instructions and the approach speed, mm/s.
    fn safety(
        &self,
        raw: &RawSafety,
        limits: &Limits,
    ) -> Result<(Vec<Instruction>, f64), ConfigError> {
        let (text, span) = located(
            raw.estop.as_ref(),
            crate::ports::uim2503::DEFAULT_STOP.to_owned(),
        );
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
            limits.max_speed_mm_s,
        )?;
        Ok((estop, approach_speed_mm_s))
    }
}

/// One `[[gateway]]` table checked.
struct OneGateway {
    spec: GatewaySpec,
    stations: Stations,
    mbox: Option<MboxBox>,
    scl: Option<SclEntry>,
}

/// `[matrix]` checked: the limits and what else the installation takes from it.
struct Matrix {
    limits: Limits,
    pitch_mm: f64,
    counts_per_mm: f64,
    home_mm: f64,
    /// Rows and cols are as configured (not defaults in place of wrong values): the
    /// units can be given to the gateways.
    sized: bool,
}
