//! The twin against the document's vectors: motion, time, registers, e-stop, reset,
//! effects, addressing, sequence numbers and refused datagrams.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::super::tests::{document_motion_frame, hex};
use super::*;
use crate::mbox::{AxisPositions, RegisterRange};

/// The document's 10-axis relative vector (100 ms, every axis to 50 000).
const RELATIVE_TEN: &str = "55 aa 00 00 14 01 00 02 ff ff ff ff 00 00 00
     01 00 00 00 64 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
     50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3 50 00 00 c3
     50 00 00 c3 50 12 34 56 78 ab cd";
/// The document's e-stop, its release, the reset and "all effects on".
const ESTOP: &str = "55 aa 00 00 12 01 00 00 ff ff ff ff 00 90 00 01 00 01";
const RELEASE: &str = "55 aa 00 00 12 01 00 00 ff ff ff ff 00 90 00 01 00 00";
const RESET: &str = "55 aa 00 00 12 01 00 02 ff ff ff ff 00 00 00 01 00 00";
const EFFECTS: &str = "55 aa 00 00 12 01 00 02 ff ff ff ff 00 01 00 01 ff ff";
/// Read FN001, FN002 from every box, every box replying; and the document's reply.
const READ_FN: &str = "55 aa 00 00 11 01 00 01 ff ff ff ff 00 01 00 02";
const REPLY_FN: &str = "55 aa 00 00 11 02 00 01 00 00 00 00 00 01 00 02 00 00 00 00";

fn twin() -> MboxTwin {
    MboxTwin::new(TwinConfig::default())
}

/// A frame for the default twin: every axis to `pulses`, broadcast, no reply.
fn frame(mode: TimeMode, sequence: u32, time_ms: u32, pulses: i32) -> Vec<u8> {
    MotionFrame {
        mode,
        route: Route::BROADCAST_SILENT,
        sequence,
        time_code: TimeCode::from_ms(time_ms),
        positions_pulses: AxisPositions::uniform(AxisCount::Ten, pulses),
        digital: DigitalOutputs::NONE,
        analog: [0, 0],
    }
    .encode()
}

fn read(twin: &mut MboxTwin, now_us: u64, bank: ReadBank, start: u16, count: usize) -> Vec<u16> {
    let request = RegisterRead {
        bank,
        route: Route::to(twin.address()),
        range: RegisterRange::new(start, count).unwrap(),
    };
    let reply = twin.receive(now_us, &request.encode()).expect("a reply");
    match Datagram::decode(&reply) {
        Ok(Datagram::ReadReply(reply)) => {
            assert_eq!(reply.bank, bank);
            assert_eq!(reply.route, Route::REPLY);
            assert_eq!(reply.block.start(), start);
            reply.block.values().to_vec()
        }
        other => panic!("not a read reply: {other:?}"),
    }
}

#[test]
fn the_documents_relative_frame_moves_every_axis_linearly_over_its_time() {
    let mut twin = twin();
    assert_eq!(twin.receive(1_000, &hex(RELATIVE_TEN)), None);
    assert_eq!(twin.next_event_us(), Some(101_000));
    twin.advance(26_000);
    assert_eq!(twin.positions_pulses(), vec![12_500; 10]);
    twin.advance(101_000);
    let snapshot = twin.snapshot();
    assert_eq!(snapshot.positions_pulses, vec![50_000; 10]);
    assert!(!snapshot.moving);
    assert_eq!(
        (snapshot.digital, snapshot.analog),
        (0x1234, [0x5678, 0xABCD])
    );
    assert_eq!(snapshot.counters.motion_frames, 1);
}

#[test]
fn time_code_zero_takes_the_boxs_default_in_either_mode() {
    for mode in [TimeMode::Absolute, TimeMode::Relative] {
        let mut twin = twin();
        // The document's own absolute vectors carry time code 0.
        let wire = match mode {
            TimeMode::Absolute => document_motion_frame(mode, AxisCount::Ten).encode(),
            TimeMode::Relative => frame(mode, 1, 0, 50_000),
        };
        twin.receive(0, &wire);
        assert_eq!(twin.next_event_us(), Some(100_000), "{mode:?}");
        twin.advance(50_000);
        assert_eq!(twin.positions_pulses()[9], 25_000);
    }
    // A box configured for another internal time takes that.
    let mut twin = MboxTwin::new(TwinConfig {
        default_frame_ms: 40,
        ..TwinConfig::default()
    });
    twin.receive(0, &frame(TimeMode::Relative, 1, 0, 1_000));
    assert_eq!(twin.next_event_us(), Some(40_000));
}

