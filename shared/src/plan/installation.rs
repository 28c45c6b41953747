//! The machine a show runs on (`docs/architecture.md` §2): the [`Installation`] — the matrix, its
//! limits and calibration, every gateway's line and kind of drive ([`GatewaySpec`],
//! [`DriveKind`]) — and the one rule that gives every unit its gateway and station
//! ([`allocate`]).
//!
//! The bridge checks `floatball.toml` straight into an [`Installation`]; tests and
//! benches build one with [`Installation::row_major`]. Both allocate units through
//! [`allocate`], so one description of the gateways always gives the same addresses.

use std::collections::HashSet;
use std::fmt;
use std::ops::RangeInclusive;

use thiserror::Error;

use crate::show::{Layout, Limits};

/// The `port` of the built-in simulated gateway.
pub const SIM_PORT: &str = "sim";

/// The most units the manual allows on one UIM2503 gateway (`docs/uim2503.md` §1).
pub const MAX_UNITS_PER_GATEWAY: usize = 100;

/// The station numbers a unit may have on a bus (0 addresses every unit).
pub const STATIONS: RangeInclusive<u8> = 1..=127;

/// Distance between neighbouring balls unless configured, mm: the same as a show's
/// when its installation is not known.
pub use crate::show::DEFAULT_PITCH_MM;

/// The most axes one MBOX box drives (its 10-axis model).
pub const MAX_MBOX_AXES: usize = 10;

/// The most MOONS' drives on one SCL gateway entry: the RS-485 address characters
/// there are (`crate::scl::Address::CHARACTERS`).
pub const MAX_SCL_DRIVES: usize = 27;

/// The family of drives behind a gateway: its instruction language, feedback and
/// limits. A new family is a new variant here, and the planner's callers do not
/// change.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum DriveKind {
    /// A UIM2503 CAN gateway with its UIM342 units (PROTOCOL).
    #[default]
    Uim2503,
    /// An MBOX motion controller on UDP driving 3, 6 or 10 axes (`crate::mbox`); a
    /// unit's station is its axis number, 1 to the box's axes.
    Mbox,
    /// MOONS' stepper or servo drives commanded in SCL (`crate::scl`), one drive per
    /// unit, on an RS-485 line or over eSCL (UDP); a unit's station is its drive's place
    /// on the gateway entry, 1 to [`MAX_SCL_DRIVES`] (its RS-485 address character is
    /// the station-th of the configured addresses).
    Scl,
}

impl DriveKind {
    /// Every kind, in the order they are listed to people.
    pub const ALL: [DriveKind; 3] = [DriveKind::Uim2503, DriveKind::Mbox, DriveKind::Scl];

    /// Its name in `floatball.toml` (`kind = "uim2503"`).
    pub fn name(self) -> &'static str {
        match self {
            DriveKind::Uim2503 => "uim2503",
            DriveKind::Mbox => "mbox",
            DriveKind::Scl => "scl",
        }
    }

    /// The kind named `name` as in `floatball.toml`, if there is one.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|kind| kind.name() == name)
    }

    /// The most units one gateway of this kind serves.
    pub fn max_units(self) -> usize {
        match self {
            DriveKind::Uim2503 => MAX_UNITS_PER_GATEWAY,
            DriveKind::Mbox => MAX_MBOX_AXES,
            DriveKind::Scl => MAX_SCL_DRIVES,
        }
    }
}

impl fmt::Display for DriveKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A gateway's line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GatewaySpec {
    /// [`SIM_PORT`] or a serial device.
    pub port: String,
    /// The line's speed, baud (8N1: baud / 10 bytes per second).
    pub baud: u32,
    /// The drives behind it.
    pub kind: DriveKind,
}

impl GatewaySpec {
    /// A UIM2503 gateway on `port` ([`SIM_PORT`] or a serial device) at `baud`.
    pub fn uim2503(port: impl Into<String>, baud: u32) -> Self {
        Self {
            port: port.into(),
            baud,
            kind: DriveKind::Uim2503,
        }
    }
}

