//! The instructions a plan puts on each gateway's line, in the fewest bytes the manual
//! allows:
//!
//! - the compact form (`QP[3]1000;`, no `=`);
//! - one `*N;` per batch of a station's rows, not one per row;
//! - a `*0;` broadcast of a whole row when every unit of the gateway gets the same one,
//!   and otherwise of the row's `QT` when every unit shares the duration (tracks made
//!   from keyframes do): each unit still receives `QP`, `QV`, `QT` in that order, and
//!   its water level rises at the shared `QT`;
//! - before the first wrap of the table (rows still cleared by `MP[0]=1`), zero
//!   positions and velocities are not written in single-sequence and loop mode.
//!
//! Everything is built with the codec ([`Batch`]), so only valid instructions result.

use super::plan::{GatewayRun, Plan, RunMode, UnitPlan};
use super::stretch::Stretch;
use crate::uim2503::ascii::{Batch, Form, Instruction, MpParam};
use crate::uim2503::pvt::TABLE_ROWS;

/// The shortest row time the units take (`QT`), ms.
const ROW_MS_MIN: i32 = 10;

/// The form every planned instruction is written in.
pub const FORM: Form = Form::Compact;

/// The watermark (`MP[5]`) streaming units report at: a notice means the refill fell
/// this far behind the plan.
pub const WATERMARK_ROWS: u8 = 4;

fn push(batch: &mut Batch, instruction: Instruction) {
    // Every instruction built here is within the codec's ranges by construction
    // (stations 0–127, rows 0–255, durations 10–255, i32 operands); a refusal would be
    // a planner bug, and the instruction is left out rather than sent malformed.
    if let Err(err) = batch.push(&instruction, FORM) {
        debug_assert!(false, "planner built an invalid instruction: {err}");
    }
}

fn select(batch: &mut Batch, station: u8) {
    push(batch, Instruction::Select { station });
}

fn mp(batch: &mut Batch, param: MpParam, value: u8) {
    push(
        batch,
        Instruction::MotionProfile {
            param,
            value: Some(value),
        },
    );
}

/// The table index of row `row` of a track in `mode`.
pub fn table_index(mode: RunMode, row: usize) -> u8 {
    let index = match mode {
        RunMode::Fifo => row % TABLE_ROWS,
        RunMode::Single | RunMode::Loop => row,
    };
    u8::try_from(index).unwrap_or(u8::MAX)
}

/// Point-to-point moves of the units at `targets` (station, target counts) at
/// `speed_counts_s`: motor on, speed, targets (one broadcast when all are the same),
/// then one broadcast `BG`. `targets` should name every unit of the gateway: the
/// broadcasts reach them all.
pub fn move_to(speed_counts_s: i32, targets: &[(u8, i32)]) -> Batch {
    let mut batch = Batch::new();
    select(&mut batch, 0);
    push(&mut batch, Instruction::Motor { on: Some(true) });
    push(
        &mut batch,
        Instruction::PtpSpeed {
            speed_counts_s: Some(speed_counts_s),
        },
    );
    if targets.windows(2).all(|pair| pair[0].1 == pair[1].1) {
        if let Some(&(_, position_counts)) = targets.first() {
            push(
                &mut batch,
                Instruction::PtpPosition {
                    position_counts: Some(position_counts),
                },
            );
        }
    } else {
        for &(station, position_counts) in targets {
            select(&mut batch, station);
            push(
                &mut batch,
                Instruction::PtpPosition {
                    position_counts: Some(position_counts),
                },
            );
        }
        select(&mut batch, 0);
    }
    push(&mut batch, Instruction::Begin { at_us: None });
    batch
}

/// The moves of every unit on `run`'s gateway to its start position.
pub fn approach_start(plan: &Plan, run: &GatewayRun) -> Batch {
    let targets: Vec<(u8, i32)> = run
        .units
        .iter()
        .map(|&unit| {
            (
                plan.units[unit].address.station,
                plan.units[unit].start_counts,
            )
        })
        .collect();
    move_to(plan.approach_speed_counts_s, &targets)
}

