//! Validation of a show against an installation's physical limits (`docs/architecture.md` §3): on
//! upload, before start and in the preview.
//!
//! [`validate()`] returns every [`Violation`], each naming the ball, the time, the value
//! and the limit, with a sentence an operator can act on:
//!
//! ```
//! use floatball_shared::show::{Layout, Limits, Show, Track, TrackRow, validate};
//!
//! let show = Show {
//!     outputs: Vec::new(),
//!     name: "too fast".into(),
//!     layout: Layout { rows: 1, cols: 1, pitch_mm: 500.0 },
//!     tracks: vec![Track {
//!         start_mm: 0.0,
//!         rows: vec![TrackRow::new(1000.0, 0.0, 200)],
//!         colours: Vec::new(),
//!     }],
//! };
//! let violations = validate(&show, &Limits::for_layout(1, 1));
//! assert_eq!(
//!     violations[0].to_string(),
//!     "ball u0 (row 1, col 1) at 0.10 s: speed 7500.0 mm/s exceeds the limit of 2000.0 mm/s"
//! );
//! ```
//!
//! Positions, speeds and accelerations are checked analytically over each whole row
//! (the peak inside a row counts, not just its ends), with a tolerance of 1 µm, 1 µm/s
//! and 1 µm/s² for rounding.

use std::fmt;

use super::{DEFAULT_TRAVEL_MM, Show};
use crate::codes::{Code, Coded, Params};
use crate::params;
use crate::uim2503::pvt::{ROW_MAX_MS, ROW_MIN_MS};

/// Default top speed of a ball, mm/s (the manual: "over 2 m/s").
pub const DEFAULT_MAX_SPEED_MM_S: f64 = 2000.0;

/// Default top acceleration, mm/s²: about 0.4 g, reaching the top speed in half a
/// second, well inside what a 30 W winch with a 0.5–1 kg ball does without slipping
/// or swinging the ball.
pub const DEFAULT_MAX_ACCEL_MM_S2: f64 = 4000.0;

const TOLERANCE: f64 = 1e-3;

/// What an installation allows; the bridge fills it from its configuration. Row
/// durations are fixed by the protocol (10–255 ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Limits {
    /// Lowest position a ball may reach, mm below the top.
    pub travel_mm: f64,
    /// Top speed, mm/s.
    pub max_speed_mm_s: f64,
    /// Top acceleration, mm/s².
    pub max_accel_mm_s2: f64,
    /// Rows of balls installed.
    pub rows: u32,
    /// Balls in each row.
    pub cols: u32,
}

impl Limits {
    /// The default limits for a `rows` × `cols` matrix of UFQ750 units.
    #[must_use]
    pub fn for_layout(rows: u32, cols: u32) -> Self {
        Self {
            travel_mm: DEFAULT_TRAVEL_MM,
            max_speed_mm_s: DEFAULT_MAX_SPEED_MM_S,
            max_accel_mm_s2: DEFAULT_MAX_ACCEL_MM_S2,
            rows,
            cols,
        }
    }
}

/// A ball of the show.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct UnitRef {
    /// Row-major index (the `u` number of a CSV column).
    pub index: usize,
    /// 0-based row (messages count from 1).
    pub row: u32,
    /// 0-based column (messages count from 1).
    pub col: u32,
}

impl fmt::Display for UnitRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "ball u{} (row {}, col {})",
            self.index,
            u64::from(self.row) + 1,
            u64::from(self.col) + 1
        )
    }
}

/// What is wrong, with the value found and the limit it breaks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ViolationKind {
    /// The ball would go above the top (position below 0).
    AboveTop {
        /// The highest point reached, mm below the top (negative).
        position_mm: f64,
    },
    /// The ball would go below its travel.
    BelowTravel {
        /// The lowest point reached, mm below the top.
        position_mm: f64,
        /// The installation's travel, mm.
        travel_mm: f64,
    },
    /// Too fast.
    Speed {
        /// Peak speed, mm/s.
        speed_mm_s: f64,
        /// The limit, mm/s.
        limit_mm_s: f64,
    },
    /// Accelerating or braking too hard.
    Acceleration {
        /// Peak acceleration (absolute), mm/s².
        accel_mm_s2: f64,
        /// The limit, mm/s².
        limit_mm_s2: f64,
    },
    /// A row outside the 10–255 ms a unit accepts.
    RowDuration {
        /// The row's duration, ms.
        duration_ms: u32,
    },
    /// A track shorter than the show: every ball must run as long as the others.
    TrackDuration {
        /// This track's duration, ms.
        duration_ms: u64,
        /// The show's (longest track's) duration, ms.
        show_duration_ms: u64,
    },
    /// The last row ends moving: the unit would brake with its stop deceleration past
    /// the show's last point.
    EndsMoving {
        /// The final velocity, mm/s.
        velocity_mm_s: f64,
    },
    /// The show was made for another grid.
    Layout {
        /// Rows in the show.
        show_rows: u32,
        /// Columns in the show.
        show_cols: u32,
        /// Rows installed.
        rows: u32,
        /// Columns installed.
        cols: u32,
    },
}

