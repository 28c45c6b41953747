//! MOONS' drives under the sequencer, in simulated time: a whole playlist — homing,
//! approach, upload, start, play, E-stop, Reset and Home — against three drive twins
//! ([`crate::scl::twin`]), every request answered by the twin it is addressed to, at
//! the time it is sent.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;
use crate::api::PlayerState;
use crate::player::EntryTiming;
use crate::player::{Run, Sequencer, StartAt};
use crate::scl::Request;
use crate::scl::qprogram::{QProgramConfig, compile};
use crate::scl::twin::{self, DriveConfig};
use crate::show::{Layout, Show, Track, TrackRow};

const COUNTS_PER_MM: f64 = 100.0;

/// Three balls that each go down 20 mm and come up to 5 × (i + 1) mm, in 1 s.
fn show() -> Show {
    let track = |ball: usize| Track {
        start_mm: 0.0,
        rows: vec![
            TrackRow::new(10.0, 0.0, 250),
            TrackRow::new(20.0, 0.0, 250),
            TrackRow::new(10.0, 0.0, 250),
            TrackRow::new(5.0 * (ball as f64 + 1.0), 0.0, 250),
        ],
        colours: Vec::new(),
    };
    Show {
        name: "drop".into(),
        layout: Layout {
            rows: 1,
            cols: 3,
            pitch_mm: 500.0,
        },
        tracks: (0..3).map(track).collect(),
        outputs: Vec::new(),
    }
}

fn config(trigger: Option<Trigger>) -> SclDriveConfig {
    SclDriveConfig {
        units: (0..3)
            .map(|drive| DriveSlot {
                gateway: 0,
                drive,
                name: format!("drive \"{}\" on SCL gateway 0", drive + 1),
            })
            .collect(),
        gateways: 1,
        counts_per_mm: COUNTS_PER_MM,
        steps_per_rev: 20_000,
        approach_speed_mm_s: 1_000.0,
        max_accel_mm_s2: 4_000.0,
        home_mm: 0.0,
        travel_mm: 3_000.0,
        trigger,
    }
}

fn entry(config: &SclDriveConfig, cycles: u32) -> Run<SclEntry> {
    // The approach goes 1 mm below each show's start (the tests see it in the lines).
    entry_of(config, &show(), cycles, 1.0)
}

/// `show` as an entry of `cycles` cycles, its programs compiled, its approach
/// `below_mm` below each ball's start.
fn entry_of(config: &SclDriveConfig, show: &Show, cycles: u32, below_mm: f64) -> Run<SclEntry> {
    let settings = QProgramConfig {
        counts_per_mm: COUNTS_PER_MM,
        start: None,
        tolerance_mm: 20.0,
        ..QProgramConfig::default()
    };
    let programs = show
        .tracks
        .iter()
        .map(|track| compile(track, &settings).unwrap())
        .collect();
    Run {
        name: show.name.clone(),
        duration_ms: show.duration_ms(),
        timing: EntryTiming {
            delay_ms: 0,
            cycles,
        },
        prepared: SclEntry::new(
            config,
            show.tracks.iter().map(|track| track.start_mm + below_mm),
            Some(programs),
            show.duration_ms(),
        ),
    }
}

/// A twin's answer as the link hands it over: its lines, without their CRs.
fn lines_of(answer: &str) -> Vec<String> {
    answer
        .split('\r')
        .filter(|line| !line.is_empty())
        .map(str::to_owned)
        .collect()
}

/// The sequencer, three twins, the clock, and every line each twin was sent.
struct Rig {
    sequencer: Sequencer<SclDrive>,
    twins: Vec<twin::Drive>,
    now_us: u64,
    lines: Vec<Vec<String>>,
    /// Every state the sequencer was in, in order.
    states: Vec<PlayerState>,
    /// A request the twins answer with `?6` (refused).
    refused: Option<&'static str>,
}

impl Rig {
    fn new() -> Self {
        Self {
            sequencer: Sequencer::new(SclDrive::new(config(None))),
            twins: (0..3)
                .map(|_| twin::Drive::new(DriveConfig::default()))
                .collect(),
            now_us: 0,
            lines: vec![Vec::new(); 3],
            states: Vec::new(),
            refused: None,
        }
    }

