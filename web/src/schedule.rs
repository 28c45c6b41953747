//! The Schedule page's logic as plain types (`docs/show-control.md`, "Schedule"): the
//! weekly schedule as the form edits it (times and minutes as typed), read from and
//! turned back into the shared [`Schedule`], with what cannot be read said per field
//! before anything is sent; and how the Control page words the scheduler's state.

use floatball_shared::api::ScheduleStatus;
use floatball_shared::schedule::{
    Date, Exception, MAX_EVERY_MINUTES, MIN_EVERY_MINUTES, Program, Schedule, TimeOfDay, Weekday,
    Window,
};

/// One window as typed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WindowForm {
    /// Its start, `HH:MM`.
    pub start: String,
    /// Its end, `HH:MM` (`24:00`: midnight).
    pub end: String,
    /// Every N minutes (else: the playlist over and over).
    pub every: bool,
    /// N, as typed.
    pub minutes: String,
}

impl Default for WindowForm {
    fn default() -> Self {
        Self {
            start: "10:00".to_owned(),
            end: "22:00".to_owned(),
            every: false,
            minutes: "30".to_owned(),
        }
    }
}

impl WindowForm {
    /// The form of `window`.
    pub fn of(window: &Window) -> Self {
        let (every, minutes) = match window.program {
            Program::Loop => (false, "30".to_owned()),
            Program::Every { minutes } => (true, minutes.to_string()),
        };
        Self {
            start: window.start.to_string(),
            end: window.end.to_string(),
            every,
            minutes,
        }
    }

    fn read(&self) -> Result<Window, FormError> {
        let time = |text: &str| TimeOfDay::parse(text.trim()).ok_or(FormError::Time);
        let program = if self.every {
            let minutes = self
                .minutes
                .trim()
                .parse::<u32>()
                .ok()
                .filter(|minutes| (MIN_EVERY_MINUTES..=MAX_EVERY_MINUTES).contains(minutes))
                .ok_or(FormError::Minutes)?;
            Program::Every { minutes }
        } else {
            Program::Loop
        };
        Ok(Window {
            start: time(&self.start)?,
            end: time(&self.end)?,
            program,
        })
    }
}

/// A dated exception as typed.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ExceptionForm {
    /// The date, `YYYY-MM-DD`.
    pub date: String,
    /// Its windows; none: closed.
    pub windows: Vec<WindowForm>,
    /// A note (a holiday's name).
    pub note: String,
}

/// The schedule as the form edits it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ScheduleForm {
    /// Whether the bridge follows it.
    pub enabled: bool,
    /// The IANA time zone name.
    pub time_zone: String,
    /// The windows of each weekday, Monday first.
    pub week: [Vec<WindowForm>; 7],
    /// The dated exceptions.
    pub exceptions: Vec<ExceptionForm>,
}

/// What in the form cannot be read (the bridge checks the rest: overlaps, the zone).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FormError {
    /// A time that is not `HH:MM` (00:00–24:00).
    Time,
    /// N that is not a whole number of minutes from 1 to 1440.
    Minutes,
    /// A date that is not `YYYY-MM-DD`.
    Date,
}

/// Where a [`FormError`] is: a weekday (`day` 0–6) or an exception (its number from
/// 1), and the window's number from 1 (`None`: the exception's date).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FormProblem {
    /// What.
    pub error: FormError,
    /// The weekday, if on one.
    pub weekday: Option<Weekday>,
    /// The exception's number from 1, if on one.
    pub exception: Option<usize>,
    /// The window's number from 1, if on one.
    pub window: Option<usize>,
}

impl ScheduleForm {
    /// The form of `schedule`.
    pub fn of(schedule: &Schedule) -> Self {
        Self {
            enabled: schedule.enabled,
            time_zone: schedule.time_zone.clone(),
            week: Weekday::ALL
                .map(|day| schedule.week.day(day).iter().map(WindowForm::of).collect()),
            exceptions: schedule
                .exceptions
                .iter()
                .map(|exception| ExceptionForm {
                    date: exception.date.to_string(),
                    windows: exception.windows.iter().map(WindowForm::of).collect(),
                    note: exception.note.clone(),
                })
                .collect(),
        }
    }

    /// The schedule to send.
    ///
    /// # Errors
    /// The first field that cannot be read.
    pub fn read(&self) -> Result<Schedule, FormProblem> {
        let mut schedule = Schedule {
            enabled: self.enabled,
            time_zone: self.time_zone.trim().to_owned(),
            ..Schedule::default()
        };
        for (day, windows) in Weekday::ALL.into_iter().zip(&self.week) {
            *schedule.week.day_mut(day) = read_windows(windows, |error, window| FormProblem {
                error,
                weekday: Some(day),
                exception: None,
                window,
            })?;
        }
        for (index, exception) in self.exceptions.iter().enumerate() {
            let at = |error, window| FormProblem {
                error,
                weekday: None,
                exception: Some(index + 1),
                window,
            };
            let date = Date::parse(exception.date.trim()).ok_or(at(FormError::Date, None))?;
            schedule.exceptions.push(Exception {
                date,
                windows: read_windows(&exception.windows, at)?,
                note: exception.note.trim().to_owned(),
            });
        }
        Ok(schedule)
    }
}

fn read_windows(
    windows: &[WindowForm],
    at: impl Fn(FormError, Option<usize>) -> FormProblem,
) -> Result<Vec<Window>, FormProblem> {
    windows
        .iter()
        .enumerate()
        .map(|(index, window)| window.read().map_err(|error| at(error, Some(index + 1))))
        .collect()
}

/// What the Control page says of the scheduler: `None` when there is nothing to say
/// (no schedule followed and nothing done).
pub fn shown(status: Option<&ScheduleStatus>) -> Option<&ScheduleStatus> {
    status.filter(|status| status.enabled || status.last.is_some())
}

#[cfg(test)]
mod tests {
    use wasm_bindgen_test::wasm_bindgen_test;

    use super::*;

    #[wasm_bindgen_test(unsupported = test)]
    fn the_form_reads_back_what_it_was_given_and_names_what_it_cannot_read() {
        let mut schedule = Schedule {
            enabled: true,
            time_zone: "Asia/Shanghai".to_owned(),
            ..Schedule::default()
        };
        schedule.week.friday = vec![Window {
            start: TimeOfDay::parse("20:00").unwrap(),
            end: TimeOfDay::END_OF_DAY,
            program: Program::Every { minutes: 15 },
        }];
        schedule.exceptions = vec![Exception {
            date: Date::parse("2026-12-25").unwrap(),
            windows: Vec::new(),
            note: "closed".to_owned(),
        }];
        let mut form = ScheduleForm::of(&schedule);
        assert_eq!(form.week[4][0].end, "24:00");
        assert_eq!(form.read(), Ok(schedule));
        form.week[4][0].minutes = "0".to_owned();
        let problem = form.read().unwrap_err();
        assert_eq!(problem.error, FormError::Minutes);
        assert_eq!(problem.weekday, Some(Weekday::Friday));
        assert_eq!(problem.window, Some(1));
        form.week[4][0].minutes = "15".to_owned();
        form.exceptions[0].date = "25.12.2026".to_owned();
        assert_eq!(form.read().unwrap_err().exception, Some(1));
        form.exceptions[0].date = "2026-12-25".to_owned();
        form.week[0].push(WindowForm {
            start: "9".to_owned(),
            ..WindowForm::default()
        });
        assert_eq!(form.read().unwrap_err().error, FormError::Time);
    }
}
