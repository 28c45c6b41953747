//! Helpers for the end-to-end tests: start the real `floatball` binary on a free port
//! with a fresh data directory, start ChromeDriver, and open a headless Chromium.
//!
//! The binary and the built app come from `cargo xtask test` through `FLOATBALL_BIN`
//! and `FLOATBALL_STATIC_DIR`; without them the workspace's `target/debug/floatball`
//! and `static/` are used, and a missing build is reported with what to run.
//!
//! Every process started here ends with the test, also when it fails or panics:
//! [`Bridge`] and [`Browser`] hold a [`processes::ProcessTree`] that kills the whole
//! tree (ChromeDriver and the Chromium it started) and removes its temporary
//! directories when dropped.

pub mod processes;

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::Duration;

use fantoccini::{Client, ClientBuilder};
use tokio::io::{AsyncBufReadExt, BufReader};
use tokio::process::Command;

use crate::processes::ProcessTree;

/// How long a page may take to show what a test waits for.
pub const UI_TIMEOUT: Duration = Duration::from_secs(20);

/// The connection indicator in the top bar.
pub const INDICATOR: &str = "[data-testid=connection]";

/// How long homing, the approach and the preload may take before the show plays.
pub const PLAY_TIMEOUT: Duration = Duration::from_secs(90);

/// A gentle wave over a 10 × 10 installation: every ball swings ±300 mm around 1 m,
/// fading in and out over 2 s so it starts and ends at rest; 8 s long.
pub fn wave_csv() -> String {
    use std::fmt::Write as _;
    let mut csv = String::from("# rows=10 cols=10 pitch_mm=500\ntime_ms");
    for unit in 0..100 {
        write!(csv, ",u{unit}").expect("write to a string");
    }
    csv.push('\n');
    for step in 0..=32 {
        let t_ms = f64::from(step) * 250.0;
        let ramp = (t_ms / 2000.0)
            .min((8000.0 - t_ms) / 2000.0)
            .clamp(0.0, 1.0);
        let ramp = ramp * ramp * (3.0 - 2.0 * ramp);
        write!(csv, "{t_ms}").expect("write to a string");
        for unit in 0..100 {
            let phase = f64::from(unit % 10) * 0.5 + f64::from(unit / 10) * 0.3;
            let angle = std::f64::consts::TAU * t_ms / 8000.0 + phase;
            write!(csv, ",{:.0}", 1000.0 + 300.0 * ramp * angle.sin()).expect("write to a string");
        }
        csv.push('\n');
    }
    csv
}

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
        dir.join("pkg/index.html").is_file(),
        "{} has no built app (pkg/index.html): run `cargo xtask build --test` (or `cargo xtask test`)",
        dir.display()
    );
    dir
}

/// A running `floatball` process; killed when dropped (with any process it
/// started), then its data directory removed.
#[derive(Debug)]
pub struct Bridge {
    process: ProcessTree,
    /// Where it listens.
    pub addr: SocketAddr,
    /// Its data directory (kept across restarts by [`Bridge::restart`]).
    pub data_dir: PathBuf,
    /// Its extra command-line flags (kept across restarts).
    args: Vec<String>,
    _temp: Option<tempfile::TempDir>,
}

impl Bridge {
    /// Starts the bridge on a free port with a fresh data directory.
    pub async fn start() -> Self {
        Self::start_with(None).await
    }

    /// Starts the bridge on a free port with a fresh data directory whose
    /// `floatball.toml` is `config`.
    pub async fn start_with_config(config: &str) -> Self {
        Self::start_with(Some(config)).await
    }

    /// Starts the bridge on a free port with a fresh data directory and the extra
    /// flags `args` (e.g. `--sim-factory-fresh`), which a restart keeps.
    pub async fn start_with_args(args: &[&str]) -> Self {
        Self::start_with_all(None, args).await
    }

    /// Starts the bridge on a free port with a fresh data directory whose
    /// `floatball.toml` is `config`, and the extra flags `args` (kept by a restart).
    pub async fn start_with_config_and_args(config: &str, args: &[&str]) -> Self {
        Self::start_with_all(Some(config), args).await
    }

    async fn start_with(config: Option<&str>) -> Self {
        Self::start_with_all(config, &[]).await
    }

