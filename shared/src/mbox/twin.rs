//! A simulated MBOX box (the "digital twin"), sans-IO: datagrams and the time go in,
//! reply datagrams come out, and the axes move in between.
//!
//! - [`MboxTwin::receive`] takes one UDP datagram at a time `now_us` and returns the
//!   box's reply, if the datagram asks this box for one (only register reads have a
//!   reply the document defines, `0x1102`).
//! - [`MboxTwin::advance`] lets time pass; positions are computed from the time, so
//!   nothing happens between datagrams but the axes moving.
//! - [`MboxTwin::snapshot`] shows the box as a [`SimBox`]: positions, targets, e-stop,
//!   effects and counters, for the bridge's `GET /api/sim/positions`.
//! - [`MboxTwin::power_cycle`] restarts the box: FN parameters written "not saved" are
//!   lost, the saved ones (and a saved new IP address) take effect.
//!
//! What the twin does where the document is silent (the interpolation, early and late
//! frames, reset, which datagrams get a reply) is in `docs/protocol-notes.md`, "MBOX
//! (UDP)", "The twin". Nothing here reads a clock: time is µs since the twin started.
//!
//! # Example
//! ```
//! use floatball_shared::mbox::twin::{MboxTwin, TwinConfig};
//! use floatball_shared::mbox::{
//!     AxisCount, AxisPositions, DigitalOutputs, Encode, MotionFrame, Route, TimeCode, TimeMode,
//! };
//!
//! let mut twin = MboxTwin::new(TwinConfig::default());
//! let frame = MotionFrame {
//!     mode: TimeMode::Relative,
//!     route: Route::BROADCAST_SILENT,
//!     sequence: 1,
//!     time_code: TimeCode::from_ms(100),
//!     positions_pulses: AxisPositions::uniform(AxisCount::Ten, 50_000),
//!     digital: DigitalOutputs::NONE,
//!     analog: [0, 0],
//! };
//! assert_eq!(twin.receive(0, &frame.encode()), None);
//! twin.advance(50_000);
//! assert_eq!(twin.positions_pulses()[0], 25_000);
//! twin.advance(100_000);
//! assert_eq!(twin.positions_pulses(), vec![50_000; 10]);
//! ```

use std::collections::BTreeMap;
use std::net::Ipv4Addr;

use crate::api::{SimBox, SimBoxCounters, SimMalformed};

use super::motion::BOX_DEFAULT_FRAME_MS;
use super::register::{CX_EFFECTS, CX_PLAY_CONTROL, FN_ESTOP, FN_IP};
use super::{
    AxisCount, BoxAddress, Datagram, DecodeError, DigitalOutputs, Encode, FACTORY_IP, MotionFrame,
    ReadBank, RegisterBlock, RegisterRead, RegisterReply, RegisterWrite, Route, TimeCode, TimeMode,
    WriteBank,
};

/// How fast a reset brings the axes home, pulses/s (the document gives no speed:
/// 10 motor revolutions a second at the factory 10 000 pulses a revolution).
pub const RESET_PULSES_PER_S: u64 = 100_000;

/// A twin's hardware: its IP address and how many axes it drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TwinConfig {
    /// Its IP address at power-on (its address in datagrams is the last two octets).
    pub ip: Ipv4Addr,
    /// 3, 6 or 10 axes.
    pub axes: AxisCount,
    /// The frame time it takes for a time code of 0 ("internal time", 100 ms).
    pub default_frame_ms: u32,
}

impl TwinConfig {
    /// A box at `ip` with `axes` axes and the factory frame time.
    #[must_use]
    pub const fn new(ip: Ipv4Addr, axes: AxisCount) -> Self {
        Self {
            ip,
            axes,
            default_frame_ms: BOX_DEFAULT_FRAME_MS,
        }
    }
}

impl Default for TwinConfig {
    /// A factory-fresh 10-axis box at 192.168.15.201.
    fn default() -> Self {
        Self::new(FACTORY_IP, AxisCount::Ten)
    }
}

/// One axis's move: linear from `from` at `start_us` to `to` at `end_us`, then at rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Axis {
    from: i32,
    to: i32,
    start_us: u64,
    end_us: u64,
}

impl Axis {
    /// At rest at `pulses`.
    const fn at_rest(pulses: i32) -> Self {
        Self {
            from: pulses,
            to: pulses,
            start_us: 0,
            end_us: 0,
        }
    }

