//! The seed's example programs on the twin, each with the behaviour the seed describes;
//! RS-485 addressing and the start wire on a bus; stop-and-kill; `QL`/`QS`/`QE`/`QU`;
//! what the Host Command Reference refuses (immediate commands never stored, full
//! segments and buffers, `CS` not jogging, `JA`/`JL` jogging); and random lines that
//! must never panic a drive.

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

use super::super::tests::SEED_PROGRAMS;
use super::*;
use crate::scl::{Address, IoPoint, Level, QueueUpload, Segment, UploadHeader};

const S: u64 = 1_000_000;

fn point(n: u8) -> IoPoint {
    IoPoint::new(n).unwrap()
}

fn segment(n: u8) -> Segment {
    Segment::new(n).unwrap()
}

fn drive() -> Drive {
    Drive::new(DriveConfig::default())
}

/// Stores `program` (one command a line) as `segment` the HCR's way — `QL`, the
/// lines, `QS n` (p. 216, 218) — checking the answers.
fn store(drive: &mut Drive, n: u8, program: &str, now_us: u64) {
    let prefix = drive.address().map(|a| a.to_string()).unwrap_or_default();
    assert_eq!(
        drive.receive_line(&format!("{prefix}QL"), now_us),
        Some(format!("{prefix}%\r"))
    );
    for line in program.lines() {
        assert_eq!(
            drive.receive_line(&format!("{prefix}{line}\r"), now_us),
            Some(format!("{prefix}*\r")),
            "{line}"
        );
    }
    assert_eq!(
        drive.receive_line(&format!("{prefix}QS{n}\r"), now_us),
        Some(format!("{prefix}%\r"))
    );
    assert_eq!(
        drive.segment(segment(n)).unwrap().len(),
        program.lines().count()
    );
}

/// `QX n` from the host: buffered (HCR p. 220), it runs the segment at once.
fn run(drive: &mut Drive, n: u8, now_us: u64) {
    assert_eq!(
        drive.receive_line(&format!("QX{n}"), now_us).as_deref(),
        Some("*\r")
    );
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() < 1e-6
}

fn ends(drive: &Drive) -> Vec<(f64, f64)> {
    drive
        .move_ends()
        .iter()
        .map(|e| (e.at_s, e.position_counts))
        .collect()
}

#[test]
fn feed_to_length_waits_for_the_falling_edge_on_input_3_then_turns_4_times() {
    let mut d = drive();
    store(&mut d, 1, SEED_PROGRAMS[0], 0);
    run(&mut d, 1, 0);
    d.advance(S);
    assert_eq!(d.position_counts(), 0.0);
    assert_ne!(d.status_code() & status::WAITING_INPUT, 0);
    assert_ne!(d.status_code() & status::Q_RUNNING, 0);
    // A rising edge is not the one it waits for.
    d.set_input(point(3), Level::Low, S / 2);
    d.set_input(point(3), Level::High, S / 2);
    d.set_input(point(3), Level::Low, S);
    // 80 000 counts, AC = DE = 25 rev/s² = 500 000 counts/s²: a triangle peaking at
    // 200 000 counts/s (below VE20 = 400 000), 0.4 s each way.
    d.advance(1_400_000);
    assert!(
        close(d.position_counts(), 40_000.0),
        "{}",
        d.position_counts()
    );
    assert!(close(d.velocity_counts_s(), 200_000.0));
    assert_ne!(d.status_code() & status::MOVING, 0);
    d.advance(2 * S);
    assert_eq!(d.position_counts(), 80_000.0);
    let ends = ends(&d);
    assert_eq!(ends.len(), 1);
    assert!(close(ends[0].0, 1.8) && ends[0].1 == 80_000.0, "{ends:?}");
    assert!(!d.is_executing());
    assert_eq!(d.status_code(), status::MOTOR_ENABLED | status::IN_POSITION);
    assert_eq!(d.receive_line("IP", 2 * S).as_deref(), Some("IP=80000\r"));
}

#[test]
fn feed_to_position_goes_out_waits_a_second_and_comes_back_to_0() {
    let mut d = drive();
    store(&mut d, 1, SEED_PROGRAMS[1], 0);
    run(&mut d, 1, 0);
    d.set_input(point(3), Level::Low, S);
    d.advance(5 * S);
    // AC = DE = 100 rev/s² = 2 000 000 counts/s², VE20 = 400 000 counts/s: 80 000
    // counts is exactly 0.2 s up and 0.2 s down.
    let ends = ends(&d);
    assert_eq!(ends.len(), 2, "{ends:?}");
    assert!(close(ends[0].0, 1.4) && ends[0].1 == 80_000.0, "{ends:?}");
    assert!(close(ends[1].0, 2.8) && ends[1].1 == 0.0, "{ends:?}");
    assert_eq!(d.position_counts(), 0.0);
}

#[test]
fn feed_to_sensor_runs_until_input_7_is_high_then_stops_di_later() {
    let mut d = drive();
    d.set_input(point(7), Level::Low, 0);
    store(&mut d, 1, SEED_PROGRAMS[2], 0);
    run(&mut d, 1, 0);
    d.set_input(point(3), Level::Low, S / 10);
    // VE5 = 100 000 counts/s, reached after 0.05 s (2 500 counts); the sensor at 0.6 s.
    d.advance(600_000);
    assert!(close(d.position_counts(), 2_500.0 + 100_000.0 * 0.45));
    assert_eq!(d.target_counts(), None);
    d.set_input(point(7), Level::High, 600_000);
    // DE needs 2 500 counts to stop from 100 000 counts/s: 5 500 more at speed
    // (0.055 s), then 0.05 s down: at rest 8 000 counts past the sensor.
    assert_eq!(d.target_counts(), Some(47_500.0 + 8_000.0));
    d.advance(650_000);
    assert!(close(d.velocity_counts_s(), 100_000.0));
    d.advance(2 * S);
    let first = ends(&d);
    assert!(
        close(first[0].0, 0.705) && first[0].1 == 55_500.0,
        "{first:?}"
    );
    // Then 1 s later back to 0 at 20 rev/s.
    d.advance(5 * S);
    let both = ends(&d);
    assert_eq!(both.len(), 2);
    assert_eq!(both[1].1, 0.0);
    assert!(both[1].0 > 1.705);
}

