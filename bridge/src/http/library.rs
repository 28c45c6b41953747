//! The show files and the playlist over HTTP.
//!
//! - `GET /api/shows`: 200, every show's summary; after a start, once the show index
//!   is complete (waiting for it up to [`LIST_WAIT`], then the shows indexed so far
//!   with `Floatball-Library: indexing`).
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
//!   not a playlist; 409 `playlist_locked` when it changes the entries while a show
//!   plays or the balls move ([`playlist::locked`]; loop and defaults may change);
//!   422 every problem (unknown shows, zero cycles…).
//!
//! An upload's format is taken from its `Content-Type` here (or, without one, from its
//! first character); the show is then imported and checked against this installation
//! by [`floatball_shared::show::import()`], and stored only if it passes.
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
use floatball_shared::codes::Code;
use floatball_shared::params;
use floatball_shared::show::{self, ShowFormat, UploadLimits};

use super::session::{Operator, Session};
use super::{Failure, blocking, json_body};
use crate::config::Config;
use crate::playlist;
use crate::state::AppState;
use crate::store::{NameError, Refused, ShowName, StoreError};

/// The `{name}` of a show route, checked.
#[derive(Debug, Clone)]
pub struct NameParam(pub ShowName);

impl FromRequestParts<AppState> for NameParam {
    type Rejection = Failure;

    async fn from_request_parts(parts: &mut Parts, state: &AppState) -> Result<Self, Failure> {
        let Path(name) = Path::<String>::from_request_parts(parts, state)
            .await
            .map_err(|rejection| {
                Failure::from_template(
                    StatusCode::BAD_REQUEST,
                    Code::BadShowName,
                    params! {"reason" => rejection},
                )
            })?;
        ShowName::parse(&name).map(Self).map_err(bad_name)
    }
}

/// 400 for a show name that is not allowed.
fn bad_name(error: NameError) -> Failure {
    Failure::from_template(
        StatusCode::BAD_REQUEST,
        Code::BadShowName,
        params! {"reason" => error},
    )
}

/// 422 for an invalid show or playlist, 413 for a show too large once converted.
fn unprocessable(refused: Refused) -> Failure {
    let status = if refused.too_large {
        StatusCode::PAYLOAD_TOO_LARGE
    } else {
        StatusCode::UNPROCESSABLE_ENTITY
    };
    let mut failure = Failure::coded(status, refused.code, refused.error);
    failure.body.params = refused.params;
    failure.body.details = refused.details;
    failure.body.problems = refused.problems;
    failure
}

pub(crate) fn store_failure(error: StoreError) -> Failure {
    match &error {
        StoreError::NotFound(name) => Failure::from_template(
            StatusCode::NOT_FOUND,
            Code::ShowNotFound,
            params! {"name" => name},
        ),
        StoreError::Unreadable { name, .. } => Failure::from_template(
            StatusCode::UNPROCESSABLE_ENTITY,
            Code::ShowUnreadable,
            params! {"name" => name, "reason" => error},
        ),
        other => Failure::internal("the show store failed", other),
    }
}

/// The format of an upload's body: as its `Content-Type` says, or, when that is absent
/// or neither format's, by a look at the body: one starting with `{` is JSON.
fn upload_format(content_type: Option<&str>, body: &[u8]) -> ShowFormat {
    let essence = content_type
        .and_then(|value| value.split(';').next())
        .map(|essence| essence.trim().to_ascii_lowercase());
    let named = ShowFormat::ALL
        .into_iter()
        .find(|format| essence.as_deref() == Some(format.content_type()));
    named.unwrap_or_else(|| {
        let start = body.strip_prefix("\u{feff}".as_bytes()).unwrap_or(body);
        match start.iter().find(|byte| !byte.is_ascii_whitespace()) {
            Some(b'{') => ShowFormat::Json,
            _ => ShowFormat::Csv,
        }
    })
}

/// What this installation takes: its motion limits and `[uploads]`.
fn upload_limits(config: &Config) -> UploadLimits {
    UploadLimits {
        motion: config.installation.limits,
        max_duration_ms: u64::try_from(config.uploads.max_duration.as_millis()).unwrap_or(u64::MAX),
        max_json_bytes: config.uploads.max_bytes,
        mbox_boxes: config.installation.mbox_boxes(),
    }
}

