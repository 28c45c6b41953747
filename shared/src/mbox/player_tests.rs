//! The MBOX player against twins ([`crate::mbox::twin`]) fed its frames as datagrams.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;
use crate::api::{PlayerState, Status};
use crate::mbox::twin::{MboxTwin, TwinConfig};
use crate::mbox::{
    AxisCount, AxisPositions, DigitalOutputs, Encode, MotionFrame, Route, TimeCode, TimeMode,
};
use crate::plan::installation::{DriveKind, GatewaySpec, Stations, allocate};
use crate::plan::report;
use crate::show::{AnalogKey, DigitalKey, Limits, OutputSample, OutputTrack, demo};
use crate::uim2503::plan::PlanOptions;

const CALIBRATION: BoxCalibration = BoxCalibration {
    axes: 3,
    pulses_per_mm: 10.0,
    sign: -1,
    offset_pulses: 1_000,
};

/// A 2 × 3 matrix on two 3-axis boxes.
fn player() -> MboxPlayer {
    MboxPlayer::new(config())
}

/// The configuration of [`player`].
fn config() -> MboxPlayerConfig {
    let mut limits = Limits::for_layout(2, 3);
    limits.max_accel_mm_s2 = 40_000.0;
    let wanted = vec![
        (
            DriveKind::Mbox,
            Stations::Consecutive {
                first: 1,
                units: Some(3)
            }
        );
        2
    ];
    let units = allocate(6, &wanted).unwrap();
    let mut installation = Installation::row_major(
        limits,
        100.0,
        vec![GatewaySpec::uim2503("sim", 115_200); 2],
        1,
    )
    .unwrap();
    for gateway in &mut installation.gateways {
        gateway.kind = DriveKind::Mbox;
    }
    installation.units = units;
    installation.approach_speed_mm_s = 2_000.0;
    MboxPlayerConfig {
        installation,
        boxes: vec![CALIBRATION; 2],
        period_us: DEFAULT_PERIOD_US,
    }
}

fn entry(cycles: u32, delay_ms: u64) -> Entry {
    Entry {
        show: demo::wave(2, 3, 10, 100),
        delay_ms,
        cycles,
    }
}

/// Runs the player until it rests, feeding every frame to the twins; returns the
/// states it went through.
fn run(player: &mut MboxPlayer, twins: &mut [MboxTwin], now_us: &mut u64) -> Vec<PlayerState> {
    run_logged(player, twins, now_us, &mut |_, _, _| {})
}

/// [`run`], telling `log` each frame with the player's state and show time after the
/// poll that made it and the twins' snapshots once they received it.
fn run_logged(
    player: &mut MboxPlayer,
    twins: &mut [MboxTwin],
    now_us: &mut u64,
    log: &mut dyn FnMut(&Status, &MboxFrame, &[MboxTwin]),
) -> Vec<PlayerState> {
    let mut states = vec![player.status().state];
    while let Some(wake) = player.next_wakeup_us(*now_us) {
        *now_us = wake.max(*now_us);
        player.poll(*now_us);
        let status = player.status();
        for frame in player.take_frames() {
            send(&frame, twins);
            log(&status, &frame, twins);
        }
        let state = player.status().state;
        if states.last() != Some(&state) {
            states.push(state);
        }
        assert!(*now_us < 600_000_000, "the player never rests");
    }
    for twin in twins.iter_mut() {
        twin.advance(*now_us + 1_000_000);
    }
    states
}

fn twins() -> Vec<MboxTwin> {
    (0..2)
        .map(|_| MboxTwin::new(TwinConfig::new(crate::mbox::FACTORY_IP, AxisCount::Three)))
        .collect()
}

fn last_positions(show: &crate::show::Show) -> Vec<i32> {
    show.tracks
        .iter()
        .map(|track| {
            let mm = track
                .rows
                .last()
                .map_or(track.start_mm, |row| row.position_mm);
            CALIBRATION.pulses(mm)
        })
        .collect()
}

