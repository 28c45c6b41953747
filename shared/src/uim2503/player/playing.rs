//! The playing phase: every gateway started at once with `*0;BG;` on its priority lane
//! at one instant ([`START_LEAD_US`] ahead),
//! streaming gateways refilled round by round by the rule of
//! [`schedule`](crate::uim2503::schedule), until the show's end (what follows it is the
//! sequencer's). A timecode chase's clock trim stretches the rows not yet sent, at
//! most ±1 ms a row ([`crate::uim2503::stretch`]); without one the rows are as planned.

use super::{Command, LinkView, Phase, REFILL_LOW_BYTES, START_LEAD_US, Step, Uim2503Drive};
use crate::uim2503::plan::{Plan, RunMode};
use crate::uim2503::stretch::Stretch;
use crate::uim2503::{schedule, stream};

/// How long after its first trim the clocks' drift is taken from the trims, µs.
const DRIFT_AFTER_US: u64 = 2_000_000;

/// Time after the last row for the last ball to settle, µs.
const END_MARGIN_US: u64 = 200_000;

impl Uim2503Drive {
    pub(super) fn begin_playing(&mut self, now_us: u64) {
        let Some(plan) = self.plan.as_ref() else {
            return;
        };
        let mut start_us = Vec::with_capacity(plan.gateways.len());
        let mut next_row = Vec::with_capacity(plan.gateways.len());
        let begin = stream::begin();
        let at_us = now_us + START_LEAD_US;
        for run in &plan.gateways {
            start_us.push(at_us + run.line.time_us(begin.len()));
            next_row.push(run.preload_rows);
            self.commands.push(Command::Priority {
                gateway: run.gateway,
                batch: begin.clone(),
                at_us,
            });
        }
        self.believed
            .iter_mut()
            .for_each(|position| *position = None);
        self.step = Step::Playing {
            start_us,
            next_row,
            stretch: None,
            stretched_ms: 0.0,
            first_trim: None,
        };
        self.progress = 0.0;
    }

    /// A clock trim: the timecode puts the show's time 0 at `show_start_us`; the
    /// rows of streaming gateways not yet sent head for the units' start moved as
    /// far as that has since the first trim; a show whose rows are all in the tables
    /// cannot be trimmed.
    pub(super) fn trim_playing(&mut self, now_us: u64, show_start_us: i64) {
        let Some(plan) = self.plan.as_ref() else {
            return;
        };
        let Step::Playing {
            start_us,
            next_row,
            stretch,
            stretched_ms,
            first_trim,
        } = &mut self.step
        else {
            return;
        };
        let Some(&first_us) = start_us.first() else {
            return;
        };
        // Nothing sent ends after the latest row sent of any streaming gateway.
        let Some(sent_to_ms) = sent_to_ms(plan, next_row) else {
            return;
        };
        // The clocks' drift, from the first trim (after a couple of seconds).
        let (since_us, first_start_us) = *first_trim.get_or_insert((now_us, show_start_us));
        let drift = if now_us >= since_us + DRIFT_AFTER_US {
            (show_start_us as f64 - first_start_us as f64) / (now_us - since_us) as f64
        } else {
            0.0
        };
        // The target where the rows sent next begin: where the drift will have taken
        // it when they play.
        let now_ms = now_us.saturating_sub(first_us) as f64 / 1_000.0 - *stretched_ms;
        let target_ms = (show_start_us as f64 - first_start_us as f64) / 1_000.0
            + drift * (sent_to_ms - now_ms).max(0.0);
        stretch
            .get_or_insert_with(|| Stretch::new(longest_row_ms(plan)))
            .steer(sent_to_ms, target_ms, drift);
    }

