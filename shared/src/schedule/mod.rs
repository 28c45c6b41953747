//! The weekly schedule (issue 37, item 2; `docs/show-control.md`, "Schedule"): per
//! weekday, opening windows in the installation's local time and what plays in them —
//! the playlist over and over ([`Program::Loop`]) or once every N minutes
//! ([`Program::Every`]) — plus dated exceptions (a closed day, or other windows for
//! that date). Sans-IO, shared by the bridge (which keeps and runs it) and the app
//! (which edits it): no clock and no time zone database here. The bridge turns its
//! clock into the installation's local date and time ([`LocalDateTime`]) and asks
//! [`decide`] what to do now.
//!
//! **Windows.** A window runs from `start` to `end` of one day, `end` after `start`;
//! `24:00` is the end of the day. A window never crosses midnight: a night opening
//! is written as two windows, `22:00–24:00` and the next day's `00:00–02:00`. Windows
//! that touch (one ends when the next begins, at midnight too) with the same program
//! are one window to [`decide`]: the show plays on through the join. Windows of a day
//! must not overlap ([`problems`]).
//!
//! **Local time.** Everything is in wall-clock time: a window from 10:00 to 22:00 is
//! that on the day the clocks change too (the day is then an hour shorter or longer).
//! A window that starts in the hour skipped in spring starts when the clock jumps
//! past its start (or never, when it also ends in that hour); in the hour repeated
//! in autumn nothing starts twice: an occasion already started is not started again
//! when the clock goes back ([`Memory::started`]).
//!
//! **The decision** ([`decide`]): given the schedule, the local time now and what the
//! scheduler did last ([`Memory`]), it says whether to start the playlist, to end the
//! window the scheduler opened (home, motors off), or nothing — and when the next
//! start is and when to look again. A scheduler that knows nothing (just started,
//! after a restart) and finds itself inside a window starts its program: a restart
//! resumes the window. Every N minutes counts its slots from the window's start; a
//! slot not started at its time (the matrix was busy, a link down) is tried again
//! until the next slot begins.

pub mod time;

use std::fmt;

use serde::{Deserialize, Serialize};

pub use time::{Date, LocalDateTime, TimeOfDay, Weekday};

use crate::codes::{Code, Coded, Params};
use crate::params;

/// Fewest minutes between two starts of an every-N program.
pub const MIN_EVERY_MINUTES: u32 = 1;
/// Most minutes between two starts of an every-N program (a day).
pub const MAX_EVERY_MINUTES: u32 = 24 * 60;
/// Most windows a day (or an exception) may have.
pub const MAX_WINDOWS_PER_DAY: usize = 48;
/// Most dated exceptions.
pub const MAX_EXCEPTIONS: usize = 400;
/// How far back [`decide`] looks for the start of the window it is in, days: windows
/// that touch day after day for longer are one window started this long ago.
pub const LOOK_BACK_DAYS: i64 = 8;
/// How far ahead [`decide`] looks for the next start, days.
pub const LOOK_AHEAD_DAYS: i64 = 400;

/// What plays in a window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Program {
    /// The playlist from its first entry, over and over until the window ends.
    Loop,
    /// The playlist once (not looping) at the window's start and every `minutes`
    /// after, while the window lasts.
    Every {
        /// Minutes from one start to the next, [`MIN_EVERY_MINUTES`]–[`MAX_EVERY_MINUTES`].
        minutes: u32,
    },
}

/// One opening window of a day.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Window {
    /// When it opens, `HH:MM`.
    pub start: TimeOfDay,
    /// When it closes, `HH:MM`, after `start` (`24:00`: at midnight).
    pub end: TimeOfDay,
    /// What plays.
    pub program: Program,
}

/// The windows of each day of the week.
#[derive(Debug, Clone, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(default)]
#[allow(missing_docs)]
pub struct Week {
    pub monday: Vec<Window>,
    pub tuesday: Vec<Window>,
    pub wednesday: Vec<Window>,
    pub thursday: Vec<Window>,
    pub friday: Vec<Window>,
    pub saturday: Vec<Window>,
    pub sunday: Vec<Window>,
}

impl Week {
    /// The windows of `day`.
    #[must_use]
    pub fn day(&self, day: Weekday) -> &[Window] {
        match day {
            Weekday::Monday => &self.monday,
            Weekday::Tuesday => &self.tuesday,
            Weekday::Wednesday => &self.wednesday,
            Weekday::Thursday => &self.thursday,
            Weekday::Friday => &self.friday,
            Weekday::Saturday => &self.saturday,
            Weekday::Sunday => &self.sunday,
        }
    }