    /// Answers every request at once, until none is left.
    fn exchange(&mut self) {
        loop {
            self.sequencer.poll(self.now_us);
            let state = self.sequencer.status().state;
            if self.states.last() != Some(&state) {
                self.states.push(state);
            }
            let asks = self.sequencer.drive_mut().take_asks();
            if asks.is_empty() {
                return;
            }
            for ask in asks {
                let twin = &mut self.twins[ask.drive];
                twin.advance(self.now_us);
                self.lines[ask.drive].push(ask.text.clone());
                let answer = twin
                    .receive_line(&ask.text, self.now_us)
                    .unwrap_or_default();
                let answer = if self.refused == Some(ask.text.as_str()) {
                    "?6".to_owned()
                } else {
                    answer
                };
                self.sequencer
                    .drive_mut()
                    .answer(self.now_us, ask.id, Ok(lines_of(&answer)));
            }
        }
    }

    /// Runs until `until_us` or until the sequencer rests.
    fn run_until(&mut self, until_us: u64) {
        loop {
            self.exchange();
            let Some(wake_us) = self.sequencer.next_wakeup_us(self.now_us) else {
                return;
            };
            if wake_us > until_us {
                self.now_us = until_us;
                return;
            }
            self.now_us = wake_us.max(self.now_us + 1);
            for twin in &mut self.twins {
                twin.advance(self.now_us);
            }
        }
    }

    fn positions(&self) -> Vec<i64> {
        self.twins
            .iter()
            .map(twin::Drive::position_integer)
            .collect()
    }

    /// Every line sent but the waits' queries (`IP`, `SC`).
    fn commands(&mut self, drive: usize) -> Vec<String> {
        std::mem::take(&mut self.lines[drive])
            .into_iter()
            .filter(|line| line != "IP" && line != "SC")
            .collect()
    }
}

#[test]
fn a_show_homes_approaches_uploads_starts_and_ends_where_it_was_drawn() {
    let mut rig = Rig::new();
    let run = entry(rig.sequencer.drive().config(), 2);
    rig.sequencer.start(0, vec![run], false).unwrap();
    assert_eq!(rig.sequencer.status().state, PlayerState::Homing);
    rig.states.push(PlayerState::Homing);
    rig.run_until(60_000_000);
    assert_eq!(
        rig.states,
        [
            PlayerState::Homing,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Approaching,
            // The second cycle's start (no upload): `playing` once every drive
            // took its QE.
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Idle,
        ]
    );
    // Every ball ends at 5 × (i + 1) mm, as drawn.
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
    let lines = rig.commands(1);
    // The motor enabled (once a run), homing, then the approach to 1 mm, at
    // 1000 mm/s (5 rev/s) and 4000 mm/s².
    assert_eq!(
        lines[..11],
        [
            "ME", "VE5.0000", "AC20.000", "DE20.000", "DI0", "FP", "VE5.0000", "AC20.000",
            "DE20.000", "DI100", "FP"
        ]
    );
    assert_eq!(lines.iter().filter(|line| *line == "ME").count(), 1);
    // A program of one segment goes to the queue each cycle (`QL`, its lines, `QE`:
    // HCR p. 216, 212), never to memory: no `QS`, nothing to read back.
    assert_eq!(lines.iter().filter(|line| *line == "QL").count(), 2);
    assert_eq!(lines.iter().filter(|line| *line == "QE").count(), 2);
    assert!(
        !lines
            .iter()
            .any(|line| line.starts_with("QS") || line.starts_with("QU"))
    );
    assert_eq!(lines.last().map(String::as_str), Some("QE"));
    // The third ball's program takes three segments: stored, each segment once
    // (compared with `QU` first); the others none.
    assert_eq!(rig.sequencer.drive().flash_writes(), [0, 0, 3]);
    let stored: Vec<u32> = rig
        .twins
        .iter()
        .map(twin::Drive::flash_writes_total)
        .collect();
    assert_eq!(stored, [0, 0, 3]);
    rig.commands(2);
    // A repeated Start of the same show writes nothing (HCR p. 294: each partition
    // lasts about 10,000 writes): every segment read back equal.
    let run = entry(rig.sequencer.drive().config(), 1);
    rig.sequencer.start(rig.now_us, vec![run], false).unwrap();
    rig.run_until(rig.now_us + 60_000_000);
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    assert_eq!(rig.sequencer.drive().flash_writes(), [0, 0, 3]);
    let stored: Vec<u32> = rig
        .twins
        .iter()
        .map(twin::Drive::flash_writes_total)
        .collect();
    assert_eq!(stored, [0, 0, 3]);
    let third = rig.commands(2);
    assert!(third.iter().any(|line| line == "QU1"));
    assert!(!third.iter().any(|line| line.starts_with("QS")));
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
}