/// The moves of every unit on `run`'s gateway home.
pub fn home(plan: &Plan, run: &GatewayRun) -> Batch {
    let targets: Vec<(u8, i32)> = run
        .units
        .iter()
        .map(|&unit| (plan.units[unit].address.station, plan.home_counts))
        .collect();
    move_to(plan.approach_speed_counts_s, &targets)
}

/// Asks each unit at `stations` where it is (`PA;`): the simulated units answer with
/// their position, so a move's arrival can be confirmed.
pub fn where_are(stations: &[u8]) -> Batch {
    let mut batch = Batch::new();
    for &station in stations {
        select(&mut batch, station);
        push(
            &mut batch,
            Instruction::PtpPosition {
                position_counts: None,
            },
        );
    }
    batch
}

/// Arms every unit of the gateway to start at row 0 (`PV=0`) and asks the unit at
/// `barrier_station` for its `PV`: the answer comes only after the gateway has carried
/// out everything sent before it.
pub fn arm_and_confirm(barrier_station: u8) -> Batch {
    let mut batch = arm();
    select(&mut batch, barrier_station);
    push(&mut batch, Instruction::PvtStart { row: None });
    batch
}

/// Configures the table of every unit on `run`'s gateway (units at rest): mode, a
/// cleared table, the sequence range (single and loop), the stop deceleration, and the
/// watermark notice (FIFO).
pub fn configure(plan: &Plan, run: &GatewayRun) -> Batch {
    configure_with(plan, run, true)
}

/// [`configure`] without the motor on (`MO=1`): the table only, for arming a show
/// while the matrix is idle (the approach turns the motors on before the start).
pub fn configure_table(plan: &Plan, run: &GatewayRun) -> Batch {
    configure_with(plan, run, false)
}

fn configure_with(plan: &Plan, run: &GatewayRun, motor_on: bool) -> Batch {
    let mut batch = Batch::new();
    select(&mut batch, 0);
    if motor_on {
        push(&mut batch, Instruction::Motor { on: Some(true) });
    }
    mp(&mut batch, MpParam::Mode, run.mode.mp3());
    mp(&mut batch, MpParam::Clear, 1);
    push(
        &mut batch,
        Instruction::StopDecel {
            decel_counts_s2: Some(plan.stop_decel_counts_s2),
        },
    );
    match run.mode {
        RunMode::Fifo => {
            mp(&mut batch, MpParam::Watermark, WATERMARK_ROWS);
            push(
                &mut batch,
                Instruction::InfoEnable {
                    index: 5,
                    enabled: Some(true),
                },
            );
        }
        RunMode::Single | RunMode::Loop => {
            mp(&mut batch, MpParam::FirstRow, 0);
            let last =
                |unit: usize| table_index(run.mode, plan.units[unit].rows.len().saturating_sub(1));
            let lasts: Vec<u8> = run.units.iter().map(|&unit| last(unit)).collect();
            if lasts.windows(2).all(|pair| pair[0] == pair[1]) {
                if let Some(&last) = lasts.first() {
                    mp(&mut batch, MpParam::LastRow, last);
                }
            } else {
                for (&unit, &last) in run.units.iter().zip(&lasts) {
                    select(&mut batch, plan.units[unit].address.station);
                    mp(&mut batch, MpParam::LastRow, last);
                }
                select(&mut batch, 0);
            }
        }
    }
    batch
}

/// Every unit of the gateway's motor on (`*0;MO=1;`): before the start of tables that
/// were loaded while the matrix was idle ([`configure_table`]).
pub fn motor_on() -> Batch {
    let mut batch = Batch::new();
    select(&mut batch, 0);
    push(&mut batch, Instruction::Motor { on: Some(true) });
    batch
}

/// Arms every unit of the gateway to start at row 0 (`PV=0`), after its rows are in.
pub fn arm() -> Batch {
    let mut batch = Batch::new();
    select(&mut batch, 0);
    push(&mut batch, Instruction::PvtStart { row: Some(0) });
    batch
}

/// The synchronised start: every unit of the gateway begins in the same µs.
pub fn begin() -> Batch {
    let mut batch = Batch::new();
    select(&mut batch, 0);
    push(&mut batch, Instruction::Begin { at_us: None });
    batch
}