    /// Where the axis is at `now_us` (rounded towards `from`).
    fn position(&self, now_us: u64) -> i32 {
        if now_us >= self.end_us {
            return self.to;
        }
        if now_us <= self.start_us {
            return self.from;
        }
        let span = i128::from(self.end_us - self.start_us);
        let elapsed = i128::from(now_us - self.start_us);
        let travel = i128::from(self.to) - i128::from(self.from);
        let pulses = i128::from(self.from) + travel * elapsed / span;
        // Between `from` and `to`, so it fits.
        i32::try_from(pulses).unwrap_or(self.to)
    }

    /// From where it is at `now_us` to `target` over `duration_us`.
    fn retarget(&mut self, now_us: u64, target: i32, duration_us: u64) {
        *self = Self {
            from: self.position(now_us),
            to: target,
            start_us: now_us,
            end_us: now_us.saturating_add(duration_us),
        };
    }
}

/// A simulated MBOX; see the [module documentation](self).
#[derive(Debug, Clone)]
pub struct MboxTwin {
    config: TwinConfig,
    /// Its address in datagrams: from the IP it powered on with.
    address: BoxAddress,
    now_us: u64,
    axes: Vec<Axis>,
    /// DN parameters (read only over UDP; the document names none, all read 0).
    dn: BTreeMap<u16, u16>,
    /// FN parameters in effect.
    fn_live: BTreeMap<u16, u16>,
    /// FN parameters as saved: what the box powers on with.
    fn_saved: BTreeMap<u16, u16>,
    /// CX command registers (0 at power-on).
    cx: BTreeMap<u16, u16>,
    /// The last absolute frame's time code, the start of the next absolute frame.
    last_time_code: Option<u32>,
    /// The last non-zero sequence number.
    last_sequence: Option<u32>,
    digital: DigitalOutputs,
    analog: [u16; 2],
    counters: SimBoxCounters,
}

impl MboxTwin {
    /// A box at power-on: every axis at 0, every register 0 but its IP (FN020–FN023).
    #[must_use]
    pub fn new(config: TwinConfig) -> Self {
        let fn_saved: BTreeMap<u16, u16> =
            (FN_IP..).zip(config.ip.octets().map(u16::from)).collect();
        Self {
            config,
            address: BoxAddress::of_ip(config.ip),
            now_us: 0,
            axes: vec![Axis::at_rest(0); config.axes.count()],
            dn: BTreeMap::new(),
            fn_live: fn_saved.clone(),
            fn_saved,
            cx: BTreeMap::new(),
            last_time_code: None,
            last_sequence: None,
            digital: DigitalOutputs::NONE,
            analog: [0, 0],
            counters: SimBoxCounters::default(),
        }
    }

    /// Its address in datagrams.
    #[must_use]
    pub const fn address(&self) -> BoxAddress {
        self.address
    }

    /// The twin's clock, µs.
    #[must_use]
    pub const fn now_us(&self) -> u64 {
        self.now_us
    }

    /// Lets time pass up to `now_us` (time never goes back).
    pub fn advance(&mut self, now_us: u64) {
        self.now_us = self.now_us.max(now_us);
    }

    /// When the last moving axis reaches its target, if any axis is moving.
    #[must_use]
    pub fn next_event_us(&self) -> Option<u64> {
        self.axes
            .iter()
            .map(|axis| axis.end_us)
            .filter(|&end| end > self.now_us)
            .max()
    }

    /// Every axis's position now, pulses, axis 1 first.
    #[must_use]
    pub fn positions_pulses(&self) -> Vec<i32> {
        self.axes
            .iter()
            .map(|axis| axis.position(self.now_us))
            .collect()
    }

    /// Whether the e-stop is engaged (FN `0x0090` ≠ 0).
    #[must_use]
    pub fn estopped(&self) -> bool {
        self.fn_live.get(&FN_ESTOP).is_some_and(|&value| value != 0)
    }

    /// An FN parameter in effect.
    #[must_use]
    pub fn fn_parameter(&self, address: u16) -> u16 {
        self.fn_live.get(&address).copied().unwrap_or(0)
    }

    /// A CX command register.
    #[must_use]
    pub fn cx_register(&self, address: u16) -> u16 {
        self.cx.get(&address).copied().unwrap_or(0)
    }

