//! Every page at the two device sizes the app is made for — a phone (390 × 844) and a
//! landscape tablet (1280 × 800) — in both languages: a screenshot of each (PNG files
//! under the target directory, `screens/`; the test prints where), and the checks a
//! look at them would make:
//!
//! - no page is wider than the screen (`scrollWidth` ≤ `innerWidth`);
//! - "E-STOP" stays on one line;
//! - on the phone, the compact status bar (state, show, progress) is at the top of
//!   every page once connected, and a chosen show's picture (Preview, Create) is
//!   above the fold;
//! - on the tablet, Control puts the playlist and the status side by side;
//! - the console gives a position answer in counts and in mm (`PA = … (… mm)`).
//!
//! Every failure names the page, the size and the language.

use std::path::Path;

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT, screens_dir, wave_csv};
use serde_json::Value;

/// The phone's viewport, CSS pixels.
const PHONE: (u32, u32) = (390, 844);
/// The tablet's viewport, CSS pixels.
const TABLET: (u32, u32) = (1280, 800);
/// The operator's password after the first login.
const PASSWORD: &str = "screens-and-sizes";

/// Calls back once the fonts are loaded and two more frames are drawn.
const SETTLED: &str = r"
    const done = arguments[arguments.length - 1];
    document.fonts.ready.then(() =>
        requestAnimationFrame(() => requestAnimationFrame(() => done(true))));
";

/// What one look at the page found: the layout's measures, read in the page.
const MEASURE: &str = r"
    const box = (css) => {
        const element = document.querySelector(css);
        if (!element || element.offsetParent === null) return null;
        const r = element.getBoundingClientRect();
        return { left: r.left, right: r.right, top: r.top, bottom: r.bottom };
    };
    const wrapped = [...document.querySelectorAll('.estop-label')].some((label) => {
        const height = label.getBoundingClientRect().height;
        const line = parseFloat(getComputedStyle(label).lineHeight);
        return height > line * 1.5;
    });
    return {
        scrollWidth: document.documentElement.scrollWidth,
        innerWidth: window.innerWidth,
        innerHeight: window.innerHeight,
        estopWrapped: wrapped,
        statusbar: box('[data-testid=statusbar]'),
        playlist: box('[data-testid=playlist]'),
        status: box('[data-testid=status]'),
        stage: box('[data-testid=preview-canvas]'),
    };
";

/// One device in one language, and what went wrong on it.
struct Tour<'a> {
    browser: &'a Browser,
    size: (u32, u32),
    dir: &'a Path,
    problems: Vec<String>,
}