/// Rows `from..to` of every unit of `run`'s gateway (each unit's rows clipped to its
/// track), as one batch.
pub fn rows(plan: &Plan, run: &GatewayRun, from: usize, to: usize) -> Batch {
    rows_stretched(plan, run, from, to, None)
}

/// [`rows`] with each row's time field (`QT`) stretched as `stretch` says (at most
/// ±1 ms a row, [`Stretch::row_ms`]); `None`: as planned (the same bytes as [`rows`]).
pub fn rows_stretched(
    plan: &Plan,
    run: &GatewayRun,
    from: usize,
    to: usize,
    stretch: Option<&Stretch>,
) -> Batch {
    let mut batch = Batch::new();
    let units: Vec<&UnitPlan> = run.units.iter().map(|&unit| &plan.units[unit]).collect();
    // A row as written: its duration stretched.
    let row_of = |unit: &UnitPlan, row: usize| {
        let mut values = unit.rows[row];
        if let Some(stretch) = stretch {
            let start_ms = unit.row_start_ms.get(row).copied().unwrap_or(0);
            let gain = stretch.row_ms(start_ms, u64::from(values.duration_ms));
            values.duration_ms = u8::try_from(
                (i32::from(values.duration_ms) + gain).clamp(ROW_MS_MIN, i32::from(u8::MAX)),
            )
            .unwrap_or(values.duration_ms);
        }
        values
    };
    let everyone_has_all = units.iter().all(|unit| unit.rows.len() >= to);
    let identical_rows = everyone_has_all
        && (from..to).all(|row| {
            units
                .windows(2)
                .all(|pair| row_of(pair[0], row) == row_of(pair[1], row))
        });
    let shared_durations = everyone_has_all
        && (from..to).all(|row| {
            units
                .windows(2)
                .all(|pair| row_of(pair[0], row).duration_ms == row_of(pair[1], row).duration_ms)
        });
    // Rows never written since the table was cleared still hold zeros.
    let fresh = |row: usize| run.mode != RunMode::Fifo || row < TABLE_ROWS;
    let write_row = |batch: &mut Batch, unit: &UnitPlan, row: usize, with_time: bool| {
        let index = table_index(run.mode, row);
        let values = row_of(unit, row);
        let skip_zeros = run.mode != RunMode::Fifo && fresh(row);
        if !(skip_zeros && values.position_counts == 0) {
            push(
                batch,
                Instruction::PvtPosition {
                    row: index,
                    position_counts: Some(values.position_counts),
                },
            );
        }
        if !(skip_zeros && values.velocity_counts_s == 0) {
            push(
                batch,
                Instruction::PvtVelocity {
                    row: index,
                    velocity_counts_s: Some(values.velocity_counts_s),
                },
            );
        }
        if with_time {
            push(
                batch,
                Instruction::PvtTime {
                    row: index,
                    duration_ms: Some(values.duration_ms),
                },
            );
        }
    };
    if identical_rows && !units.is_empty() {
        select(&mut batch, 0);
        for row in from..to {
            write_row(&mut batch, units[0], row, true);
        }
        return batch;
    }
    for unit in &units {
        let end = to.min(unit.rows.len());
        if from >= end {
            continue;
        }
        select(&mut batch, unit.address.station);
        for row in from..end {
            write_row(&mut batch, unit, row, !shared_durations);
        }
    }
    if shared_durations && !units.is_empty() {
        select(&mut batch, 0);
        for row in from..to {
            push(
                &mut batch,
                Instruction::PvtTime {
                    row: table_index(run.mode, row),
                    duration_ms: Some(row_of(units[0], row).duration_ms),
                },
            );
        }
    }
    batch
}

