//! Live mode on UIM2503 units ([`crate::player::live`]): the filtered motion streamed
//! as PVT rows into a short FIFO on every unit, one row per period.
//!
//! - **The row time** is what each gateway's line carries: every unit on a gateway
//!   needs a row each period (a FIFO unit that runs out of rows stops, so a ball that
//!   stands still costs a row too), so a period must carry a row for every unit of
//!   the gateway — `*N;QP[i]p;QV[i]v;` each, at their longest values, and one shared
//!   `*0;QT[i]t;` — at the planner's share of the line
//!   ([`schedule::planned_byte_ms`]). The slowest gateway sets the period for all
//!   (every unit takes the same rows at the same time), at least [`ROW_MIN_MS`]; more
//!   than [`ROW_MAX_MS`] is refused ([`StartError::LiveLineTooSlow`]).
//! - **Prepare**: every gateway's units are configured for FIFO mode (motor on, the
//!   table cleared, the watermark notice), given [`live_fifo_rows`] rows at rest where
//!   they stand, armed (`PV=0`) and confirmed with the `PV;` barrier (it answers the
//!   water level); then `*0;BG;` goes on every gateway's priority lane at one instant
//!   ([`START_LEAD_US`] ahead), and the units' start is the first period's slot.
//! - **Stream**: each period one row per unit with the filtered position and velocity
//!   at the period's end — a filter step has a constant acceleration, so the unit's
//!   cubic between rows is the filter's parabola exactly — written into the table
//!   round (`row % 256`), rows every unit of a gateway shares broadcast once
//!   ([`stream::rows`]). The FIFO stays [`live_fifo_rows`] deep (six rows, and at least
//!   [`LIVE_FIFO_MIN_MS`]): a row written at a slot runs that many rows later, so the
//!   latency is one row time more than the FIFO's depth (one more row for an input
//!   that just missed a slot).
//! - **Rounding**: rows are whole counts, so the filter runs a little under the
//!   installation's speed and acceleration (what half a count at each end of a row can
//!   add, [`rounding_margins`]: 6/T² + 6/T counts/s² — at 100 counts/mm and 11 ms rows
//!   501 mm/s², a quarter of 2,000 mm/s²; the row is made long enough that this is at
//!   most half the limits): no row asks a unit for more than it has. Each row is the
//!   whole-count row nearest to the filter's state that the unit accepts after the
//!   row before it ([`rounding::live_row`]): inside the travel along its whole cubic,
//!   with an end from which the next row can stay inside too — near an end of the
//!   travel a state rounded on its own (0.4 counts below the top, still rising, becomes
//!   the top itself, still rising) makes the next row's cubic dip past the end, and
//!   the unit stops with LIMIT. So a fader at 0 or full brings the balls to the very
//!   end, to the count, and never past it.
//! - **Running dry**: a bridge more than [`live_fifo_rows`] rows late (a stall under
//!   heavy load) leaves the units without a row; they brake with `SD`, stop, and run
//!   no row written after — silently (the rows' `QT` is broadcast, so not even a full
//!   FIFO is answered). Every [`LEVEL_CHECK_ROWS`] rows each gateway's first unit is
//!   asked its water level (`PV;`); more than twice the FIFO's rows pending means
//!   it stopped taking rows: live mode fails with that said, the matrix is stopped,
//!   and the next live mode homes first.
//! - **End**: the last rows hold the balls at rest; the FIFO runs out after them and
//!   the units stop where the rows end. Their positions are then **read back**
//!   ([`AfterLive`]): a unit whose FIFO ran dry before (the bridge fell more than the
//!   FIFO's rows behind, e.g. under heavy load) braked with `SD` and stands where it
//!   stopped, not where the rows end (`docs/uim2503.md` §3: a FIFO whose rows run
//!   out stops, with `SD`; the rows written after that are never run). Until every unit answered, the
//!   positions are unknown (live mode or a show asked for meanwhile homes or asks,
//!   and no new table is loaded under an old run still going): live mode again
//!   starts its rows where each unit really is, not with a row the unit cannot
//!   follow.

