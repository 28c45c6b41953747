//! The simulated gateway as a link: as slow as a real line, answering as the manual
//! says, its balls visible through the positions view.

use std::time::{Duration, Instant};

use floatball_bridge::ports::uim2503::{Batch, BaudError, Link, LinkConfig};
use floatball_shared::api::LinkState;
use floatball_shared::uim2503::ascii::{Form, parse_script};
use floatball_shared::uim2503::feedback::{Ack, Feedback};
use floatball_shared::uim2503::sim::GatewayConfig;

fn batch(script: &str) -> Batch {
    Batch::encode(&parse_script(script).unwrap(), Form::Standard).unwrap()
}

fn sim_link(baud: u32, gateway: GatewayConfig) -> Link {
    let mut config = LinkConfig::new("sim", baud);
    config.sim = gateway;
    Link::open(0, config)
}

async fn up(link: &Link) {
    let mut status = link.status();
    tokio::time::timeout(
        Duration::from_secs(5),
        status.wait_for(|s| s.state == LinkState::Up),
    )
    .await
    .expect("the simulated link comes up at once")
    .unwrap();
}

/// Streams rows for `window` after a warm-up and returns the measured bytes/s at the
/// gateway's end of the line.
async fn measured_rate(baud: u32, window: Duration) -> f64 {
    let link = sim_link(baud, GatewayConfig::numbered(10));
    up(&link).await;
    let view = link
        .sim_view()
        .expect("a simulated link has a view")
        .clone();
    let mut rows = batch("*3;");
    for row in 0..2000u32 {
        let index = row % 256;
        rows.extend(&batch(&format!("QP[{index}]=123456;QV[{index}]=-2345;")));
    }
    assert!(rows.len() as f64 > f64::from(baud) / 10.0 * (window.as_secs_f64() + 1.0));
    link.send(rows).await.unwrap();
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (start, start_bytes) = (Instant::now(), view.received_bytes());
    tokio::time::sleep(window).await;
    let (end, end_bytes) = (Instant::now(), view.received_bytes());
    (end_bytes - start_bytes) as f64 / (end - start).as_secs_f64()
}

/// Checks the line's pace at `baud`: never faster than baud/10 + 5 %, and within 5 %
/// of it in one of three measurements — a machine busy with other work can only
/// starve the writer (slower), so a slow window is measured again, never a fast one.
async fn assert_paced(baud: u32, window: Duration) {
    let expected = f64::from(baud) / 10.0;
    let mut rates = Vec::new();
    for _ in 0..3 {
        let rate = measured_rate(baud, window).await;
        assert!(
            rate <= expected * 1.05,
            "{rate:.1} B/s at {baud} baud: faster than the line"
        );
        rates.push(rate);
        if rate >= expected * 0.95 {
            return;
        }
    }
    panic!("{rates:.1?} B/s at {baud} baud: slower than the line three times");
}

#[tokio::test]
async fn throughput_at_9600_baud_is_within_five_percent_of_baud_over_ten() {
    assert_paced(9600, Duration::from_secs(3)).await;
}

#[tokio::test]
async fn throughput_at_115200_baud_is_within_five_percent_of_baud_over_ten() {
    assert_paced(115_200, Duration::from_secs(2)).await;
}

#[tokio::test]
async fn a_ball_moves_and_the_view_shows_it() {
    let link = sim_link(115_200, GatewayConfig::numbered(4));
    up(&link).await;
    let mut feedback = link.feedback();
    link.send(batch("*2;MO=1;SP=100000;PA=50000;BG;"))
        .await
        .unwrap();
    let view = link.sim_view().unwrap().clone();
    // The BG's ACK comes back over the line.
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let frame = tokio::time::timeout_at(deadline.into(), feedback.recv())
            .await
            .expect("the BG ACK within 5 s")
            .unwrap();
        if let Ok(Feedback::Ack(Ack::Begin { .. })) = Feedback::from_frame(&frame) {
            assert_eq!(frame.station(), 2);
            break;
        }
    }
    tokio::time::sleep(Duration::from_millis(200)).await;
    let moving = view.positions(0);
    let unit = &moving.units[1];
    assert_eq!(unit.station, 2);
    assert!(unit.motor_on && unit.moving, "{unit:?}");
    assert!(
        unit.position_counts > 0.0 && unit.position_counts < 50_000.0,
        "{unit:?}"
    );
    // 50000 counts at 100000 counts/s: half a second plus the ramps.
    tokio::time::sleep(Duration::from_millis(800)).await;
    let arrived = view.positions(0);
    assert_eq!(arrived.units[1].position_counts, 50_000.0);
    assert!(!arrived.units[1].moving);
    assert_eq!(arrived.units[0].position_counts, 0.0, "the others stay put");
}

#[tokio::test]
async fn factory_fresh_discovery_returns_every_unit() {
    let link = sim_link(115_200, GatewayConfig::factory_fresh(12));
    up(&link).await;
    let mut feedback = link.feedback();
    link.send(batch("*0;SN;")).await.unwrap();
    let mut serials = Vec::new();
    while serials.len() < 12 {
        let frame = tokio::time::timeout(Duration::from_secs(5), feedback.recv())
            .await
            .expect("every unit answers within 5 s")
            .unwrap();
        if let Ok(Feedback::Ack(Ack::Serial { serial })) = Feedback::from_frame(&frame) {
            assert_eq!(
                frame.station(),
                5,
                "factory-fresh units all answer on station 5"
            );
            serials.push(serial);
        }
    }
    serials.sort_unstable();
    serials.dedup();
    assert_eq!(serials.len(), 12, "each unit has its own serial");
}

#[tokio::test]
async fn the_simulated_gateway_is_greeted_and_follows_a_line_speed_change() {
    let link = sim_link(9600, GatewayConfig::numbered(2));
    up(&link).await;
    let view = link
        .sim_view()
        .expect("a simulated link has a view")
        .clone();
    // The greeting (`ABC;`, 4 bytes) is what brought it up.
    assert!(view.received_bytes() >= 4);

    let changed = link
        .change_baud(115_200, Duration::from_secs(3))
        .await
        .unwrap();
    assert_eq!((changed.from_baud, changed.baud), (9600, 115_200));
    assert!(changed.took_ms < 3000);
    assert_eq!(link.baud(), 115_200);
    assert_eq!(link.snapshot().state, LinkState::Up);
    // The units answer at the new speed, and nothing was lost to a mismatch on the way
    // (the link switched after the gateway restarted).
    let mut feedback = link.feedback();
    link.send(batch("*1;PV;")).await.unwrap();
    let frame = tokio::time::timeout(Duration::from_secs(2), feedback.recv())
        .await
        .expect("an answer at 115200 baud")
        .unwrap();
    assert_eq!(frame.station(), 1);

    assert_eq!(
        link.change_baud(4800, Duration::from_secs(1)).await,
        Err(BaudError::OutOfRange { baud: 4800 })
    );
    assert!(link.estop().is_none());
    assert_eq!(
        link.change_baud(9600, Duration::from_secs(1)).await,
        Err(BaudError::EstopLatched)
    );
    assert_eq!(link.baud(), 115_200);
}
