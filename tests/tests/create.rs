//! Show creation end to end, on a phone-sized browser against the real bridge and
//! its simulated matrix: a newcomer makes a 60 s show of a wave, a word and a ripple
//! with blends between them, sees it change in 3D as a slider moves, keeps it in the
//! local files, uploads it, and plays it on the matrix — without leaving the app.
//! A second test draws every pattern and saves its picture for `docs/create.md`
//! (`<target>/screens/create-<pattern>.png`; the test prints where).

use floatball_e2e::{Bridge, Browser, UI_TIMEOUT, screens_dir};
use serde_json::Value;

/// Sets the form control matching `css` to `value` as a person would leave it: an
/// `input` event, then a `change` event.
async fn set_value(browser: &Browser, css: &str, value: &str) {
    browser.wait_for(css).await;
    let script = r"
        const [css, value] = arguments;
        const element = document.querySelector(css);
        element.value = value;
        element.dispatchEvent(new Event('input', { bubbles: true }));
        element.dispatchEvent(new Event('change', { bubbles: true }));
        return element.value;
    ";
    browser
        .client
        .execute(script, vec![Value::from(css), Value::from(value)])
        .await
        .unwrap_or_else(|err| panic!("set {css} to {value}: {err}"));
}

/// A fingerprint of the 3D preview's picture, once two more frames are drawn.
async fn picture(browser: &Browser) -> String {
    let script = r"
        const done = arguments[arguments.length - 1];
        requestAnimationFrame(() => requestAnimationFrame(() => {
            const canvas = document.querySelector('[data-testid=preview-canvas]');
            const url = canvas.toDataURL('image/png');
            let hash = 0;
            for (let i = 0; i < url.length; i++) hash = (hash * 31 + url.charCodeAt(i)) | 0;
            done(url.length + ':' + hash);
        }));
    ";
    browser
        .client
        .execute_async(script, Vec::new())
        .await
        .expect("read the preview")
        .as_str()
        .unwrap_or_default()
        .to_owned()
}

/// Waits until a generation has finished after `before` (the page's counter).
async fn generated_after(browser: &Browser, before: &str) -> String {
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    loop {
        let element = browser.wait_for("[data-testid=create-generated]").await;
        let count = element
            .attr("data-count")
            .await
            .ok()
            .flatten()
            .unwrap_or_default();
        if count != before {
            return count;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "no new generation after {before}: {}",
            browser.text("[data-testid=create]").await
        );
        tokio::time::sleep(std::time::Duration::from_millis(50)).await;
    }
}

async fn generation(browser: &Browser) -> String {
    browser
        .wait_for("[data-testid=create-generated]")
        .await
        .attr("data-count")
        .await
        .ok()
        .flatten()
        .unwrap_or_default()
}

/// Waits for the planner's verdict on the Create page: the line can carry the show.
async fn line_can_carry_it(browser: &Browser) {
    browser
        .wait_for_attribute(
            "[data-testid=create-verdict]",
            "data-verdict",
            "feasible",
            UI_TIMEOUT,
        )
        .await;
}

/// Pauses the preview so that its picture changes only when the show does.
async fn pause(browser: &Browser) {
    let toggle = browser.wait_for("[data-testid=preview-toggle]").await;
    if toggle.attr("data-playing").await.ok().flatten().as_deref() == Some("true") {
        toggle.click().await.expect("pause");
    }
    browser
        .wait_for_attribute(
            "[data-testid=preview-toggle]",
            "data-playing",
            "false",
            UI_TIMEOUT,
        )
        .await;
}

