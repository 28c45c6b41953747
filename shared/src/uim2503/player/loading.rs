//! The loading phase: configure every gateway's units for the run, preload their rows
//! in rounds as the line drains, arm them with `PV=0`, and confirm with a `PV;` query
//! whose answer comes after everything before it was carried out (the barrier).

use super::{Command, LinkView, Phase, REFILL_LOW_BYTES, Step, Uim2503Drive};
use crate::uim2503::plan::RunMode;
use crate::uim2503::schedule::ROUND_ROWS;
use crate::uim2503::stream;

impl Uim2503Drive {
    /// Loads the current entry's plan (what arming loaded of it, if it was armed).
    pub(super) fn begin_loading(&mut self) {
        if self.begin_load_armed() {
            self.poll_loading(&[]);
            return;
        }
        let Some(plan) = self.plan.as_ref() else {
            return;
        };
        let runs = plan.gateways.len();
        let reuse = self.loaded_entry == Some(self.entry)
            && plan.gateways.iter().all(|run| run.mode == RunMode::Single);
        let total_rows: usize = plan
            .gateways
            .iter()
            .map(|run| run.preload_rows * run.units.len())
            .sum();
        let next_row = if reuse {
            plan.gateways.iter().map(|run| run.preload_rows).collect()
        } else {
            vec![0; runs]
        };
        self.step = Step::Loading {
            next_row,
            configured: reuse,
            armed: false,
            confirmed: vec![false; runs],
            total_rows,
            loaded_rows: if reuse { total_rows } else { 0 },
        };
        self.poll_loading(&[]);
    }

    pub(super) fn poll_loading(&mut self, links: &[LinkView]) {
        let Some(plan) = self.plan.as_ref() else {
            return;
        };
        let Step::Loading {
            next_row,
            configured,
            armed,
            total_rows,
            loaded_rows,
            ..
        } = &mut self.step
        else {
            return;
        };
        let mut commands = Vec::new();
        if !*configured {
            for run in &plan.gateways {
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::configure(plan, run),
                });
            }
            *configured = true;
        }
        let queued = |gateway: usize| {
            links
                .get(gateway)
                .map_or(usize::MAX, |link| link.queued_bytes)
        };
        for (index, run) in plan.gateways.iter().enumerate() {
            let next = &mut next_row[index];
            if *next < run.preload_rows && queued(run.gateway) <= REFILL_LOW_BYTES {
                let to = (*next + ROUND_ROWS).min(run.preload_rows);
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::rows(plan, run, *next, to),
                });
                *loaded_rows += (to - *next) * run.units.len();
                *next = to;
            }
        }
        let all_loaded = plan
            .gateways
            .iter()
            .zip(next_row.iter())
            .all(|(run, &next)| next >= run.preload_rows);
        if all_loaded && !*armed {
            for run in &plan.gateways {
                if let Some(&first) = run.units.first() {
                    commands.push(Command::Bulk {
                        gateway: run.gateway,
                        batch: stream::arm_and_confirm(plan.units[first].address.station),
                    });
                }
            }
            *armed = true;
        }
        self.progress = if *total_rows == 0 {
            1.0
        } else {
            *loaded_rows as f64 / *total_rows as f64
        };
        self.commands.extend(commands);
    }

    /// The answer to the `PV;` barrier of `gateway`'s first unit: the load is over
    /// when every gateway answered as expected; it failed when one did not.
    pub(super) fn barrier_answered(
        &mut self,
        now_us: u64,
        gateway: usize,
        station: u8,
        value: u16,
    ) -> Phase {
        let Some(plan) = self.plan.as_ref() else {
            return Phase::Pending;
        };
        let Step::Loading {
            armed: true,
            confirmed,
            ..
        } = &mut self.step
        else {
            return Phase::Pending;
        };
        let Some(index) = plan.gateways.iter().position(|run| run.gateway == gateway) else {
            return Phase::Pending;
        };
        let run = &plan.gateways[index];
        let Some(&first) = run.units.first() else {
            return Phase::Pending;
        };
        if plan.units[first].address.station != station {
            return Phase::Pending;
        }
        let expected = match run.mode {
            // FIFO: the water level is the preload.
            RunMode::Fifo => u16::try_from(run.preload_rows).unwrap_or(u16::MAX),
            // Single and loop: the row it will start from.
            RunMode::Single | RunMode::Loop => 0,
        };
        if value != expected {
            let who = self.describe_unit(first);
            return Phase::Failed(format!(
                "{who} answered PV with {value} after loading, expected {expected}; the matrix was stopped"
            ));
        }
        confirmed[index] = true;
        if confirmed.iter().all(|&done| done) {
            self.loaded_entry = Some(self.entry);
            self.step = Step::Idle;
            return Phase::Done { at_us: now_us };
        }
        Phase::Pending
    }
}
