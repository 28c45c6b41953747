//! Commissioning through the real `floatball` binary: a simulated gateway of 100
//! factory-fresh units at 9600 baud is rolled call, given stations 1–100 in serial
//! order, a unit is identified, and the stations survive a restart.

use crate::common;

use std::time::{Duration, Instant};

use axum::http::{Method, StatusCode};
use common::process::Process;
use common::{Reply, status_until};
use floatball_shared::api::{
    AssignRequest, Assignment, Identifying, PlayerState, RollCall, SimPositions,
};

const CONFIG: &str = "[matrix]\nrows = 10\ncols = 10\n[[gateway]]\nport = \"sim\"\nbaud = 9600\n";

async fn post(bridge: &Process, token: &str, path: &str, body: serde_json::Value) -> Reply {
    bridge
        .request(
            Method::POST,
            path,
            Some(token),
            Some(("application/json", serde_json::to_vec(&body).expect("json"))),
        )
        .await
}

async fn roll_call(bridge: &Process, token: &str) -> RollCall {
    let reply = post(
        bridge,
        token,
        "/api/gateways/0/rollcall",
        serde_json::json!({}),
    )
    .await;
    assert_eq!(
        reply.status,
        StatusCode::OK,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    reply.json()
}

async fn positions(bridge: &Process, token: &str) -> Vec<(u64, f64, bool)> {
    let reply = bridge
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    let positions: SimPositions = reply.json();
    positions.gateways[0]
        .units
        .iter()
        .map(|unit| (unit.serial, unit.position_counts, unit.moving))
        .collect()
}

/// Every configured station answers, once, where the assignment put it.
fn assert_clean(call: &RollCall, serials: &[u64]) {
    assert!(call.duplicated.is_empty(), "{:?}", call.duplicated);
    assert!(call.missing.is_empty(), "{:?}", call.missing);
    assert!(call.unexpected.is_empty(), "{:?}", call.unexpected);
    assert_eq!(call.units.len(), 100);
    for (index, unit) in call.units.iter().enumerate() {
        assert_eq!(unit.serial, serials[index]);
        assert_eq!(usize::from(unit.station), index + 1);
        assert_eq!(
            unit.cell,
            Some(index),
            "station {} is cell {index}",
            unit.station
        );
        assert_eq!(unit.position_mm, Some(0.0));
        assert_eq!(unit.fault, None);
    }
}

#[tokio::test]
async fn a_factory_fresh_gateway_is_commissioned_and_keeps_its_stations() {
    let bridge = Process::start_with_args(CONFIG, &["--sim-factory-fresh"]);
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    assert!(common::process::links_up(&mut ws).await);

    // Every unit answers on the factory station 5.
    let fresh = roll_call(&bridge, &token).await;
    assert_eq!(fresh.units.len(), 100);
    assert!(
        fresh
            .units
            .iter()
            .all(|unit| unit.station == 5 && unit.position_mm.is_none() && unit.cell.is_none())
    );
    assert_eq!(fresh.duplicated, [5]);
    assert_eq!(fresh.missing.len(), 99);
    assert!(!fresh.missing.contains(&5));
    assert!(fresh.took_ms < 5_000, "{} ms at 9600 baud", fresh.took_ms);
    let serials: Vec<u64> = fresh.units.iter().map(|unit| unit.serial).collect();
    assert!(serials.windows(2).all(|pair| pair[0] < pair[1]));

    // A shared station cannot be identified: all its balls would move.
    let shared = post(
        &bridge,
        &token,
        "/api/gateways/0/identify",
        serde_json::json!({"station": 5}),
    )
    .await;
    assert_eq!(shared.status, StatusCode::CONFLICT);
    assert_eq!(shared.error().code, "commission_station_shared");

    // Stations 1–100 in serial order, confirmed by the roll call the answer is.
    let request = AssignRequest {
        assignments: serials
            .iter()
            .zip(1..=100)
            .map(|(&serial, station)| Assignment { serial, station })
            .collect(),
    };
    let started = Instant::now();
    let reply = post(
        &bridge,
        &token,
        "/api/gateways/0/assign",
        serde_json::to_value(&request).expect("json"),
    )
    .await;
    assert_eq!(
        reply.status,
        StatusCode::OK,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    assert_clean(&reply.json(), &serials);
    assert!(
        started.elapsed() < Duration::from_secs(10),
        "{:?}",
        started.elapsed()
    );

    // The health in the status says so.
    status_until(&mut ws, Duration::from_secs(5), |status| {
        status
            .gateways
            .first()
            .and_then(|gateway| gateway.health.as_ref())
            .is_some_and(|health| {
                health.expected == 100 && health.answering == 100 && health.missing.is_empty()
            })
    })
    .await;

    // Identify moves exactly the unit on station 42, and it comes back.
    let reply = post(
        &bridge,
        &token,
        "/api/gateways/0/identify",
        serde_json::json!({"station": 42}),
    )
    .await;
    assert_eq!(
        reply.status,
        StatusCode::ACCEPTED,
        "{}",
        String::from_utf8_lossy(&reply.body)
    );
    let identifying: Identifying = reply.json();
    assert_eq!((identifying.station, identifying.distance_mm), (42, 300.0));
    let busy = post(
        &bridge,
        &token,
        "/api/gateways/0/identify",
        serde_json::json!({"station": 7}),
    )
    .await;
    assert_eq!(busy.status, StatusCode::CONFLICT);
    assert_eq!(busy.error().code, "commission_in_progress");
    let back_at = Instant::now() + Duration::from_millis(identifying.duration_ms);
    let mut deepest = 0.0f64;
    while Instant::now() < back_at {
        let now = positions(&bridge, &token).await;
        let moved: Vec<u64> = now
            .iter()
            .filter(|(_, counts, moving)| *counts != 0.0 || *moving)
            .map(|(serial, _, _)| *serial)
            .collect();
        assert!(
            moved.is_empty() || moved == [serials[41]],
            "{moved:?} moved"
        );
        deepest = now
            .iter()
            .map(|(_, counts, _)| *counts)
            .fold(deepest, f64::max);
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    assert!(
        deepest > 25_000.0,
        "it went down to {deepest} counts, 30000 asked"
    );
    let back = tokio::time::timeout(Duration::from_secs(3), async {
        loop {
            let now = positions(&bridge, &token).await;
            if now
                .iter()
                .all(|(_, counts, moving)| *counts == 0.0 && !moving)
            {
                return;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    })
    .await;
    let left: Vec<_> = positions(&bridge, &token)
        .await
        .into_iter()
        .filter(|(_, counts, moving)| *counts != 0.0 || *moving)
        .collect();
    assert!(back.is_ok(), "the ball did not come back: {left:?}");

    // Refusals name what is wrong.
    for (path, body, status, code) in [
        (
            "/api/gateways/3/rollcall",
            serde_json::json!({}),
            StatusCode::NOT_FOUND,
            "no_such_gateway",
        ),
        (
            "/api/gateways/0/identify",
            serde_json::json!({"station": 0}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "commission_bad_station",
        ),
        (
            "/api/gateways/0/identify",
            serde_json::json!({"station": 1, "distance_mm": -5.0}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "commission_bad_distance",
        ),
        (
            "/api/gateways/0/assign",
            serde_json::json!({"assignments": []}),
            StatusCode::UNPROCESSABLE_ENTITY,
            "commission_no_assignments",
        ),
    ] {
        let reply = post(&bridge, &token, path, body).await;
        assert_eq!(reply.status, status, "{path}");
        assert_eq!(reply.error().code, code, "{path}");
    }
    let silent = post(
        &bridge,
        &token,
        "/api/gateways/0/identify",
        serde_json::json!({"station": 101}),
    )
    .await;
    assert_eq!(silent.status, StatusCode::NOT_FOUND);
    assert_eq!(silent.error().code, "commission_station_silent");

    // The units keep their stations through a restart, as real ones do in flash.
    let bridge = bridge.restart(&["--sim-factory-fresh"]);
    let reply = bridge.login(common::PASSWORD).await;
    assert_eq!(reply.status, StatusCode::OK);
    let token = reply.json::<floatball_shared::api::LoginResponse>().token;
    let mut ws = bridge.ws(&token).await;
    assert!(common::process::links_up(&mut ws).await);
    assert_clean(&roll_call(&bridge, &token).await, &serials);
}

#[tokio::test]
async fn commissioning_waits_for_a_matrix_at_rest_and_moves_nothing_after_an_estop() {
    let bridge = Process::start(
        "[matrix]\nrows = 2\ncols = 2\n[[gateway]]\nport = \"sim\"\n\
         [safety]\napproach_speed_mm_s = 2000.0\n",
    );
    let show = common::show_json("dip", 2, 2, 30.0);
    let token = bridge.prepare_show("dip", &show, true).await;
    let mut ws = bridge.ws(&token).await;
    assert!(common::process::links_up(&mut ws).await);
    common::send_text(&mut ws, r#"{"type":"start"}"#).await;
    status_until(&mut ws, Duration::from_secs(10), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    for path in [
        "/api/gateways/0/rollcall",
        "/api/gateways/0/identify",
        "/api/gateways/0/assign",
    ] {
        let body = serde_json::json!({"station": 1, "assignments": [{"serial": 1, "station": 2}]});
        let reply = post(&bridge, &token, path, body).await;
        assert_eq!(reply.status, StatusCode::CONFLICT, "{path}");
        let error = reply.error();
        assert_eq!(error.code, "commission_not_idle", "{path}");
        assert_eq!(error.params["state"], "playing");
    }

    common::send_text(&mut ws, r#"{"type":"estop"}"#).await;
    status_until(&mut ws, Duration::from_secs(5), |status| {
        status.state == PlayerState::Stopped
    })
    .await;
    // Stopped is at rest: the roll call (queries only) runs; nothing moves or is
    // renumbered while the e-stop is latched.
    let reply = post(
        &bridge,
        &token,
        "/api/gateways/0/rollcall",
        serde_json::json!({}),
    )
    .await;
    assert_eq!(reply.status, StatusCode::OK);
    let call: RollCall = reply.json();
    assert_eq!(call.units.len(), 4);
    assert!(call.missing.is_empty() && call.duplicated.is_empty());
    assert!(call.units.iter().all(|unit| unit.position_mm.is_some()));
    for (path, body) in [
        (
            "/api/gateways/0/identify",
            serde_json::json!({"station": 1}),
        ),
        (
            "/api/gateways/0/assign",
            serde_json::json!({"assignments": [{"serial": call.units[0].serial, "station": 9}]}),
        ),
    ] {
        let reply = post(&bridge, &token, path, body).await;
        assert_eq!(reply.status, StatusCode::CONFLICT, "{path}");
        assert_eq!(reply.error().code, "estop_latched", "{path}");
    }
}

/// Identifies per run of [`identify_moves_its_ball_every_time_under_load`]: 30 here,
/// `IDENTIFY_REPEATS` when set (`cargo xtask identify-repeat` runs 200).
fn identify_repeats() -> usize {
    std::env::var("IDENTIFY_REPEATS")
        .ok()
        .and_then(|value| value.parse().ok())
        .filter(|&repeats| repeats > 0)
        .unwrap_or(30)
}

/// Simulated gateways of the repeat test, identified side by side (one call at a time
/// runs per gateway, and an identify holds its gateway until its ball is back).
const REPEAT_GATEWAYS: usize = 10;

/// Spins a CPU until `stop`: the load the repeat test runs under.
fn burn(stop: &std::sync::atomic::AtomicBool) -> u64 {
    let mut x = 1u64;
    while !stop.load(std::sync::atomic::Ordering::Relaxed) {
        for _ in 0..10_000 {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        }
    }
    x
}

/// Issue 36: one Identify answered 202 and no simulated unit moved. Every 202 must be
/// a move: `IDENTIFY_REPEATS` identifies over [`REPEAT_GATEWAYS`] simulated gateways,
/// with every core kept busy and the simulator polled without pause, and each unit
/// identified must have begun its move down after its 202 — counted by the simulated
/// unit itself (`ptp_moves`), so a 1 mm move over between two looks at a loaded
/// machine's pace is not taken for a miss.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn identify_moves_its_ball_every_time_under_load() {
    use std::sync::Arc;
    use std::sync::atomic::{AtomicBool, Ordering};

    let mut config = String::from("[matrix]\nrows = 2\ncols = 10\n");
    // Half the lines at 9600 baud, half at the simulator's usual 115200.
    for gateway in 0..REPEAT_GATEWAYS {
        let baud = if gateway % 2 == 0 { 9600 } else { 115_200 };
        config.push_str(&format!(
            "[[gateway]]\nport = \"sim\"\nbaud = {baud}\nunits = 2\n"
        ));
    }
    let bridge = Arc::new(Process::start(&config));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    assert!(common::process::links_up(&mut ws).await);

    let stop = Arc::new(AtomicBool::new(false));
    let cores = std::thread::available_parallelism().map_or(2, std::num::NonZeroUsize::get);
    let burners: Vec<_> = (0..cores)
        .map(|_| {
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || burn(&stop))
        })
        .collect();
    let poller = {
        let (bridge, token, stop) = (Arc::clone(&bridge), token.clone(), Arc::clone(&stop));
        tokio::spawn(async move {
            while !stop.load(Ordering::Relaxed) {
                let _ = bridge
                    .request(Method::GET, "/api/sim/positions", Some(&token), None)
                    .await;
            }
        })
    };

    let repeats = identify_repeats();
    let started = Instant::now();
    let mut runs = Vec::new();
    for gateway in 0..REPEAT_GATEWAYS {
        let (bridge, token) = (Arc::clone(&bridge), token.clone());
        let count = repeats / REPEAT_GATEWAYS + usize::from(gateway < repeats % REPEAT_GATEWAYS);
        runs.push(tokio::spawn(async move {
            let mut waits = Vec::new();
            for round in 0..count {
                let station = u8::try_from(round % 2).expect("0 or 1") + 1;
                let path = format!("/api/gateways/{gateway}/identify");
                let body = serde_json::json!({"station": station, "distance_mm": 1.0});
                // The previous identify holds the gateway until its ball is back (and
                // its motor off again): refused meanwhile, asked again.
                let reply = loop {
                    let reply = post(&bridge, &token, &path, body.clone()).await;
                    if reply.status == StatusCode::CONFLICT
                        && reply.error().code == "commission_in_progress"
                    {
                        tokio::time::sleep(Duration::from_millis(20)).await;
                        continue;
                    }
                    break reply;
                };
                assert_eq!(
                    reply.status,
                    StatusCode::ACCEPTED,
                    "gateway {gateway} station {station}: {}",
                    String::from_utf8_lossy(&reply.body)
                );
                // Each identify is two moves (down, then back), and the next one is
                // accepted only once the ball is back: this one's move down is the
                // unit's move number 2 × (its earlier identifies) + 1. Counted by the
                // simulated unit, so a move over before the next look still counts.
                let earlier = u64::try_from(round / 2).expect("a count");
                let wanted_moves = 2 * earlier + 1;
                let accepted = Instant::now();
                // Generous: the point is that every 202 is a move, not how fast a
                // machine this busy writes it.
                let deadline = accepted + Duration::from_secs(10);
                loop {
                    let reply = bridge
                        .request(Method::GET, "/api/sim/positions", Some(&token), None)
                        .await;
                    let positions: SimPositions = reply.json();
                    let unit = positions.gateways[gateway]
                        .units
                        .iter()
                        .find(|unit| unit.station == station)
                        .copied()
                        .expect("the unit");
                    if unit.ptp_moves >= wanted_moves {
                        waits.push(accepted.elapsed());
                        break;
                    }
                    assert!(
                        Instant::now() < deadline,
                        "gateway {gateway} station {station}, identify {round}: 202 and the \
                         unit never began move {wanted_moves}: {unit:?}, line {:?}",
                        positions.gateways[gateway].line
                    );
                    tokio::time::sleep(Duration::from_millis(2)).await;
                }
            }
            waits
        }));
    }
    let mut waits = Vec::new();
    let mut failure = None;
    for run in runs {
        match run.await {
            Ok(mut more) => waits.append(&mut more),
            Err(error) => failure = failure.or(Some(error)),
        }
    }
    stop.store(true, Ordering::Relaxed);
    poller.abort();
    for burner in burners {
        burner.join().expect("a burner");
    }
    if let Some(error) = failure {
        std::panic::resume_unwind(error.into_panic());
    }
    assert_eq!(waits.len(), repeats);
    waits.sort();
    eprintln!(
        "{repeats} identifies on {REPEAT_GATEWAYS} gateways under load in {:?}: every one \
         moved its unit, 202 to the move seen median {:?}, max {:?}",
        started.elapsed(),
        waits[waits.len() / 2],
        waits[waits.len() - 1]
    );
}