#[test]
fn the_show_time_is_counted_from_the_start_and_playing_begins_with_it() {
    let mut rig = Rig::new();
    let run = entry(rig.sequencer.drive().config(), 1);
    rig.sequencer.start(0, vec![run], false).unwrap();
    while rig.sequencer.status().state != PlayerState::Playing {
        let at_us = rig.now_us + 1_000;
        rig.run_until(at_us);
    }
    let started_us = rig.sequencer.drive().started_us().unwrap();
    assert!(
        rig.now_us - started_us <= 1_000,
        "playing as the start goes"
    );
    rig.run_until(started_us + 500_000);
    let status = rig.sequencer.status();
    assert_eq!(status.show_time_ms, 500);
    assert_eq!(status.progress, 0.5);
}

#[test]
fn start_after_an_estop_homes_first() {
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    rig.sequencer
        .start(0, vec![entry(&config, 1)], false)
        .unwrap();
    rig.run_until(60_000_000);
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    rig.commands(0);
    // Start again: the positions are known, no homing.
    rig.sequencer
        .start(rig.now_us, vec![entry(&config, 1)], false)
        .unwrap();
    let at_us = rig.now_us + 5_000;
    rig.run_until(at_us);
    assert_eq!(rig.sequencer.status().state, PlayerState::Approaching);
    let lines = rig.commands(0);
    assert_eq!(lines[..2], ["ME", "VE5.0000"], "the motor enabled first");
    assert_eq!(lines[4], "DI100", "straight to the show's start");
    // The e-stop (the caller sent SK): nothing more is asked of the drives.
    rig.sequencer.estop();
    for twin in &mut rig.twins {
        twin.receive_line("SK", rig.now_us);
    }
    assert!(rig.sequencer.drive_mut().take_asks().is_empty());
    assert_eq!(rig.sequencer.next_wakeup_us(rig.now_us), None);
    assert_eq!(rig.sequencer.status().state, PlayerState::Stopped);
    // The next Start homes first, then approaches.
    rig.commands(0);
    rig.sequencer
        .start(rig.now_us, vec![entry(&config, 1)], false)
        .unwrap();
    assert_eq!(rig.sequencer.status().state, PlayerState::Homing);
    rig.run_until(rig.now_us + 60_000_000);
    let lines = rig.commands(0);
    assert_eq!(lines[4], "DI0", "home first: {lines:?}");
    assert_eq!(lines[9], "DI100", "then the approach: {lines:?}");
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
}

#[test]
fn home_rests_at_home_and_a_refused_upload_fails_naming_the_drive() {
    let mut rig = Rig::new();
    rig.sequencer.home(0);
    rig.run_until(60_000_000);
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    assert_eq!(rig.positions(), [0, 0, 0]);
    // A program the drive cannot take: an answer that is not its own.
    let config = rig.sequencer.drive().config().clone();
    rig.refused = Some("QL");
    rig.sequencer
        .start(rig.now_us, vec![entry(&config, 1)], false)
        .unwrap();
    rig.run_until(rig.now_us + 60_000_000);
    // The third ball's program is stored (three segments): its first `QL` is the
    // first, before any drive plays.
    assert_eq!(
        rig.commands(2).last().map(String::as_str),
        Some("QL"),
        "nothing after"
    );
    let status = rig.sequencer.status();
    assert_eq!(status.state, PlayerState::Error);
    let error = status.last_error.unwrap();
    assert!(
        error.starts_with("drive \"3\" on SCL gateway 0 refused QL (code 6): it does not take"),
        "{error}"
    );
    assert!(rig.sequencer.take_estop(), "the matrix is stopped");
}

