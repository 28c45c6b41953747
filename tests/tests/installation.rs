//! The installation in the app, end to end against the real bridge (issue 17's third
//! test and item 5):
//!
//! - the preview checks a show against the installation's limits once connected: a
//!   wave within the default limits but beyond the bridge's tighter `max_speed_mm_s`
//!   (a `floatball.toml` of 100 mm/s) is drawn with red balls and listed against
//!   the installation's limits, where offline it was within the defaults;
//! - the Installation page (from Settings) lists every problem of a bad change at
//!   once, and a valid change is saved, shown in the fields and served by
//!   `GET /api/installation`.

use std::time::Duration;

use floatball_e2e::{Bridge, Browser, UI_TIMEOUT, wave_csv};
use serde_json::Value;

/// The default matrix with a top speed far below the wave's (about 240 mm/s), and an
/// approach within it.
const SLOW_MATRIX: &str = "[matrix]\nrows = 10\ncols = 10\nmax_speed_mm_s = 100.0\n\
                           [safety]\napproach_speed_mm_s = 50.0\n";

/// How many pixels of the 2D preview are the red of a ball beyond a limit.
async fn red_pixels(browser: &Browser) -> u64 {
    let script = r#"
        const canvas = document.querySelector('[data-testid=preview-canvas][data-renderer="2d"]');
        const data = canvas.getContext('2d').getImageData(0, 0, canvas.width, canvas.height).data;
        let red = 0;
        for (let i = 0; i < data.length; i += 4) {
            const [r, g, b] = [data[i], data[i + 1], data[i + 2]];
            if (r > 120 && g < r / 2 && b < r / 2) red += 1;
        }
        return red;
    "#;
    let value = browser
        .client
        .execute(script, Vec::new())
        .await
        .unwrap_or_else(|err| panic!("count red pixels: {err}"));
    value.as_u64().unwrap_or_else(|| panic!("{value}"))
}

