//! The thin slice end to end: the real bridge serves the built app, Chromium loads it,
//! the operator logs in, the app connects over the WebSocket with its token, and it
//! notices the bridge going away and coming back without a reload. Sessions survive
//! the bridge's restart, so the app reconnects by itself; a session that has ended
//! (here: logged out elsewhere) sends the operator back to Login, never leaving a stale
//! "Connected".

use std::time::{Duration, Instant};

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT};

#[tokio::test]
async fn app_shows_connected_and_follows_a_bridge_restart() {
    let mut bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "disconnected", UI_TIMEOUT)
        .await;
    assert_eq!(browser.text(INDICATOR).await, "未连接");

    browser.log_in("1234").await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
        .await;
    assert_eq!(browser.text(INDICATOR).await, "已连接");

    bridge.stop().await;
    let stopped = Instant::now();
    browser
        .wait_for_attribute(
            INDICATOR,
            "data-state",
            "disconnected",
            Duration::from_secs(2),
        )
        .await;
    assert!(stopped.elapsed() <= Duration::from_secs(2));
    assert_eq!(browser.text(INDICATOR).await, "未连接");

    // The restarted bridge still knows the session: back to Connected, no reload and
    // no new login.
    bridge.restart().await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "connected", Duration::from_secs(5))
        .await;
    assert_eq!(browser.text(INDICATOR).await, "已连接");

    browser.client.close().await.expect("close the browser");
}
