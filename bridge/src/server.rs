//! The HTTP server: the API under `/api`, the WebSocket `/ws` and the web app's
//! static files, served until a shutdown signal.
//!
//! Every response carries the headers a browser app should have ([`SECURITY_HEADERS`]):
//! a Content-Security-Policy that allows only the app's own scripts (and its
//! WebAssembly), no framing, no MIME sniffing and no referrer.
//!
//! The app's files ([`static_files`]) are served precompressed when the build wrote a
//! `.br` or `.gz` copy beside them and the browser accepts it. Files whose names carry
//! a content hash (`/pkg/floatball-<16 hex>.js`, see `xtask/src/app.rs`) are cached for
//! a year ([`IMMUTABLE`]); everything else, the page first of all, is revalidated on
//! every load ([`NO_CACHE`]), so a device picks up a new build at its next load.
//!
//! [`run`] serves each connection itself with hyper's HTTP/1 builder (not
//! `axum::serve`, which sets no timer and so no header read timeout): a request head
//! must arrive within [`HEADER_READ_TIMEOUT`] and stay under [`MAX_HEADER_BYTES`], and
//! at most [`MAX_CONNECTIONS`] are served at once. What hyper cannot read it answers
//! itself (400, 431) without the router's JSON or [`SECURITY_HEADERS`]; docs/api.md,
//! "Requests the bridge cannot read", says exactly what is sent.

use std::future::Future;
use std::net::SocketAddr;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use axum::Router;
use axum::extract::{ConnectInfo, Request};
use axum::http::{HeaderName, HeaderValue, StatusCode, header};
use axum::middleware::{Next, from_fn, map_response};
use axum::response::{IntoResponse, Response};
use axum::routing::get;
use hyper::server::conn::http1;
use hyper_util::rt::{TokioIo, TokioTimer};
use hyper_util::service::TowerToHyperService;
use tokio::net::{TcpListener, TcpStream};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, watch};
use tower_http::add_extension::AddExtension;
use tower_http::services::{ServeDir, ServeFile};
use tower_http::set_header::SetResponseHeaderLayer;

use crate::state::AppState;
use crate::{http, ws};

/// The Content-Security-Policy of every response. Scripts only from the bridge itself
/// (`static/boot.js` loads the app; there is no inline script), plus
/// `'wasm-unsafe-eval'` to compile the app's WebAssembly. Leptos sets `style`
/// attributes, hence `'unsafe-inline'` for styles only. The app may talk to another
/// controller whose address the operator types on the login page, so `connect-src`
/// allows any http(s) and ws(s) address besides its own. No plugins, no `<base>`, and
/// no page may frame the app.
pub const CONTENT_SECURITY_POLICY: &str = "default-src 'self'; \
    script-src 'self' 'wasm-unsafe-eval'; \
    style-src 'self' 'unsafe-inline'; \
    img-src 'self' data: blob:; \
    connect-src 'self' http: https: ws: wss:; \
    object-src 'none'; \
    base-uri 'none'; \
    form-action 'self'; \
    frame-ancestors 'none'";

