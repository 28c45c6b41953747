//! The verdict of a plan report (`GET /api/plan/{name}`) as typed values: [`Why`] a
//! show cannot run and each [`Fix`] that would make it run. Each value gives both its
//! English sentence (`Display`, the report's `reason` and `fixes` for API clients) and
//! its code with parameters ([`Coded`], the report's `reason_problem` and
//! `fix_problems` the app renders in the operator's language), so the two cannot
//! drift. [`verdict_report`] and [`refuse`] fill both from one value.
//!
//! A show that runs may still get [`Advice`] (the report's `advice`): a preload longer
//! than [`LONG_PRELOAD_MS`], and the gateway rate that shortens it ([`advise`]).

use std::fmt;

use crate::api::{GatewayPlan, PlanReport, Problem};
use crate::codes::{Code, Coded, Params};
use crate::params;
use crate::scl::qprogram::QProgramError;
use crate::show::{Violation, output_box_message};
use crate::uim2503::plan::PlanError;

/// Why a show cannot run.
#[derive(Debug, Clone, PartialEq)]
pub enum Why {
    /// A gateway's line cannot keep its units fed.
    Starved {
        /// The gateway's port.
        gateway: String,
        /// Its baud rate.
        baud: u32,
        /// The units on it.
        units: usize,
        /// The show's name.
        show: String,
        /// What the show streams, bytes per second.
        needed_bytes_per_s: f64,
        /// What the line carries, bytes per second.
        available_bytes_per_s: f64,
        /// When the row buffers run dry, ms of show time, if known.
        dry_at_ms: Option<f64>,
        /// The rows preloaded before the start.
        preload_rows: usize,
    },
    /// The show breaks the installation's limits: the first problem and how many more.
    Violations {
        /// The first problem.
        first: Violation,
        /// How many more follow.
        more: usize,
    },
    /// The show has a number of balls that differs from the installation's.
    BallCount {
        /// The show's balls.
        show_balls: usize,
        /// The installation's units.
        units: usize,
    },
    /// An output track for an MBOX box the installation lacks.
    OutputBox {
        /// The box the track names.
        box_index: usize,
        /// The installation's boxes.
        boxes: usize,
    },
    /// The show cannot be planned at all.
    Refused(PlanError),
    /// A ball's Q program cannot be compiled (MOONS' drives).
    Program {
        /// The ball (row-major index).
        ball: usize,
        /// Why.
        error: QProgramError,
    },
}

impl fmt::Display for Why {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Starved {
                gateway,
                baud,
                units,
                show,
                needed_bytes_per_s,
                available_bytes_per_s,
                dry_at_ms,
                preload_rows,
            } => {
                let when = dry_at_ms
                    .map(|ms| format!("{:.1} s into the show", ms / 1000.0))
                    .unwrap_or_else(|| "during the show".to_owned());
                write!(
                    f,
                    "gateway {gateway} ({baud} baud) cannot keep its {units} units fed: \
                     \"{show}\" streams {needed_bytes_per_s:.0} B/s while the line carries \
                     {available_bytes_per_s:.0} B/s, so the units' row buffers run dry {when} \
                     even with a full {preload_rows}-row preload"
                )
            }
            Self::Violations { first, more: 0 } => write!(f, "{first}"),
            Self::Violations { first, more } => write!(f, "{first} (and {more} more problems)"),
            Self::BallCount { show_balls, units } => write!(
                f,
                "the show has {show_balls} balls but the installation has {units}"
            ),
            Self::OutputBox { box_index, boxes } => {
                f.write_str(&output_box_message(*box_index, *boxes))
            }
            Self::Refused(error) => write!(f, "{error}"),
            Self::Program { ball, error } => write!(f, "ball u{ball}: {error}"),
        }
    }
}

