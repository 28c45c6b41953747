//! The weekly schedule over HTTP (`docs/api.md`, "Schedule"; [`crate::schedule`]):
//!
//! - `GET /api/schedule`: 200 with the schedule.
//! - `PUT /api/schedule`: 200 with the stored schedule; 400 not a schedule (`bad_json`:
//!   a time that is not `HH:MM`, a date that is not `YYYY-MM-DD`…); 422
//!   `schedule_invalid` with every problem coded (unknown time zone, a window that
//!   ends before it starts, overlapping windows, N out of range…). The scheduler
//!   follows it at once.
//! - `GET /api/schedule/status`: 200 with what the scheduler is doing (the same as
//!   the WebSocket's `schedule` message).
//! - `POST /api/test/clock` `{"now": "2026-11-30T10:00:00Z"}` (or `{"now": null}`
//!   for the system's clock again): sets the scheduler's clock and wakes it; 204. A
//!   404 unless the bridge was started with the hidden `--test-clock` flag (tests
//!   only).

use axum::Json;
use axum::body::Bytes;
use axum::extract::State;
use axum::http::StatusCode;
use floatball_shared::api::ScheduleStatus;
use floatball_shared::codes::{Code, Params};
use floatball_shared::params;
use floatball_shared::schedule::Schedule;
use serde::Deserialize;

use super::session::{Operator, Session};
use super::{Failure, blocking, json_body};
use crate::state::AppState;

/// `GET /api/schedule`.
pub async fn get_schedule(State(state): State<AppState>, _session: Session) -> Json<Schedule> {
    Json(state.schedules().get())
}

/// `PUT /api/schedule`.
pub async fn put_schedule(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<Json<Schedule>, Failure> {
    let new: Schedule = json_body(&body, "schedule")?;
    if let Err(problems) = crate::schedule::check(&new) {
        return Err(Failure::from_template(
            StatusCode::UNPROCESSABLE_ENTITY,
            Code::ScheduleInvalid,
            Params::new(),
        )
        .with_problems(&problems));
    }
    let storing = state.clone();
    let stored = new.clone();
    blocking(move || storing.schedules().put(stored))
        .await?
        .map_err(|error| Failure::internal("cannot store the schedule", &error))?;
    Ok(Json(new))
}

/// `GET /api/schedule/status`.
pub async fn get_status(State(state): State<AppState>, _session: Session) -> Json<ScheduleStatus> {
    Json(state.schedules().status())
}

/// The body of `POST /api/test/clock`.
#[derive(Debug, Deserialize)]
pub struct ClockRequest {
    /// The instant (RFC 3339, `2026-11-30T10:00:00Z`); `null`: the system's clock.
    pub now: Option<String>,
}

/// `POST /api/test/clock` (only with `--test-clock`).
pub async fn set_test_clock(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<StatusCode, Failure> {
    if !state.schedules().test_clock_enabled() {
        return Err(Failure::from_template(
            StatusCode::NOT_FOUND,
            Code::NotFound,
            Params::new(),
        ));
    }
    let request: ClockRequest = json_body(&body, "clock")?;
    let now = match request.now {
        Some(text) => Some(text.parse::<jiff::Timestamp>().map_err(|error| {
            Failure::from_template(
                StatusCode::BAD_REQUEST,
                Code::BadJson,
                params! {"what" => "clock", "reason" => error},
            )
        })?),
        None => None,
    };
    state.schedules().set_clock(now);
    Ok(StatusCode::NO_CONTENT)
}
