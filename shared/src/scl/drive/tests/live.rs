//! Live mode on MOONS' drives by jogging ([`crate::scl::drive`]'s `live`), in
//! simulated time against three drive twins on one RS-485 line whose timing is
//! modelled: each request goes when the one before was answered, its bytes and its
//! answer's at the line's baud, with the turnaround counted. Every twin's true
//! position is checked every millisecond against the filtered motion (one period
//! later, as the drives run it), and its speed and acceleration against the
//! installation's limits.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::super::live::{FOLLOW_SPEED_SHARE, REST_TOLERANCE_COUNTS, TURNAROUND_US};
use super::*;
use crate::api::LivePhase;
use crate::codes::Coded;
use crate::line::Line;
use crate::player::{LiveInput, StartError};

const MAX_SPEED_MM_S: f64 = 1_500.0;
const BAUD: u32 = 115_200;

fn live_config(lines: Vec<SclLine>, balls: u32) -> SclLiveConfig {
    SclLiveConfig {
        lines,
        max_speed_mm_s: MAX_SPEED_MM_S,
        layout: Layout {
            rows: 1,
            cols: balls,
            pitch_mm: 500.0,
        },
    }
}

/// A request on its way: it reaches its drive at `deliver_us`, its answer is back at
/// `answer_us`.
struct InFlight {
    ask: SclAsk,
    deliver_us: u64,
    answer_us: u64,
    answer: Option<String>,
}

/// The sequencer, three twins on one timed line, and what was seen.
struct LiveRig {
    sequencer: Sequencer<SclDrive>,
    twins: Vec<twin::Drive>,
    now_us: u64,
    line: Line,
    /// eSCL: each drive its own datagrams (a request and its answer: 1 ms).
    escl: bool,
    /// When each line (or eSCL drive) is free.
    line_free_us: Vec<u64>,
    /// The most requests a lane held waiting to go.
    longest_queue: usize,
    /// Requests starting so the twins refuse (`?5`).
    refused: Option<&'static str>,
    flight: Vec<InFlight>,
    sent: Vec<Vec<String>>,
    /// Largest |twin − filtered (one period later)| while following, mm.
    largest_error_mm: f64,
    /// Largest speed, mm/s, and acceleration, mm/s², of any twin.
    fastest_mm_s: f64,
    hardest_mm_s2: f64,
    last_velocity: Vec<f64>,
    /// Every live phase seen, in order.
    phases: Vec<Option<LivePhase>>,
    /// The bridge is busy (a stall under load): the line and the drives go on, the
    /// sequencer is not polled.
    stalled: bool,
}

impl LiveRig {
    fn new() -> Self {
        Self::on(SclLine::Rs485 { baud: BAUD })
    }

    fn on(line: SclLine) -> Self {
        let drive = SclDrive::new(config(None)).with_live(live_config(vec![line], 3));
        Self {
            sequencer: Sequencer::new(drive),
            twins: (0..3)
                .map(|_| twin::Drive::new(DriveConfig::default()))
                .collect(),
            now_us: 0,
            line: Line::new(match line {
                SclLine::Rs485 { baud } => baud,
                SclLine::Escl => BAUD,
            }),
            escl: line == SclLine::Escl,
            line_free_us: vec![0; 3],
            longest_queue: 0,
            refused: None,
            flight: Vec::new(),
            sent: vec![Vec::new(); 3],
            largest_error_mm: 0.0,
            fastest_mm_s: 0.0,
            hardest_mm_s2: 0.0,
            last_velocity: vec![0.0; 3],
            phases: Vec::new(),
            stalled: false,
        }
    }

    fn input(&mut self, targets_mm: &[f64], lost: bool) {
        let targets: Vec<Option<f64>> = targets_mm.iter().copied().map(Some).collect();
        self.sequencer.set_live_input(LiveInput {
            targets_mm: &targets,
            lost,
            ..LiveInput::default()
        });
    }

