//! The UIM2503 planner (`docs/uim2503.md` §3, `docs/architecture.md` §4–5): from a show and an
//! installation to every unit's rows in counts and how each gateway runs them (the
//! [`Plan`]); the instruction stream and its refill schedule are [`super::stream`]
//! and [`super::schedule`].
//!
//! Positions are converted from absolute millimetres, each rounded on its own, so the
//! rounding error stays below half a count and never accumulates along a track.
//!
//! ```
//! use floatball_shared::plan::{Installation, GatewaySpec};
//! use floatball_shared::show::{Layout, Limits, Show, Track, TrackRow};
//! use floatball_shared::uim2503::plan::{Plan, PlanOptions, RunMode};
//!
//! let layout = Layout { rows: 1, cols: 2, pitch_mm: 500.0 };
//! let installation = Installation::row_major(
//!     Limits::for_layout(1, 2),
//!     100.0,
//!     vec![GatewaySpec::uim2503("sim", 115_200)],
//!     1,
//! ).unwrap();
//! let track = |to_mm: f64| Track {
//!     start_mm: 1000.0,
//!     rows: vec![TrackRow::new(to_mm, 0.0, 200), TrackRow::new(1000.0, 0.0, 200)],
//!     colours: Vec::new(),
//! };
//! let show = Show { name: "bob".into(), layout, tracks: vec![track(1010.0), track(1020.0)], outputs: Vec::new() };
//! let plan = Plan::new(&show, &installation, PlanOptions::default()).unwrap();
//! assert_eq!(plan.units[1].rows[0].position_counts, 102_000);
//! assert_eq!(plan.gateways[0].mode, RunMode::Single);
//! ```

use super::schedule;
use crate::plan::{Installation, UnitAddress};

use thiserror::Error;

use super::pvt::{ROW_MAX_MS, ROW_MIN_MS, Row, TABLE_ROWS};
use crate::codes::{Code, Coded, Params};
use crate::line::Line;
use crate::params;
use crate::show::{Show, Violation, validate};

/// How a gateway's units run their rows (`MP[3]`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunMode {
    /// Every track fits the 256-row table: all rows are loaded before the start.
    Single,
    /// Tracks are longer than the table: rows are streamed while the show plays.
    Fifo,
    /// The show repeats forever and every track ends where it started: the units loop
    /// on their own, and nothing is streamed.
    Loop,
}

impl RunMode {
    /// The `MP[3]` value.
    pub fn mp3(self) -> u8 {
        match self {
            RunMode::Fifo => 0,
            RunMode::Single => 1,
            RunMode::Loop => 3,
        }
    }
}

/// One unit's part of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct UnitPlan {
    /// Where it is reached.
    pub address: UnitAddress,
    /// Where it waits at rest before the start, counts.
    pub start_counts: i32,
    /// Its rows, in counts, counts/s and ms.
    pub rows: Vec<Row>,
    /// Start time of each row in show time, ms (`row_start_ms[i]` = sum of the
    /// durations of the rows before `i`).
    pub row_start_ms: Vec<u64>,
}

impl UnitPlan {
    /// How many of its rows have started by show time `t_ms` (0 before the start).
    pub fn rows_started_by(&self, t_ms: f64) -> usize {
        if t_ms < 0.0 {
            return 0;
        }
        self.row_start_ms
            .partition_point(|&start| (start as f64) <= t_ms)
    }
}

/// How one gateway runs the show.
#[derive(Debug, Clone, PartialEq)]
pub struct GatewayRun {
    /// Index of the gateway.
    pub gateway: usize,
    /// The run mode of all its units.
    pub mode: RunMode,
    /// Its units (indices into [`Plan::units`]).
    pub units: Vec<usize>,
    /// Rows per unit written before the start (all of them unless streaming).
    pub preload_rows: usize,
    /// The gateway's line (its baud rate from the installation), for every timing.
    pub line: Line,
}

/// Choices that change a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PlanOptions {
    /// The show will repeat until stopped (the playlist loops over this one entry):
    /// loop mode may be used where it repeats exactly.
    pub repeat_forever: bool,
}

/// A show made ready for an installation.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// The show's name.
    pub show: String,
    /// The show's length, ms.
    pub duration_ms: u64,
    /// One plan per unit, in the installation's (row-major) order.
    pub units: Vec<UnitPlan>,
    /// One run per gateway that has units.
    pub gateways: Vec<GatewayRun>,
    /// `SP` for the approach and homing moves, counts/s.
    pub approach_speed_counts_s: i32,
    /// `PA` for homing, counts.
    pub home_counts: i32,
    /// `SD`, counts/s².
    pub stop_decel_counts_s2: u32,
}