    async fn start_with_all(config: Option<&str>, args: &[&str]) -> Self {
        let temp = tempfile::tempdir().expect("temp dir");
        let data_dir = temp.path().to_path_buf();
        if let Some(config) = config {
            std::fs::write(data_dir.join("floatball.toml"), config).expect("write the config");
        }
        let args: Vec<String> = args.iter().map(|arg| (*arg).to_owned()).collect();
        let (process, addr) = spawn_bridge("127.0.0.1:0", &data_dir, &args).await;
        Self {
            process,
            addr,
            data_dir,
            args,
            _temp: Some(temp),
        }
    }

    /// The app's URL.
    pub fn url(&self) -> String {
        format!("http://{}/", self.addr)
    }

    /// Kills the process (and any it started) and waits for it to be gone.
    pub async fn stop(&mut self) {
        self.process.end();
    }

    /// Starts it again on the same port and data directory.
    pub async fn restart(&mut self) {
        self.stop().await;
        let (process, addr) =
            spawn_bridge(&self.addr.to_string(), &self.data_dir, &self.args).await;
        self.process = process;
        self.addr = addr;
    }

    /// The bridge's processes now running (its pid and those of any process it
    /// started); empty once stopped.
    pub fn pids(&self) -> std::collections::BTreeSet<u32> {
        self.process.members()
    }
}

async fn spawn_bridge(
    listen: &str,
    data_dir: &std::path::Path,
    args: &[String],
) -> (ProcessTree, SocketAddr) {
    let mut command = Command::new(bridge_binary());
    command
        .args(["--listen", listen])
        .args(args)
        .arg("--data-dir")
        .arg(data_dir)
        .arg("--static-dir")
        .arg(static_dir())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    // The data directory is the bridge's own: a process whose command line names it
    // is one of the bridge's.
    let marker = data_dir.display().to_string();
    let mut process = ProcessTree::spawn(&mut command, Some(marker), None)
        .unwrap_or_else(|err| panic!("cannot start {}: {err}", bridge_binary().display()));
    let stdout = process.child_mut().stdout.take().expect("stdout");
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
    (process, addr)
}

/// Where screenshots go: `<target>/screens`, next to the test binary's profile
/// directory (`<target>/debug/deps/<test>-…`); created if missing.
pub fn screens_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let target = exe
        .ancestors()
        .nth(3)
        .map(Path::to_path_buf)
        .unwrap_or_else(std::env::temp_dir);
    let dir = target.join("screens");
    std::fs::create_dir_all(&dir).expect("create the screenshot directory");
    dir
}

/// A running ChromeDriver and a headless Chromium session; both end when dropped,
/// with every process Chromium started, and the profile is removed.
///
/// ChromeDriver and Chromium work in a temporary directory of the browser's own:
/// Chromium's profile (`profile/`, its `--user-data-dir`), their `TMPDIR` (`tmp/`)
/// and `XDG_CONFIG_HOME` (`config/`, where the crash reporter keeps its database).
/// Whatever they write there goes when the browser does.
#[derive(Debug)]
pub struct Browser {
    /// The WebDriver client.
    pub client: Client,
    driver: ProcessTree,
    profile_dir: PathBuf,
}

impl Browser {
    /// Starts ChromeDriver on a free port and opens a headless Chromium window of
    /// `width` × `height` CSS pixels, its language 中文 (`zh-CN`): the app then starts
    /// in 中文, as the tests that read its texts expect.
    pub async fn start(width: u32, height: u32) -> Self {
        Self::start_in(width, height, "zh-CN").await
    }

