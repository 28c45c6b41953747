//! The scheduler: one task, the one owner of what the schedule did
//! ([`floatball_shared::schedule::Memory`]) and of its published state.
//!
//! It wakes when the next start or the open window's end is due (at least every
//! [`MAX_SLEEP`]), when the schedule or the test clock changes, and — while a loop's
//! playlist runs — when the player's status changes; each time it asks
//! [`decide`] what to do at the local time now and does it:
//!
//! - **Start** — only through [`control::issue_unless_latched`] (refused while an
//!   e-stop is latched; it never releases one), and only when the player is idle (not
//!   in error, not playing, not loading, no Start being prepared), every link is up
//!   and no unit is missing. Otherwise it records why it did not start and tries
//!   again every [`RETRY`] while the occasion lasts. A loop's playlist that comes to
//!   its end by itself (no e-stop, Reset or Home since it started) is started again;
//!   one stopped by an operator, or a matrix an operator took live, is left alone until
//!   the window's end.
//! - **End** of a window it started something in — Home (also only through
//!   [`control::issue_unless_latched`]; never from an error, which only an operator
//!   clears), then, once every ball is home and the player idle, the motors off where
//!   the family has an instruction for it the bridge can send: UIM2503 units get
//!   `*0;MO=0;` on every link (an inert instruction the e-stop path lets through, and
//!   every later move turns the motors on again); MOONS' drives get `MD` (motor
//!   disable, inert: the e-stop path lets it through), each drive of every link in
//!   turn, and the first move of every later run (Start, Reset, Home) sends `ME`
//!   first ([`floatball_shared::scl::drive`]). MBOX boxes have no motors-off in their
//!   protocol: they keep their motors on, and the outcome says so.

use std::time::{Duration, Instant};

use floatball_shared::api::{
    LinkState, PlayerState, ScheduleOutcome, ScheduleStatus, ScheduleWindowNow, StartFrom, Status,
};
use floatball_shared::codes::{Code, Params, english_text};
use floatball_shared::params;
use floatball_shared::schedule::{
    Action, Decision, LocalDateTime, Memory, Occasion, Program, Schedule, decide,
};
use floatball_shared::scl::Command;
use floatball_shared::scl::drive::Expect;
use floatball_shared::uim2503::ascii::{Batch, Form, Instruction};
use jiff::tz::TimeZone;

use crate::config::Family;
use crate::control::{self, Control};
use crate::playlist;
use crate::ports::scl::program::DriveRef;
use crate::state::AppState;

/// The longest the scheduler sleeps without looking at the clock.
pub const MAX_SLEEP: Duration = Duration::from_secs(30);

/// How soon a start that did not happen is tried again.
pub const RETRY: Duration = Duration::from_secs(2);

/// How long a window's Home may take before the motors are left on and the outcome
/// says so.
pub const HOMED_WITHIN: Duration = Duration::from_secs(600);

/// How long the scheduler waits to see the Home begin.
const HOMING_SEEN_WITHIN: Duration = Duration::from_secs(2);

/// Starts the scheduler of `state`; it ends when the bridge stops. Must run inside the
/// async runtime.
pub fn spawn(state: AppState) {
    tokio::spawn(run(state));
}

/// A loop's playlist the scheduler started, watched for its end.
#[derive(Debug, Clone, Copy)]
struct Run {
    /// The e-stop generation it was started at: another one means someone pressed an
    /// e-stop, Reset or Home since.
    generation: u64,
    /// Whether the status has shown it running yet.
    seen_running: bool,
}

#[derive(Debug)]
struct Scheduler {
    state: AppState,
    memory: Memory,
    run: Option<Run>,
    last: Option<ScheduleOutcome>,
    /// The occasion of the last start that did not happen, and when it was tried.
    attempt: Option<(Occasion, Instant)>,
}

