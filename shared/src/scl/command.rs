//! SCL commands as typed values, and their text (`Display`): mnemonic, then the
//! parameter, no spaces. The carriage return that ends a command on the wire is added
//! by [`Request::to_wire`].

use std::fmt;

/// A decimal number exactly as SCL writes it: `mantissa / 10^scale`. The scale is kept,
/// so `VE20` and `VE20.0` stay apart and every value prints back as it was read (some
/// drives want the decimal point in `VE`, see `docs/protocol-notes.md`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Decimal {
    mantissa: i64,
    scale: u8,
}

impl Decimal {
    /// The most digits after the point.
    pub const MAX_SCALE: u8 = 9;

    /// `mantissa / 10^scale`; `None` if `scale` exceeds [`Self::MAX_SCALE`] or the
    /// mantissa is `i64::MIN` (whose digits do not fit the type once the sign is read).
    #[must_use]
    pub const fn new(mantissa: i64, scale: u8) -> Option<Self> {
        if scale > Self::MAX_SCALE || mantissa == i64::MIN {
            None
        } else {
            Some(Self { mantissa, scale })
        }
    }

    /// A whole number, written without a point.
    #[must_use]
    pub const fn from_int(value: i32) -> Self {
        Self {
            mantissa: value as i64,
            scale: 0,
        }
    }

    /// The digits as an integer.
    #[must_use]
    pub const fn mantissa(self) -> i64 {
        self.mantissa
    }

    /// The number of digits after the point.
    #[must_use]
    pub const fn scale(self) -> u8 {
        self.scale
    }

    /// Whether the value is below zero.
    #[must_use]
    pub const fn is_negative(self) -> bool {
        self.mantissa < 0
    }

    /// The value without its sign.
    #[must_use]
    pub const fn abs(self) -> Self {
        Self {
            mantissa: self.mantissa.abs(),
            scale: self.scale,
        }
    }

    /// The value as a float.
    #[must_use]
    #[allow(clippy::cast_precision_loss)] // A display value; 53 bits are plenty.
    pub fn to_f64(self) -> f64 {
        self.mantissa as f64 / 10_f64.powi(i32::from(self.scale))
    }
}

impl fmt::Display for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let sign = if self.mantissa < 0 { "-" } else { "" };
        let digits = self.mantissa.unsigned_abs();
        if self.scale == 0 {
            return write!(f, "{sign}{digits}");
        }
        let divisor = 10_u64.pow(u32::from(self.scale));
        let width = usize::from(self.scale);
        write!(f, "{sign}{}.{:0width$}", digits / divisor, digits % divisor)
    }
}

/// An RS-485 address character: sent before a command, it addresses one drive on a
/// shared line, and that drive puts it before its answer (`1DI8000` → `1%`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Address(u8);

impl Address {
    /// Every character this codec takes as an address: the digits and the punctuation
    /// that cannot start a command or an answer (`%`, `*`, `?` answer; `!`, `@` and
    /// `~` have other meanings; letters start commands).
    pub const CHARACTERS: &'static str = "0123456789\"#$&'()+,-./:;<=>";

    /// The address of a character, if it can be one.
    #[must_use]
    pub fn new(character: char) -> Option<Self> {
        u8::try_from(character)
            .ok()
            .filter(|byte| Self::CHARACTERS.as_bytes().contains(byte))
            .map(Self)
    }

    /// The character.
    #[must_use]
    pub fn character(self) -> char {
        char::from(self.0)
    }
}

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.character())
    }
}

/// A Q data register, named by one character: `0` the accumulator, `1`–`9` and
/// ``: ; < = > ? @ [ \ ] ^ _ ` `` user registers, `A`–`Z` read/write registers tied to
/// parameters (`A` acceleration, `D` distance, …), `a`–`z` read-only ones (`e` encoder
/// position, `f` alarm code, `h` condition code, …).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Register(u8);

impl Register {
    /// The accumulator, where the math commands put their result.
    pub const ACCUMULATOR: Self = Self(b'0');

