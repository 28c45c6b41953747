//! The HTTP API over real sockets: every call's success and each of its errors, the
//! login limit, token expiry, uploads cut off half-way, and a restart.

use crate::common;

use std::time::Duration;

use axum::http::{Method, StatusCode, header};
use common::{Bridge, PASSWORD, encode_path, show_json};
use floatball_shared::api::{
    GatewayKind, InstallationGateway, InstallationInfo, LoginResponse, Playlist, PlaylistEntry,
    ShowSummary,
};
use sha2::{Digest, Sha256};
use tokio::io::AsyncWriteExt;

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|byte| format!("{byte:02x}"))
        .collect()
}

/// A CSV show for the default 10 × 10 installation: every ball goes 20 mm down, stays,
/// and comes back, over `steps` keyframes 200 ms apart.
fn csv_show(steps: usize) -> String {
    let mut text = String::from("time_ms");
    for unit in 0..100 {
        text.push_str(&format!(",u{unit}"));
    }
    text.push('\n');
    for step in 0..steps {
        let depth_mm = if step == 0 || step + 1 == steps {
            0
        } else {
            20
        };
        text.push_str(&(step * 200).to_string());
        for _ in 0..100 {
            text.push_str(&format!(",{depth_mm}"));
        }
        text.push('\n');
    }
    text
}

#[tokio::test]
async fn login_answers_a_token_or_401_or_400() {
    let bridge = Bridge::start().await;
    let reply = bridge.login("1234").await;
    assert_eq!(reply.status, StatusCode::OK);
    let login: LoginResponse = reply.json();
    assert_eq!(login.token.len(), 64);
    assert!(login.must_change_password);

    let wrong = bridge.login("4321").await;
    assert_eq!(wrong.status, StatusCode::UNAUTHORIZED);
    assert_eq!(wrong.error().error, "Wrong password");
    assert_eq!(wrong.error().code, "wrong_password");

    let bad = bridge
        .request(
            Method::POST,
            "/api/login",
            None,
            Some(("application/json", b"{\"pass\":1}".to_vec())),
        )
        .await;
    assert_eq!(bad.status, StatusCode::BAD_REQUEST);
    assert!(
        bad.error().error.contains("login request"),
        "{:?}",
        bad.error()
    );
}