#[test]
fn feed_to_sensor_never_stops_sooner_than_de_allows() {
    // The seed: DI must exceed the minimum distance Dm = R·V²/(2·D) = 20 000 · 5² /
    // (2 · 100) = 2 500 counts; with DI1000 the twin stops Dm past the sensor.
    let mut d = drive();
    d.set_input(point(7), Level::Low, 0);
    store(&mut d, 1, "VE5\nDI1000\nFS7H", 0);
    run(&mut d, 1, 0);
    d.set_input(point(7), Level::High, S);
    let at_sensor = 2_500.0 + 100_000.0 * 0.95;
    d.advance(2 * S);
    assert_eq!(d.position_counts(), at_sensor + 2_500.0);
    assert!(close(d.move_ends()[0].at_s, 1.05));
    // Backwards (DI negative) and a falling edge.
    let mut d = drive();
    store(&mut d, 1, "VE5\nDI-8000\nFS7F", 0);
    run(&mut d, 1, 0);
    d.set_input(point(7), Level::Low, S);
    d.advance(2 * S);
    assert_eq!(d.position_counts(), -(at_sensor + 8_000.0));
}

#[test]
fn set_position_names_where_the_motor_stands() {
    // The seed: SP0 makes here the zero, SP5000 makes here 2.5 turns of a 2000-count
    // encoder; DI only sets the distance (nothing moves).
    let mut d = drive();
    store(&mut d, 1, SEED_PROGRAMS[3], 0);
    run(&mut d, 1, 0);
    d.advance(S);
    assert_eq!(d.receive_line("IP", S).as_deref(), Some("IP=5000\r"));
    assert_eq!(d.receive_line("DI", S).as_deref(), Some("DI=-8000\r"));
    assert!(d.move_ends().is_empty());
    // A move from there ends relative to the new zero.
    d.receive_line("FL", S);
    d.advance(2 * S);
    assert_eq!(d.position_counts(), -3_000.0);
}

#[test]
fn a_qg_loop_moves_waits_half_a_second_and_goes_round_for_ever() {
    let mut d = drive();
    // DI is buffered (HCR p. 77).
    assert_eq!(d.receive_line("DI1000", 0).as_deref(), Some("*\r"));
    store(&mut d, 1, SEED_PROGRAMS[4], 0);
    run(&mut d, 1, 0);
    d.advance(2 * S);
    // 1 000 counts at AC = DE = 2 000 000 counts/s²: 2·√(1000/2e6) s.
    let move_s = 2.0 * (1_000.0_f64 / 2e6).sqrt();
    let ends = ends(&d);
    assert_eq!(ends.len(), 4, "{ends:?}");
    for (i, (at_s, position)) in ends.iter().enumerate() {
        let n = i as f64;
        assert!(close(*at_s, (n + 1.0) * move_s + n * 0.5), "{ends:?}");
        assert_eq!(*position, (n + 1.0) * 1_000.0);
    }
    assert!(d.is_executing());
}

#[test]
fn a_qr_loop_runs_exactly_as_many_times_as_register_3_holds() {
    let mut d = drive();
    d.receive_line("DI1000", 0);
    store(&mut d, 1, SEED_PROGRAMS[5], 0);
    run(&mut d, 1, 0);
    d.advance(10 * S);
    assert_eq!(d.move_ends().len(), 5);
    assert_eq!(d.position_counts(), 5_000.0);
    assert!(!d.is_executing());
    assert_eq!(d.register(crate::scl::Register::new('3').unwrap()), 5);
    // Run again: the counter starts afresh.
    run(&mut d, 1, 10 * S);
    d.advance(20 * S);
    assert_eq!(d.position_counts(), 10_000.0);
}

#[test]
fn a_qj_jump_on_ti5l_turns_one_way_or_the_other() {
    // Input 5 high (inactive): line 7, clockwise.
    let mut d = drive();
    store(&mut d, 1, SEED_PROGRAMS[6], 0);
    run(&mut d, 1, 0);
    d.advance(S);
    assert_eq!(d.move_ends()[0].position_counts, 20_000.0);
    // Input 5 low (active): the jump to line 10, counter-clockwise.
    let mut d = drive();
    d.set_input(point(5), Level::Low, 0);
    store(&mut d, 1, SEED_PROGRAMS[6], 0);
    run(&mut d, 1, 0);
    d.advance(S);
    assert_eq!(d.move_ends()[0].position_counts, -20_000.0);
    // The condition is tested every round: switching the input turns it round.
    let before = ends(&d);
    assert!(before.windows(2).all(|w| w[1].1 - w[0].1 == -20_000.0));
    d.set_input(point(5), Level::High, S);
    d.advance(3 * S);
    let after = ends(&d);
    let n = after.len();
    assert!(n >= before.len() + 2);
    assert_eq!(after[n - 1].1 - after[n - 2].1, 20_000.0, "{after:?}");
    // Moves are 0.25 s apart.
    assert!(
        after.windows(2).all(|w| w[1].0 - w[0].0 > 0.25),
        "{after:?}"
    );
}