#[test]
fn drives_disabled_at_a_window_s_end_move_again_at_the_next_start() {
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    rig.sequencer.home(0);
    rig.run_until(60_000_000);
    // The schedule's end: MD to every drive (the bridge sends it, not the drive).
    for twin in &mut rig.twins {
        assert_eq!(twin.receive_line("MD", rig.now_us).as_deref(), Some("*\r"));
        assert!(!twin.is_enabled());
    }
    // Without ME a move is refused (No Move): what a Start before this change met.
    let mut bare = twin::Drive::new(DriveConfig::default());
    bare.receive_line("MD", 0);
    bare.receive_line("DI100", 0);
    bare.receive_line("FP", 0);
    bare.advance(1_000_000);
    assert_eq!(bare.alarm_code(), twin::alarm::NO_MOVE);
    assert_eq!(bare.position_integer(), 0);
    // The Start enables them first, then plays as ever.
    rig.commands(0);
    rig.sequencer
        .start(rig.now_us, vec![entry(&config, 1)], false)
        .unwrap();
    rig.run_until(rig.now_us + 60_000_000);
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    assert_eq!(rig.commands(0)[0], "ME");
    assert!(rig.twins.iter().all(twin::Drive::is_enabled));
    assert!(rig.twins.iter().all(|twin| twin.alarm_code() == 0));
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
}

#[test]
fn a_ball_that_does_not_arrive_fails_the_move_after_the_travel_time() {
    let mut rig = Rig::new();
    rig.sequencer.home(0);
    rig.sequencer.poll(0);
    // Answer every IP with a position that never arrives.
    let mut now_us = 0;
    while rig.sequencer.is_running() {
        loop {
            rig.sequencer.poll(now_us);
            let asks = rig.sequencer.drive_mut().take_asks();
            if asks.is_empty() {
                break;
            }
            for ask in asks {
                let answer = if ask.text == "IP" { "IP=7" } else { "%" };
                rig.sequencer
                    .drive_mut()
                    .answer(now_us, ask.id, Ok(vec![answer.into()]));
            }
        }
        now_us = rig.sequencer.next_wakeup_us(now_us).unwrap_or(now_us);
        assert!(now_us < 20_000_000);
    }
    let error = rig.sequencer.status().last_error.unwrap();
    // 3000 mm at 1000 mm/s, and 5 s more.
    assert_eq!(
        error,
        "drive \"1\" on SCL gateway 0 is at 7 counts, not 0, 8000 ms after it was sent there"
    );
    assert!((8_000_000..8_020_001).contains(&now_us), "{now_us}");
}

