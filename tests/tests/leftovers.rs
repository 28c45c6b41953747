//! A failing test leaves nothing behind: a browser test that panics ends ChromeDriver
//! and every Chromium process it started and removes the browser's profile; a bridge
//! test that panics ends the bridge and removes its data directory.
//!
//! Each test runs its failing part in a thread of its own with its own runtime, as
//! libtest runs a `#[tokio::test]`: the panic unwinds through the runtime, dropping
//! what the test held, with no chance to `close()` a WebDriver session. It notes the
//! pids (and command lines) it started before panicking; afterwards none may run.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use floatball_e2e::processes::{command_line, descendants, is_alive, kill, mentioning};
use floatball_e2e::{Bridge, Browser};

/// What the failing part noted: its processes' pids with their command lines, and
/// the directory that must be gone.
type Noted = (BTreeMap<u32, String>, PathBuf);

/// Runs `body` in a thread on a runtime of its own; it notes into the slot it is
/// given, then panics. Returns what it noted.
fn run_failing<F, Fut>(body: F) -> Noted
where
    F: FnOnce(Arc<Mutex<Option<Noted>>>) -> Fut + Send + 'static,
    Fut: std::future::Future<Output = ()>,
{
    let slot: Arc<Mutex<Option<Noted>>> = Arc::default();
    let note = Arc::clone(&slot);
    let outcome = std::thread::spawn(move || {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .expect("a runtime");
        runtime.block_on(body(note));
    })
    .join();
    assert!(outcome.is_err(), "the failing part did not panic");
    slot.lock()
        .unwrap_or_else(PoisonError::into_inner)
        .take()
        .expect("the failing part noted its processes before panicking")
}

/// `pids` with their command lines now.
fn with_command_lines(pids: impl IntoIterator<Item = u32>) -> BTreeMap<u32, String> {
    pids.into_iter()
        .map(|pid| (pid, command_line(pid)))
        .collect()
}

/// Checks that none of the noted processes runs and the directory is gone; kills
/// any that still run, so a failure here leaves nothing either.
fn assert_nothing_left((pids, dir): &Noted) {
    println!("the failing part started {} processes:", pids.len());
    for (pid, command) in pids {
        let short: String = command.chars().take(100).collect();
        println!("  {pid} {short}");
    }
    let alive: Vec<String> = pids
        .iter()
        .filter(|(pid, _)| is_alive(**pid))
        .map(|(pid, command)| format!("{pid} {command}"))
        .collect();
    for pid in pids.keys() {
        kill(*pid);
    }
    let exists = dir.exists();
    if exists {
        let _ = std::fs::remove_dir_all(dir);
    }
    assert!(
        alive.is_empty(),
        "{} of {} processes still run after the test failed:\n{}",
        alive.len(),
        pids.len(),
        alive.join("\n")
    );
    assert!(!exists, "{} is still there", dir.display());
}

#[test]
fn a_failing_browser_test_leaves_no_browser_and_no_profile() {
    let noted = run_failing(|note| async move {
        let browser = Browser::start(360, 740).await;
        browser
            .client
            .goto("data:text/html,<p id=hello>hello</p>")
            .await
            .expect("open a page");
        browser.wait_for("#hello").await;
        let profile = browser.profile_dir().to_path_buf();
        assert!(profile.is_dir(), "no profile at {}", profile.display());
        // The browser's processes are up once a page shows: ChromeDriver, Chromium and
        // its helpers (zygotes, the GPU process, a renderer…). Noted as the harness
        // sees them, and on its own: ChromeDriver's descendants, and every process
        // that names the profile.
        let deadline = Instant::now() + Duration::from_secs(10);
        let pids = loop {
            let mut pids = browser.pids();
            for &pid in &pids.clone() {
                if command_line(pid).contains("chromedriver") {
                    pids.extend(descendants(pid));
                }
            }
            pids.extend(mentioning(&profile.display().to_string()));
            let pids = with_command_lines(pids);
            if pids
                .values()
                .any(|command| command.contains("--type=renderer"))
                || Instant::now() > deadline
            {
                break pids;
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        };
        *note.lock().unwrap_or_else(PoisonError::into_inner) = Some((pids, profile));
        panic!("a browser test fails (on purpose: what it started must end)");
    });
    let (pids, _) = &noted;
    assert!(
        pids.values()
            .any(|command| command.contains("chromedriver")),
        "no ChromeDriver among {pids:?}"
    );
    assert!(
        pids.values()
            .any(|command| command.contains("--type=renderer")),
        "no Chromium renderer among {pids:?}"
    );
    assert_nothing_left(&noted);
}

#[test]
fn a_failing_bridge_test_leaves_no_bridge_and_no_data() {
    let noted = run_failing(|note| async move {
        let bridge = Bridge::start().await;
        let pids = with_command_lines(bridge.pids());
        *note.lock().unwrap_or_else(PoisonError::into_inner) =
            Some((pids, bridge.data_dir.clone()));
        panic!("a bridge test fails (on purpose: what it started must end)");
    });
    let (pids, _) = &noted;
    assert!(
        pids.values().any(|command| command.contains("--data-dir")),
        "no bridge among {pids:?}"
    );
    assert_nothing_left(&noted);
}