    /// One millisecond: the line's deliveries and answers due, the sequencer's poll,
    /// the twins' motion checked.
    fn tick(&mut self) {
        self.now_us += 1_000;
        let now_us = self.now_us;
        // Deliveries due: the twin acts at the delivery's time.
        let mut due: Vec<usize> = (0..self.flight.len())
            .filter(|&i| self.flight[i].answer.is_none() && self.flight[i].deliver_us <= now_us)
            .collect();
        due.sort_by_key(|&i| self.flight[i].deliver_us);
        for i in due {
            let flight = &mut self.flight[i];
            let twin = &mut self.twins[flight.ask.drive];
            twin.advance(flight.deliver_us);
            self.sent[flight.ask.drive].push(flight.ask.text.clone());
            let answer = twin
                .receive_line(&flight.ask.text, flight.deliver_us)
                .unwrap_or_default();
            let refused = self
                .refused
                .is_some_and(|refused| flight.ask.text.starts_with(refused));
            let answer = if refused { "?5".to_owned() } else { answer };
            if !self.escl {
                // The answer's bytes with the address before each line.
                let bytes = answer.len() + answer.matches('\r').count();
                flight.answer_us = flight.deliver_us + TURNAROUND_US + self.line.time_us(bytes);
                let line = flight.ask.gateway;
                self.line_free_us[line] = self.line_free_us[line].max(flight.answer_us);
            }
            flight.answer = Some(answer);
        }
        for twin in &mut self.twins {
            twin.advance(now_us);
        }
        // Answers back.
        let mut answered = Vec::new();
        self.flight.retain(|flight| {
            if flight.answer.is_some() && flight.answer_us <= now_us {
                answered.push((
                    flight.ask.id,
                    flight.deliver_us,
                    flight.answer.clone().unwrap_or_default(),
                ));
                false
            } else {
                true
            }
        });
        for (id, deliver_us, answer) in answered {
            let drive = self.sequencer.drive_mut();
            drive.delivered(id, deliver_us);
            drive.answer(now_us, id, Ok(lines_of(&answer)));
        }
        if !self.stalled {
            self.sequencer.poll(now_us);
            self.send();
        }
        self.watch();
    }

    /// The requests asked go on the line one after the other.
    fn send(&mut self) {
        for ask in self.sequencer.drive_mut().take_asks() {
            let line = if self.escl { ask.drive } else { ask.gateway };
            let start_us = self.line_free_us[line].max(self.now_us);
            let (deliver_us, answer_us) = if self.escl {
                (start_us + 300, start_us + 1_000)
            } else {
                // The address and CR; the answer's time when it is known.
                let deliver_us = start_us + self.line.time_us(ask.text.len() + 2);
                (deliver_us, deliver_us)
            };
            self.line_free_us[line] = answer_us;
            self.flight.push(InFlight {
                ask,
                deliver_us,
                answer_us,
                answer: None,
            });
        }
    }

    fn watch(&mut self) {
        let status = self.sequencer.status();
        let phase = status.live.as_ref().map(|live| live.phase);
        if phase == Some(LivePhase::Following) {
            let queued = self.sequencer.drive().stages.front().map_or(0, |stage| {
                stage
                    .iter()
                    .map(|lane| lane.actions.len())
                    .max()
                    .unwrap_or(0)
            });
            self.longest_queue = self.longest_queue.max(queued);
        }
        if self.phases.last() != Some(&phase) {
            self.phases.push(phase);
        }
        for (unit, twin) in self.twins.iter().enumerate() {
            let velocity = twin.velocity_counts_s() / COUNTS_PER_MM;
            self.fastest_mm_s = self.fastest_mm_s.max(velocity.abs());
            let accel = (velocity - self.last_velocity[unit]).abs() / 1e-3;
            self.hardest_mm_s2 = self.hardest_mm_s2.max(accel);
            self.last_velocity[unit] = velocity;
            // Against the motion as jogged (squeezed inside the ends) while it moves;
            // at rest a drive is fed to its exact count instead, which the tests of
            // the rests check on their own.
            if phase == Some(LivePhase::Following)
                && let Some(run) = self.sequencer.drive().live.as_ref()
                && run.units.get(unit).is_some_and(|state| {
                    [state.prev, state.from, state.to]
                        .iter()
                        .any(|state| state.velocity_mm_s != 0.0)
                })
                && let Some(reference) = run.reference_mm(unit, self.now_us)
            {
                let error = (twin.position_counts() / COUNTS_PER_MM - reference).abs();
                self.largest_error_mm = self.largest_error_mm.max(error);
            }
        }
    }

