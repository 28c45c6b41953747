//! A simulated UIM2503 gateway and its UFQ750 units, as a sans-IO state machine: bytes
//! from the host and the time go in, feedback bytes come out (manual §6–§8,
//! `docs/protocol-notes.md`).
//!
//! - [`Gateway::receive`] takes the host's bytes in any chunking at a time `now_us`:
//!   the gateway reads them with the codec's [`InstructionReader`], keeps the station
//!   selected by `*N;` (0 = every unit) and hands each instruction to the units on that
//!   station.
//! - [`Gateway::advance`] lets time pass: rows start and end, watermark notices are
//!   sent, moves end, timed `BG=N;` start.
//! - [`Gateway::poll_output`] hands over the feedback bytes, in order, made with the
//!   codec's frame encoder; [`Gateway::next_event_us`] says when `advance` next has
//!   something to do, so a caller can sleep until then.
//! - [`Gateway::units`] shows every unit (station, serial, position, velocity, motor,
//!   moving) for the bridge's `GET /api/sim/positions`.
//! - The gateway's own commands (`docs/uim2503.md` §2, `docs/protocol-notes.md` §3): it answers the greeting `ABC;`
//!   with `AA AB AC`, and stores the line speed of `BDR=x;`, which
//!   [`Gateway::restart`] (a power cycle) hands to its serial port ([`Uart`]); until
//!   then the line keeps its speed.
//!
//! Each unit keeps a [`PvtTable`](crate::uim2503::pvt::PvtTable) and moves PVT rows with the
//! shared [`Segment`](crate::motion::Segment) evaluator; point-to-point moves are
//! [`Trapezoid`](crate::motion::Trapezoid)s. Time is µs since [`Gateway::new`], and the
//! units' system time (the clock `BG=N;` refers to) is that time modulo 2³². Nothing
//! here reads a clock or draws a random number: the same configuration and inputs give
//! the same bytes.
//! Where the manual is silent, `docs/protocol-notes.md` ("What the simulator does
//! where the manual is silent") says what the simulator does.
//!
//! # Example
//! ```
//! use floatball_shared::uim2503::feedback::{Ack, Feedback, FrameDecoder};
//! use floatball_shared::uim2503::sim::{Gateway, GatewayConfig};
//!
//! let mut gateway = Gateway::new(GatewayConfig::numbered(3))?;
//! // Unit 2 moves to 40000 counts at 10000 counts/s; the instruction arrives in pieces.
//! gateway.receive(0, b"*2;MO=1;SP=10");
//! gateway.receive(1_000, b"000;PA=40000;BG;");
//! let mut bytes = Vec::new();
//! gateway.poll_output(&mut bytes);
//! let answers: Vec<_> = FrameDecoder::new()
//!     .push(&bytes)
//!     .map(|frame| (frame.station(), Feedback::from_frame(&frame)))
//!     .collect();
//! assert_eq!(answers.len(), 4);
//! assert_eq!(answers[3], (2, Ok(Feedback::Ack(Ack::Begin { at_us: 0 }))));
//!
//! // Half a second later the ball is on its way; it arrives when the trapezoid says
//! // (4 s cruising plus 25 ms to speed up at the default 400000 counts/s²).
//! gateway.advance(501_000);
//! let unit = gateway.unit(1).expect("three units");
//! assert!(unit.moving && unit.position_counts > 0.0);
//! assert_eq!(gateway.next_event_us(), Some(1_000 + 4_025_000));
//! gateway.advance(4_026_000);
//! assert_eq!(gateway.unit(1).map(|unit| unit.position_counts), Some(40_000.0));
//! # Ok::<(), floatball_shared::uim2503::sim::ConfigError>(())
//! ```

mod config;
mod line;
mod motion;
pub mod noise;
mod unit;

#[cfg(test)]
mod procedures;

use std::ops::Range;

use crate::api::{SimGateway, SimLineStats, SimUnit};
use crate::uim2503::ascii::gateway::GREETING_ANSWER;
use crate::uim2503::ascii::{
    Field, GatewayCommand, Instruction, InstructionReader, ParseError, ParseErrorKind,
};
use crate::uim2503::feedback::{Feedback, Frame, UnitError, code};

pub use config::{
    ConfigError, DEFAULT_COUNTS_PER_MM, FACTORY_STATION, Faults, Garble, GatewayConfig, MAX_UNITS,
};
pub use line::{RX_FIFO_BYTES, RxLine, TX_QUEUE_BYTES, Uart};

use config::Limits;
use unit::{Outbox, Timed, Unit};

/// The units' system time at gateway time `now_us`: a 32-bit µs counter (`BG=N` takes
/// N = 0…0xFFFFFFFF), so it wraps every 71.6 minutes.
fn system_time_us(now_us: u64) -> u32 {
    // Keeping the low 32 bits is the point.
    now_us as u32
}

/// A simulated gateway with its units; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct Gateway {
    limits: Limits,
    units: Vec<Unit>,
    /// Unit indices by (station, index): the order in which units answer (on CAN the
    /// lower id wins arbitration).
    order: Vec<usize>,
    /// `order[station_start[s]..station_start[s + 1]]` are the units on station `s`.
    station_start: [usize; 129],
    reader: InstructionReader,
    /// The station `*N;` chose; 0 = every unit. The gateway starts with 0.
    selected: u8,
    now_us: u64,
    /// No unit has anything to do before this time (a lower bound).
    next_event_us: u64,
    /// Frames the units send unasked, gathered to be sent in time order.
    timed: Vec<Timed>,
    /// Answers to the instruction being carried out.
    answers: Vec<Frame>,
    output: Vec<u8>,
    /// Bytes sent so far, to find the ones to garble.
    sent_bytes: u64,
    /// Bytes to garble, by position.
    garbles: Vec<Garble>,
    /// The line speed the last `BDR=x;` stored, baud: used from the next restart on.
    stored_baud: Option<u32>,
}

/// A unit index that does not exist.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("there is no unit {unit} on this gateway")]
pub struct NoSuchUnit {
    /// The index given.
    pub unit: usize,
}

