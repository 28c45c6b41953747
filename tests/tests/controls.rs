//! Safe controls during a show, end to end in the real app against the real bridge
//! and its simulated gateway: while the show plays the playlist is locked (its icons
//! disabled with the reason, the bridge refuses an edit with `playlist_locked`), the
//! playing entry is marked and Start says why it cannot be pressed; Reset asks first
//! (Cancel leaves the show playing, Confirm homes the balls, with the homing's own
//! progress instead of a show time); after an E-stop Start asks too; Home brings
//! every ball home and the matrix stays idle, and the E-stop badge clears once the
//! matrix leaves `stopped`.
//!
//! The checks read `data-*` attributes, not words: the app's language follows the
//! browser's.

use std::time::Duration;

use fantoccini::Locator;
use floatball_e2e::{Bridge, Browser, PLAY_TIMEOUT, UI_TIMEOUT};

const STATE: &str = "[data-testid=status-state]";
const BADGE: &str = ".topbar [data-testid=estop]";

async fn enabled(browser: &Browser, css: &str) -> bool {
    browser
        .wait_for(css)
        .await
        .is_enabled()
        .await
        .expect("enabled state")
}

async fn count(browser: &Browser, css: &str) -> usize {
    browser
        .client
        .find_all(Locator::Css(css))
        .await
        .expect("find elements")
        .len()
}

/// `PUT /api/playlist` from the page with `playlist`; the status and the JSON answer.
async fn put_playlist(browser: &Browser, playlist: serde_json::Value) -> serde_json::Value {
    let script = r"
        const [body, done] = arguments;
        const session = JSON.parse(localStorage.getItem('floatball.session'));
        fetch('/api/playlist', {
            method: 'PUT',
            headers: { Authorization: 'Bearer ' + session.token, 'Content-Type': 'application/json' },
            body: JSON.stringify(body),
        })
            .then(async (reply) => done({ status: reply.status, body: await reply.json() }))
            .catch((error) => done({ error: String(error) }));
    ";
    browser
        .client
        .execute_async(script, vec![playlist])
        .await
        .expect("PUT /api/playlist from the page")
}