/// Where one unit is reached.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnitAddress {
    /// Index of the gateway in [`Installation::gateways`].
    pub gateway: usize,
    /// The unit's station number on that gateway's bus (1–127).
    pub station: u8,
}

/// The machine a show runs on.
#[derive(Debug, Clone, PartialEq)]
pub struct Installation {
    /// Physical limits and the matrix size (rows × cols).
    pub limits: Limits,
    /// Distance between neighbouring balls, mm.
    pub pitch_mm: f64,
    /// Calibration: encoder counts per millimetre of ball travel.
    pub counts_per_mm: f64,
    /// The gateways, in configuration order.
    pub gateways: Vec<GatewaySpec>,
    /// Every unit's address, row-major (`units[row * cols + col]`).
    pub units: Vec<UnitAddress>,
    /// Speed of the point-to-point moves before a show and when homing, mm/s.
    pub approach_speed_mm_s: f64,
    /// Where balls go when homing (Reset, Start after an e-stop), mm below the top.
    pub home_mm: f64,
    /// The stop deceleration (`SD`) for runs that end moving, mm/s².
    pub stop_decel_mm_s2: f64,
}

impl Installation {
    /// How many MBOX boxes drive it (its gateways, in order), if it is an MBOX
    /// installation; output tracks are for them.
    #[must_use]
    pub fn mbox_boxes(&self) -> Option<usize> {
        let mbox = !self.gateways.is_empty()
            && self
                .gateways
                .iter()
                .all(|gateway| gateway.kind == DriveKind::Mbox);
        mbox.then_some(self.gateways.len())
    }

    /// An installation whose units are shared evenly among `gateways` by [`allocate`]
    /// (row-major, gateway by gateway), each gateway on consecutive stations from
    /// `first_station`; the pitch is [`DEFAULT_PITCH_MM`], the approach 300 mm/s, home
    /// at the top.
    ///
    /// # Errors
    /// [`AllocationError`]: no gateway, more units than the gateways serve, or stations
    /// past 127.
    pub fn row_major(
        limits: Limits,
        counts_per_mm: f64,
        gateways: Vec<GatewaySpec>,
        first_station: u8,
    ) -> Result<Self, AllocationError> {
        let wanted: Vec<(DriveKind, Stations)> = gateways
            .iter()
            .map(|gateway| {
                let stations = Stations::Consecutive {
                    first: first_station,
                    units: None,
                };
                (gateway.kind, stations)
            })
            .collect();
        let units = allocate(limits.rows as usize * limits.cols as usize, &wanted)?;
        Ok(Self {
            limits,
            pitch_mm: DEFAULT_PITCH_MM,
            counts_per_mm,
            gateways,
            units,
            approach_speed_mm_s: 300.0,
            home_mm: 0.0,
            stop_decel_mm_s2: limits.max_accel_mm_s2,
        })
    }

    /// The installation the demo shows ([`crate::show::demo`]) are tried on in tests and
    /// benches: a `rows` × `cols` matrix on simulated UIM2503 gateways, one per entry of
    /// `bauds`, units shared evenly from station 1, 100 counts/mm, the default limits but
    /// an acceleration of 40 000 mm/s² (so a wave's start from rest is within them).
    ///
    /// # Errors
    /// [`AllocationError`] as for [`Installation::row_major`].
    pub fn demo(rows: u32, cols: u32, bauds: &[u32]) -> Result<Self, AllocationError> {
        let mut limits = Limits::for_layout(rows, cols);
        limits.max_accel_mm_s2 = 40_000.0;
        let gateways = bauds
            .iter()
            .map(|&baud| GatewaySpec::uim2503(SIM_PORT, baud))
            .collect();
        Self::row_major(limits, 100.0, gateways, 1)
    }