    /// Its IP address as saved (FN020–FN023): the address it powers on with.
    #[must_use]
    pub fn saved_ip(&self) -> Ipv4Addr {
        let octet = |index: u16| {
            let value = self.fn_saved.get(&(FN_IP + index)).copied().unwrap_or(0);
            u8::try_from(value).unwrap_or(u8::MAX)
        };
        Ipv4Addr::new(octet(0), octet(1), octet(2), octet(3))
    }

    /// What it received so far.
    #[must_use]
    pub const fn counters(&self) -> &SimBoxCounters {
        &self.counters
    }

    /// The box now, for `GET /api/sim/positions`.
    #[must_use]
    pub fn snapshot(&self) -> SimBox {
        SimBox {
            address: self.address.0,
            ip: self.saved_ip().to_string(),
            time_us: self.now_us,
            positions_pulses: self.positions_pulses(),
            targets_pulses: self.axes.iter().map(|axis| axis.to).collect(),
            moving: self.next_event_us().is_some(),
            estop: self.estopped(),
            play_control: self.cx_register(CX_PLAY_CONTROL),
            effects_mask: self.cx_register(CX_EFFECTS),
            digital: self.digital.bits(),
            analog: self.analog,
            counters: self.counters,
        }
    }

    /// Switches the box off and on at `now_us`: the axes stop where they are, FN
    /// parameters are the saved ones again (a saved e-stop stays engaged; a saved IP
    /// address becomes its address), CX registers, outputs, the time code and the
    /// sequence start over. The counters are the twin's, and are kept.
    pub fn power_cycle(&mut self, now_us: u64) {
        self.advance(now_us);
        self.stop_axes();
        self.fn_live = self.fn_saved.clone();
        self.cx.clear();
        self.address = BoxAddress::of_ip(self.saved_ip());
        self.last_time_code = None;
        self.last_sequence = None;
        self.digital = DigitalOutputs::NONE;
        self.analog = [0, 0];
    }

    /// Takes one datagram at `now_us`; returns the reply the box sends to its sender,
    /// if any.
    pub fn receive(&mut self, now_us: u64, bytes: &[u8]) -> Option<Vec<u8>> {
        self.advance(now_us);
        self.counters.datagrams += 1;
        let datagram = match Datagram::decode(bytes) {
            Ok(datagram) => datagram,
            Err(error) => {
                count_malformed(&mut self.counters.malformed, error);
                return None;
            }
        };
        let route = match &datagram {
            Datagram::ReadReply(_) => {
                self.counters.unexpected += 1;
                return None;
            }
            Datagram::Motion(frame) => frame.route,
            Datagram::Read(read) => read.route,
            Datagram::Write(write) => write.route,
        };
        if !self.names(route.receiver) {
            self.counters.not_for_this_box += 1;
            return None;
        }
        match datagram {
            Datagram::Motion(frame) => self.motion(&frame),
            Datagram::Write(write) => self.write(&write),
            Datagram::Read(read) => return self.read(&read),
            Datagram::ReadReply(_) => {}
        }
        None
    }

    /// Whether `address` (a receiver or replier) means this box.
    fn names(&self, address: BoxAddress) -> bool {
        address == self.address || address == BoxAddress::ALL
    }

    fn motion(&mut self, frame: &MotionFrame) {
        self.check_sequence(frame.sequence);
        if self.estopped() {
            self.counters.ignored_estop += 1;
            return;
        }
        if frame.positions_pulses.axes() != self.config.axes {
            self.counters.wrong_axes += 1;
            return;
        }
        let duration_ms = self.frame_ms(frame.mode, frame.time_code);
        let duration_us = u64::from(duration_ms) * 1_000;
        let now_us = self.now_us;
        for (axis, &target) in self.axes.iter_mut().zip(frame.positions_pulses.as_slice()) {
            axis.retarget(now_us, target, duration_us);
        }
        self.digital = frame.digital;
        self.analog = frame.analog;
        self.counters.motion_frames += 1;
    }

