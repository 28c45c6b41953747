//! The show files and the playlist over HTTP.
//!
//! - `GET /api/shows`: 200, every show's summary.
//! - `PUT /api/shows/{name}`: native JSON or CSV; 201 with the summary of a new show,
//!   200 when it replaced one; 400 bad name (also one with invisible or text-direction
//!   characters); 413 over the size limit (the upload, or the show as stored: a CSV
//!   converted to rows); 422 with every problem when the show is invalid, empty or
//!   longer than `max_duration` (nothing is stored). The body is read whole
//!   before anything is checked or written, so an upload cut off half-way stores
//!   nothing.
//! - `GET /api/shows/{name}`: 200 the stored native JSON; 404.
//! - `DELETE /api/shows/{name}`: 204; 404; 409 while the playlist plays it.
//! - `GET /api/playlist`: 200. `PUT /api/playlist`: 200 with the stored playlist; 400
//!   not a playlist; 422 every problem (unknown shows, zero cycles…).
//!
//! Reading needs a [`Session`]; changing needs an [`Operator`].

use axum::Json;
use axum::body::Bytes;
use axum::extract::rejection::BytesRejection;
use axum::extract::{FromRequestParts, Path, State};
use axum::http::request::Parts;
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use floatball_shared::api::{Playlist, ShowSummary};

use super::session::{Operator, Session};
use super::{Failure, blocking, json_body};
use crate::playlist;
use crate::state::AppState;
use crate::store::{Refused, ShowName, StoreError, UploadFormat, decode_upload};

/// The `{name}` of a show route, checked.
#[derive(Debug, Clone)]
pub struct NameParam(pub ShowName);

impl FromRequestParts<AppState> for NameParam {
    type Rejection = Failure;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Failure> {
        let Path(name) = Path::<String>::from_request_parts(parts, state)
            .await
            .map_err(|rejection| {
                Failure::new(
                    StatusCode::BAD_REQUEST,
                    format!("bad show name: {rejection}"),
                )
            })?;
        ShowName::parse(&name)
            .map(Self)
            .map_err(|error| Failure::new(StatusCode::BAD_REQUEST, error.to_string()))
    }
}

/// 422 for an invalid show or playlist, 413 for a show too large once converted.
fn unprocessable(refused: Refused) -> Failure {
    let status = if refused.too_large {
        StatusCode::PAYLOAD_TOO_LARGE
    } else {
        StatusCode::UNPROCESSABLE_ENTITY
    };
    Failure::new(status, refused.error).with_details(refused.details)
}

pub(crate) fn store_failure(error: StoreError) -> Failure {
    match error {
        StoreError::NotFound(_) => Failure::new(StatusCode::NOT_FOUND, error.to_string()),
        other => Failure::internal("the show store failed", &other),
    }
}

/// `GET /api/shows`.
pub async fn list_shows(
    State(state): State<AppState>,
    _session: Session,
) -> Json<Vec<ShowSummary>> {
    Json(state.shows().list())
}

/// `GET /api/shows/{name}`.
pub async fn get_show(
    State(state): State<AppState>,
    _session: Session,
    NameParam(name): NameParam,
) -> Result<Response, Failure> {
    let reading = state.clone();
    let bytes = blocking(move || reading.shows().read(&name))
        .await?
        .map_err(store_failure)?;
    Ok(([(header::CONTENT_TYPE, "application/json")], bytes).into_response())
}

/// `PUT /api/shows/{name}`.
pub async fn put_show(
    State(state): State<AppState>,
    Operator(_session): Operator,
    NameParam(name): NameParam,
    headers: HeaderMap,
    body: Result<Bytes, BytesRejection>,
) -> Result<Response, Failure> {
    let name = ShowName::parse_new(name.as_str())
        .map_err(|error| Failure::new(StatusCode::BAD_REQUEST, error.to_string()))?;
    let body = body.map_err(|rejection| {
        let status = rejection.status();
        if status == StatusCode::PAYLOAD_TOO_LARGE {
            Failure::new(
                status,
                format!(
                    "the show file is larger than the limit of {} bytes ([uploads] max_bytes)",
                    state.config().uploads.max_bytes
                ),
            )
        } else {
            Failure::new(
                status,
                format!("the upload was not received whole: {rejection}"),
            )
        }
    })?;
    let content_type = headers
        .get(header::CONTENT_TYPE)
        .and_then(|value| value.to_str().ok());
    let format = UploadFormat::detect(content_type, &body);
    let decoding = state.clone();
    let show_name = name.clone();
    let upload = blocking(move || decode_upload(&show_name, &body, format, decoding.config()))
        .await?
        .map_err(unprocessable)?;
    let _catalogue = state.lock_catalogue().await;
    let storing = state.clone();
    let (summary, created) =
        blocking(move || storing.shows().put(&name, &upload.show, &upload.json))
            .await?
            .map_err(store_failure)?;
    tracing::info!("stored show \"{}\" ({} bytes)", summary.name, summary.bytes);
    let status = if created {
        StatusCode::CREATED
    } else {
        StatusCode::OK
    };
    Ok((status, Json(summary)).into_response())
}

/// `DELETE /api/shows/{name}`.
pub async fn delete_show(
    State(state): State<AppState>,
    Operator(_session): Operator,
    NameParam(name): NameParam,
) -> Result<StatusCode, Failure> {
    let _catalogue = state.lock_catalogue().await;
    if state.playlist().uses(name.as_str()) {
        return Err(Failure::new(
            StatusCode::CONFLICT,
            format!("\"{name}\" is in the playlist; remove it from the playlist first"),
        ));
    }
    let deleting = state.clone();
    blocking(move || deleting.shows().delete(&name))
        .await?
        .map_err(store_failure)?;
    Ok(StatusCode::NO_CONTENT)
}

/// `GET /api/playlist`.
pub async fn get_playlist(State(state): State<AppState>, _session: Session) -> Json<Playlist> {
    Json(state.playlist().get())
}

/// `PUT /api/playlist`.
pub async fn put_playlist(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<Json<Playlist>, Failure> {
    let new: Playlist = json_body(&body, "playlist")?;
    let _catalogue = state.lock_catalogue().await;
    playlist::check(&new, |show| state.shows().contains(show)).map_err(unprocessable)?;
    let storing = state.clone();
    let stored = new.clone();
    blocking(move || storing.playlist().put(stored))
        .await?
        .map_err(|error| Failure::internal("cannot store the playlist", &error))?;
    Ok(Json(new))
}