    /// The register named by `character` (`'0'` to `'z'`).
    #[must_use]
    pub fn new(character: char) -> Option<Self> {
        u8::try_from(character)
            .ok()
            .filter(|byte| (b'0'..=b'z').contains(byte))
            .map(Self)
    }

    /// Its character.
    #[must_use]
    pub fn character(self) -> char {
        char::from(self.0)
    }

    /// Whether the drive only lets programs read it (`a`–`z`).
    #[must_use]
    pub fn is_read_only(self) -> bool {
        self.0.is_ascii_lowercase()
    }
}

impl fmt::Display for Register {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.character())
    }
}

/// A number in a bounded range, written in decimal: Q line numbers, segments and I/O
/// points.
macro_rules! bounded {
    ($(#[$doc:meta])* $name:ident, $min:expr, $max:expr, $range:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(u8);

        impl $name {
            /// The smallest value.
            pub const MIN: u8 = $min;
            /// The largest value.
            pub const MAX: u8 = $max;
            /// The range, in words (for error messages).
            pub const RANGE: &'static str = $range;

            /// The value, if it is in range.
            #[must_use]
            pub const fn new(value: u8) -> Option<Self> {
                if value >= Self::MIN && value <= Self::MAX {
                    Some(Self(value))
                } else {
                    None
                }
            }

            /// The number.
            #[must_use]
            pub const fn get(self) -> u8 {
                self.0
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                write!(f, "{}", self.0)
            }
        }
    };
}

bounded!(
    /// A line of the queue (a Q program segment has up to 62 lines).
    QLine, 1, 62, "1 to 62"
);
bounded!(
    /// A stored Q program segment (a drive holds up to 12).
    Segment, 1, 12, "1 to 12"
);
bounded!(
    /// An input (`X`n) or output (`Y`n) point, one digit.
    IoPoint, 0, 9, "one digit, 0 to 9"
);

/// The state of an input that `WI` waits for and `FS` stops at.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum InputCondition {
    /// `H`: high (open).
    High,
    /// `L`: low (closed).
    Low,
    /// `R`: a rising edge.
    Rising,
    /// `F`: a falling edge.
    Falling,
}

impl InputCondition {
    /// Every condition.
    pub const ALL: [Self; 4] = [Self::High, Self::Low, Self::Rising, Self::Falling];

    /// Its letter.
    #[must_use]
    pub const fn letter(self) -> char {
        match self {
            Self::High => 'H',
            Self::Low => 'L',
            Self::Rising => 'R',
            Self::Falling => 'F',
        }
    }

    /// The condition of a letter.
    #[must_use]
    pub fn from_letter(letter: char) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.letter() == letter)
    }
}

/// A level: what `TI` tests an input for and `SO` sets an output to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Level {
    /// `H`: high (open).
    High,
    /// `L`: low (closed).
    Low,
}

impl Level {
    /// Its letter.
    #[must_use]
    pub const fn letter(self) -> char {
        match self {
            Self::High => 'H',
            Self::Low => 'L',
        }
    }

    /// The level of a letter.
    #[must_use]
    pub fn from_letter(letter: char) -> Option<Self> {
        match letter {
            'H' => Some(Self::High),
            'L' => Some(Self::Low),
            _ => None,
        }
    }
}

/// The condition a `QJ` jump tests (set by `TI`, `TR`, `CR` and the math commands).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JumpCondition {
    /// `T`: true.
    True,
    /// `F`: false.
    False,
    /// `P`: positive.
    Positive,
    /// `G`: greater than.
    Greater,
    /// `L`: less than.
    Less,
    /// `E`: equal.
    Equal,
    /// `U`: unequal.
    Unequal,
    /// `Z`: zero.
    Zero,
}

impl JumpCondition {
    /// Every condition, in the Host Command Reference's order.
    pub const ALL: [Self; 8] = [
        Self::True,
        Self::False,
        Self::Positive,
        Self::Greater,
        Self::Less,
        Self::Equal,
        Self::Unequal,
        Self::Zero,
    ];

    /// Its letter.
    #[must_use]
    pub const fn letter(self) -> char {
        match self {
            Self::True => 'T',
            Self::False => 'F',
            Self::Positive => 'P',
            Self::Greater => 'G',
            Self::Less => 'L',
            Self::Equal => 'E',
            Self::Unequal => 'U',
            Self::Zero => 'Z',
        }
    }

