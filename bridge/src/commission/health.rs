//! Unit health of one UIM2503 gateway ([`UnitHealth`]): a monitor task owns the record
//! and publishes it as a snapshot (a `watch`) that the playback task copies into
//! [`GatewayStatus::health`](floatball_shared::api::GatewayStatus::health).
//!
//! What it learns from:
//! - every **roll call** (it replaces the record: who answered, on which station);
//! - every **feedback frame** of the gateway (a station that sends anything is
//!   answering; `ER` frames are the units' last faults; `SN` answers tell who is on a
//!   station);
//! - a **light probe while the matrix is at rest**: one configured station's `*s;SN;`
//!   per [`PROBE_PERIOD`] (6 bytes out, 12 back: about 1 % of a 9600-baud line), and
//!   only after the line has carried nothing but greetings and probes for
//!   [`QUIET_BEFORE_PROBING`]. It never probes while a show plays, loads or streams,
//!   while a Start is being prepared, or while a commissioning call is under way.
//!
//! [`HealthBook`] is the record without I/O (tested beside it); [`monitor`] is the task.

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Duration;

use floatball_shared::api::{PlayerState, RollCall, Status, UnitFault, UnitHealth};
use floatball_shared::uim2503::ascii::{Batch, Form, Instruction};
use floatball_shared::uim2503::feedback::{Ack, Feedback, Frame};
use tokio::sync::{broadcast, mpsc, watch};

use crate::ports::uim2503::Link;

/// How often the idle probe asks one station.
pub const PROBE_PERIOD: Duration = Duration::from_secs(1);

/// How long the line must have been quiet (nothing but greetings and probes) before
/// the probe starts.
pub const QUIET_BEFORE_PROBING: Duration = Duration::from_secs(30);

/// Bytes per [`PROBE_PERIOD`] others may write without the line counting as in use (the
/// link's own greeting, `ABC;`, every two seconds or so).
const BACKGROUND_BYTES: u64 = 8;

/// The health snapshot of one gateway: absent until the bridge has asked.
pub type HealthView = watch::Receiver<Option<UnitHealth>>;

/// What a station did lately.
#[derive(Debug, Clone, Default)]
struct Station {
    /// It answered when last asked, or sent something since.
    answering: bool,
    /// The serials heard on it when last asked.
    serials: BTreeSet<u64>,
}

/// A probe waiting for its answer.
#[derive(Debug, Clone)]
struct Probe {
    station: u8,
    answered: bool,
    serials: BTreeSet<u64>,
}

/// One gateway's unit health, fed with roll calls, frames and probes.
#[derive(Debug, Clone, Default)]
pub struct HealthBook {
    /// The configured stations, each once.
    expected: BTreeSet<u8>,
    stations: BTreeMap<u8, Station>,
    faults: BTreeMap<u8, UnitFault>,
    /// Whether the bridge has asked yet (a roll call or a probe).
    asked: bool,
    probe: Option<Probe>,
    /// The next station the probe asks (round robin over the configured ones).
    next_probe: u8,
}

impl HealthBook {
    /// A record for a gateway whose cells have `stations`.
    pub fn new(stations: &[u8]) -> Self {
        Self {
            expected: stations.iter().copied().collect(),
            ..Self::default()
        }
    }

    /// The gateway's cells now have `stations`.
    pub fn expect(&mut self, stations: &[u8]) {
        self.expected = stations.iter().copied().collect();
    }

    /// A frame from `station` meaning `feedback` (station 0, the gateway itself, is
    /// not a unit).
    pub fn frame(&mut self, station: u8, feedback: &Feedback) {
        if station == 0 {
            return;
        }
        let serial = match *feedback {
            Feedback::Ack(Ack::Serial { serial }) => Some(serial),
            Feedback::Error(error) => {
                self.faults.insert(station, UnitFault::of(station, &error));
                None
            }
            _ => None,
        };
        let probing = self.probe.as_mut().filter(|probe| probe.station == station);
        if let Some(probe) = probing {
            probe.answered = true;
            probe.serials.extend(serial);
        } else {
            let entry = self.stations.entry(station).or_default();
            entry.answering = true;
            entry.serials.extend(serial);
        }
    }

    /// A roll call found `call` on a gateway whose cells have `stations`: it replaces
    /// what the record knew of who answers.
    pub fn roll_call(&mut self, call: &RollCall, stations: &[u8]) {
        self.expect(stations);
        self.asked = true;
        self.probe = None;
        self.stations.clear();
        for unit in &call.units {
            let entry = self.stations.entry(unit.station).or_default();
            entry.answering = true;
            entry.serials.insert(unit.serial);
            if let Some(fault) = unit.fault {
                self.faults.entry(fault.station).or_insert(fault);
            }
        }
        for &station in &self.expected {
            self.stations.entry(station).or_default();
        }
    }