#[tokio::test]
async fn five_wrong_passwords_in_a_minute_get_429_with_retry_after() {
    let bridge = Bridge::start().await;
    for _ in 0..5 {
        assert_eq!(bridge.login("0000").await.status, StatusCode::UNAUTHORIZED);
    }
    let refused = bridge.login("1234").await;
    assert_eq!(refused.status, StatusCode::TOO_MANY_REQUESTS);
    let retry_after: u64 = refused.headers[header::RETRY_AFTER]
        .to_str()
        .expect("ascii")
        .parse()
        .expect("seconds");
    assert!((1..=60).contains(&retry_after), "{retry_after}");
    assert_eq!(refused.error().code, "too_many_attempts");
    assert_eq!(
        refused.error().params["retry_after_s"],
        retry_after.to_string()
    );

    // Another address is not held back.
    let other = bridge
        .request_from(
            "127.0.0.2".parse().expect("ip"),
            Method::POST,
            "/api/login",
            None,
            Some(("application/json", br#"{"password":"1234"}"#.to_vec())),
            &[],
        )
        .await;
    assert_eq!(other.status, StatusCode::OK);

    // A minute later the address may try again.
    bridge.clock.advance(Duration::from_secs(60));
    assert_eq!(bridge.login("1234").await.status, StatusCode::OK);
}

#[tokio::test]
async fn concurrent_guesses_cannot_slip_past_the_limit() {
    let bridge = Bridge::start().await;
    let guesses = (0..20).map(|_| bridge.login("0000"));
    let replies = futures_util::future::join_all(guesses).await;
    let checked = replies
        .iter()
        .filter(|reply| reply.status == StatusCode::UNAUTHORIZED)
        .count();
    let refused = replies
        .iter()
        .filter(|reply| reply.status == StatusCode::TOO_MANY_REQUESTS)
        .count();
    assert_eq!((checked, refused), (5, 15));
}

#[tokio::test]
async fn every_call_but_login_needs_a_valid_token() {
    let bridge = Bridge::start().await;
    for (method, path) in [
        (Method::POST, "/api/logout"),
        (Method::POST, "/api/password"),
        (Method::GET, "/api/shows"),
        (Method::GET, "/api/shows/a"),
        (Method::PUT, "/api/shows/a"),
        (Method::DELETE, "/api/shows/a"),
        (Method::GET, "/api/playlist"),
        (Method::PUT, "/api/playlist"),
        (Method::GET, "/api/installation"),
    ] {
        for token in [None, Some("0123abcd")] {
            let reply = bridge.request(method.clone(), path, token, None).await;
            assert_eq!(reply.status, StatusCode::UNAUTHORIZED, "{method} {path}");
            assert_eq!(reply.headers[header::WWW_AUTHENTICATE], "Bearer");
            assert!(!reply.error().error.is_empty());
        }
    }
}

#[tokio::test]
async fn changes_are_refused_until_the_initial_password_is_changed() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let upload = bridge
        .upload(
            &token,
            "wave",
            "application/json",
            &show_json("wave", 10, 10, 40.0),
        )
        .await;
    assert_eq!(upload.status, StatusCode::FORBIDDEN);
    assert!(
        upload.error().error.contains("initial password"),
        "{:?}",
        upload.error()
    );
    let delete = bridge
        .request(Method::DELETE, "/api/shows/wave", Some(&token), None)
        .await;
    assert_eq!(delete.status, StatusCode::FORBIDDEN);
    let playlist = bridge
        .request(
            Method::PUT,
            "/api/playlist",
            Some(&token),
            Some((
                "application/json",
                serde_json::to_vec(&Playlist::default()).expect("json"),
            )),
        )
        .await;
    assert_eq!(playlist.status, StatusCode::FORBIDDEN);
    // Reading is allowed.
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(list.status, StatusCode::OK);

    assert_eq!(
        bridge
            .change_password(&token, "1234", PASSWORD)
            .await
            .status,
        StatusCode::NO_CONTENT
    );
    let upload = bridge
        .upload(
            &token,
            "wave",
            "application/json",
            &show_json("wave", 10, 10, 40.0),
        )
        .await;
    assert_eq!(upload.status, StatusCode::CREATED);
}

#[tokio::test]
async fn the_password_change_checks_both_passwords_and_ends_other_sessions() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let other = bridge.token().await;

    let wrong = bridge.change_password(&token, "9999", PASSWORD).await;
    assert_eq!(wrong.status, StatusCode::FORBIDDEN);
    assert_eq!(wrong.error().error, "The current password is wrong");
    assert_eq!(wrong.error().code, "wrong_current_password");
    let short = bridge.change_password(&token, "1234", "abc").await;
    assert_eq!(short.status, StatusCode::BAD_REQUEST);
    assert_eq!(short.error().code, "password_too_short");
    assert_eq!(short.error().params["min"], "4");
    let same = bridge.change_password(&token, "1234", "1234").await;
    assert_eq!(same.status, StatusCode::BAD_REQUEST);
    assert_eq!(same.error().code, "password_is_default");
    let garbage = bridge
        .request(
            Method::POST,
            "/api/password",
            Some(&token),
            Some(("application/json", b"[]".to_vec())),
        )
        .await;
    assert_eq!(garbage.status, StatusCode::BAD_REQUEST);

    let changed = bridge.change_password(&token, "1234", PASSWORD).await;
    assert_eq!(changed.status, StatusCode::NO_CONTENT);
    assert!(changed.body.is_empty());

    assert_eq!(bridge.login("1234").await.status, StatusCode::UNAUTHORIZED);
    let login: LoginResponse = bridge.login(PASSWORD).await.json();
    assert!(!login.must_change_password);
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(list.status, StatusCode::OK, "the changing session goes on");
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&other), None)
        .await;
    assert_eq!(list.status, StatusCode::UNAUTHORIZED, "other sessions end");
}

#[tokio::test]
async fn wrong_current_passwords_count_towards_the_limit() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    for _ in 0..5 {
        let reply = bridge.change_password(&token, "0000", PASSWORD).await;
        assert_eq!(reply.status, StatusCode::FORBIDDEN);
    }
    let reply = bridge.change_password(&token, "1234", PASSWORD).await;
    assert_eq!(reply.status, StatusCode::TOO_MANY_REQUESTS);
    assert!(reply.headers.contains_key(header::RETRY_AFTER));
}

