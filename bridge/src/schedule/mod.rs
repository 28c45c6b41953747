//! The weekly schedule in the bridge (issue 37, item 2; `docs/show-control.md`,
//! "Schedule"): kept in `<data-dir>/schedule.json` (written atomically, like the
//! playlist), edited over `GET`/`PUT /api/schedule` ([`crate::http::schedule`]), and
//! followed by one scheduler task ([`task`]) that alone owns what it did and
//! publishes its state as a snapshot ([`Schedules::subscribe`], sent to the app as
//! `ServerMessage::Schedule`).
//!
//! The model and the decision are `floatball_shared::schedule` (local times, no zones);
//! this module turns the clock's instant into the installation's local time with the
//! system's time zone database (`jiff`, `/usr/share/zoneinfo`).
//!
//! **The clock.** The scheduler asks [`Schedules::now`]: the system's clock, or —
//! only when the bridge was started with the hidden `--test-clock` flag — the instant
//! a test set with `POST /api/test/clock`, which also wakes the scheduler at once (no
//! test waits for minutes to pass).

pub mod task;

use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use floatball_shared::api::ScheduleStatus;
use floatball_shared::schedule::{Date, LocalDateTime, Schedule};
use jiff::Timestamp;
use jiff::tz::TimeZone;
use tokio::sync::watch;

use crate::durable;

pub use task::spawn;

/// The schedule file's name inside the data directory.
pub const FILE_NAME: &str = "schedule.json";

/// The stored schedule, the scheduler's published state and its clock.
#[derive(Debug)]
pub struct Schedules {
    dir: PathBuf,
    /// The schedule now; the scheduler is woken when it changes.
    current: watch::Sender<Schedule>,
    /// The scheduler's state (its one writer is the scheduler task).
    status: watch::Sender<ScheduleStatus>,
    /// Whether `POST /api/test/clock` may set the clock (`--test-clock`).
    test_clock: AtomicBool,
    /// The instant a test set; `None`: the system's clock.
    clock: watch::Sender<Option<Timestamp>>,
}

impl Schedules {
    /// Reads `<data_dir>/schedule.json`; the default (off, UTC, no windows) when
    /// there is none.
    ///
    /// # Errors
    /// The file cannot be read or is not a schedule.
    pub fn open(data_dir: &Path) -> Result<Self, String> {
        let path = data_dir.join(FILE_NAME);
        let current = match std::fs::read_to_string(&path) {
            Ok(text) => serde_json::from_str(&text).map_err(|error| {
                format!(
                    "{}: not a schedule ({error}); fix or delete it",
                    path.display()
                )
            })?,
            Err(error) if error.kind() == io::ErrorKind::NotFound => Schedule::default(),
            Err(error) => return Err(format!("{}: {error}", path.display())),
        };
        // What the scheduler will publish first when the schedule is off, so that it
        // wakes no client then.
        let status = ScheduleStatus {
            enabled: current.enabled,
            time_zone: current.time_zone.clone(),
            ..ScheduleStatus::default()
        };
        Ok(Self {
            dir: data_dir.to_owned(),
            current: watch::channel(current).0,
            status: watch::channel(status).0,
            test_clock: AtomicBool::new(false),
            clock: watch::channel(None).0,
        })
    }

    /// The schedule.
    pub fn get(&self) -> Schedule {
        self.current.borrow().clone()
    }

    /// Stores `schedule` (already checked: [`check`]) on disk, then makes it the one
    /// the scheduler follows.
    ///
    /// # Errors
    /// An I/O error; the schedule is then as before.
    pub fn put(&self, schedule: Schedule) -> io::Result<()> {
        let text = serde_json::to_vec_pretty(&schedule).map_err(io::Error::other)?;
        durable::write_atomic(&self.dir, FILE_NAME, &text)?;
        self.current.send_replace(schedule);
        Ok(())
    }

    /// A receiver of the schedule (the scheduler's).
    pub fn subscribe_schedule(&self) -> watch::Receiver<Schedule> {
        self.current.subscribe()
    }

    /// The scheduler's state now.
    pub fn status(&self) -> ScheduleStatus {
        self.status.borrow().clone()
    }

    /// A receiver of the scheduler's state.
    pub fn subscribe(&self) -> watch::Receiver<ScheduleStatus> {
        self.status.subscribe()
    }

    /// Publishes the scheduler's state (the scheduler task only); receivers are
    /// woken only when it changed.
    pub(crate) fn publish(&self, status: ScheduleStatus) {
        self.status.send_if_modified(|old| {
            let changed = *old != status;
            *old = status;
            changed
        });
    }