#[test]
fn a_playlist_homes_approaches_plays_and_ends_at_the_last_positions() {
    let mut player = player();
    let mut twins = twins();
    let mut now = 0;
    player.start(now, vec![entry(2, 50)], false).unwrap();
    assert_eq!(
        player.start(now, vec![entry(1, 0)], false),
        Err(StartError::Busy)
    );
    let states = run(&mut player, &mut twins, &mut now);
    assert_eq!(
        states,
        [
            PlayerState::Homing,
            PlayerState::Waiting,
            PlayerState::Approaching,
            // The show's first frame goes at the slot after the approach's last:
            // until it does, the start is given, not yet under way.
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Idle
        ]
    );
    let reached: Vec<i32> = twins.iter().flat_map(MboxTwin::positions_pulses).collect();
    assert_eq!(reached, last_positions(&entry(1, 0).show));
    assert!((player.status().progress - 1.0).abs() < 1e-9);
}

#[test]
fn estop_stops_at_once_and_the_next_start_homes_first() {
    let mut player = player();
    let mut now = 0;
    player.start(now, vec![entry(1, 0)], true).unwrap();
    now += 2_000_000;
    player.poll(now);
    assert!(!player.take_frames().is_empty());
    player.estop();
    assert_eq!(player.status().state, PlayerState::Stopped);
    assert_eq!(player.next_wakeup_us(now), None);
    player.poll(now + 100_000);
    assert!(player.take_frames().is_empty());
    player.start(now, vec![entry(1, 0)], false).unwrap();
    assert_eq!(player.status().state, PlayerState::Homing);
    player.home(now);
    let mut twins = twins();
    let states = run(&mut player, &mut twins, &mut now);
    assert_eq!(states, [PlayerState::Homing, PlayerState::Idle]);
    let home: Vec<i32> = twins.iter().flat_map(MboxTwin::positions_pulses).collect();
    assert_eq!(home, vec![CALIBRATION.pulses(0.0); 6]);
}

#[test]
fn invalid_shows_are_refused_before_anything_moves() {
    let mut player = player();
    let wrong = Entry {
        show: demo::wave(3, 3, 10, 100),
        delay_ms: 0,
        cycles: 1,
    };
    let refused = player.start(0, vec![wrong], false);
    assert!(
        matches!(refused, Err(StartError::Invalid { entry: 1, .. })),
        "{refused:?}"
    );
    // Why, also coded for the app: a 3 × 3 show on the 2 × 3 installation.
    let reason = refused
        .unwrap_err()
        .reason_problem()
        .expect("a coded reason");
    assert_eq!(reason.code, "wrong_layout", "{reason:?}");
    assert_eq!(reason.params["show_rows"], "3");
    assert_eq!(player.start(0, Vec::new(), false), Err(StartError::Empty));
    assert_eq!(player.status().state, PlayerState::Idle);
    assert!(player.take_frames().is_empty());
}

#[test]
fn calibration_maps_millimetres_to_pulses() {
    assert_eq!(CALIBRATION.pulses(0.0), 1_000);
    assert_eq!(CALIBRATION.pulses(12.34), 877);
    let up = BoxCalibration {
        sign: 1,
        ..CALIBRATION
    };
    assert_eq!(up.pulses(1e12), i32::MAX);
}

#[test]
fn reset_homes_and_plays_and_a_refused_reset_stays_stopped() {
    let mut player = player();
    let mut now = 0;
    let refused = player.reset(now, Err(StartError::Empty), false);
    assert_eq!(refused, Err(StartError::Empty));
    let status = player.status();
    assert_eq!(status.state, PlayerState::Stopped);
    assert_eq!(status.last_error, Some(StartError::Empty.to_string()));
    player.reset(now, Ok(vec![entry(1, 0)]), false).unwrap();
    let mut twins = twins();
    let states = run(&mut player, &mut twins, &mut now);
    assert_eq!(
        states,
        [
            PlayerState::Homing,
            PlayerState::Approaching,
            PlayerState::Loading,
            PlayerState::Playing,
            PlayerState::Idle
        ]
    );
    assert_eq!(player.status().last_error, None);
}

