//! Helpers for the end-to-end tests: start the real `floatball` binary on a free port
//! with a fresh data directory, start ChromeDriver, and open a headless Chromium.
//!
//! The binary and the built app come from `cargo xtask test` through `FLOATBALL_BIN`
//! and `FLOATBALL_STATIC_DIR`; without them the workspace's `target/debug/floatball`
//! and `static/` are used, and a missing build is reported with what to run.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::Stdio;
use std::time::Duration;

use fantoccini::{Client, ClientBuilder};
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::{Child, Command};

/// How long a page may take to show what a test waits for.
pub const UI_TIMEOUT: Duration = Duration::from_secs(20);

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(PathBuf::from)
        .unwrap_or_default()
}

/// The `floatball` binary under test.
pub fn bridge_binary() -> PathBuf {
    let path = std::env::var_os("FLOATBALL_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target/debug/floatball"));
    assert!(
        path.is_file(),
        "{} does not exist: run `cargo xtask test` (or `cargo build -p floatball-bridge`)",
        path.display()
    );
    path
}

/// The directory with the built app.
pub fn static_dir() -> PathBuf {
    let dir = std::env::var_os("FLOATBALL_STATIC_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("static"));
    assert!(
        dir.join("pkg/floatball.js").is_file(),
        "{} has no built app: run `cargo xtask test` (or `cargo xtask run`)",
        dir.display()
    );
    dir
}

/// A running `floatball` process; killed when dropped.
#[derive(Debug)]
pub struct Bridge {
    child: Child,
    /// Where it listens.
    pub addr: SocketAddr,
    /// Its data directory (kept across restarts by [`Bridge::restart`]).
    pub data_dir: PathBuf,
    _temp: Option<tempfile::TempDir>,
}

impl Bridge {
    /// Starts the bridge on a free port with a fresh data directory.
    pub async fn start() -> Self {
        let temp = tempfile::tempdir().expect("temp dir");
        let data_dir = temp.path().to_path_buf();
        let (child, addr) = spawn_bridge("127.0.0.1:0", &data_dir).await;
        Self {
            child,
            addr,
            data_dir,
            _temp: Some(temp),
        }
    }

    /// The app's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Kills the process and waits for it to be gone.
    pub async fn stop(&mut self) {
        let _ = self.child.kill().await;
    }

    /// Starts it again on the same port and data directory.
    pub async fn restart(&mut self) {
        self.stop().await;
        let (child, addr) = spawn_bridge(&self.addr.to_string(), &self.data_dir).await;
        self.child = child;
        self.addr = addr;
    }
}

async fn spawn_bridge(listen: &str, data_dir: &std::path::Path) -> (Child, SocketAddr) {
    let mut child = Command::new(bridge_binary())
        .args(["--listen", listen])
        .arg("--data-dir")
        .arg(data_dir)
        .arg("--static-dir")
        .arg(static_dir())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .kill_on_drop(true)
        .spawn()
        .expect("start floatball");
    let stdout = child.stdout.take().expect("stdout");
    let mut lines = BufReader::new(stdout).lines();
    let line = tokio::time::timeout(Duration::from_secs(30), lines.next_line())
        .await
        .expect("floatball printed nothing within 30 s")
        .expect("read floatball's stdout")
        .expect("floatball exited before listening");
    let addr = line
        .rsplit("http://")
        .next()
        .and_then(|addr| addr.trim().parse().ok())
        .unwrap_or_else(|| panic!("unexpected first line from floatball: {line}"));
    // Keep draining stdout so the bridge never blocks on a full pipe.
    tokio::spawn(async move { while let Ok(Some(_)) = lines.next_line().await {} });
    (child, addr)
}

/// A running ChromeDriver and a headless Chromium session; both end when dropped.
#[derive(Debug)]
pub struct Browser {
    /// The WebDriver client.
    pub client: Client,
    _driver: Child,
    _profile: tempfile::TempDir,
}

impl Browser {
    /// Starts ChromeDriver on a free port and opens a headless Chromium window of
    /// `width` × `height` CSS pixels.
    pub async fn start(width: u32, height: u32) -> Self {
        let chromedriver = std::env::var("CHROMEDRIVER").unwrap_or("/usr/bin/chromedriver".into());
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|listener| listener.local_addr())
            .expect("free port")
            .port();
        let driver = Command::new(&chromedriver)
            .arg(format!("--port={port}"))
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .kill_on_drop(true)
            .spawn()
            .unwrap_or_else(|err| panic!("cannot start {chromedriver}: {err}"));
        let profile = tempfile::tempdir().expect("profile dir");
        let mut capabilities = serde_json::Map::new();
        capabilities.insert(
            "goog:chromeOptions".into(),
            serde_json::json!({
                // A real phone-sized viewport: desktop windows do not get narrower
                // than 500 px.
                "mobileEmulation": {
                    "deviceMetrics": { "width": width, "height": height, "pixelRatio": 1.0 }
                },
                "args": [
                    "--headless=new",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--disable-dev-shm-usage",
                    "--disable-background-networking",
                    "--disable-component-update",
                    "--disable-sync",
                    "--disable-quic",
                    "--no-first-run",
                    format!("--window-size={},{height}", width.max(500)),
                    format!("--user-data-dir={}", profile.path().display()),
                ]
            }),
        );
        let url = format!("http://127.0.0.1:{port}");
        let mut last_error = None;
        for _ in 0..100 {
            let connector = hyper_util::client::legacy::connect::HttpConnector::new();
            match ClientBuilder::new(connector)
                .capabilities(capabilities.clone())
                .connect(&url)
                .await
            {
                Ok(client) => {
                    return Self {
                        client,
                        _driver: driver,
                        _profile: profile,
                    };
                }
                Err(err) => {
                    last_error = Some(err);
                    tokio::time::sleep(Duration::from_millis(100)).await;
                }
            }
        }
        panic!("cannot start a Chromium session: {last_error:?}");
    }

    /// Waits until the element matching `css` has attribute `name` equal to `value`.
    pub async fn wait_for_attribute(&self, css: &str, name: &str, value: &str, within: Duration) {
        let deadline = tokio::time::Instant::now() + within;
        let mut seen = None;
        while tokio::time::Instant::now() < deadline {
            if let Ok(element) = self.client.find(fantoccini::Locator::Css(css)).await {
                seen = element.attr(name).await.ok().flatten();
                if seen.as_deref() == Some(value) {
                    return;
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("{css} never had {name}={value:?} within {within:?} (last seen {seen:?})");
    }

    /// The text of the element matching `css`.
    pub async fn text(&self, css: &str) -> String {
        self.client
            .find(fantoccini::Locator::Css(css))
            .await
            .unwrap_or_else(|err| panic!("no element {css}: {err}"))
            .text()
            .await
            .expect("element text")
    }

    /// Waits until an element matching `css` exists, and returns it.
    pub async fn wait_for(&self, css: &str) -> fantoccini::elements::Element {
        self.client
            .wait()
            .at_most(UI_TIMEOUT)
            .for_element(fantoccini::Locator::Css(css))
            .await
            .unwrap_or_else(|err| panic!("{css} never appeared within {UI_TIMEOUT:?}: {err}"))
    }

    /// Waits for the element matching `css`, then clicks it once it is enabled.
    pub async fn click(&self, css: &str) {
        let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
        loop {
            let element = self.wait_for(css).await;
            let enabled = element.is_enabled().await.unwrap_or(false);
            if enabled && element.click().await.is_ok() {
                return;
            }
            assert!(
                tokio::time::Instant::now() < deadline,
                "{css} could not be clicked within {UI_TIMEOUT:?}"
            );
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
    }

    /// Replaces the text of the input matching `css` with `text`, as typed.
    pub async fn type_into(&self, css: &str, text: &str) {
        let element = self.wait_for(css).await;
        element.clear().await.expect("clear the field");
        element.send_keys(text).await.expect("type into the field");
    }

    /// Picks the file at `path` in the file input matching `css`.
    pub async fn pick_file(&self, css: &str, path: &std::path::Path) {
        let element = self.wait_for(css).await;
        element
            .send_keys(&path.display().to_string())
            .await
            .expect("pick the file");
    }

    /// Waits until the text of the element matching `css` contains `part`.
    pub async fn wait_for_text(&self, css: &str, part: &str) {
        let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
        let mut seen = None;
        while tokio::time::Instant::now() < deadline {
            if let Ok(element) = self.client.find(fantoccini::Locator::Css(css)).await {
                seen = element.text().await.ok();
                if seen.as_deref().is_some_and(|text| text.contains(part)) {
                    return;
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("{css} never contained {part:?} within {UI_TIMEOUT:?} (last seen {seen:?})");
    }

    /// Logs in from the Login page (opened with the connection button) with
    /// `password`.
    pub async fn log_in(&self, password: &str) {
        self.click("[data-testid=connection]").await;
        self.type_into("[data-testid=login-password]", password)
            .await;
        self.click("[data-testid=login-submit]").await;
    }
}