/// The length of [`rows`] for any range of one run's rows, without building the
/// batches: planning a hundred gateways tries a dozen preload depths on each, and
/// encoding every row of every unit for each was most of its time.
///
/// Built once a run (every row's instructions measured once), it answers from prefix
/// sums with the same rules as [`rows`]: one broadcast for rows every unit shares, a
/// shared `QT` when every unit's durations agree, a `*N;` per unit and batch.
#[derive(Debug, Clone)]
pub struct RowBytes {
    /// Per unit: `QP` + `QV` bytes of its rows before row `r` (index `r`).
    position_velocity: Vec<Vec<usize>>,
    /// Per unit: `QT` bytes of its rows before row `r`.
    time: Vec<Vec<usize>>,
    /// Per unit: the bytes of its `*N;`.
    select: Vec<usize>,
    /// The bytes of `*0;`.
    broadcast: usize,
    /// Rows before `r` (of the rows every unit has) at which every unit's row is the
    /// same.
    identical: Vec<usize>,
    /// Rows before `r` at which every unit's duration is the same.
    shared_durations: Vec<usize>,
    /// The fewest rows any unit has.
    shortest: usize,
}

/// The bytes `instruction` takes in a batch (none if the codec refuses it, as
/// [`push`] leaves it out).
fn instruction_bytes(instruction: Instruction, scratch: &mut Vec<u8>) -> usize {
    scratch.clear();
    instruction.encode_into(FORM, scratch).unwrap_or(0)
}

impl RowBytes {
    /// Measures every row of `run`.
    pub fn new(plan: &Plan, run: &GatewayRun) -> Self {
        let units: Vec<&UnitPlan> = run.units.iter().map(|&unit| &plan.units[unit]).collect();
        let mut scratch = Vec::with_capacity(crate::uim2503::ascii::MAX_LEN);
        let fresh = |row: usize| run.mode != RunMode::Fifo || row < TABLE_ROWS;
        let mut position_velocity = Vec::with_capacity(units.len());
        let mut time = Vec::with_capacity(units.len());
        let mut select = Vec::with_capacity(units.len());
        for unit in &units {
            let mut pv = Vec::with_capacity(unit.rows.len() + 1);
            let mut t = Vec::with_capacity(unit.rows.len() + 1);
            let (mut pv_sum, mut t_sum) = (0, 0);
            pv.push(0);
            t.push(0);
            for (row, values) in unit.rows.iter().enumerate() {
                let index = table_index(run.mode, row);
                let skip_zeros = run.mode != RunMode::Fifo && fresh(row);
                if !(skip_zeros && values.position_counts == 0) {
                    pv_sum += instruction_bytes(
                        Instruction::PvtPosition {
                            row: index,
                            position_counts: Some(values.position_counts),
                        },
                        &mut scratch,
                    );
                }
                if !(skip_zeros && values.velocity_counts_s == 0) {
                    pv_sum += instruction_bytes(
                        Instruction::PvtVelocity {
                            row: index,
                            velocity_counts_s: Some(values.velocity_counts_s),
                        },
                        &mut scratch,
                    );
                }
                t_sum += instruction_bytes(
                    Instruction::PvtTime {
                        row: index,
                        duration_ms: Some(values.duration_ms),
                    },
                    &mut scratch,
                );
                pv.push(pv_sum);
                t.push(t_sum);
            }
            position_velocity.push(pv);
            time.push(t);
            select.push(instruction_bytes(
                Instruction::Select {
                    station: unit.address.station,
                },
                &mut scratch,
            ));
        }
        let shortest = units.iter().map(|unit| unit.rows.len()).min().unwrap_or(0);
        let mut identical = Vec::with_capacity(shortest + 1);
        let mut shared_durations = Vec::with_capacity(shortest + 1);
        let (mut same_rows, mut same_durations) = (0, 0);
        identical.push(0);
        shared_durations.push(0);
        for row in 0..shortest {
            if units
                .windows(2)
                .all(|pair| pair[0].rows[row] == pair[1].rows[row])
            {
                same_rows += 1;
            }
            if units
                .windows(2)
                .all(|pair| pair[0].rows[row].duration_ms == pair[1].rows[row].duration_ms)
            {
                same_durations += 1;
            }
            identical.push(same_rows);
            shared_durations.push(same_durations);
        }
        Self {
            position_velocity,
            time,
            select,
            broadcast: instruction_bytes(Instruction::Select { station: 0 }, &mut scratch),
            identical,
            shared_durations,
            shortest,
        }
    }

