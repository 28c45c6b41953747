//! Live mode end to end through the real `floatball` binary, on a simulated bridge of
//! each family in turn — UIM2503 gateways over Art-Net then sACN, MBOX boxes over
//! sACN then Art-Net, MOONS' drives (jogging) over Art-Net then sACN — fed by
//! Debian's `olad` as `live.rs` feeds it (its Art-Net and E1.31 plugins, driven by
//! `ola_set_dmx` and `ola_streaming_client`; without `ola`, this test's own senders,
//! unless `FLOATBALL_REQUIRE_OLA=1`): go live over the WebSocket; for each protocol
//! the simulated balls follow a fader ramp, a 1,000 mm step is followed at the top
//! speed (sampled on the simulation's clock) and silence → holding; a recording
//! stored as a show that plans, Leave live, and the e-stop with both protocols' input
//! coming (sACN's, then Art-Net's once sACN's stream ended, reaching the targets):
//! stopped, nothing moves, `live on` refused while latched.
//!
//! `olad` and the bridges use the fixed ports 6454 and 5568, which no test but
//! `live.rs` and `timecode.rs` (run alone in CI, after this one) uses: this one runs
//! beside the others.

use crate::common;
use crate::live::{
    Console, HOLD_AFTER_MS, Repeat, SacnStream, TRAVEL_MM, follows, mm, multicast_works, ola,
    ola_run, start_olad, status_until,
};

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::Process;
use common::{next_message, send_text};
use floatball_shared::api::ServerMessage;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn balls_follow_consoles_in_live_mode_on_every_family() {
    let started = Instant::now();
    let ola = ola();
    let ola_sacn = ola && multicast_works();
    let olad = ola.then(start_olad);

    // UIM2503 gateways, fed over Art-Net, then sACN.
    let bridge = Process::start(&live_mode_config(
        4,
        "[[gateway]]\nport = \"sim\"\nbaud = 115200\n",
    ));
    live_mode(
        &bridge,
        "UIM2503",
        |value| Fader::artnet(ola, value),
        |value| Fader::sacn(ola_sacn, value),
    )
    .await;
    drop(bridge);

    // MBOX boxes, fed over sACN, then Art-Net.
    let bridge = Process::start(&live_mode_config(
        3,
        "[mbox]\nhost_port = 0\n[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n",
    ));
    live_mode(
        &bridge,
        "MBOX",
        |value| Fader::sacn(ola_sacn, value),
        |value| Fader::artnet(ola, value),
    )
    .await;
    drop(bridge);

    // MOONS' drives (jogging), fed over Art-Net, then sACN.
    let bridge = Process::start(&live_mode_config(
        3,
        "[scl]\nhost_port = 0\n[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n",
    ));
    live_mode(
        &bridge,
        "MOONS'",
        |value| Fader::artnet(ola, value),
        |value| Fader::sacn(ola_sacn, value),
    )
    .await;
    drop(bridge);

    drop(olad);
    println!("live mode checked in {:?}", started.elapsed());
}

/// `[matrix] max_speed_mm_s` of the live-mode cases: a step is followed at this speed
/// at most.
const TOP_SPEED_MM_S: f64 = 1000.0;

/// The bridge's configuration for the live-mode cases (10, 11): a 1 × `cols` matrix
/// of `gateway`, live input on, the top speed [`TOP_SPEED_MM_S`].
fn live_mode_config(cols: u32, gateway: &str) -> String {
    format!(
        "[matrix]\nrows = 1\ncols = {cols}\ntravel_mm = {TRAVEL_MM:.1}\n\
         max_speed_mm_s = {TOP_SPEED_MM_S:.1}\nmax_accel_mm_s2 = 4000.0\n\
         [safety]\napproach_speed_mm_s = {TOP_SPEED_MM_S:.1}\n\
         {gateway}\
         [live]\nenabled = true\nhold_after_ms = {HOLD_AFTER_MS}\n\
         artnet_listen = \"0.0.0.0:6454\"\nsacn_listen = \"0.0.0.0:5568\"\n"
    )
}

