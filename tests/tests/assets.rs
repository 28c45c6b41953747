//! The built app as the browser gets it: the page names the content-hashed js, wasm
//! and css under `/pkg/`, they arrive compressed (`Content-Encoding: br` or `gzip`,
//! whichever Chromium offers) and are cached for a year as immutable, while the page
//! and `boot.js` (and the planner's `plan-worker.js`) are revalidated on every load
//! (`no-cache`), so an update reaches every device at its next load.

use floatball_e2e::{Bridge, Browser, INDICATOR, UI_TIMEOUT};

/// Fetches the page's files again from inside the page and reports their headers,
/// and how the wasm the app loaded came over the wire (resource timing).
const PROBE: &str = r#"
const done = arguments[arguments.length - 1];
const href = (selector) => {
  const link = document.querySelector(selector);
  return link ? link.href : null;
};
const urls = {
  js: href('link[rel="modulepreload"]'),
  wasm: href('link[rel="preload"][as="fetch"]'),
  css: href('link[rel="stylesheet"]'),
  page: location.origin + '/',
  boot: location.origin + '/boot.js',
  worker: location.origin + '/plan-worker.js',
};
const loaded = performance.getEntriesByName(urls.wasm || '')[0];
Promise.all(Object.entries(urls).map(async ([what, url]) => {
  if (!url) return [what, null];
  const answer = await fetch(url, { cache: 'no-store' });
  await answer.arrayBuffer();
  return [what, {
    url,
    status: answer.status,
    encoding: answer.headers.get('content-encoding'),
    cache: answer.headers.get('cache-control'),
    vary: answer.headers.get('vary'),
  }];
})).then(
  (entries) => done({
    files: Object.fromEntries(entries),
    wasm_encoded: loaded ? loaded.encodedBodySize : null,
    wasm_decoded: loaded ? loaded.decodedBodySize : null,
  }),
  (error) => done({ error: String(error) }),
);
"#;

#[tokio::test]
async fn the_app_arrives_compressed_with_hashed_names_and_cache_headers() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    // The app rendered: the hashed js and wasm the page names loaded.
    browser
        .wait_for_attribute(INDICATOR, "data-state", "disconnected", UI_TIMEOUT)
        .await;
    let report = browser
        .client
        .execute_async(PROBE, Vec::new())
        .await
        .expect("run the probe");
    assert!(report.get("error").is_none(), "{report}");
    let files = &report["files"];
    for (what, extension) in [("js", ".js"), ("wasm", ".wasm"), ("css", ".css")] {
        let file = &files[what];
        let url = file["url"]
            .as_str()
            .unwrap_or_else(|| panic!("no {what} in the page"));
        let name = url.rsplit('/').next().unwrap_or_default();
        let hash = name
            .strip_suffix(extension)
            .and_then(|stem| stem.rsplit_once('-'))
            .map(|(_, hash)| hash)
            .unwrap_or_default();
        assert!(
            url.contains("/pkg/")
                && hash.len() == 16
                && hash.bytes().all(|byte| byte.is_ascii_hexdigit()),
            "{what} has no content-hashed name under /pkg/: {url}"
        );
        assert_eq!(file["status"], 200, "{what}: {file}");
        assert!(
            matches!(file["encoding"].as_str(), Some("br" | "gzip")),
            "{what} is not served compressed: {file}"
        );
        assert_eq!(
            file["cache"], "public, max-age=31536000, immutable",
            "{what}: {file}"
        );
        assert_eq!(file["vary"], "accept-encoding", "{what}: {file}");
    }
    for what in ["page", "boot", "worker"] {
        let file = &files[what];
        assert_eq!(file["status"], 200, "{what}: {file}");
        assert_eq!(file["cache"], "no-cache", "{what}: {file}");
    }
    // The wasm the app itself loaded came compressed too.
    let encoded = report["wasm_encoded"]
        .as_u64()
        .expect("wasm resource timing");
    let decoded = report["wasm_decoded"]
        .as_u64()
        .expect("wasm resource timing");
    assert!(
        encoded > 0 && encoded * 2 < decoded,
        "the loaded wasm was not compressed: {encoded} bytes for {decoded}"
    );
    println!(
        "wasm came as {} ({encoded} of {decoded} bytes); js {}, css {}",
        files["wasm"]["encoding"], files["js"]["encoding"], files["css"]["encoding"]
    );
    browser.client.close().await.expect("close the browser");
}

