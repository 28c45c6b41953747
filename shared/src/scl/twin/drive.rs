//! One simulated drive: its parameters, I/O, registers, motion and the task that runs
//! buffered commands (from the host, or from the queue when a program runs), and its
//! answers. The queue, the segments and the program flow are in [`super::program`].

use std::collections::VecDeque;

use super::profile::Profile;
use super::program::Program;
use crate::scl::command::{
    Address, Command, Decimal, InputCondition, IoPoint, JumpCondition, Kind, Level, MathOp,
    Register, Request, Segment, StopRate,
};
use crate::scl::response::{Answer, QueueUpload, Reply};
use crate::scl::{escl, units};

/// Alarm code bits the twin raises (HCR p. 27, `AL`).
pub mod alarm {
    /// `0001` Position Limit: a move whose target is beyond a soft limit.
    pub const POSITION_LIMIT: u16 = 0x0001;
    /// `4000` Blank Q Segment: `QX`, `QL` or `QC` of a segment that holds nothing.
    pub const BLANK_Q_SEGMENT: u16 = 0x4000;
    /// `8000` No Move: a move while the motor is disabled or an alarm is present.
    pub const NO_MOVE: u16 = 0x8000;
}

/// Status word bits the twin reports (HCR p. 195, `SC`).
pub mod status {
    /// `0001` Motor Enabled.
    pub const MOTOR_ENABLED: u16 = 0x0001;
    /// `0008` In Position: not moving.
    pub const IN_POSITION: u16 = 0x0008;
    /// `0010` Moving.
    pub const MOVING: u16 = 0x0010;
    /// `0040` Stopping (after `ST` or `SK`).
    pub const STOPPING: u16 = 0x0040;
    /// `0080` Waiting for an input (`WI`).
    pub const WAITING_INPUT: u16 = 0x0080;
    /// `0200` Alarm present.
    pub const ALARM: u16 = 0x0200;
    /// `0800` Waiting for time (`WT`).
    pub const WAITING_TIME: u16 = 0x0800;
    /// `4000` Q program running.
    pub const Q_RUNNING: u16 = 0x4000;
}

/// How a simulated drive is set up.
#[derive(Debug, Clone, PartialEq)]
pub struct DriveConfig {
    /// Its RS-485 address; `None`: it takes every line and answers without one
    /// (RS-232, or eSCL).
    pub address: Option<Address>,
    /// `EG` at power-up: steps per revolution.
    pub steps_per_rev: u32,
    /// `VE` at power-up, rev/s.
    pub velocity_rev_s: Decimal,
    /// `AC` at power-up, rev/s².
    pub accel_rev_s2: Decimal,
    /// `DE` at power-up, rev/s².
    pub decel_rev_s2: Decimal,
    /// Soft limits `(lowest, highest)`, counts: a move whose target is outside them is
    /// not started and raises [`alarm::POSITION_LIMIT`].
    pub soft_limits_counts: Option<(i32, i32)>,
}

impl Default for DriveConfig {
    fn default() -> Self {
        Self {
            address: None,
            steps_per_rev: crate::scl::qprogram::DEFAULT_STEPS_PER_REV,
            velocity_rev_s: Decimal::from_int(10),
            accel_rev_s2: Decimal::from_int(100),
            decel_rev_s2: Decimal::from_int(100),
            soft_limits_counts: None,
        }
    }
}

/// An output changing level, as the twin logged it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutputChange {
    /// When, s since the twin's clock 0.
    pub at_s: f64,
    /// The output.
    pub output: IoPoint,
    /// Its new level.
    pub level: Level,
}

/// A move coming to rest, as the twin logged it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveEnd {
    /// When, s since the twin's clock 0.
    pub at_s: f64,
    /// Where, counts.
    pub position_counts: f64,
}

/// The most entries each log keeps (the oldest half goes when it is full).
const LOG_CAPACITY: usize = 8192;
/// The most program lines run at one instant before the program is taken for a loop
/// that never waits: it then pauses [`PAUSE_S`] while the motor moves (it may be
/// polling the position), or until an input changes or a host line arrives (nothing
/// else can change what it does). A loop must not hang the caller.
const STEPS_PER_INSTANT: u32 = 200;
/// The pause of a program that ran [`STEPS_PER_INSTANT`] lines at one instant.
const PAUSE_S: f64 = 0.001;
/// Time within which two instants are the same (float rounding).
pub(super) const EPSILON_S: f64 = 1e-9;
/// The refusal code for a value out of range (HCR p. 304: `?5`).
const OUT_OF_RANGE: u16 = 5;
/// The refusal code of a full command buffer, or a full segment while `QL` loads
/// (HCR p. 304: `?6`, "Command buffer (queue) full").
pub const BUFFER_FULL: u16 = 6;
/// The refusal code of a command the drive cannot carry out now (HCR p. 304: `?7`):
/// `CS` while not jogging, `JA`/`JL` while jogging (HCR p. 71, 150, 155).
pub const CANNOT_PROCESS: u16 = 7;
/// The refusal code of a command a running program does not allow (HCR p. 304: `?8`,
/// "Program running").
pub const PROGRAM_RUNNING: u16 = 8;
/// The command buffer's places (HCR p. 53: `BS` answers 63 when it is empty).
pub const BUFFER_PLACES: usize = 63;
/// `EG` range (the twin's limits; `VE`, `AC`, `DE` and `WT`: [`units`]).
const STEPS_PER_REV_RANGE: std::ops::RangeInclusive<u32> = 200..=51_200;
/// The jog speed's register (HCR p. 64: `J`, 0.25 rpm).
const JOG_REGISTER: char = 'J';
/// Registers `'0'` to `'z'`.
const REGISTERS: usize = (b'z' - b'0' + 1) as usize;