/// The headers set on every response: API answers, static files, WebSocket refusals
/// and 404s alike.
pub const SECURITY_HEADERS: [(HeaderName, &str); 4] = [
    (header::CONTENT_SECURITY_POLICY, CONTENT_SECURITY_POLICY),
    (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
    (header::X_FRAME_OPTIONS, "DENY"),
    (header::REFERRER_POLICY, "no-referrer"),
];

/// `Cache-Control` of files whose names carry their content's hash: a new build has
/// new names, so a browser may keep these for good.
pub const IMMUTABLE: &str = "public, max-age=31536000, immutable";

/// `Cache-Control` of every other static file (the page, `boot.js`, icons): kept, but
/// checked with the bridge (a cheap `304 Not Modified`) before each use.
pub const NO_CACHE: &str = "no-cache";

/// Builds the router: `/api/…`, `/ws`, then the app's [`static_files`].
pub fn router(state: AppState) -> Router {
    let app = static_files(state.static_dir());
    let mut router = Router::new()
        .nest("/api", http::router(&state))
        .route(
            "/ws",
            get(ws::upgrade).layer(map_response(http::json_errors)),
        )
        .fallback_service(app)
        .with_state(state);
    for (name, value) in SECURITY_HEADERS {
        router = router.layer(SetResponseHeaderLayer::overriding(
            name,
            HeaderValue::from_static(value),
        ));
    }
    router
}

/// The app's files under `static_dir`. The page is the built one (`pkg/index.html`,
/// written by `cargo xtask` with the hashed file names) when there is one, else the
/// template `index.html` (whose `boot.js` then says the app is not built). Unknown
/// paths get the page, so the app's own routes survive a reload — except under
/// `/pkg/`, where a missing file is a 404 (never a page cached as a script for a
/// year). Precompressed copies are preferred; see the module doc for caching.
pub fn static_files(static_dir: &Path) -> Router {
    let built = static_dir.join("pkg").join("index.html");
    let page_path = if built.is_file() {
        built
    } else {
        static_dir.join("index.html")
    };
    let page = ServeFile::new(page_path)
        .precompressed_br()
        .precompressed_gzip();
    let pkg = ServeDir::new(static_dir.join("pkg"))
        .precompressed_br()
        .precompressed_gzip();
    let rest = ServeDir::new(static_dir)
        .precompressed_br()
        .precompressed_gzip()
        .fallback(page.clone());
    Router::new()
        .route_service("/", page.clone())
        .route_service("/index.html", page)
        .nest_service("/pkg", pkg)
        .fallback_service(rest)
        .layer(from_fn(cache_headers))
        .layer(from_fn(refuse_long_names))
}

/// The longest file name the static files are looked up by, bytes: Linux's
/// `NAME_MAX` (255) less the 3 bytes of a precompressed copy's `.br` or `.gz`, which
/// is looked up too. A longer path segment can name no file here, and looking it up
/// failed with an error the file service answered `500`.
pub const MAX_NAME_BYTES: usize = 255 - 3;

/// Answers `404` to a path with a segment longer than [`MAX_NAME_BYTES`] once
/// percent-decoded (no file, no app route has such a name), before any file is
/// looked up.
async fn refuse_long_names(request: Request, next: Next) -> Response {
    let too_long = request
        .uri()
        .path()
        .split('/')
        .any(|segment| decoded_len(segment) > MAX_NAME_BYTES);
    if too_long {
        return StatusCode::NOT_FOUND.into_response();
    }
    next.run(request).await
}

/// The length of `segment` percent-decoded, bytes (each `%XX` one byte).
fn decoded_len(segment: &str) -> usize {
    let escapes = segment
        .as_bytes()
        .windows(3)
        .filter(|window| {
            window[0] == b'%' && window[1].is_ascii_hexdigit() && window[2].is_ascii_hexdigit()
        })
        .count();
    segment.len() - 2 * escapes
}

/// Sets `Cache-Control` (see the module doc) and `Vary: Accept-Encoding` (the body
/// depends on it) on a static file's answer.
async fn cache_headers(request: Request, next: Next) -> Response {
    let hashed = is_hashed_asset(request.uri().path());
    let mut response = next.run(request).await;
    let status = response.status();
    let kept = status.is_success() || status == StatusCode::NOT_MODIFIED;
    let cache = if hashed && kept { IMMUTABLE } else { NO_CACHE };
    let headers = response.headers_mut();
    headers.insert(header::CACHE_CONTROL, HeaderValue::from_static(cache));
    headers.insert(header::VARY, HeaderValue::from_static("accept-encoding"));
    response
}

/// Whether `path` names a content-hashed build output: `/pkg/<stem>-<16 hex
/// digits>.<extension>`, as `cargo xtask` names the app's js, wasm and css.
pub fn is_hashed_asset(path: &str) -> bool {
    let Some(name) = path.strip_prefix("/pkg/") else {
        return false;
    };
    if name.contains('/') {
        return false;
    }
    let Some((stem, _extension)) = name.split_once('.') else {
        return false;
    };
    let Some((base, hash)) = stem.rsplit_once('-') else {
        return false;
    };
    !base.is_empty()
        && hash.len() == 16
        && hash
            .bytes()
            .all(|byte| byte.is_ascii_digit() || (b'a'..=b'f').contains(&byte))
}

/// How long a client has to send a request's line and headers, from the moment its
/// connection is accepted or its previous answer went out: a connection that has not
/// sent a whole request head by then (a slowloris, or a keep-alive connection left
/// idle) is closed without an answer.
pub const HEADER_READ_TIMEOUT: Duration = Duration::from_secs(10);

/// The most bytes a request's headers may take: beyond, the answer is `431 Request
/// Header Fields Too Large` and the connection is closed. The app sends a few hundred.
pub const MAX_HEADER_BYTES: usize = 32 * 1024;

/// The most HTTP connections served at once. Beyond, new connections wait in the
/// system's accept queue until one closes (each idle one does within
/// [`HEADER_READ_TIMEOUT`]); open WebSockets are not counted and keep working.
pub const MAX_CONNECTIONS: usize = 512;

/// How long to wait before accepting again after an error that is not about one
/// connection (out of file descriptors).
const ACCEPT_RETRY: Duration = Duration::from_secs(1);

/// Serves on `listener` until `shutdown` completes (and completes the show index in
/// the background: [`crate::store`]; and arms the playlist's first entry while the
/// matrix is idle: [`crate::arming`]); then open WebSockets are closed
/// and requests under way finish. Handlers see each client's address (for the login
/// limit).
///
/// Each connection is HTTP/1.1 with the limits above ([`HEADER_READ_TIMEOUT`],
/// [`MAX_HEADER_BYTES`], [`MAX_CONNECTIONS`]). A request hyper cannot read is answered
/// by hyper itself before any router sees it, and the connection closed: `400 Bad
/// Request` (a malformed request line or header) or `431` (a head over
/// [`MAX_HEADER_BYTES`], a long URI included, or over 100 headers), each with
/// `connection: close`, `content-length: 0` and `date` only — no body and no
/// [`SECURITY_HEADERS`] (hyper has no hook for these answers; see docs/api.md).
///
/// # Errors
/// None at present: errors accepting a connection are logged and accepting goes on.
pub async fn run(
    listener: TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    // The listener is bound: the shows are indexed from now on, on a thread of their
    // own (`crate::store`), while the API, the WebSocket and the e-stop answer.
    state.shows().start_indexing();
    crate::arming::spawn(state.clone());
    crate::schedule::spawn(state.clone());
    let app = router(state.clone());
    let permits = Arc::new(Semaphore::new(MAX_CONNECTIONS));
    // Every connection's task holds a receiver: the sender is told to close them, and
    // learns when the last one is gone.
    let (close, closing) = watch::channel(false);
    let mut shutdown = std::pin::pin!(shutdown);
    loop {
        let (stream, remote, permit) = tokio::select! {
            () = &mut shutdown => break,
            accepted = accept(&listener, &permits) => match accepted {
                Some(accepted) => accepted,
                None => break,
            },
        };
        let service = TowerToHyperService::new(AddExtension::new(app.clone(), ConnectInfo(remote)));
        let mut closing = closing.clone();
        tokio::spawn(async move {
            let _permit = permit;
            let mut builder = http1::Builder::new();
            builder
                .timer(TokioTimer::new())
                .header_read_timeout(HEADER_READ_TIMEOUT)
                .max_header_size(MAX_HEADER_BYTES);
            let connection = builder
                .serve_connection(TokioIo::new(stream), service)
                .with_upgrades();
            let mut connection = std::pin::pin!(connection);
            let mut asked = false;
            loop {
                tokio::select! {
                    result = connection.as_mut() => {
                        if let Err(error) = result {
                            tracing::debug!("connection from {remote}: {error}");
                        }
                        break;
                    }
                    _ = closing.changed(), if !asked => {
                        // Requests under way finish; an idle connection closes now.
                        asked = true;
                        connection.as_mut().graceful_shutdown();
                    }
                }
            }
        });
    }
    state.stop();
    drop(listener);
    drop(closing);
    let _ = close.send(true);
    close.closed().await;
    Ok(())
}

/// The next connection, once fewer than [`MAX_CONNECTIONS`] are served (`None` only if
/// the semaphore were closed, which it never is).
async fn accept(
    listener: &TcpListener,
    permits: &Arc<Semaphore>,
) -> Option<(TcpStream, SocketAddr, OwnedSemaphorePermit)> {
    let permit = Arc::clone(permits).acquire_owned().await.ok()?;
    loop {
        match listener.accept().await {
            Ok((stream, remote)) => return Some((stream, remote, permit)),
            Err(error) if is_connection_error(&error) => {}
            Err(error) => {
                tracing::error!("accepting a connection: {error}");
                tokio::time::sleep(ACCEPT_RETRY).await;
            }
        }
    }
}

/// Whether an accept error is about one connection only (it went before it was taken).
fn is_connection_error(error: &std::io::Error) -> bool {
    matches!(
        error.kind(),
        std::io::ErrorKind::ConnectionRefused
            | std::io::ErrorKind::ConnectionAborted
            | std::io::ErrorKind::ConnectionReset
    )
}

#[cfg(test)]
mod tests {
    use super::is_hashed_asset;

    #[test]
    fn only_hashed_names_under_pkg_are_immutable() {
        for hashed in [
            "/pkg/floatball-0123456789abcdef.js",
            "/pkg/floatball_bg-0123456789abcdef.wasm",
            "/pkg/style-fedcba9876543210.css",
            "/pkg/floatball-0123456789abcdef.js.br",
            // The chunk loader and the lazily loaded pages' chunks (issue 35).
            "/pkg/floatball_split-0123456789abcdef.js",
            "/pkg/split_create-0123456789abcdef.wasm",
            "/pkg/chunk_4-0123456789abcdef.wasm.gz",
        ] {
            assert!(is_hashed_asset(hashed), "{hashed}");
        }
        for plain in [
            "/",
            "/index.html",
            "/pkg/index.html",
            "/boot.js",
            "/pkg/floatball.js",
            "/style-0123456789abcdef.css",
            "/pkg/floatball-0123456789ABCDEF.js",
            "/pkg/floatball-0123456789abcde.js",
            "/pkg/-0123456789abcdef.js",
            "/pkg/sub/floatball-0123456789abcdef.js",
            "/pkg/floatball-0123456789abcdefg.js",
        ] {
            assert!(!is_hashed_asset(plain), "{plain}");
        }
    }
}