impl Gateway {
    /// A gateway at time 0 with its units at power-on: at the top, motor off.
    ///
    /// # Errors
    /// [`ConfigError`] if the configuration cannot be simulated.
    pub fn new(config: GatewayConfig) -> Result<Self, ConfigError> {
        let limits = config.limits()?;
        let units = config
            .stations
            .iter()
            .enumerate()
            .map(|(index, &station)| {
                let serial = config::serial(config.seed, index);
                let connected = !config.faults.disconnected.contains(&index);
                Unit::new(station, serial, connected, &limits)
            })
            .collect();
        let mut garbles = config.faults.garbled_output;
        garbles.sort_by_key(|garble| garble.byte);
        let mut gateway = Self {
            limits,
            units,
            order: (0..config.stations.len()).collect(),
            station_start: [0; 129],
            reader: InstructionReader::new(),
            selected: 0,
            now_us: 0,
            next_event_us: u64::MAX,
            timed: Vec::new(),
            answers: Vec::new(),
            output: Vec::new(),
            sent_bytes: 0,
            garbles,
            stored_baud: None,
        };
        gateway.sort_stations();
        Ok(gateway)
    }

    /// Bytes from the host arrive at `now_us`: time first passes up to `now_us`, then
    /// every instruction the bytes complete is carried out at `now_us`. Bytes of an
    /// unfinished instruction wait for the next call. Times earlier than the gateway's
    /// count as its time (time never goes back).
    pub fn receive(&mut self, now_us: u64, bytes: &[u8]) {
        self.advance(now_us);
        for &byte in bytes {
            if let Some(read) = self.reader.push_byte(byte) {
                self.execute(read);
            }
        }
    }

    /// The line speed the last `BDR=x;` stored, baud, if one did: the gateway's serial
    /// port uses it from its next [`restart`](Self::restart) on.
    #[must_use]
    pub fn stored_baud(&self) -> Option<u32> {
        self.stored_baud
    }

    /// The gateway restarts (a power cycle of the gateway alone; the units keep their
    /// power, their stations and their motion): a half-read instruction is forgotten,
    /// the selection is back to 0 (every unit), answers not handed over yet are lost.
    /// Returns the line speed its serial port runs at from now on, if `BDR=x;` stored
    /// one (it stays stored, as in the gateway's flash, for later restarts too).
    pub fn restart(&mut self) -> Option<u32> {
        self.reader = InstructionReader::new();
        self.selected = 0;
        self.output.clear();
        self.stored_baud
    }

