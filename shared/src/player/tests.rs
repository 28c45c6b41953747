//! The sequencer's own semantics, family-agnostic: a drive whose every step takes a
//! fixed time, and which writes down each step it is asked for. The families' drives
//! are tested against their twins beside them (`plan/mbox_tests.rs`, `scl/drive`).

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;

/// Every step takes `step_us`; loading happens when `loads` and on a first cycle.
#[derive(Debug, Default)]
struct Timed {
    step_us: u64,
    loads: bool,
    ends_us: Option<u64>,
    fails_at: Option<&'static str>,
    current: &'static str,
    log: Vec<String>,
    /// A show's units start this long after its play step begins, µs.
    start_lead_us: u64,
    /// When the show under way starts on the units, µs.
    show_start_us: Option<u64>,
    /// It can end a run without an e-stop ([`Drive::interrupt`]).
    interrupts: bool,
}

impl Timed {
    fn begin(&mut self, now_us: u64, what: &'static str, detail: String) {
        self.log.push(format!("{now_us} {what}{detail}"));
        self.current = what;
        self.show_start_us = (what == "play").then_some(now_us + self.start_lead_us);
        self.ends_us = Some(now_us + self.step_us);
    }
}

impl Drive for Timed {
    type Entry = &'static str;

    fn begin_run(&mut self, now_us: u64, _first: Option<&mut &'static str>) {
        self.log.push(format!("{now_us} run"));
    }

    fn begin_home(&mut self, now_us: u64) {
        self.begin(now_us, "home", String::new());
    }

    fn begin_approach(&mut self, now_us: u64, entry: &mut &'static str) -> bool {
        self.begin(now_us, "approach", format!(" {entry}"));
        true
    }

    fn begin_load(
        &mut self,
        now_us: u64,
        index: usize,
        entry: &mut &'static str,
        cycle: u32,
    ) -> bool {
        if self.loads && cycle == 1 {
            self.begin(now_us, "load", format!(" {entry} #{index}"));
            true
        } else {
            false
        }
    }

    fn begin_play(&mut self, now_us: u64, entry: &mut &'static str, last: bool) {
        self.begin(
            now_us,
            "play",
            format!(" {entry}{}", if last { " last" } else { "" }),
        );
    }

    fn poll(&mut self, now_us: u64, _entry: Option<&mut &'static str>) -> Phase {
        match self.ends_us {
            Some(_) if self.fails_at == Some(self.current) => {
                self.ends_us = None;
                Phase::Failed(format!("{} failed", self.current))
            }
            Some(at_us) if now_us >= at_us => {
                self.ends_us = None;
                Phase::Done { at_us }
            }
            _ => Phase::Pending,
        }
    }

    fn progress(&self) -> f64 {
        0.5
    }

    fn show_start_us(&self) -> Option<u64> {
        self.show_start_us
    }

    fn stop(&mut self) {
        self.log.push("stop".into());
        self.ends_us = None;
    }

    fn interrupt(&mut self, now_us: u64) -> bool {
        if self.interrupts {
            self.log.push(format!("{now_us} interrupt"));
            self.ends_us = None;
        }
        self.interrupts
    }

    fn next_wakeup_us(&self, now_us: u64) -> Option<u64> {
        self.ends_us.map(|at_us| at_us.max(now_us))
    }
}

fn run(name: &'static str, delay_ms: u64, cycles: u32) -> Run<&'static str> {
    Run {
        name: name.into(),
        duration_ms: 1_000,
        timing: EntryTiming { delay_ms, cycles },
        prepared: name,
    }
}

/// Polls whenever the sequencer asks, up to `until_us`.
fn run_until(sequencer: &mut Sequencer<Timed>, mut now_us: u64, until_us: u64) -> u64 {
    while let Some(wake_us) = sequencer.next_wakeup_us(now_us) {
        if wake_us > until_us {
            break;
        }
        now_us = wake_us;
        sequencer.poll(now_us);
    }
    until_us.max(now_us)
}

fn timed(loads: bool) -> Sequencer<Timed> {
    Sequencer::new(Timed {
        step_us: 100,
        loads,
        ..Timed::default()
    })
}

#[test]
fn the_first_start_homes_then_plays_each_entry_with_its_delay_and_cycles() {
    let mut sequencer = timed(true);
    sequencer
        .start(0, vec![run("a", 0, 2), run("b", 1, 1)], false)
        .unwrap();
    run_until(&mut sequencer, 0, 10_000);
    assert_eq!(
        sequencer.drive().log,
        [
            "0 run",
            "0 home",
            "100 approach a",
            "200 load a #0",
            "300 play a",
            "400 approach a",
            "500 play a",
            // b waits its 1 ms from the end of a's second cycle.
            "1600 approach b",
            "1700 load b #1",
            "1800 play b last",
        ]
    );
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Idle);
    assert_eq!(status.progress, 1.0);
    assert!(!sequencer.needs_home());
}