/// One problem found by [`validate()`]. Its `Display` is a sentence for the operator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Violation {
    /// The ball concerned; `None` for a problem of the whole show.
    pub unit: Option<UnitRef>,
    /// The 0-based row of the ball's track concerned, if one.
    pub row: Option<usize>,
    /// When, ms of show time, if at a moment.
    pub time_ms: Option<f64>,
    /// What is wrong.
    pub kind: ViolationKind,
}

impl fmt::Display for Violation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(unit) = self.unit {
            write!(f, "{unit}")?;
            if let Some(time_ms) = self.time_ms {
                write!(f, " at {:.2} s", time_ms / 1000.0)?;
            }
            f.write_str(": ")?;
        }
        match self.kind {
            ViolationKind::AboveTop { position_mm } => write!(
                f,
                "position {position_mm:.1} mm is above the top (0 mm); the ball would hit the upper limit switch"
            ),
            ViolationKind::BelowTravel {
                position_mm,
                travel_mm,
            } => write!(
                f,
                "position {position_mm:.1} mm is below the lowest point (travel {travel_mm:.1} mm)"
            ),
            ViolationKind::Speed {
                speed_mm_s,
                limit_mm_s,
            } => write!(
                f,
                "speed {speed_mm_s:.1} mm/s exceeds the limit of {limit_mm_s:.1} mm/s"
            ),
            ViolationKind::Acceleration {
                accel_mm_s2,
                limit_mm_s2,
            } => write!(
                f,
                "acceleration {accel_mm_s2:.1} mm/s² exceeds the limit of {limit_mm_s2:.1} mm/s²"
            ),
            ViolationKind::RowDuration { duration_ms } => write!(
                f,
                "row {} of the track lasts {duration_ms} ms; a row must last {ROW_MIN_MS} to {ROW_MAX_MS} ms",
                self.row.map_or(0, |row| row + 1)
            ),
            ViolationKind::TrackDuration {
                duration_ms,
                show_duration_ms,
            } => write!(
                f,
                "the track lasts {:.3} s but the show lasts {:.3} s; every ball's track must last as long as the show",
                duration_ms as f64 / 1000.0,
                show_duration_ms as f64 / 1000.0
            ),
            ViolationKind::EndsMoving { velocity_mm_s } => write!(
                f,
                "the track ends moving at {velocity_mm_s:.1} mm/s; it must end at rest (velocity 0) or the ball brakes past its last point"
            ),
            ViolationKind::Layout {
                show_rows,
                show_cols,
                rows,
                cols,
            } => write!(
                f,
                "the show is made for {show_rows} rows × {show_cols} columns of balls but the installation has {rows} rows × {cols} columns"
            ),
        }
    }
}