    fn run_for(&mut self, us: u64, mut input: impl FnMut(u64) -> Option<Vec<f64>>) {
        let until_us = self.now_us + us;
        while self.now_us < until_us {
            if let Some(targets) = input(self.now_us) {
                self.input(&targets, false);
            }
            self.tick();
        }
    }

    fn phase(&self) -> Option<LivePhase> {
        self.sequencer.status().live.map(|live| live.phase)
    }

    fn twin_mm(&self) -> Vec<f64> {
        self.twins
            .iter()
            .map(|twin| twin.position_counts() / COUNTS_PER_MM)
            .collect()
    }

    fn within_limits(&self) {
        let config = config(None);
        assert!(
            self.fastest_mm_s <= MAX_SPEED_MM_S * (1.0 + 1e-9),
            "speed {} mm/s",
            self.fastest_mm_s
        );
        assert!(
            self.hardest_mm_s2 <= config.max_accel_mm_s2 * (1.0 + 1e-6),
            "acceleration {} mm/s²",
            self.hardest_mm_s2
        );
    }

    /// Live mode from rest, input at `start_mm`, until the balls follow.
    fn go_live(&mut self, start_mm: &[f64]) {
        self.input(start_mm, false);
        self.sequencer.go_live(self.now_us).unwrap();
        self.send();
        for _ in 0..20_000 {
            if self.phase() == Some(LivePhase::Following) {
                return;
            }
            self.tick();
        }
        panic!("never following: {:?}", self.phases);
    }
}

/// A triangle between 500 and 2500 mm at `speed` mm/s, each ball `shift_s` later.
fn ramp(t_s: f64, speed: f64, ball: usize) -> f64 {
    let span = 2_000.0;
    let period = 2.0 * span / speed;
    let phase = (t_s + ball as f64 * 0.3).rem_euclid(period) * speed;
    500.0
        + if phase < span {
            phase
        } else {
            2.0 * span - phase
        }
}

/// Live mode from unknown positions on `line`, then a ramp for 6 s: the largest
/// error, the period and the latency.
fn follow_a_ramp(line: SclLine) -> LiveRig {
    let mut rig = LiveRig::on(line);
    let setup = crate::player::Drive::live_setup(rig.sequencer.drive()).unwrap();
    let status_period_ms = setup.period_us() / 1_000;
    rig.go_live(&[500.0, 900.0, 1_300.0]);
    assert_eq!(
        rig.phases,
        [
            Some(LivePhase::Homing),
            Some(LivePhase::Preparing),
            Some(LivePhase::Approaching),
            Some(LivePhase::Following)
        ],
        "homed first (the positions were unknown)"
    );
    // The jog's ramps at the installation's acceleration (20 rev/s², as held), and
    // the smallest `JS` for the first `CJ`.
    assert!(
        rig.sent[0].contains(&"JA20.000".to_owned()),
        "{:?}",
        rig.sent[0]
    );
    assert!(rig.sent[0].contains(&"JL20.000".to_owned()));
    assert!(rig.sent[0].contains(&"JS0.0042".to_owned()));
    let start_us = rig.now_us;
    rig.largest_error_mm = 0.0;
    rig.run_for(6_000_000, |now_us| {
        let t_s = (now_us - start_us) as f64 / 1e6;
        Some((0..3).map(|ball| ramp(t_s, 800.0, ball)).collect())
    });
    let status = rig.sequencer.status();
    let live = status.live.unwrap();
    assert_eq!(u64::from(live.period_ms), status_period_ms);
    println!(
        "ramp at 800 mm/s, {line:?}, 3 drives, period {} ms, latency {} ms: largest \
         error {:.2} mm; fastest {:.0} mm/s, hardest {:.0} mm/s²; longest queue {}",
        live.period_ms,
        live.latency_ms,
        rig.largest_error_mm,
        rig.fastest_mm_s,
        rig.hardest_mm_s2,
        rig.longest_queue
    );
    rig.within_limits();
    // Jogged: speeds changed while jogging, turned round at the ramp's ends.
    let sent = &rig.sent[0];
    assert!(sent.iter().any(|line| line.starts_with("CS")));
    assert!(sent.iter().any(|line| line == "SJ"));
    // Turned round by the sign of CS (HCR p. 71: the sign is the direction), never
    // a CS while not jogging (the twin refuses it, `?7`).
    assert!(sent.iter().any(|line| line.starts_with("CS-")));
    assert!(
        sent.iter()
            .any(|line| line.starts_with("CS") && !line.starts_with("CS-"))
    );
    assert!(!sent.iter().any(|line| line.starts_with('?')));
    rig
}

