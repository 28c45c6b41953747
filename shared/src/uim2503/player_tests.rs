//! The player against simulated gateways, in virtual time: a small stand-in for the
//! bridge that paces every byte at baud / 10 in both directions, hands instructions to
//! [`crate::uim2503::sim::Gateway`]s when their last byte has crossed, decodes the answers and
//! feeds them back — the player sees what it would see on a real line.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use std::collections::VecDeque;

use super::plan::tests::wave;
use super::player::{Command, Entry, LinkView, Player, PlayerConfig, StartError, prepare};
use crate::api::PlayerState;
use crate::plan::Installation;
use crate::show::{Sampler, Show};
use crate::uim2503::ascii::{Batch, Form, parse_script};
use crate::uim2503::feedback::FrameDecoder;
use crate::uim2503::sim::{Gateway, GatewayConfig};

const STEP_US: u64 = 1_000;

/// One gateway behind a virtual line.
struct Line {
    gateway: Gateway,
    baud: u32,
    bulk: VecDeque<Vec<u8>>,
    /// Instructions and the instant (µs) before which they are not written.
    priority: VecDeque<(u64, Vec<u8>)>,
    line_free_us: u64,
    in_flight: VecDeque<(u64, Vec<u8>)>,
    answers: VecDeque<(u64, u8)>,
    answers_free_us: u64,
    decoder: FrameDecoder,
    /// The station the bulk lane last selected, restored after a priority write.
    bulk_selection: Option<Vec<u8>>,
    reselect: bool,
    /// Feedback decoded while the bridge was stalled, handed to the player after.
    stalled: Vec<crate::uim2503::feedback::Frame>,
    /// Every instruction written, in order: when it began to cross the line (µs) and its
    /// bytes — what the golden wire test pins.
    wire: Vec<(u64, Vec<u8>)>,
}

impl Line {
    fn byte_us(&self) -> u64 {
        crate::line::Line::new(self.baud).time_us(1)
    }

    fn queued_bytes(&self) -> usize {
        self.bulk.iter().map(Vec::len).sum()
    }

    fn push(&mut self, lane: Lane, batch: &Batch) {
        match lane {
            Lane::Bulk => self.bulk.extend(batch.instructions().map(<[u8]>::to_vec)),
            Lane::Priority { at_us } => self
                .priority
                .extend(batch.instructions().map(|bytes| (at_us, bytes.to_vec()))),
        }
    }
}

#[derive(Clone, Copy)]
enum Lane {
    Bulk,
    /// Written first, not before `at_us`.
    Priority {
        at_us: u64,
    },
}

/// The stand-in bridge.
struct Rig {
    estop: Batch,
    now_us: u64,
    lines: Vec<Line>,
    player: Player,
    installation: Installation,
    states: Vec<(u64, PlayerState)>,
}

fn installation(rows: u32, cols: u32, bauds: &[u32]) -> Installation {
    let mut installation = Installation::demo(rows, cols, bauds).unwrap();
    installation.approach_speed_mm_s = 1500.0;
    installation
}

impl Rig {
    fn new(installation: Installation) -> Self {
        let lines = (0..installation.gateways.len())
            .map(|gateway| {
                let stations: Vec<u8> = installation
                    .units_on(gateway)
                    .map(|unit| installation.units[unit].station)
                    .collect();
                let mut config = GatewayConfig::numbered(1);
                config.stations = stations;
                config.seed = gateway as u64;
                config.max_accel_mm_s2 = installation.limits.max_accel_mm_s2;
                config.max_speed_mm_s = installation.limits.max_speed_mm_s;
                config.travel_mm = installation.limits.travel_mm;
                config.counts_per_mm = installation.counts_per_mm;
                Line {
                    gateway: Gateway::new(config).unwrap(),
                    baud: installation.gateways[gateway].baud,
                    bulk: VecDeque::new(),
                    priority: VecDeque::new(),
                    line_free_us: 0,
                    in_flight: VecDeque::new(),
                    answers: VecDeque::new(),
                    answers_free_us: 0,
                    decoder: FrameDecoder::new(),
                    bulk_selection: None,
                    reselect: false,
                    stalled: Vec::new(),
                    wire: Vec::new(),
                }
            })
            .collect();
        let estop = Batch::encode(&parse_script("*0;MO=0;").unwrap(), Form::Standard).unwrap();
        let player = Player::new(PlayerConfig {
            installation: installation.clone(),
        });
        Self {
            estop,
            now_us: 0,
            lines,
            player,
            installation,
            states: Vec::new(),
        }
    }

    fn links(&self) -> Vec<LinkView> {
        self.lines
            .iter()
            .map(|line| LinkView {
                up: true,
                queued_bytes: line.queued_bytes(),
            })
            .collect()
    }

    fn carry_out(&mut self) {
        for command in self.player.take_commands() {
            match command {
                Command::Bulk { gateway, batch } => self.lines[gateway].push(Lane::Bulk, &batch),
                Command::Priority {
                    gateway,
                    batch,
                    at_us,
                } => {
                    self.lines[gateway].push(Lane::Priority { at_us }, &batch);
                }
                Command::Estop => self.send_stop(),
            }
        }
    }

    /// The bridge's e-stop path: every line drops its bulk and writes the stop first.
    fn send_stop(&mut self) {
        let estop = self.estop.clone();
        for line in &mut self.lines {
            line.bulk.clear();
            line.priority.clear();
            line.push(Lane::Priority { at_us: 0 }, &estop);
        }
    }

    /// The operator's e-stop: the stop on every line, then the player is told.
    fn estop(&mut self) {
        self.send_stop();
        self.player.estop();
        self.carry_out();
    }

    /// One step of virtual time: the lines move bytes, the gateways run, answers come
    /// back, the player is polled.
    fn step(&mut self) {
        self.step_polled(true);
    }

    /// One step of virtual time; `polled: false`: the bridge is busy (a stall under
    /// load) — the lines and the units go on, the player is neither told nor polled.
    fn step_polled(&mut self, polled: bool) {
        let end = self.now_us + STEP_US;
        for (index, line) in self.lines.iter_mut().enumerate() {
            // Writer: one instruction at a time, priority first, as the bridge's link; a
            // start held for its instant keeps the line free until then.
            while line.line_free_us <= end {
                let mut start = line.line_free_us.max(self.now_us);
                let next = if let Some(&(at_us, _)) = line.priority.front() {
                    if at_us > end {
                        break;
                    }
                    start = start.max(at_us);
                    let Some((_, next)) = line.priority.pop_front() else {
                        break;
                    };
                    if next.first() == Some(&b'*') {
                        line.reselect = true;
                    }
                    next
                } else if line.reselect
                    && line
                        .bulk
                        .front()
                        .is_some_and(|next| next.first() != Some(&b'*'))
                    && line.bulk_selection.is_some()
                {
                    line.reselect = false;
                    line.bulk_selection.clone().unwrap_or_default()
                } else if let Some(next) = line.bulk.pop_front() {
                    if next.first() == Some(&b'*') {
                        line.bulk_selection = Some(next.clone());
                        line.reselect = false;
                    }
                    next
                } else {
                    break;
                };
                line.line_free_us = start + line.byte_us() * next.len() as u64;
                line.wire.push((start, next.clone()));
                line.in_flight.push_back((line.line_free_us, next));
            }
            while line.in_flight.front().is_some_and(|(at, _)| *at <= end) {
                let (at, bytes) = line.in_flight.pop_front().unwrap();
                line.gateway.receive(at, &bytes);
            }
            line.gateway.advance(end);
            let mut out = Vec::new();
            line.gateway.poll_output(&mut out);
            for byte in out {
                let start = line.answers_free_us.max(self.now_us);
                line.answers_free_us = start + line.byte_us();
                line.answers.push_back((line.answers_free_us, byte));
            }
            let mut arrived = Vec::new();
            while line.answers.front().is_some_and(|(at, _)| *at <= end) {
                arrived.push(line.answers.pop_front().unwrap().1);
            }
            let frames: Vec<_> = line.decoder.push(&arrived).collect();
            if polled {
                for frame in line.stalled.drain(..).chain(frames) {
                    self.player.handle_feedback(end, index, &frame);
                }
            } else {
                line.stalled.extend(frames);
            }
        }
        self.now_us = end;
        if !polled {
            return;
        }
        let links = self.links();
        self.player.poll(self.now_us, &links);
        self.carry_out();
        let state = self.player.status().state;
        if self.states.last().map(|(_, last)| *last) != Some(state) {
            self.states.push((self.now_us, state));
        }
    }