/// What the task waits for before its next command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Wait {
    /// Nothing: it runs.
    Nothing,
    /// The clock to reach this time, s (`WT`, or a pause).
    Until { at_s: f64, wt: bool },
    /// An input to meet a condition (`WI`).
    Input {
        input: IoPoint,
        condition: InputCondition,
    },
    /// The motion to end (a move with `MT0`, or a move waiting for the one before).
    Motion,
    /// An input change or a host line (a program looping without waiting).
    Spin,
}

/// What a motion is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum MotionKind {
    /// A move to rest (`FL`, `FP`, an `FS` past its sensor).
    Move,
    /// `FS` looking for its sensor; then `distance_counts` (unsigned) more.
    Seek {
        input: IoPoint,
        condition: InputCondition,
        distance_counts: f64,
        decel_counts_s2: f64,
        speed_counts_s: f64,
        accel_counts_s2: f64,
    },
    /// Jogging (`CJ`) in `direction` (1 or −1): until `SJ`, `ST` or `SK`.
    Jog {
        /// 1 forward, −1 backward.
        direction: f64,
    },
    /// Slowing down after `ST` or `SK`.
    Stopping,
}

#[derive(Debug, Clone, PartialEq)]
struct Motion {
    start_s: f64,
    profile: Profile,
    kind: MotionKind,
    /// Added to the profile's positions (`SP` during a move).
    offset_counts: f64,
}

impl Motion {
    fn at(&self, clock_s: f64) -> (f64, f64) {
        let (x, v) = self.profile.at(clock_s - self.start_s);
        (x + self.offset_counts, v)
    }

    fn end_s(&self) -> f64 {
        self.start_s + self.profile.duration_s()
    }
}

/// The condition code the last test or math command left (`QJ` reads it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(super) struct ConditionCode {
    /// `TI`: the input was at the level; `TR`/`CR`: equal; math: a result not zero.
    pub truth: bool,
    /// `TR`/`CR`: first − second; math: the result; `TI`: 1 or 0.
    pub value: i64,
}

impl ConditionCode {
    pub(super) fn meets(self, condition: JumpCondition) -> bool {
        match condition {
            JumpCondition::True => self.truth,
            JumpCondition::False => !self.truth,
            JumpCondition::Positive | JumpCondition::Greater => self.value > 0,
            JumpCondition::Less => self.value < 0,
            JumpCondition::Equal | JumpCondition::Zero => self.value == 0,
            JumpCondition::Unequal => self.value != 0,
        }
    }
}

/// Whether a command only means something in a program (`QG QR QJ QC`): buffered,
/// but refused from a host outside a `QL` load (a flow command needs a running
/// queue; our choice where the HCR is silent, `docs/protocol-notes.md` §8).
fn program_only(command: &Command) -> bool {
    matches!(
        command,
        Command::QueueGoto { .. }
            | Command::QueueRepeat { .. }
            | Command::QueueJump { .. }
            | Command::QueueCall { .. }
    )
}

/// Whether a command's values are in the twin's ranges (else `?5`): `VE`, `AC`, `DE`
/// and `WT` as a drive takes them ([`units`]: `VE` from 0.0042 rev/s, `AC`/`DE` from
/// 0.167 rev/s²).
fn in_range(command: &Command) -> bool {
    let held = |value: Option<Decimal>, resolution: units::Resolution| {
        value.is_none_or(|v| resolution.steps(v).is_some())
    };
    match *command {
        Command::Velocity { rev_s } | Command::JogSpeed { rev_s } => held(rev_s, units::VELOCITY),
        Command::ChangeSpeed { rev_s } => held(Some(rev_s.abs()), units::VELOCITY),
        Command::JogAcceleration { rev_s2 } | Command::JogDeceleration { rev_s2 } => {
            held(rev_s2, units::ACCELERATION)
        }
        Command::Acceleration { rev_s2 } | Command::Deceleration { rev_s2 } => {
            held(rev_s2, units::ACCELERATION)
        }
        Command::WaitTime { s } => held(Some(s), units::WAIT),
        Command::ElectronicGearing { steps_per_rev } => {
            steps_per_rev.is_none_or(|s| STEPS_PER_REV_RANGE.contains(&s))
        }
        Command::RegisterLoad { register, .. }
        | Command::RegisterMove {
            destination: register,
            ..
        } => !register.is_read_only(),
        _ => true,
    }
}

/// A simulated MOONS' drive. See the [module](super) and `docs/protocol-notes.md` §8.
#[derive(Debug, Clone)]
pub struct Drive {
    config: DriveConfig,
    pub(super) clock_s: f64,
    distance_counts: i32,
    velocity_rev_s: Decimal,
    accel_rev_s2: Decimal,
    decel_rev_s2: Decimal,
    jog_speed_rev_s: Decimal,
    jog_accel_rev_s2: Decimal,
    jog_decel_rev_s2: Decimal,
    steps_per_rev: u32,
    pub(super) multitasking: bool,
    enabled: bool,
    alarm: u16,
    registers: [i32; REGISTERS],
    pub(super) condition: ConditionCode,
    inputs: [Level; 10],
    outputs: [Level; 10],
    motion: Option<Motion>,
    rest_counts: f64,
    encoder_offset_counts: i64,
    pub(super) segments: [Option<Vec<Command>>; 12],
    pub(super) queue: Vec<Command>,
    pub(super) program: Option<Program>,
    host: VecDeque<Command>,
    /// `PS` ran: the command buffer waits for `CT`.
    paused: bool,
    /// The jog velocity while jogging (the `J` register), in steps of 0.25 rpm
    /// (1/240 rev/s), signed: the direction (HCR p. 64, p. 71).
    jog_steps: i64,
    pub(super) wait: Wait,
    /// `QL` (without a segment) is loading the queue from the host.
    pub(super) loading: bool,
    /// The stored segment the queue was loaded from (`QX`, `QC`, `QL n`), if any:
    /// where a `QC` returns from (HCR p. 210: the caller is loaded again from memory).
    pub(super) running_segment: Option<Segment>,
    /// Writes to each segment's non-volatile partition (`QS`; HCR p. 294: about 10,000
    /// each).
    flash_writes: [u32; 12],
    steps_at_instant: u32,
    output_log: Vec<OutputChange>,
    move_log: Vec<MoveEnd>,
}

