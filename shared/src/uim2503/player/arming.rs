//! Arming: while the matrix is idle, the first playlist entry's tables are loaded into
//! the units ahead of Start, so that Start needs only the approach.
//!
//! Arming writes what the load phase writes before the units are armed — each
//! gateway's table configuration ([`stream::configure_table`]: mode, a cleared table,
//! the sequence range or the watermark; not the motor on) and the preload rows, in
//! rounds as the line drains — and nothing else: no `MO=1`, no `PA`, no `PV=n`, no
//! `BG`, so nothing moves. The manual's own sequences write the rows before the
//! approach (`docs/uim2503.md` §3): a point-to-point move leaves the table as it is.
//!
//! Right after live mode the units still run the FIFO's last rows, and a unit
//! refuses a table mode (`MP[3]`) while it runs rows — silently, for the broadcast
//! configuration — so the tables would be loaded into a FIFO: arming then waits,
//! its progress at 0, until every unit answered where it stopped
//! ([`super::live`]'s read-back after live mode), and loads them then.
//!
//! A Start whose first plan is the armed one takes the armed tables over
//! ([`Player::start_prepared`]): its load phase goes on from where arming got (nothing
//! left when it is armed) and only arms and confirms (`PV=0`, `PV;`). Anything that
//! could change what the units hold drops the arming ([`Player::disarm`]): the e-stop,
//! Reset, Home, a lost link, and whatever the caller says (a console line, a new
//! playlist or installation, a commissioning command). Each disarm counts up
//! [`Player::disarms`], so an arming prepared before it is refused.

use std::sync::Arc;

use super::{Command, LinkView, Player, REFILL_LOW_BYTES, Uim2503Drive};
use crate::api::ArmedShow;
use crate::uim2503::plan::Plan;
use crate::uim2503::schedule::ROUND_ROWS;
use crate::uim2503::stream;

use super::prepare::Prepared;

/// The first entry's tables on their way into the units (or there).
#[derive(Debug, Clone)]
pub(super) struct Arming {
    /// The first entry's plan.
    pub(super) plan: Arc<Plan>,
    /// Per run: the next row to load.
    pub(super) next_row: Vec<usize>,
    /// The tables are configured.
    pub(super) configured: bool,
    /// Rows to load, of every unit.
    pub(super) total_rows: usize,
    /// Rows queued so far, of every unit.
    pub(super) loaded_rows: usize,
    /// Every row is queued and the lines have written them all: armed.
    complete: bool,
}

impl Arming {
    fn new(plan: Arc<Plan>) -> Self {
        let total_rows = plan
            .gateways
            .iter()
            .map(|run| run.preload_rows * run.units.len())
            .sum();
        Self {
            next_row: vec![0; plan.gateways.len()],
            plan,
            configured: false,
            total_rows,
            loaded_rows: 0,
            complete: false,
        }
    }

    fn all_loaded(&self) -> bool {
        self.plan
            .gateways
            .iter()
            .zip(&self.next_row)
            .all(|(run, &next)| next >= run.preload_rows)
    }

    /// How much has reached the lines, 0.0 to 1.0 (1.0 only once every byte is
    /// written).
    fn progress(&self) -> f64 {
        if self.complete {
            1.0
        } else if self.total_rows == 0 {
            0.0
        } else {
            (self.loaded_rows as f64 / self.total_rows as f64).min(0.99)
        }
    }
}

impl Player {
    /// Arms the first entry of `prepared` (a playlist [`prepare`](super::prepare)d as
    /// Start would prepare it): while the player stays idle, [`Player::poll`] loads its
    /// tables. Refused (returns `false`) unless the player is idle, every link is up,
    /// and no disarm came since `disarms` ([`Player::disarms`] when the caller began to
    /// prepare). Arming the same plan again keeps what is loaded.
    pub fn arm(&mut self, prepared: Prepared, disarms: u64, links: &[LinkView]) -> bool {
        if super::prepare::check_links(&self.drive().config.installation, links).is_err() {
            return false;
        }
        prepared
            .plans
            .first()
            .is_some_and(|plan| self.sequencer.arm(plan, disarms))
    }

    /// Drops the arming: the next Start loads every table again. Counts a disarm (an
    /// arming prepared before it is refused).
    pub fn disarm(&mut self) {
        self.sequencer.drive_mut().disarm_tables();
    }

    /// How many times the player was disarmed (or ran, or stopped) since it began: an
    /// arming is accepted only for the count it was prepared at.
    pub fn disarms(&self) -> u64 {
        self.sequencer.drive().disarms
    }

    /// The show being armed or armed, for the status.
    pub fn armed(&self) -> Option<ArmedShow> {
        self.sequencer.drive().armed_show()
    }
}

impl Uim2503Drive {
    /// Takes `plan` to arm, unless a disarm came since `disarms` (the sequencer
    /// calls it only while idle); arming the same plan again keeps what is loaded.
    pub(super) fn arm_plan(&mut self, plan: &Arc<Plan>, disarms: u64) -> bool {
        if disarms != self.disarms {
            return false;
        }
        if self
            .arming
            .as_ref()
            .is_none_or(|arming| !same_plan(&arming.plan, plan))
        {
            self.arming = Some(Arming::new(Arc::clone(plan)));
        }
        true
    }

