//! A unit's 256-row PVT table and its run, as a deterministic state machine driven by
//! time (manual §7.2–§7.4, §8 MP/PV/QP/QV/QT).
//!
//! The simulator wraps one [`PvtTable`] per simulated unit. The planner does not run
//! this table: it predicts FIFO water levels on paper ([`crate::uim2503::schedule`]) from
//! the rows' start times, with the same table size ([`TABLE_ROWS`]; one slot is held by
//! the running row). Time is a parameter in µs of the unit's system time (the clock
//! `BG=N;` refers to) and nothing here allocates.
//!
//! Drive it like a sans-IO protocol state machine: first bring the table to the time an
//! instruction takes effect with [`PvtTable::advance`] (and act on the [`Events`] it
//! returns), then apply the instruction. Every change applies at the time of the last
//! `advance`.
//!
//! ```
//! use floatball_shared::uim2503::pvt::{Mode, PvtTable};
//!
//! # fn main() -> Result<(), floatball_shared::uim2503::pvt::PvtError> {
//! let mut table = PvtTable::new(100_000.0); // SD: stop deceleration, counts/s²
//! table.set_mp(3, 0)?; // FIFO
//! table.set_mp(5, 1)?; // watermark: notify when one row is left
//! for (index, position) in [(0u8, 1000), (1, 2000), (2, 3000)] {
//!     table.write_position(index, position);
//!     table.write_velocity(index, 0);
//!     table.write_time(index, 100)?;
//! }
//! assert_eq!(table.pv(), 3); // FIFO: PV answers the water level
//! table.set_start_row(0)?;
//! table.begin(0.0, 0.0)?; // from the unit's current position and velocity
//! let events = table.advance(100_000); // 100 ms later row 1 starts, one row is left
//! assert_eq!(events.watermark.map(|w| w.pending), Some(1));
//! assert_eq!(table.state_at(100_000).map(|k| k.position), Some(1000.0));
//! assert_eq!(table.mode(), Mode::Fifo);
//! # Ok(())
//! # }
//! ```
//!
//! Where the manual is silent this model decides, and says so on the item concerned:
//! rows are read when they start (later writes only affect later executions); every
//! `QT` write raises the water level; the watermark fires when the pending rows *fall
//! to* `MP[5]`; in single-sequence mode the pending rows are those up to `MP[2]`.

use thiserror::Error;

use crate::motion::{Kinematics, Segment};

/// Number of rows in a unit's PVT table.
pub const TABLE_ROWS: usize = 256;

/// Shortest row duration `QT` accepts, ms.
pub const ROW_MIN_MS: u8 = 10;

/// Longest row duration `QT` accepts, ms.
pub const ROW_MAX_MS: u8 = 255;

/// Most rows that can be pending in FIFO mode (all of the table, when idle).
const FIFO_CAPACITY: u16 = 256;

/// One row of the table as written with `QP[X]`, `QV[X]`, `QT[X]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Row {
    /// `QP[X]`: target position, counts.
    pub position_counts: i32,
    /// `QV[X]`: velocity at the target, counts/s.
    pub velocity_counts_s: i32,
    /// `QT[X]`: duration, ms (0 = never written or cleared; otherwise 10–255).
    pub duration_ms: u8,
}

impl Row {
    /// The segment this row describes when it starts from `position_counts` moving at
    /// `velocity_counts_s`.
    #[must_use]
    pub fn segment_from(&self, position_counts: f64, velocity_counts_s: f64) -> Segment {
        Segment::new(
            position_counts,
            velocity_counts_s,
            f64::from(self.position_counts),
            f64::from(self.velocity_counts_s),
            f64::from(self.duration_ms) / 1000.0,
        )
    }
}

/// How the table is run, `MP[3]`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Mode {
    /// `MP[3]=0`: the host keeps writing rows; they run in index order, wrapping
    /// 255 → 0, until none is pending.
    #[default]
    Fifo,
    /// `MP[3]=1`: run from the start row up to `MP[2]` once.
    Single,
    /// `MP[3]=3`: run from the start row up to `MP[2]`, then from `MP[1]` again, forever.
    Loop,
}

impl Mode {
    /// The `MP[3]` value of this mode.
    #[must_use]
    pub const fn code(self) -> u8 {
        match self {
            Self::Fifo => 0,
            Self::Single => 1,
            Self::Loop => 3,
        }
    }
}

/// Why a run ran out of rows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EndReason {
    /// Single-sequence mode finished row `MP[2]`.
    Completed,
    /// FIFO mode: no row was pending when the last one finished.
    Underflow,
    /// The next row has `QT` = 0 (never written, or cleared by `MP[0]=1`).
    EmptyRow {
        /// The row that could not run.
        index: u8,
    },
}

/// A row began executing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowStart {
    /// The row's index.
    pub index: u8,
    /// When it began, µs of system time.
    pub at_us: u64,
}

/// The pending rows fell to the watermark `MP[5]`: the unit sends its notification
/// (RTCN) three times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Watermark {
    /// When the level fell to the watermark, µs.
    pub at_us: u64,
    /// Rows pending at that moment (equal to `MP[5]`).
    pub pending: u16,
}

/// The run has no next row: PVT motion ends, braking with the stop deceleration (SD)
/// if the unit is still moving.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunEnd {
    /// When the last row finished (or `BG` found nothing to run), µs.
    pub at_us: u64,
    /// Why the run ended.
    pub reason: EndReason,
    /// Position at that moment, counts.
    pub position_counts: f64,
    /// Velocity at that moment, counts/s; braking follows unless it is zero.
    pub velocity_counts_s: f64,
}

/// The motion came to rest after a run ended.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stopped {
    /// When the unit came to rest, µs.
    pub at_us: u64,
    /// Where it rests, counts.
    pub position_counts: f64,
}