#[test]
fn qc_calls_segment_2_twice_and_its_outputs_toggle_every_quarter_second() {
    let mut d = drive();
    let mut lines = SEED_PROGRAMS[7].lines();
    assert_eq!(lines.next(), Some("QC2"));
    let segment_2: Vec<&str> = lines.collect();
    store(&mut d, 2, &segment_2.join("\n"), 0);
    // Segment 1 calls segment 2 at lines 6 and 10, as in the seed.
    store(
        &mut d,
        1,
        "DI4000\nFL\nWT0.1\nSO3L\nWT0.1\nQC2\nFL\nSO3H\nWT0.1\nQC2\nDI0\nFP",
        0,
    );
    run(&mut d, 1, 0);
    d.advance(5 * S);
    let ends = ends(&d);
    assert_eq!(ends.len(), 3);
    let first_call = ends[0].0 + 0.2;
    let second_call = ends[1].0 + 0.1;
    assert!(
        close(ends[1].0, first_call + 0.75 + (ends[0].0)),
        "{ends:?}"
    );
    let changes: Vec<(f64, u8, Level)> = d
        .output_changes()
        .iter()
        .map(|c| (c.at_s, c.output.get(), c.level))
        .collect();
    let expected = |t: f64| {
        vec![
            (t, 1, Level::Low),
            (t + 0.25, 2, Level::Low),
            (t + 0.5, 2, Level::High),
            (t + 0.75, 1, Level::High),
        ]
    };
    let mut want = vec![(ends[0].0 + 0.1, 3, Level::Low)];
    want.extend(expected(first_call));
    want.push((ends[1].0, 3, Level::High));
    want.extend(expected(second_call));
    assert_eq!(changes.len(), want.len(), "{changes:?}");
    for (got, want) in changes.iter().zip(&want) {
        assert!(
            close(got.0, want.0) && got.1 == want.1 && got.2 == want.2,
            "{got:?} vs {want:?}"
        );
    }
    assert_eq!(d.position_counts(), 0.0);
    // The queue holds the caller again.
    assert_eq!(d.queue(), d.segment(segment(1)).unwrap());
}

#[test]
fn calls_nest_five_deep_and_a_sixth_is_ignored() {
    let mut d = drive();
    for k in 1..=6_u8 {
        store(&mut d, k, &format!("SO{k}L\nQC{}\nQC", k + 1), 0);
    }
    store(&mut d, 7, "SO7L\nQC", 0);
    run(&mut d, 1, 0);
    d.advance(S);
    for k in 1..=6 {
        assert_eq!(d.output(point(k)), Level::Low, "Y{k}");
    }
    assert_eq!(d.output(point(7)), Level::High);
    assert!(!d.is_executing());
    // A QJ to its own line or past the end is ignored (HCR p. 167).
    store(&mut d, 10, "TI0H\nQJT2\nQJT9\nSO9L", 0);
    run(&mut d, 10, 0);
    assert_eq!(d.output(point(9)), Level::Low);
    // Calling a segment never written raises Blank Q Segment.
    store(&mut d, 8, "QC9\nSO8L", S);
    run(&mut d, 8, S);
    assert_eq!(d.alarm_code(), alarm::BLANK_Q_SEGMENT);
    assert_eq!(d.output(point(8)), Level::High);
}

#[test]
fn with_mt1_the_output_is_set_half_a_second_into_the_move_with_mt0_after_it() {
    // 400 000 counts at 10 rev/s = 200 000 counts/s: about 2.1 s.
    let mut mt1 = drive();
    mt1.receive_line("DI400000", 0);
    store(&mut mt1, 1, SEED_PROGRAMS[8], 0);
    run(&mut mt1, 1, 0);
    mt1.advance(5 * S);
    let move_end = mt1.move_ends()[0].at_s;
    assert!(move_end > 2.0);
    assert_eq!(mt1.output_changes().len(), 1);
    assert!(close(mt1.output_changes()[0].at_s, 0.5));
    // The same program with MT0: the output 0.5 s after the move.
    let mut mt0 = drive();
    mt0.receive_line("DI400000", 0);
    store(&mut mt0, 1, &SEED_PROGRAMS[8].replace("MT1", "MT0"), 0);
    run(&mut mt0, 1, 0);
    mt0.advance(5 * S);
    assert!(close(mt0.output_changes()[0].at_s, move_end + 0.5));
    // With MT1 moves still take turns: the second waits for the first.
    let mut d = drive();
    d.receive_line("DI400000", 0);
    store(&mut d, 1, "MT1\nFL\nFL\nSO1L", 0);
    run(&mut d, 1, 0);
    d.advance(10 * S);
    let ends = ends(&d);
    assert!(close(ends[1].0, 2.0 * ends[0].0), "{ends:?}");
    assert!(close(d.output_changes()[0].at_s, ends[0].0));
    assert_eq!(d.position_counts(), 800_000.0);
}

#[test]
fn on_a_bus_only_the_addressed_drive_answers_after_its_address() {
    let drives = "012"
        .chars()
        .map(|c| {
            Drive::new(DriveConfig {
                address: Address::new(c),
                ..DriveConfig::default()
            })
        })
        .collect();
    let mut bus = Bus::new(drives);
    assert_eq!(bus.receive(b"1DI8000\r", 0), b"1*\r");
    assert_eq!(bus.receive(b"1VE200\r", 0), b"1?5\r");
    assert_eq!(bus.receive(b"1AC10\r", 0), b"1*\r");
    assert_eq!(bus.receive(b"5SK\r", 0), b"");
    // A global line (no address) is for every drive; one that asks is answered by
    // each (HCR p. 305: they collide on a real line), one that sets, by none.
    assert_eq!(bus.receive(b"IP\r", 0), b"0IP=0\r1IP=0\r2IP=0\r");
    assert_eq!(bus.receive(b"JS2\r", 0), b"");
    // A line may arrive in pieces; two lines in one read.
    assert_eq!(bus.receive(b"2D", 0), b"");
    assert_eq!(bus.receive(b"I\r0DI", 0), b"2DI=0\r");
    assert_eq!(bus.receive(b"\r1DI\r", 0), b"0DI=0\r1DI=8000\r");
    assert_eq!(bus.receive(b"1FL\r", 0), b"1*\r");
    bus.advance(S);
    let at = |bus: &Bus, c| {
        bus.drive(Address::new(c).unwrap())
            .unwrap()
            .position_counts()
    };
    assert_eq!(
        (at(&bus, '0'), at(&bus, '1'), at(&bus, '2')),
        (0.0, 8000.0, 0.0)
    );
    assert_eq!(bus.receive(b"1IP\r", S), b"1IP=8000\r");
    assert_eq!(bus.receive(b"1XX\r", S), b"1?\r");
}