    /// Time passes up to `now_us`: every unit's motion, row starts, watermark notices,
    /// run ends and timed starts up to then happen, in time order. Cheap when nothing is
    /// due (see [`next_event_us`](Self::next_event_us)), and never allocates once the
    /// output has room.
    pub fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
        let now = self.now_us;
        if self.next_event_us > now {
            return;
        }
        let mut next = u64::MAX;
        for (index, unit) in self.units.iter_mut().enumerate() {
            if unit.next_us() <= now {
                let mut out = Outbox {
                    unit: index,
                    frames: &mut self.timed,
                };
                unit.advance(now, &self.limits, &mut out);
            }
            next = next.min(unit.next_us());
        }
        self.next_event_us = next;
        self.flush_timed();
    }

    /// Appends the feedback bytes produced so far to `out`, in order, and returns how
    /// many there were.
    pub fn poll_output(&mut self, out: &mut Vec<u8>) -> usize {
        out.extend_from_slice(&self.output);
        let count = self.output.len();
        self.output.clear();
        count
    }

    /// When [`advance`](Self::advance) next has something to do (a row ends, a move
    /// ends, a timed `BG` starts, a ball reaches a limit), µs; `None` while nothing is
    /// under way. Positions change continuously in between: [`units`](Self::units)
    /// evaluates them at the gateway's time.
    #[must_use]
    pub fn next_event_us(&self) -> Option<u64> {
        self.units
            .iter()
            .map(Unit::next_us)
            .min()
            .filter(|&next| next != u64::MAX)
    }

    /// The gateway's time: µs since [`new`](Self::new), as of the last `receive` or
    /// `advance`.
    #[must_use]
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The units' system time, the clock `BG=N;` refers to: [`now_us`](Self::now_us)
    /// modulo 2³² (every unit's clock started with the gateway).
    #[must_use]
    pub fn system_time_us(&self) -> u32 {
        system_time_us(self.now_us)
    }

    /// Every unit, in configuration order, at the gateway's time, as the bridge serves
    /// it at `GET /api/sim/positions`.
    pub fn units(&self) -> impl ExactSizeIterator<Item = SimUnit> + '_ {
        self.units.iter().map(|unit| self.view(unit))
    }

    /// Unit `index` (its place in [`GatewayConfig::stations`]) at the gateway's time.
    #[must_use]
    pub fn unit(&self, index: usize) -> Option<SimUnit> {
        self.units.get(index).map(|unit| self.view(unit))
    }

    /// Every unit as the bridge serves it at `GET /api/sim/positions`, for the gateway
    /// with index `gateway` in the bridge's configuration.
    #[must_use]
    pub fn positions(&self, gateway: usize) -> SimGateway {
        SimGateway {
            gateway,
            time_us: self.now_us,
            units: self.units().collect(),
            line: SimLineStats::default(),
        }
    }

    /// Connects unit `unit` to the bus or cuts it off (fault injection). A unit off the
    /// bus receives no instruction and sends nothing (what it would have sent is lost),
    /// but keeps moving as it was told.
    ///
    /// # Errors
    /// [`NoSuchUnit`] if there is no unit `unit`.
    pub fn set_connected(&mut self, unit: usize, connected: bool) -> Result<(), NoSuchUnit> {
        let found = self.units.get_mut(unit).ok_or(NoSuchUnit { unit })?;
        found.connected = connected;
        Ok(())
    }

    /// Garbles one more byte of the output (fault injection); bytes already sent stay
    /// as they were.
    pub fn garble_output(&mut self, garble: Garble) {
        let at = self.garbles.partition_point(|g| g.byte <= garble.byte);
        self.garbles.insert(at, garble);
    }

    fn view(&self, unit: &Unit) -> SimUnit {
        let state = unit.kinematics(self.now_us, &self.limits);
        SimUnit {
            station: unit.station,
            serial: unit.serial,
            position_counts: state.position,
            velocity_counts_s: state.velocity,
            motor_on: unit.motor_on,
            moving: unit.moving(self.now_us, &self.limits),
            ptp_moves: unit.ptp_moves,
        }
    }

    /// Carries out what the reader made of one instruction.
    fn execute(&mut self, read: Result<Instruction, ParseError>) {
        match read {
            Ok(Instruction::Select { station }) => self.selected = station,
            // A mnemonic no unit knows: the gateway cannot turn it into a CAN message.
            Ok(Instruction::Generic(_)) => self.gateway_error(),
            Ok(Instruction::Gateway(GatewayCommand::Greet)) => self.send_raw(&GREETING_ANSWER),
            // Stored, silently; the line changes speed at the next restart.
            Ok(Instruction::Gateway(GatewayCommand::SetBaud { baud })) => {
                self.stored_baud = Some(baud);
            }
            Ok(instruction) => self.dispatch(&instruction),
            Err(error) => match unit_refusal(&error) {
                Some(refusal) => self.refuse(refusal),
                None => self.gateway_error(),
            },
        }
    }

    /// Hands `instruction` to the units on the selected station and sends their answers.
    fn dispatch(&mut self, instruction: &Instruction) {
        let now = self.now_us;
        let mut answers = std::mem::take(&mut self.answers);
        answers.clear();
        for &index in self.order.get(self.targets()).unwrap_or_default() {
            let Some(unit) = self.units.get_mut(index).filter(|unit| unit.connected) else {
                continue;
            };
            let mut out = Outbox {
                unit: index,
                frames: &mut self.timed,
            };
            unit.advance(now, &self.limits, &mut out);
            let answer = unit.apply(now, instruction, &self.limits, &mut out);
            if let Some(frame) = answer.and_then(|answer| answer.to_frame(unit.station).ok())
                && !answers.contains(&frame)
            {
                answers.push(frame);
            }
            self.next_event_us = self.next_event_us.min(unit.next_us());
        }
        if self.selected != 0 || answers_broadcast(instruction) {
            for frame in &answers {
                self.send(frame);
            }
        }
        self.answers = answers;
        self.flush_timed();
        if matches!(instruction, Instruction::SetStation { .. }) {
            self.sort_stations();
        }
    }

    /// The units on the selected station refuse an instruction the reader found out of
    /// range; after `*0;` they do so silently.
    fn refuse(&mut self, refusal: UnitError) {
        if self.selected == 0 {
            return;
        }
        let mut answers = std::mem::take(&mut self.answers);
        answers.clear();
        for &index in self.order.get(self.targets()).unwrap_or_default() {
            if let Some(unit) = self.units.get(index).filter(|unit| unit.connected)
                && let Ok(frame) = Feedback::Error(refusal).to_frame(unit.station)
                && !answers.contains(&frame)
            {
                answers.push(frame);
            }
        }
        for frame in &answers {
            self.send(frame);
        }
        self.answers = answers;
    }

    /// The gateway itself could not read an instruction: ER `[0x32, 0, 0]` from station 0.
    fn gateway_error(&mut self) {
        let syntax = Feedback::Error(UnitError {
            error: code::error::SYNTAX,
            code: 0,
            index: 0,
        });
        if let Ok(frame) = syntax.to_frame(0) {
            self.send(&frame);
        }
    }

    /// The positions in `order` of the units the selected station addresses.
    fn targets(&self) -> Range<usize> {
        match usize::from(self.selected) {
            0 => 0..self.order.len(),
            station => {
                let start = |s: usize| self.station_start.get(s).copied().unwrap_or_default();
                start(station)..start(station + 1)
            }
        }
    }

    /// Rebuilds the answering order and the station ranges after stations changed.
    fn sort_stations(&mut self) {
        let units = &self.units;
        self.order
            .sort_unstable_by_key(|&index| (units.get(index).map(|unit| unit.station), index));
        let mut start = [0; 129];
        for unit in units {
            for slot in start.iter_mut().skip(usize::from(unit.station) + 1) {
                *slot += 1;
            }
        }
        self.station_start = start;
    }

    /// Sends the frames the units produced unasked, in time order.
    fn flush_timed(&mut self) {
        if self.timed.is_empty() {
            return;
        }
        let mut timed = std::mem::take(&mut self.timed);
        timed.sort_unstable_by_key(|t| (t.at_us, t.unit, t.seq));
        for t in &timed {
            if self.units.get(t.unit).is_some_and(|unit| unit.connected) {
                self.send(&t.frame);
            }
        }
        timed.clear();
        self.timed = timed;
    }

    /// Puts one frame on the line, garbling the bytes fault injection asks for.
    fn send(&mut self, frame: &Frame) {
        self.send_raw(frame.encode().as_bytes());
    }

    /// Puts bytes on the line, garbling the ones fault injection asks for.
    fn send_raw(&mut self, bytes: &[u8]) {
        for &byte in bytes {
            let mut byte = byte;
            while let Some(garble) = self.garbles.first().filter(|g| g.byte <= self.sent_bytes) {
                if garble.byte == self.sent_bytes {
                    byte ^= garble.xor_mask;
                }
                self.garbles.remove(0);
            }
            self.output.push(byte);
            self.sent_bytes += 1;
        }
    }
}

/// Whether every unit answers `instruction` after `*0;`: queries do (each unit, e.g.
/// `*0;SN;`), and `SN[X]=s/n` (only one unit can match); sets do not.
fn answers_broadcast(instruction: &Instruction) -> bool {
    use Instruction as I;
    match *instruction {
        I::MotionProfile { value, .. } => value.is_none(),
        I::PvtStart { row } => row.is_none(),
        I::PvtPosition {
            position_counts, ..
        } => position_counts.is_none(),
        I::PvtVelocity {
            velocity_counts_s, ..
        } => velocity_counts_s.is_none(),
        I::PvtTime { duration_ms, .. } => duration_ms.is_none(),
        I::Motor { on } => on.is_none(),
        I::PtpSpeed { speed_counts_s } => speed_counts_s.is_none(),
        I::PtpPosition { position_counts } => position_counts.is_none(),
        I::StopDecel { decel_counts_s2 } => decel_counts_s2.is_none(),
        I::InfoEnable { enabled, .. } => enabled.is_none(),
        I::QuerySerial | I::SetStation { .. } => true,
        I::Begin { .. } | I::Select { .. } | I::Generic(_) | I::Gateway(_) => false,
    }
}