    /// The show being armed or armed, for the status.
    pub(super) fn armed_show(&self) -> Option<ArmedShow> {
        let arming = self.arming.as_ref()?;
        Some(ArmedShow {
            entry: 0,
            show: arming.plan.show.clone(),
            progress: arming.progress(),
        })
    }

    /// Drops the arming; counts a disarm.
    pub(super) fn disarm_tables(&mut self) {
        self.arming = None;
        self.disarms += 1;
    }

    /// Whether tables are still on their way (the caller polls at [`super::TICK_US`]).
    pub(super) fn arming_under_way(&self) -> bool {
        self.arming.as_ref().is_some_and(|arming| !arming.complete)
    }

    /// A unit refused an instruction while the show was being armed: the arming is
    /// dropped (not counted as a disarm: the same arming is not tried again until
    /// something changes); returns what the error says.
    pub(super) fn arming_refused(
        &mut self,
        who: String,
        error: impl std::fmt::Display,
    ) -> Option<String> {
        let arming = self.arming.take()?;
        Some(format!(
            "{who} refused an instruction while \"{}\" was being loaded ahead of \
             Start: {error}; nothing moved, and Start will load it again",
            arming.plan.show
        ))
    }

    /// Loads the next rounds of the armed tables as the lines drain; a lost link drops
    /// the arming.
    pub(super) fn poll_arming(&mut self, links: &[LinkView]) {
        let Some(arming) = self.arming.as_mut() else {
            return;
        };
        let queued = |gateway: usize| {
            links
                .get(gateway)
                .filter(|link| link.up)
                .map(|link| link.queued_bytes)
        };
        if arming
            .plan
            .gateways
            .iter()
            .any(|run| queued(run.gateway).is_none())
        {
            self.disarm_tables();
            return;
        }
        if self.after_live.is_some() {
            // Live mode's last rows may still run: a unit takes no table mode while
            // it runs rows (`MP[3]` is refused, and silently after `*0;`), so the
            // table waits until every unit answered where it stopped.
            return;
        }
        // Only what was queued on an earlier turn can have been written since.
        let queued_before = arming.configured && arming.all_loaded();
        let mut commands = Vec::new();
        if !arming.configured {
            for run in &arming.plan.gateways {
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::configure_table(&arming.plan, run),
                });
            }
            arming.configured = true;
        }
        for (index, run) in arming.plan.gateways.iter().enumerate() {
            let next = &mut arming.next_row[index];
            if *next < run.preload_rows
                && queued(run.gateway).is_some_and(|bytes| bytes <= REFILL_LOW_BYTES)
            {
                let to = (*next + ROUND_ROWS).min(run.preload_rows);
                commands.push(Command::Bulk {
                    gateway: run.gateway,
                    batch: stream::rows(&arming.plan, run, *next, to),
                });
                arming.loaded_rows += (to - *next) * run.units.len();
                *next = to;
            }
        }
        arming.complete = queued_before
            && arming
                .plan
                .gateways
                .iter()
                .all(|run| queued(run.gateway) == Some(0));
        self.commands.extend(commands);
    }

    /// Takes the arming over for a Start of `self.plans`: what is loaded stays for
    /// the load phase of entry 0 (it goes on from there) if the first plan is the
    /// armed one; an arming of another plan is dropped.
    pub(super) fn take_arming_for(&mut self, first: &Arc<Plan>) {
        let arming = self.arming.take();
        self.preloaded = arming.filter(|arming| same_plan(first, &arming.plan));
        self.disarms += 1;
    }

    /// The load phase of entry 0 from what arming loaded: the rows still missing are
    /// loaded, then the units are armed and confirmed as after any load. `false` when
    /// nothing was armed for this run.
    pub(super) fn begin_load_armed(&mut self) -> bool {
        if self.entry != 0 {
            return false;
        }
        let Some(armed) = self.preloaded.take() else {
            return false;
        };
        if !self
            .plan
            .as_ref()
            .is_some_and(|plan| same_plan(plan, &armed.plan))
        {
            return false;
        }
        // The motors are on after the approach; said again, as the load phase would,
        // for balls that were at their start already (no approach was sent).
        for run in &armed.plan.gateways {
            self.commands.push(Command::Bulk {
                gateway: run.gateway,
                batch: stream::motor_on(),
            });
        }
        let runs = armed.plan.gateways.len();
        self.step = super::Step::Loading {
            next_row: armed.next_row,
            configured: armed.configured,
            armed: false,
            confirmed: vec![false; runs],
            total_rows: armed.total_rows,
            loaded_rows: armed.loaded_rows,
        };
        true
    }
}

/// Whether two plans are the same: the same one shared (the bridge hands the armed
/// playlist's plans to Start), or equal.
fn same_plan(a: &Arc<Plan>, b: &Arc<Plan>) -> bool {
    Arc::ptr_eq(a, b) || a == b
}