#[test]
fn with_a_trigger_every_drive_waits_then_the_trigger_ball_fires_the_edge_itself() {
    // The trigger is drive 1's output 2, and drive 1 plays a ball: its program's line
    // 1 is the edge (`SO2L` in place of `WI3F`), and it is started last, so the
    // bridge never writes to a drive whose program runs.
    let trigger = Trigger {
        drive: Ok(0),
        name: "drive \"1\" on SCL gateway 0".into(),
        output: IoPoint::new(2).unwrap(),
    };
    let mut drive = SclDrive::new(config(Some(trigger)));
    let config = drive.config().clone();
    let settings = QProgramConfig {
        counts_per_mm: COUNTS_PER_MM,
        tolerance_mm: 20.0,
        ..QProgramConfig::default()
    };
    let programs: Vec<_> = show()
        .tracks
        .iter()
        .map(|track| compile(track, &settings).unwrap())
        .collect();
    let mut entry = SclEntry::new(&config, [0.0; 3], Some(programs), 1_000);
    let first_lines: Vec<String> = entry
        .programs
        .as_ref()
        .unwrap()
        .iter()
        .map(|segments| segments[0].1[0].to_string())
        .collect();
    assert_eq!(first_lines, ["SO2L", "WI3F", "WI3F"]);
    drive.begin_play(0, &mut entry, true);
    let mut sent = Vec::new();
    let mut now_us = 0;
    for _ in 0..400 {
        assert_eq!(drive.poll(now_us, None), Phase::Pending);
        for ask in drive.take_asks() {
            let command = Request::parse(&ask.text).unwrap().command;
            if !matches!(command.kind(), crate::scl::Kind::Immediate) || ask.text.starts_with("Q") {
                sent.push(format!("{} {}", ask.drive, ask.text));
            }
            let answer = match command.kind() {
                _ if ask.text == "SC" => "SC=0000",
                crate::scl::Kind::Buffered => "*",
                crate::scl::Kind::Immediate => "%",
            };
            drive.answer(now_us, ask.id, Ok(vec![answer.into()]));
        }
        if drive.started_us().is_some() {
            break;
        }
        now_us = drive.next_wakeup_us(now_us).unwrap_or(now_us + 1_000);
    }
    assert!(drive.started_us().is_some());
    // The wire at its idle level first; every queue loaded; drives 2 and 3 started
    // (waiting at WI3F); drive 1 last: its program sets the wire.
    assert_eq!(sent[0], "0 SO2H");
    let position = |line: &str| sent.iter().position(|sent| sent == line).unwrap();
    // (The third ball's program is stored: `QX1`, no queue.)
    assert!(position("0 QL") < position("1 QE"));
    assert!(position("1 QL") < position("1 QE"));
    assert!(position("1 QE") < position("0 QE") && position("2 QX1") < position("0 QE"));
    assert_eq!(sent.last().map(String::as_str), Some("0 QE"));
    // The edge goes only as line 1 of drive 1's queue, never on its own.
    assert_eq!(
        sent.iter().filter(|line| line.ends_with("SO2L")).count(),
        1,
        "{sent:?}"
    );
    assert_eq!(position("0 SO2L"), position("0 QL") + 1);
}

#[test]
fn the_state_is_playing_from_the_first_drives_start_and_counts_from_its_arrival() {
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    rig.sequencer
        .start(0, vec![entry(&config, 1)], false)
        .unwrap();
    // Answer everything but the starts.
    let mut starts = Vec::new();
    for _ in 0..10_000 {
        rig.sequencer.poll(rig.now_us);
        for ask in rig.sequencer.drive_mut().take_asks() {
            if ask.text == "QE" {
                starts.push(ask);
                continue;
            }
            let twin = &mut rig.twins[ask.drive];
            twin.advance(rig.now_us);
            let answer = twin.receive_line(&ask.text, rig.now_us).unwrap_or_default();
            rig.sequencer
                .drive_mut()
                .answer(rig.now_us, ask.id, Ok(lines_of(&answer)));
        }
        if !starts.is_empty() {
            break;
        }
        rig.now_us += 1_000;
        for twin in &mut rig.twins {
            twin.advance(rig.now_us);
        }
    }
    assert_eq!(starts.len(), 1, "one QE at a time on a line");
    let status = rig.sequencer.status();
    assert_eq!(
        status.state,
        PlayerState::Loading,
        "starting, not playing yet"
    );
    assert_eq!(status.show_time_ms, 0);
    // The drives take their starts, one after the other on the line: the first
    // `QX1` to reach its drive is the show's time 0 (issue 34, item 5), and the state
    // is `playing` from then on, not once the last drive answered.
    let mut first_delivered_us = None;
    while let Some(ask) = starts.pop() {
        rig.now_us += 7_000;
        // Through the line 4 ms before its answer came back.
        let delivered_us = rig.now_us - 4_000;
        first_delivered_us.get_or_insert(delivered_us);
        let answer = rig.twins[ask.drive]
            .receive_line(&ask.text, delivered_us)
            .unwrap_or_default();
        rig.sequencer.drive_mut().delivered(ask.id, delivered_us);
        rig.sequencer
            .drive_mut()
            .answer(rig.now_us, ask.id, Ok(lines_of(&answer)));
        rig.sequencer.poll(rig.now_us);
        starts.extend(
            rig.sequencer
                .drive_mut()
                .take_asks()
                .into_iter()
                .filter(|ask| ask.text == "QX1"),
        );
        let status = rig.sequencer.status_at(rig.now_us);
        assert_eq!(
            status.state,
            PlayerState::Playing,
            "the first drive started"
        );
        assert_eq!(
            rig.sequencer.drive().started_us(),
            first_delivered_us,
            "time 0 is the first start's arrival"
        );
        assert_eq!(
            status.show_time_ms,
            (rig.now_us - first_delivered_us.unwrap()) / 1_000
        );
    }
}