    /// Lets `POST /api/test/clock` set the scheduler's clock (`--test-clock`).
    pub fn enable_test_clock(&self) {
        self.test_clock.store(true, Ordering::Release);
    }

    /// Whether the test clock may be set.
    pub fn test_clock_enabled(&self) -> bool {
        self.test_clock.load(Ordering::Acquire)
    }

    /// Sets the scheduler's clock to `now` (`None`: the system's again) and wakes the
    /// scheduler; `false` (nothing changed) unless [`Schedules::enable_test_clock`].
    pub fn set_clock(&self, now: Option<Timestamp>) -> bool {
        if !self.test_clock_enabled() {
            return false;
        }
        self.clock.send_replace(now);
        true
    }

    /// A receiver that wakes when the test clock is set.
    pub fn subscribe_clock(&self) -> watch::Receiver<Option<Timestamp>> {
        self.clock.subscribe()
    }

    /// The scheduler's clock now: the system's, or the instant a test set.
    pub fn now(&self) -> Timestamp {
        (*self.clock.borrow()).unwrap_or_else(Timestamp::now)
    }
}

/// Whether `name` is a time zone the bridge knows.
pub fn zone_known(name: &str) -> bool {
    !name.is_empty() && TimeZone::get(name).is_ok()
}

/// Checks `schedule`: its time zone known here, its windows and exceptions as
/// `floatball_shared::schedule::problems` says.
///
/// # Errors
/// Every problem.
pub fn check(schedule: &Schedule) -> Result<(), Vec<floatball_shared::schedule::ScheduleProblem>> {
    let problems = floatball_shared::schedule::problems(schedule, zone_known);
    if problems.is_empty() {
        Ok(())
    } else {
        Err(problems)
    }
}

/// The local date and time at `now` in `zone`.
pub fn local(now: Timestamp, zone: &TimeZone) -> Option<LocalDateTime> {
    let civil = now.to_zoned_datetime(zone.clone()).datetime();
    let date = Date::new(
        i32::from(civil.year()),
        u8::try_from(civil.month()).ok()?,
        u8::try_from(civil.day()).ok()?,
    )?;
    let second = u32::try_from(
        i32::from(civil.hour()) * 3600 + i32::from(civil.minute()) * 60 + i32::from(civil.second()),
    )
    .ok()?;
    Some(LocalDateTime::new(date, second))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn local_time_follows_the_zone_and_its_clock_changes() {
        let zurich = TimeZone::get("Europe/Zurich").expect("zoneinfo");
        let at = |text: &str| local(text.parse().expect("timestamp"), &zurich).expect("local");
        assert_eq!(at("2026-11-29T09:00:00Z").to_string(), "2026-11-29 10:00");
        assert_eq!(at("2026-07-01T09:00:00Z").to_string(), "2026-07-01 11:00");
        // 2026-03-29 01:00 UTC: 02:00 local becomes 03:00.
        assert_eq!(
            at("2026-03-29T00:59:59Z").to_string(),
            "2026-03-29 01:59:59"
        );
        assert_eq!(at("2026-03-29T01:00:00Z").to_string(), "2026-03-29 03:00");
        assert!(zone_known("Asia/Shanghai"));
        assert!(zone_known("UTC"));
        assert!(!zone_known("Mars/Olympus"));
        assert!(!zone_known(""));
    }

    #[test]
    fn the_schedule_survives_a_restart_and_the_test_clock_is_off_by_default() {
        let dir = tempfile::tempdir().expect("dir");
        let schedules = Schedules::open(dir.path()).expect("open");
        assert_eq!(schedules.get(), Schedule::default());
        let schedule = Schedule {
            enabled: true,
            time_zone: "Asia/Shanghai".to_owned(),
            ..Schedule::default()
        };
        schedules.put(schedule.clone()).expect("put");
        assert!(!schedules.set_clock(Some(Timestamp::UNIX_EPOCH)));
        assert_ne!(schedules.now(), Timestamp::UNIX_EPOCH);
        schedules.enable_test_clock();
        assert!(schedules.set_clock(Some(Timestamp::UNIX_EPOCH)));
        assert_eq!(schedules.now(), Timestamp::UNIX_EPOCH);
        assert_eq!(Schedules::open(dir.path()).expect("reopen").get(), schedule);
        std::fs::write(dir.path().join(FILE_NAME), "{").expect("write");
        assert!(Schedules::open(dir.path()).is_err());
    }
}