/// Why a show cannot be planned.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PlanError {
    /// The show was made for another matrix size.
    #[error(
        "the show is for a {show_rows} × {show_cols} matrix but this installation is {rows} × {cols}"
    )]
    LayoutMismatch {
        /// The show's rows.
        show_rows: u32,
        /// The show's columns.
        show_cols: u32,
        /// The installation's rows.
        rows: u32,
        /// The installation's columns.
        cols: u32,
    },
    /// The show breaks the installation's limits.
    #[error("the show is not valid here: {} problem(s), the first: {}", violations.len(), violations.first().map(ToString::to_string).unwrap_or_default())]
    Invalid {
        /// Every problem.
        violations: Vec<Violation>,
    },
    /// A position or speed does not fit the units' 32-bit counters.
    #[error("ball {unit}: {value_mm} mm does not fit in counts at {counts_per_mm} counts/mm")]
    OutOfCounts {
        /// The unit (row-major index).
        unit: usize,
        /// The value, mm or mm/s.
        value_mm: f64,
        /// The calibration.
        counts_per_mm: f64,
    },
    /// The installation's unit list does not match its matrix size.
    #[error("the installation lists {listed} units for a matrix of {expected}")]
    UnitCount {
        /// Units listed.
        listed: usize,
        /// rows × cols.
        expected: usize,
    },
}

impl Coded for PlanError {
    fn code(&self) -> Code {
        match self {
            Self::LayoutMismatch { .. } => Code::WrongLayout,
            Self::Invalid { .. } => Code::ShowUnfit,
            Self::OutOfCounts { .. } => Code::OutOfCounts,
            Self::UnitCount { .. } => Code::UnitCount,
        }
    }

    /// The figures; `unit` (`u3`) for a value out of counts. An invalid show's
    /// problems are the report's fixes ([`report::refused`]).
    fn params(&self) -> Params {
        match self {
            Self::LayoutMismatch {
                show_rows,
                show_cols,
                rows,
                cols,
            } => params! {
                "show_rows" => show_rows,
                "show_cols" => show_cols,
                "rows" => rows,
                "cols" => cols,
            },
            Self::Invalid { violations } => params! {"count" => violations.len()},
            Self::OutOfCounts {
                unit,
                value_mm,
                counts_per_mm,
            } => params! {
                "unit" => format!("u{unit}"),
                "value_mm" => value_mm,
                "counts_per_mm" => counts_per_mm,
            },
            Self::UnitCount { listed, expected } => {
                params! {"listed" => listed, "expected" => expected}
            }
        }
    }
}

impl Plan {
    /// Plans `show` for `installation`: checks it, converts it to counts and chooses
    /// each gateway's mode and preload. The FIFO preload depth comes from
    /// [`schedule::choose_preload`]; a show the lines cannot carry still gets a plan
    /// (with the deepest preload), and [`report`] says why it cannot run.
    ///
    /// # Errors
    /// [`PlanError`]: another layout, limit violations, values beyond the counters.
    pub fn new(
        show: &Show,
        installation: &Installation,
        options: PlanOptions,
    ) -> Result<Self, PlanError> {
        check_show(show, installation)?;
        Self::build(
            show.name.clone(),
            show.duration_ms(),
            show.tracks.iter(),
            installation,
            options,
        )
    }

    /// Plans `show` as [`Plan::new`] does, taking it: each track's rows are freed as
    /// soon as they are converted, so the show and its plan are never both whole in
    /// memory (a 10,000-ball minute is 72 MB of show for 60 MB of plan).
    ///
    /// # Errors
    /// As [`Plan::new`].
    pub fn from_show(
        show: Show,
        installation: &Installation,
        options: PlanOptions,
    ) -> Result<Self, PlanError> {
        check_show(&show, installation)?;
        let duration_ms = show.duration_ms();
        Self::build(
            show.name,
            duration_ms,
            show.tracks.into_iter(),
            installation,
            options,
        )
    }

