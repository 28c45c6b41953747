//! The simulated units' own memory: a real UFQ750 keeps the station `SN[X]=s/n` gave
//! it in flash, so a simulated one must find it again when the bridge restarts.
//!
//! The stations of every in-process simulated gateway's units, in unit order, live in
//! `sim-units.json` in the data directory, written atomically ([`crate::durable`])
//! after each assignment. At start a simulated gateway takes its units' stations from
//! that file when it lists as many units as the installation gives the gateway (the
//! serials follow from the unit order); otherwise its units are new: on the factory
//! station 5 with `floatball --sim-factory-fresh`, else on the installation's
//! stations.

use std::path::Path;

use floatball_shared::uim2503::sim::FACTORY_STATION;
use serde::{Deserialize, Serialize};

/// The file's name in the data directory.
pub const FILE_NAME: &str = "sim-units.json";

/// How new simulated units leave the factory.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SimUnits {
    /// Every new unit answers on station 5 (`--sim-factory-fresh`), as real ones do.
    pub factory_fresh: bool,
}

/// The file: every simulated gateway's units.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
struct Stored {
    gateways: Vec<StoredGateway>,
}

/// One simulated gateway's units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct StoredGateway {
    /// The gateway (0-based, as configured).
    gateway: usize,
    /// Each unit's station, in unit order.
    stations: Vec<u8>,
}

fn read(data_dir: &Path) -> Stored {
    let path = data_dir.join(FILE_NAME);
    match std::fs::read(&path) {
        Ok(bytes) => serde_json::from_slice(&bytes).unwrap_or_else(|error| {
            tracing::warn!(
                "{} is not readable ({error}); the simulated units start anew",
                path.display()
            );
            Stored::default()
        }),
        Err(_) => Stored::default(),
    }
}

impl SimUnits {
    /// The stations the units of simulated gateway `gateway` have at start: what they
    /// kept, or new units' ([`SimUnits::factory_fresh`] or the installation's
    /// `configured` stations).
    pub fn stations(self, data_dir: &Path, gateway: usize, configured: &[u8]) -> Vec<u8> {
        let kept = read(data_dir)
            .gateways
            .into_iter()
            .find(|stored| stored.gateway == gateway)
            .map(|stored| stored.stations)
            .filter(|stations| {
                stations.len() == configured.len()
                    && stations.iter().all(|station| (1..=127).contains(station))
            });
        match kept {
            Some(stations) => stations,
            None if self.factory_fresh => vec![FACTORY_STATION; configured.len()],
            None => configured.to_vec(),
        }
    }
}

/// Remembers that simulated gateway `gateway`'s units now have `stations`.
///
/// # Errors
/// The file cannot be written.
pub fn remember(data_dir: &Path, gateway: usize, stations: Vec<u8>) -> std::io::Result<()> {
    let mut stored = read(data_dir);
    stored.gateways.retain(|one| one.gateway != gateway);
    stored.gateways.push(StoredGateway { gateway, stations });
    stored.gateways.sort_by_key(|one| one.gateway);
    let bytes = serde_json::to_vec_pretty(&stored).map_err(std::io::Error::other)?;
    crate::durable::write_atomic(data_dir, FILE_NAME, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_keep_their_stations_and_new_ones_follow_the_flag() {
        let dir = tempfile::tempdir().unwrap();
        let configured = [1, 2, 3];
        let fresh = SimUnits {
            factory_fresh: true,
        };
        assert_eq!(fresh.stations(dir.path(), 0, &configured), [5, 5, 5]);
        assert_eq!(
            SimUnits::default().stations(dir.path(), 0, &configured),
            configured
        );
        remember(dir.path(), 1, vec![9, 8, 7]).unwrap();
        remember(dir.path(), 0, vec![3, 1, 2]).unwrap();
        remember(dir.path(), 1, vec![7, 8, 9]).unwrap();
        assert_eq!(fresh.stations(dir.path(), 0, &configured), [3, 1, 2]);
        assert_eq!(fresh.stations(dir.path(), 1, &configured), [7, 8, 9]);
        // Another number of units: these are new units.
        assert_eq!(fresh.stations(dir.path(), 1, &[1, 2]), [5, 5]);
        std::fs::write(dir.path().join(FILE_NAME), b"{").unwrap();
        assert_eq!(fresh.stations(dir.path(), 0, &configured), [5, 5, 5]);
    }
}
