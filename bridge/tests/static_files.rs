//! The app's files from the real `floatball` binary: precompressed copies by
//! `Accept-Encoding`, a year's `immutable` caching for content-hashed files under
//! `/pkg/`, `no-cache` for the page and every other file, `Vary: Accept-Encoding`, and
//! the built page (`pkg/index.html`) in place of the template.

use crate::common;

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

const JS: &str = "/pkg/floatball-0123456789abcdef.js";
const JS_BODY: &str = "export function start() {}\n";
const JS_BROTLI: &[u8] = b"not really brotli, but the bridge only serves it";
const JS_GZIP: &[u8] = b"not really gzip either";

/// The binary on a temporary static directory holding a page template, a built page,
/// a hashed js with `.br` and `.gz` copies, an unhashed file with a `.br` copy, and
/// `a.js` (unhashed, outside `pkg/`) with `a.js.br`.
struct Served {
    child: Child,
    addr: SocketAddr,
    _dir: tempfile::TempDir,
}

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn serve(with_built_page: bool) -> Served {
    let dir = tempfile::tempdir().expect("temp dir");
    let static_dir = dir.path().join("static");
    let pkg = static_dir.join("pkg");
    std::fs::create_dir_all(&pkg).expect("pkg dir");
    let write =
        |path: std::path::PathBuf, content: &[u8]| std::fs::write(path, content).expect("write");
    write(static_dir.join("index.html"), b"template page");
    write(static_dir.join("a.js"), b"plain a");
    write(static_dir.join("a.js.br"), b"brotli a");
    if with_built_page {
        write(pkg.join("index.html"), b"built page");
    }
    write(static_dir.join(&JS[1..]), JS_BODY.as_bytes());
    write(static_dir.join(format!("{}.br", &JS[1..])), JS_BROTLI);
    write(static_dir.join(format!("{}.gz", &JS[1..])), JS_GZIP);
    write(pkg.join("notes.txt"), b"unhashed");
    let data = dir.path().join("data");
    std::fs::create_dir_all(&data).expect("data dir");
    let mut child = Command::new(env!("CARGO_BIN_EXE_floatball"))
        .args(["--listen", "127.0.0.1:0", "--data-dir"])
        .arg(&data)
        .arg("--static-dir")
        .arg(&static_dir)
        .env("RUST_LOG", "warn")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start floatball");
    let addr = common::process::listening_address(child.stdout.take().expect("stdout"));
    Served {
        child,
        addr,
        _dir: dir,
    }
}

/// An answer: status, lower-cased header names with their values, body.
struct Answer {
    status: u16,
    headers: Vec<(String, String)>,
    body: Vec<u8>,
}

impl Answer {
    fn header(&self, name: &str) -> Option<&str> {
        self.headers
            .iter()
            .find(|(key, _)| key == name)
            .map(|(_, value)| value.as_str())
    }
}

/// `GET path` with `Accept-Encoding: accept` (none if empty), over a fresh connection.
fn get(addr: SocketAddr, path: &str, accept: &str) -> Answer {
    get_with(addr, path, accept, "")
}

/// `GET path` with `Accept-Encoding: accept` and `extra` header lines (each ending in
/// CRLF).
fn get_with(addr: SocketAddr, path: &str, accept: &str, extra: &str) -> Answer {
    let mut stream = TcpStream::connect(addr).expect("connect");
    stream
        .set_read_timeout(Some(Duration::from_secs(10)))
        .expect("timeout");
    let accept = if accept.is_empty() {
        String::new()
    } else {
        format!("Accept-Encoding: {accept}\r\n")
    };
    write!(
        stream,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\n{accept}{extra}Connection: close\r\n\r\n"
    )
    .expect("send");
    let mut raw = Vec::new();
    stream.read_to_end(&mut raw).expect("read");
    let split = raw
        .windows(4)
        .position(|window| window == b"\r\n\r\n")
        .expect("head");
    let head = String::from_utf8(raw[..split].to_vec()).expect("utf-8 head");
    let mut lines = head.lines();
    let status = lines
        .next()
        .and_then(|line| line.split_whitespace().nth(1))
        .and_then(|code| code.parse().ok())
        .expect("status");
    let headers = lines
        .filter_map(|line| line.split_once(':'))
        .map(|(name, value)| (name.trim().to_ascii_lowercase(), value.trim().to_owned()))
        .collect();
    Answer {
        status,
        headers,
        body: raw[split + 4..].to_vec(),
    }
}