/// One GET of `path` from the bridge at `addr` with `Accept-Encoding: br`: the
/// answer's head (lower case) and its body's length as sent.
async fn get_br(addr: std::net::SocketAddr, path: &str) -> (String, usize) {
    use tokio::io::{AsyncReadExt as _, AsyncWriteExt as _};
    let mut stream = tokio::net::TcpStream::connect(addr)
        .await
        .expect("connect to the bridge");
    stream
        .write_all(
            format!(
                "GET {path} HTTP/1.1\r\nHost: {addr}\r\nAccept-Encoding: br\r\nConnection: close\r\n\r\n"
            )
            .as_bytes(),
        )
        .await
        .expect("send the request");
    let mut answer = Vec::new();
    stream
        .read_to_end(&mut answer)
        .await
        .expect("read the answer");
    let split = answer
        .windows(4)
        .position(|window| window == b"\r\n\r\n")
        .unwrap_or_else(|| panic!("{path}: no answer head"));
    let head = String::from_utf8_lossy(&answer[..split]).to_ascii_lowercase();
    assert!(head.starts_with("http/1.1 200"), "{path}: {head}");
    assert!(!head.contains("transfer-encoding"), "{path}: {head}");
    (head, answer.len() - split - 4)
}

/// The value of `attribute` in every tag of `page` that contains `marker`.
fn attributes<'a>(page: &'a str, marker: &str, attribute: &str) -> Vec<&'a str> {
    page.split('<')
        .filter(|tag| tag.contains(marker))
        .filter_map(|tag| {
            let start = tag.find(&format!("{attribute}=\""))? + attribute.len() + 2;
            let end = start + tag[start..].find('"')?;
            Some(&tag[start..end])
        })
        .collect()
}

/// The most a phone may download before the app is usable (issue 35), as
/// `xtask/src/app.rs` says it (`FIRST_LOAD_BUDGET_BYTES`): the page, `boot.js`, the
/// js glue, the chunk loader, the main wasm and the css as sent with brotli.
const FIRST_LOAD_BUDGET_BYTES: usize = 375_000;