    /// The condition of a letter.
    #[must_use]
    pub fn from_letter(letter: char) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.letter() == letter)
    }
}

/// A register math operation: `R+ R- R* R/ R| R&` on two registers, the result in the
/// accumulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MathOp {
    /// `R+`: first + second.
    Add,
    /// `R-`: first − second.
    Subtract,
    /// `R*`: first × second.
    Multiply,
    /// `R/`: first ÷ second.
    Divide,
    /// `R|`: bitwise or.
    Or,
    /// `R&`: bitwise and.
    And,
}

impl MathOp {
    /// Every operation.
    pub const ALL: [Self; 6] = [
        Self::Add,
        Self::Subtract,
        Self::Multiply,
        Self::Divide,
        Self::Or,
        Self::And,
    ];

    /// Its symbol, after the `R`.
    #[must_use]
    pub const fn symbol(self) -> char {
        match self {
            Self::Add => '+',
            Self::Subtract => '-',
            Self::Multiply => '*',
            Self::Divide => '/',
            Self::Or => '|',
            Self::And => '&',
        }
    }

    /// The operation of a symbol.
    #[must_use]
    pub fn from_symbol(symbol: char) -> Option<Self> {
        Self::ALL.into_iter().find(|op| op.symbol() == symbol)
    }
}