/// What happened during one [`PvtTable::advance`] (or [`PvtTable::begin`]).
///
/// Within one call the pending rows only fall, so each kind of notice happens at most
/// once, except row starts, which are counted.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Events {
    /// How many rows began executing.
    pub rows_started: u32,
    /// The last row that began.
    pub last_row: Option<RowStart>,
    /// The watermark notification is due.
    pub watermark: Option<Watermark>,
    /// The run ran out of rows.
    pub run_end: Option<RunEnd>,
    /// The unit came to rest after the run ended.
    pub stopped: Option<Stopped>,
}

/// An instruction the unit refuses (the manual's errors, and where it is silent the
/// choices this model makes, each said on its variant).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum PvtError {
    /// `PV=N` while the PVT motion moves: the manual says setting PV while the velocity
    /// is not zero returns an error.
    #[error("PV cannot be set while the ball is moving under PVT; wait until it stops")]
    PvWhileMoving,
    /// `PV=N` with N outside 0…255.
    #[error("PV={value}: the row index must be 0…255")]
    RowOutOfRange {
        /// The operand given.
        value: i32,
    },
    /// Single-sequence or loop mode with `MP[1]` ≥ `MP[2]` (the manual requires
    /// `MP[1] < MP[2]`); checked at `PV=N` and `BG`.
    #[error("MP[1]={first} must be less than MP[2]={last}")]
    RangeInverted {
        /// `MP[1]`, the first row.
        first: u8,
        /// `MP[2]`, the last row.
        last: u8,
    },
    /// Single-sequence or loop mode with a start row outside `MP[1]`…`MP[2]` (the
    /// manual: `MP[1] <= X <= MP[2]` for `PV=X`).
    #[error("PV={start} is outside the rows MP[1]={first}…MP[2]={last}")]
    StartOutsideRange {
        /// The start row.
        start: u8,
        /// `MP[1]`.
        first: u8,
        /// `MP[2]`.
        last: u8,
    },
    /// `QT[X]=0`: a row's duration can never be 0.
    #[error("QT[{index}]=0: a row's time can never be 0 (it must be 10…255 ms)")]
    QtZero {
        /// The row written.
        index: u8,
    },
    /// `QT[X]` outside 10…255 ms.
    #[error("QT[{index}]={value}: a row's time must be 10…255 ms")]
    QtOutOfRange {
        /// The row written.
        index: u8,
        /// The duration given, ms.
        value: i32,
    },
    /// FIFO mode: writing `QT` would make more rows pending than the table holds
    /// (256 when idle, 255 while a row runs, since the running row keeps its slot).
    /// The write is refused and nothing changes.
    #[error("QT[{index}]: the FIFO is full ({pending} rows pending); wait for the watermark")]
    FifoFull {
        /// The row written.
        index: u8,
        /// Rows pending.
        pending: u16,
    },
    /// `MP[X]` with X not 0…3, 5, 6 (`MP[4]` is reserved).
    #[error("MP[{index}] does not exist (MP[0]…MP[3], MP[5] and MP[6] do)")]
    NoSuchParameter {
        /// The parameter index.
        index: u8,
    },
    /// `MP[X]=N` with N outside the parameter's range (0…255; `MP[0]` takes 0 or 1,
    /// `MP[3]` 0, 1 or 3, `MP[5]` 0…254).
    #[error("MP[{index}]={value} is out of range")]
    ValueOutOfRange {
        /// The parameter index.
        index: u8,
        /// The value given.
        value: i32,
    },
    /// `MP[3]=2`: the manual reserves mode 2.
    #[error("MP[3]=2 is reserved; use 0 (FIFO), 1 (single sequence) or 3 (loop)")]
    ReservedMode,
    /// `MP[6]=N`: `MP[6]` (the next write index) can only be queried.
    #[error("MP[6] (the next write index) can only be queried")]
    ReadOnlyParameter,
    /// `MP[1]`, `MP[2]` (manual) or `MP[3]` (this model's choice) set while the ball
    /// moves under PVT.
    #[error("MP[{index}] cannot be changed while the ball is moving under PVT")]
    WhileMoving {
        /// The parameter index.
        index: u8,
    },
}

/// What the run is doing.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// No PVT motion (never begun, or aborted).
    Idle,
    /// A row is executing.
    Row {
        index: u8,
        start_us: u64,
        end_us: u64,
        segment: Segment,
    },
    /// Rows ran out while moving: braking with SD.
    Braking {
        start_us: u64,
        end_us: u64,
        position: f64,
        velocity: f64,
        decel: f64,
    },
    /// The run ended; the unit rests where it stopped.
    Holding { position: f64 },
}

/// The part of the state that time changes; copied to look ahead in `state_at`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Run {
    phase: Phase,
    /// FIFO water level: rows written (QT) and not yet started.
    level: u16,
    /// The row executing, or the last one executed, or the one `PV=N` named.
    read_index: u8,
}

/// One unit's PVT table, its `MP` parameters and its run.
///
/// Power-on state (the manual gives none): rows cleared, FIFO mode, `MP[1]=0`,
/// `MP[2]=255`, no watermark, start row 0, idle at time 0.
#[derive(Debug, Clone, PartialEq)]
pub struct PvtTable {
    rows: [Row; TABLE_ROWS],
    mode: Mode,
    first: u8,
    last: u8,
    watermark: u8,
    next_write: u8,
    start_index: u8,
    stop_decel_counts_s2: f64,
    now_us: u64,
    run: Run,
}

impl PvtTable {
    /// A table in its power-on state; `stop_decel_counts_s2` is the unit's SD setting,
    /// used when a run ends while moving.
    #[must_use]
    pub fn new(stop_decel_counts_s2: f64) -> Self {
        Self {
            rows: [Row::default(); TABLE_ROWS],
            mode: Mode::Fifo,
            first: 0,
            last: u8::MAX,
            watermark: 0,
            next_write: 0,
            start_index: 0,
            stop_decel_counts_s2,
            now_us: 0,
            run: Run {
                phase: Phase::Idle,
                level: 0,
                read_index: 0,
            },
        }
    }