#[tokio::test]
async fn a_newcomer_makes_a_show_on_the_phone_and_plays_it_on_the_matrix() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    browser.first_login("create-a-show").await;

    browser.click("[data-testid=nav-create]").await;
    browser.wait_for("[data-testid=preview-canvas]").await;
    // Made for the controller's installation (the simulated 10 × 10 matrix).
    browser
        .wait_for("[data-testid=create-for-installation]")
        .await;
    set_value(&browser, "[data-testid=create-name]", "lobby").await;

    // A wave of 15 s blending into the next over 4 s; a slider moves and the
    // picture changes with it.
    let before = generation(&browser).await;
    set_value(&browser, "[data-testid=segment-duration]", "15").await;
    set_value(&browser, "[data-testid=segment-transition]", "4").await;
    let count = generated_after(&browser, &before).await;
    pause(&browser).await;
    let still = picture(&browser).await;
    assert_eq!(picture(&browser).await, still, "a paused picture stays");
    set_value(&browser, "[data-testid=param-amplitude_mm]", "300").await;
    generated_after(&browser, &count).await;
    let moved = picture(&browser).await;
    assert_ne!(moved, still, "the picture follows the slider");
    assert!(
        browser
            .text("[data-testid=param-amplitude_mm-value]")
            .await
            .starts_with("300"),
    );

    // A word: HI, raised, for 15 s, blending over 4 s.
    browser.click("[data-testid=segment-add]").await;
    set_value(&browser, "[data-testid=create-pattern]", "text").await;
    browser.wait_for("[data-testid=param-text]").await;
    set_value(&browser, "[data-testid=param-text]", "HI").await;
    set_value(&browser, "[data-testid=segment-duration]", "15").await;
    set_value(&browser, "[data-testid=segment-transition]", "4").await;

    // A ripple for 20 s; with the blends between them, the start from rest and the
    // end at rest (2 s in all), 60 s.
    browser.click("[data-testid=segment-add]").await;
    set_value(&browser, "[data-testid=create-pattern]", "ripple").await;
    browser.wait_for("[data-testid=param-wavelength_m]").await;
    set_value(&browser, "[data-testid=segment-duration]", "20").await;
    let patterns = browser
        .client
        .execute(
            "return [...document.querySelectorAll('[data-testid=segment]')].map((s) => s.dataset.pattern);",
            Vec::new(),
        )
        .await
        .expect("the timeline");
    assert_eq!(patterns, serde_json::json!(["wave", "text", "ripple"]));
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    while !browser
        .text("[data-testid=preview-facts]")
        .await
        .contains("1:00.0")
    {
        assert!(
            tokio::time::Instant::now() < deadline,
            "not a 60 s show: {} ({})",
            browser.text("[data-testid=preview-facts]").await,
            browser.text("[data-testid=create-checks]").await
        );
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
    assert_eq!(browser.text("[data-testid=create-total]").await, "60.0 s");

    // Within the installation's limits, and the line can carry it: planned in the
    // page's worker, off the thread that answers the buttons.
    browser
        .wait_for_text("[data-testid=preview-valid]", "本装置")
        .await;
    line_can_carry_it(&browser).await;
    browser
        .wait_for_attribute(
            "[data-testid=create-verdict]",
            "data-planned",
            "worker",
            UI_TIMEOUT,
        )
        .await;

    // Kept in the local files.
    browser.click("[data-testid=create-save-local]").await;
    browser
        .wait_for_text("[data-testid=create-message]", "lobby.json")
        .await;
    browser.click("[data-testid=nav-files]").await;
    browser
        .wait_for("[data-testid=local-file][data-name='lobby.json']")
        .await;

    // Uploaded from the Create page (the draft is still there), then played.
    browser.click("[data-testid=nav-create]").await;
    browser.wait_for("[data-testid=create-name]").await;
    let name = browser
        .client
        .execute(
            "return document.querySelector('[data-testid=create-name]').value;",
            Vec::new(),
        )
        .await
        .expect("the show's name");
    assert_eq!(
        name, "lobby",
        "the draft is kept while other pages are open"
    );
    line_can_carry_it(&browser).await;
    browser.click("[data-testid=create-upload]").await;
    browser
        .wait_for_text("[data-testid=create-message]", "lobby")
        .await;
    let shows = browser.get_json("/api/shows").await;
    let lobby = shows
        .as_array()
        .and_then(|shows| shows.iter().find(|show| show["name"] == "lobby"))
        .unwrap_or_else(|| panic!("lobby among the controller's shows: {shows}"));
    assert_eq!(lobby["units"], 100, "{lobby}");
    let duration_ms = lobby["duration_ms"].as_u64().unwrap_or_default();
    assert!(
        (60_000..=61_000).contains(&duration_ms),
        "a 60 s show: {lobby}"
    );

    browser.queue_show("lobby").await;
    browser.play_then_estop("lobby").await;
    browser.client.close().await.expect("close the browser");
}

/// A tablet-sized browser on the Create page, not logged in (made for a matrix of its
/// own, with the default limits).
async fn create_offline(bridge: &Bridge) -> Browser {
    let browser = Browser::start_in(640, 800, "en-US").await;
    browser
        .client
        .goto(&format!("{}#/create", bridge.url()))
        .await
        .expect("open the Create page");
    browser.wait_for("[data-testid=preview-canvas]").await;
    browser
}

