//! Planning a playlist before anything moves: every entry planned for the installation
//! and checked (valid, feasible on its lines, every gateway connected), or refused with
//! a [`StartError`] saying why.

use std::sync::Arc;

use super::{Entry, EntryTiming, LinkView};
use crate::api::Problem;
use crate::codes::{Code, Coded, Params};
use crate::params;
use crate::plan::report::line_verdict;
use crate::plan::verdict::{Fix, Why};
use crate::plan::{Installation, Plan, PlanOptions};

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

/// Why Start (or Reset) was refused. Nothing moved.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StartError {
    /// The playlist has no entries.
    #[error("the playlist is empty: add a show first")]
    Empty,
    /// A show cannot be planned (invalid, wrong layout…).
    #[error("entry {entry} (\"{show}\") cannot run: {reason}")]
    Invalid {
        /// 1-based entry number.
        entry: usize,
        /// The show's name.
        show: String,
        /// Why: the plan's refusal, or (MBOX boxes, MOONS' drives) why the show does
        /// not fit the installation.
        reason: Box<Why>,
    },
    /// A show is valid but the lines cannot carry it.
    #[error("entry {entry} (\"{show}\") cannot run: {reason}")]
    Infeasible {
        /// 1-based entry number.
        entry: usize,
        /// The show's name.
        show: String,
        /// Why, with the numbers.
        reason: Box<Why>,
        /// What would make it run.
        fixes: Vec<Fix>,
    },
    /// A gateway is not connected.
    #[error("gateway {gateway} is not connected")]
    NotConnected {
        /// The gateway.
        gateway: usize,
    },
    /// The matrix is already playing (press E-stop or Reset first).
    #[error("the matrix is already running a playlist")]
    Busy,
    /// The E-stop was pressed after this request was made: the request is void and
    /// the matrix stays stopped.
    #[error("the E-stop was pressed after this request was made; the matrix stays stopped")]
    Superseded,
}

impl Coded for StartError {
    fn code(&self) -> Code {
        match self {
            Self::Empty => Code::PlaylistEmpty,
            Self::Invalid { .. } => Code::EntryInvalid,
            Self::Infeasible { .. } => Code::EntryInfeasible,
            Self::NotConnected { .. } => Code::GatewayNotConnected,
            Self::Busy => Code::PlayerBusy,
            Self::Superseded => Code::Superseded,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::Empty | Self::Busy | Self::Superseded => Params::new(),
            Self::Invalid {
                entry,
                show,
                reason,
            } => params! {"entry" => entry, "show" => show, "reason" => reason},
            Self::Infeasible {
                entry,
                show,
                reason,
                ..
            } => params! {
                "entry" => entry,
                "show" => show,
                "reason" => reason,
                "fixes" => self.fix_sentences().join("; "),
            },
            Self::NotConnected { gateway } => params! {"gateway" => gateway},
        }
    }
}

impl StartError {
    /// The `reason` parameter as a coded problem, for the app to render in the
    /// operator's language (the parameter stays English for API clients).
    #[must_use]
    pub fn reason_problem(&self) -> Option<Problem> {
        match self {
            Self::Invalid { reason, .. } | Self::Infeasible { reason, .. } => {
                Some(Problem::of(reason.as_ref()))
            }
            _ => None,
        }
    }

    /// The `fixes` parameter as coded problems, in the same order.
    #[must_use]
    pub fn fix_problems(&self) -> Vec<Problem> {
        match self {
            Self::Infeasible { fixes, .. } => fixes.iter().map(Problem::of).collect(),
            _ => Vec::new(),
        }
    }

    /// What would make it run, in English (empty unless infeasible).
    #[must_use]
    pub fn fix_sentences(&self) -> Vec<String> {
        match self {
            Self::Infeasible { fixes, .. } => fixes.iter().map(ToString::to_string).collect(),
            _ => Vec::new(),
        }
    }
}