/// `entry(1, 0)` with outputs: box 0 switches outputs 1 and 3 on at 0 and only output
/// 12 from 500 ms, and ramps analog channel 0 from 0 to 1000 over the show; box 1
/// switches every output on at 200 ms.
fn entry_with_outputs() -> Entry {
    let mut entry = entry(1, 0);
    entry.show.outputs = vec![
        OutputTrack {
            box_index: 0,
            digital: vec![
                DigitalKey {
                    time_ms: 0,
                    bits: 0b101,
                },
                DigitalKey {
                    time_ms: 500,
                    bits: 0x0800,
                },
            ],
            analog: vec![
                AnalogKey {
                    time_ms: 0,
                    channel: 0,
                    value: 0,
                },
                AnalogKey {
                    time_ms: 1_000,
                    channel: 0,
                    value: 1_000,
                },
            ],
        },
        OutputTrack {
            box_index: 1,
            digital: vec![DigitalKey {
                time_ms: 200,
                bits: 0x0FFF,
            }],
            analog: Vec::new(),
        },
    ];
    entry.show.check().unwrap();
    entry
}

#[test]
fn frames_carry_the_outputs_at_their_show_time_and_0_outside_the_show() {
    let mut player = player();
    let mut twins = twins();
    let mut now = 0;
    let entry = entry_with_outputs();
    let duration_ms = entry.show.duration_ms();
    assert_eq!(duration_ms, 1_000);
    player.start(now, vec![entry], false).unwrap();
    let mut played = Vec::new();
    let mut log = |status: &Status, frame: &MboxFrame, twins: &[MboxTwin]| {
        let snapshots: Vec<_> = twins
            .iter()
            .map(|twin| {
                let snapshot = twin.snapshot();
                (snapshot.digital, snapshot.analog)
            })
            .collect();
        let sent: Vec<_> = frame
            .outputs
            .iter()
            .map(|one| (one.digital_bits, one.analog))
            .collect();
        // The twins keep what the frame carried.
        assert_eq!(snapshots, sent);
        if status.state == PlayerState::Playing {
            played.push((status.show_time_ms, sent));
        } else {
            // Homing and approaching: every output 0.
            assert_eq!(sent, vec![(0, [0, 0]); 2], "{:?}", status.state);
        }
    };
    run_logged(&mut player, &mut twins, &mut now, &mut log);
    let at = |t_ms: u64| {
        played
            .iter()
            .find(|(time, _)| *time == t_ms)
            .map(|(_, sent)| sent.clone())
            .unwrap()
    };
    // The approach's last frame (at the show's first positions, outputs 0) goes
    // while the show's start is given (`loading`, issue 34 item 5); the show's first
    // frame, at show time 0, is the first while playing and carries the outputs at 0.
    let at_0: Vec<_> = played.iter().filter(|(time, _)| *time == 0).collect();
    assert_eq!(at_0.len(), 1);
    assert_eq!(at_0[0].1, vec![(0b101, [0, 0]), (0, [0, 0])]);
    assert_eq!(at(20), vec![(0b101, [20, 0]), (0, [0, 0])]);
    assert_eq!(at(180), vec![(0b101, [180, 0]), (0, [0, 0])]);
    assert_eq!(at(200), vec![(0b101, [200, 0]), (0x0FFF, [0, 0])]);
    assert_eq!(at(480), vec![(0b101, [480, 0]), (0x0FFF, [0, 0])]);
    assert_eq!(at(500), vec![(0x0800, [500, 0]), (0x0FFF, [0, 0])]);
    assert_eq!(at(980), vec![(0x0800, [980, 0]), (0x0FFF, [0, 0])]);
    // The settle frames after the show's end switch everything off.
    let (end_ms, last) = played.last().unwrap();
    assert_eq!(*end_ms, duration_ms);
    assert_eq!(*last, vec![(0, [0, 0]); 2]);
    for twin in &twins {
        let snapshot = twin.snapshot();
        assert_eq!((snapshot.digital, snapshot.analog), (0, [0, 0]));
    }
}

#[test]
fn home_switches_the_outputs_off_and_an_estop_leaves_them() {
    let mut player = player();
    let mut now = 0;
    player
        .start(now, vec![entry_with_outputs()], false)
        .unwrap();
    let mut last_sent = None;
    while player.status().show_time_ms < 600 || player.status().state != PlayerState::Playing {
        now = player.next_wakeup_us(now).unwrap();
        player.poll(now);
        if let Some(frame) = player.take_frames().pop() {
            last_sent = Some(frame.outputs);
        }
    }
    let sent = last_sent.unwrap();
    assert_eq!(sent[0].digital_bits, 0x0800);
    // An e-stop sends nothing more: the boxes keep the last frame's outputs.
    player.estop();
    player.poll(now + 100_000);
    assert!(player.take_frames().is_empty());
    // Homing carries 0 from its first frame.
    player.home(now + 100_000);
    player.poll(now + 100_000);
    let frames = player.take_frames();
    assert_eq!(frames.len(), 1);
    assert_eq!(frames[0].outputs, vec![OutputSample::default(); 2]);
}