/// Issue 34, item 3: the approach's `VE`, `AC` and `DE` are whole steps as a drive
/// holds them, never faster than set, and a crawl below the smallest `VE` is written
/// as the smallest (not a value the drive refuses).
#[test]
fn the_approach_writes_values_a_drive_holds() {
    let mut config = config(None);
    for (speed_mm_s, accel_mm_s2) in [(1_000.0, 4_000.0), (0.1, 3.0), (777.7, 1_234.5)] {
        config.approach_speed_mm_s = speed_mm_s;
        config.max_accel_mm_s2 = accel_mm_s2;
        let mut sequencer = Sequencer::new(SclDrive::new(config.clone()));
        sequencer.home(0);
        // Each drive's lines one after the other: every one answered at once.
        let mut asked = Vec::new();
        for _ in 0..8 {
            for ask in sequencer.drive_mut().take_asks() {
                asked.push(ask.text.clone());
                sequencer
                    .drive_mut()
                    .answer(0, ask.id, Ok(vec!["%".to_owned()]));
            }
            sequencer.poll(0);
        }
        let value = |mnemonic: &str| {
            let text = asked
                .iter()
                .find(|text| text.starts_with(mnemonic))
                .map(|text| text[mnemonic.len()..].to_owned())
                .expect("asked");
            match crate::scl::Request::parse(&format!("{mnemonic}{text}"))
                .expect("a command")
                .command
            {
                Command::Velocity { rev_s: Some(v) } => v,
                Command::Acceleration { rev_s2: Some(a) }
                | Command::Deceleration { rev_s2: Some(a) } => a,
                other => panic!("{other:?}"),
            }
        };
        let per_rev = f64::from(config.steps_per_rev);
        let ve = value("VE");
        let steps = units::VELOCITY.steps(ve).expect("a VE the drive takes");
        assert!(steps >= 1);
        assert!(
            (units::VELOCITY.held(ve).unwrap() - ve.to_f64()).abs() < units::VELOCITY.step / 40.0,
            "{ve} is a whole step"
        );
        let set = speed_mm_s * config.counts_per_mm / per_rev;
        assert!(ve.to_f64() <= set.max(units::VELOCITY.smallest().unwrap().to_f64()) + 1e-9);
        for mnemonic in ["AC", "DE"] {
            let a = value(mnemonic);
            assert!(units::ACCELERATION.steps(a).is_some(), "{mnemonic}{a}");
        }
    }
}

#[test]
fn a_start_from_a_time_uploads_the_cut_then_the_whole_show_for_the_next_cycle() {
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    let cut = show().from_time(375, 2_000.0).unwrap();
    assert!(cut.start_ms > 0 && cut.joins_ms == 375, "{cut:?}");
    let lead = entry_of(&config, &cut.show, 1, 0.0);
    rig.sequencer
        .start_at(
            0,
            vec![entry(&config, 2)],
            false,
            crate::player::StartAt {
                entry: 0,
                lead: Some(crate::player::Lead {
                    from_ms: cut.start_ms,
                    prepared: lead.prepared,
                }),
            },
        )
        .unwrap();
    while rig.sequencer.status().state != PlayerState::Playing {
        let at_us = rig.now_us + 1_000;
        rig.run_until(at_us);
    }
    // The lead plays on the full show's clock.
    let status = rig.sequencer.status();
    assert_eq!((status.cycle, status.show_duration_ms), (1, 1_000));
    assert!(status.show_time_ms >= cut.start_ms && status.show_time_ms <= cut.start_ms + 2);
    rig.run_until(60_000_000);
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
    let lines = rig.commands(1);
    // Two loads of the queue: the cut's, then the whole show's for the entry's
    // second cycle.
    assert_eq!(lines.iter().filter(|line| *line == "QL").count(), 2);
    assert_eq!(lines.iter().filter(|line| *line == "QE").count(), 2);
}