#[tokio::test]
async fn the_playlist_locks_while_playing_reset_and_home_ask_first_and_home_stays_idle() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    browser.first_login("night-show-7").await;
    browser.upload_wave().await;
    browser.queue_show("wave").await;
    browser.play("wave").await;

    // Locked while playing: the icons, with the reason; the bridge refuses too.
    for icon in ["add", "move-up", "move-down", "delete", "edit"] {
        assert!(
            !enabled(&browser, &format!("[data-testid={icon}]")).await,
            "{icon}"
        );
    }
    browser.wait_for("[data-testid=playlist-locked]").await;
    assert!(!enabled(&browser, "[data-testid=start]").await);
    browser
        .wait_for_attribute(
            "[data-testid=start-reason]",
            "data-reason",
            "StartWhileRunning",
            UI_TIMEOUT,
        )
        .await;
    assert_eq!(
        count(&browser, "[data-testid=entry][data-show=wave].playing").await,
        1,
        "the playing entry is marked"
    );
    let mut playlist = browser.get_json("/api/playlist").await;
    playlist["entries"][0]["cycles"] = 3.into();
    let refused = put_playlist(&browser, playlist).await;
    assert_eq!(refused["status"], 409, "{refused}");
    assert_eq!(refused["body"]["code"], "playlist_locked", "{refused}");

    // Reset asks first; Cancel leaves the show playing.
    browser.click("[data-testid=reset]").await;
    browser
        .wait_for_attribute("[data-testid=confirm]", "data-action", "reset", UI_TIMEOUT)
        .await;
    browser.click("[data-testid=confirm-cancel]").await;
    assert_eq!(count(&browser, "[data-testid=confirm]").await, 0);
    tokio::time::sleep(Duration::from_millis(300)).await;
    assert_eq!(
        browser
            .wait_for(STATE)
            .await
            .attr("data-state")
            .await
            .unwrap()
            .as_deref(),
        Some("playing"),
        "Cancel moved nothing"
    );
    // Confirmed, the balls home: the homing's own progress, not a show time.
    browser.click("[data-testid=reset]").await;
    browser.click("[data-testid=confirm-yes]").await;
    browser
        .wait_for_attribute(STATE, "data-state", "homing", UI_TIMEOUT)
        .await;
    let time = browser.text("[data-testid=status-time]").await;
    assert!(time.contains('%') && !time.contains('/'), "{time}");

    // E-stop never asks; after it, Start asks (the balls home first).
    browser.estop().await;
    browser.click("[data-testid=start]").await;
    browser
        .wait_for_attribute("[data-testid=confirm]", "data-action", "start", UI_TIMEOUT)
        .await;
    browser.click("[data-testid=confirm-cancel]").await;

    // Home: asks, every ball goes home, the badge clears, the matrix stays idle.
    browser.click("[data-testid=home]").await;
    browser
        .wait_for_attribute("[data-testid=confirm]", "data-action", "home", UI_TIMEOUT)
        .await;
    browser.click("[data-testid=confirm-yes]").await;
    browser
        .wait_for_attribute(STATE, "data-state", "homing", UI_TIMEOUT)
        .await;
    let badge = browser
        .wait_for(BADGE)
        .await
        .attr("data-ack")
        .await
        .unwrap();
    assert_eq!(
        badge.as_deref(),
        Some("ready"),
        "the badge cleared when homing began"
    );
    browser
        .wait_for_attribute(STATE, "data-state", "idle", PLAY_TIMEOUT)
        .await;
    let positions = browser.get_json("/api/sim/positions").await;
    let units = positions["gateways"][0]["units"]
        .as_array()
        .unwrap_or_else(|| panic!("{positions}"));
    assert_eq!(units.len(), 100, "{positions}");
    for unit in units {
        let counts = unit["position_counts"].as_f64().expect("position");
        assert!(counts.abs() < 1.0 && unit["moving"] == false, "{unit}");
    }
    tokio::time::sleep(Duration::from_secs(1)).await;
    assert_eq!(
        browser
            .wait_for(STATE)
            .await
            .attr("data-state")
            .await
            .unwrap()
            .as_deref(),
        Some("idle"),
        "Home stays idle"
    );
    assert!(enabled(&browser, "[data-testid=delete]").await, "unlocked");
    assert_eq!(count(&browser, "[data-testid=playlist-locked]").await, 0);

    browser.client.close().await.expect("close the browser");
}

/// An ArtDmx packet (Art-Net 4) for Port-Address 0 (the bridge's universe 1) with
/// `data` (written here, not with the bridge's encoder).
fn art_dmx(data: &[u8]) -> Vec<u8> {
    let mut packet = b"Art-Net\0".to_vec();
    packet.extend_from_slice(&0x5000u16.to_le_bytes());
    packet.extend_from_slice(&[0, 14, 0, 0, 0, 0]);
    packet.extend_from_slice(&u16::try_from(data.len()).expect("length").to_be_bytes());
    packet.extend_from_slice(data);
    packet
}

/// Whether an element `css` is on screen (the Preview keeps a show hidden under the
/// live picture).
async fn displayed(browser: &Browser, css: &str) -> bool {
    for element in browser
        .client
        .find_all(Locator::Css(css))
        .await
        .expect("find elements")
    {
        if element.is_displayed().await.expect("displayed") {
            return true;
        }
    }
    false
}

