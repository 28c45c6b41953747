//! The HTTP server: the API under `/api`, the WebSocket `/ws` and the web app's
//! static files, served until a shutdown signal.
//!
//! Every response carries the headers a browser app should have ([`SECURITY_HEADERS`]):
//! a Content-Security-Policy that allows only the app's own scripts (and its
//! WebAssembly), no framing, no MIME sniffing and no referrer.

use std::future::Future;
use std::net::SocketAddr;

use axum::Router;
use axum::http::{HeaderName, HeaderValue, header};
use axum::middleware::map_response;
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

/// Builds the router: `/api/…`, `/ws`, then the app's static files (unknown paths get
/// `index.html`, so the app's own routes survive a reload).
pub fn router(state: AppState) -> Router {
    let static_dir = state.static_dir().clone();
    let app = ServeDir::new(&static_dir).fallback(ServeFile::new(static_dir.join("index.html")));
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

/// Serves on `listener` until `shutdown` completes; then open WebSockets are closed
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