/// Each simulated ball's position, mm (100 counts or pulses a mm), and the
/// simulation's clock, µs.
async fn sim_balls(bridge: &Process, token: &str) -> (Vec<f64>, u64) {
    let reply = bridge
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let positions: floatball_shared::api::SimPositions = reply.json();
    if let Some(gateway) = positions.gateways.first() {
        let mm = gateway
            .units
            .iter()
            .map(|unit| unit.position_counts / 100.0)
            .collect();
        (mm, gateway.time_us)
    } else if let Some(one) = positions.boxes.first() {
        let mm = one
            .positions_pulses
            .iter()
            .map(|&pulses| f64::from(pulses).abs() / 100.0)
            .collect();
        (mm, one.time_us)
    } else {
        // MOONS' drive twins have no clock of their own: this test's.
        assert!(
            !positions.drives.is_empty(),
            "a simulated gateway, box or drive"
        );
        let mm = positions
            .drives
            .iter()
            .map(|drive| drive.position_counts / 100.0)
            .collect();
        let epoch = *SIM_EPOCH.get_or_init(Instant::now);
        (
            mm,
            u64::try_from(epoch.elapsed().as_micros()).unwrap_or(u64::MAX),
        )
    }
}

/// The clock of samples from simulated MOONS' drives (which have none of their own).
static SIM_EPOCH: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();