/// Checks `show` against `limits` and returns every violation (empty when the show can
/// run): layout size, then per ball in order and per row in time: position within
/// 0…travel, speed, acceleration, row duration, ending at rest, track duration.
#[must_use]
pub fn validate(show: &Show, limits: &Limits) -> Vec<Violation> {
    let mut violations = Vec::new();
    let layout = show.layout;
    if (layout.rows, layout.cols) != (limits.rows, limits.cols) {
        violations.push(Violation {
            unit: None,
            row: None,
            time_ms: None,
            kind: ViolationKind::Layout {
                show_rows: layout.rows,
                show_cols: layout.cols,
                rows: limits.rows,
                cols: limits.cols,
            },
        });
    }
    let show_duration_ms = show.duration_ms();
    for (index, track) in show.tracks.iter().enumerate() {
        let (row, col) = layout.cell(index);
        let unit = UnitRef { index, row, col };
        let mut report = |row: Option<usize>, time_ms: Option<f64>, kind| {
            violations.push(Violation {
                unit: Some(unit),
                row,
                time_ms,
                kind,
            });
        };
        if track.rows.is_empty() {
            check_position(track.start_mm, None, Some(0.0), limits, &mut report);
        }
        for (row, (start_ms, segment)) in track.segments().enumerate() {
            let duration_ms = track.rows[row].duration_ms;
            let at = |at_s: f64| Some(start_ms as f64 + at_s * 1000.0);
            if !(u32::from(ROW_MIN_MS)..=u32::from(ROW_MAX_MS)).contains(&duration_ms) {
                report(
                    Some(row),
                    at(0.0),
                    ViolationKind::RowDuration { duration_ms },
                );
            }
            if duration_ms == 0 {
                // An instantaneous row has no motion to check.
                continue;
            }
            let range = segment.position_range();
            check_position(
                range.min.value,
                Some(row),
                at(range.min.at_s),
                limits,
                &mut report,
            );
            check_position(
                range.max.value,
                Some(row),
                at(range.max.at_s),
                limits,
                &mut report,
            );
            let speed = segment.peak_speed();
            if speed.value > limits.max_speed_mm_s + TOLERANCE {
                report(
                    Some(row),
                    at(speed.at_s),
                    ViolationKind::Speed {
                        speed_mm_s: speed.value,
                        limit_mm_s: limits.max_speed_mm_s,
                    },
                );
            }
            let accel = segment.peak_acceleration();
            if accel.value > limits.max_accel_mm_s2 + TOLERANCE {
                report(
                    Some(row),
                    at(accel.at_s),
                    ViolationKind::Acceleration {
                        accel_mm_s2: accel.value,
                        limit_mm_s2: limits.max_accel_mm_s2,
                    },
                );
            }
        }
        if let Some(last) = track.rows.last()
            && last.velocity_mm_s.abs() > TOLERANCE
        {
            report(
                Some(track.rows.len() - 1),
                Some(track.duration_ms() as f64),
                ViolationKind::EndsMoving {
                    velocity_mm_s: last.velocity_mm_s,
                },
            );
        }
        let duration_ms = track.duration_ms();
        if duration_ms != show_duration_ms {
            report(
                None,
                None,
                ViolationKind::TrackDuration {
                    duration_ms,
                    show_duration_ms,
                },
            );
        }
    }
    violations
}

fn check_position(
    position_mm: f64,
    row: Option<usize>,
    time_ms: Option<f64>,
    limits: &Limits,
    report: &mut impl FnMut(Option<usize>, Option<f64>, ViolationKind),
) {
    if position_mm < -TOLERANCE {
        report(row, time_ms, ViolationKind::AboveTop { position_mm });
    } else if position_mm > limits.travel_mm + TOLERANCE {
        report(
            row,
            time_ms,
            ViolationKind::BelowTravel {
                position_mm,
                travel_mm: limits.travel_mm,
            },
        );
    }
}

impl Coded for Violation {
    fn code(&self) -> Code {
        match self.kind {
            ViolationKind::AboveTop { .. } => Code::AboveTop,
            ViolationKind::BelowTravel { .. } => Code::BelowTravel,
            ViolationKind::Speed { .. } => Code::TooFast,
            ViolationKind::Acceleration { .. } => Code::TooHardAcceleration,
            ViolationKind::RowDuration { .. } => Code::RowDuration,
            ViolationKind::TrackDuration { .. } => Code::TrackDuration,
            ViolationKind::EndsMoving { .. } => Code::EndsMoving,
            ViolationKind::Layout { .. } => Code::WrongLayout,
        }
    }