async fn run(state: AppState) {
    let schedules = state.schedules();
    let mut schedule_rx = schedules.subscribe_schedule();
    let mut clock_rx = schedules.subscribe_clock();
    let mut status_rx = state.subscribe_status();
    let mut stopping = state.stopping();
    let mut me = Scheduler {
        state: state.clone(),
        memory: Memory::default(),
        run: None,
        last: None,
        attempt: None,
    };
    loop {
        if *stopping.borrow_and_update() {
            return;
        }
        let schedule = schedule_rx.borrow_and_update().clone();
        clock_rx.borrow_and_update();
        let zone = TimeZone::get(&schedule.time_zone).unwrap_or(TimeZone::UTC);
        let Some(now) = super::local(schedules.now(), &zone) else {
            tracing::error!("schedule: the clock is outside the calendar");
            tokio::time::sleep(MAX_SLEEP).await;
            continue;
        };
        let status = status_rx.borrow_and_update().clone();
        me.observe(&status);
        let decision = decide(&schedule, now, &me.memory);
        let acted = match decision.action {
            Action::Start {
                occasion,
                program,
                again,
            } => {
                let tried_lately = me
                    .attempt
                    .is_some_and(|(tried, at)| tried == occasion && at.elapsed() < RETRY);
                !tried_lately && me.start(now, occasion, program, again).await
            }
            Action::End { .. } => {
                me.end(now).await;
                true
            }
            Action::Nothing => false,
        };
        if acted {
            // What it did changes what comes next: decide again at once.
            continue;
        }
        schedules.publish(me.snapshot(&schedule, &decision));
        let mut sleep = MAX_SLEEP;
        if let Some(wake_at) = decision.wake_at {
            let seconds = (wake_at.local_seconds() - now.local_seconds()).max(0);
            sleep = sleep.min(Duration::from_secs(u64::try_from(seconds).unwrap_or(0)));
        }
        if let (Some((_, at)), Action::Start { .. }) = (me.attempt, decision.action) {
            sleep = sleep.min(RETRY.saturating_sub(at.elapsed()));
        }
        let watch_status = me.run.is_some();
        tokio::select! {
            _ = stopping.changed() => return,
            _ = schedule_rx.changed() => {}
            _ = clock_rx.changed() => {}
            _ = status_rx.changed(), if watch_status => {}
            () = tokio::time::sleep(sleep) => {}
        }
    }
}

/// Why the scheduler did not start the matrix.
#[derive(Debug, Clone, PartialEq)]
enum Refusal {
    /// An e-stop is latched (an operator pressed it).
    EstopLatched,
    /// An operator has the matrix live.
    Live,
    /// Anything else: its code and parameters.
    Other(Code, Params),
}

impl Refusal {
    /// Whether an operator took the matrix over (pressed the e-stop, or took it
    /// live): it is theirs until the window's end, and a loop's playlist is not
    /// started over.
    fn taken_over(&self) -> bool {
        matches!(self, Self::EstopLatched | Self::Live)
    }

    /// The outcome recorded for it.
    fn outcome(self) -> (Code, Params) {
        match self {
            Self::EstopLatched => (Code::ScheduleEstopLatched, Params::new()),
            Self::Live => (Code::ScheduleNotIdle, params! {"state" => "live"}),
            Self::Other(code, params) => (code, params),
        }
    }
}

/// A motors-off's outcome: `failed` names where it was not sent (with why), if
/// anywhere.
fn motors_off_sent(failed: &[String]) -> Result<(), String> {
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the motors-off was not sent to {}",
            failed.join("; ")
        ))
    }
}

impl Scheduler {
    /// Follows the loop's run in `status`: running, then idle again with no e-stop
    /// since (it came to its end by itself: started again while the window lasts), or
    /// stopped by someone (left alone).
    fn observe(&mut self, status: &Status) {
        let Some(run) = &mut self.run else {
            return;
        };
        let latch = self.state.playback().latch();
        if latch.generation() != run.generation
            || matches!(status.state, PlayerState::Stopped | PlayerState::Error)
            || status.live.is_some()
        {
            // Stopped, or an operator took the matrix live: left alone.
            self.run = None;
        } else if playlist::locked(status.state) {
            run.seen_running = true;
        } else if status.state == PlayerState::Idle
            && run.seen_running
            && !self.state.starts_pending()
        {
            self.memory.run_ended = !latch.is_latched();
            self.run = None;
        }
    }

    /// Why the matrix may not be started by the schedule now, if it may not.
    fn not_ready(&self) -> Option<Refusal> {
        if self.state.playback().latch().is_latched() {
            return Some(Refusal::EstopLatched);
        }
        if self.state.starts_pending() {
            return Some(Refusal::Other(
                Code::ScheduleNotIdle,
                params! {"state" => "starting"},
            ));
        }
        let status = self.state.subscribe_status().borrow().clone();
        if status.live.is_some() {
            return Some(Refusal::Live);
        }
        match status.state {
            PlayerState::Idle => {}
            PlayerState::Error => {
                return Some(Refusal::Other(
                    Code::ScheduleInError,
                    params! {"error" => status.last_error.unwrap_or_default()},
                ));
            }
            other => {
                return Some(Refusal::Other(
                    Code::ScheduleNotIdle,
                    params! {"state" => other.as_str()},
                ));
            }
        }
        // The status's own gateways when it lists them all (it is the newest); the
        // full list (published a little behind) for a large installation.
        let summary = &status.gateway_summary;
        let gateways = if summary.complete {
            status.gateways.clone()
        } else {
            self.state.gateway_list()
        };
        if summary.up < summary.total
            && gateways.iter().all(|gateway| gateway.link == LinkState::Up)
        {
            let gateway = summary.problems.first().copied().unwrap_or_default();
            return Some(Refusal::Other(
                Code::ScheduleLinkDown,
                params! {"gateway" => gateway, "link" => "not up"},
            ));
        }
        for gateway in gateways {
            if gateway.link != LinkState::Up {
                let link = match gateway.link {
                    LinkState::Up => "up",
                    LinkState::Connecting => "connecting",
                    LinkState::Down => "down",
                    LinkState::NotAnswering => "not answering",
                };
                return Some(Refusal::Other(
                    Code::ScheduleLinkDown,
                    params! {"gateway" => gateway.index, "link" => link},
                ));
            }
            let mut missing: Vec<String> = gateway
                .health
                .iter()
                .flat_map(|health| health.missing.iter().map(ToString::to_string))
                .collect();
            missing.extend(
                gateway
                    .drives
                    .iter()
                    .filter(|drive| drive.position_counts.is_none())
                    .map(|drive| drive.address.clone()),
            );
            if !missing.is_empty() {
                return Some(Refusal::Other(
                    Code::ScheduleUnitsMissing,
                    params! {"gateway" => gateway.index, "stations" => missing.join(", ")},
                ));
            }
        }
        None
    }

