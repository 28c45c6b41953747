//! Live mode in the sequencer, family-agnostic: a drive whose moves take a fixed time
//! and which writes down every live period it is given. Every output is checked
//! against the installation's speed, acceleration and travel. The families' output is
//! tested against their twins beside them (`mbox/player_tests.rs`).

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;
use crate::api::LivePhase;
use crate::live::filter::FilterLimits;
use crate::show::Layout;

/// The default limits at a 20 ms step (7.5 m of travel, 2 m/s, 4 m/s²).
const LIMITS: FilterLimits = FilterLimits::default_at(20);
const PERIOD_US: u64 = 20_000;
const BALLS: usize = 3;
const HOME_US: u64 = 100_000;
/// Floating-point rounding only.
const EPS: f64 = 1e-6;

/// Moves take [`HOME_US`]; a show's steps as long; live periods are written down.
#[derive(Debug, Default)]
struct Recording {
    /// Refuses live mode.
    unsupported: bool,
    /// Prepares live motion for this long first.
    prepares_us: Option<u64>,
    /// Preparing live motion until then.
    prepared_at_us: Option<u64>,
    log: Vec<String>,
    ends_us: Option<u64>,
    rest_mm: Option<Vec<f64>>,
    moving: bool,
    /// Every live period: its slot and the states.
    periods: Vec<(u64, Vec<BallState>)>,
    ended: Option<(u64, Vec<BallState>)>,
}

impl Recording {
    fn begin(&mut self, now_us: u64, what: &str) {
        self.log.push(format!("{now_us} {what}"));
        self.ends_us = Some(now_us + HOME_US);
        self.moving = true;
    }
}

impl Drive for Recording {
    type Entry = &'static str;

    fn begin_run(&mut self, _now_us: u64, _first: Option<&mut &'static str>) {}

    fn begin_home(&mut self, now_us: u64) {
        self.begin(now_us, "home");
        self.rest_mm = None;
    }

    fn begin_approach(&mut self, now_us: u64, _entry: &mut &'static str) -> bool {
        self.begin(now_us, "approach");
        true
    }

    fn begin_load(&mut self, _: u64, _: usize, _: &mut &'static str, _: u32) -> bool {
        false
    }

    fn begin_play(&mut self, now_us: u64, _entry: &mut &'static str, _last: bool) {
        self.begin(now_us, "play");
    }

    fn poll(&mut self, now_us: u64, _entry: Option<&mut &'static str>) -> Phase {
        if let Some(at_us) = self.prepared_at_us {
            if now_us < at_us {
                return Phase::Pending;
            }
            self.prepared_at_us = None;
            self.log.push(format!("{at_us} prepared"));
            return Phase::Done { at_us };
        }
        match self.ends_us {
            Some(at_us) if now_us >= at_us => {
                self.ends_us = None;
                self.moving = false;
                self.rest_mm = Some(vec![0.0; BALLS]);
                Phase::Done { at_us }
            }
            _ => Phase::Pending,
        }
    }

    fn progress(&self) -> f64 {
        0.0
    }

    fn show_start_us(&self) -> Option<u64> {
        None
    }

    fn interrupt(&mut self, _now_us: u64) -> bool {
        self.log.push("interrupt".into());
        true
    }

    fn stop(&mut self) {
        self.log.push("stop".into());
        self.ends_us = None;
        self.prepared_at_us = None;
        self.moving = false;
        self.rest_mm = None;
    }

    fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        self.ends_us
            .or(self.prepared_at_us)
            .map(|at| at.max(now_us))
    }

    fn live_setup(&self) -> Result<LiveSetup, StartError> {
        if self.unsupported {
            return Err(StartError::LiveUnsupported { family: "the test" });
        }
        Ok(LiveSetup {
            limits: LIMITS,
            approach_speed_mm_s: 500.0,
            layout: Layout {
                rows: 1,
                cols: BALLS as u32,
                pitch_mm: 100.0,
            },
            latency_us: 2 * PERIOD_US,
            every_period: false,
        })
    }

