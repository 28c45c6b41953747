//! The operator's evening on an installation of MBOX boxes, end to end: ten simulated
//! 10-axis boxes (`port = "sim"`, twins on loopback UDP in the bridge) make the
//! 10 × 10 matrix. Log in, upload a CSV, put it in the playlist, press Start and see
//! it play, press E-stop and see it stop — and every box got the e-stop (its FN
//! `0x0090` register is 1, read through `GET /api/sim/positions`).

use floatball_e2e::{Bridge, Browser};

/// Ten simulated 10-axis boxes, one row of the matrix each.
fn config() -> String {
    let mut config = String::from("[matrix]\nrows = 10\ncols = 10\n[mbox]\nhost_port = 0\n");
    for _ in 0..10 {
        config.push_str("[[gateway]]\nkind = \"mbox\"\nport = \"sim\"\naxes = 10\n");
    }
    config
}

#[tokio::test]
async fn operator_plays_and_stops_ten_mbox_boxes() {
    let bridge = Bridge::start_with_config(&config()).await;
    let browser = Browser::open(&bridge).await;

    browser.first_login("night-show-7").await;
    browser.upload_wave().await;
    browser.queue_show("wave").await;
    browser.play_then_estop("wave").await;

    // Every box holds the e-stop, after it got the show's frames.
    let positions = browser.get_json("/api/sim/positions").await;
    let boxes = positions["boxes"]
        .as_array()
        .unwrap_or_else(|| panic!("{positions}"));
    assert_eq!(boxes.len(), 10, "{positions}");
    for (index, one) in boxes.iter().enumerate() {
        assert_eq!(one["estop"], true, "box {index}: {one}");
        assert!(
            one["counters"]["motion_frames"].as_u64() > Some(0),
            "box {index}: {one}"
        );
    }

    browser.client.close().await.expect("close the browser");
}
