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

use std::future::Future;
use std::net::SocketAddr;
use std::path::Path;

use axum::Router;
use axum::extract::Request;
use axum::http::{HeaderName, HeaderValue, StatusCode, header};
use axum::middleware::{Next, from_fn, map_response};
use axum::response::Response;
use axum::routing::get;
use tokio::net::TcpListener;
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

/// Serves on `listener` until `shutdown` completes (and completes the show index in
/// the background: [`crate::store`]; and arms the playlist's first entry while the
/// matrix is idle: [`crate::arming`]); then open WebSockets are closed
/// and requests under way finish. Handlers see each client's address (for the login
/// limit).
///
/// # Errors
/// If accepting connections fails for good.
pub async fn run(
    listener: TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let stopping = state.clone();
    // The listener is bound: the shows are indexed from now on, on a thread of their
    // own (`crate::store`), while the API, the WebSocket and the e-stop answer.
    state.shows().start_indexing();
    crate::arming::spawn(state.clone());
    axum::serve(
        listener,
        router(state).into_make_service_with_connect_info::<SocketAddr>(),
    )
    .with_graceful_shutdown(async move {
        shutdown.await;
        stopping.stop();
    })
    .await
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
