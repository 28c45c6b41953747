//! Files that behave, end to end in the real app against the real bridge: the
//! selected local file is highlighted; a `.bin` is refused by name with what is
//! supported, and Upload then has nothing to act on; a show with many violations
//! lists 20 with "show all"; a binary file renamed `.csv` does not widen the page;
//! a deleted file and a password changed from Settings are confirmed with a toast;
//! after too many wrong passwords the login's wait counts down.

use std::path::Path;
use std::time::Duration;

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT};
use serde_json::Value;

/// Shows the app in English whatever language it starts in (the switch names the
/// other language).
async fn in_english(browser: &Browser) {
    browser.wait_for("[data-testid=lang]").await;
    if browser.text("[data-testid=lang]").await == "English" {
        browser.click("[data-testid=lang]").await;
    }
    browser.wait_for_text("[data-testid=lang]", "中文").await;
}

/// Runs `script` in the page and returns its value.
async fn eval(browser: &Browser, script: &str) -> Value {
    browser
        .client
        .execute(script, Vec::new())
        .await
        .unwrap_or_else(|err| panic!("{script}: {err}"))
}

/// Adds the file at `path` from the device.
async fn add(browser: &Browser, path: &Path) {
    browser.pick_file("[data-testid=file-picker]", path).await;
}

/// Logs out from the Login page (opened with the connection button).
async fn log_out(browser: &Browser) {
    browser.click("[data-testid=connection]").await;
    browser.click("[data-testid=logout]").await;
    browser.wait_for("[data-testid=login-form]").await;
}

/// The page is no wider than the screen.
async fn no_horizontal_overflow(browser: &Browser, when: &str) {
    let widths = eval(
        browser,
        "return [document.documentElement.scrollWidth, window.innerWidth];",
    )
    .await;
    let (page, screen) = (widths[0].as_u64(), widths[1].as_u64());
    assert!(
        page <= screen,
        "{when}: the page is {page:?} px wide on a {screen:?} px screen"
    );
}

/// 100 balls that all jump 300 mm in 50 ms: far over the speed limit, so the bridge
/// lists a problem for every ball.
fn too_fast_csv() -> String {
    let units: Vec<String> = (0..100).map(|unit| format!("u{unit}")).collect();
    let row = |mm: u32| vec![mm.to_string(); 100].join(",");
    format!(
        "# rows=10 cols=10 pitch_mm=500\ntime_ms,{}\n0,{}\n50,{}\n2000,{}\n",
        units.join(","),
        row(1000),
        row(1300),
        row(1300)
    )
}

/// Bytes that are no text: one long token without a line break, comma or space.
fn noise() -> Vec<u8> {
    (0..6_000u32)
        .map(|i| (i.wrapping_mul(151) % 256) as u8)
        .filter(|byte| !matches!(byte, b'\n' | b'\r' | b',' | b' ' | b'#'))
        .collect()
}

