//! The MBOX player against twins ([`crate::mbox::twin`]) fed its frames as datagrams.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::*;
use crate::api::PlayerState;
use crate::mbox::twin::{MboxTwin, TwinConfig};
use crate::mbox::{
    AxisCount, AxisPositions, DigitalOutputs, Encode, MotionFrame, Route, TimeCode, TimeMode,
};
use crate::plan::installation::{DriveKind, GatewaySpec, Stations, allocate};
use crate::show::{Limits, demo};

const CALIBRATION: BoxCalibration = BoxCalibration {
    axes: 3,
    pulses_per_mm: 10.0,
    sign: -1,
    offset_pulses: 1_000,
};

/// A 2 × 3 matrix on two 3-axis boxes.
fn player() -> MboxPlayer {
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
    MboxPlayer::new(MboxPlayerConfig {
        installation,
        boxes: vec![CALIBRATION; 2],
        period_us: DEFAULT_PERIOD_US,
    })
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
    let mut states = vec![player.status().state];
    while let Some(wake) = player.next_wakeup_us(*now_us) {
        *now_us = wake.max(*now_us);
        player.poll(*now_us);
        for frame in player.take_frames() {
            for (twin, positions) in twins.iter_mut().zip(&frame.positions_pulses) {
                let datagram = MotionFrame {
                    mode: TimeMode::Relative,
                    route: Route::BROADCAST_SILENT,
                    sequence: 0,
                    time_code: TimeCode::from_ms(frame.time_ms),
                    positions_pulses: AxisPositions::from_slice(positions).unwrap(),
                    digital: DigitalOutputs::NONE,
                    analog: [0, 0],
                };
                twin.receive(frame.slot_us, &datagram.encode());
            }
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
            PlayerState::Playing,
            PlayerState::Approaching,
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
    assert!(matches!(
        player.start(0, vec![wrong], false),
        Err(StartError::Invalid { entry: 1, .. })
    ));
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
            PlayerState::Playing,
            PlayerState::Idle
        ]
    );
    assert_eq!(player.status().last_error, None);
}