    /// Ends the probe under way (its answer had time to come) and starts one of the
    /// next configured station; returns that station, if any is configured.
    pub fn next_probe(&mut self) -> Option<u8> {
        self.close_probe();
        let station = self
            .expected
            .range(self.next_probe..)
            .next()
            .or_else(|| self.expected.first())
            .copied()?;
        self.next_probe = station.saturating_add(1);
        self.asked = true;
        self.probe = Some(Probe {
            station,
            answered: false,
            serials: BTreeSet::new(),
        });
        Some(station)
    }

    /// Ends the probe under way, if any: its station answers or not.
    pub fn close_probe(&mut self) {
        if let Some(probe) = self.probe.take() {
            let entry = self.stations.entry(probe.station).or_default();
            entry.answering = probe.answered;
            entry.serials = probe.serials;
        }
    }

    /// The faults heard, newest per station, for a roll call.
    pub fn faults(&self) -> Vec<UnitFault> {
        self.faults.values().copied().collect()
    }

    /// The health as it stands; `None` until the bridge has asked.
    pub fn health(&self) -> Option<UnitHealth> {
        if !self.asked {
            return None;
        }
        let answering: BTreeSet<u8> = self
            .stations
            .iter()
            .filter(|(_, station)| station.answering)
            .map(|(&station, _)| station)
            .collect();
        let health = UnitHealth {
            expected: u32::try_from(self.expected.len()).unwrap_or(u32::MAX),
            answering: u32::try_from(self.expected.intersection(&answering).count())
                .unwrap_or(u32::MAX),
            missing: self.expected.difference(&answering).copied().collect(),
            unexpected: answering.difference(&self.expected).copied().collect(),
            duplicated: self
                .stations
                .iter()
                .filter(|(_, station)| station.serials.len() > 1)
                .map(|(&station, _)| station)
                .collect(),
            faults: self.faults(),
        };
        Some(health)
    }
}

/// What the commissioning calls tell the monitor.
#[derive(Debug)]
pub enum Report {
    /// A roll call's result on a gateway whose cells have these stations.
    RollCall(RollCall, Vec<u8>),
    /// The faults heard so far, for a roll call.
    Faults(tokio::sync::oneshot::Sender<Vec<UnitFault>>),
}

/// What the monitor of one gateway needs.
#[derive(Debug)]
pub struct MonitorConfig {
    /// The gateway's link.
    pub link: Link,
    /// The stations of its cells.
    pub stations: Vec<u8>,
    /// The player's status (the probe runs only while the matrix is at rest).
    pub status: watch::Receiver<Status>,
    /// Set while a commissioning call uses the gateway.
    pub busy: Arc<AtomicBool>,
    /// How many Starts or Resets are being prepared.
    pub starts_pending: Arc<AtomicUsize>,
}

/// Whether the player leaves the line alone.
pub fn at_rest(state: PlayerState) -> bool {
    matches!(
        state,
        PlayerState::Idle | PlayerState::Stopped | PlayerState::Error
    )
}

/// The monitor task of one gateway: owns its [`HealthBook`], publishes it on `health`.
pub async fn monitor(
    config: MonitorConfig,
    mut reports: mpsc::Receiver<Report>,
    health: watch::Sender<Option<UnitHealth>>,
) {
    let MonitorConfig {
        link,
        stations,
        status,
        busy,
        starts_pending,
    } = config;
    let mut book = HealthBook::new(&stations);
    let mut frames = link.feedback();
    let mut tick = tokio::time::interval(PROBE_PERIOD);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut seen_bytes = link.written_bytes();
    let mut own_bytes = 0u64;
    let mut quiet_ticks = 0u32;
    let needed_ticks = QUIET_BEFORE_PROBING.as_millis() / PROBE_PERIOD.as_millis().max(1);
    loop {
        tokio::select! {
            frame = frames.recv() => match frame {
                Ok(frame) => take_frame(&mut book, &frame),
                Err(broadcast::error::RecvError::Lagged(missed)) => {
                    tracing::debug!("health monitor of gateway {}: {missed} frames missed", link.index());
                }
                Err(broadcast::error::RecvError::Closed) => return,
            },
            report = reports.recv() => match report {
                Some(Report::RollCall(call, stations)) => {
                    book.roll_call(&call, &stations);
                    publish(&health, &book);
                }
                Some(Report::Faults(reply)) => { let _ = reply.send(book.faults()); }
                None => return,
            },
            _ = tick.tick() => {
                let written = link.written_bytes();
                let others = written.saturating_sub(seen_bytes).saturating_sub(own_bytes);
                seen_bytes = written;
                own_bytes = 0;
                let rest = at_rest(status.borrow().state)
                    && starts_pending.load(Ordering::SeqCst) == 0
                    && !busy.load(Ordering::Acquire)
                    && link.is_up()
                    && link.queued_bytes() == 0
                    && !link.latch().is_latched();
                if !rest || others > BACKGROUND_BYTES {
                    quiet_ticks = 0;
                    book.close_probe();
                } else if u128::from(quiet_ticks) < needed_ticks {
                    quiet_ticks += 1;
                } else if let Some(station) = book.next_probe()
                    && let Ok(batch) = Batch::encode(
                        &[Instruction::Select { station }, Instruction::QuerySerial],
                        Form::Standard,
                    )
                {
                    own_bytes = batch.len() as u64;
                    if link.enqueue(&batch, link.latch().generation()).is_err() {
                        book.close_probe();
                    }
                }
                publish(&health, &book);
            }
        }
    }
}