#[test]
fn an_absolute_frame_lasts_from_the_last_time_code_to_its_own() {
    let mut twin = twin();
    // (arrival µs, time code ms, when the move ends µs)
    let steps = [
        // The first has no earlier time code: the default 100 ms.
        (0, 15_000, 100_000),
        // The document's example: 15 000 ms then 15 100 ms → 100 ms.
        (100_000, 15_100, 200_000),
        // 250 ms later on the film.
        (200_000, 15_350, 450_000),
        // A time code not after the last one (the film rewound): the default.
        (450_000, 15_000, 550_000),
        // Time code 0: the default, and the last time code stays 15 000…
        (550_000, 0, 650_000),
        // …so 15 020 lasts 20 ms.
        (650_000, 15_020, 670_000),
    ];
    for (sequence, (now_us, code, end_us)) in (1..).zip(steps) {
        let pulses = i32::try_from(sequence).unwrap() * 1_000;
        twin.receive(now_us, &frame(TimeMode::Absolute, sequence, code, pulses));
        assert_eq!(twin.next_event_us(), Some(end_us), "time code {code}");
    }
    // The rewind was a fault; the first frame and time code 0 were not.
    assert_eq!(twin.counters().time_code_faults, 1);
}

#[test]
fn a_repeated_or_decreasing_absolute_time_code_is_a_fault() {
    let mut twin = twin();
    // (time code ms, a fault)
    let codes = [
        (4_394, false),
        // The same code again: a move in 0 ms.
        (4_394, true),
        (4_394, true),
        (4_414, false),
        // Back in time.
        (4_400, true),
        (4_420, false),
        (4_440, false),
    ];
    let mut faults = 0;
    for (sequence, (code, fault)) in (1..).zip(codes) {
        let now_us = u64::from(sequence) * 20_000;
        twin.receive(now_us, &frame(TimeMode::Absolute, sequence, code, 1_000));
        faults += u64::from(fault);
        assert_eq!(twin.counters().time_code_faults, faults, "time code {code}");
    }
    // Relative frames have no time code to repeat.
    for sequence in 8..10 {
        twin.receive(200_000, &frame(TimeMode::Relative, sequence, 20, 1_000));
    }
    assert_eq!(twin.snapshot().counters.time_code_faults, faults);
    // A reset starts the time base over: the next code is no fault, whatever it is.
    twin.receive(300_000, &hex(RESET));
    twin.receive(400_000, &frame(TimeMode::Absolute, 10, 20, 0));
    twin.receive(420_000, &frame(TimeMode::Absolute, 11, 40, 0));
    assert_eq!(twin.counters().time_code_faults, faults);
}

#[test]
fn an_early_frame_starts_from_where_the_axis_is_and_a_late_one_from_its_target() {
    let mut twin = twin();
    twin.receive(0, &frame(TimeMode::Relative, 1, 100, 10_000));
    // Early: halfway (at 5 000), the next frame sends it to 0 over 100 ms.
    twin.receive(50_000, &frame(TimeMode::Relative, 2, 100, 0));
    assert_eq!(twin.snapshot().targets_pulses, vec![0; 10]);
    twin.advance(100_000);
    assert_eq!(twin.positions_pulses(), vec![2_500; 10]);
    // Late: it rested at 0 from 150 ms; the next frame starts from there at 300 ms.
    twin.advance(300_000);
    assert_eq!(twin.positions_pulses(), vec![0; 10]);
    twin.receive(300_000, &frame(TimeMode::Relative, 3, 200, -4_000));
    twin.advance(350_000);
    assert_eq!(twin.positions_pulses(), vec![-1_000; 10]);
}

