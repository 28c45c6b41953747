//! One simulated UFQ750: what it does with each instruction, how it moves, and what it
//! answers (manual §7–§8, `docs/protocol-notes.md`).
//!
//! The PVT side is a [`PvtTable`] driven row by row: the unit advances the table to each
//! row's end, so it sees every row start. When a row starts the unit checks it against
//! its physical limits (an overload stops the unit) and finds where, if anywhere, the
//! row leaves the travel (the ball stops there). Point-to-point moves are
//! [`Trapezoid`]s. Everything the unit sends unasked (watermark notices, faults) goes
//! through an [`Outbox`] with its time, for the gateway to put in order.
//!
//! The unit is internal to the simulator; see [`Gateway`](super::Gateway) for an
//! example of the whole.

use crate::motion::{Kinematics, Segment};
use crate::uim2503::ascii::Instruction;
use crate::uim2503::feedback::{Ack, Feedback, Frame, Notification, UnitError, code};
use crate::uim2503::pvt::{Events, PvtError, PvtTable};

use super::config::Limits;
use super::motion;
use super::system_time_us;
use crate::motion::{Trapezoid, braking};

/// The notifications enabled at power-on: `IE[5]` (the PVT watermark), so that the
/// manual's FIFO procedure (§7.4), which never sends `IE[5]=1;`, gets its notices.
/// `MP[5]=0` (also the power-on value) keeps a unit silent.
const INFO_AT_POWER_ON: [u64; 4] = [1 << 5, 0, 0, 0];

/// The notification index of the PVT watermark, `IE[5]`.
const INFO_WATERMARK: u8 = 5;

/// Float noise allowed when a time in seconds becomes whole µs, µs.
const MICROS_SLACK: f64 = 1e-3;

/// Relative slack on the speed and acceleration limits, for float noise only.
const LIMIT_SLACK: f64 = 1e-9;

/// A frame a unit sends unasked, with the time it is sent.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct Timed {
    /// When, µs of gateway time.
    pub at_us: u64,
    /// The unit's index.
    pub unit: usize,
    /// The order of sending within the unit (and the batch).
    pub seq: usize,
    /// The frame.
    pub frame: Frame,
}

/// Where one unit puts the frames it sends unasked.
#[derive(Debug)]
pub(super) struct Outbox<'a> {
    /// The unit's index.
    pub unit: usize,
    /// The gateway's batch of timed frames.
    pub frames: &'a mut Vec<Timed>,
}

impl Outbox<'_> {
    fn send(&mut self, at_us: u64, station: u8, feedback: Feedback) {
        // Stations are 1–127 (checked by the configuration and by SN), so the frame
        // always builds.
        if let Ok(frame) = feedback.to_frame(station) {
            let seq = self.frames.len();
            self.frames.push(Timed {
                at_us,
                unit: self.unit,
                seq,
                frame,
            });
        }
    }
}

/// What `BG` starts: the mode chosen last by `PA=p` (point to point) or `PV=N` (PVT).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum BeginMode {
    Ptp,
    Pvt,
}

/// The ball stops at a limit (0 or the travel) at this time.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Stop {
    at_us: u64,
    position: f64,
}

/// How the ball moves now.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Motion {
    /// Still (brake on, or motor holding).
    Rest { position: f64 },
    /// A point-to-point move started at `start_us`, at rest on its target from `end_us`.
    Ptp {
        start_us: u64,
        end_us: u64,
        trapezoid: Trapezoid,
        stop: Option<Stop>,
    },
    /// The PVT table runs: a row that ends at `row_end_us`, or (`None`) braking with SD
    /// after the last row.
    Pvt {
        row_end_us: Option<u64>,
        stop: Option<Stop>,
        last_row: u8,
    },
}