#[test]
fn start_after_an_estop_homes_first_and_begins_at_the_first_entry() {
    let mut sequencer = timed(false);
    sequencer
        .start(0, vec![run("a", 0, 1), run("b", 0, 1)], false)
        .unwrap();
    // Into b's approach.
    run_until(&mut sequencer, 0, 350);
    assert_eq!(sequencer.status().entry, Some(1));
    sequencer.estop();
    assert_eq!(sequencer.status().state, PlayerState::Stopped);
    assert!(sequencer.needs_home());
    assert_eq!(
        sequencer.next_wakeup_us(400),
        None,
        "nothing runs after the e-stop"
    );
    sequencer.drive_mut().log.clear();
    sequencer
        .start(1_000, vec![run("a", 0, 1), run("b", 0, 1)], false)
        .unwrap();
    run_until(&mut sequencer, 1_000, 1_250);
    assert_eq!(
        sequencer.drive().log,
        ["1000 run", "1000 home", "1100 approach a", "1200 play a"]
    );
}

#[test]
fn start_without_an_estop_between_does_not_home_again() {
    let mut sequencer = timed(false);
    sequencer.start(0, vec![run("a", 0, 1)], false).unwrap();
    run_until(&mut sequencer, 0, 1_000);
    sequencer.drive_mut().log.clear();
    sequencer.start(2_000, vec![run("a", 0, 1)], false).unwrap();
    assert_eq!(sequencer.drive().log, ["2000 run", "2000 approach a"]);
}

#[test]
fn start_is_refused_while_running_and_without_entries() {
    let mut sequencer = timed(false);
    assert_eq!(
        sequencer.start(0, Vec::new(), false),
        Err(StartError::Empty)
    );
    sequencer.start(0, vec![run("a", 0, 1)], false).unwrap();
    assert_eq!(
        sequencer.start(10, vec![run("a", 0, 1)], false),
        Err(StartError::Busy)
    );
}

#[test]
fn reset_stops_homes_and_plays_from_the_first_entry_and_home_rests() {
    let mut sequencer = timed(false);
    sequencer
        .start(0, vec![run("a", 0, 1), run("b", 0, 1)], true)
        .unwrap();
    run_until(&mut sequencer, 0, 450);
    sequencer.drive_mut().log.clear();
    sequencer
        .reset(500, Ok(vec![run("a", 0, 1)]), false)
        .unwrap();
    run_until(&mut sequencer, 500, 800);
    assert_eq!(
        sequencer.drive().log,
        [
            "stop",
            "500 run",
            "500 home",
            "600 approach a",
            "700 play a last"
        ]
    );
    sequencer.drive_mut().log.clear();
    sequencer.home(1_000);
    assert_eq!(sequencer.status().state, PlayerState::Homing);
    assert_eq!(
        sequencer.status().show,
        None,
        "homing to rest names no show"
    );
    run_until(&mut sequencer, 1_000, 2_000);
    assert_eq!(sequencer.drive().log, ["stop", "1000 run", "1000 home"]);
    assert_eq!(sequencer.status().state, PlayerState::Idle);
    // A Reset that cannot start leaves the matrix stopped, saying why.
    assert_eq!(
        sequencer.reset(3_000, Err(StartError::Empty), false),
        Err(StartError::Empty)
    );
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Stopped);
    assert_eq!(
        status.last_error.as_deref(),
        Some(&*StartError::Empty.to_string())
    );
}

#[test]
fn a_drive_failure_stops_asks_for_the_estop_and_the_next_start_homes() {
    let mut sequencer = Sequencer::new(Timed {
        step_us: 100,
        fails_at: Some("play"),
        ..Timed::default()
    });
    sequencer.start(0, vec![run("a", 0, 1)], true).unwrap();
    run_until(&mut sequencer, 0, 1_000);
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Error);
    assert_eq!(status.last_error.as_deref(), Some("play failed"));
    assert!(sequencer.take_estop());
    assert!(!sequencer.take_estop(), "asked once");
    // An e-stop keeps the failure visible.
    sequencer.estop();
    assert_eq!(sequencer.status().state, PlayerState::Error);
    assert!(sequencer.needs_home());
}

