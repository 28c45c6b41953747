//! Planning a playlist before anything moves: every entry planned for the installation
//! and checked (valid, feasible on its lines, every gateway connected), or refused with
//! a [`StartError`] saying why.

use std::sync::Arc;

use super::{Entry, EntryTiming, LinkView};
use crate::plan::Installation;
use crate::plan::report::line_verdict;
use crate::plan::verdict::Why;
pub use crate::player::StartError;
use crate::uim2503::plan::{Plan, PlanOptions};

/// A playlist planned and checked, ready to start: the slow part of Start, which the
/// caller may run away from the player (it needs only the installation).
///
/// It holds each entry's plan (shared: a clone is a few pointers, so the caller may
/// keep one for the next Start while the player plays another) and each entry's
/// timing, not the shows: once planned, a show's tracks are not needed to play it (a
/// 10,000-ball minute's are 72 MB beside its plan's 60 MB).
#[derive(Debug, Clone)]
pub struct Prepared {
    pub(super) plans: Vec<Arc<Plan>>,
    pub(super) entries: Vec<EntryTiming>,
    pub(super) loop_playlist: bool,
}

impl Prepared {
    /// The plan of each entry, in order.
    #[must_use]
    pub fn plans(&self) -> &[Arc<Plan>] {
        &self.plans
    }
}

/// Plans every entry of a playlist for `installation`, refusing an invalid or
/// infeasible show (or a gateway that is not connected) before anything moves.
///
/// # Errors
/// [`StartError`] naming the entry and the reason.
pub fn prepare(
    installation: &Installation,
    entries: Vec<Entry>,
    loop_playlist: bool,
    links: &[LinkView],
) -> Result<Prepared, StartError> {
    if entries.is_empty() {
        return Err(StartError::Empty);
    }
    check_links(installation, links)?;
    let options = PlanOptions {
        repeat_forever: loop_playlist && entries.len() == 1,
    };
    let mut plans = Vec::with_capacity(entries.len());
    let mut timings = Vec::with_capacity(entries.len());
    for (index, entry) in entries.into_iter().enumerate() {
        timings.push(entry.timing());
        let name = entry.show.name.clone();
        // Taken: each track is freed as it is planned.
        let plan = Plan::from_show(entry.show, installation, options).map_err(|error| {
            StartError::Invalid {
                entry: index + 1,
                show: name.clone(),
                reason: Box::new(Why::Refused(error)),
            }
        })?;
        if let (_, Some(reason), fixes) = line_verdict(&plan, installation) {
            return Err(StartError::Infeasible {
                entry: index + 1,
                show: name,
                reason: Box::new(reason),
                fixes,
            });
        }
        plans.push(Arc::new(plan));
    }
    Ok(Prepared {
        plans,
        entries: timings,
        loop_playlist,
    })
}

pub(super) fn check_links(
    installation: &Installation,
    links: &[LinkView],
) -> Result<(), StartError> {
    for gateway in 0..installation.gateways.len() {
        if !links.get(gateway).is_some_and(|link| link.up) {
            return Err(StartError::NotConnected { gateway });
        }
    }
    Ok(())
}
