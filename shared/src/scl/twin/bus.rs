//! Drives on one RS-485 line, and the start wire: every drive hears every line, the
//! one it is addressed to answers (after its address), and one drive's output wired to
//! an input of every drive carries a level change to all of them at the same instant.

use super::drive::{Drive, EPSILON_S};
use crate::scl::CR;
use crate::scl::command::{Address, IoPoint, Level};

/// One drive's output wired to the same input of every drive on the bus (itself too):
/// how a show's common start reaches every drive at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StartWire {
    /// The drive whose output drives the wire.
    pub from: Address,
    /// Its output.
    pub output: IoPoint,
    /// The input it drives on every drive.
    pub input: IoPoint,
}

/// Drives sharing one line (and the wires between them).
#[derive(Debug, Clone)]
pub struct Bus {
    drives: Vec<Drive>,
    wires: Vec<StartWire>,
    /// Bytes of a line not yet ended by CR.
    pending: Vec<u8>,
}

/// The longest line kept while waiting for its CR; longer ones are dropped (no drive
/// line is this long).
const MAX_LINE_BYTES: usize = 256;
/// How often wires settle at one instant before the bus stops following them (two
/// drives wired to each other's inputs could otherwise toggle for ever).
const MAX_SETTLE_ROUNDS: usize = 64;

impl Bus {
    /// A bus of `drives` (give each its own address for RS-485).
    #[must_use]
    pub fn new(drives: Vec<Drive>) -> Self {
        Self {
            drives,
            wires: Vec::new(),
            pending: Vec::new(),
        }
    }

    /// Wires `wire.output` of the drive at `wire.from` to `wire.input` of every drive;
    /// the input takes the output's level at once.
    pub fn wire(&mut self, wire: StartWire) {
        self.wires.push(wire);
        self.settle();
    }

    /// The wires.
    #[must_use]
    pub fn wires(&self) -> &[StartWire] {
        &self.wires
    }

    /// The drives.
    #[must_use]
    pub fn drives(&self) -> &[Drive] {
        &self.drives
    }

    /// The drives, to change (an input, a configuration).
    pub fn drives_mut(&mut self) -> &mut [Drive] {
        &mut self.drives
    }

    /// The index of the drive at `address`: the drive with that address, or — drives
    /// without addresses (eSCL, one socket each) — the drive whose index is the
    /// address's place in [`Address::CHARACTERS`] (`'0'` the first).
    #[must_use]
    pub fn index_of(&self, address: Address) -> Option<usize> {
        self.drives
            .iter()
            .position(|d| d.address() == Some(address))
            .or_else(|| {
                Address::CHARACTERS
                    .chars()
                    .position(|c| c == address.character())
                    .filter(|&i| self.drives.get(i).is_some_and(|d| d.address().is_none()))
            })
    }

    /// The drive at `address` (see [`Bus::index_of`]).
    #[must_use]
    pub fn drive(&self, address: Address) -> Option<&Drive> {
        self.index_of(address).and_then(|i| self.drives.get(i))
    }

    /// One eSCL datagram for the drive at `index` at `now_us`: its answer datagrams
    /// (see [`Drive::receive_escl`]); the wires settle after it, as on a line.
    pub fn receive_escl(&mut self, index: usize, datagram: &[u8], now_us: u64) -> Vec<Vec<u8>> {
        self.advance(now_us);
        let answers = self
            .drives
            .get_mut(index)
            .map(|drive| drive.receive_escl(datagram, now_us))
            .unwrap_or_default();
        self.settle();
        answers
    }

    /// Bytes from the line at `now_us` (lines end with CR; a partial line waits for the
    /// rest): every drive hears every line; the answers, in the drives' order, as they
    /// go back on the line.
    pub fn receive(&mut self, bytes: &[u8], now_us: u64) -> Vec<u8> {
        self.advance(now_us);
        let mut answers = Vec::new();
        for &byte in bytes {
            if byte == CR {
                let line = String::from_utf8_lossy(&self.pending).into_owned();
                self.pending.clear();
                answers.extend(self.receive_line(&line, now_us).into_bytes());
            } else if byte != b'\n' {
                if self.pending.len() >= MAX_LINE_BYTES {
                    self.pending.clear();
                }
                self.pending.push(byte);
            }
        }
        answers
    }

    /// One line (without its CR) at `now_us`: the answers of the drives it is for.
    pub fn receive_line(&mut self, line: &str, now_us: u64) -> String {
        self.advance(now_us);
        let mut answers = String::new();
        for drive in &mut self.drives {
            if let Some(answer) = drive.receive_line(line, now_us) {
                answers.push_str(&answer);
            }
        }
        self.settle();
        answers
    }

    /// Runs every drive to `now_us`, event by event, so that an output one drive sets
    /// reaches the wired inputs at the instant it is set.
    pub fn advance(&mut self, now_us: u64) {
        #[allow(clippy::cast_precision_loss)]
        let now_s = now_us as f64 / 1e6;
        loop {
            let next = self
                .drives
                .iter()
                .filter_map(Drive::next_event_s)
                .fold(f64::INFINITY, f64::min);
            if next > now_s + EPSILON_S || next.is_nan() {
                break;
            }
            for drive in &mut self.drives {
                drive.advance_to(next);
            }
            self.settle();
        }
        for drive in &mut self.drives {
            drive.advance_to(now_s);
        }
        self.settle();
    }

    /// Carries every wired output's level to its inputs, until nothing changes.
    fn settle(&mut self) {
        for _ in 0..MAX_SETTLE_ROUNDS {
            let mut changed = false;
            for wire in &self.wires {
                let Some(level) = self
                    .index_of(wire.from)
                    .and_then(|i| self.drives.get(i))
                    .map(|d| d.output(wire.output))
                else {
                    continue;
                };
                for drive in &mut self.drives {
                    if drive.input(wire.input) != level {
                        drive.set_input_now(wire.input, level);
                        changed = true;
                    }
                }
            }
            if !changed {
                return;
            }
        }
    }

    /// Sets an input on every drive at `now_us` (a sensor or switch shared by all).
    pub fn set_input(&mut self, input: IoPoint, level: Level, now_us: u64) {
        self.advance(now_us);
        for drive in &mut self.drives {
            drive.set_input_now(input, level);
        }
        self.settle();
    }
}
