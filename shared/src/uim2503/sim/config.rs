//! What a simulated gateway is made of: its units and their stations, the calibration
//! and physical limits they move with, and the faults to inject.
//!
//! ```
//! use floatball_shared::uim2503::sim::{Garble, GatewayConfig};
//!
//! // The installation's default: 100 units on stations 1…100.
//! let config = GatewayConfig::default();
//! assert_eq!(config.stations.len(), 100);
//! assert_eq!((config.stations[0], config.stations[99]), (1, 100));
//!
//! // A new matrix: every unit still on the factory station 5; and a line that garbles
//! // the 8th byte the gateway sends.
//! let mut fresh = GatewayConfig::factory_fresh(10);
//! fresh.faults.garbled_output.push(Garble { byte: 7, xor_mask: 0x80 });
//! assert!(fresh.stations.iter().all(|&station| station == 5));
//! ```

use thiserror::Error;

use crate::show::DEFAULT_TRAVEL_MM;
use crate::show::validate::{DEFAULT_MAX_ACCEL_MM_S2, DEFAULT_MAX_SPEED_MM_S};

/// Most units one UIM2503 gateway serves (manual §1: "one gateway serves up to 100"):
/// the installation model's one copy of the limit.
pub const MAX_UNITS: usize = crate::plan::MAX_UNITS_PER_GATEWAY;

/// The station every unit has when it leaves the factory (manual §6.0).
pub const FACTORY_STATION: u8 = 5;

/// Encoder counts per mm of ball travel when the installation gives no calibration.
///
/// The manual does not give the UFQ750's drum or encoder; 100 counts/mm (0.01 mm per
/// count) keeps a 7.5 m travel (750 000 counts) and 2 m/s (200 000 counts/s) well inside
/// the protocol's 32-bit numbers.
pub const DEFAULT_COUNTS_PER_MM: f64 = 100.0;

/// A simulated gateway and its units.
#[derive(Debug, Clone, PartialEq)]
pub struct GatewayConfig {
    /// The station (CAN id, 1–127) of each unit, in bus order; a unit's position in this
    /// list is its index everywhere in the simulator. Several units may share a station,
    /// as on a real bus.
    pub stations: Vec<u8>,
    /// Seed of the units' serial numbers: the same seed gives the same serials.
    pub seed: u64,
    /// Encoder counts per mm of travel (the bridge's calibration).
    pub counts_per_mm: f64,
    /// Travel from the upper limit switch (0) to the lowest position, mm.
    pub travel_mm: f64,
    /// Top speed of a ball, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration of a ball, mm/s²; also the point-to-point acceleration.
    pub max_accel_mm_s2: f64,
    /// Faults to inject, for tests.
    pub faults: Faults,
}

impl Default for GatewayConfig {
    /// The installation's default layout: 10 × 10 = 100 units on stations 1…100, the
    /// default calibration and the limits `show` validates against.
    fn default() -> Self {
        Self::numbered(100)
    }
}

impl GatewayConfig {
    /// `count` units on stations 1…`count`, with the default calibration and limits.
    #[must_use]
    pub fn numbered(count: u8) -> Self {
        Self::with_stations((1..=count).collect())
    }

    /// `count` units fresh from the factory: every one on station 5.
    #[must_use]
    pub fn factory_fresh(count: usize) -> Self {
        Self::with_stations(vec![FACTORY_STATION; count])
    }

    fn with_stations(stations: Vec<u8>) -> Self {
        Self {
            stations,
            seed: 0,
            counts_per_mm: DEFAULT_COUNTS_PER_MM,
            travel_mm: DEFAULT_TRAVEL_MM,
            max_speed_mm_s: DEFAULT_MAX_SPEED_MM_S,
            max_accel_mm_s2: DEFAULT_MAX_ACCEL_MM_S2,
            faults: Faults::default(),
        }
    }