    fn rest_positions_mm(&self) -> Option<Vec<f64>> {
        self.rest_mm.clone().filter(|_| !self.moving)
    }

    fn begin_live(&mut self, now_us: u64, states: &[BallState]) -> bool {
        self.log.push(format!("{now_us} live"));
        assert!(states.iter().all(|state| state.velocity_mm_s == 0.0));
        self.rest_mm = None;
        self.prepared_at_us = self.prepares_us.map(|us| now_us + us);
        self.prepared_at_us.is_some()
    }

    fn live_step(&mut self, slot_us: u64, states: &[BallState]) {
        if let Some((last, _)) = self.periods.last() {
            assert!(slot_us > *last, "slots in order");
        }
        self.periods.push((slot_us, states.to_vec()));
    }

    fn end_live(&mut self, at_us: u64, states: &[BallState]) {
        self.log.push(format!("{at_us} end"));
        self.rest_mm = Some(states.iter().map(|state| state.position_mm).collect());
        self.ended = Some((at_us, states.to_vec()));
    }
}

fn sequencer() -> Sequencer<Recording> {
    Sequencer::new(Recording::default())
}

/// Homed (Home, before 0): idle at 0 mm, positions known, the log empty.
fn homed() -> Sequencer<Recording> {
    let mut sequencer = sequencer();
    sequencer.home(0);
    sequencer.poll(HOME_US);
    assert!(sequencer.is_idle() && !sequencer.needs_home());
    sequencer.drive_mut().log.clear();
    sequencer
}

fn input(targets: &[Option<f64>], lost: bool) -> LiveInput<'_> {
    LiveInput {
        targets_mm: targets,
        lost,
        ..LiveInput::default()
    }
}

/// Polls at every wakeup until `until_us`, handing `targets(t)` before each poll;
/// returns the time reached.
fn run_live(
    sequencer: &mut Sequencer<Recording>,
    mut now_us: u64,
    until_us: u64,
    targets: &mut dyn FnMut(u64) -> (Vec<Option<f64>>, bool),
) -> u64 {
    while let Some(wake) = sequencer.next_wakeup_us(now_us) {
        if wake > until_us {
            break;
        }
        now_us = wake.max(now_us);
        let (targets, lost) = targets(now_us);
        sequencer.set_live_input(input(&targets, lost));
        sequencer.poll(now_us);
    }
    until_us.max(now_us)
}

/// Every consecutive pair of outputs keeps the limits: speed, acceleration (one
/// period's change of velocity), travel.
fn check_limits(from: &[BallState], periods: &[(u64, Vec<BallState>)]) {
    let dt = f64::from(LIMITS.dt_ms) / 1000.0;
    let mut before = from.to_vec();
    for (slot_us, states) in periods {
        for (ball, (a, b)) in before.iter().zip(states).enumerate() {
            let accel = (b.velocity_mm_s - a.velocity_mm_s) / dt;
            assert!(
                accel.abs() <= LIMITS.max_accel_mm_s2 * (1.0 + EPS),
                "ball {ball} at {slot_us} µs: acceleration {accel}"
            );
            assert!(
                b.velocity_mm_s.abs() <= LIMITS.max_speed_mm_s * (1.0 + EPS),
                "ball {ball} at {slot_us} µs: speed {}",
                b.velocity_mm_s
            );
            assert!(
                (-EPS..=LIMITS.travel_mm + EPS).contains(&b.position_mm),
                "ball {ball} at {slot_us} µs: position {}",
                b.position_mm
            );
            let moved = b.position_mm - a.position_mm;
            let fastest = a.velocity_mm_s.abs().max(b.velocity_mm_s.abs()) * dt;
            assert!(
                moved.abs() <= fastest + 1e-6,
                "ball {ball} at {slot_us} µs: {moved} mm in a period"
            );
        }
        before.clone_from(states);
    }
}