#[test]
fn the_start_wire_starts_every_drive_at_the_same_instant() {
    let drives: Vec<Drive> = "012"
        .chars()
        .map(|c| {
            let mut d = Drive::new(DriveConfig {
                address: Address::new(c),
                ..DriveConfig::default()
            });
            // Drive 0 is the trigger: its own program sets the wire (the bridge
            // never writes to a drive whose program runs).
            let program = if c == '0' {
                "SO2L\nDI1000\nFL"
            } else {
                "WI3F\nDI1000\nFL"
            };
            store(&mut d, 1, program, 0);
            if c != '0' {
                run_addressed(&mut d, c);
            }
            d
        })
        .collect();
    let mut bus = Bus::new(drives);
    bus.wire(StartWire {
        from: Address::new('0').unwrap(),
        output: point(2),
        input: point(3),
    });
    bus.advance(S);
    assert!(bus.drives().iter().all(|d| d.position_counts() == 0.0));
    // A buffered line to a drive whose program runs is refused: program running.
    assert_eq!(bus.receive(b"1SO2L\r", S), b"1?8\r");
    assert_eq!(bus.receive(b"0QX1\r", 1_234_567), b"0*\r");
    bus.advance(3 * S);
    for d in bus.drives() {
        assert_eq!(d.position_counts(), 1000.0);
        assert!(close(
            d.move_ends()[0].at_s,
            1.234_567 + 2.0 * (1_000.0_f64 / 2e6).sqrt()
        ));
    }
    // A program's own SO drives the wire too, at the instant it runs.
    let mut bus = Bus::new(
        "01".chars()
            .map(|c| {
                Drive::new(DriveConfig {
                    address: Address::new(c),
                    ..DriveConfig::default()
                })
            })
            .collect(),
    );
    bus.wire(StartWire {
        from: Address::new('0').unwrap(),
        output: point(2),
        input: point(3),
    });
    for line in [
        "1QL", "1WI3F", "1SO1L", "1QE", "0QL", "0WT0.3", "0SO2L", "0QE",
    ] {
        bus.receive_line(line, 0);
    }
    bus.advance(S);
    let drive_1 = bus.drive(Address::new('1').unwrap()).unwrap();
    assert!(close(drive_1.output_changes()[0].at_s, 0.3));
}

fn run_addressed(d: &mut Drive, c: char) {
    assert_eq!(
        d.receive_line(&format!("{c}QX1"), 0),
        Some(format!("{c}*\r"))
    );
}

#[test]
fn sk_mid_move_stops_at_de_and_empties_the_program_and_the_buffer() {
    let mut d = drive();
    d.receive_line("DI400000", 0);
    store(&mut d, 1, "FL\nSO1L\nFL", 0);
    run(&mut d, 1, 0);
    d.advance(S);
    let (x, v) = (d.position_counts(), d.velocity_counts_s());
    assert!(close(v, 200_000.0));
    assert_eq!(d.receive_line("SK", S).as_deref(), Some("%\r"));
    assert!(!d.is_executing());
    assert_ne!(d.status_code() & status::STOPPING, 0);
    d.advance(2 * S);
    // 200 000 counts/s at DE 2 000 000 counts/s²: 10 000 counts, 0.1 s.
    assert!(close(d.position_counts(), x + 10_000.0));
    assert!(close(d.move_ends()[0].at_s, 1.1));
    assert_eq!(d.output(point(1)), Level::High);
    assert!(!d.is_moving());
    // Buffered host commands are emptied too.
    d.receive_line("FL", 2 * S);
    d.receive_line("WT5", 2 * S);
    d.receive_line("SO1L", 2 * S);
    d.receive_line("SK", 2_500_000);
    d.advance(20 * S);
    assert_eq!(d.output(point(1)), Level::High);
    // ST stops the move but the buffer goes on.
    d.receive_line("FL", 20 * S);
    d.receive_line("SO1L", 20 * S);
    d.receive_line("ST", 21 * S);
    d.advance(22 * S);
    assert_eq!(d.output(point(1)), Level::Low);
}

