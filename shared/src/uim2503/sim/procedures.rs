//! The manual's worked PVT sequences (§7.4) played into the simulator as the manual
//! writes them (after `*20;`, the station of the manual's §8 examples, and with `;` for
//! the manual's full-width `；`): the exact ACK bytes, and the ball's position sampled
//! against the rows evaluated with [`Segment`].
//!
//! The manual leaves the rows between its examples' first and last ones out ("……");
//! the rows here fill them smoothly. Its rows move a few thousand counts in 100 ms,
//! which at the default 100 counts/mm asks up to 1.8 g of a ball: the procedures run at
//! 1000 counts/mm, where they stay within the default limits, and one test shows the
//! default calibration refusing the loop example's row 4.

use std::f64::consts::PI;

use super::tests::{ack, sent};
use super::{Gateway, GatewayConfig};
use crate::motion::Segment;
use crate::uim2503::feedback::Ack;

#[cfg(target_arch = "wasm32")]
use wasm_bindgen_test::wasm_bindgen_test as test;

const STATION: u8 = 20;
const MS: u64 = 1000;

fn gateway(counts_per_mm: f64) -> Gateway {
    let mut config = GatewayConfig::numbered(STATION);
    config.counts_per_mm = counts_per_mm;
    Gateway::new(config).unwrap()
}

/// The ball of station 20.
fn ball(gateway: &Gateway) -> f64 {
    gateway
        .unit(usize::from(STATION) - 1)
        .unwrap()
        .position_counts
}

/// Writes rows (index, P, V, T) as the manual does, `QP[X]=…;QV[X]=…;QT[X]=…;`, and
/// returns the ACKs they must get, made with the codec's encoder.
fn write_rows(gateway: &mut Gateway, now_us: u64, rows: &[(u8, i32, i32, u8)]) -> String {
    let mut text = String::new();
    let mut acks = Vec::new();
    for &(row, p, v, t) in rows {
        text.push_str(&format!("QP[{row}]={p};QV[{row}]={v};QT[{row}]={t};"));
        let row = row.into();
        acks.push(ack(
            STATION,
            Ack::PvtPosition {
                row,
                position_counts: p,
            },
        ));
        acks.push(ack(
            STATION,
            Ack::PvtVelocity {
                row,
                velocity_counts_s: v,
            },
        ));
        acks.push(ack(
            STATION,
            Ack::PvtTime {
                row,
                duration_ms: t,
            },
        ));
    }
    gateway.receive(now_us, text.as_bytes());
    acks.join(" ")
}

/// The motion rows describe when they run from `start_us`, starting at rest at
/// `from_counts`: each a segment from where the previous one ended.
fn chain(start_us: u64, from_counts: f64, rows: &[(u8, i32, i32, u8)]) -> Vec<(u64, Segment)> {
    let (mut at_us, mut p, mut v) = (start_us, from_counts, 0.0);
    rows.iter()
        .map(|&(_, p1, v1, t)| {
            let segment = Segment::new(p, v, p1.into(), v1.into(), f64::from(t) / 1000.0);
            let piece = (at_us, segment);
            (at_us, p, v) = (at_us + u64::from(t) * MS, p1.into(), v1.into());
            piece
        })
        .collect()
}

/// Where `pieces` put the ball at `at_us` (at rest at the end of the last one after it).
fn expected(pieces: &[(u64, Segment)], at_us: u64) -> f64 {
    let index = pieces.partition_point(|&(start, _)| start <= at_us).max(1) - 1;
    let (start, segment) = pieces[index];
    let tau = ((at_us - start) as f64 / 1e6).min(segment.duration_s);
    if tau == segment.duration_s {
        segment.p1
    } else {
        segment.position(tau)
    }
}

/// Advances the gateway from `from_us` to `to_us` every ms (and at an odd µs in each
/// ms), checking the ball against `pieces`; returns what the gateway sent and when.
fn follow(
    gateway: &mut Gateway,
    pieces: &[(u64, Segment)],
    from_us: u64,
    to_us: u64,
) -> Vec<(u64, String)> {
    let mut sent_at = Vec::new();
    let mut at_us = from_us;
    while at_us <= to_us {
        for t in [at_us, at_us + 317] {
            if t > to_us {
                break;
            }
            gateway.advance(t);
            let (actual, wanted) = (ball(gateway), expected(pieces, t));
            assert!(
                (actual - wanted).abs() < 1e-6,
                "at {t} µs: the ball is at {actual}, the rows say {wanted}"
            );
            let output = sent(gateway);
            if !output.is_empty() {
                sent_at.push((t, output));
            }
        }
        at_us += MS;
    }
    sent_at
}