#[test]
fn live_homes_first_approaches_then_follows_a_ramp_within_the_limits() {
    let mut sequencer = sequencer();
    let first = vec![Some(1000.0), Some(500.0), None];
    sequencer.set_live_input(input(&first, false));
    sequencer.go_live(0).unwrap();
    assert_eq!(sequencer.status().state, PlayerState::Homing);
    assert_eq!(
        sequencer.status().live.map(|live| live.phase),
        Some(LivePhase::Homing)
    );
    let now = run_live(&mut sequencer, 0, HOME_US, &mut |_| (first.clone(), false));
    assert_eq!(sequencer.drive().log, ["0 home", "100000 live"]);
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Approaching);
    let live = status.live.unwrap();
    assert_eq!(live.phase, LivePhase::Approaching);
    assert_eq!((live.period_ms, live.latency_ms), (20, 40));
    assert_eq!(status.show, None, "no show plays");
    // 1000 mm at 500 mm/s and 4000 mm/s²: 2.125 s.
    let now = run_live(&mut sequencer, now, HOME_US + 2_200_000, &mut |_| {
        (first.clone(), false)
    });
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Playing);
    assert_eq!(status.live.unwrap().phase, LivePhase::Following);
    assert_eq!(
        sequencer.live_states(),
        [
            BallState::at_rest(1000.0),
            BallState::at_rest(500.0),
            BallState::at_rest(0.0)
        ]
    );
    let approach_periods = sequencer.drive().periods.len();
    // The approach's frames are at the approach speed.
    for (_, states) in &sequencer.drive().periods {
        assert!(states.iter().all(|s| s.velocity_mm_s.abs() <= 500.0 + EPS));
    }
    // A ramp at 300 mm/s from 1000 mm: followed, within the limits, at its speed.
    let ramp_from_us = now;
    let now = run_live(&mut sequencer, now, now + 3_000_000, &mut |t| {
        let mm = 1000.0 + 300.0 * (t - ramp_from_us) as f64 / 1e6;
        (vec![Some(mm), Some(500.0), None], false)
    });
    let periods = &sequencer.drive().periods;
    check_limits(
        &[BallState::at_rest(0.0); BALLS],
        &periods[..approach_periods],
    );
    check_limits(
        &periods[approach_periods - 1].1,
        &periods[approach_periods..],
    );
    let last = &periods.last().unwrap().1;
    assert!((last[0].velocity_mm_s - 300.0).abs() < 1e-6, "{last:?}");
    let expected = 1000.0 + 300.0 * (now - ramp_from_us) as f64 / 1e6;
    assert!(
        (last[0].position_mm - expected).abs() < 30.0,
        "{} behind {expected}",
        last[0].position_mm
    );
    assert_eq!(last[1], BallState::at_rest(500.0));
    // One period per slot, none missed.
    for pair in periods.windows(2) {
        assert_eq!(pair[1].0 - pair[0].0, PERIOD_US);
    }
}

/// Live at rest on the first targets (positions known: no homing), at `now`.
fn following(targets: &[Option<f64>]) -> (Sequencer<Recording>, u64) {
    let mut sequencer = homed();
    sequencer.set_live_input(input(targets, false));
    sequencer.go_live(0).unwrap();
    assert_eq!(sequencer.drive().log, ["0 live"], "no homing when known");
    let owned = targets.to_vec();
    let now = run_live(&mut sequencer, 0, 20_000_000, &mut |_| {
        (owned.clone(), false)
    });
    assert_eq!(sequencer.status().live.unwrap().phase, LivePhase::Following);
    (sequencer, now)
}