/// What one step of the task did.
pub(super) enum Step {
    /// Go on with the next command.
    Next,
    /// Try the same command again later (a wait was set).
    Again,
    /// Go on at this index of the queue.
    Goto(usize),
    /// Nothing more to do (the program ended or was killed).
    Stop,
}

impl Drive {
    /// A drive at power-up: enabled, at 0, no alarm, inputs and outputs high, no
    /// segment stored.
    #[must_use]
    pub fn new(config: DriveConfig) -> Self {
        Self {
            distance_counts: 0,
            velocity_rev_s: config.velocity_rev_s,
            accel_rev_s2: config.accel_rev_s2,
            decel_rev_s2: config.decel_rev_s2,
            jog_speed_rev_s: config.velocity_rev_s,
            jog_accel_rev_s2: config.accel_rev_s2,
            jog_decel_rev_s2: config.decel_rev_s2,
            steps_per_rev: config.steps_per_rev,
            config,
            clock_s: 0.0,
            multitasking: false,
            enabled: true,
            alarm: 0,
            registers: [0; REGISTERS],
            condition: ConditionCode::default(),
            inputs: [Level::High; 10],
            outputs: [Level::High; 10],
            motion: None,
            rest_counts: 0.0,
            encoder_offset_counts: 0,
            segments: Default::default(),
            queue: Vec::new(),
            program: None,
            host: VecDeque::new(),
            paused: false,
            jog_steps: 0,
            wait: Wait::Nothing,
            loading: false,
            running_segment: None,
            flash_writes: [0; 12],
            steps_at_instant: 0,
            output_log: Vec::new(),
            move_log: Vec::new(),
        }
    }

    /// Its configuration.
    #[must_use]
    pub fn config(&self) -> &DriveConfig {
        &self.config
    }

    /// Its RS-485 address.
    #[must_use]
    pub fn address(&self) -> Option<Address> {
        self.config.address
    }

    /// Its clock, µs (the latest `now_us` it was given).
    #[must_use]
    #[allow(clippy::cast_possible_truncation, clippy::cast_sign_loss)]
    pub fn now_us(&self) -> u64 {
        (self.clock_s * 1e6).round() as u64
    }

    // ----- the host's side ------------------------------------------------------------

    /// One line from the host (a trailing CR allowed), at `now_us`: the drive's whole
    /// answer, every line ended by CR, or `None` when it says nothing (a line for
    /// another drive, an empty line, a global command that asks nothing).
    ///
    /// A drive with an address also takes a **global** line, one without an address
    /// (it starts with a command's capital letter): every drive on the line carries
    /// it out, and none answers unless it asks for data (HCR p. 304–305).
    pub fn receive_line(&mut self, line: &str, now_us: u64) -> Option<String> {
        self.advance(now_us);
        let line = line.strip_suffix('\r').unwrap_or(line);
        let global =
            self.config.address.is_some() && line.starts_with(|c: char| c.is_ascii_uppercase());
        let prefix = self
            .config
            .address
            .map(|a| a.to_string())
            .unwrap_or_default();
        let body = match self.config.address {
            Some(_) if global => line,
            Some(address) => {
                // Only lines that start with its address are for it.
                line.strip_prefix(address.character())?
            }
            None => line,
        };
        if body.trim_matches([' ', '\t']).is_empty() {
            return None;
        }
        let text = if self.config.address.is_some() && !global {
            line
        } else {
            body
        };
        let Ok(request) = Request::parse(text) else {
            return (!global).then(|| format!("{prefix}?\r"));
        };
        if global && !request.command.is_query() {
            let _ = self.execute_request(request.command);
            return None;
        }
        if let Command::QueueUpload { segment } = request.command {
            let upload = self.queue_upload(segment);
            let mut text = format!("{prefix}%\r");
            for line in upload.lines() {
                text.push_str(&format!("{prefix}{line}\r"));
            }
            return Some(text);
        }
        let replies = self.execute_request(request.command);
        let mut text = String::new();
        for answer in replies {
            text.push_str(&format!("{prefix}{answer}\r"));
        }
        Some(text)
    }

    /// One eSCL datagram (header `00 07`, the text, CR): the answer's datagrams, one a
    /// line. A datagram without the header says nothing.
    pub fn receive_escl(&mut self, datagram: &[u8], now_us: u64) -> Vec<Vec<u8>> {
        let Some(text) = datagram
            .strip_prefix(&escl::HEADER[..])
            .and_then(|rest| std::str::from_utf8(rest).ok())
        else {
            return Vec::new();
        };
        let Some(answer) = self.receive_line(text, now_us) else {
            return Vec::new();
        };
        answer
            .split_inclusive('\r')
            .map(|line| {
                let mut datagram = escl::HEADER.to_vec();
                datagram.extend_from_slice(line.as_bytes());
                datagram
            })
            .collect()
    }

    /// A typed command from the host at `now_us`, and the drive's answers (with its
    /// address). `QU` answers only its `%` here: its lines are
    /// [`Drive::queue_upload`]. Lines for another drive are the caller's business.
    pub fn command(&mut self, request: &Request, now_us: u64) -> Vec<Reply> {
        self.advance(now_us);
        self.execute_request(request.command)
            .into_iter()
            .map(|answer| Reply {
                address: self.config.address,
                answer,
            })
            .collect()
    }

    /// Writes to `segment`'s non-volatile partition so far (each `QS` of it).
    #[must_use]
    pub fn flash_writes(&self, segment: Segment) -> u32 {
        self.flash_writes[usize::from(segment.get() - 1)]
    }

    /// One more write to `segment`'s partition.
    pub(super) fn count_flash_write(&mut self, segment: Segment) {
        let slot = &mut self.flash_writes[usize::from(segment.get() - 1)];
        *slot = slot.saturating_add(1);
    }