#[test]
fn outputs_for_a_box_the_installation_lacks_are_refused() {
    let mut player = player();
    let mut entry = entry_with_outputs();
    entry.show.outputs[1].box_index = 2;
    let error = player.start(0, vec![entry], false).unwrap_err();
    assert!(
        error
            .to_string()
            .contains("outputs for box 2 but the installation's MBOX boxes are 0–1"),
        "{error}"
    );
}

#[test]
fn the_report_says_a_valid_show_can_run_however_long_it_is() {
    let mut installation = player().config().installation.clone();
    for gateway in &mut installation.gateways {
        gateway.baud = 0; // as the configuration gives a box: it has no serial line
    }
    // Ten minutes of 100 ms rows: far more than a 256-row preload, which no serial
    // line would carry at 0 baud; an MBOX frame stream has no such limit.
    let long = demo::wave(2, 3, 6_000, 100);
    let verdict = report::report(&long, &installation, PlanOptions::default());
    assert!(verdict.feasible, "{:?}", verdict.reason);
    assert_eq!(verdict.reason, None);
    assert!(verdict.gateways.is_empty(), "{:?}", verdict.gateways);
    // Nothing is preloaded: frames carry positions as the show plays.
    assert_eq!((verdict.preload_ms, verdict.advice.len()), (0, 0));

    let wrong_size = demo::wave(1, 3, 10, 100);
    let verdict = report::report(&wrong_size, &installation, PlanOptions::default());
    assert!(!verdict.feasible);
    assert_eq!(
        verdict.reason.as_deref(),
        Some(
            "the show is made for 1 rows × 3 columns of balls but the installation has 2 \
             rows × 3 columns"
        )
    );

    let mut too_deep = demo::wave(2, 3, 10, 100);
    too_deep.tracks[4].start_mm = installation.limits.travel_mm + 100.0;
    let verdict = report::report(&too_deep, &installation, PlanOptions::default());
    assert!(!verdict.feasible);
    assert!(verdict.reason.is_some_and(|reason| !reason.is_empty()));
    let reason = verdict.reason_problem.expect("coded");
    assert_eq!(reason.code, "below_travel");
    assert_eq!(reason.params["unit"], "u4");
}

#[test]
fn the_report_codes_outputs_for_a_box_the_installation_lacks() {
    let installation = player().config().installation.clone();
    let mut show = entry_with_outputs().show;
    show.outputs[1].box_index = 2;
    let verdict = report::report(&show, &installation, PlanOptions::default());
    assert!(!verdict.feasible);
    assert!(
        verdict
            .reason
            .as_deref()
            .is_some_and(|reason| reason.contains("outputs for box 2")),
        "{verdict:?}"
    );
    let reason = verdict.reason_problem.expect("coded");
    assert_eq!(reason.code, "output_box");
    assert_eq!(reason.params["box"], "2");
    assert_eq!(reason.params["boxes"], "2");
}

/// `show`'s positions at `t_ms` as the boxes' frames carry them (box, then axis).
fn show_pulses(player: &MboxPlayer, show: &crate::show::Show, t_ms: u64) -> Vec<Vec<i32>> {
    let config = player.config();
    let mut sampler = crate::show::Sampler::new(show);
    let mut samples = vec![0.0; sampler.unit_count()];
    sampler.sample(t_ms as f64, &mut samples, None);
    let mut positions: Vec<Vec<i32>> = config
        .boxes
        .iter()
        .map(|calibration| vec![calibration.pulses(0.0); calibration.axes])
        .collect();
    for (address, &mm) in config.installation.units.iter().zip(&samples) {
        let calibration = config.boxes[address.gateway];
        positions[address.gateway][usize::from(address.station) - 1] =
            calibration.pulses(f64::from(mm));
    }
    positions
}

/// The frames of a whole run: Start with the positions unknown, `entry` its only show.
fn frames_of(player: &mut MboxPlayer, entry: Entry) -> Vec<MboxFrame> {
    let mut twins = twins();
    let mut now = 0;
    player.start(now, vec![entry], false).unwrap();
    let mut frames = Vec::new();
    run_logged(player, &mut twins, &mut now, &mut |_, frame, _| {
        frames.push(frame.clone());
    });
    frames
}