#[tokio::test]
async fn tokens_expire_after_twelve_idle_hours_and_on_logout() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    bridge.clock.advance(Duration::from_secs(11 * 3600));
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(list.status, StatusCode::OK, "used after 11 h: still valid");
    bridge.clock.advance(Duration::from_secs(11 * 3600));
    let list = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(
        list.status,
        StatusCode::OK,
        "11 h after its last use: still valid"
    );
    bridge.clock.advance(Duration::from_secs(12 * 3600));
    let expired = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(expired.status, StatusCode::UNAUTHORIZED);
    assert!(expired.error().error.contains("log in again"));

    let token = bridge.token().await;
    let logout = bridge
        .request(Method::POST, "/api/logout", Some(&token), None)
        .await;
    assert_eq!(logout.status, StatusCode::NO_CONTENT);
    let after = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(after.status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn a_json_show_is_stored_listed_downloaded_replaced_and_deleted() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let name = "波浪 1";
    let path = encode_path(name);

    let created = bridge
        .upload(
            &token,
            &path,
            "application/json",
            &show_json("anything", 10, 10, 40.0),
        )
        .await;
    assert_eq!(created.status, StatusCode::CREATED, "{:?}", created.body);
    let summary: ShowSummary = created.json();
    assert_eq!(summary.name, name);
    assert_eq!(summary.units, 100);
    assert_eq!(summary.duration_ms, 500);
    assert!(summary.modified.ends_with('Z'));

    let download = bridge
        .request(
            Method::GET,
            &format!("/api/shows/{path}"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(download.status, StatusCode::OK);
    assert_eq!(download.headers[header::CONTENT_TYPE], "application/json");
    assert_eq!(summary.bytes, download.body.len() as u64);
    assert_eq!(summary.sha256, sha256_hex(&download.body));
    let stored: serde_json::Value = download.json();
    assert_eq!(
        stored["name"], name,
        "the stored show carries its store name"
    );

    let list = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await;
    assert_eq!(list.status, StatusCode::OK);
    assert_eq!(
        list.json::<Vec<ShowSummary>>(),
        std::slice::from_ref(&summary)
    );

    let replaced = bridge
        .upload(
            &token,
            &path,
            "application/json",
            &show_json(name, 10, 10, 30.0),
        )
        .await;
    assert_eq!(replaced.status, StatusCode::OK);
    assert_ne!(replaced.json::<ShowSummary>().sha256, summary.sha256);
    let list: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert_eq!(list.len(), 1);

    let deleted = bridge
        .request(
            Method::DELETE,
            &format!("/api/shows/{path}"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(deleted.status, StatusCode::NO_CONTENT);
    for method in [Method::GET, Method::DELETE] {
        let gone = bridge
            .request(
                method.clone(),
                &format!("/api/shows/{path}"),
                Some(&token),
                None,
            )
            .await;
        assert_eq!(gone.status, StatusCode::NOT_FOUND, "{method}");
        assert!(gone.error().error.contains(name));
    }
    let list: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert!(list.is_empty());
}

#[tokio::test]
async fn csv_uploads_are_converted_with_the_installation_layout() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    for (name, content_type) in [("declared", "text/csv"), ("sniffed", "")] {
        let reply = bridge
            .upload(&token, name, content_type, csv_show(6).as_bytes())
            .await;
        assert_eq!(
            reply.status,
            StatusCode::CREATED,
            "{name}: {:?}",
            reply.body
        );
        let summary: ShowSummary = reply.json();
        assert_eq!((summary.units, summary.duration_ms), (100, 1000));
        let stored = bridge
            .request(
                Method::GET,
                &format!("/api/shows/{name}"),
                Some(&token),
                None,
            )
            .await;
        let json: serde_json::Value = stored.json();
        assert_eq!(json["format"], "floatball-show", "stored as native JSON");
        assert_eq!(json["layout"]["rows"], 10);
    }
}

#[tokio::test]
async fn bad_names_get_400_and_store_nothing() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let body = show_json("x", 10, 10, 40.0);
    let too_long = encode_path(&"波".repeat(34));
    for path in [
        "..%2Fescape",
        "a%2Fb",
        "a%5Cb",
        ".hidden",
        "a..b",
        "bell%07",
        "%00",
        too_long.as_str(),
    ] {
        let reply = bridge.upload(&token, path, "application/json", &body).await;
        assert_eq!(reply.status, StatusCode::BAD_REQUEST, "{path}");
        assert!(!reply.error().error.is_empty());
    }
    let longest = encode_path(&"波".repeat(33));
    let reply = bridge
        .upload(&token, &longest, "application/json", &body)
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "99 bytes is allowed");
    let shows_dir = bridge.data_dir().join("shows");
    assert_eq!(std::fs::read_dir(&shows_dir).expect("dir").count(), 1);
    assert!(!bridge.data_dir().join("escape").exists());
}

#[tokio::test]
async fn invalid_shows_get_422_listing_every_problem() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;

    // Too deep for the travel (7500 mm) and too fast, on every ball.
    let reply = bridge
        .upload(
            &token,
            "deep",
            "application/json",
            &show_json("deep", 10, 10, 9000.0),
        )
        .await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let error = reply.error();
    assert!(
        error.error.contains("does not fit this installation"),
        "{error:?}"
    );
    assert!(
        error.details.len() >= 200,
        "every ball's problems: {}",
        error.details.len()
    );
    assert!(
        error.details.iter().any(|d| d.starts_with("ball u99 ")),
        "{error:?}"
    );
    assert!(
        error
            .details
            .iter()
            .any(|d| d.contains("below the lowest point"))
    );
    assert_eq!(error.code, "show_unfit");
    assert_eq!(error.problems.len(), error.details.len());
    let below = error
        .problems
        .iter()
        .find(|problem| problem.code == "below_travel")
        .expect("a coded violation");
    assert!(below.params.contains_key("unit") && below.params.contains_key("travel_mm"));

    let reply = bridge
        .upload(
            &token,
            "small",
            "application/json",
            &show_json("small", 2, 2, 40.0),
        )
        .await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert!(reply.error().details[0].contains("the installation has 10 rows × 10 columns"));

    for (content_type, body) in [
        (
            "application/json",
            b"{\"format\":\"floatball-show\"".to_vec(),
        ),
        ("text/csv", b"time_ms,u0\n0,0\n".to_vec()),
        ("text/csv", b"\xff\xfe\x00".to_vec()),
    ] {
        let reply = bridge.upload(&token, "broken", content_type, &body).await;
        assert_eq!(
            reply.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{content_type}"
        );
        let error = reply.error();
        assert!(!error.details.is_empty());
        assert_eq!(error.problems.len(), error.details.len(), "{error:?}");
        assert!(!error.code.is_empty() && !error.problems[0].code.is_empty());
    }
    let list: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert!(list.is_empty(), "nothing stored: {list:?}");
}

