//! When each refill round of a FIFO stream can go on the line, and the water levels
//! that leaves.
//!
//! A streaming gateway is fed in rounds of [`ROUND_ROWS`] rows for every unit
//! ([`super::stream::rows`]). A round may go out once it fits every unit's FIFO
//! ([`FIFO_LIMIT`] pending rows while running, counted when its shared `QT` lands) and
//! lands when its last byte has crossed the line. A row must have landed before it
//! starts, or the unit runs dry and stops with `SD`. The player sends rounds by the
//! same rule ([`round_room_at_ms`]); [`simulate`] plays it out on paper at a line speed
//! derated to [`LINE_UTILISATION`], and [`choose_preload`] picks the shallowest preload
//! that keeps every FIFO at least [`MIN_LEVEL_ROWS`] deep.

use super::plan::{GatewayRun, Plan, RunMode};
use super::stream;
use crate::line::Line;
use crate::uim2503::pvt::TABLE_ROWS;

/// Rows per unit in one refill round.
pub const ROUND_ROWS: usize = 16;

/// Most rows pending in a running unit's FIFO: the table's [`TABLE_ROWS`] less the slot
/// the running row keeps (as [`crate::uim2503::pvt::PvtTable`] counts them).
pub const FIFO_LIMIT: usize = TABLE_ROWS - 1;

/// The fewest rows that must be pending whenever a refill lands, for a plan to count
/// as feasible: a margin for jitter on the line and in the host.
pub const MIN_LEVEL_ROWS: i64 = 2;

/// Rows added to the shallowest workable preload, for what paper cannot foresee (a
/// host busy for a moment, a slow answer); capped by the table.
pub const SAFETY_ROWS: usize = ROUND_ROWS;

/// The share of the line's bytes/s the plan counts on (pauses between writes, the
/// host's scheduling).
pub const LINE_UTILISATION: f64 = 0.95;

/// How long a byte takes on `line` as the planner counts it (derated), ms.
pub fn planned_byte_ms(line: Line) -> f64 {
    line.byte_ms() / LINE_UTILISATION
}

/// The outcome of streaming a gateway's rows on paper.
#[derive(Debug, Clone, PartialEq)]
pub struct Simulation {
    /// Rows per unit loaded before the start.
    pub preload_rows: usize,
    /// Bytes sent before the start (configuration, preload, arming).
    pub preload_bytes: u64,
    /// Time to send them, ms (derated line speed).
    pub preload_ms: f64,
    /// Bytes streamed while the show plays.
    pub stream_bytes: u64,
    /// Bytes on the wire per unit-row, on average.
    pub bytes_per_row: f64,
    /// The lowest FIFO water level when a refill lands, rows; negative means a unit
    /// ran dry. `None` when nothing streams.
    pub lowest_level: Option<i64>,
    /// Show time of the first refill that landed too late, ms.
    pub underrun_at_ms: Option<f64>,
}

impl Simulation {
    /// Whether every FIFO stays at least [`MIN_LEVEL_ROWS`] deep.
    pub fn keeps_margin(&self) -> bool {
        self.lowest_level
            .is_none_or(|level| level >= MIN_LEVEL_ROWS)
    }
}

/// The rows of round `from..` (up to [`ROUND_ROWS`], clipped to the longest track).
pub fn round_end(run: &GatewayRun, plan: &Plan, from: usize) -> usize {
    (from + ROUND_ROWS).min(longest(plan, run))
}

/// The most rows any unit of the run has.
pub fn longest(plan: &Plan, run: &GatewayRun) -> usize {
    run.units
        .iter()
        .map(|&unit| plan.units[unit].rows.len())
        .max()
        .unwrap_or(0)
}

/// The earliest show time (ms; negative infinity if at once) at which rows up to `to`
/// fit every unit's FIFO.
pub fn round_room_at_ms(plan: &Plan, run: &GatewayRun, to: usize) -> f64 {
    let mut at = f64::NEG_INFINITY;
    for &unit in &run.units {
        let unit = &plan.units[unit];
        let to = to.min(unit.rows.len());
        // Pending after the round = to - started ≤ FIFO_LIMIT, so at least
        // to - FIFO_LIMIT rows must have started: the start of row (to - FIFO_LIMIT - 1).
        if let Some(must_start) = to.checked_sub(FIFO_LIMIT + 1) {
            at = at.max(unit.row_start_ms[must_start] as f64);
        }
    }
    at
}

