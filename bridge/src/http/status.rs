//! The live status over HTTP, beside the WebSocket's `status` messages.
//!
//! - `GET /api/status/gateways`: 200 every gateway's [`GatewayStatus`], in
//!   installation order (`index` 0, 1, …), as the playback task last built the status.
//!   A status with more than [`floatball_shared::api::GATEWAY_DETAIL_LIMIT`] gateways
//!   details only those with a problem and counts the rest in its `gateway_summary`;
//!   this call gives all of them (the app's expandable list of gateways).
//!
//! Needs a [`Session`] (any logged-in client).

use axum::Json;
use axum::extract::State;
use floatball_shared::api::GatewayStatus;

use super::session::Session;
use crate::state::AppState;

/// `GET /api/status/gateways`.
pub async fn gateways(
    State(state): State<AppState>,
    _session: Session,
) -> Json<Vec<GatewayStatus>> {
    Json(state.gateway_list())
}
