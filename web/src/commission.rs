//! The Commissioning page's decisions, testable without a browser: which units a roll
//! call flags, "assign all in grid order", a station as typed, the mapping of a
//! gateway's cells to stations that the installer builds by tapping the grid, the
//! installation to save, and the line speeds the guided change offers.
//!
//! A gateway serves the cells `first_cell .. first_cell + stations.len()` of the
//! matrix in row-major order (as seen from below); `stations[i]` is the station of its
//! i-th cell ([`InstallationInfo::first_cell`]). Commissioning therefore only ever
//! rewrites a gateway's `stations` list: [`Mapping`] keeps it a list of distinct
//! stations while cells are tapped, and [`Mapping::apply`] puts it back into the
//! installation for `PUT /api/installation`.

use floatball_shared::api::{Assignment, FoundUnit, InstallationInfo, RollCall};

/// The line speeds a UIM2503 gateway offers (`BDR`), baud: the planner's list.
pub const BAUD_RATES: [u32; 5] = floatball_shared::plan::report::GATEWAY_BAUDS;

/// The highest station a unit can be given (`SN[X]=s/n`, 1–127).
pub const MAX_STATION: u8 = 127;

/// What is wrong with one unit of a roll call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum UnitFlag {
    /// Another unit answers on its station too.
    Duplicated,
    /// Its station is not configured on this gateway.
    Unexpected,
    /// It reported an error.
    Fault,
}

impl UnitFlag {
    /// The flag's stable key (`data-flags`, styling).
    pub fn key(self) -> &'static str {
        match self {
            UnitFlag::Duplicated => "duplicated",
            UnitFlag::Unexpected => "unexpected",
            UnitFlag::Fault => "fault",
        }
    }
}

/// The flags of `unit` in `roll`, most serious first.
pub fn unit_flags(roll: &RollCall, unit: &FoundUnit) -> Vec<UnitFlag> {
    let mut flags = Vec::new();
    if roll.duplicated.contains(&unit.station) {
        flags.push(UnitFlag::Duplicated);
    }
    if roll.unexpected.contains(&unit.station) {
        flags.push(UnitFlag::Unexpected);
    }
    if unit.fault.is_some() {
        flags.push(UnitFlag::Fault);
    }
    flags
}

/// Whether the roll call found the bus as configured: every configured station
/// answered, once, and nothing else did.
pub fn roll_call_clean(roll: &RollCall) -> bool {
    roll.duplicated.is_empty() && roll.missing.is_empty() && roll.unexpected.is_empty()
}

/// "Assign all in grid order": the units of a roll call by serial number, ascending,
/// get the gateway's configured `stations` in cell order (the first serial the first
/// cell's station). Units beyond the configured stations get none (they are left as
/// they are); stations beyond the units found stay unassigned.
pub fn grid_order(units: &[FoundUnit], stations: &[u8]) -> Vec<Assignment> {
    let mut serials: Vec<u64> = units.iter().map(|unit| unit.serial).collect();
    serials.sort_unstable();
    serials.dedup();
    serials
        .into_iter()
        .zip(stations.iter().copied())
        .map(|(serial, station)| Assignment { serial, station })
        .collect()
}

/// A station as typed: a whole number from 1 to [`MAX_STATION`], spaces around
/// allowed.
pub fn parse_station(text: &str) -> Option<u8> {
    let text = text.trim();
    if text.is_empty() || !text.bytes().all(|byte| byte.is_ascii_digit()) {
        return None;
    }
    text.parse::<u8>()
        .ok()
        .filter(|station| (1..=MAX_STATION).contains(station))
}

/// An identify distance that is not a positive number of mm.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BadDistance;

/// The identify distance as typed, mm: empty for the bridge's default (`Ok(None)`),
/// else a positive number (a decimal point or comma allowed).
///
/// # Errors
/// [`BadDistance`] for anything else.
pub fn parse_distance(text: &str) -> Result<Option<f64>, BadDistance> {
    let text = text.trim();
    if text.is_empty() {
        return Ok(None);
    }
    match text.replace(',', ".").parse::<f64>() {
        Ok(mm) if mm.is_finite() && mm > 0.0 => Ok(Some(mm)),
        _ => Err(BadDistance),
    }
}

/// What tapping a cell does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Tap {
    /// The identified station is given this cell (local index).
    Map {
        /// The cell, counted from the gateway's first.
        cell: usize,
        /// The station placed there.
        station: u8,
    },
    /// The ball of the station configured at the cell moves.
    Identify(u8),
    /// Nothing: no unit identified and no station at the cell.
    Nothing,
}

/// The mapping of one gateway's cells to stations while the installer builds it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mapping {
    gateway: usize,
    first_cell: usize,
    cols: usize,
    saved: Vec<u8>,
    stations: Vec<u8>,
    placed: Vec<bool>,
}

