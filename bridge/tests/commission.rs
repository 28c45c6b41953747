//! Commissioning through the real `floatball` binary: a simulated gateway of 100
//! factory-fresh units at 9600 baud is rolled call, given stations 1–100 in serial
//! order, a unit is identified, and the stations survive a restart.

mod common;

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