/// The error a unit reports for an instruction the reader refused, if the unit is the
/// one to refuse it: an operand (`DATA`) or index (`INDEX`) out of range on an
/// instruction the units know. Everything else is the gateway's syntax error.
fn unit_refusal(error: &ParseError) -> Option<UnitError> {
    let ParseErrorKind::OutOfRange(range) = error.kind else {
        return None;
    };
    let (number, mnemonic, index) = match range.field {
        Field::Operand(mnemonic) => (code::error::DATA, mnemonic, range.index.unwrap_or(0)),
        // An index beyond 255 is reported as 255.
        Field::Index(mnemonic) => (
            code::error::INDEX,
            mnemonic,
            u8::try_from(range.value).unwrap_or(u8::MAX),
        ),
        Field::Station | Field::Baud => return None,
    };
    Some(UnitError {
        error: number,
        code: code::of(mnemonic)?,
        index,
    })
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::motion::Trapezoid;
    use crate::uim2503::feedback::{Ack, FrameDecoder, Notification};

    /// Bytes as the manual writes them: `F0 14 15 01 E0`.
    pub(super) fn hex(bytes: &[u8]) -> String {
        bytes
            .iter()
            .map(|byte| format!("{byte:02X}"))
            .collect::<Vec<_>>()
            .join(" ")
    }

    /// What the gateway has sent since the last call, as hex.
    pub(super) fn sent(gateway: &mut Gateway) -> String {
        let mut bytes = Vec::new();
        gateway.poll_output(&mut bytes);
        hex(&bytes)
    }

    /// What the gateway has sent since the last call, decoded.
    pub(super) fn feedback(gateway: &mut Gateway) -> Vec<(u8, Feedback)> {
        let mut bytes = Vec::new();
        gateway.poll_output(&mut bytes);
        let mut decoder = FrameDecoder::new();
        let frames: Vec<_> = decoder.push(&bytes).collect();
        assert_eq!(decoder.stats().dropped_bytes, 0, "{}", hex(&bytes));
        frames
            .iter()
            .map(|frame| (frame.station(), Feedback::from_frame(frame).unwrap()))
            .collect()
    }

    /// The wire bytes of `ack` from `station`, as hex.
    pub(super) fn ack(station: u8, ack: Ack) -> String {
        hex(ack.to_frame(station).unwrap().encode().as_bytes())
    }

    fn error(station: u8, error: u8, code: u8, index: u8) -> String {
        let refusal = Feedback::Error(UnitError { error, code, index });
        hex(refusal.to_frame(station).unwrap().encode().as_bytes())
    }

    fn position(gateway: &Gateway, unit: usize) -> f64 {
        gateway.unit(unit).unwrap().position_counts
    }

    #[test]
    fn factory_fresh_discovery_returns_every_unit_and_sn_renumbers_exactly_one() {
        let mut config = GatewayConfig::factory_fresh(10);
        config.seed = 42;
        let mut gateway = Gateway::new(config).unwrap();
        let serials: Vec<u64> = gateway.units().map(|unit| unit.serial).collect();
        gateway.receive(0, b"*0;SN;");
        let found = feedback(&mut gateway);
        assert_eq!(
            found,
            serials
                .iter()
                .map(|&serial| (5, Feedback::Ack(Ack::Serial { serial })))
                .collect::<Vec<_>>(),
            "one SN frame per unit, all from station 5"
        );
        // Renumber every unit by its serial, through station 5 and through the
        // broadcast: only the unit with that serial answers, from its new station.
        for (index, &serial) in serials.iter().enumerate() {
            let station = u8::try_from(index).unwrap() + 10;
            let select = if index % 2 == 0 { "*5;" } else { "*0;" };
            gateway.receive(1, format!("{select}SN[{station}]={serial};").as_bytes());
            assert_eq!(
                feedback(&mut gateway),
                [(station, Feedback::Ack(Ack::Serial { serial }))]
            );
            assert_eq!(gateway.unit(index).unwrap().station, station);
        }
        // Each station now holds exactly its unit.
        for (index, &serial) in serials.iter().enumerate() {
            let station = u8::try_from(index).unwrap() + 10;
            gateway.receive(2, format!("*{station};SN;").as_bytes());
            assert_eq!(
                feedback(&mut gateway),
                [(station, Feedback::Ack(Ack::Serial { serial }))]
            );
        }
        gateway.receive(3, b"*5;SN;*0;SN[3]=7;");
        assert_eq!(sent(&mut gateway), "", "nobody left on 5; no serial 7");
        gateway.receive(4, b"*0;SN;");
        assert_eq!(feedback(&mut gateway).len(), 10);
    }

    #[test]
    fn units_sharing_a_station_all_obey_and_identical_answers_merge() {
        let mut gateway = Gateway::new(GatewayConfig::factory_fresh(3)).unwrap();
        gateway.receive(0, b"*5;MO=1;PA=1000;BG;SN;");
        let answers = feedback(&mut gateway);
        assert_eq!(
            answers[..3],
            [
                (5, Feedback::Ack(Ack::Motor { on: true })),
                (
                    5,
                    Feedback::Ack(Ack::PtpPosition {
                        position_counts: 1000
                    })
                ),
                (5, Feedback::Ack(Ack::Begin { at_us: 0 })),
            ],
            "identical frames from several units are one frame on CAN"
        );
        assert_eq!(answers.len(), 3 + 3, "three different serials");
        gateway.advance(10_000_000);
        assert!(gateway.units().all(|unit| unit.position_counts == 1000.0));
        // SN[0] would put a unit on the broadcast address: refused.
        let serial = gateway.unit(1).unwrap().serial;
        gateway.receive(10_000_000, format!("*5;SN[0]={serial};").as_bytes());
        assert_eq!(sent(&mut gateway), error(5, 0x33, 0x0C, 0));
    }

    #[test]
    fn answers_follow_the_codecs_who_answers_rule() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(3)).unwrap();
        // Power-on selection is the broadcast: sets are silent, queries answer per unit.
        gateway.receive(0, b"MO=1;SP=500;MO;");
        let answers = feedback(&mut gateway);
        assert_eq!(
            answers,
            (1..=3)
                .map(|station| (station, Feedback::Ack(Ack::Motor { on: true })))
                .collect::<Vec<_>>()
        );
        // `*N;` gets no frame; every instruction to one station gets exactly one.
        gateway.receive(1, b"*2;");
        assert_eq!(sent(&mut gateway), "");
        gateway.receive(
            2,
            b"SP;SP=700;SD;SD=100000;IE[5];IE[9]=1;IE[9];MP[5]=3;MP[5];MP[6];MP[0]=1;MP[0];",
        );
        assert_eq!(
            feedback(&mut gateway),
            [
                Ack::PtpSpeed {
                    speed_counts_s: 500
                },
                Ack::PtpSpeed {
                    speed_counts_s: 700
                },
                Ack::StopDecel {
                    decel_counts_s2: 400_000
                },
                Ack::StopDecel {
                    decel_counts_s2: 100_000
                },
                Ack::InfoEnable {
                    index: 5,
                    enabled: true
                },
                Ack::InfoEnable {
                    index: 9,
                    enabled: true
                },
                Ack::InfoEnable {
                    index: 9,
                    enabled: true
                },
                Ack::MotionProfile { param: 5, value: 3 },
                Ack::MotionProfile { param: 5, value: 3 },
                Ack::MotionProfile { param: 6, value: 0 },
                Ack::MotionProfile { param: 0, value: 1 },
                Ack::MotionProfile { param: 0, value: 0 },
            ]
            .map(|ack| (2, Feedback::Ack(ack)))
        );
        // A station nobody has: silence.
        gateway.receive(3, b"*99;MO;SN;");
        assert_eq!(sent(&mut gateway), "");
    }

    #[test]
    fn errors_follow_the_codecs_decisions() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(20)).unwrap();
        gateway.receive(0, b"*20;QT[3]=0;QT[3];QT[200]=9;");
        assert_eq!(
            sent(&mut gateway),
            format!(
                "{} {} {}",
                "F0 14 0F 33 27 03 E0",
                ack(
                    20,
                    Ack::PvtTime {
                        row: 3,
                        duration_ms: 0
                    }
                ),
                error(20, 0x33, 0x27, 200),
            ),
            "QT[X]=0 refused, the row not written"
        );
        gateway.receive(
            0,
            b"MP[7]=1;MP[4];MP[6]=3;MP[3]=2;MP[1]=256;PV=300;MO=2;QP[256];",
        );
        assert_eq!(
            sent(&mut gateway),
            [
                error(20, 0x34, 0x22, 7),
                error(20, 0x34, 0x22, 4),
                error(20, 0x33, 0x22, 6),
                error(20, 0x33, 0x22, 3),
                error(20, 0x33, 0x22, 1),
                error(20, 0x33, 0x23, 0),
                error(20, 0x33, 0x15, 0),
                error(20, 0x34, 0x25, 255),
            ]
            .join(" ")
        );
        // Text the gateway cannot read, and mnemonics no unit knows: station 0.
        gateway.receive(0, b"HELLO;QP[3=1;*128;ILx=0A;QP[1]={5};");
        assert_eq!(sent(&mut gateway), ["F0 00 0F 32 00 00 E0"; 5].join(" "));
        // BG with the motor off; SP, SD of 0.
        gateway.receive(0, b"BG;BG=5;SP=0;SP=-3;SD=0;");
        assert_eq!(
            sent(&mut gateway),
            [
                error(20, 0x3E, 0x16, 0),
                error(20, 0x3E, 0x16, 0),
                error(20, 0x33, 0x1E, 0),
                error(20, 0x33, 0x1E, 0),
                error(20, 0x33, 0x1C, 0),
            ]
            .join(" ")
        );
        // MP[1] >= MP[2] is refused when BG starts a single or loop run.
        gateway.receive(
            0,
            b"MO=1;MP[3]=1;MP[1]=50;MP[2]=10;QP[50]=0;QV[50]=0;QT[50]=10;",
        );
        sent(&mut gateway);
        gateway.receive(0, b"MP[2]=60;PV=50;MP[2]=50;BG;BG=1000;");
        assert_eq!(
            sent(&mut gateway),
            [
                ack(
                    20,
                    Ack::MotionProfile {
                        param: 2,
                        value: 60
                    }
                ),
                ack(20, Ack::PvtStart { value: 50 }),
                ack(
                    20,
                    Ack::MotionProfile {
                        param: 2,
                        value: 50
                    }
                ),
                error(20, 0x33, 0x22, 2),
                error(20, 0x33, 0x22, 2),
            ]
            .join(" ")
        );
        assert!(!gateway.unit(19).unwrap().moving, "no motion");
        // PV=N while moving (here a point-to-point move); MP[1] during a PVT run.
        // (At the instant BG starts the move the ball is still at rest.)
        gateway.receive(0, b"SP=1000;PA=5000;BG;");
        sent(&mut gateway);
        gateway.receive(100_000, b"PV=50;");
        assert_eq!(sent(&mut gateway), error(20, 0x3D, 0x23, 0));
        gateway.receive(6_000_000, b"MP[2]=60;QP[50]=5000;QT[50]=10;QP[51]=5000;");
        gateway.receive(6_000_000, b"QV[51]=0;QT[51]=100;PV=50;BG;");
        sent(&mut gateway);
        gateway.receive(6_050_000, b"MP[1]=20;MP[5]=1;");
        assert_eq!(
            sent(&mut gateway),
            format!(
                "{} {}",
                error(20, 0x3D, 0x22, 1),
                ack(20, Ack::MotionProfile { param: 5, value: 1 })
            )
        );
        // After `*0;` refusals are as silent as the sets they refuse.
        gateway.receive(6_000_000, b"*0;QT[3]=0;BG;MP[7]=1;");
        assert_eq!(sent(&mut gateway), "");
        gateway.receive(6_000_000, b"HELLO;");
        assert_eq!(
            sent(&mut gateway),
            "F0 00 0F 32 00 00 E0",
            "the gateway's own"
        );
    }

    #[test]
    fn a_trapezoid_has_the_right_times_and_peak_speed() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        gateway.receive(0, b"*1;MO=1;SP=20000;PA=100000;");
        sent(&mut gateway);
        gateway.receive(1_000_000, b"BG;");
        // 400000 counts/s²: 50 ms and 500 counts to 20000 counts/s, 4.95 s cruising.
        assert_eq!(gateway.next_event_us(), Some(6_050_000));
        let mut peak: f64 = 0.0;
        for ms in 1000..=6050 {
            gateway.advance(ms * 1000);
            let unit = gateway.unit(0).unwrap();
            peak = peak.max(unit.velocity_counts_s);
            let tau = (ms - 1000) as f64 / 1000.0;
            let expected = if tau <= 0.05 {
                0.5 * 400_000.0 * tau * tau
            } else if tau <= 5.0 {
                500.0 + 20_000.0 * (tau - 0.05)
            } else {
                let rest = 5.05 - tau;
                100_000.0 - 0.5 * 400_000.0 * rest * rest
            };
            assert!(
                (unit.position_counts - expected).abs() < 1e-6,
                "{ms} ms: {} vs {expected}",
                unit.position_counts
            );
            assert_eq!(unit.moving, ms < 6050, "{ms} ms");
        }
        assert!((peak - 20_000.0).abs() < 1e-9, "{peak}");
        assert_eq!(position(&gateway, 0), 100_000.0);
        assert_eq!(gateway.next_event_us(), None);
        // One move counted, and a BG to where the ball is already moves it nowhere.
        assert_eq!(gateway.unit(0).unwrap().ptp_moves, 1);
        gateway.receive(6_100_000, b"BG;");
        gateway.advance(6_200_000);
        assert_eq!(
            gateway.unit(0).unwrap().ptp_moves,
            1,
            "no move, none counted"
        );
        // Asked for more than the unit can: the top speed, 200000 counts/s.
        gateway.receive(7_000_000, b"SP=2000000000;PA=0;BG;");
        gateway.advance(7_500_000);
        assert_eq!(gateway.unit(0).unwrap().velocity_counts_s, -200_000.0);
        assert_eq!(gateway.unit(0).unwrap().ptp_moves, 2);
    }

    #[test]
    fn the_ball_stops_at_the_upper_limit_and_the_end_of_the_travel() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        gateway.receive(0, b"*1;MO=1;SP=100000;PA=2000000000;BG;");
        gateway.advance(20_000_000);
        assert_eq!(position(&gateway, 0), 750_000.0, "the end of the travel");
        gateway.receive(20_000_000, b"PA=-5000;BG;");
        let mut lowest = f64::MAX;
        for ms in 20_000..30_000 {
            gateway.advance(ms * 1000);
            lowest = lowest.min(position(&gateway, 0));
        }
        assert_eq!((lowest, position(&gateway, 0)), (0.0, 0.0));
        gateway.receive(30_000_000, b"PA;");
        let answers = feedback(&mut gateway);
        assert_eq!(
            answers.last(),
            Some(&(1, Feedback::Ack(Ack::PtpPosition { position_counts: 0 })))
        );
        // A PVT row that would rise above the top: the switch stops the ball at 0,
        // the unit says so (ER LIMIT, QT, row) and stays enabled.
        gateway.receive(30_000_000, b"SP=10000;PA=1000;BG;");
        gateway.advance(31_000_000);
        gateway.receive(31_000_000, b"QP[0]=-1000;QV[0]=0;QT[0]=200;PV=0;BG;");
        sent(&mut gateway);
        // p(t) = 1000 - 2000 (3s² - 2s³): 0 at s = 0.5, 100 ms into the row.
        assert_eq!(gateway.next_event_us(), Some(31_100_000));
        gateway.advance(31_099_999);
        assert!(position(&gateway, 0) > 0.0);
        assert_eq!(sent(&mut gateway), "");
        gateway.advance(31_100_000);
        assert_eq!(sent(&mut gateway), error(1, 0x41, 0x27, 0));
        gateway.advance(32_000_000);
        let unit = gateway.unit(0).unwrap();
        assert_eq!((unit.position_counts, unit.moving), (0.0, false));
        assert!(unit.motor_on);
    }

    #[test]
    fn motor_off_stops_every_ball_at_once_and_cancels_timed_starts() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(3)).unwrap();
        gateway.receive(0, b"*0;MO=1;SP=50000;PA=500000;*1;BG;*2;BG;*3;BG=9000000;");
        sent(&mut gateway);
        gateway.advance(2_000_000);
        let before: Vec<f64> = (0..3).map(|unit| position(&gateway, unit)).collect();
        assert!(before[0] > 0.0 && before[0] == before[1] && before[2] == 0.0);
        gateway.receive(2_000_000, b"*0;MO=0;");
        gateway.advance(20_000_000);
        for (unit, &at) in before.iter().enumerate() {
            let view = gateway.unit(unit).unwrap();
            assert_eq!(
                (view.position_counts, view.velocity_counts_s, view.moving),
                (at, 0.0, false)
            );
            assert!(!view.motor_on);
        }
        assert_eq!(gateway.next_event_us(), None, "the timed BG is gone");
        assert_eq!(sent(&mut gateway), "");
    }

    #[test]
    fn bg_n_starts_when_the_system_time_reaches_n() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(2)).unwrap();
        gateway.receive(0, b"*0;MO=1;SP=10000;PA=10000;*1;BG=2000000;");
        assert_eq!(sent(&mut gateway), ack(1, Ack::Begin { at_us: 2_000_000 }));
        assert_eq!(gateway.next_event_us(), Some(2_000_000));
        gateway.advance(1_999_999);
        assert!(!gateway.unit(0).unwrap().moving);
        gateway.advance(2_000_000);
        assert!(gateway.unit(0).unwrap().moving);
        gateway.advance(2_010_000);
        // 10 ms at 400000 counts/s² from rest: 20 counts.
        assert!((position(&gateway, 0) - 20.0).abs() < 1e-9);
        // The system time is 32-bit: near the wrap, a small N is after the wrap.
        let wrap = 1_u64 << 32;
        gateway.advance(wrap - 1000);
        assert_eq!(gateway.system_time_us(), u32::MAX - 999);
        gateway.receive(wrap - 1000, b"*2;BG=500;");
        assert_eq!(gateway.next_event_us(), Some(wrap + 500));
        // BG=N with N the current system time starts at once.
        let now = gateway.system_time_us();
        gateway.receive(wrap - 1000, format!("*1;PA=0;BG={now};").as_bytes());
        assert!(gateway.unit(0).unwrap().moving);
    }

    #[test]
    fn a_timed_bg_whose_parameters_went_wrong_reports_when_its_time_comes() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        gateway.receive(
            0,
            b"*1;MO=1;MP[3]=1;MP[1]=0;MP[2]=1;QT[0]=10;QT[1]=10;PV=0;",
        );
        sent(&mut gateway);
        gateway.receive(0, b"BG=1000;MP[1]=5;");
        assert_eq!(
            sent(&mut gateway),
            format!(
                "{} {}",
                ack(1, Ack::Begin { at_us: 1000 }),
                ack(1, Ack::MotionProfile { param: 1, value: 5 })
            )
        );
        gateway.advance(1000);
        assert_eq!(sent(&mut gateway), error(1, 0x33, 0x22, 2), "sent unasked");
        assert!(!gateway.unit(0).unwrap().moving);
    }

    #[test]
    fn a_point_to_point_move_takes_over_a_pvt_run_at_once() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        // FIFO rows up to a steady 10000 counts/s; PA=0;BG; in the middle of the second.
        gateway.receive(0, b"*1;MO=1;SP=5000;QP[0]=1000;QV[0]=10000;QT[0]=200;");
        gateway.receive(0, b"QP[1]=2000;QV[1]=10000;QT[1]=100;PV=0;BG;");
        sent(&mut gateway);
        gateway.advance(250_000);
        let at = gateway.unit(0).unwrap();
        assert!((at.velocity_counts_s - 10_000.0).abs() < 1e-6, "{at:?}");
        gateway.receive(250_000, b"PA=0;BG;PV;");
        assert_eq!(
            sent(&mut gateway),
            [
                ack(1, Ack::PtpPosition { position_counts: 0 }),
                ack(1, Ack::Begin { at_us: 0 }),
                ack(1, Ack::PvtStart { value: 0 }),
            ]
            .join(" ")
        );
        // It brakes from 10000 counts/s, comes back at SP and stops at 0.
        let trapezoid = Trapezoid::new(at.position_counts, 10_000.0, 0.0, 5000.0, 400_000.0);
        assert_eq!(trapezoid.pieces().len(), 4);
        for ms in 250..1000 {
            gateway.advance(ms * 1000);
            let tau = (ms - 250) as f64 / 1000.0;
            assert!(
                (position(&gateway, 0) - trapezoid.kinematics(tau).position).abs() < 1e-6,
                "{ms} ms"
            );
        }
        assert_eq!(sent(&mut gateway), "", "the PVT run ended silently");
    }

    #[test]
    fn braking_after_a_run_never_exceeds_the_top_acceleration() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        gateway.receive(
            0,
            b"*1;MO=1;SD=4000000000;QP[0]=1000;QV[0]=20000;QT[0]=100;PV=0;BG;",
        );
        gateway.advance(100_000);
        // 20000 counts/s at the top acceleration, 400000 counts/s²: 50 ms, 500 counts.
        gateway.advance(125_000);
        let braking = gateway.unit(0).unwrap();
        assert!((braking.velocity_counts_s - 10_000.0).abs() < 1e-6);
        gateway.advance(150_000);
        let stopped = gateway.unit(0).unwrap();
        assert!((stopped.position_counts - 1500.0).abs() < 1e-6);
        assert!(!stopped.moving);
    }

    #[test]
    fn a_global_bg_starts_every_unit_in_the_same_microsecond() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(5)).unwrap();
        gateway.receive(0, b"*0;MO=1;MP[3]=0;QP[0]=500;QV[0]=0;QT[0]=100;PV=0;");
        gateway.receive(123_457, b"*0;BG;");
        gateway.advance(173_457);
        let halfway: Vec<f64> = gateway.units().map(|unit| unit.position_counts).collect();
        assert!(halfway.iter().all(|&p| p == 250.0), "{halfway:?}");
        assert_eq!(gateway.next_event_us(), Some(223_457));
        assert_eq!(sent(&mut gateway), "", "a broadcast set is silent");
    }

    #[test]
    fn a_row_beyond_the_units_limits_faults_it() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(1)).unwrap();
        // 100000 counts in 100 ms from rest: 1.5e6 counts/s peak, 6e7 counts/s².
        gateway.receive(
            0,
            b"*1;MO=1;IE[5]=1;MP[5]=1;QP[0]=100000;QV[0]=0;QT[0]=100;",
        );
        gateway.receive(0, b"QP[1]=0;QV[1]=0;QT[1]=100;PV=0;BG;");
        let answers = sent(&mut gateway);
        assert!(
            answers.ends_with(&format!(
                "{} {}",
                ack(1, Ack::Begin { at_us: 0 }),
                error(1, 0x40, 0x27, 0)
            )),
            "{answers}"
        );
        let unit = gateway.unit(0).unwrap();
        assert_eq!(
            (unit.position_counts, unit.moving, unit.motor_on),
            (0.0, false, false)
        );
        // The unit needs MO=1 again.
        gateway.receive(1000, b"PV=1;BG;");
        assert!(sent(&mut gateway).ends_with(&error(1, 0x3E, 0x16, 0)));
    }

    #[test]
    fn the_watermark_notice_is_sent_three_times_only_when_enabled() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(2)).unwrap();
        let rows: String = (0..4)
            .map(|row| format!("QP[{row}]=0;QV[{row}]=0;QT[{row}]=10;"))
            .collect();
        gateway.receive(0, format!("*0;MO=1;MP[5]=1;{rows}*2;IE[5]=0;").as_bytes());
        sent(&mut gateway);
        gateway.receive(0, b"*0;PV=0;BG;");
        gateway.advance(19_999);
        assert_eq!(sent(&mut gateway), "");
        // Row 2 starts at 20 ms with one row left.
        gateway.advance(20_000);
        let notices = feedback(&mut gateway);
        assert_eq!(
            notices,
            [(1, Feedback::Notification(Notification::PVT_WATERMARK)); 3]
        );
        assert_eq!(sent(&mut gateway), "");
        // A FIFO run that drains ends; PV; answers the water level.
        gateway.advance(40_000);
        gateway.receive(40_000, b"*1;PV;");
        assert_eq!(sent(&mut gateway), ack(1, Ack::PvtStart { value: 0 }));
        assert!(!gateway.unit(0).unwrap().moving);
    }

    #[test]
    fn a_disconnected_unit_stays_silent_and_reconnects() {
        let mut config = GatewayConfig::numbered(3);
        config.faults.disconnected.push(1);
        let mut gateway = Gateway::new(config).unwrap();
        gateway.receive(0, b"*2;MO=1;MO;*0;SN;");
        let answers = feedback(&mut gateway);
        assert_eq!(
            answers
                .iter()
                .map(|&(station, _)| station)
                .collect::<Vec<_>>(),
            [1, 3]
        );
        assert!(!gateway.unit(1).unwrap().motor_on, "it received nothing");
        gateway.set_connected(1, true).unwrap();
        gateway.receive(1, b"*2;MO;");
        assert_eq!(sent(&mut gateway), ack(2, Ack::Motor { on: false }));
        assert_eq!(gateway.set_connected(3, true), Err(NoSuchUnit { unit: 3 }));
    }

    #[test]
    fn a_garbled_byte_is_garbled_and_the_decoder_notices_a_high_bit() {
        let mut config = GatewayConfig::numbered(1);
        // The first frame's data byte: bit 7 set, which a data byte never has.
        config.faults.garbled_output.push(Garble {
            byte: 3,
            xor_mask: 0x80,
        });
        let mut gateway = Gateway::new(config).unwrap();
        // And the second frame's data byte: a low bit, which nothing can notice.
        gateway.garble_output(Garble {
            byte: 8,
            xor_mask: 0x01,
        });
        gateway.receive(0, b"*1;MO=1;MO=1;MO=1;");
        let mut bytes = Vec::new();
        gateway.poll_output(&mut bytes);
        assert_eq!(hex(&bytes), "F0 01 15 81 E0 F0 01 15 00 E0 F0 01 15 01 E0");
        let mut decoder = FrameDecoder::new();
        let frames: Vec<_> = decoder.push(&bytes).collect();
        assert_eq!(
            decoder.stats().dropped_bytes,
            5,
            "the first frame is dropped"
        );
        let meaning: Vec<_> = frames
            .iter()
            .map(|f| Feedback::from_frame(f).unwrap())
            .collect();
        assert_eq!(
            meaning,
            [
                Feedback::Ack(Ack::Motor { on: false }),
                Feedback::Ack(Ack::Motor { on: true })
            ]
        );
    }

    #[test]
    fn the_units_are_what_the_api_serves() {
        let mut gateway = Gateway::new(GatewayConfig::numbered(2)).unwrap();
        gateway.receive(5, b"*2;MO=1;");
        let positions = gateway.positions(3);
        assert_eq!((positions.gateway, positions.time_us), (3, 5));
        assert_eq!(positions.units.len(), 2);
        let unit = gateway.unit(1).unwrap();
        assert_eq!(
            positions.units[1],
            SimUnit {
                station: 2,
                serial: unit.serial,
                position_counts: 0.0,
                velocity_counts_s: 0.0,
                motor_on: true,
                moving: false,
                ptp_moves: 0,
            }
        );
        assert_eq!(positions.units[1], unit);
        assert_eq!(gateway.unit(2), None);
        assert_eq!(gateway.now_us(), 5);
        gateway.advance(1);
        assert_eq!(gateway.now_us(), 5, "time never goes back");
        assert_eq!(
            NoSuchUnit { unit: 7 }.to_string(),
            "there is no unit 7 on this gateway"
        );
    }

    #[test]
    fn the_same_inputs_give_the_same_bytes() {
        let run = || {
            let mut config = GatewayConfig::factory_fresh(4);
            config.seed = 9;
            let mut gateway = Gateway::new(config).unwrap();
            gateway.receive(0, b"*0;SN;MO=1;MP[5]=2;QP[0]=5;QT[0]=10;QT[1]=10;QT[2]=10;");
            gateway.receive(7, b"*0;PV=0;BG;PV;");
            gateway.advance(100_000);
            let mut bytes = Vec::new();
            gateway.poll_output(&mut bytes);
            bytes
        };
        let first = run();
        // Four serials (12 bytes each), one water level (the four units' answers are
        // the same frame), four units' notices at the first row (three of 5 bytes).
        assert_eq!(first.len(), 4 * 12 + 6 + 4 * 3 * 5);
        assert_eq!(first, run());
    }
}