#[test]
fn ql_and_qs_store_a_segment_and_qu_reads_it_back() {
    let mut d = drive();
    store(&mut d, 3, SEED_PROGRAMS[0], 0);
    let answer = d.receive_line("QU3", 0).unwrap();
    assert_eq!(answer, "%\rQU7\rWI3F\rAC25\rDE25\rVE20\rDI80000\rFL\r");
    let lines: Vec<&str> = answer.split_inclusive('\r').collect();
    assert_eq!(lines[0], "%\r");
    assert_eq!(
        QueueUpload::parse_header(lines[1]),
        Ok((None, UploadHeader::Lines(6)))
    );
    let (_, upload) = QueueUpload::parse(&lines[1..]).unwrap();
    assert_eq!(upload, d.queue_upload(Some(segment(3))));
    assert_eq!(d.receive_line("QU4", 0).as_deref(), Some("%\rQU0\r"));
    // The queue keeps what QL loaded.
    assert!(
        d.receive_line("QU0", 0)
            .unwrap()
            .starts_with("%\rQU7\rWI3F\r")
    );
    d.receive_line("QL", 0);
    assert_eq!(d.receive_line("QU0", 0).as_deref(), Some("%\rQU1\r"));
    assert_eq!(d.receive_line("QL3", 0).as_deref(), Some("%\r"));
    assert!(
        d.receive_line("QU0", 0)
            .unwrap()
            .starts_with("%\rQU7\rWI3F\r")
    );
    assert_eq!(d.receive_line("QS5", 0).as_deref(), Some("%\r"));
    assert_eq!(d.segment(segment(5)), d.segment(segment(3)));
    run(&mut d, 3, 0);
    assert_eq!(d.receive_line("QU3", 0).as_deref(), Some("%\rQU-1\r"));
    assert_eq!(d.receive_line("SK", 0).as_deref(), Some("%\r"));
    // On a shared line every line of the upload carries the address.
    let mut d = Drive::new(DriveConfig {
        address: Address::new('7'),
        ..DriveConfig::default()
    });
    store(&mut d, 1, "DI10\nFL", 0);
    assert_eq!(
        d.receive_line("7QU1", 0).as_deref(),
        Some("7%\r7QU3\r7DI10\r7FL\r")
    );
    // At most 62 lines: the 63rd is refused, queue full (HCR p. 304: `?6`); a
    // query is answered, not stored.
    let mut d = drive();
    d.receive_line("QL", 0);
    for _ in 0..62 {
        assert_eq!(d.receive_line("WT0.1", 0).as_deref(), Some("*\r"));
    }
    assert_eq!(d.receive_line("WT0.1", 0).as_deref(), Some("?6\r"));
    assert_eq!(d.receive_line("IP", 0).as_deref(), Some("IP=0\r"));
    assert_eq!(d.receive_line("QS2", 0).as_deref(), Some("%\r"));
    assert_eq!(d.segment(segment(2)).unwrap().len(), 62);
    assert_eq!(d.flash_writes(segment(2)), 1);
    // SK while the queue loads ends the load; nothing is saved.
    d.receive_line("QL", 0);
    d.receive_line("FL", 0);
    assert_eq!(d.receive_line("SK", 0).as_deref(), Some("%\r"));
    assert!(!d.is_loading());
    assert_eq!(d.segment(segment(4)), None);
    // `QW` is no MOONS' command: a real drive answers `?` (the HCR has none).
    assert_eq!(d.receive_line("QW1", 0).as_deref(), Some("?\r"));
}

#[test]
fn immediate_commands_sent_while_the_queue_loads_are_carried_out_never_stored() {
    // HCR p. 13: immediate commands are executed at once; a stored program is made
    // of buffered commands only. CS (p. 71) and SJ (p. 248) are immediate.
    let mut d = drive();
    assert_eq!(d.receive_line("QL", 0).as_deref(), Some("%\r"));
    for (line, answer) in [
        ("JS1", "*"),
        ("MT1", "*"),
        ("CJ", "*"),
        ("WT0.5", "*"),
        // Not jogging now (the queue is only loading): refused, not stored.
        ("CS2", "?7"),
        ("SJ", "%"),
        ("RLJ480", "%"),
        ("SC", "SC=0009"),
        ("RXJ480", "*"),
        ("WT0.5", "*"),
        ("SMD", "*"),
        ("WM", "*"),
        ("SO1L", "*"),
    ] {
        assert_eq!(
            d.receive_line(line, 0),
            Some(format!("{answer}\r")),
            "{line}"
        );
    }
    let queue: Vec<String> = d.queue().iter().map(ToString::to_string).collect();
    assert_eq!(
        queue,
        [
            "JS1", "MT1", "CJ", "WT0.5", "RXJ480", "WT0.5", "SMD", "WM", "SO1L"
        ]
    );
    assert!(
        d.queue()
            .iter()
            .all(|c| c.kind() == crate::scl::Kind::Buffered)
    );
    // QE ends the load and runs the queue from line 1, without touching memory.
    assert_eq!(d.receive_line("QE", 0).as_deref(), Some("%\r"));
    assert_eq!(d.flash_writes_total(), 0);
    d.advance(3 * S);
    // 1 rev/s (20 000 counts/s) for 0.5 s, then 2 rev/s (RXJ480: 480 × 0.25 rpm),
    // then the stop; SO1L after WM, when the motor stands.
    assert!(!d.is_executing() && !d.is_moving());
    let stop = d.move_ends()[0];
    assert!(close(d.output_changes()[0].at_s, stop.at_s), "{stop:?}");
    assert!(d.position_counts() > 20_000.0);
}

#[test]
fn the_command_buffer_holds_63_commands_pauses_and_continues() {
    let mut d = drive();
    assert_eq!(d.receive_line("BS", 0).as_deref(), Some("BS=63\r"));
    // HCR p. 206: PS holds what follows until CT (p. 72).
    assert_eq!(d.receive_line("PS", 0).as_deref(), Some("*\r"));
    assert_eq!(d.receive_line("BS", 0).as_deref(), Some("BS=63\r"));
    for n in 0..63 {
        assert_eq!(d.receive_line("WT0.01", 0).as_deref(), Some("*\r"), "{n}");
    }
    assert_eq!(d.receive_line("BS", 0).as_deref(), Some("BS=0\r"));
    // HCR p. 53: a command more overflows the buffer: `?6` (p. 304).
    assert_eq!(d.receive_line("WT0.01", 0).as_deref(), Some("?6\r"));
    d.advance(S);
    assert_eq!(d.receive_line("BS", S).as_deref(), Some("BS=0\r"));
    // CT continues it: a command leaves the buffer when it starts, one every 10 ms.
    assert_eq!(d.receive_line("CT", S).as_deref(), Some("%\r"));
    d.advance(S + 305_000);
    assert_eq!(
        d.receive_line("BS", S + 305_000).as_deref(),
        Some("BS=31\r")
    );
    d.advance(2 * S);
    assert_eq!(d.receive_line("BS", 2 * S).as_deref(), Some("BS=63\r"));
    let mut bus = Bus::new(
        "01".chars()
            .map(|c| {
                Drive::new(DriveConfig {
                    address: Address::new(c),
                    ..DriveConfig::default()
                })
            })
            .collect(),
    );
    for line in ["0PS", "1PS", "0DI100", "1DI200", "0FL", "1FL"] {
        bus.receive_line(line, 0);
    }
    bus.advance(S);
    assert!(bus.drives().iter().all(|d| d.position_counts() == 0.0));
    // One CT without an address starts both at once, unanswered (HCR p. 305).
    assert_eq!(bus.receive(b"CT\r", S), b"");
    bus.advance(2 * S);
    let ends: Vec<f64> = bus.drives().iter().map(|d| d.move_ends()[0].at_s).collect();
    assert!(
        ends.iter().all(|&at_s| at_s > 1.0 && at_s < 1.1),
        "{ends:?}"
    );
    assert_eq!(bus.drives()[1].position_counts(), 200.0);
}