    /// The plan of a checked show's `tracks`.
    fn build<T: std::borrow::Borrow<crate::show::Track>>(
        name: String,
        duration_ms: u64,
        tracks: impl ExactSizeIterator<Item = T>,
        installation: &Installation,
        options: PlanOptions,
    ) -> Result<Self, PlanError> {
        let counts = |unit: usize, mm: f64| {
            installation.counts(mm).ok_or(PlanError::OutOfCounts {
                unit,
                value_mm: mm,
                counts_per_mm: installation.counts_per_mm,
            })
        };
        let mut units = Vec::with_capacity(tracks.len());
        for (unit, (track, address)) in tracks.zip(&installation.units).enumerate() {
            let track = track.borrow();
            let mut rows = Vec::with_capacity(track.rows.len());
            let mut row_start_ms = Vec::with_capacity(track.rows.len());
            let mut t_ms = 0u64;
            for row in &track.rows {
                let duration_ms = u8::try_from(row.duration_ms)
                    .ok()
                    .filter(|ms| (ROW_MIN_MS..=ROW_MAX_MS).contains(ms))
                    .unwrap_or(ROW_MAX_MS);
                rows.push(Row {
                    position_counts: counts(unit, row.position_mm)?,
                    velocity_counts_s: counts(unit, row.velocity_mm_s)?,
                    duration_ms,
                });
                row_start_ms.push(t_ms);
                t_ms += u64::from(duration_ms);
            }
            units.push(UnitPlan {
                address: *address,
                start_counts: counts(unit, track.start_mm)?,
                rows,
                row_start_ms,
            });
        }
        let mut gateways = Vec::new();
        for (gateway, spec) in installation.gateways.iter().enumerate() {
            let members: Vec<usize> = installation.units_on(gateway).collect();
            if members.is_empty() {
                continue;
            }
            let longest = members
                .iter()
                .map(|&u| units[u].rows.len())
                .max()
                .unwrap_or(0);
            let shortest = members
                .iter()
                .map(|&u| units[u].rows.len())
                .min()
                .unwrap_or(0);
            let fits = longest <= TABLE_ROWS && shortest >= 2;
            let periodic = members.iter().all(|&u| is_periodic(&units[u]));
            let mode = if !fits {
                RunMode::Fifo
            } else if options.repeat_forever && periodic {
                RunMode::Loop
            } else {
                RunMode::Single
            };
            gateways.push(GatewayRun {
                gateway,
                mode,
                units: members,
                preload_rows: longest,
                line: Line::new(spec.baud),
            });
        }
        let approach_speed_counts_s = counts(0, installation.approach_speed_mm_s)?.max(1);
        let home_counts = counts(0, installation.home_mm)?;
        let stop_decel_counts_s2 =
            u32::try_from(counts(0, installation.stop_decel_mm_s2)?.max(1)).unwrap_or(1);
        let mut plan = Self {
            show: name,
            duration_ms,
            units,
            gateways,
            approach_speed_counts_s,
            home_counts,
            stop_decel_counts_s2,
        };
        for index in 0..plan.gateways.len() {
            if plan.gateways[index].mode == RunMode::Fifo {
                let line = plan.gateways[index].line;
                let preload = schedule::choose_preload(&plan, index, line).preload_rows;
                plan.gateways[index].preload_rows = preload;
            }
        }
        Ok(plan)
    }

    /// The run of gateway `gateway` (its index in the installation), if it has units.
    pub fn run_of(&self, gateway: usize) -> Option<&GatewayRun> {
        self.gateways.iter().find(|run| run.gateway == gateway)
    }
}

/// Whether `show` may be planned for `installation`: its layout, the installation's
/// unit count, and the installation's limits.
fn check_show(show: &Show, installation: &Installation) -> Result<(), PlanError> {
    let limits = &installation.limits;
    if show.layout.rows != limits.rows || show.layout.cols != limits.cols {
        return Err(PlanError::LayoutMismatch {
            show_rows: show.layout.rows,
            show_cols: show.layout.cols,
            rows: limits.rows,
            cols: limits.cols,
        });
    }
    let expected = limits.rows as usize * limits.cols as usize;
    if installation.units.len() != expected {
        return Err(PlanError::UnitCount {
            listed: installation.units.len(),
            expected,
        });
    }
    let violations = validate(show, limits);
    if !violations.is_empty() {
        return Err(PlanError::Invalid { violations });
    }
    Ok(())
}

/// Whether a unit ends exactly where and how it started (at rest at its start), so
/// running its rows again continues the motion without a jump.
fn is_periodic(unit: &UnitPlan) -> bool {
    unit.rows.last().is_some_and(|last| {
        last.position_counts == unit.start_counts && last.velocity_counts_s == 0
    })
}