/// One SCL command. Where a command sets a value, `None` is its query form (`VE` alone
/// asks the drive for its velocity and it answers `VE=…`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Command {
    /// `FL`: feed to length — move `DI` counts from here (the sign is the direction)
    /// with `AC`, `DE` and `VE`.
    FeedToLength,
    /// `FP`: feed to position — move to the absolute position `DI`.
    FeedToPosition,
    /// `FS`: feed to sensor — run (direction from the sign of `DI`) until `input` meets
    /// `condition`, then travel `DI` more and stop.
    FeedToSensor {
        /// The input watched.
        input: IoPoint,
        /// The state that stops the move.
        condition: InputCondition,
    },
    /// `DI`: the distance (`FL`), target (`FP`) or distance after the sensor (`FS`), in
    /// steps or encoder counts.
    Distance {
        /// The value, or `None` to ask.
        counts: Option<i32>,
    },
    /// `VE`: the speed of moves, rev/s.
    Velocity {
        /// The speed, or `None` to ask.
        rev_s: Option<Decimal>,
    },
    /// `AC`: the acceleration of moves, rev/s².
    Acceleration {
        /// The acceleration, or `None` to ask.
        rev_s2: Option<Decimal>,
    },
    /// `DE`: the deceleration of moves, rev/s².
    Deceleration {
        /// The deceleration, or `None` to ask.
        rev_s2: Option<Decimal>,
    },
    /// `JS`: the jog speed, rev/s (what `CJ` runs at).
    JogSpeed {
        /// The speed, or `None` to ask.
        rev_s: Option<Decimal>,
    },
    /// `JA`: the jog acceleration, rev/s².
    JogAcceleration {
        /// The acceleration, or `None` to ask.
        rev_s2: Option<Decimal>,
    },
    /// `JL`: the jog deceleration, rev/s².
    JogDeceleration {
        /// The deceleration, or `None` to ask.
        rev_s2: Option<Decimal>,
    },
    /// `CJ`: commence jogging at `JS`, in the direction of the sign of `DI`.
    CommenceJogging,
    /// `CS`: change the speed while jogging, rev/s, **signed**: the sign is the
    /// direction (`-` backward), whatever `DI` says (HCR p. 71; reached at `JA`, or
    /// `JL` when slower). Immediate: it cannot be stored in a program.
    ChangeSpeed {
        /// The new velocity, rev/s (negative: backward).
        rev_s: Decimal,
    },
    /// `SJ`: stop jogging (slowing down at `JL`). Immediate (HCR p. 248): a program
    /// stops its jog with `SM` instead.
    StopJogging,
    /// `SM`: stop the move under way (HCR p. 250) — buffered, so a program can stop a
    /// jog (with `MT1`, HCR p. 64).
    StopMove {
        /// `D`: at `DE` (or `JL` when jogging); `M`: at `AM`.
        rate: StopRate,
    },
    /// `WM`: wait until the move under way ends (HCR p. 272; with `MT1`).
    WaitOnMove,
    /// `EG`: electronic gearing, steps per revolution.
    ElectronicGearing {
        /// Steps per revolution, or `None` to ask.
        steps_per_rev: Option<u32>,
    },
    /// `SP`: set the current absolute position (encoder counts; **not** a speed).
    SetPosition {
        /// The new position, or `None` to ask.
        counts: Option<i32>,
    },
    /// `EP`: the encoder position, counts (set or ask).
    EncoderPosition {
        /// The new position, or `None` to ask.
        counts: Option<i32>,
    },
    /// `IP`: ask the immediate (commanded) position.
    ImmediatePosition,
    /// `WI`: wait until `input` meets `condition` (`WI3F`).
    WaitForInput {
        /// The input.
        input: IoPoint,
        /// The state waited for.
        condition: InputCondition,
    },
    /// `WT`: wait, seconds.
    WaitTime {
        /// The time, s (not negative).
        s: Decimal,
    },
    /// `QG`: go to a line of the queue.
    QueueGoto {
        /// The line.
        line: QLine,
    },
    /// `QR`: repeat from `line` as many times as `count_register` holds.
    QueueRepeat {
        /// The register holding the count.
        count_register: Register,
        /// The line to repeat from.
        line: QLine,
    },
    /// `QJ`: jump to `line` if the condition code meets `condition`.
    QueueJump {
        /// The condition.
        condition: JumpCondition,
        /// The line.
        line: QLine,
    },
    /// `QC`: call a stored segment, or with `None` return to the caller.
    QueueCall {
        /// The segment called, or `None` to return.
        segment: Option<Segment>,
    },
    /// `QL`: load the queue — with a segment, from that stored segment; without
    /// (`QL` alone), from the host: every buffered command that follows becomes the
    /// next line until `QS` or `QE` (HCR p. 216).
    QueueLoad {
        /// The stored segment, or `None`: the lines that follow from the host.
        segment: Option<Segment>,
    },
    /// `QS`: save the queue as a stored segment.
    QueueSave {
        /// The segment.
        segment: Segment,
    },
    /// `QX`: load a stored segment and execute it.
    QueueExecute {
        /// The segment.
        segment: Segment,
    },
    /// `QE`: execute the queue.
    QueueExecuteLoaded,
    /// `QU`: upload a stored segment, or with `None` (`QU0`) the queue; the drive
    /// answers `%`, then `QU{lines + 1}` and each line (see
    /// [`QueueUpload`](super::response::QueueUpload)).
    QueueUpload {
        /// The segment read, or `None` for the queue.
        segment: Option<Segment>,
    },
    /// `TI`: test an input for a level (sets the condition code).
    TestInput {
        /// The input.
        input: IoPoint,
        /// The level tested for.
        level: Level,
    },
    /// `TR`: test a register against a value (sets the condition code).
    TestRegister {
        /// The register.
        register: Register,
        /// The value.
        value: i32,
    },
    /// `CR`: compare two registers (sets the condition code).
    CompareRegisters {
        /// The first register.
        first: Register,
        /// The second register.
        second: Register,
    },
    /// `MT`: multitasking on (`MT1`) or off (`MT0`).
    Multitasking {
        /// On or off, or `None` to ask.
        on: Option<bool>,
    },
    /// `SO`: set an output to a level (`SO1L`).
    SetOutput {
        /// The output.
        output: IoPoint,
        /// The level.
        level: Level,
    },
    /// `R+ R- R* R/ R| R&`: math on two registers; the result goes to the accumulator.
    RegisterMath {
        /// The operation.
        op: MathOp,
        /// The first operand.
        first: Register,
        /// The second operand.
        second: Register,
    },
    /// `RL`: load a register with a value at once, or with `None` ask it (immediate,
    /// HCR p. 226: never stored in a program).
    RegisterLoadImmediate {
        /// The register.
        register: Register,
        /// The value, or `None` to ask.
        value: Option<i32>,
    },
    /// `RX`: load a register with a value (buffered, HCR p. 234: a program may hold it;
    /// `RXJ` sets the jog speed while jogging, in 0.25 rpm, signed — HCR p. 64).
    RegisterLoad {
        /// The register.
        register: Register,
        /// The value.
        value: i32,
    },
    /// `RM`: copy a register into another.
    RegisterMove {
        /// The register written.
        destination: Register,
        /// The register read.
        source: Register,
    },
    /// `SK`: stop and kill — stop the motion and empty the command buffer.
    StopKill,
    /// `ST`: stop the motion (decelerate).
    Stop,
    /// `ME`: enable the motor.
    MotorEnable,
    /// `MD`: disable the motor.
    MotorDisable,
    /// `SC`: ask the status code.
    StatusCode,
    /// `AL`: ask the alarm code.
    AlarmCode,
    /// `AR`: reset the alarm.
    AlarmReset,
    /// `BS`: ask how many of the command buffer's 63 places are free (HCR p. 53).
    BufferStatus,
    /// `PS`: pause the command buffer: what follows is kept until `CT` (HCR p. 206).
    Pause,
    /// `CT`: continue the paused command buffer (immediate, HCR p. 72); sent without
    /// an address on RS-485 it continues every drive of the line at once (HCR p. 305).
    Continue,
}