    fn run_until(&mut self, limit_us: u64, mut done: impl FnMut(&Rig) -> bool) {
        let deadline = self.now_us + limit_us;
        while !done(self) {
            assert!(
                self.now_us < deadline,
                "timed out in {:?}; states {:?}; last error {:?}",
                self.player.status().state,
                self.states,
                self.player.status().last_error
            );
            self.step();
        }
    }

    fn start(&mut self, entries: Vec<Entry>, loop_playlist: bool) -> Result<(), StartError> {
        let links = self.links();
        let result = self
            .player
            .start(self.now_us, entries, loop_playlist, &links);
        self.carry_out();
        result
    }

    fn state(&self) -> PlayerState {
        self.player.status().state
    }

    /// Every ball's true position, mm.
    fn positions_mm(&self) -> Vec<f64> {
        let cpm = self.installation.counts_per_mm;
        let mut positions = vec![0.0; self.installation.units.len()];
        for (gateway, line) in self.lines.iter().enumerate() {
            for (slot, unit) in self.installation.units_on(gateway).enumerate() {
                positions[unit] = line.gateway.unit(slot).unwrap().position_counts / cpm;
            }
        }
        positions
    }

    /// Asserts every ball is at home (within 0.01 mm).
    fn assert_homed(&self) {
        for position in self.positions_mm() {
            assert!(position.abs() < 0.01, "homed to {position}");
        }
    }

    fn anyone_moving(&self) -> bool {
        self.lines
            .iter()
            .any(|line| line.gateway.units().any(|unit| unit.moving))
    }
}

fn entry(show: Show, delay_ms: u64, cycles: u32) -> Entry {
    Entry {
        show,
        delay_ms,
        cycles,
    }
}

/// A rig of 1 × 2 units started on a playlist of two 12 s waves, "wave" then
/// "second" (each once, no delay); returns the rig, the second show and the playlist.
fn started_with_two_entries() -> (Rig, Show, Vec<Entry>) {
    let first = wave(1, 2, 60, 200);
    let mut second = wave(1, 2, 60, 200);
    second.name = "second".into();
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    let playlist = vec![entry(first, 0, 1), entry(second.clone(), 0, 1)];
    rig.start(playlist.clone(), false).unwrap();
    (rig, second, playlist)
}

/// Plays to `Playing` and checks every ball against the show every 100 ms until the
/// end; returns the largest deviation, mm.
fn follow(rig: &mut Rig, show: &Show) -> f64 {
    rig.run_until(120_000_000, |rig| rig.state() == PlayerState::Playing);
    let start_us = rig.now_us;
    compare_from(rig, show, start_us)
}

/// Steps until the show ends, comparing every ball with the show every 100 ms; the
/// player reached `Playing` at `start_us`. Returns the largest deviation, mm.
fn compare_from(rig: &mut Rig, show: &Show, start_us: u64) -> f64 {
    // The state turns `playing` when the units begin (`*0;BG;`, written at the
    // start's instant, through the line): the show's time 0 (issue 34, item 5).
    let begin_us = start_us;
    let mut sampler = Sampler::new(show);
    let mut expected = vec![0.0f32; show.tracks.len()];
    let mut worst: f64 = 0.0;
    let mut checks = 0;
    while rig.state() == PlayerState::Playing {
        rig.step();
        if !(rig.now_us - start_us).is_multiple_of(100_000) || rig.now_us < begin_us {
            continue;
        }
        let show_ms = (rig.now_us - begin_us) as f64 / 1000.0;
        if show_ms > show.duration_ms() as f64 {
            continue;
        }
        sampler.sample(show_ms, &mut expected, None);
        for (actual, expected) in rig.positions_mm().iter().zip(&expected) {
            worst = worst.max((actual - f64::from(*expected)).abs());
        }
        checks += 1;
    }
    assert!(checks > 10, "only {checks} samples were compared");
    worst
}

#[test]
fn a_show_plays_as_written_within_a_millimetre() {
    let show = wave(2, 3, 120, 200);
    let mut rig = Rig::new(installation(2, 3, &[115_200]));
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
    // The first start homes the balls (their positions are unknown), then approaches.
    let states: Vec<PlayerState> = rig.states.iter().map(|(_, state)| *state).collect();
    assert_eq!(
        &states[..5],
        [
            PlayerState::Homing,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Idle
        ]
    );
}

#[test]
fn a_long_show_streams_without_running_dry() {
    // 400 rows of 100 ms per ball: more than the table holds, streamed at 115200 baud.
    let show = wave(2, 5, 400, 100);
    let mut rig = Rig::new(installation(2, 5, &[115_200]));
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
    let lowest = rig.player.lowest_water_levels()[0].unwrap();
    assert!(lowest >= 2, "the FIFOs went down to {lowest} rows");
    // Every ball finished its track.
    let ends: Vec<f64> = show
        .tracks
        .iter()
        .map(|track| track.rows.last().unwrap().position_mm)
        .collect();
    for (actual, end) in rig.positions_mm().iter().zip(&ends) {
        assert!((actual - end).abs() < 0.01, "{actual} vs {end}");
    }
}

#[test]
fn an_infeasible_show_is_refused_with_numbers_before_anything_moves() {
    let show = wave(10, 10, 600, 250);
    let mut rig = Rig::new(installation(10, 10, &[9600]));
    let error = rig.start(vec![entry(show, 0, 1)], false).unwrap_err();
    let StartError::Infeasible { reason, fixes, .. } = &error else {
        panic!("expected an infeasible show, got {error}");
    };
    assert!(reason.to_string().contains("960 B/s"), "{reason}");
    assert!(!fixes.is_empty());
    assert!(rig.player.take_commands().is_empty(), "nothing may be sent");
    assert_eq!(rig.state(), PlayerState::Idle);
}

#[test]
fn an_infeasible_start_carries_its_reason_and_fixes_as_codes_beside_the_english() {
    use crate::codes::Coded;
    let show = wave(10, 10, 600, 250);
    let mut rig = Rig::new(installation(10, 10, &[9600]));
    let error = rig.start(vec![entry(show, 0, 1)], false).unwrap_err();
    let params = error.params();
    let reason = error.reason_problem().expect("a coded reason");
    assert!(
        reason.code == "line_starved" || reason.code == "line_starved_during",
        "{reason:?}"
    );
    assert_eq!(reason.params["available_bytes_per_s"], "960");
    assert_eq!(reason.params["baud"], "9600");
    assert!(params["reason"].contains("960 B/s"), "{params:?}");
    let fixes = error.fix_problems();
    assert_eq!(fixes.len(), error.fix_sentences().len());
    assert!(
        fixes.iter().any(|fix| fix.code == "fix_faster_line"),
        "{fixes:?}"
    );
    assert_eq!(params["fixes"], error.fix_sentences().join("; "));
}

#[test]
fn an_estop_stops_every_ball_within_one_instruction_and_start_homes_first() {
    let show = wave(2, 3, 200, 200);
    let mut rig = Rig::new(installation(2, 3, &[115_200]));
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    rig.run_until(3_000_000, |rig| {
        rig.now_us % 1_000_000 == 0 && rig.anyone_moving()
    });
    rig.estop();
    let stopped_at = rig.now_us;
    // One instruction already on the wire (≤ 20 bytes) plus the 8-byte stop.
    let bound_us = crate::line::Line::new(115_200).time_us(28) + STEP_US;
    rig.run_until(bound_us, |rig| !rig.anyone_moving());
    assert!(rig.now_us - stopped_at <= bound_us);
    assert_eq!(rig.state(), PlayerState::Stopped);
    let frozen = rig.positions_mm();
    rig.run_until(1_000_000, |rig| rig.now_us >= stopped_at + 1_000_000);
    assert_eq!(rig.positions_mm(), frozen, "nothing moves after an e-stop");

    // Start again: home first, then from the beginning.
    rig.states.clear();
    rig.start(vec![entry(show, 0, 1)], false).unwrap();
    assert_eq!(rig.state(), PlayerState::Homing);
    rig.run_until(30_000_000, |rig| rig.state() == PlayerState::Approaching);
    rig.assert_homed();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    assert_eq!(rig.player.status().entry, Some(0));
    assert!(rig.player.status().show_time_ms < 100);
}