    /// The time of the last [`advance`](Self::advance), µs.
    #[must_use]
    pub fn now_us(&self) -> u64 {
        self.now_us
    }

    /// The run mode, `MP[3]`.
    #[must_use]
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Row `index` as written.
    #[must_use]
    pub fn row(&self, index: u8) -> Row {
        self.rows[usize::from(index)]
    }

    /// The FIFO water level: rows written with `QT` and not yet started (0…256).
    #[must_use]
    pub fn water_level(&self) -> u16 {
        self.run.level
    }

    /// The answer to `PV;`: the water level in FIFO mode, otherwise the row executing
    /// (or last executed, or named by `PV=N`).
    #[must_use]
    pub fn pv(&self) -> u16 {
        match self.mode {
            Mode::Fifo => self.run.level,
            Mode::Single | Mode::Loop => u16::from(self.run.read_index),
        }
    }

    /// The answer to `MP[6];`: the row after the last one whose `QT` was written.
    #[must_use]
    pub fn next_write_index(&self) -> u8 {
        self.next_write
    }

    /// The answer to `MP[X];`. `MP[0]` (clear) reads as 0.
    ///
    /// # Errors
    /// [`PvtError::NoSuchParameter`] for `MP[4]` and X > 6.
    pub fn mp(&self, index: u8) -> Result<u8, PvtError> {
        match index {
            0 => Ok(0),
            1 => Ok(self.first),
            2 => Ok(self.last),
            3 => Ok(self.mode.code()),
            5 => Ok(self.watermark),
            6 => Ok(self.next_write),
            _ => Err(PvtError::NoSuchParameter { index }),
        }
    }

    /// The row executing now, if any.
    #[must_use]
    pub fn current_row(&self) -> Option<u8> {
        match self.run.phase {
            Phase::Row { index, .. } => Some(index),
            Phase::Idle | Phase::Braking { .. } | Phase::Holding { .. } => None,
        }
    }

    /// Whether PVT motion is under way (a row executing, or braking after the last).
    #[must_use]
    pub fn is_moving(&self) -> bool {
        matches!(self.run.phase, Phase::Row { .. } | Phase::Braking { .. })
    }

    /// `QP[X]=N`. The row is read when it starts, so changing a pending row is allowed.
    pub fn write_position(&mut self, index: u8, counts: i32) {
        self.rows[usize::from(index)].position_counts = counts;
    }

    /// `QV[X]=N`.
    pub fn write_velocity(&mut self, index: u8, counts_s: i32) {
        self.rows[usize::from(index)].velocity_counts_s = counts_s;
    }

    /// `QT[X]=N`: sets the duration and raises the water level by one (every `QT`
    /// write does, as the manual says; outside FIFO mode the level is only counted,
    /// up to 256). `MP[6]` becomes X + 1.
    ///
    /// # Errors
    /// [`PvtError::QtZero`], [`PvtError::QtOutOfRange`], and in FIFO mode
    /// [`PvtError::FifoFull`]; a refused write changes nothing.
    pub fn write_time(&mut self, index: u8, ms: i32) -> Result<(), PvtError> {
        let duration_ms = match u8::try_from(ms) {
            Ok(0) => return Err(PvtError::QtZero { index }),
            Ok(ms) if ms >= ROW_MIN_MS => ms,
            _ => return Err(PvtError::QtOutOfRange { index, value: ms }),
        };
        if self.mode == Mode::Fifo {
            let capacity = match self.run.phase {
                Phase::Row { .. } => FIFO_CAPACITY - 1,
                Phase::Idle | Phase::Braking { .. } | Phase::Holding { .. } => FIFO_CAPACITY,
            };
            if self.run.level >= capacity {
                return Err(PvtError::FifoFull {
                    index,
                    pending: self.run.level,
                });
            }
        }
        self.rows[usize::from(index)].duration_ms = duration_ms;
        self.run.level = (self.run.level + 1).min(FIFO_CAPACITY);
        self.next_write = index.wrapping_add(1);
        Ok(())
    }

    /// `MP[X]=N`.
    ///
    /// - `MP[0]=1` clears every row at once, the water level, the write index and the
    ///   start row; a row already executing finishes (it was read when it started),
    ///   then the run ends for lack of rows. `MP[0]=0` does nothing.
    /// - `MP[1]`, `MP[2]`: first and last row for single-sequence and loop mode.
    /// - `MP[3]`: the [`Mode`].
    /// - `MP[5]`: the watermark, 0 (off) or 1…254.
    ///
    /// # Errors
    /// See [`PvtError`]: unknown or read-only parameters, values out of range, mode 2,
    /// and `MP[1]`…`MP[3]` while moving.
    pub fn set_mp(&mut self, index: u8, value: i32) -> Result<(), PvtError> {
        match index {
            0..=3 | 5 => {}
            6 => return Err(PvtError::ReadOnlyParameter),
            _ => return Err(PvtError::NoSuchParameter { index }),
        }
        let out_of_range = PvtError::ValueOutOfRange { index, value };
        let n = u8::try_from(value).map_err(|_| out_of_range)?;
        if matches!(index, 1..=3) && self.is_moving() {
            return Err(PvtError::WhileMoving { index });
        }
        match (index, n) {
            (0, 0) => {}
            (0, 1) => self.clear(),
            (1, _) => self.first = n,
            (2, _) => self.last = n,
            (3, 0) => self.mode = Mode::Fifo,
            (3, 1) => self.mode = Mode::Single,
            (3, 2) => return Err(PvtError::ReservedMode),
            (3, 3) => self.mode = Mode::Loop,
            (5, 0..=254) => self.watermark = n,
            _ => return Err(out_of_range),
        }
        Ok(())
    }