/// Every pattern, offline on a 16 × 24 matrix: a picture of each a few seconds in,
/// for the documentation; each within the default limits.
#[tokio::test]
async fn every_pattern_draws_within_the_limits_and_leaves_a_picture() {
    let bridge = Bridge::start().await;
    let browser = create_offline(&bridge).await;
    // Offline: a matrix of 16 × 24 balls, large enough for a word to read.
    set_value(&browser, "[data-testid=create-rows]", "16").await;
    set_value(&browser, "[data-testid=create-cols]", "24").await;
    browser
        .wait_for_text("[data-testid=preview-facts]", "384")
        .await;
    let dir = screens_dir();
    let names = browser
        .client
        .execute(
            "return [...document.querySelectorAll('[data-testid=create-pattern] option')].map((o) => o.value);",
            Vec::new(),
        )
        .await
        .expect("the patterns");
    let names: Vec<String> = serde_json::from_value(names).expect("pattern names");
    assert!(names.len() >= 8, "{names:?}");
    // A picture for the picture pattern: a bright disc fading to dark edges.
    let folder = tempfile::tempdir().expect("temp dir");
    let png = folder.path().join("disc.png");
    image::GrayImage::from_fn(64, 64, |x, y| {
        let d = (f64::from(x) - 31.5).hypot(f64::from(y) - 31.5) / 32.0;
        image::Luma([(255.0 * (1.0 - d).clamp(0.0, 1.0)) as u8])
    })
    .save(&png)
    .expect("write the picture");
    for name in &names {
        let before = generation(&browser).await;
        set_value(&browser, "[data-testid=create-pattern]", name).await;
        let mut count = generated_after(&browser, &before).await;
        if name == "image" {
            browser.pick_file("[data-testid=param-image]", &png).await;
            count = generated_after(&browser, &count).await;
        }
        if name == "text" {
            // Standing still, HELLO is wider than 24 balls: a note says only its
            // middle is shown. HI fits, whole, and the note goes.
            set_value(&browser, "[data-testid=param-scroll_m_s]", "0").await;
            browser
                .wait_for_text(
                    "[data-testid=create-notes]",
                    "38 balls across on a matrix 24 across, only its middle is shown",
                )
                .await;
            set_value(&browser, "[data-testid=param-text]", "HI").await;
            browser
                .wait_for_text_gone("[data-testid=create]", "only its middle is shown")
                .await;
            count = generation(&browser).await;
        }
        let _ = count;
        browser.wait_for("[data-testid=preview-valid]").await;
        pause(&browser).await;
        // In 3D, then seen from above (the top view: higher balls larger and
        // brighter), where a word or a picture reads best.
        for (view, suffix) in [("3d", ""), ("top", "-top")] {
            browser
                .client
                .execute(
                    &format!(
                        "document.querySelector('[data-testid=preview-mode-{view}]').click();"
                    ),
                    Vec::new(),
                )
                .await
                .expect("choose the view");
            set_value(&browser, "[data-testid=preview-slider]", "6000").await;
            picture(&browser).await;
            let canvas = browser.wait_for("[data-testid=preview-canvas]").await;
            let png = canvas.screenshot().await.expect("screenshot");
            let path = dir.join(format!("create-{name}{suffix}.png"));
            std::fs::write(&path, png).expect("write the picture");
            println!("{name}: {}", path.display());
        }
        browser
            .client
            .execute(
                "document.querySelector('[data-testid=preview-mode-3d]').click();",
                Vec::new(),
            )
            .await
            .expect("back to 3D");
    }
    browser.client.close().await.expect("close the browser");
}