#[test]
fn a_jump_far_beyond_the_speed_limit_is_followed_within_the_limits() {
    let (mut sequencer, now) = following(&[Some(0.0), Some(7500.0), Some(3000.0)]);
    let from = sequencer.live_states().to_vec();
    let skip = sequencer.drive().periods.len();
    // Every ball jumps across the travel and back, each 50 ms: a console's snap.
    let now = run_live(&mut sequencer, now, now + 10_000_000, &mut |t| {
        let far = (t / 50_000) % 2 == 0;
        let jump = if far { 7500.0 } else { 0.0 };
        (vec![Some(jump), Some(7500.0 - jump), Some(-500.0)], false)
    });
    check_limits(&from, &sequencer.drive().periods[skip..]);
    // Then one far target: reached, at rest.
    let skip = sequencer.drive().periods.len();
    let from = sequencer.live_states().to_vec();
    run_live(&mut sequencer, now, now + 10_000_000, &mut |_| {
        (vec![Some(7000.0), Some(10.0), Some(1e9)], false)
    });
    check_limits(&from, &sequencer.drive().periods[skip..]);
    assert_eq!(
        sequencer.live_states(),
        [
            BallState::at_rest(7000.0),
            BallState::at_rest(10.0),
            BallState::at_rest(7500.0)
        ]
    );
}

#[test]
fn lost_input_holds_within_the_limits_and_the_status_says_so() {
    let (mut sequencer, now) = following(&[Some(0.0); BALLS]);
    // Full speed downwards…
    let now = run_live(&mut sequencer, now, now + 1_000_000, &mut |_| {
        (vec![Some(7500.0); BALLS], false)
    });
    let moving = sequencer.live_states()[0];
    assert_eq!(moving.velocity_mm_s, 2000.0);
    // …then the input is lost: the targets, whatever they say, no longer count.
    let skip = sequencer.drive().periods.len();
    let now = run_live(&mut sequencer, now, now + 2_000_000, &mut |_| {
        (vec![Some(0.0); BALLS], true)
    });
    let status = sequencer.status();
    let live = status.live.unwrap();
    assert_eq!(live.phase, LivePhase::Holding);
    assert!(live.input_lost);
    assert_eq!(status.state, PlayerState::Playing);
    let periods = &sequencer.drive().periods[skip..];
    check_limits(&[moving; BALLS], periods);
    // Braked at the top acceleration: 0.5 s to stop, never back up.
    let stopped = periods
        .iter()
        .position(|(_, states)| states[0].velocity_mm_s == 0.0)
        .unwrap();
    assert!(
        stopped as u64 * PERIOD_US <= 500_000 + PERIOD_US,
        "{stopped}"
    );
    let held = periods[stopped].1[0];
    assert!(periods[stopped..].iter().all(|(_, s)| s[0] == held));
    assert!(held.position_mm > moving.position_mm);
    assert!(held.position_mm - moving.position_mm <= 2000.0 * 2000.0 / 8000.0 + 2000.0 * 0.02);
    // Input back: the balls follow again.
    run_live(&mut sequencer, now, now + 10_000_000, &mut |_| {
        (vec![Some(100.0); BALLS], false)
    });
    assert_eq!(sequencer.status().live.unwrap().phase, LivePhase::Following);
    assert_eq!(sequencer.live_states()[2], BallState::at_rest(100.0));
}

#[test]
fn the_estop_leaves_live_mode_and_the_next_live_homes_first() {
    let (mut sequencer, now) = following(&[Some(2000.0); BALLS]);
    sequencer.start_recording("take").unwrap();
    sequencer.estop();
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Stopped);
    assert_eq!(status.live, None);
    assert!(!sequencer.is_live() && sequencer.needs_home());
    assert_eq!(sequencer.next_wakeup_us(now), None);
    assert_eq!(sequencer.stop_recording(), None, "the recording is dropped");
    // Input alone moves nothing and releases nothing.
    let periods = sequencer.drive().periods.len();
    sequencer.set_live_input(input(&[Some(10.0); BALLS], false));
    sequencer.poll(now + 1_000_000);
    assert_eq!(sequencer.status().state, PlayerState::Stopped);
    assert_eq!(sequencer.drive().periods.len(), periods);
    // The operator goes live again: homing first.
    sequencer.go_live(now + 1_000_000).unwrap();
    assert_eq!(sequencer.status().state, PlayerState::Homing);
    assert_eq!(
        sequencer.drive().log.last().map(String::as_str),
        Some(format!("{} home", now + 1_000_000).as_str())
    );
}