    /// The limits in counts, after checking the configuration.
    pub(super) fn limits(&self) -> Result<Limits, ConfigError> {
        if self.stations.len() > MAX_UNITS {
            return Err(ConfigError::TooManyUnits {
                count: self.stations.len(),
            });
        }
        if let Some((unit, &station)) = self
            .stations
            .iter()
            .enumerate()
            .find(|&(_, station)| !(1..=127).contains(station))
        {
            return Err(ConfigError::Station { unit, station });
        }
        let positive = |name, value: f64| {
            if value > 0.0 && value.is_finite() {
                Ok(value)
            } else {
                Err(ConfigError::NotPositive { name, value })
            }
        };
        let counts_per_mm = positive("counts_per_mm", self.counts_per_mm)?;
        let travel_counts = positive("travel_mm", self.travel_mm)? * counts_per_mm;
        if travel_counts > f64::from(i32::MAX) {
            return Err(ConfigError::TravelTooLong { travel_counts });
        }
        let max_speed_counts_s = positive("max_speed_mm_s", self.max_speed_mm_s)? * counts_per_mm;
        let max_accel_counts_s2 =
            positive("max_accel_mm_s2", self.max_accel_mm_s2)? * counts_per_mm;
        if max_speed_counts_s > f64::from(i32::MAX) || max_accel_counts_s2 > f64::from(u32::MAX) {
            return Err(ConfigError::LimitTooLarge {
                max_speed_counts_s,
                max_accel_counts_s2,
            });
        }
        if let Some(&unit) = self
            .faults
            .disconnected
            .iter()
            .find(|&&unit| unit >= self.stations.len())
        {
            return Err(ConfigError::NoSuchUnit { unit });
        }
        Ok(Limits {
            travel_counts,
            max_speed_counts_s,
            max_accel_counts_s2,
        })
    }
}

/// Faults to inject into a simulated gateway, for tests of the host side.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Faults {
    /// Units (by index) cut off the bus from the start: they neither receive
    /// instructions nor send frames. [`Gateway::set_connected`](super::Gateway::set_connected)
    /// changes this while running.
    pub disconnected: Vec<usize>,
    /// Bytes of the gateway's output to corrupt.
    pub garbled_output: Vec<Garble>,
}

/// Corrupt one byte of the gateway's output stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Garble {
    /// Which byte, counted from 0 over everything the gateway ever sends.
    pub byte: u64,
    /// The bits to flip (`0x80` makes a data byte look like a header or tail byte, which
    /// the decoder notices; low bits change a value unnoticed, as the line has no
    /// checksum).
    pub xor_mask: u8,
}

/// A configuration the simulator cannot run.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum ConfigError {
    /// More units than one gateway serves.
    #[error("{count} units on one gateway; a UIM2503 serves at most {MAX_UNITS}")]
    TooManyUnits {
        /// The number of units configured.
        count: usize,
    },
    /// A station outside 1–127 (0 addresses every unit; feedback carries 7 bits).
    #[error("unit {unit} has station {station}; stations are 1–127 (0 is the broadcast)")]
    Station {
        /// The unit's index.
        unit: usize,
        /// Its station.
        station: u8,
    },
    /// A calibration or limit that is not a positive finite number.
    #[error("{name} must be a positive number, found {value}")]
    NotPositive {
        /// The field.
        name: &'static str,
        /// Its value.
        value: f64,
    },
    /// The travel in counts does not fit the protocol's 32-bit positions.
    #[error("the travel is {travel_counts} counts; positions are 32-bit (at most 2147483647)")]
    TravelTooLong {
        /// The travel, counts.
        travel_counts: f64,
    },
    /// The top speed or acceleration in counts does not fit the protocol's numbers
    /// (`SP` is 32-bit signed, `SD` 32-bit unsigned).
    #[error(
        "the limits are {max_speed_counts_s} counts/s and {max_accel_counts_s2} counts/s²; \
         SP holds at most 2147483647 and SD 4294967295"
    )]
    LimitTooLarge {
        /// Top speed, counts/s.
        max_speed_counts_s: f64,
        /// Top acceleration, counts/s².
        max_accel_counts_s2: f64,
    },
    /// A fault names a unit that does not exist.
    #[error("fault injection names unit {unit}, which does not exist")]
    NoSuchUnit {
        /// The index given.
        unit: usize,
    },
}