#[cfg(all(test, not(target_arch = "wasm32")))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    /// A session's worth of text: setup, rows, motion, queries, errors and garbage.
    const SCRIPT: &str = "*0;SN;*3;MO=1;MP[3]=0;MP[5]=2;MP[0]=1;\
        QP[0]=1000;QV[0]=0;QT[0]=100;QP[1]=4000;QV[1]=500;QT[1]=100;\
        QP[2]=3000;QV[2]=0;QT[2]=100;PV;SP=1000;PA=1000;BG;PA;\
        QT[3]=0;MP[7]=1;HELLO;*1;MO=1;PA=500;BG=100;*0;PV=0;MO;\
        *2;SN[9]=1234;QP[1];  qv [ 1 ] : -9000 ;IE[5]=0;*9;MO;";

    proptest! {
        /// Bytes split anywhere, even inside instructions, give the same output as one
        /// chunk.
        #[test]
        fn chunking_does_not_change_the_output(
            cuts in proptest::collection::vec(any::<prop::sample::Index>(), 0..30),
        ) {
            let bytes = SCRIPT.as_bytes();
            let mut whole = Gateway::new(GatewayConfig::numbered(9)).unwrap();
            whole.receive(1000, bytes);
            let mut expected = Vec::new();
            whole.poll_output(&mut expected);

            let mut cuts: Vec<usize> = cuts.iter().map(|cut| cut.index(bytes.len() + 1)).collect();
            cuts.sort_unstable();
            let mut chunked = Gateway::new(GatewayConfig::numbered(9)).unwrap();
            let mut from = 0;
            for cut in cuts.into_iter().chain([bytes.len()]) {
                chunked.receive(1000, &bytes[from..cut]);
                from = cut;
            }
            let mut output = Vec::new();
            chunked.poll_output(&mut output);
            prop_assert_eq!(output, expected);
        }

        /// No bytes make the gateway panic, and every output byte decodes (a feedback
        /// frame or a greeting's answer).
        #[test]
        fn any_bytes_are_survived(
            bytes in proptest::collection::vec(
                prop_oneof![any::<u8>(), Just(b';'), b'A'..=b'Z', b'0'..=b'9'],
                0..400,
            ),
            step_us in 0..50_000_u64,
        ) {
            let mut gateway = Gateway::new(GatewayConfig::numbered(4)).unwrap();
            gateway.receive(0, b"*0;MO=1;");
            for (i, chunk) in bytes.chunks(7).enumerate() {
                gateway.receive(i as u64 * step_us, chunk);
            }
            gateway.advance(10_000_000);
            let mut output = Vec::new();
            gateway.poll_output(&mut output);
            // Feedback frames, and the greeting's answer for every `ABC;` among the
            // bytes (it is no frame: the decoder skips it as noise).
            let mut decoder = crate::uim2503::feedback::FrameDecoder::new();
            let decoded: usize = decoder.push(&output).map(|f| f.encoded_len()).sum();
            let greetings = crate::uim2503::ascii::gateway::GreetingWatch::new().push(&output);
            prop_assert_eq!(decoded + greetings * GREETING_ANSWER.len(), output.len());
            for unit in gateway.units() {
                prop_assert!((0.0..=750_000.0).contains(&unit.position_counts));
                prop_assert!(unit.velocity_counts_s.abs() <= 200_000.0 * (1.0 + 1e-9));
            }
        }
    }
}
