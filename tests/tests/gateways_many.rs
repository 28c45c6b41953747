//! Twenty gateways on a phone, end to end: the real bridge with 19 simulated gateways
//! and one whose serial port is not there; the Control page on a 360 px screen shows
//! them as a summary (19 of 20 up, the broken one with its problem) and, on request,
//! every gateway's row from `GET /api/status/gateways` in a box that scrolls, the page
//! no wider than the screen.
//!
//! The checks read `data-*` attributes, not words: the app's language follows the
//! browser's.

use std::time::Duration;

use fantoccini::Locator;
use floatball_e2e::{Bridge, Browser, UI_TIMEOUT};

/// 20 gateways of 3 units, one row each; gateway 7's port is not there.
fn config() -> String {
    let mut text = String::from("[matrix]\nrows = 20\ncols = 3\n");
    for index in 0..20 {
        let port = if index == 7 {
            "/dev/floatball-no-such-port".to_owned()
        } else {
            "sim".to_owned()
        };
        text.push_str(&format!("[[gateway]]\nport = \"{port}\"\nunits = 3\n"));
    }
    text
}

async fn count(browser: &Browser, css: &str) -> usize {
    browser
        .client
        .find_all(Locator::Css(css))
        .await
        .expect("find elements")
        .len()
}

#[tokio::test]
async fn twenty_gateways_show_as_a_summary_and_a_scrolling_list_on_a_phone() {
    let bridge = Bridge::start_with_config(&config()).await;
    let browser = Browser::open(&bridge).await;
    browser.first_login("gateway-count").await;
    browser.click("[data-testid=nav-control]").await;
    browser
        .wait_for_attribute("[data-testid=gateways-up]", "data-up", "19", UI_TIMEOUT)
        .await;
    let up = browser.wait_for("[data-testid=gateways-up]").await;
    assert_eq!(
        up.attr("data-total").await.expect("attr").as_deref(),
        Some("20")
    );
    assert_eq!(
        count(&browser, "[data-testid=gateway]").await,
        0,
        "no line per gateway"
    );
    let problem = browser.wait_for("[data-testid=gateway-problem]").await;
    assert_eq!(
        problem.attr("data-index").await.expect("attr").as_deref(),
        Some("7")
    );
    assert!(
        problem.text().await.expect("text").contains("no-such-port"),
        "the problem names the port"
    );

    browser.click("[data-testid=gateway-list-toggle]").await;
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    while count(&browser, "[data-testid=gateway-row]").await != 20 {
        assert!(
            tokio::time::Instant::now() < deadline,
            "the full list never showed 20 gateways"
        );
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    let sizes = browser
        .client
        .execute(
            "const list = document.querySelector('[data-testid=gateway-list]');
             return [document.documentElement.scrollWidth, window.innerWidth,
                     list.scrollWidth, list.clientWidth, list.clientHeight, list.scrollHeight];",
            Vec::new(),
        )
        .await
        .expect("measure");
    let size = |index: usize| sizes[index].as_f64().expect("a number");
    assert!(
        size(0) <= size(1),
        "the page is {} px on a {} px screen",
        size(0),
        size(1)
    );
    assert!(
        size(2) <= size(3),
        "rows wider than the list: {} > {}",
        size(2),
        size(3)
    );
    assert!(
        size(4) < size(5) && size(4) < 400.0,
        "20 rows scroll inside a box ({} of {} px)",
        size(4),
        size(5)
    );
}