/// Publishes the record if it changed (frames are taken at once, published with the
/// next tick: a show's thousands of answers a second cost no snapshot each).
fn publish(health: &watch::Sender<Option<UnitHealth>>, book: &HealthBook) {
    let current = book.health();
    health.send_if_modified(|published| {
        let changed = *published != current;
        if changed {
            *published = current;
        }
        changed
    });
}

fn take_frame(book: &mut HealthBook, frame: &Frame) {
    if let Ok(feedback) = Feedback::from_frame(frame) {
        book.frame(frame.station(), &feedback);
    }
}

#[cfg(test)]
mod tests {
    use floatball_shared::api::FoundUnit;
    use floatball_shared::uim2503::feedback::UnitError;

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

    fn call(units: Vec<FoundUnit>) -> RollCall {
        RollCall {
            gateway: 0,
            units,
            duplicated: Vec::new(),
            missing: Vec::new(),
            unexpected: Vec::new(),
            took_ms: 0,
        }
    }

    #[test]
    fn nothing_is_said_until_the_bridge_has_asked() {
        let mut book = HealthBook::new(&[1, 2]);
        book.frame(1, &Feedback::Ack(Ack::Serial { serial: 9 }));
        assert_eq!(book.health(), None);
    }

    #[test]
    fn a_roll_call_sets_answering_missing_unexpected_and_duplicated() {
        let mut book = HealthBook::new(&[1, 2, 3]);
        book.roll_call(
            &call(vec![unit(10, 5), unit(11, 5), unit(12, 1), unit(13, 9)]),
            &[1, 2, 3, 5],
        );
        let health = book.health().unwrap();
        assert_eq!((health.expected, health.answering), (4, 2));
        assert_eq!(health.missing, [2, 3]);
        assert_eq!(health.unexpected, [9]);
        assert_eq!(health.duplicated, [5]);
        assert!(health.faults.is_empty());
    }

    #[test]
    fn frames_mark_answering_and_errors_are_the_last_faults() {
        let mut book = HealthBook::new(&[1, 2]);
        book.roll_call(&call(vec![unit(10, 1)]), &[1, 2]);
        assert_eq!(book.health().unwrap().missing, [2]);
        book.frame(2, &Feedback::Ack(Ack::Motor { on: true }));
        let refusal = |error| UnitError {
            error,
            code: 0x27,
            index: 3,
        };
        book.frame(2, &Feedback::Error(refusal(0x33)));
        book.frame(2, &Feedback::Error(refusal(0x40)));
        book.frame(0, &Feedback::Error(refusal(0x32)));
        let health = book.health().unwrap();
        assert_eq!((health.answering, health.missing.len()), (2, 0));
        assert_eq!(
            health.faults,
            [UnitFault {
                station: 2,
                error: 0x40,
                code: 0x27,
                index: 3
            }]
        );
    }

    #[test]
    fn the_probe_goes_round_the_configured_stations_and_finds_the_silent_one() {
        let mut book = HealthBook::new(&[3, 1, 2]);
        assert_eq!(book.next_probe(), Some(1));
        book.frame(1, &Feedback::Ack(Ack::Serial { serial: 100 }));
        assert_eq!(book.next_probe(), Some(2));
        // Station 2 stays silent; station 3 has two units.
        assert_eq!(book.next_probe(), Some(3));
        book.frame(3, &Feedback::Ack(Ack::Serial { serial: 300 }));
        book.frame(3, &Feedback::Ack(Ack::Serial { serial: 301 }));
        assert_eq!(book.next_probe(), Some(1), "round again");
        book.close_probe();
        let health = book.health().unwrap();
        assert_eq!(health.missing, [1, 2], "1 did not answer its second probe");
        assert_eq!(health.duplicated, [3]);
        assert_eq!(health.answering, 1);
        assert_eq!(HealthBook::new(&[]).next_probe(), None);
    }
}