    /// The kind's figures (mm with one decimal, s with three), and where: `unit`
    /// (`u3`), `unit_row` and `unit_col` (from 1) and `time_s` when known.
    fn params(&self) -> Params {
        let mut params = match self.kind {
            ViolationKind::AboveTop { position_mm } => {
                params! {"position_mm" => format!("{position_mm:.1}")}
            }
            ViolationKind::BelowTravel {
                position_mm,
                travel_mm,
            } => params! {
                "position_mm" => format!("{position_mm:.1}"),
                "travel_mm" => format!("{travel_mm:.1}"),
            },
            ViolationKind::Speed {
                speed_mm_s,
                limit_mm_s,
            } => params! {
                "speed_mm_s" => format!("{speed_mm_s:.1}"),
                "limit_mm_s" => format!("{limit_mm_s:.1}"),
            },
            ViolationKind::Acceleration {
                accel_mm_s2,
                limit_mm_s2,
            } => params! {
                "accel_mm_s2" => format!("{accel_mm_s2:.1}"),
                "limit_mm_s2" => format!("{limit_mm_s2:.1}"),
            },
            ViolationKind::RowDuration { duration_ms } => params! {
                "row" => self.row.map_or(0, |row| row + 1),
                "duration_ms" => duration_ms,
                "min_ms" => ROW_MIN_MS,
                "max_ms" => ROW_MAX_MS,
            },
            ViolationKind::TrackDuration {
                duration_ms,
                show_duration_ms,
            } => params! {
                "duration_s" => format!("{:.3}", duration_ms as f64 / 1000.0),
                "show_duration_s" => format!("{:.3}", show_duration_ms as f64 / 1000.0),
            },
            ViolationKind::EndsMoving { velocity_mm_s } => {
                params! {"velocity_mm_s" => format!("{velocity_mm_s:.1}")}
            }
            ViolationKind::Layout {
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
        };
        if let Some(unit) = self.unit {
            params.insert("unit".into(), format!("u{}", unit.index));
            params.insert("unit_row".into(), (u64::from(unit.row) + 1).to_string());
            params.insert("unit_col".into(), (u64::from(unit.col) + 1).to_string());
            if let Some(time_ms) = self.time_ms {
                params.insert("time_s".into(), format!("{:.2}", time_ms / 1000.0));
            }
        }
        params
    }
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::show::{Layout, Track, TrackRow};

    fn show(tracks: Vec<Track>, rows: u32, cols: u32) -> Show {
        Show {
            outputs: Vec::new(),
            name: "test".into(),
            layout: Layout {
                rows,
                cols,
                pitch_mm: 500.0,
            },
            tracks,
        }
    }

    fn track(start_mm: f64, rows: &[(f64, f64, u32)]) -> Track {
        Track {
            start_mm,
            rows: rows.iter().copied().map(TrackRow::from).collect(),
            colours: Vec::new(),
        }
    }

    /// A gentle, valid track: 1000 → 1100 mm over 1.5 s, accelerating at 800 mm/s².
    fn gentle() -> Track {
        track(
            1000.0,
            &[
                (1025.0, 200.0, 250),
                (1075.0, 200.0, 250),
                (1100.0, 0.0, 250),
                (1100.0, 0.0, 250),
                (1100.0, 0.0, 250),
                (1100.0, 0.0, 250),
            ],
        )
    }

    fn kinds(violations: &[Violation]) -> Vec<ViolationKind> {
        violations.iter().map(|v| v.kind).collect()
    }

    #[test]
    fn a_valid_show_has_no_violations() {
        let limits = Limits::for_layout(1, 2);
        assert_eq!(validate(&show(vec![gentle(), gentle()], 1, 2), &limits), []);
    }

    #[test]
    fn each_kind_of_violation_is_caught() {
        let limits = Limits::for_layout(2, 3);
        let mut tracks = vec![gentle(); 6];
        let rest = |p: f64| (p, 0.0, 250);
        // u1: reverses at 2400 mm/s and dips above the top inside a row (the ends are
        // inside travel).
        tracks[1] = track(
            100.0,
            &[
                (100.0, -2400.0, 250),
                (100.0, 2400.0, 250),
                rest(100.0),
                rest(100.0),
                rest(100.0),
                rest(100.0),
            ],
        );
        // u2: goes below the travel.
        tracks[2] = track(
            7000.0,
            &[
                rest(7600.0),
                rest(7000.0),
                rest(7000.0),
                rest(7000.0),
                rest(7000.0),
                rest(7000.0),
            ],
        );
        // u3: a row of 300 ms and a row of 5 ms, same total.
        tracks[3] = track(
            1000.0,
            &[
                (1000.0, 0.0, 300),
                (1000.0, 0.0, 5),
                rest(1000.0),
                rest(1000.0),
                rest(1000.0),
                rest(1000.0),
                (1000.0, 0.0, 195),
            ],
        );
        // u4: ends moving.
        tracks[4].rows[5].velocity_mm_s = 50.0;
        // u5: shorter than the show.
        tracks[5].rows.pop();
        let violations = validate(&show(tracks, 2, 3), &limits);
        let by_unit = |index| -> Vec<ViolationKind> {
            violations
                .iter()
                .filter(|v| v.unit.map(|u| u.index) == Some(index))
                .map(|v| v.kind)
                .collect()
        };
        assert_eq!(by_unit(0), []);
        let u1 = by_unit(1);
        assert!(
            u1.iter().any(
                |k| matches!(k, ViolationKind::AboveTop { position_mm } if *position_mm < -49.0)
            ),
            "{u1:?}"
        );
        assert!(u1.iter().any(|k| matches!(k, ViolationKind::Speed { .. })));
        assert!(
            u1.iter()
                .any(|k| matches!(k, ViolationKind::Acceleration { .. }))
        );
        assert!(matches!(
            by_unit(2)[0],
            ViolationKind::BelowTravel {
                position_mm: 7600.0,
                travel_mm: 7500.0
            }
        ));
        assert_eq!(
            by_unit(3),
            [
                ViolationKind::RowDuration { duration_ms: 300 },
                ViolationKind::RowDuration { duration_ms: 5 },
            ]
        );
        assert_eq!(
            by_unit(4),
            [ViolationKind::EndsMoving {
                velocity_mm_s: 50.0
            }]
        );
        assert_eq!(
            by_unit(5),
            [ViolationKind::TrackDuration {
                duration_ms: 1250,
                show_duration_ms: 1500
            }]
        );
        // The ball is named by cell: u5 is row 2, column 3.
        let u5 = violations
            .iter()
            .find(|v| v.unit.map(|u| u.index) == Some(5))
            .unwrap();
        assert_eq!(u5.unit.map(|u| (u.row, u.col)), Some((1, 2)));
        assert!(
            u5.to_string()
                .starts_with("ball u5 (row 2, col 3): the track lasts 1.250 s")
        );
        let u3 = violations
            .iter()
            .find(|v| v.unit.map(|u| u.index) == Some(3))
            .unwrap();
        assert_eq!(
            u3.to_string(),
            "ball u3 (row 2, col 1) at 0.00 s: row 1 of the track lasts 300 ms; a row must last 10 to 255 ms"
        );
    }

    #[test]
    fn peaks_inside_a_row_are_placed_in_time() {
        // Speed peaks in the middle of the second row: 200 + 100 ms.
        let fast = track(
            0.0,
            &[(0.0, 0.0, 200), (1000.0, 0.0, 200), (1000.0, 0.0, 200)],
        );
        let limits = Limits::for_layout(1, 1);
        let violations = validate(&show(vec![fast], 1, 1), &limits);
        let speed = violations
            .iter()
            .find(|v| matches!(v.kind, ViolationKind::Speed { .. }))
            .unwrap();
        assert_eq!(speed.row, Some(1));
        assert!((speed.time_ms.unwrap() - 300.0).abs() < 1e-9);
        // 1.5 × 1000 mm / 0.2 s.
        let ViolationKind::Speed {
            speed_mm_s,
            limit_mm_s,
        } = speed.kind
        else {
            unreachable!()
        };
        assert!((speed_mm_s - 7500.0).abs() < 1e-9);
        assert_eq!(limit_mm_s, 2000.0);
        assert_eq!(
            speed.to_string(),
            "ball u0 (row 1, col 1) at 0.30 s: speed 7500.0 mm/s exceeds the limit of 2000.0 mm/s"
        );
        // Acceleration peaks at the row's ends: 6 × 1000 / 0.2² at 200 ms.
        let accel = violations
            .iter()
            .find(|v| matches!(v.kind, ViolationKind::Acceleration { .. }))
            .unwrap();
        assert_eq!(accel.time_ms, Some(200.0));
    }

    #[test]
    fn layout_and_a_resting_start_outside_travel() {
        let limits = Limits {
            travel_mm: 5000.0,
            ..Limits::for_layout(3, 3)
        };
        let outside = track(6000.0, &[]);
        let violations = validate(&show(vec![outside], 1, 1), &limits);
        assert_eq!(
            kinds(&violations),
            [
                ViolationKind::Layout {
                    show_rows: 1,
                    show_cols: 1,
                    rows: 3,
                    cols: 3
                },
                ViolationKind::BelowTravel {
                    position_mm: 6000.0,
                    travel_mm: 5000.0
                }
            ]
        );
        assert_eq!(
            violations[0].to_string(),
            "the show is made for 1 rows × 1 columns of balls but the installation has 3 rows × 3 columns"
        );
    }

    #[test]
    fn rounding_at_the_limits_is_tolerated() {
        let edge = track(0.0, &[(7500.0, 0.0, 250), (7500.0, 0.0, 250)]);
        let limits = Limits {
            max_speed_mm_s: 45_000.0,
            max_accel_mm_s2: 720_000.0,
            ..Limits::for_layout(1, 1)
        };
        assert_eq!(validate(&show(vec![edge], 1, 1), &limits), []);
    }
}