/// One simulated unit.
#[derive(Debug, Clone)]
pub(super) struct Unit {
    /// Station (CAN id), 1–127.
    pub station: u8,
    /// Serial number.
    pub serial: u64,
    /// On the bus: receives instructions and sends frames.
    pub connected: bool,
    /// `MO=1`.
    pub motor_on: bool,
    table: PvtTable,
    begin_mode: BeginMode,
    /// `SP`, counts/s (> 0).
    speed_counts_s: i32,
    /// `PA`, counts.
    target_counts: i32,
    /// `SD`, counts/s² (> 0).
    stop_decel_counts_s2: u32,
    /// `IE[X]`, one bit each.
    info_enabled: [u64; 4],
    motion: Motion,
    /// A `BG=N;` waiting for its time, µs of gateway time.
    begin_at_us: Option<u64>,
    /// Point-to-point moves begun since power-on (a `BG` in point-to-point mode that
    /// moved the ball): what an observer counts to know a move was made, however
    /// short.
    pub ptp_moves: u64,
}

impl Unit {
    /// A unit at power-on: at the top (0), motor off, point-to-point mode with `PA=0`,
    /// `SP` a tenth of the top speed, `SD` the top acceleration, `IE[5]=1`.
    pub fn new(station: u8, serial: u64, connected: bool, limits: &Limits) -> Self {
        let stop_decel = limits.max_accel_counts_s2;
        Self {
            station,
            serial,
            connected,
            motor_on: false,
            table: PvtTable::new(stop_decel),
            begin_mode: BeginMode::Ptp,
            // Float-to-int `as` rounds toward zero and saturates; the configuration keeps
            // both within range.
            speed_counts_s: ((limits.max_speed_counts_s / 10.0).round() as i32).max(1),
            target_counts: 0,
            stop_decel_counts_s2: (stop_decel.round() as u32).max(1),
            info_enabled: INFO_AT_POWER_ON,
            motion: Motion::Rest { position: 0.0 },
            begin_at_us: None,
            ptp_moves: 0,
        }
    }

    /// The next time something happens to this unit by itself (a row ends, a move
    /// ends, a limit is reached, a timed `BG` starts); `u64::MAX` for none.
    pub fn next_us(&self) -> u64 {
        let motion = match self.motion {
            Motion::Rest { .. } => u64::MAX,
            Motion::Ptp { end_us, stop, .. } => stop.map_or(end_us, |stop| stop.at_us.min(end_us)),
            Motion::Pvt {
                row_end_us, stop, ..
            } => row_end_us
                .unwrap_or(u64::MAX)
                .min(stop.map_or(u64::MAX, |stop| stop.at_us)),
        };
        motion.min(self.begin_at_us.unwrap_or(u64::MAX))
    }

    /// Runs the unit up to `now_us`, one event at a time.
    pub fn advance(&mut self, now_us: u64, limits: &Limits, out: &mut Outbox<'_>) {
        loop {
            let next = self.next_us();
            if next > now_us {
                break;
            }
            self.step(next, limits, out);
        }
        // The table follows the clock too (the water level, the end of braking).
        let events = self.table.advance(now_us);
        self.handle(events, limits, out);
    }

    /// Handles the event due at `at_us` (the earliest, [`next_us`](Self::next_us)).
    fn step(&mut self, at_us: u64, limits: &Limits, out: &mut Outbox<'_>) {
        match self.motion {
            Motion::Rest { .. } => {}
            Motion::Ptp {
                end_us,
                trapezoid,
                stop,
                ..
            } => {
                if let Some(stop) = stop.filter(|stop| stop.at_us <= at_us) {
                    self.motion = Motion::Rest {
                        position: stop.position,
                    };
                } else if end_us <= at_us {
                    self.motion = Motion::Rest {
                        position: trapezoid.target_counts(),
                    };
                }
            }
            Motion::Pvt {
                row_end_us,
                stop,
                last_row,
            } => {
                if let Some(stop) = stop.filter(|stop| stop.at_us <= at_us) {
                    self.table.abort();
                    self.motion = Motion::Rest {
                        position: stop.position,
                    };
                    let error = refused(code::error::LIMIT, code::QT, last_row);
                    out.send(stop.at_us, self.station, error);
                } else if let Some(end_us) = row_end_us.filter(|&end_us| end_us <= at_us) {
                    self.motion = Motion::Pvt {
                        row_end_us: None,
                        stop,
                        last_row,
                    };
                    let events = self.table.advance(end_us);
                    self.handle(events, limits, out);
                }
            }
        }
        if let Some(begin_us) = self.begin_at_us.filter(|&begin_us| begin_us <= at_us) {
            self.begin_at_us = None;
            if let Err(error) = self.start(begin_us, limits, out) {
                out.send(begin_us, self.station, Feedback::Error(refusal(error)));
            }
        }
    }