#[tokio::test]
async fn uploads_over_the_limit_get_413_as_json() {
    let bridge = Bridge::start_with("[uploads]\nmax_bytes = 2048\n").await;
    let token = bridge.operator().await;
    let reply = bridge
        .upload(&token, "big", "text/csv", csv_show(10).as_bytes())
        .await;
    assert_eq!(reply.status, StatusCode::PAYLOAD_TOO_LARGE);
    let error = reply.error();
    assert!(error.error.contains("2048"), "{error:?}");
    assert_eq!(error.code, "show_too_large");
    assert_eq!(error.params["limit_bytes"], "2048");
    let list: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert!(list.is_empty());
}

#[tokio::test]
async fn an_upload_cut_off_half_way_stores_nothing() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let csv = csv_show(20);
    // Cut at a line break: what arrived is itself a valid CSV show, so only reading the
    // whole declared body tells that the upload is incomplete.
    let cut = csv
        .char_indices()
        .filter(|(_, c)| *c == '\n')
        .nth(10)
        .map(|(at, _)| at + 1)
        .expect("a line break");
    let mut stream = tokio::net::TcpStream::connect(bridge.addr)
        .await
        .expect("connect");
    let head = format!(
        "PUT /api/shows/cut HTTP/1.1\r\nHost: {}\r\nAuthorization: Bearer {token}\r\n\
         Content-Type: text/csv\r\nContent-Length: {}\r\n\r\n",
        bridge.addr,
        csv.len()
    );
    stream.write_all(head.as_bytes()).await.expect("head");
    stream
        .write_all(&csv.as_bytes()[..cut])
        .await
        .expect("half");
    stream.flush().await.expect("flush");
    tokio::time::sleep(Duration::from_millis(200)).await;
    drop(stream);
    tokio::time::sleep(Duration::from_millis(300)).await;

    let list: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert!(list.is_empty(), "{list:?}");
    let files = std::fs::read_dir(bridge.data_dir().join("shows"))
        .expect("dir")
        .count();
    assert_eq!(files, 0, "no file, not even a temporary one");

    // The same body, whole, is a show.
    let whole = bridge
        .upload(&token, "cut", "text/csv", csv.as_bytes())
        .await;
    assert_eq!(whole.status, StatusCode::CREATED, "{:?}", whole.body);
    let reply = bridge
        .upload(&token, "cut-short", "text/csv", &csv.as_bytes()[..cut])
        .await;
    assert_eq!(
        reply.status,
        StatusCode::CREATED,
        "the first half alone is valid too"
    );
}