    /// Writes to every segment's partition together.
    #[must_use]
    pub fn flash_writes_total(&self) -> u32 {
        self.flash_writes.iter().sum()
    }

    /// Whether `QL` is loading the queue from the host.
    #[must_use]
    pub fn is_loading(&self) -> bool {
        self.loading
    }

    /// Free places in the command buffer (what `BS` answers).
    #[must_use]
    pub fn buffer_free(&self) -> usize {
        BUFFER_PLACES.saturating_sub(self.host.len())
    }

    /// Whether the motor jogs (`CJ` under way, not stopping).
    #[must_use]
    pub fn is_jogging(&self) -> bool {
        matches!(
            self.motion.as_ref().map(|motion| motion.kind),
            Some(MotionKind::Jog { .. })
        )
    }

    fn execute_request(&mut self, command: Command) -> Vec<Answer> {
        let refused = |code| vec![Answer::Refused { code: Some(code) }];
        if self.wait == Wait::Spin {
            self.wake();
        }
        if !in_range(&command) {
            return refused(OUT_OF_RANGE);
        }
        if command.kind() == Kind::Immediate {
            // Carried out at once, also while `QL` loads: never a line (HCR p. 13).
            return self.immediate(command);
        }
        if self.loading {
            if self.queue.len() >= QueueUpload::MAX_LINES {
                return refused(BUFFER_FULL);
            }
            self.queue.push(command);
            return vec![Answer::Buffered];
        }
        if self.program.is_some() {
            // Our choice where the HCR is silent (`docs/protocol-notes.md` §8): a
            // running program owns the buffer; the bridge never sends buffered
            // commands to a drive whose program runs.
            return refused(PROGRAM_RUNNING);
        }
        if program_only(&command) {
            return vec![Answer::Refused { code: None }];
        }
        if matches!(
            command,
            Command::JogAcceleration { .. } | Command::JogDeceleration { .. }
        ) && self.is_jogging()
        {
            // HCR p. 150, 155: JA and JL cannot be changed while jogging.
            return refused(CANNOT_PROCESS);
        }
        if self.host.len() >= BUFFER_PLACES {
            return refused(BUFFER_FULL);
        }
        self.host.push_back(command);
        self.run();
        vec![Answer::Buffered]
    }

    fn immediate(&mut self, command: Command) -> Vec<Answer> {
        let value = |name: &str, value: String| {
            vec![Answer::Value {
                name: name.to_owned(),
                value,
            }]
        };
        let ok = vec![Answer::Executed];
        match command {
            Command::Distance { counts: None } => value("DI", self.distance_counts.to_string()),
            Command::Velocity { rev_s: None } => value("VE", self.velocity_rev_s.to_string()),
            Command::Acceleration { rev_s2: None } => value("AC", self.accel_rev_s2.to_string()),
            Command::Deceleration { rev_s2: None } => value("DE", self.decel_rev_s2.to_string()),
            Command::JogSpeed { rev_s: None } => value("JS", self.jog_speed_rev_s.to_string()),
            Command::JogAcceleration { rev_s2: None } => {
                value("JA", self.jog_accel_rev_s2.to_string())
            }
            Command::JogDeceleration { rev_s2: None } => {
                value("JL", self.jog_decel_rev_s2.to_string())
            }
            Command::ElectronicGearing {
                steps_per_rev: None,
            } => value("EG", self.steps_per_rev.to_string()),
            Command::SetPosition { counts: None } | Command::ImmediatePosition => {
                value(command.mnemonic(), self.position_integer().to_string())
            }
            Command::EncoderPosition { counts: None } => value(
                "EP",
                (self.position_integer() + self.encoder_offset_counts).to_string(),
            ),
            Command::Multitasking { on: None } => {
                value("MT", u8::from(self.multitasking).to_string())
            }
            Command::StatusCode => value("SC", format!("{:04X}", self.status_code())),
            Command::AlarmCode => value("AL", format!("{:04X}", self.alarm)),
            Command::BufferStatus => value("BS", self.buffer_free().to_string()),
            Command::RegisterLoadImmediate {
                register,
                value: None,
            } => vec![Answer::Value {
                name: format!("RL{register}"),
                value: self.register(register).to_string(),
            }],
            Command::RegisterLoadImmediate {
                register,
                value: Some(value),
            } => {
                if register.is_read_only() {
                    return vec![Answer::Refused {
                        code: Some(OUT_OF_RANGE),
                    }];
                }
                self.write_register(register, value);
                self.run();
                ok
            }
            Command::ChangeSpeed { rev_s } => {
                // HCR p. 71: the speed while jogging; not jogging, nothing to change.
                if !self.is_jogging() {
                    return vec![Answer::Refused {
                        code: Some(CANNOT_PROCESS),
                    }];
                }
                let steps = units::VELOCITY.steps(rev_s.abs()).unwrap_or(0);
                self.set_jog_steps(if rev_s.is_negative() { -steps } else { steps });
                ok
            }
            Command::StopJogging => {
                self.stop_jog();
                self.run();
                ok
            }
            Command::Continue => {
                self.paused = false;
                self.run();
                ok
            }
            Command::QueueLoad { .. } | Command::QueueSave { .. } | Command::QueueExecuteLoaded => {
                if self.program.is_some() {
                    return vec![Answer::Refused {
                        code: Some(PROGRAM_RUNNING),
                    }];
                }
                if !self.queue_command(command) {
                    return vec![Answer::Refused { code: None }];
                }
                self.run();
                ok
            }
            Command::QueueUpload { .. } => ok,
            _ => {
                self.apply(command);
                self.run();
                ok
            }
        }
    }

    // ----- time and inputs --------------------------------------------------------------

    /// Runs programs and moves to exactly `now_us` (a time before the drive's clock is
    /// taken as its clock).
    pub fn advance(&mut self, now_us: u64) {
        #[allow(clippy::cast_precision_loss)]
        let now_s = now_us as f64 / 1e6;
        self.advance_to(now_s);
    }