    /// Acts on what the table reports: a row began (checked against the limits; the
    /// watermark), the run ran out of rows (braking), the ball came to rest.
    fn handle(&mut self, events: Events, limits: &Limits, out: &mut Outbox<'_>) {
        if let Some(start) = events.last_row {
            // The table has just started the row: its state now is the row's start.
            let from = self.table.state_at(start.at_us).unwrap_or_default();
            let row = self.table.row(start.index);
            let segment = row.segment_from(from.position, from.velocity);
            if overloaded(&segment, limits) {
                self.table.abort();
                self.motion = Motion::Rest {
                    position: from.position,
                };
                self.motor_on = false;
                self.begin_at_us = None;
                let error = refused(code::error::OVERLOAD, code::QT, start.index);
                out.send(start.at_us, self.station, error);
                return;
            }
            if let Some(watermark) = events.watermark
                && self.info(INFO_WATERMARK)
            {
                for _ in 0..3 {
                    let notice = Feedback::Notification(Notification::PVT_WATERMARK);
                    out.send(watermark.at_us, self.station, notice);
                }
            }
            self.motion = Motion::Pvt {
                row_end_us: Some(start.at_us + u64::from(row.duration_ms) * 1000),
                stop: stop_at(start.at_us, motion::exit(&segment, limits.travel_counts)),
                last_row: start.index,
            };
        }
        if let Some(end) = events.run_end {
            let last_row = match self.motion {
                Motion::Pvt { last_row, .. } => last_row,
                Motion::Rest { .. } | Motion::Ptp { .. } => 0,
            };
            let stop = (end.velocity_counts_s != 0.0)
                .then(|| {
                    let brake = braking(
                        end.position_counts,
                        end.velocity_counts_s,
                        self.stop_decel(limits),
                    );
                    stop_at(end.at_us, motion::exit(&brake, limits.travel_counts))
                })
                .flatten();
            self.motion = Motion::Pvt {
                row_end_us: None,
                stop,
                last_row,
            };
        }
        if let Some(stopped) = events.stopped {
            self.table.abort();
            self.motion = Motion::Rest {
                position: stopped.position_counts,
            };
        }
    }

    /// Begins motion at `at_us` in the mode chosen last, from the ball's position and
    /// velocity then.
    fn start(&mut self, at_us: u64, limits: &Limits, out: &mut Outbox<'_>) -> Result<(), PvtError> {
        let events = self.table.advance(at_us);
        self.handle(events, limits, out);
        let from = self.kinematics(at_us, limits);
        match self.begin_mode {
            BeginMode::Ptp => {
                self.table.abort();
                let target = f64::from(self.target_counts).clamp(0.0, limits.travel_counts);
                let speed = f64::from(self.speed_counts_s).min(limits.max_speed_counts_s);
                let trapezoid = Trapezoid::new(
                    from.position,
                    from.velocity,
                    target,
                    speed,
                    limits.max_accel_counts_s2,
                );
                self.motion = if trapezoid.pieces().is_empty() {
                    Motion::Rest {
                        position: from.position,
                    }
                } else {
                    self.ptp_moves += 1;
                    Motion::Ptp {
                        start_us: at_us,
                        end_us: at_us.saturating_add(micros(trapezoid.duration_s())),
                        trapezoid,
                        stop: stop_at(at_us, motion::move_exit(&trapezoid, limits.travel_counts)),
                    }
                };
            }
            BeginMode::Pvt => {
                let events = self.table.begin(from.position, from.velocity)?;
                self.motion = Motion::Pvt {
                    row_end_us: None,
                    stop: None,
                    last_row: 0,
                };
                self.handle(events, limits, out);
            }
        }
        Ok(())
    }