#[tokio::test]
async fn the_playlist_is_checked_and_stored() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    let get = bridge
        .request(Method::GET, "/api/playlist", Some(&token), None)
        .await;
    assert_eq!(get.status, StatusCode::OK);
    assert_eq!(get.json::<Playlist>(), Playlist::default());

    let reply = bridge
        .upload(
            &token,
            &encode_path("雨"),
            "application/json",
            &show_json("雨", 10, 10, 10.0),
        )
        .await;
    assert_eq!(reply.status, StatusCode::CREATED);
    let playlist = Playlist {
        entries: vec![PlaylistEntry {
            show: "雨".into(),
            delay_ms: 500,
            cycles: 3,
            timecode_start: None,
        }],
        loop_playlist: true,
        default_delay_ms: 1000,
        default_cycles: 2,
    };
    let put = |playlist: &Playlist| {
        let body = serde_json::to_vec(playlist).expect("json");
        bridge.request(
            Method::PUT,
            "/api/playlist",
            Some(&token),
            Some(("application/json", body)),
        )
    };
    let stored = put(&playlist).await;
    assert_eq!(stored.status, StatusCode::OK, "{:?}", stored.body);
    assert_eq!(stored.json::<Playlist>(), playlist);
    let get = bridge
        .request(Method::GET, "/api/playlist", Some(&token), None)
        .await;
    assert_eq!(get.json::<Playlist>(), playlist);

    let mut unknown = playlist.clone();
    unknown.entries.push(PlaylistEntry {
        show: "snow".into(),
        delay_ms: 0,
        cycles: 0,
        timecode_start: None,
    });
    let refused = put(&unknown).await;
    assert_eq!(refused.status, StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(
        refused.error().details,
        [
            "entry 2: there is no show named \"snow\"",
            "entry 2: cycles is 0; it must be from 1 to 1000000"
        ]
    );
    let codes: Vec<String> = refused
        .error()
        .problems
        .into_iter()
        .map(|problem| problem.code)
        .collect();
    assert_eq!(codes, ["playlist_unknown_show", "entry_cycles"]);
    let bad = bridge
        .request(
            Method::PUT,
            "/api/playlist",
            Some(&token),
            Some(("application/json", b"{\"entries\":3}".to_vec())),
        )
        .await;
    assert_eq!(bad.status, StatusCode::BAD_REQUEST);
    let get = bridge
        .request(Method::GET, "/api/playlist", Some(&token), None)
        .await;
    assert_eq!(
        get.json::<Playlist>(),
        playlist,
        "refused playlists change nothing"
    );

    let in_use = bridge
        .request(
            Method::DELETE,
            &format!("/api/shows/{}", encode_path("雨")),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(in_use.status, StatusCode::CONFLICT);
    assert!(in_use.error().error.contains("playlist"));
}

#[tokio::test]
async fn a_restart_finds_exactly_the_complete_files_and_the_playlist() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    for name in ["one", "二"] {
        let reply = bridge
            .upload(
                &token,
                &encode_path(name),
                "application/json",
                &show_json(name, 10, 10, 20.0),
            )
            .await;
        assert_eq!(reply.status, StatusCode::CREATED);
    }
    let playlist = Playlist {
        entries: vec![PlaylistEntry {
            show: "二".into(),
            delay_ms: 0,
            cycles: 1,
            timecode_start: None,
        }],
        ..Playlist::default()
    };
    let reply = bridge
        .request(
            Method::PUT,
            "/api/playlist",
            Some(&token),
            Some((
                "application/json",
                serde_json::to_vec(&playlist).expect("json"),
            )),
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    let before: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    // What a crash in the middle of a write leaves behind.
    let shows_dir = bridge.data_dir().join("shows");
    std::fs::write(
        shows_dir.join(".74.json.00ff00ff00ff00ff.tmp"),
        b"{\"format\":",
    )
    .expect("write");

    let bridge = bridge.restart().await;
    let token = bridge.login(PASSWORD).await.json::<LoginResponse>().token;
    let after: Vec<ShowSummary> = bridge
        .request(Method::GET, "/api/shows", Some(&token), None)
        .await
        .json();
    assert_eq!(after, before);
    let names: Vec<&str> = after.iter().map(|show| show.name.as_str()).collect();
    assert_eq!(names, ["one", "二"]);
    let stored: Playlist = bridge
        .request(Method::GET, "/api/playlist", Some(&token), None)
        .await
        .json();
    assert_eq!(stored, playlist);
    assert_eq!(std::fs::read_dir(&shows_dir).expect("dir").count(), 2);
}

#[tokio::test]
async fn unknown_api_paths_and_methods_answer_json() {
    let bridge = Bridge::start().await;
    let token = bridge.token().await;
    let missing = bridge
        .request(Method::GET, "/api/nothing", Some(&token), None)
        .await;
    assert_eq!(missing.status, StatusCode::NOT_FOUND);
    assert!(!missing.error().error.is_empty());
    let method = bridge
        .request(Method::PATCH, "/api/playlist", Some(&token), None)
        .await;
    assert_eq!(method.status, StatusCode::METHOD_NOT_ALLOWED);
    assert!(!method.error().error.is_empty());
}

#[tokio::test]
async fn cors_answers_only_the_configured_origins() {
    let bridge = Bridge::start_with("allowed_origins = [\"http://kiosk.local:3000\"]\n").await;
    let bridge = &bridge;
    let preflight = |origin: &'static str| async move {
        let headers = [
            ("origin", origin),
            ("access-control-request-method", "GET"),
            ("access-control-request-headers", "authorization"),
        ];
        bridge
            .request_from(
                "127.0.0.1".parse().expect("ip"),
                Method::OPTIONS,
                "/api/shows",
                None,
                None,
                &headers,
            )
            .await
    };
    let allowed = preflight("http://kiosk.local:3000").await;
    assert_eq!(
        allowed.headers["access-control-allow-origin"],
        "http://kiosk.local:3000"
    );
    let refused = preflight("http://evil.example").await;
    assert!(!refused.headers.contains_key("access-control-allow-origin"));
}