/// Advances until the current point-to-point move ends; returns when it did.
fn arrive(gateway: &mut Gateway) -> u64 {
    let arrival = gateway.next_event_us().unwrap();
    gateway.advance(arrival);
    assert!(!gateway.unit(usize::from(STATION) - 1).unwrap().moving);
    arrival
}

/// Rows 5…99 of the single-sequence example: a slow ramp from row 4 towards row 100.
fn single_rows() -> Vec<(u8, i32, i32, u8)> {
    let mut rows = vec![(3, 1000, 0, 100), (4, 4000, 500, 100)];
    rows.extend((5..=99).map(|i| (i, 4000 + (i32::from(i) - 4) * 40, 400, 100)));
    rows.push((100, 8000, 0, 100));
    rows
}

#[test]
fn single_sequence_example() {
    let mut gateway = gateway(1000.0);
    // Steps 1–4.
    gateway.receive(0, b"*20;MO=1;MP[3]=1;MP[1]=3;MP[2]=100;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 15 01 E0 F0 14 22 03 01 00 E0 F0 14 22 01 03 00 E0 F0 14 22 02 64 00 E0"
    );
    // Step 5: the manual's rows 3, 4 and 100 (and 5…99 between).
    gateway.receive(
        0,
        b"QP[3]=1000;QV[3]=0;QT[3]=100;QP[4]=4000;QV[4]=500;QT[4]=100;",
    );
    assert_eq!(
        sent(&mut gateway),
        "F4 14 25 03 00 68 03 00 00 E0 F0 14 26 03 00 00 00 00 00 E0 F0 14 27 03 00 64 E0 \
         F4 14 25 04 00 20 0F 00 00 E0 F4 14 26 04 00 74 01 00 00 E0 F0 14 27 04 00 64 E0"
    );
    let rows = single_rows();
    let acks = write_rows(&mut gateway, 0, &rows[2..rows.len() - 1]);
    assert_eq!(sent(&mut gateway), acks);
    gateway.receive(0, b"QP[100]=8000;QV[100]=0;QT[100]=100;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 25 64 00 40 1F 00 00 E0 F0 14 26 64 00 00 00 00 00 E0 F0 14 27 64 00 64 E0"
    );
    // Step 6: to QP[4] at 1000 counts/s (4 s, and 0.25 ms each to speed up and down at
    // 4e6 counts/s²).
    gateway.receive(0, b"SP=1000;PA=4000;BG;");
    assert_eq!(
        sent(&mut gateway),
        "F1 14 1E 68 03 00 00 E0 F1 14 20 20 0F 00 00 E0 F0 14 16 00 00 00 00 E0"
    );
    assert_eq!(arrive(&mut gateway), 4_000_250);
    assert_eq!(ball(&gateway), 4000.0);
    // Step 7: once there, start at row 4.
    let t0 = 4_500_000;
    gateway.receive(t0, b"PV=4;BG;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 23 04 00 E0 F0 14 16 00 00 00 00 E0"
    );
    let pieces = chain(t0, 4000.0, &rows[1..]);
    let end = t0 + 97 * 100 * MS;
    assert_eq!(follow(&mut gateway, &pieces, t0, end + 500 * MS), []);
    assert_eq!(ball(&gateway), 8000.0);
    // PV answers the row executed last, and the run has ended.
    gateway.receive(end + 500 * MS, b"PV;");
    assert_eq!(sent(&mut gateway), "F0 14 23 64 00 E0");
    assert_eq!(gateway.next_event_us(), None);
}

/// The loop example's rows: 5…99 swing back from row 4 to row 100, which must meet
/// row 3 (manual: "MP[1]'s point should be close to MP[2]'s").
fn loop_rows() -> Vec<(u8, i32, i32, u8)> {
    let mut rows = vec![(3, 1000, 0, 100), (4, 4000, 500, 100)];
    rows.extend((5..=99).map(|i| {
        let phase = PI * f64::from(i - 4) / 96.0;
        let p = 1000.0 + 1500.0 * (1.0 + phase.cos());
        let v = -1500.0 * PI / 96.0 * phase.sin() / 0.1;
        (i, p.round() as i32, v.round() as i32, 100)
    }));
    rows.push((100, 1000, 0, 100));
    rows
}

