//! The HTTP server: the web app's static files, the API routes and `/ws`.

use std::future::Future;

use axum::Router;
use axum::routing::get;
use tokio::net::TcpListener;
use tower_http::services::{ServeDir, ServeFile};

use crate::state::AppState;
use crate::ws;

/// Builds the router: `/ws`, then the app's static files (unknown paths get
/// `index.html`, so the app's own routes survive a reload).
pub fn router(state: AppState) -> Router {
    let static_dir = state.static_dir().clone();
    let app = ServeDir::new(&static_dir).fallback(ServeFile::new(static_dir.join("index.html")));
    Router::new()
        .route("/ws", get(ws::upgrade))
        .fallback_service(app)
        .with_state(state)
}

/// Serves on `listener` until `shutdown` completes.
pub async fn run(
    listener: TcpListener,
    state: AppState,
    shutdown: impl Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    axum::serve(listener, router(state))
        .with_graceful_shutdown(shutdown)
        .await
}