#[test]
fn reset_stops_homes_and_restarts_from_the_first_entry() {
    let (mut rig, _, playlist) = started_with_two_entries();
    rig.run_until(60_000_000, |rig| {
        rig.player.status().entry == Some(1) && rig.state() == PlayerState::Playing
    });
    rig.states.clear();
    let links = rig.links();
    rig.send_stop();
    rig.player
        .reset(rig.now_us, playlist, false, &links)
        .unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Homing);
    // Homing shows its own progress, not the stopped show's time.
    let homing = rig.player.status();
    assert_eq!(
        (homing.entry, homing.show.as_deref(), homing.show_time_ms),
        (None, None, 0)
    );
    assert_eq!((homing.show_duration_ms, homing.cycle), (0, 0));
    rig.run_until(30_000_000, |rig| {
        let status = rig.player.status();
        status.state != PlayerState::Homing || status.progress > 0.3
    });
    let halfway = rig.player.status();
    assert_eq!(halfway.state, PlayerState::Homing);
    assert!(halfway.progress < 1.0, "{halfway:?}");
    assert_eq!((halfway.show, halfway.show_time_ms), (None, 0));
    rig.run_until(30_000_000, |rig| rig.state() == PlayerState::Approaching);
    rig.assert_homed();
    assert_eq!(rig.player.status().show_time_ms, 0, "no stale time");
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    assert_eq!(rig.player.status().entry, Some(0));
    assert_eq!(rig.player.status().show.as_deref(), Some("wave"));
}

#[test]
fn a_locate_ends_the_show_without_a_stop_and_approaches_the_new_entry_without_homing() {
    let (mut rig, second, playlist) = started_with_two_entries();
    rig.run_until(60_000_000, |rig| {
        rig.player.status().entry == Some(0)
            && rig.state() == PlayerState::Playing
            && rig.player.status().show_time_ms > 3_000
    });
    rig.states.clear();
    // No MO=0 is sent: the approach's `PA=…;BG;` ends the table on every unit.
    let links = rig.links();
    rig.player
        .locate(rig.now_us, playlist, false, 1, &links)
        .unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Approaching);
    rig.run_until(60_000_000, |rig| {
        rig.player.status().entry == Some(1) && rig.state() == PlayerState::Playing
    });
    let states: Vec<PlayerState> = rig.states.iter().map(|(_, state)| *state).collect();
    assert!(!states.contains(&PlayerState::Homing), "{states:?}");
    // Every unit's motor stayed on, and the second show plays as written.
    for line in &rig.lines {
        assert!(line.gateway.units().all(|unit| unit.motor_on));
    }
    assert_eq!(rig.player.status().show.as_deref(), Some("second"));
    let error_mm = follow(&mut rig, &second);
    assert!(error_mm < 1.0, "{error_mm} mm");
}

#[test]
fn delays_cycles_and_loop_behave_as_specified() {
    let show = wave(1, 2, 20, 100); // 2 s
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    rig.start(vec![entry(show.clone(), 700, 2)], true).unwrap();
    rig.run_until(30_000_000, |rig| rig.state() == PlayerState::Waiting);
    let waited_from = rig.now_us;
    rig.run_until(2_000_000, |rig| rig.state() != PlayerState::Waiting);
    let waited_us = rig.now_us - waited_from;
    assert!(
        (690_000..=710_000).contains(&waited_us),
        "waited {waited_us} µs"
    );
    rig.run_until(30_000_000, |rig| {
        rig.state() == PlayerState::Playing && rig.player.status().cycle == 1
    });
    rig.run_until(30_000_000, |rig| {
        rig.state() == PlayerState::Playing && rig.player.status().cycle == 2
    });
    // The loop comes back to the entry, delay and all.
    rig.run_until(30_000_000, |rig| rig.state() == PlayerState::Waiting);
    rig.run_until(30_000_000, |rig| {
        rig.state() == PlayerState::Playing && rig.player.status().cycle == 1
    });
    assert_eq!(rig.player.status().last_error, None);
}

#[test]
fn two_gateways_start_together() {
    let show = wave(2, 3, 40, 200);
    let mut rig = Rig::new(installation(2, 3, &[115_200, 115_200]));
    assert_eq!(rig.installation.units_on(1).count(), 3);
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    let start_us = rig.now_us;
    // Both gateways' balls are under way within the same couple of milliseconds after
    // the start's instant…
    rig.run_until(super::player::START_LEAD_US + 3_000, |rig| {
        rig.lines
            .iter()
            .all(|line| line.gateway.units().all(|unit| unit.moving))
    });
    // …and all follow the show from the same start.
    let worst = compare_from(&mut rig, &show, start_us);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
}

#[test]
fn a_unit_error_stops_the_matrix_and_says_which_ball() {
    let show = wave(1, 3, 100, 200);
    let mut rig = Rig::new(installation(1, 3, &[115_200]));
    rig.start(vec![entry(show, 0, 1)], false).unwrap();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    // Unit 2 (station 2) reports an overload.
    let frame = crate::uim2503::feedback::Frame::new(
        2,
        crate::uim2503::feedback::code::ER,
        &[0x40, 0x27, 7],
    )
    .unwrap();
    rig.player.handle_feedback(rig.now_us, 0, &frame);
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Error);
    let error = rig.player.status().last_error.unwrap();
    assert!(
        error.contains("row 1, col 2") && error.contains("station 2"),
        "{error}"
    );
    rig.run_until(100_000, |rig| !rig.anyone_moving());
}

#[test]
fn home_stops_brings_every_ball_home_and_stays_idle() {
    let show = wave(1, 3, 200, 200);
    let mut rig = Rig::new(installation(1, 3, &[115_200]));
    rig.start(vec![entry(show, 0, 1)], false).unwrap();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    rig.send_stop();
    let links = rig.links();
    rig.player.home(rig.now_us, &links).unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Homing);
    assert_eq!(
        rig.player.status().show,
        None,
        "homing shows no show's time"
    );
    rig.run_until(30_000_000, |rig| rig.state() == PlayerState::Idle);
    rig.assert_homed();
    let until_us = rig.now_us + 1_000_000;
    rig.run_until(2_000_000, |rig| rig.now_us >= until_us);
    assert!(
        rig.states
            .ends_with(&[(rig.states.last().unwrap().0, PlayerState::Idle)]),
        "it stays idle at home: {:?}",
        rig.states
    );
}

#[test]
fn a_failure_asks_for_the_estop_and_an_estop_keeps_the_failure() {
    let show = wave(1, 2, 200, 200);
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    rig.start(vec![entry(show, 0, 1)], false).unwrap();
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    rig.player.fail_with("gateway 0 stalled".into());
    assert_eq!(rig.player.take_commands(), vec![Command::Estop]);
    assert_eq!(rig.state(), PlayerState::Error);
    rig.player.estop();
    assert_eq!(rig.state(), PlayerState::Error);
    assert_eq!(
        rig.player.status().last_error.as_deref(),
        Some("gateway 0 stalled")
    );
}

/// The instructions written to each gateway, one a line: when the instruction began to
/// cross the line (µs of virtual time), a space, its bytes as ASCII.
fn wire_text(rig: &Rig) -> Vec<String> {
    rig.lines
        .iter()
        .map(|line| {
            line.wire
                .iter()
                .map(|(at_us, bytes)| format!("{at_us} {}\n", bytes.escape_ascii()))
                .collect()
        })
        .collect()
}

