//! The operator's evening on an installation of MOONS' drives, end to end: four
//! gateway entries of 25 simulated drives each (`kind = "scl"`, `port = "sim"`: drive
//! twins on loopback eSCL in the bridge, all on one start wire) make the 10 × 10
//! matrix. Log in, upload a CSV, put it in the playlist, press Start and see it play
//! — by Q programs stored on every drive and started together by the common start —
//! press E-stop and see it stop. What the drives did is read through
//! `GET /api/sim/positions`.

use floatball_e2e::{Bridge, Browser};

/// Four entries of 25 simulated drives (an RS-485 line takes at most 27), the
/// trigger on the first drive's output 2, wired to input 3 of every drive.
///
/// `tolerance_mm = 50`: the test wave swings ±300 mm through keyframes 250 ms apart,
/// and the compiler's rest-to-rest trapezoids (one a keyframe; the wave's 32 moves fit
/// in the 12 × 62 lines unreduced) leave the show's path between keyframes by up to
/// 39.7 mm (ball 37 at 6189 ms, `GET /api/qprogram/wave?unit=37`), more than the
/// default 10 mm; 50 mm takes every ball with some margin.
fn config() -> String {
    let mut config = String::from(
        "[matrix]\nrows = 10\ncols = 10\n[scl]\ntrigger = \"0:2\"\ntolerance_mm = 50.0\n",
    );
    for _ in 0..4 {
        config.push_str("[[gateway]]\nkind = \"scl\"\nport = \"sim\"\nunits = 25\n");
    }
    config
}

/// Every simulated drive, as `GET /api/sim/positions` reports them.
async fn drives(browser: &Browser) -> Vec<serde_json::Value> {
    let positions = browser.get_json("/api/sim/positions").await;
    let drives = positions["drives"]
        .as_array()
        .unwrap_or_else(|| panic!("{positions}"))
        .clone();
    assert_eq!(drives.len(), 100, "{positions}");
    drives
}

#[tokio::test]
async fn operator_plays_and_stops_a_hundred_moons_drives() {
    let bridge = Bridge::start_with_config(&config()).await;
    let browser = Browser::open(&bridge).await;

    browser.first_login("night-show-7").await;
    browser.upload_wave().await;
    browser.queue_show("wave").await;
    browser.play("wave").await;

    // Playing: every drive runs its program (stored, or one segment from its queue),
    // none is left waiting for the start input — the one edge on the wire started
    // them all.
    for drive in drives(&browser).await {
        let stored = drive["segments_stored"].as_u64().unwrap_or(0);
        let queued = drive["queue_lines"].as_u64().unwrap_or(0);
        assert!(stored >= 1 || queued >= 1, "{drive}");
        assert_eq!(drive["executing"], true, "{drive}");
        assert_eq!(drive["waiting_input"], false, "{drive}");
        assert_eq!(drive["alarm_code"], 0, "{drive}");
    }

    browser.estop().await;

    // Stopped: no program runs any more; `SK` erased every queue (HCR p. 249).
    for drive in drives(&browser).await {
        assert_eq!(drive["executing"], false, "{drive}");
        assert_eq!(drive["queue_lines"], 0, "{drive}");
    }

    browser.client.close().await.expect("close the browser");
}