/// An upload as the show `name`, if this installation takes it.
pub(crate) fn import_upload(
    name: &ShowName,
    body: &[u8],
    format: ShowFormat,
    config: &Config,
) -> Result<show::Show, show::Refused> {
    show::import(
        name.as_str(),
        body,
        format,
        Some(config.installation.layout()),
        Some(&upload_limits(config)),
    )
}

/// How long `GET /api/shows` waits for the show index after a start before it answers
/// the shows indexed so far ([`LIBRARY_HEADER`]).
pub const LIST_WAIT: std::time::Duration = std::time::Duration::from_secs(10);

/// The header of a show list that is not complete yet: `Floatball-Library: indexing`.
pub const LIBRARY_HEADER: &str = "floatball-library";

/// `GET /api/shows`: every show, once the show index is complete (it waits up to
/// [`LIST_WAIT`] after a start; then the shows indexed so far, marked with
/// [`LIBRARY_HEADER`]).
pub async fn list_shows(State(state): State<AppState>, _session: Session) -> Response {
    let complete = state.shows().wait_indexed(LIST_WAIT).await;
    let list: Json<Vec<ShowSummary>> = Json(state.shows().list());
    if complete {
        list.into_response()
    } else {
        (
            [
                (LIBRARY_HEADER, "indexing"),
                (header::RETRY_AFTER.as_str(), "1"),
            ],
            list,
        )
            .into_response()
    }
}