/// Compares `actual` with the golden file `name` (in `shared/tests/golden/`) line by
/// line and names the first instruction that differs. With `FLOATBALL_BLESS=1` (native
/// only) the file is written from `actual` instead: only ever from code whose bytes on
/// the wire are known to be right.
fn assert_golden(name: &str, expected: &str, actual: &str) {
    #[cfg(not(target_arch = "wasm32"))]
    if std::env::var_os("FLOATBALL_BLESS").is_some() {
        let path = format!("{}/tests/golden/{name}", env!("CARGO_MANIFEST_DIR"));
        std::fs::write(&path, actual).unwrap();
        return;
    }
    let mut expected_lines = expected.lines();
    let mut actual_lines = actual.lines();
    for number in 1.. {
        match (expected_lines.next(), actual_lines.next()) {
            (None, None) => break,
            (expected, actual) if expected == actual => {}
            (expected, actual) => panic!(
                "{name}: instruction {number} differs on the wire\n  expected: {}\n  actual:   {}",
                expected.unwrap_or("(nothing: the stream ended)"),
                actual.unwrap_or("(nothing: the stream ended)")
            ),
        }
    }
    assert_eq!(
        expected, actual,
        "{name}: same instructions, other line ends"
    );
}

/// Golden wire test, streaming: two gateways at 9600 baud, three units each, a 28 s
/// wave too long for the table (FIFO). Pins every byte each gateway is sent, and when:
/// homing, approach, position queries, configuration, preload, arm, the synchronised
/// start and every refill round.
#[test]
fn the_wire_carries_exactly_the_golden_stream_when_streaming() {
    let show = wave(2, 3, 280, 100);
    let mut rig = Rig::new(installation(2, 3, &[9600, 9600]));
    rig.start(vec![entry(show, 0, 1)], false).unwrap();
    rig.run_until(120_000_000, |rig| rig.state() == PlayerState::Playing);
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
    let wire = wire_text(&rig);
    assert_golden(
        "wave_fifo_9600_gateway0.txt",
        include_str!("../../tests/golden/wave_fifo_9600_gateway0.txt"),
        &wire[0],
    );
    assert_golden(
        "wave_fifo_9600_gateway1.txt",
        include_str!("../../tests/golden/wave_fifo_9600_gateway1.txt"),
        &wire[1],
    );
}

/// Golden wire test, a playlist of short shows: two gateways at 9600 baud, a wave that
/// fits the table (single mode) played twice after a delay, then a second show — the
/// moves and loads between entries and cycles.
#[test]
fn the_wire_carries_exactly_the_golden_stream_for_a_playlist() {
    let first = wave(2, 3, 20, 200);
    let mut second = wave(2, 3, 12, 250);
    second.name = "second".into();
    let mut rig = Rig::new(installation(2, 3, &[9600, 9600]));
    rig.start(vec![entry(first, 300, 2), entry(second, 0, 1)], false)
        .unwrap();
    rig.run_until(120_000_000, |rig| {
        rig.player.status().entry == Some(1) && rig.state() == PlayerState::Playing
    });
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
    let wire = wire_text(&rig);
    assert_golden(
        "wave_playlist_9600_gateway0.txt",
        include_str!("../../tests/golden/wave_playlist_9600_gateway0.txt"),
        &wire[0],
    );
    assert_golden(
        "wave_playlist_9600_gateway1.txt",
        include_str!("../../tests/golden/wave_playlist_9600_gateway1.txt"),
        &wire[1],
    );
}

// ---- arm ----

impl Rig {
    /// Arms `entries` as the bridge does while idle: prepared as Start would prepare
    /// them, at the player's current disarm count.
    fn arm(&mut self, entries: Vec<Entry>, loop_playlist: bool) -> bool {
        let links = self.links();
        let prepared =
            super::player::prepare(&self.installation, entries, loop_playlist, &links).unwrap();
        let disarms = self.player.disarms();
        let armed = self.player.arm(prepared, disarms, &links);
        self.carry_out();
        armed
    }

    fn armed_progress(&self) -> Option<f64> {
        self.player.armed().map(|armed| armed.progress)
    }

    /// Every instruction written to every gateway since `from` (per gateway, an index
    /// into its wire), as text.
    fn wire_since(&self, from: &[usize]) -> String {
        self.lines
            .iter()
            .zip(from)
            .flat_map(|(line, &from)| &line.wire[from..])
            .map(|(_, bytes)| format!("{}\n", bytes.escape_ascii()))
            .collect()
    }

    fn wire_marks(&self) -> Vec<usize> {
        self.lines.iter().map(|line| line.wire.len()).collect()
    }
}

/// Arms `show` on an idle rig until it is armed, checking that nothing moves and that
/// only the table is written; returns the wire as it was before arming.
fn arm_fully(rig: &mut Rig, show: &Show) -> Vec<usize> {
    let before = rig.wire_marks();
    let positions = rig.positions_mm();
    assert!(rig.arm(vec![entry(show.clone(), 0, 1)], false));
    let armed = rig
        .player
        .status()
        .armed
        .expect("arming shows in the status");
    assert_eq!((armed.entry, armed.show.as_str()), (0, show.name.as_str()));
    let mut last = 0.0;
    rig.run_until(60_000_000, |rig| {
        let progress = rig.armed_progress().expect("still arming");
        assert!(
            progress >= last,
            "progress went back from {last} to {progress}"
        );
        last = progress;
        progress == 1.0
    });
    assert_eq!(rig.state(), PlayerState::Idle);
    assert!(!rig.anyone_moving());
    assert_eq!(rig.positions_mm(), positions, "nothing moved while arming");
    let written = rig.wire_since(&before);
    assert!(written.contains("QP"), "{written}");
    for forbidden in ["MO", "PA", "PV", "BG", "SP"] {
        assert!(
            !written.contains(forbidden),
            "arming wrote {forbidden}:\n{written}"
        );
    }
    before
}

#[test]
fn an_armed_show_starts_after_the_approach_alone_and_plays_as_written() {
    // 120 rows of 200 ms: the single-sequence table.
    let show = wave(2, 3, 120, 200);
    let mut rig = Rig::new(installation(2, 3, &[9600]));
    arm_fully(&mut rig, &show);
    // A Start of the same playlist takes the tables over: no row is sent again.
    let marks = rig.wire_marks();
    rig.states.clear();
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    assert_eq!(
        rig.player.status().armed,
        None,
        "a running show is not armed"
    );
    rig.run_until(60_000_000, |rig| rig.state() == PlayerState::Playing);
    let start = rig.wire_since(&marks);
    assert!(!start.contains("QP"), "rows were loaded again:\n{start}");
    assert!(start.contains("PV"), "{start}");
    // The load phase only arms and confirms: a few bytes, not the show's table.
    let loading_us: u64 = rig
        .states
        .windows(2)
        .filter(|pair| pair[0].1 == PlayerState::Loading)
        .map(|pair| pair[1].0 - pair[0].0)
        .sum();
    assert!(loading_us < 200_000, "loading took {loading_us} µs");
    let start_us = rig.now_us;
    let worst = compare_from(&mut rig, &show, start_us);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
}

#[test]
fn a_streamed_show_armed_or_half_armed_plays_as_written() {
    // 600 rows: more than the table holds, streamed (FIFO) after its preload.
    let show = wave(1, 2, 600, 200);
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    arm_fully(&mut rig, &show);
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);

    // A Start while arming is under way takes over from where it got.
    let mut rig = Rig::new(installation(1, 2, &[9600]));
    assert!(rig.arm(vec![entry(show.clone(), 0, 1)], false));
    rig.run_until(10_000_000, |rig| {
        rig.armed_progress().is_some_and(|progress| progress > 0.3)
    });
    let progress = rig.armed_progress().unwrap();
    assert!(progress < 1.0, "{progress}");
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
}

#[test]
fn an_estop_or_a_disarm_drops_the_arming_and_a_stale_one_is_refused() {
    let show = wave(1, 2, 60, 200);
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    arm_fully(&mut rig, &show);
    rig.estop();
    assert_eq!(rig.player.status().armed, None);
    // Stopped is not idle: nothing is armed until the matrix is idle again.
    assert!(!rig.arm(vec![entry(show.clone(), 0, 1)], false));

    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    arm_fully(&mut rig, &show);
    let links = rig.links();
    let prepared = super::player::prepare(
        &rig.installation,
        vec![entry(show.clone(), 0, 1)],
        false,
        &links,
    )
    .unwrap();
    let stale = rig.player.disarms();
    rig.player.disarm();
    assert_eq!(rig.player.status().armed, None);
    assert!(
        !rig.player.arm(prepared, stale, &links),
        "prepared before the disarm"
    );
    // A lost link drops it too.
    assert!(rig.arm(vec![entry(show.clone(), 0, 1)], false));
    let mut links = rig.links();
    links[0].up = false;
    rig.player.poll(rig.now_us, &links);
    assert_eq!(rig.player.status().armed, None);
    assert_eq!(rig.state(), PlayerState::Idle);
}