/// One cell of a gateway as the grid draws it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CellView {
    /// Its index among the gateway's cells.
    pub local: usize,
    /// Its index in the matrix (row-major).
    pub cell: usize,
    /// Its row, seen from below, from 0.
    pub row: usize,
    /// Its column, seen from below, from 0.
    pub col: usize,
    /// The station it has now.
    pub station: u8,
    /// Whether the installer placed it on this page (tapped it after identifying).
    pub placed: bool,
    /// Whether its station differs from the saved installation's.
    pub changed: bool,
}

impl Mapping {
    /// The mapping of `gateway` as `info` has it; `None` for a gateway it does not
    /// have.
    pub fn new(info: &InstallationInfo, gateway: usize) -> Option<Self> {
        let stations = info.gateways.get(gateway)?.stations.clone();
        Some(Self {
            gateway,
            first_cell: info.first_cell(gateway),
            cols: (info.cols as usize).max(1),
            saved: stations.clone(),
            placed: vec![false; stations.len()],
            stations,
        })
    }

    /// The gateway's stations now, in cell order.
    pub fn stations(&self) -> &[u8] {
        &self.stations
    }

    /// The station at the gateway's cell `local`.
    pub fn station_at(&self, local: usize) -> Option<u8> {
        self.stations.get(local).copied()
    }

    /// The gateway's cell (local index) that has `station`.
    pub fn cell_of(&self, station: u8) -> Option<usize> {
        self.stations.iter().position(|&one| one == station)
    }

    /// What tapping the gateway's cell `local` does, with `identified` the station
    /// last identified (moved) and not yet placed.
    pub fn tap(&self, local: usize, identified: Option<u8>) -> Tap {
        match (identified, self.station_at(local)) {
            (_, None) => Tap::Nothing,
            (Some(station), Some(_)) => Tap::Map {
                cell: local,
                station,
            },
            (None, Some(station)) => Tap::Identify(station),
        }
    }

    /// Gives `station` the cell `local`. The station it had there goes to the cell
    /// `station` had (the two swap), so no station is listed twice; a station new to
    /// the gateway replaces the one at the cell. Returns whether the cell exists.
    pub fn place(&mut self, local: usize, station: u8) -> bool {
        let Some(&before) = self.stations.get(local) else {
            return false;
        };
        if let Some(previous) = self.cell_of(station) {
            self.stations[previous] = before;
        }
        self.stations[local] = station;
        self.placed[local] = true;
        true
    }

    /// How many cells were placed on this page.
    pub fn placed_count(&self) -> usize {
        self.placed.iter().filter(|&&placed| placed).count()
    }

    /// Whether the stations differ from the saved installation's.
    pub fn changed(&self) -> bool {
        self.stations != self.saved
    }

    /// Every cell of the gateway, in cell order.
    pub fn cells(&self) -> Vec<CellView> {
        self.stations
            .iter()
            .enumerate()
            .map(|(local, &station)| {
                let cell = self.first_cell + local;
                CellView {
                    local,
                    cell,
                    row: cell / self.cols,
                    col: cell % self.cols,
                    station,
                    placed: self.placed[local],
                    changed: self.saved.get(local) != Some(&station),
                }
            })
            .collect()
    }

    /// The rows of the matrix the gateway's cells cover: the first and one past the
    /// last.
    pub fn rows(&self) -> (usize, usize) {
        let first = self.first_cell / self.cols;
        let end = (self.first_cell + self.stations.len()).div_ceil(self.cols);
        (first, end.max(first))
    }

    /// The matrix's columns.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// `info` with this gateway's stations replaced: the body of
    /// `PUT /api/installation`.
    pub fn apply(&self, info: &InstallationInfo) -> InstallationInfo {
        let mut info = info.clone();
        if let Some(gateway) = info.gateways.get_mut(self.gateway) {
            gateway.stations = self.stations.clone();
        }
        info
    }
}

/// How long ago a unit last answered, in seconds with one decimal: `0.3 s`.
pub fn age_text(age_ms: u64) -> String {
    format!("{}.{} s", age_ms / 1000, age_ms % 1000 / 100)
}