use super::{Command, Phase, START_LEAD_US, Step, Uim2503Drive};
use crate::line::Line;
use crate::live::filter::{BallState, FilterLimits};
use crate::player::{LiveSetup, StartError};
use crate::uim2503::ascii::{Batch, Instruction};
use crate::uim2503::plan::{GatewayRun, Plan, RunMode, UnitPlan};
use crate::uim2503::pvt::rounding::{self, End, Envelope};
use crate::uim2503::pvt::{ROW_MAX_MS, ROW_MIN_MS, Row, TABLE_ROWS};
use crate::uim2503::{schedule, stream};

/// Rows every unit's FIFO holds ahead while live, at least.
pub const LIVE_FIFO_ROWS: usize = 6;

/// Time every unit's FIFO holds ahead while live, at least, ms: the bridge may fall
/// this far behind (a stall on a loaded host) before a unit runs dry. Six rows of a
/// small matrix's short row time (84 ms at 14 ms) ran dry under load.
pub const LIVE_FIFO_MIN_MS: u64 = 150;

/// Rows every unit's FIFO holds ahead while live at rows of `row_ms`: at least
/// [`LIVE_FIFO_ROWS`], and at least [`LIVE_FIFO_MIN_MS`] of them.
#[must_use]
pub fn live_fifo_rows(row_ms: u8) -> usize {
    let by_time = LIVE_FIFO_MIN_MS.div_ceil(u64::from(row_ms.max(1)));
    LIVE_FIFO_ROWS.max(usize::try_from(by_time).unwrap_or(LIVE_FIFO_ROWS))
}

/// Rows between two questions of each gateway's water level (`PV;` to its first
/// unit) while live: a unit whose FIFO ran dry stopped and runs no row written after
/// (`docs/uim2503.md` §3), so its level climbs past what is ever written ahead.
pub const LEVEL_CHECK_ROWS: usize = 16;

/// Position questions after live mode before one counts as unanswered (the
/// positions then stay unknown: the next live mode or show homes or asks).
const AFTER_LIVE_QUERIES: u32 = 20;

/// The least time between two rounds of position questions after live mode, µs.
const AFTER_LIVE_WAIT_US: u64 = 20_000;

/// After live mode: where each unit stopped, asked (`PA;`) once its FIFO ran out.
/// A unit's position is taken when it answers where the rows left it, or the same
/// twice running (at rest elsewhere: its FIFO ran dry and it braked there).
#[derive(Debug, Clone)]
pub(super) struct AfterLive {
    /// Where the rows left each unit, counts.
    expected: Vec<Option<i32>>,
    /// Each unit's last answer, counts.
    answers: Vec<Option<i32>>,
    confirmed: Vec<bool>,
    next_query_us: u64,
    /// Between rounds of questions, µs.
    wait_us: u64,
    queries: u32,
}

/// Live motion under way on the units.
#[derive(Debug, Clone)]
pub(super) struct LiveStream {
    /// The units' rows: a table's round of rows per unit, the next at `next_row % 256`.
    plan: Plan,
    row_ms: u8,
    /// The travel and limits the rows keep, in counts.
    envelope: Envelope,
    next_row: usize,
    /// Per run: the barrier answered.
    confirmed: Vec<bool>,
    started: bool,
}

impl Uim2503Drive {
    /// The bytes of one live row for every unit on `gateway`, at their longest.
    fn live_row_bytes(&self, gateway: usize) -> usize {
        let installation = &self.config.installation;
        let limits = installation.limits;
        let longest = |mm: f64| installation.counts(mm).map_or(i32::MIN, |c| -c.abs());
        let position = longest(limits.travel_mm).min(longest(0.0));
        let velocity = longest(limits.max_speed_mm_s);
        let mut batch = Batch::new();
        let mut push = |instruction: Instruction| {
            let _ = batch.push(&instruction, stream::FORM);
        };
        for unit in installation.units_on(gateway) {
            push(Instruction::Select {
                station: installation.units[unit].station,
            });
            push(Instruction::PvtPosition {
                row: 255,
                position_counts: Some(position),
            });
            push(Instruction::PvtVelocity {
                row: 255,
                velocity_counts_s: Some(velocity),
            });
        }
        push(Instruction::Select { station: 0 });
        push(Instruction::PvtTime {
            row: 255,
            duration_ms: Some(ROW_MAX_MS),
        });
        batch.len()
    }