#[test]
fn live_homes_approaches_and_follows_a_ramp_within_the_limits_on_jogging_drives() {
    // The largest error includes the start from a rest: a drive at rest stands on its
    // exact count, the motion it jogs is squeezed inside the ends (`END_MARGIN_MM`
    // at each end, 2·margin·(1 − 2·p/travel) off at p), and it catches that up.
    let rig = follow_a_ramp(SclLine::Rs485 { baud: BAUD });
    assert!(rig.largest_error_mm < 2.5, "{} mm", rig.largest_error_mm);
    // The line keeps up: no lane ever holds more than a period's requests at most
    // (every drive turning round, and a read).
    assert!(rig.longest_queue <= 3 * 4 + 1, "{}", rig.longest_queue);
    let rig = follow_a_ramp(SclLine::Escl);
    assert!(rig.largest_error_mm < 2.0, "{} mm", rig.largest_error_mm);
    assert!(rig.longest_queue <= 4 + 1, "{}", rig.longest_queue);
    let rig = follow_a_ramp(SclLine::Rs485 { baud: 9_600 });
    assert!(rig.largest_error_mm < 40.0, "{} mm", rig.largest_error_mm);
    assert!(rig.longest_queue <= 3 * 4 + 1, "{}", rig.longest_queue);
}

/// A drive that refuses a speed fails live mode, naming the drive: the sequencer
/// stops and asks for the e-stop.
#[test]
fn a_refused_speed_stops_live_mode_naming_the_drive() {
    let mut rig = LiveRig::new();
    rig.go_live(&[300.0, 300.0, 300.0]);
    rig.refused = Some("CS");
    rig.run_for(2_000_000, |_| Some(vec![2_000.0, 2_000.0, 2_000.0]));
    assert!(!rig.sequencer.is_live());
    assert_eq!(rig.sequencer.status().state, PlayerState::Error);
    let error = rig.sequencer.status().last_error.unwrap_or_default();
    assert!(
        error.contains("drive \"1\"") && error.contains("CS"),
        "{error}"
    );
    assert!(rig.sequencer.take_estop());
}

