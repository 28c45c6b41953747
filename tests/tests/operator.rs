//! The operator's evening, end to end: log in with the factory password, change it,
//! add a CSV from the device, upload it, see it among the controller's files, put it
//! in the playlist, talk to a unit from the console, press Start and see it play,
//! press E-stop and see it stop — in the real app against the real bridge and its
//! simulated gateway.

use std::fmt::Write as _;
use std::time::Duration;

use floatball_e2e::{Bridge, Browser, UI_TIMEOUT};

const INDICATOR: &str = "[data-testid=connection]";

/// How long homing, the approach and the preload may take before the show plays.
const PLAY_TIMEOUT: Duration = Duration::from_secs(90);

/// A gentle wave over the default 10 × 10 installation: every ball swings ±300 mm
/// around 1 m, fading in and out over 2 s so it starts and ends at rest.
fn wave_csv() -> String {
    let mut csv = String::from("# rows=10 cols=10 pitch_mm=500\ntime_ms");
    for unit in 0..100 {
        write!(csv, ",u{unit}").expect("write to a string");
    }
    csv.push('\n');
    for step in 0..=32 {
        let t_ms = f64::from(step) * 250.0;
        let ramp = (t_ms / 2000.0)
            .min((8000.0 - t_ms) / 2000.0)
            .clamp(0.0, 1.0);
        let ramp = ramp * ramp * (3.0 - 2.0 * ramp);
        write!(csv, "{t_ms}").expect("write to a string");
        for unit in 0..100 {
            let phase = f64::from(unit % 10) * 0.5 + f64::from(unit / 10) * 0.3;
            let angle = std::f64::consts::TAU * t_ms / 8000.0 + phase;
            write!(csv, ",{:.0}", 1000.0 + 300.0 * ramp * angle.sin()).expect("write to a string");
        }
        csv.push('\n');
    }
    csv
}

#[tokio::test]
async fn operator_logs_in_uploads_plays_and_stops() {
    let bridge = Bridge::start().await;
    let browser = Browser::start(360, 740).await;
    browser
        .client
        .goto(&bridge.url())
        .await
        .expect("open the app");

    // Log in with the factory password; the app insists on a new one.
    browser.log_in("1234").await;
    browser.wait_for("[data-testid=password-form]").await;
    browser
        .type_into("[data-testid=password-new]", "night-show-7")
        .await;
    browser
        .type_into("[data-testid=password-confirm]", "night-show-7")
        .await;
    browser.click("[data-testid=password-submit]").await;
    browser.wait_for("[data-testid=page-files]").await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
        .await;

    // Add a CSV from the device and upload it.
    let folder = tempfile::tempdir().expect("temp dir");
    let path = folder.path().join("wave.csv");
    std::fs::write(&path, wave_csv()).expect("write the CSV");
    browser.pick_file("[data-testid=file-picker]", &path).await;
    browser
        .wait_for("[data-testid=local-file][data-name='wave.csv']")
        .await;
    browser.click("[data-testid=upload]").await;
    browser
        .wait_for_text("[data-testid=files-message]", "已上传: wave")
        .await;
    browser.click("[data-testid=tab-controller]").await;
    let row = browser
        .wait_for("[data-testid=controller-file][data-name=wave]")
        .await;
    let row = row.text().await.expect("row text");
    assert!(row.contains("100") && row.contains("0:08.0"), "{row}");

    // Put it in the playlist; it is stored on the bridge, so a reload shows it again
    // (and the login survives the reload).
    browser.click("[data-testid=nav-control]").await;
    browser.click("[data-testid=add]").await;
    browser
        .click("[data-testid=pick-show][data-name=wave]")
        .await;
    browser
        .wait_for("[data-testid=entry][data-show=wave]")
        .await;
    browser.client.refresh().await.expect("reload");
    browser
        .wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
        .await;
    browser
        .wait_for("[data-testid=entry][data-show=wave]")
        .await;
    browser
        .wait_for_attribute(
            "[data-testid=status-state]",
            "data-state",
            "idle",
            UI_TIMEOUT,
        )
        .await;

    // The console: a checked line goes to the simulated gateway, and its answer comes
    // back decoded.
    browser.click("[data-testid=nav-console]").await;
    browser
        .type_into("[data-testid=console-input]", "*5;PV;")
        .await;
    browser
        .wait_for_attribute(
            "[data-testid=console-check]",
            "data-state",
            "ok",
            UI_TIMEOUT,
        )
        .await;
    browser.click("[data-testid=console-send]").await;
    browser
        .wait_for_text("[data-testid=feedback-line]", "PV = ")
        .await;

    // The bandwidth report says the show can run; Start plays it.
    browser.click("[data-testid=nav-control]").await;
    browser
        .wait_for_attribute(
            "[data-testid=verdict]",
            "data-verdict",
            "feasible",
            UI_TIMEOUT,
        )
        .await;
    browser.click("[data-testid=start]").await;
    browser
        .wait_for_attribute(
            "[data-testid=status-state]",
            "data-state",
            "playing",
            PLAY_TIMEOUT,
        )
        .await;
    assert_eq!(browser.text("[data-testid=status-show]").await, "wave");

    // E-stop from the top bar: one press, acknowledged on the button, and the
    // bridge reports the matrix stopped.
    browser.click(".topbar [data-testid=estop]").await;
    browser
        .wait_for_attribute(
            "[data-testid=status-state]",
            "data-state",
            "stopped",
            UI_TIMEOUT,
        )
        .await;
    browser
        .wait_for_attribute(
            ".topbar [data-testid=estop]",
            "data-ack",
            "stopped",
            UI_TIMEOUT,
        )
        .await;

    browser.client.close().await.expect("close the browser");
}