#[test]
fn a_locate_kills_the_programs_and_feeds_on_from_where_the_balls_stopped() {
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    rig.sequencer
        .start(0, vec![entry(&config, 1)], false)
        .unwrap();
    while rig.sequencer.status().state != PlayerState::Playing {
        let at_us = rig.now_us + 1_000;
        rig.run_until(at_us);
    }
    let at_us = rig.now_us + 300_000;
    rig.run_until(at_us);
    assert_eq!(rig.sequencer.status().state, PlayerState::Playing);
    rig.commands(0);
    // The timecode jumped back to the entry's start: no e-stop, no homing.
    let at = StartAt {
        entry: 0,
        lead: None,
    };
    rig.sequencer
        .locate_at(rig.now_us, Ok((vec![entry(&config, 1)], at)), false)
        .unwrap();
    assert_eq!(rig.sequencer.status().state, PlayerState::Approaching);
    rig.run_until(rig.now_us + 60_000_000);
    let lines = rig.commands(0);
    // The program is killed where the ball is (SK, at DE), then (enabled, as every
    // run's first move is) the feed to the show's start: never DI0 (home).
    assert_eq!(
        lines[..7],
        [
            "SK", "ME", "VE5.0000", "AC20.000", "DE20.000", "DI100", "FP"
        ]
    );
    assert!(!lines.iter().any(|line| line == "DI0"), "{lines:?}");
    assert!(!rig.sequencer.needs_home());
    assert_eq!(rig.sequencer.status().state, PlayerState::Idle);
    assert_eq!(rig.positions(), [500, 1_000, 1_500]);
}

mod live;

/// A smooth wave, ±`amplitude_mm` around 1 m every `period_s`, from rest, for
/// `periods` periods (rows of 200 ms).
fn wave_track(period_s: f64, periods: usize, amplitude_mm: f64) -> Track {
    let rows = (period_s * periods as f64 / 0.2).round() as usize;
    let omega = std::f64::consts::TAU / period_s;
    Track {
        start_mm: 1000.0 - amplitude_mm,
        rows: (1..=rows)
            .map(|row| {
                let t = row as f64 * 0.2;
                TrackRow::new(
                    1000.0 - amplitude_mm * (omega * t).cos(),
                    amplitude_mm * omega * (omega * t).sin(),
                    200,
                )
            })
            .collect(),
        colours: Vec::new(),
    }
}