    /// The row time the lines carry (the slowest gateway's), ms.
    ///
    /// # Errors
    /// [`StartError::LiveLineTooSlow`] for a gateway that needs more than a row may
    /// last.
    pub(super) fn live_row_ms(&self) -> Result<u8, StartError> {
        let installation = &self.config.installation;
        let mut row_ms = u64::from(rounding_row_min_ms(installation));
        for (gateway, spec) in installation.gateways.iter().enumerate() {
            let units = installation.units_on(gateway).count();
            if units == 0 {
                continue;
            }
            let line = crate::line::Line::new(spec.baud);
            let bytes = self.live_row_bytes(gateway);
            let needs_ms = (bytes as f64 * schedule::planned_byte_ms(line)).ceil() as u64;
            if needs_ms > u64::from(ROW_MAX_MS) {
                return Err(StartError::LiveLineTooSlow {
                    gateway,
                    units,
                    row_ms: needs_ms,
                    max_ms: u64::from(ROW_MAX_MS),
                });
            }
            row_ms = row_ms.max(needs_ms);
        }
        Ok(u8::try_from(row_ms).unwrap_or(ROW_MAX_MS))
    }

    pub(super) fn live_setup_uim(&self) -> Result<LiveSetup, StartError> {
        let row_ms = self.live_row_ms()?;
        let installation = &self.config.installation;
        let limits = installation.limits;
        let row_us = u64::from(row_ms) * 1_000;
        // Rows are whole counts: the filter keeps what rounding can add under the
        // limits, so no row asks the unit for more than it has (the unit refuses a
        // row over its limits).
        let (speed_margin, accel_margin) = rounding_margins(installation, row_ms);
        Ok(LiveSetup {
            limits: FilterLimits {
                travel_mm: limits.travel_mm,
                max_speed_mm_s: (limits.max_speed_mm_s - speed_margin)
                    .max(limits.max_speed_mm_s / 2.0),
                max_accel_mm_s2: (limits.max_accel_mm_s2 - accel_margin)
                    .max(limits.max_accel_mm_s2 / 2.0),
                dt_ms: u32::from(row_ms),
            },
            approach_speed_mm_s: installation.approach_speed_mm_s,
            layout: installation.layout(),
            latency_us: (live_fifo_rows(row_ms) as u64 + 1) * row_us,
            // The units take a row from their FIFO every row time, late caller or
            // not: every row is written.
            every_period: true,
        })
    }

    /// Where the balls rest, mm, when every one is known and nothing moves.
    pub(super) fn rest_mm(&self) -> Option<Vec<f64>> {
        if !matches!(self.step, Step::Idle) || self.live.is_some() {
            return None;
        }
        let per_mm = self.config.installation.counts_per_mm;
        self.believed
            .iter()
            .map(|counts| counts.map(|counts| f64::from(counts) / per_mm))
            .collect()
    }

    /// A ball's state as a row of `row_ms` after the row that ended at `from`: the
    /// whole-count row nearest to it that the unit accepts ([`rounding::live_row`]:
    /// inside the travel along its whole cubic, and after it every next row can be,
    /// within the limits).
    fn live_row(&self, envelope: &Envelope, from: End, state: BallState, row_ms: u8) -> Row {
        let per_mm = self.config.installation.counts_per_mm;
        rounding::live_row(
            envelope,
            from,
            state.position_mm * per_mm,
            state.velocity_mm_s * per_mm,
            row_ms,
        )
    }