impl Coded for Why {
    fn code(&self) -> Code {
        match self {
            Self::Starved {
                dry_at_ms: Some(_), ..
            } => Code::LineStarved,
            Self::Starved { .. } => Code::LineStarvedDuring,
            Self::Violations { first, .. } => first.code(),
            Self::BallCount { .. } => Code::BallCount,
            Self::OutputBox { .. } => Code::OutputBox,
            Self::Refused(error) => error.code(),
            Self::Program { error, .. } => error.code(),
        }
    }

    /// The figures as plain numbers (B/s and seconds rounded as the English says
    /// them); a violation's own parameters with `more` when more problems follow; a
    /// ball's program error's with `unit` (`u3`).
    fn params(&self) -> Params {
        match self {
            Self::Starved {
                gateway,
                baud,
                units,
                show,
                needed_bytes_per_s,
                available_bytes_per_s,
                dry_at_ms,
                preload_rows,
            } => {
                let mut params = params! {
                    "gateway" => gateway,
                    "baud" => baud,
                    "units" => units,
                    "show" => show,
                    "needed_bytes_per_s" => format!("{needed_bytes_per_s:.0}"),
                    "available_bytes_per_s" => format!("{available_bytes_per_s:.0}"),
                    "preload_rows" => preload_rows,
                };
                if let Some(ms) = dry_at_ms {
                    params.insert("dry_at_s".to_owned(), format!("{:.1}", ms / 1000.0));
                }
                params
            }
            Self::Violations { first, more } => {
                let mut params = first.params();
                if *more > 0 {
                    params.insert("more".to_owned(), more.to_string());
                }
                params
            }
            Self::BallCount { show_balls, units } => {
                params! {"show_balls" => show_balls, "units" => units}
            }
            Self::OutputBox { box_index, boxes } => params! {"box" => box_index, "boxes" => boxes},
            Self::Refused(error) => error.params(),
            Self::Program { ball, error } => {
                let mut params = error.params();
                params.insert("unit".to_owned(), format!("u{ball}"));
                params
            }
        }
    }
}

/// What would make a show run.
#[derive(Debug, Clone, PartialEq)]
pub enum Fix {
    /// Raise the line to `baud`.
    FasterLine {
        /// The slowest baud rate that is enough.
        baud: u32,
    },
    /// No baud rate up to `max_baud` is enough on its own.
    NoBaudEnough {
        /// The fastest a gateway can be set to.
        max_baud: u32,
    },
    /// Put fewer units on each gateway.
    FewerUnits {
        /// The most units one gateway at `baud` can feed.
        units_per_gateway: usize,
        /// The line's baud rate.
        baud: u32,
        /// The gateways that would take.
        gateways: usize,
        /// The units of the gateway that is short.
        units: usize,
    },
    /// Use longer rows.
    LongerRows {
        /// The shortest rows that would do, ms.
        row_ms: f64,
        /// The show's rows on average, ms.
        mean_row_ms: f64,
    },
    /// Shorten the show so it loads completely before it starts.
    FewerRows {
        /// The most rows per ball.
        rows: usize,
    },
    /// Fix a problem of the show.
    Problem(Violation),
    /// Raise `[scl] tolerance_mm`, or give the show gentler moves.
    Tolerance {
        /// The tolerance that would take every ball, mm.
        tolerance_mm: f64,
        /// The largest deviation of any ball, mm.
        deviation_mm: f64,
    },
}

