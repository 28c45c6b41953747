//! The HTTP server: the API under `/api`, the WebSocket `/ws` and the web app's
//! static files, served until a shutdown signal.

use std::future::Future;
use std::net::SocketAddr;

use axum::Router;
use axum::routing::get;
use tokio::net::TcpListener;
use tower_http::services::{ServeDir, ServeFile};

use crate::state::AppState;
use crate::{http, ws};

/// Builds the router: `/api/…`, `/ws`, then the app's static files (unknown paths get
/// `index.html`, so the app's own routes survive a reload).
pub fn router(state: AppState) -> Router {
    let static_dir = state.static_dir().clone();
    let app = ServeDir::new(&static_dir).fallback(ServeFile::new(static_dir.join("index.html")));
    Router::new()
        .nest("/api", http::router(&state))
        .route("/ws", get(ws::upgrade))
        .fallback_service(app)
        .with_state(state)
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