/// How `SM` stops (HCR p. 250).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum StopRate {
    /// `D`: at `DE`, or at `JL` while jogging.
    Decel,
    /// `M`: at `AM`.
    Max,
}

impl StopRate {
    /// The letter on the wire.
    #[must_use]
    pub const fn letter(self) -> char {
        match self {
            Self::Decel => 'D',
            Self::Max => 'M',
        }
    }

    /// The rate of a letter.
    #[must_use]
    pub const fn from_letter(letter: char) -> Option<Self> {
        match letter {
            'D' => Some(Self::Decel),
            'M' => Some(Self::Max),
            _ => None,
        }
    }
}

/// Where a command goes when a drive receives it (HCR p. 13, and each command's
/// page: "Type").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// Into the command buffer (or, while `QL` loads, the queue), run one at a time;
    /// the only commands a stored program may hold (HCR p. 13).
    Buffered,
    /// Carried out the moment it arrives, never stored.
    Immediate,
}

impl Command {
    /// Every mnemonic, for error messages and tests (the math commands as `R+` … `R&`).
    pub const MNEMONICS: [&'static str; 54] = [
        "FL", "FP", "FS", "DI", "VE", "AC", "DE", "EG", "SP", "EP", "IP", "WI", "WT", "QG", "QR",
        "QJ", "QC", "QL", "QS", "QX", "QE", "QU", "TI", "TR", "CR", "MT", "SO", "R+", "R-", "R*",
        "R/", "R|", "R&", "RL", "RX", "RM", "SK", "ST", "ME", "MD", "SC", "AL", "AR", "JS", "JA",
        "JL", "CJ", "CS", "SJ", "SM", "WM", "BS", "PS", "CT",
    ];

    /// Buffered or immediate, as the HCR types it (the page of each: the command's
    /// page; a query — a setting without its value — is answered at once).
    #[must_use]
    pub const fn kind(&self) -> Kind {
        if self.is_query() {
            return Kind::Immediate;
        }
        match self {
            // p. 248 SJ, p. 71 CS, p. 249 SK, p. 254 ST, p. 41 AR, p. 140 IP,
            // p. 242 SC, p. 33 AL, p. 53 BS, p. 72 CT, p. 226 RL,
            // p. 216 QL, p. 218 QS, p. 212 QE, p. 219 QU.
            Self::StopJogging
            | Self::ChangeSpeed { .. }
            | Self::StopKill
            | Self::Stop
            | Self::AlarmReset
            | Self::ImmediatePosition
            | Self::StatusCode
            | Self::AlarmCode
            | Self::BufferStatus
            | Self::Continue
            | Self::RegisterLoadImmediate { .. }
            | Self::QueueLoad { .. }
            | Self::QueueSave { .. }
            | Self::QueueExecuteLoaded
            | Self::QueueUpload { .. } => Kind::Immediate,
            // Every other command here is BUFFERED on its page: among them DI (p. 77),
            // ME/MD (p. 176/175), CJ (p. 64), SM (p. 250), WM (p. 272), PS (p. 206),
            // RX (p. 234), QX (p. 220), QC (p. 210), MT (p. 183), JA/JL/JS (p. 150/155/157).
            _ => Kind::Buffered,
        }
    }