impl fmt::Display for Fix {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::FasterLine { baud } => write!(
                f,
                "raise the line to {baud} baud (Commissioning → Line speed)"
            ),
            Self::NoBaudEnough { max_baud } => {
                write!(f, "no baud rate up to {max_baud} is enough on its own")
            }
            Self::FewerUnits {
                units_per_gateway,
                baud,
                gateways,
                units,
            } => write!(
                f,
                "put at most {units_per_gateway} of these units on each gateway at {baud} baud \
                 ({gateways} gateways for these {units})"
            ),
            Self::LongerRows {
                row_ms,
                mean_row_ms,
            } => write!(
                f,
                "use rows of at least {row_ms:.0} ms (this show's rows last {mean_row_ms:.0} ms \
                 on average)"
            ),
            Self::FewerRows { rows } => write!(
                f,
                "or shorten the show to at most {rows} rows per ball so it loads completely \
                 before it starts"
            ),
            Self::Problem(violation) => write!(f, "{violation}"),
            Self::Tolerance {
                tolerance_mm,
                deviation_mm,
            } => write!(
                f,
                "raise [scl] tolerance_mm to {tolerance_mm:.0} mm or more (the largest \
                 deviation of any ball is {deviation_mm:.1} mm), or give the show fewer, \
                 gentler moves"
            ),
        }
    }
}

impl Coded for Fix {
    fn code(&self) -> Code {
        match self {
            Self::FasterLine { .. } => Code::FixFasterLine,
            Self::NoBaudEnough { .. } => Code::FixNoBaudEnough,
            Self::FewerUnits { .. } => Code::FixFewerUnits,
            Self::LongerRows { .. } => Code::FixLongerRows,
            Self::FewerRows { .. } => Code::FixFewerRows,
            Self::Problem(violation) => violation.code(),
            Self::Tolerance { .. } => Code::FixTolerance,
        }
    }

    /// The figures as the English says them.
    fn params(&self) -> Params {
        match self {
            Self::FasterLine { baud } => params! {"baud" => baud},
            Self::NoBaudEnough { max_baud } => params! {"max_baud" => max_baud},
            Self::FewerUnits {
                units_per_gateway,
                baud,
                gateways,
                units,
            } => params! {
                "units_per_gateway" => units_per_gateway,
                "baud" => baud,
                "gateways" => gateways,
                "units" => units,
            },
            Self::LongerRows {
                row_ms,
                mean_row_ms,
            } => params! {
                "row_ms" => format!("{row_ms:.0}"),
                "mean_row_ms" => format!("{mean_row_ms:.0}"),
            },
            Self::FewerRows { rows } => params! {"rows" => rows},
            Self::Problem(violation) => violation.params(),
            Self::Tolerance {
                tolerance_mm,
                deviation_mm,
            } => params! {
                "tolerance_mm" => format!("{tolerance_mm:.0}"),
                "deviation_mm" => format!("{deviation_mm:.1}"),
            },
        }
    }
}

/// A preload longer than this is worth advice, ms: past half a minute an operator
/// waits for the show in `loading` (unless it was armed while the matrix was idle).
pub const LONG_PRELOAD_MS: u64 = 30_000;

/// Advice for a show that runs but could start sooner.
#[derive(Debug, Clone, PartialEq)]
pub enum Advice {
    /// A gateway's preload takes longer than [`LONG_PRELOAD_MS`] at its rate, and a
    /// faster rate shortens it.
    LongPreload {
        /// The gateway's port.
        gateway: String,
        /// Its baud rate.
        baud: u32,
        /// The bytes it sends before the start.
        preload_bytes: u64,
        /// How long they take at `baud`, ms.
        preload_ms: u64,
        /// The slowest rate that brings the preload within [`LONG_PRELOAD_MS`], or the
        /// fastest rate when none does.
        faster_baud: u32,
        /// The preload at `faster_baud`, ms.
        faster_preload_ms: u64,
    },
    /// A gateway's preload takes longer than [`LONG_PRELOAD_MS`] at the fastest rate.
    LongPreloadFastest {
        /// The gateway's port.
        gateway: String,
        /// Its baud rate (the fastest).
        baud: u32,
        /// The bytes it sends before the start.
        preload_bytes: u64,
        /// How long they take, ms.
        preload_ms: u64,
    },
}

/// A preload in whole seconds (rounded up), as the advice says it.
fn seconds(ms: u64) -> u64 {
    ms.div_ceil(1000)
}