    /// Starts the playlist for `occasion` if the matrix is ready; records the outcome.
    /// Returns whether it started.
    async fn start(
        &mut self,
        now: LocalDateTime,
        occasion: Occasion,
        program: Program,
        again: bool,
    ) -> bool {
        let refused = match self.not_ready() {
            Some(why) => Err(why),
            None => {
                let generation = self.state.playback().latch().generation();
                match control::issue_unless_latched(
                    &self.state,
                    Control::Start(StartFrom::default()),
                ) {
                    Err(control::NotIssued::Latched) => Err(Refusal::EstopLatched),
                    Err(control::NotIssued::Refused(refusal)) => Err(Refusal::Other(
                        Code::ScheduleStartRefused,
                        params! {"reason" => control::reason(*refusal)},
                    )),
                    Ok(starting) => match starting.await {
                        Ok(()) => Ok(generation),
                        Err(refusal) => Err(Refusal::Other(
                            Code::ScheduleStartRefused,
                            params! {"reason" => control::reason(refusal)},
                        )),
                    },
                }
            }
        };
        match refused {
            Ok(generation) => {
                self.memory.started = Some(occasion);
                self.memory.open = Some(occasion.window_start);
                self.memory.run_ended = false;
                self.attempt = None;
                self.run = (program == Program::Loop).then_some(Run {
                    generation,
                    seen_running: false,
                });
                let (code, params) = match program {
                    Program::Loop => (Code::ScheduleStartedLoop, Params::new()),
                    Program::Every { minutes } => {
                        (Code::ScheduleStartedEvery, params! {"minutes" => minutes})
                    }
                };
                if again {
                    tracing::info!("schedule: the playlist ended; started again");
                }
                self.record(now, true, code, params);
                true
            }
            Err(refusal) => {
                self.attempt = Some((occasion, Instant::now()));
                // A loop starting over is tried again while the window lasts (a link
                // that dropped between two runs) — but not once an operator pressed
                // the e-stop or took the matrix live: they have taken over until the
                // window's end.
                if refusal.taken_over() {
                    self.memory.run_ended = false;
                }
                let (code, params) = refusal.outcome();
                self.record(now, false, code, params);
                false
            }
        }
    }

    /// Ends the window the scheduler opened: Home, then the motors off; records the
    /// outcome.
    async fn end(&mut self, now: LocalDateTime) {
        self.memory.open = None;
        self.memory.run_ended = false;
        self.run = None;
        self.attempt = None;
        let (code, params) = match self.home_and_motors_off().await {
            Ok(code) => (code, Params::new()),
            Err(why) => why,
        };
        let done = matches!(code, Code::ScheduleEnded | Code::ScheduleEndedMotorsOn);
        self.record(now, done, code, params);
    }