/// The water level when rows up to `written` have landed at show time `at_ms`: the
/// fewest rows any still-receiving unit has pending (negative if it ran dry).
pub fn level_at(plan: &Plan, run: &GatewayRun, written: usize, at_ms: f64) -> Option<i64> {
    run.units
        .iter()
        .map(|&unit| &plan.units[unit])
        .filter(|unit| unit.rows.len() > written)
        .map(|unit| written as i64 - unit.rows_started_by(at_ms) as i64)
        .min()
}

/// Streams run `run_index` of `plan` on paper over `line` with `preload_rows` rows per
/// unit loaded before the start.
pub fn simulate(plan: &Plan, run_index: usize, line: Line, preload_rows: usize) -> Simulation {
    let Some(run) = plan.gateways.get(run_index) else {
        return simulate_measured(plan, run_index, line, preload_rows, None);
    };
    let bytes = stream::RowBytes::new(plan, run);
    simulate_measured(plan, run_index, line, preload_rows, Some(&bytes))
}

/// [`simulate`] with the run's rows measured already ([`stream::RowBytes`] of run
/// `run_index`; `None` only when there is no such run).
fn simulate_measured(
    plan: &Plan,
    run_index: usize,
    line: Line,
    preload_rows: usize,
    bytes: Option<&stream::RowBytes>,
) -> Simulation {
    let (Some(run), Some(bytes)) = (plan.gateways.get(run_index), bytes) else {
        return Simulation {
            preload_rows: 0,
            preload_bytes: 0,
            preload_ms: 0.0,
            stream_bytes: 0,
            bytes_per_row: 0.0,
            lowest_level: None,
            underrun_at_ms: None,
        };
    };
    let byte_ms = planned_byte_ms(line);
    let total_rows = longest(plan, run);
    let preload_rows = match run.mode {
        RunMode::Fifo => preload_rows.min(total_rows),
        RunMode::Single | RunMode::Loop => total_rows,
    };
    let mut preload_bytes =
        (stream::configure(plan, run).len() + stream::arm().len() + stream::begin().len()) as u64;
    let mut row = 0;
    while row < preload_rows {
        let to = (row + ROUND_ROWS).min(preload_rows);
        preload_bytes += bytes.len(row, to) as u64;
        row = to;
    }
    let mut stream_bytes = 0u64;
    let mut lowest: Option<i64> = None;
    let mut underrun_at_ms = None;
    let mut line_free_ms = 0.0f64;
    while row < total_rows {
        let to = round_end(run, plan, row);
        let start = line_free_ms.max(round_room_at_ms(plan, run, to));
        let round_bytes = bytes.len(row, to) as u64;
        let landed = start + round_bytes as f64 * byte_ms;
        if let Some(level) = level_at(plan, run, row, landed) {
            if level < 0 && underrun_at_ms.is_none() {
                underrun_at_ms = Some(landed);
            }
            lowest = Some(lowest.map_or(level, |lowest| lowest.min(level)));
        }
        stream_bytes += round_bytes;
        line_free_ms = landed;
        row = to;
    }
    let unit_rows: usize = run
        .units
        .iter()
        .map(|&unit| plan.units[unit].rows.len())
        .sum();
    let row_bytes = preload_bytes + stream_bytes;
    Simulation {
        preload_rows,
        preload_bytes,
        preload_ms: preload_bytes as f64 * byte_ms,
        stream_bytes,
        bytes_per_row: if unit_rows == 0 {
            0.0
        } else {
            row_bytes as f64 / unit_rows as f64
        },
        lowest_level: lowest,
        underrun_at_ms,
    }
}