#[tokio::test]
async fn files_are_highlighted_refused_cut_short_and_wrapped() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    in_english(&browser).await;
    browser.first_login("night-show-7").await;

    let folder = tempfile::tempdir().expect("temp dir");
    let write = |name: &str, bytes: &[u8]| {
        let path = folder.path().join(name);
        std::fs::write(&path, bytes).expect("write a file");
        path
    };

    // Two show files: the one added last is selected, and it looks it.
    add(
        &browser,
        &write("a.csv", floatball_e2e::wave_csv().as_bytes()),
    )
    .await;
    add(
        &browser,
        &write("b.csv", floatball_e2e::wave_csv().as_bytes()),
    )
    .await;
    browser
        .wait_for_attribute(
            "[data-testid=local-file][data-name='b.csv']",
            "aria-pressed",
            "true",
            UI_TIMEOUT,
        )
        .await;
    let backgrounds = eval(
        &browser,
        "const rows = [...document.querySelectorAll('[data-testid=local-file]')];
         return rows.map((row) => [row.dataset.name, getComputedStyle(row).backgroundColor]);",
    )
    .await;
    let background = |name: &str| {
        backgrounds
            .as_array()
            .and_then(|rows| rows.iter().find(|row| row[0] == name))
            .map(|row| row[1].to_string())
            .unwrap_or_else(|| panic!("no row {name}: {backgrounds}"))
    };
    assert_ne!(background("a.csv"), background("b.csv"), "{backgrounds}");

    // A .bin is refused by name, with what is supported; nothing stays selected, so
    // Upload cannot send the file picked before.
    add(&browser, &write("junk.bin", b"\x00\x01binary")).await;
    browser
        .wait_for_text("[data-testid=files-message]", "junk.bin")
        .await;
    let message = browser.text("[data-testid=files-message]").await;
    assert!(message.contains(".csv, .json"), "{message}");
    assert!(!message.contains("storage"), "{message}");
    let selected = eval(
        &browser,
        "return document.querySelectorAll('[data-testid=local-file][aria-pressed=true]').length;",
    )
    .await;
    assert_eq!(selected, 0);
    let upload = browser.wait_for("[data-testid=upload]").await;
    assert!(!upload.is_enabled().await.expect("enabled?"));

    // A show over the limits for every ball: the first 20 problems, the count, and
    // "show all".
    add(&browser, &write("fast.csv", too_fast_csv().as_bytes())).await;
    browser
        .wait_for_attribute(
            "[data-testid=local-file][data-name='fast.csv']",
            "aria-pressed",
            "true",
            UI_TIMEOUT,
        )
        .await;
    browser.click("[data-testid=upload]").await;
    browser.wait_for("[data-testid=upload-details]").await;
    let details = browser.wait_for("[data-testid=upload-details]").await;
    let total: usize = details
        .attr("data-total")
        .await
        .expect("data-total")
        .and_then(|total| total.parse().ok())
        .expect("a count");
    assert!(total > 20, "{total} problems");
    const LISTED: &str =
        "return document.querySelectorAll('[data-testid=upload-details] li').length;";
    assert_eq!(eval(&browser, LISTED).await, 20);
    let more = browser.text("[data-testid=problems-more]").await;
    assert!(more.contains(&format!("{total} in all")), "{more}");
    browser.click("[data-testid=problems-toggle]").await;
    assert_eq!(eval(&browser, LISTED).await, total);
    no_horizontal_overflow(&browser, "every problem shown").await;

    // A binary file renamed .csv: its error wraps within the screen, on Files and in
    // the preview.
    add(&browser, &write("noise.csv", &noise())).await;
    browser
        .wait_for_attribute(
            "[data-testid=local-file][data-name='noise.csv']",
            "aria-pressed",
            "true",
            UI_TIMEOUT,
        )
        .await;
    // Choosing the tab clears the message, so the one that comes is the upload's.
    browser.click("[data-testid=tab-local]").await;
    browser.click("[data-testid=upload]").await;
    browser
        .wait_for_attribute(
            "[data-testid=files-message]",
            "class",
            "note error",
            UI_TIMEOUT,
        )
        .await;
    no_horizontal_overflow(&browser, "the binary file's refusal").await;
    browser.click("[data-testid=preview-local]").await;
    browser.wait_for("[data-testid=preview-error]").await;
    no_horizontal_overflow(&browser, "the binary file's preview").await;

    // Delete is confirmed with a toast.
    browser.click("[data-testid=nav-files]").await;
    browser
        .click("[data-testid=local-file][data-name='a.csv']")
        .await;
    browser.click("[data-testid=delete-local]").await;
    browser.click("[data-testid=delete-local]").await;
    browser
        .wait_for_text("[data-testid=toast]", "Deleted: a.csv")
        .await;

    browser.client.close().await.expect("close the browser");
}

#[tokio::test]
async fn the_password_changes_from_settings_and_the_login_wait_counts_down() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    in_english(&browser).await;
    browser.first_login("night-show-7").await;

    // Settings: old, new, repeat; a toast confirms it.
    browser.click("[data-testid=nav-control]").await;
    browser.click("[data-testid=subtab-settings]").await;
    browser
        .wait_for("[data-testid=settings-password-form]")
        .await;
    browser
        .type_into("[data-testid=password-current]", "night-show-7")
        .await;
    browser
        .type_into("[data-testid=password-new]", "dawn-show-8")
        .await;
    browser
        .type_into("[data-testid=password-confirm]", "dawn-show-8")
        .await;
    browser.click("[data-testid=password-submit]").await;
    browser
        .wait_for_text("[data-testid=toast]", "The password was changed")
        .await;
    browser.wait_for("[data-testid=password-done]").await;

    // The new password is the one that logs in.
    log_out(&browser).await;
    browser.log_in("dawn-show-8").await;
    browser.wait_for("[data-testid=page-files]").await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
        .await;

    // Five wrong passwords, then the bridge makes this address wait, and the login
    // counts the wait down.
    log_out(&browser).await;
    for _ in 0..5 {
        let status = browser
            .client
            .execute_async(
                "const [done] = arguments;
                 fetch('/api/login', { method: 'POST', headers: { 'Content-Type': 'application/json' },
                                       body: JSON.stringify({ password: 'wrong' }) })
                     .then((reply) => done(reply.status), (error) => done(String(error)));",
                Vec::new(),
            )
            .await
            .expect("a wrong login");
        assert_eq!(status, 401);
    }
    browser
        .type_into("[data-testid=login-password]", "dawn-show-8")
        .await;
    browser.click("[data-testid=login-submit]").await;
    browser
        .wait_for_text("[data-testid=login-error]", "try again in")
        .await;
    browser.wait_for("[data-testid=login-wait-note]").await;
    let seconds = |text: String| -> u64 {
        text.rsplit("in ")
            .next()
            .and_then(|rest| rest.trim_end_matches(" s").parse().ok())
            .unwrap_or_else(|| panic!("no wait in {text:?}"))
    };
    let first = seconds(browser.text("[data-testid=login-error]").await);
    assert!((1..=60).contains(&first), "{first} s");
    tokio::time::sleep(Duration::from_millis(2_200)).await;
    let later = seconds(browser.text("[data-testid=login-error]").await);
    assert!(
        later < first,
        "the wait counts down: {first} s, then {later} s"
    );
    let submit = browser.wait_for("[data-testid=login-submit]").await;
    assert!(
        !submit.is_enabled().await.expect("enabled?"),
        "no tries while waiting"
    );

    browser.client.close().await.expect("close the browser");
}