    /// Stops at once where the ball is: motor off (the brake holds it) or a fault.
    fn halt(&mut self, now_us: u64, limits: &Limits) {
        let position = self.kinematics(now_us, limits).position;
        self.table.abort();
        self.motion = Motion::Rest { position };
        self.begin_at_us = None;
    }

    /// Carries out one instruction addressed to this unit at `now_us` (the unit has been
    /// advanced to `now_us`) and returns its answer: the ACK with the value now in
    /// effect, or the error. `None` when the unit does not take part (a `SN[X]=s/n`
    /// for another serial; `*N;` and unknown mnemonics, which the gateway handles).
    pub fn apply(
        &mut self,
        now_us: u64,
        instruction: &Instruction,
        limits: &Limits,
        out: &mut Outbox<'_>,
    ) -> Option<Feedback> {
        use Instruction as I;
        let answer = match *instruction {
            I::Select { .. } | I::Generic(_) | I::Gateway(_) => return None,
            I::Begin { at_us } => self.begin(now_us, at_us, limits, out),
            I::MotionProfile { param, value } => {
                let param = param.index();
                match value {
                    None => self.table.mp(param),
                    Some(value) => self.table.set_mp(param, value.into()).map(|()| value),
                }
                .map(|value| Ack::MotionProfile {
                    param,
                    value: value.into(),
                })
                .map_err(refusal)
            }
            I::PvtStart { row: None } => Ok(Ack::PvtStart {
                value: self.table.pv(),
            }),
            I::PvtStart { row: Some(row) } => self.set_start_row(now_us, row, limits),
            I::PvtPosition {
                row,
                position_counts,
            } => {
                if let Some(counts) = position_counts {
                    self.table.write_position(row, counts);
                }
                Ok(Ack::PvtPosition {
                    row: row.into(),
                    position_counts: self.table.row(row).position_counts,
                })
            }
            I::PvtVelocity {
                row,
                velocity_counts_s,
            } => {
                if let Some(counts_s) = velocity_counts_s {
                    self.table.write_velocity(row, counts_s);
                }
                Ok(Ack::PvtVelocity {
                    row: row.into(),
                    velocity_counts_s: self.table.row(row).velocity_counts_s,
                })
            }
            I::PvtTime { row, duration_ms } => duration_ms
                .map_or(Ok(()), |ms| self.table.write_time(row, ms.into()))
                .map(|()| Ack::PvtTime {
                    row: row.into(),
                    duration_ms: self.table.row(row).duration_ms,
                })
                .map_err(refusal),
            I::QuerySerial => Ok(Ack::Serial {
                serial: self.serial,
            }),
            I::SetStation { station, serial } => {
                if serial != self.serial {
                    return None;
                }
                if station == 0 {
                    Err(data_error(code::SN, 0))
                } else {
                    self.station = station;
                    Ok(Ack::Serial { serial })
                }
            }
            I::Motor { on } => {
                if let Some(on) = on {
                    if !on {
                        self.halt(now_us, limits);
                    }
                    self.motor_on = on;
                }
                Ok(Ack::Motor { on: self.motor_on })
            }
            I::PtpSpeed { speed_counts_s } => match speed_counts_s {
                Some(speed) if speed <= 0 => Err(data_error(code::SP, 0)),
                Some(speed) => {
                    self.speed_counts_s = speed;
                    Ok(Ack::PtpSpeed {
                        speed_counts_s: speed,
                    })
                }
                None => Ok(Ack::PtpSpeed {
                    speed_counts_s: self.speed_counts_s,
                }),
            },
            I::PtpPosition {
                position_counts: Some(target),
            } => {
                self.target_counts = target;
                self.begin_mode = BeginMode::Ptp;
                Ok(Ack::PtpPosition {
                    position_counts: target,
                })
            }
            I::PtpPosition {
                position_counts: None,
            } => Ok(Ack::PtpPosition {
                // Positions lie within 0…travel, which fits an i32.
                position_counts: self.kinematics(now_us, limits).position.round() as i32,
            }),
            I::StopDecel { decel_counts_s2 } => match decel_counts_s2 {
                Some(0) => Err(data_error(code::SD, 0)),
                Some(decel) => {
                    self.stop_decel_counts_s2 = decel;
                    self.table.set_stop_deceleration(self.stop_decel(limits));
                    Ok(Ack::StopDecel {
                        decel_counts_s2: decel,
                    })
                }
                None => Ok(Ack::StopDecel {
                    decel_counts_s2: self.stop_decel_counts_s2,
                }),
            },
            I::InfoEnable { index, enabled } => {
                if let Some(enabled) = enabled {
                    let (word, bit) = (usize::from(index / 64), index % 64);
                    if enabled {
                        self.info_enabled[word] |= 1 << bit;
                    } else {
                        self.info_enabled[word] &= !(1 << bit);
                    }
                }
                Ok(Ack::InfoEnable {
                    index,
                    enabled: self.info(index),
                })
            }
        };
        Some(match answer {
            Ok(ack) => Feedback::Ack(ack),
            Err(error) => Feedback::Error(error),
        })
    }

