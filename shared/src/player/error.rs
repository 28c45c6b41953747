//! Why a Start, Reset or Home was refused ([`StartError`]), with its code and
//! parameters: the same refusals for every drive family.

use crate::api::Problem;
use crate::codes::{Code, Coded, Params};
use crate::params;
use crate::plan::verdict::{Fix, Why};

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
    /// A start at an entry the playlist lacks.
    #[error("there is no entry {entry}: the playlist has {entries} entries")]
    NoSuchEntry {
        /// The 1-based entry asked for.
        entry: usize,
        /// How many entries the playlist has.
        entries: usize,
    },
    /// A start at a time at or after the end of the entry's show (or within its last
    /// 10 ms, where nothing can start).
    #[error("entry {entry} cannot start at {time_ms} ms: its show ends at {duration_ms} ms")]
    PastTheEnd {
        /// The 1-based entry.
        entry: usize,
        /// The time asked for, ms.
        time_ms: u64,
        /// The show's length, ms.
        duration_ms: u64,
    },
    /// A start from a time inside a show on drives that play programs stored on
    /// them (MOONS' drives with `programs = "stored"`): nothing can be cut there.
    #[error(
        "entry {entry} cannot start from a time: the drives play the programs stored on them; \
         start it from its beginning, or let the bridge upload programs"
    )]
    NoCut {
        /// The 1-based entry.
        entry: usize,
    },
    /// Live mode asked of a drive family that does not carry it (yet): nothing moved.
    #[error("live mode is not available on {family}")]
    LiveUnsupported {
        /// The family, in words ("UIM2503 units").
        family: &'static str,
    },
    /// Live mode on UIM2503 units whose line cannot carry a row for each of its units
    /// within the longest row a unit takes.
    #[error(
        "live mode: gateway {gateway}'s line needs {row_ms} ms for a row of its {units} units, \
         more than the {max_ms} ms a row may last"
    )]
    LiveLineTooSlow {
        /// The gateway.
        gateway: usize,
        /// Its units.
        units: usize,
        /// The row time its line needs, ms.
        row_ms: u64,
        /// The longest row, ms.
        max_ms: u64,
    },
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
            Self::NoSuchEntry { .. } => Code::StartNoSuchEntry,
            Self::PastTheEnd { .. } => Code::StartPastTheEnd,
            Self::NoCut { .. } => Code::StartNoCut,
            Self::LiveUnsupported { .. } => Code::LiveUnsupported,
            Self::LiveLineTooSlow { .. } => Code::LiveLineTooSlow,
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
            Self::LiveUnsupported { family } => params! {"family" => family},
            Self::LiveLineTooSlow {
                gateway,
                units,
                row_ms,
                max_ms,
            } => params! {
                "gateway" => gateway,
                "units" => units,
                "row_ms" => row_ms,
                "max_ms" => max_ms,
            },
            Self::NoCut { entry } => params! {"entry" => entry},
            Self::NoSuchEntry { entry, entries } => {
                params! {"entry" => entry, "entries" => entries}
            }
            Self::PastTheEnd {
                entry,
                time_ms,
                duration_ms,
            } => params! {"entry" => entry, "time_ms" => time_ms, "duration_ms" => duration_ms},
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
