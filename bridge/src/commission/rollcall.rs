//! The bookkeeping of one roll call, without I/O: the answers go in as they arrive
//! (station, what they mean, when), the [`RollCall`] comes out.
//!
//! - an `SN` answer names a unit (its serial) and the station it answers on; the same
//!   serial heard again keeps its newest station and time;
//! - a station more than one serial answered on is **duplicated** (factory-fresh units
//!   all answer on 5): their answers to a position query cannot be told apart, so none
//!   of them gets a position or a cell;
//! - a `PA` answer is the position of the one unit on its station, when the station
//!   has exactly one unit and answered exactly one position;
//! - configured stations nobody answered on are **missing**, answered stations the
//!   gateway's cells do not name are **unexpected**;
//! - each unit's last error comes from the `ER` frames it sent during the roll call,
//!   or, failing that, from the health monitor's record ([`Context::faults`]).

use std::collections::{BTreeMap, BTreeSet};
use std::time::{Duration, Instant};

use floatball_shared::api::{FoundUnit, RollCall, UnitFault};
use floatball_shared::uim2503::feedback::{Ack, Feedback};

/// What the roll call needs to know about the installation.
#[derive(Debug, Clone, Copy)]
pub struct Context<'a> {
    /// The gateway (0-based).
    pub gateway: usize,
    /// The station of each of the gateway's cells, in cell order.
    pub cells: &'a [u8],
    /// The cell (row-major index into the matrix) of the gateway's first cell.
    pub first_cell: usize,
    /// Counts per mm of ball travel.
    pub counts_per_mm: f64,
    /// The last fault of each station heard before the roll call.
    pub faults: &'a [UnitFault],
}

impl Context<'_> {
    /// The configured stations, ascending, each once.
    pub fn configured(&self) -> BTreeSet<u8> {
        self.cells.iter().copied().collect()
    }

    /// The cell of `station`: where the installation puts it, when it names it once.
    fn cell_of(&self, station: u8) -> Option<usize> {
        let mut at = self
            .cells
            .iter()
            .enumerate()
            .filter(|&(_, &cell_station)| cell_station == station)
            .map(|(index, _)| index);
        match (at.next(), at.next()) {
            (Some(index), None) => Some(self.first_cell + index),
            _ => None,
        }
    }
}

/// One unit heard during the roll call.
#[derive(Debug, Clone, Copy)]
struct Heard {
    station: u8,
    at: Instant,
}

/// The answers of one roll call so far.
#[derive(Debug, Clone)]
pub struct Tally {
    started: Instant,
    /// By serial.
    units: BTreeMap<u64, Heard>,
    /// The distinct positions each station answered, counts.
    positions: BTreeMap<u8, BTreeSet<i32>>,
    /// The last error each station sent.
    faults: BTreeMap<u8, UnitFault>,
    /// Every station that sent anything, and when it last did.
    stations: BTreeMap<u8, Instant>,
}

impl Tally {
    /// A roll call that started at `started`.
    pub fn new(started: Instant) -> Self {
        Self {
            started,
            units: BTreeMap::new(),
            positions: BTreeMap::new(),
            faults: BTreeMap::new(),
            stations: BTreeMap::new(),
        }
    }

    /// A frame from `station` meaning `feedback` arrived `at`. Station 0 is the gateway
    /// itself (it could not read an instruction): not a unit.
    pub fn frame(&mut self, at: Instant, station: u8, feedback: &Feedback) {
        if station == 0 {
            return;
        }
        self.stations
            .entry(station)
            .and_modify(|last| *last = (*last).max(at))
            .or_insert(at);
        match *feedback {
            Feedback::Ack(Ack::Serial { serial }) => {
                self.units.insert(serial, Heard { station, at });
            }
            Feedback::Ack(Ack::PtpPosition { position_counts }) => {
                self.positions
                    .entry(station)
                    .or_default()
                    .insert(position_counts);
            }
            Feedback::Error(error) => {
                self.faults.insert(station, UnitFault::of(station, &error));
            }
            _ => {}
        }
    }

    /// The stations units answered `SN` on, each once.
    pub fn answered(&self) -> BTreeSet<u8> {
        self.units.values().map(|heard| heard.station).collect()
    }

    /// How many units answered on each station.
    fn census(&self) -> BTreeMap<u8, usize> {
        let mut census = BTreeMap::new();
        for heard in self.units.values() {
            *census.entry(heard.station).or_insert(0) += 1;
        }
        census
    }

    /// Stations more than one unit answered on, ascending.
    pub fn duplicated(&self) -> Vec<u8> {
        self.census()
            .into_iter()
            .filter(|&(_, count)| count > 1)
            .map(|(station, _)| station)
            .collect()
    }

    /// The roll call as it stands at `now`.
    pub fn finish(&self, now: Instant, context: &Context<'_>) -> RollCall {
        let census = self.census();
        let configured = context.configured();
        let earlier: BTreeMap<u8, UnitFault> = context
            .faults
            .iter()
            .map(|fault| (fault.station, *fault))
            .collect();
        let units = self
            .units
            .iter()
            .map(|(&serial, heard)| {
                let alone = census.get(&heard.station) == Some(&1);
                let position_mm = self
                    .positions
                    .get(&heard.station)
                    .filter(|positions| alone && positions.len() == 1)
                    .and_then(|positions| positions.first())
                    .map(|&counts| f64::from(counts) / context.counts_per_mm);
                let last = self
                    .stations
                    .get(&heard.station)
                    .copied()
                    .unwrap_or(heard.at)
                    .max(heard.at);
                FoundUnit {
                    serial,
                    station: heard.station,
                    position_mm,
                    last_answer_age_ms: millis(now.saturating_duration_since(last)),
                    fault: self
                        .faults
                        .get(&heard.station)
                        .or_else(|| earlier.get(&heard.station))
                        .copied(),
                    cell: alone.then(|| context.cell_of(heard.station)).flatten(),
                }
            })
            .collect();
        let answered: BTreeSet<u8> = census.keys().copied().collect();
        RollCall {
            gateway: context.gateway,
            units,
            duplicated: self.duplicated(),
            missing: configured.difference(&answered).copied().collect(),
            unexpected: answered.difference(&configured).copied().collect(),
            took_ms: millis(now.saturating_duration_since(self.started)),
        }
    }
}