/// The pages an operator rarely opens (Create, Commissioning, Installation,
/// Settings) and the parts of the others needed now and then (the console's
/// parsers, the CSV reader, the Preview's performance and plot panels, the Files
/// page's Q program panel, the forced password change) are wasm chunks (issue 35): the page names
/// each one's chunks for `boot.js` and preloads none of them; they are served as
/// brotli and cached as immutable like the rest. Prints the first load and every
/// chunk as sent with `Accept-Encoding: br`; a release build (`cargo xtask test`
/// builds one, the page says so in `<meta name="floatball-build">`) must come within
/// the first-load budget. A quick test build (`cargo xtask build --test`) is not held
/// to it, and the test says so.
#[tokio::test]
async fn the_rare_pages_are_chunks_outside_the_first_load() {
    let bridge = Bridge::start().await;
    let pkg = floatball_e2e::static_dir().join("pkg");
    let page = std::fs::read_to_string(pkg.join("index.html"))
        .expect("static/pkg/index.html: build the app with `cargo xtask build`");
    let js = attributes(&page, "rel=\"modulepreload\"", "href");
    let wasm = attributes(&page, "as=\"fetch\"", "href");
    let css = attributes(&page, "rel=\"stylesheet\"", "href");
    assert_eq!((js.len(), wasm.len(), css.len()), (1, 1, 1), "{page}");
    // The loader of the chunks, which the glue imports.
    let glue =
        std::fs::read_to_string(pkg.join(js[0].trim_start_matches("/pkg/"))).expect("the js");
    let loader: Vec<&str> = glue
        .split('"')
        .filter(|part| part.starts_with("./floatball_split-") && part.ends_with(".js"))
        .collect();
    assert!(!loader.is_empty(), "the glue imports no chunk loader");
    let loader = format!("/pkg/{}", loader[0].trim_start_matches("./"));
    let mut first_load = 0;
    println!("first load (as sent with Accept-Encoding: br):");
    for path in ["/", "/boot.js", js[0], loader.as_str(), wasm[0], css[0]] {
        let (head, bytes) = get_br(bridge.addr, path).await;
        if path.starts_with("/pkg/") {
            assert!(head.contains("content-encoding: br"), "{path}: {head}");
        }
        println!("  {path:<48} {:>9.1} KB", bytes as f64 / 1000.0);
        first_load += bytes;
    }
    println!("  {:<48} {:>9.1} KB", "total", first_load as f64 / 1000.0);
    let build = attributes(&page, "name=\"floatball-build\"", "content");
    assert_eq!(build.len(), 1, "{page}");
    if build[0] == "release" {
        assert!(
            first_load <= FIRST_LOAD_BUDGET_BYTES,
            "the first load is {first_load} bytes as sent with brotli, over the budget of \
             {FIRST_LOAD_BUDGET_BYTES}: move what the operator's pages do not need into a \
             chunk (web/src/lazy.rs)"
        );
        println!(
            "  within the budget of {:.1} KB",
            FIRST_LOAD_BUDGET_BYTES as f64 / 1000.0
        );
    } else {
        println!(
            "  a {} build: the budget holds release builds only (cargo xtask build)",
            build[0]
        );
    }
    let first_files = [js[0], loader.as_str(), wasm[0], css[0]];

    // Each rarely opened page's chunks, by the page's meta: none is in the first load.
    let chunks = attributes(&page, "name=\"floatball-chunks\"", "content");
    assert_eq!(chunks.len(), 1, "{page}");
    let mut pages = Vec::new();
    println!("chunks loaded when a page is opened:");
    for entry in chunks[0].split(';') {
        let (name, files) = entry.split_once('=').expect("page=files");
        let mut total = 0;
        for file in files.split(' ') {
            assert!(
                file.starts_with("/pkg/") && file.ends_with(".wasm"),
                "{file}"
            );
            assert!(!first_files.contains(&file), "{file} is in the first load");
            assert!(
                !page.contains(&format!("href=\"{file}\"")),
                "{file} is preloaded"
            );
            let (head, bytes) = get_br(bridge.addr, file).await;
            assert!(head.contains("content-encoding: br"), "{file}: {head}");
            assert!(head.contains("immutable"), "{file}: {head}");
            println!("  {name:<13} {file:<48} {:>9.1} KB", bytes as f64 / 1000.0);
            total += bytes;
        }
        println!(
            "  {name:<13} {:<48} {:>9.1} KB",
            "(all it needs)",
            total as f64 / 1000.0
        );
        pages.push(name);
    }
    pages.sort_unstable();
    assert_eq!(
        pages,
        [
            "check",
            "commission",
            "console",
            "create",
            "csv",
            "installation",
            "live",
            "password",
            "patch",
            "perf",
            "plot",
            "qprogram",
            "schedule",
            "settings",
            "showcontrol"
        ]
    );
}

/// The planner worker (`static/plan-worker.js`) loads the app's module and, on its
/// first request, the Create chunk its planner is in (issue 35): the answer to a
/// recipe that is not one is the recipe reader's, from the chunk — not that the
/// chunk could not be loaded, nor the worker failing to start.
#[tokio::test]
async fn the_plan_worker_runs_the_planner_from_the_create_chunk() {
    let bridge = Bridge::start().await;
    let browser = Browser::open(&bridge).await;
    browser
        .wait_for_attribute(INDICATOR, "data-state", "disconnected", UI_TIMEOUT)
        .await;
    let answer = browser
        .client
        .execute_async(
            r"
            const done = arguments[arguments.length - 1];
            const worker = new Worker('/plan-worker.js', { type: 'module' });
            worker.onmessage = (event) => done(event.data);
            worker.onerror = (event) => done({ failed: String(event.message) });
            worker.postMessage({
                module: document.querySelector('link[rel=modulepreload]').href,
                id: 7, recipe: '{}', installation: '{}',
            });",
            Vec::new(),
        )
        .await
        .expect("ask the worker");
    assert_eq!(answer["id"], 7, "{answer}");
    let error = answer["error"].as_str().unwrap_or_default();
    assert!(
        error.contains("not a Floatball recipe"),
        "the worker did not plan in the chunk: {answer}"
    );
    browser.client.close().await.expect("close the browser");
}