#[test]
fn a_show_frame_is_sent_for_every_sample_the_first_included() {
    let mut player = player();
    let entry = entry(1, 0);
    let show = entry.show.clone();
    let duration_ms = show.duration_ms();
    let period_ms = DEFAULT_PERIOD_US / 1_000;
    assert_eq!(duration_ms % period_ms, 0);
    let frames = frames_of(&mut player, entry);
    let first_position = show_pulses(&player, &show, 0);
    // The show's sample one period in differs from its first position: the first
    // frame that leaves the approach's target is the show's first.
    assert_ne!(show_pulses(&player, &show, period_ms), first_position);
    // The approach's frames (and its settle frames) carry the show's first position.
    let approach = frames
        .iter()
        .position(|frame| frame.positions_pulses == first_position)
        .expect("the approach to the show's first position");
    let first = approach
        + frames[approach..]
            .iter()
            .take_while(|frame| frame.positions_pulses == first_position)
            .count();
    let approach_end = &frames[first - 1];
    // Every period of the show has its frame: the target at the period's end, to be
    // reached in exactly one period, the first period included.
    let show_frames = usize::try_from(duration_ms / period_ms).unwrap();
    for k in 0..show_frames {
        let frame = &frames[first + k];
        let k_u64 = u64::try_from(k).unwrap();
        assert_eq!(
            frame.slot_us,
            approach_end.slot_us + (k_u64 + 1) * DEFAULT_PERIOD_US,
            "frame {k} of the show"
        );
        assert_eq!(u64::from(frame.time_ms), period_ms, "frame {k} of the show");
        assert_eq!(
            frame.positions_pulses,
            show_pulses(&player, &show, (k_u64 + 1) * period_ms),
            "frame {k} of the show: the sample at {} ms",
            (k_u64 + 1) * period_ms
        );
    }
    // Then the settle frames hold the last position.
    let last = show_pulses(&player, &show, duration_ms);
    let settle = &frames[first + show_frames..];
    assert_eq!(settle.len(), usize::try_from(SETTLE_FRAMES).unwrap());
    assert!(settle.iter().all(|frame| frame.positions_pulses == last));
}

#[test]
fn a_locate_moves_on_from_the_last_frame_and_after_a_move_from_anywhere() {
    use crate::player::{Drive, Phase};
    let config = config();
    let period_us = config.period_us;
    let travel_mm = config.installation.limits.travel_mm;
    let speed = config.installation.approach_speed_mm_s;
    let mut drive = MboxDrive::new(config);
    let mut show = MboxEntry::new(demo::wave(2, 3, 10, 100));
    drive.begin_run(0, None);
    drive.begin_play(0, &mut show, true);
    let mut now_us = 0;
    while now_us < 500_000 {
        assert_eq!(drive.poll(now_us, Some(&mut show)), Phase::Pending);
        now_us += period_us;
    }
    let last = drive.take_frames().pop().expect("show frames");
    // The timecode jumped: the show ends without an e-stop, and the move to the new
    // point goes from where the last frame sent the boxes, timed for that distance.
    assert!(drive.interrupt(now_us));
    assert_eq!(drive.show_start_us(), None);
    let mut target = MboxEntry::new(
        demo::wave(2, 3, 10, 100)
            .from_time(500, 1_000.0)
            .unwrap()
            .show,
    );
    assert!(drive.begin_approach(now_us, &mut target));
    drive.poll(now_us, Some(&mut target));
    let first = drive.take_frames().remove(0);
    let mut samples = vec![0.0; 6];
    target.sampler.sample(0.0, &mut samples, None);
    let from = &last.positions_pulses;
    let farthest_mm = samples
        .iter()
        .enumerate()
        .map(|(unit, &mm)| {
            let to = CALIBRATION.pulses(f64::from(mm));
            f64::from((to - from[unit / 3][unit % 3]).abs()) / CALIBRATION.pulses_per_mm
        })
        .fold(0.0, f64::max);
    let expected_ms = (farthest_mm / speed * 1e3).ceil() as u32;
    assert!(
        first.time_ms.abs_diff(expected_ms) <= 1 + (period_us / 1_000) as u32,
        "{} ms for {farthest_mm} mm",
        first.time_ms
    );
    // A locate during a move: the boxes are somewhere between, so the next move is
    // timed for the whole travel.
    assert!(drive.interrupt(now_us));
    assert!(drive.begin_approach(now_us, &mut target));
    drive.poll(now_us + period_us, Some(&mut target));
    let frame = drive.take_frames().remove(0);
    let whole_ms = (travel_mm / speed * 1e3) as u32;
    assert!(frame.time_ms + 50 >= whole_ms, "{} ms", frame.time_ms);
}