    /// The mnemonic.
    #[must_use]
    pub const fn mnemonic(&self) -> &'static str {
        match self {
            Self::FeedToLength => "FL",
            Self::FeedToPosition => "FP",
            Self::FeedToSensor { .. } => "FS",
            Self::Distance { .. } => "DI",
            Self::Velocity { .. } => "VE",
            Self::Acceleration { .. } => "AC",
            Self::Deceleration { .. } => "DE",
            Self::JogSpeed { .. } => "JS",
            Self::JogAcceleration { .. } => "JA",
            Self::JogDeceleration { .. } => "JL",
            Self::CommenceJogging => "CJ",
            Self::ChangeSpeed { .. } => "CS",
            Self::StopJogging => "SJ",
            Self::StopMove { .. } => "SM",
            Self::WaitOnMove => "WM",
            Self::BufferStatus => "BS",
            Self::Pause => "PS",
            Self::Continue => "CT",
            Self::RegisterLoadImmediate { .. } => "RL",
            Self::ElectronicGearing { .. } => "EG",
            Self::SetPosition { .. } => "SP",
            Self::EncoderPosition { .. } => "EP",
            Self::ImmediatePosition => "IP",
            Self::WaitForInput { .. } => "WI",
            Self::WaitTime { .. } => "WT",
            Self::QueueGoto { .. } => "QG",
            Self::QueueRepeat { .. } => "QR",
            Self::QueueJump { .. } => "QJ",
            Self::QueueCall { .. } => "QC",
            Self::QueueLoad { .. } => "QL",
            Self::QueueSave { .. } => "QS",
            Self::QueueExecute { .. } => "QX",
            Self::QueueExecuteLoaded => "QE",
            Self::QueueUpload { .. } => "QU",
            Self::TestInput { .. } => "TI",
            Self::TestRegister { .. } => "TR",
            Self::CompareRegisters { .. } => "CR",
            Self::Multitasking { .. } => "MT",
            Self::SetOutput { .. } => "SO",
            Self::RegisterMath { op, .. } => match op {
                MathOp::Add => "R+",
                MathOp::Subtract => "R-",
                MathOp::Multiply => "R*",
                MathOp::Divide => "R/",
                MathOp::Or => "R|",
                MathOp::And => "R&",
            },
            Self::RegisterLoad { .. } => "RX",
            Self::RegisterMove { .. } => "RM",
            Self::StopKill => "SK",
            Self::Stop => "ST",
            Self::MotorEnable => "ME",
            Self::MotorDisable => "MD",
            Self::StatusCode => "SC",
            Self::AlarmCode => "AL",
            Self::AlarmReset => "AR",
        }
    }

    /// Whether this is a query (a command that asks and sets nothing).
    #[must_use]
    pub const fn is_query(&self) -> bool {
        matches!(
            self,
            Self::Distance { counts: None }
                | Self::Velocity { rev_s: None }
                | Self::Acceleration { rev_s2: None }
                | Self::Deceleration { rev_s2: None }
                | Self::JogSpeed { rev_s: None }
                | Self::JogAcceleration { rev_s2: None }
                | Self::JogDeceleration { rev_s2: None }
                | Self::ElectronicGearing {
                    steps_per_rev: None
                }
                | Self::SetPosition { counts: None }
                | Self::EncoderPosition { counts: None }
                | Self::Multitasking { on: None }
                | Self::ImmediatePosition
                | Self::StatusCode
                | Self::AlarmCode
                | Self::BufferStatus
                | Self::RegisterLoadImmediate { value: None, .. }
        )
    }
}