    /// The windows of `day`, to edit.
    pub fn day_mut(&mut self, day: Weekday) -> &mut Vec<Window> {
        match day {
            Weekday::Monday => &mut self.monday,
            Weekday::Tuesday => &mut self.tuesday,
            Weekday::Wednesday => &mut self.wednesday,
            Weekday::Thursday => &mut self.thursday,
            Weekday::Friday => &mut self.friday,
            Weekday::Saturday => &mut self.saturday,
            Weekday::Sunday => &mut self.sunday,
        }
    }
}

/// A date whose windows are not its weekday's: closed (no windows), or a special day.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Exception {
    /// The date, `YYYY-MM-DD`.
    pub date: Date,
    /// Its windows instead of the weekday's; none: closed all day.
    #[serde(default)]
    pub windows: Vec<Window>,
    /// A note for people (a holiday's name).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// The weekly schedule (`<data-dir>/schedule.json`, `GET`/`PUT /api/schedule`).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Schedule {
    /// Whether the bridge follows it (off: nothing starts or ends by the clock).
    #[serde(default)]
    pub enabled: bool,
    /// The installation's time zone, an IANA name (`Europe/Zurich`, `Asia/Shanghai`,
    /// `UTC`): the windows are in its local time.
    pub time_zone: String,
    /// The windows of each weekday.
    #[serde(default)]
    pub week: Week,
    /// Dates that differ from their weekday.
    #[serde(default)]
    pub exceptions: Vec<Exception>,
}

impl Default for Schedule {
    fn default() -> Self {
        Self {
            enabled: false,
            time_zone: "UTC".to_owned(),
            week: Week::default(),
            exceptions: Vec::new(),
        }
    }
}

impl Schedule {
    /// The windows of `date`: its exception's, else its weekday's.
    #[must_use]
    pub fn windows_on(&self, date: Date) -> &[Window] {
        self.exceptions
            .iter()
            .find(|exception| exception.date == date)
            .map_or_else(
                || self.week.day(date.weekday()),
                |exception| &exception.windows,
            )
    }
}

/// Where in the schedule a problem is: a weekday, or an exception's date.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Day {
    /// A weekday's windows.
    Weekday(Weekday),
    /// The exception of a date.
    Date(Date),
}

impl fmt::Display for Day {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Weekday(day) => f.write_str(day.as_str()),
            Self::Date(date) => date.fmt(f),
        }
    }
}

/// One problem of a schedule; its `Display` is the English sentence, windows numbered
/// from 1 in the order given.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ScheduleProblem {
    /// The time zone is not one the bridge knows.
    UnknownTimeZone {
        /// The name given.
        zone: String,
    },
    /// A window whose end is not after its start.
    EndNotAfterStart {
        /// Its day.
        day: Day,
        /// Its number, from 1.
        window: usize,
        /// Its start.
        start: TimeOfDay,
        /// Its end.
        end: TimeOfDay,
    },
    /// Two windows of a day overlap.
    Overlap {
        /// Their day.
        day: Day,
        /// The first window's number, from 1.
        first: usize,
        /// The second's.
        second: usize,
    },
    /// An every-N program whose N is out of range.
    EveryOutOfRange {
        /// Its day.
        day: Day,
        /// Its window's number, from 1.
        window: usize,
        /// The minutes given.
        minutes: u32,
    },
    /// More than [`MAX_WINDOWS_PER_DAY`] windows on a day.
    TooManyWindows {
        /// The day.
        day: Day,
        /// Windows given.
        windows: usize,
    },
    /// More than [`MAX_EXCEPTIONS`] exceptions.
    TooManyExceptions {
        /// Exceptions given.
        exceptions: usize,
    },
    /// Two exceptions for one date.
    ExceptionTwice {
        /// The date.
        date: Date,
    },
}

impl Coded for ScheduleProblem {
    fn code(&self) -> Code {
        match self {
            Self::UnknownTimeZone { .. } => Code::ScheduleUnknownTimeZone,
            Self::EndNotAfterStart { .. } => Code::ScheduleEndNotAfterStart,
            Self::Overlap { .. } => Code::ScheduleWindowsOverlap,
            Self::EveryOutOfRange { .. } => Code::ScheduleEveryOutOfRange,
            Self::TooManyWindows { .. } => Code::ScheduleTooManyWindows,
            Self::TooManyExceptions { .. } => Code::ScheduleTooManyExceptions,
            Self::ExceptionTwice { .. } => Code::ScheduleExceptionTwice,
        }
    }

    fn params(&self) -> Params {
        match self {
            Self::UnknownTimeZone { zone } => params! {"zone" => zone},
            Self::EndNotAfterStart {
                day,
                window,
                start,
                end,
            } => params! {"day" => day, "window" => window, "start" => start, "end" => end},
            Self::Overlap { day, first, second } => {
                params! {"day" => day, "first" => first, "second" => second}
            }
            Self::EveryOutOfRange {
                day,
                window,
                minutes,
            } => params! {
                "day" => day, "window" => window, "minutes" => minutes,
                "min" => MIN_EVERY_MINUTES, "max" => MAX_EVERY_MINUTES
            },
            Self::TooManyWindows { day, windows } => {
                params! {"day" => day, "windows" => windows, "max" => MAX_WINDOWS_PER_DAY}
            }
            Self::TooManyExceptions { exceptions } => {
                params! {"exceptions" => exceptions, "max" => MAX_EXCEPTIONS}
            }
            Self::ExceptionTwice { date } => params! {"date" => date},
        }
    }
}

