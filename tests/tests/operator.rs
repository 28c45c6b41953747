//! The operator's evening, end to end: log in with the factory password, change it,
//! add a CSV from the device, upload it, see it among the controller's files, put it
//! in the playlist, talk to a unit from the console, press Start and see it play,
//! press E-stop and see it stop — in the real app against the real bridge and its
//! simulated gateway.

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT};

#[tokio::test]
async fn operator_logs_in_uploads_plays_and_stops() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;

    // Log in with the factory password; the app insists on a new one.
    browser.first_login("night-show-7").await;

    // Add a CSV from the device and upload it.
    browser.upload_wave().await;

    // Put it in the playlist; it is stored on the bridge, so a reload shows it again
    // (and the login survives the reload).
    browser.queue_show("wave").await;
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

    // The bandwidth report says the show can run; Start plays it; E-stop from the
    // top bar: one press, acknowledged on the button, and the bridge reports the
    // matrix stopped.
    browser.play_then_estop("wave").await;

    browser.client.close().await.expect("close the browser");
}