#[test]
fn live_is_refused_while_a_show_plays_and_a_show_while_live() {
    let mut sequencer = sequencer();
    let run = Run {
        name: "show".into(),
        duration_ms: 1_000,
        timing: EntryTiming {
            delay_ms: 0,
            cycles: 1,
        },
        prepared: "show",
    };
    sequencer.start(0, vec![run.clone()], false).unwrap();
    assert_eq!(sequencer.go_live(10), Err(StartError::Busy));
    assert!(!sequencer.is_live());
    sequencer.estop();
    let (mut live, now) = following(&[Some(10.0); BALLS]);
    assert_eq!(
        live.start(now, vec![run.clone()], false),
        Err(StartError::Busy)
    );
    assert_eq!(live.go_live(now), Err(StartError::Busy));
    // Nor does a timecode locate end live mode (only the operator leaves it).
    let at = StartAt {
        entry: 0,
        lead: None,
    };
    assert_eq!(
        live.locate_at(now, Ok((vec![run.clone()], at)), false),
        Err(StartError::Busy)
    );
    assert!(live.is_live() && !live.drive().log.iter().any(|line| line == "interrupt"));
    // A family without live output refuses, nothing moves.
    let mut refusing = Sequencer::new(Recording {
        unsupported: true,
        ..Recording::default()
    });
    let refused = refusing.go_live(0);
    assert_eq!(
        refused,
        Err(StartError::LiveUnsupported { family: "the test" })
    );
    assert_eq!(
        crate::codes::Coded::code(&refused.unwrap_err()),
        crate::codes::Code::LiveUnsupported
    );
    assert!(refusing.is_idle() && refusing.drive().log.is_empty());
}

#[test]
fn leaving_brakes_to_rest_then_idles_with_the_positions_known() {
    let (mut sequencer, now) = following(&[Some(0.0); BALLS]);
    let now = run_live(&mut sequencer, now, now + 1_000_000, &mut |_| {
        (vec![Some(7500.0); BALLS], false)
    });
    let moving = sequencer.live_states().to_vec();
    let skip = sequencer.drive().periods.len();
    assert!(sequencer.leave_live(now));
    assert_eq!(sequencer.status().live.unwrap().phase, LivePhase::Leaving);
    let now = run_live(&mut sequencer, now, now + 5_000_000, &mut |_| {
        (vec![Some(7500.0); BALLS], false)
    });
    check_limits(&moving, &sequencer.drive().periods[skip..]);
    assert!(sequencer.is_idle() && !sequencer.needs_home());
    assert_eq!(sequencer.status().live, None);
    let (_, rest) = sequencer.drive().ended.clone().unwrap();
    assert!(rest.iter().all(|state| state.velocity_mm_s == 0.0));
    // The last periods hold the rest.
    let periods = &sequencer.drive().periods;
    let tail = &periods[periods.len() - LIVE_SETTLE_PERIODS as usize..];
    assert!(tail.iter().all(|(_, states)| *states == rest));
    // Live again: no homing, the approach from where they rest.
    sequencer.go_live(now).unwrap();
    assert_eq!(
        sequencer.status().live.unwrap().phase,
        LivePhase::Approaching
    );
    assert!(!sequencer.leave_live(now + 1) || sequencer.is_live());
    assert!(!sequencer.drive().log.iter().any(|l| l.ends_with("home")));
}

#[test]
fn leaving_while_homing_for_live_homes_and_rests() {
    let mut sequencer = sequencer();
    sequencer.go_live(0).unwrap();
    assert!(sequencer.leave_live(10));
    assert!(!sequencer.is_live());
    run_live(&mut sequencer, 10, 1_000_000, &mut |_| (Vec::new(), false));
    assert!(sequencer.is_idle() && !sequencer.needs_home());
    assert!(sequencer.drive().periods.is_empty());
}

