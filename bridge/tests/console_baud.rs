//! A console `BDR=x;` on a UIM2503 installation, through the real `floatball` binary
//! and a tapped pseudo-terminal gateway: refused with `console_line_speed` (the line
//! speed changes only through the guided change that keeps the link in step), nothing
//! of it reaches the line, and the link keeps working.

mod common;

use std::time::{Duration, Instant};

use common::process::{Process, Tap, links_up};
use common::{next_reply, send_text};
use floatball_shared::api::ServerMessage;
use floatball_shared::sim::GatewayConfig;

#[tokio::test]
async fn a_console_bdr_is_refused_and_the_link_keeps_working() {
    let dir = tempfile::tempdir().expect("temp dir");
    let tap = Tap::new(dir.path(), "gateway0", 9600, GatewayConfig::numbered(4));
    let bridge = Process::start(&format!(
        "[matrix]\nrows = 2\ncols = 2\n[[gateway]]\nport = \"{}\"\nbaud = 9600\n",
        tap.path.display()
    ));
    let token = bridge.operator().await;
    let mut ws = bridge.ws(&token).await;
    send_text(&mut ws, r#"{"type":"feedback","relay":false}"#).await;
    assert!(links_up(&mut ws).await, "the link comes up");

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