#[test]
fn a_start_of_another_show_loads_it_in_full() {
    let armed = wave(1, 2, 60, 200);
    let mut other = wave(1, 2, 80, 200);
    other.name = "other".into();
    let mut rig = Rig::new(installation(1, 2, &[115_200]));
    arm_fully(&mut rig, &armed);
    let marks = rig.wire_marks();
    rig.start(vec![entry(other.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &other);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    assert!(
        rig.wire_since(&marks).contains("MP[0]"),
        "the table was cleared"
    );
}

#[test]
fn a_start_from_a_time_plays_the_cut_then_the_whole_show_for_the_next_cycle() {
    let show = wave(1, 3, 20, 200);
    let installation = installation(1, 3, &[115_200]);
    let mut rig = Rig::new(installation.clone());
    let cut = show.from_time(1_500, 2_000.0).unwrap();
    assert_eq!(cut.joins_ms, 1_500);
    let links = rig.links();
    let prepared = prepare(
        &installation,
        vec![entry(show.clone(), 0, 2)],
        false,
        &links,
    )
    .unwrap();
    let lead = prepare(
        &installation,
        vec![entry(cut.show.clone(), 0, 1)],
        false,
        &links,
    )
    .unwrap();
    rig.player
        .start_prepared_at(
            rig.now_us,
            prepared,
            (0, Some((cut.start_ms, lead))),
            &links,
        )
        .unwrap();
    rig.carry_out();
    rig.run_until(120_000_000, |rig| rig.state() == PlayerState::Playing);
    let status = rig.player.status();
    assert_eq!((status.cycle, status.show_duration_ms), (1, 4_000));
    assert!(status.show_time_ms >= cut.start_ms && status.show_time_ms <= cut.start_ms + 20);
    // The cut as planned, then the whole show in the entry's second cycle (its tables
    // loaded anew, not the cut's taken for them).
    let start_us = rig.now_us;
    let worst = compare_from(&mut rig, &cut.show, start_us);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off the cut");
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    assert_eq!(rig.player.status().cycle, 0);
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
}

/// Steps the rig live until `until_us`, handing `targets(t)` before each step;
/// checks every ball's true speed on the way (the units' own motion, every ms).
fn run_live(rig: &mut Rig, until_us: u64, targets: &dyn Fn(u64) -> Vec<Option<f64>>) {
    let max_speed = rig.installation.limits.max_speed_mm_s;
    let mut before = rig.positions_mm();
    while rig.now_us < until_us {
        let targets = targets(rig.now_us);
        rig.player
            .sequencer_mut()
            .set_live_input(crate::player::LiveInput {
                targets_mm: &targets,
                ..Default::default()
            });
        rig.step();
        let after = rig.positions_mm();
        for (ball, (a, b)) in before.iter().zip(&after).enumerate() {
            let speed = (b - a).abs() / (STEP_US as f64 / 1e6);
            assert!(
                speed <= max_speed * 1.01 + 1.0,
                "ball {ball} at {} µs: {speed} mm/s",
                rig.now_us
            );
        }
        before = after;
        assert_ne!(
            rig.state(),
            PlayerState::Error,
            "{:?}",
            rig.player.status().last_error
        );
    }
}

#[test]
fn live_rows_stream_into_the_fifo_and_the_units_follow_within_the_limits() {
    use crate::api::LivePhase;
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    let first = |_| vec![Some(1000.0), Some(1500.0), Some(2000.0), None];
    rig.player
        .sequencer_mut()
        .set_live_input(crate::player::LiveInput {
            targets_mm: &first(0),
            ..Default::default()
        });
    rig.player.sequencer_mut().go_live(0).unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Homing);
    let phase = |rig: &Rig| rig.player.status().live.map(|live| live.phase);
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Preparing));
    rig.run_until(5_000_000, |rig| phase(rig) == Some(LivePhase::Approaching));
    let live = rig.player.status().live.unwrap();
    // Four units at 115,200 baud: a 14 ms row; the FIFO eleven rows deep (at least
    // 150 ms ahead).
    assert_eq!(live.period_ms, 14, "{live:?}");
    assert_eq!(live.latency_ms, 12 * 14);
    let until = rig.now_us + 5_000_000;
    run_live(&mut rig, until, &first);
    assert_eq!(phase(&rig), Some(LivePhase::Following));
    let at = rig.positions_mm();
    for (ball, want) in [1000.0, 1500.0, 2000.0].into_iter().enumerate() {
        assert!((at[ball] - want).abs() < 0.5, "ball {ball} at {}", at[ball]);
    }
    // A snap across the travel and back: followed within the limits, then held.
    let from = rig.now_us;
    let snap = move |t: u64| {
        let down = t - from < 1_000_000;
        vec![
            Some(if down { 7000.0 } else { 1000.0 }),
            Some(1500.0),
            Some(if down { 0.0 } else { 2000.0 }),
            None,
        ]
    };
    run_live(&mut rig, from + 6_000_000, &snap);
    let at = rig.positions_mm();
    for (ball, want) in [1000.0, 1500.0, 2000.0].into_iter().enumerate() {
        assert!((at[ball] - want).abs() < 0.5, "ball {ball} at {}", at[ball]);
    }
    // Leave: braked to rest, idle, positions known; a show then needs no homing.
    rig.player.sequencer_mut().leave_live(rig.now_us);
    let until = rig.now_us + 3_000_000;
    run_live(&mut rig, until, &snap);
    assert_eq!(rig.state(), PlayerState::Idle);
    assert!(!rig.anyone_moving());
    rig.start(vec![entry(wave(2, 2, 20, 100), 0, 1)], false)
        .unwrap();
    assert_eq!(rig.state(), PlayerState::Approaching);
}

#[test]
fn live_mode_stops_with_the_estop_and_a_slow_line_is_refused() {
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    rig.player.sequencer_mut().go_live(0).unwrap();
    rig.carry_out();
    rig.run_until(30_000_000, |rig| {
        rig.player.status().live.map(|live| live.phase) == Some(crate::api::LivePhase::Following)
    });
    rig.estop();
    assert_eq!(rig.state(), PlayerState::Stopped);
    assert_eq!(rig.player.status().live, None);
    rig.run_until(1_000_000, |rig| !rig.anyone_moving());
    // The next live request homes first.
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    assert_eq!(rig.state(), PlayerState::Homing);
    // Eight units on a 9,600-baud line need a longer row than a unit takes.
    let mut slow = Rig::new(installation(2, 4, &[9_600]));
    let refused = slow.player.sequencer_mut().go_live(0).unwrap_err();
    assert!(
        matches!(
            refused,
            StartError::LiveLineTooSlow {
                gateway: 0,
                units: 8,
                max_ms: 255,
                ..
            }
        ),
        "{refused:?}"
    );
    assert_eq!(
        crate::codes::Coded::code(&refused),
        crate::codes::Code::LiveLineTooSlow
    );
    assert!(slow.player.take_commands().is_empty());
}

/// The row time live mode streams at, per line speed and units on the line: the
/// figures in `docs/live.md`.
#[test]
fn the_live_row_time_is_what_the_line_carries_for_its_units() {
    use crate::uim2503::player::Uim2503Drive;
    let row_ms = |units: u32, baud: u32| {
        let drive = Uim2503Drive::new(PlayerConfig {
            installation: installation(1, units, &[baud]),
        });
        crate::player::Drive::live_setup(&drive).map(|setup| setup.limits.dt_ms)
    };
    // 115,200 baud: about 3 ms a unit; 9,600 baud: about 36 ms a unit.
    assert_eq!(row_ms(1, 115_200), Ok(10), "the shortest row");
    assert_eq!(row_ms(4, 115_200), Ok(14));
    assert_eq!(row_ms(16, 115_200), Ok(51));
    assert_eq!(row_ms(64, 115_200), Ok(200));
    assert_eq!(row_ms(1, 9_600), Ok(52));
    assert_eq!(row_ms(4, 9_600), Ok(161));
    assert_eq!(row_ms(6, 9_600), Ok(233));
    // The most units a line carries in a row of at most 255 ms.
    assert_eq!(
        (1..200).find(|&units| row_ms(units, 115_200).is_err()),
        Some(82)
    );
    assert_eq!(
        (1..20).find(|&units| row_ms(units, 9_600).is_err()),
        Some(7)
    );
}