#[test]
fn a_step_far_beyond_the_speed_limit_is_followed_within_the_limits_then_held_and_left() {
    let mut rig = LiveRig::new();
    rig.go_live(&[200.0, 200.0, 200.0]);
    rig.largest_error_mm = 0.0;
    // A snap from 200 to 2800 mm: the fastest move the installation allows.
    rig.run_for(3_000_000, |_| Some(vec![2_800.0, 2_800.0, 2_800.0]));
    println!(
        "step 200 → 2800 mm: largest error {:.2} mm, fastest {:.0} mm/s",
        rig.largest_error_mm, rig.fastest_mm_s
    );
    assert!(rig.largest_error_mm < 1.0, "{} mm", rig.largest_error_mm);
    assert!(
        rig.fastest_mm_s > 0.99 * FOLLOW_SPEED_SHARE * MAX_SPEED_MM_S,
        "went at the filter's top speed"
    );
    rig.within_limits();
    for mm in rig.twin_mm() {
        println!("at rest after the step: {:.3} mm off", mm - 2_800.0);
        assert!((mm - 2_800.0).abs() < 1.5, "{mm}");
    }
    // Input lost while moving: every ball brakes within the limits and stays.
    rig.run_for(300_000, |_| Some(vec![500.0, 500.0, 500.0]));
    rig.input(&[500.0; 3], true);
    rig.run_for(2_000_000, |_| None);
    assert_eq!(rig.phase(), Some(LivePhase::Holding));
    let held = rig.twin_mm();
    assert!(rig.twins.iter().all(|twin| !twin.is_moving()), "at rest");
    let filtered: Vec<f64> = rig
        .sequencer
        .live_states()
        .iter()
        .map(|state| state.position_mm)
        .collect();
    for (mm, filtered) in held.iter().zip(&filtered) {
        assert!((mm - filtered).abs() < 3.0, "{mm} vs {filtered}");
        assert!(*mm > 500.0 + 100.0, "braked, not at the target: {mm}");
    }
    rig.run_for(1_000_000, |_| None);
    assert_eq!(rig.twin_mm(), held, "held still");
    rig.within_limits();
    // Leave: rest with the positions known, each drive fed to the exact count.
    rig.sequencer.leave_live(rig.now_us);
    for _ in 0..3_000 {
        rig.tick();
    }
    assert!(rig.sequencer.is_idle() && !rig.sequencer.is_live());
    let known = crate::player::Drive::rest_positions_mm(rig.sequencer.drive()).unwrap();
    for (twin, mm) in rig.twins.iter().zip(&known) {
        assert!(!twin.is_moving());
        assert_eq!(
            twin.position_integer(),
            (mm * COUNTS_PER_MM).round() as i64,
            "at the exact count"
        );
    }
    assert!(rig.sent[0].last().is_some_and(|line| line == "IP"));
    assert!(rig.sent[0].iter().any(|line| line == "FP"));
    rig.within_limits();
    // The drives disabled meanwhile (`MD`, as at a schedule window's end), then live
    // again: from there, without homing, enabled first.
    for twin in &mut rig.twins {
        twin.receive_line("MD", rig.now_us);
    }
    rig.sent.iter_mut().for_each(Vec::clear);
    rig.phases.clear();
    rig.go_live(&[1_000.0, 1_000.0, 1_000.0]);
    assert!(
        !rig.phases.contains(&Some(LivePhase::Homing)),
        "{:?}",
        rig.phases
    );
    assert_eq!(rig.sent[0].first().map(String::as_str), Some("ME"));
    rig.run_for(2_000_000, |_| Some(vec![1_000.0, 1_000.0, 1_000.0]));
    for mm in rig.twin_mm() {
        assert!((mm - 1_000.0).abs() < 1.5, "{mm}");
    }
}

#[test]
fn an_estop_stops_the_jogging_drives_and_the_next_live_homes_first() {
    let mut rig = LiveRig::new();
    rig.go_live(&[300.0, 300.0, 300.0]);
    rig.run_for(400_000, |_| Some(vec![2_500.0, 2_000.0, 1_500.0]));
    assert!(rig.twins.iter().all(twin::Drive::is_moving));
    // The port's SK to every drive, ahead of everything; the sequencer stops.
    for twin in &mut rig.twins {
        twin.receive_line("SK", rig.now_us);
    }
    rig.sequencer.estop();
    assert!(!rig.sequencer.is_live());
    // Live input goes on arriving: nothing moves, nothing is asked.
    rig.run_for(1_000_000, |_| Some(vec![100.0, 100.0, 100.0]));
    assert!(rig.twins.iter().all(|twin| !twin.is_moving()), "stopped");
    assert!(rig.sequencer.drive_mut().take_asks().is_empty() && rig.flight.is_empty());
    assert_eq!(rig.sequencer.status().state, PlayerState::Stopped);
    rig.within_limits();
    // The next live request homes first.
    rig.phases.clear();
    rig.go_live(&[100.0, 100.0, 100.0]);
    assert!(
        rig.phases.contains(&Some(LivePhase::Homing)),
        "{:?}",
        rig.phases
    );
}