/// `GET /api/shows/{name}`.
pub async fn get_show(
    State(state): State<AppState>,
    _session: Session,
    NameParam(name): NameParam,
) -> Result<Response, Failure> {
    let reading = state.clone();
    let bytes = blocking(move || reading.shows().file(&name))
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
    let name = ShowName::parse_new(name.as_str()).map_err(bad_name)?;
    let body = body.map_err(|rejection| {
        let status = rejection.status();
        if status == StatusCode::PAYLOAD_TOO_LARGE {
            Failure::coded(
                status,
                Code::ShowTooLarge,
                format!(
                    "the show file is larger than the limit of {} bytes ([uploads] max_bytes)",
                    state.config().uploads.max_bytes
                ),
            )
            .param("limit_bytes", state.config().uploads.max_bytes)
        } else {
            Failure::coded(
                status,
                Code::UploadIncomplete,
                format!("the upload was not received whole: {rejection}"),
            )
        }
    })?;
    let content_type = headers
        .get(header::CONTENT_TYPE)
        .and_then(|value| value.to_str().ok());
    let format = upload_format(content_type, &body);
    let importing = state.clone();
    let show_name = name.clone();
    let show = blocking(move || import_upload(&show_name, &body, format, &importing.config()))
        .await?
        .map_err(|refused| unprocessable(refused.into()))?;
    let _catalogue = state.lock_catalogue().await;
    let storing = state.clone();
    let (summary, created) = blocking(move || storing.shows().put(&name, &show))
        .await?
        .map_err(store_failure)?;
    tracing::info!("stored show \"{}\" ({} bytes)", summary.name, summary.bytes);
    if state.playlist().uses(&summary.name) {
        // A show of the playlist changed: what was armed may be another show now.
        crate::arming::disarm(&state);
    }
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
        return Err(Failure::from_template(
            StatusCode::CONFLICT,
            Code::ShowInPlaylist,
            params! {"name" => name},
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

/// 409 `playlist_locked`: the entries cannot change while the matrix is `state`
/// (`playing`…, or `starting` while a Start is prepared).
fn playlist_locked(state: &str) -> Failure {
    Failure::coded(
        StatusCode::CONFLICT,
        Code::PlaylistLocked,
        format!(
            "the playlist cannot change while the matrix is {state}; \
             press E-stop or wait until it is idle (loop and defaults may change)"
        ),
    )
}

/// `PUT /api/playlist`.
pub async fn put_playlist(
    State(state): State<AppState>,
    Operator(_session): Operator,
    body: Bytes,
) -> Result<Json<Playlist>, Failure> {
    let new: Playlist = json_body(&body, "playlist")?;
    let _catalogue = state.lock_catalogue().await;
    let running = state.subscribe_status().borrow().state;
    let why = if state.starts_pending() {
        Some("starting")
    } else {
        playlist::locked(running).then(|| running.as_str())
    };
    if let Some(why) = why
        && playlist::changes_what_plays(&state.playlist().get(), &new)
    {
        return Err(playlist_locked(why));
    }
    playlist::check(&new, |show| state.shows().contains(show)).map_err(unprocessable)?;
    let storing = state.clone();
    let stored = new.clone();
    blocking(move || storing.playlist().put(stored))
        .await?
        .map_err(|error| Failure::internal("cannot store the playlist", &error))?;
    // The first entry (or how the playlist is planned) may have changed: re-armed
    // after the quiet time.
    crate::arming::disarm(&state);
    Ok(Json(new))
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;
    use crate::config::Overrides;
    use crate::store::tests::show;

    fn config(rows: u32, cols: u32) -> Config {
        Config::parse(
            Path::new("floatball.toml"),
            &format!("[matrix]\nrows = {rows}\ncols = {cols}\n"),
            &Overrides::default(),
        )
        .expect("config")
    }

    #[test]
    fn the_format_follows_the_content_type_or_the_first_character() {
        assert_eq!(
            upload_format(Some("application/json; charset=utf-8"), b"x"),
            ShowFormat::Json
        );
        assert_eq!(upload_format(Some("Text/CSV"), b"{"), ShowFormat::Csv);
        assert_eq!(upload_format(None, b"  \n{\"a\":1}"), ShowFormat::Json);
        assert_eq!(
            upload_format(None, "\u{feff}{}".as_bytes()),
            ShowFormat::Json
        );
        assert_eq!(
            upload_format(Some("application/octet-stream"), b"time_ms,u0"),
            ShowFormat::Csv
        );
    }

    #[test]
    fn uploads_are_validated_against_the_installation() {
        let name = ShowName::parse("test").expect("name");
        let json = show(1, 2).to_json().expect("json");
        let imported =
            import_upload(&name, json.as_bytes(), ShowFormat::Json, &config(1, 2)).expect("ok");
        assert_eq!(imported.name, "test");

        let refused: Refused =
            import_upload(&name, json.as_bytes(), ShowFormat::Json, &config(2, 2))
                .expect_err("wrong layout")
                .into();
        assert_eq!(refused.details.len(), 1, "{refused:?}");
        assert!(
            refused.details[0].contains("2 rows × 2 columns"),
            "{refused:?}"
        );
        assert!(!refused.too_large);

        // Without a layout line a CSV takes the installation's.
        let csv = "time_ms,u0,u1\n0,0,0\n200,9000,0\n";
        let refused: Refused = import_upload(&name, csv.as_bytes(), ShowFormat::Csv, &config(1, 2))
            .expect_err("beyond travel and too fast")
            .into();
        assert!(refused.details.len() >= 2, "{refused:?}");
        assert!(refused.error.contains("problems"), "{refused:?}");
        let refused = import_upload(&name, csv.as_bytes(), ShowFormat::Csv, &config(2, 2))
            .expect_err("two columns for four balls");
        assert!(matches!(refused, show::Refused::Csv(_)), "{refused:?}");

        let refused: Refused = import_upload(&name, b"\xff\xfe", ShowFormat::Csv, &config(1, 2))
            .expect_err("not UTF-8")
            .into();
        assert!(refused.error.contains("UTF-8"), "{refused:?}");
    }

    #[test]
    fn the_upload_limits_are_the_configured_ones() {
        let config = Config::parse(
            Path::new("floatball.toml"),
            "[uploads]\nmax_bytes = 4096\nmax_duration = \"1m 30s\"\n",
            &Overrides::default(),
        )
        .expect("config");
        let limits = upload_limits(&config);
        assert_eq!(limits.max_json_bytes, 4096);
        assert_eq!(limits.max_duration_ms, 90_000);
        assert_eq!(limits.motion, config.installation.limits);
        // The refusal names the limit as the file writes it.
        let refused = show::Refused::TooLong {
            max_duration_ms: limits.max_duration_ms,
            duration_ms: 100_000,
        };
        assert!(refused.to_string().contains(&format!(
            "the limit of {} ([uploads] max_duration)",
            humantime::format_duration(config.uploads.max_duration)
        )));
    }

    #[test]
    fn refusals_write_durations_as_the_configuration_does() {
        let mut duration_ms = 1;
        while duration_ms < 100 * 365 * 86_400_000 {
            for ms in [duration_ms, duration_ms * 7 + 13, duration_ms * 61 - 1] {
                assert_eq!(
                    show::import::human_duration(ms),
                    humantime::format_duration(std::time::Duration::from_millis(ms)).to_string(),
                    "{ms} ms"
                );
            }
            duration_ms *= 3;
        }
    }
}
