//! `GET /api/qprogram/{show}?unit=N` over real sockets: a CSV show uploaded, one ball's
//! Q program as JSON and as a download, and the 400/404/422 answers.

use crate::common;

use axum::http::{Method, StatusCode, header};
use common::Bridge;
use floatball_shared::api::QProgramListing;
use floatball_shared::scl::{Command, parse_script};

/// A CSV show for the default 10 × 10 installation: every ball at `depth_mm(step)`
/// at `step × step_ms`.
fn csv_show(steps: usize, step_ms: usize, depth_mm: impl Fn(usize) -> u32) -> String {
    let mut text = String::from("time_ms");
    for unit in 0..100 {
        text.push_str(&format!(",u{unit}"));
    }
    text.push('\n');
    for step in 0..steps {
        text.push_str(&(step * step_ms).to_string());
        for _ in 0..100 {
            text.push_str(&format!(",{}", depth_mm(step)));
        }
        text.push('\n');
    }
    text
}

#[tokio::test]
async fn a_ball_s_program_is_listed_downloaded_or_refused() {
    let bridge = Bridge::start().await;
    let token = bridge.operator().await;
    // Down 20 mm, stay, back up.
    let dip = csv_show(6, 200, |step| if step == 0 || step == 5 { 0 } else { 20 });
    let reply = bridge
        .upload(&token, "dip", "text/csv", dip.as_bytes())
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "{:?}", reply.body);

    // A smooth wave, ±400 mm every 8 s for 40 s (issue 34, item 2): jogged, within
    // the default tolerance of 5 mm.
    let wave = csv_show(201, 200, |step| {
        let t_s = step as f64 * 0.2;
        (400.0 - 400.0 * (std::f64::consts::TAU * t_s / 8.0).cos()).round() as u32
    });
    let reply = bridge
        .upload(&token, "wave", "text/csv", wave.as_bytes())
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "{:?}", reply.body);
    let reply = bridge
        .request(Method::GET, "/api/qprogram/wave?unit=0", Some(&token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let listing: QProgramListing = reply.json();
    assert!(listing.max_deviation_mm <= 5.0, "{listing:?}");
    assert!(listing.text.contains("\nCJ\n"), "{}", listing.text);

    let reply = bridge
        .request(Method::GET, "/api/qprogram/dip?unit=7", Some(&token), None)
        .await;
    assert_eq!(reply.status, StatusCode::OK, "{:?}", reply.body);
    let listing: QProgramListing = reply.json();
    assert_eq!((listing.unit, listing.show.as_str()), (7, "dip"));
    assert_eq!(listing.segments, 1);
    assert_eq!(listing.moves, 2);
    assert!(listing.max_deviation_mm < 10.0, "{listing:?}");
    let commands: Vec<&str> = listing
        .text
        .lines()
        .filter(|l| !l.starts_with('['))
        .collect();
    assert_eq!(commands.len(), listing.lines);
    let parsed = parse_script(&commands.join("\r")).unwrap();
    assert_eq!(parsed[0].command.to_string(), "WI3F");
    assert!(parsed.iter().any(|r| r.command == Command::FeedToPosition));
    assert_eq!(parsed.last().unwrap().command.to_string(), "FP");

    let reply = bridge
        .request(
            Method::GET,
            "/api/qprogram/dip?unit=7&format=text",
            Some(&token),
            None,
        )
        .await;
    assert_eq!(reply.status, StatusCode::OK);
    assert_eq!(
        reply.headers[header::CONTENT_TYPE],
        "text/plain; charset=utf-8"
    );
    assert_eq!(
        reply.headers[header::CONTENT_DISPOSITION],
        "attachment; filename=\"dip-unit7.q\""
    );
    assert_eq!(String::from_utf8_lossy(&reply.body), listing.text);

    for (path, status) in [
        ("/api/qprogram/dip?unit=100", StatusCode::NOT_FOUND),
        ("/api/qprogram/nothing?unit=0", StatusCode::NOT_FOUND),
        ("/api/qprogram/dip", StatusCode::BAD_REQUEST),
        ("/api/qprogram/dip?unit=one", StatusCode::BAD_REQUEST),
    ] {
        let reply = bridge.request(Method::GET, path, Some(&token), None).await;
        assert_eq!(reply.status, status, "{path}: {:?}", reply.body);
        assert!(!reply.error().error.is_empty());
    }
    let reply = bridge
        .request(Method::GET, "/api/qprogram/dip?unit=0", None, None)
        .await;
    assert_eq!(reply.status, StatusCode::UNAUTHORIZED);

    // 1000 turns of 30 mm, 400 ms apart: more moves than a drive holds, and what fits
    // strays more than the 5 mm tolerance.
    let zigzag = csv_show(1000, 400, |step| if step % 2 == 0 { 0 } else { 30 });
    let reply = bridge
        .upload(&token, "zigzag", "text/csv", zigzag.as_bytes())
        .await;
    assert_eq!(reply.status, StatusCode::CREATED, "{:?}", reply.body);
    let reply = bridge
        .request(
            Method::GET,
            "/api/qprogram/zigzag?unit=3",
            Some(&token),
            None,
        )
        .await;
    assert_eq!(reply.status, StatusCode::UNPROCESSABLE_ENTITY);
    let body = reply.error();
    let error = &body.error;
    assert!(
        error.contains("mm off the show at") && error.contains("tolerance of 5 mm"),
        "{error}"
    );
    // The reason as a code too, for the app to say in the operator's language.
    assert_eq!(body.code, "qprogram_refused");
    assert_eq!(body.problems.len(), 1, "{body:?}");
    assert_eq!(body.problems[0].code, "qprogram_too_far");
    assert_eq!(body.problems[0].params["unit"], "u3");
    assert_eq!(body.problems[0].params["tolerance_mm"], "5");
    assert!(
        body.details[0].starts_with("ball u3: the program would be"),
        "{body:?}"
    );
}