    /// A row of `row_ms` at rest at `position_mm` (rounded, inside the travel).
    fn rest_row(&self, envelope: &Envelope, position_mm: f64, row_ms: u8) -> Row {
        let counts = self
            .config
            .installation
            .counts(position_mm)
            .unwrap_or(envelope.low_counts)
            .clamp(envelope.low_counts, envelope.high_counts);
        Row {
            position_counts: counts,
            velocity_counts_s: 0,
            duration_ms: row_ms,
        }
    }

    /// Configures every unit for FIFO mode, preloads [`live_fifo_rows`] rows at rest
    /// at `states` and arms them with the barrier.
    pub(super) fn begin_live_stream(&mut self, states: &[BallState]) -> bool {
        let Ok(row_ms) = self.live_row_ms() else {
            return false;
        };
        let installation = &self.config.installation;
        let envelope = Envelope::of(installation);
        let units: Vec<UnitPlan> = installation
            .units
            .iter()
            .enumerate()
            .map(|(unit, address)| {
                let state = states.get(unit).copied().unwrap_or_default();
                let rest = self.rest_row(&envelope, state.position_mm, row_ms);
                UnitPlan {
                    address: *address,
                    start_counts: rest.position_counts,
                    rows: vec![rest; TABLE_ROWS],
                    row_start_ms: Vec::new(),
                }
            })
            .collect();
        let gateways: Vec<GatewayRun> = installation
            .gateways
            .iter()
            .enumerate()
            .filter_map(|(gateway, spec)| {
                let members: Vec<usize> = installation.units_on(gateway).collect();
                (!members.is_empty()).then(|| GatewayRun {
                    gateway,
                    mode: RunMode::Fifo,
                    units: members,
                    preload_rows: live_fifo_rows(row_ms),
                    line: crate::line::Line::new(spec.baud),
                })
            })
            .collect();
        let counts = |mm: f64| installation.counts(mm).unwrap_or(0);
        let plan = Plan {
            show: "live".into(),
            duration_ms: 0,
            units,
            gateways,
            approach_speed_counts_s: counts(installation.approach_speed_mm_s).max(1),
            home_counts: counts(installation.home_mm),
            stop_decel_counts_s2: u32::try_from(counts(installation.stop_decel_mm_s2).max(1))
                .unwrap_or(1),
        };
        for run in &plan.gateways {
            let Some(&first) = run.units.first() else {
                continue;
            };
            let mut batch = stream::configure(&plan, run);
            batch.extend(&stream::rows(&plan, run, 0, live_fifo_rows(row_ms)));
            batch.extend(&stream::arm_and_confirm(plan.units[first].address.station));
            self.commands.push(Command::Bulk {
                gateway: run.gateway,
                batch,
            });
        }
        self.believed.iter_mut().for_each(|counts| *counts = None);
        self.after_live = None;
        self.step = Step::Idle;
        self.progress = 0.0;
        self.live = Some(LiveStream {
            confirmed: vec![false; plan.gateways.len()],
            plan,
            row_ms,
            envelope,
            next_row: live_fifo_rows(row_ms),
            started: false,
        });
        true
    }