    /// `BG;` / `BG=N;`.
    fn begin(
        &mut self,
        now_us: u64,
        at_us: Option<u32>,
        limits: &Limits,
        out: &mut Outbox<'_>,
    ) -> Result<Ack, UnitError> {
        if !self.motor_on {
            return Err(UnitError {
                error: code::error::MOTOR_OFF,
                code: code::BG,
                index: 0,
            });
        }
        // A new BG replaces one still waiting for its time.
        self.begin_at_us = None;
        let Some(start_us) = at_us else {
            self.start(now_us, limits, out).map_err(refusal)?;
            return Ok(Ack::Begin { at_us: 0 });
        };
        if self.begin_mode == BeginMode::Pvt {
            // Refuse now what the table would refuse at the start time.
            self.table.clone().begin(0.0, 0.0).map_err(refusal)?;
        }
        let wait_us = u64::from(start_us.wrapping_sub(system_time_us(now_us)));
        if wait_us == 0 {
            self.start(now_us, limits, out).map_err(refusal)?;
        } else {
            self.begin_at_us = Some(now_us + wait_us);
        }
        Ok(Ack::Begin { at_us: start_us })
    }

    /// `PV=N;`: refused while the ball moves, in any mode.
    fn set_start_row(&mut self, now_us: u64, row: u8, limits: &Limits) -> Result<Ack, UnitError> {
        if self.kinematics(now_us, limits).velocity != 0.0 {
            return Err(UnitError {
                error: code::error::WHILE_MOVING,
                code: code::PV,
                index: 0,
            });
        }
        self.table.set_start_row(row.into()).map_err(refusal)?;
        self.begin_mode = BeginMode::Pvt;
        Ok(Ack::PvtStart { value: row.into() })
    }

    /// Whether notification `IE[index]` is enabled.
    fn info(&self, index: u8) -> bool {
        self.info_enabled[usize::from(index / 64)] & (1 << (index % 64)) != 0
    }

    /// The deceleration braking uses: `SD`, but never beyond the top acceleration.
    fn stop_decel(&self, limits: &Limits) -> f64 {
        f64::from(self.stop_decel_counts_s2).min(limits.max_accel_counts_s2)
    }

