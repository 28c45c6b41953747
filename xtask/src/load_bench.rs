//! `cargo xtask load-bench`: how heavy the release app is and how soon it is usable
//! on a slow link.
//!
//! Builds the release app (see [`crate::app`]) and the bridge, prints the first load
//! as sent with brotli ([`crate::app::first_load`]) and the raw, gzip and brotli
//! sizes of each lazily loaded page's chunks, then starts the bridge
//! with a fresh data directory and loads the app cold (a new Chromium session with an
//! empty profile each run) through ChromeDriver with the network throttled by the
//! DevTools protocol (`Network.emulateNetworkConditions`, sent through ChromeDriver's
//! `goog/cdp/execute`). "Usable" is the moment the app has rendered its top bar (the
//! connection indicator), measured in the page from the start of navigation. Prints
//! the median, minimum and maximum over the runs of each link profile and the bytes
//! transferred; then, in the same session, opens the Create page (whose code is a
//! chunk fetched when it is opened, see `web/src/lazy.rs`) and prints how much later
//! it is usable (its name field shown) and what that fetched. The sizes are printed
//! as the first load (the page's js, chunk loader, main wasm and css) and each
//! lazily loaded page's chunks. A figure printer, not a test: nothing fails on a slow
//! machine — except the first load's size: over [`crate::app::FIRST_LOAD_BUDGET_BYTES`]
//! the command fails, after printing every figure.
//!
//! ChromeDriver is spoken to directly over HTTP/1.1 (WebDriver is JSON over HTTP), so
//! the xtask needs no async runtime.

use std::io::{BufRead as _, BufReader, Read as _, Write as _};
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use serde_json::{Value, json};

use crate::app::{self, Build};
use crate::tools::{self, Env};

/// A link to load the app over.
#[derive(Debug, Clone, Copy)]
struct Link {
    name: &'static str,
    download_bits_per_s: u64,
    latency_ms: u64,
}

/// The links of the issue: shop WiFi at its usual and at its worst.
const LINKS: [Link; 2] = [
    Link {
        name: "20 Mbit/s, 30 ms",
        download_bits_per_s: 20_000_000,
        latency_ms: 30,
    },
    Link {
        name: "9 Mbit/s, 60 ms",
        download_bits_per_s: 9_000_000,
        latency_ms: 60,
    },
];

/// The element whose appearance makes the app usable: the top bar's connection
/// indicator (`tests/src/lib.rs` waits for the same).
const USABLE_SELECTOR: &str = "[data-testid=connection]";

/// The element whose appearance makes the Create page usable: its show's name.
const CREATE_SELECTOR: &str = "[data-testid=create-name]";