    /// `rows(plan, run, from, to).len()`, for `from ≤ to`.
    pub fn len(&self, from: usize, to: usize) -> usize {
        if self.select.is_empty() || from > to {
            return 0;
        }
        let everyone_has_all = self.shortest >= to;
        let all = |counts: &[usize]| everyone_has_all && counts[to] - counts[from] == to - from;
        let span = |sums: &[usize], end: usize| sums[end] - sums[from];
        if all(&self.identical) {
            return self.broadcast + span(&self.position_velocity[0], to) + span(&self.time[0], to);
        }
        let shared_durations = all(&self.shared_durations);
        let mut bytes = 0;
        for (unit, select) in self.select.iter().enumerate() {
            let end = to.min(self.time[unit].len() - 1);
            if from >= end {
                continue;
            }
            bytes += select + span(&self.position_velocity[unit], end);
            if !shared_durations {
                bytes += span(&self.time[unit], end);
            }
        }
        if shared_durations {
            bytes += self.broadcast + span(&self.time[0], to);
        }
        bytes
    }
}

/// The bytes the naive form `*N;QP[X]=…;QV[X]=…;QT[X]=…;` needs for every row of every
/// unit of `run`: the yardstick the stream is measured against.
pub fn naive_bytes(plan: &Plan, run: &GatewayRun) -> usize {
    let mut total = 0;
    for &unit in &run.units {
        let unit = &plan.units[unit];
        for (row, values) in unit.rows.iter().enumerate() {
            let index = table_index(run.mode, row);
            let instructions = [
                Instruction::Select {
                    station: unit.address.station,
                },
                Instruction::PvtPosition {
                    row: index,
                    position_counts: Some(values.position_counts),
                },
                Instruction::PvtVelocity {
                    row: index,
                    velocity_counts_s: Some(values.velocity_counts_s),
                },
                Instruction::PvtTime {
                    row: index,
                    duration_ms: Some(values.duration_ms),
                },
            ];
            total += instructions
                .iter()
                .map(|instruction| instruction.encoded_len(Form::Standard))
                .sum::<usize>();
        }
    }
    total
}

#[cfg(test)]
mod tests {
    #[cfg(target_arch = "wasm32")]
    use wasm_bindgen_test::wasm_bindgen_test as test;

    use super::*;
    use crate::uim2503::ascii::parse_script;
    use crate::uim2503::plan::tests::{installation, wave};
    use crate::uim2503::plan::{Plan, PlanOptions};

    fn text(batch: &Batch) -> String {
        String::from_utf8(batch.as_bytes().to_vec()).unwrap()
    }

    #[test]
    fn row_bytes_are_the_length_of_the_rows_for_every_range() {
        // A wave (durations shared), the same rows on every unit (one broadcast),
        // tracks of different lengths and durations, in FIFO, single and loop mode.
        let mut still = wave(1, 3, 30, 100);
        still.name = "still".into();
        for track in &mut still.tracks {
            track.start_mm = 0.0;
            for row in &mut track.rows {
                row.position_mm = 0.0;
                row.velocity_mm_s = 0.0;
            }
        }
        let cases = [
            (wave(1, 3, 300, 250), PlanOptions::default()),
            (wave(1, 3, 40, 250), PlanOptions::default()),
            (
                wave(1, 3, 40, 250),
                PlanOptions {
                    repeat_forever: true,
                },
            ),
            (wave(1, 3, 40, 100), PlanOptions::default()),
            (still, PlanOptions::default()),
        ];
        for (case, (show, options)) in cases.into_iter().enumerate() {
            let mut plan = Plan::new(&show, &installation(1, 3, 115_200), options).unwrap();
            if case == 3 {
                // Tracks of different lengths and durations (as the planner never
                // makes them, but `rows` takes them).
                plan.units[1].rows.truncate(25);
                for (index, row) in plan.units[2].rows.iter_mut().enumerate() {
                    row.duration_ms = 100 + (index % 3) as u8 * 10;
                }
            }
            let run = &plan.gateways[0];
            let measured = RowBytes::new(&plan, run);
            let longest = super::super::schedule::longest(&plan, run);
            for from in 0..longest {
                for to in from..=longest.min(from + 40) {
                    assert_eq!(
                        measured.len(from, to),
                        rows(&plan, run, from, to).len(),
                        "{} {:?} rows {from}..{to}",
                        show.name,
                        run.mode
                    );
                }
            }
        }
    }