fn millis(duration: Duration) -> u64 {
    u64::try_from(duration.as_millis()).unwrap_or(u64::MAX)
}

#[cfg(test)]
mod tests {
    use floatball_shared::uim2503::feedback::UnitError;

    use super::*;

    fn serial(serial: u64) -> Feedback {
        Feedback::Ack(Ack::Serial { serial })
    }

    fn position(position_counts: i32) -> Feedback {
        Feedback::Ack(Ack::PtpPosition { position_counts })
    }

    fn context<'a>(cells: &'a [u8], faults: &'a [UnitFault]) -> Context<'a> {
        Context {
            gateway: 1,
            cells,
            first_cell: 100,
            counts_per_mm: 100.0,
            faults,
        }
    }

    #[test]
    fn factory_fresh_units_collide_on_five_and_the_rest_is_missing() {
        let start = Instant::now();
        let mut tally = Tally::new(start);
        for s in [30, 10, 20] {
            tally.frame(start + Duration::from_millis(s), 5, &serial(s));
        }
        // Three different positions from station 5: nobody's.
        for counts in [0, 100, 200] {
            tally.frame(start, 5, &position(counts));
        }
        let cells = [1, 2, 3, 4, 5];
        let call = tally.finish(start + Duration::from_millis(50), &context(&cells, &[]));
        assert_eq!(call.duplicated, [5]);
        assert_eq!(call.missing, [1, 2, 3, 4]);
        assert!(call.unexpected.is_empty());
        assert_eq!(call.took_ms, 50);
        let serials: Vec<u64> = call.units.iter().map(|unit| unit.serial).collect();
        assert_eq!(serials, [10, 20, 30], "by serial, ascending");
        assert!(
            call.units
                .iter()
                .all(|unit| unit.station == 5 && unit.position_mm.is_none() && unit.cell.is_none())
        );
        // Station 5 last answered at 30 ms: every unit on it is 20 ms old.
        assert!(call.units.iter().all(|unit| unit.last_answer_age_ms == 20));
    }

    #[test]
    fn unique_stations_get_their_position_cell_and_fault() {
        let start = Instant::now();
        let mut tally = Tally::new(start);
        tally.frame(start, 2, &serial(222));
        tally.frame(start, 2, &position(15_000));
        tally.frame(start, 9, &serial(999));
        tally.frame(start, 9, &position(0));
        tally.frame(start, 3, &serial(333));
        let refusal = UnitError {
            error: 0x33,
            code: 0x27,
            index: 4,
        };
        tally.frame(start, 3, &Feedback::Error(refusal));
        // The gateway's own syntax error (station 0) is not a unit.
        tally.frame(start, 0, &Feedback::Error(refusal));
        let earlier = [UnitFault {
            station: 2,
            error: 0x40,
            code: 0x27,
            index: 7,
        }];
        let cells = [1, 2, 3];
        let call = tally.finish(start, &context(&cells, &earlier));
        assert_eq!(call.missing, [1]);
        assert_eq!(call.unexpected, [9]);
        assert!(call.duplicated.is_empty());
        let by_station: BTreeMap<u8, &FoundUnit> =
            call.units.iter().map(|unit| (unit.station, unit)).collect();
        let two = by_station[&2];
        assert_eq!((two.position_mm, two.cell), (Some(150.0), Some(101)));
        assert_eq!(two.fault, Some(earlier[0]), "the monitor's record");
        let three = by_station[&3];
        assert_eq!(three.position_mm, None, "it did not answer PA");
        assert_eq!(three.cell, Some(102));
        assert_eq!(
            three.fault,
            Some(UnitFault {
                station: 3,
                error: 0x33,
                code: 0x27,
                index: 4
            })
        );
        let nine = by_station[&9];
        assert_eq!((nine.position_mm, nine.cell), (Some(0.0), None));
        assert_eq!(call.units.len(), 3);
    }

    #[test]
    fn a_serial_heard_twice_counts_once_on_its_newest_station() {
        let start = Instant::now();
        let mut tally = Tally::new(start);
        tally.frame(start, 5, &serial(7));
        tally.frame(start, 5, &serial(8));
        assert_eq!(tally.duplicated(), [5]);
        tally.frame(start + Duration::from_millis(1), 1, &serial(7));
        assert!(tally.duplicated().is_empty());
        assert_eq!(tally.answered(), BTreeSet::from([1, 5]));
        // A station the installation names twice gives neither cell.
        let cells = [1, 1, 5];
        let call = tally.finish(start, &context(&cells, &[]));
        assert!(
            call.units
                .iter()
                .all(|unit| unit.station != 1 || unit.cell.is_none())
        );
        let five = call.units.iter().find(|unit| unit.station == 5).unwrap();
        assert_eq!(five.cell, Some(102));
    }
}