#[test]
fn cs_is_signed_refused_unless_jogging_and_ja_jl_are_refused_while_jogging() {
    let mut d = drive();
    for line in ["JA10", "JL10", "JS1", "DI1", "CJ"] {
        assert_eq!(d.receive_line(line, 0).as_deref(), Some("*\r"), "{line}");
    }
    d.advance(S);
    // HCR p. 150, 155: JA and JL cannot change while jogging.
    assert_eq!(d.receive_line("JA20", S).as_deref(), Some("?7\r"));
    assert_eq!(d.receive_line("JL20", S).as_deref(), Some("?7\r"));
    // HCR p. 71: the sign of CS is the direction, whatever DI said.
    assert_eq!(d.receive_line("CS-1", S).as_deref(), Some("%\r"));
    d.advance(2 * S);
    assert!(d.velocity_counts_s() < 0.0);
    assert_eq!(d.receive_line("SJ", 2 * S).as_deref(), Some("%\r"));
    d.advance(3 * S);
    assert!(!d.is_moving());
    assert_eq!(d.receive_line("CS1", 3 * S).as_deref(), Some("?7\r"));
    assert_eq!(d.receive_line("JA20", 3 * S).as_deref(), Some("*\r"));
}

#[test]
fn a_jog_under_mt0_in_a_program_never_ends() {
    // HCR p. 64: SJ and ST are immediate, so a program cannot stop its jog; with
    // MT0 the program waits for CJ's move to end, which it never does.
    let mut d = drive();
    store(&mut d, 1, "MT0\nJS1\nCJ\nSO1L", 0);
    run(&mut d, 1, 0);
    d.advance(600 * S);
    assert!(d.is_jogging() && d.is_executing());
    assert!(d.output_changes().is_empty());
    // The e-stop ends it.
    assert_eq!(d.receive_line("SK", 600 * S).as_deref(), Some("%\r"));
    d.advance(601 * S);
    assert!(!d.is_moving() && !d.is_executing());
}

#[test]
fn a_call_returns_by_loading_its_caller_from_memory() {
    // HCR p. 210: the calling segment is loaded again from memory at the return.
    let mut d = drive();
    store(&mut d, 2, "SO1L\nQC", 0);
    store(&mut d, 1, "QC2\nSO2L", 0);
    run(&mut d, 1, 0);
    d.advance(S);
    assert_eq!(
        (d.output(point(1)), d.output(point(2))),
        (Level::Low, Level::Low)
    );
    // A queue loaded from the host is no segment: its call cannot return.
    let mut d = drive();
    store(&mut d, 2, "SO1L\nQC", 0);
    for line in ["QL", "QC2", "SO2L", "QE"] {
        d.receive_line(line, 0);
    }
    d.advance(S);
    assert_eq!(d.output(point(1)), Level::Low);
    assert_eq!(d.output(point(2)), Level::High);
    assert_eq!(d.alarm_code(), alarm::BLANK_Q_SEGMENT);
}

#[test]
fn values_below_a_drives_range_are_refused_and_the_rest_run_in_its_steps() {
    let mut d = drive();
    // The issue's creep: VE0.0006 … VE0.0024 are below the smallest VE (0.0042 rev/s);
    // AC/DE below 0.167 rev/s²; a negative or over-long WT (issue 34, item 3).
    for line in [
        "VE0.0006", "VE0.0024", "VE0.0041", "AC0.1", "DE0.166", "WT320.01", "VE100.01",
    ] {
        assert_eq!(d.receive_line(line, 0).as_deref(), Some("?5\r"), "{line}");
    }
    // Refused values are not taken.
    assert_eq!(d.receive_line("VE", 0).as_deref(), Some("VE=10\r"));
    for line in ["VE0.0042", "AC0.167", "DE0.167", "WT320", "WT0"] {
        assert_eq!(d.receive_line(line, 0).as_deref(), Some("*\r"), "{line}");
    }
    // VE0.6910 is held as 166 steps of 1/240 rev/s (0.69167 rev/s), AC2.5 as 15 steps
    // of 1/6 rev/s²: a 110 000-count FL lasts exactly what those give.
    let mut d = drive();
    for line in ["VE0.6910", "AC2.5", "DE2.5", "DI110000", "FL"] {
        d.receive_line(line, 0);
    }
    d.advance(20 * S);
    let (speed, accel) = (166.0 / 240.0 * 20_000.0, 15.0 / 6.0 * 20_000.0);
    let duration_s = speed / accel + 110_000.0 / speed;
    let end = d.move_ends()[0];
    assert!(
        (end.at_s - duration_s).abs() < 1e-9,
        "{end:?} vs {duration_s}"
    );
    // … and WT0.504 waits 0.50 s (whole hundredths).
    let mut d = drive();
    for line in ["WT0.504", "DI100", "FL"] {
        d.receive_line(line, 0);
    }
    d.advance(S);
    let start_s = d.move_ends()[0].at_s - (100.0_f64 / (100.0 * 20_000.0)).sqrt() * 2.0;
    assert!((start_s - 0.5).abs() < 1e-9, "{start_s}");
}