    #[test]
    fn rows_select_each_station_once_and_share_durations() {
        let show = wave(1, 2, 300, 250);
        let plan = Plan::new(&show, &installation(1, 2, 115_200), PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        let batch = rows(&plan, run, 0, 2);
        let text = text(&batch);
        let first = &plan.units[0].rows;
        let second = &plan.units[1].rows;
        let expected = format!(
            "*1;QP[0]{};QV[0]{};QP[1]{};QV[1]{};*2;QP[0]{};QV[0]{};QP[1]{};QV[1]{};*0;QT[0]250;QT[1]250;",
            first[0].position_counts,
            first[0].velocity_counts_s,
            first[1].position_counts,
            first[1].velocity_counts_s,
            second[0].position_counts,
            second[0].velocity_counts_s,
            second[1].position_counts,
            second[1].velocity_counts_s,
        );
        assert_eq!(text, expected);
        // And it is valid instruction text.
        assert_eq!(
            parse_script(&text).unwrap().len(),
            batch.instruction_count()
        );
    }

    #[test]
    fn identical_rows_are_broadcast() {
        let mut show = wave(1, 3, 20, 200);
        let same = show.tracks[0].clone();
        for track in &mut show.tracks {
            *track = same.clone();
        }
        let plan = Plan::new(&show, &installation(1, 3, 115_200), PlanOptions::default()).unwrap();
        let batch = rows(&plan, &plan.gateways[0], 0, 1);
        let row = plan.units[0].rows[0];
        assert_eq!(
            text(&batch),
            format!(
                "*0;QP[0]{};QV[0]{};QT[0]200;",
                row.position_counts, row.velocity_counts_s
            )
        );
    }

    #[test]
    fn fifo_rows_wrap_the_table() {
        let show = wave(1, 2, 600, 200);
        let plan = Plan::new(&show, &installation(1, 2, 115_200), PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        assert_eq!(run.mode, RunMode::Fifo);
        let text = text(&rows(&plan, run, 255, 257));
        assert!(text.contains("QP[255]") && text.contains("QP[0]"), "{text}");
        assert!(text.ends_with("QT[255]200;QT[0]200;"), "{text}");
    }

    #[test]
    fn configure_and_approach_read_as_the_manual_writes_them() {
        let show = wave(1, 2, 20, 200);
        let plan = Plan::new(&show, &installation(1, 2, 115_200), PlanOptions::default()).unwrap();
        let run = &plan.gateways[0];
        assert_eq!(
            text(&configure(&plan, run)),
            "*0;MO1;MP[3]1;MP[0]1;SD4000000;MP[1]0;MP[2]19;"
        );
        let approach = text(&approach_start(&plan, run));
        assert_eq!(
            approach,
            format!(
                "*0;MO1;SP30000;*1;PA{};*2;PA{};*0;BG;",
                plan.units[0].start_counts, plan.units[1].start_counts
            )
        );
        assert_eq!(text(&home(&plan, run)), "*0;MO1;SP30000;PA0;BG;");
        assert_eq!(text(&arm()), "*0;PV0;");
        assert_eq!(text(&begin()), "*0;BG;");
    }

    #[test]
    fn a_wave_of_100_units_needs_at_most_three_quarters_of_the_naive_bytes() {
        let show = wave(10, 10, 600, 250);
        let plan = Plan::new(
            &show,
            &installation(10, 10, 115_200),
            PlanOptions::default(),
        )
        .unwrap();
        let run = &plan.gateways[0];
        let mut ours = 0;
        let mut row = 0;
        while row < 600 {
            ours += rows(&plan, run, row, (row + 16).min(600)).len();
            row += 16;
        }
        let naive = naive_bytes(&plan, run);
        let ratio = ours as f64 / naive as f64;
        assert!(ratio <= 0.75, "{ours} bytes vs {naive} naive: {ratio:.3}");
    }
}
