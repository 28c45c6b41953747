//! A console `BDR=x;` on a UIM2503 installation, through the real `floatball` binary
//! and a tapped pseudo-terminal gateway: refused with `console_line_speed` (the line
//! speed changes only through the guided change that keeps the link in step), nothing
//! of it reaches the line, and the link keeps working.

use crate::common;

use std::time::{Duration, Instant};

use common::process::tapped_bridge;
use common::{next_reply, send_text};
use floatball_shared::api::ServerMessage;

#[tokio::test]
async fn a_console_bdr_is_refused_and_the_link_keeps_working() {
    let dir = tempfile::tempdir().expect("temp dir");
    let (tap, _bridge, _token, mut ws) = tapped_bridge(dir.path()).await;

    for line in ["BDR=38400;", "*1;PV;\nbdr 57600;"] {
        let message = serde_json::json!({"type": "raw", "line": line, "gateway": 0});
        send_text(&mut ws, &message.to_string()).await;
        let reply = tokio::time::timeout(Duration::from_secs(10), next_reply(&mut ws))
            .await
            .unwrap_or_else(|_| panic!("{line}: no answer within 10 s"));
        match reply {
            ServerMessage::Error { code, params, .. } => {
                assert_eq!(code, "console_line_speed", "{line}");
                assert!(params.contains_key("baud"), "{params:?}");
            }
            other => panic!("{line}: expected a refusal, got {other:?}"),
        }
    }

    // The link still carries the console's lines.
    send_text(&mut ws, r#"{"type":"raw","line":"*3;PV;","gateway":0}"#).await;
    let deadline = Instant::now() + Duration::from_secs(5);
    let contains = |wire: &[u8], text: &[u8]| wire.windows(text.len()).any(|w| w == text);
    while !contains(&tap.wire(), b"*3;PV;") {
        assert!(
            Instant::now() < deadline,
            "the query after the refusal reached the line"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let wire = tap.wire();
    assert!(!contains(&wire, b"BDR"), "no BDR on the line");
    assert!(
        !contains(&wire, b"*1;PV;"),
        "a refused line is refused whole"
    );
}