    /// `PV=N`: the next [`begin`](Self::begin) starts at row N.
    ///
    /// # Errors
    /// [`PvtError::RowOutOfRange`]; [`PvtError::PvWhileMoving`] if the PVT motion's
    /// velocity is not zero now; in single-sequence and loop mode
    /// [`PvtError::RangeInverted`] and [`PvtError::StartOutsideRange`].
    pub fn set_start_row(&mut self, value: i32) -> Result<(), PvtError> {
        let index = u8::try_from(value).map_err(|_| PvtError::RowOutOfRange { value })?;
        let moving = self.is_moving();
        if moving
            && self
                .state_at(self.now_us)
                .is_some_and(|k| k.velocity != 0.0)
        {
            return Err(PvtError::PvWhileMoving);
        }
        self.check_start(index)?;
        self.start_index = index;
        if !moving {
            self.run.read_index = index;
        }
        Ok(())
    }

    /// Sets the stop deceleration (SD), counts/s², used by runs that end from now on.
    /// A value that is not a positive finite number stops the motion at once.
    pub fn set_stop_deceleration(&mut self, counts_s2: f64) {
        self.stop_decel_counts_s2 = counts_s2;
    }

    /// `BG`: begins running at the start row (`PV=N`) now, from the unit's current
    /// position and velocity; the first row is one segment from there, so they should
    /// be close to that row's start (the manual's warning). Replaces any run under way.
    /// In FIFO mode with nothing pending the run ends at once.
    ///
    /// # Errors
    /// In single-sequence and loop mode [`PvtError::RangeInverted`] and
    /// [`PvtError::StartOutsideRange`] (the parameters may have changed since `PV=N`).
    pub fn begin(
        &mut self,
        position_counts: f64,
        velocity_counts_s: f64,
    ) -> Result<Events, PvtError> {
        self.check_start(self.start_index)?;
        let mut events = Events::default();
        let mut run = self.run;
        if self.mode == Mode::Fifo && run.level == 0 {
            self.end_run(
                &mut run,
                self.now_us,
                position_counts,
                velocity_counts_s,
                EndReason::Underflow,
                &mut events,
            );
        } else {
            self.start_row(
                &mut run,
                self.start_index,
                self.now_us,
                position_counts,
                velocity_counts_s,
                &mut events,
            );
        }
        self.run = run;
        Ok(events)
    }

    /// Ends PVT motion at once without braking: the motor was switched off (`MO=0`) or
    /// another motion mode took over (`PA=…;BG;`). The rows and the water level stay.
    pub fn abort(&mut self) {
        self.run.phase = Phase::Idle;
    }

    /// Runs the table up to `now_us` and reports what happened. A time earlier than
    /// the last one changes nothing.
    pub fn advance(&mut self, now_us: u64) -> Events {
        let mut events = Events::default();
        if now_us > self.now_us {
            let mut run = self.run;
            self.run_until(&mut run, now_us, &mut events);
            self.run = run;
            self.now_us = now_us;
        }
        events
    }

    /// Position, velocity and acceleration of the PVT motion at `at_us` (counts,
    /// counts/s, counts/s²), as [`advance`](Self::advance) to that time would leave it
    /// if nothing is written meanwhile; times before the last `advance` read as that
    /// time. After a run ends the unit rests where it stopped; `None` when there is no
    /// PVT motion (never begun, or aborted).
    #[must_use]
    pub fn state_at(&self, at_us: u64) -> Option<Kinematics> {
        let at_us = at_us.max(self.now_us);
        let mut run = self.run;
        self.run_until(&mut run, at_us, &mut Events::default());
        match run.phase {
            Phase::Idle => None,
            Phase::Row {
                start_us, segment, ..
            } => Some(segment.kinematics(micros_to_s(at_us - start_us))),
            Phase::Braking {
                start_us,
                position,
                velocity,
                decel,
                ..
            } => Some(braking(
                position,
                velocity,
                decel,
                micros_to_s(at_us - start_us),
            )),
            Phase::Holding { position } => Some(Kinematics {
                position,
                velocity: 0.0,
                acceleration: 0.0,
            }),
        }
    }

    fn clear(&mut self) {
        self.rows = [Row::default(); TABLE_ROWS];
        self.run.level = 0;
        self.next_write = 0;
        self.start_index = 0;
        if !self.is_moving() {
            self.run.read_index = 0;
        }
    }

    fn check_start(&self, start: u8) -> Result<(), PvtError> {
        let (first, last) = (self.first, self.last);
        match self.mode {
            Mode::Fifo => Ok(()),
            Mode::Single | Mode::Loop if first >= last => {
                Err(PvtError::RangeInverted { first, last })
            }
            Mode::Single | Mode::Loop if start < first || start > last => {
                Err(PvtError::StartOutsideRange { start, first, last })
            }
            Mode::Single | Mode::Loop => Ok(()),
        }
    }

    fn run_until(&self, run: &mut Run, until_us: u64, events: &mut Events) {
        loop {
            match run.phase {
                Phase::Row {
                    index,
                    end_us,
                    segment,
                    ..
                } if end_us <= until_us => {
                    // The row ends exactly at its target: the next starts from there.
                    let (position, velocity) = (segment.p1, segment.v1);
                    match self.next_index(run, index) {
                        Ok(next) => {
                            self.start_row(run, next, end_us, position, velocity, events);
                        }
                        Err(reason) => {
                            self.end_run(run, end_us, position, velocity, reason, events);
                        }
                    }
                }
                Phase::Braking {
                    start_us,
                    end_us,
                    position,
                    velocity,
                    decel,
                } if end_us <= until_us => {
                    let rest = braking(position, velocity, decel, micros_to_s(end_us - start_us));
                    run.phase = Phase::Holding {
                        position: rest.position,
                    };
                    events.stopped = Some(Stopped {
                        at_us: end_us,
                        position_counts: rest.position,
                    });
                }
                Phase::Idle | Phase::Row { .. } | Phase::Braking { .. } | Phase::Holding { .. } => {
                    return;
                }
            }
        }
    }