#[test]
fn the_estop_stops_every_axis_where_it_is_and_holds_it_until_released() {
    let mut twin = twin();
    twin.receive(0, &hex(RELATIVE_TEN));
    assert_eq!(twin.receive(40_000, &hex(ESTOP)), None);
    let stopped = twin.snapshot();
    assert!(stopped.estop && !stopped.moving);
    assert_eq!(stopped.positions_pulses, vec![20_000; 10]);
    assert_eq!(stopped.targets_pulses, vec![20_000; 10]);
    // Frames are ignored; a reset does not move it either.
    twin.receive(50_000, &frame(TimeMode::Relative, 2, 100, 0));
    twin.receive(60_000, &hex(RESET));
    twin.advance(1_000_000);
    assert_eq!(twin.positions_pulses(), vec![20_000; 10]);
    assert_eq!(twin.counters().ignored_estop, 1);
    // Readable: FN 0x0090 = 1.
    assert_eq!(read(&mut twin, 1_000_000, ReadBank::Fn, FN_ESTOP, 1), [1]);
    // Released, the next frame moves it from where it stopped.
    twin.receive(1_000_000, &hex(RELEASE));
    assert!(!twin.estopped());
    assert_eq!(read(&mut twin, 1_000_000, ReadBank::Fn, FN_ESTOP, 1), [0]);
    twin.receive(1_000_000, &frame(TimeMode::Relative, 3, 100, 30_000));
    twin.advance(1_050_000);
    assert_eq!(twin.positions_pulses(), vec![25_000; 10]);
}

#[test]
fn reset_brings_every_axis_home_and_effects_are_kept() {
    let mut twin = twin();
    twin.receive(0, &hex(RELATIVE_TEN));
    twin.advance(100_000);
    twin.receive(100_000, &hex(EFFECTS));
    assert_eq!(twin.snapshot().effects_mask, 0xFFFF);
    assert_eq!(twin.receive(100_000, &hex(RESET)), None);
    // 50 000 pulses at RESET_PULSES_PER_S: half a second.
    assert_eq!(twin.next_event_us(), Some(600_000));
    twin.advance(350_000);
    assert_eq!(twin.positions_pulses(), vec![25_000; 10]);
    twin.advance(600_000);
    let snapshot = twin.snapshot();
    assert_eq!(snapshot.positions_pulses, vec![0; 10]);
    assert_eq!((snapshot.play_control, snapshot.effects_mask), (0, 0xFFFF));
}

#[test]
fn reads_answer_with_the_documents_reply_only_when_the_replier_asks() {
    let mut twin = twin();
    // Every box replies: the document's reply, byte for byte.
    assert_eq!(twin.receive(0, &hex(READ_FN)), Some(hex(REPLY_FN)));
    // Replier 0: no reply; another box's address: no reply.
    let mut silent = hex(READ_FN);
    silent[10..12].copy_from_slice(&[0, 0]);
    assert_eq!(twin.receive(0, &silent), None);
    silent[10..12].copy_from_slice(&[0x05, 0x10]);
    assert_eq!(twin.receive(0, &silent), None);
    // Its own address.
    silent[10..12].copy_from_slice(&[0x0F, 0xC9]);
    assert_eq!(twin.receive(0, &silent), Some(hex(REPLY_FN)));
    // DN parameters (the document names none) read 0; the IP is in FN020–FN023.
    assert_eq!(read(&mut twin, 0, ReadBank::Dn, 0x10, 16), [0; 16]);
    assert_eq!(
        read(&mut twin, 0, ReadBank::Fn, FN_IP, 4),
        [192, 168, 15, 201]
    );
    let counters = twin.counters();
    assert_eq!((counters.register_reads, counters.replies), (6, 4));
}

#[test]
fn fn_writes_saved_survive_a_power_cycle_and_unsaved_ones_do_not() {
    let mut twin = twin();
    let volatile = RegisterWrite {
        bank: WriteBank::FnVolatile,
        route: Route::BROADCAST_SILENT,
        block: RegisterBlock::new(0x0001, vec![7, 8]).unwrap(),
    };
    let saved = RegisterWrite {
        bank: WriteBank::FnSaved,
        block: RegisterBlock::new(0x0003, vec![9]).unwrap(),
        ..volatile.clone()
    };
    assert_eq!(twin.receive(0, &volatile.encode()), None);
    assert_eq!(twin.receive(0, &saved.encode()), None);
    assert_eq!(read(&mut twin, 0, ReadBank::Fn, 0x0001, 3), [7, 8, 9]);
    twin.receive(0, &hex(EFFECTS));
    twin.power_cycle(10);
    assert_eq!(read(&mut twin, 10, ReadBank::Fn, 0x0001, 3), [0, 0, 9]);
    assert_eq!(twin.snapshot().effects_mask, 0);
}