    async fn home_and_motors_off(&self) -> Result<Code, (Code, Params)> {
        let refused = |reason: String| (Code::ScheduleEndRefused, params! {"reason" => reason});
        let mut status = self.state.subscribe_status();
        let before = status.borrow_and_update().clone();
        if before.state == PlayerState::Error {
            return Err(refused(format!(
                "the matrix is in error ({}); only an operator clears it",
                before.last_error.unwrap_or_default()
            )));
        }
        let homing =
            control::issue_unless_latched(&self.state, Control::Home).map_err(|not| match not {
                control::NotIssued::Latched => (Code::ScheduleEndLatched, Params::new()),
                control::NotIssued::Refused(refusal) => refused(control::reason(*refusal)),
            })?;
        if let Err(error) = homing.await {
            return Err(refused(control::reason(error)));
        }
        let _ = tokio::time::timeout(
            HOMING_SEEN_WITHIN,
            status.wait_for(|status| status.state == PlayerState::Homing),
        )
        .await;
        let after = tokio::time::timeout(
            HOMED_WITHIN,
            status.wait_for(|status| status.state != PlayerState::Homing),
        )
        .await
        .ok()
        .and_then(Result::ok)
        .map(|status| status.state);
        if after != Some(PlayerState::Idle) {
            return Err(refused(format!(
                "the homing ended {}",
                after.map_or("not in time", PlayerState::as_str)
            )));
        }
        match &self.state.config().family {
            Family::Uim2503 => {
                self.uim2503_motors_off().await.map_err(refused)?;
                Ok(Code::ScheduleEnded)
            }
            Family::Scl(_) => {
                self.scl_motors_off().await.map_err(refused)?;
                Ok(Code::ScheduleEnded)
            }
            Family::Mbox(_) => Ok(Code::ScheduleEndedMotorsOn),
        }
    }

    /// `MD` to every MOONS' drive on every link: each motor disabled (the next run's
    /// first move enables it again, `ME`).
    async fn scl_motors_off(&self) -> Result<(), String> {
        let playback = self.state.playback();
        let Some(net) = playback.scl() else {
            return Ok(());
        };
        let generation = playback.latch().generation();
        let mut failed = Vec::new();
        for link in net.links() {
            for drive in 0..link.drives() {
                let answer = link
                    .request(
                        drive,
                        Command::MotorDisable.to_string(),
                        Expect::One,
                        generation,
                    )
                    .await;
                let refused = match &answer {
                    Ok(lines) => lines
                        .first()
                        .is_some_and(|line| line.trim_start().starts_with('?')),
                    Err(_) => true,
                };
                if refused {
                    failed.push(format!(
                        "{}: {}",
                        net.name(DriveRef {
                            gateway: link.index(),
                            drive
                        }),
                        answer.map_or_else(|error| error.to_string(), |lines| lines.join(" "))
                    ));
                }
            }
        }
        motors_off_sent(&failed)
    }

    /// `*0;MO=0;` on every UIM2503 link: every unit's motor off.
    async fn uim2503_motors_off(&self) -> Result<(), String> {
        let batch = Batch::encode(
            &[
                Instruction::Select { station: 0 },
                Instruction::Motor { on: Some(false) },
            ],
            Form::Standard,
        )
        .map_err(|error| error.to_string())?;
        let playback = self.state.playback();
        let generation = playback.latch().generation();
        let mut failed = Vec::new();
        for (index, link) in playback.links().iter().enumerate() {
            if let Err(error) = link.send_issued(batch.clone(), generation).await {
                failed.push(format!("gateway {index}: {error}"));
            }
        }
        motors_off_sent(&failed)
    }

    /// Records an outcome (logged when it differs from the last one).
    fn record(&mut self, now: LocalDateTime, done: bool, code: Code, params: Params) {
        let message = english_text(code, &params);
        let same = self.last.as_ref().is_some_and(|last| {
            last.code == code.as_str() && last.params == params && last.done == done
        });
        if same && !done {
            // Tried again, for the same reason: the first time it was refused stands.
            return;
        }
        if done {
            tracing::info!("schedule at {now}: {message}");
        } else {
            tracing::warn!("schedule at {now}: {message}");
        }
        self.last = Some(ScheduleOutcome {
            at: now.to_string(),
            done,
            code: code.as_str().to_owned(),
            params,
            message,
        });
    }

    fn snapshot(&self, schedule: &Schedule, decision: &Decision) -> ScheduleStatus {
        ScheduleStatus {
            enabled: schedule.enabled,
            time_zone: schedule.time_zone.clone(),
            window: decision.window.map(|span| ScheduleWindowNow {
                start: span.start.to_string(),
                end: span.end.to_string(),
                program: span.program,
            }),
            next_start: decision.next_start.map(|start| start.to_string()),
            last: self.last.clone(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refusal_is_taken_over_by_its_kind_and_records_its_code() {
        assert!(Refusal::EstopLatched.taken_over());
        assert!(Refusal::Live.taken_over());
        assert_eq!(
            Refusal::Live.outcome(),
            (Code::ScheduleNotIdle, params! {"state" => "live"})
        );
        assert_eq!(
            Refusal::EstopLatched.outcome(),
            (Code::ScheduleEstopLatched, Params::new())
        );
        // A refusal naming the same state is another's (a state string decides
        // nothing).
        let other = Refusal::Other(Code::ScheduleNotIdle, params! {"state" => "live"});
        assert!(!other.taken_over());
        assert!(!Refusal::Other(Code::ScheduleInError, Params::new()).taken_over());
    }
}