    /// Runs to `t_s`, event by event.
    pub(super) fn advance_to(&mut self, t_s: f64) {
        loop {
            self.run();
            match self.next_event_s() {
                Some(at_s) if at_s <= t_s + EPSILON_S => self.set_clock(at_s.max(self.clock_s)),
                _ => {
                    self.set_clock(t_s.max(self.clock_s));
                    self.run();
                    return;
                }
            }
        }
    }

    /// The next time something happens by itself (a move ends, a wait ends), if any.
    pub(super) fn next_event_s(&self) -> Option<f64> {
        let motion = self
            .motion
            .as_ref()
            .map(Motion::end_s)
            .filter(|t| t.is_finite());
        let wait = match self.wait {
            Wait::Until { at_s, .. } => Some(at_s),
            _ => None,
        };
        match (motion, wait) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        }
    }

    fn set_clock(&mut self, t_s: f64) {
        if t_s > self.clock_s + EPSILON_S {
            self.steps_at_instant = 0;
        }
        self.clock_s = t_s;
        if let Some(motion) = &self.motion
            && self.clock_s + EPSILON_S >= motion.end_s()
        {
            let (end, _) = motion.at(f64::INFINITY);
            let end_s = motion.end_s();
            self.rest_counts = end;
            self.motion = None;
            log(
                &mut self.move_log,
                MoveEnd {
                    at_s: end_s,
                    position_counts: end,
                },
            );
        }
        if let Wait::Until { at_s, .. } = self.wait
            && self.clock_s + EPSILON_S >= at_s
        {
            self.wait = Wait::Nothing;
        }
    }

    /// Sets an input at `now_us` (what a sensor, a switch or the start wire does); an
    /// edge or level a `WI` or an `FS` waits for takes effect at once.
    pub fn set_input(&mut self, input: IoPoint, level: Level, now_us: u64) {
        self.advance(now_us);
        self.set_input_now(input, level);
    }

    /// Sets an input at the drive's clock.
    pub(super) fn set_input_now(&mut self, input: IoPoint, level: Level) {
        let index = usize::from(input.get());
        let old = self.inputs[index];
        if old == level {
            return;
        }
        self.inputs[index] = level;
        let edge = match level {
            Level::Low => InputCondition::Falling,
            Level::High => InputCondition::Rising,
        };
        let meets =
            |condition: InputCondition| condition == edge || condition == level_condition(level);
        if self.wait == Wait::Spin {
            self.wake();
        }
        if let Wait::Input {
            input: waited,
            condition,
        } = self.wait
            && waited == input
            && meets(condition)
        {
            self.wait = Wait::Nothing;
        }
        if let Some(Motion {
            kind:
                MotionKind::Seek {
                    input: sensor,
                    condition,
                    ..
                },
            ..
        }) = self.motion
            && sensor == input
            && meets(condition)
        {
            self.sensor_found();
        }
        self.run();
    }

    /// An input's level.
    #[must_use]
    pub fn input(&self, input: IoPoint) -> Level {
        self.inputs[usize::from(input.get())]
    }

    /// An output's level.
    #[must_use]
    pub fn output(&self, output: IoPoint) -> Level {
        self.outputs[usize::from(output.get())]
    }

    // ----- what the drive shows ---------------------------------------------------------

    /// The position at the drive's clock, counts, exact on the profile.
    #[must_use]
    pub fn position_counts(&self) -> f64 {
        self.motion
            .as_ref()
            .map_or(self.rest_counts, |m| m.at(self.clock_s).0)
    }

    /// The velocity at the drive's clock, counts/s.
    #[must_use]
    pub fn velocity_counts_s(&self) -> f64 {
        self.motion.as_ref().map_or(0.0, |m| m.at(self.clock_s).1)
    }

    /// The position `IP` reports: the nearest whole count.
    #[must_use]
    #[allow(clippy::cast_possible_truncation)]
    pub fn position_integer(&self) -> i64 {
        self.position_counts().round() as i64
    }

    /// Where the current motion ends (where the drive rests when it does not move);
    /// `None` while an `FS` looks for its sensor.
    #[must_use]
    pub fn target_counts(&self) -> Option<f64> {
        match &self.motion {
            Some(motion) => motion
                .profile
                .end_counts()
                .map(|end| end + motion.offset_counts),
            None => Some(self.rest_counts),
        }
    }

    /// Whether the motor moves.
    #[must_use]
    pub fn is_moving(&self) -> bool {
        self.motion.is_some()
    }

    /// Whether a program runs or buffered commands wait to run.
    #[must_use]
    pub fn is_executing(&self) -> bool {
        self.program.is_some() || !self.host.is_empty()
    }

    /// Whether the motor is enabled.
    #[must_use]
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// The alarm code (`AL`).
    #[must_use]
    pub fn alarm_code(&self) -> u16 {
        self.alarm
    }

    /// The status word (`SC`), with the bits in [`status`].
    #[must_use]
    pub fn status_code(&self) -> u16 {
        let mut code = 0;
        if self.enabled {
            code |= status::MOTOR_ENABLED;
        }
        match &self.motion {
            None => code |= status::IN_POSITION,
            Some(motion) => {
                code |= status::MOVING;
                if motion.kind == MotionKind::Stopping {
                    code |= status::STOPPING;
                }
            }
        }
        match self.wait {
            Wait::Input { .. } => code |= status::WAITING_INPUT,
            Wait::Until { wt: true, .. } => code |= status::WAITING_TIME,
            _ => {}
        }
        if self.alarm != 0 {
            code |= status::ALARM;
        }
        if self.program.is_some() {
            code |= status::Q_RUNNING;
        }
        code
    }

    /// A register's value.
    #[must_use]
    pub fn register(&self, register: Register) -> i32 {
        let index = usize::from(register.character() as u8 - b'0');
        match register.character() {
            'e' => i32::try_from(self.position_integer() + self.encoder_offset_counts)
                .unwrap_or(i32::MAX),
            'f' => i32::from(self.alarm),
            'h' => i32::try_from(self.condition.value).unwrap_or(i32::MAX),
            JOG_REGISTER => i32::try_from(self.jog_steps).unwrap_or(i32::MAX),
            _ => self.registers.get(index).copied().unwrap_or(0),
        }
    }

    /// The outputs' changes so far (the latest [`LOG_CAPACITY`] at most).
    #[must_use]
    pub fn output_changes(&self) -> &[OutputChange] {
        &self.output_log
    }

    /// The moves' ends so far (the latest [`LOG_CAPACITY`] at most).
    #[must_use]
    pub fn move_ends(&self) -> &[MoveEnd] {
        &self.move_log
    }

    // ----- the task ---------------------------------------------------------------------

    /// Runs the task at the drive's clock until it waits or has nothing to do.
    pub(super) fn run(&mut self) {
        loop {
            match self.wait {
                Wait::Nothing => {}
                Wait::Input { input, condition } => {
                    if level_condition(self.input(input)) == condition {
                        self.wait = Wait::Nothing;
                    } else {
                        return;
                    }
                }
                Wait::Motion => {
                    if self.motion.is_some() {
                        return;
                    }
                    self.wait = Wait::Nothing;
                }
                Wait::Until { .. } | Wait::Spin => return,
            }
            if self.program.is_some() {
                if self.steps_at_instant >= STEPS_PER_INSTANT {
                    self.wait = if self.motion.is_some() {
                        Wait::Until {
                            at_s: self.clock_s + PAUSE_S,
                            wt: false,
                        }
                    } else {
                        Wait::Spin
                    };
                    return;
                }
                self.steps_at_instant += 1;
                self.program_step();
            } else if !self.paused
                && let Some(&command) = self.host.front()
            {
                match self.execute(command) {
                    Step::Again => {}
                    _ => {
                        self.host.pop_front();
                    }
                }
            } else {
                return;
            }
        }
    }

    /// Executes one buffered command (from the host or the queue).
    pub(super) fn execute(&mut self, command: Command) -> Step {
        match command {
            Command::FeedToLength | Command::FeedToPosition | Command::FeedToSensor { .. } => {
                if self.motion.is_some() {
                    self.wait = Wait::Motion;
                    return Step::Again;
                }
                if !self.start_move(command) {
                    return Step::Stop;
                }
                if !self.multitasking {
                    self.wait = Wait::Motion;
                }
                Step::Next
            }
            Command::CommenceJogging => {
                match self.motion.as_ref().map(|motion| motion.kind) {
                    // Already jogging: nothing more.
                    Some(MotionKind::Jog { .. }) => return Step::Next,
                    Some(_) => {
                        self.wait = Wait::Motion;
                        return Step::Again;
                    }
                    None => {}
                }
                if !self.enabled || self.alarm != 0 {
                    self.fault(alarm::NO_MOVE);
                    return Step::Stop;
                }
                // HCR p. 64: CJ starts at JS, the way the last DI says.
                let steps = units::VELOCITY.steps(self.jog_speed_rev_s).unwrap_or(0);
                let direction = if self.distance_counts < 0 { -1.0 } else { 1.0 };
                self.jog_steps = if direction < 0.0 { -steps } else { steps };
                let speed = self.jog_counts_s(self.jog_steps);
                let (accel, decel) = self.jog_rates();
                self.motion = Some(Motion {
                    start_s: self.clock_s,
                    profile: Profile::run(self.rest_counts, 0.0, speed, accel, decel),
                    kind: MotionKind::Jog { direction },
                    offset_counts: 0.0,
                });
                // A jog is a move that never ends by itself: with `MT0` what follows
                // waits until something stops it (`SJ`, `ST`, `SK` — none of which a
                // program can hold: HCR p. 64); with `MT1` the program goes on.
                if !self.multitasking {
                    self.wait = Wait::Motion;
                }
                Step::Next
            }
            Command::StopMove { rate } => {
                // HCR p. 250: stops the move under way (a jog at `JL`), not a wait.
                match rate {
                    StopRate::Decel if self.is_jogging() => self.stop_jog(),
                    _ => self.stop_motion(),
                }
                Step::Next
            }
            Command::WaitOnMove => {
                if self.motion.is_some() {
                    self.wait = Wait::Motion;
                }
                Step::Next
            }
            Command::Pause => {
                self.paused = true;
                Step::Next
            }
            Command::WaitTime { s } => {
                self.wait = Wait::Until {
                    at_s: self.clock_s + units::WAIT.held(s).unwrap_or(0.0),
                    wt: true,
                };
                Step::Next
            }
            Command::WaitForInput { input, condition } => {
                let level = self.input(input);
                if condition != level_condition(level) {
                    self.wait = Wait::Input { input, condition };
                }
                Step::Next
            }
            Command::QueueExecute { segment } if self.program.is_none() => {
                // From the host's buffer: the segment runs (HCR p. 220).
                if !self.queue_command(Command::QueueExecute { segment }) {
                    return Step::Stop;
                }
                Step::Next
            }
            Command::QueueGoto { .. }
            | Command::QueueRepeat { .. }
            | Command::QueueJump { .. }
            | Command::QueueCall { .. }
            | Command::QueueExecute { .. } => self.flow(command),
            Command::StopKill => {
                self.stop_and_kill();
                Step::Stop
            }
            Command::MotorDisable => {
                self.apply(command);
                Step::Stop
            }
            other => {
                self.apply(other);
                Step::Next
            }
        }
    }

    /// Applies a command that takes no time and does not move the program.
    fn apply(&mut self, command: Command) {
        match command {
            Command::Distance {
                counts: Some(counts),
            } => self.distance_counts = counts,
            Command::Velocity { rev_s: Some(v) } => self.velocity_rev_s = v,
            Command::Acceleration { rev_s2: Some(a) } => self.accel_rev_s2 = a,
            Command::Deceleration { rev_s2: Some(d) } => self.decel_rev_s2 = d,
            Command::JogSpeed { rev_s: Some(v) } => self.jog_speed_rev_s = v,
            Command::JogAcceleration { rev_s2: Some(a) } => self.jog_accel_rev_s2 = a,
            Command::JogDeceleration { rev_s2: Some(d) } => self.jog_decel_rev_s2 = d,
            Command::ElectronicGearing {
                steps_per_rev: Some(s),
            } => self.steps_per_rev = s,
            Command::SetPosition {
                counts: Some(counts),
            } => {
                let shift = f64::from(counts) - self.position_counts();
                self.rest_counts += shift;
                if let Some(motion) = &mut self.motion {
                    motion.offset_counts += shift;
                }
            }
            Command::EncoderPosition {
                counts: Some(counts),
            } => self.encoder_offset_counts = i64::from(counts) - self.position_integer(),
            Command::Multitasking { on: Some(on) } => self.multitasking = on,
            Command::SetOutput { output, level } => {
                let index = usize::from(output.get());
                if self.outputs[index] != level {
                    self.outputs[index] = level;
                    log(
                        &mut self.output_log,
                        OutputChange {
                            at_s: self.clock_s,
                            output,
                            level,
                        },
                    );
                }
            }
            Command::TestInput { input, level } => {
                let truth = self.input(input) == level;
                self.condition = ConditionCode {
                    truth,
                    value: i64::from(truth),
                };
            }
            Command::TestRegister { register, value } => {
                self.compare(i64::from(self.register(register)), i64::from(value));
            }
            Command::CompareRegisters { first, second } => {
                self.compare(
                    i64::from(self.register(first)),
                    i64::from(self.register(second)),
                );
            }
            Command::RegisterLoad { register, value } => self.write_register(register, value),
            Command::RegisterMove {
                destination,
                source,
            } => self.write_register(destination, self.register(source)),
            Command::RegisterMath { op, first, second } => {
                let (a, b) = (self.register(first), self.register(second));
                let result = match op {
                    MathOp::Add => a.wrapping_add(b),
                    MathOp::Subtract => a.wrapping_sub(b),
                    MathOp::Multiply => a.wrapping_mul(b),
                    MathOp::Divide => a.checked_div(b).unwrap_or(0),
                    MathOp::Or => a | b,
                    MathOp::And => a & b,
                };
                self.write_register(Register::ACCUMULATOR, result);
                self.condition = ConditionCode {
                    truth: result != 0,
                    value: i64::from(result),
                };
            }
            Command::StopKill => self.stop_and_kill(),
            Command::Stop => self.stop_motion(),
            Command::MotorEnable => self.enabled = true,
            Command::MotorDisable => {
                // The motor lets go where it is; nothing runs any more.
                self.rest_counts = self.position_counts();
                self.motion = None;
                self.enabled = false;
                self.kill();
            }
            Command::AlarmReset => self.alarm = 0,
            _ => {}
        }
    }

    /// Ends a [`Wait::Spin`]: the looping program goes on.
    fn wake(&mut self) {
        self.wait = Wait::Nothing;
        self.steps_at_instant = 0;
    }

    fn compare(&mut self, first: i64, second: i64) {
        let value = first - second;
        self.condition = ConditionCode {
            truth: value == 0,
            value,
        };
    }

    fn write_register(&mut self, register: Register, value: i32) {
        if register.is_read_only() {
            return;
        }
        if register.character() == JOG_REGISTER {
            // HCR p. 64: loading `J` changes the jog speed (0.25 rpm units, signed
            // as `CS`: the direction), not `JS` nor `DI`.
            self.set_jog_steps(i64::from(value));
            return;
        }
        let index = usize::from(register.character() as u8 - b'0');
        if let Some(slot) = self.registers.get_mut(index) {
            *slot = value;
        }
    }

    /// Empties the command buffer and ends the program (and a `QL` load); nothing
    /// waits.
    pub(super) fn kill(&mut self) {
        self.host.clear();
        self.program = None;
        self.loading = false;
        self.paused = false;
        self.wait = Wait::Nothing;
    }

    /// The jog velocity (the `J` register) set to `steps` of 1/240 rev/s, signed:
    /// while jogging, reached at `JA` (faster) or `JL` (slower), through 0 when the
    /// sign changes.
    fn set_jog_steps(&mut self, steps: i64) {
        self.jog_steps = steps;
        if let Some(motion) = &self.motion
            && let MotionKind::Jog { .. } = motion.kind
        {
            let (x, v) = motion.at(self.clock_s);
            let speed = self.jog_counts_s(steps);
            let (accel, decel) = self.jog_rates();
            let direction = if steps < 0 { -1.0 } else { 1.0 };
            self.motion = Some(Motion {
                start_s: self.clock_s,
                profile: Profile::run(x, v, speed, accel, decel),
                kind: MotionKind::Jog { direction },
                offset_counts: 0.0,
            });
        }
    }

    /// A jog velocity in steps of 1/240 rev/s, counts/s.
    fn jog_counts_s(&self, steps: i64) -> f64 {
        steps as f64 * units::VELOCITY.step * f64::from(self.steps_per_rev)
    }

    /// Ends a jog: slows down to rest at `JL` (`SJ`, or `SM D` while jogging).
    fn stop_jog(&mut self) {
        if let Some(motion) = &self.motion
            && let MotionKind::Jog { .. } = motion.kind
        {
            let (x, v) = motion.at(self.clock_s);
            let (_, decel) = self.jog_rates();
            self.motion = Some(Motion {
                start_s: self.clock_s,
                profile: Profile::stop(x, v, decel),
                kind: MotionKind::Move,
                offset_counts: 0.0,
            });
            // A stop that takes no time ends the motion now.
            self.set_clock(self.clock_s);
        }
    }

    /// `SK`: stops the motion and erases the queue (HCR p. 249) and the buffer.
    fn stop_and_kill(&mut self) {
        self.stop_motion();
        self.kill();
        self.queue.clear();
        self.running_segment = None;
    }

    /// Slows the motion down to rest at `DE`.
    fn stop_motion(&mut self) {
        let decel = self.counts(self.decel_rev_s2, units::ACCELERATION);
        if let Some(motion) = &self.motion
            && motion.kind != MotionKind::Stopping
        {
            let (x, v) = motion.at(self.clock_s);
            self.motion = Some(Motion {
                start_s: self.clock_s,
                profile: Profile::stop(x, v, decel),
                kind: MotionKind::Stopping,
                offset_counts: 0.0,
            });
            // A stop that takes no time ends the motion now.
            self.set_clock(self.clock_s);
        }
    }

    /// `JA` and `JL` as the drive holds them, counts/s².
    fn jog_rates(&self) -> (f64, f64) {
        (
            self.counts(self.jog_accel_rev_s2, units::ACCELERATION),
            self.counts(self.jog_decel_rev_s2, units::ACCELERATION),
        )
    }

    /// A rev/s (or rev/s²) value, as the drive holds it in `resolution`'s steps, in
    /// counts/s (counts/s²).
    fn counts(&self, rev: Decimal, resolution: units::Resolution) -> f64 {
        resolution.held(rev).unwrap_or(0.0) * f64::from(self.steps_per_rev)
    }

    /// Raises an alarm: the move is not made, the buffer and the program are killed.
    fn fault(&mut self, bits: u16) -> bool {
        self.alarm |= bits;
        self.kill();
        false
    }

    /// Starts `FL`, `FP` or `FS`; `false` (and an alarm) if the drive may not move.
    fn start_move(&mut self, command: Command) -> bool {
        if !self.enabled || self.alarm != 0 {
            return self.fault(alarm::NO_MOVE);
        }
        let here = self.rest_counts;
        let (speed, accel, decel) = (
            self.counts(self.velocity_rev_s, units::VELOCITY),
            self.counts(self.accel_rev_s2, units::ACCELERATION),
            self.counts(self.decel_rev_s2, units::ACCELERATION),
        );
        let distance = f64::from(self.distance_counts);
        let (profile, kind) = match command {
            Command::FeedToSensor { input, condition } => {
                let direction = if self.distance_counts < 0 { -1.0 } else { 1.0 };
                (
                    Profile::run(here, 0.0, direction * speed, accel, decel),
                    MotionKind::Seek {
                        input,
                        condition,
                        distance_counts: distance.abs(),
                        decel_counts_s2: decel,
                        speed_counts_s: speed,
                        accel_counts_s2: accel,
                    },
                )
            }
            _ => {
                let target = if command == Command::FeedToLength {
                    here + distance
                } else {
                    distance
                };
                if let Some((low, high)) = self.config.soft_limits_counts
                    && (target < f64::from(low) || target > f64::from(high))
                {
                    return self.fault(alarm::POSITION_LIMIT);
                }
                (
                    Profile::to_rest(here, 0.0, target, speed, accel, decel),
                    MotionKind::Move,
                )
            }
        };
        self.motion = Some(Motion {
            start_s: self.clock_s,
            profile,
            kind,
            offset_counts: 0.0,
        });
        if let MotionKind::Seek {
            input, condition, ..
        } = kind
        {
            // A level already met is found at once.
            if level_condition(self.input(input)) == condition {
                self.sensor_found();
            }
        }
        // A move of no length ends now.
        self.set_clock(self.clock_s);
        true
    }

    /// `FS` met its sensor: go on at the speed it has, then slow down at `DE` to stop
    /// `DI` past the sensor — or, when `DI` is shorter than the distance `DE` needs to
    /// stop from that speed, that distance.
    fn sensor_found(&mut self) {
        let Some(motion) = &self.motion else {
            return;
        };
        let MotionKind::Seek {
            distance_counts,
            decel_counts_s2,
            speed_counts_s,
            accel_counts_s2,
            ..
        } = motion.kind
        else {
            return;
        };
        let (x, v) = motion.at(self.clock_s);
        let direction = if v < 0.0 { -1.0 } else { 1.0 };
        let stopping = v * v / (2.0 * decel_counts_s2);
        let target = x + direction * distance_counts.max(stopping);
        self.motion = Some(Motion {
            start_s: self.clock_s,
            profile: Profile::to_rest(
                x,
                v,
                target,
                speed_counts_s.max(v.abs()),
                accel_counts_s2,
                decel_counts_s2,
            ),
            kind: MotionKind::Move,
            offset_counts: 0.0,
        });
        self.set_clock(self.clock_s);
    }

    /// The lines `QU` sends for `segment` (`None`: the queue).
    #[must_use]
    pub fn queue_upload(&self, segment: Option<Segment>) -> QueueUpload {
        if self.program.is_some() {
            return QueueUpload::ProgramRunning;
        }
        match segment {
            None => QueueUpload::Lines(self.queue.clone()),
            Some(segment) => self
                .segment(segment)
                .map_or(QueueUpload::NoSegment, |lines| {
                    QueueUpload::Lines(lines.to_vec())
                }),
        }
    }

    /// A stored segment's lines, if it was written.
    #[must_use]
    pub fn segment(&self, segment: Segment) -> Option<&[Command]> {
        self.segments
            .get(usize::from(segment.get()) - 1)
            .and_then(|s| s.as_deref())
    }

    /// The queue's lines.
    #[must_use]
    pub fn queue(&self) -> &[Command] {
        &self.queue
    }

    /// Raises the Blank Q Segment alarm and kills (a call or load of nothing).
    pub(super) fn blank_segment(&mut self) {
        self.fault(alarm::BLANK_Q_SEGMENT);
    }
}

/// The condition a level meets.
fn level_condition(level: Level) -> InputCondition {
    match level {
        Level::High => InputCondition::High,
        Level::Low => InputCondition::Low,
    }
}

fn log<T>(log: &mut Vec<T>, entry: T) {
    if log.len() >= LOG_CAPACITY {
        log.drain(..LOG_CAPACITY / 2);
    }
    log.push(entry);
}