/// Sends `frame` to the twins as the bridge does (one datagram a box).
fn send(frame: &MboxFrame, twins: &mut [MboxTwin]) {
    let boxes = frame.positions_pulses.iter().zip(&frame.outputs);
    for (twin, (positions, outputs)) in twins.iter_mut().zip(boxes) {
        let datagram = MotionFrame {
            mode: TimeMode::Relative,
            route: Route::BROADCAST_SILENT,
            sequence: 0,
            time_code: TimeCode::from_ms(frame.time_ms),
            positions_pulses: AxisPositions::from_slice(positions).unwrap(),
            digital: DigitalOutputs::from_bits(outputs.digital_bits),
            analog: outputs.analog,
        };
        twin.receive(frame.slot_us, &datagram.encode());
    }
}

/// Polls the player live until `until_us`, handing `targets(t)` before each poll and
/// sending every frame to the twins; returns the frames.
fn run_live(
    player: &mut MboxPlayer,
    twins: &mut [MboxTwin],
    now_us: &mut u64,
    until_us: u64,
    targets: &dyn Fn(u64) -> Vec<Option<f64>>,
) -> Vec<MboxFrame> {
    let mut frames = Vec::new();
    while let Some(wake) = player.next_wakeup_us(*now_us) {
        if wake > until_us {
            break;
        }
        *now_us = wake.max(*now_us);
        let targets = targets(*now_us);
        player
            .sequencer_mut()
            .set_live_input(crate::player::LiveInput {
                targets_mm: &targets,
                ..Default::default()
            });
        player.poll(*now_us);
        for frame in player.take_frames() {
            send(&frame, twins);
            frames.push(frame);
        }
    }
    *now_us = until_us.max(*now_us);
    frames
}

#[test]
fn live_frames_every_period_follow_the_filter_and_the_twins_take_them() {
    use crate::api::LivePhase;
    let mut player = player();
    let mut twins = twins();
    let limits = player.config().installation.limits;
    let mut now = 0;
    let first = |_| vec![Some(1000.0); 6];
    player
        .sequencer_mut()
        .set_live_input(crate::player::LiveInput {
            targets_mm: &first(0),
            ..Default::default()
        });
    player.sequencer_mut().go_live(now).unwrap();
    assert_eq!(player.status().state, PlayerState::Homing);
    // Homing (the whole travel at the approach speed), then the approach.
    let mut frames = run_live(&mut player, &mut twins, &mut now, 10_000_000, &first);
    let live = player.status().live.unwrap();
    assert_eq!(live.phase, LivePhase::Following);
    // Input to frame at most: a period waiting for the frame that takes it (no frame
    // lead nor send lateness here)…
    assert_eq!(live.latency_ms, 20);
    // … and with the bridge's: its 5 ms lead and the lateness its sender measured.
    player
        .sequencer_mut()
        .drive_mut()
        .set_send_timing(5_000, 1_200);
    assert_eq!(player.status().live.unwrap().latency_ms, 27);
    player.sequencer_mut().drive_mut().set_send_timing(0, 0);
    let at_1000: Vec<i32> = twins.iter().flat_map(MboxTwin::positions_pulses).collect();
    assert_eq!(at_1000, vec![CALIBRATION.pulses(1000.0); 6]);
    // A snap to the bottom and back on half the balls: frames every period, each a
    // move the limits allow.
    let from = now;
    let snap = move |t: u64| {
        let down = (t - from) < 1_500_000;
        (0..6)
            .map(|ball| {
                Some(if ball % 2 == 0 && down {
                    7000.0
                } else {
                    1000.0
                })
            })
            .collect()
    };
    let live_from = frames.len();
    frames.extend(run_live(
        &mut player,
        &mut twins,
        &mut now,
        from + 6_000_000,
        &snap,
    ));
    let live = &frames[live_from..];
    assert_eq!(live.len() as u64, 6_000_000 / DEFAULT_PERIOD_US);
    let per_frame_pulses = limits.max_speed_mm_s * 0.02 * CALIBRATION.pulses_per_mm;
    for pair in live.windows(2) {
        assert_eq!(pair[1].slot_us - pair[0].slot_us, DEFAULT_PERIOD_US);
        assert_eq!(pair[1].time_ms, 20);
        for (a, b) in pair[0]
            .positions_pulses
            .iter()
            .zip(&pair[1].positions_pulses)
        {
            for (a, b) in a.iter().zip(b) {
                assert!(f64::from((b - a).abs()) <= per_frame_pulses + 1.0);
            }
        }
    }
    let back: Vec<i32> = twins.iter().flat_map(MboxTwin::positions_pulses).collect();
    assert_eq!(back, vec![CALIBRATION.pulses(1000.0); 6]);
    for twin in &twins {
        let counters = twin.snapshot().counters;
        assert_eq!(
            counters.motion_frames,
            frames.len() as u64,
            "every frame taken"
        );
        assert_eq!(counters.datagrams, counters.motion_frames);
    }
    // Leave: braked to rest, idle, and a show then approaches without homing.
    player.sequencer_mut().leave_live(now);
    let until = now + 2_000_000;
    run_live(&mut player, &mut twins, &mut now, until, &snap);
    assert_eq!(player.status().state, PlayerState::Idle);
    assert_eq!(player.status().live, None);
    player.start(now, vec![entry(1, 0)], false).unwrap();
    assert_eq!(player.status().state, PlayerState::Approaching);
}