#[test]
fn a_saved_new_ip_is_the_address_after_a_power_cycle() {
    let mut twin = twin();
    let new_ip = Ipv4Addr::new(10, 0, 5, 16);
    twin.receive(0, &RegisterWrite::set_ip(Route::BROADCAST, new_ip).encode());
    assert_eq!(twin.address(), BoxAddress(0x0FC9));
    twin.power_cycle(1);
    assert_eq!(twin.address(), BoxAddress(0x0510));
    assert_eq!(twin.snapshot().ip, "10.0.5.16");
    // A saved e-stop is engaged at power-on too.
    let mut twin = self::twin();
    let estop = RegisterWrite {
        bank: WriteBank::FnSaved,
        ..RegisterWrite::estop(Route::BROADCAST_SILENT)
    };
    twin.receive(0, &estop.encode());
    twin.receive(0, &hex(RELEASE));
    assert!(!twin.estopped());
    twin.power_cycle(1);
    assert!(twin.estopped());
}

#[test]
fn datagrams_for_other_boxes_are_counted_and_ignored() {
    let mut twin = twin();
    let mut other = frame(TimeMode::Relative, 1, 100, 5_000);
    other[8..10].copy_from_slice(&[0x0F, 0xCA]);
    twin.receive(0, &other);
    // Addressed to it (0x0FC9).
    let mut mine = frame(TimeMode::Relative, 2, 100, 6_000);
    mine[8..10].copy_from_slice(&[0x0F, 0xC9]);
    twin.receive(0, &mine);
    // A read reply is what a box sends, not takes.
    twin.receive(0, &hex(REPLY_FN));
    // A 3-axis frame to a 10-axis box.
    twin.receive(
        0,
        &document_motion_frame(TimeMode::Relative, AxisCount::Three).encode(),
    );
    twin.advance(1_000_000);
    assert_eq!(twin.positions_pulses(), vec![6_000; 10]);
    let counters = twin.counters();
    assert_eq!(
        (
            counters.datagrams,
            counters.not_for_this_box,
            counters.unexpected,
            counters.wrong_axes,
            counters.motion_frames
        ),
        (4, 1, 1, 1, 1)
    );
}

#[test]
fn sequence_gaps_and_repeats_are_counted_and_zero_is_unnumbered() {
    let mut twin = twin();
    for sequence in [1, 2, 5, 5, 3, 0, 0, 4, 9] {
        twin.receive(0, &frame(TimeMode::Relative, sequence, 20, 0));
    }
    let counters = twin.counters();
    // 2 → 5 skips 3 and 4; 4 → 9 skips 5–8; 5 again and 3 are repeats.
    assert_eq!(counters.sequence_gaps, 2);
    assert_eq!(counters.sequence_skipped, 2 + 4);
    assert_eq!(counters.sequence_repeats, 2);
    assert_eq!(counters.motion_frames, 9);
}

#[test]
fn malformed_datagrams_are_counted_by_reason() {
    let mut twin = twin();
    let good = hex(ESTOP);
    let mut bad_magic = good.clone();
    bad_magic[0] = 0x56;
    let mut bad_pass = good.clone();
    bad_pass[3] = 1;
    let mut unknown_function = good.clone();
    unknown_function[5] = 0x07;
    let mut unknown_channel = good.clone();
    unknown_channel[7] = 3;
    let mut register_length = good.clone();
    register_length.push(0);
    let mut empty_range = hex(READ_FN);
    empty_range[15] = 0;
    let mut motion_length = hex(RELATIVE_TEN);
    motion_length.pop();
    for bytes in [
        &good[..5],
        &bad_magic,
        &bad_pass,
        &unknown_function,
        &unknown_channel,
        &register_length,
        &empty_range,
        &motion_length,
        &[][..],
    ] {
        assert_eq!(twin.receive(0, bytes), None);
    }
    let malformed = twin.counters().malformed;
    assert_eq!(
        malformed,
        SimMalformed {
            truncated: 2,
            bad_magic: 1,
            bad_pass_code: 1,
            unknown_function: 1,
            unknown_channel: 1,
            motion_length: 1,
            register_length: 1,
            registers: 1,
        }
    );
    assert_eq!(malformed.total(), 9);
    assert!(!twin.estopped());
    // Nothing panics whatever arrives.
    for length in 0..80 {
        let noise: Vec<u8> = (0..length).map(|i| (i * 37 + 0x55) as u8).collect();
        twin.receive(1, &noise);
    }
}

#[test]
fn three_and_six_axis_boxes_take_their_own_frames() {
    for axes in [AxisCount::Three, AxisCount::Six] {
        let mut twin = MboxTwin::new(TwinConfig::new(FACTORY_IP, axes));
        twin.receive(0, &document_motion_frame(TimeMode::Relative, axes).encode());
        twin.advance(100_000);
        assert_eq!(twin.positions_pulses(), vec![50_000; axes.count()]);
    }
}