    /// Position, velocity and acceleration at `at_us` (not before the last event),
    /// the position within `0..=travel`.
    pub fn kinematics(&self, at_us: u64, limits: &Limits) -> Kinematics {
        let rest = |position| Kinematics {
            position,
            velocity: 0.0,
            acceleration: 0.0,
        };
        let stopped = |stop: Option<Stop>| stop.filter(|stop| at_us >= stop.at_us);
        let state = match self.motion {
            Motion::Rest { position } => rest(position),
            Motion::Ptp {
                start_us,
                end_us,
                trapezoid,
                stop,
            } => match stopped(stop) {
                Some(stop) => rest(stop.position),
                None if at_us >= end_us => rest(trapezoid.target_counts()),
                None => trapezoid.kinematics(seconds(at_us.saturating_sub(start_us))),
            },
            Motion::Pvt { stop, .. } => match stopped(stop) {
                Some(stop) => rest(stop.position),
                None => self.table.state_at(at_us).unwrap_or_default(),
            },
        };
        Kinematics {
            position: state.position.clamp(0.0, limits.travel_counts),
            ..state
        }
    }

    /// Whether a motion is under way at `at_us`: a move before its end, a PVT row, or
    /// braking.
    pub fn moving(&self, at_us: u64, limits: &Limits) -> bool {
        match self.motion {
            Motion::Rest { .. } => false,
            Motion::Ptp { end_us, stop, .. } => {
                at_us < stop.map_or(end_us, |stop| stop.at_us.min(end_us))
            }
            Motion::Pvt { stop, .. } => {
                stop.is_none_or(|stop| at_us < stop.at_us)
                    && (self.table.current_row().is_some()
                        || self.kinematics(at_us, limits).velocity != 0.0)
            }
        }
    }
}

/// The stop at a limit, `exit` after `start_us`.
fn stop_at(start_us: u64, exit: Option<motion::Exit>) -> Option<Stop> {
    exit.map(|exit| Stop {
        at_us: start_us.saturating_add(micros(exit.after_s)),
        position: exit.position_counts,
    })
}

/// Whether a row asks for more than the unit has.
fn overloaded(segment: &Segment, limits: &Limits) -> bool {
    let over = |value: f64, limit: f64| value > limit * (1.0 + LIMIT_SLACK);
    over(segment.peak_speed().value, limits.max_speed_counts_s)
        || over(
            segment.peak_acceleration().value,
            limits.max_accel_counts_s2,
        )
}

/// A span of seconds as whole µs, rounded up (an event is never early by more than
/// float noise: 4.025 s is 4 025 000 µs, not 4 025 001).
fn micros(seconds: f64) -> u64 {
    // Float-to-int `as` saturates, which is what an absurd duration deserves.
    (seconds * 1e6 - MICROS_SLACK).ceil() as u64
}

/// µs as seconds.
fn seconds(micros: u64) -> f64 {
    micros as f64 / 1e6
}

/// An error report as feedback.
fn refused(error: u8, code: u8, index: u8) -> Feedback {
    Feedback::Error(UnitError { error, code, index })
}

/// `DATA` error on the instruction with `code` and `index`.
fn data_error(code: u8, index: u8) -> UnitError {
    UnitError {
        error: code::error::DATA,
        code,
        index,
    }
}

/// The error report for what the PVT table refuses (`docs/protocol-notes.md` §3).
fn refusal(error: PvtError) -> UnitError {
    use code::error::{DATA, INDEX, WHILE_MOVING};
    let (number, code, index) = match error {
        PvtError::PvWhileMoving => (WHILE_MOVING, code::PV, 0),
        PvtError::RowOutOfRange { .. } | PvtError::StartOutsideRange { .. } => (DATA, code::PV, 0),
        PvtError::RangeInverted { .. } => (DATA, code::MP, 2),
        PvtError::QtZero { index }
        | PvtError::QtOutOfRange { index, .. }
        | PvtError::FifoFull { index, .. } => (DATA, code::QT, index),
        PvtError::NoSuchParameter { index } => (INDEX, code::MP, index),
        PvtError::ValueOutOfRange { index, .. } => (DATA, code::MP, index),
        PvtError::ReservedMode => (DATA, code::MP, 3),
        PvtError::ReadOnlyParameter => (DATA, code::MP, 6),
        PvtError::WhileMoving { index } => (WHILE_MOVING, code::MP, index),
    };
    UnitError {
        error: number,
        code,
        index,
    }
}
