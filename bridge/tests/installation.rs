//! `PUT /api/installation` through the real `floatball` binary: a new installation is
//! checked (every problem listed), saved into `floatball.toml` with its comments
//! kept, applied without a restart (a following show plays on the new stations) and
//! kept by a restart; refused while a show plays. And the patch of live input
//! (`GET` / `PUT /api/live/patch`), written into the same file.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode};
use common::process::Process;
use common::{Remote, send_text, status_until};
use floatball_shared::api::{
    InstallationInfo, LinkState, LivePatch, LoginResponse, PlayerState, RollCall, SimPositions,
};
use floatball_shared::live::patch::{Patch, Profile};

/// A small matrix on the simulated gateway, with the installer's comments.
const HALL: &str = "# The test hall: keep this comment.\n\
                    [matrix]\n\
                    rows = 1 # one row for now\n\
                    cols = 2\n\
                    \n\
                    [[gateway]]\n\
                    # the built-in simulator\n\
                    port = \"sim\"\n\
                    baud = 115200\n";

async fn get_installation(remote: &Remote, token: &str) -> InstallationInfo {
    let reply = remote
        .request(Method::GET, "/api/installation", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    reply.json()
}

async fn put_installation(
    remote: &Remote,
    token: Option<&str>,
    installation: &InstallationInfo,
) -> common::Reply {
    remote
        .request(
            Method::PUT,
            "/api/installation",
            token,
            Some((
                "application/json",
                serde_json::to_vec(installation).expect("json"),
            )),
        )
        .await
}

async fn positions(remote: &Remote, token: &str) -> SimPositions {
    let reply = remote
        .request(Method::GET, "/api/sim/positions", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    reply.json()
}

fn file(bridge: &Process) -> String {
    std::fs::read_to_string(bridge.data.path().join("floatball.toml")).expect("floatball.toml")
}

/// A CSV show of `balls` balls: ball `b` goes down to `depths_mm[b]` in 2 s, holds
/// for `hold_ms`.
fn csv(depths_mm: &[f64], hold_ms: u32) -> Vec<u8> {
    let header: Vec<String> = (0..depths_mm.len())
        .map(|ball| format!("u{ball}"))
        .collect();
    let zeros: Vec<String> = depths_mm.iter().map(|_| "0".to_owned()).collect();
    let depths: Vec<String> = depths_mm.iter().map(|mm| format!("{mm:.1}")).collect();
    format!(
        "time_ms,{}\n0,{}\n2000,{}\n{},{}\n",
        header.join(","),
        zeros.join(","),
        depths.join(","),
        2000 + hold_ms,
        depths.join(",")
    )
    .into_bytes()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_new_installation_is_saved_with_its_comments_applied_at_once_and_kept_by_a_restart() {
    let bridge = Process::start(HALL);
    let token = bridge.operator().await;
    let before = get_installation(&bridge, &token).await;
    assert_eq!((before.rows, before.cols), (1, 2));

    // Only an operator may change it.
    let anonymous = put_installation(&bridge, None, &before).await;
    assert_eq!(anonymous.status, StatusCode::UNAUTHORIZED);

    let mut wanted = before.clone();
    wanted.cols = 3;
    wanted.max_speed_mm_s = 1500.0;
    wanted.approach_speed_mm_s = 200.0;
    wanted.gateways[0].stations = vec![1, 2, 3];
    let reply = put_installation(&bridge, Some(&token), &wanted).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    assert_eq!(reply.json::<InstallationInfo>(), wanted);
    assert_eq!(get_installation(&bridge, &token).await, wanted);
    // The simulated gateway has its third ball now.
    let sim = positions(&bridge, &token).await;
    let stations: Vec<u8> = sim.gateways[0]
        .units
        .iter()
        .map(|unit| unit.station)
        .collect();
    assert_eq!(stations, [1, 2, 3]);
    // Commissioning follows the new installation too: the roll call asks the new
    // simulated gateway (not the link it replaced) and expects the new stations. The
    // new link is up once its gateway answered the greeting.
    let mut ws = bridge.ws(&token).await;
    status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways.len() == 1 && status.gateways[0].link == LinkState::Up
    })
    .await;
    drop(ws);
    let reply = bridge
        .request(Method::POST, "/api/gateways/0/rollcall", Some(&token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let call: RollCall = reply.json();
    let mut answered: Vec<(u8, Option<usize>)> = call
        .units
        .iter()
        .map(|unit| (unit.station, unit.cell))
        .collect();
    answered.sort_unstable();
    assert_eq!(
        answered,
        [(1, Some(0)), (2, Some(1)), (3, Some(2))],
        "{call:?}"
    );
    assert!(
        call.missing.is_empty() && call.unexpected.is_empty(),
        "{call:?}"
    );

    let text = file(&bridge);
    for kept in [
        "# The test hall: keep this comment.\n",
        "rows = 1 # one row for now\n",
        "# the built-in simulator\nport = \"sim\"\n",
        "cols = 3\n",
        "max_speed_mm_s = 1500.0",
        "approach_speed_mm_s = 200.0",
    ] {
        assert!(text.contains(kept), "{kept:?} is not in:\n{text}");
    }
    // No temporary file left behind.
    let leftovers: Vec<_> = std::fs::read_dir(bridge.data.path())
        .expect("data dir")
        .filter_map(Result::ok)
        .filter(|entry| entry.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
    // Uploads and plans see the new matrix at once: a 2-ball show no longer fits it.
    let upload = bridge
        .upload(&token, "two", "text/csv", &csv(&[100.0, 100.0], 500))
        .await;
    assert_eq!(upload.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        upload
            .error()
            .details
            .join(" ")
            .contains("1 rows × 3 columns"),
        "{:?}",
        upload.error()
    );
    let upload = bridge
        .upload(
            &token,
            "three",
            "text/csv",
            &csv(&[100.0, 200.0, 300.0], 500),
        )
        .await;
    assert_eq!(upload.status, StatusCode::CREATED, "{:?}", upload.body);
    let plan = bridge
        .request(Method::GET, "/api/plan/three", Some(&token), None)
        .await;
    let plan: floatball_shared::api::PlanReport = plan.json();
    assert!(plan.feasible, "{plan:?}");
    assert_eq!(plan.gateways[0].units, 3);

    let bridge = bridge.restart(&[]);
    let login = bridge.login(common::PASSWORD).await;
    let token = login.json::<LoginResponse>().token;
    assert_eq!(get_installation(&bridge, &token).await, wanted);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_invalid_installation_lists_every_problem_and_changes_nothing() {
    let bridge = Process::start(HALL);
    let token = bridge.operator().await;
    let before = get_installation(&bridge, &token).await;
    let mut wrong = before.clone();
    wrong.rows = 0;
    wrong.max_speed_mm_s = -1.0;
    wrong.home_mm = wrong.travel_mm + 1.0;
    wrong.approach_speed_mm_s = 9999.0;
    let reply = put_installation(&bridge, Some(&token), &wrong).await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let error = reply.error();
    assert_eq!(error.code, "installation_invalid");
    assert_eq!(error.params["problems"], "4", "{error:?}");
    assert_eq!(error.problems.len(), 4, "{error:?}");
    assert_eq!(error.details.len(), 4, "{error:?}");
    assert!(
        error
            .problems
            .iter()
            .all(|problem| problem.code == "installation_problem"),
        "{error:?}"
    );
    let all = error.details.join("\n");
    for part in [
        "rows = 0 must be from 1 to 1000",
        "max_speed_mm_s = -1 must be",
        "home_mm = 7501 must be from 0 to travel_mm",
        "approach_speed_mm_s = 9999 must be",
    ] {
        assert!(all.contains(part), "{part} is not in {all}");
    }
    // Not the file's place: the client sent no file.
    assert!(!all.contains("floatball.toml"), "{all}");

    // A station twice and one out of range, with the matrix fine.
    let mut stations = before.clone();
    stations.gateways[0].stations = vec![7, 7];
    let reply = put_installation(&bridge, Some(&token), &stations).await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let error = reply.error();
    assert!(error.details.join(" ").contains('7'), "{error:?}");

    // No gateway at all.
    let mut none = before.clone();
    none.gateways.clear();
    let reply = put_installation(&bridge, Some(&token), &none).await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        reply.error().details[0].contains("no gateway"),
        "{:?}",
        reply.error()
    );

    // Not JSON of an installation: 400.
    let reply = bridge
        .request(
            Method::PUT,
            "/api/installation",
            Some(&token),
            Some(("application/json", b"{\"rows\": 3}".to_vec())),
        )
        .await;
    assert_eq!(reply.status, StatusCode::BAD_REQUEST);

    assert_eq!(file(&bridge), HALL);
    assert_eq!(get_installation(&bridge, &token).await, before);

    the_patch_is_checked_saved_with_the_comments_and_read_back(&bridge, &token).await;
}

async fn put_patch(remote: &Remote, token: Option<&str>, patch: &Patch) -> common::Reply {
    remote
        .request(
            Method::PUT,
            "/api/live/patch",
            token,
            Some(("application/json", serde_json::to_vec(patch).expect("json"))),
        )
        .await
}

async fn get_patch(remote: &Remote, token: &str) -> LivePatch {
    let reply = remote
        .request(Method::GET, "/api/live/patch", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    reply.json()
}

/// `GET` / `PUT /api/live/patch` on [`HALL`] (no `[live]` yet): the default patch,
/// a login needed, a wrong patch refused with every problem coded and nothing
/// written, a right one saved into `[live]` with the installer's comments kept.
async fn the_patch_is_checked_saved_with_the_comments_and_read_back(bridge: &Process, token: &str) {
    let live = get_patch(bridge, token).await;
    assert_eq!((live.rows, live.cols), (1, 2));
    assert!(!live.enabled && live.artnet && live.sacn);
    assert_eq!(live.hold_after_ms, 1000);
    assert_eq!(
        live.patch,
        Patch::matrix(2, Profile::default(), 1, 1).expect("matrix")
    );
    assert_eq!(live.universes, [1]);
    let reply = bridge
        .request(Method::GET, "/api/live/patch", None, None)
        .await;
    assert_eq!(reply.status, StatusCode::UNAUTHORIZED);
    assert_eq!(
        put_patch(bridge, None, &live.patch).await.status,
        StatusCode::UNAUTHORIZED
    );
    // Live input off: its status says so, and needs a login too.
    let reply = bridge
        .request(Method::GET, "/api/live/status", None, None)
        .await;
    assert_eq!(reply.status, StatusCode::UNAUTHORIZED);
    let reply = bridge
        .request(Method::GET, "/api/live/status", Some(token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let status: floatball_bridge::live::LiveStatus = reply.json();
    assert!(!status.running && status.targets.is_empty(), "{status:?}");

    // Three balls for two, the third on the second's slots, a 12-bit speed limit.
    let mut wrong = Patch::matrix(3, Profile::default(), 1, 1).expect("matrix");
    wrong.balls[2].address = 4;
    wrong.balls[1].profile = Some(Profile {
        speed_limit_bits: Some(12),
        ..Profile::default()
    });
    let reply = put_patch(bridge, Some(token), &wrong).await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let error = reply.error();
    assert_eq!(error.code, "patch_invalid");
    let codes: Vec<&str> = error.problems.iter().map(|p| p.code.as_str()).collect();
    assert_eq!(
        codes,
        ["patch_ball_count", "patch_speed_bits", "patch_overlap"],
        "{error:?}"
    );
    assert_eq!(error.params["problems"], "3");
    assert_eq!(error.problems[1].params["bits"], "12");
    assert_eq!(file(bridge), HALL);

    // Not JSON of a patch: 400.
    let reply = bridge
        .request(
            Method::PUT,
            "/api/live/patch",
            Some(token),
            Some(("application/json", b"{\"balls\": 3}".to_vec())),
        )
        .await;
    assert_eq!(reply.status, StatusCode::BAD_REQUEST);

    // A DMX winch's profile from universe 7 address 101; the second ball apart.
    let profile = Profile {
        speed_limit_bits: Some(8),
        enable: true,
        colour: false,
    };
    let mut right = Patch::matrix(2, profile, 7, 101).expect("matrix");
    right.balls[1].universe = 9;
    right.balls[1].address = 1;
    let reply = put_patch(bridge, Some(token), &right).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let saved: LivePatch = reply.json();
    assert_eq!(saved.patch, right);
    assert_eq!(saved.universes, [7, 9]);
    assert_eq!(get_patch(bridge, token).await, saved);
    let text = file(bridge);
    assert!(text.starts_with(HALL), "{text}");
    assert!(
        text.contains("matrix = { universe = 7, address = 101 }"),
        "{text}"
    );
    assert!(
        text.contains("[[live.ball]]\nball = 1\nuniverse = 9\naddress = 1\n"),
        "{text}"
    );

    // The installation is checked against the patch: one column fewer leaves
    // `[[live.ball]] ball = 1` without its ball.
    let mut smaller = get_installation(bridge, token).await;
    smaller.cols = 1;
    smaller.gateways[0].stations = vec![1];
    let reply = put_installation(bridge, Some(token), &smaller).await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let details = reply.error().details.join("\n");
    assert!(
        details.contains("[[live.ball]] ball = 1: the installation has balls 0–0"),
        "{details}"
    );
    assert_eq!(file(bridge), text);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn stations_saved_as_a_list_are_used_by_the_next_show_and_refused_while_it_plays() {
    let bridge = Process::start(HALL);
    let token = bridge
        .prepare_upload("deep", "text/csv", &csv(&[300.0, 600.0], 2500), false)
        .await;
    let before = get_installation(&bridge, &token).await;
    assert_eq!(before.gateways[0].stations, vec![1, 2]);

    // The first cell is station 2's ball, the second station 1's.
    let mut swapped = before.clone();
    swapped.gateways[0].stations = vec![2, 1];
    let reply = put_installation(&bridge, Some(&token), &swapped).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    assert!(
        file(&bridge).contains("stations = [2, 1]"),
        "{}",
        file(&bridge)
    );

    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"start"}"#).await;
    status_until(&mut ws, Duration::from_secs(15), |status| {
        status.state == PlayerState::Playing
    })
    .await;
    // While it plays: refused, coded, nothing written.
    let reply = put_installation(&bridge, Some(&token), &before).await;
    assert_eq!(reply.status, StatusCode::CONFLICT, "{:?}", reply.body);
    let error = reply.error();
    assert_eq!(error.code, "installation_busy");
    assert_eq!(error.params["state"], "playing");
    assert!(file(&bridge).contains("stations = [2, 1]"));
    // The patch too.
    let patch = get_patch(&bridge, &token).await.patch;
    let reply = put_patch(&bridge, Some(&token), &patch).await;
    assert_eq!(reply.status, StatusCode::CONFLICT, "{:?}", reply.body);
    let error = reply.error();
    assert_eq!(error.code, "patch_busy");
    assert_eq!(error.params["state"], "playing");
    assert!(!file(&bridge).contains("[live]"));

    status_until(&mut ws, Duration::from_secs(15), |status| {
        status.state == PlayerState::Idle
    })
    .await;
    let sim = positions(&bridge, &token).await;
    let depth_mm = |station: u8| {
        let unit = sim.gateways[0]
            .units
            .iter()
            .find(|unit| unit.station == station)
            .expect("the station's unit");
        unit.position_counts / before.counts_per_mm
    };
    assert!((depth_mm(2) - 300.0).abs() < 5.0, "{sim:?}");
    assert!((depth_mm(1) - 600.0).abs() < 5.0, "{sim:?}");

    // Idle again: the old order is taken back.
    let reply = put_installation(&bridge, Some(&token), &before).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    assert!(!file(&bridge).contains("stations ="), "{}", file(&bridge));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gateways_are_added_reopened_at_a_new_speed_and_removed_without_a_restart() {
    let bridge = Process::start(HALL);
    let token = bridge.operator().await;
    let before = get_installation(&bridge, &token).await;
    let mut ws = bridge.ws(&token).await;
    status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways.len() == 1
            && status.gateways[0].link == floatball_shared::api::LinkState::Up
    })
    .await;

    // Two gateways, one ball each; the first's line at another speed.
    let mut two = before.clone();
    two.gateways[0].stations = vec![1];
    two.gateways[0].baud = Some(57_600);
    let mut second = two.gateways[0].clone();
    second.baud = Some(38_400);
    second.stations = vec![5];
    two.gateways.push(second);
    let reply = put_installation(&bridge, Some(&token), &two).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let status = status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways.len() == 2
            && status
                .gateways
                .iter()
                .all(|gateway| gateway.link == floatball_shared::api::LinkState::Up)
    })
    .await;
    let bauds: Vec<Option<u32>> = status.gateways.iter().map(|gateway| gateway.baud).collect();
    assert_eq!(bauds, [Some(57_600), Some(38_400)]);
    let sim = positions(&bridge, &token).await;
    assert_eq!(sim.gateways.len(), 2);
    assert_eq!(sim.gateways[1].units[0].station, 5);
    let text = file(&bridge);
    assert_eq!(text.matches("[[gateway]]").count(), 2, "{text}");
    assert!(text.contains("baud = 57600"), "{text}");

    // Back to one: the second gateway's link closes.
    let reply = put_installation(&bridge, Some(&token), &before).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let status = status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways.len() == 1
            && status.gateways[0].link == floatball_shared::api::LinkState::Up
    })
    .await;
    assert_eq!(status.gateways[0].baud, Some(115_200));
    assert_eq!(positions(&bridge, &token).await.gateways.len(), 1);
    assert_eq!(get_installation(&bridge, &token).await, before);
}

async fn post_baud(remote: &Remote, token: &str, gateway: usize, baud: u32) -> common::Reply {
    remote
        .request(
            Method::POST,
            &format!("/api/gateways/{gateway}/baud"),
            Some(token),
            Some((
                "application/json",
                serde_json::to_vec(&floatball_shared::api::BaudRequest { baud }).expect("json"),
            )),
        )
        .await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_gateway_line_speed_changes_live_and_is_saved() {
    let bridge = Process::start(HALL);
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways.len() == 1
            && status.gateways[0].link == floatball_shared::api::LinkState::Up
    })
    .await;

    let refused = post_baud(&bridge, &token, 0, 300).await;
    assert_eq!(refused.status, StatusCode::UNPROCESSABLE_ENTITY);
    let error = refused.error();
    assert_eq!(error.code, "baud_not_allowed");
    assert_eq!(error.params["allowed"], "9600, 19200, 38400, 57600, 115200");
    let missing = post_baud(&bridge, &token, 3, 9600).await;
    assert_eq!(missing.status, StatusCode::NOT_FOUND);
    assert_eq!(missing.error().code, "no_such_gateway");

    let reply = post_baud(&bridge, &token, 0, 9600).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let changed: floatball_shared::api::BaudChanged = reply.json();
    assert_eq!((changed.from_baud, changed.baud), (115_200, 9600));
    let status = status_until(&mut ws, Duration::from_secs(10), |status| {
        status.gateways[0].link == floatball_shared::api::LinkState::Up
            && status.gateways[0].baud == Some(9600)
    })
    .await;
    assert_eq!(status.gateways.len(), 1);
    let text = file(&bridge);
    assert!(text.contains("baud = 9600\n"), "{text}");
    assert!(text.contains("# the built-in simulator\n"), "{text}");
    assert_eq!(
        get_installation(&bridge, &token).await.gateways[0].baud,
        Some(9600)
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_mbox_installation_takes_new_limits_live_but_not_new_gateways() {
    let config =
        "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n";
    let bridge = Process::start(config);
    let token = bridge.operator().await;
    let before = get_installation(&bridge, &token).await;
    // The same installation: nothing changes.
    let same = put_installation(&bridge, Some(&token), &before).await;
    assert_eq!(same.status, StatusCode::OK, "{:?}", same.body);
    assert_eq!(file(&bridge), config);

    // Its gateways' stations (the boxes' axes): only in the file.
    let mut axes = before.clone();
    axes.gateways[0].stations = vec![3, 2, 1];
    let reply = put_installation(&bridge, Some(&token), &axes).await;
    assert_eq!(reply.status, StatusCode::CONFLICT);
    assert_eq!(reply.error().code, "installation_not_live");
    assert_eq!(file(&bridge), config);

    // A slower top speed: saved and used at once (the plan refuses a fast show).
    let mut slower = before.clone();
    slower.max_speed_mm_s = 100.0;
    slower.approach_speed_mm_s = 50.0;
    let reply = put_installation(&bridge, Some(&token), &slower).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let text = file(&bridge);
    assert!(text.contains("max_speed_mm_s = 100.0"), "{text}");
    assert!(
        text.contains("[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 3\n"),
        "{text}"
    );
    let upload = bridge
        .upload(
            &token,
            "fast",
            "text/csv",
            &csv(&[500.0, 500.0, 500.0], 500),
        )
        .await;
    assert_eq!(upload.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        upload.error().details.join(" ").contains("100"),
        "{:?}",
        upload.error()
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_scl_installation_takes_new_limits_live() {
    let config =
        "[matrix]\nrows = 1\ncols = 3\n[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n";
    let bridge = Process::start(config);
    let token = bridge.operator().await;
    let before = get_installation(&bridge, &token).await;
    let mut places = before.clone();
    places.gateways[0].stations = vec![1, 2];
    let reply = put_installation(&bridge, Some(&token), &places).await;
    assert_eq!(reply.status, StatusCode::CONFLICT);
    assert_eq!(reply.error().code, "installation_not_live");

    let mut slower = before.clone();
    slower.max_speed_mm_s = 100.0;
    slower.approach_speed_mm_s = 50.0;
    let reply = put_installation(&bridge, Some(&token), &slower).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    assert_eq!(get_installation(&bridge, &token).await, slower);
    assert!(
        file(&bridge).contains("[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 3\n"),
        "{}",
        file(&bridge)
    );
    let upload = bridge
        .upload(
            &token,
            "fast",
            "text/csv",
            &csv(&[500.0, 500.0, 500.0], 500),
        )
        .await;
    assert_eq!(upload.status, StatusCode::UNPROCESSABLE_ENTITY);
}