#[test]
fn the_status_counts_show_time_only_while_playing() {
    let mut sequencer = timed(false);
    sequencer.start(0, vec![run("a", 0, 1)], false).unwrap();
    run_until(&mut sequencer, 0, 150);
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Approaching);
    assert_eq!(
        (status.show_time_ms, status.show.as_deref()),
        (0, Some("a"))
    );
    run_until(&mut sequencer, 150, 250);
    sequencer.poll(250);
    let status = sequencer.status();
    assert_eq!(status.state, PlayerState::Playing);
    assert_eq!((status.show_time_ms, status.show_duration_ms), (0, 1_000));
    assert_eq!(status.progress, 0.0);
}

/// Issue 34, item 5: the status counts the show on the units' clock, at the instant it
/// is made, and says `playing` from the instant the units start — announced ahead
/// while the start is given.
#[test]
fn the_status_clock_is_the_units_clock_at_the_instant_it_is_made() {
    let mut sequencer = Sequencer::new(Timed {
        step_us: 5_000_000,
        start_lead_us: 30_000,
        ..Timed::default()
    });
    sequencer.start(0, vec![run("a", 0, 1)], false).unwrap();
    // Home 0–5 s, approach 5–10 s, play from 10 s: the units start 30 ms later.
    run_until(&mut sequencer, 0, 10_000_000);
    assert_eq!(
        sequencer.drive().log.last().unwrap(),
        "10000000 play a last"
    );
    let given = sequencer.status_at(10_010_000);
    assert_eq!(given.state, PlayerState::Loading);
    assert_eq!(given.show_starts_in_ms, Some(20));
    assert_eq!(given.show_time_ms, 0);
    assert_eq!(given.progress, 1.0, "loaded: the start is under way");
    assert_eq!(sequencer.state_at(10_029_999), PlayerState::Loading);
    // The start is an instant of its own for the caller (the status goes out then),
    // not a poll: the drive's next wake-up stands.
    assert_eq!(sequencer.next_state_change_us(10_010_000), Some(10_030_000));
    assert_eq!(sequencer.next_wakeup_us(10_010_000), Some(15_000_000));
    assert_eq!(sequencer.state_at(10_030_000), PlayerState::Playing);
    // Between polls, a status is exact to its own instant.
    let playing = sequencer.status_at(10_030_000 + 567_890);
    assert_eq!(playing.state, PlayerState::Playing);
    assert_eq!(playing.show_time_ms, 567);
    assert_eq!(playing.show_starts_in_ms, None);
    assert!((playing.progress - 0.567).abs() < 1e-9);
    assert_eq!(sequencer.next_state_change_us(10_030_000), None);
    // Never past the show's length.
    assert_eq!(sequencer.status_at(12_000_000).show_time_ms, 1_000);
}

fn lead_at(entry: usize, from_ms: u64) -> StartAt<&'static str> {
    StartAt {
        entry,
        lead: Some(Lead {
            from_ms,
            prepared: "cut",
        }),
    }
}

#[test]
fn a_start_from_a_time_plays_the_cut_first_then_the_entry_in_full() {
    let mut sequencer = timed(true);
    sequencer
        .start_at(
            0,
            vec![run("a", 5, 1), run("b", 5, 2), run("c", 0, 1)],
            false,
            lead_at(1, 400),
        )
        .unwrap();
    // Into the cut's play (its units start at once): the full show's clock.
    run_until(&mut sequencer, 0, 350);
    let status = sequencer.status_at(350);
    assert_eq!(status.state, PlayerState::Playing);
    assert_eq!(status.entry, Some(1));
    assert_eq!(status.show.as_deref(), Some("b"));
    assert_eq!(status.show_duration_ms, 1_000);
    assert_eq!(status.cycle, 1);
    assert_eq!(status.show_time_ms, 400);
    assert!((status.progress - 0.4).abs() < 1e-9);
    assert_eq!(sequencer.status_at(2_300).show_time_ms, 402);
    run_until(&mut sequencer, 0, 100_000);
    assert_eq!(
        sequencer.drive().log,
        [
            "0 run",
            "0 home",
            // No delay before a start from inside the show.
            "100 approach cut",
            // The cut is loaded under a reserved entry number (`usize::MAX`, whose
            // value depends on the target: 32 bits on wasm32).
            format!("200 load cut #{}", usize::MAX).as_str(),
            "300 play cut",
            // b's second cycle is the drive's first of b in full: it loads, on b's
            // clock from 0.
            "400 approach b",
            "500 load b #1",
            "600 play b",
            "700 approach c",
            "800 load c #2",
            "900 play c last",
        ]
    );
}

