//! `floatball simulate --kind mbox`: two simulated 10-axis boxes on loopback UDP; the
//! test is the host. It reads and writes registers and sends motion frames over real
//! sockets, and checks the replies; the document defines no register that holds an
//! axis's position, so positions are checked in the final state the process prints
//! when it is stopped.

use crate::common;

use std::net::{SocketAddr, UdpSocket};
use std::time::Duration;

use common::mbox_sim::Simulator;
use floatball_shared::mbox::{
    AxisCount, AxisPositions, BoxAddress, Datagram, DigitalOutputs, Encode, MotionFrame, ReadBank,
    RegisterRange, RegisterRead, RegisterWrite, Route, TimeCode, TimeMode,
};

/// The e-stop register (FN `0x0090`).
const FN_ESTOP: u16 = 0x0090;
const FIRST: BoxAddress = BoxAddress(0x0FC9);
const SECOND: BoxAddress = BoxAddress(0x0FCA);

fn host() -> UdpSocket {
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    socket
        .set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    socket
}

/// Reads `count` registers from `start` of the box at `to`, which `route` names;
/// returns the values of the reply, or `None` when no reply came.
fn read(
    host: &UdpSocket,
    to: SocketAddr,
    route: Route,
    bank: ReadBank,
    start: u16,
    count: usize,
) -> Option<Vec<u16>> {
    let request = RegisterRead {
        bank,
        route,
        range: RegisterRange::new(start, count).unwrap(),
    };
    host.send_to(&request.encode(), to).unwrap();
    let mut buffer = [0u8; 2048];
    let (len, from) = host.recv_from(&mut buffer).ok()?;
    assert_eq!(from, to, "the reply comes from the box's socket");
    match Datagram::decode(&buffer[..len]) {
        Ok(Datagram::ReadReply(reply)) => {
            assert_eq!((reply.bank, reply.route), (bank, Route::REPLY));
            assert_eq!(reply.block.start(), start);
            Some(reply.block.values().to_vec())
        }
        other => panic!("not a read reply: {other:?}"),
    }
}

fn frame(route: Route, sequence: u32, time_ms: u32, pulses: i32) -> Vec<u8> {
    MotionFrame {
        mode: TimeMode::Relative,
        route,
        sequence,
        time_code: TimeCode::from_ms(time_ms),
        positions_pulses: AxisPositions::uniform(AxisCount::Ten, pulses),
        digital: DigitalOutputs::from_bits(0x000D),
        analog: [0, 0],
    }
    .encode()
}

#[test]
fn mbox_twins_on_loopback_answer_reads_move_and_hold_an_estop() {
    let (simulator, sockets) = Simulator::start(10, 2, 0);
    let [first, second] = sockets[..] else {
        panic!("two boxes")
    };
    let host = host();

    // Registers: the IP in FN020–FN023, DN parameters 0, the e-stop released.
    let ip = read(&host, first, Route::to(FIRST), ReadBank::Fn, 0x0020, 4);
    assert_eq!(ip, Some(vec![192, 168, 15, 201]));
    let dn = read(&host, second, Route::BROADCAST, ReadBank::Dn, 0x0010, 16);
    assert_eq!(dn, Some(vec![0; 16]));
    // No reply when the replier is 0 or another box.
    assert_eq!(
        read(&host, first, Route::silent(FIRST), ReadBank::Fn, 1, 2),
        None
    );
    let other = Route {
        receiver: FIRST,
        replier: SECOND,
    };
    assert_eq!(read(&host, first, other, ReadBank::Fn, 1, 2), None);

    // The first box moves to 50 000 over 100 ms (two frames, the second repeating the
    // target); the second starts a slow move and is stopped on its way.
    host.send_to(&frame(Route::silent(FIRST), 1, 100, 20_000), first)
        .unwrap();
    host.send_to(&frame(Route::BROADCAST_SILENT, 2, 100, 50_000), first)
        .unwrap();
    host.send_to(&frame(Route::silent(SECOND), 1, 2_000, 1_000_000), second)
        .unwrap();
    std::thread::sleep(Duration::from_millis(200));
    host.send_to(
        &RegisterWrite::estop(Route::silent(SECOND)).encode(),
        second,
    )
    .unwrap();
    // The e-stop is acknowledged the only way the document allows: FN 0x0090 reads 1.
    let estop = read(&host, second, Route::to(SECOND), ReadBank::Fn, FN_ESTOP, 1);
    assert_eq!(estop, Some(vec![1]));
    // Motion frames are ignored while it holds, a reset too.
    host.send_to(&frame(Route::silent(SECOND), 2, 20, 0), second)
        .unwrap();
    host.send_to(
        &RegisterWrite::reset(Route::BROADCAST_SILENT).encode(),
        second,
    )
    .unwrap();
    // Effects are kept; a frame for the other box and a malformed datagram are counted.
    host.send_to(
        &RegisterWrite::effects(Route::silent(SECOND), 0x0FFF).encode(),
        second,
    )
    .unwrap();
    host.send_to(&frame(Route::silent(FIRST), 3, 20, 0), second)
        .unwrap();
    host.send_to(&[0x55, 0xAA, 0x00, 0x00, 0x14], first)
        .unwrap();
    // Every datagram was taken before the box answers this read.
    assert_eq!(
        read(&host, second, Route::to(SECOND), ReadBank::Fn, FN_ESTOP, 1),
        Some(vec![1])
    );
    std::thread::sleep(Duration::from_millis(100));

    let boxes = simulator.stop();
    let [one, two] = &boxes[..] else {
        panic!("two final states: {boxes:?}")
    };
    assert_eq!((one.address, two.address), (FIRST.0, SECOND.0));
    assert_eq!(one.positions_pulses, vec![50_000; 10]);
    assert!(!one.moving && !one.estop);
    assert_eq!(one.digital, 0x000D);
    assert_eq!(one.counters.motion_frames, 2);
    assert_eq!(one.counters.malformed.truncated, 1);
    // The second stopped somewhere on its way to 1 000 000 and stayed there.
    let stopped = two.positions_pulses[0];
    assert!(
        (10_000..1_000_000).contains(&stopped),
        "stopped at {stopped}"
    );
    assert_eq!(two.positions_pulses, vec![stopped; 10]);
    assert_eq!(two.targets_pulses, vec![stopped; 10]);
    assert!(two.estop && !two.moving);
    assert_eq!(two.effects_mask, 0x0FFF);
    assert_eq!(two.counters.ignored_estop, 1);
    assert_eq!(two.counters.not_for_this_box, 1);
    assert_eq!(two.counters.replies, 3);
}