#[test]
fn a_recording_of_live_motion_is_a_show_within_the_limits() {
    let (mut sequencer, now) = following(&[Some(1000.0); BALLS]);
    assert_eq!(
        sequencer.start_recording("too early").err(),
        None,
        "following: recording may start"
    );
    assert!(sequencer.stop_recording().is_some());
    let mut approaching = sequencer_at_approach();
    assert_eq!(
        approaching.start_recording("x"),
        Err(RecordStartError::NotLive)
    );
    // Record moves, a snap and a loss.
    sequencer.start_recording("take 1").unwrap();
    let from_us = now;
    let now = run_live(&mut sequencer, now, now + 4_000_000, &mut |t| {
        let s = (t - from_us) as f64 / 1e6;
        let snap = if s > 2.0 { 6000.0 } else { 1000.0 + 400.0 * s };
        (vec![Some(snap), Some(3000.0), None], s > 3.5)
    });
    assert!(sequencer.status().live.unwrap().recording);
    assert!(sequencer.status().live.unwrap().recorded_ms >= 4_000);
    sequencer.leave_live(now);
    run_live(&mut sequencer, now, now + 5_000_000, &mut |_| {
        (Vec::new(), false)
    });
    let show = sequencer.stop_recording().unwrap();
    assert_eq!(show.name, "take 1");
    assert_eq!(show.tracks.len(), BALLS);
    show.check().unwrap();
    let limits = crate::show::Limits {
        travel_mm: LIMITS.travel_mm,
        max_speed_mm_s: LIMITS.max_speed_mm_s,
        max_accel_mm_s2: LIMITS.max_accel_mm_s2,
        rows: 1,
        cols: BALLS as u32,
    };
    let violations = crate::show::validate::validate(&show, &limits);
    assert!(violations.is_empty(), "{violations:?}");
    assert!(show.duration_ms() >= 4_000);
    assert_eq!(sequencer.stop_recording(), None);
}

/// Live, approaching (positions known).
fn sequencer_at_approach() -> Sequencer<Recording> {
    let mut sequencer = homed();
    sequencer.set_live_input(input(&[Some(5000.0); BALLS], false));
    sequencer.go_live(0).unwrap();
    assert_eq!(sequencer.status().state, PlayerState::Approaching);
    sequencer
}

/// Sends every ball to the bottom and polls 50 times, every 70 ms from `now_us` (a
/// late caller: the period is 20 ms); returns the last poll's time.
fn poll_late_to_the_bottom(sequencer: &mut Sequencer<Recording>, now_us: u64) -> u64 {
    sequencer.set_live_input(input(&[Some(7500.0); BALLS], false));
    let mut t = now_us;
    for _ in 0..50 {
        t += 70_000;
        sequencer.poll(t);
    }
    t
}

#[test]
fn a_late_caller_skips_periods_and_the_filter_never_runs_ahead() {
    let (mut sequencer, now) = following(&[Some(0.0); BALLS]);
    let from = sequencer.live_states().to_vec();
    let skip = sequencer.drive().periods.len();
    // Polled every 70 ms instead of 20: one step per poll.
    poll_late_to_the_bottom(&mut sequencer, now);
    let periods = &sequencer.drive().periods[skip..];
    assert_eq!(periods.len(), 50);
    check_limits(&from, periods);
}

#[test]
fn a_drive_that_prepares_first_starts_the_approach_when_it_is_ready() {
    let mut sequencer = homed();
    sequencer.drive_mut().prepares_us = Some(250_000);
    sequencer.set_live_input(input(&[Some(100.0); BALLS], false));
    sequencer.go_live(1_000).unwrap();
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Loading);
    assert_eq!(status.live.unwrap().phase, LivePhase::Preparing);
    assert_eq!(sequencer.next_wakeup_us(1_000), Some(251_000));
    sequencer.poll(100_000);
    assert!(
        sequencer.drive().periods.is_empty(),
        "nothing moves while preparing"
    );
    run_live(&mut sequencer, 100_000, 400_000, &mut |_| {
        (vec![Some(100.0); BALLS], false)
    });
    assert_eq!(sequencer.drive().log, ["1000 live", "251000 prepared"]);
    let periods = &sequencer.drive().periods;
    assert_eq!(periods[0].0, 251_000, "the first slot is the drive's start");
    check_limits(&[BallState::at_rest(0.0); BALLS], periods);
    // An e-stop while preparing leaves live mode.
    let mut preparing = homed();
    preparing.drive_mut().prepares_us = Some(250_000);
    preparing.go_live(0).unwrap();
    preparing.estop();
    assert!(!preparing.is_live() && preparing.needs_home());
    assert_eq!(preparing.status().live, None);
}