#[test]
fn hashed_files_come_compressed_and_are_kept_for_a_year() {
    let served = serve(true);
    for (accept, encoding, body) in [
        ("gzip, deflate, br, zstd", Some("br"), JS_BROTLI),
        ("gzip", Some("gzip"), JS_GZIP),
        ("", None, JS_BODY.as_bytes()),
    ] {
        let answer = get(served.addr, JS, accept);
        assert_eq!(answer.status, 200, "{accept}");
        assert_eq!(answer.header("content-encoding"), encoding, "{accept}");
        assert_eq!(answer.body, body, "{accept}");
        assert_eq!(
            answer.header("content-type"),
            Some("text/javascript"),
            "{accept}"
        );
        assert_eq!(
            answer.header("cache-control"),
            Some("public, max-age=31536000, immutable"),
            "{accept}"
        );
        assert_eq!(answer.header("vary"), Some("accept-encoding"), "{accept}");
        assert!(
            answer.header("content-security-policy").is_some(),
            "security headers stay"
        );
    }
}

#[test]
fn the_page_and_unhashed_files_are_revalidated() {
    let served = serve(true);
    for path in ["/", "/index.html", "/control", "/settings/password"] {
        let answer = get(served.addr, path, "br");
        assert_eq!(answer.status, 200, "{path}");
        assert_eq!(answer.body, b"built page", "{path}");
        assert_eq!(answer.header("cache-control"), Some("no-cache"), "{path}");
    }
    let plain = get(served.addr, "/a.js", "br");
    assert_eq!(plain.header("content-encoding"), Some("br"));
    assert_eq!(plain.body, b"brotli a");
    assert_eq!(plain.header("cache-control"), Some("no-cache"));
    assert_eq!(plain.header("vary"), Some("accept-encoding"));
    let plain = get(served.addr, "/a.js", "gzip");
    assert_eq!(plain.header("content-encoding"), None);
    assert_eq!(plain.body, b"plain a");
    let notes = get(served.addr, "/pkg/notes.txt", "");
    assert_eq!(notes.body, b"unhashed");
    assert_eq!(notes.header("cache-control"), Some("no-cache"));
}

#[test]
fn revalidating_an_unchanged_page_is_a_304() {
    let served = serve(true);
    let first = get(served.addr, "/", "br");
    let modified = first.header("last-modified").expect("last-modified");
    let again = get_with(
        served.addr,
        "/",
        "br",
        &format!("If-Modified-Since: {modified}\r\n"),
    );
    assert_eq!(again.status, 304);
    assert!(again.body.is_empty());
    assert_eq!(again.header("cache-control"), Some("no-cache"));
}

#[test]
fn a_missing_build_file_is_a_404_that_is_not_kept() {
    let served = serve(true);
    let answer = get(served.addr, "/pkg/floatball-fedcba9876543210.js", "br");
    assert_eq!(answer.status, 404);
    assert_eq!(answer.header("cache-control"), Some("no-cache"));
}

#[test]
fn without_a_build_the_template_page_is_served() {
    let served = serve(false);
    let answer = get(served.addr, "/", "");
    assert_eq!(answer.status, 200);
    assert_eq!(answer.body, b"template page");
    assert_eq!(answer.header("cache-control"), Some("no-cache"));
}

/// A path segment longer than a file name can be (255 bytes, less a precompressed
/// copy's `.br`) is a 404, not the `500` the file lookup's "name too long" gave (found
/// by the storm of issue 52); 252 bytes are still looked up (an app route: the page).
#[test]
fn a_name_too_long_for_a_file_is_a_404() {
    let served = serve(true);
    let name = |length: usize| "a".repeat(length);
    for path in [
        format!("/{}", name(253)),
        format!("/{}", name(256)),
        format!("/settings/{}", name(300)),
        format!("/pkg/{}.js", name(253)),
        format!("/{}", "%41".repeat(256)),
    ] {
        let answer = get(served.addr, &path, "br");
        assert_eq!(answer.status, 404, "{}…", &path[..20]);
    }
    assert_eq!(
        get(served.addr, &format!("/{}", name(252)), "br").status,
        200
    );
    assert_eq!(
        get(served.addr, &format!("/{}", "%41".repeat(252)), "gzip").status,
        200
    );
}