#[test]
fn after_the_cut_the_entry_counts_its_own_time_and_an_estop_forgets_the_cut() {
    let mut sequencer = timed(false);
    sequencer
        .start_at(0, vec![run("a", 0, 2)], false, lead_at(0, 900))
        .unwrap();
    run_until(&mut sequencer, 0, 250);
    assert_eq!(sequencer.status_at(250).show_time_ms, 900);
    // The second cycle: a in full, from its start.
    run_until(&mut sequencer, 250, 450);
    let status = sequencer.status_at(450);
    assert_eq!((status.state, status.cycle), (PlayerState::Playing, 2));
    assert_eq!(status.show_time_ms, 0);
    sequencer.estop();
    sequencer.drive_mut().log.clear();
    sequencer.start(1_000, vec![run("a", 0, 1)], false).unwrap();
    run_until(&mut sequencer, 1_000, 1_250);
    assert_eq!(
        sequencer.drive().log,
        [
            "1000 run",
            "1000 home",
            "1100 approach a",
            "1200 play a last"
        ]
    );
}

#[test]
fn a_start_at_an_entry_without_a_time_waits_its_delay_and_a_bad_start_is_refused() {
    let mut sequencer = timed(false);
    let entries = || vec![run("a", 0, 1), run("b", 1, 1)];
    assert_eq!(
        sequencer.start_at(0, entries(), false, lead_at(2, 10)),
        Err(StartError::NoSuchEntry {
            entry: 3,
            entries: 2
        })
    );
    assert_eq!(
        sequencer.start_at(0, entries(), false, lead_at(1, 1_000)),
        Err(StartError::PastTheEnd {
            entry: 2,
            time_ms: 1_000,
            duration_ms: 1_000
        })
    );
    assert!(sequencer.is_idle());
    sequencer
        .start_at(
            0,
            entries(),
            false,
            StartAt {
                entry: 1,
                lead: None,
            },
        )
        .unwrap();
    run_until(&mut sequencer, 0, 10_000);
    assert_eq!(
        sequencer.drive().log,
        ["0 run", "0 home", "1100 approach b", "1200 play b last"]
    );
}

#[test]
fn a_locate_ends_the_show_without_a_stop_and_approaches_the_new_point_without_homing() {
    let mut sequencer = timed(false);
    sequencer.drive_mut().interrupts = true;
    sequencer
        .start(0, vec![run("a", 0, 1), run("b", 0, 1)], false)
        .unwrap();
    run_until(&mut sequencer, 0, 250);
    assert_eq!(sequencer.status_at(250).state, PlayerState::Playing);
    sequencer.drive_mut().log.clear();
    sequencer
        .locate_at(
            250,
            Ok((vec![run("a", 0, 1), run("b", 0, 1)], lead_at(1, 600))),
            false,
        )
        .unwrap();
    run_until(&mut sequencer, 250, 10_000);
    assert_eq!(
        sequencer.drive().log,
        [
            "250 interrupt",
            "250 run",
            // From where the balls are: no stop, no home.
            "250 approach cut",
            // b's only cycle, the playlist's last.
            "350 play cut last",
        ]
    );
    assert!(!sequencer.needs_home());
}

#[test]
fn a_locate_that_cannot_begin_leaves_the_show_playing() {
    let mut sequencer = timed(false);
    sequencer.start(0, vec![run("a", 0, 1)], false).unwrap();
    run_until(&mut sequencer, 0, 250);
    // This drive cannot end a run without an e-stop: refused, nothing changed.
    assert_eq!(
        sequencer.locate_at(250, Ok((vec![run("a", 0, 1)], lead_at(0, 500))), false),
        Err(StartError::Busy)
    );
    sequencer.drive_mut().interrupts = true;
    // Past the show's end, or no such entry: refused before anything is interrupted.
    assert!(matches!(
        sequencer.locate_at(250, Ok((vec![run("a", 0, 1)], lead_at(0, 1_000))), false),
        Err(StartError::PastTheEnd { .. })
    ));
    assert!(matches!(
        sequencer.locate_at(250, Ok((vec![run("a", 0, 1)], lead_at(3, 0))), false),
        Err(StartError::NoSuchEntry { .. })
    ));
    assert!(
        !sequencer
            .drive()
            .log
            .iter()
            .any(|line| line.contains("interrupt"))
    );
    assert_eq!(sequencer.status_at(260).state, PlayerState::Playing);
    // Idle: a locate is a start (homing first when the positions are unknown).
    let mut idle = timed(false);
    idle.drive_mut().interrupts = true;
    idle.locate_at(0, Ok((vec![run("a", 0, 1)], lead_at(0, 500))), false)
        .unwrap();
    run_until(&mut idle, 0, 1_000);
    assert_eq!(
        idle.drive().log,
        ["0 run", "0 home", "100 approach cut", "200 play cut last"]
    );
}