/// The shallowest preload (rows per unit) that keeps every FIFO at least
/// [`MIN_LEVEL_ROWS`] deep over `line`, plus [`SAFETY_ROWS`], with its simulation; the
/// deepest possible preload when none does (the simulation then says how it fails).
pub fn choose_preload(plan: &Plan, run_index: usize, line: Line) -> Simulation {
    let Some(run) = plan.gateways.get(run_index) else {
        return simulate(plan, run_index, line, 0);
    };
    // Every depth tried streams the same rows: measure them once.
    let bytes = stream::RowBytes::new(plan, run);
    let simulate = |plan, run_index, line, preload_rows| {
        simulate_measured(plan, run_index, line, preload_rows, Some(&bytes))
    };
    let total = longest(plan, run);
    let deepest = simulate(plan, run_index, line, total.min(FIFO_LIMIT));
    if run.mode != RunMode::Fifo || !deepest.keeps_margin() {
        return deepest;
    }
    // The level only rises with a deeper preload: search the shallowest that works.
    let (mut low, mut high) = (ROUND_ROWS.min(total), total.min(FIFO_LIMIT));
    let mut best = deepest;
    while low < high {
        let middle = (low + high) / 2;
        let attempt = simulate(plan, run_index, line, middle);
        if attempt.keeps_margin() {
            high = middle;
            best = attempt;
        } else {
            low = middle + 1;
        }
    }
    let safe = (high + SAFETY_ROWS).min(total.min(FIFO_LIMIT));
    if best.preload_rows != safe {
        best = simulate(plan, run_index, line, safe);
    }
    best
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::uim2503::plan::tests::{installation, wave};
    use crate::uim2503::plan::{Plan, PlanOptions};

    #[test]
    fn a_slow_show_on_a_fast_line_streams_with_a_shallow_preload() {
        // 10 units, 600 rows of 250 ms (150 s) at 115200 baud: easy.
        let show = wave(2, 5, 600, 250);
        let plan = Plan::new(&show, &installation(2, 5, 115_200), PlanOptions::default()).unwrap();
        let simulation = choose_preload(&plan, 0, Line::new(115_200));
        assert!(simulation.keeps_margin(), "{simulation:?}");
        assert!(simulation.preload_rows <= 48, "{simulation:?}");
        assert_eq!(plan.gateways[0].preload_rows, simulation.preload_rows);
    }

    #[test]
    fn a_hundred_units_on_9600_baud_run_dry() {
        let show = wave(10, 10, 600, 250);
        let plan = Plan::new(&show, &installation(10, 10, 9600), PlanOptions::default()).unwrap();
        let simulation = choose_preload(&plan, 0, Line::new(9600));
        assert!(!simulation.keeps_margin());
        assert_eq!(simulation.preload_rows, 255);
        assert!(simulation.lowest_level.unwrap() < 0);
        assert!(simulation.underrun_at_ms.is_some());
    }

    #[test]
    fn a_deeper_preload_never_lowers_the_level() {
        let show = wave(4, 5, 400, 120);
        let plan = Plan::new(&show, &installation(4, 5, 57_600), PlanOptions::default()).unwrap();
        let mut previous = i64::MIN;
        for preload in [16, 32, 64, 128, 255] {
            let level = simulate(&plan, 0, Line::new(57_600), preload)
                .lowest_level
                .unwrap();
            assert!(level >= previous, "{preload}: {level} < {previous}");
            previous = level;
        }
    }

    #[test]
    fn rounds_wait_for_room_in_the_fifo() {
        let show = wave(1, 1, 600, 100);
        let plan = Plan::new(&show, &installation(1, 1, 115_200), PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        assert_eq!(round_room_at_ms(&plan, run, 255), f64::NEG_INFINITY);
        // Rows up to 272 fit once row 16 has started: 16 × 100 ms in.
        assert_eq!(round_room_at_ms(&plan, run, 272), 1600.0);
    }

    #[test]
    fn single_mode_preloads_everything() {
        let show = wave(1, 2, 100, 200);
        let plan = Plan::new(&show, &installation(1, 2, 9600), PlanOptions::default()).unwrap();
        let simulation = choose_preload(&plan, 0, Line::new(9600));
        assert_eq!(simulation.preload_rows, 100);
        assert_eq!(simulation.lowest_level, None);
        assert_eq!(simulation.stream_bytes, 0);
        assert!(simulation.preload_ms > 1000.0);
    }
}