    /// The matrix's grid, for CSV import.
    pub fn layout(&self) -> Layout {
        Layout {
            rows: self.limits.rows,
            cols: self.limits.cols,
            pitch_mm: self.pitch_mm,
        }
    }

    /// `mm` in counts, rounded; `None` when it does not fit an `i32`.
    pub fn counts(&self, mm: f64) -> Option<i32> {
        let counts = (mm * self.counts_per_mm).round();
        (counts.is_finite() && counts >= f64::from(i32::MIN) && counts <= f64::from(i32::MAX))
            .then_some(counts as i32)
    }

    /// The units (indices into [`Installation::units`]) on `gateway`, in order.
    pub fn units_on(&self, gateway: usize) -> impl Iterator<Item = usize> + '_ {
        self.units
            .iter()
            .enumerate()
            .filter(move |(_, address)| address.gateway == gateway)
            .map(|(unit, _)| unit)
    }

    /// The stations of the units on `gateway`, in unit order.
    pub fn stations_on(&self, gateway: usize) -> Vec<u8> {
        self.units
            .iter()
            .filter(|address| address.gateway == gateway)
            .map(|address| address.station)
            .collect()
    }
}

/// Which units a gateway serves, as configured.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Stations {
    /// Consecutive stations from `first`: `units` of them, or when `None` an even share
    /// of the units the gateways with a count or a list leave over.
    Consecutive {
        /// The station of the gateway's first unit.
        first: u8,
        /// How many units, or `None` for a share.
        units: Option<usize>,
    },
    /// The station of each unit, in unit order.
    Listed(Vec<u8>),
}

/// Why units cannot be given to the gateways.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum AllocationError {
    /// There is no gateway at all.
    #[error("no gateway is configured")]
    NoGateway,
    /// A gateway would serve more units than its kind allows.
    #[error("gateway {} would serve {units} units; a gateway serves at most {max}", gateway + 1)]
    TooManyUnits {
        /// The gateway (0-based).
        gateway: usize,
        /// The units it would serve.
        units: usize,
        /// The most it may serve.
        max: usize,
    },
    /// Consecutive stations would leave 1–127.
    #[error("gateway {}: stations {first} to {last} must lie within 1 to 127", gateway + 1)]
    StationsOutOfRange {
        /// The gateway (0-based).
        gateway: usize,
        /// Its first station.
        first: usize,
        /// Its last station.
        last: usize,
    },
    /// A listed station is not in 1–127.
    #[error("gateway {}: station {station} must be from 1 to 127", gateway + 1)]
    StationOutOfRange {
        /// The gateway (0-based).
        gateway: usize,
        /// Where it stands in the list (0-based).
        index: usize,
        /// The station.
        station: u8,
    },
    /// A station is listed twice.
    #[error(
        "gateway {}: station {station} is listed twice; two units with one station number break the bus",
        gateway + 1
    )]
    DuplicateStation {
        /// The gateway (0-based).
        gateway: usize,
        /// Where its second mention stands in the list (0-based).
        index: usize,
        /// The station.
        station: u8,
    },
    /// The gateways together serve more or fewer units than the matrix has.
    #[error("the matrix has {units} units but the gateways serve {served}")]
    UnitCount {
        /// rows × cols.
        units: usize,
        /// What the gateways serve together.
        served: usize,
    },
}