#[test]
fn refusals_and_alarms() {
    let mut d = Drive::new(DriveConfig {
        soft_limits_counts: Some((-1_000, 1_000)),
        ..DriveConfig::default()
    });
    for (line, answer) in [
        ("QG1", "?"),
        ("QC2", "?"),
        ("VE0", "?5"),
        ("VE200", "?5"),
        ("AC0", "?5"),
        ("EG10", "?5"),
        ("RXe5", "?5"),
        ("XX", "?"),
        ("di100", "?"),
        ("VE", "VE=10"),
        ("MT", "MT=0"),
        ("EG", "EG=20000"),
        ("SC", "SC=0009"),
        ("AL", "AL=0000"),
        ("QL1", "?"),
        ("QX1", "*"),
    ] {
        assert_eq!(
            d.receive_line(line, 0),
            Some(format!("{answer}\r")),
            "{line}"
        );
    }
    // QX of a blank segment raised Blank Q Segment; AR clears it.
    assert_eq!(d.alarm_code(), alarm::BLANK_Q_SEGMENT);
    assert_eq!(d.receive_line("SC", 0).as_deref(), Some("SC=0209\r"));
    assert_eq!(d.receive_line("AR", 0).as_deref(), Some("%\r"));
    // A move beyond a soft limit is not made: Position Limit.
    d.receive_line("DI2000", 0);
    d.receive_line("FP", 0);
    d.advance(S);
    assert_eq!(d.position_counts(), 0.0);
    assert_eq!(d.alarm_code(), alarm::POSITION_LIMIT);
    // While an alarm is present, and while the motor is disabled: No Move.
    d.receive_line("DI500", S);
    d.receive_line("FP", S);
    assert_eq!(d.alarm_code(), alarm::POSITION_LIMIT | alarm::NO_MOVE);
    d.receive_line("AR", S);
    assert_eq!(d.receive_line("MD", S).as_deref(), Some("*\r"));
    assert_eq!(d.status_code() & status::MOTOR_ENABLED, 0);
    d.receive_line("FP", S);
    assert_eq!(d.alarm_code(), alarm::NO_MOVE);
    d.receive_line("AR", S);
    d.receive_line("ME", S);
    d.receive_line("FP", S);
    d.advance(2 * S);
    assert_eq!(d.position_counts(), 500.0);
    // A buffered command while a program runs is refused, program running (`?8`;
    // our choice where the HCR is silent); immediate ones are not.
    store(&mut d, 1, "WT10", 2 * S);
    run(&mut d, 1, 2 * S);
    for line in ["FL", "WT1", "SO4L", "QX1"] {
        assert_eq!(
            d.receive_line(line, 2 * S).as_deref(),
            Some("?8\r"),
            "{line}"
        );
    }
    assert_eq!(d.output(point(4)), Level::High);
    assert_eq!(d.receive_line("QL", 2 * S).as_deref(), Some("?8\r"));
    assert_eq!(d.receive_line("QW1", 2 * S).as_deref(), Some("?\r"));
    assert_eq!(d.receive_line("SC", 2 * S).as_deref(), Some("SC=4809\r"));
    // Register math: the result in the accumulator, the condition code set.
    let mut d = drive();
    for line in [
        "RX17", "RX23", "R-12", "RM41", "R*12", "R/02", "TR07", "SP250", "EP0",
    ] {
        d.receive_line(line, 0);
    }
    let r = |c| d.register(crate::scl::Register::new(c).unwrap());
    assert_eq!((r('0'), r('4')), (7, 7));
    assert!(d.condition.meets(crate::scl::JumpCondition::Equal));
    assert_eq!(d.receive_line("IP", 0).as_deref(), Some("IP=250\r"));
    assert_eq!(d.receive_line("EP", 0).as_deref(), Some("EP=0\r"));
}

#[test]
fn a_loop_that_never_waits_does_not_hang_and_still_sees_its_input() {
    let mut d = drive();
    store(&mut d, 1, "TI5L\nQJT4\nQG1\nSO1L", 0);
    run(&mut d, 1, 0);
    d.advance(1_000 * S);
    assert!(d.is_executing());
    d.set_input(point(5), Level::Low, 1_000 * S);
    assert_eq!(d.output(point(1)), Level::Low);
    assert!(!d.is_executing());
    // Polling the position while an MT1 move runs: within a millisecond.
    let mut d = drive();
    d.receive_line("DI400000", 0);
    d.receive_line("RX1200000", 0);
    store(&mut d, 1, "MT1\nFL\nCRe1\nQJL3\nSO1L", 0);
    run(&mut d, 1, 0);
    d.advance(5 * S);
    let at_s = d.output_changes()[0].at_s;
    // 200 000 counts: halfway through the symmetric move.
    let half_s = d.move_ends()[0].at_s / 2.0;
    assert!(
        at_s >= half_s - 1e-9 && at_s < half_s + 0.0011,
        "{at_s} vs {half_s}"
    );
}