/// A preload in minutes with one decimal, as the advice says it beside the seconds.
fn minutes(ms: u64) -> String {
    format!("{:.1}", ms as f64 / 60_000.0)
}

impl fmt::Display for Advice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LongPreload {
                gateway,
                baud,
                preload_bytes,
                preload_ms,
                faster_baud,
                faster_preload_ms,
            } => write!(
                f,
                "gateway {gateway} preloads {preload_bytes} bytes in {} s ({} min) at {baud} \
                 baud before the show can start; at {faster_baud} baud it takes {} s (change \
                 the line speed to {faster_baud} in Commissioning → Line speed)",
                seconds(*preload_ms),
                minutes(*preload_ms),
                seconds(*faster_preload_ms)
            ),
            Self::LongPreloadFastest {
                gateway,
                baud,
                preload_bytes,
                preload_ms,
            } => write!(
                f,
                "gateway {gateway} preloads {preload_bytes} bytes in {} s ({} min) at {baud} \
                 baud before the show can start, even at the fastest rate; as the playlist's \
                 first entry it is loaded while the matrix is idle",
                seconds(*preload_ms),
                minutes(*preload_ms)
            ),
        }
    }
}

impl Coded for Advice {
    fn code(&self) -> Code {
        match self {
            Self::LongPreload { .. } => Code::PreloadLong,
            Self::LongPreloadFastest { .. } => Code::PreloadLongFastest,
        }
    }

    /// The times as the English says them: whole seconds rounded up (`preload_s`,
    /// `faster_preload_s`) and minutes with one decimal (`preload_min`).
    fn params(&self) -> Params {
        match self {
            Self::LongPreload {
                gateway,
                baud,
                preload_bytes,
                preload_ms,
                faster_baud,
                faster_preload_ms,
            } => params! {
                "gateway" => gateway,
                "baud" => baud,
                "preload_bytes" => preload_bytes,
                "preload_s" => seconds(*preload_ms),
                "preload_min" => minutes(*preload_ms),
                "faster_baud" => faster_baud,
                "faster_preload_s" => seconds(*faster_preload_ms),
            },
            Self::LongPreloadFastest {
                gateway,
                baud,
                preload_bytes,
                preload_ms,
            } => params! {
                "gateway" => gateway,
                "baud" => baud,
                "preload_bytes" => preload_bytes,
                "preload_s" => seconds(*preload_ms),
                "preload_min" => minutes(*preload_ms),
            },
        }
    }
}

/// Adds `advice` to `report`'s advice, as codes (the English is each code's
/// translation; [`Advice`]'s `Display` is the same sentence for logs and tests).
pub fn advise(report: &mut PlanReport, advice: &[Advice]) {
    report.advice.extend(advice.iter().map(Problem::of));
}

/// A report with `why` (none: feasible) and `fixes`, each in English and as codes.
#[must_use]
pub fn verdict_report(
    show: String,
    why: Option<&Why>,
    fixes: &[Fix],
    gateways: Vec<GatewayPlan>,
) -> PlanReport {
    let mut report = PlanReport {
        show,
        feasible: true,
        reason: None,
        fixes: Vec::new(),
        reason_problem: None,
        fix_problems: Vec::new(),
        preload_ms: gateways
            .iter()
            .map(|gateway| gateway.preload_ms)
            .max()
            .unwrap_or(0),
        advice: Vec::new(),
        gateways,
    };
    if let Some(why) = why {
        refuse(&mut report, why, fixes);
    }
    report
}

/// Makes `report` not feasible because of `why` (replacing its reason) and adds
/// `fixes` to its fixes, in English and as codes.
pub fn refuse(report: &mut PlanReport, why: &Why, fixes: &[Fix]) {
    report.feasible = false;
    report.reason = Some(why.to_string());
    report.reason_problem = Some(Problem::of(why));
    report.fixes.extend(fixes.iter().map(ToString::to_string));
    report.fix_problems.extend(fixes.iter().map(Problem::of));
}