    /// The answer to a gateway's `PV;` barrier while live mode prepares: once every
    /// gateway answered its water level, every gateway starts at one instant, and the
    /// units' start is live motion's first slot.
    pub(super) fn live_barrier_answered(
        &mut self,
        now_us: u64,
        gateway: usize,
        station: u8,
        value: u16,
    ) -> Phase {
        let Some(live) = self.live.as_mut() else {
            return Phase::Pending;
        };
        if live.started {
            return Phase::Pending;
        }
        let Some(index) = live
            .plan
            .gateways
            .iter()
            .position(|run| run.gateway == gateway)
        else {
            return Phase::Pending;
        };
        let run = &live.plan.gateways[index];
        let Some(&first) = run.units.first() else {
            return Phase::Pending;
        };
        if live.plan.units[first].address.station != station {
            return Phase::Pending;
        }
        let rows = live_fifo_rows(live.row_ms);
        if usize::from(value) != rows {
            let who = self.describe_unit(first);
            return Phase::Failed(format!(
                "{who} answered PV with {value} while preparing live mode, expected {rows}; the matrix was stopped"
            ));
        }
        live.confirmed[index] = true;
        if !live.confirmed.iter().all(|&done| done) {
            return Phase::Pending;
        }
        live.started = true;
        let begin = stream::begin();
        let at_us = now_us + START_LEAD_US;
        let mut start_us = None;
        for run in &live.plan.gateways {
            start_us.get_or_insert(at_us + run.line.time_us(begin.len()));
            self.commands.push(Command::Priority {
                gateway: run.gateway,
                batch: begin.clone(),
                at_us,
            });
        }
        self.progress = 1.0;
        Phase::Done {
            at_us: start_us.unwrap_or(at_us),
        }
    }

    /// A water level (`PV;`) answered while the units run live rows: why live mode
    /// fails when the unit stopped taking rows (its FIFO ran dry).
    pub(super) fn live_ran_dry(&self, gateway: usize, station: u8, value: u16) -> Option<String> {
        let live = self.live.as_ref().filter(|live| live.started)?;
        let rows = live_fifo_rows(live.row_ms);
        if usize::from(value) <= 2 * rows {
            return None;
        }
        let run = live
            .plan
            .gateways
            .iter()
            .find(|run| run.gateway == gateway)?;
        let first = *run.units.first()?;
        (live.plan.units[first].address.station == station).then(|| {
            format!(
                "{} has {value} live rows pending, not taking them: its rows ran out (the \
                 bridge fell more than {rows} rows of {} ms behind, e.g. under heavy \
                 load) and the units on gateway {gateway} stopped; the matrix was stopped",
                self.describe_unit(first),
                live.row_ms
            )
        })
    }