#[test]
fn a_streamed_show_keeps_every_buffer_topped_up_and_follows_the_show() {
    // Issue 46, item 3: a show streamed into the command buffers (`PS`, the buffer
    // filled, `CT`; `BS` and the next lines as it plays), on three twins that refuse a
    // 64th buffered command.
    let mut rig = Rig::new();
    let config = rig.sequencer.drive().config().clone();
    let settings = QProgramConfig {
        counts_per_mm: COUNTS_PER_MM,
        start: None,
        ..QProgramConfig::default()
    };
    let tracks: Vec<Track> = (0..3)
        .map(|ball| wave_track(3.0 + ball as f64, 4, 300.0))
        .collect();
    let programs: Vec<_> = tracks
        .iter()
        .map(|track| crate::scl::qprogram::compile_streamed(track, &settings).unwrap())
        .collect();
    let longest = programs.iter().map(QProgram::lines).max().unwrap();
    assert!(
        longest > 62 * 12,
        "{longest} lines: more than a drive stores"
    );
    let duration_ms = tracks.iter().map(Track::duration_ms).max().unwrap();
    let run = Run {
        name: "waves".into(),
        duration_ms,
        timing: EntryTiming {
            delay_ms: 0,
            cycles: 1,
        },
        prepared: SclEntry::new(
            &config,
            tracks.iter().map(|track| track.start_mm),
            Some(programs),
            duration_ms,
        ),
    };
    let show = Show {
        name: "waves".into(),
        layout: Layout {
            rows: 1,
            cols: 3,
            pitch_mm: 500.0,
        },
        tracks: tracks.clone(),
        outputs: Vec::new(),
    };
    let mut sampler = crate::show::sample::Sampler::new(&show);
    let mut show_mm = [0.0_f32; 3];
    rig.sequencer.start(0, vec![run], false).unwrap();
    while rig.sequencer.status().state != PlayerState::Playing {
        let at_us = rig.now_us + 1_000;
        rig.run_until(at_us);
        assert!(rig.now_us < 30_000_000, "{:?}", rig.sequencer.status());
    }
    let started_us = rig.sequencer.drive().started_us().unwrap();
    // Every 10 ms the balls are where the show is, within 5 mm.
    let mut worst: f64 = 0.0;
    let mut fullest = 0;
    for step in 1..(duration_ms / 10) {
        rig.run_until(started_us + step * 10_000);
        for twin in &mut rig.twins {
            twin.advance(rig.now_us);
        }
        let t_ms = rig.now_us.saturating_sub(started_us) as f64 / 1_000.0;
        sampler.sample(t_ms, &mut show_mm, None);
        for (twin, show_mm) in rig.twins.iter().zip(show_mm) {
            let at_mm = twin.position_counts() / COUNTS_PER_MM;
            worst = worst.max((at_mm - f64::from(show_mm)).abs());
            fullest = fullest.max(63 - twin.buffer_free());
        }
    }
    rig.run_until(started_us + (duration_ms + 15_000) * 1_000);
    assert_eq!(
        rig.sequencer.status().state,
        PlayerState::Idle,
        "{:?}",
        rig.sequencer.status()
    );
    assert!(worst < 5.0, "{worst} mm");
    assert!(fullest <= 63);
    let lines = rig.commands(0);
    assert_eq!(lines.iter().filter(|line| *line == "PS").count(), 1);
    assert_eq!(lines.iter().filter(|line| *line == "CT").count(), 1);
    assert!(lines.iter().filter(|line| *line == "BS").count() > 10);
    assert!(
        !lines.iter().any(|line| line.starts_with('Q')),
        "no program: {lines:?}"
    );
    assert_eq!(rig.sequencer.drive().flash_writes(), [0, 0, 0]);
}

#[test]
fn a_line_too_slow_for_its_streams_is_refused_before_anything_is_sent() {
    // Three drives streaming on one RS-485 line at 9600 baud: it carries one.
    let live = SclLiveConfig {
        lines: vec![SclLine::Rs485 { baud: 9_600 }],
        max_speed_mm_s: 2_000.0,
        layout: Layout {
            rows: 1,
            cols: 3,
            pitch_mm: 500.0,
        },
    };
    let mut drive = SclDrive::new(config(None)).with_live(live);
    let config = drive.config().clone();
    let settings = QProgramConfig {
        counts_per_mm: COUNTS_PER_MM,
        start: None,
        tolerance_mm: 20.0,
        ..QProgramConfig::default()
    };
    let programs: Vec<_> = show()
        .tracks
        .iter()
        .map(|track| crate::scl::qprogram::compile_streamed(track, &settings).unwrap())
        .collect();
    let mut entry = SclEntry::new(&config, [0.0; 3], Some(programs), 1_000);
    drive.begin_play(0, &mut entry, true);
    let Phase::Failed(why) = drive.poll(0, None) else {
        panic!("not refused");
    };
    assert!(
        why.starts_with("SCL gateway 0 would stream the show to 3 drives; its line carries 1"),
        "{why}"
    );
    assert!(drive.take_asks().is_empty());
}