/// Waits until `check` holds for the count of red pixels (frames are drawn on the
/// next animation frame).
async fn wait_for_red(browser: &Browser, check: impl Fn(u64) -> bool, what: &str) -> u64 {
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    loop {
        let red = red_pixels(browser).await;
        if check(red) {
            return red;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "{what}: {red} red pixels"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

#[tokio::test]
async fn the_preview_checks_against_the_installations_tighter_speed() {
    let bridge = Bridge::start_with_config(SLOW_MATRIX).await;
    let browser = Browser::open(&bridge).await;

    // Offline: the wave is within the default limits, no ball is red.
    let folder = tempfile::tempdir().expect("temp dir");
    let path = folder.path().join("wave.csv");
    std::fs::write(&path, wave_csv()).expect("write the CSV");
    browser.pick_file("[data-testid=file-picker]", &path).await;
    browser
        .wait_for("[data-testid=local-file][data-name='wave.csv']")
        .await;
    browser.click("[data-testid=preview-local]").await;
    browser.wait_for("[data-testid=preview-valid]").await;
    browser.click("[data-testid=preview-mode-top]").await;
    browser
        .wait_for("[data-testid=preview-canvas][data-renderer='2d']")
        .await;
    wait_for_red(&browser, |red| red == 0, "offline, within the defaults").await;

    // Connected: the installation's 100 mm/s applies; the balls turn red.
    browser.first_login("night-show-7").await;
    let info = browser.get_json("/api/installation").await;
    assert_eq!(info["max_speed_mm_s"], 100.0, "{info}");
    // The Preview page opens anew (in 3D where WebGL2 draws): the 2D view again.
    browser.click("[data-testid=nav-preview]").await;
    browser.click("[data-testid=preview-mode-top]").await;
    browser
        .wait_for("[data-testid=preview-canvas][data-renderer='2d']")
        .await;
    browser
        .wait_for_attribute(
            "[data-testid=preview-problems]",
            "data-limits",
            "installation",
            UI_TIMEOUT,
        )
        .await;
    let problems = browser.text("[data-testid=preview-problems]").await;
    assert!(problems.contains("超出本装置的限制"), "{problems}");
    assert!(problems.contains("100.0"), "the limit is named: {problems}");
    let red = wait_for_red(&browser, |red| red > 100, "connected, beyond 100 mm/s").await;
    assert!(red > 100, "{red}");

    browser.client.close().await.expect("close the browser");
}

/// The value of the installation page's field `key`.
async fn field(browser: &Browser, key: &str) -> String {
    browser
        .wait_for(&format!("[data-testid={key}]"))
        .await
        .prop("value")
        .await
        .expect("the field's value")
        .unwrap_or_default()
}

#[tokio::test]
async fn the_installation_page_lists_every_problem_and_saves_a_valid_change() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    browser.first_login("night-show-7").await;

    browser.click("[data-testid=nav-control]").await;
    browser.click("[data-testid=subtab-settings]").await;
    browser.click("[data-testid=open-installation]").await;
    browser.wait_for("[data-testid=page-installation]").await;
    browser.wait_for("[data-testid=installation-form]").await;
    assert_eq!(field(&browser, "rows").await, "10");
    assert_eq!(field(&browser, "max_speed_mm_s").await, "2000");
    assert_eq!(field(&browser, "gateway-port").await, "sim");
    let summary = browser.text("[data-testid=gateway-summary]").await;
    assert!(summary.contains("1-100"), "{summary}");

    // A word where a number goes is caught before anything is sent.
    browser.type_into("[data-testid=pitch_mm]", "wide").await;
    browser.click("[data-testid=installation-save]").await;
    browser
        .wait_for_attribute(
            "[data-testid=installation-problems]",
            "data-total",
            "1",
            UI_TIMEOUT,
        )
        .await;

    // Three bad values: the bridge lists them all at once.
    browser.type_into("[data-testid=pitch_mm]", "-1").await;
    browser.type_into("[data-testid=travel_mm]", "0").await;
    browser
        .type_into("[data-testid=max_speed_mm_s]", "-5")
        .await;
    browser.click("[data-testid=installation-save]").await;
    browser.wait_for("[data-testid=installation-error]").await;
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    let total = loop {
        let total = browser
            .wait_for("[data-testid=installation-problems]")
            .await
            .attr("data-total")
            .await
            .expect("data-total")
            .and_then(|total| total.parse::<usize>().ok())
            .unwrap_or_default();
        if total >= 3 || tokio::time::Instant::now() > deadline {
            break total;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    assert!(
        total >= 3,
        "every problem is listed, not the first: {total}"
    );
    let listed = browser.text("[data-testid=installation-problems]").await;
    for key in ["pitch_mm", "travel_mm", "max_speed_mm_s"] {
        assert!(listed.contains(key), "{key} in {listed}");
    }
    let info = browser.get_json("/api/installation").await;
    assert_eq!(info["max_speed_mm_s"], 2000.0, "nothing saved: {info}");

    // A valid change is saved and shown.
    browser.type_into("[data-testid=pitch_mm]", "600").await;
    browser.type_into("[data-testid=travel_mm]", "7000").await;
    browser
        .type_into("[data-testid=max_speed_mm_s]", "1500")
        .await;
    browser.click("[data-testid=installation-save]").await;
    browser.wait_for("[data-testid=installation-saved]").await;
    assert_eq!(field(&browser, "max_speed_mm_s").await, "1500");
    assert_eq!(field(&browser, "pitch_mm").await, "600");
    let info: Value = browser.get_json("/api/installation").await;
    assert_eq!(info["max_speed_mm_s"], 1500.0, "{info}");
    assert_eq!(info["pitch_mm"], 600.0, "{info}");
    assert_eq!(info["travel_mm"], 7000.0, "{info}");

    browser.client.close().await.expect("close the browser");
}