#[test]
fn going_live_disarms_an_armed_show_and_the_show_then_plays_in_full() {
    let show = wave(2, 2, 20, 100);
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    arm_fully(&mut rig, &show);
    assert!(rig.player.armed().is_some());
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    rig.carry_out();
    assert_eq!(
        rig.player.armed(),
        None,
        "live motion overwrites the tables"
    );
    rig.run_until(30_000_000, |rig| {
        rig.player.status().live.map(|live| live.phase) == Some(crate::api::LivePhase::Following)
    });
    rig.player.sequencer_mut().leave_live(rig.now_us);
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst < 1.0, "{worst} mm off the show");
    assert_eq!(rig.state(), PlayerState::Idle);
}

/// The row times (`QT`) written from `from_us` on, every gateway.
fn row_times_ms(rig: &Rig, from_us: u64) -> Vec<u32> {
    rig.lines
        .iter()
        .flat_map(|line| &line.wire)
        .filter(|(at_us, _)| *at_us >= from_us)
        .filter_map(|(_, bytes)| {
            let text = std::str::from_utf8(bytes).ok()?;
            let value = text.strip_prefix("QT[")?.split(']').nth(1)?;
            value.trim_end_matches(';').parse().ok()
        })
        .collect()
}

#[test]
fn a_clock_trim_shortens_streamed_rows_by_at_most_a_millisecond_to_follow_a_fast_clock() {
    // 1200 rows of 100 ms per ball, streamed (the table's first 25.6 s preloaded, as
    // planned: no trim reaches them); the timecode's clock runs 0.5 % fast.
    let show = wave(2, 3, 1_200, 100);
    let mut rig = Rig::new(installation(2, 3, &[115_200]));
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    rig.run_until(120_000_000, |rig| rig.state() == PlayerState::Playing);
    let start_us = rig.now_us;
    let given_start = |t: u64| (t - (t - start_us) * 1_005 / 1_000) as i64;
    let mut sampler = Sampler::new(&show);
    let mut expected = vec![0.0f32; show.tracks.len()];
    let mut worst_late: f64 = 0.0;
    let mut last_status_ms = 0;
    while rig.state() == PlayerState::Playing {
        if (rig.now_us - start_us).is_multiple_of(50_000) {
            rig.player
                .trim_clock(rig.now_us, 0, given_start(rig.now_us));
        }
        rig.step();
        let given_ms = (rig.now_us as i64 - given_start(rig.now_us)) as f64 / 1_000.0;
        if (rig.now_us - start_us).is_multiple_of(100_000)
            && given_ms > 80_000.0
            && given_ms < show.duration_ms() as f64 - 200.0
        {
            // Late in the show (the 0.5 % made good at up to 1 %) the balls are where the given clock has the show.
            sampler.sample(given_ms, &mut expected, None);
            for (actual, expected) in rig.positions_mm().iter().zip(&expected) {
                worst_late = worst_late.max((actual - f64::from(*expected)).abs());
            }
            last_status_ms = rig.player.status().show_time_ms;
            assert!(
                (last_status_ms as f64 - given_ms).abs() <= 15.0,
                "the status says {last_status_ms} ms, the given clock {given_ms} ms"
            );
        }
    }
    assert!(last_status_ms > 80_000);
    // (Within the few ms the first trim found the units' start apart from it.)
    assert!(
        worst_late <= 2.0,
        "a ball was {worst_late:.3} mm off the given clock's show"
    );
    // Every row written after the start lasts 100 ms ± 1, and the trim shortened some.
    let times = row_times_ms(&rig, start_us);
    assert!(times.len() > 100, "{} rows", times.len());
    assert!(
        times.iter().all(|&ms| (99..=100).contains(&ms)),
        "{times:?}"
    );
    let shortened = times.iter().filter(|&&ms| ms == 99).count();
    // 0.6 s made good (0.5 % of 120 s), a millisecond a row.
    assert!(
        (550..=650).contains(&shortened),
        "{shortened} rows shortened"
    );
    assert_eq!(rig.player.status().last_error, None);
}

/// The balls' rest positions as the drive has them (`None`: unknown).
fn rest_mm(rig: &Rig) -> Option<Vec<f64>> {
    crate::player::Drive::rest_positions_mm(rig.player.sequencer().drive())
}

/// The bridge stalls under load for longer than the FIFO's rows while the balls
/// move: the units run dry, brake with `SD` and take no row written after. Their
/// water level tells (`PV;`): live mode fails saying so — not silently standing
/// while the status says following — and live mode again homes first.
#[test]
fn rows_run_dry_in_a_stall_fail_live_mode_and_live_again_homes_first() {
    use crate::api::LivePhase;
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    let phase = |rig: &Rig| rig.player.status().live.map(|live| live.phase);
    let at = |mm: f64| move |_| vec![Some(mm); 4];
    rig.player.sequencer_mut().go_live(0).unwrap();
    rig.carry_out();
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Following));
    let until = rig.now_us + 1_000_000;
    run_live(&mut rig, until, &at(1000.0));
    // A step, and the bridge stalls for 250 ms (over 17 rows, more than the FIFO
    // holds) while the balls move.
    let until = rig.now_us + 300_000;
    run_live(&mut rig, until, &at(3000.0));
    for _ in 0..STALL_STEPS {
        rig.step_polled(false);
    }
    let stalled_us = rig.now_us;
    rig.run_until(1_000_000, |rig| rig.state() == PlayerState::Error);
    assert!(
        rig.now_us - stalled_us < 500_000,
        "{} µs",
        rig.now_us - stalled_us
    );
    let reason = rig.player.status().last_error.unwrap_or_default();
    assert!(reason.contains("rows ran out"), "{reason}");
    rig.estop();
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Homing);
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Following));
    let until = rig.now_us + 3_000_000;
    run_live(&mut rig, until, &at(2000.0));
    let at = rig.positions_mm();
    assert!(at.iter().all(|&mm| (mm - 2000.0).abs() < 0.5), "{at:?}");
}

/// The bridge stalls while the balls brake after Leave live: the units run dry
/// and stop short of where the rows end. Their positions are read back after
/// leaving, so live mode again starts its rows where the units are — not with a row
/// from where the filter left them, which the unit cannot follow (error 0x40).
#[test]
fn live_again_after_the_rows_ran_dry_starts_where_the_units_stopped() {
    use crate::api::LivePhase;
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    let phase = |rig: &Rig| rig.player.status().live.map(|live| live.phase);
    let at = |mm: f64| move |_| vec![Some(mm); 4];
    rig.player.sequencer_mut().go_live(0).unwrap();
    rig.carry_out();
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Following));
    let until = rig.now_us + 1_000_000;
    run_live(&mut rig, until, &at(1000.0));
    let until = rig.now_us + 600_000;
    run_live(&mut rig, until, &at(3000.0));
    rig.player.sequencer_mut().leave_live(rig.now_us);
    for _ in 0..STALL_STEPS {
        rig.step_polled(false);
    }
    rig.run_until(5_000_000, |rig| rig.player.status().live.is_none());
    assert_eq!(
        rig.state(),
        PlayerState::Idle,
        "{:?}",
        rig.player.status().last_error
    );
    // The units stopped short of where the rows end; what the drive has is what
    // they answer.
    rig.run_until(2_000_000, |rig| rest_mm(rig).is_some());
    let stood = rig.positions_mm();
    let rest = rest_mm(&rig).unwrap();
    for (believed, at) in rest.iter().zip(&stood) {
        assert!((believed - at).abs() < 0.02, "{rest:?} vs {stood:?}");
    }
    let note = rig.player.status().last_error.unwrap_or_default();
    assert!(note.contains("their rows ran out"), "{note}");
    // Live again: no homing, the approach from where the balls are, no overload.
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    rig.carry_out();
    assert_ne!(rig.state(), PlayerState::Homing);
    let until = rig.now_us + 3_000_000;
    run_live(&mut rig, until, &at(2000.0));
    assert_eq!(phase(&rig), Some(LivePhase::Following));
    let at = rig.positions_mm();
    assert!(at.iter().all(|&mm| (mm - 2000.0).abs() < 0.5), "{at:?}");
}