/// Steps 1–6 of the loop example; returns when the ball is at QP[3].
fn loop_setup(gateway: &mut Gateway) -> u64 {
    gateway.receive(0, b"*20;MO=1;MP[3]=3;MP[1]=3;MP[2]=100;");
    assert_eq!(
        sent(gateway),
        "F0 14 15 01 E0 F0 14 22 03 03 00 E0 F0 14 22 01 03 00 E0 F0 14 22 02 64 00 E0"
    );
    // Step 5, with the manual's spacing in `QV[3]= 0;`.
    gateway.receive(
        0,
        b"QP[3]=1000;QV[3]= 0;QT[3]=100;QP[4]=4000;QV[4]=500;QT[4]=100;",
    );
    assert_eq!(
        sent(gateway),
        "F4 14 25 03 00 68 03 00 00 E0 F0 14 26 03 00 00 00 00 00 E0 F0 14 27 03 00 64 E0 \
         F4 14 25 04 00 20 0F 00 00 E0 F4 14 26 04 00 74 01 00 00 E0 F0 14 27 04 00 64 E0"
    );
    let rows = loop_rows();
    let acks = write_rows(gateway, 0, &rows[2..rows.len() - 1]);
    assert_eq!(sent(gateway), acks);
    gateway.receive(0, b"QP[100]=1000;QV[100]=0;QT[100]=100;");
    assert_eq!(
        sent(gateway),
        "F4 14 25 64 00 68 03 00 00 E0 F0 14 26 64 00 00 00 00 00 E0 F0 14 27 64 00 64 E0"
    );
    // Step 6: to QP[3].
    gateway.receive(0, b"SP=1000;PA=1000;BG;");
    assert_eq!(
        sent(gateway),
        "F1 14 1E 68 03 00 00 E0 F1 14 20 68 03 00 00 E0 F0 14 16 00 00 00 00 E0"
    );
    let arrival = arrive(gateway);
    assert_eq!(ball(gateway), 1000.0);
    arrival
}

#[test]
fn loop_example() {
    let mut gateway = gateway(1000.0);
    assert_eq!(loop_setup(&mut gateway), 1_000_250);
    // Step 7.
    let t0 = 2_000_000;
    gateway.receive(t0, b"PV=3;BG;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 23 03 00 E0 F0 14 16 00 00 00 00 E0"
    );
    // Two and a half laps of rows 3…100, each from MP[1] again after MP[2].
    let rows = loop_rows();
    let laps: Vec<_> = rows
        .iter()
        .chain(&rows)
        .chain(&rows[..49])
        .copied()
        .collect();
    let pieces = chain(t0, 1000.0, &laps);
    let lap_us = 98 * 100 * MS;
    assert_eq!(
        follow(&mut gateway, &pieces, t0, t0 + 2 * lap_us + 4000 * MS),
        [],
        "no watermark notice in loop mode, no end"
    );
    // PV answers the row executing; the loop never ends by itself.
    gateway.receive(t0 + 2 * lap_us + 4050 * MS, b"PV;");
    assert_eq!(sent(&mut gateway), "F0 14 23 2B 00 E0", "row 43");
    assert_eq!(gateway.next_event_us(), Some(t0 + 2 * lap_us + 4100 * MS));
    // MO=0 ends it at once.
    gateway.receive(t0 + 2 * lap_us + 4070 * MS, b"MO=0;");
    let stopped = ball(&gateway);
    gateway.advance(t0 + 3 * lap_us);
    assert_eq!(ball(&gateway), stopped);
    assert_eq!(gateway.next_event_us(), None);
}

#[test]
fn loop_example_at_the_default_calibration_overloads_at_row_4() {
    // 3000 counts in 100 ms from rest is 1.79e6 counts/s²: 17.9 m/s² at 100 counts/mm.
    let mut gateway = gateway(100.0);
    assert_eq!(loop_setup(&mut gateway), 1_002_500);
    gateway.receive(2_000_000, b"PV=3;BG;");
    sent(&mut gateway);
    gateway.advance(2_099_999);
    assert_eq!(sent(&mut gateway), "");
    gateway.advance(2_100_000);
    assert_eq!(
        sent(&mut gateway),
        "F0 14 0F 40 27 04 E0",
        "ER OVERLOAD, QT, row 4"
    );
    let unit = gateway.unit(usize::from(STATION) - 1).unwrap();
    assert_eq!(
        (unit.position_counts, unit.moving, unit.motor_on),
        (1000.0, false, false)
    );
}

/// The FIFO example's batches as (first row, rows): each starts with the manual's
/// `(1000, 0)` and `(4000, 500)` and ends with its `(1000, 7000)`; the rows between
/// descend evenly.
fn fifo_batch(first: u8, count: u16) -> Vec<(u8, i32, i32, u8)> {
    let between = f64::from(count - 2);
    (0..count)
        .map(|j| {
            let row = first.wrapping_add(u8::try_from(j % 256).unwrap());
            let (p, v) = match j {
                0 => (1000, 0),
                1 => (4000, 500),
                j if j == count - 1 => (1000, 7000),
                j => (
                    (4000.0 - 3000.0 * f64::from(j - 1) / between).round() as i32,
                    (-30_000.0 / between).round() as i32,
                ),
            };
            (row, p, v, 100)
        })
        .collect()
}