/// A position in whole millimetres, `—` when unknown.
pub fn position_text(position_mm: Option<f64>) -> String {
    position_mm.map_or_else(|| "—".to_owned(), |mm| format!("{mm:.0} mm"))
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::{GatewayKind, InstallationGateway, UnitFault};
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    fn unit(serial: u64, station: u8) -> FoundUnit {
        FoundUnit {
            serial,
            station,
            position_mm: None,
            last_answer_age_ms: 0,
            fault: None,
            cell: None,
        }
    }

    fn info(stations: &[&[u8]], cols: u32) -> InstallationInfo {
        let units: usize = stations.iter().map(|list| list.len()).sum();
        InstallationInfo {
            rows: (units as u32).div_ceil(cols),
            cols,
            pitch_mm: 500.0,
            travel_mm: 3000.0,
            max_speed_mm_s: 500.0,
            max_accel_mm_s2: 1000.0,
            home_mm: 0.0,
            approach_speed_mm_s: 200.0,
            counts_per_mm: 10.0,
            gateways: stations
                .iter()
                .map(|list| InstallationGateway {
                    kind: GatewayKind::Uim2503,
                    port: "sim".into(),
                    baud: Some(9600),
                    stations: list.to_vec(),
                })
                .collect(),
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn flags_name_the_collision_the_stranger_and_the_fault() {
        let mut faulty = unit(3, 2);
        faulty.fault = Some(UnitFault {
            station: 2,
            error: 0x37,
            code: 0,
            index: 0,
        });
        let roll = RollCall {
            gateway: 0,
            units: vec![unit(1, 5), unit(2, 5), faulty.clone(), unit(4, 9)],
            duplicated: vec![5],
            missing: vec![1],
            unexpected: vec![9],
            took_ms: 10,
        };
        assert_eq!(unit_flags(&roll, &roll.units[0]), [UnitFlag::Duplicated]);
        assert_eq!(unit_flags(&roll, &faulty), [UnitFlag::Fault]);
        assert_eq!(unit_flags(&roll, &roll.units[3]), [UnitFlag::Unexpected]);
        assert!(!roll_call_clean(&roll));
        let clean = RollCall {
            units: vec![unit(1, 1)],
            duplicated: Vec::new(),
            missing: Vec::new(),
            unexpected: Vec::new(),
            ..roll
        };
        assert!(roll_call_clean(&clean));
        assert!(unit_flags(&clean, &clean.units[0]).is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn grid_order_gives_the_stations_by_ascending_serial() {
        let units = [unit(30, 5), unit(10, 5), unit(20, 5), unit(10, 5)];
        let assignments = grid_order(&units, &[7, 8, 9, 11]);
        assert_eq!(
            assignments,
            [
                Assignment {
                    serial: 10,
                    station: 7
                },
                Assignment {
                    serial: 20,
                    station: 8
                },
                Assignment {
                    serial: 30,
                    station: 9
                },
            ]
        );
        // More units than stations: the extra ones get none.
        assert_eq!(grid_order(&units, &[1]).len(), 1);
        assert!(grid_order(&[], &[1, 2]).is_empty());
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn stations_are_whole_numbers_from_1_to_127() {
        assert_eq!(parse_station(" 12 "), Some(12));
        assert_eq!(parse_station("127"), Some(127));
        for bad in ["", "0", "128", "300", "-1", "1.5", "x"] {
            assert_eq!(parse_station(bad), None, "{bad}");
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn distances_are_positive_millimetres_or_the_default() {
        assert_eq!(parse_distance(""), Ok(None));
        assert_eq!(parse_distance(" 20 "), Ok(Some(20.0)));
        assert_eq!(parse_distance("12,5"), Ok(Some(12.5)));
        for bad in ["0", "-5", "x", "inf", "NaN"] {
            assert_eq!(parse_distance(bad), Err(BadDistance), "{bad}");
        }
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn tapping_after_identifying_maps_and_swaps() {
        let info = info(&[&[1, 2, 3, 4]], 2);
        let mut mapping = Mapping::new(&info, 0).unwrap();
        assert!(!mapping.changed());
        // Nothing identified: the cell's ball moves.
        assert_eq!(mapping.tap(2, None), Tap::Identify(3));
        // Station 1 identified, seen above cell 3.
        assert_eq!(
            mapping.tap(3, Some(1)),
            Tap::Map {
                cell: 3,
                station: 1
            }
        );
        assert!(mapping.place(3, 1));
        assert_eq!(mapping.stations(), [4, 2, 3, 1]);
        assert_eq!(mapping.placed_count(), 1);
        assert!(mapping.changed());
        // A station new to the gateway replaces the one at the cell.
        assert!(mapping.place(1, 40));
        assert_eq!(mapping.stations(), [4, 40, 3, 1]);
        assert!(!mapping.place(4, 9));
        assert_eq!(mapping.tap(7, Some(1)), Tap::Nothing);
        let saved = mapping.apply(&info);
        assert_eq!(saved.gateways[0].stations, [4, 40, 3, 1]);
        assert_eq!(saved.rows, info.rows);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn cells_of_a_second_gateway_start_where_the_first_ends() {
        let info = info(&[&[1, 2, 3], &[1, 2, 3, 4, 5]], 4);
        let mapping = Mapping::new(&info, 1).unwrap();
        let cells = mapping.cells();
        assert_eq!(cells[0].cell, 3);
        assert_eq!((cells[0].row, cells[0].col), (0, 3));
        assert_eq!((cells[1].row, cells[1].col), (1, 0));
        assert_eq!(mapping.rows(), (0, 2));
        assert_eq!(mapping.cols(), 4);
        assert!(Mapping::new(&info, 2).is_none());
        let mut changed = mapping.clone();
        changed.place(0, 5);
        let cells = changed.cells();
        assert!(cells[0].changed && cells[0].placed && cells[4].changed);
        assert!(!cells[1].changed && !cells[1].placed);
    }

    #[wasm_bindgen_test(unsupported = test)]
    fn ages_and_positions_read_plainly() {
        assert_eq!(age_text(0), "0.0 s");
        assert_eq!(age_text(12_345), "12.3 s");
        assert_eq!(position_text(Some(1499.6)), "1500 mm");
        assert_eq!(position_text(None), "—");
    }
}