    fn next_index(&self, run: &Run, index: u8) -> Result<u8, EndReason> {
        match self.mode {
            Mode::Fifo if run.level > 0 => Ok(index.wrapping_add(1)),
            Mode::Fifo => Err(EndReason::Underflow),
            Mode::Single if index >= self.last => Err(EndReason::Completed),
            Mode::Single => Ok(index + 1),
            Mode::Loop if index == self.last => Ok(self.first),
            Mode::Loop => Ok(index.wrapping_add(1)),
        }
    }

    fn start_row(
        &self,
        run: &mut Run,
        index: u8,
        at_us: u64,
        position: f64,
        velocity: f64,
        events: &mut Events,
    ) {
        let row = self.rows[usize::from(index)];
        if row.duration_ms == 0 {
            let reason = EndReason::EmptyRow { index };
            self.end_run(run, at_us, position, velocity, reason, events);
            return;
        }
        run.phase = Phase::Row {
            index,
            start_us: at_us,
            end_us: at_us.saturating_add(u64::from(row.duration_ms) * 1000),
            segment: row.segment_from(position, velocity),
        };
        run.read_index = index;
        events.rows_started = events.rows_started.saturating_add(1);
        events.last_row = Some(RowStart { index, at_us });
        let pending = match self.mode {
            Mode::Fifo => {
                run.level = run.level.saturating_sub(1);
                Some(run.level)
            }
            Mode::Single => Some(u16::from(self.last.saturating_sub(index))),
            Mode::Loop => None,
        };
        if let Some(pending) = pending
            && self.watermark != 0
            && pending == u16::from(self.watermark)
        {
            events.watermark = Some(Watermark { at_us, pending });
        }
    }

    fn end_run(
        &self,
        run: &mut Run,
        at_us: u64,
        position: f64,
        velocity: f64,
        reason: EndReason,
        events: &mut Events,
    ) {
        events.run_end = Some(RunEnd {
            at_us,
            reason,
            position_counts: position,
            velocity_counts_s: velocity,
        });
        let decel = self.stop_decel_counts_s2;
        if velocity != 0.0 && decel > 0.0 && decel.is_finite() {
            let duration_us = (velocity.abs() / decel * 1e6).ceil();
            run.phase = Phase::Braking {
                start_us: at_us,
                // A float-to-int `as` saturates, which is what an absurd SD deserves.
                end_us: at_us.saturating_add(duration_us as u64),
                position,
                velocity,
                decel,
            };
        } else {
            run.phase = Phase::Holding { position };
            events.stopped = Some(Stopped {
                at_us,
                position_counts: position,
            });
        }
    }
}

/// Converts a span of system time to seconds.
fn micros_to_s(us: u64) -> f64 {
    // Exact for any span below 2^53 µs (285 years).
    us as f64 / 1e6
}