/// A stall of the bridge while live or braking after Leave live, in rig steps (ms):
/// longer than the
/// FIFO holds ahead ([`crate::uim2503::player::live::LIVE_FIFO_MIN_MS`]).
const STALL_STEPS: usize = 250;

/// Live mode asked for again at once after leaving (while the units still run the
/// FIFO's last rows, their positions not yet read back): it homes first rather than
/// load a new table under the old run; asked a moment later, it does not home.
#[test]
fn live_again_at_once_after_leaving_homes_and_a_moment_later_does_not() {
    use crate::api::LivePhase;
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    let phase = |rig: &Rig| rig.player.status().live.map(|live| live.phase);
    let at = |mm: f64| move |_| vec![Some(mm); 4];
    rig.player.sequencer_mut().go_live(0).unwrap();
    rig.carry_out();
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Following));
    let until = rig.now_us + 2_000_000;
    run_live(&mut rig, until, &at(1500.0));
    rig.player.sequencer_mut().leave_live(rig.now_us);
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert!(rig.anyone_moving() || rest_mm(&rig).is_none());
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    rig.carry_out();
    assert_eq!(rig.state(), PlayerState::Homing);
    rig.run_until(30_000_000, |rig| phase(rig) == Some(LivePhase::Following));
    let until = rig.now_us + 2_000_000;
    run_live(&mut rig, until, &at(1500.0));
    rig.player.sequencer_mut().leave_live(rig.now_us);
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    // Read back within a few rows (14 ms each) after the FIFO ran out.
    let idle_us = rig.now_us;
    rig.run_until(1_000_000, |rig| rest_mm(rig).is_some());
    assert!(
        rig.now_us - idle_us < 200_000,
        "{} µs",
        rig.now_us - idle_us
    );
    assert!(
        rest_mm(&rig)
            .unwrap()
            .iter()
            .all(|&mm| (mm - 1500.0).abs() < 0.01)
    );
    assert_eq!(rig.player.status().last_error, None);
    rig.player.sequencer_mut().go_live(rig.now_us).unwrap();
    rig.carry_out();
    assert_ne!(rig.state(), PlayerState::Homing);
    rig.run_until(5_000_000, |rig| phase(rig) == Some(LivePhase::Following));
}

// ---- live at the ends of the travel, and arming after live (issue 47) ----

/// The matrix the outside check used: 1 × 3 balls, a 1000 mm travel, 500 mm/s,
/// 2000 mm/s², one gateway at 115,200 baud (11 ms live rows).
fn small_installation() -> Installation {
    let mut installation = installation(1, 3, &[115_200]);
    installation.limits.travel_mm = 1000.0;
    installation.limits.max_speed_mm_s = 500.0;
    installation.limits.max_accel_mm_s2 = 2000.0;
    installation.stop_decel_mm_s2 = 2000.0;
    installation.approach_speed_mm_s = 250.0;
    installation
}

impl Rig {
    /// Every ball's true position and velocity, counts and counts/s.
    fn kinematics_counts(&self) -> Vec<(f64, f64)> {
        let mut out = vec![(0.0, 0.0); self.installation.units.len()];
        for (gateway, line) in self.lines.iter().enumerate() {
            for (slot, unit) in self.installation.units_on(gateway).enumerate() {
                let view = line.gateway.unit(slot).unwrap();
                out[unit] = (view.position_counts, view.velocity_counts_s);
            }
        }
        out
    }

    /// Goes live with every ball to `first_mm` and waits until they follow.
    fn live_at(&mut self, first_mm: &[f64]) {
        let targets: Vec<Option<f64>> = first_mm.iter().map(|&mm| Some(mm)).collect();
        self.player
            .sequencer_mut()
            .set_live_input(crate::player::LiveInput {
                targets_mm: &targets,
                ..Default::default()
            });
        self.player.sequencer_mut().go_live(self.now_us).unwrap();
        self.carry_out();
        self.run_until(30_000_000, |rig| {
            rig.player.status().live.map(|live| live.phase)
                == Some(crate::api::LivePhase::Following)
        });
    }
}

/// What the balls did while [`follow_live`] ran: the peaks of the twins' own motion
/// (velocity every ms; acceleration from it over each ms) and of positions sampled
/// every 10 ms (as an outside check reading `GET /api/sim/positions` would), mm/s and
/// mm/s².
#[derive(Debug, Default, Clone, Copy)]
struct Peaks {
    speed_mm_s: f64,
    accel_mm_s2: f64,
    sampled_speed_mm_s: f64,
    sampled_accel_mm_s2: f64,
}

/// Live for `duration_us` with every ball's target `targets_mm`: no unit fault, and
/// the peaks of the motion.
fn follow_live(rig: &mut Rig, duration_us: u64, targets_mm: &[f64]) -> Peaks {
    let targets: Vec<Option<f64>> = targets_mm.iter().map(|&mm| Some(mm)).collect();
    let cpm = rig.installation.counts_per_mm;
    let until = rig.now_us + duration_us;
    let mut peaks = Peaks::default();
    let mut before = rig.kinematics_counts();
    let mut samples: Vec<Vec<f64>> = Vec::new();
    while rig.now_us < until {
        rig.player
            .sequencer_mut()
            .set_live_input(crate::player::LiveInput {
                targets_mm: &targets,
                ..Default::default()
            });
        rig.step();
        assert_ne!(
            rig.state(),
            PlayerState::Error,
            "{:?}",
            rig.player.status().last_error
        );
        let now = rig.kinematics_counts();
        for (&(_, v0), &(_, v1)) in before.iter().zip(&now) {
            peaks.speed_mm_s = peaks.speed_mm_s.max(v1.abs() / cpm);
            let accel = (v1 - v0).abs() / (STEP_US as f64 / 1e6) / cpm;
            peaks.accel_mm_s2 = peaks.accel_mm_s2.max(accel);
        }
        before = now;
        if rig.now_us.is_multiple_of(10_000) {
            samples.push(rig.positions_mm());
        }
    }
    let dt_s = 0.01;
    for pair in samples.windows(2) {
        for (a, b) in pair[0].iter().zip(&pair[1]) {
            peaks.sampled_speed_mm_s = peaks.sampled_speed_mm_s.max((b - a).abs() / dt_s);
        }
    }
    for three in samples.windows(3) {
        for ((a, b), c) in three[0].iter().zip(&three[1]).zip(&three[2]) {
            let second = c - 2.0 * b + a;
            peaks.sampled_accel_mm_s2 = peaks.sampled_accel_mm_s2.max(second.abs() / (dt_s * dt_s));
        }
    }
    peaks
}

/// Every ball rests exactly at `counts` (the twin's own position, to the count).
fn assert_at_counts(rig: &Rig, counts: &[f64]) {
    let at: Vec<(f64, f64)> = rig.kinematics_counts();
    for (ball, (&(position, velocity), &want)) in at.iter().zip(counts).enumerate() {
        assert_eq!(
            (position, velocity),
            (want, 0.0),
            "ball {ball} at {position} counts moving {velocity} counts/s"
        );
    }
}