/// A fingerprint of the picture on the canvas `css`, once two more frames are drawn.
async fn picture(browser: &Browser, css: &str) -> String {
    let script = r"
        const [css, done] = arguments;
        requestAnimationFrame(() => requestAnimationFrame(() => {
            const url = document.querySelector(css).toDataURL('image/png');
            let hash = 0;
            for (let i = 0; i < url.length; i++) hash = (hash * 31 + url.charCodeAt(i)) | 0;
            done(url.length + ':' + hash);
        }));
    ";
    browser
        .client
        .execute_async(script, vec![serde_json::Value::from(css)])
        .await
        .expect("read the picture")
        .as_str()
        .unwrap_or_default()
        .to_owned()
}

/// The Live card on Control (issue 38): Go live shows the phase until the balls
/// follow a console's Art-Net (this test's own datagrams), Record a take and Stop
/// recording → the take is among the controller's files, Leave live → off. While
/// live the card draws the balls' live positions, and they move with the console.
/// The Preview page shows the live picture meanwhile (the 3D matrix, every ball at
/// its live position); a show previewed while live is one tap from it, and is what
/// the page shows again once live mode ends.
#[tokio::test]
async fn go_live_shows_the_phase_a_recorded_take_is_listed_and_leave_live_ends_it() {
    let socket = std::net::UdpSocket::bind("127.0.0.1:0").expect("a socket");
    let port = {
        let probe = std::net::UdpSocket::bind("127.0.0.1:0").expect("a free port");
        probe.local_addr().expect("address").port()
    };
    let bridge = Bridge::start_with_config(&format!(
        "[matrix]\nrows = 1\ncols = 4\ntravel_mm = 2000.0\n[safety]\napproach_speed_mm_s = 2000.0\n\
         [[gateway]]\nport = \"sim\"\n\
         [live]\nenabled = true\nsacn = false\nartnet_listen = \"127.0.0.1:{port}\"\n"
    ))
    .await;
    // A console: every ball at a quarter of the travel (then half), 20 times a second.
    let sending = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(true));
    let fader = std::sync::Arc::new(std::sync::atomic::AtomicU8::new(0x40));
    let console = {
        let sending = std::sync::Arc::clone(&sending);
        let fader = std::sync::Arc::clone(&fader);
        std::thread::spawn(move || {
            while sending.load(std::sync::atomic::Ordering::SeqCst) {
                let coarse = fader.load(std::sync::atomic::Ordering::SeqCst);
                let packet = art_dmx(&[coarse, 0, coarse, 0, coarse, 0, coarse, 0]);
                let _ = socket.send_to(&packet, ("127.0.0.1", port));
                std::thread::sleep(Duration::from_millis(50));
            }
        })
    };
    let browser = Browser::open(&bridge).await;
    browser.first_login("night-show-7").await;
    browser.click("[data-testid=nav-control]").await;
    browser.click("[data-testid=live-open]").await;
    browser
        .wait_for_attribute("[data-testid=live-phase]", "data-phase", "off", UI_TIMEOUT)
        .await;
    browser.click("[data-testid=go-live]").await;
    browser
        .wait_for_attribute(
            "[data-testid=live-phase]",
            "data-phase",
            "following",
            PLAY_TIMEOUT,
        )
        .await;
    assert!(enabled(&browser, "[data-testid=leave-live]").await);
    assert!(!enabled(&browser, "[data-testid=go-live]").await);
    assert!(!browser.text("[data-testid=live-timing]").await.is_empty());
    // The live positions: every ball at a quarter of 2,000 mm, then at half.
    browser
        .wait_for_attribute(
            "[data-testid=live-positions]",
            "data-high-mm",
            "500",
            UI_TIMEOUT,
        )
        .await;
    browser.wait_for("[data-testid=live-matrix]").await;

    // The Preview page: the live picture, the installation's 4 balls at 500 mm, on
    // the 3D stage; the card gone meanwhile, the positions keep coming.
    const LIVE_PICTURE: &str = "[data-testid=preview-live-picture]";
    const LIVE_CANVAS: &str = "[data-testid=preview-live-picture] [data-testid=preview-canvas]";
    browser.click("[data-testid=nav-preview]").await;
    for (name, value) in [("data-high-mm", "500"), ("data-low-mm", "500")] {
        browser
            .wait_for_attribute(LIVE_PICTURE, name, value, UI_TIMEOUT)
            .await;
    }
    let live_picture = browser.wait_for(LIVE_PICTURE).await;
    assert_eq!(
        live_picture
            .attr("data-balls")
            .await
            .expect("attribute")
            .as_deref(),
        Some("4")
    );
    assert!(
        !browser
            .text("[data-testid=preview-live-title]")
            .await
            .is_empty()
    );
    browser
        .wait_for_attribute(
            "[data-testid=preview-live-phase]",
            "data-phase",
            "following",
            UI_TIMEOUT,
        )
        .await;
    assert!(!displayed(&browser, "[data-testid=preview-empty]").await);
    browser
        .wait_for(&format!("{LIVE_CANVAS}[data-renderer=webgl2]"))
        .await;
    let at_500 = picture(&browser, LIVE_CANVAS).await;
    // The console moves the balls: the picture follows.
    fader.store(0x80, std::sync::atomic::Ordering::SeqCst);
    browser
        .wait_for_attribute(LIVE_PICTURE, "data-low-mm", "1000", PLAY_TIMEOUT)
        .await;
    assert_ne!(picture(&browser, LIVE_CANVAS).await, at_500);

    // Back on Control, the card has them too (asked for again when it opened).
    browser.click("[data-testid=nav-control]").await;
    browser
        .wait_for_attribute(
            "[data-testid=live-positions]",
            "data-low-mm",
            "1000",
            PLAY_TIMEOUT,
        )
        .await;

    browser.type_into("[data-testid=record-name]", "take").await;
    browser.click("[data-testid=record-start]").await;
    browser.wait_for("[data-testid=live-recorded]").await;
    tokio::time::sleep(Duration::from_millis(700)).await;
    browser.click("[data-testid=record-stop]").await;
    browser.click("[data-testid=nav-files]").await;
    browser.click("[data-testid=tab-controller]").await;
    browser
        .wait_for("[data-testid=controller-file][data-name=take]")
        .await;
    // A show previewed while live: the show, with a bar to the live picture; from
    // the live picture, a button back to the show.
    browser
        .click("[data-testid=controller-file][data-name=take]")
        .await;
    browser.click("[data-testid=preview-controller]").await;
    browser.wait_for("[data-testid=preview-live-bar]").await;
    browser
        .wait_for_text("[data-testid=preview-name]", "take")
        .await;
    browser.click("[data-testid=preview-live-open]").await;
    browser
        .wait_for_attribute(LIVE_PICTURE, "data-low-mm", "1000", UI_TIMEOUT)
        .await;
    assert!(!displayed(&browser, "[data-testid=preview-name]").await);
    browser.click("[data-testid=preview-live-to-show]").await;
    browser
        .wait_for_text("[data-testid=preview-name]", "take")
        .await;
    assert_eq!(count(&browser, LIVE_PICTURE).await, 0);

    browser.click("[data-testid=nav-control]").await;
    browser.click("[data-testid=leave-live]").await;
    browser
        .wait_for_attribute(
            "[data-testid=live-phase]",
            "data-phase",
            "off",
            PLAY_TIMEOUT,
        )
        .await;
    // Not live: the Preview page shows the show chosen, without the live bar.
    browser.click("[data-testid=nav-preview]").await;
    browser
        .wait_for_text("[data-testid=preview-name]", "take")
        .await;
    browser.wait_for("[data-testid=preview-canvas]").await;
    assert_eq!(count(&browser, "[data-testid=preview-live-bar]").await, 0);
    assert_eq!(count(&browser, LIVE_PICTURE).await, 0);
    sending.store(false, std::sync::atomic::Ordering::SeqCst);
    console.join().expect("the console thread");
}