#[cfg(test)]
pub(crate) mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::plan::report;
    use crate::show::TrackRow;

    pub(crate) use crate::show::demo::wave;

    /// Generous limits so test shows are valid (the start-from-rest jumps in speed are
    /// within these).
    pub(crate) fn installation(rows: u32, cols: u32, baud: u32) -> Installation {
        Installation::demo(rows, cols, &[baud]).unwrap()
    }

    #[test]
    fn a_show_taken_plans_as_the_show_borrowed() {
        for (rows_per_ball, baud) in [(50, 115_200), (400, 9600)] {
            let show = wave(2, 3, rows_per_ball, 200);
            let installation = installation(2, 3, baud);
            let options = PlanOptions::default();
            let plan = Plan::new(&show, &installation, options).unwrap();
            assert_eq!(
                Plan::from_show(show.clone(), &installation, options).unwrap(),
                plan
            );
            assert_eq!(
                report::report_of(show.clone(), &installation, options),
                report::report(&show, &installation, options)
            );
        }
        let show = wave(1, 3, 50, 200);
        let elsewhere = installation(2, 3, 115_200);
        assert_eq!(
            Plan::from_show(show.clone(), &elsewhere, PlanOptions::default()),
            Plan::new(&show, &elsewhere, PlanOptions::default())
        );
        assert_eq!(
            report::report_of(show.clone(), &elsewhere, PlanOptions::default()),
            report::report(&show, &elsewhere, PlanOptions::default())
        );
    }

    #[test]
    fn positions_are_rounded_from_absolute_millimetres() {
        let show = wave(1, 3, 50, 200);
        let plan = Plan::new(&show, &installation(1, 3, 115_200), PlanOptions::default()).unwrap();
        for (unit, track) in plan.units.iter().zip(&show.tracks) {
            for (row, source) in unit.rows.iter().zip(&track.rows) {
                let error = f64::from(row.position_counts) - source.position_mm * 100.0;
                assert!(error.abs() <= 0.5, "{error}");
            }
        }
    }

    #[test]
    fn the_mode_follows_the_table_size() {
        let installation = installation(2, 5, 115_200);
        let short =
            Plan::new(&wave(2, 5, 256, 250), &installation, PlanOptions::default()).unwrap();
        assert_eq!(short.gateways[0].mode, RunMode::Single);
        assert_eq!(short.gateways[0].preload_rows, 256);
        let long = Plan::new(&wave(2, 5, 257, 250), &installation, PlanOptions::default()).unwrap();
        assert_eq!(long.gateways[0].mode, RunMode::Fifo);
        assert!(long.gateways[0].preload_rows <= 255);
    }

    #[test]
    fn loop_mode_only_when_repeating_forever_and_periodic() {
        let installation = installation(1, 2, 115_200);
        let mut show = wave(1, 2, 16, 250);
        let forever = PlanOptions {
            repeat_forever: true,
        };
        // The 4 s wave ends at its start after 16 rows of 250 ms, at rest only if we
        // make it so.
        for track in &mut show.tracks {
            let last = track.rows.len() - 1;
            track.rows[last] = TrackRow::new(track.start_mm, 0.0, 250);
        }
        let plan = Plan::new(&show, &installation, forever).unwrap();
        assert_eq!(plan.gateways[0].mode, RunMode::Loop);
        let once = Plan::new(&show, &installation, PlanOptions::default()).unwrap();
        assert_eq!(once.gateways[0].mode, RunMode::Single);
        let start = show.tracks[1].start_mm;
        show.tracks[1].rows.pop();
        show.tracks[1]
            .rows
            .push(TrackRow::new(start + 1.0, 0.0, 250));
        // One ball ending a millimetre off its start: not periodic any more.
        let not_periodic = Plan::new(&show, &installation, forever).unwrap();
        assert_eq!(not_periodic.gateways[0].mode, RunMode::Single);
    }

    #[test]
    fn invalid_and_mismatched_shows_are_refused() {
        let installation = installation(1, 2, 115_200);
        let error =
            Plan::new(&wave(2, 2, 10, 200), &installation, PlanOptions::default()).unwrap_err();
        assert!(matches!(error, PlanError::LayoutMismatch { .. }), "{error}");
        let mut show = wave(1, 2, 10, 200);
        show.tracks[0].rows[3].position_mm = 9000.0;
        let error = Plan::new(&show, &installation, PlanOptions::default()).unwrap_err();
        assert!(error.to_string().contains("not valid"), "{error}");
    }
}
