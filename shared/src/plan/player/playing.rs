//! The playing phase: every gateway started at once with `*0;BG;` on its priority lane
//! at one instant ([`START_LEAD_US`] ahead),
//! streaming gateways refilled round by round by the rule of
//! [`schedule`](crate::plan::schedule), and, when a show ends, the next cycle, the
//! next entry, or the end of the playlist (or its start again, looping).

use super::{Command, LinkView, NextRun, Player, REFILL_LOW_BYTES, START_LEAD_US, Step, next_run};
use crate::plan::{RunMode, schedule, stream};

/// Time after the last row for the last ball to settle, µs.
const END_MARGIN_US: u64 = 200_000;

impl Player {
    pub(super) fn begin_entry(&mut self, now_us: u64, entry: usize) {
        self.entry = entry;
        self.cycle = 1;
        self.show_time_ms = 0;
        let delay_ms = self.entries.get(entry).map_or(0, |entry| entry.delay_ms);
        if delay_ms > 0 {
            self.step = Step::Waiting {
                until_us: now_us + delay_ms * 1000,
            };
        } else {
            self.begin_approach(now_us);
        }
    }

    pub(super) fn cycle_done(&mut self, now_us: u64) {
        let Some(plan) = self.plans.get(self.entry) else {
            self.step = Step::Idle;
            return;
        };
        // The balls rest where their tracks end.
        for (position, unit) in self.believed.iter_mut().zip(&plan.units) {
            *position = Some(
                unit.rows
                    .last()
                    .map_or(unit.start_counts, |row| row.position_counts),
            );
        }
        match next_run(
            &self.entries,
            self.entry,
            &mut self.cycle,
            self.loop_playlist,
        ) {
            NextRun::Cycle => self.begin_approach(now_us),
            NextRun::Entry(entry) => self.begin_entry(now_us, entry),
            NextRun::Rest => {
                self.step = Step::Idle;
                self.progress = 1.0;
            }
        }
    }

    pub(super) fn begin_play(&mut self, now_us: u64) {
        let Some(plan) = self.plans.get(self.entry) else {
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
        self.show_time_ms = 0;
        self.progress = 0.0;
    }

    pub(super) fn poll_playing(&mut self, now_us: u64, links: &[LinkView]) {
        let Some(plan) = self.plans.get(self.entry) else {
            return;
        };
        let Step::Playing { start_us, next_row } = &mut self.step else {
            return;
        };
        let first_start = start_us.first().copied().unwrap_or(now_us);
        let elapsed_us = now_us.saturating_sub(first_start);
        let looping = plan.gateways.iter().all(|run| run.mode == RunMode::Loop);
        let duration_us = plan.duration_ms * 1000;
        self.show_time_ms = if looping && duration_us > 0 {
            (elapsed_us % duration_us) / 1000
        } else {
            (elapsed_us / 1000).min(plan.duration_ms)
        };
        self.progress = if plan.duration_ms == 0 {
            1.0
        } else {
            self.show_time_ms as f64 / plan.duration_ms as f64
        };
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
            self.cycle_done(now_us);
        }
    }
}
