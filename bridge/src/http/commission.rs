//! Commissioning a UIM2503 gateway's units over HTTP (`crate::commission`):
//!
//! - `POST /api/gateways/{gateway}/rollcall`: 200 [`RollCall`]: every unit that
//!   answered (serial, station, position, last answer, last fault, cell), and the
//!   duplicated, missing and unexpected stations;
//! - `POST /api/gateways/{gateway}/assign` with an [`AssignRequest`]: sends
//!   `*0;SN[X]=s/n;` for each unit, then 200 a new [`RollCall`];
//! - `POST /api/gateways/{gateway}/identify` with an [`IdentifyRequest`]: 202
//!   [`Identifying`]: the station's ball is on its way down and back.
//!
//! All need an [`Operator`]. Refusals: 404 `no_such_gateway`, 422
//! `commission_not_uim2503` / `commission_bad_station` / `commission_bad_distance` /
//! the assignment's own codes, 404 `commission_station_silent`, 409
//! `commission_not_idle` / `commission_in_progress` / `commission_station_shared` /
//! `estop_latched`, 503 `gateway_not_connected` / `line_not_sent`.

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::StatusCode;
use floatball_shared::api::{AssignRequest, IdentifyRequest, Identifying, RollCall};

use super::session::Operator;
use super::{Failure, json_body};
use crate::commission::CommissionError;
use crate::state::AppState;

/// The status code of a refusal.
fn failure(error: &CommissionError) -> Failure {
    use CommissionError as E;
    let status = match error {
        E::NoSuchGateway { .. } | E::StationSilent { .. } => StatusCode::NOT_FOUND,
        E::NotUim2503 { .. }
        | E::BadStation { .. }
        | E::BadDistance { .. }
        | E::NoAssignments
        | E::SerialTwice { .. }
        | E::StationTwice { .. }
        | E::SerialTooLong { .. } => StatusCode::UNPROCESSABLE_ENTITY,
        E::NotAtRest { .. } | E::InProgress { .. } | E::EstopLatched | E::StationShared { .. } => {
            StatusCode::CONFLICT
        }
        E::NotConnected { .. } | E::NotSent { .. } => StatusCode::SERVICE_UNAVAILABLE,
    };
    Failure::of(status, error)
}

/// `POST /api/gateways/{gateway}/rollcall`.
pub async fn rollcall(
    State(state): State<AppState>,
    _operator: Operator,
    Path(gateway): Path<usize>,
) -> Result<Json<RollCall>, Failure> {
    state
        .commission()
        .roll_call(gateway, &state.config().installation)
        .await
        .map(Json)
        .map_err(|error| failure(&error))
}

/// `POST /api/gateways/{gateway}/assign`.
pub async fn assign(
    State(state): State<AppState>,
    _operator: Operator,
    Path(gateway): Path<usize>,
    body: Bytes,
) -> Result<Json<RollCall>, Failure> {
    let request: AssignRequest = json_body(&body, "assignment request")?;
    state
        .commission()
        .assign(gateway, &state.config().installation, &request)
        .await
        .map(Json)
        .map_err(|error| failure(&error))
}

/// `POST /api/gateways/{gateway}/identify`.
pub async fn identify(
    State(state): State<AppState>,
    _operator: Operator,
    Path(gateway): Path<usize>,
    body: Bytes,
) -> Result<(StatusCode, Json<Identifying>), Failure> {
    let request: IdentifyRequest = json_body(&body, "identify request")?;
    state
        .commission()
        .identify(gateway, &state.config().installation, &request)
        .await
        .map(|identifying| (StatusCode::ACCEPTED, Json(identifying)))
        .map_err(|error| failure(&error))
}