    /// How long a frame takes, ms: a relative time as it is; an absolute time code
    /// minus the last one; 0, or an absolute frame with no earlier time code or one not
    /// after it, the box's default. An absolute time code not after the last one (a
    /// repeat or a rewind) is counted as a fault (`time_code_faults`): the document
    /// gives such a frame no time to take.
    fn frame_ms(&mut self, mode: TimeMode, time_code: TimeCode) -> u32 {
        let default = self.config.default_frame_ms;
        match (mode, time_code) {
            (_, TimeCode::BoxDefault) => default,
            (TimeMode::Relative, TimeCode::Ms(ms)) => ms.get(),
            (TimeMode::Absolute, TimeCode::Ms(code)) => {
                let Some(previous) = self.last_time_code.replace(code.get()) else {
                    return default;
                };
                match code.get().checked_sub(previous).filter(|&ms| ms > 0) {
                    Some(ms) => ms,
                    None => {
                        self.counters.time_code_faults += 1;
                        default
                    }
                }
            }
        }
    }

    /// Counts gaps and repeats; sequence 0 is "not numbered" (the document allows it)
    /// and is not checked.
    fn check_sequence(&mut self, sequence: u32) {
        if sequence == 0 {
            return;
        }
        if let Some(last) = self.last_sequence.replace(sequence) {
            if sequence <= last {
                self.counters.sequence_repeats += 1;
            } else if sequence - last > 1 {
                self.counters.sequence_gaps += 1;
                self.counters.sequence_skipped += u64::from(sequence - last - 1);
            }
        }
    }

    fn read(&mut self, read: &RegisterRead) -> Option<Vec<u8>> {
        self.counters.register_reads += 1;
        if !self.names(read.route.replier) {
            return None;
        }
        let bank = match read.bank {
            ReadBank::Dn => &self.dn,
            ReadBank::Fn => &self.fn_live,
        };
        let start = read.range.start();
        let values = (0..read.range.count())
            .map(|offset| bank.get(&start.wrapping_add(offset)).copied().unwrap_or(0))
            .collect();
        // A valid range gives a valid block.
        let block = RegisterBlock::new(start, values).ok()?;
        self.counters.replies += 1;
        Some(
            RegisterReply {
                bank: read.bank,
                route: Route::REPLY,
                block,
            }
            .encode(),
        )
    }

    fn write(&mut self, write: &RegisterWrite) {
        self.counters.register_writes += 1;
        let was_estopped = self.estopped();
        let start = write.block.start();
        let registers = (start..).zip(write.block.values().iter().copied());
        match write.bank {
            WriteBank::FnVolatile => self.fn_live.extend(registers),
            WriteBank::FnSaved => {
                for (address, value) in registers {
                    self.fn_live.insert(address, value);
                    self.fn_saved.insert(address, value);
                }
            }
            WriteBank::Cx => {
                self.cx.extend(registers);
                if write.block.get(CX_PLAY_CONTROL) == Some(0) {
                    self.reset();
                }
            }
        }
        if self.estopped() && !was_estopped {
            self.stop_axes();
        }
    }

    /// CX 0 = 0: unless the e-stop holds them, every axis goes back to 0 in a straight
    /// line, all arriving together at [`RESET_PULSES_PER_S`] for the farthest; the
    /// time code and the sequence start over.
    fn reset(&mut self) {
        self.last_time_code = None;
        self.last_sequence = None;
        if self.estopped() {
            return;
        }
        let now_us = self.now_us;
        let farthest = self
            .axes
            .iter()
            .map(|axis| u64::from(axis.position(now_us).unsigned_abs()))
            .max()
            .unwrap_or(0);
        let duration_us = farthest * 1_000_000 / RESET_PULSES_PER_S;
        for axis in &mut self.axes {
            axis.retarget(now_us, 0, duration_us);
        }
    }

    /// Every axis stops where it is now.
    fn stop_axes(&mut self) {
        let now_us = self.now_us;
        for axis in &mut self.axes {
            *axis = Axis::at_rest(axis.position(now_us));
        }
    }
}

/// Counts a refused datagram under its reason.
fn count_malformed(malformed: &mut SimMalformed, error: DecodeError) {
    let counter = match error {
        DecodeError::Truncated { .. } => &mut malformed.truncated,
        DecodeError::BadMagic { .. } => &mut malformed.bad_magic,
        DecodeError::BadPassCode { .. } => &mut malformed.bad_pass_code,
        DecodeError::UnknownFunction { .. } => &mut malformed.unknown_function,
        DecodeError::UnknownChannel { .. } => &mut malformed.unknown_channel,
        DecodeError::MotionLength { .. } => &mut malformed.motion_length,
        DecodeError::RegisterLength { .. } => &mut malformed.register_length,
        DecodeError::Registers { .. } => &mut malformed.registers,
    };
    *counter += 1;
}

#[cfg(test)]
mod tests;