#[test]
fn a_line_too_slow_for_its_drives_is_refused_and_nothing_is_asked() {
    let mut config = config(None);
    config.units = (0..16)
        .map(|drive| DriveSlot {
            gateway: 0,
            drive,
            name: format!("drive {drive}"),
        })
        .collect();
    let mut sequencer = Sequencer::new(
        SclDrive::new(config).with_live(live_config(vec![SclLine::Rs485 { baud: 9_600 }], 16)),
    );
    let refused = sequencer.go_live(0);
    let Err(StartError::LiveLineTooSlow {
        gateway: 0,
        units: 16,
        row_ms,
        max_ms: 255,
    }) = refused
    else {
        panic!("{refused:?}");
    };
    assert!(row_ms > 255);
    assert_eq!(
        refused.unwrap_err().code(),
        crate::codes::Code::LiveLineTooSlow
    );
    assert!(sequencer.is_idle() && !sequencer.is_live());
    assert!(sequencer.drive_mut().take_asks().is_empty());
    // Without the lines' settings live mode is refused as unsupported.
    let mut sequencer = Sequencer::new(SclDrive::new(super::config(None)));
    assert!(matches!(
        sequencer.go_live(0),
        Err(StartError::LiveUnsupported { .. })
    ));
    assert!(sequencer.drive_mut().take_asks().is_empty());
}

/// The figures `docs/live.md` gives: the period and latency per line and drive count.
#[test]
fn the_live_period_is_what_the_line_carries() {
    let figures = |line: SclLine, drives: usize| {
        let mut config = config(None);
        config.units = (0..drives)
            .map(|drive| DriveSlot {
                gateway: 0,
                drive,
                name: format!("drive {drive}"),
            })
            .collect();
        let drive = SclDrive::new(config).with_live(live_config(vec![line], drives as u32));
        crate::player::Drive::live_setup(&drive)
            .map(|setup| (setup.period_us() / 1_000, setup.latency_us.div_ceil(1_000)))
    };
    for (line, drives) in [
        (SclLine::Rs485 { baud: 9_600 }, 1),
        (SclLine::Rs485 { baud: 9_600 }, 4),
        (SclLine::Rs485 { baud: 9_600 }, 10),
        (SclLine::Rs485 { baud: 9_600 }, 13),
        (SclLine::Rs485 { baud: 115_200 }, 1),
        (SclLine::Rs485 { baud: 115_200 }, 4),
        (SclLine::Rs485 { baud: 115_200 }, 10),
        (SclLine::Rs485 { baud: 115_200 }, 32),
        (SclLine::Rs485 { baud: 115_200 }, 100),
        (SclLine::Escl, 100),
    ] {
        println!("{line:?} × {drives}: {:?}", figures(line, drives));
    }
    for baud in [9_600, 19_200, 38_400, 57_600, 115_200] {
        let most = (1..200)
            .take_while(|&drives| figures(SclLine::Rs485 { baud }, drives).is_ok())
            .last();
        println!("{baud} baud: at most {most:?} drives");
    }
    assert_eq!(figures(SclLine::Rs485 { baud: 115_200 }, 1), Ok((10, 30)));
    assert!(figures(SclLine::Rs485 { baud: 9_600 }, 14).is_err());
    // Two lines: the slower sets the period for all; the refusal names its gateway.
    let mut config = config(None);
    config.gateways = 2;
    config.units = (0..8)
        .map(|unit| DriveSlot {
            gateway: unit / 4,
            drive: unit % 4,
            name: format!("drive {unit}"),
        })
        .collect();
    let two = |lines: Vec<SclLine>| {
        let drive = SclDrive::new(config.clone()).with_live(live_config(lines, 8));
        crate::player::Drive::live_setup(&drive).map(|setup| setup.period_us() / 1_000)
    };
    assert_eq!(
        two(vec![SclLine::Escl, SclLine::Rs485 { baud: 9_600 }]),
        figures(SclLine::Rs485 { baud: 9_600 }, 4).map(|(period_ms, _)| period_ms)
    );
    assert!(matches!(
        two(vec![SclLine::Escl, SclLine::Rs485 { baud: 1_200 }]),
        Err(StartError::LiveLineTooSlow {
            gateway: 1,
            units: 4,
            ..
        })
    ));
    assert_eq!(figures(SclLine::Escl, 100), Ok((10, 30)));
    let (period_ms, _) = figures(SclLine::Rs485 { baud: 9_600 }, 4).unwrap();
    assert!(period_ms > 50, "{period_ms}");
}