/// Until balls 0–2 are within 3 mm of `mm` (at most 5 s).
async fn balls_at(bridge: &Process, token: &str, what: &str, mm: f64) -> Vec<f64> {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let (balls, _) = sim_balls(bridge, token).await;
        if balls.len() >= 3 && balls[..3].iter().all(|&at| (at - mm).abs() < 3.0) {
            return balls;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: the balls are at {balls:?}, not at {mm:.1} mm\n{}",
            bridge.log()
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The simulated balls once balls 0–2 stand within 1 mm of `mm` (at most 5 s).
async fn balls_at_rest(bridge: &Process, token: &str, mm: f64) -> (Vec<f64>, u64) {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let balls = sim_balls(bridge, token).await;
        if balls.0.len() >= 3 && balls.0[..3].iter().all(|&at| (at - mm).abs() < 1.0) {
            return balls;
        }
        assert!(
            Instant::now() < deadline,
            "not at rest at {mm:.1} mm: {:?}",
            balls.0
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The next error from the bridge (statuses and other news skipped), within 5 s: its
/// code.
async fn next_error(ws: &mut common::Ws) -> String {
    loop {
        // Statuses, feedback, the e-stop's own answer (it may come after the status
        // that showed it), positions: not what is waited for.
        if let ServerMessage::Error { code, .. } = next_message(ws).await {
            return code;
        }
    }
}

/// The next `live_positions` message that `what` accepts (others and statuses
/// skipped), within 5 s.
async fn live_positions(ws: &mut common::Ws, what: impl Fn(&[i32]) -> bool) -> Vec<i32> {
    tokio::time::timeout(Duration::from_secs(5), async {
        loop {
            if let ServerMessage::LivePositions { positions_mm } = next_message(ws).await
                && what(&positions_mm)
            {
                return positions_mm;
            }
        }
    })
    .await
    .expect("live positions within 5 s")
}

/// The live phase of a status.
fn phase(status: &floatball_shared::api::Status) -> Option<floatball_shared::api::LivePhase> {
    status.live.as_ref().map(|live| live.phase)
}

/// A console's fader for balls 0–3 (each ball at the same 16-bit position): Art-Net
/// repeated every 100 ms (through `olad` or this test's socket), or an sACN stream
/// at priority 150 on universe 1 (through `ola_streaming_client` or this test's
/// unicast).
enum Fader {
    Artnet {
        value: Arc<std::sync::atomic::AtomicU16>,
        _repeat: Repeat,
    },
    Sacn {
        stream: SacnStream,
        ola: bool,
    },
}

impl Fader {
    /// The protocol's name, for the messages.
    fn protocol(&self) -> &'static str {
        match self {
            Self::Artnet { .. } => "Art-Net",
            Self::Sacn { .. } => "sACN",
        }
    }

    fn artnet(ola: bool, value: u16) -> Self {
        let shared = Arc::new(std::sync::atomic::AtomicU16::new(value));
        let now = Arc::clone(&shared);
        Self::Artnet {
            value: shared,
            _repeat: Repeat::start(move || {
                Console { ola }.artnet(&four(now.load(Ordering::SeqCst)));
            }),
        }
    }

    fn sacn(ola: bool, value: u16) -> Self {
        if ola {
            // OLA universe 1 out on E1.31 universe 1 (unpatched again by `stop`).
            assert!(ola_run("ola_patch", &["-d", "2", "-p", "0", "-u", "1"]));
        }
        Self::Sacn {
            stream: SacnStream::start(ola, 1, &four(value)),
            ola,
        }
    }

    fn set(&self, value: u16) {
        match self {
            Self::Artnet { value: now, .. } => now.store(value, Ordering::SeqCst),
            Self::Sacn { stream, .. } => stream.set(&four(value)),
        }
    }

    /// The console goes silent (an sACN stream is not terminated: it just stops).
    fn stop(self) {
        if let Self::Sacn { ola: true, .. } = &self {
            // olad would go on sending the last values: its port is unpatched (which
            // terminates the stream, as a console switched off does).
            assert!(ola_run(
                "ola_patch",
                &["-r", "-d", "2", "-p", "0", "-u", "1"]
            ));
        }
        drop(self);
    }
}

/// Balls 0–3 at the same 16-bit position.
fn four(value: u16) -> Vec<u8> {
    (0..4).flat_map(|_| value.to_be_bytes()).collect()
}

/// The 16-bit position of `mm`.
fn value_of(mm: f64) -> u16 {
    (mm / TRAVEL_MM * 65535.0).round() as u16
}

/// A step of `console` from `from_mm` to `to_mm` (far beyond the top speed): the
/// simulated balls follow it at the top speed, not in one jump. The simulation's own
/// clock times the samples.
async fn step_followed(
    bridge: &Process,
    token: &str,
    what: &str,
    console: &Fader,
    (from, to): (f64, f64),
) {
    console.set(value_of(to));
    let mut samples: Vec<(u64, f64)> = Vec::new();
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let (balls, at_us) = sim_balls(bridge, token).await;
        samples.push((at_us, balls[0]));
        if (balls[0] - to).abs() < 3.0 {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "{what}: the step not followed: {balls:?}\n{}",
            bridge.log()
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let mut fastest_mm_s = 0.0f64;
    let mut i = 0;
    for j in 1..samples.len() {
        let (t0, p0) = samples[i];
        let (t1, p1) = samples[j];
        // Windows of 0.4 s: a box's 20 ms frame, or one sent 40 ms late on a loaded
        // machine and the next on time, is then a tenth of the distance at most.
        if t1.saturating_sub(t0) >= 400_000 {
            fastest_mm_s = fastest_mm_s.max((p1 - p0).abs() / ((t1 - t0) as f64 / 1e6));
            i = j;
        }
    }
    let took_s = (samples.last().expect("samples").0 - samples[0].0) as f64 / 1e6;
    let distance_mm = (to - from).abs();
    assert!(
        fastest_mm_s <= TOP_SPEED_MM_S * 1.15,
        "{what}: {fastest_mm_s:.0} mm/s over the top speed: {samples:?}"
    );
    assert!(
        fastest_mm_s >= TOP_SPEED_MM_S * 0.5 && took_s >= distance_mm / TOP_SPEED_MM_S * 0.9,
        "{what}: the step took {took_s:.2} s at {fastest_mm_s:.0} mm/s at most: {samples:?}"
    );
    println!(
        "{what}: a {distance_mm:.0} mm step followed in {took_s:.2} s, {fastest_mm_s:.0} mm/s \
         at most ({} samples)",
        samples.len()
    );
}

/// The console goes silent: the balls hold, the status says so.
async fn loss_holds(
    bridge: &Process,
    token: &str,
    what: &str,
    ws: &mut common::Ws,
    console: Fader,
) {
    use floatball_shared::api::LivePhase;
    console.stop();
    let status = common::status_until(ws, Duration::from_secs(15), |status| {
        phase(status) == Some(LivePhase::Holding)
    })
    .await;
    assert!(status.live.as_deref().is_some_and(|live| live.input_lost));
    // The status says holding once the filter rests; the balls may still finish
    // their braking (an MBOX box runs its paced lines out, a UIM2503 unit its FIFO's
    // rows): within 2 s they stand still, and then they stay.
    let settled_by = Instant::now() + Duration::from_secs(2);
    let (mut held, _) = sim_balls(bridge, token).await;
    loop {
        tokio::time::sleep(Duration::from_millis(100)).await;
        let (now, _) = sim_balls(bridge, token).await;
        let still = held.iter().zip(&now).all(|(a, b)| (a - b).abs() < 0.01);
        held = now;
        if still || Instant::now() > settled_by {
            break;
        }
    }
    tokio::time::sleep(Duration::from_millis(300)).await;
    let (still, _) = sim_balls(bridge, token).await;
    assert!(
        held.iter().zip(&still).all(|(a, b)| (a - b).abs() < 1.0),
        "{what}: moved while holding: {held:?} → {still:?}"
    );
}

/// Live mode end to end on `bridge` (10: UIM2503 over Art-Net, then sACN; 11: MBOX
/// over sACN, then Art-Net; 12: MOONS' drives over Art-Net, then sACN), one bridge
/// for both protocols: go live over the WebSocket; over `fader`'s protocol a fader
/// ramp followed by the simulated balls, a step far beyond the top speed followed
/// within it, input lost → holding; the same over `other`'s (input back over it);
/// Record → Stop recording → the show stored, Leave live, and the e-stop with both
/// protocols' input coming: stopped, nothing moves, a `live on` while latched
/// refused.
async fn live_mode(
    bridge: &Process,
    family: &str,
    fader: impl Fn(u16) -> Fader,
    other: impl Fn(u16) -> Fader,
) {
    use floatball_shared::api::{LivePhase, PlayerState};
    let started = Instant::now();
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    let long = Duration::from_secs(15);

    // Go live: the balls home, approach the input and follow it.
    let console = fader(0x1000);
    send_text(&mut ws, r#"{"type":"live","on":true}"#).await;
    let status = common::status_until(&mut ws, long, |status| {
        phase(status) == Some(LivePhase::Following)
    })
    .await;
    let live = status.live.as_deref().expect("live");
    assert!(!live.input_lost && live.period_ms > 0, "{family}: {live:?}");
    println!(
        "{family}: following after {:?}: period {} ms, latency {} ms",
        started.elapsed(),
        live.period_ms,
        live.latency_ms
    );
    // A fader ramp.
    for value in [0x1000u16, 0x1800, 0x2000, 0x2800] {
        console.set(value);
        balls_at(bridge, &token, &format!("{family}: the ramp"), mm(value)).await;
    }
    // The live positions, asked for: what the simulated balls show.
    // (At rest at the ramp's end: the positions are published ten times a second, so
    // a moving ball's may be a few mm behind the simulated one.)
    send_text(&mut ws, r#"{"type":"live_positions","on":true}"#).await;
    let end_mm = mm(0x2800);
    let positions_mm = live_positions(&mut ws, |mm| {
        mm.len() >= 3
            && mm[..3]
                .iter()
                .all(|&at| (f64::from(at) - end_mm).abs() < 1.0)
    })
    .await;
    let (sim, _) = balls_at_rest(bridge, &token, end_mm).await;
    assert!(
        !positions_mm.is_empty() && positions_mm.len() <= sim.len(),
        "{family}: {positions_mm:?}"
    );
    assert!(
        positions_mm
            .iter()
            .zip(&sim)
            .all(|(&live, &at)| (f64::from(live) - at).abs() < 3.0),
        "{family}: live positions {positions_mm:?}, the simulated balls at {sim:?}"
    );
    send_text(&mut ws, r#"{"type":"live_positions","on":false}"#).await;
    // A step of 1,000 mm: followed at the top speed, not in one jump.
    let what = format!("{family} over {}", console.protocol());
    let (from, to) = (mm(0x2800), mm(0x2800) + 1_000.0);
    step_followed(bridge, &token, &what, &console, (from, to)).await;
    // Loss: the console stops; the balls hold, the status says so.
    loss_holds(bridge, &token, &what, &mut ws, console).await;

    // The other protocol, on the same bridge: input back over it (where the balls
    // hold), following again; its ramp, its step (back up), its loss.
    let held = value_of(to);
    let console = other(held);
    let what = format!("{family} over {}", console.protocol());
    common::status_until(&mut ws, long, |status| {
        phase(status) == Some(LivePhase::Following)
    })
    .await;
    for value in [held - 0x400, held - 0x800, held - 0xc00] {
        console.set(value);
        balls_at(bridge, &token, &format!("{what}: the ramp"), mm(value)).await;
    }
    let from = mm(held - 0xc00);
    step_followed(bridge, &token, &what, &console, (from, from - 1_000.0)).await;
    loss_holds(bridge, &token, &what, &mut ws, console).await;

    // Input back: following again; a recording.
    let console = fader(0x2000);
    common::status_until(&mut ws, long, |status| {
        phase(status) == Some(LivePhase::Following)
    })
    .await;
    let take = format!("take {family}");
    send_text(
        &mut ws,
        &serde_json::json!({"type": "record", "name": take}).to_string(),
    )
    .await;
    common::status_until(&mut ws, long, |status| {
        status.live.as_deref().is_some_and(|live| live.recording)
    })
    .await;
    console.set(0x2400);
    tokio::time::sleep(Duration::from_millis(600)).await;
    send_text(&mut ws, r#"{"type":"record_stop"}"#).await;
    let recorded = loop {
        match next_message(&mut ws).await {
            ServerMessage::Recorded { name, duration_ms } => break (name, duration_ms),
            ServerMessage::Error { message, .. } => panic!("{family}: {message}"),
            _ => {}
        }
    };
    assert_eq!(recorded.0, take);
    assert!(recorded.1 >= 500, "{family}: {recorded:?}");
    let reply = bridge
        .request(
            Method::GET,
            &format!("/api/shows/{}", common::encode_path(&take)),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let show =
        floatball_shared::show::Show::from_json(std::str::from_utf8(&reply.body).expect("utf-8"))
            .expect("a native show file");
    show.check().expect("a valid show");
    assert_eq!(show.layout.rows, 1);
    let plan = bridge
        .request(
            Method::GET,
            &format!("/api/plan/{}", common::encode_path(&take)),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(plan.status, StatusCode::OK, "{:?}", plan.body);
    let plan: floatball_shared::api::PlanReport = plan.json();
    assert!(plan.feasible, "{family}: {plan:?}");
    // The same name again: refused (a recording never replaces a show).
    send_text(
        &mut ws,
        &serde_json::json!({"type": "record", "name": take}).to_string(),
    )
    .await;
    assert_eq!(next_error(&mut ws).await, "record_name_taken");
    println!("{family}: recorded {recorded:?}");

    // Leave live: the balls brake to rest, the matrix is idle, the live positions say
    // so once and stop; then live again (the positions known: no homing — UIM2503
    // units are asked where they stand once their FIFO ran out, a few rows after
    // idle, hence the moment's pause; asked at once they would home first).
    send_text(&mut ws, r#"{"type":"live_positions","on":true}"#).await;
    live_positions(&mut ws, |mm| !mm.is_empty()).await;
    send_text(&mut ws, r#"{"type":"live","on":false}"#).await;
    // Once empty as live mode ends, none after it (the matrix idle by then too).
    let (mut ended, mut idle) = (false, false);
    tokio::time::timeout(long, async {
        while !(ended && idle) {
            match next_message(&mut ws).await {
                ServerMessage::Status(status) => {
                    idle = status.state == PlayerState::Idle && status.live.is_none();
                }
                ServerMessage::LivePositions { positions_mm } => {
                    assert!(
                        !ended,
                        "{family}: live positions after leaving: {positions_mm:?}"
                    );
                    ended = positions_mm.is_empty();
                }
                _ => {}
            }
        }
    })
    .await
    .expect("the live positions end and the matrix is idle after leaving");
    send_text(&mut ws, r#"{"type":"live_positions","on":false}"#).await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    send_text(&mut ws, r#"{"type":"live","on":true}"#).await;
    common::status_until(&mut ws, long, |status| {
        phase(status) == Some(LivePhase::Following)
    })
    .await;

    // The e-stop with both protocols' input coming: stopped; each protocol's input
    // reaches the targets and nothing moves; live mode does not come back by itself,
    // and a `live on` while latched is refused.
    let second = other(0x2400);
    tokio::time::sleep(Duration::from_millis(200)).await;
    send_text(&mut ws, r#"{"type":"estop"}"#).await;
    common::status_until(&mut ws, long, |status| {
        status.state == PlayerState::Stopped && status.live.is_none()
    })
    .await;
    tokio::time::sleep(Duration::from_millis(200)).await;
    let (stopped, _) = sim_balls(bridge, &token).await;
    let (sacn, artnet) = if matches!(console, Fader::Sacn { .. }) {
        (console, second)
    } else {
        (second, console)
    };
    // sACN (priority 150) has the universe while both send…
    for value in [0x3000u16, 0x6000] {
        artnet.set(value);
        sacn.set(value + 0x800);
        status_until(bridge, &token, "sACN's input after the e-stop", |status| {
            follows(status, value + 0x800, 0)
        })
        .await;
    }
    // …and once its stream ended, Art-Net's.
    sacn.stop();
    artnet.set(0x1000);
    status_until(
        bridge,
        &token,
        "Art-Net's input after the e-stop",
        |status| follows(status, 0x1000, 0),
    )
    .await;
    send_text(&mut ws, r#"{"type":"live","on":true}"#).await;
    assert_eq!(next_error(&mut ws).await, "live_estop_latched");
    // Nothing comes back by itself meanwhile (input still coming).
    let _ = tokio::time::timeout(Duration::from_millis(500), async {
        loop {
            if let ServerMessage::Status(status) = next_message(&mut ws).await {
                assert!(
                    status.state == PlayerState::Stopped && status.live.is_none(),
                    "{family}: {status:?}"
                );
            }
        }
    })
    .await;
    let (after, _) = sim_balls(bridge, &token).await;
    assert!(
        stopped.iter().zip(&after).all(|(a, b)| (a - b).abs() < 1.0),
        "{family}: moved after the e-stop: {stopped:?} → {after:?}"
    );
    artnet.stop();
    println!("{family}: live mode checked in {:?}", started.elapsed());
}