#[test]
fn live_after_an_estop_homes_first_and_a_live_request_during_a_show_is_refused() {
    let mut player = player();
    let mut twins = twins();
    let mut now = 0;
    player.start(now, vec![entry(1, 0)], false).unwrap();
    assert_eq!(player.sequencer_mut().go_live(now), Err(StartError::Busy));
    player.estop();
    player.sequencer_mut().go_live(now).unwrap();
    run_live(&mut player, &mut twins, &mut now, 20_000_000, &|_| {
        vec![Some(500.0); 6]
    });
    player.estop();
    assert_eq!(player.status().state, PlayerState::Stopped);
    assert!(player.take_frames().is_empty());
    player.sequencer_mut().go_live(now).unwrap();
    assert_eq!(player.status().state, PlayerState::Homing);
}

#[test]
fn with_a_clock_trim_each_frame_samples_the_show_at_the_given_clock() {
    let mut player = player();
    let entry = entry(1, 0);
    let show = entry.show.clone();
    let period_us = DEFAULT_PERIOD_US;
    let mut now = 0;
    player.start(now, vec![entry], false).unwrap();
    while player.status().state != PlayerState::Playing {
        now = player.next_wakeup_us(now).unwrap().max(now);
        player.poll(now);
        player.take_frames();
    }
    // The show's time 0 is this slot: the first trim is where its clock is.
    assert_eq!(player.status().show_time_ms, 0);
    let start_us = now;
    // A clock 0.5 % fast from the show's start: its show time at `t` is
    // 1.005 × (t − start); its time 0, seen from `t`, is `t − 1.005 × (t − start)`.
    let given_start = |t: u64| (t - (t - start_us) * 1_005 / 1_000) as i64;
    player.trim_clock(now, 0, given_start(now));
    let mut checked = 0;
    while player.status().state == PlayerState::Playing && now < start_us + 800_000 {
        now = player.next_wakeup_us(now).unwrap().max(now);
        player.trim_clock(now, 0, given_start(now));
        player.poll(now);
        for frame in player.take_frames() {
            let t_ms = (frame.slot_us as i64 - given_start(now)) as u64 / 1_000;
            assert_eq!(
                frame.positions_pulses,
                show_pulses(&player, &show, t_ms + period_us / 1_000),
                "the frame at {} µs samples the given clock's {t_ms} ms, a period on",
                frame.slot_us
            );
            checked += 1;
        }
        // The status counts the given clock's show time.
        let status = player.status();
        assert_eq!(
            status.show_time_ms,
            (now as i64 - given_start(now)) as u64 / 1_000
        );
    }
    assert!(checked >= 30, "{checked} frames");
    // A trim for another entry is not this show's: nothing changes.
    let before = player.status().show_time_ms;
    player.trim_clock(now, 1, 0);
    assert_eq!(player.status().show_time_ms, before);
    // Only the trims' changes count: a constant error in them moves nothing.
    player.trim_clock(now, 0, given_start(now) + 40_000);
    assert_eq!(player.status().show_time_ms, before - 40);
}