    /// Refills streaming gateways as their lines drain; over when the show's length
    /// (and a margin for the last ball to settle) has passed, the balls resting where
    /// their tracks end.
    pub(super) fn poll_playing(&mut self, now_us: u64, links: &[LinkView]) -> Phase {
        let Some(plan) = self.plan.as_ref() else {
            return Phase::Pending;
        };
        let Step::Playing {
            start_us,
            next_row,
            stretch,
            stretched_ms,
            ..
        } = &mut self.step
        else {
            return Phase::Pending;
        };
        let first_start = start_us.first().copied().unwrap_or(now_us);
        if let Some(stretch) = stretch.as_ref() {
            // The units' nominal time now: the stretch reached is the one at it.
            let real_ms = now_us.saturating_sub(first_start) as f64 / 1_000.0;
            *stretched_ms = stretch.at(real_ms - *stretched_ms);
        }
        let stretched_us = (*stretched_ms * 1_000.0).round() as i64;
        let elapsed_us = now_us
            .saturating_sub(first_start)
            .saturating_add_signed(-stretched_us);
        let looping = plan.gateways.iter().all(|run| run.mode == RunMode::Loop);
        let duration_us = plan.duration_ms * 1000;
        let mut commands = Vec::new();
        for (index, run) in plan.gateways.iter().enumerate() {
            if run.mode != RunMode::Fifo {
                continue;
            }
            let next = &mut next_row[index];
            let total = schedule::longest(plan, run);
            let queued = links
                .get(run.gateway)
                .map_or(usize::MAX, |link| link.queued_bytes);
            if *next >= total || queued > REFILL_LOW_BYTES {
                continue;
            }
            let to = schedule::round_end(run, plan, *next);
            let show_ms = now_us.saturating_sub(start_us[index]) as f64 / 1000.0 - *stretched_ms;
            if schedule::round_room_at_ms(plan, run, to) > show_ms {
                continue;
            }
            let batch = stream::rows_stretched(plan, run, *next, to, stretch.as_ref());
            let landing_ms = show_ms + run.line.time_us(queued + batch.len()) as f64 / 1000.0;
            if let Some(level) = schedule::level_at(plan, run, *next, landing_ms) {
                let level = u16::try_from(level.max(0)).unwrap_or(u16::MAX);
                let lowest = &mut self.lowest_level[run.gateway];
                *lowest = Some(lowest.map_or(level, |lowest| lowest.min(level)));
            }
            commands.push(Command::Bulk {
                gateway: run.gateway,
                batch,
            });
            *next = to;
        }
        self.commands.extend(commands);
        if !looping && elapsed_us >= duration_us + END_MARGIN_US {
            // The balls rest where their tracks end.
            for (position, unit) in self.believed.iter_mut().zip(&plan.units) {
                *position = Some(
                    unit.rows
                        .last()
                        .map_or(unit.start_counts, |row| row.position_counts),
                );
            }
            self.step = Step::Idle;
            return Phase::Done { at_us: now_us };
        }
        Phase::Pending
    }
}

/// The nominal show time up to which rows of streaming gateways were sent (the latest
/// row end of any unit), ms; `None` when no gateway streams.
fn sent_to_ms(plan: &Plan, next_row: &[usize]) -> Option<f64> {
    plan.gateways
        .iter()
        .zip(next_row)
        .filter(|(run, _)| run.mode == RunMode::Fifo)
        .map(|(run, &next)| {
            run.units
                .iter()
                .map(|&unit| {
                    let unit = &plan.units[unit];
                    unit.row_start_ms
                        .get(next)
                        .copied()
                        .unwrap_or(plan.duration_ms)
                })
                .max()
                .unwrap_or(0)
        })
        .max()
        .map(|ms| ms as f64)
}

/// The longest row of `plan`'s streaming gateways, ms.
fn longest_row_ms(plan: &Plan) -> u64 {
    plan.gateways
        .iter()
        .filter(|run| run.mode == RunMode::Fifo)
        .flat_map(|run| &run.units)
        .flat_map(|&unit| &plan.units[unit].rows)
        .map(|row| u64::from(row.duration_ms))
        .max()
        .unwrap_or(u64::from(u8::MAX))
}