impl fmt::Display for ScheduleProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&crate::codes::english_text(self.code(), &self.params()))
    }
}

/// Every problem of `schedule`, in order; none when it can be stored. The time zone is
/// checked by `zone_known` (the bridge's time zone database; the app passes a check
/// that accepts any non-empty name and leaves the rest to the bridge).
#[must_use]
pub fn problems(schedule: &Schedule, zone_known: impl Fn(&str) -> bool) -> Vec<ScheduleProblem> {
    let mut found = Vec::new();
    if !zone_known(&schedule.time_zone) {
        found.push(ScheduleProblem::UnknownTimeZone {
            zone: schedule.time_zone.clone(),
        });
    }
    for day in Weekday::ALL {
        day_problems(Day::Weekday(day), schedule.week.day(day), &mut found);
    }
    if schedule.exceptions.len() > MAX_EXCEPTIONS {
        found.push(ScheduleProblem::TooManyExceptions {
            exceptions: schedule.exceptions.len(),
        });
    }
    let mut dates = std::collections::BTreeSet::new();
    for exception in &schedule.exceptions {
        if !dates.insert(exception.date) {
            found.push(ScheduleProblem::ExceptionTwice {
                date: exception.date,
            });
        }
        day_problems(Day::Date(exception.date), &exception.windows, &mut found);
    }
    found
}

fn day_problems(day: Day, windows: &[Window], found: &mut Vec<ScheduleProblem>) {
    if windows.len() > MAX_WINDOWS_PER_DAY {
        found.push(ScheduleProblem::TooManyWindows {
            day,
            windows: windows.len(),
        });
    }
    for (index, window) in windows.iter().enumerate() {
        if window.end <= window.start {
            found.push(ScheduleProblem::EndNotAfterStart {
                day,
                window: index + 1,
                start: window.start,
                end: window.end,
            });
        }
        if let Program::Every { minutes } = window.program
            && !(MIN_EVERY_MINUTES..=MAX_EVERY_MINUTES).contains(&minutes)
        {
            found.push(ScheduleProblem::EveryOutOfRange {
                day,
                window: index + 1,
                minutes,
            });
        }
    }
    for (first, a) in windows.iter().enumerate() {
        for (offset, b) in windows.iter().enumerate().skip(first + 1) {
            if a.start < b.end && b.start < a.end && a.start < a.end && b.start < b.end {
                found.push(ScheduleProblem::Overlap {
                    day,
                    first: first + 1,
                    second: offset + 1,
                });
            }
        }
    }
}

/// A window as [`decide`] sees it: touching windows with the same program joined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Span {
    /// When it opened.
    pub start: LocalDateTime,
    /// When it closes.
    pub end: LocalDateTime,
    /// What plays.
    pub program: Program,
    /// It was open already [`LOOK_BACK_DAYS`] ago: its true start is earlier.
    pub open_before: bool,
}

impl Span {
    /// Whether `time` is inside it.
    #[must_use]
    pub fn contains(&self, time: LocalDateTime) -> bool {
        (self.start <= time || self.open_before) && time < self.end
    }
}

/// The windows between the dates `from` and `to` (both included), joined where they
/// touch with the same program, in order.
#[must_use]
pub fn spans(schedule: &Schedule, from: Date, to: Date) -> Vec<Span> {
    let mut spans: Vec<Span> = Vec::new();
    let mut date = from;
    while date <= to {
        let mut windows: Vec<&Window> = schedule
            .windows_on(date)
            .iter()
            .filter(|window| window.start < window.end)
            .collect();
        windows.sort_by_key(|window| window.start);
        for window in windows {
            let start = LocalDateTime::at(date, window.start);
            let end = LocalDateTime::at(date, window.end);
            match spans.last_mut() {
                Some(last) if last.end == start && last.program == window.program => {
                    last.end = end;
                }
                // Overlapping windows (a schedule not checked): the later one starts
                // when the earlier ends.
                Some(last) if last.end > start => {
                    if end > last.end {
                        let start = last.end;
                        spans.push(Span {
                            start,
                            end,
                            program: window.program,
                            open_before: false,
                        });
                    }
                }
                _ => spans.push(Span {
                    start,
                    end,
                    program: window.program,
                    open_before: date == from && window.start == TimeOfDay::MIDNIGHT,
                }),
            }
        }
        match date.plus_days(1) {
            Some(next) => date = next,
            None => break,
        }
    }
    spans
}

