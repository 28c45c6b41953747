//! The playlist as every family plays it: an [`Entry`] (a show, its delay and
//! cycles), its [`EntryTiming`], what follows a cycle ([`next_run`]), where the
//! playlist stands for the status ([`PlaylistProgress`]), and what admission knows of
//! a link ([`LinkView`]).

use crate::api::{PlayerState, Status};
use crate::show::Show;

/// Where a player is in its playlist, as the status shows it: the one place both
/// players (this one and [`super::mbox::MboxPlayer`]) turn it into a [`Status`].
#[derive(Debug, Clone)]
pub(crate) struct PlaylistProgress {
    pub(crate) state: PlayerState,
    /// The entry being played, its show's name and duration, ms; `None` when no
    /// entry is (idle, stopped, homing to rest).
    pub(crate) playing: Option<(usize, String, u64)>,
    pub(crate) show_time_ms: u64,
    /// The show's start is given and comes in this many ms.
    pub(crate) starts_in_ms: Option<u64>,
    pub(crate) cycle: u32,
    pub(crate) progress: f64,
    pub(crate) last_error: Option<String>,
}

impl PlaylistProgress {
    /// The status (the bridge adds the gateways). Homing names no show and no time
    /// (its progress is the homing's own, not the previous show's); the show time is
    /// only counted while a show plays, so no state carries a stale one.
    pub(crate) fn status(self) -> Status {
        let homing = self.state == PlayerState::Homing;
        let current = self.playing.filter(|_| !homing);
        let playing = current.is_some();
        let counting = playing && self.state == PlayerState::Playing;
        let (entry, show, show_duration_ms) = match current {
            Some((entry, show, duration_ms)) => (Some(entry), Some(show), duration_ms),
            None => (None, None, 0),
        };
        Status {
            state: self.state,
            entry,
            show,
            show_time_ms: if counting { self.show_time_ms } else { 0 },
            show_starts_in_ms: self.starts_in_ms.filter(|_| playing),
            show_duration_ms,
            cycle: if playing { self.cycle } else { 0 },
            progress: self.progress,
            gateways: Vec::new(),
            last_error: self.last_error,
            armed: None,
            gateway_summary: crate::api::GatewaySummary::default(),
            live: None,
        }
    }
}

/// What follows a show's cycle: another cycle, the next entry, the playlist again, or
/// rest — the same for both players.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum NextRun {
    /// The same entry again (`cycle` was counted up).
    Cycle,
    /// This entry from its start.
    Entry(usize),
    /// The playlist is over.
    Rest,
}

/// What follows cycle `cycle` of entry `entry` (of `entries`, each with its cycles).
pub(crate) fn next_run(
    entries: &[impl Cycles],
    entry: usize,
    cycle: &mut u32,
    loop_playlist: bool,
) -> NextRun {
    let cycles = entries.get(entry).map_or(1, |entry| entry.cycles().max(1));
    if *cycle < cycles {
        *cycle += 1;
        NextRun::Cycle
    } else if entry + 1 < entries.len() {
        NextRun::Entry(entry + 1)
    } else if loop_playlist {
        NextRun::Entry(0)
    } else {
        NextRun::Rest
    }
}

/// One playlist entry, with its show.
#[derive(Debug, Clone)]
pub struct Entry {
    /// The show.
    pub show: Show,
    /// Wait before the entry, ms.
    pub delay_ms: u64,
    /// Plays in a row (at least 1).
    pub cycles: u32,
}

/// When and how often an entry plays: what the player keeps of an [`Entry`] once its
/// show is planned (the plan has the rows; the show's tracks are not kept).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EntryTiming {
    /// Wait before the entry, ms.
    pub delay_ms: u64,
    /// Plays in a row (at least 1).
    pub cycles: u32,
}

impl Entry {
    /// When and how often it plays.
    #[must_use]
    pub fn timing(&self) -> EntryTiming {
        EntryTiming {
            delay_ms: self.delay_ms,
            cycles: self.cycles,
        }
    }
}

/// An entry's cycles, for [`next_run`]: both players' entries have them.
pub(crate) trait Cycles {
    /// Plays in a row.
    fn cycles(&self) -> u32;
}

impl Cycles for Entry {
    fn cycles(&self) -> u32 {
        self.cycles
    }
}

impl Cycles for EntryTiming {
    fn cycles(&self) -> u32 {
        self.cycles
    }
}

/// What the player knows of a link when it is polled.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkView {
    /// The link is up.
    pub up: bool,
    /// Bytes waiting on its bulk lane.
    pub queued_bytes: usize,
}