impl Tour<'_> {
    fn phone(&self) -> bool {
        self.size == PHONE
    }

    /// Switches the app to `lang` (`zh` or `en`); the switch shows the other
    /// language's name.
    async fn language(&self, lang: &str) {
        let other = if lang == "zh" { "English" } else { "中文" };
        self.browser.wait_for("[data-testid=lang]").await;
        if self.browser.text("[data-testid=lang]").await != other {
            self.browser.click("[data-testid=lang]").await;
        }
        self.browser
            .wait_for_text("[data-testid=lang]", other)
            .await;
    }

    /// Takes the screenshot of `page` (named `page`, and `-offline` before the login)
    /// and checks what is in view.
    async fn shoot(&mut self, page: &str, lang: &str, connected: bool) {
        let browser = self.browser;
        browser
            .wait_for(&format!("[data-testid=page-{page}]"))
            .await;
        // Fonts loaded and two frames drawn: what a user would see.
        browser
            .client
            .execute_async(SETTLED, Vec::new())
            .await
            .expect("wait for the page to settle");
        let (width, height) = self.size;
        let offline = if connected { "" } else { "-offline" };
        let name = format!("{width}x{height}-{lang}-{page}{offline}.png");
        let png = browser.client.screenshot().await.expect("screenshot");
        std::fs::write(self.dir.join(&name), png).expect("write the screenshot");
        let seen = browser
            .client
            .execute(MEASURE, Vec::new())
            .await
            .expect("measure the page");
        let here = format!("{page} at {width}×{height} in {lang}");
        let number = |key: &str| seen[key].as_f64().unwrap_or(f64::NAN);
        if number("scrollWidth") > number("innerWidth") {
            self.problems.push(format!(
                "{here}: the page is {} px wide on a {} px screen",
                number("scrollWidth"),
                number("innerWidth")
            ));
        }
        if seen["estopWrapped"] == Value::Bool(true) {
            self.problems
                .push(format!("{here}: E-STOP wraps onto two lines"));
        }
        let edge = |key: &str, side: &str| seen[key][side].as_f64();
        if self.phone() && connected {
            match (edge("statusbar", "top"), edge("statusbar", "bottom")) {
                (Some(top), Some(bottom)) if top >= 0.0 && bottom <= 220.0 => {}
                other => self.problems.push(format!(
                    "{here}: the status bar is not at the top of the screen ({other:?})"
                )),
            }
        }
        if self.phone() && (page == "preview" || page == "create") {
            match edge("stage", "top") {
                Some(top) if top < number("innerHeight") * 0.5 => {}
                other => self.problems.push(format!(
                    "{here}: the chosen show's picture is not in the upper half of the screen (top {other:?})"
                )),
            }
        }
        if !self.phone() && page == "control" {
            let side_by_side = match (
                edge("playlist", "right"),
                edge("playlist", "top"),
                edge("playlist", "bottom"),
                edge("status", "left"),
                edge("status", "top"),
            ) {
                (Some(right), Some(top), Some(bottom), Some(left), Some(status_top)) => {
                    left >= right && status_top < bottom && top < number("innerHeight")
                }
                _ => false,
            };
            if !side_by_side {
                self.problems.push(format!(
                    "{here}: the playlist and the status are not side by side (playlist {}, status {})",
                    seen["playlist"], seen["status"]
                ));
            }
        }
    }

    /// Opens `page` from the navigation (Settings from Control's tabs).
    async fn open(&self, page: &str) {
        match page {
            "login" => self.browser.click(INDICATOR).await,
            "settings" => {
                self.browser.click("[data-testid=nav-control]").await;
                self.browser.click("[data-testid=subtab-settings]").await;
            }
            "commission" => {
                self.browser.click("[data-testid=nav-control]").await;
                self.browser.click("[data-testid=subtab-commission]").await;
            }
            "schedule" => {
                self.browser.click("[data-testid=nav-control]").await;
                self.browser.click("[data-testid=subtab-schedule]").await;
            }
            _ => {
                self.browser
                    .click(&format!("[data-testid=nav-{page}]"))
                    .await;
            }
        }
    }

    /// Every page, logged in and connected, in `lang`; the preview on `show`.
    async fn every_page(&mut self, lang: &str, show: &str) {
        self.language(lang).await;
        for page in [
            "login",
            "files",
            "create",
            "preview",
            "control",
            "settings",
            "console",
            "commission",
            "schedule",
        ] {
            self.open(page).await;
            if page == "preview" {
                // Once a show is chosen a phone folds the lists away.
                let folded = self
                    .browser
                    .client
                    .find(fantoccini::Locator::Css(
                        "[data-testid=preview-choose-another]",
                    ))
                    .await
                    .ok();
                if let Some(button) = folded
                    && button.is_displayed().await.unwrap_or(false)
                {
                    button.click().await.expect("choose another show");
                }
                self.browser
                    .click(&format!(
                        "[data-testid=preview-pick-controller][data-name='{show}']"
                    ))
                    .await;
                self.browser.wait_for("[data-testid=preview-canvas]").await;
            }
            if page == "create" {
                // The draft's picture, made for the installation.
                self.browser.wait_for("[data-testid=preview-canvas]").await;
                self.browser
                    .wait_for("[data-testid=create-for-installation]")
                    .await;
            }
            if page == "console" {
                // A position query: its answer comes in counts and in mm.
                self.browser
                    .type_into("[data-testid=console-input]", "*5;PA;")
                    .await;
                self.browser.click("[data-testid=console-send]").await;
                self.browser
                    .wait_for_text("[data-testid=feedback-line]", " mm)")
                    .await;
            }
            if page == "control" {
                self.browser
                    .wait_for(&format!("[data-testid=entry][data-show={show}]"))
                    .await;
            }
            if page == "commission" {
                // The grid of the simulated gateway, and the line-speed choice.
                self.browser.wait_for("[data-testid=grid]").await;
            }
            if page == "schedule" {
                // The schedule read from the bridge: a window added to Monday.
                self.browser
                    .wait_for("[data-testid=schedule-time-zone]")
                    .await;
                self.browser.click("[data-testid=day0-add]").await;
                self.browser
                    .wait_for("[data-testid=day0-window0-start]")
                    .await;
            }
            self.shoot(page, lang, true).await;
        }
    }
}

#[tokio::test]
async fn every_page_fits_the_phone_and_the_tablet_in_both_languages() {
    let bridge = Bridge::start().await;
    let dir = screens_dir();
    let folder = tempfile::tempdir().expect("temp dir");
    let csv = folder.path().join("wave.csv");
    std::fs::write(&csv, wave_csv()).expect("write the CSV");
    let mut problems = Vec::new();
    let mut first = true;
    for size in [PHONE, TABLET] {
        let browser = Browser::start(size.0, size.1).await;
        browser
            .client
            .goto(&bridge.url())
            .await
            .expect("open the app");
        let mut tour = Tour {
            browser: &browser,
            size,
            dir: &dir,
            problems: Vec::new(),
        };
        // The login page before any login, in both languages.
        for lang in ["zh", "en"] {
            tour.language(lang).await;
            tour.open("login").await;
            tour.shoot("login", lang, false).await;
        }
        tour.language("zh").await;
        if first {
            browser.first_login(PASSWORD).await;
            browser.upload_wave().await;
            browser.queue_show("wave").await;
            first = false;
        } else {
            browser.log_in(PASSWORD).await;
            browser
                .wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
                .await;
            // The same file among this device's local files.
            browser.pick_file("[data-testid=file-picker]", &csv).await;
            browser
                .wait_for("[data-testid=local-file][data-name='wave.csv']")
                .await;
        }
        browser.click("[data-testid=nav-control]").await;
        browser
            .wait_for_attribute(
                "[data-testid=status-state]",
                "data-state",
                "idle",
                UI_TIMEOUT,
            )
            .await;
        for lang in ["zh", "en"] {
            tour.every_page(lang, "wave").await;
        }
        problems.append(&mut tour.problems);
        browser.client.close().await.expect("close the browser");
    }
    println!("screenshots: {}", dir.display());
    assert!(
        problems.is_empty(),
        "{} layout problems (screenshots in {}):\n{}",
        problems.len(),
        dir.display(),
        problems.join("\n")
    );
}