/// Snapped to either end of the travel (issue 47): no twin passes either end, to the
/// count, on its way or at rest, and each comes to rest exactly on the end's count
/// (the jog runs inside the ends by the margin, the rest feed does the last of it).
#[test]
fn snaps_to_the_ends_of_the_travel_stay_within_it_and_reach_them() {
    for line in [SclLine::Escl, SclLine::Rs485 { baud: BAUD }] {
        let mut rig = LiveRig::on(line);
        rig.go_live(&[1_500.0, 1_500.0, 1_500.0]);
        let mut lowest = f64::MAX;
        let mut highest = f64::MIN;
        for end in [0.0, 3_000.0, 0.0, 3_000.0] {
            for _ in 0..3_500 {
                rig.input(&[end; 3], false);
                rig.tick();
                for twin in &rig.twins {
                    lowest = lowest.min(twin.position_counts());
                    highest = highest.max(twin.position_counts());
                }
            }
            for (unit, twin) in rig.twins.iter().enumerate() {
                assert_eq!(
                    twin.position_counts(),
                    end * COUNTS_PER_MM,
                    "{line:?}: ball {unit} at rest off the end {end} mm"
                );
            }
        }
        let limits = config(None);
        println!(
            "{line:?}: travel 0–3000 mm: the twins went from {lowest:.1} to {highest:.1} \
             counts; at the ball (every ms): peak speed {:.0} mm/s ({:.1} % of \
             {MAX_SPEED_MM_S}), peak acceleration {:.0} mm/s² ({:.1} % of {})",
            rig.fastest_mm_s,
            100.0 * rig.fastest_mm_s / MAX_SPEED_MM_S,
            rig.hardest_mm_s2,
            100.0 * rig.hardest_mm_s2 / limits.max_accel_mm_s2,
            limits.max_accel_mm_s2
        );
        rig.within_limits();
        assert!(
            lowest >= -0.5 && highest <= 3_000.0 * COUNTS_PER_MM + 0.5,
            "{line:?}: past an end: {lowest} {highest} counts"
        );
    }
}

/// The bridge stalls under load while the drives ramp down to a stop (their `SJ`
/// and the slower speeds come late, and they jog on past the filter): once the
/// filter rests, each drive is fed to the exact count — jogging holds no position,
/// and a ball would otherwise stay off until the input moves again.
#[test]
fn a_stall_while_stopping_is_made_good_at_rest() {
    for line in [SclLine::Escl, SclLine::Rs485 { baud: BAUD }] {
        let mut worst = (0.0f64, 0, 0);
        for stall_ms in [60u64, 250] {
            for at_ms in (0..400).step_by(40) {
                let mut rig = LiveRig::on(line);
                rig.go_live(&[200.0, 200.0, 200.0]);
                rig.run_for(300_000, |_| Some(vec![200.0; 3]));
                rig.run_for(at_ms * 1000 + 1000, |_| Some(vec![262.5; 3]));
                rig.stalled = true;
                rig.run_for(stall_ms * 1000, |_| Some(vec![262.5; 3]));
                rig.stalled = false;
                rig.run_for(1_500_000, |_| Some(vec![262.5; 3]));
                let off = rig
                    .twin_mm()
                    .iter()
                    .map(|mm| (mm - 262.5).abs())
                    .fold(0.0, f64::max);
                if off > worst.0 {
                    worst = (off, stall_ms, at_ms);
                }
                assert_eq!(rig.phase(), Some(LivePhase::Following));
                rig.within_limits();
            }
        }
        println!(
            "{line:?}: at rest at most {:.2} mm off (a stall of {} ms {} ms into the step)",
            worst.0, worst.1, worst.2
        );
        assert!(
            worst.0 * COUNTS_PER_MM < REST_TOLERANCE_COUNTS,
            "{line:?}: {worst:?}"
        );
    }
}