    /// One period's rows: every unit's state at the period's end.
    pub(super) fn live_rows(&mut self, states: &[BallState]) {
        let Some(mut live) = self.live.take() else {
            return;
        };
        if live.started {
            let index = live.next_row % TABLE_ROWS;
            // Every row follows the one before it (the preload's rest rows first).
            let previous = (live.next_row + TABLE_ROWS - 1) % TABLE_ROWS;
            for (unit, plan) in live.plan.units.iter_mut().enumerate() {
                let state = states.get(unit).copied().unwrap_or_default();
                let from = End::of(&plan.rows[previous]);
                plan.rows[index] = self.live_row(&live.envelope, from, state, live.row_ms);
            }
            let check = live.next_row % LEVEL_CHECK_ROWS == 0;
            for run in &live.plan.gateways {
                let mut batch = stream::rows(&live.plan, run, index, index + 1);
                if check && let Some(&first) = run.units.first() {
                    let station = live.plan.units[first].address.station;
                    for instruction in [
                        Instruction::Select { station },
                        Instruction::PvtStart { row: None },
                    ] {
                        let _ = batch.push(&instruction, stream::FORM);
                    }
                }
                self.commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch,
                });
            }
            live.next_row += 1;
        }
        self.live = Some(live);
    }

    /// Live motion is over at `at_us`: the rows leave the balls at rest at `states`.
    /// Where they are is asked once the FIFO ran out ([`AfterLive`]); unknown until
    /// then.
    pub(super) fn end_live_stream(&mut self, at_us: u64, states: &[BallState]) {
        let live = self.live.take();
        let row_ms = live.as_ref().map_or(ROW_MAX_MS, |live| live.row_ms);
        let row_us = u64::from(row_ms) * 1_000;
        let installation = &self.config.installation;
        // Where the last rows written leave each unit (the states rounded as the
        // rows were, inside the travel).
        let expected: Vec<Option<i32>> = (0..installation.units.len())
            .map(|unit| match &live {
                Some(live) => {
                    let last = (live.next_row + TABLE_ROWS - 1) % TABLE_ROWS;
                    live.plan
                        .units
                        .get(unit)
                        .map(|plan| plan.rows[last].position_counts)
                }
                None => states
                    .get(unit)
                    .and_then(|state| installation.counts(state.position_mm)),
            })
            .collect();
        let units = expected.len();
        self.believed.iter_mut().for_each(|counts| *counts = None);
        self.after_live = Some(AfterLive {
            expected,
            answers: vec![None; units],
            confirmed: vec![false; units],
            // The rows still in the FIFO run out (one more for the row under way).
            next_query_us: at_us + (live_fifo_rows(row_ms) as u64 + 1) * row_us,
            wait_us: (2 * row_us).max(AFTER_LIVE_WAIT_US),
            queries: 0,
        });
        self.step = Step::Idle;
    }

    /// Whether the positions after live mode are still being asked.
    pub(super) fn after_live_under_way(&self) -> bool {
        self.after_live.is_some()
    }

    /// While idle after live mode: the position questions, when due.
    pub(super) fn poll_after_live(&mut self, now_us: u64) {
        let Some(after) = self.after_live.as_mut() else {
            return;
        };
        if now_us < after.next_query_us {
            return;
        }
        if after.queries >= AFTER_LIVE_QUERIES {
            // Not every unit answered: the positions stay unknown.
            self.after_live = None;
            return;
        }
        after.queries += 1;
        let installation = &self.config.installation;
        let mut slowest_us = 0;
        for (gateway, spec) in installation.gateways.iter().enumerate() {
            let stations: Vec<u8> = installation
                .units_on(gateway)
                .filter(|&unit| !after.confirmed.get(unit).copied().unwrap_or(true))
                .map(|unit| installation.units[unit].station)
                .collect();
            if !stations.is_empty() {
                let batch = stream::where_are(&stations);
                // Questions and answers both cross the line: leave room for them.
                slowest_us = slowest_us.max(3 * Line::new(spec.baud).time_us(batch.len() * 2));
                self.commands.push(Command::Bulk { gateway, batch });
            }
        }
        after.next_query_us = now_us + after.wait_us.max(slowest_us);
    }

    /// A unit's answer to a position question after live mode. Once every unit's
    /// position is known they are the drive's; a note when some ball stood elsewhere
    /// than the rows left it.
    pub(super) fn after_live_answered(&mut self, unit: usize, counts: i32) -> Option<String> {
        let after = self.after_live.as_mut()?;
        let expected = after.expected.get(unit).copied().flatten();
        let previous = after.answers.get_mut(unit)?.replace(counts);
        if Some(counts) == expected || previous == Some(counts) {
            after.confirmed[unit] = true;
        }
        if !after.confirmed.iter().all(|&done| done) {
            return None;
        }
        let after = self.after_live.take()?;
        self.believed.clone_from(&after.answers);
        let off: Vec<(usize, f64)> = after
            .answers
            .iter()
            .zip(&after.expected)
            .enumerate()
            .filter_map(|(unit, (answer, expected))| {
                let (answer, expected) = (answer.as_ref()?, expected.as_ref()?);
                (answer != expected).then(|| {
                    let per_mm = self.config.installation.counts_per_mm;
                    (unit, f64::from(answer - expected).abs() / per_mm)
                })
            })
            .collect();
        let &(first, mm) = off.first()?;
        Some(format!(
            "{} ball(s) stopped away from where live mode left them (first {}, {mm:.1} mm \
             from it): their rows ran out (the bridge fell behind); their positions were read",
            off.len(),
            self.describe_unit(first)
        ))
    }
}