#[tokio::test]
async fn the_app_is_served_and_unknown_paths_fall_back_to_index() {
    let bridge = Bridge::start().await;
    for path in ["/", "/control"] {
        let reply = bridge.request(Method::GET, path, None, None).await;
        assert_eq!(reply.status, StatusCode::OK, "{path}");
        assert!(String::from_utf8_lossy(&reply.body).contains("<title>t</title>"));
    }
}

#[tokio::test]
async fn the_installation_gives_its_calibration_and_stations() {
    let config = "[matrix]\nrows = 2\ncols = 2\ncounts_per_mm = 500\n\n[[gateway]]\nport = \"sim\"\nbaud = 115200\n";
    let bridge = Bridge::start_with(config).await;
    let path = "/api/installation";
    let token = bridge.token().await;
    let reply = bridge.request(Method::GET, path, Some(&token), None).await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let info: InstallationInfo = reply.json();
    assert_eq!(info.counts_per_mm, 500.0);
    assert_eq!(
        info.gateways,
        vec![InstallationGateway {
            kind: GatewayKind::Uim2503,
            port: "sim".into(),
            baud: Some(115_200),
            stations: vec![1, 2, 3, 4],
        }]
    );
    assert_eq!((info.rows, info.cols, info.unit_count()), (2, 2, 4));
}