#[test]
fn escl_datagrams_get_one_datagram_a_line() {
    let mut d = drive();
    assert_eq!(
        d.receive_escl(b"\x00\x07QL\r", 0),
        [b"\x00\x07%\r".to_vec()]
    );
    assert_eq!(
        d.receive_escl(b"\x00\x07FL\r", 0),
        [b"\x00\x07*\r".to_vec()]
    );
    assert_eq!(
        d.receive_escl(b"\x00\x07QS1\r", 0),
        [b"\x00\x07%\r".to_vec()]
    );
    assert_eq!(
        d.receive_escl(b"\x00\x07QU1\r", 0),
        [
            b"\x00\x07%\r".to_vec(),
            b"\x00\x07QU2\r".to_vec(),
            b"\x00\x07FL\r".to_vec()
        ]
    );
    assert!(d.receive_escl(b"\x00\x08IP\r", 0).is_empty());
}

#[cfg(not(target_arch = "wasm32"))]
mod proptests {
    use proptest::prelude::*;

    use super::*;

    fn line() -> impl Strategy<Value = String> {
        prop_oneof![
            proptest::sample::select(vec![
                "FL", "FP", "FS7H", "FS3F", "DI1000", "DI-500", "DI0", "VE20", "VE0.5", "AC25",
                "DE400", "WI3F", "WI7H", "WT0.01", "WT0", "MT1", "MT0", "SO1L", "SO2H", "TI5L",
                "RX35", "R+12", "R/30", "TR05", "CR12", "SK", "ST", "ME", "MD", "AR", "SC", "IP",
                "QL", "QU1", "QU0", "QX1", "QX2", "QE", "QL1", "QS3", "QC1", "QC2", "QC", "CS-1",
                "CS2", "CJ", "SJ", "SMD", "WM", "RXJ-100", "RLJ50", "BS", "PS", "CT", "JA5", "QG1",
                "QJT1", "QR31", "SP100", "EP5", "EG200", "",
            ])
            .prop_map(str::to_owned),
            "[ -~]{0,12}",
        ]
    }

    proptest! {
        #[test]
        fn random_lines_at_random_times_never_panic_a_drive(
            steps in proptest::collection::vec((line(), 0..200_000_u64, 0..10_u8, any::<bool>()), 1..60),
        ) {
            let mut d = drive();
            let mut now = 0;
            for (line, dt, input, high) in steps {
                now += dt;
                let level = if high { Level::High } else { Level::Low };
                d.set_input(point(input), level, now);
                let answer = d.receive_line(&line, now);
                if let Some(answer) = answer {
                    prop_assert!(answer.ends_with('\r'));
                }
                prop_assert!(d.position_counts().is_finite());
            }
            d.advance(now + 10 * S);
            prop_assert!(d.position_counts().is_finite());
        }

        #[test]
        fn random_bytes_on_a_bus_never_panic_and_only_addressed_drives_answer(
            chunks in proptest::collection::vec(
                (proptest::collection::vec(prop_oneof![
                    3 => any::<u8>(),
                    2 => Just(b'\r'),
                    2 => proptest::sample::select(b"01".to_vec()),
                    4 => proptest::sample::select(b"FLPSIDQXWUEVTCRMK0123456789-.".to_vec()),
                ], 0..24), 0..100_000_u64),
                1..40,
            ),
        ) {
            let drives = "01".chars().map(|c| Drive::new(DriveConfig {
                address: Address::new(c),
                ..DriveConfig::default()
            })).collect();
            let mut bus = Bus::new(drives);
            bus.wire(StartWire {
                from: Address::new('0').unwrap(),
                output: point(2),
                input: point(3),
            });
            let mut now = 0;
            for (bytes, dt) in chunks {
                now += dt;
                let answers = bus.receive(&bytes, now);
                for line in String::from_utf8_lossy(&answers).split_terminator('\r') {
                    prop_assert!(line.starts_with('0') || line.starts_with('1'), "{line:?}");
                }
            }
            bus.advance(now + 10 * S);
        }
    }
}

#[test]
fn a_jog_speeds_up_at_ja_changes_speed_and_stops_at_jl() {
    // JA = JL = 10 rev/s² (200 000 counts/s²), JS 1 rev/s, backwards (DI's sign); 1 s
    // later the J register at −2 rev/s (−480 × 0.25 rpm, signed as CS), 1 s later SM D
    // at JL and WM: the program waits for the stop (MT1, HCR p. 64), then SO1L.
    let mut d = drive();
    store(
        &mut d,
        1,
        "JA10\nJL10\nJS1\nDI-1\nMT1\nCJ\nWT1\nRXJ-480\nWT1\nSMD\nWM\nSO1L",
        0,
    );
    assert_eq!(d.receive_line("QX1", 0).as_deref(), Some("*\r"));
    d.advance(S / 2);
    // Up to 20 000 counts/s in 0.1 s (1000 counts), then 0.4 s at it.
    assert!(
        (d.position_counts() + 9_000.0).abs() < 1e-6,
        "{}",
        d.position_counts()
    );
    assert!(d.is_moving() && d.is_executing());
    d.advance(3 * S);
    // 19 000 by 1 s; 20 000 → 40 000 in 0.1 s (3000), 0.9 s at 40 000 (36 000); the
    // stop from 40 000 at 200 000 counts/s² (4000) ends at 2.2 s.
    assert!((d.position_counts() + 62_000.0).abs() < 1e-6);
    let end = d.move_ends()[0];
    assert!((end.at_s - 2.2).abs() < 1e-9, "{end:?}");
    let low = d.output_changes()[0];
    assert!((low.at_s - 2.2).abs() < 1e-9, "{low:?}");
    // Its values as asked, and refused below a drive's range.
    // Loading J leaves JS (HCR p. 64).
    assert_eq!(d.receive_line("JS", 3 * S).as_deref(), Some("JS=1\r"));
    assert_eq!(d.receive_line("JA", 3 * S).as_deref(), Some("JA=10\r"));
    assert_eq!(d.receive_line("CS0.001", 3 * S).as_deref(), Some("?5\r"));
    assert_eq!(d.receive_line("JL0.1", 3 * S).as_deref(), Some("?5\r"));
}