/// The physical limits of every unit, in counts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Limits {
    /// Lowest position, counts (the highest is 0, the upper limit switch).
    pub travel_counts: f64,
    /// Top speed, counts/s.
    pub max_speed_counts_s: f64,
    /// Top acceleration, counts/s².
    pub max_accel_counts_s2: f64,
}

/// The serial number of unit `index` for `seed`: distinct for every index, and at most
/// 32 bits so that `SN[127]=s/n;` fits in the gateway's 20 characters (the manual calls
/// the serial "32 bits" while its ACK carries 8 bytes).
pub(super) fn serial(seed: u64, index: usize) -> u64 {
    // Folding the seed and adding the index gives distinct inputs for distinct indices
    // (below 2^32); every step of the mixer is a bijection of u32, so the outputs are
    // distinct too. The `as` casts keep the low 32 bits on purpose.
    let folded = (seed as u32) ^ ((seed >> 32) as u32);
    let mut x = folded.wrapping_add(index as u32);
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^= x >> 16;
    u64::from(x)
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    #[test]
    fn the_default_is_the_installation() {
        let config = GatewayConfig::default();
        assert_eq!(config.stations, (1..=100).collect::<Vec<u8>>());
        let limits = config.limits().unwrap();
        assert_eq!(limits.travel_counts, 750_000.0);
        assert_eq!(limits.max_speed_counts_s, 200_000.0);
        assert_eq!(limits.max_accel_counts_s2, 400_000.0);
    }

    #[test]
    fn serials_are_distinct_fit_sn_and_follow_the_seed() {
        for seed in [0, 1, u64::MAX, 0x1234_5678_9ABC_DEF0] {
            let mut serials: Vec<u64> = (0..MAX_UNITS).map(|i| serial(seed, i)).collect();
            assert!(serials.iter().all(|&s| s <= u64::from(u32::MAX)));
            serials.sort_unstable();
            serials.dedup();
            assert_eq!(serials.len(), MAX_UNITS, "seed {seed}");
        }
        assert_eq!(serial(7, 3), serial(7, 3));
        assert_ne!(serial(7, 3), serial(8, 3));
    }

    #[test]
    fn bad_configurations_are_refused_with_the_reason() {
        let check = |config: GatewayConfig| config.limits().unwrap_err().to_string();
        assert_eq!(
            check(GatewayConfig::factory_fresh(101)),
            "101 units on one gateway; a UIM2503 serves at most 100"
        );
        let mut config = GatewayConfig::numbered(3);
        config.stations[2] = 0;
        assert_eq!(
            check(config.clone()),
            "unit 2 has station 0; stations are 1–127 (0 is the broadcast)"
        );
        config.stations[2] = 128;
        assert!(check(config).contains("station 128"));
        let mut config = GatewayConfig::numbered(3);
        config.counts_per_mm = f64::NAN;
        assert_eq!(
            check(config.clone()),
            "counts_per_mm must be a positive number, found NaN"
        );
        config.counts_per_mm = 1e6;
        assert!(check(config.clone()).starts_with("the travel is 7500000000 counts"));
        config.counts_per_mm = 200.0;
        config.max_speed_mm_s = 1e8;
        assert!(check(config.clone()).contains("SP holds at most"));
        config.max_speed_mm_s = 2000.0;
        config.max_accel_mm_s2 = -1.0;
        assert!(check(config).starts_with("max_accel_mm_s2 must be a positive number"));
        let mut config = GatewayConfig::numbered(3);
        config.faults.disconnected.push(3);
        assert_eq!(
            check(config),
            "fault injection names unit 3, which does not exist"
        );
        assert!(GatewayConfig::numbered(0).limits().is_ok());
    }
}