/// What rounding a live row to whole counts can add to the filter's motion at rows
/// of `row_ms`, in mm/s and mm/s²: a position off by half a count at each end of a
/// row (and a velocity by half a count/s) bends its cubic by up to 6/T² + 3/T
/// counts/s² and 1.5/T counts/s; kept here are 6/T² + 6/T and 3/T + 1, which also
/// leave room for the row ends chosen near an end of the travel
/// ([`rounding::live_row`]: none over the limits in its tests' random sweep). The
/// filter keeps that much under the limits, so no row asks the unit for more than
/// it has. At 100 counts/mm: 606 mm/s² at 10 ms rows, 501 at 11 ms, 310 at 14 ms.
fn rounding_margins(installation: &crate::plan::Installation, row_ms: u8) -> (f64, f64) {
    let t_s = f64::from(row_ms.max(1)) / 1000.0;
    let per_mm = installation.counts_per_mm.abs().max(f64::MIN_POSITIVE);
    let speed_margin_mm_s = (3.0 / t_s + 1.0) / per_mm;
    let accel_margin_mm_s2 = (6.0 / (t_s * t_s) + 6.0 / t_s) / per_mm;
    (speed_margin_mm_s, accel_margin_mm_s2)
}

/// The shortest live row, ms, at which rounding takes at most half of the top speed
/// and acceleration ([`rounding_margins`]): shorter rows of a coarse calibration or a
/// low acceleration would bend the cubics by more than the filter can leave spare
/// (at 100 counts/mm and 500 mm/s², 16 ms rather than 10).
fn rounding_row_min_ms(installation: &crate::plan::Installation) -> u8 {
    let limits = installation.limits;
    (ROW_MIN_MS..=ROW_MAX_MS)
        .find(|&row_ms| {
            let (speed_mm_s, accel_mm_s2) = rounding_margins(installation, row_ms);
            speed_mm_s <= limits.max_speed_mm_s / 2.0 && accel_mm_s2 <= limits.max_accel_mm_s2 / 2.0
        })
        .unwrap_or(ROW_MAX_MS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_are_long_enough_for_rounding_to_take_at_most_half_the_limits() {
        let installation = |accel_mm_s2: f64, counts_per_mm: f64| {
            let mut installation =
                crate::plan::Installation::demo(1, 1, &[115_200]).expect("a matrix");
            installation.limits.max_accel_mm_s2 = accel_mm_s2;
            installation.counts_per_mm = counts_per_mm;
            installation
        };
        // 100 counts/mm: 10 ms rows bend the cubics by up to 606 mm/s².
        assert_eq!(rounding_row_min_ms(&installation(2000.0, 100.0)), 10);
        assert_eq!(rounding_row_min_ms(&installation(500.0, 100.0)), 16);
        assert_eq!(rounding_row_min_ms(&installation(2000.0, 10.0)), 25);
        let (_, accel_mm_s2) = rounding_margins(&installation(2000.0, 100.0), 11);
        assert!((accel_mm_s2 - 501.3).abs() < 0.1, "{accel_mm_s2}");
        for accel in [100.0, 500.0, 2000.0, 40_000.0] {
            let installation = installation(accel, 100.0);
            let row_ms = rounding_row_min_ms(&installation);
            let (_, margin) = rounding_margins(&installation, row_ms);
            assert!(
                margin <= accel / 2.0 || row_ms == ROW_MAX_MS,
                "{accel}: {row_ms} ms"
            );
        }
    }

    #[test]
    fn the_fifo_holds_six_rows_and_at_least_150_ms() {
        // A small matrix's short rows: 150 ms of them.
        assert_eq!(live_fifo_rows(14), 11);
        assert_eq!(live_fifo_rows(10), 15);
        assert_eq!(live_fifo_rows(25), 6);
        // Long rows: six.
        assert_eq!(live_fifo_rows(156), 6);
        assert_eq!(live_fifo_rows(u8::MAX), 6);
        for row_ms in ROW_MIN_MS..=u8::MAX {
            let rows = live_fifo_rows(row_ms);
            assert!((LIVE_FIFO_ROWS..TABLE_ROWS).contains(&rows));
            assert!(rows as u64 * u64::from(row_ms) >= LIVE_FIFO_MIN_MS);
        }
    }
}