/// The draft outlives a reload: one right after a change (saved as the page is left)
/// and one after a pause (saved a moment after the change).
#[tokio::test]
async fn the_draft_outlives_a_reload_right_after_a_change() {
    let bridge = Bridge::start().await;
    let browser = create_offline(&bridge).await;
    let draft = async || {
        browser.wait_for("[data-testid=preview-canvas]").await;
        browser
            .client
            .execute(
                "return [document.querySelector('[data-testid=create-name]').value,
                         [...document.querySelectorAll('[data-testid=segment]')].map((s) => s.dataset.pattern),
                         JSON.parse(localStorage.getItem('floatball.recipe') || 'null')?.name ?? null];",
                Vec::new(),
            )
            .await
            .expect("the draft")
    };

    // A change, and at once a reload.
    set_value(&browser, "[data-testid=create-name]", "kept").await;
    browser.click("[data-testid=segment-add]").await;
    set_value(&browser, "[data-testid=create-pattern]", "text").await;
    browser.wait_for("[data-testid=param-text]").await;
    browser.client.refresh().await.expect("reload");
    assert_eq!(
        draft().await,
        serde_json::json!(["kept", ["wave", "text"], "kept"])
    );

    // A change, a pause, and the draft is stored without leaving the page.
    set_value(&browser, "[data-testid=create-name]", "later").await;
    let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
    while draft().await[2] != "later" {
        assert!(tokio::time::Instant::now() < deadline, "{}", draft().await);
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }
    browser.client.refresh().await.expect("reload");
    assert_eq!(
        draft().await,
        serde_json::json!(["later", ["wave", "text"], "later"])
    );

    // Two lines, one with a character the font lacks: drawn as ?, and a note under
    // the preview names it and says what to use instead.
    browser
        .click("[data-testid=segment][data-pattern=text] [data-testid=segment-pick]")
        .await;
    set_value(&browser, "[data-testid=param-text]", "HI|字").await;
    browser
        .wait_for_text(
            "[data-testid=create-notes]",
            "字 not in the built-in font, drawn as ? (draw them with the Bitmap parameter",
        )
        .await;
    set_value(&browser, "[data-testid=param-text]", "HI|42").await;
    browser
        .wait_for_text_gone("[data-testid=create]", "not in the built-in font")
        .await;
    browser.client.close().await.expect("close the browser");
}

/// The Create page's code is a chunk fetched when the page is opened (issue 35): a
/// chunk that cannot be fetched (offline, a stale cache after an update) shows an
/// error, a Retry and a Reload while the top bar, its E-STOP and the other pages
/// keep working; Retry fetches it again, Reload loads the app again.
#[tokio::test]
async fn a_create_chunk_that_cannot_be_fetched_shows_a_retry_and_breaks_nothing_else() {
    let bridge = Bridge::start().await;
    let browser = Browser::open_in(&bridge, "en-US").await;
    browser.first_login("floor-2468").await;
    let offline = |on: bool| {
        let script = "
            if (arguments[0]) {
                window.__online ??= window.fetch;
                window.fetch = (url, ...rest) => String(url).endsWith('.wasm')
                    ? Promise.reject(new TypeError('offline (test)'))
                    : window.__online(url, ...rest);
            } else {
                window.fetch = window.__online;
            }";
        browser.client.execute(script, vec![Value::from(on)])
    };
    offline(true).await.expect("go offline");
    browser.click("[data-testid=nav-create]").await;
    browser.wait_for("[data-testid=chunk-error]").await;
    browser
        .wait_for_text("[data-testid=chunk-error]", "could not be loaded")
        .await;
    // The E-STOP works meanwhile, and so do the other pages; Create fails again
    // while offline.
    browser.click(".topbar [data-testid=estop]").await;
    browser
        .wait_for_attribute(
            ".topbar [data-testid=estop]",
            "data-ack",
            "stopped",
            UI_TIMEOUT,
        )
        .await;
    browser.click("[data-testid=nav-files]").await;
    browser.wait_for("[data-testid=page-files]").await;
    browser.click("[data-testid=nav-create]").await;
    browser.wait_for("[data-testid=chunk-retry]").await;
    // Back online, Retry loads the page.
    offline(false).await.expect("go online");
    browser.click("[data-testid=chunk-retry]").await;
    browser.wait_for("[data-testid=preview-canvas]").await;
    assert!(
        browser
            .client
            .find_all(fantoccini::Locator::Css("[data-testid=chunk-error]"))
            .await
            .expect("look for the error")
            .is_empty()
    );

    // The console's parsers, offline (or stale after an update): the Console page is
    // there, its check says the checker is missing and nothing can be sent; Reload
    // loads the app again (the page served now names the chunks that exist) and
    // the Console checks lines.
    offline(true).await.expect("go offline");
    browser.click("[data-testid=nav-console]").await;
    browser.wait_for("[data-testid=console-input]").await;
    set_value(&browser, "[data-testid=console-input]", "*5;PV;").await;
    browser
        .wait_for_attribute(
            "[data-testid=console-check]",
            "data-state",
            "unavailable",
            UI_TIMEOUT,
        )
        .await;
    browser
        .wait_for_text("[data-testid=console-check]", "checker could not be loaded")
        .await;
    browser.click("[data-testid=console-reload]").await;
    browser.wait_for("[data-testid=console-input]").await;
    set_value(&browser, "[data-testid=console-input]", "*5;PV;").await;
    browser
        .wait_for_attribute(
            "[data-testid=console-check]",
            "data-state",
            "ok",
            UI_TIMEOUT,
        )
        .await;
    browser.client.close().await.expect("close the browser");
}
