//! The playing phase: every gateway started at once with `*0;BG;` on its priority lane
//! at one instant ([`START_LEAD_US`] ahead),
//! streaming gateways refilled round by round by the rule of
//! [`schedule`](crate::uim2503::schedule), until the show's end (what follows it is the
//! sequencer's).

use super::{Command, LinkView, Phase, REFILL_LOW_BYTES, START_LEAD_US, Step, Uim2503Drive};
use crate::uim2503::plan::RunMode;
use crate::uim2503::{schedule, stream};

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
        self.step = Step::Playing { start_us, next_row };
        self.progress = 0.0;
    }

    /// Refills streaming gateways as their lines drain; over when the show's length
    /// (and a margin for the last ball to settle) has passed, the balls resting where
    /// their tracks end.
    pub(super) fn poll_playing(&mut self, now_us: u64, links: &[LinkView]) -> Phase {
        let Some(plan) = self.plan.as_ref() else {
            return Phase::Pending;
        };
        let Step::Playing { start_us, next_row } = &mut self.step else {
            return Phase::Pending;
        };
        let first_start = start_us.first().copied().unwrap_or(now_us);
        let elapsed_us = now_us.saturating_sub(first_start);
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
            let show_ms = now_us.saturating_sub(start_us[index]) as f64 / 1000.0;
            if schedule::round_room_at_ms(plan, run, to) > show_ms {
                continue;
            }
            let batch = stream::rows(plan, run, *next, to);
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