    /// [`Browser::start`] with the browser's language `lang` (a BCP 47 tag such as
    /// `en-US`): `navigator.language(s)` and `Accept-Language` say it.
    pub async fn start_in(width: u32, height: u32, lang: &str) -> Self {
        let chromedriver = std::env::var("CHROMEDRIVER").unwrap_or("/usr/bin/chromedriver".into());
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|listener| listener.local_addr())
            .expect("free port")
            .port();
        let dir = tempfile::tempdir().expect("the browser's temporary directory");
        let profile_dir = dir.path().join("profile");
        let temp_dir = dir.path().join("tmp");
        std::fs::create_dir(&temp_dir).expect("the browser's TMPDIR");
        let mut command = Command::new(&chromedriver);
        // Chromium's temporary files and its crash reporter's database (under
        // `$XDG_CONFIG_HOME/chromium`) go in the browser's directory too.
        command
            .arg(format!("--port={port}"))
            .env("TMPDIR", &temp_dir)
            .env("XDG_CONFIG_HOME", dir.path().join("config"))
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        // Every Chromium process names the directory in its command line (the profile,
        // or the crash reporter's database): so even the crash reporter, which leaves
        // the process group and its parent, is found.
        let marker = dir.path().display().to_string();
        let driver = ProcessTree::spawn(&mut command, Some(marker), Some(dir))
            .unwrap_or_else(|err| panic!("cannot start {chromedriver}: {err}"));
        let mut capabilities = serde_json::Map::new();
        capabilities.insert(
            "goog:chromeOptions".into(),
            serde_json::json!({
                // A real phone-sized viewport: desktop windows do not get narrower
                // than 500 px.
                "mobileEmulation": {
                    "deviceMetrics": { "width": width, "height": height, "pixelRatio": 1.0 }
                },
                "prefs": { "intl.accept_languages": lang },
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
                    format!("--lang={lang}"),
                    format!("--accept-lang={lang}"),
                    format!("--window-size={},{height}", width.max(500)),
                    format!("--user-data-dir={}", profile_dir.display()),
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
                        driver,
                        profile_dir,
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

    /// The pids of ChromeDriver and of every process of the browser now running.
    pub fn pids(&self) -> std::collections::BTreeSet<u32> {
        self.driver.members()
    }

    /// Chromium's profile directory (`--user-data-dir`), removed when the browser
    /// ends.
    pub fn profile_dir(&self) -> &Path {
        &self.profile_dir
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
        self.wait_for_text_that(
            css,
            &|text| text.contains(part),
            &format!("contained {part:?}"),
        )
        .await;
    }

    /// Waits until the element matching `css` is there and its text no longer contains
    /// `part`.
    pub async fn wait_for_text_gone(&self, css: &str, part: &str) {
        self.wait_for_text_that(css, &|text| !text.contains(part), &format!("lost {part:?}"))
            .await;
    }

    /// Waits until the element matching `css` is there and its text passes `test`;
    /// panics after [`UI_TIMEOUT`] saying it never `did` (and what was last seen).
    async fn wait_for_text_that(&self, css: &str, test: &dyn Fn(&str) -> bool, did: &str) {
        let deadline = tokio::time::Instant::now() + UI_TIMEOUT;
        let mut seen = None;
        while tokio::time::Instant::now() < deadline {
            if let Ok(element) = self.client.find(fantoccini::Locator::Css(css)).await {
                seen = element.text().await.ok();
                if seen.as_deref().is_some_and(test) {
                    return;
                }
            }
            tokio::time::sleep(Duration::from_millis(50)).await;
        }
        panic!("{css} never {did} within {UI_TIMEOUT:?} (last seen {seen:?})");
    }

    /// Logs in from the Login page (opened with the connection button) with
    /// `password`.
    pub async fn log_in(&self, password: &str) {
        self.click("[data-testid=connection]").await;
        self.type_into("[data-testid=login-password]", password)
            .await;
        self.click("[data-testid=login-submit]").await;
    }

    /// A phone-sized (360 × 740) Chromium with the app of `bridge` open, in 中文.
    pub async fn open(bridge: &Bridge) -> Self {
        Self::open_in(bridge, "zh-CN").await
    }

    /// [`Browser::open`] in a browser whose language is `lang` (`en-US`, `zh-CN`…).
    pub async fn open_in(bridge: &Bridge, lang: &str) -> Self {
        let browser = Self::start_in(360, 740, lang).await;
        browser
            .client
            .goto(&bridge.url())
            .await
            .expect("open the app");
        browser
    }

    /// The operator's first login: with the factory password `1234`, then the new
    /// `password` the app insists on; returns on the Files page, connected.
    pub async fn first_login(&self, password: &str) {
        self.log_in("1234").await;
        self.wait_for("[data-testid=password-form]").await;
        self.type_into("[data-testid=password-new]", password).await;
        self.type_into("[data-testid=password-confirm]", password)
            .await;
        self.click("[data-testid=password-submit]").await;
        self.wait_for("[data-testid=page-files]").await;
        self.wait_for_attribute(INDICATOR, "data-state", "connected", UI_TIMEOUT)
            .await;
    }

    /// Adds the CSV at `path` (named `name.csv`) from the device, uploads it, and
    /// waits for it among the controller's files; returns the text of its row.
    pub async fn upload_csv(&self, path: &std::path::Path, name: &str) -> String {
        self.pick_file("[data-testid=file-picker]", path).await;
        self.wait_for(&format!("[data-testid=local-file][data-name='{name}.csv']"))
            .await;
        self.click("[data-testid=upload]").await;
        self.wait_for_text("[data-testid=files-message]", &format!("已上传: {name}"))
            .await;
        self.click("[data-testid=tab-controller]").await;
        let row = self
            .wait_for(&format!("[data-testid=controller-file][data-name={name}]"))
            .await;
        row.text().await.expect("row text")
    }

    /// Uploads [`wave_csv`] as `wave.csv` from the device and checks its row among
    /// the controller's files: 100 units, 8 s.
    pub async fn upload_wave(&self) {
        let folder = tempfile::tempdir().expect("temp dir");
        let path = folder.path().join("wave.csv");
        std::fs::write(&path, wave_csv()).expect("write the CSV");
        let row = self.upload_csv(&path, "wave").await;
        assert!(row.contains("100") && row.contains("0:08.0"), "{row}");
    }

    /// Puts the show `name` in the playlist from the Control page.
    pub async fn queue_show(&self, name: &str) {
        self.click("[data-testid=nav-control]").await;
        self.click("[data-testid=add]").await;
        self.click(&format!("[data-testid=pick-show][data-name={name}]"))
            .await;
        self.wait_for(&format!("[data-testid=entry][data-show={name}]"))
            .await;
    }

    /// From the Control page: the bandwidth report says the playlist can run, Start
    /// plays the show `name`, and one press of the top bar's E-stop stops it — the
    /// button acknowledges it and the bridge reports the matrix stopped.
    pub async fn play_then_estop(&self, name: &str) {
        self.play(name).await;
        self.estop().await;
    }

    /// From the Control page: the bandwidth report says the playlist can run, and
    /// Start plays the show `name` (the status says `playing` and names it).
    pub async fn play(&self, name: &str) {
        self.click("[data-testid=nav-control]").await;
        self.wait_for_attribute(
            "[data-testid=verdict]",
            "data-verdict",
            "feasible",
            UI_TIMEOUT,
        )
        .await;
        self.click("[data-testid=start]").await;
        self.wait_for_attribute(
            "[data-testid=status-state]",
            "data-state",
            "playing",
            PLAY_TIMEOUT,
        )
        .await;
        assert_eq!(self.text("[data-testid=status-show]").await, name);
    }

    /// One press of the top bar's E-stop: the button acknowledges it and the bridge
    /// reports the matrix stopped.
    pub async fn estop(&self) {
        self.click(".topbar [data-testid=estop]").await;
        self.wait_for_attribute(
            "[data-testid=status-state]",
            "data-state",
            "stopped",
            UI_TIMEOUT,
        )
        .await;
        self.wait_for_attribute(
            ".topbar [data-testid=estop]",
            "data-ack",
            "stopped",
            UI_TIMEOUT,
        )
        .await;
    }

    /// The page's `<html lang>`.
    pub async fn document_lang(&self) -> String {
        self.client
            .execute("return document.documentElement.lang;", Vec::new())
            .await
            .expect("read <html lang>")
            .as_str()
            .unwrap_or_default()
            .to_owned()
    }

    /// `GET path` on the bridge from the page, with the page's login; the JSON answer.
    pub async fn get_json(&self, path: &str) -> serde_json::Value {
        let script = r"
            const [path, done] = arguments;
            const session = JSON.parse(localStorage.getItem('floatball.session'));
            fetch(path, { headers: { Authorization: 'Bearer ' + session.token } })
                .then((reply) => reply.json())
                .then(done, (error) => done({ error: String(error) }));
        ";
        self.client
            .execute_async(script, vec![serde_json::Value::from(path)])
            .await
            .unwrap_or_else(|err| panic!("GET {path} from the page: {err}"))
    }
}