/// Issue 47, item 1: a fader at 0 (the top) or full (the travel) brings every ball to
/// that end exactly, to the count, and never past it — before, a state rounded on
/// its own near an end (0.4 counts below the top still rising → the top, still
/// rising) made the next row dip past it and the unit stopped with LIMIT (0x41).
/// From these starts every ball's last rows towards the end were such a pair.
#[test]
fn a_fader_at_either_end_brings_the_balls_there_to_the_count_never_past_it() {
    let mut rig = Rig::new(small_installation());
    let limits = rig.installation.limits;
    rig.live_at(&[109.0, 118.0, 20.0]);
    follow_live(&mut rig, 1_000_000, &[109.0, 118.0, 20.0]);
    // Snapped to the top.
    let peaks = follow_live(&mut rig, 2_000_000, &[0.0; 3]);
    assert_at_counts(&rig, &[0.0; 3]);
    let mut worst = peaks;
    // To the bottom of the travel, from where the last rows dipped past it.
    follow_live(&mut rig, 3_000_000, &[120.0, 131.0, 142.0]);
    let peaks = follow_live(&mut rig, 3_000_000, &[1000.0; 3]);
    assert_at_counts(&rig, &[100_000.0; 3]);
    worst.speed_mm_s = worst.speed_mm_s.max(peaks.speed_mm_s);
    worst.accel_mm_s2 = worst.accel_mm_s2.max(peaks.accel_mm_s2);
    // Full travel steps, and slow fades onto each end, back and forth.
    for (targets, duration_us) in [
        ([0.0; 3], 3_000_000),
        ([1000.0; 3], 3_000_000),
        ([0.0; 3], 3_000_000),
        ([0.004, 999.996, 0.0], 1_000_000),
        ([1000.0, 0.0, 1000.0], 3_000_000),
    ] {
        let peaks = follow_live(&mut rig, duration_us, &targets);
        worst.speed_mm_s = worst.speed_mm_s.max(peaks.speed_mm_s);
        worst.accel_mm_s2 = worst.accel_mm_s2.max(peaks.accel_mm_s2);
    }
    assert_at_counts(&rig, &[100_000.0, 0.0, 100_000.0]);
    let from = rig.now_us;
    let fade = |ball: usize, t_us: u64| {
        // Each ball fades at its own speed onto an end and off it again.
        let rate_mm_s = [37.0, 113.0, 290.0][ball];
        let s = (t_us - from) as f64 / 1e6;
        (1000.0 - rate_mm_s * s).clamp(0.0, 1000.0)
    };
    while rig.now_us < from + 30_000_000 {
        let at: Vec<f64> = (0..3).map(|ball| fade(ball, rig.now_us)).collect();
        let peaks = follow_live(&mut rig, 5_000, &at);
        worst.speed_mm_s = worst.speed_mm_s.max(peaks.speed_mm_s);
        worst.accel_mm_s2 = worst.accel_mm_s2.max(peaks.accel_mm_s2);
    }
    follow_live(&mut rig, 1_000_000, &[0.0; 3]);
    assert_at_counts(&rig, &[0.0; 3]);
    // The twins' own motion never above the limits (they refuse a row over them:
    // OVERLOAD, and a row past an end: LIMIT, both faults the loop above fails on).
    assert!(
        worst.speed_mm_s <= limits.max_speed_mm_s + 1e-6,
        "{worst:?}"
    );
    assert!(
        worst.accel_mm_s2 <= limits.max_accel_mm_s2 * 1.001,
        "{worst:?}"
    );
    // Leaving rests where they are, read back exactly.
    rig.player.sequencer_mut().leave_live(rig.now_us);
    rig.run_until(5_000_000, |rig| rest_mm(rig).is_some());
    assert_eq!(rest_mm(&rig), Some(vec![0.0; 3]));
    assert_eq!(rig.player.status().last_error, None);
}

/// Issue 47, item 2: the share of the top speed and acceleration live motion uses at
/// the ball on UIM2503 units, on a fader step across the whole travel and back (the
/// figures in `docs/live.md`): the twins' own motion, and positions sampled every
/// 10 ms. Rows are whole counts, so the filter keeps 6/T² + 6/T counts/s² under the
/// top acceleration (at 100 counts/mm and 11 ms rows, 501 mm/s²: a quarter) and
/// 3/T + 1 counts/s under the top speed (2.7 mm/s).
#[test]
fn live_motion_at_the_ball_uses_three_quarters_of_the_acceleration() {
    let mut rig = Rig::new(small_installation());
    let limits = rig.installation.limits;
    assert_eq!(rig.player.sequencer_mut().go_live(0), Ok(()));
    assert_eq!(rig.player.status().live.unwrap().period_ms, 11);
    rig.estop();
    rig.live_at(&[0.0; 3]);
    follow_live(&mut rig, 500_000, &[0.0; 3]);
    let down = follow_live(&mut rig, 3_000_000, &[1000.0; 3]);
    assert_at_counts(&rig, &[100_000.0; 3]);
    let up = follow_live(&mut rig, 3_000_000, &[0.0; 3]);
    assert_at_counts(&rig, &[0.0; 3]);
    let share = |value: f64, limit: f64| value / limit;
    for (what, peaks) in [("0 → full", down), ("full → 0", up)] {
        eprintln!(
            "{what}: speed {:.1} mm/s ({:.1} %), sampled every 10 ms {:.1} mm/s ({:.1} %); \
             acceleration {:.0} mm/s² ({:.1} %), sampled every 10 ms {:.0} mm/s² ({:.1} %)",
            peaks.speed_mm_s,
            100.0 * share(peaks.speed_mm_s, limits.max_speed_mm_s),
            peaks.sampled_speed_mm_s,
            100.0 * share(peaks.sampled_speed_mm_s, limits.max_speed_mm_s),
            peaks.accel_mm_s2,
            100.0 * share(peaks.accel_mm_s2, limits.max_accel_mm_s2),
            peaks.sampled_accel_mm_s2,
            100.0 * share(peaks.sampled_accel_mm_s2, limits.max_accel_mm_s2),
        );
    }
    for (what, peaks) in [("0 → full", down), ("full → 0", up)] {
        let speed = share(peaks.speed_mm_s, limits.max_speed_mm_s);
        let accel = share(peaks.accel_mm_s2, limits.max_accel_mm_s2);
        assert!((0.99..=1.0).contains(&speed), "{what}: {peaks:?}");
        assert!((0.74..=1.0).contains(&accel), "{what}: {peaks:?}");
        let sampled = share(peaks.sampled_accel_mm_s2, limits.max_accel_mm_s2);
        assert!((0.70..=0.85).contains(&sampled), "{what}: {peaks:?}");
    }
}

/// Issue 47, item 3: a show armed right after Leave live, while the units still run
/// the FIFO's last rows: a unit takes no table mode while it runs rows (`MP[3]` is
/// refused, silently after `*0;`), so the tables went into the FIFO and Start failed
/// ("answered PV with 20 after loading, expected 0"). Arming now waits until every
/// unit answered where it stopped, then loads; the show plays as written.
#[test]
fn arming_right_after_leaving_live_waits_for_the_last_rows_then_plays_as_written() {
    let show = wave(2, 2, 20, 100);
    let mut rig = Rig::new(installation(2, 2, &[115_200]));
    rig.live_at(&[1500.0; 4]);
    follow_live(&mut rig, 1_000_000, &[1500.0; 4]);
    rig.player.sequencer_mut().leave_live(rig.now_us);
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert!(rig.anyone_moving(), "the FIFO's last rows still run");
    let marks = rig.wire_marks();
    assert!(rig.arm(vec![entry(show.clone(), 0, 1)], false));
    // Nothing of the table goes out while the last rows run.
    while rig.anyone_moving() {
        rig.step();
        assert!(
            !rig.wire_since(&marks).contains("MP[3]"),
            "configured under the old rows"
        );
        assert_eq!(rig.armed_progress(), Some(0.0));
    }
    rig.run_until(10_000_000, |rig| rig.armed_progress() == Some(1.0));
    assert_eq!(rig.player.status().last_error, None);
    assert!(rest_mm(&rig).is_some());
    let marks = rig.wire_marks();
    rig.start(vec![entry(show.clone(), 0, 1)], false).unwrap();
    let worst = follow(&mut rig, &show);
    assert!(worst <= 1.0, "a ball was {worst:.3} mm off its show");
    assert!(
        !rig.wire_since(&marks).contains("QP"),
        "the armed tables were used"
    );
    rig.run_until(5_000_000, |rig| rig.state() == PlayerState::Idle);
    assert_eq!(rig.player.status().last_error, None);
}