/// Writes `value` if there is one (the query form writes nothing).
fn optional(f: &mut fmt::Formatter<'_>, value: Option<impl fmt::Display>) -> fmt::Result {
    match value {
        Some(value) => write!(f, "{value}"),
        None => Ok(()),
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.mnemonic())?;
        match *self {
            Self::FeedToSensor { input, condition } | Self::WaitForInput { input, condition } => {
                write!(f, "{input}{}", condition.letter())
            }
            Self::Distance { counts }
            | Self::SetPosition { counts }
            | Self::EncoderPosition { counts } => optional(f, counts),
            Self::Velocity { rev_s } | Self::JogSpeed { rev_s } => optional(f, rev_s),
            Self::Acceleration { rev_s2 }
            | Self::Deceleration { rev_s2 }
            | Self::JogAcceleration { rev_s2 }
            | Self::JogDeceleration { rev_s2 } => optional(f, rev_s2),
            Self::ChangeSpeed { rev_s } => write!(f, "{rev_s}"),
            Self::ElectronicGearing { steps_per_rev } => optional(f, steps_per_rev),
            Self::WaitTime { s } => write!(f, "{s}"),
            Self::QueueGoto { line } => write!(f, "{line}"),
            Self::QueueRepeat {
                count_register,
                line,
            } => write!(f, "{count_register}{line}"),
            Self::QueueJump { condition, line } => write!(f, "{}{line}", condition.letter()),
            Self::QueueCall { segment } | Self::QueueLoad { segment } => optional(f, segment),
            Self::QueueSave { segment } | Self::QueueExecute { segment } => {
                write!(f, "{segment}")
            }
            Self::StopMove { rate } => write!(f, "{}", rate.letter()),
            Self::RegisterLoadImmediate { register, value } => {
                write!(f, "{register}")?;
                optional(f, value)
            }
            // The queue is segment 0 on the wire.
            Self::QueueUpload { segment } => match segment {
                Some(segment) => write!(f, "{segment}"),
                None => f.write_str("0"),
            },
            Self::TestInput { input, level } => write!(f, "{input}{}", level.letter()),
            Self::SetOutput { output, level } => write!(f, "{output}{}", level.letter()),
            Self::TestRegister { register, value } | Self::RegisterLoad { register, value } => {
                write!(f, "{register}{value}")
            }
            Self::CompareRegisters { first, second } | Self::RegisterMath { first, second, .. } => {
                write!(f, "{first}{second}")
            }
            Self::RegisterMove {
                destination,
                source,
            } => write!(f, "{destination}{source}"),
            Self::Multitasking { on } => optional(f, on.map(u8::from)),
            Self::FeedToLength
            | Self::FeedToPosition
            | Self::ImmediatePosition
            | Self::QueueExecuteLoaded
            | Self::StopKill
            | Self::Stop
            | Self::MotorEnable
            | Self::MotorDisable
            | Self::StatusCode
            | Self::AlarmCode
            | Self::AlarmReset
            | Self::CommenceJogging
            | Self::StopJogging
            | Self::WaitOnMove
            | Self::BufferStatus
            | Self::Pause
            | Self::Continue => Ok(()),
        }
    }
}

/// A command as sent: an optional RS-485 address, then the command. Its text is
/// `Display`; [`Request::to_wire`] adds the carriage return.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Request {
    /// The drive addressed, if the line is shared.
    pub address: Option<Address>,
    /// The command.
    pub command: Command,
}

impl Request {
    /// A command without an address (one drive on the line, or eSCL).
    #[must_use]
    pub const fn new(command: Command) -> Self {
        Self {
            address: None,
            command,
        }
    }

    /// A command to the drive at `address`.
    #[must_use]
    pub const fn to(address: Address, command: Command) -> Self {
        Self {
            address: Some(address),
            command,
        }
    }

    /// The bytes on a serial line: the text and a carriage return.
    #[must_use]
    pub fn to_wire(&self) -> Vec<u8> {
        super::wire(self)
    }
}

impl fmt::Display for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        optional(f, self.address)?;
        write!(f, "{}", self.command)
    }
}