/// Runs the benchmark; `args` are its options (`--runs N`, `--no-build`, `--host IP`).
pub fn load_bench(args: &[String]) -> Result<(), String> {
    let mut runs = 5_usize;
    let mut build = true;
    let mut host = "127.0.0.1".to_owned();
    let mut iter = args.iter();
    while let Some(arg) = iter.next() {
        match arg.as_str() {
            "--runs" => {
                runs = iter
                    .next()
                    .and_then(|value| value.parse().ok())
                    .filter(|&runs| runs > 0)
                    .ok_or("--runs needs a positive number")?;
            }
            "--no-build" => build = false,
            "--host" => host = iter.next().ok_or("--host needs an address")?.clone(),
            other => return Err(format!("unknown option {other}")),
        }
    }
    let root = tools::workspace_root();
    let env = Env::discover(&root)?;
    tools::ensure_chromium(&env)?;
    if build {
        tools::ensure_wasm_target(&env)?;
        tools::ensure_wasm_bindgen_cli(&env)?;
        app::build_web(&env, Build::Release)?;
        tools::run_command(tools::cargo(&env).args([
            "build",
            "--release",
            "--package",
            "floatball-bridge",
            "--bin",
            "floatball",
        ]))?;
    }
    let static_dir = root.join("static");
    let first_load = print_sizes(&static_dir.join("pkg"))?;

    let data = std::env::temp_dir().join(format!("floatball-load-bench-{}", std::process::id()));
    std::fs::create_dir_all(&data)
        .map_err(|err| format!("cannot create {}: {err}", data.display()))?;
    let result: Result<(), String> = (|| {
        let mut bridge = Guard(
            Command::new(env.target_dir.join("release").join("floatball"))
                .arg("--listen")
                .arg(format!("{host}:0"))
                .arg("--data-dir")
                .arg(&data)
                .arg("--static-dir")
                .arg(&static_dir)
                .env("RUST_LOG", "warn")
                .stdout(Stdio::piped())
                .stderr(Stdio::null())
                .spawn()
                .map_err(|err| format!("cannot start floatball: {err}"))?,
        );
        let url = bridge_url(bridge.0.stdout.take())?;
        let (driver, driver_addr) = start_chromedriver()?;
        let _driver = Guard(driver);
        println!("\ncold loads of {url} in headless Chromium ({runs} runs per link):");
        println!(
            "{:<18} {:>10} {:>10} {:>10} {:>14}",
            "link", "median ms", "min ms", "max ms", "transferred"
        );
        let mut create = Vec::new();
        for link in LINKS {
            let mut usable_ms = Vec::new();
            let mut create_ms = Vec::new();
            let mut transferred_bytes = 0;
            let mut create_bytes = 0;
            for _ in 0..runs {
                let load = cold_load(&driver_addr, &url, link)?;
                usable_ms.push(load.usable_ms);
                create_ms.push(load.create_ms);
                transferred_bytes = load.bytes;
                create_bytes = load.create_bytes;
            }
            usable_ms.sort_by(f64::total_cmp);
            create_ms.sort_by(f64::total_cmp);
            println!(
                "{:<18} {:>10.0} {:>10.0} {:>10.0} {:>14}",
                link.name,
                median(&usable_ms),
                usable_ms[0],
                usable_ms[usable_ms.len() - 1],
                kb(transferred_bytes)
            );
            create.push((link, create_ms, create_bytes));
        }
        println!("\nthen opening Create the first time (its chunks fetched), ms more:");
        println!(
            "{:<18} {:>10} {:>10} {:>10} {:>14}",
            "link", "median ms", "min ms", "max ms", "transferred"
        );
        for (link, create_ms, create_bytes) in create {
            println!(
                "{:<18} {:>10.0} {:>10.0} {:>10.0} {:>14}",
                link.name,
                median(&create_ms),
                create_ms[0],
                create_ms[create_ms.len() - 1],
                kb(create_bytes)
            );
        }
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&data);
    result?;
    if first_load > app::FIRST_LOAD_BUDGET_BYTES {
        return Err(format!(
            "the first load is {}, over its budget of {}",
            kb(first_load),
            kb(app::FIRST_LOAD_BUDGET_BYTES)
        ));
    }
    Ok(())
}

/// Kills the child when dropped.
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn kb(bytes: u64) -> String {
    format!("{:.1} KB", bytes as f64 / 1000.0)
}

fn median(sorted: &[f64]) -> f64 {
    let middle = sorted.len() / 2;
    if sorted.len().is_multiple_of(2) {
        (sorted[middle - 1] + sorted[middle]) / 2.0
    } else {
        sorted[middle]
    }
}

/// Prints raw, gzip and brotli sizes of the first load's files in `pkg` (the ones
/// the page names, and the chunk loader), then of each lazily loaded page's chunks
/// (the page's `<meta name="floatball-chunks">`).
fn print_sizes(pkg: &Path) -> Result<u64, String> {
    let size = |name: &str| {
        let path = pkg.join(name);
        std::fs::metadata(&path)
            .map(|meta| meta.len())
            .map_err(|err| {
                format!(
                    "cannot read {}: {err}; build with `cargo xtask build`",
                    path.display()
                )
            })
    };
    let sizes = |name: &str| -> Result<[u64; 3], String> {
        Ok([
            size(name)?,
            size(&format!("{name}.gz"))?,
            size(&format!("{name}.br"))?,
        ])
    };
    let page = std::fs::read_to_string(pkg.join("index.html")).map_err(|err| {
        format!(
            "cannot read {}: {err}; build with `cargo xtask build`",
            pkg.join("index.html").display()
        )
    })?;
    println!("\nthe first load, as sent with Accept-Encoding: br:");
    let first = app::first_load(pkg.parent().unwrap_or(pkg))?;
    for (name, size) in &first {
        println!("{name:<56} {:>12}", kb(*size));
    }
    let total: u64 = first.iter().map(|(_, size)| size).sum();
    println!(
        "{:<56} {:>12} (budget {})",
        "first load",
        kb(total),
        kb(app::FIRST_LOAD_BUDGET_BYTES)
    );
    let chunks = page
        .split("name=\"floatball-chunks\" content=\"")
        .nth(1)
        .and_then(|rest| rest.split('"').next())
        .unwrap_or_default();
    println!("\neach lazily loaded page's chunks (fetched when it is first opened):");
    println!(
        "{:<44} {:>12} {:>12} {:>12}",
        "page: file", "raw", "gzip", "brotli"
    );
    for entry in chunks.split(';').filter(|entry| !entry.is_empty()) {
        let (page, files) = entry.split_once('=').unwrap_or((entry, ""));
        let mut totals = [0_u64; 3];
        for file in files.split(' ') {
            let name = file.trim_start_matches("/pkg/");
            let sizes = sizes(name)?;
            for (total, size) in totals.iter_mut().zip(sizes) {
                *total += size;
            }
            println!(
                "{:<44} {:>12} {:>12} {:>12}",
                format!("{page}: {name}"),
                kb(sizes[0]),
                kb(sizes[1]),
                kb(sizes[2])
            );
        }
        println!(
            "{:<44} {:>12} {:>12} {:>12}",
            format!("{page}: all it needs"),
            kb(totals[0]),
            kb(totals[1]),
            kb(totals[2])
        );
    }
    Ok(total)
}

/// The bridge's URL from its first line on stdout; the rest is read and dropped, so
/// the bridge never blocks on a full pipe.
fn bridge_url(stdout: Option<std::process::ChildStdout>) -> Result<String, String> {
    let mut stdout = BufReader::new(stdout.ok_or("floatball has no stdout")?);
    let mut line = String::new();
    stdout
        .read_line(&mut line)
        .map_err(|err| format!("cannot read floatball's output: {err}"))?;
    std::thread::spawn(move || std::io::copy(&mut stdout, &mut std::io::sink()));
    let addr = line
        .trim()
        .strip_prefix("floatball listening on http://")
        .ok_or_else(|| format!("unexpected first line from floatball: {line}"))?;
    Ok(format!("http://{addr}/"))
}

/// Starts ChromeDriver on a free port and waits until it is ready.
fn start_chromedriver() -> Result<(Child, SocketAddr), String> {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|listener| listener.local_addr())
        .map_err(|err| format!("no free port: {err}"))?
        .port();
    let child = Command::new(tools::CHROMEDRIVER)
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|err| format!("cannot start {}: {err}", tools::CHROMEDRIVER))?;
    let addr = SocketAddr::from(([127, 0, 0, 1], port));
    let started = Instant::now();
    while started.elapsed() < Duration::from_secs(20) {
        if webdriver(&addr, "GET", "/status", None)
            .is_ok_and(|status| status["ready"].as_bool() == Some(true))
        {
            return Ok((child, addr));
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    Err("ChromeDriver did not become ready within 20 s".to_owned())
}

/// Records in the page, from the start of navigation, when the app became usable.
/// DevTools scripts are not subject to the page's Content-Security-Policy.
fn observer_script() -> String {
    format!(
        "(() => {{ const seen = () => {{ if (window.__floatballUsableMs === undefined && \
         document.querySelector('{USABLE_SELECTOR}')) {{ window.__floatballUsableMs = performance.now(); }} }}; \
         new MutationObserver(seen).observe(document, {{ childList: true, subtree: true }}); }})();"
    )
}

/// What one cold load measured.
struct ColdLoad {
    /// From the start of navigation to a usable app, ms.
    usable_ms: f64,
    /// Bytes transferred until then.
    bytes: u64,
    /// From the click on Create to a usable Create page, ms.
    create_ms: f64,
    /// Bytes transferred for it.
    create_bytes: u64,
}

/// Opens Create and records in the page how long until it is usable.
fn create_script() -> String {
    format!(
        "const started = performance.now(); window.__floatballBytes = \
         performance.getEntries().reduce((sum, e) => sum + (e.transferSize || 0), 0); \
         new MutationObserver((_, observer) => {{ if (document.querySelector('{CREATE_SELECTOR}')) {{ \
         window.__floatballCreateMs = performance.now() - started; observer.disconnect(); }} }})\
         .observe(document, {{ childList: true, subtree: true }}); \
         document.querySelector('[data-testid=nav-create]').click();"
    )
}

/// One cold load over `link`, then Create opened.
fn cold_load(driver: &SocketAddr, url: &str, link: Link) -> Result<ColdLoad, String> {
    static SESSIONS: AtomicUsize = AtomicUsize::new(0);
    let profile = std::env::temp_dir().join(format!(
        "floatball-load-bench-profile-{}-{}",
        std::process::id(),
        SESSIONS.fetch_add(1, Ordering::Relaxed)
    ));
    let capabilities = json!({
        "capabilities": { "alwaysMatch": {
            "browserName": "chrome",
            "pageLoadStrategy": "none",
            "goog:chromeOptions": {
                "binary": tools::CHROMIUM,
                "args": [
                    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                    "--disable-background-networking", "--disable-component-update",
                    "--disable-sync", "--disable-quic", "--no-first-run",
                    "--window-size=1280,800",
                    format!("--user-data-dir={}", profile.display()),
                ]
            }
        }}
    });
    let session = webdriver(driver, "POST", "/session", Some(&capabilities))?;
    let id = session["sessionId"]
        .as_str()
        .ok_or("ChromeDriver returned no session id")?
        .to_owned();
    let execute = |script: &str| {
        webdriver(
            driver,
            "POST",
            &format!("/session/{id}/execute/sync"),
            Some(&json!({ "script": script, "args": [] })),
        )
    };
    let open_create = |usable_ms: f64, bytes: u64| -> Result<ColdLoad, String> {
        execute(&create_script())?;
        let started = Instant::now();
        while started.elapsed() < Duration::from_secs(60) {
            let answer = execute(
                "return [window.__floatballCreateMs ?? null, \
                 performance.getEntries().reduce((sum, e) => sum + (e.transferSize || 0), 0) - window.__floatballBytes];",
            )?;
            if let Some(create_ms) = answer[0].as_f64() {
                return Ok(ColdLoad {
                    usable_ms,
                    bytes,
                    create_ms,
                    create_bytes: answer[1].as_f64().unwrap_or(0.0) as u64,
                });
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Err(format!(
            "Create was not usable within 60 s on {}",
            link.name
        ))
    };
    let result = (|| {
        let cdp = |cmd: &str, params: Value| {
            webdriver(
                driver,
                "POST",
                &format!("/session/{id}/goog/cdp/execute"),
                Some(&json!({ "cmd": cmd, "params": params })),
            )
        };
        cdp("Network.enable", json!({}))?;
        cdp("Network.clearBrowserCache", json!({}))?;
        let bytes_per_s = link.download_bits_per_s / 8;
        cdp(
            "Network.emulateNetworkConditions",
            json!({
                "offline": false,
                "latency": link.latency_ms,
                "downloadThroughput": bytes_per_s,
                "uploadThroughput": bytes_per_s,
            }),
        )?;
        cdp(
            "Page.addScriptToEvaluateOnNewDocument",
            json!({ "source": observer_script() }),
        )?;
        webdriver(
            driver,
            "POST",
            &format!("/session/{id}/url"),
            Some(&json!({ "url": url })),
        )?;
        let started = Instant::now();
        while started.elapsed() < Duration::from_secs(60) {
            let answer = webdriver(
                driver,
                "POST",
                &format!("/session/{id}/execute/sync"),
                Some(&json!({
                    "script": "return [window.__floatballUsableMs ?? null, \
                        performance.getEntries().reduce((sum, e) => sum + (e.transferSize || 0), 0)];",
                    "args": [],
                })),
            )?;
            if let Some(ms) = answer[0].as_f64() {
                let bytes = answer[1].as_f64().unwrap_or(0.0) as u64;
                return open_create(ms, bytes);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Err(format!(
            "the app was not usable within 60 s on {}",
            link.name
        ))
    })();
    let _ = webdriver(driver, "DELETE", &format!("/session/{id}"), None);
    let _ = std::fs::remove_dir_all(&profile);
    result
}

/// One WebDriver command; its `value`, or its error.
fn webdriver(
    addr: &SocketAddr,
    method: &str,
    path: &str,
    body: Option<&Value>,
) -> Result<Value, String> {
    let body = body.map(Value::to_string).unwrap_or_default();
    let mut stream = TcpStream::connect(addr).map_err(|err| format!("ChromeDriver: {err}"))?;
    stream
        .set_read_timeout(Some(Duration::from_secs(90)))
        .map_err(|err| format!("ChromeDriver: {err}"))?;
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nContent-Type: application/json; charset=utf-8\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .map_err(|err| format!("ChromeDriver: {err}"))?;
    // ChromeDriver keeps the connection open: read the head, then as much body as it
    // announces (or chunks up to the last one).
    let mut answer = Vec::new();
    let mut buffer = [0_u8; 16 * 1024];
    let complete = |answer: &[u8]| -> Option<usize> {
        let split = answer.windows(4).position(|window| window == b"\r\n\r\n")?;
        let head = String::from_utf8_lossy(&answer[..split]).to_ascii_lowercase();
        let body = &answer[split + 4..];
        if head.contains("transfer-encoding: chunked") {
            body.ends_with(b"0\r\n\r\n").then_some(split)
        } else {
            // Without a length the body ends when the connection does.
            let length: usize = head
                .lines()
                .find_map(|line| line.strip_prefix("content-length:"))
                .and_then(|value| value.trim().parse().ok())?;
            (body.len() >= length).then_some(split)
        }
    };
    let split = loop {
        if let Some(split) = complete(&answer) {
            break split;
        }
        let read = stream
            .read(&mut buffer)
            .map_err(|err| format!("ChromeDriver: {err}"))?;
        if read == 0 {
            let head_end = answer.windows(4).position(|window| window == b"\r\n\r\n");
            let chunked = String::from_utf8_lossy(&answer)
                .to_ascii_lowercase()
                .contains("transfer-encoding: chunked");
            match head_end {
                Some(split) if !chunked => break split,
                _ => return Err("ChromeDriver closed the connection mid-answer".to_owned()),
            }
        }
        answer.extend_from_slice(&buffer[..read]);
    };
    let head = String::from_utf8_lossy(&answer[..split]).to_ascii_lowercase();
    let payload = &answer[split + 4..];
    let payload = if head.contains("transfer-encoding: chunked") {
        dechunk(payload)
    } else {
        payload.to_vec()
    };
    let value: Value = serde_json::from_slice(&payload).map_err(|err| {
        format!(
            "ChromeDriver sent no JSON ({err}): {}",
            String::from_utf8_lossy(&payload)
        )
    })?;
    let value = value["value"].clone();
    if let Some(error) = value["error"].as_str() {
        return Err(format!(
            "ChromeDriver {method} {path}: {error}: {}",
            value["message"].as_str().unwrap_or_default()
        ));
    }
    Ok(value)
}

/// The body of a chunked HTTP answer.
fn dechunk(mut payload: &[u8]) -> Vec<u8> {
    let mut body = Vec::new();
    while let Some(end) = payload.windows(2).position(|window| window == b"\r\n") {
        let size = std::str::from_utf8(&payload[..end])
            .ok()
            .and_then(|size| usize::from_str_radix(size.trim(), 16).ok());
        let rest = &payload[end + 2..];
        match size {
            Some(size) if size > 0 && rest.len() >= size => {
                body.extend_from_slice(&rest[..size]);
                payload = rest[size..].strip_prefix(b"\r\n").unwrap_or(&rest[size..]);
            }
            _ => break,
        }
    }
    body
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_median_of_an_even_count_is_the_mean_of_the_middle_two() {
        assert_eq!(median(&[1.0, 2.0, 3.0]), 2.0);
        assert_eq!(median(&[1.0, 2.0, 4.0, 10.0]), 3.0);
    }

    /// A one-shot server that reads a whole request without a body (the client may
    /// write it in pieces: answering and closing after the first piece would break
    /// the client's pipe), answers `answer` and closes the connection.
    fn answering(answer: &'static [u8]) -> SocketAddr {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        std::thread::spawn(move || {
            let (mut stream, _) = listener.accept().unwrap();
            let mut request = Vec::new();
            let mut piece = [0_u8; 1024];
            while !request.windows(4).any(|end| end == b"\r\n\r\n") {
                match stream.read(&mut piece) {
                    Ok(0) | Err(_) => break,
                    Ok(n) => request.extend_from_slice(&piece[..n]),
                }
            }
            stream.write_all(answer).unwrap();
        });
        addr
    }

    #[test]
    fn an_answer_without_a_length_ends_with_the_connection() {
        let addr = answering(b"HTTP/1.1 200 OK\r\nContent-Type: application/json\r\n\r\n{\"value\":{\"ready\":true}}");
        let value = webdriver(&addr, "GET", "/status", None).unwrap();
        assert_eq!(value["ready"], true);
        let addr = answering(b"HTTP/1.1 200 OK\r\nContent-Length: 12\r\n\r\n{\"value\":7}");
        assert_eq!(webdriver(&addr, "GET", "/x", None).unwrap(), 7);
    }

    #[test]
    fn chunked_answers_are_joined() {
        assert_eq!(
            dechunk(b"4\r\n{\"a\"\r\n3\r\n:1}\r\n0\r\n\r\n"),
            b"{\"a\":1}"
        );
    }
}