#[test]
fn fifo_example_with_watermark_and_wrap() {
    let mut gateway = gateway(1000.0);
    // Steps 1–4.
    gateway.receive(0, b"*20;MO=1;MP[3]=0;MP[5]=5;MP[0]=1;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 15 01 E0 F0 14 22 03 00 00 E0 F0 14 22 05 05 00 E0 F0 14 22 00 01 00 E0"
    );
    // Step 5: rows 0…10.
    let first = fifo_batch(0, 11);
    gateway.receive(
        0,
        b"QP[0]=1000;QV[0]= 0;QT[0]=100;QP[1]=4000;QV[1]=500;QT[1]=100;",
    );
    assert_eq!(
        sent(&mut gateway),
        "F4 14 25 00 00 68 03 00 00 E0 F0 14 26 00 00 00 00 00 00 E0 F0 14 27 00 00 64 E0 \
         F4 14 25 01 00 20 0F 00 00 E0 F4 14 26 01 00 74 01 00 00 E0 F0 14 27 01 00 64 E0"
    );
    let acks = write_rows(&mut gateway, 0, &first[2..10]);
    assert_eq!(sent(&mut gateway), acks);
    gateway.receive(0, b"QP[10]=1000;QV[10]=7000;QT[10]=100;PV;");
    assert_eq!(
        sent(&mut gateway),
        "F4 14 25 0A 00 68 03 00 00 E0 F0 14 26 0A 00 58 1B 00 00 E0 F0 14 27 0A 00 64 E0 \
         F0 14 23 0B 00 E0",
        "and PV; answers the water level, 11"
    );
    // Step 6: to QP[0] at the power-on speed.
    gateway.receive(0, b"PA=1000;BG;");
    assert_eq!(
        sent(&mut gateway),
        "F1 14 20 68 03 00 00 E0 F0 14 16 00 00 00 00 E0"
    );
    arrive(&mut gateway);
    assert_eq!(ball(&gateway), 1000.0);
    // Step 7.
    let t0 = 1_000_000;
    gateway.receive(t0, b"PV=0;BG;");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 23 00 00 E0 F0 14 16 00 00 00 00 E0"
    );
    // Step 8: rows 11…255 while row 0 runs; 255 pending and the running row fill the
    // table.
    let second = fifo_batch(11, 245);
    let acks = write_rows(&mut gateway, t0, &second);
    assert_eq!(sent(&mut gateway), acks);
    assert!(acks.ends_with(
        "F5 14 25 7F 00 68 03 00 00 E0 F1 14 26 7F 00 58 1B 00 00 E0 F1 14 27 7F 00 64 E0"
    ));
    gateway.receive(t0, b"PV;QT[0]=100;");
    assert_eq!(
        sent(&mut gateway),
        format!(
            "{} {}",
            ack(STATION, Ack::PvtStart { value: 255 }),
            "F0 14 0F 33 27 00 E0"
        ),
        "a full FIFO refuses another row"
    );
    // Step 9: the notice (RTN0=44, three times) when row 250 starts, 5 rows left.
    let third = fifo_batch(0, 250);
    let run: Vec<_> = first.iter().chain(&second).chain(&third).copied().collect();
    let mut pieces = chain(t0, 1000.0, &run);
    let notice = "F0 14 5A 2C E0 F0 14 5A 2C E0 F0 14 5A 2C E0".to_owned();
    let first_notice = t0 + 250 * 100 * MS;
    assert_eq!(
        follow(&mut gateway, &pieces, t0, first_notice),
        [(first_notice, notice.clone())]
    );
    // Step 10: rows 0…249, no more (5 are pending).
    let acks = write_rows(&mut gateway, first_notice, &third);
    assert_eq!(sent(&mut gateway), acks);
    // Step 11: the next notice when row 244 starts after the wrap.
    let second_notice = t0 + (256 + 244) * 100 * MS;
    assert_eq!(
        follow(&mut gateway, &pieces, first_notice + MS, second_notice),
        [(second_notice, notice)]
    );
    // Step 12: all written rows run; the last ends at 7000 counts/s and the unit brakes
    // with SD (the top acceleration, 4e6 counts/s²): 1.75 ms, 6.125 counts.
    let last_end = t0 + (256 + 250) * 100 * MS;
    pieces.push((
        last_end,
        Segment::new(1000.0, 7000.0, 1006.125, 0.0, 0.001_75),
    ));
    assert_eq!(
        follow(
            &mut gateway,
            &pieces,
            second_notice + MS,
            last_end + 100 * MS
        ),
        []
    );
    assert!((ball(&gateway) - 1006.125).abs() < 1e-9);
    gateway.receive(last_end + 100 * MS, b"PV;MP[6];");
    assert_eq!(
        sent(&mut gateway),
        "F0 14 23 00 00 E0 F2 14 22 06 7A 00 E0",
        "nothing pending; the next write goes to row 250"
    );
}