/// Issue 38's latency: a change of the input just after a slot, the balls at rest,
/// goes out half a period after that slot (not a whole period), its step filtered
/// for the 10 ms it really has; the frames then go a period apart from it, and a
/// fader that keeps moving stays on that grid.
#[test]
fn a_live_change_after_a_quiet_period_goes_before_the_next_slot_filtered_for_its_time() {
    let mut player = player();
    let mut twins = twins();
    let limits = player.config().installation.limits;
    let mut now = 0;
    let rest = |_| vec![Some(1000.0); 6];
    player
        .sequencer_mut()
        .set_live_input(crate::player::LiveInput {
            targets_mm: &rest(0),
            ..Default::default()
        });
    player.sequencer_mut().go_live(now).unwrap();
    let frames = run_live(&mut player, &mut twins, &mut now, 10_000_000, &rest);
    let last = frames.last().unwrap().clone();
    assert_eq!(last.positions_pulses[0][0], CALIBRATION.pulses(1000.0));
    // 1 ms after the last slot the fader moves: too soon for a frame (the gap is
    // half a period), but the next is due 10 ms after the slot, not 20.
    now = last.slot_us + 1_000;
    assert!(player.sequencer().live_awaits_change());
    let moved = vec![Some(1100.0); 6];
    player
        .sequencer_mut()
        .set_live_input(crate::player::LiveInput {
            targets_mm: &moved,
            ..Default::default()
        });
    assert!(!player.sequencer().live_awaits_change());
    player.poll(now);
    assert!(player.take_frames().is_empty());
    let due = player.next_wakeup_us(now).unwrap();
    assert_eq!(due, last.slot_us + 10_000);
    player.poll(due + 300);
    let early = player.take_frames();
    assert_eq!(early.len(), 1, "{early:?}");
    let early = &early[0];
    assert_eq!(early.slot_us, last.slot_us + 10_000);
    assert_eq!(early.time_ms, 20);
    // From rest, a 10 ms step moves at most a·dt²/2 (2 mm here; a 20 ms step could
    // move 8 mm) and the state's speed is at most a·dt.
    let moved_pulses = (early.positions_pulses[0][0] - last.positions_pulses[0][0]).abs();
    assert!(moved_pulses > 0);
    let dt_s = 0.010;
    assert!(
        f64::from(moved_pulses)
            <= limits.max_accel_mm_s2 * dt_s * dt_s / 2.0 * CALIBRATION.pulses_per_mm + 1.0,
        "{moved_pulses} pulses in 10 ms"
    );
    for state in player.sequencer().live_states() {
        assert!(state.velocity_mm_s <= limits.max_accel_mm_s2 * dt_s + 1e-6);
    }
    send(early, &mut twins);
    // The fader keeps moving (a new value every 10 ms): frames a period apart from
    // the early one, each a move within the limits.
    let from = now;
    let fader = move |t: u64| vec![Some(1100.0 + (t - from) as f64 / 10_000.0); 6];
    let following = run_live(&mut player, &mut twins, &mut now, from + 1_000_000, &fader);
    assert!(following.len() >= 49, "{}", following.len());
    assert_eq!(following[0].slot_us, early.slot_us + 20_000);
    let per_frame_pulses = limits.max_speed_mm_s * 0.02 * CALIBRATION.pulses_per_mm;
    for pair in following.windows(2) {
        assert_eq!(pair[1].slot_us - pair[0].slot_us, DEFAULT_PERIOD_US);
        let step = (pair[1].positions_pulses[0][0] - pair[0].positions_pulses[0][0]).abs();
        assert!(f64::from(step) <= per_frame_pulses + 1.0);
    }
    for twin in &twins {
        let counters = twin.snapshot().counters;
        assert_eq!(counters.time_code_faults, 0);
        assert_eq!(counters.wrong_axes, 0);
    }
}