/// The one rule that gives each of a matrix's `unit_count` units (row-major) its
/// gateway and station: the gateways take the units in order, the first gateway the
/// first units, and so on. A gateway with a [list](Stations::Listed) serves as many
/// units as it lists; one with a count serves that many; the others share what is left
/// evenly, the first of them one more while it does not divide. Each gateway serves at
/// most its kind's [`DriveKind::max_units`], on stations within 1–127, none twice.
///
/// # Errors
/// The first problem, gateway by gateway ([`AllocationError`]).
pub fn allocate(
    unit_count: usize,
    gateways: &[(DriveKind, Stations)],
) -> Result<Vec<UnitAddress>, AllocationError> {
    if gateways.is_empty() {
        return Err(AllocationError::NoGateway);
    }
    let counted = |stations: &Stations| match stations {
        Stations::Listed(list) => Some(list.len()),
        Stations::Consecutive { units, .. } => *units,
    };
    let claimed: usize = gateways
        .iter()
        .filter_map(|(_, stations)| counted(stations))
        .sum();
    let sharing = gateways
        .iter()
        .filter(|(_, stations)| counted(stations).is_none())
        .count()
        .max(1);
    let rest = unit_count.saturating_sub(claimed);
    let mut shared_index = 0;
    let mut units = Vec::with_capacity(unit_count);
    for (gateway, (kind, stations)) in gateways.iter().enumerate() {
        let count = counted(stations).unwrap_or_else(|| {
            let share = rest / sharing + usize::from(shared_index < rest % sharing);
            shared_index += 1;
            share
        });
        if count > kind.max_units() {
            return Err(AllocationError::TooManyUnits {
                gateway,
                units: count,
                max: kind.max_units(),
            });
        }
        let address = |station| UnitAddress { gateway, station };
        match stations {
            Stations::Listed(list) => {
                let mut seen = HashSet::new();
                for (index, &station) in list.iter().enumerate() {
                    if !STATIONS.contains(&station) {
                        return Err(AllocationError::StationOutOfRange {
                            gateway,
                            index,
                            station,
                        });
                    }
                    if !seen.insert(station) {
                        return Err(AllocationError::DuplicateStation {
                            gateway,
                            index,
                            station,
                        });
                    }
                }
                units.extend(list.iter().copied().map(address));
            }
            &Stations::Consecutive { first, .. } => {
                let last = usize::from(first) + count.saturating_sub(1);
                if first < *STATIONS.start() || last > usize::from(*STATIONS.end()) {
                    return Err(AllocationError::StationsOutOfRange {
                        gateway,
                        first: usize::from(first),
                        last,
                    });
                }
                units.extend((first..).take(count).map(address));
            }
        }
    }
    if units.len() != unit_count {
        return Err(AllocationError::UnitCount {
            units: unit_count,
            served: units.len(),
        });
    }
    Ok(units)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    fn spec(port: &str) -> GatewaySpec {
        GatewaySpec::uim2503(port, 115_200)
    }

    fn shared(first: u8) -> (DriveKind, Stations) {
        (
            DriveKind::Uim2503,
            Stations::Consecutive { first, units: None },
        )
    }

    fn stations_of(units: &[UnitAddress], gateway: usize) -> Vec<u8> {
        units
            .iter()
            .filter(|address| address.gateway == gateway)
            .map(|address| address.station)
            .collect()
    }

    #[test]
    fn big_matrices_spread_over_gateways() {
        let limits = Limits::for_layout(15, 10);
        let error = Installation::row_major(limits, 100.0, vec![spec("a")], 1).unwrap_err();
        assert_eq!(
            error,
            AllocationError::TooManyUnits {
                gateway: 0,
                units: 150,
                max: 100
            }
        );
        assert_eq!(
            error.to_string(),
            "gateway 1 would serve 150 units; a gateway serves at most 100"
        );
        let two = Installation::row_major(limits, 100.0, vec![spec("a"), spec("b")], 1).unwrap();
        assert_eq!(
            two.units[74],
            UnitAddress {
                gateway: 0,
                station: 75
            }
        );
        assert_eq!(
            two.units[75],
            UnitAddress {
                gateway: 1,
                station: 1
            }
        );
        assert_eq!(two.units_on(1).count(), 75);
        assert_eq!(two.stations_on(1), (1..=75).collect::<Vec<u8>>());
        assert_eq!(two.layout().pitch_mm, DEFAULT_PITCH_MM);
        let none = Installation::row_major(limits, 100.0, Vec::new(), 1).unwrap_err();
        assert_eq!(none, AllocationError::NoGateway);
    }

    #[test]
    fn shares_are_even_and_the_first_gateways_take_the_remainder() {
        let units = allocate(10, &[shared(1), shared(1), shared(20)]).unwrap();
        assert_eq!(stations_of(&units, 0), [1, 2, 3, 4]);
        assert_eq!(stations_of(&units, 1), [1, 2, 3]);
        assert_eq!(stations_of(&units, 2), [20, 21, 22]);
        // Row-major, gateway by gateway.
        let gateways: Vec<usize> = units.iter().map(|address| address.gateway).collect();
        assert_eq!(gateways, [0, 0, 0, 0, 1, 1, 1, 2, 2, 2]);
    }

    #[test]
    fn counts_and_lists_come_first_and_the_rest_is_shared() {
        let gateways = [
            (
                DriveKind::Uim2503,
                Stations::Consecutive {
                    first: 5,
                    units: Some(3),
                },
            ),
            shared(1),
            (DriveKind::Uim2503, Stations::Listed(vec![9, 7])),
            shared(50),
        ];
        let units = allocate(10, &gateways).unwrap();
        assert_eq!(stations_of(&units, 0), [5, 6, 7]);
        assert_eq!(stations_of(&units, 1), [1, 2, 3]);
        assert_eq!(stations_of(&units, 2), [9, 7]);
        assert_eq!(stations_of(&units, 3), [50, 51]);
    }

    #[test]
    fn every_problem_is_named_with_its_gateway() {
        assert_eq!(
            allocate(3, &[shared(126)]),
            Err(AllocationError::StationsOutOfRange {
                gateway: 0,
                first: 126,
                last: 128
            })
        );
        assert_eq!(
            allocate(1, &[shared(0)]),
            Err(AllocationError::StationsOutOfRange {
                gateway: 0,
                first: 0,
                last: 0
            })
        );
        let listed = |list: Vec<u8>| [(DriveKind::Uim2503, Stations::Listed(list))];
        assert_eq!(
            allocate(3, &listed(vec![5, 6, 5])),
            Err(AllocationError::DuplicateStation {
                gateway: 0,
                index: 2,
                station: 5
            })
        );
        assert_eq!(
            allocate(2, &listed(vec![1, 128])),
            Err(AllocationError::StationOutOfRange {
                gateway: 0,
                index: 1,
                station: 128
            })
        );
        assert_eq!(
            allocate(3, &listed(vec![1, 2])),
            Err(AllocationError::UnitCount {
                units: 3,
                served: 2
            })
        );
        let too_many = [
            shared(1),
            (
                DriveKind::Uim2503,
                Stations::Consecutive {
                    first: 1,
                    units: Some(101),
                },
            ),
        ];
        assert_eq!(
            allocate(101, &too_many),
            Err(AllocationError::TooManyUnits {
                gateway: 1,
                units: 101,
                max: MAX_UNITS_PER_GATEWAY
            })
        );
    }

    #[test]
    fn drive_kinds_have_names() {
        for kind in DriveKind::ALL {
            assert_eq!(DriveKind::from_name(kind.name()), Some(kind));
            assert_eq!(kind.to_string(), kind.name());
        }
        assert_eq!(DriveKind::from_name("uim2503"), Some(DriveKind::Uim2503));
        assert_eq!(DriveKind::from_name("mbox"), Some(DriveKind::Mbox));
        assert_eq!(DriveKind::Mbox.max_units(), MAX_MBOX_AXES);
        assert_eq!(DriveKind::from_name("scl"), Some(DriveKind::Scl));
        assert_eq!(
            DriveKind::Scl.max_units(),
            crate::scl::Address::CHARACTERS.len()
        );
        assert_eq!(DriveKind::from_name("uim342"), None);
        assert_eq!(DriveKind::default(), DriveKind::Uim2503);
    }
}