/// Braking from `velocity` at constant `decel` for `tau_s` seconds (held at rest once
/// the velocity reaches zero).
fn braking(position: f64, velocity: f64, decel: f64, tau_s: f64) -> Kinematics {
    let stop_s = velocity.abs() / decel;
    let acceleration = -velocity.signum() * decel;
    if tau_s >= stop_s {
        Kinematics {
            position: position + velocity * stop_s + 0.5 * acceleration * stop_s * stop_s,
            velocity: 0.0,
            acceleration: 0.0,
        }
    } else {
        Kinematics {
            position: position + velocity * tau_s + 0.5 * acceleration * tau_s * tau_s,
            velocity: velocity + acceleration * tau_s,
            acceleration,
        }
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;

    const SD: f64 = 200_000.0;
    const MS: u64 = 1000;

    fn write_row(table: &mut PvtTable, index: u8, p: i32, v: i32, t: i32) {
        table.write_position(index, p);
        table.write_velocity(index, v);
        table.write_time(index, t).unwrap();
    }

    /// The §7.4 single-sequence and loop examples give rows 3, 4 and the last; the rows
    /// between ("……") are a smooth ramp here.
    fn ramp(index: u8) -> (i32, i32) {
        (4000 + (i32::from(index) - 4) * 40, 400)
    }

    #[test]
    fn single_sequence_follows_the_manual_step_by_step() {
        let mut t = PvtTable::new(SD);
        // Steps 2-4: MP[3]=1; MP[1]=3; MP[2]=100.
        t.set_mp(3, 1).unwrap();
        t.set_mp(1, 3).unwrap();
        t.set_mp(2, 100).unwrap();
        // Step 5: the rows.
        write_row(&mut t, 3, 1000, 0, 100);
        write_row(&mut t, 4, 4000, 500, 100);
        for i in 5..100 {
            let (p, v) = ramp(i);
            write_row(&mut t, i, p, v, 100);
        }
        write_row(&mut t, 100, 8000, 0, 100);
        assert_eq!(t.next_write_index(), 101);
        // Step 6: PTP to 4000 (the simulator's job); step 7: PV=4; BG; at 1 s.
        let t0 = 1_000_000;
        assert!(t.advance(t0).rows_started == 0);
        t.set_start_row(4).unwrap();
        assert_eq!(t.pv(), 4);
        let events = t.begin(4000.0, 0.0).unwrap();
        assert_eq!(
            events.last_row,
            Some(RowStart {
                index: 4,
                at_us: t0
            })
        );
        assert_eq!(t.current_row(), Some(4));
        // Row by row: each starts exactly where the previous ended.
        for index in 5..=100u8 {
            let start = t0 + u64::from(index - 4) * 100 * MS;
            let before = t.advance(start - 1);
            assert_eq!(before.rows_started, 0);
            let events = t.advance(start);
            assert_eq!(events.rows_started, 1);
            assert_eq!(events.last_row.map(|r| r.index), Some(index));
            assert_eq!(t.pv(), u16::from(index), "PV answers the row executing");
            let previous = t.row(index - 1);
            let k = t.state_at(start).unwrap();
            assert_eq!(k.position, f64::from(previous.position_counts));
            assert_eq!(k.velocity, f64::from(previous.velocity_counts_s));
        }
        // MP[1]/MP[2] cannot change while running.
        assert_eq!(t.set_mp(2, 50), Err(PvtError::WhileMoving { index: 2 }));
        // Row 100 ends at rest: the run completes without braking.
        let end = t0 + 97 * 100 * MS;
        let events = t.advance(end);
        let run_end = events.run_end.unwrap();
        assert_eq!(run_end.reason, EndReason::Completed);
        assert_eq!(run_end.at_us, end);
        assert_eq!(events.stopped.unwrap().position_counts, 8000.0);
        assert!(!t.is_moving());
        assert_eq!(t.state_at(end + 5_000_000).unwrap().position, 8000.0);
        assert_eq!(t.pv(), 100);
    }

    #[test]
    fn a_run_that_ends_moving_brakes_with_sd() {
        let mut t = PvtTable::new(SD);
        t.set_mp(3, 1).unwrap();
        t.set_mp(1, 0).unwrap();
        t.set_mp(2, 1).unwrap();
        write_row(&mut t, 0, 1000, 10_000, 100);
        write_row(&mut t, 1, 3000, 20_000, 100);
        t.set_start_row(0).unwrap();
        t.begin(0.0, 0.0).unwrap();
        let events = t.advance(200 * MS);
        let run_end = events.run_end.unwrap();
        assert_eq!(run_end.velocity_counts_s, 20_000.0);
        assert!(events.stopped.is_none());
        assert!(t.is_moving());
        // PV cannot be set while braking at speed.
        assert_eq!(t.set_start_row(0), Err(PvtError::PvWhileMoving));
        // Braking 20000/s at 200000/s² takes 100 ms and covers 1000 counts.
        let mid = t.state_at(250 * MS).unwrap();
        assert!((mid.velocity - 10_000.0).abs() < 1e-6);
        assert_eq!(mid.acceleration, -SD);
        let events = t.advance(300 * MS);
        let stopped = events.stopped.unwrap();
        assert_eq!(stopped.at_us, 300 * MS);
        assert!((stopped.position_counts - 4000.0).abs() < 1e-6);
        assert!(!t.is_moving());
        assert_eq!(t.set_start_row(0), Ok(()));
    }

    #[test]
    fn loop_follows_the_manual_and_wraps_to_mp1() {
        let mut t = PvtTable::new(SD);
        t.set_mp(3, 3).unwrap();
        t.set_mp(1, 3).unwrap();
        t.set_mp(2, 100).unwrap();
        t.set_mp(5, 5).unwrap(); // no effect in loop mode
        write_row(&mut t, 3, 1000, 0, 100);
        write_row(&mut t, 4, 4000, 500, 100);
        for i in 5..100 {
            let (p, v) = ramp(i);
            write_row(&mut t, i, p, v, 100);
        }
        write_row(&mut t, 100, 1000, 0, 100);
        // PA=1000 then PV=3; BG;
        t.set_start_row(3).unwrap();
        t.begin(1000.0, 0.0).unwrap();
        let mut expected = 3u8;
        for step in 1..=3 * 98u64 {
            expected = if expected == 100 { 3 } else { expected + 1 };
            let events = t.advance(step * 100 * MS);
            assert_eq!(events.rows_started, 1);
            assert_eq!(events.last_row.map(|r| r.index), Some(expected));
            assert!(events.watermark.is_none(), "no watermark in loop mode");
            assert!(events.run_end.is_none());
            assert_eq!(t.pv(), u16::from(expected));
        }
        // After MP[2] the loop restarts at MP[1] from QP[100]/QV[100].
        let k = t.state_at(t.now_us()).unwrap();
        assert_eq!((k.position, k.velocity), (1000.0, 0.0));
        // A long jump runs many rows in one advance.
        let events = t.advance(3 * 98 * 100 * MS + 98 * 100 * MS);
        assert_eq!(events.rows_started, 98);
        assert_eq!(t.current_row(), Some(3));
    }

    #[test]
    fn fifo_follows_the_manual_with_watermark_and_wrap() {
        let mut t = PvtTable::new(SD);
        let row = |i: u8| -> (i32, i32) {
            let i = i32::from(i);
            (1000 + 10 * i, 100)
        };
        // Steps 2-4.
        t.set_mp(3, 0).unwrap();
        t.set_mp(5, 5).unwrap();
        t.set_mp(0, 1).unwrap();
        // Step 5: rows 0..=10.
        for i in 0..=10 {
            let (p, v) = row(i);
            write_row(&mut t, i, p, v, 100);
        }
        assert_eq!(t.pv(), 11, "PV answers the water level in FIFO mode");
        assert_eq!(t.mp(6), Ok(11));
        // Steps 6-7: PA=1000; BG; then PV=0; BG; at 0.5 s.
        let t0 = 500 * MS;
        t.advance(t0);
        t.set_start_row(0).unwrap();
        let events = t.begin(1000.0, 0.0).unwrap();
        assert_eq!(events.last_row.map(|r| r.index), Some(0));
        assert_eq!(t.water_level(), 10, "the running row is no longer pending");
        // Step 8: rows 11..=255 while row 0 runs.
        for i in 11..=255 {
            let (p, v) = row(i);
            write_row(&mut t, i, p, v, 100);
        }
        assert_eq!(t.water_level(), 255);
        assert_eq!(t.mp(6), Ok(0), "the write index wraps 255 -> 0");
        // The table is full: 255 pending plus the running row.
        assert_eq!(
            t.write_time(0, 100),
            Err(PvtError::FifoFull {
                index: 0,
                pending: 255
            })
        );
        // Step 9: wait for the watermark; it comes when row 250 starts (251..=255 left).
        let at = |k: u64| t0 + k * 100 * MS;
        for k in 1..250 {
            let events = t.advance(at(k));
            assert_eq!(events.last_row.map(|r| u64::from(r.index)), Some(k));
            assert!(events.watermark.is_none());
            assert_eq!(u64::from(t.pv()), 255 - k);
        }
        let events = t.advance(at(250));
        assert_eq!(
            events.watermark,
            Some(Watermark {
                at_us: at(250),
                pending: 5
            })
        );
        // Step 10: rows 0..=249 (at most 249 as the manual says, since 5 are pending).
        for i in 0..=249 {
            let (p, v) = row(i);
            write_row(&mut t, i, p, v, 100);
        }
        assert_eq!(t.water_level(), 255);
        assert!(t.write_time(250, 100).is_err());
        // Step 11: the next watermark, when row 244 starts after the wrap.
        let events = t.advance(at(256 + 243));
        assert!(events.watermark.is_none());
        assert_eq!(t.current_row(), Some(243));
        let events = t.advance(at(256 + 244));
        assert_eq!(events.watermark.map(|w| w.at_us), Some(at(256 + 244)));
        // Step 12: everything written has run: row 249 ends, nothing is pending, the
        // unit brakes from QV[249] with SD.
        let last_end = at(256 + 250);
        let events = t.advance(last_end);
        let run_end = events.run_end.unwrap();
        assert_eq!(run_end.reason, EndReason::Underflow);
        assert_eq!(run_end.at_us, last_end);
        assert_eq!(run_end.position_counts, f64::from(row(249).0));
        assert_eq!(t.water_level(), 0);
        // 100 counts/s at 200000 counts/s² stops in 0.5 ms, 0.025 counts further.
        let events = t.advance(last_end + 500);
        let stopped = events.stopped.unwrap();
        assert_eq!(stopped.at_us, last_end + 500);
        assert!((stopped.position_counts - (f64::from(row(249).0) + 0.025)).abs() < 1e-9);
    }

    #[test]
    fn fifo_begin_with_nothing_pending_ends_at_once() {
        let mut t = PvtTable::new(SD);
        let events = t.begin(10.0, 0.0).unwrap();
        assert_eq!(events.rows_started, 0);
        assert_eq!(events.run_end.unwrap().reason, EndReason::Underflow);
        assert_eq!(events.stopped.unwrap().position_counts, 10.0);
    }

    #[test]
    fn an_idle_fifo_holds_256_rows() {
        let mut t = PvtTable::new(SD);
        for i in 0..=255 {
            write_row(&mut t, i, 0, 0, 10);
        }
        assert_eq!(t.pv(), 256);
        assert!(matches!(
            t.write_time(0, 10),
            Err(PvtError::FifoFull { pending: 256, .. })
        ));
        t.begin(0.0, 0.0).unwrap();
        assert_eq!(t.pv(), 255);
    }

    #[test]
    fn single_mode_watermark_counts_rows_up_to_mp2() {
        let mut t = PvtTable::new(SD);
        t.set_mp(3, 1).unwrap();
        t.set_mp(1, 0).unwrap();
        t.set_mp(2, 10).unwrap();
        t.set_mp(5, 3).unwrap();
        for i in 0..=10 {
            write_row(&mut t, i, 0, 0, 10);
        }
        t.set_start_row(0).unwrap();
        t.begin(0.0, 0.0).unwrap();
        let events = t.advance(60 * MS);
        assert_eq!(events.rows_started, 6);
        assert!(events.watermark.is_none());
        let events = t.advance(70 * MS);
        assert_eq!(events.last_row.map(|r| r.index), Some(7));
        assert_eq!(events.watermark.map(|w| w.pending), Some(3));
    }

    #[test]
    fn the_row_is_read_when_it_starts() {
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 100, 0, 100);
        write_row(&mut t, 1, 200, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        // Changing the running row does not change its motion; changing a pending one does.
        t.write_position(0, 5000);
        t.write_position(1, 300);
        t.advance(100 * MS);
        assert_eq!(t.state_at(100 * MS).unwrap().position, 100.0);
        assert_eq!(t.state_at(200 * MS).unwrap().position, 300.0);
    }

    #[test]
    fn an_unwritten_row_ends_a_single_run() {
        let mut t = PvtTable::new(SD);
        t.set_mp(3, 1).unwrap();
        t.set_mp(1, 0).unwrap();
        t.set_mp(2, 5).unwrap();
        write_row(&mut t, 0, 100, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        let events = t.advance(100 * MS);
        assert_eq!(
            events.run_end.map(|e| e.reason),
            Some(EndReason::EmptyRow { index: 1 })
        );
    }

    #[test]
    fn clearing_mid_run_lets_the_running_row_finish() {
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 100, 0, 100);
        write_row(&mut t, 1, 200, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        t.advance(50 * MS);
        t.set_mp(0, 1).unwrap();
        assert_eq!(t.pv(), 0);
        assert_eq!(t.row(1), Row::default());
        let events = t.advance(100 * MS);
        assert_eq!(events.run_end.map(|e| e.reason), Some(EndReason::Underflow));
        assert_eq!(events.stopped.map(|s| s.position_counts), Some(100.0));
    }

    #[test]
    fn state_at_looks_ahead_like_advance() {
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 1000, 8000, 100);
        write_row(&mut t, 1, 2000, 9000, 110);
        write_row(&mut t, 2, 3000, 9500, 90);
        write_row(&mut t, 3, 2000, -9000, 110);
        write_row(&mut t, 4, 1000, -8000, 100);
        t.begin(0.0, 0.0).unwrap();
        let ahead: Vec<_> = (0..700).map(|ms| t.state_at(ms * MS)).collect();
        for (ms, expected) in (0..700).zip(ahead) {
            t.advance(ms * MS);
            assert_eq!(t.state_at(ms * MS), expected, "at {ms} ms");
        }
        // The manual's rows end exactly on their targets.
        let mut t2 = PvtTable::new(SD);
        for (i, (p, v, ms)) in [(1000, 8000, 100), (2000, 9000, 110), (3000, 9500, 90)]
            .into_iter()
            .enumerate()
        {
            write_row(&mut t2, u8::try_from(i).unwrap(), p, v, ms);
        }
        t2.begin(0.0, 0.0).unwrap();
        let k = t2.state_at(210 * MS).unwrap();
        assert_eq!((k.position, k.velocity), (2000.0, 9000.0));
    }

    #[test]
    fn abort_ends_motion_and_keeps_the_rows() {
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 1000, 0, 100);
        write_row(&mut t, 1, 1000, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        t.abort();
        assert!(t.state_at(0).is_none());
        assert!(!t.is_moving());
        assert_eq!(t.water_level(), 1);
    }

    #[test]
    fn the_manuals_errors() {
        let mut t = PvtTable::new(SD);
        assert_eq!(t.write_time(3, 0), Err(PvtError::QtZero { index: 3 }));
        for bad in [1, 9, 256, -5] {
            assert_eq!(
                t.write_time(3, bad),
                Err(PvtError::QtOutOfRange {
                    index: 3,
                    value: bad
                })
            );
        }
        assert_eq!(t.water_level(), 0, "refused writes change nothing");
        t.write_time(3, 10).unwrap();
        t.write_time(3, 255).unwrap();
        assert_eq!(t.water_level(), 2, "every QT write raises the level");
        assert_eq!(t.set_mp(3, 2), Err(PvtError::ReservedMode));
        assert_eq!(
            t.set_mp(3, 4),
            Err(PvtError::ValueOutOfRange { index: 3, value: 4 })
        );
        assert_eq!(t.set_mp(4, 0), Err(PvtError::NoSuchParameter { index: 4 }));
        assert_eq!(t.set_mp(7, 0), Err(PvtError::NoSuchParameter { index: 7 }));
        assert_eq!(
            t.set_mp(9, 300),
            Err(PvtError::NoSuchParameter { index: 9 })
        );
        assert_eq!(t.mp(4), Err(PvtError::NoSuchParameter { index: 4 }));
        assert_eq!(t.set_mp(6, 0), Err(PvtError::ReadOnlyParameter));
        assert_eq!(
            t.set_mp(5, 255),
            Err(PvtError::ValueOutOfRange {
                index: 5,
                value: 255
            })
        );
        assert_eq!(
            t.set_mp(1, 256),
            Err(PvtError::ValueOutOfRange {
                index: 1,
                value: 256
            })
        );
        assert_eq!(
            t.set_mp(0, 2),
            Err(PvtError::ValueOutOfRange { index: 0, value: 2 })
        );
        assert_eq!(
            t.set_start_row(256),
            Err(PvtError::RowOutOfRange { value: 256 })
        );
        // MP[1] >= MP[2] in single-sequence and loop mode.
        for mode in [1, 3] {
            t.set_mp(3, mode).unwrap();
            t.set_mp(1, 20).unwrap();
            t.set_mp(2, 20).unwrap();
            assert_eq!(
                t.set_start_row(20),
                Err(PvtError::RangeInverted {
                    first: 20,
                    last: 20
                })
            );
            assert_eq!(
                t.begin(0.0, 0.0),
                Err(PvtError::RangeInverted {
                    first: 20,
                    last: 20
                })
            );
            t.set_mp(2, 30).unwrap();
            assert_eq!(
                t.set_start_row(31),
                Err(PvtError::StartOutsideRange {
                    start: 31,
                    first: 20,
                    last: 30
                })
            );
            t.set_start_row(25).unwrap();
        }
        // PV while moving; MP[3] while moving.
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 1000, 100, 100);
        write_row(&mut t, 1, 2000, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        t.advance(50 * MS);
        assert_eq!(t.set_start_row(0), Err(PvtError::PvWhileMoving));
        assert_eq!(t.set_mp(3, 1), Err(PvtError::WhileMoving { index: 3 }));
        // The watermark may change while running.
        assert_eq!(t.set_mp(5, 3), Ok(()));
        assert_eq!(t.mp(5), Ok(3));
        let messages = [
            PvtError::PvWhileMoving.to_string(),
            PvtError::QtZero { index: 3 }.to_string(),
        ];
        assert!(messages[0].contains("moving"));
        assert!(messages[1].contains("QT[3]=0"));
    }

    #[test]
    fn pv_is_accepted_at_a_standstill_between_rows() {
        let mut t = PvtTable::new(SD);
        write_row(&mut t, 0, 1000, 0, 100);
        write_row(&mut t, 1, 1000, 0, 100);
        t.begin(0.0, 0.0).unwrap();
        t.advance(100 * MS);
        assert!(t.is_moving());
        assert_eq!(t.set_start_row(7), Ok(()));
        assert_eq!(t.current_row(), Some(1));
    }

    #[test]
    fn a_non_positive_sd_stops_at_once() {
        let mut t = PvtTable::new(SD);
        t.set_stop_deceleration(0.0);
        write_row(&mut t, 0, 1000, 5000, 100);
        t.begin(0.0, 0.0).unwrap();
        let events = t.advance(100 * MS);
        assert_eq!(
            events.stopped,
            Some(Stopped {
                at_us: 100 * MS,
                position_counts: 1000.0
            })
        );
    }
}