#[test]
fn a_drive_that_runs_its_own_clock_gets_every_period_from_a_late_caller() {
    let (mut sequencer, now) = following(&[Some(0.0); BALLS]);
    // As the drive's setup would say it.
    if let Some(live) = sequencer.live.as_mut() {
        live.setup.every_period = true;
    }
    let from = sequencer.live_states().to_vec();
    let skip = sequencer.drive().periods.len();
    let first_slot = sequencer.next_wakeup_us(now).unwrap();
    // Polled every 70 ms: three or four periods each time, none missed.
    let t = poll_late_to_the_bottom(&mut sequencer, now);
    let periods = &sequencer.drive().periods[skip..];
    assert_eq!(periods.len() as u64, (t - first_slot) / PERIOD_US + 1);
    for (index, (slot_us, _)) in periods.iter().enumerate() {
        assert_eq!(*slot_us, first_slot + index as u64 * PERIOD_US);
    }
    check_limits(&from, periods);
}

#[cfg(not(target_arch = "wasm32"))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    /// One stretch of input: each ball's target (or none), lost or not, held for some
    /// periods, polled every so many µs (late callers included); or the operator
    /// leaving.
    #[derive(Debug, Clone)]
    enum Stretch {
        Input {
            targets: Vec<Option<f64>>,
            lost: bool,
            periods: u8,
            poll_us: u64,
        },
        Leave,
    }

    fn stretch() -> impl Strategy<Value = Stretch> {
        let target = prop_oneof![
            4 => (0.0..7500.0f64).prop_map(Some),
            1 => (-2000.0..10_000.0f64).prop_map(Some),
            1 => Just(None),
        ];
        prop_oneof![
            12 => (
                prop::collection::vec(target, BALLS),
                prop::bool::weighted(0.15),
                1..60u8,
                prop_oneof![Just(20_000u64), 1_000..90_000u64],
            )
                .prop_map(|(targets, lost, periods, poll_us)| Stretch::Input {
                    targets,
                    lost,
                    periods,
                    poll_us,
                }),
            1 => Just(Stretch::Leave),
        ]
    }

    proptest! {
        #[test]
        fn no_live_output_breaks_a_limit_for_any_input(
            first in prop::collection::vec(0.0..7500.0f64, BALLS),
            stretches in prop::collection::vec(stretch(), 1..12),
        ) {
            let mut sequencer = homed();
            let first: Vec<Option<f64>> = first.into_iter().map(Some).collect();
            sequencer.set_live_input(input(&first, false));
            sequencer.go_live(0).unwrap();
            let mut now = 0;
            for stretch in stretches {
                match stretch {
                    Stretch::Leave => {
                        sequencer.leave_live(now);
                    }
                    Stretch::Input { targets, lost, periods, poll_us } => {
                        let until = now + u64::from(periods) * PERIOD_US;
                        while now < until {
                            now += poll_us;
                            sequencer.set_live_input(input(&targets, lost));
                            sequencer.poll(now);
                        }
                    }
                }
            }
            check_limits(&[BallState::at_rest(0.0); BALLS], &sequencer.drive().periods);
            // Left: at rest, and the drive was told where.
            if !sequencer.is_live() {
                let (_, rest) = sequencer.drive().ended.clone().unwrap();
                prop_assert!(rest.iter().all(|state| state.velocity_mm_s == 0.0));
            }
        }
    }
}