/// One start the schedule asks for: a window's (loop) or a slot of it (every N).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Occasion {
    /// The window's start.
    pub window_start: LocalDateTime,
    /// The slot's start (the window's start for a loop).
    pub at: LocalDateTime,
}

/// What the scheduler did last, which [`decide`] needs: kept by the scheduler, empty
/// when it starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Memory {
    /// The last occasion it started the playlist for.
    pub started: Option<Occasion>,
    /// The window it started something in and has not ended yet (its start).
    pub open: Option<LocalDateTime>,
    /// For a loop: the playlist it started has come to its end by itself (not
    /// stopped by an e-stop, Reset or Home): it is started again while the window
    /// lasts.
    pub run_ended: bool,
}

/// What to do now.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Action {
    /// Nothing.
    Nothing,
    /// Start the playlist for `occasion` (looping for a [`Program::Loop`]); `again`
    /// when the loop's playlist ended by itself and starts over.
    Start {
        /// The occasion.
        occasion: Occasion,
        /// What plays.
        program: Program,
        /// A loop starting over.
        again: bool,
    },
    /// The window the scheduler opened (its start) is over: home, motors off.
    End {
        /// The window's start.
        window_start: LocalDateTime,
    },
}

/// [`decide`]'s answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decision {
    /// What to do now.
    pub action: Action,
    /// The window `now` is in, if any.
    pub window: Option<Span>,
    /// The next start after `now` (a window's or a slot's), if any within
    /// [`LOOK_AHEAD_DAYS`].
    pub next_start: Option<LocalDateTime>,
    /// When to decide again at the latest (the next start, or the window's end).
    pub wake_at: Option<LocalDateTime>,
}

/// What to do at local time `now`, given `schedule` and what was done last (`memory`):
/// start the playlist, end the window the scheduler opened, or nothing; and when the
/// next start is. A disabled schedule ends an open window and starts nothing.
#[must_use]
pub fn decide(schedule: &Schedule, now: LocalDateTime, memory: &Memory) -> Decision {
    let from = now.date.plus_days(-LOOK_BACK_DAYS).unwrap_or(now.date);
    let to = now.date.plus_days(LOOK_AHEAD_DAYS).unwrap_or(now.date);
    let spans = if schedule.enabled {
        spans(schedule, from, to)
    } else {
        Vec::new()
    };
    let current = spans.iter().find(|span| span.contains(now)).copied();
    let in_current = |time: LocalDateTime| {
        current.is_some_and(|span| (span.start <= time || span.open_before) && time < span.end)
    };
    let slot = current.map(|span| slot_at(&span, now));
    let action = match (memory.open, current) {
        (Some(open), _) if !in_current(open) => Action::End { window_start: open },
        (_, Some(span)) => {
            let at = slot.unwrap_or(span.start);
            let occasion = Occasion {
                window_start: span.start,
                at,
            };
            let started = memory
                .started
                .filter(|started| in_current(started.window_start));
            let done = match span.program {
                Program::Loop => started.is_some(),
                Program::Every { .. } => started.is_some_and(|started| started.at >= at),
            };
            if !done {
                Action::Start {
                    occasion,
                    program: span.program,
                    again: false,
                }
            } else if span.program == Program::Loop && memory.run_ended {
                Action::Start {
                    occasion: started.unwrap_or(occasion),
                    program: span.program,
                    again: true,
                }
            } else {
                Action::Nothing
            }
        }
        _ => Action::Nothing,
    };
    let next_slot = current.and_then(|span| match span.program {
        Program::Every { minutes } => {
            let next = LocalDateTime::from_local_seconds(
                slot.unwrap_or(span.start).local_seconds() + i64::from(minutes.max(1)) * 60,
            )?;
            (next < span.end).then_some(next)
        }
        Program::Loop => None,
    });
    let next_start = next_slot.or_else(|| {
        spans
            .iter()
            .find(|span| span.start > now)
            .map(|span| span.start)
    });
    let end = current
        .map(|span| span.end)
        .filter(|_| memory.open.is_some());
    let wake_at = match (next_start, end) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    Decision {
        action,
        window: current,
        next_start,
        wake_at,
    }
}

/// The start of the every-N slot of `span` that `now` is in (the window's start for a
/// loop).
fn slot_at(span: &Span, now: LocalDateTime) -> LocalDateTime {
    match span.program {
        Program::Loop => span.start,
        Program::Every { minutes } => {
            let period = i64::from(minutes.max(1)) * 60;
            let since = (now.local_seconds() - span.start.local_seconds()).max(0);
            LocalDateTime::from_local_seconds(span.start.local_seconds() + since / period * period)
                .unwrap_or(span.start)
        }
    }
}

#[cfg(test)]
mod tests;
