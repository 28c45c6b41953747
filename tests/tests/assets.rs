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
